"""What each planar force element exerts at every output time, compiled: ``element_history.py`` hands the run's q, q'
histories and the scene's force data (``scene.force_data``: the rows the engine's force kernels read) to these loops.

At output time k every element e of a kernel's rows gets one row of ``out[e, k]``:

- ``planar_tsda_history``: (tension f = k (l - l0) + c l' + f_a(t) (eq. 5.14), power, potential 1/2 k (l - l0)^2,
  length l);
- ``planar_rsda_history``: (torque f = k (theta - theta0) + c theta' + f_a(t) (eq. 5.15), power,
  potential 1/2 k (theta - theta0)^2);
- ``planar_load_history``: (F_x, F_y global, the torque T, power) of a point force or a torque (eq. 5.10).

The power is q_i'^T Q_i + q_j'^T Q_j with (Q_i, Q_j) from the engine's own force kernel (``kernels.py``) on the
element's row alone: the generalized force the run integrated. These are the numbers of the elements' per-state
methods (``planar/forces.py``: ``measures``, ``forces``, ``potential``; what students read), within rounding
(``tests/solutions/test_element_history.py``), in one pass where the per-state loop costs ~50 us per element and
output time in Python (60-85 % of a compiled call on a scene with a spring).

This module imports numba: it is imported only when a compiled run's model has force elements. Its loops are compiled
at import (``history_kernels.eager``), with the integrator loops by ``mbd compile``.
"""

from __future__ import annotations

import math

import numpy as np

from .history_kernels import CUBE, IMATRIX, IVECTOR, MATRIX, VECTOR, eager, inlined
from .kernels import body_coordinates, body_vectors, function, planar_load, planar_rsda, planar_tsda, point_vectors


@inlined
def block_power(qd, Q, b, width):
    """q_b'^T Q_b of body b (width coordinates; ground b < 0 has none: 0), and Q_b set back to zero for the next
    element (``Q`` holds one element's generalized force at a time)."""
    if b < 0:
        return 0.0
    total = 0.0
    for c in range(width * b, width * b + width):
        total += qd[c] * Q[c]
        Q[c] = 0.0
    return total


@inlined
def _tsda_state(q, qd, i, j, s):
    """(l, l') of the spring-damper between P_i (s[0:2] on body i) and P_j (s[2:4] on body j) (eq. 5.12), from d_ij
    and d_ij' (``kernels.point_vectors``)."""
    d, d_dot, _, _, _ = point_vectors(q, qd, i, j, s[0], s[1], s[2], s[3])
    length = math.sqrt(d[0] * d[0] + d[1] * d[1])
    return length, (d[0] * d_dot[0] + d[1] * d_dot[1]) / length


@inlined
def spring_row(row, length, velocity, parameters, actuator, power):
    """row = (f = k (l - l0) + c l' + f_a, power, V = 1/2 k (l - l0)^2, l) of a spring-damper-actuator at one time,
    parameters (k, c, l0) (eq. 5.14, 10.12)."""
    stiffness, damping, free = parameters[0], parameters[1], parameters[2]
    spring = stiffness * (length - free)
    row[0] = spring + damping * velocity + actuator
    row[1] = power
    row[2] = 0.5 * stiffness * (length - free) ** 2
    row[3] = length


@eager(VECTOR, MATRIX, MATRIX, IMATRIX, MATRIX, IVECTOR, MATRIX, CUBE)
def planar_tsda_history(times, q, qd, ints, floats, fk, fp, out):
    """(f, power, V, l) of every spring-damper-actuator at every output time (module docstring). ints (i, j,
    actuator function), floats (s_i', s_j', k, c, l0), as ``kernels.planar_tsda`` reads them."""
    Q, powers = np.zeros(q.shape[1]), np.zeros(2)
    for k in range(times.size):
        for e in range(ints.shape[0]):
            i, j, t = ints[e, 0], ints[e, 1], times[k]
            planar_tsda(q[k], qd[k], t, ints[e : e + 1], floats[e : e + 1], fk, fp, Q, powers)
            power = block_power(qd[k], Q, i, 3) + block_power(qd[k], Q, j, 3)
            length, velocity = _tsda_state(q[k], qd[k], i, j, floats[e])
            spring_row(out[e, k], length, velocity, floats[e, 4:7], function(fk, fp, ints[e, 2], t, 0), power)


@eager(VECTOR, MATRIX, MATRIX, IMATRIX, MATRIX, IVECTOR, MATRIX, CUBE)
def planar_rsda_history(times, q, qd, ints, floats, fk, fp, out):
    """(f, power, V) of every rotational spring-damper-actuator at every output time, theta = phi_j - phi_i (module
    docstring). ints (i, j, actuator function), floats (k, c, theta0), as ``kernels.planar_rsda`` reads them."""
    Q, powers = np.zeros(q.shape[1]), np.zeros(2)
    for k in range(times.size):
        for e in range(ints.shape[0]):
            i, j = ints[e, 0], ints[e, 1]
            stiffness, damping, free = floats[e, 0], floats[e, 1], floats[e, 2]
            angle = body_coordinates(q[k], j)[2] - body_coordinates(q[k], i)[2]
            velocity = body_coordinates(qd[k], j)[2] - body_coordinates(qd[k], i)[2]
            spring = stiffness * (angle - free)
            out[e, k, 0] = spring + damping * velocity + function(fk, fp, ints[e, 2], times[k], 0)
            planar_rsda(q[k], qd[k], times[k], ints[e : e + 1], floats[e : e + 1], fk, fp, Q, powers)
            out[e, k, 1] = block_power(qd[k], Q, i, 3) + block_power(qd[k], Q, j, 3)
            out[e, k, 2] = 0.5 * stiffness * (body_coordinates(q[k], j)[2] - body_coordinates(q[k], i)[2] - free) ** 2


@eager(VECTOR, MATRIX, MATRIX, IMATRIX, MATRIX, IVECTOR, MATRIX, CUBE)
def planar_load_history(times, q, qd, ints, floats, fk, fp, out):
    """(F_x, F_y, T, power) of every point force (F global: A_i F' when body-fixed) and torque at every output time
    (module docstring). ints (i, f_x, f_y, body fixed, torque function), floats (s_i'), as ``kernels.planar_load``."""
    Q, powers = np.zeros(q.shape[1]), np.zeros(2)
    for k in range(times.size):
        for e in range(ints.shape[0]):
            i = ints[e, 0]
            fx, fy = function(fk, fp, ints[e, 1], times[k], 0), function(fk, fp, ints[e, 2], times[k], 0)
            if ints[e, 3]:
                fx, fy, _, _ = body_vectors(body_coordinates(q[k], i)[2], fx, fy)
            out[e, k, 0], out[e, k, 1] = fx, fy
            out[e, k, 2] = function(fk, fp, ints[e, 4], times[k], 0)
            planar_load(q[k], qd[k], times[k], ints[e : e + 1], floats[e : e + 1], fk, fp, Q, powers)
            out[e, k, 3] = block_power(qd[k], Q, i, 3)
