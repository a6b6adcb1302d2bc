# Generated from solutions/spatial/mass.py by `make modules` (every homework stubbed): do not edit by hand.
"""The spatial mass matrix in (r, p) form and its quadratic-velocity term.

A body with mass m and inertia matrix J' about its centre of mass, in its body frame, has the kinetic
energy T = 1/2 m r'^T r' + 1/2 omega'^T J' omega'. With omega' = 2 L(p) p' (``rotations``),

    T = 1/2 r'^T (m I) r' + 1/2 p'^T (4 L^T J' L) p'

so its mass matrix in the coordinates q = (r, p) is (course notes, eq. 10.4; Haug 1989, the
Euler-parameter equations of motion, who writes G for our L; Nikravesh 1988)

    M_i = diag(m I_3, M_p),       M_p = 4 L(p)^T J' L(p).

M_p depends on p, and L depends on p, so Lagrange's equations bring a quadratic-velocity term:
since L(p) p' = -L(p') p and L(p') p' = 0, d/dt (dT/dp') - dT/dp = M_p p'' - 8 L(p')^T J' L(p') p,
and the rotational equations of motion read (eq. 10.5)

    4 L^T J' L p'' + Psi_p^T lambda = Q_p + Q_v,        Q_v = 8 L(p')^T J' L(p') p.

Q_v = -4 L(p')^T J' omega' is the gyroscopic term omega' x J' omega' of Euler's equations seen in
p coordinates; it does no work (p'^T Q_v = 0).

M_p is singular: L p = 0, so a change of |p| costs no kinetic energy. The normalization constraint
p^T p - 1 = 0, whose Jacobian row is 2 p^T, removes that direction, so the augmented system is
regular. Formulations that factor M itself (a Cholesky factor, M^-1 in a projection) need a regular
matrix: ``dynamic_mass_matrix`` adds Phi_p^T w Phi_p = 4 w p p^T with w = tr(J') / 3, which gives

    M_p + 4 w p p^T = 4 [p, L^T] diag(w, J') [p, L^T]^T,       [p, L^T] orthogonal for |p| = 1,

positive definite, and changes nothing but the normalization multiplier: on the constraints
(2 p^T p'' = gamma_p) the added term 4 w p p^T p'' = Phi_p^T (w gamma_p) is a multiple of the
constraint's own gradient, which its multiplier absorbs. The accelerations and the multipliers of
every joint and driver are the same as with M_p.
"""

from __future__ import annotations

import functools

import numpy as np

from ..io.model import Model
from ..rotation_matrices import l_entries
from ..rotations import l_matrix


def rotational_mass_matrix(inertia: np.ndarray, p: np.ndarray) -> np.ndarray:
    """M_p = 4 L(p)^T J' L(p) (4 x 4) for the body-frame inertia matrix J' (eq. 10.4)."""
    raise NotImplementedError("rotational_mass_matrix: M_p = 4 L(p)^T J' L(p) (4 x 4) for the body-frame inertia matrix J', see eq. 10.4")


def body_mass_matrix(mass: float, inertia: np.ndarray, p: np.ndarray) -> np.ndarray:
    """M_i = diag(m I_3, 4 L^T J' L) (7 x 7): one spatial body at orientation p (eq. 10.4)."""
    out = np.zeros((7, 7))
    raise NotImplementedError("body_mass_matrix: M_i = diag(m I_3, 4 L^T J' L) (7 x 7): one spatial body at orientation p, see eq. 10.4")
    return out


def quadratic_velocity_force(inertia: np.ndarray, p: np.ndarray, pd: np.ndarray) -> np.ndarray:
    """Q_v = 8 L(p')^T J' L(p') p (4,): the quadratic-velocity term of the p equations (eq. 10.5)."""
    raise NotImplementedError("quadratic_velocity_force: Q_v = 8 L(p')^T J' L(p') p (4,): the quadratic-velocity term of the p equations, see eq. 10.5")


def mass_matrix(model: Model, q: np.ndarray) -> np.ndarray:
    """The (n x n) mass matrix of a spatial model at q, n = 7 nb: body blocks on the diagonal (eq. 10.4)."""
    n = 7 * len(model.bodies)
    M = np.zeros((n, n))
    for k, body in enumerate(model.bodies):
        M[7 * k : 7 * k + 7, 7 * k : 7 * k + 7] = body_mass_matrix(body.mass, body.inertia, q[7 * k + 3 : 7 * k + 7])
    return M


