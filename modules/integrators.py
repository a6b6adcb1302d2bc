# Generated from solutions/integrators.py by `make modules` (every homework stubbed): do not edit by hand.
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

- "rk45" and "dop853", this package's own loop around the same embedded pairs and step-size control as
  solve_ivp's RK45 (Dormand-Prince 5(4)) and DOP853 (Dormand-Prince 8(5,3)) (Hairer, Norsett and Wanner,
  Solving ODEs I, sec. II.4-II.6 and II.10), with their dense output; the coefficients are scipy's
  (``tableaux.py``: a run on them does not import ``scipy.integrate``). It
  does per step only the stages, the error norm and the step-size update, so a small system whose
  right-hand side costs a few tens of microseconds does not pay solve_ivp's per-step bookkeeping (the
  method object, its step() and its dense-output object), which is of the same order.

Right-hand-side evaluations are counted here, by wrapping f (``Budget``), whatever the method does with them
(stages, finite-difference Jacobians of the implicit methods, restarts). Two guards keep a run from
going on for ever or quietly wrong:

- an **evaluation budget** (``max_evaluations``): past it the run stops with an AnalysisError that
  names the time reached, the step size and, if found, the stiffness;
- a **stiffness monitor** for the explicit methods: after 50, 100, 200, ... accepted steps it estimates
  the spectral radius rho of the Jacobian df/dy by power iteration on J^2 with finite differences
  (J^2 turns the imaginary pair +-i w of a stiff spring into the real -w^2), and when h rho is close
  to the method's stability limit (about 3.3 for RK45, 6 for DOP853) the step size is bounded by
  stability, not accuracy: the scene is stiff (Hairer and Wanner, Solving ODEs II, sec. IV.2). The
  finding is reported (``IntegrationStats.stiffness``), or raised at once with ``stiffness="error"``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .diagnostics import AnalysisError, setting_words
from .tableaux import TABLEAUX

RHS = Callable[[float, np.ndarray], np.ndarray]
AfterStep = Callable[[float, np.ndarray], "np.ndarray | None"]
Record = Callable[[int, float, np.ndarray], None]

SOLVE_IVP_METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")
"""The methods of ``solve_ivp``: the names of their classes in ``scipy.integrate`` (``scipy_method``)."""
FIXED_STEP_METHODS = ("rk4",)
EMBEDDED_METHODS = {"rk45": "RK45", "dop853": "DOP853"}
"""This package's own loop around solve_ivp's pairs: their tableaux (``tableaux.py``) are scipy's coefficients."""
INTEGRATORS = (*SOLVE_IVP_METHODS, *FIXED_STEP_METHODS, *EMBEDDED_METHODS)
EXPLICIT_METHODS = ("RK45", "RK23", "DOP853", "rk45", "dop853")
STABILITY_LIMIT = {"RK23": 2.5, "RK45": 3.3, "rk45": 3.3, "DOP853": 6.0, "dop853": 6.0}
"""About where the stability region of each explicit method meets the negative real axis (h lambda)."""
DEFAULT_MAX_EVALUATIONS = 2_000_000


def scipy_method(name: str) -> type:
    """The class of a ``solve_ivp`` method, e.g. ``scipy_method("DOP853")`` is ``scipy.integrate.DOP853``.

    ``scipy.integrate`` is imported here, by the runs that use it, not with this module: importing it
    (it imports scipy.optimize and scipy.special) takes longer than a short run of ``mbd``.
    """
    import scipy.integrate

    return getattr(scipy.integrate, name)


@dataclass
class IntegrationStats:
    """How an integration went: right-hand-side evaluations, steps taken (and rejected), restarts after
    corrections, and what the stiffness monitor found (None: not stiff, or not monitored)."""

    method: str
    rhs_evaluations: int = 0
    steps: int = 0
    restarts: int = 0
    rejected: int = 0
    stiffness: dict | None = None
    step_size: float = float("nan")
    """The last accepted step (this package's loops)."""


class StiffnessError(AnalysisError):
    """An explicit method whose step size is bounded by stability: the scene is stiff."""


class BudgetError(AnalysisError):
    """The right-hand-side evaluation budget of a run is spent."""


def power_start(size: int) -> np.ndarray:
    """The unit start vector of ``spectral_radius``'s power iteration: the same draw every time (a run's rho, and
    so its default tolerance, do not change from one call to the next). A copy of the one drawn per size (making
    the generator costs more than a small scene's 21 compiled evaluations of the right-hand side)."""
    return _power_start(size).copy()


