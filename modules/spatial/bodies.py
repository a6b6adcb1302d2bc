# Generated from solutions/spatial/bodies.py by `make modules` (every homework stubbed): do not edit by hand.
"""Spatial body kinematics: the vectors every spatial joint formula is built from.

A spatial body has the coordinates q_i = (r_i, p_i) = (x, y, z, e0, e1, e2, e3): the position r_i of
its frame's origin (the centre of mass) and the Euler parameters p_i of its orientation, kept on
p^T p = 1 by a constraint. Ground has q = (0, 0, 0, 1, 0, 0, 0) and no columns in the Jacobian.

A vector fixed in body i, with body components a', is a = A(p) a' and a point P of body i at s' lies
at r^P = r + A(p) s' (course notes, eq. 9.1). Because A = G L^T is a homogeneous quadratic form in p,
its derivative with respect to p is linear in p (Haug 1989, the B matrix; course notes, eq. 9.3):

    d(A(p) a')/dp = B(p, a') = 2 [ (e0 I + e~) a',  e a'^T - (e0 I + e~) a'~ ]        (3 x 4)

and B(p, a') x = B(x, a') p for any x. Hence the first and second time derivatives of a = A a' are

    a'  = B(p, a') p',          a'' = B(p, a') p'' + B(p', a') p',

and the velocity part of a'', B(p', a') p', is what every gamma is made of.
"""

from __future__ import annotations

import numpy as np

from ..rotations import rotation_matrix


def b_matrix(p: np.ndarray, a: np.ndarray) -> np.ndarray:
    """B(p, a') = d(A(p) a')/dp = 2 [(e0 I + e~) a', e a'^T - (e0 I + e~) a'~] (eq. 9.3).

    Written out entry by entry (it is evaluated for every vector of every joint at every step), with
    v = (e0 I + e~) a' and, since e~ a'~ = a' e^T - (e^T a') I, the last three columns
    W = e a'^T - a' e^T + (e^T a') I - e0 a'~.
    """
    raise NotImplementedError("b_matrix: B(p, a') = d(A(p) a')/dp = 2 [(e0 I + e~) a', e a'^T - (e0 I + e~) a'~], see eq. 9.3")


def body_vector(q: np.ndarray, a: np.ndarray) -> np.ndarray:
    """a = A(p) a': a body-fixed vector in the global frame."""
    return rotation_matrix(q[3:7]) @ a


def body_vector_dot(q: np.ndarray, qd: np.ndarray, a: np.ndarray) -> np.ndarray:
    """a' = B(p, a') p' (time derivative of a body-fixed vector)."""
    return b_matrix(q[3:7], a) @ qd[3:7]


def body_vector_quadratic(qd: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Velocity part of a'': B(p', a') p' (a'' = B(p, a') p'' + this vector)."""
    return b_matrix(qd[3:7], a) @ qd[3:7]


def point_vector(qi: np.ndarray, si: np.ndarray, qj: np.ndarray, sj: np.ndarray) -> np.ndarray:
    """d_ij = r_j + A_j s_j' - r_i - A_i s_i': from point P_i on body i to point P_j on body j."""
    raise NotImplementedError("point_vector: d_ij = r_j + A_j s_j' - r_i - A_i s_i': from point P_i on body i to point P_j on body j, see eq. 9.1 and the notes in spatial/bodies.py")


def point_vector_dot(
    qi: np.ndarray, si: np.ndarray, qj: np.ndarray, sj: np.ndarray, qdi: np.ndarray, qdj: np.ndarray
) -> np.ndarray:
    """d_ij' = r_j' + B(p_j, s_j') p_j' - r_i' - B(p_i, s_i') p_i'."""
    raise NotImplementedError("point_vector_dot: d_ij' = r_j' + B(p_j, s_j') p_j' - r_i' - B(p_i, s_i') p_i', see eq. 9.1 and the notes in spatial/bodies.py")


def point_vector_quadratic(si: np.ndarray, sj: np.ndarray, qdi: np.ndarray, qdj: np.ndarray) -> np.ndarray:
    """Velocity part of d_ij'': B(p_j', s_j') p_j' - B(p_i', s_i') p_i'.

    d_ij'' = r_j'' + B(p_j, s_j') p_j'' - r_i'' - B(p_i, s_i') p_i'' + (this vector).
    """
    raise NotImplementedError("point_vector_quadratic: Velocity part of d_ij'': B(p_j', s_j') p_j' - B(p_i', s_i') p_i', see eq. 9.1 and the notes in spatial/bodies.py")


def point_jacobian(q: np.ndarray, s: np.ndarray) -> np.ndarray:
    """d(r + A s')/dq = [I, B(p, s')] (3 x 7): the Jacobian of a body point."""
    out = np.empty((3, 7))
    out[:, :3] = np.eye(3)
    out[:, 3:] = b_matrix(q[3:7], s)
    return out


def vector_jacobian(q: np.ndarray, a: np.ndarray) -> np.ndarray:
    """d(A a')/dq = [0, B(p, a')] (3 x 7): the Jacobian of a body-fixed vector."""
    out = np.zeros((3, 7))
    out[:, 3:] = b_matrix(q[3:7], a)
    return out


__all__ = [
    "b_matrix",
    "body_vector",
    "body_vector_dot",
    "body_vector_quadratic",
    "point_jacobian",
    "point_vector",
    "point_vector_dot",
    "point_vector_quadratic",
    "vector_jacobian",
]
