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

import math

import numpy as np
from numba import njit

jit = njit(cache=False, fastmath=False, nogil=True)
"""Not cached here: compiled into the generated tree modules that call them (see ``tree_kernels.jit``).

The steps of one joint below index the tree's arrays by joint and body (IA[C, i, j]) rather than take slices of them:
a slice costs ~20 ns of reference counting, more than a 3 x 3 step's arithmetic (the joint's slices were half the
algorithm's time on a planar chain; ``benchmarks/tree_rhs.py``). LLVM inlines them into ``two_passes`` (numba's own
inline="always" made them slower)."""


@jit
def shift_matrix(links, e, X, nv):
    """X of joint e's link l (module docstring), written into X: 6 x 6 [[1, -[l]x], [0, 1]] on (v, omega); planar
    3 x 3 [[1, 0, -l_y], [0, 1, l_x], [0, 0, 1]] on (v_x, v_y, omega)."""
    for i in range(nv):
        for j in range(nv):
            X[i, j] = 1.0 if i == j else 0.0
    l0, l1, l2 = links[e, 0], links[e, 1], links[e, 2]
    if nv == 3:
        X[0, 2], X[1, 2] = -l1, l0
    else:
        X[0, 4], X[0, 5] = l2, -l1
        X[1, 3], X[1, 5] = -l2, l0
        X[2, 3], X[2, 4] = l1, -l0


@jit
def shift_nonzeros(X, rows, counts, nv):
    """X's nonzero entries column by column: rows[j, :counts[j]] the rows (ascending) of column j's nonzeros. X is
    the identity but for the block -[l]x: at most three nonzeros a column, so X^T I X costs ~9 products an entry
    instead of nv^2, and the same numbers as the dense product (the same nonzero terms summed in the same order)."""
    for j in range(nv):
        count = 0
        for a in range(nv):
            if X[a, j] != 0.0:
                rows[j, count] = a
                count += 1
        counts[j] = count


@jit
def joint_terms(IA, pA, S, C, e, d, U, u, L, nv):
    """U = I^A_C S_e, u = -S_e^T p^A_C and D_e = S_e^T U (its lower triangle, into L[e]) of joint e with d columns
    and child C (eq. 7.8)."""
    for c in range(d):
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


@jit
def factor_joint(L, e, d):
    """D_e = L L^T (Cholesky, ``projection_kernels.cholesky``: 1 / L_jj on the diagonal) over L[e]'s lower
    triangle; False where D_e is not positive definite."""
    for j in range(d):
        s = L[e, j, j]
        for k in range(j):
            s -= L[e, j, k] * L[e, j, k]
        if not s > 0.0:
            return False
        inverse = 1.0 / math.sqrt(s)
        L[e, j, j] = inverse
        for i in range(j + 1, d):
            s = L[e, i, j]
            for k in range(j):
                s -= L[e, i, k] * L[e, j, k]
            L[e, i, j] = s * inverse
    return True


@jit
def solve_joint(L, e, d, B, columns):
    """D_e^-1 B: every column of B[:d, :columns] solved in place by forward and back substitution with
    ``factor_joint``'s L (``projection_kernels.cholesky_solve``, column by column)."""
    for col in range(columns):
        for i in range(d):
            s = B[i, col]
            for k in range(i):
                s -= L[e, i, k] * B[k, col]
            B[i, col] = s * L[e, i, i]
        for i in range(d - 1, -1, -1):
            s = B[i, col]
            for k in range(i + 1, d):
                s -= L[e, k, i] * B[k, col]
            B[i, col] = s * L[e, i, i]


@jit
def passed_on(IA, pA, U, u, L, C, e, d, DU, Ia, pa, nv):
    """What child C passes on through joint e (eq. 7.9 before the shift): Ia = I^A_C - U D_e^-1 U^T, pa = p^A_C +
    U D_e^-1 u. DU holds D_e^-1 U^T in its first nv columns and D_e^-1 u in its last."""
    for c in range(d):
        for i in range(nv):
            DU[c, i] = U[e, i, c]
        DU[c, nv] = u[e, c]
    solve_joint(L, e, d, DU, nv + 1)
    for i in range(nv):
        s = pA[C, i]
        for c in range(d):
            s += U[e, i, c] * DU[c, nv]
        pa[i] = s
        for j in range(nv):
            s = IA[C, i, j]
            for c in range(d):
                s -= U[e, i, c] * DU[c, j]
            Ia[i, j] = s


@jit
def shift_to_parent(X, rows, counts, Ia, pa, IA, pA, P, nv):
    """The child's articulated inertia and bias force carried to its parent's centre and added there (eq. 7.9):
    I^A_P += X^T Ia X, p^A_P += X^T pa, over X's nonzeros (``shift_nonzeros``)."""
    for i in range(nv):
        s = 0.0
        for r in range(counts[i]):
            a = rows[i, r]
            s += X[a, i] * pa[a]
        pA[P, i] += s
        for j in range(nv):
            s = 0.0
            for r in range(counts[i]):
                a = rows[i, r]
                for c in range(counts[j]):
                    b = rows[j, c]
                    s += X[a, i] * Ia[a, b] * X[b, j]
            IA[P, i, j] += s


