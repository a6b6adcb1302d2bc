"""Compiled kernels of the compiled engine: one function per element type, force type and formulation step.

Each kernel evaluates every element of one type, from the element data stacked in two arrays (``ints``:
bodies, first constraint row, function indices; ``floats``: body-frame vectors and parameters, one row per
element; ``scene.py`` builds them). They are the formulas of the numpy reference, written out for numba:

- planar joints (``planar/joints.py``): revolute eq. 3.17, relative angle and rotational driver eq. 3.21,
  3.34, pin in a slot eq. 3.24 and translation / prismatic driver / rack and pinion eq. 3.31, 3.35 (both
  from ``along_direction``, eq. 3.13), distance eq. 3.27, coordinate driver eq. 3.34, gear pair eq. 3.29,
  cam with a roller follower eq. 3.32 and with a flat-faced follower eq. 3.33;
- spatial basic constraints (``spatial/joints.py``): dot-1 eq. 9.10, dot-2 eq. 9.11, spherical eq. 9.12,
  Euler-parameter normalization eq. 9.9, with B(p, a') of eq. 9.3; the drivers: rotation eq. 9.21,
  translation eq. 9.22, distance eq. 9.13, coordinate;
- forces: planar point force eq. 5.10, TSDA eq. 5.12-5.14, RSDA eq. 5.15; spatial point force and torque
  eq. 10.10, TSDA eq. 10.12, RSDA eq. 10.13, the quadratic-velocity term eq. 10.5 and the regularized
  spatial mass matrix (``spatial/mass.py``);
- functions (``functions.py``): constant, polynomial, harmonic, smooth ramp, Fourier series (of time), and
  the eccentric circle (a cam profile, of the cam angle).

Every kernel adds into (or writes) preallocated arrays: Psi, Psi_q (dense, m x n), Psi_t, gamma, Q, and the
two powers (dissipated, applied) of the energy balance. Ground is body -1: it has no columns.

This module imports numba: it is imported only when the compiled engine runs (``solutions.compiled``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from ..rotation_matrices import g_entries, l_entries, planar_rotation_entries, rotation_entries, unit_rotation_entries
from .lapack import PIVOT_TYPE, lapack

jit = njit(cache=True, fastmath=False, nogil=True)
inlined = njit(cache=True, fastmath=False, nogil=True, inline="always")


def typed(signature):
    """Compiled once, at import (or loaded from disk), under this one signature: called with a constant (an order 0,
    1 or 2, a column 0, 1 or 2, a flag True or False, a first body 0) numba would otherwise compile one version per
    value of the constant, and every generated module that calls the function would optimize each version again."""
    return njit(signature, cache=True, fastmath=False, nogil=True)


planar_rotation_entries_jit, rotation_entries_jit = jit(planar_rotation_entries), jit(rotation_entries)
unit_rotation_entries_jit, g_entries_jit, l_entries_jit = jit(unit_rotation_entries), jit(g_entries), jit(l_entries)
"""A(phi), A(p) (any p; unit p), G(p) and L(p) as ``rotation_matrices`` writes them (once), compiled by numba.
The generated modules' cache names hash ``rotation_matrices.py`` (``codegen``), but numba's on-disk cache of a kernel
here is keyed by this file only: after an edit of ``rotation_matrices.py``, clear this file's numba cache."""

# -- functions of time (functions.py) -------------------------------------------------------------------
CONSTANT, POLYNOMIAL, HARMONIC, RAMP, FOURIER, ECCENTRIC = 0, 1, 2, 3, 4, 5


@jit
def _fourier(p, x, order):
    """a0 + sum_k (a_k cos(k w x) + b_k sin(k w x)) and its derivatives, term by term as ``Fourier``.
    p = (number of terms N, w, a0, a_1 .. a_N, b_1 .. b_N)."""
    n, frequency = int(p[0]), p[1]
    total = 0.0
    for k in range(1, n + 1):
        ak, bk = p[2 + k], p[2 + n + k]
        w = k * frequency
        c, s = math.cos(w * x), math.sin(w * x)
        if order == 0:
            total += ak * c + bk * s
        elif order == 1:
            total += w * (-ak * s + bk * c)
        else:
            total += -w * w * (ak * c + bk * s)
    return p[2] + total if order == 0 else total


@jit
def _eccentric(p, theta, order):
    """rho(theta) = e cos(theta) + sqrt(a^2 - e^2 sin^2(theta)) and its derivatives, as ``EccentricCircle``.
    p = (radius a, eccentricity e)."""
    a, e = p[0], p[1]
    s, c = math.sin(theta), math.cos(theta)
    root = math.sqrt(a * a - (e * s) ** 2)
    if order == 0:
        return e * c + root
    if order == 1:
        return -e * s - e * e * s * c / root
    g = e * e * s * c
    dg = e * e * (c * c - s * s)
    droot = -g / root
    return -e * c - (dg * root - g * droot) / (root * root)


@typed(types.float64(types.int64[::1], types.float64[:, ::1], types.int64, types.float64, types.int64))
def function(kinds, params, f, t, order):
    """f(t), f'(t) or f''(t) (order 0, 1, 2) of function number f; f < 0 is the zero function.

    params[f] holds: constant (c); polynomial (number of coefficients, c0, c1, ...); harmonic (amplitude,
    frequency, phase, offset); smooth ramp (start, end, start value, end value); Fourier series (``_fourier``);
    eccentric circle (``_eccentric``, a cam profile: t is then the cam angle).
    """
    if f < 0:
        return 0.0
    kind = kinds[f]
    p = params[f]
    if kind == CONSTANT:
        return p[0] if order == 0 else 0.0
    if kind == POLYNOMIAL:  # Horner's scheme, as Polynomial
        n = int(p[0])
        result = 0.0
        if order == 0:
            for k in range(n - 1, -1, -1):
                result = result * t + p[1 + k]
        elif order == 1:
            for k in range(n - 1, 0, -1):
                result = result * t + k * p[1 + k]
        else:
            for k in range(n - 1, 1, -1):
                result = result * t + k * (k - 1) * p[1 + k]
        return result
    if kind == HARMONIC:
        amplitude, w, phase, offset = p[0], p[1], p[2], p[3]
        if order == 0:
            return offset + amplitude * math.sin(w * t + phase)
        if order == 1:
            return amplitude * w * math.cos(w * t + phase)
        return -amplitude * w * w * math.sin(w * t + phase)
    if kind == FOURIER:
        return _fourier(p, t, order)
    if kind == ECCENTRIC:
        return _eccentric(p, t, order)
    # smooth ramp (cycloidal step)
    start, end, v0, v1 = p[0], p[1], p[2], p[3]
    tau = min(max((t - start) / (end - start), 0.0), 1.0)
    span = end - start
    if order == 0:
        return v0 + (v1 - v0) * (tau - math.sin(2.0 * math.pi * tau) / (2.0 * math.pi))
    if order == 1:
        return (v1 - v0) * (1.0 - math.cos(2.0 * math.pi * tau)) / span
    return (v1 - v0) * 2.0 * math.pi * math.sin(2.0 * math.pi * tau) / span**2


# -- planar: body states -----------------------------------------------------------------------------------
@jit
def body_coordinates(x, b):
    """(x, y, phi) of body b in x (q or q'); ground (b < 0) is zero."""
    if b < 0:
        return 0.0, 0.0, 0.0
    return x[3 * b], x[3 * b + 1], x[3 * b + 2]


@jit
def body_vectors(phi, sx, sy):
    """A s' and B s' = A R90 s', R90 s' = (-s_y', s_x') (eq. 2.1, 2.5)."""
    a11, a12, a21, a22 = planar_rotation_entries_jit(phi)
    return turned(a11, a12, a21, a22, sx, sy)


@jit
def turned(a11, a12, a21, a22, sx, sy):
    """``body_vectors`` of A's entries (eq. 2.2, row by row): A s' and B s' = A R90 s'."""
    return a11 * sx + a12 * sy, a21 * sx + a22 * sy, a11 * -sy + a12 * sx, a21 * -sy + a22 * sx


@typed(types.void(types.float64[:, ::1], types.int64, types.int64, types.int64, types.int64, types.float64))
def _jac_add(jac, row, b, per, k, value):
    if b >= 0:
        jac[row, per * b + k] += value


@jit
def planar_revolute(q, qd, t, ints, floats, psi, jac, gam):
    """Revolute joints (eq. 3.17): Psi = r_i + A_i s_i' - r_j - A_j s_j', Psi_q = [I, B_i s_i', -I, -B_j s_j'],
    gamma = A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2. ints (i, j, row), floats (s_i', s_j')."""
    for e in range(ints.shape[0]):
        i, j = ints[e, 0], ints[e, 1]
        Ai = planar_rotation_entries_jit(body_coordinates(q, i)[2])
        Aj = planar_rotation_entries_jit(body_coordinates(q, j)[2])
        revolute_rows(q, qd, ints, floats, e, Ai, Aj, psi, jac, gam, True)


