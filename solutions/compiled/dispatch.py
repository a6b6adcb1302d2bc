"""Which engine runs a forward-dynamic analysis, and the compiled run handed back to ``forward_dynamics``.

``engine="numpy"`` is the reference; ``"compiled"`` takes the compiled engine whenever it covers the run
(``solutions.compiled``), else numpy with the reason; ``"auto"`` (the default) takes it when it also pays:

    the compiled engine when its machine code for the run's dimension and formulation is on disk (``mbd
    compile`` makes all of it once per machine) and the numpy run is expected to take
    longer than LOAD_SECONDS (importing numba and loading that code costs about that: a one-step run stays on
    numpy, whose start is free); when it is not on disk, when the numpy run is expected to take longer than
    COMPILE_SECONDS (a first compilation, measured on the course's scenes: ``benchmarks/engines.py``), saying
    so on stderr while it compiles. ``"cached"`` takes it whenever its code is on disk (a process that runs
    many scenes, the grader, pays the loading once). The numpy run time is estimated as (evaluations) x (one
    numpy evaluation, timed at the initial state), with evaluations = stages x t_end / h, h the starting step
    of Hairer's rule (sec. II.4) at the run's tolerance (a fixed-step run: its steps); where that comes within a
    tenth of the bound, from a trial of TRIAL_STEPS steps of the same pair (this package's loop): its own seconds
    times t_end over the time it reached. On the 28 course models at three tolerances the starting step alone was
    0.14 to 29,000 times the run's evaluations (far above it where the motion starts at rest, so such a run takes
    the trial), the trial's mean rate 0.05 to 1.65 times (1.0 median; below 0.1 only where the motion itself
    speeds up tenfold later, Andrews' squeezer driven by a constant torque); the trial's last step, its figure
    before, was 0.03 to 51 times (quarter_car: its first steps are rejected in turn, the eighth was 40 times
    shorter than the sixteenth). The run's whole time is then that of its integration times RUN_FACTOR (its
    outputs and checks). ``benchmarks/auto_estimate.py`` prints these ratios.

The choice and its reason go into ``info['chosen']`` (``engine``, ``engine_why``).
"""

from __future__ import annotations

import math
import sys
import time
from types import SimpleNamespace

import numpy as np

from .. import compiled  # the package: its functions looked up at each call (a test may replace one)
from ..diagnostics import AnalysisError
from ..integrators import (
    FIXED_STEP_METHODS,
    BudgetError,
    IntegrationStats,
    budget_message,
    collapse_message,
    initial_step,
    integrate,
    power_start,
)
from ..settings import ENGINES, Settings
from .tree import TreeScene

COMPILE_SECONDS = 8.0
"""What a first compilation of a scene's module costs (numba 0.68, one core of the course machine: 5.7-8.7 s
measured, with the loops compiled already: they take 10-20 s more once per machine)."""
LOAD_SECONDS = 0.5
"""What loading the cached machine code costs (importing numba, reading the cache): 0.42-0.55 s measured in a new
process on the idle course machine (``benchmarks/engines.py --calibrate``, ``benchmarks/results/engines.md``)."""
STAGES = {"DOP853": 12, "dop853": 12, "RK45": 6, "rk45": 6, "rk4": 4}
TRIAL_STEPS = 16
"""Accepted steps of the trial run behind the estimate of a long numpy run (``trial_seconds``): 8 steps' mean rate was
0.05 to 25 times the run's on the course models (a step grown from a tiny starting one), 16 steps' 0.05 to 1.65."""


RUN_FACTOR = 2.0
"""A numpy run's whole time over its integration's (the outputs, the checks, the divergence companion): 0.5 to 5.5,
median 1.8, with the divergence check skipped and 0.7 to 9.9, median 2.2, with it, on the course models' runs of
2 s with 100 outputs against their trial's estimate (``benchmarks/auto_estimate.py --calibrate``)."""


