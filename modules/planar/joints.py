# Generated from solutions/planar/joints.py by `make modules` (every homework stubbed): do not edit by hand.
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
    raise NotImplementedError("along_direction: The scalar u_i^T d_ij with a direction u_i = A_i u_i' fixed in body i, see eq. 3.13")


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
        raise NotImplementedError('Revolute.constraints: the constraint equations Psi (Revolute joint: point P_i of body i and P_j of body j coincide), see eq. 3.17')

    def jacobian(self, qi, qj, t):
        raise NotImplementedError('Revolute.jacobian: the Jacobian Psi_q (Revolute joint: point P_i of body i and P_j of body j coincide), see eq. 3.17')

    def gamma(self, qi, qj, qdi, qdj, t):
        raise NotImplementedError("Revolute.gamma: gamma, the right side of Psi_q q'' = gamma (Revolute joint: point P_i of body i and P_j of body j coincide), see eq. 3.17")


@dataclass
class RelativeAngle(PlanarElement):
    """phi_j - phi_i - phi0 - f(t) = 0: the angle equation of prismatic and rigid joints (f = 0) and
    the rotational driver of a revolute joint (eq. 3.21, 3.34). Psi_t = -f', gamma = f''."""

    phi0: float = 0.0
    function: ScalarFunction = field(default_factory=lambda: Constant(0.0))

    def __post_init__(self):
        self.labels = (f"{self.name}.phi",)

    def constraints(self, qi, qj, t):
        raise NotImplementedError('RelativeAngle.constraints: the constraint equations Psi (phi_j - phi_i - phi0 - f(t) = 0: the angle equation of prismatic and rigid joints (f = 0) and the rotational driver of a revolute joint), see eq. 3.21, 3.34')

    def jacobian(self, qi, qj, t):
        raise NotImplementedError('RelativeAngle.jacobian: the Jacobian Psi_q (phi_j - phi_i - phi0 - f(t) = 0: the angle equation of prismatic and rigid joints (f = 0) and the rotational driver of a revolute joint), see eq. 3.21, 3.34')

    def psi_t(self, qi, qj, t):
        raise NotImplementedError('RelativeAngle.psi_t: Psi_t, the partial time derivative of Psi (phi_j - phi_i - phi0 - f(t) = 0: the angle equation of prismatic and rigid joints (f = 0) and the rotational driver of a revolute joint), see eq. 3.21, 3.34')

    def gamma(self, qi, qj, qdi, qdj, t):
        raise NotImplementedError("RelativeAngle.gamma: gamma, the right side of Psi_q q'' = gamma (phi_j - phi_i - phi0 - f(t) = 0: the angle equation of prismatic and rigid joints (f = 0) and the rotational driver of a revolute joint), see eq. 3.21, 3.34")


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
        raise NotImplementedError("PinInSlot.constraints: the constraint equations Psi (Revolute-prismatic joint: pin P_j of body j moves in a slot of body i through P_i along v_i'), see eq. 3.24")

    def jacobian(self, qi, qj, t):
        raise NotImplementedError("PinInSlot.jacobian: the Jacobian Psi_q (Revolute-prismatic joint: pin P_j of body j moves in a slot of body i through P_i along v_i'), see eq. 3.24")

    def gamma(self, qi, qj, qdi, qdj, t):
        raise NotImplementedError("PinInSlot.gamma: gamma, the right side of Psi_q q'' = gamma (Revolute-prismatic joint: pin P_j of body j moves in a slot of body i through P_i along v_i'), see eq. 3.24")


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
        raise NotImplementedError('Distance.constraints: the constraint equations Psi (Distance between P_i and P_j equals L(t): the revolute-revolute joint (composite link, L constant) and the distance driver), see eq. 3.27')

    def jacobian(self, qi, qj, t):
        raise NotImplementedError('Distance.jacobian: the Jacobian Psi_q (Distance between P_i and P_j equals L(t): the revolute-revolute joint (composite link, L constant) and the distance driver), see eq. 3.27')

    def psi_t(self, qi, qj, t):
        raise NotImplementedError('Distance.psi_t: Psi_t, the partial time derivative of Psi (Distance between P_i and P_j equals L(t): the revolute-revolute joint (composite link, L constant) and the distance driver), see eq. 3.27')

    def gamma(self, qi, qj, qdi, qdj, t):
        raise NotImplementedError("Distance.gamma: gamma, the right side of Psi_q q'' = gamma (Distance between P_i and P_j equals L(t): the revolute-revolute joint (composite link, L constant) and the distance driver), see eq. 3.27")


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
        raise NotImplementedError("Translation.constraints: the constraint equations Psi (Displacement of P_j along the direction v_i' of body i: v_i^T d_ij - d0 - f(t) = 0), see eq. 3.35")

    def jacobian(self, qi, qj, t):
        raise NotImplementedError("Translation.jacobian: the Jacobian Psi_q (Displacement of P_j along the direction v_i' of body i: v_i^T d_ij - d0 - f(t) = 0), see eq. 3.35")

    def psi_t(self, qi, qj, t):
        raise NotImplementedError("Translation.psi_t: Psi_t, the partial time derivative of Psi (Displacement of P_j along the direction v_i' of body i: v_i^T d_ij - d0 - f(t) = 0), see eq. 3.35")

    def gamma(self, qi, qj, qdi, qdj, t):
        raise NotImplementedError("Translation.gamma: gamma, the right side of Psi_q q'' = gamma (Displacement of P_j along the direction v_i' of body i: v_i^T d_ij - d0 - f(t) = 0), see eq. 3.35")


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
        raise NotImplementedError('Gear.constraints: the constraint equations Psi (Gear pair with pitch radii R_i, R_j centred at P_i, P_j), see eq. 3.29')

    def jacobian(self, qi, qj, t):
        raise NotImplementedError('Gear.jacobian: the Jacobian Psi_q (Gear pair with pitch radii R_i, R_j centred at P_i, P_j), see eq. 3.29')

    def gamma(self, qi, qj, qdi, qdj, t):
        raise NotImplementedError("Gear.gamma: gamma, the right side of Psi_q q'' = gamma (Gear pair with pitch radii R_i, R_j centred at P_i, P_j), see eq. 3.29")


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
        raise NotImplementedError("RollerCam.constraints: the constraint equations Psi (Cam i with a roller follower j whose centre P_j runs on the cam's pitch curve), see eq. 3.32")

    def jacobian(self, qi, qj, t):
        raise NotImplementedError("RollerCam.jacobian: the Jacobian Psi_q (Cam i with a roller follower j whose centre P_j runs on the cam's pitch curve), see eq. 3.32")

    def gamma(self, qi, qj, qdi, qdj, t):
        raise NotImplementedError("RollerCam.gamma: gamma, the right side of Psi_q q'' = gamma (Cam i with a roller follower j whose centre P_j runs on the cam's pitch curve), see eq. 3.32")


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
        raise NotImplementedError('FlatFaceCam.constraints: the constraint equations Psi (Cam i with a flat-faced follower j), see eq. 3.33')

    def jacobian(self, qi, qj, t):
        raise NotImplementedError('FlatFaceCam.jacobian: the Jacobian Psi_q (Cam i with a flat-faced follower j), see eq. 3.33')

    def gamma(self, qi, qj, qdi, qdj, t):
        raise NotImplementedError("FlatFaceCam.gamma: gamma, the right side of Psi_q q'' = gamma (Cam i with a flat-faced follower j), see eq. 3.33")


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
        raise NotImplementedError('BodyCoordinate.constraints: the constraint equations Psi (Driver of one coordinate of body j (x, y or phi): q_j[k] - f(t) = 0), see eq. 3.34')

    def jacobian(self, qi, qj, t):
        raise NotImplementedError('BodyCoordinate.jacobian: the Jacobian Psi_q (Driver of one coordinate of body j (x, y or phi): q_j[k] - f(t) = 0), see eq. 3.34')

    def psi_t(self, qi, qj, t):
        raise NotImplementedError('BodyCoordinate.psi_t: Psi_t, the partial time derivative of Psi (Driver of one coordinate of body j (x, y or phi): q_j[k] - f(t) = 0), see eq. 3.34')

    def gamma(self, qi, qj, qdi, qdj, t):
        raise NotImplementedError("BodyCoordinate.gamma: gamma, the right side of Psi_q q'' = gamma (Driver of one coordinate of body j (x, y or phi): q_j[k] - f(t) = 0), see eq. 3.34")
