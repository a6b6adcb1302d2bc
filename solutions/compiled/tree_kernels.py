"""Compiled kernels of joint coordinates: the recursive kinematics of a tree and its embedded equations.

The formulas of ``joint_coordinates.py`` (``PlanarTree.motion``, ``SpatialTree.motion``,
``JointCoordinates.embedded_equations``, ``spatial_forces``, ``coordinate_accelerations``), written out for
numba over the tree's joint data (``tree.py``: one row per joint in topological order):

- ints (kind, parent, child, position, velocity, count, the columns of D that move the child ...): kind 0
  revolute, 1 prismatic, 2 spherical; parent -1 is ground; where the joint's coordinates start in the
  positions and in the velocities of the state; the child's columns (its parent's and the joint's own);
- floats (s_P' (3), s_C' (3), axis h (3), planar offset, a (4), c (4), u0 (4), u1 (4), the child's joint frame
  f, g, h (9)): the constant data of ``TreeJoint``.

Recursion from ground, joint after joint (module docstring of ``joint_coordinates.py``): q, q' (planar:
body coordinates; spatial: v and the body-frame omega'), xi (the accelerations with theta'' = 0) and each joint's
columns S_e and link l. An open tree then gets theta'' from (D^T M D) theta'' = D^T (Q - M xi) (eq. 5.44 with
Z = D) by the articulated-body algorithm in O(N) (``articulated.py``), without ever forming D. A tree with cut
joints, and the outputs at the output times, also need D = dq/dtheta: the recursion carries the columns of D that
move each body (the numpy code's inherited columns; a planar tree leaves the other entries, zeros, unwritten: no
reader reads them), and the cut rows join D^T M D (summed over the columns that move each body) in the augmented system
of eq. 7.6, solved by the cut rows' Schur complement on the tree's factorization H = L^T D L (``cut_accelerations``,
notes eq. 7.11-7.12: O(N) on a shallow tree). A matrix that is not positive definite gives NaN, which the adaptive
integrators reject.

This module imports numba: it is imported only when the compiled engine runs (``solutions.compiled``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..joint_coordinates import half_transpose_product, scaled_product
from ..rotation_matrices import quaternion_product_entries
from .articulated import WIDTHS, body_rows, joint_rows, planar_passes, spatial_passes
from .kernels import (
    l_entries_jit,
    lu_solve,
    planar_rotation_entries_jit,
    revolute_rows,
    unit_rotation_entries_jit,
)

jit = njit(cache=False, fastmath=False, nogil=True)
"""Not cached here: these functions are compiled into the generated modules that call them, which are cached
under names that hash this file (numba's cache does not follow a cached function's callees into other files:
a cached kernel here could keep an old copy of a function it calls from another file)."""

inlined = njit(cache=False, fastmath=False, nogil=True, inline="always")
"""The steps a right-hand side calls once each (the recursion, the articulated pass, the outputs' q'' and lambda),
and the spatial recursion's steps of a joint or a body that read or write the work arrays (``_child_motion``,
``_vector``, ``body_force``, ...): numba writes them into the generated ``scene_rhs`` itself, where a call of a
compiled function costs two atomic reference counts per array it is handed (~10 ns each: ~50 ns a call at two
bodies, a quarter of a planar tree's theta''; the spatial recursion's helpers called as functions were ~40 ns a
joint of its ~130)."""

_half_transpose_product, _scaled_product = jit(half_transpose_product), jit(scaled_product)
"""1/2 M^T w and s M x of a 3 x 4 matrix M (G or L), as the joint coordinates write them (``joint_coordinates``)."""

REVOLUTE, PRISMATIC, SPHERICAL = 0, 1, 2  # the kinds (``articulated.WIDTHS``: the velocity columns of each)
MOTION = 5
"""The row of a planar body's cos phi and sin phi in ``body`` (``planar_motion``), after the articulated pass's five
(``articulated.body_rows``)."""
PLANAR_MOTION_ROWS = 1
"""The recursion's rows of a planar body in ``body`` (``tree._arrays``)."""
S_PARENT, S_CHILD, AXIS, OFFSET, A, C, U0, U1, FRAME = 0, 3, 6, 9, 10, 14, 18, 22, 26
WIDTH = 35
"""Columns of a joint's floats (module docstring)."""


# -- planar ------------------------------------------------------------------------------------------------
@inlined
def planar_motion(theta, rate, ints, floats, nb, k, q, qd, xi, Dm, columns, body, joint):
    """q, q', xi (3 nb) of a planar tree (``PlanarTree.motion``), each joint's column S_e (v_x, v_y, omega) and link
    l = r_C - r_P (a revolute joint: its point from the parent's centre e_P = l + rho_C instead, for its pass at
    the point, ``articulated.revolute_passed_on``) into ``joint`` (``articulated.joint_rows``); with ``columns``, D
    (3 nb x k) too: on each body the columns that move it, all that any reader reads (``planar_equations``,
    ``cut_accelerations``, ``tree_accelerations``); the other entries, zeros of D, are left as the caller's array
    has them (the outputs zeroed all 3 nb x k at every output time: 0.4 MB an evaluation at a loop chain of 64).
    One pass from ground, each child from its parent's q, q', xi (ground's: zero), each body's cos phi and sin phi
    made once (eq. 2.2) and kept in ``body``'s row ``MOTION`` (the caller's work array) for its children."""
    S, _, _, _, LINK, ARM = joint_rows(3)
    for e in range(ints.shape[0]):
        P, Cb, c = ints[e, 1], ints[e, 2], ints[e, 3]
        px = py = pphi = pvx = pvy = wp = pax = pay = 0.0  # ground: at rest at the origin, A = 1
        cp, sp = 1.0, 0.0
        if P >= 0:
            o = 3 * P
            px, py, pphi, pvx, pvy, wp = q[o], q[o + 1], q[o + 2], qd[o], qd[o + 1], qd[o + 2]
            pax, pay = xi[o], xi[o + 1]
            cp, sp = body[P, MOTION, 0], body[P, MOTION, 1]
        revolute = ints[e, 0] == REVOLUTE
        phi = pphi + (theta[c] if revolute else floats[e, OFFSET])
        cc, _, sc, _ = planar_rotation_entries_jit(phi)  # A_C (eq. 2.2), once per body
        body[Cb, MOTION, 0], body[Cb, MOTION, 1] = cc, sc
        spx, spy, scx, scy = floats[e, S_PARENT], floats[e, S_PARENT + 1], floats[e, S_CHILD], floats[e, S_CHILD + 1]
        rcx, rcy = cc * scx - sc * scy, sc * scx + cc * scy  # rho_C = A_C s_C'
        ux = uy = s = sd = w_rel = 0.0
        if revolute:
            w_rel = rate[c]
        else:
            ax0, ax1 = floats[e, AXIS], floats[e, AXIS + 1]
            ux, uy = cp * ax0 - sp * ax1, sp * ax0 + cp * ax1
            s, sd = theta[c], rate[c]
        ex, ey = cp * spx - sp * spy + s * ux, sp * spx + cp * spy + s * uy  # rho_P + d
        lx, ly = ex - rcx, ey - rcy  # the link
        o = 3 * Cb
        q[o], q[o + 1], q[o + 2] = px + lx, py + ly, phi
        wc = wp + w_rel
        qd[o] = pvx - wp * ly + ux * sd + w_rel * rcy
        qd[o + 1] = pvy + wp * lx + uy * sd - w_rel * rcx
        qd[o + 2] = wc
        xi[o] = pax - wp * wp * ex + wc * wc * rcx - 2.0 * wp * sd * uy
        xi[o + 1] = pay - wp * wp * ey + wc * wc * rcy + 2.0 * wp * sd * ux
        xi[o + 2] = 0.0
        if revolute:  # S_e: (rho_C rotated by -90 degrees, 1) or (u, 0)
            joint[e, S, 0], joint[e, S + 1, 0], joint[e, S + 2, 0] = rcy, -rcx, 1.0
            joint[e, ARM, 0], joint[e, ARM, 1] = ex, ey
        else:
            joint[e, S, 0], joint[e, S + 1, 0], joint[e, S + 2, 0] = ux, uy, 0.0
            joint[e, LINK, 0], joint[e, LINK, 1], joint[e, LINK, 2] = lx, ly, 0.0
        if columns:  # D_C = D_P + R90 l (angle row of D_P) over the parent's columns, then the joint's own
            i, j = 3 * Cb, 3 * ints[e, 1]
            for g in range(ints[e, 5] - 1):  # the columns that move the parent (none at ground)
                col = ints[e, 6 + g]
                Dm[i, col] = Dm[j, col] - ly * Dm[j + 2, col]
                Dm[i + 1, col] = Dm[j + 1, col] + lx * Dm[j + 2, col]
                Dm[i + 2, col] = Dm[j + 2, col]
            Dm[i, c], Dm[i + 1, c], Dm[i + 2, c] = joint[e, S, 0], joint[e, S + 1, 0], joint[e, S + 2, 0]