@functools.lru_cache(maxsize=64)
def _power_start(size: int) -> np.ndarray:
    v = np.random.default_rng(7).standard_normal(size)
    return v / np.linalg.norm(v)


def spectral_radius(f: RHS, t: float, y: np.ndarray, fy: np.ndarray, iterations: int = 10) -> float:
    """Estimate rho(df/dy) at (t, y) by power iteration on J^2, J v = (f(t, y + eps v) - f(t, y)) / eps.

    J^2 makes an undamped fast oscillation (eigenvalues +-i w) a real dominant eigenvalue -w^2, which
    power iteration finds; rho = sqrt(|J^2 v|) for the unit vector v once it has turned into the
    dominant direction.
    """
    v = power_start(y.size)
    eps = np.sqrt(np.finfo(float).eps) * (1.0 + np.linalg.norm(y))

    def product(x: np.ndarray) -> np.ndarray:  # J x for a unit x
        return (f(t, y + eps * x) - fy) / eps

    rho2 = 0.0
    for _ in range(iterations):
        w = product(v)
        size = float(np.linalg.norm(w))
        if not np.isfinite(size) or size == 0.0:
            return 0.0 if size == 0.0 else float("inf")
        w = product(w / size) * size  # J^2 v
        rho2 = float(np.linalg.norm(w))
        if not np.isfinite(rho2) or rho2 == 0.0:
            return 0.0 if rho2 == 0.0 else float("inf")
        v = w / rho2
    return float(np.sqrt(rho2))


class StiffnessMonitor:
    """Checks an explicit method's step h against its stability limit after 50, 100, 200, ... steps."""

    def __init__(self, f: RHS, method: str, stats: IntegrationStats, raise_error: bool):
        self.f, self.method, self.stats, self.raise_error = f, method, stats, raise_error
        self.limit = STABILITY_LIMIT.get(method)
        self.next_check = 50

    def check(self, t: float, y: np.ndarray, fy: np.ndarray, h: float) -> None:
        if self.limit is None or self.stats.steps < self.next_check or self.stats.stiffness is not None:
            return
        self.next_check *= 2
        rho = spectral_radius(self.f, t, y, fy)
        if h * rho < 0.5 * self.limit:
            return
        self.stats.stiffness = {"t": float(t), "step": float(h), "rho": float(rho), "h_rho": float(h * rho)}
        if self.raise_error:
            raise StiffnessError(stiffness_message(self.method, self.stats.stiffness))


def stiffness_message(method: str, found: dict) -> str:
    """What the stiffness monitor found, in words."""
    return (
        f"integrator {method} at t = {found['t']:.6g} s: the step size is bounded by stability, not accuracy "
        f"(h = {found['step']:.3g} s, h |lambda| = {found['h_rho']:.3g} against the method's limit of about "
        f"{STABILITY_LIMIT[method]}; fastest mode |lambda| = {found['rho']:.3g} 1/s, a period of "
        f"{2 * math.pi / found['rho']:.3g} s): the scene is stiff; use an implicit method (Radau, BDF, hht)"
    )


class Budget:
    """f(t, y), its evaluations counted, stopping the run once ``limit`` of them are spent (one object between the
    integrator and f: a call through it costs a few hundred nanoseconds, a small scene's f a few tens of us)."""

    def __init__(self, f: RHS, limit: int | None, method: str, stats: IntegrationStats):
        self.f, self.limit, self.method, self.stats = f, limit, method, stats
        self.evaluations = 0
        self._stop = math.inf if limit is None else limit
        self.t, self.h = 0.0, float("nan")

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        if self.evaluations >= self._stop:
            raise BudgetError(budget_message(self.method, self.limit, self.t, self.h, self.stats))
        self.evaluations += 1
        return self.f(t, y)


def budget_message(method: str, limit: int, t: float, h: float, stats: IntegrationStats) -> str:
    """What a run that spent its evaluation budget says (either engine's)."""
    message = (
        f"integrator {method} spent its budget of {limit} right-hand-side evaluations by "
        f"t = {t:.6g} s (last step {h:.3g} s, {stats.steps} steps)"
    )
    if stats.stiffness is not None:
        return message + ". " + stiffness_message(method, stats.stiffness)
    return message + (
        ": the motion is too fast for the tolerance, or the scene is stiff; raise the budget, e.g. "
        + setting_words("max_evaluations", 4 * limit)
    )


