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
  distance, coordinate drivers, gear pairs (external and internal), cams with a roller or a flat-faced
  follower; spatial joints made of the basic constraints (spherical, universal, revolute, cylindrical,
  prismatic, rigid), the Euler-parameter normalization and the spatial drivers (rotation, translation,
  distance, coordinate); gravity, TSDA, RSDA (with an actuator given as a function of time), point forces
  and torques; constant, polynomial, harmonic, smooth-ramp and Fourier functions of time, and the
  eccentric-circle and Fourier cam profiles. Every example model of ``course/models`` is covered.

Anything else runs on the numpy engine, and ``info['chosen']`` says why: other formulations, implicit or
multistep integrators, and what is Python code rather than data: user forces, actuators given through the
API as a Python callable of time, length and speed, functions given as Python callables
(``PythonFunction``), masses given by the caller. ``scene.py`` reads what a scene has, ``codegen.py`` writes
and caches its module, ``kernels.py`` holds the compiled element formulas.

``projection.py`` and ``tree.py`` write the modules of the projection and joint-coordinates formulations
(their kernels: ``projection_kernels.py``, ``tree_kernels.py``); ``plan`` says which a run takes. Every
run's output stage is one compiled pass (``loops.output_history``; a large Psi_q's by its rows' blocks,
``blocked_output_history``): at every output time the right-hand side with its outputs (q'', lambda) and Psi,
Psi_q, Psi_t, from which ``history.py`` builds the residuals and the reactions and ``guard.Guard.check_outputs``
makes its checks.

The kinematic analysis has a compiled engine of its own on the same kernels (``kinematic.py``, its step
loop ``kinematic_loop.py``): ``kinematics.kinematic_analysis(..., engine="compiled")``.

Cached machine code that a change of another file made stale is removed at this package's import
(``cache_stamp``: numba renews a function's cache when its own file changes, not its callees').

numba is imported only here, when a run is compiled: importing ``solutions`` (and the student package
generated from it) never imports it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .cache_stamp import forget_stale_machine_code

forget_stale_machine_code()  # before any compiled module of the package loads its cached machine code

from . import tree  # noqa: E402
from .scene import Scene, describe  # noqa: E402
from .tree import TreeScene  # noqa: E402

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


def plan(system, M, forces, formulation: str, formulation_object) -> Plan:
    """The compiled run of ``system`` with M and ``forces`` by the numpy ``formulation_object`` (made for the same
    run): its scene described (``describe``), and for joint coordinates the tree over it (``tree.describe``), whose
    cut elements (``tree.cut_names``) the scene describes first in each constraint kernel's data (the integration
    evaluates those alone: ``TreeScene.data``). The one place a tree's scene is described: every caller's scene
    has its cut elements first."""
    if formulation != "joint-coordinates":
        scene = describe(system, M, forces)
    else:
        scene = describe(system, M, forces, tree.cut_names(formulation_object))
        if scene.unsupported is None:
            scene = tree.describe(scene, formulation_object)
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
    """Importing numba and the loops and loading the scene's module: compiling it too when it was not cached."""
    cached: bool
    psi: np.ndarray = None
    """Psi, Psi_q, Psi_t at the output times (``loops.output_history``), for the checks and the reactions; a large
    Psi_q's history by its rows' blocks (``history.BlockedJacobians``, ``ONE_PASS_LARGEST``)."""
    jac: np.ndarray = None
    psit: np.ndarray = None
    joint_states: np.ndarray | None = None
    """A joint-coordinates run's integrated states (joint positions, joint velocities, energies) at the output
    times; its ``Y`` holds the body coordinates made from them (q, q', energies), as every other run's."""
    reached: int = 0
    """How many output times the run reached (all on success). A run that stopped early (status > 0) has only
    those rows, and after them one more: the state where it stopped, at ``t``."""


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
    if formulation == "projection" and singular_mass(scene):
        return "the projection formulation with a singular mass matrix (a point mass), which the compiled code inverts"
    return scene.unsupported


def singular_mass(scene: Scene) -> bool:
    """Whether a scene's M is singular (a point mass): a zero on a planar diagonal, a spatial inertia with an
    eigenvalue <= 0 (``mass_matrix.singular_inertia``)."""
    diagonal, inertias = getattr(scene, "mass_diagonal", None), getattr(scene, "inertias", None)
    if diagonal is not None and np.any(diagonal <= 0.0):
        return True
    return inertias is not None and bool(np.any(np.linalg.eigvalsh(inertias)[:, 0] <= 0.0))


