"""Implicit integration of the index-3 equations of motion: the generalized-alpha method.

Commercial multibody codes (Adams, Chrono, Simpack, Abaqus) integrate the equations of motion in their
original index-3 form, positions on the constraints and no Baumgarte terms, with an implicit
Newmark-type method: stiff springs and fast modes do not limit the step, and numerical damping
removes the high frequencies a coarse step cannot resolve. At every step t_n -> t_n+1 = t_n + h the
unknowns q'', lambda at t_n+1 solve (course notes, sec. 6.5, eq. 6.50-6.53; Arnold and Bruels 2007)

    M q''_n+1 + Psi_q(q_n+1)^T lambda_n+1 = Q(q_n+1, q'_n+1, t_n+1)      equations of motion
    Psi(q_n+1, t_n+1) = 0                                                 constraints (index 3)
    q_n+1  = q_n + h q'_n + h^2 (1/2 - beta) a_n + h^2 beta a_n+1          Newmark formulas
    q'_n+1 = q'_n + h (1 - gamma) a_n + h gamma a_n+1
    (1 - alpha_m) a_n+1 + alpha_m a_n = (1 - alpha_f) q''_n+1 + alpha_f q''_n

with an auxiliary "acceleration" a (a_0 = q''_0). The parameters follow from the spectral radius
rho_inf of the method at infinite step (Chung and Hulbert 1993):

    generalized-alpha   alpha_m = (2 rho_inf - 1) / (rho_inf + 1),  alpha_f = rho_inf / (rho_inf + 1)
    hht                 alpha_m = 0,  alpha_f = (1 - rho_inf) / (1 + rho_inf),  rho_inf in [1/2, 1]
                        (Hilber-Hughes-Taylor in the form of Arnold and Bruels)
    both                gamma = 1/2 - alpha_m + alpha_f,  beta = (gamma + 1/2)^2 / 4

Both are second-order accurate and unconditionally stable for linear problems; rho_inf = 1 keeps every
frequency (no damping), smaller values damp the frequencies that the step cannot resolve.

Newton iterations (eq. 6.56). q_n+1 and q'_n+1 depend linearly on q''_n+1, with
dq/dq'' = h^2 beta' and dq'/dq'' = h gamma', beta' = beta (1 - alpha_f) / (1 - alpha_m), gamma' likewise.
The residual, with the constraints scaled by 1/(h^2 beta') so the iteration matrix does not degrade for
small h (Bottasso, Bauchau and Cardona 2008), and the iteration matrix are

    r = [ M q'' + Psi_q^T lambda - Q ;  Psi / (h^2 beta') ]
    S = [ M + h^2 beta' K + h gamma' C    Psi_q^T ]      K = d(Psi_q^T lambda - Q)/dq  tangent stiffness
        [ Psi_q                           0       ]      C = -dQ/dq'                   tangent damping

and each iteration solves S [dq''; dlambda] = -r. K and C, formed by forward differences (2n evaluations
of Q and n of Psi_q), are kept from step to step (modified Newton) and recomputed only when the
iterations stall or diverge; S itself is refactored at every step with the step's h and Psi_q at the
predictor (q'' and lambda of the last step). The iterations stop when the position correction
h^2 beta' dq'' is below ``newton_tol`` in the weighted norm below.

Step control (eq. 6.58). With an output grid and no fixed ``step``, the step adapts to the local error
of the positions, estimated from the change of a over the step. a_n approximates q'' at the shifted
time t_n + (alpha_m - alpha_f) h, and the Taylor expansion of the q formula then leaves the local
error h^3 (beta - gamma/2 + 1/12) q''' (Zienkiewicz and Xie 1991 for Newmark, gamma = 1/2), so

    e = h^2 (beta - gamma/2 + 1/12) (a_n+1 - a_n),    err = sqrt(mean((e / (atol + rtol |q|))^2))

A step with err <= 1 is accepted; the next step is h min(2, max(0.2, 0.9 err^(-1/3))) (the method is
second order, the error is O(h^3)). A rejected step or a failed Newton iteration is retried with a
smaller h. Steps end on every output time. With ``step`` given the step is fixed (each output interval
is split into equal steps no longer than ``step``) and there is no error control.

Step control needs rho_inf < 1. At rho_inf = 1 (the trapezoidal rule) nothing damps the algebraic part of the
index-3 equations: an error of the constraint level shows as q'' and lambda alternating from step to step with
an amplitude of about (error) / h^2, which a change of step from h to h' multiplies by (h / h')^2. The error
estimate h^2 (a_n+1 - a_n) of such a mode does not fall with h, so step control shrinks the step, the mode grows,
and the run crawls to a stop (measured on the double pendulum: q'' from 9 to 2500 m/s^2 over 0.03 s, the step
from 6e-4 to 7e-7 s). Fixed steps keep the amplitude constant, and any rho_inf < 1 damps it (0.999 runs).

Guards (``GuardedSteps``, issue 29): the run's ``guard.Guard`` checks the drift at every output time and
Psi_q at every accepted step, as on the other formulations. The method passes singular positions (S is singular
only at one, and a step lands there with probability zero); each one passed is listed with the run, and the branch
the motion took there is judged from the steps on either side (a switch stops the run by name, a crossing it
cannot judge is a warning). The evaluation budget (``max_evaluations``) bounds Q's evaluations, as the ODE
integrators' right-hand sides.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from .assembly import System
from .diagnostics import NEAR_SINGULAR, AnalysisError
from .dynamics import constraint_residuals
from .energy import constraint_power, energy_history
from .formulations import augmented_accelerations
from .generalized_forces import ForceModel
from .guard import Guard
from .integrators import BudgetError, IntegrationStats, budget_message
from .linalg import independent_rows
from .mass_matrix import mass_at
from .reactions import REDUNDANT_NOTE, minimum_norm_multipliers
from .results import Index3Info, Result
from .settings import Settings

METHODS = ("generalized-alpha", "hht")
DEFAULT_RHO = 0.9
"""rho_inf = 0.9: little damping of the resolved motion, the unresolved high frequencies die out."""


@dataclass(frozen=True)
class AlphaParameters:
    """alpha_m, alpha_f, gamma, beta of the generalized-alpha family (eq. 6.54)."""

    alpha_m: float
    alpha_f: float
    gamma: float
    beta: float

    @property
    def beta_prime(self) -> float:
        """beta' = dq_n+1/dq''_n+1 / h^2 = beta (1 - alpha_f) / (1 - alpha_m)."""
        return self.beta * (1.0 - self.alpha_f) / (1.0 - self.alpha_m)

    @property
    def gamma_prime(self) -> float:
        """gamma' = dq'_n+1/dq''_n+1 / h = gamma (1 - alpha_f) / (1 - alpha_m)."""
        return self.gamma * (1.0 - self.alpha_f) / (1.0 - self.alpha_m)

    @property
    def error_constant(self) -> float:
        """C in the local position error C h^2 (a_n+1 - a_n) (eq. 6.58)."""
        return self.beta - self.gamma / 2.0 + 1.0 / 12.0


