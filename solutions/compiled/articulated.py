"""The articulated-body algorithm: theta'' of an open tree in O(N) operations, planar and spatial.

Joint coordinates (``joint_coordinates.py``, course notes ch. 7) give the joint accelerations of a tree from the
embedded equations (eq. 5.44 with Z = D)

    (D^T M D) theta'' = D^T (Q - M xi)                                                  (eq. 7.4)

Assembled as one dense k x k matrix and factored, they cost O(N^2) to build (every column of D through every
body) and O(k^3) to solve: on a chain of 64 bodies, hundreds of microseconds per right-hand side. The tree's
structure solves the same equations in O(N): Featherstone's articulated-body algorithm (R. Featherstone, *Rigid
Body Dynamics Algorithms*, Springer 2008, sec. 7.3 and table 7.1; the recursion MuJoCo and Drake also offer).

Every body b is described at its centre of mass, in global axes: its motion by V = (v, omega) (planar: (v_x, v_y,
omega)), a force on it by F = (f, n), its inertia by I_b = diag(m I, J) (spatial: J = A J' A^T). A joint e joins
parent P and child C; l = r_C - r_P is the link between their centres, S_e the columns of D the joint adds (the
child's motion when only that joint moves: revolute (rho_C x h, h), prismatic (h, 0), spherical three revolute
columns about the child's joint axes). Rigidly carried motion and forces move between the two centres by

    X V = (v - l x omega, omega)        X^T F = (f, n + l x f)                          (eq. 7.7)

so that the θ''-dependent part of every body's acceleration, A_b = (acceleration) - xi_b, satisfies
A_C = X A_P + S_e theta''_e (the recursion of D's columns, ``tree_kernels``), and eq. 5.44 is the tree's
equations of motion with the body forces

    p_b = I_b xi_b - (Q_b - gyroscopic terms)            (the bias force: what the body needs at theta'' = 0)

Two passes then give theta'' exactly (to rounding) as the dense solve does:

1. from the leaves to ground (articulated inertias I^A and bias forces p^A, starting from I_b and p_b):
   U = I^A_C S, D_e = S^T U, u = -S^T p^A_C;                                            (eq. 7.8)
   I^A_P += X^T (I^A_C - U D_e^-1 U^T) X,      p^A_P += X^T (p^A_C + U D_e^-1 u)       (eq. 7.9)
2. from ground to the leaves (A of ground = 0):
   A' = X A_P,   theta''_e = D_e^-1 (u - U^T A'),   A_C = A' + S theta''_e              (eq. 7.10)

Each joint costs a fixed number of 3 x 3 or 6 x 6 operations, whatever N. D_e (1 x 1, or 3 x 3 for a spherical
joint) is factored by Cholesky; a D_e that is not positive definite (a massless end of the tree) gives NaN,
which the adaptive integrators reject, as the dense solve does.

Trees with cut joints (closed loops, drivers) keep the augmented system of ``tree_kernels.cut_accelerations``.

This module imports numba: it is imported only when the compiled engine runs (``solutions.compiled``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .projection_kernels import cholesky, cholesky_solve

jit = njit(cache=False, fastmath=False, nogil=True)
"""Not cached here: compiled into the generated tree modules that call them (see ``tree_kernels.jit``)."""


@jit
def shift_matrix(l, X):
    """X of the link l (module docstring), written into X: 6 x 6 [[1, -[l]x], [0, 1]] on (v, omega); planar 3 x 3
    [[1, 0, -l_y], [0, 1, l_x], [0, 0, 1]] on (v_x, v_y, omega)."""
    X[:] = 0.0
    for i in range(X.shape[0]):
        X[i, i] = 1.0
    if X.shape[0] == 3:
        X[0, 2], X[1, 2] = -l[1], l[0]
    else:
        X[0, 4], X[0, 5] = l[2], -l[1]
        X[1, 3], X[1, 5] = -l[2], l[0]
        X[2, 3], X[2, 4] = l[1], -l[0]


@jit
def articulated_accelerations(IA, pA, ints, S, links, widths, first, thdd, acc):
    """theta'' of an open tree by the two passes of the module docstring (written into ``thdd``), and every body's
    acceleration A_b = (D theta'')_b on the way (``acc``, (nb + 1) x nv, ground last: zero): the outputs' q'' is
    A_b + xi_b, with no D formed (``tree_kernels.planar_body_accelerations``, ``spatial_body_accelerations``).

    IA, pA: every body's inertia I_b and bias force p_b at its centre (nv x nv and nv: nv = 3 planar, 6 spatial),
    nb + 1 of them with ground last (overwritten by the articulated ones); ints: the tree's joints in topological
    order, a row each (kind, parent, child, ...; parent -1 is ground), the joint's first velocity column in column
    ``first``; widths: the columns of each kind; S (joints x nv x 3): the columns S_e; links (joints x 3): l.
    (Written as loops over the entries: at 3 x 3 and 6 x 6 a call into BLAS costs more than the arithmetic.)"""
    ne, nb, nv = ints.shape[0], IA.shape[0] - 1, IA.shape[1]
    U, L, u = np.zeros((ne, nv, 3)), np.zeros((ne, 3, 3)), np.zeros((ne, 3))
    X, Ia, pa, DU, x = np.empty((nv, nv)), np.empty((nv, nv)), np.empty(nv), np.empty((3, nv)), np.empty(3)
    for e in range(ne - 1, -1, -1):  # 1. from the leaves to ground
        P, C, d = ints[e, 1], ints[e, 2], widths[ints[e, 0]]
        if P < 0:
            P = nb
        for c in range(d):  # U = I^A S, u = -S^T p^A, D_e = S^T U (its lower triangle)
            for i in range(nv):
                s = 0.0
                for j in range(nv):
                    s += IA[C, i, j] * S[e, j, c]
                U[e, i, c] = s
            s = 0.0
            for i in range(nv):
                s -= S[e, i, c] * pA[C, i]
            u[e, c] = s
            for c2 in range(c + 1):
                s = 0.0
                for i in range(nv):
                    s += S[e, i, c] * U[e, i, c2]
                L[e, c, c2] = s
        if not cholesky(L[e, :d, :d]):
            thdd[:] = np.nan
            return
        for c in range(d):  # D_e^-1 u, and D_e^-1 U^T column by column
            x[c] = u[e, c]
            for i in range(nv):
                DU[c, i] = U[e, i, c]
        cholesky_solve(L[e, :d, :d], x[:d])
        for i in range(nv):
            cholesky_solve(L[e, :d, :d], DU[:d, i])
        for i in range(nv):  # what the child passes on: Ia = I^A - U D_e^-1 U^T, pa = p^A + U D_e^-1 u
            s = pA[C, i]
            for c in range(d):
                s += U[e, i, c] * x[c]
            pa[i] = s
            for j in range(nv):
                s = IA[C, i, j]
                for c in range(d):
                    s -= U[e, i, c] * DU[c, j]
                Ia[i, j] = s
        shift_matrix(links[e], X)  # to the parent's centre: I^A_P += X^T Ia X, p^A_P += X^T pa
        for i in range(nv):
            s = 0.0
            for a in range(nv):
                s += X[a, i] * pa[a]
            pA[P, i] += s
            for j in range(nv):
                s = 0.0
                for a in range(nv):
                    if X[a, i] != 0.0:
                        for b in range(nv):
                            s += X[a, i] * Ia[a, b] * X[b, j]
                IA[P, i, j] += s
    acc[nb] = 0.0  # 2. from ground to the leaves: A of ground is zero
    shifted = np.empty(nv)
    for e in range(ne):
        P, C, d, at = ints[e, 1], ints[e, 2], widths[ints[e, 0]], ints[e, first]
        if P < 0:
            P = nb
        shift_matrix(links[e], X)
        for i in range(nv):  # A' = X A_P
            s = 0.0
            for j in range(nv):
                s += X[i, j] * acc[P, j]
            shifted[i] = s
        for c in range(d):  # theta'' = D_e^-1 (u - U^T A')
            s = u[e, c]
            for i in range(nv):
                s -= U[e, i, c] * shifted[i]
            x[c] = s
        cholesky_solve(L[e, :d, :d], x[:d])
        for i in range(nv):  # A_C = A' + S theta''
            s = shifted[i]
            for c in range(d):
                s += S[e, i, c] * x[c]
            acc[C, i] = s
        for c in range(d):
            thdd[at + c] = x[c]


__all__ = ["articulated_accelerations", "shift_matrix"]
