"""What each spatial force element exerts at every output time, compiled: the spatial half of
``element_history_kernels.py`` (whose module docstring says what is computed and why), a module of its own so that a
planar run never compiles it (numba compiles a module's signatures at its import).

- ``spatial_tsda_history``: (tension f = k (l - l0) + c l' + f_a(t) (eq. 10.12), power, potential
  1/2 k (l - l0)^2, length l);
- ``spatial_rsda_history``: (torque f = k (theta - theta0) + c theta' + f_a(t) about h_i (eq. 10.13), power,
  potential 1/2 k (theta - theta0)^2), theta taken in (theta0 - pi, theta0 + pi] as ``spatial/forces.RSDA``;
- ``spatial_load_history``: (the global force F or torque n, power) of a point force or a torque (eq. 10.10).

The power q_i'^T Q_i + q_j'^T Q_j from the engine's own force kernel (``kernels.py``) on the element's row alone.

This module imports numba: it is imported only when a compiled run of a spatial model has force elements.
"""

from __future__ import annotations

import math

import numpy as np

from .element_history_kernels import block_power, spring_row
from .history_kernels import CUBE, IMATRIX, IVECTOR, MATRIX, VECTOR, eager, inlined
from .kernels import (
    angular_velocity,
    body_position,
    euler_parameters,
    function,
    orientation,
    point_terms,
    rotate,
    spatial_load,
    spatial_rsda,
    spatial_tsda,
)


@inlined
def _point(q, qd, b, s):
    """(r + A s', r' + B(p, s') p') of the body point s' of body b: the point and its velocity (eq. 9.1, 9.3)."""
    A, B, _ = point_terms(q, qd, b, s[0], s[1], s[2])
    r, v = body_position(q, b), body_position(qd, b)
    d0, d1, d2, d3 = euler_parameters(qd, b)  # ground's p' is zero
    dot0 = B[0] * d0 + B[1] * d1 + B[2] * d2 + B[3] * d3
    dot1 = B[4] * d0 + B[5] * d1 + B[6] * d2 + B[7] * d3
    dot2 = B[8] * d0 + B[9] * d1 + B[10] * d2 + B[11] * d3
    return (r[0] + A[0], r[1] + A[1], r[2] + A[2]), (v[0] + dot0, v[1] + dot1, v[2] + dot2)


@inlined
def _tsda_state(q, qd, i, j, s):
    """(l, l') of the spring-damper between P_i (s[0:3] on body i) and P_j (s[3:6] on body j): l = |d_ij|,
    l' = u^T d_ij', u = d_ij / l (eq. 10.12)."""
    (pix, piy, piz), (vix, viy, viz) = _point(q, qd, i, s[0:3])
    (pjx, pjy, pjz), (vjx, vjy, vjz) = _point(q, qd, j, s[3:6])
    dx, dy, dz = pjx - pix, pjy - piy, pjz - piz
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    ux, uy, uz = dx / length, dy / length, dz / length
    return length, ux * (vjx - vix) + uy * (vjy - viy) + uz * (vjz - viz)


@eager(VECTOR, MATRIX, MATRIX, IMATRIX, MATRIX, IVECTOR, MATRIX, CUBE)
def spatial_tsda_history(times, q, qd, ints, floats, fk, fp, out):
    """(f, power, V, l) of every spring-damper-actuator at every output time (module docstring). ints (i, j,
    actuator function), floats (s_i', s_j', k, c, l0), as ``kernels.spatial_tsda`` reads them."""
    Q, powers = np.zeros(q.shape[1]), np.zeros(2)
    for k in range(times.size):
        for e in range(ints.shape[0]):
            i, j, t = ints[e, 0], ints[e, 1], times[k]
            spatial_tsda(q[k], qd[k], t, ints[e : e + 1], floats[e : e + 1], fk, fp, Q, powers)
            power = block_power(qd[k], Q, i, 7) + block_power(qd[k], Q, j, 7)
            length, velocity = _tsda_state(q[k], qd[k], i, j, floats[e])
            spring_row(out[e, k], length, velocity, floats[e, 6:9], function(fk, fp, ints[e, 2], t, 0), power)


