"""The compiled kinematic analysis: the steps of ``kinematics.kinematic_analysis`` run by a compiled loop.

``kinematic_analysis(..., engine="compiled")`` (``mbd run --engine compiled`` of a kinematic model) hands its
steps here after the assembly and the rank check at t = 0: ``describe`` reads the scene's constraint elements
(the kernels of ``kernels.py`` that ``scene.py`` names, as for the dynamic engine; no mass matrix, no forces),
``codegen.generate_kinematic`` writes the scene's ``evaluate`` (Psi, Psi_q, Psi_t, gamma), and
``kinematic_loop.steps`` runs Newton-Raphson, the LU factors with their tests and the velocity and acceleration
solves at every output time.

The compiled steps decide nothing unusual: at the first step where the numpy loop would do more than the
ordinary step (Newton-Raphson not converging, an exact zero pivot, the lock-up test, a sign change of det Psi_q, a dip
of the pivot ratio), they stop, and the numpy loop goes on from that step with the state, the pivot ratios and
the determinant sign so far: the same errors, the same search for a singular position, the same results.

Which engine (``choose``), as ``dispatch.choose`` for forward dynamics: ``numpy``; ``compiled`` whenever the
kernels cover the model (else numpy, and ``info['chosen']`` says why); ``cached`` when the machine code of the
scene's dimension is on disk; ``auto``:

    the compiled steps when the numpy steps are expected to take longer than LOAD_SECONDS and the machine code
    is on disk (``mbd compile``), or longer than COMPILE_SECONDS (a first compilation: the scene's ``evaluate``
    and, once per machine, the loop; one line on stderr says so); the numpy time is estimated as (output
    times) x NEWTON_PASSES x (one pass of Psi, Psi_q, LU and solve, timed at the assembled q).

No numba here: it is imported (by ``run``) only when the compiled steps run.
"""

from __future__ import annotations

import inspect
import sys
import time
from dataclasses import dataclass
from functools import cache

import numpy as np

from ..diagnostics import AnalysisError
from .dispatch import ENGINES, LOAD_SECONDS, on_disk
from .scene import (
    PLANAR_CONSTRAINTS,
    SPATIAL_CONSTRAINTS,
    Functions,
    Scene,
    Unsupported,
    planar_constraints,
    scene_arrays,
    spatial_constraints,
)
from .scene import packed as pack

COMPILE_SECONDS = 8.0
"""What a first compilation may cost: the step loop and the kernels it calls, once per machine, about 9 s (numba
0.68, one core of the course machine), then each dimension's ``evaluate`` (every constraint kernel of it) once. The
rule counts the first as ``dispatch.COMPILE_SECONDS`` does: it leaves to numpy every run it cannot surely repay."""
NEWTON_PASSES = 3
"""Passes of (Psi, Psi_q, LU, solve) per step in the estimate of the numpy time: about two Newton iterations and
the final factorization (with Psi_t, gamma and the two solves, about what a step of the slider-crank costs)."""
REASONS = (
    "",
    "Newton-Raphson did not converge",
    "an exact zero pivot in a Newton-Raphson solve",
    "the lock-up test fired (pivots of Psi_q spread beyond LOCKUP_CONDITION)",
    "det(Psi_q) changed sign",
    "the pivot ratio dipped",
)
"""Why the compiled steps stopped, by the reason code of ``kinematic_loop.steps``."""


@dataclass
class KinematicRun:
    """What the compiled steps give back: rows 0..stop-1 of the results, and per step the Newton iterations, the
    residuals, the pivot ratios and the det signs; ``stop`` the first step the numpy loop takes, ``reason`` why."""

    Q: np.ndarray
    QD: np.ndarray
    QDD: np.ndarray
    ratios: np.ndarray
    signs: np.ndarray
    iterations: np.ndarray
    residuals: np.ndarray
    stop: int
    reason: int
    load_seconds: float
    cached: bool