def quadratic_velocity_vector(model: Model, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Q_v of every body stacked (n,), zero in the r rows (eq. 10.5)."""
    out = np.zeros(7 * len(model.bodies))
    for k, body in enumerate(model.bodies):
        p, pd = q[7 * k + 3 : 7 * k + 7], qd[7 * k + 3 : 7 * k + 7]
        out[7 * k + 3 : 7 * k + 7] = quadratic_velocity_force(body.inertia, p, pd)
    return out


def kinetic_energy(model: Model, q: np.ndarray, qd: np.ndarray) -> float:
    """T = sum 1/2 m r'^T r' + 1/2 omega'^T J' omega', omega' = 2 L p' (eq. 10.3)."""
    energy = 0.0
    for k, body in enumerate(model.bodies):
        rd, p, pd = qd[7 * k : 7 * k + 3], q[7 * k + 3 : 7 * k + 7], qd[7 * k + 3 : 7 * k + 7]
        omega = 2.0 * l_matrix(p) @ pd
        energy += 0.5 * body.mass * (rd @ rd) + 0.5 * omega @ body.inertia @ omega
    return float(energy)


def kinetic_energy_history(model: Model, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """T at every row of the histories q, q' (N x 7 nb): ``kinetic_energy`` over all states at once (eq. 10.3)."""
    N, nb = len(q), len(model.bodies)
    q, qd = np.asarray(q).reshape(N, nb, 7), np.asarray(qd).reshape(N, nb, 7)
    L = np.stack(l_entries(*np.moveaxis(q[..., 3:], -1, 0)), axis=-1).reshape(N, nb, 3, 4)  # L(p) of every body
    omega = 2.0 * np.einsum("kbij,kbj->kbi", L, qd[..., 3:])
    masses, inertias = np.array([b.mass for b in model.bodies]), np.array([b.inertia for b in model.bodies])
    translation = np.einsum("b,kbi,kbi->k", masses, qd[..., :3], qd[..., :3])
    return 0.5 * translation + 0.5 * np.einsum("kbi,bij,kbj->k", omega, inertias, omega)


class SpatialMassMatrix:
    """M(q) of a spatial model for dynamic analyses: ``M(q)`` is the regular ``dynamic_mass_matrix``.

    The dynamics layer calls it where a planar model has a constant array; ``kinetic_energy(q, q')``
    is the exact T.
    """

    def __init__(self, model: Model):
        self.model = model
        self.inertias = [np.asarray(body.inertia, dtype=float) for body in model.bodies]
        stacked = np.array(self.inertias).reshape(-1, 3, 3)
        self.weights = (np.trace(stacked, axis1=1, axis2=2) / 3.0).tolist()  # every body's tr(J') / 3 at once

    @functools.cached_property
    def translational(self) -> np.ndarray:
        """The constant m I blocks of every body, zero elsewhere: made at the first M(q) (a compiled run, whose
        module keeps the masses itself, never evaluates one)."""
        diagonal = np.zeros((len(self.model.bodies), 7))
        diagonal[:, :3] = np.array([body.mass for body in self.model.bodies], dtype=float)[:, None]
        return np.diag(diagonal.ravel())

    def __call__(self, q: np.ndarray) -> np.ndarray:
        """``dynamic_mass_matrix(model, q)``, the same numbers, from the m I blocks kept since the start: at every
        state only each body's p block 4 L^T J' L + 4 w p p^T is computed (eq. 10.4), the dynamics' every
        right-hand side (a spatial model's M depends on q)."""
        M = self.translational.copy()
        for k, (inertia, w) in enumerate(zip(self.inertias, self.weights, strict=True)):
            p = q[7 * k + 3 : 7 * k + 7]
            block = rotational_mass_matrix(inertia, p)
            block += 4.0 * w * (p[:, None] * p)  # np.outer(p, p)
            M[7 * k + 3 : 7 * k + 7, 7 * k + 3 : 7 * k + 7] = block
        return M

    def quadratic_velocity(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        return quadratic_velocity_vector(self.model, q, qd)

    def kinetic_energy(self, q: np.ndarray, qd: np.ndarray) -> float:
        return kinetic_energy(self.model, q, qd)

    def kinetic_energy_history(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        return kinetic_energy_history(self.model, q, qd)


def dynamic_mass_matrix(model: Model, q: np.ndarray, weights: list[float] | None = None) -> np.ndarray:
    """M(q) + sum_k Phi_pk^T w_k Phi_pk: the mass matrix made regular along each p_k (module docstring).

    The added block of body k is 4 w_k p_k p_k^T, w_k = tr(J_k') / 3 by default.
    """
    M = mass_matrix(model, q)
    for k, body in enumerate(model.bodies):
        w = float(np.trace(body.inertia)) / 3.0 if weights is None else weights[k]
        p = q[7 * k + 3 : 7 * k + 7]
        M[7 * k + 3 : 7 * k + 7, 7 * k + 3 : 7 * k + 7] += 4.0 * w * np.outer(p, p)
    return M


__all__ = [
    "SpatialMassMatrix",
    "body_mass_matrix",
    "dynamic_mass_matrix",
    "kinetic_energy",
    "kinetic_energy_history",
    "mass_matrix",
    "quadratic_velocity_force",
    "quadratic_velocity_vector",
    "rotational_mass_matrix",
]