def tableau(dop: bool) -> tuple:
    """(A, B, C, E, E3, E5, D, P) of DOP853 or RK45 (``tableaux.py``: scipy's coefficients; the unused ones empty).
    DOP853's A and C are those of all 16 stages: the 12 of a step, the 13th (B at t + h, first of the next step)
    and the 3 extra ones of the dense output."""
    if dop in _TABLEAUS:  # made once per process (the loops never write them): 10 us a run
        return _TABLEAUS[dop]
    from ..tableaux import DOP853, RK45

    empty1, empty2 = np.zeros(1), np.zeros((1, 1))
    if dop:
        d = DOP853
        n, extra = d.n_stages, len(d.C_EXTRA)
        A = np.zeros((n + 1 + extra, n + 1 + extra))
        A[:n, :n], A[n, :n], A[n + 1 :] = d.A, d.B, d.A_EXTRA
        C = np.concatenate([d.C, [1.0], d.C_EXTRA])
        _TABLEAUS[dop] = (A, d.B, C, empty1, d.E3, d.E5, d.D, empty2)
    else:
        _TABLEAUS[dop] = (RK45.A, RK45.B, RK45.C, RK45.E, empty1, empty1, empty2, RK45.P)
    return _TABLEAUS[dop]


_TABLEAUS: dict = {}


def parameters(
    scene: Scene | TreeScene, alpha: float = 0.0, beta: float = 0.0, tol: float = 0.0, iterations: float = 0.0
) -> tuple:
    """P: the numbers the generated module takes besides the element data D (``codegen``, ``loops.P_TYPE``): the
    formulation's (Baumgarte's alpha, beta; the projection's tolerance and iterations, ``Plan.numbers``) and the
    sizes and switches P[8] = (n, m, 3 with the energy states else 0, joint positions, joint velocities, 1 when a
    tree's drivers' power needs lambda at every evaluation, the number of cut rows, the cut rows..., the tree's
    rows' owners..., the two bodies of each cut row..., the tree's rows body by body: ``tree.row_index``, the cut
    solve's sparsity: ``structure.cut_structure``). Made
    once per scene and numbers (a run's start rates and its loop ask for the same)."""
    kept = scene.__dict__.setdefault("_parameters", {})
    key = (alpha, beta, tol, iterations)
    if key not in kept:
        kept[key] = _parameters(scene, alpha, beta, tol, iterations)
    return kept[key]


def _parameters(scene: Scene | TreeScene, alpha: float, beta: float, tol: float, iterations: float) -> tuple:
    tree = scene if isinstance(scene, TreeScene) else None
    scene = scene.scene if tree is not None else scene
    extra = 3 if scene.energies else 0
    positions, velocities = (tree.n_positions, tree.k) if tree is not None else (scene.n, scene.n)
    drivers_power = int(tree is not None and scene.drivers and scene.energies)  # a tree's lambda at every evaluation
    ncut = tree.cut_rows.size if tree is not None else 0
    sizes = np.array([scene.n, scene.m, extra, positions, velocities, drivers_power, ncut], np.int64)
    empty1, empty3 = _EMPTY
    mass = scene.mass_diagonal if scene.mass_diagonal is not None else empty1
    return (
        scene.Q0,
        mass if scene.dimension == 2 else empty1,
        scene.masses if scene.dimension == 3 else empty1,
        scene.inertias if scene.dimension == 3 else empty3,
        scene.weights if scene.dimension == 3 else empty1,
        scene.function_kinds,
        scene.function_params,
        np.array([alpha, beta, tol, iterations], dtype=float),
        sizes if tree is None else np.concatenate([sizes, *tree.arrays()]),
    )


_EMPTY = (np.zeros(1), np.zeros((1, 3, 3)))
"""The entries of P a scene does not use (a planar scene's masses and inertias, a spatial one's diagonal), made once
(no kernel writes P; two numpy calls a run at its start, 2-8 us there)."""


def load(plan: Plan) -> tuple[object, object, bool]:
    """(module with ``scene_rhs``, ``project`` of the formulation, all machine code was on disk), found once per plan
    (its start rates and its run load the same; the second finds it loaded, and says what the first found: on
    disk or compiled, ``load_seconds``)."""
    if "_loaded" in plan.__dict__:
        return plan.__dict__["_loaded"][:3]
    start = time.perf_counter()
    module, project, cached = _load(plan)
    plan.__dict__["_loaded"] = (module, project, cached, time.perf_counter() - start)
    return module, project, cached


