# Generated from solutions/rotations.py by `make modules` (every homework stubbed): do not edit by hand.
"""Rotations in space: Euler parameters, the rotation matrix, Euler angles, Rodrigues' formula, screws.

The orientation of a body frame (x', y', z') in the global frame (x, y, z) is the 3 x 3 rotation
matrix A: a vector with body components a' has global components a = A a' (course notes, ch. 8).
A is orthogonal, A^T A = I, det A = +1, so only three of its nine entries are independent.

Euler's theorem: any rotation is a rotation by an angle chi about a unit axis u. The four
**Euler parameters** (a unit quaternion) describe it without any singular orientation,

    p = (e0, e), e0 = cos(chi / 2), e = u sin(chi / 2),      p^T p = 1              (eq. 8.10)

and p and -p are the same rotation. The rotation matrix in terms of them is (eq. 8.12)

    A(p) = (2 e0^2 - 1) I + 2 (e e^T + e0 e~) = G(p) L(p)^T,

with the skew-symmetric matrix a~ of a vector (a~ b = a x b) and the two 3 x 4 matrices (eq. 8.14)

    G(p) = [-e, e~ + e0 I],       L(p) = [-e, -e~ + e0 I].

They give the angular velocity from the Euler-parameter rates (eq. 8.16),

    omega = 2 G(p) p'      (global frame),          omega' = 2 L(p) p'      (body frame),

and back, p' = 1/2 G^T omega = 1/2 L^T omega'. (This is Nikravesh's notation, Computer-Aided
Analysis of Mechanical Systems, 1988; Haug, Computer-Aided Kinematics and Dynamics of
Mechanical Systems, 1989, writes E for our G and G for our L.)

Euler angles are three successive rotations about coordinate axes: 3-1-3 (precession psi, nutation
theta, spin phi, the classical choice for a top) and 1-2-3 (Cardan, or Bryant, angles). Each has a
singular orientation (gimbal lock: theta = 0 or pi for 3-1-3, theta = +-pi/2 for 1-2-3) where only
the sum or difference of the first and last angle is defined; the conversions below return one valid
triple there (the last angle set to zero).

The functions students write here (``rotation_matrix``, ``g_matrix``, ``l_matrix``) are their homework; the rest
of the package takes A(p), G(p) and L(p) from ``rotation_matrices``, where each is written once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .rotation_matrices import quaternion_product_entries

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
"""The Euler parameters of no rotation."""

GIMBAL_TOLERANCE = 1e-9
"""|sin theta| (3-1-3) or |cos theta| (1-2-3) below which an orientation counts as gimbal-locked."""


def skew(a: np.ndarray) -> np.ndarray:
    """The skew-symmetric matrix a~ with a~ b = a x b (eq. 8.4)."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


# -- Euler parameters and the rotation matrix -----------------------------------------------------
def g_matrix(p: np.ndarray) -> np.ndarray:
    """G(p) = [-e, e~ + e0 I] (3 x 4): omega = 2 G p' in the global frame (eq. 8.14)."""
    raise NotImplementedError("g_matrix: G(p) = [-e, e~ + e0 I] (3 x 4): omega = 2 G p' in the global frame, see eq. 8.14")


def l_matrix(p: np.ndarray) -> np.ndarray:
    """L(p) = [-e, -e~ + e0 I] (3 x 4): omega' = 2 L p' in the body frame (eq. 8.14)."""
    raise NotImplementedError("l_matrix: L(p) = [-e, -e~ + e0 I] (3 x 4): omega' = 2 L p' in the body frame, see eq. 8.14")