@inlined
def tree_revolute(q, qd, ints, floats, psi, jac, gam, body, rated):
    """``kernels.planar_revolute`` in a planar tree's module (eq. 3.17), each body's A (eq. 2.2) from the recursion:
    cos phi and sin phi of ``body``'s row MOTION (``planar_motion``), where the kernel made both bodies' again at
    every joint (two cos/sin pairs a joint); gamma of the first ``rated`` joints alone: the cut joints, first in the
    slot, whose rows the cut solve reads (the tree joints' gamma is read nowhere: the integration evaluates the cut
    joints alone, the outputs every joint). The same numbers: the same cos and sin of the same angle, in the same
    expressions."""
    for e in range(ints.shape[0]):
        Ai, Aj = _rotation(body, ints[e, 0]), _rotation(body, ints[e, 1])
        revolute_rows(q, qd, ints, floats, e, Ai, Aj, psi, jac, gam, e < rated)


@inlined
def _rotation(body, b):
    """A(phi_b) row by row (eq. 2.2) from the recursion's cos phi, sin phi; ground's A(0) as
    ``planar_rotation_entries`` makes it."""
    if b < 0:
        return 1.0, -0.0, 0.0, 1.0
    c, s = body[b, MOTION, 0], body[b, MOTION, 1]
    return c, -s, s, c


@inlined
def planar_articulated(mass, xi, Q, ints, thdd, body, joint):
    """theta'' of an open planar tree in O(N) (``articulated``): the bodies' I_b = diag(m, m, J) and bias forces
    p_b = M_b xi_b - Q_b (no gyroscopic term in the plane) into ``body`` (ground last), whose rows ACC get the
    bodies' accelerations D theta''; ``joint`` holds S_e and the links (``planar_motion``). Both the caller's work
    arrays (``articulated.body_rows``, ``joint_rows``): no allocation here."""
    nb = mass.size // 3
    IA, PA, _ = body_rows(3)
    for b in range(nb):
        for r in range(3):
            for c in range(3):
                body[b, IA + r, c] = mass[3 * b + r] if r == c else 0.0
            body[b, PA, r] = mass[3 * b + r] * xi[3 * b + r] - Q[3 * b + r]
    for r in range(3):  # ground
        body[nb, PA, r] = body[nb, IA + r, 0] = body[nb, IA + r, 1] = body[nb, IA + r, 2] = 0.0
    planar_passes(body, joint, ints, 3, thdd)


@jit
def planar_equations(mass, Dm, xi, Q, ints):
    """(D^T M D (its lower triangle), D^T (Q - M xi)), M = diag(mass)."""
    k = Dm.shape[1]
    work = np.zeros(k * k + k)  # one allocation for both
    matrix, rhs = work[: k * k].reshape((k, k)), work[k * k :]
    for e in range(ints.shape[0]):
        b, count = ints[e, 2], ints[e, 5]
        for r in range(3 * b, 3 * b + 3):
            force = Q[r] - mass[r] * xi[r]
            for a in range(count):
                i = ints[e, 6 + a]
                weighted = Dm[r, i] * mass[r]
                rhs[i] += Dm[r, i] * force
                for c in range(count):
                    j = ints[e, 6 + c]
                    if j <= i:
                        matrix[i, j] += weighted * Dm[r, j]
    return matrix, rhs


# -- spatial: 3-vectors and Euler parameters ---------------------------------------------------------------
@jit
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@jit
def _rotate(R, v0, v1, v2):
    """A v, A (9,) row by row."""
    return (
        R[0] * v0 + R[1] * v1 + R[2] * v2,
        R[3] * v0 + R[4] * v1 + R[5] * v2,
        R[6] * v0 + R[7] * v1 + R[8] * v2,
    )


@jit
def _rotate_back(R, v0, v1, v2):
    """A^T v."""
    return (
        R[0] * v0 + R[3] * v1 + R[6] * v2,
        R[1] * v0 + R[4] * v1 + R[7] * v2,
        R[2] * v0 + R[5] * v1 + R[8] * v2,
    )


_qmul = jit(quaternion_product_entries)
"""The quaternion product a b entry by entry (``rotation_matrices.quaternion_product_entries``)."""


@jit
def _half_l_transpose(e0, e1, e2, e3, w0, w1, w2):
    """p' = 1/2 L(p)^T omega' (eq. 8.17), as ``joint_coordinates.half_l_transpose``."""
    return _half_transpose_product(l_entries_jit(e0, e1, e2, e3), (w0, w1, w2))


@jit
def _half_l(e0, e1, e2, e3, x0, x1, x2, x3):
    """1/2 L(p) x: the body-frame torque n' of Q_p = 2 L^T n', as ``joint_coordinates.half_l``."""
    return _scaled_product(0.5, l_entries_jit(e0, e1, e2, e3), (x0, x1, x2, x3))


# -- spatial tree ------------------------------------------------------------------------------------------
@inlined
def _spatial_joint(kind, f, AP, theta, rate, rates, at, c):
    """What a joint adds to its parent, A_P the parent's rotation (``joint_coordinates.joint_rotation``): its own
    rotation j, its global axis h (zero for a spherical joint), the sliding rate s' and e_P = rho_P (+ s h for a
    prismatic joint). The rates of its position coordinates go to ``rates`` (a spherical joint's e' = 1/2 L(e)^T
    w', eq. 8.17)."""
    rp0, rp1, rp2 = _rotate(AP, f[S_PARENT], f[S_PARENT + 1], f[S_PARENT + 2])
    if kind == REVOLUTE:
        h = _rotate(AP, f[AXIS], f[AXIS + 1], f[AXIS + 2])
        co, si = math.cos(0.5 * theta[at]), math.sin(0.5 * theta[at])
        j0, j1 = co * f[U0] + si * f[U1], co * f[U0 + 1] + si * f[U1 + 1]
        j2, j3 = co * f[U0 + 2] + si * f[U1 + 2], co * f[U0 + 3] + si * f[U1 + 3]
        rates[at] = rate[c]
        return (j0, j1, j2, j3), h, 0.0, (rp0, rp1, rp2)
    if kind == PRISMATIC:
        h0, h1, h2 = _rotate(AP, f[AXIS], f[AXIS + 1], f[AXIS + 2])
        rates[at] = rate[c]
        e_p = (rp0 + theta[at] * h0, rp1 + theta[at] * h1, rp2 + theta[at] * h2)  # rho_P + d
        return (f[U0], f[U0 + 1], f[U0 + 2], f[U0 + 3]), (h0, h1, h2), rate[c], e_p
    e0, e1, e2, e3 = theta[at], theta[at + 1], theta[at + 2], theta[at + 3]
    norm = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
    e0, e1, e2, e3 = e0 / norm, e1 / norm, e2 / norm, e3 / norm
    b0, b1, b2, b3 = _qmul(f[A], f[A + 1], f[A + 2], f[A + 3], e0, e1, e2, e3)
    j = _qmul(b0, b1, b2, b3, f[C], f[C + 1], f[C + 2], f[C + 3])
    rates[at], rates[at + 1], rates[at + 2], rates[at + 3] = _half_l_transpose(
        e0, e1, e2, e3, rate[c], rate[c + 1], rate[c + 2]
    )
    return j, (0.0, 0.0, 0.0), 0.0, (rp0, rp1, rp2)


@inlined
def _relative_omega(kind, joint, e, rate, c, h):
    """The child's angular velocity relative to its parent, global: theta' h (revolute), zero (prismatic), the
    three rates about the child's joint frame A_C (f, g, h) (spherical: the angular rows of its columns S_e,
    ``_joint_columns``)."""
    S = joint_rows(6)[0]
    wr0 = wr1 = wr2 = 0.0
    if kind == REVOLUTE:
        wr0, wr1, wr2 = rate[c] * h[0], rate[c] * h[1], rate[c] * h[2]
    elif kind == SPHERICAL:
        for n in range(3):
            x0, x1, x2 = joint[e, S + 3, n], joint[e, S + 4, n], joint[e, S + 5, n]
            rel = rate[c + n]
            if n == 0:
                wr0, wr1, wr2 = rel * x0, rel * x1, rel * x2
            else:
                wr0, wr1, wr2 = wr0 + rel * x0, wr1 + rel * x1, wr2 + rel * x2
    return wr0, wr1, wr2


