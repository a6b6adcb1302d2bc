"""The mass matrix M of the equations of motion M q'' + Psi_q^T lambda = Q.

In planar body coordinates q_i = (x_i, y_i, phi_i) of the centre of mass the kinetic energy of body i
is T_i = 1/2 m_i (x_i'^2 + y_i'^2) + 1/2 J_i phi_i'^2, so its mass matrix is the constant diagonal block
M_i = diag(m_i, m_i, J_i) (course notes, eq. 5.3), and the system's is block diagonal (eq. 5.4):

    M = diag(M_1, M_2, ..., M_nb)

It does not depend on q, so a dynamic analysis builds it once. A kinematic analysis never needs it.
"""

from __future__ import annotations

import numpy as np

from .io.model import Model


def body_mass_matrix(mass: float, inertia: float) -> np.ndarray:
    """M_i = diag(m_i, m_i, J_i): one planar body, J_i the polar moment about its centre of mass (eq. 5.3)."""
    ### BEGIN SOLUTION hw2
    return np.diag([mass, mass, inertia])
    ### END SOLUTION


def mass_matrix(model: Model) -> np.ndarray:
    """The (n x n) mass matrix of a planar model, n = 3 nb: body blocks on the diagonal (eq. 5.4).

    A spatial model's mass matrix depends on the orientations: for one this returns the callable
    M(q) of ``spatial.mass.SpatialMassMatrix``; ``mass_at(M, q)`` gives the matrix at q either way.
    """
    if model.dimension == 3:
        from .spatial.mass import SpatialMassMatrix

        return SpatialMassMatrix(model)
    n = 3 * len(model.bodies)
    M = np.zeros((n, n))
    ### BEGIN SOLUTION hw2
    for k, body in enumerate(model.bodies):
        M[3 * k : 3 * k + 3, 3 * k : 3 * k + 3] = body_mass_matrix(body.mass, body.inertia)
    ### END SOLUTION
    return M


def singular_inertia(model: Model) -> list[int]:
    """Bodies with mass whose inertia about the centre of mass is singular: a point mass (inertia 0, spatial
    [0, 0, 0]) or a spatial body with a zero principal moment (a slender rod's about its axis). M is then
    singular; the equations of motion stay solvable where it is regular on the motions the joints allow (eq. 5.44)."""
    if all(isinstance(body.inertia, float | int) for body in model.bodies):  # planar moments, as a file gives them
        return _singular_moments(model, [float(body.inertia) for body in model.bodies])
    inertias = [np.atleast_2d(np.asarray(body.inertia, dtype=float)) for body in model.bodies]
    if all(inertia.shape == (1, 1) for inertia in inertias):  # planar moments given as arrays
        return _singular_moments(model, [float(inertia[0, 0]) for inertia in inertias])
    stacked = np.array(inertias)  # every body's 3 x 3 at once (the same LAPACK call per matrix as one by one)
    if np.count_nonzero(stacked) == np.count_nonzero(stacked.diagonal(axis1=1, axis2=2)):  # principal axes, all
        smallest = stacked.diagonal(axis1=1, axis2=2).min(axis=1)  # the moments are the eigenvalues (exactly)
    else:
        smallest = np.linalg.eigvalsh(0.5 * (stacked + np.swapaxes(stacked, 1, 2)))[:, 0]
    scales = np.abs(stacked).max(axis=(1, 2))  # each body's largest |entry|, all at once (no np.max a body)
    return [
        k
        for k, (body, least, scale) in enumerate(zip(model.bodies, smallest.tolist(), scales.tolist(), strict=True))
        if body.has_mass and not least > 1e-12 * scale
    ]


def _singular_moments(model: Model, moments: list[float]) -> list[int]:
    """``singular_inertia`` of planar bodies: a moment is its own eigenvalue and its own largest |entry|."""
    return [
        k
        for k, (body, least) in enumerate(zip(model.bodies, moments, strict=True))
        if body.has_mass and not least > 1e-12 * abs(least)
    ]


def mass_at(M, q: np.ndarray) -> np.ndarray:
    """The mass matrix at q: the constant array of a planar model, M(q) of a spatial one."""
    return M(q) if callable(M) else M


__all__ = ["body_mass_matrix", "mass_at", "mass_matrix", "singular_inertia"]
