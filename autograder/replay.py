"""Known mistakes, replayed on the reference package: the evidence behind "Likely cause: ...".

The reference package is run again with one function changed the way students get it wrong --
B(phi)^T for B(phi) (a transposed block), the quadratic-velocity terms of gamma dropped, Baumgarte's
terms dropped or with the wrong sign, one joint's gamma negated, G(p) for L(p) -- and when that
reproduces a student's numbers, that is the likely cause (``mbdkit.diagnosis.likely_cause``).

The mistakes are made in a private copy of the reference package (``replay_package``), never in the
package that computes expected values. For public and hidden scenes the replays are made once, with the
reference runs
(``python -m autograder.reference`` stores them, ``stored_replays``), so that the student kit can name
causes from stored data alone and grading never changes the reference package. Per-student scenes,
made at grading time, replay only the checks that fail (``live_replays``). This module runs in the
grader only, never in a sandbox and never in a student kit.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mbdkit.probes import PROBES, Job, Package

COPY = "mbd_reference_replays"
"""The name under which a private copy of the reference package is imported for the replays."""


def replay_package() -> Package:
    """A second copy of the reference package, imported under its own name from the same files: the
    mistakes are made in it, so the package that computes the expected values (and anything else in this
    process that imported ``solutions``) is never changed, not even while a mistake is replayed. The
    package's imports are relative, so the copy is whole: its modules see only each other."""
    if COPY not in sys.modules:
        found = importlib.util.find_spec("solutions")
        spec = importlib.util.spec_from_file_location(
            COPY, found.origin, submodule_search_locations=list(found.submodule_search_locations)
        )
        module = importlib.util.module_from_spec(spec)
        sys.modules[COPY] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[COPY]
            raise
    return Package(COPY)


REPLAY = replay_package()


@dataclass(frozen=True)
class Hypothesis:
    """A known mistake: ``target`` (a function or method of the reference package) is replaced by
    ``make(original)`` while the probe runs again."""

    cause: str
    target: str
    make: Callable


def _package_modules(package: Package) -> list:
    prefix = package.name + "."
    return [m for n, m in list(sys.modules.items()) if m is not None and (n == package.name or n.startswith(prefix))]


@contextlib.contextmanager
def patched(package: Package, target: str, make: Callable):
    """Replace a function of the package (everywhere it was imported by name) or a method of a class.

    A module first imported while the patch is on binds the replacement too: on the way out every
    module of the package is searched for it, so nothing keeps the mistake. The replacement is always a
    new function object, so that restoring it never touches a function of the package that the mistake
    merely calls (G(p) standing in for L(p) must leave G(p) itself alone).
    """
    parts = target.split(".")
    for cut in range(len(parts) - 1, 0, -1):
        try:
            module = package[".".join(parts[:cut])]
            attributes = parts[cut:]
            break
        except ImportError:
            continue
    else:
        raise ImportError(target)
    if len(attributes) == 1:
        original = getattr(module, attributes[0])
        mistaken = make(original)

        def replacement(*args, **kwargs):
            return mistaken(*args, **kwargs)

        try:
            for mod in _package_modules(package):
                for attr, value in list(vars(mod).items()):
                    if value is original:
                        setattr(mod, attr, replacement)
            yield
        finally:
            for mod in _package_modules(package):
                for attr, value in list(vars(mod).items()):
                    if value is replacement:
                        setattr(mod, attr, original)
    else:
        owner = getattr(module, attributes[0])
        own = attributes[1] in vars(owner)
        previous = vars(owner)[attributes[1]] if own else None
        setattr(owner, attributes[1], make(getattr(owner, attributes[1])))
        try:
            yield
        finally:
            if own:
                setattr(owner, attributes[1], previous)
            else:
                delattr(owner, attributes[1])


def _transposed(f):
    return lambda *a, **k: np.asarray(f(*a, **k)).T


def _zero(f):
    return lambda *a, **k: np.zeros_like(np.asarray(f(*a, **k), dtype=float))


