"""What a compiled run of a spatial model reports at every output time besides its motion, compiled: the spatial
halves of ``history_kernels.py`` (whose module docstring says what they compute and why), a module of their own so
that a planar run never compiles them (numba compiles a module's signatures at its import: ~2.5 s of a planar
model's first run).

``spatial_reactions``: the force and moment of every spatial joint at every output time in one pass.

``spatial_kinetic_energy``: T of a spatial model at every output time (``spatial.mass.kinetic_energy_history``'s
three einsums and the stack of L cost ~0.05-0.1 ms of a two-body run's result).

This module imports numba: it is imported only when the compiled engine runs a spatial model (``history.py``).
"""

from __future__ import annotations

import math

import numpy as np

from .history_kernels import CUBE, IVECTOR, MATRIX, VECTOR, eager, inlined, joint_force
from .kernels import g_entries_jit, l_entries_jit, rotation_entries_jit


@inlined
def _unit_parameters(q, t, body):
    """The unit Euler parameters of ``body`` at output time t (ground: (1, 0, 0, 0))."""
    if body < 0:
        return 1.0, 0.0, 0.0, 0.0
    e0, e1, e2, e3 = q[t, 7 * body + 3], q[t, 7 * body + 4], q[t, 7 * body + 5], q[t, 7 * body + 6]
    size = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
    return e0 / size, e1 / size, e2 / size, e3 / size


