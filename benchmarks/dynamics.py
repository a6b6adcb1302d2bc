"""Benchmark of forward dynamics: run time against error for every formulation and integrator.

Three scenes, each with a high-accuracy reference that does not use the code under test:

- ``double_pendulum.yaml`` (2 s): Lagrange's equations in the two joint angles, DOP853 at rtol = atol = 1e-13;
- ``slider_crank_flywheel.yaml`` (1 s, about 8 crank turns, gas force and load torque): the one-degree-of-
  freedom equation M(theta) theta'' + C(theta) theta'^2 = Q(theta, t) in the crank angle, DOP853 at 1e-13;
- ``andrews.yaml`` (0.03 s): the published reference solution of the IVP Test Set at t = 0.03 s.

The error of a run is the largest absolute error of the scene's angles at the end time (rad): the two
pendulum angles, the crank angle, Andrews' seven published angles. Two tables per scene:

1. every formulation (baumgarte, partitioning, qr, svd, projection) with DOP853;
2. every integrator with the baumgarte formulation: solve_ivp's RK45, DOP853, Radau, BDF and LSODA,
   the implicit index-3 methods hht and generalized-alpha (no formulation: they solve the index-3
   equations), each at rtol = atol = 1e-4, 1e-6, 1e-8, 1e-10; and fixed-step rk4 at four step sizes.

Columns: error, wall time of the whole ``forward_dynamics`` call (consistent initial conditions,
integration, output), right-hand-side evaluations (for the implicit methods: evaluations of Q in the
Newton residuals and their finite-difference tangents), microseconds per evaluation (wall time divided by
evaluations), integrator steps and the largest constraint residual |Psi| on the output grid. One run per
entry unless ``--repeats`` (then the median time). This is a benchmark, not a test: the times depend on
the machine. Run::

    .venv/bin/python benchmarks/dynamics.py            # full run, a few minutes
    .venv/bin/python benchmarks/dynamics.py --quick    # smoke run: rtol 1e-4 only, rk4 at one step
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")  # must be set before NumPy is imported: the matrices are small

import argparse  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from solutions.assembly import build_system  # noqa: E402
from solutions.diagnostics import AnalysisError  # noqa: E402
from solutions.dynamics import forward_dynamics  # noqa: E402
from solutions.formulations import FORMULATIONS  # noqa: E402
from solutions.functions import function_from_spec  # noqa: E402
from solutions.io.model import Model, load_model  # noqa: E402

MODELS = Path(__file__).resolve().parents[1] / "course" / "models"
TOLERANCES = (1e-4, 1e-6, 1e-8, 1e-10)
ADAPTIVE = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
IMPLICIT = ("hht", "generalized-alpha")


@dataclass
class Scene:
    """A model, its end time, the angles a run is judged by and their reference values at the end."""

    name: str
    file: str
    t_end: float
    angles: Callable[[np.ndarray], np.ndarray]  # from the body coordinates q (n,) to the judged angles
    reference: np.ndarray
    rk4_steps: tuple[float, ...]


# -- references ---------------------------------------------------------------------------------------------
def _joint(model: Model, name: str) -> np.ndarray:
    return np.asarray(next(j for j in model.joints if j["name"] == name)["location"], dtype=float)


def _down_angle(vector: np.ndarray) -> float:
    """Angle of a vector measured from hanging straight down (the pendulum angle)."""
    return math.atan2(vector[0], -vector[1])


def _check_on_line(point, start, end, what: str) -> None:
    d, e = point - start, end - start
    if abs(d[0] * e[1] - d[1] * e[0]) > 1e-12:
        raise SystemExit(f"benchmark reference: {what} is not on its link's line; the model file changed")


def double_pendulum_reference(model: Model, t_end: float) -> np.ndarray:
    """(theta1, theta2) at t_end from Lagrange's equations in the joint angles, the link data taken from the file.

    M11 = m1 a1^2 + I1 + m2 l1^2, M12 = m2 l1 a2 cos(t1 - t2), M22 = m2 a2^2 + I2 (a: pivot to centre)
    M11 t1'' + M12 t2'' + m2 l1 a2 sin(t1 - t2) t2'^2 + (m1 a1 + m2 l1) g sin t1 = 0
    M12 t1'' + M22 t2'' - m2 l1 a2 sin(t1 - t2) t1'^2 + m2 a2 g sin t2 = 0
    """
    upper, lower = model.bodies
    o, a = _joint(model, "O"), _joint(model, "A")
    _check_on_line(upper.location, o, a, "the upper rod's centre")
    g = -float(model.gravity[1])
    l1, a1, a2 = np.linalg.norm(a - o), np.linalg.norm(upper.location - o), np.linalg.norm(lower.location - a)
    m1, m2, i1, i2 = upper.mass, lower.mass, upper.inertia, lower.inertia
    m11, m22 = m1 * a1**2 + i1 + m2 * l1**2, m2 * a2**2 + i2

    def f(t, y):
        t1, t2, w1, w2 = y
        m12, s = m2 * l1 * a2 * math.cos(t1 - t2), m2 * l1 * a2 * math.sin(t1 - t2)
        rhs = [-s * w2 * w2 - (m1 * a1 + m2 * l1) * g * math.sin(t1), s * w1 * w1 - m2 * a2 * g * math.sin(t2)]
        acc = np.linalg.solve([[m11, m12], [m12, m22]], rhs)
        return [w1, w2, acc[0], acc[1]]

    y0 = [_down_angle(upper.location - o), _down_angle(lower.location - a), 0.0, 0.0]
    solution = solve_ivp(f, (0.0, t_end), y0, method="DOP853", rtol=1e-13, atol=1e-13)
    return solution.y[:2, -1]


def double_pendulum_angles(model: Model) -> Callable[[np.ndarray], np.ndarray]:
    """theta_i = phi_i + (theta_i - phi_i at t = 0): each rod's angle from hanging, from its body angle."""
    o, a = _joint(model, "O"), _joint(model, "A")
    upper, lower = model.bodies
    offsets = np.array(
        [_down_angle(upper.location - o) - upper.orientation, _down_angle(lower.location - a) - lower.orientation]
    )
    return lambda q: q[[2, 5]] + offsets