@eager(VECTOR, MATRIX, MATRIX, IMATRIX, MATRIX, IVECTOR, MATRIX, CUBE)
def spatial_rsda_history(times, q, qd, ints, floats, fk, fp, out):
    """(f, power, V) of every rotational spring-damper-actuator at every output time: theta = atan2(g_i^T f_j,
    f_i^T f_j) in (theta0 - pi, theta0 + pi], theta' = h_i^T (omega_j - omega_i) (module docstring). ints (i, j,
    actuator function), floats (f_i', g_i', h_i', f_j', k, c, theta0), as ``kernels.spatial_rsda`` reads them."""
    Q, powers = np.zeros(q.shape[1]), np.zeros(2)
    fi, gi, hi, fj = np.empty((4, 3))
    for k in range(times.size):
        for e in range(ints.shape[0]):
            i, j = ints[e, 0], ints[e, 1]
            pi0, pi1, pi2, pi3 = orientation(q[k], i)
            pj0, pj1, pj2, pj3 = orientation(q[k], j)
            rotate(pi0, pi1, pi2, pi3, floats[e, 0:3], fi)
            rotate(pi0, pi1, pi2, pi3, floats[e, 3:6], gi)
            rotate(pi0, pi1, pi2, pi3, floats[e, 6:9], hi)
            rotate(pj0, pj1, pj2, pj3, floats[e, 9:12], fj)
            stiffness, damping, free = floats[e, 12], floats[e, 13], floats[e, 14]
            theta = math.atan2(
                gi[0] * fj[0] + gi[1] * fj[1] + gi[2] * fj[2], fi[0] * fj[0] + fi[1] * fj[1] + fi[2] * fj[2]
            )
            x = theta - free
            angle = free + (x - 2.0 * math.pi * np.round(x / (2.0 * math.pi)))  # math.remainder, as the kernel
            wj0, wj1, wj2 = angular_velocity(q[k], qd[k], j)
            wi0, wi1, wi2 = angular_velocity(q[k], qd[k], i)
            velocity = hi[0] * (wj0 - wi0) + hi[1] * (wj1 - wi1) + hi[2] * (wj2 - wi2)
            spring = stiffness * (angle - free)
            out[e, k, 0] = spring + damping * velocity + function(fk, fp, ints[e, 2], times[k], 0)
            spatial_rsda(q[k], qd[k], times[k], ints[e : e + 1], floats[e : e + 1], fk, fp, Q, powers)
            out[e, k, 1] = block_power(qd[k], Q, i, 7) + block_power(qd[k], Q, j, 7)
            out[e, k, 2] = 0.5 * stiffness * (angle - free) ** 2


@eager(VECTOR, MATRIX, MATRIX, IMATRIX, MATRIX, IVECTOR, MATRIX, CUBE)
def spatial_load_history(times, q, qd, ints, floats, fk, fp, out):
    """(the global F or n, power) of every point force and torque at every output time: A_i F' (A_i n') where it is
    fixed in the body (module docstring). ints (i, kind 0 force / 1 torque, body fixed, f_x, f_y, f_z), floats
    (s_i'), as ``kernels.spatial_load`` reads them."""
    Q, powers = np.zeros(q.shape[1]), np.zeros(2)
    value, turned = np.empty(3), np.empty(3)
    for k in range(times.size):
        for e in range(ints.shape[0]):
            i = ints[e, 0]
            for c in range(3):
                value[c] = function(fk, fp, ints[e, 3 + c], times[k], 0)
            if ints[e, 2]:
                p0, p1, p2, p3 = orientation(q[k], i)
                rotate(p0, p1, p2, p3, value, turned)
                value[0], value[1], value[2] = turned[0], turned[1], turned[2]
            out[e, k, 0], out[e, k, 1], out[e, k, 2] = value[0], value[1], value[2]
            spatial_load(q[k], qd[k], times[k], ints[e : e + 1], floats[e : e + 1], fk, fp, Q, powers)
            out[e, k, 3] = block_power(qd[k], Q, i, 7)
