"""Compiled kernels of the spatial drivers (``spatial/joints.py``), for the compiled kinematic analysis.

As the constraint kernels of ``kernels.py`` (same data layout, same arrays filled: Psi, Psi_q, Psi_t, gamma), for
the drivers a fully driven spatial mechanism has:

- translation driver, h_i^T d_ij - s0 - f(t) = 0 (eq. 9.22): the dot-2 kernel, plus the time terms;
- distance driver, (d^T d - L(t)^2) / 2 = 0 (eq. 9.13);
- rotation driver, n^T f_j = 0 with n = A_i (-sin theta f_i' + cos theta g_i'), theta = theta0 + f(t) (eq. 9.21);
- coordinate driver, r_j[k] - f(t) = 0.

This module imports numba: it is imported only when a compiled kinematic analysis runs.
"""

from __future__ import annotations

import math

import numpy as np

from .kernels import _body_vector, _r, function, jit, spatial_dot2


@jit
def spatial_translation(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """Translation drivers (eq. 9.22): the dot-2 of (a_i', s_i', s_j') minus s0 + f(t); Psi_t = -f',
    gamma = gamma(dot-2) + f''. ints (i, j, row, function), floats (a_i', s_i', s_j', s0)."""
    spatial_dot2(q, qd, t, ints, floats, psi, jac, gam)
    for e in range(ints.shape[0]):
        row, f = ints[e, 2], ints[e, 3]
        psi[row] = psi[row] - floats[e, 9] - function(fk, fp, f, t, 0)
        psit[row] = -function(fk, fp, f, t, 1)
        gam[row] = gam[row] + function(fk, fp, f, t, 2)


@jit
def spatial_distance(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """Distance drivers (eq. 9.13): (d^T d - L^2) / 2 = 0, Psi_qi = [-d^T, -d^T B(p_i, s_i')],
    Psi_qj = [d^T, d^T B(p_j, s_j')], Psi_t = -L L', gamma = -d'^T d' - d^T (d'')_v + L'^2 + L L''.
    ints (i, j, row, function L), floats (s_i', s_j')."""
    Si, sdoti, squadi, Sj, sdotj, squadj = np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    BSi, BdSi, BSj, BdSj = np.empty((3, 4)), np.empty((3, 4)), np.empty((3, 4)), np.empty((3, 4))
    d, d_dot = np.empty(3), np.empty(3)
    for e in range(ints.shape[0]):
        i, j, row, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        _body_vector(q, qd, i, floats[e, 0:3], Si, BSi, BdSi, sdoti, squadi)
        _body_vector(q, qd, j, floats[e, 3:6], Sj, BSj, BdSj, sdotj, squadj)
        ri, rj, vi, vj = _r(q, i), _r(q, j), _r(qd, i), _r(qd, j)
        square = 0.0
        g = 0.0
        for k in range(3):
            d[k] = rj[k] + Sj[k] - ri[k] - Si[k]
            d_dot[k] = vj[k] + sdotj[k] - vi[k] - sdoti[k]
            square += d[k] * d[k]
            g += d_dot[k] * d_dot[k] + d[k] * (squadj[k] - squadi[k])
        L, L1, L2 = function(fk, fp, f, t, 0), function(fk, fp, f, t, 1), function(fk, fp, f, t, 2)
        psi[row] = 0.5 * square - 0.5 * L**2
        for k in range(3):
            if i >= 0:
                jac[row, 7 * i + k] -= d[k]
            if j >= 0:
                jac[row, 7 * j + k] += d[k]
        for c in range(4):
            if i >= 0:
                jac[row, 7 * i + 3 + c] -= d[0] * BSi[0, c] + d[1] * BSi[1, c] + d[2] * BSi[2, c]
            if j >= 0:
                jac[row, 7 * j + 3 + c] += d[0] * BSj[0, c] + d[1] * BSj[1, c] + d[2] * BSj[2, c]
        psit[row] = -L * L1
        gam[row] = -g + L1 * L1 + L * L2


@jit
def spatial_rotation(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """Rotation drivers (eq. 9.21): theta = theta0 + f(t), n' = -sin theta f_i' + cos theta g_i', c' = cos theta f_i'
    + sin theta g_i'; Psi = n^T f_j, Psi_qi = [0, f_j^T B(p_i, n')], Psi_qj = [0, n^T B(p_j, f_j')],
    Psi_t = -theta' c^T f_j, gamma = -f_j^T [B(p_i', n') p_i' - 2 theta' B(p_i, c') p_i' - theta'' c - theta'^2 n]
    - 2 n_t'^T f_j' - n^T B(p_j', f_j') p_j' with n_t' = B(p_i, n') p_i' - theta' c. ints (i, j, row, function),
    floats (f_i', g_i', f_j', theta0)."""
    vectors = np.empty((11, 3))  # n', c', then n, B(p_i, n') p_i', B(p_i', n') p_i' and the same of c' and f_j'
    nb, cb, n, ndot, nquad, c = vectors[0], vectors[1], vectors[2], vectors[3], vectors[4], vectors[5]
    cdot, cquad, fj, fdot, fquad = vectors[6], vectors[7], vectors[8], vectors[9], vectors[10]
    matrices = np.empty((6, 3, 4))
    Bn, Bdn, Bc, Bdc, Bf, Bdf = matrices[0], matrices[1], matrices[2], matrices[3], matrices[4], matrices[5]
    for e in range(ints.shape[0]):
        i, j, row, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        theta = floats[e, 9] + function(fk, fp, f, t, 0)
        rate, acceleration = function(fk, fp, f, t, 1), function(fk, fp, f, t, 2)
        cos, sin = math.cos(theta), math.sin(theta)
        for k in range(3):
            nb[k] = -sin * floats[e, k] + cos * floats[e, 3 + k]
            cb[k] = cos * floats[e, k] + sin * floats[e, 3 + k]
        _body_vector(q, qd, i, nb, n, Bn, Bdn, ndot, nquad)
        _body_vector(q, qd, i, cb, c, Bc, Bdc, cdot, cquad)
        _body_vector(q, qd, j, floats[e, 6:9], fj, Bf, Bdf, fdot, fquad)
        psi[row] = n[0] * fj[0] + n[1] * fj[1] + n[2] * fj[2]
        for col in range(4):
            if i >= 0:
                jac[row, 7 * i + 3 + col] += fj[0] * Bn[0, col] + fj[1] * Bn[1, col] + fj[2] * Bn[2, col]
            if j >= 0:
                jac[row, 7 * j + 3 + col] += n[0] * Bf[0, col] + n[1] * Bf[1, col] + n[2] * Bf[2, col]
        psit[row] = -rate * (c[0] * fj[0] + c[1] * fj[1] + c[2] * fj[2])
        value = 0.0
        for k in range(3):
            n_quadratic = nquad[k] - 2.0 * rate * cdot[k] - acceleration * c[k] - rate**2 * n[k]
            n_dot = ndot[k] - rate * c[k]
            value += fj[k] * n_quadratic + 2.0 * n_dot * fdot[k] + n[k] * fquad[k]
        gam[row] = -value


@jit
def spatial_coordinate(q, qd, t, ints, floats, fk, fp, psi, jac, psit, gam):
    """Coordinate drivers: r_j[k] - f(t) = 0. ints (j, row, k, function)."""
    for e in range(ints.shape[0]):
        j, row, k, f = ints[e, 0], ints[e, 1], ints[e, 2], ints[e, 3]
        psi[row] = q[7 * j + k] - function(fk, fp, f, t, 0)
        jac[row, 7 * j + k] += 1.0
        psit[row] = -function(fk, fp, f, t, 1)
        gam[row] = function(fk, fp, f, t, 2)


__all__ = ["spatial_coordinate", "spatial_distance", "spatial_rotation", "spatial_translation"]