def estimated_numpy_seconds(equations, z0: np.ndarray, settings: Settings, threshold: float = math.inf) -> float:
    """The numpy engine's expected run time (module docstring): its integration's, first from the starting step h0,
    then, when that comes within a tenth of ``threshold`` (the time the compiled engine must beat), from a trial of
    the method, times RUN_FACTOR (what the run does besides integrating)."""
    f, integrator, t_end, step = equations.rhs, settings.integrator, settings.t_end, settings.step
    start = time.perf_counter()
    fy = f(0.0, z0)
    for _ in range(4):
        f(0.0, z0)
    per_call = (time.perf_counter() - start) / 5
    if integrator == "rk4":
        substeps = max(1, math.ceil(t_end / settings.steps / step - 1e-9)) if step else 1
        return RUN_FACTOR * per_call * 4 * settings.steps * substeps
    order = 7 if integrator in ("DOP853", "dop853") else 4
    h = initial_step(f, 0.0, z0, fy, order, settings.rtol, settings.atol, t_end)
    quick = RUN_FACTOR * per_call * STAGES[integrator] * t_end / max(h, 1e-300)
    if quick < threshold / 10:
        return quick
    return RUN_FACTOR * trial_seconds(f, z0, t_end, integrator, settings.rtol, settings.atol, step)


def trial_seconds(f, z0: np.ndarray, t_end: float, integrator: str, rtol: float, atol: float, step) -> float:
    """The run time extrapolated from a trial of TRIAL_STEPS accepted steps of this package's loop of the same pair
    (dop853 or rk45, ``integrators.integrate``) with the numpy right-hand side: (its evaluations x t_end / the time
    it reached) x (its seconds per evaluation) (``trial_rate``)."""
    evaluations, per_evaluation = trial_rate(f, z0, t_end, integrator, rtol, atol, step)
    return evaluations * per_evaluation


def trial_rate(f, z0: np.ndarray, t_end: float, integrator: str, rtol: float, atol: float, step) -> tuple[float, float]:
    """(the run's expected right-hand-side evaluations, seconds per evaluation) from a trial of TRIAL_STEPS accepted
    steps: the evaluations it took, scaled by t_end over the time it reached (its mean rate, rejected steps
    included; a single step's length, even the last, swings tenfold where the controller is rejecting steps in
    turn), and its wall time per evaluation (the loop's own work included). A run the trial finishes is its own
    figure."""
    method = "dop853" if integrator in ("DOP853", "dop853") else "rk45"
    reached = [0.0]

    def after_step(t, y):
        reached[0] = t

    start = time.perf_counter()
    stats = integrate(
        f, z0, np.array([0.0, t_end]), lambda k, t, y: None, method, rtol, atol, step, after_step=after_step,
        max_evaluations=None, stiffness="off", max_steps=TRIAL_STEPS,
    )  # fmt: skip
    evaluations = max(stats.rhs_evaluations, 1)
    per_evaluation = (time.perf_counter() - start) / evaluations
    return evaluations * t_end / max(min(reached[0], t_end), 1e-300), per_evaluation


def choose(settings: Settings, equations, z0: np.ndarray, expected: float | None = None):
    """(Plan or None, {'engine', 'engine_why'}): the compiled engine's plan (``solutions.compiled.plan``) when it
    runs this analysis; ``settings`` are the run's, with its formulation, integrator and tolerances chosen;
    ``expected``: the numpy run's seconds as ``compiled_start`` estimated them (at this rtol, or more than
    LOAD_SECONDS at a looser one, which a tighter one only lengthens): no second estimate."""
    engine, formulation, integrator = settings.engine, settings.formulation, settings.integrator
    if engine == "numpy":
        return None, {"engine": "numpy", "engine_why": "numpy engine asked for"}
    if settings.stiffness == "error" and integrator not in FIXED_STEP_METHODS:  # the same verdict: the numpy loop's
        return None, {"engine": "numpy", "engine_why": "stiffness error: the stiffness monitor is not compiled"}
    if engine != "auto":
        expected = None
    else:  # a run shorter than loading the compiled code stays on numpy, whatever is on disk
        if expected is None:
            expected = estimated_numpy_seconds(equations, z0, settings, LOAD_SECONDS)
        if expected <= LOAD_SECONDS:
            why = f"numpy run estimated at {expected:.3g} s, less than loading the compiled code ({LOAD_SECONDS:g} s)"
            return None, {"engine": "numpy", "engine_why": why}
    job = compiled_plan(equations, formulation)
    why_not = compiled.unsupported(job.scene, formulation, integrator, settings.formulation_options)
    if why_not is not None:
        return None, {"engine": "numpy", "engine_why": f"not compiled: {why_not}"}
    cached, cannot = on_disk(compiled.is_cached, job, engine)
    if cannot:
        return None, {"engine": "numpy", "engine_why": cannot}
    if engine == "compiled":
        return _compiling(job, cached), {"engine": "compiled", "engine_why": "compiled engine asked for"}
    if engine == "cached":
        if cached:
            return job, {"engine": "compiled", "engine_why": "compiled code for this scene's dimension is cached"}
        return None, {"engine": "numpy", "engine_why": "no compiled code for this scene's dimension is cached"}
    if cached:
        why = f"numpy run estimated at {expected:.3g} s, more than loading the compiled code ({LOAD_SECONDS:g} s)"
        return job, {"engine": "compiled", "engine_why": why}
    if expected > COMPILE_SECONDS:
        why = f"numpy run estimated at {expected:.3g} s, more than a first compilation ({COMPILE_SECONDS:g} s)"
        return _compiling(job, cached), {"engine": "compiled", "engine_why": why}
    why = (
        f"numpy run estimated at {expected:.3g} s, less than a first compilation ({COMPILE_SECONDS:g} s): "
        "mbd compile makes the compiled engine once per machine"
    )
    return None, {"engine": "numpy", "engine_why": why}