def load_seconds(plan: Plan) -> float:
    """What the plan's first ``load`` took: importing numba and the loops, loading (or compiling) the modules."""
    return plan.__dict__["_loaded"][3] if "_loaded" in plan.__dict__ else 0.0


def _load(plan: Plan) -> tuple[object, object, bool]:
    from . import loops  # imports numba

    if isinstance(plan.scene, TreeScene):
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
    """Whether numba's machine code of everything the plan runs is on disk (no compilation needed): so where the plan
    has loaded it (``load``: its start rates did, or the prepared run's first run), without asking the disk."""
    if "_loaded" in plan.__dict__:
        return True
    if isinstance(plan.scene, TreeScene):
        return tree.is_cached(plan.scene)
    from .codegen import is_cached as scene_cached

    if plan.formulation == "projection":
        from . import projection

        return scene_cached(plan.scene) and projection.is_cached(plan.scene)
    return scene_cached(plan.scene)


ONE_PASS_LARGEST = 1024
"""Entries of Psi_q (m n) up to which a run keeps Psi_q's history dense (N, m, n) (``loops.output_history``);
above, by its rows' blocks (``Scene.row_columns``, ``history.BlockedJacobians``, ``loops.blocked_output_history``:
no (N, m, n) array, whose first touch costs more than the arithmetic: a spatial chain of 64 bodies, 256 x 448, 23
ms against 51 for the dense history). Both from the one pass of the outputs (q'', lambda). Whole call, dense against
blocks (thread CPU, the loop chain, joint coordinates; the blocks then in a second pass): N = 2-6 (m n 210-1482) the
same within 0.3 ms, N = 8 (2550) 10.9 -> 10.6 ms, N = 12 (5550) 16.1 -> 13.9 ms; the spatial chain of 16 (7168)
29.0 -> 26.8 ms (benchmarks/results/call_cost.md, twenty-first session). The Guard reads either form. Since the
blocks come from the same pass (thirtieth session; outputs, Guard and result, paired in one process, ms a call):
loops N = 5 (1056) -0.034, N = 6 (1482) -0.044, the planar chain of 16 (1536) -0.080, the spatial chain of 8 (1792)
-0.056; below, loops N = 2-4 (210-702), the slider-crank and the bench scenes +0.003 to +0.06 (a small dense route of
the Guard makes the blocks dense again)."""
INT64_MAX = int(np.iinfo(np.int64).max)
"""The largest budget of evaluations or steps: none (``np.iinfo`` made once, not 2 us a run)."""
PAUSE_STEPS = 1000
"""The compiled loop pauses after this many steps for the configuration check of ``on_pause`` (``run``): a run that
crawls at a singular position stops there as the numpy engine's run, which checks after every step, stops."""


def paused_embedded(loops, rhs, project, z0: np.ndarray, times: np.ndarray, numbers: tuple, on_pause) -> tuple:
    """``loops.embedded`` over the output grid in pieces of PAUSE_STEPS steps, ``on_pause(t, z)`` between them (it
    raises to stop the run); the same results as one call (the loop resumes with its next step size, and f(t, z) is
    evaluated anew, one evaluation more per pause). (Y, evaluations, steps, rejected, status, t, h, reached)."""
    rtol, atol, max_step, budget, dop, scipy_like, tableau_, P, D = numbers
    span, every = float(times[-1] - times[0]), INT64_MAX if on_pause is None else PAUSE_STEPS
    piece = loops.embedded(
        rhs, project, z0, times, rtol, atol, max_step, budget, dop, scipy_like, tableau_, P, D, span, 0.0, every
    )
    if piece[4] != 5:  # one piece: the loop's own array is the history (its row 0 is z0, a stop's state after k)
        return piece
    Y, k, spent, steps, rejected = np.empty((times.size, z0.size)), 1, 0, 0, 0
    Y[0] = z0
    while True:
        Yp, evaluations, done, refused, status, t, h, reached = piece
        spent, steps, rejected = spent + evaluations, steps + done, rejected + refused
        Y[k : k + reached - 1] = Yp[1:reached]
        k += reached - 1
        if status != 5:
            if status != 0:
                Y[k] = Yp[reached]
            return Y, spent, steps, rejected, status, t, h, k
        z = Yp[reached].copy()
        on_pause(t, z)
        rest = np.ascontiguousarray(np.append(t, times[k:]))
        piece = loops.embedded(
            rhs, project, z, rest, rtol, atol, max_step, budget - spent, dop, scipy_like, tableau_, P, D, span, h,
            every,
        )  # fmt: skip