def describe(system) -> Scene:
    """The scene of the constraint elements alone (``scene.describe`` without masses and forces)."""
    model = system.model
    scene = Scene(model.dimension, system.n_coordinates, system.n_constraints)
    scene.drivers = bool(model.motors)
    functions = Functions()
    try:
        if model.dimension == 2:
            constraints = scene_arrays(planar_constraints(system, functions), PLANAR_CONSTRAINTS)
        else:
            constraints = scene_arrays(spatial_constraints(system, functions), SPATIAL_CONSTRAINTS)
    except Unsupported as why:
        scene.unsupported = str(why)
        return scene
    scene.constraint_kernels = constraints
    scene.function_kinds, scene.function_params = functions.arrays()
    return scene


def packed(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """D = (ints, floats, offsets) of the kinematic loop: the constraint kernels' rows in the order of
    ``codegen.KINEMATIC_SLOTS`` (``scene.packed``)."""
    from .codegen import KINEMATIC_SLOTS

    return pack(scene.constraint_kernels, KINEMATIC_SLOTS)


@cache
def _newton_defaults() -> tuple[float, int]:
    """tol and max_iterations of ``kinematics.newton_raphson``: the compiled steps stop as it does."""
    from ..kinematics import newton_raphson

    parameters = inspect.signature(newton_raphson).parameters
    return float(parameters["tol"].default), int(parameters["max_iterations"].default)


def estimated_numpy_seconds(system, q: np.ndarray, points: int, repeats: int = 5) -> float:
    """The numpy steps' expected run time (module docstring)."""
    from ..linalg import lu_factor, lu_solve

    start = time.perf_counter()
    for k in range(repeats):
        x = q * (1.0 + 1e-12 * (k + 1))  # a new q every time: the System keeps the configuration of the last one
        lu_solve(lu_factor(system.jacobian(x, 0.0)), system.constraints(x, 0.0))
    return points * NEWTON_PASSES * (time.perf_counter() - start) / repeats


def choose(engine: str, system, q: np.ndarray, points: int) -> tuple[Scene | None, dict]:
    """(Scene or None, {'engine', 'engine_why'}): the scene when the compiled steps run this analysis."""
    if engine not in ENGINES:
        raise AnalysisError(f"unknown engine {engine!r} (one of: {', '.join(ENGINES)})")
    if engine == "numpy":
        return None, {"engine": "numpy", "engine_why": "numpy engine asked for"}
    expected = estimated_numpy_seconds(system, q, points) if engine == "auto" else None
    if expected is not None and expected <= LOAD_SECONDS:  # shorter than loading the compiled code: numpy
        why = f"numpy steps estimated at {expected:.3g} s, less than loading the compiled code ({LOAD_SECONDS:g} s)"
        return None, {"engine": "numpy", "engine_why": why}
    scene = describe(system)
    if scene.unsupported is not None:
        return None, {"engine": "numpy", "engine_why": f"not compiled: {scene.unsupported}"}
    from .codegen import is_kinematic_cached

    cached, cannot = on_disk(is_kinematic_cached, scene, engine)
    if cannot:
        return None, {"engine": "numpy", "engine_why": cannot}
    if engine == "compiled":
        _announce(scene, cached)
        return scene, {"engine": "compiled", "engine_why": "compiled engine asked for"}
    if engine == "cached":
        if cached:
            return scene, {"engine": "compiled", "engine_why": "compiled code for this scene's dimension is cached"}
        return None, {"engine": "numpy", "engine_why": "no compiled code for this scene's dimension is cached"}
    if cached:
        why = f"numpy steps estimated at {expected:.3g} s, more than loading the compiled code ({LOAD_SECONDS:g} s)"
        return scene, {"engine": "compiled", "engine_why": why}
    if expected > COMPILE_SECONDS:
        _announce(scene, cached)
        why = f"numpy steps estimated at {expected:.3g} s, more than a first compilation ({COMPILE_SECONDS:g} s)"
        return scene, {"engine": "compiled", "engine_why": why}
    why = (
        f"numpy steps estimated at {expected:.3g} s, less than a first compilation ({COMPILE_SECONDS:g} s): "
        "mbd compile makes the compiled engine once per machine"
    )
    return None, {"engine": "numpy", "engine_why": why}


def _announce(scene: Scene, cached: bool) -> None:
    """One line on stderr when the machine code is not on disk: a first compilation takes a while."""
    if not cached:
        dimension = "planar" if scene.dimension == 2 else "spatial"
        print(
            f"mbd: compiling the engine of {dimension} kinematic runs, once per machine (10-60 s; mbd compile makes "
            "all of it) ...", file=sys.stderr, flush=True,
        )  # fmt: skip


def run(scene: Scene, q: np.ndarray, times: np.ndarray, system=None) -> KinematicRun:
    """The compiled steps from the assembled q at times[0] (``kinematic_loop.steps``).

    Where the pivot ratios dip with det Psi_q of one sign, the numpy loop searches the interval for a singular
    position (``kinematics.locate_singular_position``); so does this function, with ``system``, and where the search
    finds none the compiled steps go on past the dip (without ``system``, or where it finds one, they stop there).
    """
    from ..kinematics import LOCKUP_CONDITION, PIVOT_DIP, dip_start, locate_singular_position
    from . import kinematic_loop  # imports numba
    from .codegen import load_kinematic
    from .loops import first_class

    start = time.perf_counter()
    module, cached = load_kinematic(scene)
    evaluate = first_class(module.evaluate, kinematic_loop.EVALUATE_SIGNATURE)
    tol, max_iterations = _newton_defaults()
    points, n = times.size, scene.n
    Q, QD, QDD = np.empty((points, n)), np.empty((points, n)), np.empty((points, n))
    ratios, signs = np.empty(points), np.empty(points)
    iterations, residuals = np.zeros(points, np.int64), np.zeros(points)
    q, times = np.ascontiguousarray(q, dtype=float), np.ascontiguousarray(times, dtype=float)
    F, D = (scene.function_kinds, scene.function_params), packed(scene)
    limits = (float(tol), int(max_iterations), float(LOCKUP_CONDITION), float(PIVOT_DIP))
    first, passed = 0, -1
    while True:
        stop, reason = kinematic_loop.steps(
            evaluate, q, times, F, D, limits, first, passed, (Q, QD, QDD), (ratios, signs, iterations, residuals)
        )
        if reason != kinematic_loop.DIP or system is None or (stop > 0 and signs[stop] != signs[stop - 1]):
            break
        dip = dip_start([float(r) for r in ratios[: stop + 1]], points)
        if locate_singular_position(system, times[dip], Q[dip], QD[dip], QDD[dip], times[stop]) is not None:
            break  # a singular position: the numpy loop stops there with its error
        first = passed = stop
    return KinematicRun(
        Q, QD, QDD, ratios, signs, iterations, residuals, stop, reason, time.perf_counter() - start, cached
    )


def steps(engine: str, system, q: np.ndarray, times: np.ndarray, Q, QD, QDD) -> tuple:
    """The steps the compiled engine takes of a kinematic analysis from the assembled q at t = 0.

    Fills rows 0..k-1 of Q, QD, QDD and returns (k, Newton iterations, max residual, pivot ratios, det sign
    of step k-1 or None, ``info['chosen']``): the numpy loop goes on from step k (k = 0: it runs them all).
    """
    scene, chosen = choose(engine, system, q, times.size)
    if scene is None:
        return 0, 0, 0.0, [], None, chosen
    out = run(scene, q, times, system)
    k = int(out.stop)
    Q[:k], QD[:k], QDD[:k] = out.Q[:k], out.QD[:k], out.QDD[:k]
    if k < times.size:
        chosen["engine_why"] += (
            f"; the compiled steps stopped at t = {times[k]:.6g} s (step {k} of {times.size - 1}): "
            f"{REASONS[out.reason]}, and the numpy engine went on from there"
        )
    sign = float(out.signs[k - 1]) if k > 0 else None
    residual = float(np.max(out.residuals[:k], initial=0.0))
    return k, int(out.iterations[:k].sum()), residual, [float(r) for r in out.ratios[:k]], sign, chosen


__all__ = [
    "COMPILE_SECONDS",
    "KinematicRun",
    "choose",
    "describe",
    "estimated_numpy_seconds",
    "packed",
    "run",
    "steps",
]
