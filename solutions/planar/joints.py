"""Planar joints (kinematic pairs) as constraint equations Psi(q_i, q_j, t) = 0.

Every element connects body i and body j (either may be ground, whose q is zero) and gives

- ``constraints``  Psi                        (m,)
- ``jacobian``     (Psi_qi, Psi_qj)           two (m, 3) blocks
- ``psi_t``        dPsi/dt                    (m,)    zero for a joint, non-zero for a driver
- ``gamma``        right side of Psi_q q'' = gamma, gamma = -(Psi_q q')_q q' - 2 Psi_qt q' - Psi_tt

Points ``s_i``, ``s_j`` and directions are in the body frames (primed quantities of the notes).
Equation numbers refer to the course notes, chapter 3 (planar kinematic constraints).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..elements import ConstraintElement
from ..functions import Constant, ScalarFunction
from .bodies import (
    R90,
    point_vector,
    point_vector_dot,
    point_vector_quadratic,
    rotation,
    rotation_derivative,
)

ANGLE_ROW = np.array([0.0, 0.0, 1.0])


class PlanarElement(ConstraintElement):
    """A planar constraint element (``elements.ConstraintElement``): q_i = (x_i, y_i, phi_i), Psi_q blocks (m, 3)."""


def along_direction(qi, si, ui, qj, sj, qdi, qdj):
    """The scalar u_i^T d_ij with a direction u_i = A_i u_i' fixed in body i (eq. 3.13).

    This is the building block of the prismatic joint, the pin in a slot, the rack and pinion and
    the prismatic driver. Returns (value, Psi_qi row, Psi_qj row, gamma) where gamma is minus the
    velocity part of its second time derivative; pass ``qdi = qdj = None`` to skip gamma:

        (u^T d)'' = u^T d'' + 2 u'^T d' + u''^T d,  u' = B_i u_i' phi_i',  u'' = B_i u_i' phi_i'' - u phi_i'^2
        gamma = u^T d phi_i'^2 - 2 phi_i' (B_i u_i')^T d' - u^T (A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2)
    """
    ### BEGIN SOLUTION hw1
    u = rotation(qi[2]) @ ui
    w = rotation_derivative(qi[2]) @ ui  # du/dphi_i
    d = point_vector(qi, si, qj, sj)
    value = u @ d
    row_i = np.array([-u[0], -u[1], w @ d - u @ rotation_derivative(qi[2]) @ si])
    row_j = np.array([u[0], u[1], u @ rotation_derivative(qj[2]) @ sj])
    if qdi is None:
        return value, row_i, row_j, None
    d_dot = point_vector_dot(qi, si, qj, sj, qdi, qdj)
    quadratic = point_vector_quadratic(qi, si, qj, sj, qdi, qdj)
    gamma = value * qdi[2] ** 2 - 2.0 * qdi[2] * (w @ d_dot) - u @ quadratic
    return value, row_i, row_j, gamma
    ### END SOLUTION


@dataclass
class Revolute(PlanarElement):
    """Revolute joint: point P_i of body i and P_j of body j coincide (eq. 3.17).

    Psi = r_i + A_i s_i' - r_j - A_j s_j' = -d_ij                     (2 equations)
    Psi_q = [I, B_i s_i', -I, -B_j s_j'],  gamma = A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2
    """

    si: np.ndarray = None
    sj: np.ndarray = None

    def __post_init__(self):
        self.labels = (f"{self.name}.x", f"{self.name}.y")

    def constraints(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        return -point_vector(qi, self.si, qj, self.sj)
        ### END SOLUTION

    def jacobian(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        jac_i = np.zeros((2, 3))
        jac_j = np.zeros((2, 3))
        jac_i[:, :2] = np.eye(2)
        jac_i[:, 2] = rotation_derivative(qi[2]) @ self.si
        jac_j[:, :2] = -np.eye(2)
        jac_j[:, 2] = -rotation_derivative(qj[2]) @ self.sj
        return jac_i, jac_j
        ### END SOLUTION

    def gamma(self, qi, qj, qdi, qdj, t):
        ### BEGIN SOLUTION hw1
        return point_vector_quadratic(qi, self.si, qj, self.sj, qdi, qdj)
        ### END SOLUTION


@dataclass
class RelativeAngle(PlanarElement):
    """phi_j - phi_i - phi0 - f(t) = 0: the angle equation of prismatic and rigid joints (f = 0) and
    the rotational driver of a revolute joint (eq. 3.21, 3.34). Psi_t = -f', gamma = f''."""

    phi0: float = 0.0
    function: ScalarFunction = field(default_factory=lambda: Constant(0.0))

    def __post_init__(self):
        self.labels = (f"{self.name}.phi",)

    def constraints(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        return np.array([qj[2] - qi[2] - self.phi0 - self.function.value(t)])
        ### END SOLUTION

    def jacobian(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        return -ANGLE_ROW[None, :], ANGLE_ROW[None, :]
        ### END SOLUTION

    def psi_t(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        return np.array([-self.function.first(t)])
        ### END SOLUTION

    def gamma(self, qi, qj, qdi, qdj, t):
        ### BEGIN SOLUTION hw1
        return np.array([self.function.second(t)])
        ### END SOLUTION


@dataclass
class PinInSlot(PlanarElement):
    """Revolute-prismatic joint: pin P_j of body j moves in a slot of body i through P_i along v_i'.

    Psi = n_i^T d_ij = 0 with the slot normal n_i = A_i R90 v_i' (eq. 3.24): one equation.
    """

    si: np.ndarray = None
    sj: np.ndarray = None
    axis: np.ndarray = None  # unit slot direction v_i' in body i

    def __post_init__(self):
        self.labels = (f"{self.name}.n",)
        self._normal = R90 @ self.axis

    def constraints(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        value, _, _, _ = along_direction(qi, self.si, self._normal, qj, self.sj, None, None)
        return np.array([value])
        ### END SOLUTION

    def jacobian(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        _, row_i, row_j, _ = along_direction(qi, self.si, self._normal, qj, self.sj, None, None)
        return row_i[None, :], row_j[None, :]
        ### END SOLUTION

    def gamma(self, qi, qj, qdi, qdj, t):
        ### BEGIN SOLUTION hw1
        _, _, _, gamma = along_direction(qi, self.si, self._normal, qj, self.sj, qdi, qdj)
        return np.array([gamma])
        ### END SOLUTION


@dataclass
class Distance(PlanarElement):
    """Distance between P_i and P_j equals L(t): the revolute-revolute joint (composite link, L
    constant) and the distance driver (eq. 3.27).

    Psi = (d^T d - L^2) / 2,  Psi_q = d^T [-I, -B_i s_i', I, B_j s_j'],  Psi_t = -L L'
    gamma = -d'^T d' - d^T (A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2) + L'^2 + L L''
    """

    si: np.ndarray = None
    sj: np.ndarray = None
    length: ScalarFunction = None

    def __post_init__(self):
        self.labels = (f"{self.name}.length",)

    def constraints(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        d = point_vector(qi, self.si, qj, self.sj)
        return np.array([0.5 * (d @ d - self.length.value(t) ** 2)])
        ### END SOLUTION

    def jacobian(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        d = point_vector(qi, self.si, qj, self.sj)
        row_i = np.array([-d[0], -d[1], -d @ rotation_derivative(qi[2]) @ self.si])
        row_j = np.array([d[0], d[1], d @ rotation_derivative(qj[2]) @ self.sj])
        return row_i[None, :], row_j[None, :]
        ### END SOLUTION

    def psi_t(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        return np.array([-self.length.value(t) * self.length.first(t)])
        ### END SOLUTION

    def gamma(self, qi, qj, qdi, qdj, t):
        ### BEGIN SOLUTION hw1
        d = point_vector(qi, self.si, qj, self.sj)
        d_dot = point_vector_dot(qi, self.si, qj, self.sj, qdi, qdj)
        quadratic = point_vector_quadratic(qi, self.si, qj, self.sj, qdi, qdj)
        L, Ld, Ldd = self.length.value(t), self.length.first(t), self.length.second(t)
        return np.array([-(d_dot @ d_dot) - d @ quadratic + Ld * Ld + L * Ldd])
        ### END SOLUTION


@dataclass
class Translation(PlanarElement):
    """Displacement of P_j along the direction v_i' of body i: v_i^T d_ij - d0 - f(t) = 0.

    With a function f this is the driver of a prismatic joint (eq. 3.35). With ``pinion_radius``
    R it is the rack and pinion (eq. 3.31): body i is the rack with pitch line through P_i along
    v_i', body j the pinion centred at P_j, rolling without slip:
    v_i^T d_ij + side R (phi_j - phi_i) - d0 = 0, side = +1 when the pinion is on the left of v_i.
    """

    si: np.ndarray = None
    sj: np.ndarray = None
    axis: np.ndarray = None
    d0: float = 0.0
    function: ScalarFunction = field(default_factory=lambda: Constant(0.0))
    pinion_radius: float = 0.0
    side: float = 1.0

    def __post_init__(self):
        self.labels = (f"{self.name}.s",)

    def constraints(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        value, _, _, _ = along_direction(qi, self.si, self.axis, qj, self.sj, None, None)
        rolling = self.side * self.pinion_radius * (qj[2] - qi[2])
        return np.array([value + rolling - self.d0 - self.function.value(t)])
        ### END SOLUTION

    def jacobian(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        _, row_i, row_j, _ = along_direction(qi, self.si, self.axis, qj, self.sj, None, None)
        rolling = self.side * self.pinion_radius
        row_i[2] -= rolling
        row_j[2] += rolling
        return row_i[None, :], row_j[None, :]
        ### END SOLUTION

    def psi_t(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        return np.array([-self.function.first(t)])
        ### END SOLUTION

    def gamma(self, qi, qj, qdi, qdj, t):
        ### BEGIN SOLUTION hw1
        _, _, _, gamma = along_direction(qi, self.si, self.axis, qj, self.sj, qdi, qdj)
        return np.array([gamma + self.function.second(t)])
        ### END SOLUTION


@dataclass
class Gear(PlanarElement):
    """Gear pair with pitch radii R_i, R_j centred at P_i, P_j (eq. 3.29).

    Rolling without slip, measured relative to the line of centres at angle theta = atan2(d_ij):
    Psi = R_i (phi_i - theta) + sigma R_j (phi_j - theta) - c0, sigma = +1 for external gears and -1
    for an internal (ring) gear j. theta' = n^T d' / |d|^2 with n = R90 d, so
    Psi_q = [0, 0, R_i] for i, [0, 0, sigma R_j] for j, minus (R_i + sigma R_j) theta_q, and
    gamma = (R_i + sigma R_j) (n^T (A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2) - 2 theta' d^T d') / |d|^2.
    atan2 gives theta only modulo 2 pi, while the line of centres of a planetary gear turns without
    bound, so Psi is taken modulo 2 pi (R_i + sigma R_j): continuous where Psi is near zero.
    """

    si: np.ndarray = None
    sj: np.ndarray = None
    radius_i: float = 1.0
    radius_j: float = 1.0
    sigma: float = 1.0
    c0: float = 0.0

    def __post_init__(self):
        self.labels = (f"{self.name}.rolling",)

    def _theta(self, d):
        return math.atan2(d[1], d[0])

    def constraints(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        theta = self._theta(point_vector(qi, self.si, qj, self.sj))
        value = self.radius_i * (qi[2] - theta) + self.sigma * self.radius_j * (qj[2] - theta) - self.c0
        k = self.radius_i + self.sigma * self.radius_j
        return np.array([k * math.remainder(value / k, 2.0 * math.pi) if k else value])
        ### END SOLUTION

    def jacobian(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        d = point_vector(qi, self.si, qj, self.sj)
        n = R90 @ d / (d @ d)  # d theta / d d
        k = self.radius_i + self.sigma * self.radius_j
        row_i = np.array([k * n[0], k * n[1], self.radius_i + k * (n @ rotation_derivative(qi[2]) @ self.si)])
        row_j = np.array(
            [-k * n[0], -k * n[1], self.sigma * self.radius_j - k * (n @ rotation_derivative(qj[2]) @ self.sj)]
        )
        return row_i[None, :], row_j[None, :]
        ### END SOLUTION

    def gamma(self, qi, qj, qdi, qdj, t):
        ### BEGIN SOLUTION hw1
        d = point_vector(qi, self.si, qj, self.sj)
        d_dot = point_vector_dot(qi, self.si, qj, self.sj, qdi, qdj)
        quadratic = point_vector_quadratic(qi, self.si, qj, self.sj, qdi, qdj)
        dd = d @ d
        n = R90 @ d
        theta_dot = n @ d_dot / dd
        k = self.radius_i + self.sigma * self.radius_j
        return np.array([k * (n @ quadratic - 2.0 * theta_dot * (d @ d_dot)) / dd])
        ### END SOLUTION


@dataclass
class RollerCam(PlanarElement):
    """Cam i with a roller follower j whose centre P_j runs on the cam's pitch curve (eq. 3.32).

    The pitch curve is given in polar form in the cam frame, rho(theta), about the cam centre P_i:
    Psi = |d| - rho(beta - phi_i), beta = atan2(d), d = d_ij. With e = d / |d|, e_n = R90 e and
    g = e - rho'(theta) e_n / |d|: Psi_q = [-g^T, -g^T B_i s_i' + rho', g^T, g^T B_j s_j'];
    gamma = -(e^T a + (|d'|^2 - (e^T d')^2) / |d| - rho'' theta'^2
             - rho' (e_n^T a - 2 beta' e^T d') / |d|),  a = A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2.
    """

    si: np.ndarray = None
    sj: np.ndarray = None
    profile: ScalarFunction = None

    def __post_init__(self):
        self.labels = (f"{self.name}.contact",)

    def constraints(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        d = point_vector(qi, self.si, qj, self.sj)
        theta = math.atan2(d[1], d[0]) - qi[2]
        return np.array([math.hypot(d[0], d[1]) - self.profile.value(theta)])
        ### END SOLUTION

    def jacobian(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        d = point_vector(qi, self.si, qj, self.sj)
        length = math.hypot(d[0], d[1])
        e = d / length
        theta = math.atan2(d[1], d[0]) - qi[2]
        slope = self.profile.first(theta)
        g = e - slope * (R90 @ e) / length
        row_i = np.array([-g[0], -g[1], -g @ rotation_derivative(qi[2]) @ self.si + slope])
        row_j = np.array([g[0], g[1], g @ rotation_derivative(qj[2]) @ self.sj])
        return row_i[None, :], row_j[None, :]
        ### END SOLUTION

    def gamma(self, qi, qj, qdi, qdj, t):
        ### BEGIN SOLUTION hw1
        d = point_vector(qi, self.si, qj, self.sj)
        d_dot = point_vector_dot(qi, self.si, qj, self.sj, qdi, qdj)
        a = point_vector_quadratic(qi, self.si, qj, self.sj, qdi, qdj)
        length = math.hypot(d[0], d[1])
        e = d / length
        e_n = R90 @ e
        theta = math.atan2(d[1], d[0]) - qi[2]
        beta_dot = e_n @ d_dot / length
        theta_dot = beta_dot - qdi[2]
        radial = e @ d_dot
        length_part = e @ a + (d_dot @ d_dot - radial**2) / length
        angle_part = (e_n @ a - 2.0 * beta_dot * radial) / length
        velocity_part = length_part - self.profile.second(theta) * theta_dot**2 - self.profile.first(theta) * angle_part
        return np.array([-velocity_part])
        ### END SOLUTION


@dataclass
class FlatFaceCam(PlanarElement):
    """Cam i with a flat-faced follower j (eq. 3.33).

    The face is the line of body j through P_j with unit normal u = A_j u_j' pointing away from the
    cam; the cam is described by its support function p(psi), the distance from the cam centre P_i
    to its tangent line of normal angle psi in the cam frame. Contact:
    Psi = u^T (P_j - P_i) - p(psi) = 0, psi = phi_j - phi_i + alpha, alpha the angle of u_j'.
    u^T d_ij is ``along_direction`` seen from body j (d_ji = -d_ij), so Psi_q and gamma follow
    from it with the p terms: Psi_qi[2] += p', Psi_qj[2] -= p', gamma += p'' psi'^2.
    """

    si: np.ndarray = None
    sj: np.ndarray = None
    normal: np.ndarray = None  # u_j' in body j
    profile: ScalarFunction = None

    def __post_init__(self):
        self.labels = (f"{self.name}.contact",)
        self._alpha = math.atan2(self.normal[1], self.normal[0])

    def constraints(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        value, _, _, _ = along_direction(qj, self.sj, self.normal, qi, self.si, None, None)
        psi = qj[2] - qi[2] + self._alpha
        return np.array([-value - self.profile.value(psi)])
        ### END SOLUTION

    def jacobian(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        _, row_j, row_i, _ = along_direction(qj, self.sj, self.normal, qi, self.si, None, None)
        slope = self.profile.first(qj[2] - qi[2] + self._alpha)
        row_i, row_j = -row_i, -row_j
        row_i[2] += slope
        row_j[2] -= slope
        return row_i[None, :], row_j[None, :]
        ### END SOLUTION

    def gamma(self, qi, qj, qdi, qdj, t):
        ### BEGIN SOLUTION hw1
        _, _, _, gamma = along_direction(qj, self.sj, self.normal, qi, self.si, qdj, qdi)
        psi = qj[2] - qi[2] + self._alpha
        psi_dot = qdj[2] - qdi[2]
        return np.array([-gamma + self.profile.second(psi) * psi_dot**2])
        ### END SOLUTION


@dataclass
class BodyCoordinate(PlanarElement):
    """Driver of one coordinate of body j (x, y or phi): q_j[k] - f(t) = 0 (eq. 3.34).

    Body i is ground. Psi_q is a unit row, Psi_t = -f'(t), gamma = f''(t).
    """

    index: int = 0
    function: ScalarFunction = None

    def __post_init__(self):
        self.labels = (f"{self.name}.{'xyz'[self.index] if self.index < 2 else 'phi'}",)
        self._row = np.eye(3)[self.index][None, :]

    def constraints(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        return np.array([qj[self.index] - self.function.value(t)])
        ### END SOLUTION

    def jacobian(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        return np.zeros((1, 3)), self._row
        ### END SOLUTION

    def psi_t(self, qi, qj, t):
        ### BEGIN SOLUTION hw1
        return np.array([-self.function.first(t)])
        ### END SOLUTION

    def gamma(self, qi, qj, qdi, qdj, t):
        ### BEGIN SOLUTION hw1
        return np.array([self.function.second(t)])
        ### END SOLUTION