@inlined
def revolute_rows(q, qd, ints, floats, e, Ai, Aj, psi, jac, gam, rates):
    """Revolute joint e's rows (``planar_revolute``: ints (i, j, row), floats (s_i', s_j')) with its bodies' A_i,
    A_j given (eq. 2.2, row by row: a tree's recursion has them, ``tree_kernels.tree_revolute``); gamma only where
    ``rates`` (the outputs read none). Written into its callers (a function handed five arrays costs more than a
    joint's arithmetic)."""
    i, j, row = ints[e, 0], ints[e, 1], ints[e, 2]
    xi, yi, _ = body_coordinates(q, i)
    xj, yj, _ = body_coordinates(q, j)
    aix, aiy, bix, biy = turned(Ai[0], Ai[1], Ai[2], Ai[3], floats[e, 0], floats[e, 1])
    ajx, ajy, bjx, bjy = turned(Aj[0], Aj[1], Aj[2], Aj[3], floats[e, 2], floats[e, 3])
    psi[row] = xi + aix - xj - ajx
    psi[row + 1] = yi + aiy - yj - ajy
    _jac_add(jac, row, i, 3, 0, 1.0)
    _jac_add(jac, row + 1, i, 3, 1, 1.0)
    _jac_add(jac, row, i, 3, 2, bix)
    _jac_add(jac, row + 1, i, 3, 2, biy)
    _jac_add(jac, row, j, 3, 0, -1.0)
    _jac_add(jac, row + 1, j, 3, 1, -1.0)
    _jac_add(jac, row, j, 3, 2, -bjx)
    _jac_add(jac, row + 1, j, 3, 2, -bjy)
    if rates:
        wi, wj = body_coordinates(qd, i)[2], body_coordinates(qd, j)[2]
        gam[row] = aix * wi * wi - ajx * wj * wj
        gam[row + 1] = aiy * wi * wi - ajy * wj * wj


@jit
def _along(q, qd, i, j, six, siy, sjx, sjy, uix, uiy):
    """The scalar u_i^T d_ij with u_i = A_i u_i' fixed in body i (eq. 3.13), as ``joints.along_direction``:
    (value, Psi_qi row, Psi_qj row, gamma), gamma = u^T d phi_i'^2 - 2 phi_i' (B_i u_i')^T d'
    - u^T (A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2)."""
    (dx, dy), (ddx, ddy), (qx, qy), (bix, biy), (bjx, bjy) = point_vectors(q, qd, i, j, six, siy, sjx, sjy)
    phii, wi = body_coordinates(q, i)[2], body_coordinates(qd, i)[2]
    ux, uy, wx, wy = body_vectors(phii, uix, uiy)
    value = ux * dx + uy * dy
    gamma = value * wi * wi - 2.0 * wi * (wx * ddx + wy * ddy) - (ux * qx + uy * qy)
    row_i2 = wx * dx + wy * dy - (ux * bix + uy * biy)
    return value, -ux, -uy, row_i2, ux, uy, ux * bjx + uy * bjy, gamma