def rotation_matrix(p: np.ndarray) -> np.ndarray:
    """A(p) = G(p) L(p)^T = (e0^2 - e^T e) I + 2 e e^T + 2 e0 e~ (eq. 8.12).

    For unit p this is (2 e0^2 - 1) I + 2 (e e^T + e0 e~). Written as G L^T it is a homogeneous
    quadratic form in p, which is the form the constraint Jacobians differentiate (see
    ``spatial.bodies.b_matrix``); the normalization constraint p^T p = 1 makes it a rotation.
    """
    raise NotImplementedError('rotation_matrix: A(p) = G(p) L(p)^T = (e0^2 - e^T e) I + 2 e e^T + 2 e0 e~, see eq. 8.12')


def euler_parameters(A: np.ndarray) -> np.ndarray:
    """Euler parameters of a rotation matrix, robust in every quadrant (Shepperd's method, eq. 8.13).

    From A = (2 e0^2 - 1) I + 2 (e e^T + e0 e~) the four squares are

        4 e0^2 = 1 + tr A,   4 ek^2 = 1 + 2 A_kk - tr A   (k = 1, 2, 3),

    and the off-diagonal sums and differences give the products e0 ek and ek el. Dividing by the
    largest of the four (never smaller than 1/2 in size) avoids the loss of accuracy of the naive
    formula e0 = sqrt(1 + tr A) / 2 near chi = pi. Returned with e0 >= 0.
    """
    A = np.asarray(A, dtype=float)
    trace = np.trace(A)
    squares = np.array([1.0 + trace, 1.0 + 2 * A[0, 0] - trace, 1.0 + 2 * A[1, 1] - trace, 1.0 + 2 * A[2, 2] - trace])
    k = int(np.argmax(squares))
    big = 0.5 * math.sqrt(squares[k])  # the largest parameter in size
    four_e0_e = np.array([A[2, 1] - A[1, 2], A[0, 2] - A[2, 0], A[1, 0] - A[0, 1]])  # 4 e0 e
    sym = np.array([A[0, 1] + A[1, 0], A[0, 2] + A[2, 0], A[1, 2] + A[2, 1]])  # 4 e1 e2, 4 e1 e3, 4 e2 e3
    if k == 0:
        p = np.array([big, *(four_e0_e / (4 * big))])
    elif k == 1:
        p = np.array([four_e0_e[0], 4 * big * big, sym[0], sym[1]]) / (4 * big)
    elif k == 2:
        p = np.array([four_e0_e[1], sym[0], 4 * big * big, sym[2]]) / (4 * big)
    else:
        p = np.array([four_e0_e[2], sym[1], sym[2], 4 * big * big]) / (4 * big)
    p /= np.linalg.norm(p)
    return -p if p[0] < 0 else p


def normalized(p: np.ndarray) -> np.ndarray:
    """p / |p|: the nearest unit quaternion (Euler parameters drift off |p| = 1 numerically)."""
    p = np.asarray(p, dtype=float)
    return p / np.linalg.norm(p)


def quaternion_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a * b = (a0 b0 - a.b, a0 b + b0 a + a x b): the rotation b followed by a, A(a b) = A(a) A(b)."""
    return np.array(quaternion_product_entries(*map(float, a), *map(float, b)))


def conjugate(p: np.ndarray) -> np.ndarray:
    """(e0, -e): the inverse rotation, A(conj p) = A(p)^T."""
    return np.array([p[0], -p[1], -p[2], -p[3]])


# -- angular velocity ---------------------------------------------------------------------------
def angular_velocity(p: np.ndarray, pd: np.ndarray) -> np.ndarray:
    """omega = 2 G(p) p', the angular velocity in the global frame (eq. 8.16)."""
    return 2.0 * g_matrix(p) @ pd


def body_angular_velocity(p: np.ndarray, pd: np.ndarray) -> np.ndarray:
    """omega' = 2 L(p) p' = A^T omega, the angular velocity in the body frame (eq. 8.16)."""
    return 2.0 * l_matrix(p) @ pd


