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

A spherical joint takes the same two passes at its joint point instead of the child's centre
(``spherical_passed_on``, ``spherical_acceleration``): there S_e = [0; F] (F its three axes), the joint transmits
no moment, and what the child passes on is a 3 x 3 translational block, F dropping out of U D_e^-1 U^T: about a
third of the 6 x 6 route's products (Featherstone 2008, sec. 7.3: each joint's quantities where its S is simplest).
The same theta'' to rounding (the products in another order).

A planar revolute joint takes them at its joint point too (``revolute_passed_on``, ``revolute_point_to_parent``,
``revolute_acceleration``). Motion at the point J = r_C + rho_C reaches the child's centre by X_c = [[1, b], [0,
1]] on (v_x, v_y, omega), b = (rho_y, -rho_x) (v_C = v_J + omega k x (-rho_C)), and there S_e = (0, 0, 1): X_c (0,
0, 1) = (b, 1) is the joint's column at the centre. Seen at J the child's articulated inertia and bias force read

    I' = X_c^T I^A_C X_c = [[I_vv, G], [G^T, K]],      G = I_vv b + I_vw,   K = I_ww + I_wv b + b^T G,
    p' = X_c^T p^A_C = (p_v, p'_w),                    p'_w = p_w + b^T p_v                             (eq. 7.7)

so that eq. 7.8 gives U = (G, K), D_e = K, u = -p'_w, and eq. 7.9 what the child passes on at J: the joint
transmits no moment, and U D_e^-1 U^T = [[G G^T / K, G], [G^T, K]] takes away the angular row and column whole,

    Ia = [[M, 0], [0, 0]],   M = I_vv - G G^T / K,      pa = (p_v - G p'_w / K, 0)                   (eq. 7.9 at J)

a 2 x 2 block and a force, carried on to the parent's centre by X_p = [[1, B], [0, 1]], B = (-e_y, e_x) (e = e_P
= l + rho_C, the joint point from the parent's centre): I^A_P += [[M, M B], [B^T M, B^T M B]], p^A_P += (pa_v,
B^T pa_v). Pass 2 (eq. 7.10 at J): the point's acceleration a_J = a_P + alpha_P B, the child's angular acceleration
from the zero moment G^T a_J + K alpha_C + p'_w = 0, theta''_e = alpha_C - alpha_P, and A_C = (a_J + alpha_C b,
alpha_C). About half the products of the 3 x 3 route, no square root (D_e = K is a number). A prismatic
joint keeps the 3 x 3 route at the child's centre (its S_e = (u, 0) has no point where it is simpler).

Trees with cut joints (closed loops, drivers) keep the augmented system of ``tree_kernels.cut_accelerations``.

