"""The compiled engine: a scene-specialized right-hand side and integrator loop, compiled by numba.

The numpy code of ``solutions/`` is the readable reference (what students write); this package is a second
engine generated from the same model, for speed. ``dynamics.forward_dynamics(..., engine="compiled")``
(``mbd run --engine compiled``) hands a run here when it can take it:

- formulations ``baumgarte`` (eq. 5.29, 5.30; any alpha, beta >= 0), ``projection`` (eq. 5.30 unstabilized,
  then the mass-orthogonal projection of eq. 5.50 after every step: ``projection.py``) and
  ``joint-coordinates`` (eq. 5.44 with Z = D by recursive kinematics; revolute, prismatic and spherical
  joints; loops and drivers as cut constraints: ``tree.py``), planar and spatial;
- integrators ``DOP853`` and ``RK45`` (step by step as scipy's), ``dop853`` and ``rk45`` (as this package's
  own loop), ``rk4`` (fixed step); the loops are compiled with the right-hand side (``loops.py``);
- planar revolute, prismatic (pin in slot + angle), translation and rotation drivers, rack and pinion,
  distance, coordinate drivers; spatial joints made of the basic constraints (spherical, universal,
  revolute, cylindrical, prismatic, rigid) and the Euler-parameter normalization; gravity, TSDA, RSDA
  (with an actuator given as a function of time), point forces and torques; constant, polynomial,
  harmonic and smooth-ramp functions of time.

Anything else (other formulations, implicit or multistep integrators, gears, cams, spatial drivers,
user forces, Fourier functions, actuators of length or speed, masses given by the caller) runs on the
numpy engine, and ``info['chosen']`` says why. ``scene.py`` reads what a scene has, ``codegen.py`` writes and
caches its module, ``kernels.py`` holds the compiled element formulas.

``projection.py`` and ``tree.py`` write the modules of the projection and joint-coordinates formulations
(their kernels: ``projection_kernels.py``, ``tree_kernels.py``); ``plan`` says which a run takes.

numba is imported only here, when a run is compiled: importing ``solutions`` (and the student package
generated from it) never imports it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .scene import Scene, describe
from .tree import TreeScene

COMPILED_FORMULATIONS = ("baumgarte", "projection", "joint-coordinates")
OPTIONS = {
    "baumgarte": {"alpha", "beta"},
    "projection": {"tol", "max_iterations"},
    "joint-coordinates": {"alpha", "beta"},
}
"""The formulation options each compiled formulation takes (as its numpy class)."""
COMPILED_INTEGRATORS = {"DOP853": (True, True), "dop853": (True, False), "RK45": (False, True), "rk45": (False, False)}
"""Embedded pairs: (DOP853 or not, step by step as scipy's solve_ivp or as this package's own loop)."""
FIXED = ("rk4",)


@dataclass
class Plan:
    """A run the compiled engine takes: the scene (a ``TreeScene`` for joint coordinates), the formulation and
    its numbers (alpha, beta, projection tolerance, projection iterations), and the numpy formulation object,
    whose counters (``projections``) the compiled run fills as the numpy run would."""

    scene: Scene | TreeScene
    formulation: str
    numbers: tuple[float, float, float, float]
    formulation_object: object = None


def plan(scene: Scene, formulation: str, formulation_object) -> Plan:
    """The compiled run of a scene with the numpy ``formulation_object`` (made for the same run)."""
    if formulation == "joint-coordinates" and scene.unsupported is None:
        from .tree import describe as describe_tree

        scene = describe_tree(scene, formulation_object)
    f = formulation_object
    numbers = (
        float(getattr(f, "alpha", 0.0)),
        float(getattr(f, "beta", 0.0)),
        float(getattr(f, "tol", 0.0)),
        float(getattr(f, "max_iterations", 0)),
    )
    return Plan(scene, formulation, numbers, f)


@dataclass
class CompiledRun:
    """What the compiled loop gives back: states at the output times, q'' and lambda there (and q, q' of a
    joint-coordinates run), and counts."""

    Y: np.ndarray
    qdd: np.ndarray
    lam: np.ndarray
    evaluations: int
    steps: int
    rejected: int
    status: int
    t: float
    h: float
    load_seconds: float
    cached: bool
    q: np.ndarray | None = None
    qd: np.ndarray | None = None


def unsupported(scene: Scene, formulation: str, integrator: str, options: dict) -> str | None:
    """Why the compiled engine cannot take this run (None: it can)."""
    if formulation not in COMPILED_FORMULATIONS:
        return f"the {formulation} formulation is not compiled (only {', '.join(COMPILED_FORMULATIONS)})"
    if integrator not in COMPILED_INTEGRATORS and integrator not in FIXED:
        return f"the {integrator} integrator is not compiled (only {', '.join([*COMPILED_INTEGRATORS, *FIXED])})"
    extra = set(options) - OPTIONS[formulation]
    if extra:
        return f"formulation options {', '.join(sorted(extra))} are not compiled"
    if formulation == "joint-coordinates" and scene.unsupported is None and not isinstance(scene, TreeScene):
        return "joint coordinates without the tree (``plan``)"
    return scene.unsupported


def tableau(dop: bool) -> tuple:
    """(A, B, C, E, E3, E5, D, P) of DOP853 or RK45, scipy's coefficients (the unused ones empty)."""
    import scipy.integrate

    empty1, empty2 = np.zeros(1), np.zeros((1, 1))
    if dop:
        from scipy.integrate._ivp import dop853_coefficients as dop853

        return (dop853.A, dop853.B, dop853.C, empty1, dop853.E3, dop853.E5, dop853.D, empty2)
    rk = scipy.integrate.RK45
    return (rk.A, rk.B, rk.C, rk.E, empty1, empty1, empty2, rk.P)


