"""ODE integrators for y' = f(t, y) behind one interface: scipy's ``solve_ivp`` methods and classical RK4.

``integrate`` advances the state from t_out[0] to t_out[-1] and hands the state at every output time
to a callback. Two families:

- the methods of ``scipy.integrate.solve_ivp`` ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA"),
  adaptive, with the error per step held below atol + rtol |y|; driven here step by step (as
  ``solve_ivp`` itself does) so that a formulation may correct the state after a step
  (``after_step``), in which case the method restarts from the corrected state with its last step
  size. ``step`` is then the largest step allowed.
- "rk4", the classical fourth-order Runge-Kutta method with a fixed step h (``step``; default: the
  output spacing), which students write in homework 2 (eq. 6.12).

Right-hand-side evaluations are counted here, by wrapping f, whatever the method does with them
(stages, finite-difference Jacobians of the implicit methods, restarts).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.integrate

from .diagnostics import AnalysisError

RHS = Callable[[float, np.ndarray], np.ndarray]
AfterStep = Callable[[float, np.ndarray], "np.ndarray | None"]
Record = Callable[[int, float, np.ndarray], None]

SOLVE_IVP_METHODS = {
    "RK45": scipy.integrate.RK45,
    "RK23": scipy.integrate.RK23,
    "DOP853": scipy.integrate.DOP853,
    "Radau": scipy.integrate.Radau,
    "BDF": scipy.integrate.BDF,
    "LSODA": scipy.integrate.LSODA,
}
FIXED_STEP_METHODS = ("rk4",)
INTEGRATORS = (*SOLVE_IVP_METHODS, *FIXED_STEP_METHODS)


@dataclass
class Counter:
    """f(t, y), counting its evaluations."""

    f: RHS
    evaluations: int = 0

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        self.evaluations += 1
        return self.f(t, y)


@dataclass
class IntegrationStats:
    """How an integration went: right-hand-side evaluations, steps taken, restarts after corrections."""

    method: str
    rhs_evaluations: int = 0
    steps: int = 0
    restarts: int = 0


def rk4_step(f: RHS, t: float, y: np.ndarray, h: float) -> np.ndarray:
    """One step of the classical Runge-Kutta method (eq. 6.12):

    k1 = f(t, y),              k2 = f(t + h/2, y + h/2 k1),
    k3 = f(t + h/2, y + h/2 k2), k4 = f(t + h, y + h k3),
    y_new = y + h/6 (k1 + 2 k2 + 2 k3 + k4)
    """
    ### BEGIN SOLUTION hw2
    k1 = f(t, y)
    k2 = f(t + 0.5 * h, y + 0.5 * h * k1)
    k3 = f(t + 0.5 * h, y + 0.5 * h * k2)
    k4 = f(t + h, y + h * k3)
    return y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    ### END SOLUTION


def integrate(
    f: RHS,
    y0: np.ndarray,
    t_out: np.ndarray,
    record: Record,
    method: str = "RK45",
    rtol: float = 1e-8,
    atol: float = 1e-10,
    step: float | None = None,
    after_step: AfterStep | None = None,
) -> IntegrationStats:
    """Advance y' = f(t, y) from y(t_out[0]) = y0, calling ``record(k, t_out[k], y)`` at every output time.

    ``after_step(t, y)`` (optional) is called after every step; when it returns a state, the
    integration continues from that state instead.
    """
    counted = Counter(f)
    stats = IntegrationStats(method)
    if method in FIXED_STEP_METHODS:
        _integrate_rk4(counted, np.asarray(y0, dtype=float), t_out, record, step, after_step, stats)
    elif method in SOLVE_IVP_METHODS:
        _integrate_adaptive(
            counted, np.asarray(y0, dtype=float), t_out, record, method, rtol, atol, step, after_step, stats
        )
    else:
        raise AnalysisError(f"unknown integrator {method!r} (one of: {', '.join(INTEGRATORS)})")
    stats.rhs_evaluations = counted.evaluations
    return stats


def _integrate_rk4(f, y, t_out, record, step, after_step, stats) -> None:
    """Fixed steps: each output interval is cut into the fewest equal steps no longer than ``step``."""
    record(0, t_out[0], y)
    for k in range(1, t_out.size):
        t, span = t_out[k - 1], t_out[k] - t_out[k - 1]
        substeps = max(1, math.ceil(span / step - 1e-9)) if step else 1
        h = span / substeps
        for s in range(substeps):
            with np.errstate(over="ignore", invalid="ignore"):  # a blow-up is reported just below
                y = rk4_step(f, t + s * h, y, h)
            stats.steps += 1
            if not np.all(np.isfinite(y)):
                raise AnalysisError(
                    f"rk4: the state is no longer finite at t = {t + (s + 1) * h:.6g} s with step {h:.3g} s: the "
                    "step is beyond the scene's stability limit (or left the mechanism's reach); use a smaller "
                    "--step or an adaptive integrator"
                )
            if after_step is not None:
                corrected = after_step(t + (s + 1) * h, y)
                y = y if corrected is None else corrected
        record(k, t_out[k], y)


def _integrate_adaptive(f, y, t_out, record, method, rtol, atol, step, after_step, stats) -> None:
    """The solve_ivp loop: step, interpolate the output times passed (dense output), maybe restart."""
    solver_class = SOLVE_IVP_METHODS[method]
    max_step = step if step else np.inf
    t_end = t_out[-1]
    solver = solver_class(f, t_out[0], y, t_end, rtol=rtol, atol=atol, max_step=max_step)
    record(0, t_out[0], y)
    k = 1
    while k < t_out.size:
        message = solver.step()
        if solver.status == "failed":
            raise AnalysisError(f"integrator {method} failed at t = {solver.t:.6g} s: {message}")
        stats.steps += 1
        t, y = solver.t, solver.y
        if k < t_out.size and t_out[k] < t:
            interpolant = solver.dense_output()
            while k < t_out.size and t_out[k] < t:
                record(k, t_out[k], interpolant(t_out[k]))
                k += 1
        corrected = after_step(t, y) if after_step is not None else None
        if corrected is not None:
            y = corrected
        if k < t_out.size and t_out[k] == t:
            record(k, t, y)
            k += 1
        if corrected is not None and solver.status == "running":
            first_step = min(getattr(solver, "h_abs", solver.step_size), t_end - t)
            solver = solver_class(f, t, y, t_end, rtol=rtol, atol=atol, max_step=max_step, first_step=first_step)
            stats.restarts += 1


__all__ = ["FIXED_STEP_METHODS", "INTEGRATORS", "SOLVE_IVP_METHODS", "IntegrationStats", "integrate", "rk4_step"]
