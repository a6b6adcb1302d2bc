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
    ### BEGIN SOLUTION hw1
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])
    ### END SOLUTION


def rotation_derivative(phi: float) -> np.ndarray:
    """B(phi) = dA/dphi = A(phi) R90 = [[-sin, -cos], [cos, -sin]] (eq. 2.5)."""
    ### BEGIN SOLUTION hw1
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[-s, -c], [c, -s]])
    ### END SOLUTION


def point_vector(qi: np.ndarray, si: np.ndarray, qj: np.ndarray, sj: np.ndarray) -> np.ndarray:
    """d_ij = r_j + A_j s_j' - r_i - A_i s_i': from point P_i on body i to point P_j on body j."""
    ### BEGIN SOLUTION hw1
    return qj[:2] + rotation(qj[2]) @ sj - qi[:2] - rotation(qi[2]) @ si
    ### END SOLUTION


def point_vector_dot(
    qi: np.ndarray, si: np.ndarray, qj: np.ndarray, sj: np.ndarray, qdi: np.ndarray, qdj: np.ndarray
) -> np.ndarray:
    """d_ij' = r_j' + B_j s_j' phi_j' - r_i' - B_i s_i' phi_i' (time derivative of d_ij)."""
    ### BEGIN SOLUTION hw1
    vj = qdj[:2] + rotation_derivative(qj[2]) @ sj * qdj[2]
    vi = qdi[:2] + rotation_derivative(qi[2]) @ si * qdi[2]
    return vj - vi
    ### END SOLUTION


def point_vector_quadratic(
    qi: np.ndarray, si: np.ndarray, qj: np.ndarray, sj: np.ndarray, qdi: np.ndarray, qdj: np.ndarray
) -> np.ndarray:
    """Velocity part of d_ij'': A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2.

    d_ij'' = r_j'' + B_j s_j' phi_j'' - r_i'' - B_i s_i' phi_i'' + (this vector): since
    dB/dphi = -A, the centripetal terms are all that is left once accelerations are set to zero.
    """
    ### BEGIN SOLUTION hw1
    return rotation(qi[2]) @ si * qdi[2] ** 2 - rotation(qj[2]) @ sj * qdj[2] ** 2
    ### END SOLUTION