def parameters(scene: Scene | TreeScene, numbers: tuple = (0.0, 0.0, 0.0, 0.0)) -> tuple:
    """P: the numbers the generated module takes besides the element data D (``codegen``, ``loops.P_TYPE``)."""
    tree = scene if isinstance(scene, TreeScene) else None
    scene = scene.scene if tree is not None else scene
    extra = 3 if scene.energies else 0
    positions, velocities = (tree.n_positions, tree.k) if tree is not None else (scene.n, scene.n)
    cut = list(tree.cut_rows) if tree is not None else []
    empty1, empty3 = np.zeros(1), np.zeros((1, 3, 3))
    mass = scene.mass_diagonal if scene.mass_diagonal is not None else empty1
    return (
        scene.Q0,
        mass if scene.dimension == 2 else empty1,
        scene.masses if scene.dimension == 3 else empty1,
        scene.inertias if scene.dimension == 3 else empty3,
        scene.weights if scene.dimension == 3 else empty1,
        scene.function_kinds,
        scene.function_params,
        np.array(numbers, dtype=float),
        np.array([scene.n, scene.m, extra, positions, velocities, *cut], dtype=np.int64),
    )


def load(plan: Plan) -> tuple[object, object, bool]:
    """(module with ``scene_rhs``, ``project`` of the formulation, all machine code was on disk)."""
    from . import loops  # imports numba

    if isinstance(plan.scene, TreeScene):
        from . import tree

        module, cached = tree.load(plan.scene)
        return module, loops.no_projection, cached
    from .codegen import load as load_scene

    module, cached = load_scene(plan.scene)
    if plan.formulation != "projection":
        return module, loops.no_projection, cached
    from . import projection

    projector, projector_cached = projection.load(plan.scene)
    return module, projector.project, cached and projector_cached


def is_cached(plan: Plan) -> bool:
    """Whether numba's machine code of everything the plan runs is on disk (no compilation needed)."""
    if isinstance(plan.scene, TreeScene):
        from . import tree

        return tree.is_cached(plan.scene)
    from .codegen import is_cached as scene_cached

    if plan.formulation == "projection":
        from . import projection

        return scene_cached(plan.scene) and projection.is_cached(plan.scene)
    return scene_cached(plan.scene)


def run(
    plan: Plan,
    z0: np.ndarray,
    times: np.ndarray,
    integrator: str,
    rtol: float,
    atol: float,
    step: float | None,
    max_evaluations: int | None,
) -> CompiledRun:
    """Integrate the plan's scene from z0 over the output grid ``times`` with the compiled loop."""
    from . import loops  # imports numba

    start = time.perf_counter()
    module, project, cached = load(plan)
    scene = plan.scene
    P, D = parameters(scene, plan.numbers), scene.data()
    z0 = np.ascontiguousarray(z0, dtype=float)
    times = np.ascontiguousarray(times, dtype=float)
    rhs = module.scene_rhs
    if integrator in FIXED:
        Y, evaluations, steps, rejected, status, t, h = loops.rk4(rhs, project, z0, times, float(step or 0.0), P, D)
    else:
        dop, scipy_like = COMPILED_INTEGRATORS[integrator]
        budget = np.iinfo(np.int64).max if max_evaluations is None else int(max_evaluations)
        max_step = float(step) if step else np.inf
        Y, evaluations, steps, rejected, status, t, h = loops.embedded(
            rhs, project, z0, times, float(rtol), float(atol), max_step, budget, dop, scipy_like, tableau(dop), P, D
        )
    q = qd = None
    if isinstance(scene, TreeScene):
        q, qd, qdd, lam = loops.body_outputs(module.body_state, times, Y, P, D)
    else:
        qdd, lam = loops.outputs(module.accelerations, times, Y, P, D)
    load_seconds = time.perf_counter() - start
    return CompiledRun(
        Y,
        qdd,
        lam,
        int(evaluations),
        int(steps),
        int(rejected),
        int(status),
        float(t),
        float(h),
        load_seconds,
        cached,
        q,
        qd,
    )


__all__ = [
    "COMPILED_FORMULATIONS",
    "COMPILED_INTEGRATORS",
    "CompiledRun",
    "Plan",
    "Scene",
    "TreeScene",
    "describe",
    "is_cached",
    "plan",
    "run",
    "unsupported",
]