def alpha_parameters(method: str = "generalized-alpha", rho_inf: float = DEFAULT_RHO) -> AlphaParameters:
    """The parameters of ``method`` ('generalized-alpha' or 'hht') for spectral radius rho_inf (eq. 6.54)."""
    if method == "generalized-alpha":
        if not 0.0 <= rho_inf <= 1.0:
            raise AnalysisError(f"generalized-alpha: rho_inf = {rho_inf} must lie in [0, 1]")
        alpha_m = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
        alpha_f = rho_inf / (rho_inf + 1.0)
    elif method == "hht":
        if not 0.5 <= rho_inf <= 1.0:
            raise AnalysisError(f"hht: rho_inf = {rho_inf} must lie in [0.5, 1] (alpha in [0, 1/3])")
        alpha_m, alpha_f = 0.0, (1.0 - rho_inf) / (1.0 + rho_inf)
    else:
        raise AnalysisError(f"unknown implicit method {method!r} (one of: {', '.join(METHODS)})")
    gamma = 0.5 - alpha_m + alpha_f
    return AlphaParameters(alpha_m, alpha_f, gamma, 0.25 * (gamma + 0.5) ** 2)


def weighted_norm(x: np.ndarray, q: np.ndarray, rtol: float, atol: float) -> float:
    """sqrt(mean((x / (atol + rtol |q|))^2)): the error norm of step control and Newton iterations."""
    return float(np.sqrt(np.mean((x / (atol + rtol * np.abs(q))) ** 2)))