def compiled_start(
    settings: Settings, equations, formulation: str, z: np.ndarray, rtol: float
) -> tuple[bool, float | None]:
    """(whether ``choose`` will compile a run on engine ``cached`` or ``auto`` by ``formulation``, the numpy run's
    estimated seconds at ``rtol`` where they were estimated), decided before the run's start rates
    (``dynamics.StartRates``), which then come from the compiled right-hand side as its integration will
    (``start_rates``): the compiled engine covers the formulation, its options and the integrator (DOP853 for
    ``auto``), its machine code is on disk (no compilation before ``choose`` says so), the stiffness monitor is not
    asked to stop the run, and on ``auto`` the numpy run is estimated longer than LOAD_SECONDS at ``rtol``, the
    loosest the run can have (the tolerance rule only tightens it, which lengthens the run; the estimate comes
    first: a short run looks no further). No numba is imported to decide. ``choose`` takes the estimate instead of
    making it again (``dynamics.plan_method``: where the run's rtol is this one, or where it said 'compile')."""
    integrator = "DOP853" if settings.integrator == "auto" else settings.integrator
    if settings.engine not in ("cached", "auto") or settings.stiffness == "error":
        return False, None
    if integrator not in compiled.COMPILED_INTEGRATORS and integrator not in compiled.FIXED:
        return False, None
    expected = None
    if settings.engine == "auto":
        loosest = settings.replace(formulation=formulation, integrator=integrator, rtol=rtol)
        expected = estimated_numpy_seconds(equations, z, loosest, LOAD_SECONDS)
        if expected <= LOAD_SECONDS:
            return False, expected
    job = compiled_plan(equations, formulation)
    if compiled.unsupported(job.scene, formulation, integrator, settings.formulation_options) is not None:
        return False, expected
    return on_disk(compiled.is_cached, job, settings.engine)[0], expected


def compiled_plan(equations, formulation: str):
    """The compiled engine's ``Plan`` of ``equations`` (``solutions.compiled.plan``: the scene described),
    made once per formulation object and force model: a run's start rates and its engine's choice share it (the
    formulation object is made once for both, ``dynamics.StartRates.take``). A prepared run's
    (``equations.compiled_plans``, ``dynamics.Prepared``) is made once for all its runs: each run's formulation
    object gets the plan made for the first (the scene, its packed data, the loaded module), with itself in it."""
    made = equations.formulation
    key = (formulation, id(equations.forces))
    kept = made.__dict__.get("_compiled_plan")
    if kept is None or kept[0] != key or kept[1] is not equations.forces:
        shared = equations.compiled_plans
        shared_key = None if shared is None else _plan_key(made, formulation)
        found = None if shared is None else shared.get(shared_key)
        if found is not None:  # the prepared run's: the same system, M and forces, this run's formulation object
            job = object.__new__(type(found))  # a shallow copy: its loaded module (``load``) and parameters come along
            job.__dict__.update(found.__dict__)
            job.formulation_object = made
            loaded = found.__dict__.get("_loaded")
            if loaded is not None:  # this run loads nothing: as a call that finds the module imported already
                job.__dict__["_loaded"] = (*loaded[:2], True, 0.0)
        else:
            job = compiled.plan(made.system, made.masses, equations.forces, formulation, made)
            if shared is not None:
                shared[shared_key] = job
        made.__dict__["_compiled_plan"] = kept = (key, equations.forces, job)
    return kept[2]