This module imports numba: it is imported only when the compiled engine runs (``solutions.compiled``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

jit = njit(cache=False, fastmath=False, nogil=True)
inlined = njit(cache=False, fastmath=False, nogil=True, inline="always")
"""A spherical joint's steps, written into the passes (``tree_kernels.inlined``: each array handed to a compiled
function costs two atomic reference counts): -60 ns a chain of four spherical joints. The general route's steps stay
functions (inlined they were slower, twenty-first session)."""
"""Not cached here: compiled into the generated tree modules that call them (see ``tree_kernels.jit``).

Every array of the passes is one of two work arrays, indexed by body or joint and a named row (``body_rows``,
``joint_rows``, ``scratch_rows``), never a slice or a view of them: in numba each array handed to a function that is
not inlined, and each view kept across a loop, costs two atomic reference counts (~10 ns), more than a planar joint's
arithmetic (the views and the eleven arrays handed on were two thirds of the passes' time on a planar chain of two
bodies; ``benchmarks/tree_rhs.py``)."""

WIDTHS = np.array([1, 1, 3])
"""The velocity columns d of a joint of each kind (``tree_kernels``: 0 revolute, 1 prismatic, 2 spherical): a
revolute joint's angle, a prismatic joint's slide, a spherical joint's three rates."""


@jit
def body_rows(nv):
    """The rows of a body's entry of ``body`` ((nb + 1) entries of ``sizes(nv)[0]`` rows x nv, ground last): its
    articulated inertia I^A (rows IA to IA + nv - 1), bias force p^A (row PA), acceleration A = (D theta'')_b (row
    ACC)."""
    return 0, nv, nv + 1


@jit
def joint_rows(nv):
    """The rows of a joint's entry of ``joint`` (ne + 1 entries of ``sizes(nv)[1]`` rows x nv): its columns S_e (nv
    rows, d columns), U = I^A S_e (nv rows, d columns), D_e's factor L (d x d), u (d entries of a row), the link l
    (3 entries of a row): eq. 7.8; and the joint point from either centre, rho_C and e_P = l + rho_C (a row:
    ``spherical_passed_on``), planar e_P alone (``revolute_passed_on``: rho_C is in S_e)."""
    return 0, nv, 2 * nv, 2 * nv + 3, 2 * nv + 4, 2 * nv + 5


@jit
def scratch_rows(nv):
    """The rows of the passes' scratch, the entry after the last joint of ``joint``: X's block B (3 x 3), what the
    child passes on Ia (nv x nv) and pa (a row), D_e^-1 U^T (d rows x nv) and D_e^-1 u (d rows, column 0)."""
    return 0, 3, 3 + nv, 4 + nv, 7 + nv


def sizes(nv: int) -> tuple[int, int]:
    """The rows of an entry of ``body`` and of ``joint`` (``body_rows``, ``joint_rows``, ``scratch_rows``)."""
    return nv + 2, max(2 * nv + 6, nv + 10)


@jit
def shift_block(joint, e, s, nv):
    """X of joint e's link l (eq. 7.7) is the identity but for its block B = -[l]x, which moves the angular part
    into the linear one: X = [[1, B], [0, 1]] on (v, omega), B 3 x 3 [[0, l_z, -l_y], [-l_z, 0, l_x], [l_y, -l_x,
    0]] spatial, 2 x 1 (-l_y, l_x) planar on (v_x, v_y, omega); written into the scratch (entry s). The passes
    multiply by X through it (``shift_to_parent``, ``child_acceleration``): ~3 products an entry instead of nv."""
    link, B = joint_rows(nv)[4], scratch_rows(nv)[0]
    l0, l1, l2 = joint[e, link, 0], joint[e, link, 1], joint[e, link, 2]
    if nv == 3:
        joint[s, B, 0], joint[s, B + 1, 0] = -l1, l0
    else:
        joint[s, B, 0], joint[s, B, 1], joint[s, B, 2] = 0.0, l2, -l1
        joint[s, B + 1, 0], joint[s, B + 1, 1], joint[s, B + 1, 2] = -l2, 0.0, l0
        joint[s, B + 2, 0], joint[s, B + 2, 1], joint[s, B + 2, 2] = l1, -l0, 0.0


@jit
def joint_terms(body, joint, C, e, d, nv):
    """U = I^A_C S_e, u = -S_e^T p^A_C and D_e = S_e^T U (its lower triangle, into L) of joint e with d columns
    and child C (eq. 7.8)."""
    IA, PA, _ = body_rows(nv)
    S, U, L, u, _, _ = joint_rows(nv)
    for c in range(d):
        for i in range(nv):
            x = 0.0
            for j in range(nv):
                x += body[C, IA + i, j] * joint[e, S + j, c]
            joint[e, U + i, c] = x
        x = 0.0
        for i in range(nv):
            x -= joint[e, S + i, c] * body[C, PA, i]
        joint[e, u, c] = x
        for c2 in range(c + 1):
            x = 0.0
            for i in range(nv):
                x += joint[e, S + i, c] * joint[e, U + i, c2]
            joint[e, L + c, c2] = x


@jit
def factor_joint(joint, e, d, nv):
    """D_e = L L^T (Cholesky, ``projection_kernels.cholesky``: 1 / L_jj on the diagonal) over L's lower triangle;
    False where D_e is not positive definite."""
    L = joint_rows(nv)[2]
    for j in range(d):
        x = joint[e, L + j, j]
        for k in range(j):
            x -= joint[e, L + j, k] * joint[e, L + j, k]
        if not x > 0.0:
            return False
        inverse = 1.0 / math.sqrt(x)
        joint[e, L + j, j] = inverse
        for i in range(j + 1, d):
            x = joint[e, L + i, j]
            for k in range(j):
                x -= joint[e, L + i, k] * joint[e, L + j, k]
            joint[e, L + i, j] = x * inverse
    return True


@jit
def solve_joint(joint, e, d, s, row, col, nv):
    """D_e^-1 x in place, x the d entries joint[s, row : row + d, col] (a column of the scratch), by forward and
    back substitution with ``factor_joint``'s L (``projection_kernels.cholesky_solve``)."""
    L = joint_rows(nv)[2]
    for i in range(d):
        x = joint[s, row + i, col]
        for k in range(i):
            x -= joint[e, L + i, k] * joint[s, row + k, col]
        joint[s, row + i, col] = x * joint[e, L + i, i]
    for i in range(d - 1, -1, -1):
        x = joint[s, row + i, col]
        for k in range(i + 1, d):
            x -= joint[e, L + k, i] * joint[s, row + k, col]
        joint[s, row + i, col] = x * joint[e, L + i, i]


@jit
def passed_on(body, joint, C, e, d, s, nv):
    """What child C passes on through joint e (eq. 7.9 before the shift), into the scratch (entry s): Ia = I^A_C -
    U D_e^-1 U^T, pa = p^A_C + U D_e^-1 u, by way of D_e^-1 U^T (DU) and D_e^-1 u (Du)."""
    IA, PA, _ = body_rows(nv)
    _, U, _, u, _, _ = joint_rows(nv)
    _, Ia, pa, DU, Du = scratch_rows(nv)
    for c in range(d):
        for i in range(nv):
            joint[s, DU + c, i] = joint[e, U + i, c]
        joint[s, Du + c, 0] = joint[e, u, c]
    for i in range(nv):
        solve_joint(joint, e, d, s, DU, i, nv)
    solve_joint(joint, e, d, s, Du, 0, nv)
    for i in range(nv):
        x = body[C, PA, i]
        for c in range(d):
            x += joint[e, U + i, c] * joint[s, Du + c, 0]
        joint[s, pa, i] = x
        for j in range(nv):
            x = body[C, IA + i, j]
            for c in range(d):
                x -= joint[e, U + i, c] * joint[s, DU + c, j]
            joint[s, Ia + i, j] = x


@jit
def shift_to_parent(body, joint, P, s, nv, nw):
    """The child's articulated inertia and bias force (the scratch's Ia, pa) carried to its parent's centre and added
    there (eq. 7.9): I^A_P += X^T Ia X, p^A_P += X^T pa, with X = [[1, B], [0, 1]] (``shift_block``; nw angular
    components, the first nv - nw linear): Ia X changes only Ia's last nw columns (each plus Ia's linear columns
    times B), and X^T (Ia X) only the last nw rows. Ia is overwritten by Ia X."""
    IA, PA, _ = body_rows(nv)
    B, Ia, pa, _, _ = scratch_rows(nv)
    n1 = nv - nw
    for j in range(n1, nv):  # Ia X
        for i in range(nv):
            x = joint[s, Ia + i, j]
            for a in range(n1):
                x += joint[s, Ia + i, a] * joint[s, B + a, j - n1]
            joint[s, Ia + i, j] = x
    for i in range(n1):  # X^T (Ia X) and X^T pa: the linear rows as they are
        body[P, PA, i] += joint[s, pa, i]
        for j in range(nv):
            body[P, IA + i, j] += joint[s, Ia + i, j]
    for i in range(n1, nv):  # the angular rows plus B^T times the linear ones
        x = joint[s, pa, i]
        for a in range(n1):
            x += joint[s, B + a, i - n1] * joint[s, pa, a]
        body[P, PA, i] += x
        for j in range(nv):
            x = joint[s, Ia + i, j]
            for a in range(n1):
                x += joint[s, B + a, i - n1] * joint[s, Ia + a, j]
            body[P, IA + i, j] += x


@jit
def child_acceleration(body, joint, P, C, e, d, s, nv, nw):
    """Pass 2 at joint e (eq. 7.10): A' = X A_P (``shift_block``: the linear part plus B times the angular one; into
    the scratch's pa), theta''_e = D_e^-1 (u - U^T A') (into its Du), A_C = A' + S_e theta''_e."""
    _, _, ACC = body_rows(nv)
    S, U, _, u, _, _ = joint_rows(nv)
    B, _, shifted, _, x = scratch_rows(nv)
    n1 = nv - nw
    for i in range(n1):
        a = body[P, ACC, i]
        for j in range(nw):
            a += joint[s, B + i, j] * body[P, ACC, n1 + j]
        joint[s, shifted, i] = a
    for i in range(n1, nv):
        joint[s, shifted, i] = body[P, ACC, i]
    for c in range(d):
        a = joint[e, u, c]
        for i in range(nv):
            a -= joint[e, U + i, c] * joint[s, shifted, i]
        joint[s, x + c, 0] = a
    solve_joint(joint, e, d, s, x, 0, nv)
    for i in range(nv):
        a = joint[s, shifted, i]
        for c in range(d):
            a += joint[e, S + i, c] * joint[s, x + c, 0]
        body[C, ACC, i] = a


@jit
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@inlined
def spherical_passed_on(body, joint, C, e, s):
    """Pass 1 at a spherical joint e with child C (eq. 7.8-7.9), at the joint point J = r_C + rho_C, where the joint's
    columns are S_e = [0; F] (F = [x_0 x_1 x_2] the child's joint axes, global): there the child's inertia reads
    I' = X_c^T I^A_C X_c = [[I_vv, G], [G^T, K]] and its bias force p' = X_c^T p^A_C (X_c = [[1, [rho_C]x], [0, 1]]
    carries motion at J to the centre: G = I_vv [rho_C]x + I_vw, K = I_ww + I_wv [rho_C]x + [rho_C]x^T G, p'_w = p_w
    + [rho_C]x^T p_v). With U = I' S_e, D_e = F^T K F, U D_e^-1 U^T = I'_:w K^-1 I'_w: for any invertible F: F drops
    out, and what the child passes on (eq. 7.9) at J is a translational block alone, the joint transmitting no
    moment:

        Ia = [[I_vv - G K^-1 G^T, 0], [0, 0]],        pa = [p_v - G K^-1 p'_w; 0]                   (eq. 7.9 at J)

    (Featherstone 2008, sec. 7.3: a joint's articulated inertia in the frame where S is simplest). Into the
    scratch (entry s: Ia's and pa's first three rows and columns; D_e^-1 U^T's rows hold K^-1 G^T, D_e^-1 u's K^-1
    p'_w); into the joint's rows G (U's first three), K's factor (``factor_joint``) and p'_w (u) for pass 2. About
    a third of the 6 x 6 route's products. False where K is not positive definite."""
    IA, PA, _ = body_rows(6)
    _, U, L, u, _, ARM = joint_rows(6)
    _, Ia, pa, DU, Du = scratch_rows(6)
    r0, r1, r2 = joint[e, ARM, 0], joint[e, ARM, 1], joint[e, ARM, 2]  # rho_C
    for i in range(6):  # I^A_C X_c's angular columns, row by row: row_i [rho]x = row_i x rho (rows 0-2: G)
        x0, x1, x2 = _cross(body[C, IA + i, 0], body[C, IA + i, 1], body[C, IA + i, 2], r0, r1, r2)
        joint[e, U + i, 0] = x0 + body[C, IA + i, 3]
        joint[e, U + i, 1] = x1 + body[C, IA + i, 4]
        joint[e, U + i, 2] = x2 + body[C, IA + i, 5]
    for j in range(3):  # K = (its angular rows) + [rho]x^T G, column by column: [rho]x^T g = g x rho
        x0, x1, x2 = _cross(joint[e, U, j], joint[e, U + 1, j], joint[e, U + 2, j], r0, r1, r2)
        joint[e, L, j], joint[e, L + 1, j], joint[e, L + 2, j] = (
            joint[e, U + 3, j] + x0, joint[e, U + 4, j] + x1, joint[e, U + 5, j] + x2,
        )  # fmt: skip
    x0, x1, x2 = _cross(body[C, PA, 0], body[C, PA, 1], body[C, PA, 2], r0, r1, r2)
    joint[e, u, 0], joint[e, u, 1], joint[e, u, 2] = body[C, PA, 3] + x0, body[C, PA, 4] + x1, body[C, PA, 5] + x2
    if not factor_joint(joint, e, 3, 6):
        return False
    for c in range(3):  # K^-1 G^T and K^-1 p'_w
        for i in range(3):
            joint[s, DU + c, i] = joint[e, U + i, c]
        joint[s, Du + c, 0] = joint[e, u, c]
    for i in range(3):
        solve_joint(joint, e, 3, s, DU, i, 6)
    solve_joint(joint, e, 3, s, Du, 0, 6)
    for i in range(3):  # the translational block M and p_v - G K^-1 p'_w (``shift_point_to_parent``)
        x = body[C, PA, i]
        for c in range(3):
            x -= joint[e, U + i, c] * joint[s, Du + c, 0]
        joint[s, pa, i] = x
        for j in range(3):
            x = body[C, IA + i, j]
            for c in range(3):
                x -= joint[e, U + i, c] * joint[s, DU + c, j]
            joint[s, Ia + i, j] = x
    return True


@inlined
def shift_point_to_parent(body, joint, P, e, s):
    """``shift_to_parent`` of a translational block alone (``spherical_passed_on``: Ia = [[M, 0], [0, 0]], pa = (p,
    0) at joint e's point, in the scratch), carried to the parent's centre by X = [[1, B], [0, 1]], B = -[e_P]x:
    I^A_P += [[M, M B], [B^T M, B^T M B]], p^A_P += (p, B^T p), with B^T x = e_P x x and a row times B, a B = e_P x
    a: ``shift_to_parent``'s sums without B's zero diagonal (the same numbers)."""
    IA, PA, _ = body_rows(6)
    ARM = joint_rows(6)[5]
    _, Ia, pa, _, _ = scratch_rows(6)
    e0, e1, e2 = joint[e, ARM, 3], joint[e, ARM, 4], joint[e, ARM, 5]
    for i in range(3):  # M B into Ia's angular columns, row by row
        x0, x1, x2 = _cross(e0, e1, e2, joint[s, Ia + i, 0], joint[s, Ia + i, 1], joint[s, Ia + i, 2])
        joint[s, Ia + i, 3], joint[s, Ia + i, 4], joint[s, Ia + i, 5] = x0, x1, x2
    for i in range(3):
        body[P, PA, i] += joint[s, pa, i]
        for j in range(6):
            body[P, IA + i, j] += joint[s, Ia + i, j]
    x0, x1, x2 = _cross(e0, e1, e2, joint[s, pa, 0], joint[s, pa, 1], joint[s, pa, 2])  # B^T p
    body[P, PA, 3], body[P, PA, 4], body[P, PA, 5] = body[P, PA, 3] + x0, body[P, PA, 4] + x1, body[P, PA, 5] + x2
    for j in range(6):  # B^T times the linear rows, column by column
        x0, x1, x2 = _cross(e0, e1, e2, joint[s, Ia, j], joint[s, Ia + 1, j], joint[s, Ia + 2, j])
        body[P, IA + 3, j] += x0
        body[P, IA + 4, j] += x1
        body[P, IA + 5, j] += x2


@inlined
def spherical_acceleration(body, joint, P, C, e, s):
    """Pass 2 at a spherical joint e (eq. 7.10 at its joint point, ``spherical_passed_on``): the joint point's
    acceleration a_J = (X A_P)_v = a_P + alpha_P x e_P, the child's angular acceleration from the joint's zero moment,
    G^T a_J + K alpha_C + p'_w = 0, theta''_e = F^T (alpha_C - alpha_P) (the rates about the orthonormal axes F: S_e's
    angular rows), into the scratch's D_e^-1 u rows; A_C at the centre = (a_J + rho_C x alpha_C, alpha_C)."""
    _, _, ACC = body_rows(6)
    S, U, _, u, _, ARM = joint_rows(6)
    _, _, shifted, _, x = scratch_rows(6)
    x0, x1, x2 = _cross(body[P, ACC, 3], body[P, ACC, 4], body[P, ACC, 5], joint[e, ARM, 3], joint[e, ARM, 4],
                        joint[e, ARM, 5])  # fmt: skip
    joint[s, shifted, 0], joint[s, shifted, 1], joint[s, shifted, 2] = (
        body[P, ACC, 0] + x0, body[P, ACC, 1] + x1, body[P, ACC, 2] + x2,
    )  # fmt: skip
    for c in range(3):
        a = joint[e, u, c]
        for i in range(3):
            a += joint[e, U + i, c] * joint[s, shifted, i]
        joint[s, x + c, 0] = a
    solve_joint(joint, e, 3, s, x, 0, 6)
    w0, w1, w2 = -joint[s, x, 0], -joint[s, x + 1, 0], -joint[s, x + 2, 0]  # alpha_C
    d0, d1, d2 = w0 - body[P, ACC, 3], w1 - body[P, ACC, 4], w2 - body[P, ACC, 5]
    for n in range(3):
        joint[s, x + n, 0] = joint[e, S + 3, n] * d0 + joint[e, S + 4, n] * d1 + joint[e, S + 5, n] * d2
    x0, x1, x2 = _cross(joint[e, ARM, 0], joint[e, ARM, 1], joint[e, ARM, 2], w0, w1, w2)
    body[C, ACC, 0], body[C, ACC, 1], body[C, ACC, 2] = (
        joint[s, shifted, 0] + x0, joint[s, shifted, 1] + x1, joint[s, shifted, 2] + x2,
    )  # fmt: skip
    body[C, ACC, 3], body[C, ACC, 4], body[C, ACC, 5] = w0, w1, w2


@inlined
def revolute_passed_on(body, joint, C, e):
    """Pass 1 at a planar revolute joint e with child C (eq. 7.8-7.9 at its joint point J, module docstring): G, K
    and p'_w of I^A_C and p^A_C seen at J (b = S_e's linear part, I^A read by its upper triangle: it is symmetric),
    kept in the joint's rows U (G), L (1 / K) and u (p'_w) for pass 2; returns (K > 0, M's entries m00, m01, m11
    and pa_v): what the child passes on at J, a 2 x 2 translational block and a force."""
    IA, PA, _ = body_rows(3)
    S, U, L, u, _, _ = joint_rows(3)
    b0, b1 = joint[e, S, 0], joint[e, S + 1, 0]
    I00, I01, I02 = body[C, IA, 0], body[C, IA, 1], body[C, IA, 2]
    I11, I12, I22 = body[C, IA + 1, 1], body[C, IA + 1, 2], body[C, IA + 2, 2]
    g0, g1 = I00 * b0 + I01 * b1 + I02, I01 * b0 + I11 * b1 + I12  # G = I_vv b + I_vw
    K = I22 + b0 * (I02 + g0) + b1 * (I12 + g1)  # I_ww + I_wv b + b^T G
    pw = body[C, PA, 2] + (b0 * body[C, PA, 0] + b1 * body[C, PA, 1])  # p'_w = p_w + b^T p_v
    if not K > 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    inverse = 1.0 / K
    joint[e, U, 0], joint[e, U + 1, 0], joint[e, L, 0], joint[e, u, 0] = g0, g1, inverse, pw
    h0, h1 = g0 * inverse, g1 * inverse  # G / K
    return True, I00 - h0 * g0, I01 - h0 * g1, I11 - h1 * g1, body[C, PA, 0] - h0 * pw, body[C, PA, 1] - h1 * pw


@inlined
def revolute_point_to_parent(body, joint, P, e, m00, m01, m11, pa0, pa1):
    """The child's block M and force pa_v at joint e's point (``revolute_passed_on``) carried to the parent's centre
    and added there (eq. 7.9): I^A_P += [[M, M B], [B^T M, B^T M B]], p^A_P += (pa_v, B^T pa_v), B = (-e_y, e_x)
    from e_P (the joint's row ARM). M symmetric: B^T M is (M B)^T, the same two numbers."""
    IA, PA, _ = body_rows(3)
    ARM = joint_rows(3)[5]
    e0, e1 = joint[e, ARM, 0], joint[e, ARM, 1]
    c0, c1 = e0 * m01 - e1 * m00, e0 * m11 - e1 * m01  # M B
    body[P, IA, 0] += m00
    body[P, IA, 1] += m01
    body[P, IA, 2] += c0
    body[P, IA + 1, 0] += m01
    body[P, IA + 1, 1] += m11
    body[P, IA + 1, 2] += c1
    body[P, IA + 2, 0] += c0
    body[P, IA + 2, 1] += c1
    body[P, IA + 2, 2] += e0 * c1 - e1 * c0
    body[P, PA, 0] += pa0
    body[P, PA, 1] += pa1
    body[P, PA, 2] += e0 * pa1 - e1 * pa0


@inlined
def revolute_acceleration(body, joint, P, C, e):
    """Pass 2 at a planar revolute joint e (eq. 7.10 at its joint point, module docstring): a_J = a_P + alpha_P B,
    alpha_C = -(G^T a_J + p'_w) / K, A_C = (a_J + alpha_C b, alpha_C); returns theta''_e = alpha_C - alpha_P."""
    _, _, ACC = body_rows(3)
    S, U, L, u, _, ARM = joint_rows(3)
    alpha = body[P, ACC, 2]
    a0 = body[P, ACC, 0] - alpha * joint[e, ARM, 1]
    a1 = body[P, ACC, 1] + alpha * joint[e, ARM, 0]
    alpha_c = -(joint[e, U, 0] * a0 + joint[e, U + 1, 0] * a1 + joint[e, u, 0]) * joint[e, L, 0]
    body[C, ACC, 0] = a0 + alpha_c * joint[e, S, 0]
    body[C, ACC, 1] = a1 + alpha_c * joint[e, S + 1, 0]
    body[C, ACC, 2] = alpha_c
    return alpha_c - alpha


@inlined
def planar_passes(body, joint, ints, first, thdd):
    """theta'' of an open planar tree (into ``thdd``), as ``two_passes``' but a revolute joint at its joint point
    (``revolute_passed_on``: S_e = (0, 0, 1) there; its row ARM e_P, the joint point from the parent's centre), a
    prismatic one by the 3 x 3 route at the child's centre. Written into the caller (``tree_kernels.
    planar_articulated``, itself in scene_rhs): the four arrays it was handed cost more than its arithmetic at two
    bodies (rhs N = 2 0.32 -> 0.29 us, N = 16 1.04 -> 0.97; the prismatic route's steps stay functions)."""
    ne, nb = ints.shape[0], body.shape[0] - 1
    _, _, ACC = body_rows(3)
    x = scratch_rows(3)[4]
    for e in range(ne - 1, -1, -1):  # 1. from the leaves to ground
        P, C = ints[e, 1], ints[e, 2]
        if P < 0:
            P = nb
        if ints[e, 0] == 0:  # revolute
            positive, m00, m01, m11, pa0, pa1 = revolute_passed_on(body, joint, C, e)
            if positive:
                revolute_point_to_parent(body, joint, P, e, m00, m01, m11, pa0, pa1)
        else:  # prismatic
            joint_terms(body, joint, C, e, 1, 3)
            positive = factor_joint(joint, e, 1, 3)
            if positive:
                passed_on(body, joint, C, e, 1, ne, 3)
                shift_block(joint, e, ne, 3)
                shift_to_parent(body, joint, P, ne, 3, 1)
        if not positive:
            thdd[:] = np.nan
            return
    for i in range(3):  # 2. from ground to the leaves: A of ground is zero
        body[nb, ACC, i] = 0.0
    for e in range(ne):
        P, C, at = ints[e, 1], ints[e, 2], ints[e, first]
        if P < 0:
            P = nb
        if ints[e, 0] == 0:
            thdd[at] = revolute_acceleration(body, joint, P, C, e)
        else:
            shift_block(joint, e, ne, 3)
            child_acceleration(body, joint, P, C, e, 1, ne, 3, 1)
            thdd[at] = joint[ne, x, 0]


def two_passes(nv: int):
    """The two passes for bodies of nv velocity components (6 spatial; 3 would be the planar passes by the 3 x 3
    route at every joint, which ``planar_passes`` keeps for prismatic joints alone): nv a constant of the compiled
    code, and a joint's columns d (1, or 3 for a spherical joint) constant in each branch, so that every loop has a
    known length and the compiler writes it out (twice as fast as loops whose length is read at run time)."""
    nw = 1 if nv == 3 else 3  # the angular components: omega (planar), omega's three (spatial)

    @jit
    def passes(body, joint, ints, first, thdd):
        """theta'' (into ``thdd``) from ``body``'s I_b and p_b (``body_rows``; overwritten by I^A, p^A and A) and
        ``joint``'s S_e and links (``joint_rows``; its last entry the scratch): the caller's work arrays."""
        ne, nb = ints.shape[0], body.shape[0] - 1
        _, _, ACC = body_rows(nv)
        x = scratch_rows(nv)[4]
        for e in range(ne - 1, -1, -1):  # 1. from the leaves to ground
            P, C, d = ints[e, 1], ints[e, 2], WIDTHS[ints[e, 0]]
            if P < 0:
                P = nb
            if d == 1:
                joint_terms(body, joint, C, e, 1, nv)
                positive = factor_joint(joint, e, 1, nv)
                if positive:
                    passed_on(body, joint, C, e, 1, ne, nv)
                shift_block(joint, e, ne, nv)  # to the parent's centre
            else:  # a spherical joint (space only): at its joint point, then from there to the parent's centre
                positive = spherical_passed_on(body, joint, C, e, ne)
            if not positive:
                thdd[:] = np.nan
                return
            if d == 1:
                shift_to_parent(body, joint, P, ne, nv, nw)
            else:
                shift_point_to_parent(body, joint, P, e, ne)
        for i in range(nv):  # 2. from ground to the leaves: A of ground is zero
            body[nb, ACC, i] = 0.0
        for e in range(ne):
            P, C, d, at = ints[e, 1], ints[e, 2], WIDTHS[ints[e, 0]], ints[e, first]
            if P < 0:
                P = nb
            if d == 1:
                shift_block(joint, e, ne, nv)
                child_acceleration(body, joint, P, C, e, 1, ne, nv, nw)
            else:
                spherical_acceleration(body, joint, P, C, e, ne)
            for c in range(d):
                thdd[at + c] = joint[ne, x + c, 0]

    return passes


spatial_passes = two_passes(6)
"""(``planar_passes`` is written out above: a revolute joint at its point, which the spatial passes do not yet do.)"""


def articulated_accelerations(IA, pA, ints, S, links, widths, first, thdd, acc):
    """theta'' of an open tree by the two passes of the module docstring (written into ``thdd``), and every body's
    acceleration A_b = (D theta'')_b on the way (``acc``, (nb + 1) x nv, ground last: zero): the outputs' q'' is
    A_b + xi_b, with no D formed (``tree_kernels.planar_body_accelerations``, ``spatial_body_accelerations``).

    IA, pA: every body's inertia I_b and bias force p_b at its centre (nv x nv and nv: nv = 3 planar, 6 spatial),
    nb + 1 of them with ground last (overwritten by the articulated ones); ints: the tree's joints in topological
    order, a row each (kind, parent, child, ...; parent -1 is ground), the joint's first velocity column in column
    ``first``; widths: the columns of each kind (``WIDTHS``, which the passes read); S (joints x nv x 3): the
    columns S_e; links (joints x 3): l. (Written as loops over the entries: at 3 x 3 and 6 x 6 a call into BLAS
    costs more than the arithmetic.) The tree kernels fill the work arrays themselves and call ``planar_passes`` or
    ``spatial_passes`` directly (a module compiles only its own); this is for callers in Python: it copies the
    arrays into the work arrays (``sizes``, ``body_rows``, ``joint_rows``) and back. A spherical joint's point
    (``spherical_passed_on``) comes from its columns S_n = (rho_C x x_n, x_n) about orthonormal axes x_n:
    sum_n x_n x (rho_C x x_n) = 3 rho_C - rho_C = 2 rho_C; a planar revolute joint's from its column (rho_y,
    -rho_x, 1)."""
    if not np.array_equal(widths, WIDTHS):
        raise ValueError(f"widths {widths} differ from the passes' WIDTHS {WIDTHS}")
    nb, nv, ne = IA.shape[0] - 1, IA.shape[1], ints.shape[0]
    (I_rows, p_row, a_row), (body_size, joint_size) = body_rows(nv), sizes(nv)
    s_rows, _, _, _, l_row, arm_row = joint_rows(nv)
    body, joint = np.zeros((nb + 1, body_size, nv)), np.zeros((ne + 1, joint_size, nv))
    body[:, I_rows : I_rows + nv] = IA
    body[:, p_row] = pA
    joint[:ne, s_rows : s_rows + nv, :3] = S
    joint[:ne, l_row, :3] = links
    for e in range(ne):
        if widths[ints[e, 0]] == 3:
            rho = 0.5 * np.cross(S[e, 3:6].T, S[e, :3].T).sum(axis=0)
            joint[e, arm_row] = [*rho, *(links[e] + rho)]
        elif nv == 3 and ints[e, 0] == 0:  # a planar revolute joint's point: S_e = (rho_y, -rho_x, 1)
            joint[e, arm_row, :2] = links[e, :2] + (-S[e, 1, 0], S[e, 0, 0])
    (planar_passes if nv == 3 else spatial_passes)(body, joint, ints, first, thdd)
    IA[:], pA[:], acc[:] = body[:, I_rows : I_rows + nv], body[:, p_row], body[:, a_row]


__all__ = [
    "WIDTHS",
    "articulated_accelerations",
    "body_rows",
    "joint_rows",
    "planar_passes",
    "sizes",
    "spatial_passes",
]