def rk4_step(f: RHS, t: float, y: np.ndarray, h: float) -> np.ndarray:
    """One step of the classical Runge-Kutta method (eq. 6.12):

    k1 = f(t, y),              k2 = f(t + h/2, y + h/2 k1),
    k3 = f(t + h/2, y + h/2 k2), k4 = f(t + h, y + h k3),
    y_new = y + h/6 (k1 + 2 k2 + 2 k3 + k4)
    """
    raise NotImplementedError('rk4_step: One step of the classical Runge-Kutta method, see eq. 6.12')


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
    max_evaluations: int | None = DEFAULT_MAX_EVALUATIONS,
    stiffness: str = "report",
    max_steps: int | None = None,
    positions: int | None = None,
) -> IntegrationStats:
    """Advance y' = f(t, y) from y(t_out[0]) = y0, calling ``record(k, t_out[k], y)`` at every output time.

    ``after_step(t, y)`` (optional) is called after every step; when it returns a state, the
    integration continues from that state instead. ``max_evaluations`` bounds the right-hand-side
    evaluations (None: no bound); ``stiffness`` is "report" (in the stats), "error" (raise
    StiffnessError when found) or "off" (no monitor). ``max_steps`` (rk45 and dop853 only) ends the loop after
    that many accepted steps, the output times not reached left unrecorded: a trial of the method
    (``compiled.dispatch.trial_seconds``). ``positions`` = n (dop853 only) says that y = (q, q', ...) with
    f(t, y)[:n] = q' = y[n:2n] and that ``record`` reads only q = y[:n]: the dense output then takes its last extra
    stage's q' from the stage's state instead of evaluating f there (``DenseOutput``); the rest of y it hands to
    ``record`` is NaN.
    """
    stats = IntegrationStats(method)
    budget = Budget(f, max_evaluations, method, stats)
    monitor = StiffnessMonitor(budget, method, stats, stiffness == "error") if stiffness != "off" else None
    loop = Loop(budget, t_out, record, method, rtol, atol, step, after_step, stats, monitor, max_steps, positions)
    try:
        if method in FIXED_STEP_METHODS:
            _integrate_rk4(loop, np.asarray(y0, dtype=float))
        elif method in SOLVE_IVP_METHODS:
            _integrate_adaptive(loop, np.asarray(y0, dtype=float))
        elif method in EMBEDDED_METHODS:
            _integrate_embedded(loop, np.asarray(y0, dtype=float))
        else:
            raise AnalysisError(f"unknown integrator {method!r} (one of: {', '.join(INTEGRATORS)})")
    finally:
        stats.rhs_evaluations = budget.evaluations
    return stats


@dataclass(frozen=True)
class Loop:
    """What each integration loop below is given (``integrate``'s arguments): the right-hand side f, counted
    within its evaluation budget; the output times and ``record(k, t, y)``; the method with its tolerances and
    largest step; ``after_step``; the stats it fills and the stiffness monitor (None: off)."""

    f: Budget
    t_out: np.ndarray
    record: Record
    method: str
    rtol: float
    atol: float
    step: float | None
    after_step: AfterStep | None
    stats: IntegrationStats
    monitor: StiffnessMonitor | None
    max_steps: int | None = None
    positions: int | None = None


def _integrate_rk4(loop: Loop, y: np.ndarray) -> None:
    """Fixed steps: each output interval is cut into the fewest equal steps no longer than ``step``."""
    f, t_out, record, step, after_step, stats = loop.f, loop.t_out, loop.record, loop.step, loop.after_step, loop.stats
    record(0, t_out[0], y)
    for k in range(1, t_out.size):
        t, span = t_out[k - 1], t_out[k] - t_out[k - 1]
        substeps = max(1, math.ceil(span / step - 1e-9)) if step else 1
        h = span / substeps
        for s in range(substeps):
            with np.errstate(over="ignore", invalid="ignore"):  # a blow-up is reported just below
                y = rk4_step(f, t + s * h, y, h)
            stats.steps += 1
            f.t, f.h = t + (s + 1) * h, h
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