def euler_parameter_rates(p: np.ndarray, omega: np.ndarray, frame: str = "global") -> np.ndarray:
    """p' = 1/2 G^T omega (global omega) or 1/2 L^T omega' (body omega') (eq. 8.17).

    These invert eq. 8.16 because G G^T = L L^T = I and G p = L p = 0 for a unit p; the p' they
    give satisfies p^T p' = 0, the time derivative of the normalization constraint.
    """
    matrix = g_matrix(p) if frame == "global" else l_matrix(p)
    return 0.5 * matrix.T @ np.asarray(omega, dtype=float)


# -- axis and angle: Rodrigues' formula -------------------------------------------------------------
def rodrigues(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' formula: A = I + sin(chi) u~ + (1 - cos(chi)) u~^2 for a rotation chi about u (eq. 8.8)."""
    u = np.asarray(axis, dtype=float)
    u = u / np.linalg.norm(u)
    ut = skew(u)
    return np.eye(3) + math.sin(angle) * ut + (1.0 - math.cos(angle)) * (ut @ ut)


def from_axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """p = (cos(chi/2), u sin(chi/2)) for a rotation chi about the unit axis u (eq. 8.10)."""
    u = np.asarray(axis, dtype=float)
    u = u / np.linalg.norm(u)
    return np.array([math.cos(angle / 2), *(math.sin(angle / 2) * u)])


def to_axis_angle(p: np.ndarray) -> tuple[np.ndarray, float]:
    """(u, chi) with chi in [0, pi] of unit Euler parameters (eq. 8.10).

    chi = 2 atan2(|e|, |e0|) keeps full accuracy for small and large angles alike (arccos(e0) does
    not near chi = 0). With no rotation the axis is arbitrary: (1, 0, 0) is returned.
    """
    p = normalized(p)
    if p[0] < 0:
        p = -p
    sine = float(np.linalg.norm(p[1:]))
    if sine == 0.0:
        return np.array([1.0, 0.0, 0.0]), 0.0
    return p[1:] / sine, 2.0 * math.atan2(sine, p[0])


# -- Euler angles ---------------------------------------------------------------------------------
def axis_rotation(k: int, angle: float) -> np.ndarray:
    """Euler parameters of a rotation by ``angle`` about coordinate axis k (0 = x, 1 = y, 2 = z)."""
    p = np.zeros(4)
    p[0] = math.cos(angle / 2)
    p[k + 1] = math.sin(angle / 2)
    return p


def from_euler_313(psi: float, theta: float, phi: float) -> np.ndarray:
    """p of A = R_z(psi) R_x(theta) R_z(phi): precession, nutation, spin (eq. 8.6)."""
    return quaternion_product(quaternion_product(axis_rotation(2, psi), axis_rotation(0, theta)), axis_rotation(2, phi))


def to_euler_313(p: np.ndarray) -> tuple[float, float, float]:
    """(psi, theta, phi) with theta in [0, pi] of A = R_z(psi) R_x(theta) R_z(phi) (eq. 8.6).

    A_33 = cos(theta), (A_13, -A_23) = sin(theta) (sin psi, cos psi), (A_31, A_32) = sin(theta)
    (sin phi, cos phi). In gimbal lock (sin theta = 0) only psi +- phi is defined: phi = 0 and psi
    from the upper-left block, which is then a rotation (theta = 0) or a reflected one (theta = pi)
    with (A_11, A_21) = (cos psi, sin psi) in both cases.
    """
    A = rotation_matrix(normalized(p))
    sine = math.hypot(A[0, 2], A[1, 2])
    theta = math.atan2(sine, A[2, 2])
    if sine < GIMBAL_TOLERANCE:
        return math.atan2(A[1, 0], A[0, 0]), theta, 0.0
    return math.atan2(A[0, 2], -A[1, 2]), theta, math.atan2(A[2, 0], A[2, 1])


def from_euler_123(phi: float, theta: float, psi: float) -> np.ndarray:
    """p of A = R_x(phi) R_y(theta) R_z(psi): Cardan (Bryant) angles (eq. 8.7)."""
    return quaternion_product(quaternion_product(axis_rotation(0, phi), axis_rotation(1, theta)), axis_rotation(2, psi))


def to_euler_123(p: np.ndarray) -> tuple[float, float, float]:
    """(phi, theta, psi) with theta in [-pi/2, pi/2] of A = R_x(phi) R_y(theta) R_z(psi) (eq. 8.7).

    A_13 = sin(theta), (-A_23, A_33) = cos(theta) (sin phi, cos phi), (-A_12, A_11) = cos(theta)
    (sin psi, cos psi). In gimbal lock (cos theta = 0) only phi +- psi is defined: psi = 0 and then
    A_21 = sin(theta) sin(phi), A_22 = cos(phi).
    """
    A = rotation_matrix(normalized(p))
    cosine = math.hypot(A[0, 0], A[0, 1])
    theta = math.atan2(A[0, 2], cosine)
    if cosine < GIMBAL_TOLERANCE:
        return math.atan2(math.copysign(1.0, A[0, 2]) * A[1, 0], A[1, 1]), theta, 0.0
    return math.atan2(-A[1, 2], A[2, 2]), theta, math.atan2(-A[0, 1], A[0, 0])


# -- screw motion -----------------------------------------------------------------------------------
@dataclass
class Screw:
    """A rigid displacement as a screw (Chasles' theorem): a rotation ``angle`` about the line through
    ``point`` along the unit ``axis``, with a slide ``translation`` along it; ``pitch`` = slide / angle."""

    axis: np.ndarray
    angle: float
    translation: float
    point: np.ndarray

    @property
    def pitch(self) -> float:
        return self.translation / self.angle if self.angle else math.inf


def screw_parameters(A: np.ndarray, d: np.ndarray) -> Screw:
    """The screw of the displacement x -> A x + d (eq. 8.20).

    Axis u and angle chi in [0, pi] come from A. The slide along the axis is h = u^T d. The axis
    passes through the point rho, perpendicular to u, that only slides: A rho + d = rho + h u, whose
    solution is rho = 1/2 (d_perp + cot(chi/2) u x d), d_perp = d - h u. A pure translation
    (chi = 0) has its axis along d, the point at the origin and infinite pitch.
    """
    d = np.asarray(d, dtype=float)
    u, angle = to_axis_angle(euler_parameters(A))
    if angle < 1e-12:
        size = float(np.linalg.norm(d))
        axis = d / size if size > 0 else np.array([1.0, 0.0, 0.0])
        return Screw(axis, 0.0, size, np.zeros(3))
    slide = float(u @ d)
    perpendicular = d - slide * u
    point = 0.5 * (perpendicular + np.cross(u, d) / math.tan(angle / 2))
    return Screw(u, angle, slide, point)


def displacement(q_from: np.ndarray, q_to: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A, d) of the displacement x -> A x + d that carries a body from q_from = (r1, p1) to q_to = (r2, p2).

    A body point at r1 + A1 s' moves to r2 + A2 s', so A = A2 A1^T and d = r2 - A r1.
    """
    A = rotation_matrix(normalized(q_to[3:7])) @ rotation_matrix(normalized(q_from[3:7])).T
    return A, np.asarray(q_to[:3], dtype=float) - A @ q_from[:3]


__all__ = [
    "IDENTITY",
    "Screw",
    "angular_velocity",
    "axis_rotation",
    "body_angular_velocity",
    "conjugate",
    "displacement",
    "euler_parameter_rates",
    "euler_parameters",
    "from_axis_angle",
    "from_euler_123",
    "from_euler_313",
    "g_matrix",
    "l_matrix",
    "normalized",
    "quaternion_product",
    "rodrigues",
    "rotation_matrix",
    "screw_parameters",
    "skew",
    "to_axis_angle",
    "to_euler_123",
    "to_euler_313",
]
