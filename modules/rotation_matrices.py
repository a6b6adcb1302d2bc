# Generated from solutions/rotation_matrices.py by `make modules` (every homework stubbed): do not edit by hand.
"""The rotation matrices, each written once: A(phi) (eq. 2.2), A(p), G(p) and L(p) (eq. 8.12, 8.14), and the
quaternion product that composes two rotations.

Every part of the package that needs them and is not a student's homework evaluates them here: the model files,
the drawings, the result columns, the joint coordinates, the compiled engine (numba compiles these functions as
they are: ``compiled.kernels``) and the symbolic derivations (sympy symbols in, expressions out). Hence scalar
arithmetic only, and the entries returned row by row as a tuple. The functions a student writes
(``planar.bodies.rotation``, ``rotations.rotation_matrix``, ``rotations.g_matrix``, ``rotations.l_matrix``) are
their homework: written out there, and nothing outside the element formulas depends on them, so a student's
package loads and draws a model while they are stubs.

A(p) has two forms, which agree on p^T p = 1 only: ``rotation_entries``, the homogeneous quadratic form G L^T for
Euler parameters that are coordinates (and drift off unit length), and ``unit_rotation_entries`` for unit p.

This module is shared by planar and spatial code; the rest of the spatial rotations (Euler parameters from a
matrix, Euler angles, screws) are in ``rotations``.
"""

from __future__ import annotations

import math

import numpy as np


def planar_rotation_entries(phi: float) -> tuple[float, float, float, float]:
    """A(phi) = [[cos phi, -sin phi], [sin phi, cos phi]] row by row (eq. 2.2)."""
    c, s = math.cos(phi), math.sin(phi)
    return c, -s, s, c


def rotation_entries(e0: float, e1: float, e2: float, e3: float) -> tuple[float, ...]:
    """A(p) = G(p) L(p)^T = (e0^2 - e^T e) I + 2 e e^T + 2 e0 e~ row by row (eq. 8.12): a homogeneous quadratic
    form in p for any p, the form the constraint Jacobians differentiate (Euler parameters as coordinates, off
    p^T p = 1 by the integration error), and a rotation for unit p."""
    return (
        e0 * e0 + e1 * e1 - e2 * e2 - e3 * e3, 2 * (e1 * e2 - e0 * e3), 2 * (e1 * e3 + e0 * e2),
        2 * (e1 * e2 + e0 * e3), e0 * e0 - e1 * e1 + e2 * e2 - e3 * e3, 2 * (e2 * e3 - e0 * e1),
        2 * (e1 * e3 - e0 * e2), 2 * (e2 * e3 + e0 * e1), e0 * e0 - e1 * e1 - e2 * e2 + e3 * e3,
    )  # fmt: skip


def unit_rotation_entries(e0: float, e1: float, e2: float, e3: float) -> tuple[float, ...]:
    """A(p) = (2 e0^2 - 1) I + 2 (e e^T + e0 e~) row by row, for unit p only (eq. 8.12): Euler parameters that are
    unit by construction (a model file's, a result's normalized, the joint coordinates' products of unit
    quaternions). It equals ``rotation_entries`` on p^T p = 1, not off it."""
    return (
        2 * (e0 * e0 + e1 * e1) - 1, 2 * (e1 * e2 - e0 * e3), 2 * (e1 * e3 + e0 * e2),
        2 * (e1 * e2 + e0 * e3), 2 * (e0 * e0 + e2 * e2) - 1, 2 * (e2 * e3 - e0 * e1),
        2 * (e1 * e3 - e0 * e2), 2 * (e2 * e3 + e0 * e1), 2 * (e0 * e0 + e3 * e3) - 1,
    )  # fmt: skip


def g_entries(e0: float, e1: float, e2: float, e3: float) -> tuple[float, ...]:
    """G(p) = [-e, e~ + e0 I] (3 x 4) row by row (eq. 8.14): omega = 2 G p'."""
    return -e1, e0, -e3, e2, -e2, e3, e0, -e1, -e3, -e2, e1, e0


def l_entries(e0: float, e1: float, e2: float, e3: float) -> tuple[float, ...]:
    """L(p) = [-e, -e~ + e0 I] (3 x 4) row by row (eq. 8.14): omega' = 2 L p'."""
    return -e1, e0, e3, -e2, -e2, -e3, e0, e1, -e3, e2, -e1, e0


def quaternion_product_entries(a0, a1, a2, a3, b0, b1, b2, b3) -> tuple[float, float, float, float]:
    """The quaternion product a b = (a0 b0 - a.b, a0 b + b0 a + a x b) entry by entry: the rotation b followed by
    a, A(a b) = A(a) A(b)."""
    return (
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
        a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
    )


def planar_rotation(phi: float) -> np.ndarray:
    """A(phi) (2 x 2, eq. 2.2) from ``planar_rotation_entries``."""
    return np.array(planar_rotation_entries(float(phi))).reshape(2, 2)


def euler_rotation(p: np.ndarray) -> np.ndarray:
    """A(p) (3 x 3, eq. 8.12) of unit Euler parameters from ``unit_rotation_entries``: a model file's, a result's,
    a drawing's orientation."""
    e0, e1, e2, e3 = map(float, p)
    return np.array(unit_rotation_entries(e0, e1, e2, e3)).reshape(3, 3)