def _integrate_adaptive(loop: Loop, y: np.ndarray) -> None:
    """The solve_ivp loop: step, interpolate the output times passed (dense output), maybe restart."""
    f, t_out, record, method, rtol, atol = loop.f, loop.t_out, loop.record, loop.method, loop.rtol, loop.atol
    step, after_step, stats, monitor = loop.step, loop.after_step, loop.stats, loop.monitor
    solver_class = scipy_method(method)
    max_step = step if step else np.inf
    t_end = t_out[-1]
    span = t_end - t_out[0]
    solver = solver_class(f, t_out[0], y, t_end, rtol=rtol, atol=atol, max_step=max_step)
    record(0, t_out[0], y)
    k = 1
    while k < t_out.size:
        message = solver.step()
        if solver.status == "failed":
            raise AnalysisError(f"integrator {method} failed at t = {solver.t:.6g} s: {message}")
        stats.steps += 1
        t, y = solver.t, solver.y
        f.t, f.h = t, solver.step_size
        if solver.step_size is not None and solver.step_size < MIN_STEP * span and t_end - t > MIN_STEP * span:
            raise AnalysisError(collapse_message(method, t, solver.step_size, span, stats))
        if monitor is not None and method in EXPLICIT_METHODS:
            monitor.check(t, y, solver.f, solver.step_size)
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
        if corrected is not None and solver.status == "running" and method == "Radau":
            # go on from the corrected state with Radau's Jacobian and factors (a new solver would form the
            # Jacobian anew by finite differences, n evaluations a step); the stage values start from zero
            solver.y, solver.f, solver.sol = y, solver.fun(t, y), None
            stats.restarts += 1
        elif corrected is not None and solver.status == "running":
            first_step = min(getattr(solver, "h_abs", solver.step_size), t_end - t)
            solver = solver_class(f, t, y, t_end, rtol=rtol, atol=atol, max_step=max_step, first_step=first_step)
            stats.restarts += 1


# -- the lean embedded Runge-Kutta loop -------------------------------------------------------------------
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
"""Step-size controller of Hairer, Norsett and Wanner (sec. II.4), as in solve_ivp."""
MIN_STEP = 1e-12
"""A step below this fraction of the time span means the integrator cannot follow the motion any further
(a singular configuration, a right-hand side that is not defined beyond): the run stops there."""


def collapse_message(method: str, t: float, h: float, span: float, stats: IntegrationStats) -> str:
    message = (
        f"integrator {method} at t = {t:.6g} s: the step size fell to {h:.3g} s, below {MIN_STEP:g} of the time "
        f"span ({stats.steps} steps, {stats.rejected} rejected): the motion cannot be followed past here (a "
        "singular configuration, or a state the formulation cannot take)"
    )
    if stats.stiffness is not None:
        message += "; " + stiffness_message(method, stats.stiffness)
    return message


def error_norm(scheme, K: np.ndarray, h: float, scale: np.ndarray) -> float:
    """The scaled RMS norm of the local error estimate: h E^T K for Dormand-Prince 5(4); DOP853's
    combination of its 5th- and 3rd-order estimates (Hairer, Norsett and Wanner, sec. II.10)."""
    if scheme.name == "DOP853":
        err5 = (scheme.E5 @ K) / scale
        err3 = (scheme.E3 @ K) / scale
        e5, e3 = float(err5 @ err5), float(err3 @ err3)
        if e5 == 0.0 and e3 == 0.0:
            return 0.0
        return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * scale.size)
    err = h * (scheme.E @ K) / scale
    return math.sqrt(float(err @ err) / scale.size)


def initial_step(f, t, y, fy, order: int, rtol: float, atol: float, t_end: float) -> float:
    """Hairer's starting step (sec. II.4): from |y|, |f| and a second-derivative estimate, one extra evaluation."""
    scale = atol + np.abs(y) * rtol
    d0, d1 = np.linalg.norm(y / scale) / math.sqrt(y.size), np.linalg.norm(fy / scale) / math.sqrt(y.size)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, t_end - t)
    d2 = np.linalg.norm((f(t + h0, y + h0 * fy) - fy) / scale) / math.sqrt(y.size) / h0
    h1 = max(1e-6, h0 * 1e-3) if max(d1, d2) <= 1e-15 else (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100.0 * h0, h1, t_end - t)