POSITION, VELOCITY, OMEGA, ACCELERATION, ALPHA = 0, 1, 2, 3, 4
SPATIAL_MOTION = 8
"""The rows of a spatial body's recursion in ``body``, after the articulated pass's eight (``articulated.body_rows``):
its global r, v, omega, a and alpha with theta'' = 0 two to a row (``_vector``), then its Euler parameters p, then
its rotation A(p) (eq. 8.12, nine entries over two rows: made once per evaluation, ``_body_rotation``)."""
SPATIAL_MOTION_ROWS = 6
"""The recursion's rows of a spatial body in ``body`` (``tree._arrays``)."""


@inlined
def _vector(body, b, which):
    """Body b's global 3-vector ``which`` (POSITION, VELOCITY, OMEGA, ACCELERATION, ALPHA) of the recursion."""
    row, col = SPATIAL_MOTION + which // 2, 3 * (which % 2)
    return body[b, row, col], body[b, row, col + 1], body[b, row, col + 2]


@inlined
def _set_vector(body, b, which, x0, x1, x2):
    row, col = SPATIAL_MOTION + which // 2, 3 * (which % 2)
    body[b, row, col], body[b, row, col + 1], body[b, row, col + 2] = x0, x1, x2


@inlined
def _body_rotation(body, b):
    """A(p) of body b (eq. 8.12) row by row, as the recursion keeps it (``_keep_rotation``)."""
    row = SPATIAL_MOTION + 4
    return (
        body[b, row, 0], body[b, row, 1], body[b, row, 2], body[b, row, 3], body[b, row, 4], body[b, row, 5],
        body[b, row + 1, 0], body[b, row + 1, 1], body[b, row + 1, 2],
    )  # fmt: skip


@inlined
def _keep_rotation(body, b):
    """A(p) of body b (eq. 8.12) from its Euler parameters in ``body``, kept in its rows for every later use in the
    evaluation (the joint's parent, the outputs, the inertia A J' A^T, q''): one rotation per body and evaluation,
    where each of those made it again. Returns it."""
    row = SPATIAL_MOTION + 3
    R = unit_rotation_entries_jit(body[b, row, 0], body[b, row, 1], body[b, row, 2], body[b, row, 3])
    for i in range(6):
        body[b, row + 1, i] = R[i]
    for i in range(3):
        body[b, row + 2, i] = R[6 + i]
    return R


@inlined
def _child_motion(body, P, Cb, e_p, rc, h, w_rel, sd, prismatic):
    """The child's r, v, omega, alpha and a with theta'' = 0 from its parent's (``_vector``): e_P and rho_C the
    joint point from either centre, h, w_rel and s' the joint's axis and rates (module docstring of
    ``joint_coordinates.py``). Returns the link e_P - rho_C."""
    ep0, ep1, ep2 = e_p
    rc0, rc1, rc2 = rc
    wp0, wp1, wp2 = _vector(body, P, OMEGA)
    al0, al1, al2 = _vector(body, P, ALPHA)
    r0, r1, r2 = _vector(body, P, POSITION)
    v0, v1, v2 = _vector(body, P, VELOCITY)
    a0, a1, a2 = _vector(body, P, ACCELERATION)
    l0, l1, l2 = ep0 - rc0, ep1 - rc1, ep2 - rc2  # the link
    _set_vector(body, Cb, POSITION, r0 + l0, r1 + l1, r2 + l2)
    x0, x1, x2 = _cross(wp0, wp1, wp2, l0, l1, l2)
    vc0, vc1, vc2 = v0 + x0, v1 + x1, v2 + x2
    x0, x1, x2 = _cross(al0, al1, al2, ep0, ep1, ep2)
    y0, y1, y2 = _cross(wp0, wp1, wp2, ep0, ep1, ep2)
    y0, y1, y2 = _cross(wp0, wp1, wp2, y0, y1, y2)
    ac0, ac1, ac2 = a0 + x0 + y0, a1 + x1 + y1, a2 + x2 + y2
    if prismatic:
        h0, h1, h2 = h
        wc0, wc1, wc2, ac_0, ac_1, ac_2 = wp0, wp1, wp2, al0, al1, al2
        vc0, vc1, vc2 = vc0 + sd * h0, vc1 + sd * h1, vc2 + sd * h2
        x0, x1, x2 = _cross(wp0, wp1, wp2, h0, h1, h2)
        ac0, ac1, ac2 = ac0 + 2.0 * sd * x0, ac1 + 2.0 * sd * x1, ac2 + 2.0 * sd * x2
    else:
        wr0, wr1, wr2 = w_rel
        wc0, wc1, wc2 = wp0 + wr0, wp1 + wr1, wp2 + wr2
        x0, x1, x2 = _cross(wp0, wp1, wp2, wr0, wr1, wr2)
        ac_0, ac_1, ac_2 = al0 + x0, al1 + x1, al2 + x2
        x0, x1, x2 = _cross(rc0, rc1, rc2, wr0, wr1, wr2)
        vc0, vc1, vc2 = vc0 + x0, vc1 + x1, vc2 + x2
    _set_vector(body, Cb, VELOCITY, vc0, vc1, vc2)
    _set_vector(body, Cb, OMEGA, wc0, wc1, wc2)
    _set_vector(body, Cb, ALPHA, ac_0, ac_1, ac_2)
    x0, x1, x2 = _cross(ac_0, ac_1, ac_2, rc0, rc1, rc2)
    y0, y1, y2 = _cross(wc0, wc1, wc2, rc0, rc1, rc2)
    y0, y1, y2 = _cross(wc0, wc1, wc2, y0, y1, y2)
    _set_vector(body, Cb, ACCELERATION, ac0 - (x0 + y0), ac1 - (x1 + y1), ac2 - (x2 + y2))
    return l0, l1, l2


@inlined
def _joint_columns(kind, rc, h, AC, f, joint, e):
    """The joint's own columns S_e (v, omega, global; ``articulated``), into ``joint`` (``articulated.joint_rows``):
    revolute (rho_C x h, h), prismatic (h, 0), spherical (rho_C x x_n, x_n) about the child's joint axes x_n = A_C
    f, g, h."""
    rc0, rc1, rc2 = rc
    S = joint_rows(6)[0]
    for r in range(6):
        for n in range(3):
            joint[e, S + r, n] = 0.0
    if kind == REVOLUTE:
        joint[e, S, 0], joint[e, S + 1, 0], joint[e, S + 2, 0] = _cross(rc0, rc1, rc2, h[0], h[1], h[2])
        joint[e, S + 3, 0], joint[e, S + 4, 0], joint[e, S + 5, 0] = h
    elif kind == PRISMATIC:
        joint[e, S, 0], joint[e, S + 1, 0], joint[e, S + 2, 0] = h
    else:
        for n in range(3):
            x0, x1, x2 = _rotate(AC, f[FRAME + 3 * n], f[FRAME + 3 * n + 1], f[FRAME + 3 * n + 2])
            joint[e, S, n], joint[e, S + 1, n], joint[e, S + 2, n] = _cross(rc0, rc1, rc2, x0, x1, x2)
            joint[e, S + 3, n], joint[e, S + 4, n], joint[e, S + 5, n] = x0, x1, x2


@jit
def _child_columns(Dv, Dw, P, Cb, kind, c, link, joint, e):
    """The child's columns of D (v, omega, global): its parent's moved by omega x l, then the joint's own S_e."""
    l0, l1, l2 = link
    S = joint_rows(6)[0]
    for col in range(Dv.shape[1]):
        x0, x1, x2 = _cross(l0, l1, l2, Dw[P, col, 0], Dw[P, col, 1], Dw[P, col, 2])
        Dv[Cb, col, 0], Dv[Cb, col, 1], Dv[Cb, col, 2] = Dv[P, col, 0] - x0, Dv[P, col, 1] - x1, Dv[P, col, 2] - x2
        Dw[Cb, col, 0], Dw[Cb, col, 1], Dw[Cb, col, 2] = Dw[P, col, 0], Dw[P, col, 1], Dw[P, col, 2]
    for n in range(3 if kind == SPHERICAL else 1):
        for r in range(3):
            Dv[Cb, c + n, r], Dw[Cb, c + n, r] = joint[e, S + r, n], joint[e, S + 3 + r, n]


