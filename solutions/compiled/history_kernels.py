"""What a compiled run reports at every output time besides its motion, compiled: ``history.py`` hands its index
layouts (made once per system) and the run's histories q, q', lambda, Psi_q and Psi_t to these loops.

``residual_maxima``: max |Psi| and max |Psi_q q' + Psi_t| over the rows at every output time, the product over the
columns of the bodies the row's element joins (its nonzeros: at most 2 x 7 of n columns), where a batched product
of the dense Psi_q with q' multiplies every zero too (101 x 256 x 448 on a spatial chain of 64 bodies: 6 ms, more
than a tenth of the integration).

``planar_reactions`` (``spatial_history_kernels.spatial_reactions``): the force and moment of every joint at every
output time in one pass.

``planar_kinetic_energy`` (``spatial_history_kernels.spatial_kinetic_energy``): T at every output time.

``blocked_constraint_arrays``: a large Psi_q's history by its rows' blocks
(``history.BlockedJacobians``), made and read without the dense (N, m, n) array (the reactions take its blocks
through ``slots``: where the reported body's columns begin in each row).

The arithmetic is that of the numpy engine's ``reactions.py`` and ``spatial/reactions.py`` (what students write),
term by term: the generalized force of joint k on its body b, Q_b^k = -(Psi_qb^k)^T lambda_k summed over the
joint's rows (eq. 5.70, 10.20); planar, the force F = (Q_x, Q_y) and the moment about the joint point P,
M = Q_phi - (r_P - r_b) x F (eq. 5.71); spatial, the torque n = 1/2 G(p_b) Q_p (eq. 8.14) and the moment
M = n - (r_P - r_b) x F (eq. 10.21), F and M also in the joint frame fixed in body j. A joint on ground reports
minus what it exerts on its moving body (the second body's reaction, DESIGN section 5). Over the output times the
same columns come out of numpy's array operations within rounding (``tests/solutions/test_compiled_history.py``);
the loops spare a 2-body run the hundred small array operations that cost more than its integration.

This module imports numba: it is imported only when the compiled engine runs (``solutions.compiled``). Its loops
are compiled at import (``eager``), with the integrator loops by ``mbd compile``; loading them from disk takes
some 30 ms, once per process.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from .loops import CONSTRAINT_ARRAYS_SIGNATURE, D_TYPE, P_TYPE

jit = njit(cache=True, fastmath=False, nogil=True)
inlined = njit(cache=True, fastmath=False, nogil=True, inline="always")
"""The helpers a loop calls per element and output time, written into the loop by numba (a call of a compiled
function costs two atomic reference counts per array it is handed, ~10 ns each: more than a 3 x 3 rotation)."""
VECTOR, IVECTOR = types.float64[::1], types.int64[::1]
MATRIX, IMATRIX, CUBE = types.float64[:, ::1], types.int64[:, ::1], types.float64[:, :, ::1]
_CONSTRAINTS = types.FunctionType(CONSTRAINT_ARRAYS_SIGNATURE)


def eager(*arguments):
    """Compiled at import with these argument types (or loaded from disk): ``mbd compile`` makes them with the
    loops (``precompile._loops``), so that no run waits for them."""
    return njit(types.void(*arguments), cache=True, fastmath=False, nogil=True)


@jit
def _larger(largest, value):
    """max(largest, value), NaN kept once met (``np.max``'s rule)."""
    if math.isnan(largest) or math.isnan(value):
        return math.nan
    return value if value > largest else largest


@eager(CUBE, MATRIX, MATRIX, MATRIX, IMATRIX, IMATRIX, VECTOR, VECTOR)
def residual_maxima(stored, qd, psi, psit, columns, slots, position, velocity):
    """position[t] = max_r |Psi_r| and velocity[t] = max_r |(Psi_q q')_r + (Psi_t)_r| at every output time t (the
    residuals of eq. 4.1 and 4.5, ``dynamics.constraint_residuals``), 0 without rows, NaN where any entry is NaN (as
    ``np.max``). The product over ``columns[r]`` (the row's nonzero columns, -1 after the last): the entry of column
    columns[r, c] is stored[t, r, slots[r, c]], in that column of a dense history (N, m, n), slots = columns, or in
    slot c of a history by its rows' blocks (N, m, w), ``history.BlockedJacobians``. One pass, where the velocity
    residual of every row and two reductions in numpy made three (a maximum is exact: the same numbers)."""
    for t in range(stored.shape[0]):
        largest_position = largest_velocity = 0.0
        for r in range(stored.shape[1]):
            total = 0.0
            for c in range(columns.shape[1]):
                column = columns[r, c]
                if column < 0:
                    break
                total += stored[t, r, slots[r, c]] * qd[t, column]
            largest_position = _larger(largest_position, abs(psi[t, r]))
            largest_velocity = _larger(largest_velocity, abs(total + psit[t, r]))
        position[t], velocity[t] = largest_position, largest_velocity


@eager(_CONSTRAINTS, VECTOR, MATRIX, P_TYPE, D_TYPE, MATRIX, CUBE, MATRIX, IMATRIX, types.int64)
def blocked_constraint_arrays(constraint_arrays, T, Y, P, D, psi, values, psit, columns, n):
    """Psi (N, m), Psi_q by its rows' blocks (N, m, w) and Psi_t (N, m) at every output time: the module's
    ``constraint_arrays`` at one time after another into one (m, n) (zeros on entry, as it wants them), its
    entries in each row's ``columns`` gathered into ``values`` and zeroed again (the only ones it writes:
    ``history.row_columns``); no (N, m, n) history, whose first touch costs more than its arithmetic."""
    m, w = columns.shape
    one_t, one_y = np.empty(1), np.empty((1, Y.shape[1]))
    one_psi, jac, one_psit = np.zeros((1, m)), np.zeros((1, m, n)), np.zeros((1, m))
    for k in range(T.size):
        one_t[0] = T[k]
        for i in range(Y.shape[1]):  # loops, not slice assignments (``loops._copy``)
            one_y[0, i] = Y[k, i]
        one_psi[:] = 0.0
        one_psit[:] = 0.0
        constraint_arrays(one_t, one_y, P, D, one_psi, jac, one_psit)
        for r in range(m):
            psi[k, r], psit[k, r] = one_psi[0, r], one_psit[0, r]
        for r in range(m):
            for s in range(w):
                column = columns[r, s]
                if column < 0:
                    break
                values[k, r, s] = jac[0, r, column]
                jac[0, r, column] = 0.0


@inlined
def joint_force(jac, lam, t, rows, first, last, slots, c):
    """Entries c, c + 1, c + 2 of -(Psi_q)^T lambda on a body's columns, summed over the joint's rows rows[first:last]
    (eq. 5.70, 10.20) at output time t; the body's columns begin at slots[r] in row rows[r] of ``jac`` (its column,
    or its slot among a blocked history's blocks). The three sums side by side in locals, each over the rows in their
    order, in one pass over the rows: sums kept in an array (which may alias ``jac`` for the compiler) went to memory
    at every term, and one entry a pass read each row's index and multiplier again: either way a third more of the
    reactions' time (``benchmarks/results/call_cost.md``, twenty-sixth session)."""
    a = b = d = 0.0
    for r in range(first, last):
        row, column = rows[r], slots[r] + c
        multiplier = lam[t, row]
        a += -jac[t, row, column] * multiplier
        b += -jac[t, row, column + 1] * multiplier
        d += -jac[t, row, column + 2] * multiplier
    return a, b, d


@eager(MATRIX, MATRIX, CUBE, *(IVECTOR,) * 6, MATRIX, IVECTOR, MATRIX)
def planar_reactions(q, lam, jac, slots, rows, starts, i, j, carrier, s, carriers, out):
    """out (3 joints, N): every planar joint's force (rows 3k, 3k + 1) and moment about its point on its second
    body (row 3k + 2, module docstring) at every output time, a result column a row; ``slots``: where that body's
    columns begin in each row of ``jac`` (``joint_force``). cos and sin of each body in ``carriers`` (those that
    carry a joint point) are taken once an output time: a body carries the points of up to three joints."""
    N, joints = q.shape[0], i.size
    turn = np.empty((q.shape[1] // 3, 2))
    for t in range(N):
        for b in carriers:
            turn[b, 0], turn[b, 1] = math.cos(q[t, 3 * b + 2]), math.sin(q[t, 3 * b + 2])
        for k in range(joints):
            first = starts[k]
            last = starts[k + 1] if k + 1 < joints else rows.size
            b = carrier[k]  # the joint point r_b + A(phi_b) s (eq. 2.2); ground: the origin, A = I
            x, y, c, sn = (q[t, 3 * b], q[t, 3 * b + 1], turn[b, 0], turn[b, 1]) if b >= 0 else (0.0, 0.0, 1.0, 0.0)
            px, py = x + (c * s[k, 0] - sn * s[k, 1]), y + (sn * s[k, 0] + c * s[k, 1])
            body, sign = (j[k], 1.0) if j[k] >= 0 else (i[k], -1.0)
            fx, fy, torque = joint_force(jac, lam, t, rows, first, last, slots, 0)
            ax, ay = px - q[t, 3 * body], py - q[t, 3 * body + 1]
            out[3 * k, t], out[3 * k + 1, t] = sign * fx, sign * fy
            out[3 * k + 2, t] = sign * (torque - (ax * fy - ay * fx))


PAIRWISE_BLOCK = 128
"""Terms that numpy's pairwise summation adds in one block (its ``PW_BLOCKSIZE``); a longer row it splits in two."""


@inlined
def _pairwise_sum(a):
    """sum_i a_i in the order of numpy's ``np.sum`` over a contiguous row of at most ``PAIRWISE_BLOCK`` terms (its
    ``pairwise_sum``): fewer than 8 terms one after another; else eight running sums (terms i, i + 8, ...) added as
    ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7)), then the terms after the last multiple of 8 one by one. The
    same additions in the same order: the same bits. (A longer row's halves would need a recursion, which numba's
    cache loads wrongly: the caller keeps those rows to numpy.)"""
    count = a.size
    if count < 8:
        total = 0.0
        for i in range(count):
            total += a[i]
        return total
    s0, s1, s2, s3, s4, s5, s6, s7 = a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]
    blocks_end = count - count % 8
    for i in range(8, blocks_end, 8):
        s0, s1, s2, s3 = s0 + a[i], s1 + a[i + 1], s2 + a[i + 2], s3 + a[i + 3]
        s4, s5, s6, s7 = s4 + a[i + 4], s5 + a[i + 5], s6 + a[i + 6], s7 + a[i + 7]
    total = ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))
    for i in range(blocks_end, count):
        total += a[i]
    return total


@eager(MATRIX, VECTOR, VECTOR)
def planar_kinetic_energy(qd, diagonal, out):
    """T = 1/2 sum_i m_i q_i'^2 (eq. 5.2, M = diag(m, m, J): ``diagonal``) at every output time in one pass, q' of at
    most ``PAIRWISE_BLOCK`` coordinates: each term (q_i' m_i) q_i' as numpy's elementwise products, their sum in
    ``np.sum``'s order (``_pairwise_sum``), so ``0.5 * np.sum((qd * diagonal) * qd, axis=-1)`` bit for bit without
    its three array operations over the history (~9 of a loop chain's 13 us)."""
    terms = np.empty(qd.shape[1])
    for t in range(qd.shape[0]):
        for i in range(qd.shape[1]):
            terms[i] = (qd[t, i] * diagonal[i]) * qd[t, i]
        out[t] = 0.5 * _pairwise_sum(terms)
