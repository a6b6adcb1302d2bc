# Generated from solutions/planar/bodies.py by `make modules` (every homework stubbed): do not edit by hand.
"""Planar body kinematics: the rotation matrix and the vectors every joint formula is built from.

A point P fixed in body i at body-frame position s_i' lies at r_i^P = r_i + A_i s_i' (course notes,
eq. 2.1). A body that is ``ground`` has q = (0, 0, 0) and no columns in the Jacobian.

The vector between two body points, d_ij = r_j + A_j s_j' - r_i - A_i s_i', its time derivative and
the velocity part of its second derivative are shared by every joint, so they are written once here.
"""

from __future__ import annotations

import math

import numpy as np

R90 = np.array([[0.0, -1.0], [1.0, 0.0]])
"""Rotation by +90 degrees: R90 @ a is the vector a turned counter-clockwise (a-perp)."""


def rotation(phi: float) -> np.ndarray:
    """Planar rotation matrix A(phi) = [[cos, -sin], [sin, cos]] (eq. 2.2)."""
    raise NotImplementedError('rotation: Planar rotation matrix A(phi) = [[cos, -sin], [sin, cos]], see eq. 2.2')


def rotation_derivative(phi: float) -> np.ndarray:
    """B(phi) = dA/dphi = A(phi) R90 = [[-sin, -cos], [cos, -sin]] (eq. 2.5)."""
    raise NotImplementedError('rotation_derivative: B(phi) = dA/dphi = A(phi) R90 = [[-sin, -cos], [cos, -sin]], see eq. 2.5')


def point_vector(qi: np.ndarray, si: np.ndarray, qj: np.ndarray, sj: np.ndarray) -> np.ndarray:
    """d_ij = r_j + A_j s_j' - r_i - A_i s_i': from point P_i on body i to point P_j on body j."""
    raise NotImplementedError("point_vector: d_ij = r_j + A_j s_j' - r_i - A_i s_i': from point P_i on body i to point P_j on body j, see eq. 2.1 and the notes in planar/bodies.py")


def point_vector_dot(
    qi: np.ndarray, si: np.ndarray, qj: np.ndarray, sj: np.ndarray, qdi: np.ndarray, qdj: np.ndarray
) -> np.ndarray:
    """d_ij' = r_j' + B_j s_j' phi_j' - r_i' - B_i s_i' phi_i' (time derivative of d_ij)."""
    raise NotImplementedError("point_vector_dot: d_ij' = r_j' + B_j s_j' phi_j' - r_i' - B_i s_i' phi_i' (time derivative of d_ij), see eq. 2.1 and the notes in planar/bodies.py")


def point_vector_quadratic(
    qi: np.ndarray, si: np.ndarray, qj: np.ndarray, sj: np.ndarray, qdi: np.ndarray, qdj: np.ndarray
) -> np.ndarray:
    """Velocity part of d_ij'': A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2.

    d_ij'' = r_j'' + B_j s_j' phi_j'' - r_i'' - B_i s_i' phi_i'' + (this vector): since
    dB/dphi = -A, the centripetal terms are all that is left once accelerations are set to zero.
    """
    raise NotImplementedError("point_vector_quadratic: Velocity part of d_ij'': A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2, see eq. 2.1 and the notes in planar/bodies.py")
