"""Submissions for the autograder's tests: the reference as a student package, the untouched skeleton,
and mutants made by text substitution on a copy of ``solutions/``.

Every substitution must match exactly once, so a test fails loudly (instead of grading an unchanged
copy) when the reference code it mutates is rewritten.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SOLUTIONS = REPO / "solutions"

MUTANTS: dict[str, list[tuple[str, str, str]]] = {
    # hw1
    "gamma_sign": [
        (
            "planar/joints.py",
            "        return point_vector_quadratic(qi, self.si, qj, self.sj, qdi, qdj)",
            "        return -point_vector_quadratic(qi, self.si, qj, self.sj, qdi, qdj)",
        )
    ],
    "jacobian_transposed": [
        (
            "planar/joints.py",
            "jac_i[:, 2] = rotation_derivative(qi[2]) @ self.si",
            "jac_i[:, 2] = rotation_derivative(qi[2]).T @ self.si",
        )
    ],
    "hang": [
        (
            "kinematics.py",
            "    lu = lu if lu is not None else lu_factor(system.jacobian(q, t))\n"
            "    return lu_solve(lu, -system.psi_t(q, t))",
            "    while True:\n        system.jacobian(q, t)",
        )
    ],
    "memory": [
        (
            "kinematics.py",
            "    return lu_solve(lu, system.gamma(q, qd, t))",
            "    work = np.ones(1_250_000_000)  # 10 GB\n    return lu_solve(lu, system.gamma(q, qd, t)) + work[:1]",
        )
    ],
    "exit": [
        (
            "kinematics.py",
            "    for iteration in range(max_iterations + 1):",
            "    __import__('os')._exit(3)\n    for iteration in range(max_iterations + 1):",
        )
    ],
    "flood": [
        (
            "kinematics.py",
            "    return lu_solve(lu, -system.psi_t(q, t))",
            "    print('x' * 2**20)\n    return lu_solve(lu, -system.psi_t(q, t))",
        )
    ],
    # hw2
    "mass_missing": [("mass_matrix.py", "return np.diag([mass, mass, inertia])", "return np.diag([mass, mass, 0.0])")],
    "baumgarte_sign": [
        (
            "formulations.py",
            "return gamma - 2.0 * alpha * psi_dot - beta**2 * psi",
            "return gamma + 2.0 * alpha * psi_dot + beta**2 * psi",
        )
    ],
    "rk4_weight": [
        (
            "integrators.py",
            "return y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)",
            "return y + h / 6.0 * (k1 + 2.0 * k2 + k3 + 2.0 * k4)",
        )
    ],
    # the known mistakes of the diagnosis (test_fair_diagnosis)
    "phi_not_squared": [
        (
            "planar/bodies.py",
            "return rotation(qi[2]) @ si * qdi[2] ** 2 - rotation(qj[2]) @ sj * qdj[2] ** 2",
            "return rotation(qi[2]) @ si * qdi[2] - rotation(qj[2]) @ sj * qdj[2]",
        )
    ],
    "velocity_b_transposed": [
        (
            "planar/bodies.py",
            "    vj = qdj[:2] + rotation_derivative(qj[2]) @ sj * qdj[2]\n"
            "    vi = qdi[:2] + rotation_derivative(qi[2]) @ si * qdi[2]",
            "    vj = qdj[:2] + rotation_derivative(qj[2]).T @ sj * qdj[2]\n"
            "    vi = qdi[:2] + rotation_derivative(qi[2]).T @ si * qdi[2]",
        )
    ],
    "baumgarte_damping_sign": [
        (
            "formulations.py",
            "return gamma - 2.0 * alpha * psi_dot - beta**2 * psi",
            "return gamma + 2.0 * alpha * psi_dot - beta**2 * psi",
        )
    ],
    "lambda_sign": [("formulations.py", "matrix[:n, n:] = jacobian.T", "matrix[:n, n:] = -jacobian.T")],
    # hw3
    "quadratic_velocity_missing": [
        (
            "spatial/mass.py",
            "    return 8.0 * Ld.T @ (inertia @ (Ld @ p))",
            "    return 0.0 * Ld.T @ (inertia @ (Ld @ p))",
        )
    ],
}


def copy_reference(destination: Path) -> Path:
    """solutions/ copied as the package ``modules`` into ``destination``; returns the package folder."""
    package = destination / "modules"
    shutil.copytree(SOLUTIONS, package, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    return package


def make_mutant(destination: Path, name: str) -> Path:
    """A copy of the reference with the mutant's substitutions; each must match exactly once."""
    package = copy_reference(destination)
    for relpath, old, new in MUTANTS[name]:
        path = package / relpath
        text = path.read_text()
        assert text.count(old) == 1, f"mutant {name}: {old!r} found {text.count(old)} times in solutions/{relpath}"
        path.write_text(text.replace(old, new))
    return destination


_REGION = re.compile(r"^(?P<indent>[ \t]*)### BEGIN SOLUTION (?P<tag>hw\d+)\n.*?^[ \t]*### END SOLUTION\n", re.M | re.S)


def make_skeleton(destination: Path, homework: str) -> Path:
    """The untouched student package of ``homework``: the course's generator when it exists, else the
    fenced regions of this homework and later replaced by ``raise NotImplementedError``."""
    try:
        from course.release.generator import build_package
    except ImportError:
        build_package = None
    if build_package is not None:
        build_package(destination / "modules", homework, header=None)
        return destination
    package = copy_reference(destination)
    number = int(homework[2:])
    for path in package.rglob("*.py"):

        def stub(match):
            if int(match["tag"][2:]) >= number:
                return f"{match['indent']}raise NotImplementedError\n"
            return ""

        path.write_text(_REGION.sub(stub, path.read_text()))
    return destination


@pytest.fixture(scope="session")
def reference_copy():
    """reference_copy(folder) -> the reference copied as ``folder/modules``."""
    return copy_reference


@pytest.fixture(scope="session")
def make_submissions(tmp_path_factory):
    """make_submissions(label, {student: 'reference' | 'skeleton' | mutant name}) -> folder of students."""

    def make(label: str, students: dict[str, str], homework: str) -> Path:
        root = tmp_path_factory.mktemp(label)
        for student, kind in students.items():
            if kind == "reference":
                copy_reference(root / student)
            elif kind == "skeleton":
                make_skeleton(root / student, homework)
            else:
                make_mutant(root / student, kind)
        return root

    return make