def _negated(f):
    return lambda *a, **k: -np.asarray(f(*a, **k), dtype=float)


def _degrees(f):
    return lambda phi, *a, **k: f(np.deg2rad(phi), *a, **k)


def _baumgarte(sign: float, damping: float = 2.0, square: bool = True, stiffness_sign: float | None = None):
    """gamma_bar = gamma + sign damping alpha Psi' + stiffness_sign beta^2 Psi (the reference: sign -1, both)."""
    stiffness_sign = sign if stiffness_sign is None else stiffness_sign

    def make(original):
        def gamma_bar(gamma, psi, psi_dot, alpha, beta):
            stiffness = beta**2 if square else beta
            return gamma + sign * damping * alpha * psi_dot + stiffness_sign * stiffness * psi

        return gamma_bar

    return make


def _no_baumgarte(original):
    return lambda gamma, psi, psi_dot, alpha, beta: gamma


ROTATION = "planar.bodies.rotation"
ROTATION_DERIVATIVE = "planar.bodies.rotation_derivative"
QUADRATIC = "planar.bodies.point_vector_quadratic"

BAUMGARTE_MISTAKES = [
    Hypothesis(
        "Baumgarte's terms with the wrong sign: gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi (eq. 5.29)",
        "formulations.baumgarte_gamma",
        _baumgarte(+1.0),
    ),
    Hypothesis(
        "a missing Baumgarte term: gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi, not plain gamma (eq. 5.29)",
        "formulations.baumgarte_gamma",
        _no_baumgarte,
    ),
    Hypothesis(
        "one Baumgarte term with the wrong sign: + 2 alpha Psi' in your gamma_bar, where "
        "gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi (eq. 5.29)",
        "formulations.baumgarte_gamma",
        _baumgarte(+1.0, stiffness_sign=-1.0),
    ),
    Hypothesis(
        "one Baumgarte term with the wrong sign: + beta^2 Psi in your gamma_bar, where "
        "gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi (eq. 5.29)",
        "formulations.baumgarte_gamma",
        _baumgarte(-1.0, stiffness_sign=+1.0),
    ),
    Hypothesis(
        "beta not squared in Baumgarte's term: gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi (eq. 5.29)",
        "formulations.baumgarte_gamma",
        _baumgarte(-1.0, square=False),
    ),
    Hypothesis(
        "the factor 2 missing in Baumgarte's term 2 alpha Psi' (eq. 5.29)",
        "formulations.baumgarte_gamma",
        _baumgarte(-1.0, damping=1.0),
    ),
]

ROTATION_MISTAKES = [
    Hypothesis(
        "a transposed block: B(phi)^T used where B(phi) = dA/dphi belongs (eq. 2.5)", ROTATION_DERIVATIVE, _transposed
    ),
    Hypothesis("a transposed block: A(phi)^T used where A(phi) belongs (eq. 2.2)", ROTATION, _transposed),
    Hypothesis("degrees for radians: the angle converted as if it were in degrees", ROTATION, _degrees),
]
QUADRATIC_MISTAKE = Hypothesis(
    "a missing quadratic-velocity term: the A s' phi'^2 terms of gamma (eq. 3.17)", QUADRATIC, _zero
)


def _phi_not_squared(original):
    rotation = REPLAY[ROTATION.rsplit(".", 1)[0]].rotation

    def point_vector_quadratic(qi, si, qj, sj, qdi, qdj):
        return rotation(qi[2]) @ si * qdi[2] - rotation(qj[2]) @ sj * qdj[2]

    return point_vector_quadratic


def _velocity_b_transposed(original):
    derivative = REPLAY[ROTATION.rsplit(".", 1)[0]].rotation_derivative

    def point_vector_dot(qi, si, qj, sj, qdi, qdj):
        vj = qdj[:2] + derivative(qj[2]).T @ sj * qdj[2]
        vi = qdi[:2] + derivative(qi[2]).T @ si * qdi[2]
        return vj - vi

    return point_vector_dot