@inlined
def _spatial_outputs(body, q, qd, xi, omega):
    """q, q' = (r', 1/2 L(p)^T omega'), xi = (a, A^T alpha) and omega' = A^T omega of every body from the recursion's
    global vectors (eq. 8.17)."""
    P_ROW = SPATIAL_MOTION + 3
    for b in range(omega.shape[0]):
        Rb = _body_rotation(body, b)
        w0, w1, w2 = _vector(body, b, OMEGA)
        o0, o1, o2 = _rotate_back(Rb, w0, w1, w2)  # omega' = A^T omega
        omega[b, 0], omega[b, 1], omega[b, 2] = o0, o1, o2
        q[7 * b], q[7 * b + 1], q[7 * b + 2] = _vector(body, b, POSITION)
        qd[7 * b], qd[7 * b + 1], qd[7 * b + 2] = _vector(body, b, VELOCITY)
        xi[6 * b], xi[6 * b + 1], xi[6 * b + 2] = _vector(body, b, ACCELERATION)
        for r in range(4):
            q[7 * b + 3 + r] = body[b, P_ROW, r]
        qd[7 * b + 3], qd[7 * b + 4], qd[7 * b + 5], qd[7 * b + 6] = _half_l_transpose(
            body[b, P_ROW, 0], body[b, P_ROW, 1], body[b, P_ROW, 2], body[b, P_ROW, 3], o0, o1, o2
        )
        al0, al1, al2 = _vector(body, b, ALPHA)
        xi[6 * b + 3], xi[6 * b + 4], xi[6 * b + 5] = _rotate_back(Rb, al0, al1, al2)


@jit
def _spatial_columns(ints, nb, k, body, joint, Dm):
    """D (6 nb x k: v and omega' per joint velocity) from the joints' S_e and links of the recursion (``joint``):
    each child's columns its parent's moved by omega x l, then its joint's own (``_child_columns``); omega turned
    to the body frame, omega' = A^T omega (eq. 8.17). Only for cut rows: an open tree's passes never form D."""
    D = np.zeros((2, nb + 1, k, 3))  # v and omega of every column at every body, global; ground last
    Dv, Dw = D[0], D[1]
    LINK = joint_rows(6)[4]
    for e in range(ints.shape[0]):
        kind, P, Cb, c = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 4]
        if P < 0:
            P = nb
        link = joint[e, LINK, 0], joint[e, LINK, 1], joint[e, LINK, 2]
        _child_columns(Dv, Dw, P, Cb, kind, c, link, joint, e)
    for b in range(nb):
        Rb = _body_rotation(body, b)
        for col in range(k):
            Dm[6 * b, col], Dm[6 * b + 1, col], Dm[6 * b + 2, col] = Dv[b, col, 0], Dv[b, col, 1], Dv[b, col, 2]
            x0, x1, x2 = _rotate_back(Rb, Dw[b, col, 0], Dw[b, col, 1], Dw[b, col, 2])
            Dm[6 * b + 3, col], Dm[6 * b + 4, col], Dm[6 * b + 5, col] = x0, x1, x2


@inlined
def spatial_motion(theta, rate, ints, floats, nb, k, q, qd, xi, Dm, omega, rates, columns, body, joint):
    """q, q' (7 nb), xi (6 nb: a and the body-frame alpha'), omega' (nb x 3), the rates of the joints' position
    coordinates (``SpatialTree.motion``), each joint's columns S_e, link l and joint point from either centre
    (rho_C, e_P: a spherical joint's pass, ``articulated.spherical_passed_on``) (into ``joint``,
    ``articulated.joint_rows``); with ``columns``, D (6 nb x k: v and omega' per joint velocity) too. The
    recursion's global vectors, Euler parameters and rotation in ``body``'s rows from ``SPATIAL_MOTION`` (the
    caller's work array: no allocation on an open tree's way)."""
    for which in range(5):  # ground: at rest at the origin, p = (1, 0, 0, 0)
        _set_vector(body, nb, which, 0.0, 0.0, 0.0)
    P_ROW = SPATIAL_MOTION + 3
    body[nb, P_ROW, 0], body[nb, P_ROW, 1], body[nb, P_ROW, 2], body[nb, P_ROW, 3] = 1.0, 0.0, 0.0, 0.0
    _keep_rotation(body, nb)
    LINK, ARM = joint_rows(6)[4], joint_rows(6)[5]
    for e in range(ints.shape[0]):
        kind, P, Cb, at, c = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3], ints[e, 4]
        if P < 0:
            P = nb
        f = floats[e]
        (j0, j1, j2, j3), h, sd, e_p = _spatial_joint(kind, f, _body_rotation(body, P), theta, rate, rates, at, c)
        p0, p1, p2, p3 = _qmul(
            body[P, P_ROW, 0], body[P, P_ROW, 1], body[P, P_ROW, 2], body[P, P_ROW, 3], j0, j1, j2, j3
        )
        body[Cb, P_ROW, 0], body[Cb, P_ROW, 1], body[Cb, P_ROW, 2], body[Cb, P_ROW, 3] = p0, p1, p2, p3
        AC = _keep_rotation(body, Cb)
        rc = _rotate(AC, f[S_CHILD], f[S_CHILD + 1], f[S_CHILD + 2])
        _joint_columns(kind, rc, h, AC, f, joint, e)
        w_rel = _relative_omega(kind, joint, e, rate, c, h)
        link = _child_motion(body, P, Cb, e_p, rc, h, w_rel, sd, kind == PRISMATIC)
        joint[e, LINK, 0], joint[e, LINK, 1], joint[e, LINK, 2] = link
        joint[e, ARM, 0], joint[e, ARM, 1], joint[e, ARM, 2] = rc  # the joint point from either centre
        joint[e, ARM, 3], joint[e, ARM, 4], joint[e, ARM, 5] = e_p
    _spatial_outputs(body, q, qd, xi, omega)
    if columns:
        _spatial_columns(ints, nb, k, body, joint, Dm)


@inlined
def spatial_articulated(masses, inertias, q, xi, omega, Q, ints, thdd, body, joint):
    """theta'' of an open spatial tree in O(N) (``articulated``): I_b = diag(m I, A J' A^T) and the bias force p_b
    = -(the body force f of ``body_force``, its torque turned to global axes by A) into ``body`` (ground last),
    whose rows ACC get the bodies' accelerations D theta'' (a, and omega'' in global axes); ``joint`` holds S_e and
    the links (``spatial_motion``). Both the caller's work arrays (``articulated.body_rows``, ``joint_rows``)."""
    nb, ne = masses.size, ints.shape[0]
    IA, PA, _ = body_rows(6)
    force = joint[ne, 0]  # a body's force: the passes' scratch, free until they start
    for b in range(nb):
        J = inertias[b]
        body_force(masses[b], J, q, xi, omega, Q, b, force)
        R = _body_rotation(body, b)  # A (eq. 8.12), row by row
        t0, t1, t2 = _rotate(R, force[3], force[4], force[5])
        for r in range(6):
            for c in range(6):
                body[b, IA + r, c] = 0.0
        for r in range(3):
            body[b, IA + r, r] = masses[b]
            body[b, PA, r] = -force[r]
        body[b, PA, 3], body[b, PA, 4], body[b, PA, 5] = -t0, -t1, -t2
        for c in range(3):  # A J' A^T, column by column
            x0, x1, x2 = _rotate(R, J[0, c], J[1, c], J[2, c])  # A J' e_c
            body[b, IA + 3, 3 + c], body[b, IA + 4, 3 + c], body[b, IA + 5, 3 + c] = x0, x1, x2
        for r in range(3):  # (A J') A^T, row by row: A times the row
            x0, x1, x2 = _rotate(R, body[b, IA + 3 + r, 3], body[b, IA + 3 + r, 4], body[b, IA + 3 + r, 5])
            body[b, IA + 3 + r, 3], body[b, IA + 3 + r, 4], body[b, IA + 3 + r, 5] = x0, x1, x2
    for r in range(6):  # ground
        body[nb, PA, r] = 0.0
        for c in range(6):
            body[nb, IA + r, c] = 0.0
    spatial_passes(body, joint, ints, 4, thdd)