class DenseOutput:
    """The continuous extension of one accepted step from t to t + h (rk45: quartic in x = (s - t) / h,
    Q = K^T P; dop853: the 7th-order interpolant of three extra stages), evaluated at output times.

    ``positions`` = n (``integrate``): only q = y[:n] is asked for, and f's q rows are the state's q' = y[n:2n]; the
    q rows of the interpolant take from each stage only its q rows of f, and those of the last extra stage, which
    no other stage uses, are its state's q' (the numbers f would return there): one evaluation of f less."""

    def __init__(self, scheme, f, t, h, y, y_new, fy_new, K, positions: int | None = None):
        self.t, self.h, self.y = t, h, y
        if scheme.name == "DOP853":
            S = scheme.n_stages + 1
            extended = np.empty((S + len(scheme.C_EXTRA), y.size))
            extended[:S] = K
            last = len(extended) - 1
            for s, (a, c) in enumerate(zip(scheme.A_EXTRA, scheme.C_EXTRA, strict=True), start=S):
                stage = y + h * (a[:s] @ extended[:s])
                if s == last and positions is not None:
                    extended[s] = np.nan  # not computed: the interpolant's rows other than q
                    extended[s, :positions] = stage[positions : 2 * positions]
                else:
                    extended[s] = f(t + c * h, stage)
            delta = y_new - y
            F = np.empty((3 + len(scheme.D), y.size))  # the interpolant's degree: 7
            F[0], F[1], F[2] = delta, h * K[0] - delta, 2.0 * delta - h * (fy_new + K[0])
            F[3:] = h * (scheme.D @ extended)
            self.F, self.Q = F, None
        else:
            self.F, self.Q = None, K.T @ scheme.P

    def __call__(self, s: float) -> np.ndarray:
        x = (s - self.t) / self.h
        if self.Q is not None:
            return self.y + self.h * (self.Q @ np.cumprod(np.full(self.Q.shape[1], x)))
        out = np.zeros_like(self.y)
        for k, row in enumerate(self.F[::-1]):
            out += row
            out *= x if k % 2 == 0 else 1.0 - x
        return out + self.y


def _integrate_embedded(loop: Loop, y: np.ndarray) -> None:
    """One loop: stages, error norm, accept or shrink, dense output for the output times passed."""
    f, t_out, record, method, rtol, atol = loop.f, loop.t_out, loop.record, loop.method, loop.rtol, loop.atol
    step, after_step, stats, monitor = loop.step, loop.after_step, loop.stats, loop.monitor
    scheme = TABLEAUX[EMBEDDED_METHODS[method]]
    A, B, S = scheme.A, scheme.B, scheme.n_stages
    C = [float(c) for c in scheme.C]  # Python floats: t + c h is the same number, for less than with numpy ones
    exponent = -1.0 / (scheme.error_estimator_order + 1)
    rows = [A[s, :s] for s in range(S)]
    max_step = step if step else np.inf
    t, t_end = float(t_out[0]), float(t_out[-1])
    span = t_end - t
    fy = f(t, y)
    h = min(initial_step(f, t, y, fy, scheme.error_estimator_order, rtol, atol, t_end), max_step)
    K = np.empty((S + 1, y.size))
    record(0, t, y)
    k = 1
    while k < t_out.size:
        h = min(h, max_step, t_end - t)
        if h < MIN_STEP * span and t_end - t > MIN_STEP * span:
            raise AnalysisError(collapse_message(method, t, h, span, stats))
        K[0] = fy
        for s in range(1, S):
            K[s] = f(t + C[s] * h, y + h * (rows[s] @ K[:s]))
        y_new = y + h * (B @ K[:S])
        fy_new = f(t + h, y_new)
        K[S] = fy_new
        err = error_norm(scheme, K, h, atol + rtol * np.maximum(np.abs(y), np.abs(y_new)))
        if not err < 1.0:  # also when err is NaN (a trial state the formulation rejects): shrink
            h *= max(MIN_FACTOR, SAFETY * err**exponent) if np.isfinite(err) else MIN_FACTOR
            stats.rejected += 1
            continue
        stats.steps, stats.step_size = stats.steps + 1, h
        t_new = t_end if t_end - (t + h) < 1e-12 * max(1.0, abs(t_end)) else t + h
        if t_out[k] < t_new:
            dense = DenseOutput(scheme, f, t, h, y, y_new, fy_new, K, loop.positions)
            while k < t_out.size and t_out[k] < t_new:
                record(k, t_out[k], dense(t_out[k]))
                k += 1
        t, y, fy = t_new, y_new, fy_new
        f.t, f.h = t, h
        if monitor is not None:
            monitor.check(t, y, fy, h)
        corrected = after_step(t, y) if after_step is not None else None
        if corrected is not None:
            y, fy = corrected, f(t, corrected)
            stats.restarts += 1
        if k < t_out.size and t_out[k] == t:
            record(k, t, y)
            k += 1
        if stats.steps == loop.max_steps:
            return
        h *= MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err**exponent)


__all__ = [
    "DEFAULT_MAX_EVALUATIONS",
    "EMBEDDED_METHODS",
    "EXPLICIT_METHODS",
    "FIXED_STEP_METHODS",
    "INTEGRATORS",
    "SOLVE_IVP_METHODS",
    "STABILITY_LIMIT",
    "BudgetError",
    "IntegrationStats",
    "StiffnessError",
    "integrate",
    "rk4_step",
    "scipy_method",
    "spectral_radius",
    "stiffness_message",
]
