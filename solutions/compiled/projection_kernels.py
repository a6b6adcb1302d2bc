"""Compiled pieces of the projection formulation (``formulations.Projection``, eq. 5.50) and of joint coordinates.

The mass-orthogonal correction of least kinetic-energy norm that moves x onto r(x) = 0 to first order,

    x <- x - M^-1 Psi_q^T (Psi_q M^-1 Psi_q^T)^-1 r

(r = Psi for positions, r = Psi_q q' + Psi_t for velocities: ``formulations.project_positions``,
``project_velocities``), with M^-1 the diagonal of a planar scene or a Cholesky factor of the spatial M(q);
and a Cholesky solve for the small symmetric positive definite systems of joint coordinates.

This module imports numba: it is imported only when the compiled engine runs (``solutions.compiled``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .kernels import lu_solve

jit = njit(cache=False, fastmath=False, nogil=True)
"""Not cached here: these functions are compiled into the generated modules that call them, which are cached
under names that hash this file (numba's cache does not follow a cached function's callees into other files:
a cached kernel here could keep an old copy of a function it calls from another file)."""


@jit
def cholesky(A):
    """The lower factor L of A = L L^T (A symmetric positive definite), written over A's lower triangle with
    1 / L_jj on the diagonal (the solves multiply by it); False where A is not positive definite (as LAPACK's
    potrf)."""
    n = A.shape[0]
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= A[j, k] * A[j, k]
        if not s > 0.0:
            return False
        inverse = 1.0 / math.sqrt(s)
        A[j, j] = inverse
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= A[i, k] * A[j, k]
            A[i, j] = s * inverse
    return True


@jit
def cholesky_solve(L, b):
    """x from L L^T x = b, L from ``cholesky`` (b is overwritten with x)."""
    n = b.size
    for i in range(n):
        s = b[i]
        for k in range(i):
            s -= L[i, k] * b[k]
        b[i] = s * L[i, i]
    for i in range(n - 1, -1, -1):
        s = b[i]
        for k in range(i + 1, n):
            s -= L[k, i] * b[k]
        b[i] = s * L[i, i]


@jit
def mass_weighted(inverse_mass, L, spatial, jac):
    """W = M^-1 Psi_q^T (n x m): the diagonal inverse of a planar scene, or the Cholesky factor L of M(q)."""
    m, n = jac.shape
    W = np.empty((n, m))
    column = np.empty(n)
    for r in range(m):
        if spatial:
            for c in range(n):  # loops, not slice assignments (``loops._copy``)
                column[c] = jac[r, c]
            cholesky_solve(L, column)
            for c in range(n):
                W[c, r] = column[c]
        else:
            for c in range(n):
                W[c, r] = jac[r, c] * inverse_mass[c]
    return W


@jit
def correction(W, jac, residual):
    """W (Psi_q W)^-1 r: the mass-orthogonal correction of eq. 5.50."""
    return W @ lu_solve(jac @ W, residual)


__all__ = ["cholesky", "cholesky_solve", "correction", "mass_weighted"]