def configuration(t: float, z: np.ndarray, module, scene, P, D, rhs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, Psi, Psi_q) of the state z at t (rows of one output time), a tree's body coordinates made first."""
    from . import loops

    Y, times = np.ascontiguousarray(z[None, :]), np.array([float(t)])
    tree = isinstance(scene, TreeScene)
    out, psi, jac, _ = loops.output_history(rhs, times, Y, P, D, 3 * scene.n + scene.m if tree else scene.m)
    q = out[0, z.size : z.size + scene.n] if tree else Y[0, : scene.n]
    return q, psi, jac


def run(
    plan: Plan,
    z0: np.ndarray,
    times: np.ndarray,
    integrator: str,
    rtol: float,
    atol: float,
    step: float | None,
    max_evaluations: int | None,
    on_pause=None,
) -> CompiledRun:
    """Integrate the plan's scene from z0 over the output grid ``times`` with the compiled loop; an adaptive loop
    calls ``on_pause(t, q, Psi, Psi_q)`` every PAUSE_STEPS steps, which raises to stop the run."""
    from . import loops  # imports numba

    module, project, cached = load(plan)
    scene = plan.scene
    P, D = parameters(scene, *plan.numbers), scene.data()
    z0 = np.ascontiguousarray(z0, dtype=float)
    times = np.ascontiguousarray(times, dtype=float)
    rhs = loops.first_class(module.scene_rhs, loops.RHS_SIGNATURE)  # numba's type of each found once
    project = loops.first_class(project, loops.PROJECT_SIGNATURE)
    if integrator in FIXED:
        Y, evaluations, steps, rejected, status, t, h, reached = loops.rk4(
            rhs, project, z0, times, float(step or 0.0), P, D
        )
    else:
        dop, scipy_like = COMPILED_INTEGRATORS[integrator]
        budget = INT64_MAX if max_evaluations is None else int(max_evaluations)
        max_step = float(step) if step else np.inf
        numbers = (float(rtol), float(atol), max_step, budget, dop, scipy_like, tableau(dop), P, D)
        judge = None
        if on_pause is not None:
            judge = lambda t, z: on_pause(t, *configuration(t, z, module, scene, P, D, rhs))  # noqa: E731
        Y, evaluations, steps, rejected, status, t, h, reached = paused_embedded(
            loops, rhs, project, z0, times, numbers, judge
        )
    if status != 0:  # the output times reached and, after them, the state where the loop stopped (no others)
        times, Y = np.append(times[:reached], t), Y[: reached + 1]
    joint_states, n, m, ny = None, scene.n, scene.m, Y.shape[1]
    tree = isinstance(scene, TreeScene)  # after y': the body coordinates of the joint states, and q'', lambda there
    width = 3 * n + m if tree else m
    columns = None if m * n <= ONE_PASS_LARGEST else getattr(scene, "scene", scene).row_columns  # (a tree's scene)
    if m * n <= ONE_PASS_LARGEST or (tree and columns is None):  # Psi, Psi_q, Psi_t from the same evaluations
        out, psi, jac, psit = loops.output_history(rhs, times, Y, P, D, width)
    elif columns is not None:  # the same, Psi_q by its rows' blocks
        out, psi, values, psit = loops.blocked_output_history(rhs, times, Y, P, D, width, columns)
        from .history import BlockedJacobians

        jac = BlockedJacobians(values, columns, n)
    else:  # rows that reach other columns: Psi_q's history dense, from the module's constraint_arrays
        out = loops.outputs(rhs, times, Y, P, D, width)
    if tree:
        qdd, lam = np.ascontiguousarray(out[:, ny + 2 * n : ny + 3 * n]), np.ascontiguousarray(out[:, ny + 3 * n :])
        joint_states, Y = Y, np.concatenate([out[:, ny : ny + 2 * n], Y[:, scene.n_positions + scene.k :]], axis=1)
    else:  # q'' in y', lambda after it
        qdd, lam = np.ascontiguousarray(out[:, n : 2 * n]), np.ascontiguousarray(out[:, ny:])
    if m * n > ONE_PASS_LARGEST and columns is None and not tree:  # (a tree's module: scene_rhs alone, tree.py)
        from . import history

        psi, jac, psit = history.constraint_arrays(module, scene, times, Y)
    return CompiledRun(
        Y, qdd, lam, int(evaluations), int(steps), int(rejected), int(status), float(t), float(h),
        load_seconds(plan), cached, psi, jac, psit, joint_states, int(reached),
    )  # fmt: skip


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