@jit
def planar_along(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """u_i^T d_ij + rolling (phi_j - phi_i) - d0 - f(t) = 0 with u_i = A_i u_i' (eq. 3.13, ``_along``): the pin in
    a slot (u_i' the slot normal, eq. 3.24), the translation driver (eq. 3.35), the rack and pinion (eq. 3.31).
    ints (i, j, row, function), floats (s_i', s_j', u_i', d0, side R)."""
    for e in range(ints.shape[0]):
        i, j, row, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        fl = floats[e]
        value, ri0, ri1, ri2, rj0, rj1, rj2, gamma = _along(q, qd, i, j, fl[0], fl[1], fl[2], fl[3], fl[4], fl[5])
        d0, rolling = fl[6], fl[7]
        psi[row] = (
            value + rolling * (body_coordinates(q, j)[2] - body_coordinates(q, i)[2]) - d0 - function(fk, fp, f, t, 0)
        )
        _jac_add(jac, row, i, 3, 0, ri0)
        _jac_add(jac, row, i, 3, 1, ri1)
        _jac_add(jac, row, i, 3, 2, ri2 - rolling)
        _jac_add(jac, row, j, 3, 0, rj0)
        _jac_add(jac, row, j, 3, 1, rj1)
        _jac_add(jac, row, j, 3, 2, rj2 + rolling)
        psit[row] = -function(fk, fp, f, t, 1)
        gam[row] = gamma + function(fk, fp, f, t, 2)


@jit
def point_vectors(q, qd, i, j, six, siy, sjx, sjy):
    """d_ij, d_ij', the velocity part of d_ij'' (A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2) and B_i s_i', B_j s_j'
    (``planar/bodies.py``), each as an (x, y) pair."""
    xi, yi, phii = body_coordinates(q, i)
    xj, yj, phij = body_coordinates(q, j)
    vxi, vyi, wi = body_coordinates(qd, i)
    vxj, vyj, wj = body_coordinates(qd, j)
    aix, aiy, bix, biy = body_vectors(phii, six, siy)
    ajx, ajy, bjx, bjy = body_vectors(phij, sjx, sjy)
    d = (xj + ajx - xi - aix, yj + ajy - yi - aiy)
    d_dot = (vxj + bjx * wj - vxi - bix * wi, vyj + bjy * wj - vyi - biy * wi)
    quadratic = (aix * wi * wi - ajx * wj * wj, aiy * wi * wi - ajy * wj * wj)
    return d, d_dot, quadratic, (bix, biy), (bjx, bjy)


@jit
def planar_gear(q, qd, t, ints, floats, psi, jac, gam):
    """Gear pairs (eq. 3.29): Psi = R_i (phi_i - theta) + sigma R_j (phi_j - theta) - c0, theta = atan2(d_ij),
    taken modulo 2 pi k, k = R_i + sigma R_j; with n = R90 d / |d|^2: Psi_qi = [k n^T, R_i + k n^T B_i s_i'],
    Psi_qj = [-k n^T, sigma R_j - k n^T B_j s_j'], gamma = k (m^T a - 2 theta' d^T d') / |d|^2, m = R90 d,
    theta' = m^T d' / |d|^2, a = A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2. ints (i, j, row),
    floats (s_i', s_j', R_i, R_j, sigma, c0)."""
    for e in range(ints.shape[0]):
        i, j, row = ints[e, 0], ints[e, 1], ints[e, 2]
        fl = floats[e]
        d, d_dot, a, bi, bj = point_vectors(q, qd, i, j, fl[0], fl[1], fl[2], fl[3])
        radius_i, radius_j, sigma, c0 = fl[4], fl[5], fl[6], fl[7]
        theta = math.atan2(d[1], d[0])
        value = (
            radius_i * (body_coordinates(q, i)[2] - theta) + sigma * radius_j * (body_coordinates(q, j)[2] - theta) - c0
        )
        k = radius_i + sigma * radius_j
        if k != 0.0:
            x = value / k
            value = k * (x - 2.0 * math.pi * np.round(x / (2.0 * math.pi)))  # k remainder(value / k, 2 pi)
        psi[row] = value
        dd = d[0] * d[0] + d[1] * d[1]
        nx, ny = -d[1] / dd, d[0] / dd
        _jac_add(jac, row, i, 3, 0, k * nx)
        _jac_add(jac, row, i, 3, 1, k * ny)
        _jac_add(jac, row, i, 3, 2, radius_i + k * (nx * bi[0] + ny * bi[1]))
        _jac_add(jac, row, j, 3, 0, -k * nx)
        _jac_add(jac, row, j, 3, 1, -k * ny)
        _jac_add(jac, row, j, 3, 2, sigma * radius_j - k * (nx * bj[0] + ny * bj[1]))
        mx, my = -d[1], d[0]
        theta_dot = (mx * d_dot[0] + my * d_dot[1]) / dd
        gam[row] = k * (mx * a[0] + my * a[1] - 2.0 * theta_dot * (d[0] * d_dot[0] + d[1] * d_dot[1])) / dd


@jit
def planar_roller_cam(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """Cams with a roller follower (eq. 3.32): Psi = |d| - rho(theta), theta = beta - phi_i, beta = atan2(d);
    with e = d / |d|, e_n = R90 e, g = e - rho' e_n / |d|: Psi_qi = [-g^T, -g^T B_i s_i' + rho'],
    Psi_qj = [g^T, g^T B_j s_j'], gamma = -(e^T a + (|d'|^2 - (e^T d')^2) / |d| - rho'' theta'^2
    - rho' (e_n^T a - 2 beta' e^T d') / |d|), a = A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2. The profile rho is
    function number ``profile`` of the table, of the cam angle. ints (i, j, row, profile), floats (s_i', s_j')."""
    for e in range(ints.shape[0]):
        i, j, row, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        fl = floats[e]
        d, d_dot, a, bi, bj = point_vectors(q, qd, i, j, fl[0], fl[1], fl[2], fl[3])
        length = math.hypot(d[0], d[1])
        ex, ey = d[0] / length, d[1] / length
        theta = math.atan2(d[1], d[0]) - body_coordinates(q, i)[2]
        rho, slope = function(fk, fp, f, theta, 0), function(fk, fp, f, theta, 1)
        curvature = function(fk, fp, f, theta, 2)
        psi[row] = length - rho
        gx, gy = ex - slope * (-ey) / length, ey - slope * ex / length
        _jac_add(jac, row, i, 3, 0, -gx)
        _jac_add(jac, row, i, 3, 1, -gy)
        _jac_add(jac, row, i, 3, 2, -(gx * bi[0] + gy * bi[1]) + slope)
        _jac_add(jac, row, j, 3, 0, gx)
        _jac_add(jac, row, j, 3, 1, gy)
        _jac_add(jac, row, j, 3, 2, gx * bj[0] + gy * bj[1])
        beta_dot = (-ey * d_dot[0] + ex * d_dot[1]) / length
        theta_dot = beta_dot - body_coordinates(qd, i)[2]
        radial = ex * d_dot[0] + ey * d_dot[1]
        length_part = ex * a[0] + ey * a[1] + (d_dot[0] * d_dot[0] + d_dot[1] * d_dot[1] - radial**2) / length
        angle_part = (-ey * a[0] + ex * a[1] - 2.0 * beta_dot * radial) / length
        gam[row] = -(length_part - curvature * theta_dot**2 - slope * angle_part)


@jit
def planar_flat_cam(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """Cams with a flat-faced follower (eq. 3.33): Psi = -u^T d_ji - p(psi) with u = A_j u_j' (``_along`` seen
    from body j), psi = phi_j - phi_i + alpha; Psi_qi[2] += p', Psi_qj[2] -= p' on minus the rows of ``_along``,
    gamma = -gamma(``_along``) + p'' psi'^2. The support function p is function number ``profile`` of the
    table. ints (i, j, row, profile), floats (s_i', s_j', u_j', alpha)."""
    for e in range(ints.shape[0]):
        i, j, row, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        fl = floats[e]
        value, rj0, rj1, rj2, ri0, ri1, ri2, gamma = _along(q, qd, j, i, fl[2], fl[3], fl[0], fl[1], fl[4], fl[5])
        angle = body_coordinates(q, j)[2] - body_coordinates(q, i)[2] + fl[6]
        slope = function(fk, fp, f, angle, 1)
        psi[row] = -value - function(fk, fp, f, angle, 0)
        _jac_add(jac, row, i, 3, 0, -ri0)
        _jac_add(jac, row, i, 3, 1, -ri1)
        _jac_add(jac, row, i, 3, 2, -ri2 + slope)
        _jac_add(jac, row, j, 3, 0, -rj0)
        _jac_add(jac, row, j, 3, 1, -rj1)
        _jac_add(jac, row, j, 3, 2, -rj2 - slope)
        rate = body_coordinates(qd, j)[2] - body_coordinates(qd, i)[2]
        gam[row] = -gamma + function(fk, fp, f, angle, 2) * rate**2


@jit
def planar_angle(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """phi_j - phi_i - phi0 - f(t) = 0 (eq. 3.21, 3.34). ints (i, j, row, function), floats (phi0)."""
    for e in range(ints.shape[0]):
        i, j, row, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        psi[row] = body_coordinates(q, j)[2] - body_coordinates(q, i)[2] - floats[e, 0] - function(fk, fp, f, t, 0)
        _jac_add(jac, row, i, 3, 2, -1.0)
        _jac_add(jac, row, j, 3, 2, 1.0)
        psit[row] = -function(fk, fp, f, t, 1)
        gam[row] = function(fk, fp, f, t, 2)


@jit
def planar_coordinate(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """q_j[k] - f(t) = 0 (eq. 3.34). ints (j, row, k, function)."""
    for e in range(ints.shape[0]):
        j, row, k, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        psi[row] = q[3 * j + k] - function(fk, fp, f, t, 0)
        jac[row, 3 * j + k] += 1.0
        psit[row] = -function(fk, fp, f, t, 1)
        gam[row] = function(fk, fp, f, t, 2)


@jit
def planar_distance(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """(d^T d - L(t)^2) / 2 = 0 (eq. 3.27): Psi_q = d^T [-I, -B_i s_i', I, B_j s_j'], Psi_t = -L L',
    gamma = -d'^T d' - d^T (A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2) + L'^2 + L L''.
    ints (i, j, row, function L), floats (s_i', s_j')."""
    for e in range(ints.shape[0]):
        i, j, row, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        fl = floats[e]
        (dx, dy), (ddx, ddy), (qx, qy), (bix, biy), (bjx, bjy) = point_vectors(q, qd, i, j, fl[0], fl[1], fl[2], fl[3])
        L, L1, L2 = function(fk, fp, f, t, 0), function(fk, fp, f, t, 1), function(fk, fp, f, t, 2)
        psi[row] = 0.5 * (dx * dx + dy * dy - L * L)
        _jac_add(jac, row, i, 3, 0, -dx)
        _jac_add(jac, row, i, 3, 1, -dy)
        _jac_add(jac, row, i, 3, 2, -(dx * bix + dy * biy))
        _jac_add(jac, row, j, 3, 0, dx)
        _jac_add(jac, row, j, 3, 1, dy)
        _jac_add(jac, row, j, 3, 2, dx * bjx + dy * bjy)
        psit[row] = -L * L1
        gam[row] = -(ddx * ddx + ddy * ddy) - (dx * qx + dy * qy) + L1 * L1 + L * L2


# -- planar forces -----------------------------------------------------------------------------------------
@jit
def _add3(Q, b, fx, fy, m):
    if b >= 0:
        Q[3 * b] += fx
        Q[3 * b + 1] += fy
        Q[3 * b + 2] += m


@jit
def planar_tsda(q, qd, t, ints, floats, fk, fp, Q, power):
    """Spring-damper-actuators (eq. 5.12-5.14): tension f = k (l - l0) + c l' + f_a(t) along u = d / l,
    Q_i = f [u ; (B_i s_i')^T u], Q_j = -f [u ; (B_j s_j')^T u]; power[0] += c l'^2, power[1] -= f_a l'.
    ints (i, j, actuator function), floats (s_i', s_j', k, c, l0)."""
    for e in range(ints.shape[0]):
        i, j, f = ints[e, 0], ints[e, 1], ints[e, 2]
        fl = floats[e]
        (dx, dy), (ddx, ddy), _, (bix, biy), (bjx, bjy) = point_vectors(q, qd, i, j, fl[0], fl[1], fl[2], fl[3])
        length = math.sqrt(dx * dx + dy * dy)
        velocity = (dx * ddx + dy * ddy) / length
        actuator = function(fk, fp, f, t, 0)
        tension = floats[e, 4] * (length - floats[e, 6]) + floats[e, 5] * velocity + actuator
        ux, uy = dx / length, dy / length
        fx, fy = tension * ux, tension * uy
        _add3(Q, i, fx, fy, bix * fx + biy * fy)
        _add3(Q, j, -fx, -fy, -(bjx * fx + bjy * fy))
        power[0] += floats[e, 5] * velocity**2
        power[1] -= actuator * velocity


@jit
def planar_rsda(q, qd, t, ints, floats, fk, fp, Q, power):
    """Rotational spring-damper-actuators (eq. 5.15): f = k (theta - theta0) + c theta' + f_a(t),
    theta = phi_j - phi_i; Q_i = [0, 0, f], Q_j = [0, 0, -f]. ints (i, j, actuator), floats (k, c, theta0)."""
    for e in range(ints.shape[0]):
        i, j, f = ints[e, 0], ints[e, 1], ints[e, 2]
        angle = body_coordinates(q, j)[2] - body_coordinates(q, i)[2]
        velocity = body_coordinates(qd, j)[2] - body_coordinates(qd, i)[2]
        actuator = function(fk, fp, f, t, 0)
        torque = floats[e, 0] * (angle - floats[e, 2]) + floats[e, 1] * velocity + actuator
        _add3(Q, i, 0.0, 0.0, torque)
        _add3(Q, j, 0.0, 0.0, -torque)
        power[0] += floats[e, 1] * velocity**2
        power[1] -= actuator * velocity


@jit
def planar_load(q, qd, t, ints, floats, fk, fp, Q, power):
    """Point forces F(t) at s_i' (eq. 5.10: Q_i = [F ; (B_i s_i')^T F], F = A_i F' when body-fixed) and
    torques T(t) (Q_i = [0, 0, T]); power[1] += q_i'^T Q_i. ints (i, fx, fy, body fixed, torque function),
    floats (s_i')."""
    for e in range(ints.shape[0]):
        i = ints[e, 0]
        xi, yi, phii = body_coordinates(q, i)
        vxi, vyi, wi = body_coordinates(qd, i)
        fx, fy = function(fk, fp, ints[e, 1], t, 0), function(fk, fp, ints[e, 2], t, 0)
        if ints[e, 3]:
            fx, fy, _, _ = body_vectors(phii, fx, fy)
        _, _, bx, by = body_vectors(phii, floats[e, 0], floats[e, 1])
        m = bx * fx + by * fy + function(fk, fp, ints[e, 4], t, 0)
        _add3(Q, i, fx, fy, m)
        power[1] += vxi * fx + vyi * fy + wi * m


# -- spatial: B(p, a'), A(p) a' and the basic constraints ------------------------------------------------------
@jit
def euler_parameters(x, b):
    """(e0, e1, e2, e3) of body b in x; ground's is (1, 0, 0, 0) in q (and 0 in q': pass ground=0.0)."""
    if b < 0:
        return 0.0, 0.0, 0.0, 0.0
    return x[7 * b + 3], x[7 * b + 4], x[7 * b + 5], x[7 * b + 6]


@jit
def orientation(q, b):
    if b < 0:
        return 1.0, 0.0, 0.0, 0.0
    return q[7 * b + 3], q[7 * b + 4], q[7 * b + 5], q[7 * b + 6]


@jit
def body_position(x, b):
    if b < 0:
        return 0.0, 0.0, 0.0
    return x[7 * b], x[7 * b + 1], x[7 * b + 2]


@jit
def b_entries(e0, e1, e2, e3, a1, a2, a3):
    """B(p, a') = d(A(p) a')/dp (3 x 4, eq. 9.3) row by row, entry by entry as ``spatial.bodies.b_matrix``."""
    v1, v2, v3 = e0 * a1 + e2 * a3 - e3 * a2, e0 * a2 + e3 * a1 - e1 * a3, e0 * a3 + e1 * a2 - e2 * a1
    ea = e1 * a1 + e2 * a2 + e3 * a3
    w12, w13, w23 = e1 * a2 - e2 * a1, e1 * a3 - e3 * a1, e2 * a3 - e3 * a2
    return (
        2.0 * v1, 2.0 * ea, 2.0 * (w12 + e0 * a3), 2.0 * (w13 - e0 * a2),
        2.0 * v2, 2.0 * (-w12 - e0 * a3), 2.0 * ea, 2.0 * (w23 + e0 * a1),
        2.0 * v3, 2.0 * (-w13 + e0 * a2), 2.0 * (-w23 - e0 * a1), 2.0 * ea,
    )  # fmt: skip


@jit
def b_matrix(e0, e1, e2, e3, a1, a2, a3, out):
    """B(p, a') (``b_entries``) into the 3 x 4 ``out``."""
    B = b_entries(e0, e1, e2, e3, a1, a2, a3)
    for r in range(3):
        for c in range(4):
            out[r, c] = B[4 * r + c]


@jit
def rotate(e0, e1, e2, e3, a, out):
    """out = A(p) a' (eq. 9.1), A(p) of ``rotation_matrices.rotation_entries``."""
    R = rotation_entries_jit(e0, e1, e2, e3)
    for r in range(3):
        out[r] = R[3 * r] * a[0] + R[3 * r + 1] * a[1] + R[3 * r + 2] * a[2]


@jit
def _bvec(Bm, x0, x1, x2, x3, out):
    for r in range(3):
        out[r] = Bm[r, 0] * x0 + Bm[r, 1] * x1 + Bm[r, 2] * x2 + Bm[r, 3] * x3


@jit
def _body_vector(q, qd, b, a, A, B, Bd, dot, quad):
    """A a', B(p, a'), a_dot = B(p, a') p', and B(p', a') p' of the body-fixed vector a' of body b."""
    e0, e1, e2, e3 = orientation(q, b)
    d0, d1, d2, d3 = euler_parameters(qd, b)
    rotate(e0, e1, e2, e3, a, A)
    b_matrix(e0, e1, e2, e3, a[0], a[1], a[2], B)
    _bvec(B, d0, d1, d2, d3, dot)
    b_matrix(d0, d1, d2, d3, a[0], a[1], a[2], Bd)
    _bvec(Bd, d0, d1, d2, d3, quad)


@jit
def point_terms(q, qd, b, a0, a1, a2):
    """(A a', B(p, a') row by row, B(p', a') p') of the body-fixed point a' of body b (ground: p = (1, 0, 0, 0),
    p' = 0), as scalars: ``_body_vector``'s numbers (the same products in the same order) without its five arrays,
    whose writes and reads cost more than a spherical joint's arithmetic (eq. 9.1, 9.3)."""
    e0, e1, e2, e3 = orientation(q, b)
    d0, d1, d2, d3 = euler_parameters(qd, b)
    R = rotation_entries_jit(e0, e1, e2, e3)
    A = (
        R[0] * a0 + R[1] * a1 + R[2] * a2,
        R[3] * a0 + R[4] * a1 + R[5] * a2,
        R[6] * a0 + R[7] * a1 + R[8] * a2,
    )
    Bd = b_entries(d0, d1, d2, d3, a0, a1, a2)
    quadratic = (
        Bd[0] * d0 + Bd[1] * d1 + Bd[2] * d2 + Bd[3] * d3,
        Bd[4] * d0 + Bd[5] * d1 + Bd[6] * d2 + Bd[7] * d3,
        Bd[8] * d0 + Bd[9] * d1 + Bd[10] * d2 + Bd[11] * d3,
    )
    return A, b_entries(e0, e1, e2, e3, a0, a1, a2), quadratic


@jit
def spatial_spherical(q, qd, t, ints, floats, psi, jac, gam):
    """spherical (eq. 9.12): -d_ij = 0, Psi_qi = [I, B(p_i, s_i')], Psi_qj = [-I, -B(p_j, s_j')],
    gamma = B(p_j', s_j') p_j' - B(p_i', s_i') p_i'. ints (i, j, row), floats (s_i', s_j')."""
    for e in range(ints.shape[0]):
        i, j, row = ints[e, 0], ints[e, 1], ints[e, 2]
        Ai, Bi, qi = point_terms(q, qd, i, floats[e, 0], floats[e, 1], floats[e, 2])
        Aj, Bj, qj = point_terms(q, qd, j, floats[e, 3], floats[e, 4], floats[e, 5])
        ri, rj = body_position(q, i), body_position(q, j)
        for k in range(3):
            psi[row + k] = ri[k] + Ai[k] - rj[k] - Aj[k]
            gam[row + k] = qj[k] - qi[k]
            if i >= 0:
                jac[row + k, 7 * i + k] += 1.0
                for c in range(4):
                    jac[row + k, 7 * i + 3 + c] += Bi[4 * k + c]
            if j >= 0:
                jac[row + k, 7 * j + k] -= 1.0
                for c in range(4):
                    jac[row + k, 7 * j + 3 + c] -= Bj[4 * k + c]


@jit
def spatial_dot1(q, qd, t, ints, floats, psi, jac, gam):
    """dot-1 (eq. 9.10): a_i^T a_j = 0, Psi_qi = [0, a_j^T B(p_i, a_i')], Psi_qj = [0, a_i^T B(p_j, a_j')],
    gamma = -a_j^T B(p_i', a_i') p_i' - a_i^T B(p_j', a_j') p_j' - 2 a_i'^T a_j'. ints (i, j, row),
    floats (a_i', a_j')."""
    Ai, Aj, doti, dotj, qi, qj = np.empty((6, 3))  # two allocations, not ten: each costs more than an element
    Bi, Bj, Bdi, Bdj = np.empty((4, 3, 4))
    for e in range(ints.shape[0]):
        i, j, row = ints[e, 0], ints[e, 1], ints[e, 2]
        _body_vector(q, qd, i, floats[e, 0:3], Ai, Bi, Bdi, doti, qi)
        _body_vector(q, qd, j, floats[e, 3:6], Aj, Bj, Bdj, dotj, qj)
        psi[row] = Ai[0] * Aj[0] + Ai[1] * Aj[1] + Ai[2] * Aj[2]
        for c in range(4):
            if i >= 0:
                jac[row, 7 * i + 3 + c] += Aj[0] * Bi[0, c] + Aj[1] * Bi[1, c] + Aj[2] * Bi[2, c]
            if j >= 0:
                jac[row, 7 * j + 3 + c] += Ai[0] * Bj[0, c] + Ai[1] * Bj[1, c] + Ai[2] * Bj[2, c]
        quadratic = Aj[0] * qi[0] + Aj[1] * qi[1] + Aj[2] * qi[2] + Ai[0] * qj[0] + Ai[1] * qj[1] + Ai[2] * qj[2]
        gam[row] = -quadratic - 2.0 * (doti[0] * dotj[0] + doti[1] * dotj[1] + doti[2] * dotj[2])


@jit
def spatial_dot2(q, qd, t, ints, floats, psi, jac, gam):
    """dot-2 (eq. 9.11): a_i^T d_ij = 0, Psi_qi = [-a_i^T, d^T B(p_i, a_i') - a_i^T B(p_i, s_i')],
    Psi_qj = [a_i^T, a_i^T B(p_j, s_j')], gamma = -d^T B(p_i', a_i') p_i' - 2 a_i'^T d' - a_i^T (d'')_v.
    ints (i, j, row), floats (a_i', s_i', s_j')."""
    Ai, doti, quadi, Si, sdoti, squadi, Sj, sdotj, squadj = np.empty((9, 3))  # two allocations, not fifteen
    Bi, Bdi, BSi, BdSi, BSj, BdSj = np.empty((6, 3, 4))
    for e in range(ints.shape[0]):
        i, j, row = ints[e, 0], ints[e, 1], ints[e, 2]
        _body_vector(q, qd, i, floats[e, 0:3], Ai, Bi, Bdi, doti, quadi)
        _body_vector(q, qd, i, floats[e, 3:6], Si, BSi, BdSi, sdoti, squadi)
        _body_vector(q, qd, j, floats[e, 6:9], Sj, BSj, BdSj, sdotj, squadj)
        ri, rj, vi, vj = body_position(q, i), body_position(q, j), body_position(qd, i), body_position(qd, j)
        value = 0.0
        g = 0.0
        for k in range(3):
            d = rj[k] + Sj[k] - ri[k] - Si[k]
            d_dot = vj[k] + sdotj[k] - vi[k] - sdoti[k]
            d_quad = squadj[k] - squadi[k]
            value += Ai[k] * d
            g += d * quadi[k] + 2.0 * doti[k] * d_dot + Ai[k] * d_quad
            if i >= 0:
                jac[row, 7 * i + k] -= Ai[k]
                for c in range(4):
                    jac[row, 7 * i + 3 + c] += d * Bi[k, c] - Ai[k] * BSi[k, c]
            if j >= 0:
                jac[row, 7 * j + k] += Ai[k]
                for c in range(4):
                    jac[row, 7 * j + 3 + c] += Ai[k] * BSj[k, c]
        psi[row] = value
        gam[row] = -g


@jit
def spatial_normalization(q, qd, t, ints, psi, jac, gam):
    """p_j^T p_j - 1 = 0 (eq. 9.9): Psi_qj = [0, 2 p_j^T], gamma = -2 p_j'^T p_j'. ints (j, row)."""
    for e in range(ints.shape[0]):
        j, row = ints[e, 0], ints[e, 1]
        s = 0.0
        g = 0.0
        for c in range(4):
            p = q[7 * j + 3 + c]
            s += p * p
            g += qd[7 * j + 3 + c] ** 2
            jac[row, 7 * j + 3 + c] += 2.0 * p
        psi[row] = s - 1.0
        gam[row] = -2.0 * g


@jit
def spatial_translation(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """Translation drivers (eq. 9.22): the dot-2 a_i^T d_ij of ``spatial_dot2`` minus s0 + f(t): Psi_t = -f',
    gamma = gamma(dot-2) + f''. ints (i, j, row, function), floats (a_i', s_i', s_j', s0)."""
    spatial_dot2(q, qd, t, ints, floats, psi, jac, gam)
    for e in range(ints.shape[0]):
        row, f = ints[e, 2], ints[e, 3]
        psi[row] = psi[row] - floats[e, 9] - function(fk, fp, f, t, 0)
        psit[row] = -function(fk, fp, f, t, 1)
        gam[row] += function(fk, fp, f, t, 2)


@jit
def spatial_rotation(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """Rotation drivers (eq. 9.21): theta(t) = theta0 + f(t), n' = -sin(theta) f_i' + cos(theta) g_i',
    c' = cos(theta) f_i' + sin(theta) g_i'; Psi = n^T f_j, Psi_qi = [0, f_j^T B(p_i, n')],
    Psi_qj = [0, n^T B(p_j, f_j')], Psi_t = -theta' c^T f_j,
    gamma = -f_j^T [B(p_i', n') p_i' - 2 theta' B(p_i, c') p_i' - theta'' c - theta'^2 n] - 2 n_t'^T f_j'
    - n^T B(p_j', f_j') p_j', n_t' = B(p_i, n') p_i' - theta' c. ints (i, j, row, function),
    floats (f_i', g_i', f_j', theta0)."""
    nb, cb, N, C, Fj, ndot, cdot, fjdot, nq, cq, fjq = np.empty((11, 3))  # two allocations, not seventeen
    Bn, Bc, Bf, Bdn, Bdc, Bdf = np.empty((6, 3, 4))
    for e in range(ints.shape[0]):
        i, j, row, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        fl = floats[e]
        theta = fl[9] + function(fk, fp, f, t, 0)
        rate, acceleration = function(fk, fp, f, t, 1), function(fk, fp, f, t, 2)
        c, s = math.cos(theta), math.sin(theta)
        for k in range(3):
            nb[k] = -s * fl[k] + c * fl[3 + k]
            cb[k] = c * fl[k] + s * fl[3 + k]
        _body_vector(q, qd, i, nb, N, Bn, Bdn, ndot, nq)
        _body_vector(q, qd, i, cb, C, Bc, Bdc, cdot, cq)
        _body_vector(q, qd, j, fl[6:9], Fj, Bf, Bdf, fjdot, fjq)
        psi[row] = N[0] * Fj[0] + N[1] * Fj[1] + N[2] * Fj[2]
        for col in range(4):
            if i >= 0:
                jac[row, 7 * i + 3 + col] += Fj[0] * Bn[0, col] + Fj[1] * Bn[1, col] + Fj[2] * Bn[2, col]
            if j >= 0:
                jac[row, 7 * j + 3 + col] += N[0] * Bf[0, col] + N[1] * Bf[1, col] + N[2] * Bf[2, col]
        psit[row] = -rate * (C[0] * Fj[0] + C[1] * Fj[1] + C[2] * Fj[2])
        value = 0.0
        for k in range(3):
            n_quadratic = nq[k] - 2.0 * rate * cdot[k] - acceleration * C[k] - rate**2 * N[k]
            n_dot = ndot[k] - rate * C[k]
            value += Fj[k] * n_quadratic + 2.0 * n_dot * fjdot[k] + N[k] * fjq[k]
        gam[row] = -value


@jit
def spatial_distance(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """Distance drivers (eq. 9.13): (d^T d - L(t)^2) / 2 = 0, Psi_qi = [-d^T, -d^T B(p_i, s_i')],
    Psi_qj = [d^T, d^T B(p_j, s_j')], Psi_t = -L L', gamma = -d'^T d' - d^T (d'')_v + L'^2 + L L''.
    ints (i, j, row, function L), floats (s_i', s_j')."""
    Si, Sj, doti, dotj, qi, qj = np.empty((6, 3))  # two allocations, not ten
    Bi, Bj, Bdi, Bdj = np.empty((4, 3, 4))
    for e in range(ints.shape[0]):
        i, j, row, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        _body_vector(q, qd, i, floats[e, 0:3], Si, Bi, Bdi, doti, qi)
        _body_vector(q, qd, j, floats[e, 3:6], Sj, Bj, Bdj, dotj, qj)
        ri, rj, vi, vj = body_position(q, i), body_position(q, j), body_position(qd, i), body_position(qd, j)
        half_square = 0.0
        g = 0.0
        for k in range(3):
            d = rj[k] + Sj[k] - ri[k] - Si[k]
            d_dot = vj[k] + dotj[k] - vi[k] - doti[k]
            half_square += d * d
            g += d_dot * d_dot + d * (qj[k] - qi[k])
            if i >= 0:
                jac[row, 7 * i + k] -= d
                for col in range(4):
                    jac[row, 7 * i + 3 + col] -= d * Bi[k, col]
            if j >= 0:
                jac[row, 7 * j + k] += d
                for col in range(4):
                    jac[row, 7 * j + 3 + col] += d * Bj[k, col]
        L, L1, L2 = function(fk, fp, f, t, 0), function(fk, fp, f, t, 1), function(fk, fp, f, t, 2)
        psi[row] = 0.5 * half_square - 0.5 * L * L
        psit[row] = -L * L1
        gam[row] = -g + L1 * L1 + L * L2


@jit
def spatial_coordinate(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """r_j[k] - f(t) = 0 (a coordinate driver): a unit row, Psi_t = -f', gamma = f''. ints (j, row, k, function)."""
    for e in range(ints.shape[0]):
        j, row, k, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        psi[row] = q[7 * j + k] - function(fk, fp, f, t, 0)
        jac[row, 7 * j + k] += 1.0
        psit[row] = -function(fk, fp, f, t, 1)
        gam[row] = function(fk, fp, f, t, 2)


# -- spatial mass matrix and forces ------------------------------------------------------------------------------
@jit
def _fill(entries, out):
    """out (3 x 4) from its entries row by row."""
    for r in range(3):
        for c in range(4):
            out[r, c] = entries[4 * r + c]


@jit
def _l_matrix(e0, e1, e2, e3, out):
    """L(p) (eq. 8.14) into out."""
    _fill(l_entries_jit(e0, e1, e2, e3), out)


@jit
def l_times(L, x, out):
    """out = L x (3 x 4 by 4): the body-frame angular velocity omega' = 2 L(p) p' (eq. 8.17), by loops."""
    for r in range(3):
        out[r] = L[r, 0] * x[0] + L[r, 1] * x[1] + L[r, 2] * x[2] + L[r, 3] * x[3]


@jit
def inertia_times(J, x, out):
    """out = J' x (3 x 3 by 3), by loops."""
    for r in range(3):
        out[r] = J[r, 0] * x[0] + J[r, 1] * x[1] + J[r, 2] * x[2]


@jit
def spatial_mass(q, qd, masses, inertias, weights, M, Q):
    """M(q) = diag(m I, 4 L^T J' L + 4 w p p^T) per body (eq. 10.4, regularized as ``dynamic_mass_matrix``) and
    Q += Q_v = 8 L(p')^T J' L(p') p (eq. 10.5). Every product is written out (3 x 4 at most): numba's ``@`` and
    ``np.outer`` are BLAS calls and allocations, each dearer than the arithmetic of these small matrices."""
    L, Ld, JL = np.empty((3, 3, 4))
    v, u = np.empty((2, 3))
    for b in range(masses.size):
        o = 7 * b
        p = q[o + 3 : o + 7]
        _l_matrix(p[0], p[1], p[2], p[3], L)
        _l_matrix(qd[o + 3], qd[o + 4], qd[o + 5], qd[o + 6], Ld)
        J, w = inertias[b], 4.0 * weights[b]
        for k in range(3):
            M[o + k, o + k] = masses[b]
        for r in range(3):  # J' L
            for c in range(4):
                JL[r, c] = J[r, 0] * L[0, c] + J[r, 1] * L[1, c] + J[r, 2] * L[2, c]
        for r in range(4):  # M_pp = 4 L^T (J' L) + 4 w p p^T
            for c in range(4):
                LtJL = L[0, r] * JL[0, c] + L[1, r] * JL[1, c] + L[2, r] * JL[2, c]
                M[o + 3 + r, o + 3 + c] = 4.0 * LtJL + w * p[r] * p[c]
        l_times(Ld, p, v)  # L(p') p
        inertia_times(J, v, u)
        for r in range(4):  # Q_v = 8 L(p')^T J' L(p') p
            Q[o + 3 + r] += 8.0 * (Ld[0, r] * u[0] + Ld[1, r] * u[1] + Ld[2, r] * u[2])


@jit
def _add_l_transpose(e0, e1, e2, e3, x0, x1, x2, Q, o):
    """Q[o : o + 4] += 2 L(p)^T x (the Euler-parameter force of a body-frame torque x, eq. 10.10)."""
    Lm = l_entries_jit(e0, e1, e2, e3)
    for c in range(4):
        Q[o + c] += 2.0 * (Lm[c] * x0 + Lm[4 + c] * x1 + Lm[8 + c] * x2)


@jit
def _spatial_point_force(q, b, s, fx, fy, fz, Q):
    """Q_b += [F ; 2 L^T s'~ A^T F] (eq. 10.10): F' = A^T F, and the body-frame moment s' x F'."""
    if b < 0:
        return
    o = 7 * b
    e0, e1, e2, e3 = q[o + 3], q[o + 4], q[o + 5], q[o + 6]
    R = rotation_entries_jit(e0, e1, e2, e3)
    f0 = R[0] * fx + R[3] * fy + R[6] * fz  # F' = A^T F
    f1 = R[1] * fx + R[4] * fy + R[7] * fz
    f2 = R[2] * fx + R[5] * fy + R[8] * fz
    Q[o] += fx
    Q[o + 1] += fy
    Q[o + 2] += fz
    _add_l_transpose(e0, e1, e2, e3, s[1] * f2 - s[2] * f1, s[2] * f0 - s[0] * f2, s[0] * f1 - s[1] * f0, Q, o + 3)


@typed(types.void(types.float64[::1], types.int64, types.float64, types.float64, types.float64, types.boolean,
                  types.float64[::1]))  # fmt: skip
def _spatial_torque(q, b, nx, ny, nz, body_frame, Q):
    """Q_b += [0 ; 2 G^T n] (global n) or [0 ; 2 L^T n'] (body frame) (eq. 10.10)."""
    if b < 0:
        return
    o = 7 * b
    e0, e1, e2, e3 = q[o + 3], q[o + 4], q[o + 5], q[o + 6]
    if body_frame:
        _add_l_transpose(e0, e1, e2, e3, nx, ny, nz, Q, o + 3)
        return
    G = g_entries_jit(e0, e1, e2, e3)
    for c in range(4):
        Q[o + 3 + c] += 2.0 * (G[c] * nx + G[4 + c] * ny + G[8 + c] * nz)


@jit
def angular_velocity(q, qd, b):
    """omega = 2 G(p) p' (global, eq. 8.17), as three numbers (zero for ground)."""
    if b < 0:
        return 0.0, 0.0, 0.0
    o = 7 * b
    G = g_entries_jit(q[o + 3], q[o + 4], q[o + 5], q[o + 6])
    d0, d1, d2, d3 = qd[o + 3], qd[o + 4], qd[o + 5], qd[o + 6]
    return (
        2.0 * (G[0] * d0 + G[1] * d1 + G[2] * d2 + G[3] * d3),
        2.0 * (G[4] * d0 + G[5] * d1 + G[6] * d2 + G[7] * d3),
        2.0 * (G[8] * d0 + G[9] * d1 + G[10] * d2 + G[11] * d3),
    )


@jit
def spatial_tsda(q, qd, t, ints, floats, fk, fp, Q, power):
    """Spring-damper-actuators (eq. 10.12): f = k (l - l0) + c l' + f_a(t) along u = d / l, f u at P_i and
    -f u at P_j. ints (i, j, actuator), floats (s_i', s_j', k, c, l0)."""
    Si, Sj, doti, dotj, qi, qj = np.empty((6, 3))  # two allocations, not ten
    Bi, Bj, Bdi, Bdj = np.empty((4, 3, 4))
    d, d_dot, u = np.empty((3, 3))
    for e in range(ints.shape[0]):
        i, j, f = ints[e, 0], ints[e, 1], ints[e, 2]
        _body_vector(q, qd, i, floats[e, 0:3], Si, Bi, Bdi, doti, qi)
        _body_vector(q, qd, j, floats[e, 3:6], Sj, Bj, Bdj, dotj, qj)
        ri, rj, vi, vj = body_position(q, i), body_position(q, j), body_position(qd, i), body_position(qd, j)
        for k in range(3):  # d_ij and its rate, in the buffers of the TSDA's vectors
            d[k] = rj[k] + Sj[k] - ri[k] - Si[k]
            d_dot[k] = vj[k] + dotj[k] - vi[k] - doti[k]
        length = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        for k in range(3):
            u[k] = d[k] / length
        velocity = u[0] * d_dot[0] + u[1] * d_dot[1] + u[2] * d_dot[2]
        actuator = function(fk, fp, f, t, 0)
        tension = floats[e, 6] * (length - floats[e, 8]) + floats[e, 7] * velocity + actuator
        _spatial_point_force(q, i, floats[e, 0:3], tension * u[0], tension * u[1], tension * u[2], Q)
        _spatial_point_force(q, j, floats[e, 3:6], -tension * u[0], -tension * u[1], -tension * u[2], Q)
        power[0] += floats[e, 7] * velocity**2
        power[1] -= actuator * velocity


@jit
def spatial_rsda(q, qd, t, ints, floats, fk, fp, Q, power):
    """Rotational spring-damper-actuators about h_i (eq. 10.13): theta = atan2(g_i^T f_j, f_i^T f_j) taken in
    (theta0 - pi, theta0 + pi], theta' = h_i^T (omega_j - omega_i), torque f h_i on i and -f h_i on j.
    ints (i, j, actuator), floats (f_i', g_i', h_i', f_j', k, c, theta0)."""
    fi, gi, hi, fj = np.empty((4, 3))
    for e in range(ints.shape[0]):
        i, j, f = ints[e, 0], ints[e, 1], ints[e, 2]
        pi0, pi1, pi2, pi3 = orientation(q, i)
        pj0, pj1, pj2, pj3 = orientation(q, j)
        rotate(pi0, pi1, pi2, pi3, floats[e, 0:3], fi)
        rotate(pi0, pi1, pi2, pi3, floats[e, 3:6], gi)
        rotate(pi0, pi1, pi2, pi3, floats[e, 6:9], hi)
        rotate(pj0, pj1, pj2, pj3, floats[e, 9:12], fj)
        k, c, theta0 = floats[e, 12], floats[e, 13], floats[e, 14]
        theta = math.atan2(gi[0] * fj[0] + gi[1] * fj[1] + gi[2] * fj[2], fi[0] * fj[0] + fi[1] * fj[1] + fi[2] * fj[2])
        x = theta - theta0
        angle = theta0 + (x - 2.0 * math.pi * np.round(x / (2.0 * math.pi)))  # math.remainder
        wj0, wj1, wj2 = angular_velocity(q, qd, j)
        wi0, wi1, wi2 = angular_velocity(q, qd, i)
        velocity = hi[0] * (wj0 - wi0) + hi[1] * (wj1 - wi1) + hi[2] * (wj2 - wi2)
        actuator = function(fk, fp, f, t, 0)
        torque = k * (angle - theta0) + c * velocity + actuator
        _spatial_torque(q, i, torque * hi[0], torque * hi[1], torque * hi[2], False, Q)
        _spatial_torque(q, j, -torque * hi[0], -torque * hi[1], -torque * hi[2], False, Q)
        power[0] += c * velocity**2
        power[1] -= actuator * velocity


@jit
def spatial_load(q, qd, t, ints, floats, fk, fp, Q, power):
    """Point forces (eq. 10.10) and torques: ints (i, kind 0 force / 1 torque, body fixed, f_x, f_y, f_z),
    floats (s_i'); power[1] += q_i'^T Q_i."""
    before = np.empty(7)
    A = np.empty(3)
    for e in range(ints.shape[0]):
        i, kind, fixed = ints[e, 0], ints[e, 1], ints[e, 2]
        o = 7 * i
        for k in range(7):  # loops, not slice assignments (``loops._copy``)
            before[k] = Q[o + k]
        v = np.array(
            [function(fk, fp, ints[e, 3], t, 0), function(fk, fp, ints[e, 4], t, 0), function(fk, fp, ints[e, 5], t, 0)]
        )
        if kind == 0:
            if fixed:
                rotate(q[o + 3], q[o + 4], q[o + 5], q[o + 6], v, A)
                v[0], v[1], v[2] = A[0], A[1], A[2]
            _spatial_point_force(q, i, floats[e, 0:3], v[0], v[1], v[2], Q)
        else:
            _spatial_torque(q, i, v[0], v[1], v[2], fixed != 0, Q)
        for k in range(7):
            power[1] += qd[o + k] * (Q[o + k] - before[k])


# -- the linear solve of eq. 5.30 ------------------------------------------------------------------------------
RANGE_SPACE_SIZE = 48
"""The size n + m of eq. 5.30 from which the planar module solves eq. 5.31 within S's envelope
(``range_space_solve``); below, with S whole (``dense_range_space_solve``: no index work, which costs more than a
small S's arithmetic). The LU of eq. 5.30 it replaces grows as (n + m)^3: per right-hand side on the planar chains of
``benchmarks/chains.py``, 13.6 against 8.6 us at n + m = 40, 285 against 20 us at 160, 2100 against 48 us at 320;
on the planar double pendulum (n + m = 10) the whole right-hand side 1.07 against 0.77 us with S whole, the
slider-crank (18) 2.09 against 1.89 (thread CPU, called from a compiled loop)."""
PROFILE_WIDTH = 8
"""The mean envelope width of Psi_q M^-1 Psi_q^T (rows of the lower triangle left of the diagonal) beyond which
``range_space_solve`` reorders its rows (``_profile_order``) before Cholesky."""
MAX_ROW_ENTRIES = 12
"""The most nonzeros a row of Psi_q may have for ``range_space_solve`` (a planar element couples two bodies: 6)."""


@jit
def _row_pattern(jac, rows, counts):
    """The nonzero columns of every row of Psi_q: rows[r, :counts[r]]. False when a row has more than
    MAX_ROW_ENTRIES of them."""
    m, n = jac.shape
    for r in range(m):
        c = 0
        for k in range(n):
            if jac[r, k] != 0.0:
                if c == MAX_ROW_ENTRIES:
                    return False
                rows[r, c] = k
                c += 1
        counts[r] = c
    return True


@jit
def _range_space_matrix(mass, jac, rows, counts, S, first):
    """S = Psi_q M^-1 Psi_q^T (eq. 5.31), M diagonal, summed column by column over the rows that share it; the
    envelope: first[r], the first column of row r of S that is not zero."""
    m, n = jac.shape
    per_column = np.zeros(n + 1, np.int64)
    for r in range(m):
        for a in range(counts[r]):
            per_column[rows[r, a] + 1] += 1
    for k in range(n):
        per_column[k + 1] += per_column[k]
    members, filled = np.empty(per_column[n], np.int64), per_column[:n].copy()
    for r in range(m):
        first[r] = r
        for a in range(counts[r]):
            k = rows[r, a]
            members[filled[k]] = r
            filled[k] += 1
    for k in range(n):
        for a in range(per_column[k], per_column[k + 1]):
            r = members[a]
            scaled = jac[r, k] / mass[k]
            for b in range(per_column[k], a + 1):  # rows in increasing order: s <= r
                s = members[b]
                S[r, s] += scaled * jac[s, k]
                if s < first[r]:
                    first[r] = s


@jit
def _profile_order(S, first):
    """An order of the rows of S (symmetric, its lower triangle filled) whose envelope is narrow: reverse
    Cuthill-McKee (George and Liu, Computer Solution of Large Sparse Positive Definite Systems, 1981, sec. 4.3):
    breadth first from a row of least degree, each row's unvisited neighbours by increasing degree, the whole
    order reversed. A chain of loops whose rows come joint type by joint type gets a band again."""
    m = S.shape[0]
    degree = np.zeros(m, np.int64)
    for r in range(m):
        for c in range(first[r], r):
            if S[r, c] != 0.0:
                degree[r] += 1
                degree[c] += 1
    start = np.zeros(m + 1, np.int64)
    for r in range(m):
        start[r + 1] = start[r] + degree[r]
    neighbours, filled = np.empty(start[m], np.int64), start[:m].copy()
    for r in range(m):
        for c in range(first[r], r):
            if S[r, c] != 0.0:
                neighbours[filled[r]] = c
                filled[r] += 1
                neighbours[filled[c]] = r
                filled[c] += 1
    order, seen, size = np.empty(m, np.int64), np.zeros(m, np.bool_), 0
    while size < m:
        root = -1
        for r in range(m):  # the next part starts at an unvisited row of least degree
            if not seen[r] and (root < 0 or degree[r] < degree[root]):
                root = r
        seen[root] = True
        order[size] = root
        head, size = size, size + 1
        while head < size:
            r = order[head]
            head += 1
            first_new = size
            for a in range(start[r], start[r + 1]):
                c = neighbours[a]
                if not seen[c]:
                    seen[c] = True
                    order[size] = c
                    size += 1
            for a in range(first_new + 1, size):  # the new rows by increasing degree (insertion sort)
                c, b = order[a], a - 1
                while b >= first_new and degree[order[b]] > degree[c]:
                    order[b + 1] = order[b]
                    b -= 1
                order[b + 1] = c
    return order[::-1].copy()


@jit
def _reordered(S, order, first):
    """S with its rows and columns in ``order`` (lower triangle), and its envelope ``first`` in that order."""
    m = S.shape[0]
    P = np.zeros((m, m))
    for i in range(m):
        first[i] = i
        for j in range(i + 1):
            a, b = order[i], order[j]
            value = S[a, b] if a >= b else S[b, a]
            P[i, j] = value
            if value != 0.0 and j < first[i]:
                first[i] = j
    return P


@jit
def _envelope_cholesky(S, first):
    """S = L L^T in place (L in the lower triangle of S), within the envelope ``first`` (no fill outside it).
    False when a pivot is not positive to 1e-12 of its diagonal entry (dependent constraint rows)."""
    m = S.shape[0]
    for r in range(m):
        for s in range(first[r], r + 1):
            total = S[r, s]
            for k in range(max(first[r], first[s]), s):
                total -= S[r, k] * S[s, k]
            if s < r:
                S[r, s] = total / S[s, s]
            elif not total > 1e-12 * S[r, r]:
                return False
            else:
                S[r, r] = math.sqrt(total)
    return True


@jit
def range_space_solve(mass, jac, psi, psit, gam, Q, qd, ab, qdd, lam):
    """q'' and lambda of eq. 5.30 for a diagonal M (planar) by eq. 5.31: (Psi_q M^-1 Psi_q^T) lambda =
    Psi_q M^-1 Q - gamma_bar, q'' = M^-1 (Q - Psi_q^T lambda), gamma_bar of eq. 5.29. S = Psi_q M^-1 Psi_q^T is
    built from the nonzeros of Psi_q and factored by Cholesky within its envelope (its rows reordered first when
    the envelope is wide): banded when the rows follow the mechanism, so the cost grows with m, not as
    (n + m)^3. False (nothing written) where it does not apply:
    a mass that is not positive, a row with many nonzeros, dependent rows; ``augmented_solve`` then."""
    m, n = jac.shape
    for k in range(n):
        if not mass[k] > 0.0:
            return False
    rows, counts = np.empty((m, MAX_ROW_ENTRIES), np.int64), np.empty(m, np.int64)
    if not _row_pattern(jac, rows, counts):
        return False
    S, first = np.zeros((m, m)), np.empty(m, np.int64)
    _range_space_matrix(mass, jac, rows, counts, S, first)
    order = np.arange(m)
    if np.sum(order - first) > PROFILE_WIDTH * m:  # a wide envelope: the rows in a narrower order
        order = _profile_order(S, first)
        S = _reordered(S, order, first)
    if not _envelope_cholesky(S, first):
        return False
    stabilized = ab[0] != 0.0 or ab[1] != 0.0
    y = np.empty(m)
    for i in range(m):  # y = Psi_q M^-1 Q - gamma_bar (row order[i] in place i), then L y' = y (forward)
        r = order[i]
        total, psi_dot = 0.0, psit[r]
        for a in range(counts[r]):
            k = rows[r, a]
            total += jac[r, k] * Q[k] / mass[k]
            psi_dot += jac[r, k] * qd[k]
        gamma_bar = gam[r] - 2.0 * ab[0] * psi_dot - ab[1] ** 2 * psi[r] if stabilized else gam[r]
        total -= gamma_bar
        for k in range(first[i], i):
            total -= S[i, k] * y[k]
        y[i] = total / S[i, i]
    for i in range(m - 1, -1, -1):  # L^T lambda = y' (backward, column by column)
        y[i] /= S[i, i]
        for k in range(first[i], i):
            y[k] -= S[i, k] * y[i]
    x = np.empty(m)
    for i in range(m):
        x[order[i]] = y[i]
    force = Q.copy()
    for r in range(m):
        for a in range(counts[r]):
            k = rows[r, a]
            force[k] -= jac[r, k] * x[r]
    for k in range(n):
        qdd[k] = force[k] / mass[k]
    for r in range(m):
        lam[r] = x[r]
    return True


@jit
def _dense_cholesky(S):
    """S = L L^T in place, L in S's lower triangle (S symmetric, its lower triangle filled): eq. 5.31's matrix in
    the range-space solves. False when a pivot is not positive to 1e-12 of its entry (dependent constraint rows).
    ``_envelope_cholesky`` with the envelope whole, without its index array (which cost 0.04-0.06 us an evaluation
    on the double pendulum)."""
    m = S.shape[0]
    for r in range(m):
        for s in range(r + 1):
            total = S[r, s]
            for k in range(s):
                total -= S[r, k] * S[s, k]
            if s < r:
                S[r, s] = total / S[s, s]
            elif not total > 1e-12 * S[r, r]:
                return False
            else:
                S[r, r] = math.sqrt(total)
    return True


@jit
def _back_substitution(L, y, x):
    """x from L^T x = y, L lower triangular (``_dense_cholesky``'s factor)."""
    m = y.size
    for r in range(m - 1, -1, -1):
        total = y[r]
        for k in range(r + 1, m):
            total -= L[k, r] * x[k]
        x[r] = total / L[r, r]


@jit
def dense_range_space_solve(mass, jac, psi, psit, gam, Q, qd, ab, qdd, lam):
    """``range_space_solve`` for a small planar scene (n + m < RANGE_SPACE_SIZE): eq. 5.31 with S = Psi_q M^-1
    Psi_q^T formed whole (m x m) and factored by Cholesky, where the LU of eq. 5.30's (n + m) x (n + m) matrix
    costs several times more (the planar double pendulum: 4 x 4 against 10 x 10). False (nothing written) where
    it does not apply, as ``range_space_solve``: a mass that is not positive, dependent rows."""
    m, n = jac.shape
    for k in range(n):
        if not mass[k] > 0.0:
            return False
    S, y = np.empty((m, m)), np.empty(m)
    for r in range(m):  # the lower triangle of S: row r of Psi_q M^-1 times row s of Psi_q
        for s in range(r + 1):
            total = 0.0
            for k in range(n):
                total += jac[r, k] * jac[s, k] / mass[k]
            S[r, s] = total
    if not _dense_cholesky(S):  # dependent rows
        return False
    stabilized = ab[0] != 0.0 or ab[1] != 0.0
    for r in range(m):  # y = Psi_q M^-1 Q - gamma_bar (eq. 5.29), then L y' = y
        total, psi_dot = 0.0, psit[r]
        for k in range(n):
            total += jac[r, k] * Q[k] / mass[k]
            psi_dot += jac[r, k] * qd[k]
        total -= gam[r] - 2.0 * ab[0] * psi_dot - ab[1] ** 2 * psi[r] if stabilized else gam[r]
        for k in range(r):
            total -= S[r, k] * y[k]
        y[r] = total / S[r, r]
    _back_substitution(S, y, lam)  # L^T lambda = y'
    for k in range(n):  # q'' = M^-1 (Q - Psi_q^T lambda)
        total = Q[k]
        for r in range(m):
            total -= jac[r, k] * lam[r]
        qdd[k] = total / mass[k]
    return True


@jit
def _block_inverse(M, o, B, L):
    """B = M[o : o + 4, o : o + 4]^-1, a body's Euler-parameter block of eq. 10.4 (regularized: positive definite),
    from its Cholesky factor L L^T (L: a 4 x 5 work array, the reciprocals of its diagonal in the last column), the
    four columns of the identity solved. False when a pivot is not positive to 1e-12 of its entry (a block without
    inertia). Formed once per evaluation, the block of M^-1 is then applied by products: a triangular solve for
    each row of Psi_q is a chain of divisions, several times slower."""
    for r in range(4):
        for s in range(r + 1):
            total = M[o + r, o + s]
            for k in range(s):
                total -= L[r, k] * L[s, k]
            if s < r:
                L[r, s] = total * L[s, 4]
            elif not total > 1e-12 * M[o + r, o + r]:
                return False
            else:
                L[r, r] = math.sqrt(total)
                L[r, 4] = 1.0 / L[r, r]
    for c in range(4):  # column c of B: L L^T x = e_c, x written into B[:, c]
        for r in range(4):
            total = 1.0 if r == c else 0.0
            for k in range(r):
                total -= L[r, k] * B[k, c]
            B[r, c] = total * L[r, 4]
        for r in range(3, -1, -1):
            total = B[r, c]
            for k in range(r + 1, 4):
                total -= L[k, r] * B[k, c]
            B[r, c] = total * L[r, 4]
    return True


@typed(types.void(types.float64[:, ::1], types.float64[:, :, ::1], types.float64[::1], types.int64, types.int64,
                  types.float64[::1]))  # fmt: skip
def _mass_solve(M, B, x, first, last, out):
    """out = M^-1 x over bodies first ... last, M block-diagonal (eq. 10.4: m I, then the 4 x 4 block whose inverse
    is B[b], ``_block_inverse``)."""
    for b in range(first, last + 1):
        o = 7 * b
        for k in range(3):
            out[o + k] = x[o + k] / M[o + k, o + k]
        for r in range(4):
            Br = B[b, r]
            out[o + 3 + r] = Br[0] * x[o + 3] + Br[1] * x[o + 4] + Br[2] * x[o + 5] + Br[3] * x[o + 6]


@jit
def spatial_range_space_solve(M, jac, psi, psit, gam, Q, qd, ab, qdd, lam):
    """q'' and lambda of eq. 5.30 for the spatial M(q) (eq. 10.4, block-diagonal: m I and a 4 x 4 Euler-parameter
    block per body) by eq. 5.31: X = M^-1 Psi_q^T block by block (each 4 x 4 block inverted once, by Cholesky),
    S = Psi_q X whole (m x m) and factored by Cholesky, S lambda = Psi_q M^-1 Q - gamma_bar (eq. 5.29),
    q'' = M^-1 Q - X^T lambda. A row of Psi_q reaches the bodies first[r] ... last[r] (an element joins two), so
    S[r, s] sums over the bodies rows r and s share: on a chain S is banded. The LU of eq. 5.30's matrix
    (``augmented_solve``; the spatial double pendulum's is 22 x 22) costs more from the smallest scene on. False
    (nothing written) where it does not apply: a block or mass not positive, dependent rows; the LU then. Its
    arrays are views of one work array (an allocation costs as much as a hundred of these products)."""
    m, n = jac.shape
    nb = n // 7
    work = np.empty(16 * nb + 20 + m * n + m * m + m + n)
    B = work[: 16 * nb].reshape((nb, 4, 4))  # the blocks of M^-1
    L = work[16 * nb : 16 * nb + 20].reshape((4, 5))
    at = 16 * nb + 20
    X = work[at : at + m * n].reshape((m, n))
    at += m * n
    S = work[at : at + m * m].reshape((m, m))
    at += m * m
    y, u = work[at : at + m], work[at + m : at + m + n]
    for b in range(nb):
        o = 7 * b
        for k in range(3):
            if not M[o + k, o + k] > 0.0:
                return False
        if not _block_inverse(M, o + 3, B[b], L):
            return False
    reach = np.empty((m, 2), np.int64)  # the first and last body each row reaches
    for r in range(m):  # and X's row r = M^-1 (row r of Psi_q) over them
        first, last = nb, -1
        for k in range(n):
            if jac[r, k] != 0.0:
                first, last = min(first, k // 7), k // 7
        reach[r, 0], reach[r, 1] = first, last
        _mass_solve(M, B, jac[r], first, last, X[r])
    for r in range(m):  # the lower triangle of S over the bodies rows r and s share
        for s in range(r + 1):
            total = 0.0
            for k in range(7 * max(reach[r, 0], reach[s, 0]), 7 * min(reach[r, 1], reach[s, 1]) + 7):
                total += jac[r, k] * X[s, k]
            S[r, s] = total
    if not _dense_cholesky(S):  # dependent rows
        return False
    _mass_solve(M, B, Q, 0, nb - 1, u)  # u = M^-1 Q
    stabilized = ab[0] != 0.0 or ab[1] != 0.0
    for r in range(m):  # y = Psi_q M^-1 Q - gamma_bar (eq. 5.29), then L y' = y
        total, psi_dot = 0.0, psit[r]
        for k in range(7 * reach[r, 0], 7 * reach[r, 1] + 7):
            total += jac[r, k] * u[k]
            psi_dot += jac[r, k] * qd[k]
        total -= gam[r] - 2.0 * ab[0] * psi_dot - ab[1] ** 2 * psi[r] if stabilized else gam[r]
        for k in range(r):
            total -= S[r, k] * y[k]
        y[r] = total / S[r, r]
    _back_substitution(S, y, lam)  # L^T lambda = y'
    for k in range(u.size):  # q'' = M^-1 Q - X^T lambda
        qdd[k] = u[k]
    for r in range(m):
        for k in range(7 * reach[r, 0], 7 * reach[r, 1] + 7):
            qdd[k] -= X[r, k] * lam[r]
    return True


_GESV = lapack("dgesv", 8)
"""LAPACK's dgesv(n, nrhs, a, lda, ipiv, b, ldb, info) (``_gesv``)."""

LAPACK_SIZE = 32
"""Systems with more unknowns than this go to LAPACK's gesv (blocked LU on BLAS: 3.3x faster at 129 unknowns, 5x at
260); smaller ones, where LAPACK's call costs more than the arithmetic (3.5x slower at 6 unknowns), are eliminated
by ``lu_solve`` itself (``benchmarks/call_cost.py``; numba's np.linalg.solve)."""


@jit
def lu_solve(K, b):
    """x from K x = b by Gaussian elimination with partial pivoting (P K = L U, then two triangular solves): LAPACK's
    gesv for a system of more than LAPACK_SIZE unknowns, otherwise its algorithm written out for the small dense
    systems of one evaluation (K is overwritten). A singular K (a zero pivot) gives NaN on both branches, for the
    loop's checks to see as a state the formulation cannot take: numba's division by zero raises (its error model
    is Python's), which would end the run in a traceback instead of the message the numpy engine gives."""
    n = b.size
    if n > LAPACK_SIZE:
        return _gesv(K, b)
    x = b.copy()
    solve_in_place(K, x)
    return x


@jit
def _gesv(K, b):
    """x from K x = b by LAPACK's gesv as ``np.linalg.solve`` calls it (K copied in column-major order, b copied:
    the same numbers), without numba's wrapper of it (``lapack``); NaN where K or b is not finite or K is singular,
    where ``np.linalg.solve`` raises."""
    n = b.size
    KT, x, pivots = np.empty((n, n)), np.empty(n), np.empty(n, PIVOT_TYPE)
    finite = True
    for r in range(n):
        x[r] = b[r]
        finite = finite and np.isfinite(b[r])
        for c in range(n):
            KT[c, r] = K[r, c]
            finite = finite and np.isfinite(K[r, c])
    sizes = np.array([n, 1, 0], dtype=PIVOT_TYPE)  # n (and lda, ldb), nrhs, info
    if finite:
        _GESV(sizes[0:].ctypes, sizes[1:].ctypes, KT.ctypes, sizes[0:].ctypes, pivots.ctypes, x.ctypes,
              sizes[0:].ctypes, sizes[2:].ctypes)  # fmt: skip
    if not finite or sizes[2] != 0:  # the NaN that the elimination gives, for the loop's checks to see
        return np.full(n, np.nan)
    return x


@jit
def solve_in_place(K, x):
    """x <- K^-1 x in place by Gaussian elimination with partial pivoting (P K = L U, then two triangular solves), K
    overwritten: ``lu_solve``'s small branch (no copy of x; ``tree_kernels._small_solve`` is its copy written into
    the tree's outputs, step for step). A zero pivot (K singular) gives NaN."""
    n = x.size
    for c in range(n):
        pivot = c
        biggest = abs(K[c, c])
        for r in range(c + 1, n):
            if abs(K[r, c]) > biggest:
                biggest, pivot = abs(K[r, c]), r
        if pivot != c:
            for k in range(n):
                K[c, k], K[pivot, k] = K[pivot, k], K[c, k]
            x[c], x[pivot] = x[pivot], x[c]
        if K[c, c] == 0.0:  # every remaining entry of the column is zero: K is singular
            x[:] = np.nan
            return
        inverse = 1.0 / K[c, c]
        for r in range(c + 1, n):
            factor = K[r, c] * inverse
            if factor != 0.0:
                K[r, c] = factor
                for k in range(c + 1, n):
                    K[r, k] -= factor * K[c, k]
                x[r] -= factor * x[c]
    for r in range(n - 1, -1, -1):
        s = x[r]
        for k in range(r + 1, n):
            s -= K[r, k] * x[k]
        x[r] = s / K[r, r]


@typed(types.void(types.float64[::1], types.float64[:, ::1], types.boolean, types.float64[:, ::1],
                  *(types.float64[::1],) * 8))  # fmt: skip
def augmented_solve(mass, M, spatial, jac, psi, psit, gam, Q, qd, ab, qdd, lam):
    """q'' and lambda from eq. 5.30 with gamma_bar = gamma - 2 alpha (Psi_q q' + Psi_t) - beta^2 Psi (eq. 5.29);
    M is the diagonal ``mass`` (planar) or the matrix ``M`` (spatial)."""
    m, n = jac.shape
    K = np.zeros((n + m, n + m))
    rhs = np.empty(n + m)
    for k in range(n):
        rhs[k] = Q[k]
    stabilized = ab[0] != 0.0 or ab[1] != 0.0
    for r in range(m):
        psi_dot = psit[r]
        for c in range(n):
            K[r + n, c] = jac[r, c]
            K[c, r + n] = jac[r, c]
            psi_dot += jac[r, c] * qd[c]
        rhs[n + r] = gam[r] - 2.0 * ab[0] * psi_dot - ab[1] ** 2 * psi[r] if stabilized else gam[r]
    if spatial:
        for r in range(n):
            for c in range(n):
                K[r, c] = M[r, c]
    else:
        for k in range(n):
            K[k, k] = mass[k]
    x = lu_solve(K, rhs)
    for k in range(n):
        qdd[k] = x[k]
    for r in range(m):
        lam[r] = x[n + r]