@inlined
def body_force(m, J, q, xi, omega, Q, b, force):
    """The force on body b at theta'' = 0, f = (F - m a_xi, n' - J' alpha'_xi - omega' x J' omega') with F = Q_r and
    n' = 1/2 L(p) Q_p (``JointCoordinates.spatial_forces``; Q without Q_v): the right side of eq. 5.44 is D^T f."""
    o = 7 * b
    n0, n1, n2 = _half_l(q[o + 3], q[o + 4], q[o + 5], q[o + 6], Q[o + 3], Q[o + 4], Q[o + 5], Q[o + 6])
    w0, w1, w2 = omega[b, 0], omega[b, 1], omega[b, 2]
    d0, d1, d2 = xi[6 * b + 3], xi[6 * b + 4], xi[6 * b + 5]
    Jw0 = J[0, 0] * w0 + J[0, 1] * w1 + J[0, 2] * w2
    Jw1 = J[1, 0] * w0 + J[1, 1] * w1 + J[1, 2] * w2
    Jw2 = J[2, 0] * w0 + J[2, 1] * w1 + J[2, 2] * w2
    g0, g1, g2 = _cross(w0, w1, w2, Jw0, Jw1, Jw2)
    for r in range(3):
        force[r] = Q[o + r] - m * xi[6 * b + r]
    force[3] = n0 - ((J[0, 0] * d0 + J[0, 1] * d1 + J[0, 2] * d2) + g0)
    force[4] = n1 - ((J[1, 0] * d0 + J[1, 1] * d1 + J[1, 2] * d2) + g1)
    force[5] = n2 - ((J[2, 0] * d0 + J[2, 1] * d1 + J[2, 2] * d2) + g2)


@jit
def spatial_equations(masses, inertias, q, Dm, xi, omega, Q, ints):
    """(D^T diag(m I, J') D (its lower triangle), D^T f with f of ``body_force``): eq. 5.44 assembled, for a tree
    with cut rows (``cut_accelerations``)."""
    k = Dm.shape[1]
    work = np.zeros(k * k + k + 6 + 6 * k)  # one allocation: the matrix, the right side, f and B D of one body
    matrix, rhs = work[: k * k].reshape((k, k)), work[k * k : k * k + k]
    force, MD = work[k * k + k : k * k + k + 6], work[k * k + k + 6 :].reshape((6, k))
    for e in range(ints.shape[0]):
        b, count = ints[e, 2], ints[e, 5]
        m, J = masses[b], inertias[b]
        body_force(m, J, q, xi, omega, Q, b, force)
        for a in range(count):
            col = ints[e, 6 + a]
            for r in range(3):
                MD[r, col] = m * Dm[6 * b + r, col]
                row = 6 * b + 3
                MD[3 + r, col] = J[r, 0] * Dm[row, col] + J[r, 1] * Dm[row + 1, col] + J[r, 2] * Dm[row + 2, col]
        for a in range(count):
            i = ints[e, 6 + a]
            for r in range(6):
                rhs[i] += Dm[6 * b + r, i] * force[r]
            for c in range(count):
                j = ints[e, 6 + c]
                if j <= i:
                    s = 0.0
                    for r in range(6):
                        s += Dm[6 * b + r, i] * MD[r, j]
                    matrix[i, j] += s
    return matrix, rhs


@inlined
def tree_accelerations(Dm, thdd, xi, ints, nv, acc):
    """acc = D theta'' + xi (eq. 5.44) body by body over the columns that move the body (its joint's and its
    ancestors', ``describe``'s ints[e, 6 : 6 + ints[e, 5]]): D's only nonzeros in the body's rows, so the same sum
    as the dense product's but for the order of its terms (rounding) and the zeros skipped; no BLAS call and no
    allocation (``Dm @ thdd + xi`` made two arrays)."""
    for e in range(ints.shape[0]):
        b, count = ints[e, 2], ints[e, 5]
        for r in range(nv * b, nv * b + nv):
            s = 0.0
            for g in range(count):
                col = ints[e, 6 + g]
                s += Dm[r, col] * thdd[col]
            acc[r] = s + xi[r]


@jit
def spatial_coordinate_accelerations(q, qd, Dm, xi, omega, thdd, ints, qdd):
    """q'' = (r'', p'') from (a, omega'') = D theta'' + xi: p'' = 1/2 L(p)^T omega'' + 1/2 L(p')^T omega'."""
    acc = np.empty(xi.size)
    tree_accelerations(Dm, thdd, xi, ints, 6, acc)
    for b in range(omega.shape[0]):
        o = 7 * b
        for r in range(3):
            qdd[o + r] = acc[6 * b + r]
        x = _half_l_transpose(q[o + 3], q[o + 4], q[o + 5], q[o + 6], acc[6 * b + 3], acc[6 * b + 4], acc[6 * b + 5])
        y = _half_l_transpose(qd[o + 3], qd[o + 4], qd[o + 5], qd[o + 6], omega[b, 0], omega[b, 1], omega[b, 2])
        for r in range(4):
            qdd[o + 3 + r] = x[r] + y[r]


