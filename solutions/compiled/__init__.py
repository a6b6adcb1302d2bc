"""The compiled engine: a scene-specialized right-hand side and integrator loop, compiled by numba.

The numpy code of ``solutions/`` is the readable reference (what students write); this package is a second
engine generated from the same model, for speed. ``dynamics.forward_dynamics(..., engine="compiled")``
(``mbd run --engine compiled``) hands a run here when it can take it:

- formulation ``baumgarte`` (eq. 5.29, 5.30; any alpha, beta >= 0), planar and spatial;
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

numba is imported only here, when a run is compiled: importing ``solutions`` (and the student package
generated from it) never imports it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .scene import Scene, describe

COMPILED_FORMULATIONS = ("baumgarte",)
COMPILED_INTEGRATORS = {"DOP853": (True, True), "dop853": (True, False), "RK45": (False, True), "rk45": (False, False)}
"""Embedded pairs: (DOP853 or not, step by step as scipy's solve_ivp or as this package's own loop)."""
FIXED = ("rk4",)


@dataclass
class CompiledRun:
    """What the compiled loop gives back: states at the output times, q'' and lambda there, and counts."""

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
    """Psi, Psi_q, Psi_t at the output times (``history.constraint_arrays``), for the checks and the reactions."""
    jac: np.ndarray = None
    psit: np.ndarray = None


def unsupported(scene: Scene, formulation: str, integrator: str, options: dict) -> str | None:
    """Why the compiled engine cannot take this run (None: it can)."""
    if formulation not in COMPILED_FORMULATIONS:
        return f"the {formulation} formulation is not compiled (only {', '.join(COMPILED_FORMULATIONS)})"
    if integrator not in COMPILED_INTEGRATORS and integrator not in FIXED:
        return f"the {integrator} integrator is not compiled (only {', '.join([*COMPILED_INTEGRATORS, *FIXED])})"
    extra = set(options) - {"alpha", "beta"}
    if extra:
        return f"formulation options {', '.join(sorted(extra))} are not compiled"
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


def parameters(scene: Scene, alpha: float, beta: float) -> tuple:
    """P: the numbers the generated module takes besides the element data D (``codegen``)."""
    extra = 3 if scene.energies else 0
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
        np.array([float(alpha), float(beta)]),
        np.array([scene.n, scene.m, extra], dtype=np.int64),
    )


def run(
    scene: Scene,
    z0: np.ndarray,
    times: np.ndarray,
    integrator: str,
    rtol: float,
    atol: float,
    step: float | None,
    max_evaluations: int | None,
    alpha: float,
    beta: float,
) -> CompiledRun:
    """Integrate the scene from z0 over the output grid ``times`` with the compiled loop."""
    start = time.perf_counter()
    from . import history, loops  # imports numba
    from .codegen import load

    module, cached = load(scene)
    load_seconds = time.perf_counter() - start  # importing numba and the loops, loading (or compiling) the module
    P, D = parameters(scene, alpha, beta), scene.data()
    z0 = np.ascontiguousarray(z0, dtype=float)
    times = np.ascontiguousarray(times, dtype=float)
    if integrator in FIXED:
        Y, evaluations, steps, rejected, status, t, h = loops.rk4(module.scene_rhs, z0, times, float(step or 0.0), P, D)
    else:
        dop, scipy_like = COMPILED_INTEGRATORS[integrator]
        budget = np.iinfo(np.int64).max if max_evaluations is None else int(max_evaluations)
        max_step = float(step) if step else np.inf
        Y, evaluations, steps, rejected, status, t, h = loops.embedded(
            module.scene_rhs, z0, times, float(rtol), float(atol), max_step, budget, dop, scipy_like, tableau(dop), P, D
        )
    qdd, lam = loops.outputs(module.accelerations, times, Y, P, D)
    psi = jac = psit = None
    if status == 0:  # a run that stopped early raises (dispatch.run): no checks to make
        psi, jac, psit = history.constraint_arrays(module, scene, times, Y)
    return CompiledRun(
        Y, qdd, lam, int(evaluations), int(steps), int(rejected), int(status), float(t), float(h), load_seconds, cached,
        psi, jac, psit,
    )  # fmt: skip


__all__ = ["COMPILED_FORMULATIONS", "COMPILED_INTEGRATORS", "CompiledRun", "Scene", "describe", "run", "unsupported"]