@jit
def child_acceleration(X, acc, U, u, L, S, P, C, e, d, shifted, x, nv):
    """Pass 2 at joint e (eq. 7.10): A' = X A_P, theta''_e = D_e^-1 (u - U^T A') (into x[:d, 0]), A_C = A' +
    S_e theta''_e."""
    for i in range(nv):
        s = 0.0
        for j in range(nv):
            s += X[i, j] * acc[P, j]
        shifted[i] = s
    for c in range(d):
        s = u[e, c]
        for i in range(nv):
            s -= U[e, i, c] * shifted[i]
        x[c, 0] = s
    solve_joint(L, e, d, x, 1)
    for i in range(nv):
        s = shifted[i]
        for c in range(d):
            s += S[e, i, c] * x[c, 0]
        acc[C, i] = s


def two_passes(nv: int):
    """The two passes for bodies of nv velocity components (3 planar, 6 spatial): nv a constant of the compiled
    code, and a joint's columns d (1, or 3 for a spherical joint) constant in each branch, so that every loop has a
    known length and the compiler writes it out (twice as fast as loops whose length is read at run time)."""

    @jit
    def passes(IA, pA, ints, S, links, widths, first, thdd, acc):
        ne, nb = ints.shape[0], IA.shape[0] - 1
        joint = np.empty((ne, nv + 4, 3))  # per joint (eq. 7.8): U, D_e's factor L, u (an allocation costs ~20 ns)
        U, L, u = joint[:, :nv], joint[:, nv : nv + 3], joint[:, nv + 3]
        scratch = np.empty((2 * nv + 4, nv + 1))  # X, Ia, pa, D_e^-1 (U^T, u)
        X, Ia, pa, DU = scratch[:nv, :nv], scratch[nv : 2 * nv, :nv], scratch[2 * nv, :nv], scratch[2 * nv + 1 :]
        pattern = np.empty((nv, 4), dtype=np.int64)  # X's nonzeros: the rows of column j, their count
        rows, counts = pattern[:, :3], pattern[:, 3]
        for e in range(ne - 1, -1, -1):  # 1. from the leaves to ground
            P, C, d = ints[e, 1], ints[e, 2], widths[ints[e, 0]]
            if P < 0:
                P = nb
            if d == 1:
                joint_terms(IA, pA, S, C, e, 1, U, u, L, nv)
                positive = factor_joint(L, e, 1)
                if positive:
                    passed_on(IA, pA, U, u, L, C, e, 1, DU, Ia, pa, nv)
            else:
                joint_terms(IA, pA, S, C, e, 3, U, u, L, nv)
                positive = factor_joint(L, e, 3)
                if positive:
                    passed_on(IA, pA, U, u, L, C, e, 3, DU, Ia, pa, nv)
            if not positive:
                thdd[:] = np.nan
                return
            shift_matrix(links, e, X, nv)  # to the parent's centre
            shift_nonzeros(X, rows, counts, nv)
            shift_to_parent(X, rows, counts, Ia, pa, IA, pA, P, nv)
        acc[nb] = 0.0  # 2. from ground to the leaves: A of ground is zero
        for e in range(ne):
            P, C, d, at = ints[e, 1], ints[e, 2], widths[ints[e, 0]], ints[e, first]
            if P < 0:
                P = nb
            shift_matrix(links, e, X, nv)
            if d == 1:
                child_acceleration(X, acc, U, u, L, S, P, C, e, 1, pa, DU, nv)
            else:
                child_acceleration(X, acc, U, u, L, S, P, C, e, 3, pa, DU, nv)
            for c in range(d):
                thdd[at + c] = DU[c, 0]

    return passes


planar_passes, spatial_passes = two_passes(3), two_passes(6)


def articulated_accelerations(IA, pA, ints, S, links, widths, first, thdd, acc):
    """theta'' of an open tree by the two passes of the module docstring (written into ``thdd``), and every body's
    acceleration A_b = (D theta'')_b on the way (``acc``, (nb + 1) x nv, ground last: zero): the outputs' q'' is
    A_b + xi_b, with no D formed (``tree_kernels.planar_body_accelerations``, ``spatial_body_accelerations``).

    IA, pA: every body's inertia I_b and bias force p_b at its centre (nv x nv and nv: nv = 3 planar, 6 spatial),
    nb + 1 of them with ground last (overwritten by the articulated ones); ints: the tree's joints in topological
    order, a row each (kind, parent, child, ...; parent -1 is ground), the joint's first velocity column in column
    ``first``; widths: the columns of each kind; S (joints x nv x 3): the columns S_e; links (joints x 3): l.
    (Written as loops over the entries: at 3 x 3 and 6 x 6 a call into BLAS costs more than the arithmetic.) The
    tree kernels call ``planar_passes`` or ``spatial_passes`` directly (a module compiles only its own); this
    chooser is for callers in Python."""
    passes = planar_passes if IA.shape[1] == 3 else spatial_passes
    passes(IA, pA, ints, S, links, widths, first, thdd, acc)


__all__ = ["articulated_accelerations", "planar_passes", "shift_matrix", "spatial_passes"]
