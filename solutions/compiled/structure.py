"""The cut solve's sparsity, the tree's structure alone, compiled (issue 25).

A closed-loop scene in joint coordinates solves its cut rows by the tree's factorization (``tree_kernels.
cut_accelerations``: Featherstone 2008, sec. 6.5, H's sparsity from lambda(i)). What that solve reads besides the
numbers depends on the tree alone: made once per scene here (``TreeScene.structure``, into P[8]) from the joints'
rows (``tree.describe``: each joint's kind, child and the columns of D that move its child) and the two bodies of
each cut row. One pass over the joints and one over the cut rows' supports, in place of ~40 us of Python lists at a
loop chain of four (~100 us at sixteen), part of every call's start.

This module imports numba: it is imported only where the compiled engine runs (a run's parameters, after the
engine's choice). Its function is compiled at import (or loaded from disk), with the integrator loops by
``mbd compile``.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types

SPHERICAL = 2
"""``tree.KINDS['spherical']``: a joint with three velocity columns (the others have one)."""


@njit(types.int64[::1](types.int64[:, ::1], types.int64[::1], types.int64, types.int64), cache=True, nogil=True)
def cut_structure(ints, bodies, k, nb):
    """The integer side of the cut solve (``tree_kernels.cut_accelerations``) as one array, from the tree's joint
    rows ``ints`` (``tree.describe``: kind, parent, child, position, velocity, the count of the columns that move the
    child, those columns ascending) and the two bodies of each cut row, row after row (-1 ground). In order
    (``tree_kernels.cut_parts`` cuts it):

    - the half-band p of the cut rows' S = W^T d^-1 W (``band_solve``; a wider one goes to LAPACK);
    - lambda(i), the tree's parent of every joint velocity (-1 at ground): the previous column of the same joint (a
      spherical joint's three), else the last column of the joint's parent;
    - the tree joint whose child each body is (-1 ground);
    - where each cut row's entries of W begin (mc + 1), and where each column's (k + 1);
    - each cut row's support, the columns that move the two bodies its element joins (their union, descending: the
      ancestors of each column come after it, as L^-T needs); the slot of each of those entries in W stored column
      by column; the row of each entry column by column (rows increasing within a column)."""
    mc = bodies.size // 2
    joint, parent = np.full(nb, -1, dtype=np.int64), np.full(k, -1, dtype=np.int64)
    for e in range(ints.shape[0]):
        count, own = ints[e, 5], 3 if ints[e, 0] == SPHERICAL else 1
        joint[ints[e, 2]] = e
        for a in range(max(count - own, 1), count):
            parent[ints[e, 6 + a]] = ints[e, 5 + a]
    marked = np.zeros(k, dtype=np.bool_)  # the columns of one row's support
    row_start, support = np.zeros(mc + 1, dtype=np.int64), np.empty(mc * k, dtype=np.int64)
    for a in range(mc):
        for side in range(2):
            b = bodies[2 * a + side]
            if b >= 0:
                for g in range(ints[joint[b], 5]):
                    marked[ints[joint[b], 6 + g]] = True
        at = row_start[a]
        for i in range(k - 1, -1, -1):  # descending
            if marked[i]:
                support[at], marked[i], at = i, False, at + 1
        row_start[a + 1] = at
    entries = row_start[mc]
    column_start = np.zeros(k + 1, dtype=np.int64)
    for u in range(entries):
        column_start[support[u] + 1] += 1
    for i in range(k):
        column_start[i + 1] += column_start[i]
    filled, slot, row = column_start[:k].copy(), np.empty(entries, dtype=np.int64), np.empty(entries, dtype=np.int64)
    for a in range(mc):  # rows in order: increasing within each column
        for u in range(row_start[a], row_start[a + 1]):
            i = support[u]
            slot[u], row[filled[i]] = filled[i], a
            filled[i] += 1
    band = 0
    for i in range(k):
        if column_start[i + 1] > column_start[i]:
            band = max(band, row[column_start[i + 1] - 1] - row[column_start[i]])
    out = np.empty(1 + k + nb + mc + 1 + k + 1 + 3 * entries, dtype=np.int64)
    out[0] = band
    o = 1
    for part in (parent, joint, row_start, column_start, support[:entries], slot, row):
        for i in range(part.size):  # a loop, not a slice assignment (``loops._copy``)
            out[o + i] = part[i]
        o += part.size
    return out


__all__ = ["cut_structure"]