def slider_crank_reference(model: Model, t_end: float) -> np.ndarray:
    """Crank angle at t_end from M(theta) theta'' + C(theta) theta'^2 = Q(theta, t), data from the file.

    With the rod angle phi (r sin theta + l sin phi = 0) and its derivatives in theta,
        phi_1 = -r cos(theta) / (l cos phi),  phi_2 = (r sin(theta) + l phi_1^2 sin phi) / (l cos phi),
    the rod's centre G = A + c (cos phi, sin phi) and the piston's x_B = r cos theta + l cos phi give
        M = I_crank + m_rod |G_1|^2 + I_rod phi_1^2 + m_piston x_B1^2,
        C = m_rod G_1 . G_2 + I_rod phi_1 phi_2 + m_piston x_B1 x_B2,
        Q = T_load + F_gas(t) x_B1 - m_rod g G_1y       (subscripts 1, 2: first, second derivative in theta)
    The crank is balanced (centre on its axis), the piston's centre is on the pin B.
    """
    crank, rod, piston = model.bodies
    o, a, b = _joint(model, "O"), _joint(model, "A"), _joint(model, "B")
    if np.linalg.norm(crank.location - o) > 1e-12 or np.linalg.norm(piston.location - b) > 1e-12:
        raise SystemExit("benchmark reference: crank centre off its axis or piston centre off its pin")
    _check_on_line(rod.location, a, b, "the rod's centre")
    r, l, c = np.linalg.norm(a - o), np.linalg.norm(b - a), np.linalg.norm(rod.location - a)
    g = -float(model.gravity[1])
    gas = function_from_spec(next(f for f in model.forces if f["name"] == "gas")["value"][0])
    load = function_from_spec(next(f for f in model.forces if f["name"] == "load")["value"])

    def terms(theta):
        s, co = math.sin(theta), math.cos(theta)
        sp = -r * s / l
        cp = math.sqrt(1 - sp * sp)
        p1 = -r * co / (l * cp)
        p2 = (r * s + l * p1 * p1 * sp) / (l * cp)
        a1, a2 = np.array([-r * s, r * co]), np.array([-r * co, -r * s])
        g1 = a1 + c * p1 * np.array([-sp, cp])
        g2 = a2 + c * p2 * np.array([-sp, cp]) - c * p1 * p1 * np.array([cp, sp])
        xb1 = -r * s - l * p1 * sp
        xb2 = -r * co - l * p2 * sp - l * p1 * p1 * cp
        mass = crank.inertia + rod.mass * g1 @ g1 + rod.inertia * p1 * p1 + piston.mass * xb1 * xb1
        coriolis = rod.mass * g1 @ g2 + rod.inertia * p1 * p2 + piston.mass * xb1 * xb2
        return mass, coriolis, xb1, g1[1]

    def f(t, y):
        mass, coriolis, xb1, g1y = terms(y[0])
        force = load.value(t) + gas.value(t) * xb1 - rod.mass * g * g1y
        return [y[1], (force - coriolis * y[1] ** 2) / mass]

    solution = solve_ivp(f, (0.0, t_end), [crank.orientation, crank.angular_velocity], method="DOP853", rtol=1e-13,
                         atol=1e-13)  # fmt: skip
    return solution.y[:1, -1]