def _plan_key(made, formulation: str) -> tuple:
    """What a prepared run's compiled plan depends on besides its system, M and forces: the formulation, and the
    rotation u0 of each joint of a joint-coordinates tree, which the tree's data holds (a spatial prismatic joint's
    sign follows its initial state: ``joint_coordinates.SpatialTree.joint_state``)."""
    return (formulation, *(joint.u0 for joint in getattr(made, "joints", None) or ()))


def on_disk(is_cached, target, engine: str) -> tuple[bool, str | None]:
    """(whether the machine code of ``target`` is on disk, by ``is_cached``; None), or (False, why numpy) where numba
    cannot be loaded (missing, or its metadata: a sandbox) and the run did not ask for the compiled engine."""
    try:
        return is_cached(target), None
    except ImportError as err:
        if engine == "compiled":
            raise
        return False, f"the compiled engine cannot load here ({err})"


def _compiling(job, cached: bool):
    """The job, after one line on stderr when its machine code is not on disk: a first compilation takes a while."""
    if not cached:
        scene = job.scene.scene if isinstance(job.scene, TreeScene) else job.scene
        dimension = "planar" if scene.dimension == 2 else "spatial"
        print(
            f"mbd: compiling the engine of {dimension} {job.formulation} runs, once per machine (10-60 s; "
            "mbd compile makes all of it) ...", file=sys.stderr, flush=True,
        )  # fmt: skip
    return job


def start_rates(equations, formulation: str, options: dict, z: np.ndarray) -> tuple[float, np.ndarray] | None:
    """(rho, q'') at the state z of ``equations`` by the scene's compiled module, or None where the compiled engine
    does not cover the formulation's scene: the start rates of a run asked to be compiled (``dynamics.StartRates``).
    rho: ``loops.spectral_radius`` (the 21 evaluations of ``integrators.spectral_radius`` in one compiled call);
    q'': a tree's body accelerations are written after y' (with q, q' and lambda: ``out`` that long), other scenes'
    are y'[n:2n] (``out`` of y' alone: no lambda written after it, which nothing here reads).
    Any compiled integrator would do (the right-hand side does not depend on it): DOP853 stands for them."""
    job = compiled_plan(equations, formulation)
    if compiled.unsupported(job.scene, formulation, "DOP853", options) is not None:
        return None
    from . import loops  # imports numba

    module, _, _ = compiled.load(job)
    P, D, n = start_parameters(job, equations.extra), job.scene.data(), job.scene.n
    z = np.ascontiguousarray(z, dtype=float)
    tree = isinstance(job.scene, TreeScene)
    out = np.empty(z.size + 3 * n + job.scene.m if tree else z.size)  # y' (a tree's q'' in the outputs after it)
    module.scene_rhs(0.0, z, P, D, out)
    rhs = loops.first_class(module.scene_rhs, loops.RHS_SIGNATURE)
    rho = loops.spectral_radius(rhs, 0.0, z, out[: z.size], power_start(z.size), P, D, 10)  # f(z): read, not written
    return float(rho), (out[z.size + 2 * n : z.size + 3 * n] if tree else out[n : 2 * n]).copy()


def start_parameters(job, extra: int) -> tuple:
    """P of the start rates (``start_rates``): the run's (``parameters``) with the energy states ``extra`` as the
    equations have them and no drivers' power (it feeds nothing back), made once per plan's scene and ``extra``
    (a run's start rates made it anew: 3 us)."""
    kept = job.scene.__dict__.setdefault("_start_parameters", {})
    key = (*job.numbers, extra)
    if key not in kept:
        P = compiled.parameters(job.scene, *job.numbers)
        dims = P[8].copy()
        dims[2], dims[5] = extra, 0
        kept[key] = (*P[:8], dims)
    return kept[key]