@jit
def spatial_joint_matrix(q, Dm, out):
    """dq/dtheta (7 nb x k): the v rows of D for r, 1/2 L(p)^T times its omega' rows for p (eq. 8.17)."""
    for b in range(q.size // 7):
        o = 7 * b
        for col in range(Dm.shape[1]):
            for r in range(3):
                out[o + r, col] = Dm[6 * b + r, col]
            x = _half_l_transpose(
                q[o + 3], q[o + 4], q[o + 5], q[o + 6], Dm[6 * b + 3, col], Dm[6 * b + 4, col], Dm[6 * b + 5, col]
            )
            for r in range(4):
                out[o + 3 + r, col] = x[r]


@inlined
def tree_multipliers(jac, residual, index, width, ints, lam):
    """lambda of a tree's rows (planar, ``width`` 3, or spatial, 7) from Psi_q^T lambda = r, r = Q - M q'' (- Psi_c,q^T
    mu on the cut route, ``cut_row_forces``), body by body from the leaves: the backward pass of inverse dynamics
    (Featherstone 2008, sec. 5.3, table 5.1, the recursive Newton-Euler algorithm: f_i = I_i a_i + v_i x* I_i v_i -
    f^x_i, then f_parent += f_i carried over) with the accelerations given (q'') and, on the cut route, the
    loop-closure forces applied as external forces (sec. 8.1-8.2: a loop closed by cut constraints is the tree with
    those forces applied). The equations of motion M q'' + Psi_q^T lambda = Q (eq. 5.29) read on body C's columns

        (Psi_q)_C^T lambda_e + sum over C's children c (Psi_q)_C^T lambda_c = r_C,

    e the tree joint to C's parent (its rows, then in space C's Euler-parameter normalization: the rows C owns,
    ``tree.row_index``). From the leaves (the joints in reverse topological order) every child's lambda_c is known,
    and moving its terms to the right side (r_P -= (Psi_q)_P^T lambda_e, what joint e exerts on the parent P) leaves
    in r_C the force joint e passes to C, (Psi_q)_C^T lambda_C = r_C over C's columns alone. The joint's translational
    rows (``translational_rows``) meet C's position columns along orthogonal unit directions a, and no other row of
    C meets them: lambda_a = a^T r_C,v, their components of the force (a revolute or spherical joint's s r_C,a; a
    spatial prismatic joint's f_i^T and g_i^T r_C,v to rounding: A_i orthogonal, its Euler parameters unit from the
    recursion), no solve. Their terms moved to the right side of C's rotation columns, C's other rows (a spatial
    joint's dot-1 rows and C's normalization, at most 4 x 4; a planar prismatic joint's angle row) by least squares
    on those columns (``_other_rows``). O(N), where the normal equations of all rows cost O(m^3); the same lambda as
    those, or as the least squares of C's whole block, to rounding (r_C is consistent with (Psi_q)_C^T lambda = r_C
    up to rounding, which a least squares spreads over every entry and this puts in the rotation entries alone).
    The joint's steps are written here, not in a function of their own: a compiled call inlined in a loop still
    counts the references of every array it is handed (~10 ns a joint: twice a planar joint's arithmetic).
    ``index``: the rows of each body (``tree.row_index``, made once per scene); ``residual`` is worked in."""
    nb = residual.size // width
    start, mine = index[: nb + 1], index[nb + 1 :]
    G = np.empty((_most_rows(start, nb) + 1, _most_rows(start, nb)))  # the rotation rows' A A^T; A r in its last row
    for e in range(ints.shape[0] - 1, -1, -1):
        P, C = ints[e, 1], ints[e, 2]
        first, count = start[C], start[C + 1] - start[C]
        at, moving = translational_rows(ints[e, 0], width)
        o = width * C
        position = 2 if width == 3 else 3  # C's position columns: (x, y) or r
        for a in range(first + at, first + at + moving):
            row, x = mine[a], 0.0
            for c in range(o, o + position):
                x += jac[row, c] * residual[c]
            lam[row] = x
        if count > moving:  # the other rows (a planar revolute joint: none)
            for a in range(first + at, first + at + moving):  # the translational rows moved to the right side
                for c in range(o + position, o + width):
                    residual[c] -= lam[mine[a]] * jac[mine[a], c]
            _other_rows(jac, residual, 0, mine, first, count, at, moving, o + position, o + width, G)
            for a in range(count - moving):
                lam[mine[first + (a if a < at else a + moving)]] = G[G.shape[0] - 1, a]
        if P >= 0:  # what the joint's rows exert on its parent
            for a in range(count):
                row, x = mine[first + a], lam[mine[first + a]]
                for c in range(width * P, width * (P + 1)):
                    residual[c] -= x * jac[row, c]


@inlined
def translational_rows(kind, width):
    """(the first, how many) of a tree joint's rows that meet its child's position columns: each along one direction,
    a unit vector, the directions orthogonal. A revolute joint's in the plane (eq. 3.17, Psi = r_i + A_i s_i' - r_j -
    A_j s_j': at r_C, s I, s = +1 where C is the element's body i, -1 where body j), a prismatic joint's in the plane
    its pin-in-slot row (n_i^T d, eq. 3.27; then the relative angle), a spherical joint's rows and a spatial revolute
    joint's first three (its spherical part, eq. 9.12, 9.16: s I), and a spatial prismatic joint's two dot-2 rows
    (eq. 9.18: dot-1(f_i, h_j), dot-1(g_i, h_j), dot-2(f_i, d), dot-2(g_i, d), dot-1(f_i, g_j); at r_C, s f_i^T and
    s g_i^T, f_i and g_i two axes of body i's joint frame). The other rows meet only C's rotation columns (phi, or
    the Euler parameters). ``tree.check_row_order`` checks this order where the plan is made."""
    if width == 3:
        return 0, 2 if kind == REVOLUTE else 1
    return (2, 2) if kind == PRISMATIC else (0, 3)


@inlined
def _most_rows(start, nb):
    """The most rows a body owns (``tree.row_index``' start)."""
    most = 0
    for b in range(nb):
        most = max(most, start[b + 1] - start[b])
    return most


@inlined
def _other_rows(jac, r, shift, mine, first, count, at, skipped, lo, hi, G):
    """lambda of a body's rows (``mine[first : first + count]``) but the ``skipped`` from ``at`` from A^T lambda = r
    over the columns [lo, hi) (A: those rows' block of Psi_q, full row rank; column c's entry of r at r[c - shift])
    by least squares, (A A^T) lambda = A r: into G's last row (its first count - skipped entries)."""
    b = G.shape[0] - 1
    for a in range(count - skipped):  # by loops: at most 4 x 4, where a BLAS call costs more than the products
        row = mine[first + (a if a < at else a + skipped)]
        total = 0.0  # sums in a local (G may alias jac for the compiler: each += would store to memory)
        for c in range(lo, hi):
            total += jac[row, c] * r[c - shift]
        G[b, a] = total
        for other in range(a + 1):  # A A^T is symmetric: the same products, in the same order, either side
            other_row, total = mine[first + (other if other < at else other + skipped)], 0.0
            for c in range(lo, hi):
                total += jac[row, c] * jac[other_row, c]
            G[a, other] = G[other, a] = total
    _small_solve(G, count - skipped, b)


@inlined
def planar_joint_multipliers(jac, body, index, ints, lam):
    """lambda of an open planar tree's rows from its articulated-body pass (``articulated``; ``body`` after
    ``planar_articulated``: I^A_C, p^A_C and A_C of every body), without the backward pass (``tree_multipliers``).

    The subtree of child C moves under its own applied forces and what joint e passes it, nothing else. The force
    joint e passes to C, at C's centre in global axes (Featherstone 2008, sec. 7.3 and table 7.1: the joint force
    of the articulated-body algorithm), is

        f_e = I^A_C A_C + p^A_C

    (a leaf: I_C A_C + M_C xi_C - Q_C = M_C q''_C - Q_C, the force its joint must add; the articulated pass folds
    each child's subtree into I^A and p^A the same way). The equations of motion M q'' + Psi_q^T lambda = Q (eq.
    5.29) give the joint's rows' force on C as -(Psi_q)_C^T lambda_e, so (Psi_q)_C^T lambda_e = -f_e: what
    the backward pass finds for C once its children's rows are moved to its side, here with no
    matrix formed. A revolute joint (eq. 3.17, Psi = r_i + A_i s_i' - r_j - A_j s_j'): (Psi_q)_C = s [I, B_C s_C'],
    s = +1 where C is the element's body i, -1 where it is body j, read from Psi_q's entry at C's x column (exactly
    +-1), so lambda_e = -s f_v from the translational components alone (the angular one, (B_C s_C')^T lambda_e, is
    the same equation's: the joint passes no moment about its point). A prismatic joint's two rows meet C's three
    columns in a 2 x 3 block A: (A A^T) lambda_e = A (-f_e), least squares on C's block alone (``_other_rows``),
    nothing moved to the parent: f_e holds what C's children pass it. The same lambda as ``tree_multipliers`` to
    rounding (the sums in another order)."""
    IA, PA, ACC = body_rows(3)
    nb = body.shape[0] - 1
    start, mine = index[: nb + 1], index[nb + 1 :]
    G = np.empty((3, 2))  # a prismatic joint's 2 x 2 A A^T; A (-f) in the last row
    f = np.empty(3)
    for e in range(ints.shape[0]):
        C = ints[e, 2]
        first = start[C]
        for i in range(3):  # -f_e = -(I^A_C A_C + p^A_C)
            x = body[C, PA, i]
            for j in range(3):
                x += body[C, IA + i, j] * body[C, ACC, j]
            f[i] = -x
        if ints[e, 0] == REVOLUTE:
            for a in range(2):
                row = mine[first + a]
                lam[row] = f[a] * jac[row, 3 * C + a]  # s = +-1: its own inverse
        else:
            _other_rows(jac, f, 3 * C, mine, first, 2, 0, 0, 3 * C, 3 * C + 3, G)
            lam[mine[first]], lam[mine[first + 1]] = G[2, 0], G[2, 1]


@inlined
def _small_solve(G, count, b):
    """x <- K^-1 x with K = G[:count, :count] and x = G[b, :count], in place: ``kernels.solve_in_place`` step for step
    (the same pivots and operations, so the same numbers), written into ``_other_rows``: its call and the
    views it was handed cost more than a planar body's elimination (~30 ns a body). A zero pivot gives NaN."""
    singular = False
    for c in range(count):
        pivot = c
        biggest = abs(G[c, c])
        for r in range(c + 1, count):
            if abs(G[r, c]) > biggest:
                biggest, pivot = abs(G[r, c]), r
        if pivot != c:
            for k in range(count):
                G[c, k], G[pivot, k] = G[pivot, k], G[c, k]
            G[b, c], G[b, pivot] = G[b, pivot], G[b, c]
        if G[c, c] == 0.0:  # every remaining entry of the column is zero: K is singular
            singular = True
            break
        inverse = 1.0 / G[c, c]
        for r in range(c + 1, count):
            factor = G[r, c] * inverse
            if factor != 0.0:
                G[r, c] = factor
                for k in range(c + 1, count):
                    G[r, k] -= factor * G[c, k]
                G[b, r] -= factor * G[b, c]
    for r in range(count - 1, -1, -1):
        if singular:
            G[b, r] = np.nan
        else:
            s = G[b, r]
            for k in range(r + 1, count):
                s -= G[r, k] * G[b, k]
            G[b, r] = s / G[r, r]


@inlined
def zero_tree_blocks(jac, index, ints, width):
    """Zeros in the entries of Psi_q that ``tree_multipliers`` reads: each tree row (``index``: the rows of each body,
    ``tree.row_index``) at the coordinates of its body and of that body's parent (-1 ground), where the constraint
    kernels add their terms. With ``zero_cut_blocks`` all that lambda of every row needs, where zeroing the whole
    m x n Psi_q at every output time of a loop chain of 64 bodies wrote 1.2 MB per evaluation."""
    nb = jac.shape[1] // width
    start, mine = index[: nb + 1], index[nb + 1 :]
    for e in range(ints.shape[0]):
        P, C = ints[e, 1], ints[e, 2]
        for a in range(start[C], start[C + 1]):
            jac[mine[a], width * C : width * (C + 1)] = 0.0
            if P >= 0:
                jac[mine[a], width * P : width * (P + 1)] = 0.0


@jit
def cut_row_forces(jac, mu, rows, bodies, width, residual):
    """residual -= mu_a (Psi_q)_a over the cut rows a, each over the coordinates of its element's two bodies alone
    (-1 ground): the rest of the row is zero (``zero_cut_blocks``), so the same numbers as the product over whole
    rows, which read 2 n entries per cut row."""
    for a in range(rows.size):
        for side in range(2):
            b = bodies[2 * a + side]
            if b >= 0:
                for c in range(width * b, width * (b + 1)):
                    residual[c] -= mu[a] * jac[rows[a], c]


@inlined
def planar_body_accelerations(body, xi, qdd):
    """q'' = D theta'' + xi of a planar tree from the bodies' accelerations of the articulated pass (``body``'s rows
    ACC: D theta'' per body, (x'', y'', phi'') at its centre): no D formed."""
    ACC = body_rows(3)[2]
    for b in range(xi.size // 3):
        for r in range(3):
            qdd[3 * b + r] = body[b, ACC, r] + xi[3 * b + r]


@inlined
def spatial_body_accelerations(q, qd, body, xi, omega, qdd):
    """q'' = (r'', p'') of a spatial tree from the bodies' accelerations of the articulated pass (``body``'s rows
    ACC: a and the angular acceleration of D theta'' in global axes) and xi (a, A^T alpha): r'' = a + xi_a, the
    body-frame angular acceleration w = A^T (D theta'')_alpha + xi_alpha, p'' = 1/2 L(p)^T w + 1/2 L(p')^T omega'
    (eq. 8.17; ``spatial_coordinate_accelerations`` without D). A from the recursion's rows (``_body_rotation``)."""
    ACC = body_rows(6)[2]
    for b in range(omega.shape[0]):
        o = 7 * b
        R = _body_rotation(body, b)  # A (eq. 8.12), row by row
        for r in range(3):
            qdd[o + r] = body[b, ACC, r] + xi[6 * b + r]
        w0, w1, w2 = _rotate_back(R, body[b, ACC, 3], body[b, ACC, 4], body[b, ACC, 5])
        x = _half_l_transpose(q[o + 3], q[o + 4], q[o + 5], q[o + 6], w0 + xi[6 * b + 3], w1 + xi[6 * b + 4],
                              w2 + xi[6 * b + 5])  # fmt: skip
        y = _half_l_transpose(qd[o + 3], qd[o + 4], qd[o + 5], qd[o + 6], omega[b, 0], omega[b, 1], omega[b, 2])
        for r in range(4):
            qdd[o + 3 + r] = x[r] + y[r]


@inlined
def spatial_mass_residual(q, qd, qdd, masses, inertias, weights, Q, residual):
    """Q += Q_v = 8 L(p')^T J' L(p') p (eq. 10.5) and residual = Q - M q'' body by body, M_b = diag(m I, 4 L^T J' L
    + 4 w p p^T) (eq. 10.4, regularized as ``dynamic_mass_matrix``): ``kernels.spatial_mass`` without the n x n M.
    M_b p'' as 4 L^T (J' (L p'')) + 4 w p (p . p''), every product by loops (3 x 4 at most: numba's matrix products
    are BLAS calls, each dearer than the arithmetic)."""
    for b in range(masses.size):  # L(p), L(p') as tuples of their rows (eq. 8.14): no allocation
        o, J = 7 * b, inertias[b]
        p0, p1, p2, p3 = q[o + 3], q[o + 4], q[o + 5], q[o + 6]
        a0, a1, a2, a3 = qdd[o + 3], qdd[o + 4], qdd[o + 5], qdd[o + 6]
        L, Ld = l_entries_jit(p0, p1, p2, p3), l_entries_jit(qd[o + 3], qd[o + 4], qd[o + 5], qd[o + 6])
        u = _inertia_times(J, _l_times(Ld, p0, p1, p2, p3))  # J' L(p') p
        for r in range(4):  # Q_v = 8 L(p')^T J' L(p') p
            Q[o + 3 + r] += 8.0 * (Ld[r] * u[0] + Ld[4 + r] * u[1] + Ld[8 + r] * u[2])
        for r in range(3):
            residual[o + r] = Q[o + r] - masses[b] * qdd[o + r]
        u = _inertia_times(J, _l_times(L, a0, a1, a2, a3))  # J' L(p) p''
        along = 4.0 * weights[b] * (p0 * a0 + p1 * a1 + p2 * a2 + p3 * a3)
        for r in range(4):
            Mp = 4.0 * (L[r] * u[0] + L[4 + r] * u[1] + L[8 + r] * u[2]) + along * q[o + 3 + r]
            residual[o + 3 + r] = Q[o + 3 + r] - Mp


@jit
def _l_times(L, x0, x1, x2, x3):
    """L x (L a 3 x 4 matrix as the tuple of its rows, ``l_entries_jit``), as ``kernels.l_times``."""
    return (
        L[0] * x0 + L[1] * x1 + L[2] * x2 + L[3] * x3,
        L[4] * x0 + L[5] * x1 + L[6] * x2 + L[7] * x3,
        L[8] * x0 + L[9] * x1 + L[10] * x2 + L[11] * x3,
    )


@jit
def _inertia_times(J, x):
    """J' x (3 x 3 by 3), as ``kernels.inertia_times``."""
    return (
        J[0, 0] * x[0] + J[0, 1] * x[1] + J[0, 2] * x[2],
        J[1, 0] * x[0] + J[1, 1] * x[1] + J[1, 2] * x[2],
        J[2, 0] * x[0] + J[2, 1] * x[1] + J[2, 2] * x[2],
    )


@jit
def zero_cut_blocks(jac, rows, bodies, width):
    """Zeros in the entries of Psi_q that the cut solve reads (``cut_accelerations``): each cut row at the
    coordinates of its element's two bodies (-1 ground), where the constraint kernels add their terms."""
    for a in range(rows.size):
        for side in range(2):
            b = bodies[2 * a + side]
            if b >= 0:
                jac[rows[a], width * b : width * (b + 1)] = 0.0


@jit
def tree_factor(H, parent):
    """H = L^T diag(d) L in place (Featherstone 2008, table 6.3, "LTDL"; MuJoCo's mj_factorM): L unit lower
    triangular with L_ij nonzero only where j is an ancestor of i, so it fills in nothing outside the tree's
    sparsity (H's lower triangle) and costs the sum over the columns of their depth squared: O(N) on a shallow
    tree. L_ij goes to H[i, j], d_i to H[i, i]. False when a pivot is not positive (H not positive definite)."""
    for i in range(H.shape[0] - 1, -1, -1):
        if not H[i, i] > 0.0:
            return False
        j = parent[i]
        while j >= 0:
            a = H[i, j] / H[i, i]
            g = j
            while g >= 0:  # the ancestors of j: H_jg -= a H_ig
                H[j, g] -= a * H[i, g]
                g = parent[g]
            H[i, j] = a
            j = parent[j]
    return True


@jit
def tree_back(H, parent, y):
    """y <- L^-T y, L from ``tree_factor``: from the leaves, each y_i final moves L_ij y_i to its ancestors j."""
    for i in range(y.size - 1, -1, -1):
        if y[i] != 0.0:
            j = parent[i]
            while j >= 0:
                y[j] -= H[i, j] * y[i]
                j = parent[j]


@jit
def tree_forward(H, parent, y):
    """y <- L^-1 y, L from ``tree_factor``: from ground, y_i -= L_ij y_j over the ancestors j of i."""
    for i in range(y.size):
        j = parent[i]
        while j >= 0:
            y[i] -= H[i, j] * y[j]
            j = parent[j]


BAND = 8
"""The widest band (half-width p) of the cut rows' Schur complement that ``band_solve`` factors as written here, in
O(m p^2) (the loop chain: p = 3); a wider one goes to LAPACK (``lu_solve``: gesv above LAPACK_SIZE unknowns)."""


@jit
def band_solve(S, p, x):
    """x <- the solution of S x = x by S = L diag(d) L^T within the half-band p (S symmetric, entries |i - j| > p zero:
    no fill-in outside the band; Golub and Van Loan, Matrix Computations, 4th ed., alg. 4.3.5 without the square
    roots), in O(m p^2), S overwritten. A zero pivot (S singular) gives NaN, as ``lu_solve``."""
    m = x.size
    for j in range(m):
        for i in range(j, min(m, j + p + 1)):  # column j of L: S_ij -= sum_k L_ik d_k L_jk
            s = S[i, j]
            for c in range(max(0, i - p), j):
                s -= S[i, c] * S[c, c] * S[j, c]
            S[i, j] = s
        if S[j, j] == 0.0:
            x[:] = np.nan
            return
        for i in range(j + 1, min(m, j + p + 1)):
            S[i, j] /= S[j, j]
    for i in range(m):  # L z = b, then diag(d) L^T x = z
        for c in range(max(0, i - p), i):
            x[i] -= S[i, c] * x[c]
    for i in range(m - 1, -1, -1):
        x[i] /= S[i, i]
        for r in range(i + 1, min(m, i + p + 1)):
            x[i] -= S[r, i] * x[r]


@jit
def cut_parts(structure, k, mc, nb):
    """The views of ``structure.cut_structure``'s array (made once per scene, P[8]'s last part): (p, lambda(i) of every
    joint velocity, each body's tree joint, where each cut row's and each column's entries of W begin, the rows'
    supports, each entry's slot in W column by column, the row of each entry column by column)."""
    parent, joint = structure[1 : 1 + k], structure[1 + k : 1 + k + nb]
    o = 1 + k + nb
    row_start, column_start = structure[o : o + mc + 1], structure[o + mc + 1 : o + mc + k + 2]
    o, entries = o + mc + k + 2, row_start[mc]
    support, slot = structure[o : o + entries], structure[o + entries : o + 2 * entries]
    return structure[0], parent, joint, row_start, column_start, support, slot, structure[o + 2 * entries :]


@jit
def _cut_rows(Dq, xiq, jac, psi, psit, gam, qd, rows, bodies, alpha, beta, ints, width, H, parts, w, c, dense):
    """Each cut row's W_a = L^-T Psi_theta,a^T (Psi_theta = Psi_c,q D) on its support (the columns that move the two
    bodies its element joins, ``bodies[2a], bodies[2a + 1]``, -1 for ground, which hold all their ancestors), into
    W stored column by column (``w``, the slots of ``structure.cut_structure``); and the rows' right side c of eq. 7.6.
    ``dense`` (k, zeros): a work array (left as found)."""
    _, parent, joint, row_start, _, support, slot, _ = parts
    for a in range(rows.size):
        row, r = jac[rows[a]], rows[a]
        rate = convective = 0.0
        for side in range(2):
            b = bodies[2 * a + side]
            if b < 0:
                continue
            o, e = width * b, joint[b]
            for s in range(o, o + width):
                rate += row[s] * qd[s]
                convective += row[s] * xiq[s]
            for g in range(ints[e, 5]):  # Psi_theta,a over the columns that move body b
                col, total = ints[e, 6 + g], 0.0
                for s in range(o, o + width):
                    total += row[s] * Dq[s, col]
                dense[col] += total
        for u in range(row_start[a], row_start[a + 1]):  # L^-T from the leaves: the support holds every ancestor
            i = support[u]
            if dense[i] != 0.0:
                j = parent[i]
                while j >= 0:
                    dense[j] -= H[i, j] * dense[i]
                    j = parent[j]
        for u in range(row_start[a], row_start[a + 1]):
            w[slot[u]] = dense[support[u]]
            dense[support[u]] = 0.0
        c[a] = gam[r] - 2.0 * alpha * (psit[r] + rate) - beta * beta * psi[r] - convective


@jit
def cut_accelerations(matrix, rhs, Dq, xiq, jac, psi, psit, gam, qd, rows, bodies, alpha, beta, mu, ints, width,
                      structure):  # fmt: skip
    """theta'' of a tree with cut constraints (the rows ``rows`` of Psi, Psi_q, Psi_t, gamma), and their multipliers
    mu in ``mu``, from the augmented system of eq. 7.6 (``JointCoordinates.joint_accelerations``)

        [ H          Psi_theta^T ] [ theta'' ]   [ r = D^T (Q - M xi)                               ]
        [ Psi_theta  0           ] [ mu      ] = [ c = gamma_c - Psi_c,q xi - 2 alpha Psi_c' - beta^2 Psi_c ]

    by its Schur complement on the tree's factorization (notes eq. 7.11, 7.12), as MuJoCo solves its constraints on
    mj_factorM (Featherstone 2008, sec. 6.5 and ch. 8): H = D^T M D = L^T diag(d) L along the tree (``tree_factor``),
    W = L^-T Psi_theta^T, the cut rows' S = Psi_theta H^-1 Psi_theta^T = W^T diag(d)^-1 W (m_c x m_c), then

        S mu = W^T d^-1 L^-T r - c,        theta'' = L^-1 d^-1 (L^-T r - W mu).

    Every product follows the sparsity: a cut row meets the columns of the two bodies it joins and their ancestors,
    so on a shallow tree (the loop chain: cranks from ground, couplers on them) W has a few entries per row and S is
    a band (half-width 3), factored in O(m_c) (``band_solve``); the solve is O(N) in arithmetic where the dense
    augmented LU was O((k + m_c)^3) (a deep tree, a serial chain cut at its end, fills W and S: then S goes to LAPACK).
    The sparsity (lambda(i), W's entries row by row and column by column, S's band) is the tree's structure, the
    same at every evaluation: ``structure`` (``structure.cut_structure``, made once per scene); here only arithmetic.
    ``bodies``: the two bodies of each cut row's element (-1 ground); ``matrix`` holds the lower triangle of H
    (overwritten by its factors), ``ints`` the tree's joints, ``width`` a body's coordinates (3 planar, 7 spatial).
    A singular S, or an H that is not positive definite, gives NaN (the adaptive integrators reject the step)."""
    k, mc = rhs.size, rows.size
    parts = cut_parts(structure, k, mc, jac.shape[1] // width)
    p, parent, _, _, counts, _, _, at = parts
    entries = at.size
    work = np.empty(2 * k + entries + mc * mc + 2 * mc)  # one allocation for every work array
    y, dense, w = work[:k], work[k : 2 * k], work[2 * k : 2 * k + entries]
    S = work[2 * k + entries : 2 * k + entries + mc * mc].reshape((mc, mc))
    c, s = work[2 * k + entries + mc * mc : 2 * k + entries + mc * mc + mc], work[2 * k + entries + mc * mc + mc :]
    if not tree_factor(matrix, parent):
        mu[:] = np.nan
        return np.full(k, np.nan)
    dense[:] = 0.0
    _cut_rows(Dq, xiq, jac, psi, psit, gam, qd, rows, bodies, alpha, beta, ints, width, matrix, parts, w, c, dense)
    for i in range(k):  # loops, not slice assignments (``loops._copy``)
        y[i] = rhs[i]
    tree_back(matrix, parent, y)  # L^-T r
    for a in range(mc):  # S's lower triangle within its band zeroed (all of it beyond BAND, for LAPACK)
        for b in range(max(0, a - p) if p <= BAND else 0, a + 1 if p <= BAND else mc):
            S[a, b] = 0.0
        s[a] = -c[a]
    for i in range(k):  # S = W^T d^-1 W (its lower triangle) and its right side, column by column of the tree
        inverse = 1.0 / matrix[i, i]
        for u in range(counts[i], counts[i + 1]):
            a, wa = at[u], w[u] * inverse
            s[a] += wa * y[i]
            for v in range(counts[i], u + 1):
                S[a, at[v]] += wa * w[v]
    if p <= BAND:
        band_solve(S, p, s)
        for a in range(mc):
            mu[a] = s[a]
    else:
        for a in range(mc):
            for b in range(a):
                S[b, a] = S[a, b]
        x = lu_solve(S, s)
        for a in range(mc):
            mu[a] = x[a]
    for i in range(k):  # theta'' = L^-1 d^-1 (L^-T r - W mu)
        for u in range(counts[i], counts[i + 1]):
            y[i] -= w[u] * mu[at[u]]
        y[i] /= matrix[i, i]
    tree_forward(matrix, parent, y)
    return y


__all__ = [
    "WIDTHS",
    "body_force",
    "cut_accelerations",
    "cut_row_forces",
    "planar_articulated",
    "planar_equations",
    "planar_joint_multipliers",
    "planar_motion",
    "spatial_articulated",
    "spatial_coordinate_accelerations",
    "spatial_equations",
    "spatial_joint_matrix",
    "spatial_motion",
    "tree_accelerations",
    "tree_multipliers",
    "tree_revolute",
    "zero_cut_blocks",
    "zero_tree_blocks",
]