ANDREWS_REFERENCE = np.array(
    [
        0.1581077119629904e2,
        -0.1575637105984298e2,
        0.4082224013073101e-1,
        -0.5347301163226948e0,
        0.5244099658805304e0,
        0.5347301163226948e0,
        0.1048080741042263e1,
    ]
)
"""(beta, Theta, gamma, Phi, delta, Omega, epsilon) at t = 0.03 s: IVP Test Set, andrews.f, subroutine andsoln."""


def andrews_angles(q: np.ndarray) -> np.ndarray:
    p = q[2::3]
    return np.array([p[0], p[1] - p[0], p[2], p[3] - p[4], p[4], p[5] - p[6], p[6]])


def scenes() -> list[Scene]:
    double = load_model(MODELS / "double_pendulum.yaml")
    engine = load_model(MODELS / "slider_crank_flywheel.yaml")
    return [
        Scene("double pendulum", "double_pendulum.yaml", 2.0, double_pendulum_angles(double),
              double_pendulum_reference(double, 2.0), (1e-2, 3e-3, 1e-3, 3e-4)),
        Scene("slider-crank with flywheel", "slider_crank_flywheel.yaml", 1.0, lambda q: q[2:3],
              slider_crank_reference(engine, 1.0), (3e-3, 1e-3, 3e-4, 1e-4)),
        Scene("Andrews' squeezing mechanism", "andrews.yaml", 0.03, andrews_angles, ANDREWS_REFERENCE,
              (1e-4, 3e-5, 1e-5, 3e-6)),
    ]  # fmt: skip


# -- runs ------------------------------------------------------------------------------------------------
def run(scene: Scene, repeats: int, **settings) -> dict:
    """One entry: error at the end time, median wall time, evaluations, steps, max residual."""
    system, q0, qd0 = build_system(load_model(MODELS / scene.file))
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = forward_dynamics(system, q0, qd0, scene.t_end, 1, **settings)
        times.append(time.perf_counter() - start)
    wall = statistics.median(times)
    evaluations = int(result.info["rhs_evaluations"])
    error = float(np.max(np.abs(scene.angles(result.q[-1]) - scene.reference)))
    return {
        "error": error,
        "ms": 1e3 * wall,
        "evaluations": evaluations,
        "us_per_evaluation": 1e6 * wall / max(evaluations, 1),
        "steps": int(result.info.get("integrator_steps", 0)),
        "residual": float(result.info["max_constraint_residual"]),
    }