def run(job, z0: np.ndarray, times: np.ndarray, settings: Settings, on_pause=None):
    """The compiled run of a ``Plan``: (CompiledRun, IntegrationStats); a run that stopped early says why in
    ``stop``; ``on_pause(t, q, Psi, Psi_q)`` judges the configuration between steps (``run``). A
    projection run also counts its projections and restarts as the numpy run does: one projection per accepted
    step, a restart after each (``integrators.integrate``; the solve_ivp loop does not restart after its last step,
    rk4 never counts restarts)."""
    integrator, budget = settings.integrator, settings.max_evaluations
    out = compiled.run(job, z0, times, integrator, settings.rtol, settings.atol, settings.step, budget, on_pause)
    stats = IntegrationStats(integrator, rhs_evaluations=out.evaluations, steps=out.steps, rejected=out.rejected)
    if job.formulation == "projection":
        job.formulation_object.projections = out.steps
        if integrator != "rk4":
            stats.restarts = out.steps - (1 if integrator in ("DOP853", "RK45") else 0)
    return out, stats


def positions(job, z0: np.ndarray, times: np.ndarray, plan, settings: Settings) -> np.ndarray:
    """q at the output times of the compiled run of ``job`` from z0 by ``plan``'s integrator and tolerances (an
    adaptive one): the integration loop alone, and a tree's body coordinates from its joint states (the divergence
    check's companion run, ``dynamics.companion_centres``: the run's plan and loaded module, another tolerance).
    Raises as the run would where it stops early (``stop``); ``settings``: the run's step, budget."""
    from . import COMPILED_INTEGRATORS, INT64_MAX, load, loops, parameters, paused_embedded, tableau

    module, project, _ = load(job)
    scene, rhs = job.scene, loops.first_class(module.scene_rhs, loops.RHS_SIGNATURE)
    P, D = parameters(scene, *job.numbers), scene.data()
    dop, scipy_like = COMPILED_INTEGRATORS[plan.integrator]
    budget = INT64_MAX if settings.max_evaluations is None else int(settings.max_evaluations)
    numbers = (plan.rtol, plan.atol, float(settings.step or np.inf), budget, dop, scipy_like, tableau(dop), P, D)
    z0, times = np.ascontiguousarray(z0, dtype=float), np.ascontiguousarray(times, dtype=float)
    project = loops.first_class(project, loops.PROJECT_SIGNATURE)
    Y, evaluations, steps, rejected, status, t, h, _ = paused_embedded(loops, rhs, project, z0, times, numbers, None)
    if status != 0:
        stats = IntegrationStats(plan.integrator, rhs_evaluations=evaluations, steps=steps, rejected=rejected)
        said = settings.replace(integrator=plan.integrator)  # the run's settings may say 'auto'
        raise stop(SimpleNamespace(status=status, t=t, h=h), stats, said, float(times[-1] - times[0]))
    if isinstance(scene, TreeScene):  # the body coordinates of the joint states, written after y (``tree.py``: the
        return loops.outputs(rhs, times, Y, P, D, scene.n)[:, Y.shape[1] :]  # forward kinematics alone, no y')
    return Y[:, : scene.n]


def stop(out, stats: IntegrationStats, settings: Settings, span: float) -> AnalysisError | None:
    """Why the compiled run ``out`` stopped early, in the numpy engine's words (``integrators``), or None."""
    integrator = settings.integrator
    if out.status == 1:
        return AnalysisError(collapse_message(integrator, out.t, out.h, span, stats))
    if out.status == 2:
        return BudgetError(budget_message(integrator, settings.max_evaluations, out.t, out.h, stats))
    if out.status == 3:
        return AnalysisError(
            f"rk4: the state is no longer finite at t = {out.t:.6g} s with step {out.h:.3g} s: the step is beyond the "
            "scene's stability limit (or left the mechanism's reach); use a smaller --step or an adaptive integrator"
        )
    if out.status == 4:
        return AnalysisError(f"position projection did not converge at t = {out.t:.6g} s (residual {out.h:.3g})")
    return None


__all__ = [
    "COMPILE_SECONDS",
    "ENGINES",
    "LOAD_SECONDS",
    "choose",
    "compiled_start",
    "estimated_numpy_seconds",
    "positions",
    "run",
    "start_rates",
    "trial_rate",
    "trial_seconds",
]
