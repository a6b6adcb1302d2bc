# Generated from solutions/formulations.py by `make modules` (every homework stubbed): do not edit by hand.
"""Forward-dynamics formulations: from the state (q, q') to the accelerations q'' and multipliers lambda.

Every formulation solves the same equations of motion with constraints (course notes, chapter 5)

    M q'' + Psi_q^T lambda = Q(q, q', t),      Psi_q q'' = gamma          (eq. 5.25, 5.26)

and differs in how it keeps the positions and velocities on the constraint manifold Psi = 0,
Psi' = Psi_q q' + Psi_t = 0 while an ODE integrator advances them:

=================  ==============================================================================
``baumgarte``      augmented Lagrange-multiplier system, gamma stabilized (eq. 5.30)
``partitioning``   coordinate partitioning (Wehage-Haug): integrate the independent coordinates,
                   Newton-correct the dependent ones, repartition when Psi_u degrades (eq. 5.40)
``qr``             null-space projection with a QR basis of Psi_q^T (eq. 5.45)
``svd``            null-space projection with an SVD basis; copes with redundant constraints (eq. 5.47)
``projection``     unstabilized augmented system, then mass-orthogonal projection of q and q'
                   onto Psi = 0 and Psi' = 0 after each step (eq. 5.50)
``augmented-       augmented Lagrangian with mass-orthogonal projections (Bayo and Ledesma 1996):
lagrangian``       the leading matrix M + alpha Psi_q^T Psi_q stays positive definite where Psi_q
                   loses rank, so singular positions and redundant constraints pass (eq. 5.52-5.54)
=================  ==============================================================================

A formulation is an object made once per run. The integrator sees only its state vector y:

- ``initial_state(q, q', t) -> y``  and  ``coordinates(t, y) -> (q, q')``
- ``accelerations(q, q', t) -> (q'', lambda)``  (the formulation's equation)
- ``state_derivative(q, q', q'') -> y'``,  so ``rhs(t, y)`` = the three above in a row
- ``after_step(t, y) -> y or None``: a new state to restart from (projection, repartitioning)

The mass matrix is constant (planar body coordinates), so its inverse is made once.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import scipy.linalg

from .assembly import System
from .diagnostics import AnalysisError
from .generalized_forces import ForceModel
from .linalg import cho_solve, numerical_rank, solve
from .mass_matrix import singular_inertia

EPS = float(np.finfo(float).eps)
"""The unit roundoff of double precision, 2.2e-16."""

SINGULAR_CONDITION = 1e12
"""Condition number of Psi_u above which coordinate partitioning refuses a partition."""

DEFAULT_ALPHA = 5.0
DEFAULT_BETA = 5.0
"""Baumgarte's alpha = beta = 5 1/s (Nikravesh 1988, sec. 13.4): critically damped constraint error
Psi'' + 2 alpha Psi' + beta^2 Psi = 0 with a time constant of 0.2 s, slow beside the integrator's steps."""


# -- the course's equations --------------------------------------------------------------------------
def baumgarte_gamma(gamma: np.ndarray, psi: np.ndarray, psi_dot: np.ndarray, alpha: float, beta: float) -> np.ndarray:
    """gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi (eq. 5.29, DESIGN section 3).

    Asking Psi_q q'' = gamma_bar instead of gamma makes the constraint error obey the damped
    oscillator Psi'' + 2 alpha Psi' + beta^2 Psi = 0 instead of Psi'' = 0 (Baumgarte 1972).
    """
    raise NotImplementedError("baumgarte_gamma: gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi, see eq. 5.29")


def augmented_accelerations(
    M: np.ndarray, jacobian: np.ndarray, Q: np.ndarray, gamma: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Solve the augmented system for q'' and lambda (eq. 5.30):

    [ M      Psi_q^T ] [ q''    ]   [ Q     ]
    [ Psi_q  0       ] [ lambda ] = [ gamma ]
    """
    n = M.shape[0]
    raise NotImplementedError("augmented_accelerations: Solve the augmented system for q'' and lambda, see eq. 5.30")
    return solution[:n], solution[n:]


def null_space_accelerations(
    M: np.ndarray, Q: np.ndarray, gamma: np.ndarray, Z: np.ndarray, particular: np.ndarray
) -> np.ndarray:
    """q'' = q''_p + Z z with Z^T M Z z = Z^T (Q - M q''_p) (eq. 5.44).

    Z spans the null space of Psi_q (Psi_q Z = 0), q''_p is any solution of Psi_q q''_p = gamma: the
    constraint forces Psi_q^T lambda do no work along Z, so projecting the equations of motion onto
    Z removes lambda.
    """
    Zt = Z.T
    z = np.linalg.solve(Zt @ M @ Z, Zt @ (Q - M @ particular))
    return particular + Z @ z