HEADER = [
    "| formulation | integrator | rtol = atol / step | error (rad) | time (ms) | rhs evaluations | us/evaluation | "
    "steps | max residual |",
    "|---|---|---:|---:|---:|---:|---:|---:|---:|",
]


def row(formulation: str, integrator: str, setting: str, scene: Scene, repeats: int, **settings) -> str:
    try:
        m = run(scene, repeats, formulation=formulation, integrator=integrator, **settings)
    except (AnalysisError, np.linalg.LinAlgError, FloatingPointError, ValueError) as err:
        return f"| {formulation} | {integrator} | {setting} | failed: {str(err)[:80]} | | | | | |"
    return (
        f"| {formulation} | {integrator} | {setting} | {m['error']:.1e} | {m['ms']:.0f} | {m['evaluations']} | "
        f"{m['us_per_evaluation']:.0f} | {m['steps']} | {m['residual']:.0e} |"
    )


def formulation_table(scene: Scene, tolerances, repeats: int) -> list[str]:
    lines = list(HEADER)
    for formulation in FORMULATIONS:
        for tol in tolerances:
            lines.append(row(formulation, "DOP853", f"{tol:.0e}", scene, repeats, rtol=tol, atol=tol))
    return lines


def integrator_table(scene: Scene, tolerances, rk4_steps, repeats: int) -> list[str]:
    lines = list(HEADER)
    for integrator in (*ADAPTIVE, *IMPLICIT):
        formulation = "index-3" if integrator in IMPLICIT else "baumgarte"
        for tol in tolerances:
            lines.append(row(formulation, integrator, f"{tol:.0e}", scene, repeats, rtol=tol, atol=tol))
    for step in rk4_steps:
        with np.errstate(all="ignore"):
            lines.append(row("baumgarte", "rk4", f"h = {step:.0e}", scene, repeats, step=step))
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: rtol = atol = 1e-4 and one rk4 step only")
    parser.add_argument("--repeats", type=int, default=1, help="runs per entry, the median time is reported")
    parser.add_argument("--scene", choices=["double", "engine", "andrews"], action="append", help="only these scenes")
    args = parser.parse_args(argv)
    tolerances = TOLERANCES[:1] if args.quick else TOLERANCES
    print(
        f"Forward dynamics, run time against error; Python {platform.python_version()}, NumPy {np.__version__}, "
        f"SciPy {scipy.__version__}, {platform.machine()}, {os.cpu_count()} CPUs, "
        f"OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}, median of {args.repeats} run(s).\n"
        "error: largest absolute error of the scene's angles at the end time against the reference; time: the\n"
        "whole forward_dynamics call; us/evaluation: time / evaluations; max residual: max |Psi| on the output grid.\n"
    )
    start = time.perf_counter()
    keys = {"double": 0, "engine": 1, "andrews": 2}
    chosen = [s for k, s in enumerate(scenes()) if not args.scene or k in {keys[c] for c in args.scene}]
    for scene in chosen:
        rk4_steps = scene.rk4_steps[:1] if args.quick else scene.rk4_steps
        print(f"## {scene.name} (course/models/{scene.file}, t = 0 .. {scene.t_end} s)\n")
        print("Every formulation, DOP853:\n")
        print("\n".join(formulation_table(scene, tolerances, args.repeats)))
        print("\nEvery integrator, baumgarte formulation (hht and generalized-alpha: index-3, no formulation):\n")
        print("\n".join(integrator_table(scene, tolerances, rk4_steps, args.repeats)))
        print()
    print(f"Total {time.perf_counter() - start:.0f} s.")


if __name__ == "__main__":
    main()