@dataclass
class Counters:
    """Work done by a run: residual (right-hand-side) evaluations, iteration matrices, steps."""

    rhs_evaluations: int = 0
    tangent_updates: int = 0
    factorizations: int = 0
    newton_iterations: int = 0
    accepted_steps: int = 0
    rejected_steps: int = 0
    newton_failures: int = 0


@dataclass
class Index3Stepper:
    """One step of the generalized-alpha method on M q'' + Psi_q^T lambda = Q, Psi = 0."""

    system: System
    M: np.ndarray
    forces: ForceModel
    parameters: AlphaParameters
    rtol: float
    atol: float
    newton_tol: float = 1e-3
    max_iterations: int = 8
    counters: Counters = field(default_factory=Counters)
    max_evaluations: int | None = None
    """The evaluation budget of Q (``settings.max_evaluations``, as the ODE integrators'), None for none."""
    method: str = "generalized-alpha"

    def __post_init__(self):
        self._tangent = None  # (K, C), kept while the Newton iterations converge fast
        self._lu = None  # factored iteration matrix and the h it was made for
        self._lu_h = 0.0
        self._at = (0.0, float("nan"))  # (t, h) of the step under way, for the budget's message

    # -- the pieces of the residual ------------------------------------------------------------
    def _generalized_forces(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        counters = self.counters
        if self.max_evaluations is not None and counters.rhs_evaluations >= self.max_evaluations:
            stats = IntegrationStats(self.method, counters.rhs_evaluations, counters.accepted_steps)
            raise BudgetError(budget_message(self.method, self.max_evaluations, *self._at, stats))
        counters.rhs_evaluations += 1
        return self.forces.generalized_forces(q, qd, t)

    def _constraint_term(self, q: np.ndarray, lam: np.ndarray, t: float) -> np.ndarray:
        """Psi_q(q)^T lambda."""
        return self.system.jacobian(q, t).T @ lam

    def tangent_matrices(self, q, qd, lam, t) -> tuple[np.ndarray, np.ndarray]:
        """K = d(Psi_q^T lambda - Q)/dq and C = -dQ/dq' by forward differences (eq. 6.56)."""
        n = q.size
        base_force = self._generalized_forces(q, qd, t)
        base = self._constraint_term(q, lam, t) - base_force
        K, C = np.empty((n, n)), np.zeros((n, n))
        for k in range(n):
            delta = math.sqrt(np.finfo(float).eps) * max(1.0, abs(q[k]))
            shifted = q.copy()
            shifted[k] += delta
            force = base_force if self.forces.is_constant else self._generalized_forces(shifted, qd, t)
            K[:, k] = (self._constraint_term(shifted, lam, t) - force - base) / delta
            if not self.forces.is_constant:
                delta = math.sqrt(np.finfo(float).eps) * max(1.0, abs(qd[k]))
                shifted = qd.copy()
                shifted[k] += delta
                C[:, k] = -(self._generalized_forces(q, shifted, t) - base_force) / delta
        return K, C

    def update_tangent(self, q, qd, lam, t) -> None:
        """Recompute K and C at (q, q', lambda, t); the iteration matrix is refactored next."""
        self._tangent = self.tangent_matrices(q, qd, lam, t)
        self._lu = None
        self.counters.tangent_updates += 1

    def factor_iteration_matrix(self, q: np.ndarray, t: float, h: float) -> None:
        """S = [[M + h^2 beta' K + h gamma' C, Psi_q^T], [Psi_q, 0]] with the kept K, C; LU-factored (eq. 6.56)."""
        p = self.parameters
        K, C = self._tangent
        jacobian = self.system.jacobian(q, t)
        m = jacobian.shape[0]
        S = np.block(
            [
                [mass_at(self.M, q) + h * h * p.beta_prime * K + h * p.gamma_prime * C, jacobian.T],
                [jacobian, np.zeros((m, m))],
            ]
        )
        self._lu = scipy.linalg.lu_factor(S, check_finite=False)
        self._lu_h = h
        self.counters.factorizations += 1

    # -- one step -----------------------------------------------------------------------------
    def step(self, t, h, q, qd, qdd, a, lam):
        """Advance (q, q', q'', a, lambda) from t to t + h.

        Returns (q, q', q'', a, lambda, error) at t + h, ``error`` the weighted local error estimate
        (eq. 6.58), or None when the Newton iterations do not converge.
        """
        p, self._at = self.parameters, (t, h)
        # the parts of a_n+1, q_n+1 and q'_n+1 that do not depend on q''_n+1 (eq. 6.52, 6.53)
        a_known = (p.alpha_f * qdd - p.alpha_m * a) / (1.0 - p.alpha_m)
        q_known = q + h * qd + h * h * ((0.5 - p.beta) * a + p.beta * a_known)
        qd_known = qd + h * ((1.0 - p.gamma) * a + p.gamma * a_known)
        known = (t + h, h, q_known, qd_known)
        # predictor: q'' and lambda of the last step
        q_pred, qd_pred = q_known + h * h * p.beta_prime * qdd, qd_known + h * p.gamma_prime * qdd
        fresh = self._tangent is None
        if fresh:
            self.update_tangent(q_pred, qd_pred, lam, t + h)
        self.factor_iteration_matrix(q_pred, t + h, h)  # cheap: the kept K, C and Psi_q at the predictor
        solution = self.newton(known, qdd.copy(), lam.copy())
        if solution is None and not fresh:  # the kept K, C are stale: update them and try again
            self.update_tangent(q_pred, qd_pred, lam, t + h)
            self.factor_iteration_matrix(q_pred, t + h, h)
            solution = self.newton(known, qdd.copy(), lam.copy())
        if solution is None:
            self.counters.newton_failures += 1
            return None
        q_new, qd_new, qdd_new, lam_new = solution
        a_new = a_known + (1.0 - p.alpha_f) / (1.0 - p.alpha_m) * qdd_new
        error = weighted_norm(h * h * p.error_constant * (a_new - a), q_new, self.rtol, self.atol)
        return q_new, qd_new, qdd_new, a_new, lam_new, error

    def newton(self, known, qdd, lam):
        """Modified Newton iterations S [dq''; dlambda] = -r (eq. 6.56); None if they stall or diverge."""
        t_new, h, q_known, qd_known = known
        p = self.parameters
        n = qdd.size
        scale = h * h * p.beta_prime
        previous = None
        for _ in range(self.max_iterations):
            q = q_known + scale * qdd
            qd = qd_known + h * p.gamma_prime * qdd
            jacobian = self.system.jacobian(q, t_new)
            Q = self._generalized_forces(q, qd, t_new)
            residual = np.concatenate(
                [mass_at(self.M, q) @ qdd + jacobian.T @ lam - Q, self.system.constraints(q, t_new) / scale]
            )
            correction = scipy.linalg.lu_solve(self._lu, -residual, check_finite=False)
            qdd = qdd + correction[:n]
            lam = lam + correction[n:]
            self.counters.newton_iterations += 1
            size = weighted_norm(scale * correction[:n], q, self.rtol, self.atol)
            if size <= self.newton_tol:
                return q_known + scale * qdd, qd_known + h * p.gamma_prime * qdd, qdd, lam
            if not np.isfinite(size) or (previous is not None and size > 0.5 * previous):
                return None  # diverging, or converging too slowly for this matrix
            previous = size
        return None


BATCH_STEPS = 50
"""Accepted steps ``GuardedSteps`` checks at once (batched SVDs: a fraction of the cost of one check per step)."""


class GuardedSteps:
    """The run's ``guard.Guard`` on an index-3 run, with the checks it makes on the other formulations (issue 29):

    - drift: at every output time, how far q is off the constraints (``Guard.check_drift``);
    - singular positions: at every accepted step, sigma_r / sigma_1 of Psi_q and the sign of det [Psi_q; T^T]
      (``Guard.check_outputs`` over BATCH_STEPS steps at a time, in time order, as the numpy engine's Guard checks
      every step of the other formulations). The index-3 equations pass a singular position (their iteration
      matrix loses rank only at it, and a step lands there with probability zero), as the augmented Lagrangian
      does: the Guard records it (``Guard.through``) instead of stopping;
    - branch switches: at each singular position passed, whether the velocities changed by what the accelerations
      give (``Guard.check_branches``, ``guard.branch_verdict``), judged from the accepted steps around it, not
      the output times: a crossing between two output times is judged too, from samples much closer together.
      Each batch with a step near a singular position is judged with the last two steps of the batch before (a
      crossing at the border has its neighbours on both sides); so a long run keeps a few steps only.
    ``GuardedSteps(None)`` checks nothing (``integrate_index3`` without a Guard)."""

    def __init__(self, guard: Guard | None):
        self.guard = guard
        self.steps: list[tuple] = []  # (t, q, q', q'') of the steps not yet checked
        self.before_batch: list[tuple] = []  # the last two steps checked, with their Psi_q and sigma_r / sigma_1
        self.last: tuple | None = None  # (t, q, sigma_r / sigma_1) of the last step checked

    def accepted(self, t: float, state) -> None:
        """After an accepted step to t (and at t = 0), state = (q, q', q'', a, lambda)."""
        if self.guard is not None and self.guard.singular_ratio and self.guard.rank:
            self.steps.append((float(t), state[0], state[1], state[2]))
            if len(self.steps) >= BATCH_STEPS:
                self.judge()

    def output(self, t: float, q: np.ndarray) -> None:
        """At an output time: the drift, as the numpy engine checks it on the other formulations."""
        if self.guard is not None:
            self.guard.check_drift(q, t)

    def _configurations(self) -> tuple | None:
        """The singular-position check of the steps not yet checked; then (t, q, q', q'', Psi_q) of those steps and
        the two before them if one of them is near a singular position, else None."""
        if not self.steps:
            return None
        t, q = np.array([step[0] for step in self.steps]), np.array([step[1] for step in self.steps])
        jacobians = self.guard.jacobians(t, q)
        self.guard.check_outputs(t, q, None, jacobians, drift=False)
        ratios = self.guard.spectra(t, jacobians)[0]
        self.last = (float(t[-1]), q[-1], float(ratios[-1]))
        steps = self.before_batch + [(*step, *more) for step, *more in zip(self.steps, jacobians, ratios, strict=True)]
        self.steps, self.before_batch = [], steps[-2:]
        near = min(step[5] for step in steps) < NEAR_SINGULAR  # a crossing at the border is judged from this batch
        return tuple(np.array([step[k] for step in steps]) for k in range(5)) if near else None

    def judge(self) -> None:
        """The steps not yet checked: their configurations, and ``Guard.check_branches`` if one is near a singular
        position (BranchSwitchError at a switch)."""
        if self.guard is None:
            return
        kept = self._configurations()
        if kept is not None:
            self.guard.check_branches(*kept)

    def before(self, err: AnalysisError) -> None:
        """A run that stopped with ``err``: a branch switch in the last steps is raised instead, from ``err``."""
        if self.guard is None:
            return
        kept = self._configurations()
        if kept is not None:
            self.guard.check_branches_before(err, *kept[:4])

    def named(self, err: AnalysisError) -> AnalysisError:
        """``err`` (Newton iterations or step control that failed) naming the singular position the last accepted
        step was next to, if it was: there the iteration matrix S (eq. 6.56) loses rank with Psi_q."""
        if self.last is None or self.last[2] >= NEAR_SINGULAR or isinstance(err, BudgetError):
            return err
        from .diagnostics import singular_joints

        t, q, ratio = self.last
        system = self.guard.system
        _, joints = singular_joints(system.jacobian(q, t), system.row_owners)
        return AnalysisError(
            f"{err}. The last step, at t = {t:.6g} s, was next to a singular position (smallest singular value "
            f"{ratio:.2g} of the largest of Psi_q; joints {', '.join(joints)}), where the iteration matrix loses rank "
            "with Psi_q: another --step (one that does not land next to it), or --formulation augmented-lagrangian"
        )


def fixed_steps(t0: float, t1: float, h: float) -> list[float]:
    """Fixed steps: [t0, t1] split into the fewest equal steps no longer than h."""
    count = max(1, math.ceil((t1 - t0) / h - 1e-9))
    return [(t1 - t0) / count] * count


def initial_step(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, rtol: float, atol: float, t_end: float) -> float:
    """A first trial step: h = 0.1 / sqrt(|q'|_w + |q''|_w) in the weighted norm, at most 1 % of the run.

    Step control corrects a poor guess within a few steps; this one only avoids absurd first steps.
    """
    scale = atol + rtol * np.abs(q)
    rate = float(np.sqrt(np.mean((qd / scale) ** 2)) + np.sqrt(np.mean((qdd / scale) ** 2)))
    guess = 0.01 * t_end if rate == 0.0 else 0.1 / rate**0.5
    return float(min(guess, 0.01 * t_end))


class IndependentRows:
    """The system with its redundant constraint rows left out (``linalg.independent_rows`` at the start).

    The iteration matrix S of eq. 6.56 is singular when Psi_q has redundant rows: lambda is then not
    unique. Near the start the redundant rows of an over-constrained loop depend on the others, so the
    independent ones fix the same positions; the implicit integrators solve with them and give the left
    out rows lambda = 0, and the run reports the minimum-norm multipliers (``reactions.minimum_norm_multipliers``).
    """

    def __init__(self, system: System, rows: np.ndarray):
        self.system, self.rows = system, rows
        self.n_constraints = int(rows.size)

    def __getattr__(self, name):
        return getattr(self.system, name)

    def constraints(self, q, t):
        return self.system.constraints(q, t)[self.rows]

    def jacobian(self, q, t):
        return self.system.jacobian(q, t)[self.rows]

    def psi_t(self, q, t):
        return self.system.psi_t(q, t)[self.rows]

    def gamma(self, q, qd, t):
        return self.system.gamma(q, qd, t)[self.rows]


@dataclass
class EnergyAccount:
    """Dissipated energy and the work of loads and drivers, by the trapezoidal rule over each step.

    The same three integrals as the ODE integrators carry as extra states (``dynamics.py``); the
    trapezoidal rule is second order, like the method.
    """

    system: System
    forces: ForceModel
    active: bool
    totals: np.ndarray = field(default_factory=lambda: np.zeros(3))
    _last: np.ndarray | None = None

    def powers(self, q, qd, lam, t) -> np.ndarray:
        """(P_dissipated, P_applied, P_drivers) (eq. 5.60)."""
        drivers = constraint_power(self.system.jacobian(q, t), qd, lam) if self.system.model.motors else 0.0
        return np.array([self.forces.dissipated_power(q, qd, t), self.forces.actuator_power(q, qd, t), drivers])

    def start(self, q, qd, lam, t) -> None:
        if self.active:
            self._last = self.powers(q, qd, lam, t)

    def advance(self, h: float, q, qd, lam, t) -> None:
        if self.active:
            new = self.powers(q, qd, lam, t)
            self.totals = self.totals + 0.5 * h * (self._last + new)
            self._last = new


@dataclass(frozen=True)
class Index3Options:
    """The index-3 methods' own options (``forward_dynamics(..., rho_inf=0.8)``).

    rho_inf : spectral radius at infinity (numerical damping: 1 none, smaller more)
    first_step : first trial step with step control (default: from the initial accelerations, ``initial_step``)
    min_step : below this step the run stops with an AnalysisError
    newton_tol, max_iterations : Newton stops when the weighted position correction is below newton_tol
    """

    rho_inf: float = DEFAULT_RHO
    first_step: float | None = None
    min_step: float = 1e-12
    newton_tol: float = 1e-3
    max_iterations: int = 8

    @classmethod
    def of(cls, method: str, options: dict) -> Index3Options:
        """The options from a run's formulation options, refusing one the index-3 methods do not take."""
        known = cls.__dataclass_fields__
        unknown = sorted(set(options) - set(known))
        if unknown:
            raise AnalysisError(f"{method} takes no option {', '.join(unknown)} (it takes: {', '.join(known)})")
        return cls(**options)


def integrate_index3(
    system: System,
    masses: np.ndarray,
    forces: ForceModel,
    q0: np.ndarray,
    qd0: np.ndarray,
    settings: Settings,
    guard: Guard | None = None,
) -> Result:
    """Integrate the index-3 DAE with generalized-alpha or HHT from a consistent (q0, q0') at t = 0.

    Parameters
    ----------
    system, masses, forces : the assembled system, its mass matrix M and its applied forces
    q0, qd0 : consistent initial positions and velocities (Psi = 0, Psi_q q' + Psi_t = 0)
    settings : ``integrator`` ('generalized-alpha' or 'hht'); the output grid t = 0, t_end/steps, ..., t_end
        (every step ends on it); ``rtol``, ``atol``: local error tolerances of the positions (step control and
        Newton iterations); ``step``: a fixed step size instead of step control; the options ``Index3Options``
    guard : the run's ``guard.Guard`` (drift, singular positions passed, the branch at each: ``GuardedSteps``),
        or None for none

    Returns
    -------
    Result
        q, q', q'', lambda on the output grid; the columns 'residual.position', 'residual.velocity'
        and 'energy.*' as ``forward_dynamics`` gives them; ``info`` with the method, its parameters
        and the counts: steps accepted and rejected, Newton iterations, tangent updates,
        factorizations, residual evaluations (``rhs_evaluations``).
    """
    start = _time.perf_counter()
    options = Index3Options.of(settings.integrator, settings.formulation_options)
    parameters = alpha_parameters(settings.integrator, options.rho_inf)
    if options.rho_inf >= 1.0 and settings.step is None:
        raise AnalysisError(
            f"{settings.integrator}: rho_inf = 1 (no numerical damping) cannot run with step control: the index-3 "
            "equations' algebraic modes (q'' and lambda alternating from step to step) grow at every change of step "
            "and the step shrinks without end; give rho_inf < 1 (the default is "
            f"{DEFAULT_RHO:g}) or a fixed step (step=...)"
        )
    rows = independent_rows(system.jacobian(np.asarray(q0, dtype=float), 0.0))
    solved = system if rows.size == system.n_constraints else IndependentRows(system, rows)  # redundant: fewer rows
    stepper = Index3Stepper(
        solved, masses, forces, parameters, settings.rtol, settings.atol, options.newton_tol, options.max_iterations,
        max_evaluations=settings.max_evaluations, method=settings.integrator,
    )  # fmt: skip
    energy = EnergyAccount(solved, forces, active=not forces.is_conservative or bool(system.model.motors))
    times = np.linspace(0.0, settings.t_end, settings.steps + 1)
    out = Index3History.empty(times.size, system.n_coordinates, system.n_constraints)
    q, qd = np.asarray(q0, dtype=float), np.asarray(qd0, dtype=float)
    watch = GuardedSteps(guard)
    try:
        march(stepper, energy, out, rows, q, qd, times, settings, options, watch)
    except AnalysisError as err:  # a branch switch before the stop is its cause: said first, as the other runs
        watch.before(err)
        named = watch.named(err)
        if named is err:
            raise
        raise named from err
    watch.judge()
    if rows.size < system.n_constraints:  # the multipliers are not unique: the minimum-norm set (eq. 5.73)
        out.lam = minimum_norm_multipliers(system, out.q, out.lam, times)
    result = index3_result(system, masses, forces, out, times)
    result.info.update(index3_info(settings, options.rho_inf, parameters, stepper.counters))
    result.info["wall_time"] = _time.perf_counter() - start
    if rows.size < system.n_constraints:
        result.info["notes"] = [REDUNDANT_NOTE]
    return result


@dataclass
class Index3History:
    """q, q', q'', lambda and the three accumulated energies at the output times."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    lam: np.ndarray
    accumulated: np.ndarray

    @classmethod
    def empty(cls, size: int, n: int, m: int) -> Index3History:
        """Zeros for ``size`` output times, n coordinates and m constraints."""
        return cls(*(np.zeros((size, k)) for k in (n, n, n, m, 3)))


def march(
    stepper: Index3Stepper,
    energy: EnergyAccount,
    out: Index3History,
    rows,
    q,
    qd,
    times,
    settings,
    options,
    watch: GuardedSteps | None = None,
):
    """From the consistent (q, q') over the output times into ``out``: fixed steps, or steps with error control;
    the multipliers of the solved constraint ``rows`` (the others are left 0); ``watch`` sees every accepted
    step and output time."""
    watch = watch or GuardedSteps(None)
    system = stepper.system
    Q = stepper.forces.generalized_forces(q, qd, 0.0)
    qdd, lam = augmented_accelerations(mass_at(stepper.M, q), system.jacobian(q, 0.0), Q, system.gamma(q, qd, 0.0))
    state = (q, qd, qdd, qdd.copy(), lam)  # (q, q', q'', a, lambda), a_0 = q''_0
    energy.start(q, qd, lam, 0.0)
    out.q[0], out.qd[0], out.qdd[0], out.lam[0, rows] = q, qd, qdd, lam
    watch.accepted(0.0, state)
    step, t = settings.step, 0.0
    h = step or options.first_step or initial_step(q, qd, qdd, settings.rtol, settings.atol, times[-1])
    for k in range(1, times.size):
        if step is not None:
            state, t = _fixed_interval(stepper, energy, t, times[k], step, state, settings.integrator, watch), times[k]
        else:
            t, h, state = _adaptive_interval(stepper, energy, t, times[k], h, state, options.min_step, watch)
        watch.output(t, state[0])
        out.q[k], out.qd[k], out.qdd[k], out.lam[k, rows] = state[0], state[1], state[2], state[4]
        out.accumulated[k] = energy.totals


def _fixed_interval(
    stepper: Index3Stepper, energy: EnergyAccount, t: float, t_out: float, step: float, state, method, watch
):
    """Fixed steps from t to the output time t_out (the last one shortened to land on it); returns the state."""
    for h in fixed_steps(t, t_out, step):
        new = stepper.step(t, h, *state)
        if new is None:
            raise AnalysisError(
                f"{method}: Newton iterations did not converge at t = {t:.6g} s with step {h:.3g} s; "
                "use a smaller --step"
            )
        state, t = new[:5], t + h
        stepper.counters.accepted_steps += 1
        energy.advance(h, state[0], state[1], state[4], t)
        watch.accepted(t, state)
    return state


def index3_result(system: System, masses, forces: ForceModel, out: Index3History, times: np.ndarray) -> Result:
    """The result with its residual and energy columns, as ``forward_dynamics`` gives them."""
    result = Result(
        t=times,
        q=out.q,
        qd=out.qd,
        qdd=out.qdd,
        lam=out.lam,
        coordinate_names=system.coordinate_names,
        body_names=[b.name for b in system.model.bodies],
    )
    residuals = constraint_residuals(system, times, out.q, out.qd)
    energies = energy_history(masses, forces, out.q, out.qd, *out.accumulated.T)
    result.points.update(residuals)
    result.points.update(energies.columns())
    result.info = {
        "max_constraint_residual": float(residuals["residual.position"].max()),
        "max_velocity_residual": float(residuals["residual.velocity"].max()),
        "energy_drift": float(np.max(np.abs(energies.error))),
        "energy_drift_relative": float(np.max(np.abs(energies.error)) / energies.scale),
    }
    return result


def index3_info(settings: Settings, rho_inf: float, parameters: AlphaParameters, counters: Counters) -> Index3Info:
    """How the run was made: the method, its parameters (eq. 6.52) and the counts."""
    return {
        "analysis": "dynamic",
        "formulation": "index-3",
        "integrator": settings.integrator,
        "rtol": settings.rtol,
        "atol": settings.atol,
        "step": settings.step,
        "steps": settings.steps,
        "rho_inf": rho_inf,
        "alpha_m": parameters.alpha_m,
        "alpha_f": parameters.alpha_f,
        "gamma": parameters.gamma,
        "beta": parameters.beta,
        "rhs_evaluations": counters.rhs_evaluations,
        "integrator_steps": counters.accepted_steps,
        "rejected_steps": counters.rejected_steps,
        "newton_iterations": counters.newton_iterations,
        "newton_failures": counters.newton_failures,
        "tangent_updates": counters.tangent_updates,
        "factorizations": counters.factorizations,
    }


def _adaptive_interval(
    stepper: Index3Stepper, energy: EnergyAccount, t: float, t_out: float, h: float, state, min_step: float, watch
):
    """Steps with error control from t to the output time t_out (eq. 6.58); returns (t_out, next h, state)."""
    while t < t_out:
        remaining = t_out - t
        last = remaining <= h * (1.0 + 1e-9)
        h_try = remaining if last else (0.5 * remaining if remaining < 2.0 * h else h)  # no sliver steps
        new = stepper.step(t, h_try, *state)
        if new is None:  # Newton failed: a much smaller step
            h = 0.25 * h_try
        elif new[5] > 1.0:  # error too large: reject, retry smaller
            stepper.counters.rejected_steps += 1
            h = h_try * max(0.2, 0.9 * new[5] ** (-1.0 / 3.0))
        else:
            stepper.counters.accepted_steps += 1
            state = new[:5]
            t = t_out if last else t + h_try
            energy.advance(h_try, state[0], state[1], state[4], t)
            watch.accepted(t, state)
            grow = 2.0 if new[5] == 0.0 else min(2.0, max(0.2, 0.9 * new[5] ** (-1.0 / 3.0)))
            h = max(h, h_try * grow) if h_try < h else h_try * grow
            continue
        if h < min_step:
            what = "Newton iterations" if new is None else "error control"
            raise AnalysisError(
                f"{what} failed at t = {t:.6g} s: the step fell below {min_step:.3g} s; "
                "loosen the tolerances or check the model"
            )
    return t, h, state


__all__ = [
    "DEFAULT_RHO",
    "METHODS",
    "AlphaParameters",
    "EnergyAccount",
    "GuardedSteps",
    "IndependentRows",
    "Index3Stepper",
    "alpha_parameters",
    "integrate_index3",
    "weighted_norm",
]