@inlined
def _turns(q, t, body, A, G):
    """A(p) (eq. 8.12) and G(p) (eq. 8.14) of ``body`` at output time t, p normalized, into A[body] (3, 3) and
    G[body] (3, 4); ground's into the last rows A[-1], G[-1]."""
    parameters = _unit_parameters(q, t, body)
    rotation, g = rotation_entries_jit(*parameters), g_entries_jit(*parameters)
    for a in range(9):
        A[body, a // 3, a % 3] = rotation[a]
    for a in range(12):
        G[body, a // 4, a % 4] = g[a]


@eager(MATRIX, MATRIX, CUBE, *(IVECTOR,) * 5, MATRIX, CUBE, IVECTOR, IVECTOR, IVECTOR, MATRIX)
def spatial_reactions(q, lam, jac, slots, rows, starts, i, j, offsets, frames, framed, turned, columns, out):
    """out (columns, N): every spatial element's force and moment about its point on its second body (rows c to
    c + 5 from its first column c = ``columns[k]``: Fx, Fy, Fz, Mx, My, Mz) and of the elements with joint frames
    (``framed``: their place in ``frames``, else -1) F and M in that frame (rows c + 6 to c + 11: Fx, Mx, Fy, My,
    Fz, Mz), the frame's axes f, g, h (columns of ``frames``) turned to global axes by A(p_j) (module docstring),
    a result column a row. A(p) and G(p) of each body in ``turned`` (those the elements read) are made once an
    output time: an element reads A of its body j and G of the body it reports, most often the same."""
    N, elements = q.shape[0], i.size
    g, n, arm, point, force, moment = np.empty(7), np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    axes = np.empty((3, 3))
    A, G = np.empty((q.shape[1] // 7 + 1, 3, 3)), np.empty((q.shape[1] // 7 + 1, 3, 4))  # ground's last
    _turns(q, 0, -1, A, G)
    for t in range(N):
        for b in turned:
            _turns(q, t, b, A, G)
        for k in range(elements):
            first = starts[k]
            last = starts[k + 1] if k + 1 < elements else rows.size
            Aj = A[j[k]]  # ground: the last, A = I
            for a in range(3):
                origin = q[t, 7 * j[k] + a] if j[k] >= 0 else 0.0
                point[a] = origin + (Aj[a, 0] * offsets[k, 0] + Aj[a, 1] * offsets[k, 1] + Aj[a, 2] * offsets[k, 2])
            body, sign = (j[k], 1.0) if j[k] >= 0 else (i[k], -1.0)
            g[0], g[1], g[2] = joint_force(jac, lam, t, rows, first, last, slots, 0)  # r's columns
            g[3], g[4], g[5] = joint_force(jac, lam, t, rows, first, last, slots, 3)  # p's: seven in runs of three,
            g[4], g[5], g[6] = joint_force(jac, lam, t, rows, first, last, slots, 4)  # the last two sums made again
            Gb = G[body]
            for a in range(3):  # n = 1/2 G(p) Q_p (eq. 8.14)
                n[a] = 0.5 * (Gb[a, 0] * g[3] + Gb[a, 1] * g[4] + Gb[a, 2] * g[5] + Gb[a, 3] * g[6])
                arm[a] = point[a] - q[t, 7 * body + a]
            moment[0] = n[0] - (arm[1] * g[2] - arm[2] * g[1])
            moment[1] = n[1] - (arm[2] * g[0] - arm[0] * g[2])
            moment[2] = n[2] - (arm[0] * g[1] - arm[1] * g[0])
            c = columns[k]
            for a in range(3):
                force[a], moment[a] = sign * g[a], sign * moment[a]
                out[c + a, t], out[c + 3 + a, t] = force[a], moment[a]
            f = framed[k]
            if f >= 0:  # [f g h]^T A(p_j)^T F: the joint frame's axes, global, as rows
                for a in range(3):
                    for b in range(3):
                        axes[a, b] = (
                            Aj[a, 0] * frames[f, 0, b] + Aj[a, 1] * frames[f, 1, b] + Aj[a, 2] * frames[f, 2, b]
                        )
                for b in range(3):
                    out[c + 6 + 2 * b, t] = axes[0, b] * force[0] + axes[1, b] * force[1] + axes[2, b] * force[2]
                    out[c + 7 + 2 * b, t] = axes[0, b] * moment[0] + axes[1, b] * moment[1] + axes[2, b] * moment[2]


@eager(MATRIX, MATRIX, VECTOR, CUBE, VECTOR)
def spatial_kinetic_energy(q, qd, masses, inertias, out):
    """T = sum_b 1/2 m_b r_b'^T r_b' + 1/2 omega_b'^T J_b' omega_b', omega_b' = 2 L(p_b) p_b' (eq. 10.3, 8.14) at
    every output time: ``spatial.mass.kinetic_energy_history``'s numbers within rounding (the same products,
    summed body by body where its einsums sum as numpy orders them), in one pass with no (N, nb, 3, 4) L."""
    for t in range(q.shape[0]):
        translation, rotation = 0.0, 0.0
        for b in range(masses.size):
            o = 7 * b
            v0, v1, v2 = qd[t, o], qd[t, o + 1], qd[t, o + 2]
            translation += masses[b] * (v0 * v0 + v1 * v1 + v2 * v2)
            L = l_entries_jit(q[t, o + 3], q[t, o + 4], q[t, o + 5], q[t, o + 6])
            d0, d1, d2, d3 = qd[t, o + 3], qd[t, o + 4], qd[t, o + 5], qd[t, o + 6]
            w0 = 2.0 * (L[0] * d0 + L[1] * d1 + L[2] * d2 + L[3] * d3)
            w1 = 2.0 * (L[4] * d0 + L[5] * d1 + L[6] * d2 + L[7] * d3)
            w2 = 2.0 * (L[8] * d0 + L[9] * d1 + L[10] * d2 + L[11] * d3)
            J = inertias[b]
            rotation += w0 * (J[0, 0] * w0 + J[0, 1] * w1 + J[0, 2] * w2)
            rotation += w1 * (J[1, 0] * w0 + J[1, 1] * w1 + J[1, 2] * w2)
            rotation += w2 * (J[2, 0] * w0 + J[2, 1] * w1 + J[2, 2] * w2)
        out[t] = 0.5 * translation + 0.5 * rotation