# -- common machinery ----------------------------------------------------------------------------------
def smallest_eigenvalue(M: np.ndarray) -> float:
    """The smallest eigenvalue of the symmetric part of M: the least diagonal entry of a diagonal M (every planar
    model's: exact, and without the O(n^3) eigensolver, 4 ms at n = 192), else ``eigvalsh``'s first."""
    diagonal = np.diagonal(M)
    if np.count_nonzero(M) == np.count_nonzero(diagonal):
        return float(np.min(diagonal, initial=np.inf))
    return float(np.linalg.eigvalsh(0.5 * (M + M.T))[0])


class Formulation:
    """Base: state y = (q, q'); subclasses give ``accelerations``."""

    name = ""

    def __init__(self, system: System, M: np.ndarray, forces: ForceModel, alpha: float = 0.0, beta: float = 0.0):
        self.system, self.M, self.forces = system, M, forces
        self.masses = M  # as given: the matrix, or a spatial model's M(q) (self.M is then the last one evaluated)
        self.n = system.n_coordinates
        self.alpha, self.beta = float(alpha), float(beta)
        if not (self.alpha >= 0.0 and self.beta >= 0.0):
            raise AnalysisError(
                f"Baumgarte parameters alpha = {alpha}, beta = {beta}: both must be >= 0; a negative one makes the "
                "constraint error grow as exp(|alpha| t) instead of dying out (eq. 5.29)"
            )
        self._mass = M if callable(M) else None  # a spatial model's M(q): evaluated at every state
        if self._mass is None:
            self.factor_mass(M)

    @functools.cached_property
    def _Q_constant(self) -> np.ndarray:
        """Q of gravity alone (or nothing), for ``applied_forces`` when the forces are constant: made where first
        asked (a compiled run never asks; made in every formulation's construction it was 2-5 us of a call's start)."""
        return self.forces.generalized_forces(np.zeros(self.n), np.zeros(self.n), 0.0)

    @functools.cached_property
    def singular_mass(self) -> bool:
        """Whether M is singular (a point mass: M^-1 does not exist, ``mass_orthogonal_correction``): a spatial M(q)
        with a body's singular inertia (``singular_inertia``), a matrix with an eigenvalue <= 0. Decided where first
        asked (a projection's correction): the other formulations never ask (an eigensolver of a spatial model's
        inertias, 13-18 us of every run's start)."""
        if callable(self.masses):
            return bool(singular_inertia(self.system.model))
        return not smallest_eigenvalue(self.masses) > 0.0

    # -- pieces every formulation uses
    def factor_mass(self, M: np.ndarray) -> None:
        """Keep M; ``mass_solve`` factors it when first asked (formulations that only assemble M never do)."""
        self.M = M
        self._inverse_diagonal = self._cholesky = None

    def mass(self, q: np.ndarray) -> np.ndarray:
        """M at q: the constant matrix of a planar model; a spatial model's M(q), evaluated anew."""
        if self._mass is not None:
            self.factor_mass(self._mass(q))
        return self.M

    def mass_solve(self, x: np.ndarray) -> np.ndarray:
        """M^-1 x for a vector or the columns of a matrix (M factored once per M: once for a planar model)."""
        if self._inverse_diagonal is None and self._cholesky is None:
            diagonal = np.diag(self.M)
            if np.array_equal(self.M, np.diag(diagonal)):
                self._inverse_diagonal = 1.0 / diagonal  # planar body coordinates: M^-1 is diagonal too
            else:
                self._cholesky = scipy.linalg.cho_factor(self.M)
        if self._inverse_diagonal is not None:
            return (x.T * self._inverse_diagonal).T
        return scipy.linalg.cho_solve(self._cholesky, x)

    def applied_forces(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        """Q(q, q', t); gravity alone (or nothing) is a constant vector computed once."""
        if self.forces.is_constant:
            return self._Q_constant
        return self.forces.generalized_forces(q, qd, t)

    def constraint_terms(self, q: np.ndarray, qd: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(Psi_q, gamma), gamma stabilized to gamma_bar when alpha or beta is set (eq. 5.29).

        The system evaluates what it needs in one pass (``System.evaluate``): Psi and Psi_t only for
        the stabilization.
        """
        stabilized = self.alpha != 0.0 or self.beta != 0.0
        rheonomic = stabilized and getattr(self.system, "rheonomic", True)  # Psi_t = 0 without drivers
        psi, jacobian, psi_t, gamma = self.system.evaluate(q, qd, t, constraints=stabilized, psi_t=rheonomic)
        if stabilized:
            psi_dot = jacobian @ qd + psi_t if rheonomic else jacobian @ qd  # Psi' = Psi_q q' + Psi_t
            gamma = baumgarte_gamma(gamma, psi, psi_dot, self.alpha, self.beta)
        return jacobian, gamma

    def stabilized_gamma(self, q: np.ndarray, qd: np.ndarray, t: float, jacobian: np.ndarray) -> np.ndarray:
        """gamma, or gamma_bar when alpha or beta is set (eq. 5.29)."""
        gamma = self.system.gamma(q, qd, t)
        if self.alpha == 0.0 and self.beta == 0.0:
            return gamma
        psi = self.system.constraints(q, t)
        psi_dot = jacobian @ qd + self.system.psi_t(q, t)
        return baumgarte_gamma(gamma, psi, psi_dot, self.alpha, self.beta)

    # -- the integrator's view
    def initial_state(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        return np.concatenate([q, qd])

    def coordinates(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return y[: self.n], y[self.n :]

    def state_derivative(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        return np.concatenate([qd, qdd])

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """y' = f(t, y): the first-order form the integrator advances."""
        return self.derivative(t, y)[0]

    def derivative(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(y', q, q') at y: the right-hand side and the coordinates it was evaluated at."""
        q, qd = self.coordinates(t, y)
        qdd, _ = self.accelerations(q, qd, t)
        return self.state_derivative(q, qd, qdd), q, qd

    def after_step(self, t: float, y: np.ndarray) -> np.ndarray | None:
        return None

    def accelerations(self, q: np.ndarray, qd: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError


class Baumgarte(Formulation):
    """Augmented Lagrange-multiplier system with Baumgarte stabilization (eq. 5.30).

        [ M      Psi_q^T ] [ q''    ]   [ Q                                  ]
        [ Psi_q  0       ] [ lambda ] = [ gamma - 2 alpha Psi' - beta^2 Psi  ]

    alpha = beta = 0 is the plain index-1 system, whose constraint error drifts.
    """

    name = "baumgarte"

    def __init__(self, system, M, forces, alpha: float = DEFAULT_ALPHA, beta: float = DEFAULT_BETA):
        super().__init__(system, M, forces, alpha, beta)

    def accelerations(self, q, qd, t):
        jacobian, gamma = self.constraint_terms(q, qd, t)
        return augmented_accelerations(self.mass(q), jacobian, self.applied_forces(q, qd, t), gamma)


class NullSpaceQR(Formulation):
    """Null-space projection with QR (eq. 5.45).

    Psi_q^T = [Y Z] [R; 0] (full QR, R m x m upper triangular): Z (n x (n-m)) spans the null space of
    Psi_q, and q''_p = Y R^-T gamma solves Psi_q q''_p = gamma. Then lambda = R^-1 Y^T (Q - M q'').
    Psi_q must have full row rank (use ``svd`` for redundant constraints). Optional alpha, beta
    stabilize gamma as in ``baumgarte`` (default 0: the pure method).
    """

    name = "qr"

    def accelerations(self, q, qd, t):
        jacobian, gamma = self.constraint_terms(q, qd, t)
        Q = self.applied_forces(q, qd, t)
        m = jacobian.shape[0]
        basis, R = np.linalg.qr(jacobian.T, mode="complete")
        Y, Z, R = basis[:, :m], basis[:, m:], R[:m]
        particular = Y @ scipy.linalg.solve_triangular(R, gamma, trans="T")
        qdd = null_space_accelerations(self.mass(q), Q, gamma, Z, particular)
        lam = scipy.linalg.solve_triangular(R, Y.T @ (Q - self.M @ qdd))
        return qdd, lam


class NullSpaceSVD(Formulation):
    """Null-space projection with the SVD Psi_q = U S V^T (eq. 5.47).

    With r the numerical rank (by the package's rule, ``linalg.rank_tolerance``; or singular values above
    ``rank_tol`` times the largest when given), V_2 = V[:, r:]
    spans the null space and q''_p = V_1 S_1^-1 U_1^T gamma is the minimum-norm solution of
    Psi_q q''_p = gamma. Redundant constraints (r < m) are fine: the multipliers are then not unique
    and lambda = U_1 S_1^-1 V_1^T (Q - M q'') is the minimum-norm set, which gives the same
    constraint forces Psi_q^T lambda as any other.
    """

    name = "svd"

    def __init__(self, system, M, forces, alpha: float = 0.0, beta: float = 0.0, rank_tol: float | None = None):
        super().__init__(system, M, forces, alpha, beta)
        self.rank_tol = rank_tol

    def accelerations(self, q, qd, t):
        jacobian, gamma = self.constraint_terms(q, qd, t)
        Q = self.applied_forces(q, qd, t)
        U, s, Vt = np.linalg.svd(jacobian)
        if self.rank_tol is None:
            r = numerical_rank(s, jacobian.shape)
        else:
            r = int(np.sum(s > self.rank_tol * s[0])) if s.size else 0
        U1, s1, V1, Z = U[:, :r], s[:r], Vt[:r].T, Vt[r:].T
        particular = V1 @ ((U1.T @ gamma) / s1)
        qdd = null_space_accelerations(self.mass(q), Q, gamma, Z, particular)
        lam = U1 @ ((V1.T @ (Q - self.M @ qdd)) / s1)
        return qdd, lam


class Projection(Formulation):
    """Unstabilized augmented system, then projection after each step (eq. 5.50).

    After each integrator step the positions and velocities are moved back onto the constraints by
    the corrections of least kinetic-energy norm (mass-orthogonal projection; Bayo and Ledesma 1996):

        q  <- q  - M^-1 Psi_q^T (Psi_q M^-1 Psi_q^T)^-1 Psi          (Newton iterations until |Psi| < tol)
        q' <- q' - M^-1 Psi_q^T (Psi_q M^-1 Psi_q^T)^-1 (Psi_q q' + Psi_t)

    The integrator restarts from the projected state, so use it with one-step methods (rk4, RK45,
    DOP853): a multistep method (BDF, LSODA) would lose its history at every step.
    """

    name = "projection"

    def __init__(self, system, M, forces, tol: float = 1e-12, max_iterations: int = 10):
        super().__init__(system, M, forces)
        self.tol, self.max_iterations = tol, max_iterations
        self.projections = 0

    def accelerations(self, q, qd, t):
        jacobian, gamma = self.constraint_terms(q, qd, t)
        return augmented_accelerations(self.mass(q), jacobian, self.applied_forces(q, qd, t), gamma)

    def after_step(self, t, y):
        self.mass(y[: self.n])  # M (a spatial M(q)) at the state before the projection, for both corrections
        q, qd = project_positions(self, y[: self.n], t, self.tol, self.max_iterations)
        qd = project_velocities(self, q, y[self.n :], t)
        self.projections += 1
        return np.concatenate([q, qd])


def project_positions(
    formulation: Formulation, q: np.ndarray, t: float, tol: float = 1e-12, max_iterations: int = 10
) -> tuple[np.ndarray, np.ndarray]:
    """Mass-orthogonal projection of q onto Psi(q, t) = 0 (eq. 5.50); returns (q, Psi_q at q)."""
    system = formulation.system
    for _ in range(max_iterations):
        psi = system.constraints(q, t)
        jacobian = system.jacobian(q, t)
        if np.max(np.abs(psi), initial=0.0) < tol:
            return q, jacobian
        q = q - mass_orthogonal_correction(formulation, q, jacobian, psi)
    raise AnalysisError(f"position projection did not converge at t = {t:.6g} s (residual {np.abs(psi).max():.3g})")


def project_velocities(formulation: Formulation, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
    """Mass-orthogonal projection of q' onto Psi_q q' + Psi_t = 0 (eq. 5.50)."""
    system = formulation.system
    jacobian = system.jacobian(q, t)
    residual = jacobian @ qd + system.psi_t(q, t)
    return qd - mass_orthogonal_correction(formulation, q, jacobian, residual)


def mass_orthogonal_correction(formulation: Formulation, q: np.ndarray, jacobian: np.ndarray, r: np.ndarray):
    """The correction of least kinetic-energy norm that removes the residual r to first order (eq. 5.50),
    M^-1 Psi_q^T (Psi_q M^-1 Psi_q^T)^-1 r. Where M is singular (a point mass, regular on the motions the joints
    allow: eq. 5.44) the same x from the matrix of eq. 5.30: [M Psi_q^T; Psi_q 0] [x; mu] = [0; r]."""
    if formulation.singular_mass:
        n, m = jacobian.shape[1], jacobian.shape[0]
        kkt = np.block([[formulation.mass(q), jacobian.T], [jacobian, np.zeros((m, m))]])
        return np.linalg.solve(kkt, np.concatenate([np.zeros(n), r]))[:n]
    weighted = formulation.mass_solve(jacobian.T)  # M^-1 Psi_q^T
    return weighted @ np.linalg.solve(jacobian @ weighted, r)


DEFAULT_PENALTY = 1e7
"""Penalty of the augmented Lagrangian formulation, relative: alpha = DEFAULT_PENALTY m_max / sigma_max^2 with
m_max the largest diagonal entry of M and sigma_max the largest singular value of Psi_q at the start, so that
alpha Psi_q^T Psi_q outweighs M by this factor along every constraint direction of full rank (Bayo and
Ledesma 1996 use alpha of 1e7 for unit masses and lengths)."""


class AugmentedLagrangian(Formulation):
    """Augmented Lagrangian formulation with mass-orthogonal projections (Bayo, Garcia de Jalon and Serna
    1988; Bayo and Ledesma 1996), for mechanisms that pass singular positions or have redundant constraints.

    Accelerations. With a penalty alpha, the iterations (eq. 5.52)

        (M + alpha Psi_q^T Psi_q) q''_k+1 = Q - Psi_q^T lambda_k + alpha Psi_q^T gamma
        lambda_k+1 = lambda_k + alpha (Psi_q q''_k+1 - gamma),            lambda_0 = 0

    converge to the solution of M q'' + Psi_q^T lambda = Q, Psi_q q'' = gamma; a constraint direction with
    singular value sigma converges by the factor m / (m + alpha sigma^2) per iteration. The matrix
    M + alpha Psi_q^T Psi_q is symmetric positive definite whatever the rank of Psi_q (M is), so it is
    factored (Cholesky) where the augmented matrix of eq. 5.30 is singular: at a singular position (a
    parallelogram whose bars line up) and with redundant constraints (an over-constrained loop). Starting
    from lambda_0 = 0, every update lies in the range of Psi_q, so lambda is the minimum-norm set of
    multipliers: redundant constraints share the reaction in the least-squares sense, which is one of many
    sets that give the same constraint forces Psi_q^T lambda. The iterations stop where what is left of the
    error is rounding (``converged``: two to five where Psi_q keeps its rank); where Psi_q has lost rank they stop
    after ``max_iterations`` with the least-squares compromise, and the motion goes on.

    Projections (eq. 5.53, 5.54). After every step the positions and velocities are moved back onto the
    constraints by the corrections of least kinetic-energy norm, computed with the same matrix:

        q  <- q  - (M + alpha Psi_q^T Psi_q)^-1 alpha Psi_q^T Psi                 (repeated until |Psi| < tol)
        q' <- q' - (M + alpha Psi_q^T Psi_q)^-1 alpha Psi_q^T (Psi_q q' + Psi_t)   (repeated likewise)

    For a large alpha this is the mass-orthogonal projection M^-1 Psi_q^T (Psi_q M^-1 Psi_q^T)^-1 of
    ``projection`` (eq. 5.50), but it stays bounded where Psi_q loses rank (a Tikhonov-regularized step),
    so the state stays on the physical branch the velocities point along. As with ``projection``, the
    integrator restarts after each step: use one-step methods (dop853, rk45, RK45, DOP853, rk4).

    Optional alpha, beta stabilize gamma as in ``baumgarte`` (default 0: the projections keep the
    constraints). ``penalty`` is relative (DEFAULT_PENALTY).
    """

    name = "augmented-lagrangian"

    def __init__(
        self,
        system,
        M,
        forces,
        alpha: float = 0.0,
        beta: float = 0.0,
        penalty: float = DEFAULT_PENALTY,
        tol: float = 1e-12,
        max_iterations: int = 25,
    ):
        super().__init__(system, M, forces, alpha, beta)
        if not (penalty > 0.0 and np.isfinite(penalty)):
            raise AnalysisError(f"augmented Lagrangian: penalty = {penalty} must be a number > 0")
        self.penalty, self.tol, self.max_iterations = float(penalty), float(tol), int(max_iterations)
        self._alpha = None  # the absolute penalty, set from M and Psi_q at the first state
        self.projections = 0
        self.unconverged = 0  # evaluations whose iterations stopped at max_iterations (a singular position)
        self.iterations = 0  # iterations of eq. 5.52, over all evaluations
        self.differenced = False  # True under an implicit integrator, whose Jacobian differences q'' (``converged``)

    @property
    def held_rtol(self) -> float:
        """The tightest integrator tolerance this formulation holds: its accelerations come from the matrix
        M + alpha Psi_q^T Psi_q, of condition about ``penalty``, so they carry rounding errors that an adaptive
        step below this tolerance chases with ever smaller steps. Measured (double pendulum, DOP853, penalty
        1e7): rtol 1e-11 takes 93 steps over 2 s, 3e-12 over 1100; it scales with the penalty."""
        return 1e-11 * self.penalty / DEFAULT_PENALTY

    def penalty_factor(self, M: np.ndarray, jacobian: np.ndarray) -> float:
        """alpha = penalty m_max / sigma_max(Psi_q)^2, fixed at the first evaluation (DEFAULT_PENALTY)."""
        if self._alpha is None:
            sigma = np.linalg.norm(jacobian, 2) if jacobian.size else 1.0
            self._alpha = self.penalty * float(np.max(np.diag(M))) / max(float(sigma) ** 2, 1e-300)
        return self._alpha

    def _factor(self, M: np.ndarray, jacobian: np.ndarray):
        alpha = self.penalty_factor(M, jacobian)
        return alpha, scipy.linalg.cho_factor(M + alpha * (jacobian.T @ jacobian))

    def converged(self, changes: list[float], size: float) -> bool:
        """Whether the iterations of eq. 5.52 can stop, from their changes ||q''_k+1 - q''_k||_M so far and the
        size ||q''||_M: the error left in q'' is below what rounding leaves.

        The changes d_k = q''_k+1 - q''_k obey d_k+1 = (M + alpha Psi_q^T Psi_q)^-1 M d_k: an operator symmetric
        in the kinetic-energy norm ||x||_M = sqrt(x^T M x), with eigenvalue 1 on the motions the joints allow (to
        which every d_k is M-orthogonal) and m / (m + alpha sigma^2) < 1 along each constraint direction. In exact
        arithmetic ||d_k||_M therefore shrinks at every iteration, by a factor theta_k = ||d_k||_M / ||d_k-1||_M,
        and the error left in q''_k+1 is at most theta_k / (1 - theta_k) ||d_k||_M (a geometric series; the
        estimate Hairer and Wanner use for the simplified Newton iterations of implicit Runge-Kutta methods,
        Solving ODEs II, sec. IV.8). Rounding sets a floor: q'' comes from the matrix M + alpha Psi_q^T Psi_q of
        condition about ``penalty`` and from right-hand sides whose terms alpha Psi_q^T gamma and Psi_q^T lambda
        are ``penalty`` times larger than their difference, so each iterate moves by rounding of up to
        penalty x eps x ||q''||_M (2e-9 relative at the default 1e7; measured, 1e-11 to 1e-9). Stop when

            (a) theta_k / (1 - theta_k) ||d_k||_M <= eps ||q''||_M             (nothing left above the last bit), or
            (b) theta_k >= 1, the smallest change before, d_j, was reached by shrinking fast
                (||d_j||_M <= ||d_j-1||_M / 2), and ||d_k||_M <= penalty eps ||q''||_M         (only rounding left).

        (b): the changes stopped shrinking, which in exact arithmetic they cannot, at rounding size, after they
        had contracted fast: the error of q''_j+1 was then at most theta_j / (1 - theta_j) ||d_j||_M <= ||d_j||_M,
        itself within rounding, and the iterates since differ from it by rounding. Where Psi_q has full rank the
        iterations so stop after two to five (the first change is the penalty solution's whole error, 1e-6
        relative at the default penalty; the old rule, a change below 1e-14 of 1 + max |q''|, under the rounding
        floor, ran all ``max_iterations`` on a fifth of the Sarrus linkage's evaluations). Near a singular
        position some sigma is small and theta close to 1: the changes shrink slowly, each a new smallest one,
        none reached by shrinking fast, and the iterations run on, up to ``max_iterations``, as before.

        Not under an implicit integrator (``differenced``: Radau, BDF, LSODA), whose Newton iterations take the
        Jacobian of q'' by finite differences: states a step apart stopping after different counts give q'' a
        rounding-sized jump that the differences magnify (Sarrus' linkage through a singular position, Radau: twice
        the evaluations). There the iterations stop on a change below 1e-14 (1 + max |q''|), under the rounding
        floor: near singular positions all ``max_iterations``, a smooth function of the state.
        """
        change = changes[-1]
        if change == 0.0:
            return True
        if len(changes) < 2:  # the first change has no theta: the penalty solution's whole error
            return False
        theta = change / changes[-2]
        if theta < 1.0:  # (a)
            return theta / (1.0 - theta) * change <= EPS * size
        j = int(np.argmin(changes[:-1]))  # (b): d_j the smallest change before this one
        return j >= 1 and changes[j] <= 0.5 * changes[j - 1] and change <= self.penalty * EPS * size

    def accelerations(self, q, qd, t):
        jacobian, gamma = self.constraint_terms(q, qd, t)
        M = self.mass(q)
        Q = self.applied_forces(q, qd, t)
        alpha, factor = self._factor(M, jacobian)
        lam = np.zeros(jacobian.shape[0])
        base = Q + alpha * (jacobian.T @ gamma)
        qdd = scipy.linalg.cho_solve(factor, base)
        changes = []  # ||q''_k+1 - q''_k||_M
        for _ in range(self.max_iterations):
            lam = lam + alpha * (jacobian @ qdd - gamma)
            new = cho_solve(factor, base - jacobian.T @ lam)
            step = new - qdd
            changes.append(math.sqrt(max(float(step @ M @ step), 0.0)))
            qdd = new
            self.iterations += 1
            if self.differenced:  # a fixed rule, far below rounding: the same count for neighbouring states
                if float(np.max(np.abs(step), initial=0.0)) <= 1e-14 * (1.0 + float(np.max(np.abs(qdd), initial=0.0))):
                    break
            elif self.converged(changes, math.sqrt(max(float(qdd @ M @ qdd), 0.0))):
                break
        else:
            self.unconverged += 1
        # lambda carries the rounding of alpha (Psi_q q'' - gamma), about alpha eps: one least-squares correction
        # J^T dlambda = Q - M q'' - J^T lambda, from (J J^T + delta I) dlambda = J r, removes it (delta keeps the
        # matrix positive definite where Psi_q has lost rank)
        if not jacobian.shape[0]:
            return qdd, lam
        normal = jacobian @ jacobian.T
        delta = 1e-12 * float(np.max(np.diag(normal), initial=1.0))
        r = Q - M @ qdd - jacobian.T @ lam
        lam = lam + scipy.linalg.cho_solve(
            scipy.linalg.cho_factor(normal + delta * np.eye(normal.shape[0])), jacobian @ r
        )
        return qdd, lam

    def project(self, q: np.ndarray, residual, t: float, M: np.ndarray | None = None) -> np.ndarray:
        """Repeat x <- x - (M + alpha Psi_q^T Psi_q)^-1 alpha Psi_q^T r(x) until |r| < tol (eq. 5.53, 5.54).

        ``residual(x)`` gives (r, Psi_q); the same function serves positions (r = Psi) and velocities
        (r = Psi_q q' + Psi_t), the latter with ``M`` at the positions (a spatial M(q) is a function of the
        positions, not of the velocities being projected). Stops after ``max_iterations`` where Psi_q has lost rank.
        """
        M = self.mass(q) if M is None else M
        for _ in range(self.max_iterations):
            r, jacobian = residual(q)
            if not np.max(np.abs(r), initial=0.0) >= self.tol:  # converged (or NaN: the integrator rejects it)
                break
            alpha, factor = self._factor(M, jacobian)
            q = q - scipy.linalg.cho_solve(factor, alpha * (jacobian.T @ r))
        return q

    def after_step(self, t, y):
        system = self.system
        q = self.project(y[: self.n], lambda x: (system.constraints(x, t), system.jacobian(x, t)), t)
        jacobian, psi_t = system.jacobian(q, t), system.psi_t(q, t)
        qd = self.project(y[self.n :], lambda v: (jacobian @ v + psi_t, jacobian), t, self.mass(q))
        self.projections += 1
        return np.concatenate([q, qd])


class Partitioning(Formulation):
    """Coordinate partitioning (Wehage and Haug 1982) (eq. 5.40).

    q is split into m dependent coordinates u and n - m independent ones v, chosen as the pivot
    columns of a column-pivoted QR of Psi_q (the best-conditioned block Psi_u). The integrator
    advances only y = (v, v'); at every evaluation

    1. u from Psi(u, v, t) = 0 by Newton-Raphson, Psi_u du = -Psi  (starting from the last u)
    2. u' from Psi_u u' = -Psi_v v' - Psi_t
    3. q'' and lambda from the augmented system (eq. 5.30, unstabilized), of which v'' is kept.

    After each step the condition number of Psi_u is checked: when it has grown by more than
    ``repartition_ratio`` since the partition was chosen, a new partition is chosen and the
    integrator restarts (``after_step``). ``independent`` forces the first partition (coordinate
    names such as 'crank.phi').
    """

    name = "partitioning"

    def __init__(
        self,
        system,
        M,
        forces,
        tol: float = 1e-12,
        max_iterations: int = 20,
        repartition_ratio: float = 10.0,
        independent: list[str] | None = None,
    ):
        super().__init__(system, M, forces)
        self.tol, self.max_iterations, self.repartition_ratio = tol, max_iterations, repartition_ratio
        self._forced = list(independent) if independent else None
        self.repartitions = 0
        self.partitions: list[tuple[float, list[str]]] = []

    # -- choosing the partition
    def partition(self, q: np.ndarray, t: float) -> None:
        """Choose dependent columns u (pivots of a column-pivoted QR of Psi_q) and independent v."""
        jacobian = self.system.jacobian(q, t)
        m = jacobian.shape[0]
        if self._forced is not None:
            names = self.system.coordinate_names
            independent = sorted(names.index(name) for name in self._forced)
            self._forced = None
        else:
            _, _, pivots = scipy.linalg.qr(jacobian, pivoting=True, mode="economic")
            independent = sorted(pivots[m:])
        self.v = np.array(independent, dtype=int)
        self.u = np.array(sorted(set(range(self.n)) - set(independent)), dtype=int)
        if self.u.size != m:
            raise AnalysisError(f"partitioning: {self.u.size} dependent coordinates for {m} constraints")
        self.condition = np.linalg.cond(jacobian[:, self.u])
        if not self.condition < SINGULAR_CONDITION:
            names = ", ".join(self.system.coordinate_names[k] for k in self.v)
            raise AnalysisError(
                f"partitioning at t = {t:.6g} s: Psi_u of the dependent coordinates is singular with {names} "
                f"independent (condition number {self.condition:.3g}): the constraints do not fix the others "
                "there; choose other independent coordinates (or none, to let the pivots choose)"
            )
        self.partitions.append((t, [self.system.coordinate_names[k] for k in self.v]))
        self._q, self._jacobian = q.copy(), jacobian

    def initial_state(self, q, qd, t):
        self.partition(q, t)
        return np.concatenate([q[self.v], qd[self.v]])

    # -- from (v, v') to (q, q')
    def coordinates(self, t, y):
        k = self.v.size
        q = self._q.copy()
        q[self.v] = y[:k]
        for _ in range(self.max_iterations):
            psi = self.system.constraints(q, t)
            jacobian = self.system.jacobian(q, t)
            if np.max(np.abs(psi), initial=0.0) < self.tol:
                break
            q[self.u] -= _solve(jacobian[:, self.u], psi, t)
        else:
            raise AnalysisError(
                f"partitioning: Newton-Raphson for the dependent coordinates did not converge at t = {t:.6g} s "
                f"(residual {np.abs(psi).max():.3g})"
            )
        self._q, self._jacobian = q, jacobian  # kept for the next Newton start and for ``accelerations``
        qd = np.empty(self.n)
        qd[self.v] = y[k:]
        qd[self.u] = _solve(jacobian[:, self.u], -jacobian[:, self.v] @ y[k:] - self.system.psi_t(q, t), t)
        return q, qd

    def state_derivative(self, q, qd, qdd):
        return np.concatenate([qd[self.v], qdd[self.v]])

    def rhs(self, t, y):
        """y' = (v', v''). A trial state of the integrator whose v admits no u (an independent coordinate
        pushed beyond the mechanism's reach by a large step) gives NaN, so an adaptive integrator rejects
        the step and retries a shorter one instead of stopping."""
        try:
            return super().rhs(t, y)
        except AnalysisError:
            return np.full(y.size, np.nan)

    def accelerations(self, q, qd, t):
        jacobian = self._jacobian if q is self._q else self.system.jacobian(q, t)  # q just made by coordinates()
        return augmented_accelerations(
            self.mass(q), jacobian, self.applied_forces(q, qd, t), self.system.gamma(q, qd, t)
        )

    def after_step(self, t, y):
        q, qd = self.coordinates(t, y)
        condition = np.linalg.cond(self.system.jacobian(q, t)[:, self.u])
        if condition <= self.repartition_ratio * self.condition:
            return None
        self.repartitions += 1
        return self.initial_state(q, qd, t)


def _solve(matrix: np.ndarray, rhs: np.ndarray, t: float) -> np.ndarray:
    """matrix^-1 rhs, a singular matrix reported as an AnalysisError (with the time) instead of LinAlgError."""
    try:
        return np.linalg.solve(matrix, rhs)
    except np.linalg.LinAlgError:
        raise AnalysisError(f"partitioning at t = {t:.6g} s: Psi_u is singular") from None


FORMULATIONS = {
    "baumgarte": Baumgarte,
    "partitioning": Partitioning,
    "qr": NullSpaceQR,
    "svd": NullSpaceSVD,
    "projection": Projection,
    "augmented-lagrangian": AugmentedLagrangian,
}


def make_formulation(name: str, system: System, M: np.ndarray, forces: ForceModel, **options) -> Formulation:
    """The formulation called ``name`` (one of FORMULATIONS) with its options (alpha, beta, tol, ...)."""
    try:
        cls = FORMULATIONS[name]
    except KeyError:
        raise AnalysisError(f"unknown formulation {name!r} (one of: {', '.join(FORMULATIONS)})") from None
    try:
        return cls(system, M, forces, **options)
    except TypeError as err:
        raise AnalysisError(f"formulation {name!r}: {err}") from None


__all__ = [
    "DEFAULT_ALPHA",
    "DEFAULT_BETA",
    "DEFAULT_PENALTY",
    "AugmentedLagrangian",
    "FORMULATIONS",
    "Baumgarte",
    "Formulation",
    "NullSpaceQR",
    "NullSpaceSVD",
    "Partitioning",
    "Projection",
    "augmented_accelerations",
    "baumgarte_gamma",
    "make_formulation",
    "null_space_accelerations",
    "project_positions",
    "project_velocities",
]

from . import joint_coordinates  # noqa: E402, F401  (it builds on Formulation, defined above, and registers itself)