QUADRATIC_MISTAKES = [
    QUADRATIC_MISTAKE,
    Hypothesis(
        "phi' where phi'^2 belongs: the quadratic-velocity terms of your gamma are A s' phi'^2 (eq. 3.17)",
        QUADRATIC,
        _phi_not_squared,
    ),
]
VELOCITY_MISTAKE = Hypothesis(
    "B(phi)^T in d_ij' (point_vector_dot): d_ij' = r_j' + B_j s_j' phi_j' - r_i' - B_i s_i' phi_i' (eq. 2.5)",
    "planar.bodies.point_vector_dot",
    _velocity_b_transposed,
)


LOOP_VELOCITY_MISTAKE = Hypothesis(
    "the sign of Psi_t: q' solves Psi_q q' = -Psi_t (eq. 4.5)", "kinematics.velocity_analysis", _negated
)
LOOP_ACCELERATION_MISTAKE = Hypothesis(
    "the sign of gamma: q'' solves Psi_q q'' = gamma (eq. 4.6)", "kinematics.acceleration_analysis", _negated
)
"""The solvers' own sign mistakes, on the slider-crank of the loop_* probes (its Psi_t and gamma are given)."""


SPATIAL_ROTATION_MISTAKES = [
    Hypothesis(
        "a transposed rotation matrix: A(p)^T used where A(p) belongs (eq. 8.12)",
        "rotations.rotation_matrix",
        _transposed,
    ),
    Hypothesis(
        "G(p) used where L(p) belongs: the angular velocity in the global frame, not the body frame (eq. 8.14)",
        "rotations.l_matrix",
        lambda original: REPLAY["rotations"].g_matrix,
    ),
    Hypothesis(
        "L(p) used where G(p) belongs: the angular velocity in the body frame, not the global frame (eq. 8.14)",
        "rotations.g_matrix",
        lambda original: REPLAY["rotations"].l_matrix,
    ),
]
SPATIAL_QUADRATIC_MISTAKES = [
    Hypothesis(
        "a missing quadratic-velocity term: the (d_ij'')_v part of gamma, B(p', s') p' (eq. 9.12)",
        "spatial.bodies.point_vector_quadratic",
        _zero,
    ),
    Hypothesis(
        "a missing quadratic-velocity term: the (a'')_v part of gamma, B(p', a') p' (eq. 9.10)",
        "spatial.bodies.body_vector_quadratic",
        _zero,
    ),
]
SPATIAL_MASS_MISTAKES = [
    Hypothesis(
        "the quadratic-velocity force Q_v = 8 L(p')^T J' L(p') p is missing (eq. 10.5)",
        "spatial.mass.quadratic_velocity_force",
        _zero,
    ),
]


_CLASSES: dict[str, dict[str, list[str]]] = {}


def _element_classes(job: Job, method: str) -> list[str]:
    """Class paths of the scene's constraint elements (in the reference package) that define ``method``."""
    if job.key not in _CLASSES:
        model = REPLAY["io.model"].load_model(job.model)
        system, _, _ = REPLAY["assembly"].build_system(model)
        classes = list(dict.fromkeys(type(e) for e in system.elements))
        _CLASSES[job.key] = {
            name: [f"{c.__module__.split('.', 1)[1]}.{c.__name__}" for c in classes if name in vars(c)]
            for name in ("gamma", "psi_t")
        }
    return _CLASSES[job.key][method]


def _per_element(job: Job, method: str, cause: str, make: Callable) -> list[Hypothesis]:
    return [
        Hypothesis(cause.format(name=path.rsplit(".", 1)[1]), f"{path}.{method}", make)
        for path in _element_classes(job, method)
    ]


