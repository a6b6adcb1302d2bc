"""Planar force elements and their generalized forces Q (course notes, chapter 5).

A force F applied at a point P of body i, P at body-frame position s_i', does the virtual work
F^T (delta r_i + B_i s_i' delta phi_i), so its generalized force on body i is (eq. 5.10)

    Q_i = [ F ; (B_i s_i')^T F ]                 (x, y force components and the moment about the centre)

and a torque T on body i gives Q_i = [0, 0, T]. Every element below is built from these two rules:

- gravity                 F = m_i g at the centre of mass                                  (eq. 5.11)
- point force / torque    a given F(t) (global, or fixed in the body) or T(t)              (eq. 5.10)
- TSDA                    translational spring-damper-actuator between P_i and P_j         (eq. 5.13)
- RSDA                    rotational spring-damper-actuator between bodies i and j         (eq. 5.15)

Like the joints, every element connects body i and body j (-1 is ground, which has no coordinates);
a load on one body has j = -1: its reaction goes to the fixed surroundings. Each element gives

- ``forces(qi, qj, qdi, qdj, t)``  -> (Q_i, Q_j), two (3,) blocks of the generalized force vector
- ``potential(qi, qj)``            its potential energy (springs and gravity; 0 otherwise)
- ``dissipated_power(...)``        power taken out by its dampers (>= 0)
- ``applied_power(...)``           power put in by actuators and applied loads

so that the energy balance T + V + (energy dissipated) - (work applied) = const can be checked.

Sign convention for spring-damper-actuators (Nikravesh 1988, sec. 7.3): the scalar force f is
positive in tension, i.e. when it pulls the two points together,

    f = k (l - l0) + c l' + f_a(t, l, l'),

so a positive actuator force f_a pulls too. (Project Chrono's ChLinkTSDA uses the opposite sign for
its force functor; the keys of the model file are Chrono's, this sign is the course's.)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..functions import ScalarFunction
from .bodies import point_vector, point_vector_dot, rotation, rotation_derivative

ZERO3 = np.zeros(3)

Actuator = Callable[[float, float, float], float]
"""An actuator force (or torque) f_a(t, length, length') -- of time and, through the API, of the state."""


@dataclass(frozen=True)
class TimeActuator:
    """An actuator force that is a function of time only, f_a(t) (what a model file gives)."""

    function: ScalarFunction

    def __call__(self, t: float, length: float, velocity: float) -> float:
        return self.function.value(t)


def no_actuator(t: float, length: float, velocity: float) -> float:
    """f_a = 0."""
    return 0.0


# -- the generalized forces of the course ---------------------------------------------------------
def gravity_force(mass: float, gravity: np.ndarray) -> np.ndarray:
    """Q_i = [m_i g_x, m_i g_y, 0]: the weight acts at the centre of mass, no moment (eq. 5.11)."""
    ### BEGIN SOLUTION hw2
    return np.array([mass * gravity[0], mass * gravity[1], 0.0])
    ### END SOLUTION


def point_force(phi: float, s: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Q_i = [F ; (B_i s_i')^T F]: global force F at body point s_i' of a body at angle phi (eq. 5.10)."""
    ### BEGIN SOLUTION hw2
    moment = (rotation_derivative(phi) @ s) @ force
    return np.array([force[0], force[1], moment])
    ### END SOLUTION


def tsda_forces(
    qi: np.ndarray, si: np.ndarray, qj: np.ndarray, sj: np.ndarray, f: float
) -> tuple[np.ndarray, np.ndarray]:
    """(Q_i, Q_j) of a scalar tension f along the line from P_i to P_j (eq. 5.13).

    With d = d_ij, l = |d|, u = d / l, the force f u pulls P_i towards P_j and -f u pulls P_j back:

        Q_i = f [u ; (B_i s_i')^T u],     Q_j = -f [u ; (B_j s_j')^T u]
    """
    ### BEGIN SOLUTION hw2
    d = point_vector(qi, si, qj, sj)
    u = d / math.sqrt(d @ d)
    return point_force(qi[2], si, f * u), point_force(qj[2], sj, -f * u)
    ### END SOLUTION


def tsda_length(
    qi: np.ndarray, si: np.ndarray, qj: np.ndarray, sj: np.ndarray, qdi: np.ndarray, qdj: np.ndarray
) -> tuple[float, float]:
    """Length l = |d_ij| and its rate l' = u^T d_ij' of a spring-damper between P_i and P_j (eq. 5.12)."""
    ### BEGIN SOLUTION hw2
    d = point_vector(qi, si, qj, sj)
    length = math.sqrt(d @ d)
    velocity = (d @ point_vector_dot(qi, si, qj, sj, qdi, qdj)) / length
    return length, velocity
    ### END SOLUTION


def rsda_forces(f: float) -> tuple[np.ndarray, np.ndarray]:
    """(Q_i, Q_j) of a rotational spring-damper torque f = k (theta - theta0) + c theta' + f_a (eq. 5.15).

    theta = phi_j - phi_i; the torque f turns body i forwards and body j back: Q_i = [0, 0, f],
    Q_j = [0, 0, -f].
    """
    ### BEGIN SOLUTION hw2
    return np.array([0.0, 0.0, f]), np.array([0.0, 0.0, -f])
    ### END SOLUTION


# -- the elements ---------------------------------------------------------------------------------
@dataclass
class ForceElement:
    """Common data of every force element: its name and the two bodies it acts on (-1 is ground)."""

    name: str
    i: int
    j: int

    @property
    def is_conservative(self) -> bool:
        """True when the element has a potential and neither damps nor puts work in."""
        return False

    def potential(self, qi: np.ndarray, qj: np.ndarray) -> float:
        return 0.0

    def dissipated_power(self, qi, qj, qdi, qdj, t) -> float:
        return 0.0

    def applied_power(self, qi, qj, qdi, qdj, t) -> float:
        return 0.0

    def powers(self, qi, qj, qdi, qdj, t) -> tuple[float, float]:
        """(dissipated power, applied power) in one evaluation."""
        return self.dissipated_power(qi, qj, qdi, qdj, t), self.applied_power(qi, qj, qdi, qdj, t)

    def measures(self, qi, qj, qdi, qdj, t) -> dict[str, float]:
        """What the element exerts, by the suffix of its result column ('force', 'torque', 'Fx', ...)."""
        return {}


@dataclass
class PointForce(ForceElement):
    """A force F(t) at the body point s' of body i; ``body_fixed`` turns F with the body (F = A_i F').

    ``components`` are the functions of time giving F_x and F_y (global, or in the body frame).
    """

    point: np.ndarray = field(default_factory=lambda: np.zeros(2))
    components: tuple[ScalarFunction, ScalarFunction] = ()
    body_fixed: bool = False

    def force(self, qi: np.ndarray, t: float) -> np.ndarray:
        """The global force vector F at time t."""
        force = np.array([self.components[0].value(t), self.components[1].value(t)])
        return rotation(qi[2]) @ force if self.body_fixed else force

    def forces(self, qi, qj, qdi, qdj, t):
        return point_force(qi[2], self.point, self.force(qi, t)), ZERO3

    def applied_power(self, qi, qj, qdi, qdj, t):
        Qi, _ = self.forces(qi, qj, qdi, qdj, t)
        return float(qdi @ Qi)  # = F^T v_P

    def measures(self, qi, qj, qdi, qdj, t):
        """The global force: 'Fx', 'Fy'."""
        return dict(zip(("Fx", "Fy"), map(float, self.force(qi, t)), strict=True))


@dataclass
class Torque(ForceElement):
    """A torque T(t) on body i (counter-clockwise positive): Q_i = [0, 0, T]."""

    function: ScalarFunction = None

    def forces(self, qi, qj, qdi, qdj, t):
        return np.array([0.0, 0.0, self.function.value(t)]), ZERO3

    def applied_power(self, qi, qj, qdi, qdj, t):
        return self.function.value(t) * qdi[2]

    def measures(self, qi, qj, qdi, qdj, t):
        """The torque T, counter-clockwise positive."""
        return {"torque": self.function.value(t)}


@dataclass
class TSDA(ForceElement):
    """Translational spring-damper-actuator between P_i (s_i' on body i) and P_j (s_j' on body j).

    Tension f = k (l - l0) + c l' + f_a(t, l, l') (eq. 5.14); potential 1/2 k (l - l0)^2,
    dissipated power c l'^2, actuator power -f_a l'.
    """

    si: np.ndarray = None
    sj: np.ndarray = None
    stiffness: float = 0.0
    damping: float = 0.0
    free_length: float = 0.0
    actuator: Actuator = no_actuator

    def state(self, qi, qj, qdi, qdj) -> tuple[float, float]:
        """(l, l')."""
        length, velocity = tsda_length(qi, self.si, qj, self.sj, qdi, qdj)
        if length < 1e-12:
            raise ValueError(f"spring-damper {self.name}: its two points coincide (length 0): no line of action")
        return length, velocity

    def tension(self, t: float, length: float, velocity: float) -> float:
        """f = k (l - l0) + c l' + f_a (eq. 5.14)."""
        ### BEGIN SOLUTION hw2
        spring = self.stiffness * (length - self.free_length)
        return spring + self.damping * velocity + self.actuator(t, length, velocity)
        ### END SOLUTION

    @property
    def is_conservative(self) -> bool:
        return self.damping == 0.0 and self.actuator is no_actuator

    def forces(self, qi, qj, qdi, qdj, t):
        length, velocity = self.state(qi, qj, qdi, qdj)
        return tsda_forces(qi, self.si, qj, self.sj, self.tension(t, length, velocity))

    def potential(self, qi, qj):
        length = math.sqrt(np.sum(point_vector(qi, self.si, qj, self.sj) ** 2))
        return 0.5 * self.stiffness * (length - self.free_length) ** 2

    def dissipated_power(self, qi, qj, qdi, qdj, t):
        _, velocity = self.state(qi, qj, qdi, qdj)
        return self.damping * velocity**2

    def applied_power(self, qi, qj, qdi, qdj, t):
        length, velocity = self.state(qi, qj, qdi, qdj)
        return -self.actuator(t, length, velocity) * velocity

    def powers(self, qi, qj, qdi, qdj, t):
        length, velocity = self.state(qi, qj, qdi, qdj)
        return self.damping * velocity**2, -self.actuator(t, length, velocity) * velocity

    def measures(self, qi, qj, qdi, qdj, t):
        """The tension f = k (l - l0) + c l' + f_a, positive when it pulls the points together (eq. 5.14)."""
        return {"force": self.tension(t, *self.state(qi, qj, qdi, qdj))}


@dataclass
class RSDA(ForceElement):
    """Rotational spring-damper-actuator between bodies i and j, theta = phi_j - phi_i.

    Torque f = k (theta - theta0) + c theta' + f_a(t, theta, theta') (eq. 5.15); potential
    1/2 k (theta - theta0)^2, dissipated power c theta'^2, actuator power -f_a theta'.
    """

    stiffness: float = 0.0
    damping: float = 0.0
    free_angle: float = 0.0
    actuator: Actuator = no_actuator

    def torque(self, t: float, angle: float, velocity: float) -> float:
        """f = k (theta - theta0) + c theta' + f_a (eq. 5.15)."""
        ### BEGIN SOLUTION hw2
        spring = self.stiffness * (angle - self.free_angle)
        return spring + self.damping * velocity + self.actuator(t, angle, velocity)
        ### END SOLUTION

    @property
    def is_conservative(self) -> bool:
        return self.damping == 0.0 and self.actuator is no_actuator

    def forces(self, qi, qj, qdi, qdj, t):
        angle, velocity = qj[2] - qi[2], qdj[2] - qdi[2]
        return rsda_forces(self.torque(t, angle, velocity))

    def potential(self, qi, qj):
        return 0.5 * self.stiffness * (qj[2] - qi[2] - self.free_angle) ** 2

    def dissipated_power(self, qi, qj, qdi, qdj, t):
        return self.damping * (qdj[2] - qdi[2]) ** 2

    def applied_power(self, qi, qj, qdi, qdj, t):
        angle, velocity = qj[2] - qi[2], qdj[2] - qdi[2]
        return -self.actuator(t, angle, velocity) * velocity

    def measures(self, qi, qj, qdi, qdj, t):
        """The torque f = k (theta - theta0) + c theta' + f_a, positive when it turns body j back (eq. 5.15)."""
        return {"torque": self.torque(t, qj[2] - qi[2], qdj[2] - qdi[2])}


__all__ = [
    "RSDA",
    "TSDA",
    "Actuator",
    "ForceElement",
    "PointForce",
    "TimeActuator",
    "Torque",
    "gravity_force",
    "no_actuator",
    "point_force",
    "rsda_forces",
    "tsda_forces",
    "tsda_length",
]