def hypotheses(probe: str, job: Job) -> list[Hypothesis]:
    """The known mistakes worth replaying for a failed check of ``probe``."""
    planar = job.model.get("model", {}).get("dimension", 2) == 2
    rotation = ROTATION_MISTAKES if planar else SPATIAL_ROTATION_MISTAKES
    quadratic = [*QUADRATIC_MISTAKES, VELOCITY_MISTAKE] if planar else SPATIAL_QUADRATIC_MISTAKES

    def gamma_signs():
        return _per_element(job, "gamma", "gamma with the wrong sign in {name}.gamma", _negated)

    def psi_t_signs():
        return _per_element(job, "psi_t", "Psi_t with the wrong sign in {name}.psi_t", _negated)

    table = {
        "constraints": lambda: rotation,
        "jacobian": lambda: rotation,
        "gamma": lambda: quadratic + rotation,
        "rotation_matrices": lambda: SPATIAL_ROTATION_MISTAKES,
        "spatial_mass_matrix": lambda: SPATIAL_ROTATION_MISTAKES,
        "quadratic_velocity": lambda: SPATIAL_ROTATION_MISTAKES,
        "generalized_forces": lambda: [VELOCITY_MISTAKE] if planar else SPATIAL_MASS_MISTAKES,
        "velocity": lambda: rotation[:1] + psi_t_signs() if planar else psi_t_signs(),
        "acceleration": lambda: quadratic + gamma_signs(),
        "kinematic_run": lambda: quadratic + gamma_signs() + psi_t_signs(),
        "loop_velocity": lambda: [LOOP_VELOCITY_MISTAKE],
        "loop_acceleration": lambda: [LOOP_ACCELERATION_MISTAKE],
        "baumgarte_gamma": lambda: BAUMGARTE_MISTAKES,
        "accelerations": lambda: (
            BAUMGARTE_MISTAKES + quadratic + gamma_signs() + ([] if planar else SPATIAL_MASS_MISTAKES)
        ),
        "dynamic_run": lambda: BAUMGARTE_MISTAKES[:2],
    }
    return table[probe]() if probe in table else []


_REPLAYS: dict[tuple, dict | None] = {}


def replay(probe: str, job: Job, hypothesis: Hypothesis) -> dict | None:
    """The probe's outputs with the reference package made to commit the mistake (None if it fails).

    Kept for the next output of the same probe call (a run's q and q' share their replays)."""
    key = (probe, job.key, json.dumps(job.options, sort_keys=True), hypothesis.target, hypothesis.cause)
    if key not in _REPLAYS:
        if len(_REPLAYS) > 64:
            _REPLAYS.clear()
        try:
            with patched(REPLAY, hypothesis.target, hypothesis.make):
                _REPLAYS[key] = PROBES[probe](REPLAY, Job(job.key, job.model, job.inputs, job.options))
        except Exception:  # noqa: BLE001 - a mistake that makes the reference fail explains nothing
            _REPLAYS[key] = None
    return _REPLAYS[key]


def stored_replays(probe: str, job: Job, expected: dict) -> tuple[list[str], dict[str, np.ndarray]]:
    """The causes worth storing for a probe, and their outputs as ``replay:N:OUTPUT`` arrays.

    A mistake whose replay fails, or gives the expected values again (it does not touch this scene),
    is left out: it can explain no failure here.
    """
    causes, arrays = [], {}
    for hypothesis in hypotheses(probe, job):
        outputs = replay(probe, job, hypothesis)
        if outputs is None:
            continue
        changed = {}
        for name, value in outputs.items():
            value = np.asarray(value, dtype=float)
            reference = np.asarray(expected.get(name), dtype=float)
            if value.shape != reference.shape or not np.allclose(value, reference, 1e-12, 0.0, equal_nan=True):
                changed[name] = value
        if not changed:
            continue
        number = len(causes)
        causes.append(hypothesis.cause)
        arrays.update({f"replay:{number}:{name}": value for name, value in changed.items()})
    return causes, arrays


def live_replays(probe: str, output: str, job: Job) -> list[tuple[str, np.ndarray]]:
    """(cause, output) of every known mistake of ``probe`` replayed now (per-student scenes)."""
    found = []
    for hypothesis in hypotheses(probe, job):
        outputs = replay(probe, job, hypothesis)
        if outputs is not None and output in outputs:
            found.append((hypothesis.cause, np.asarray(outputs[output], dtype=float)))
    return found
