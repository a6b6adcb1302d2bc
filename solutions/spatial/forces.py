"""Spatial force elements and their generalized forces Q (course notes, ch. 10).

A force F (global) at a point P of body i, at body-frame position s_i', and a torque n (global) on the
body do the virtual work F^T (delta r_i + delta(A_i s_i')) + n^T delta pi, with the virtual rotation
delta pi = 2 G delta p (global) = A_i delta pi', delta pi' = 2 L delta p (body frame). Since
delta(A s') = delta pi x (A s'), the generalized force on q_i = (r_i, p_i) is (eq. 10.10)

    Q_i = [ F ;  2 L_i^T (s_i'~ F' + n') ],     F' = A_i^T F,  n' = A_i^T n            (7,)

the moment about the centre of mass in the body frame, turned into p components by 2 L^T (for a
global torque alone, 2 L^T A^T n = 2 G^T n). Q_i has no component along p_i (L p = 0), so it does not
load the normalization constraint. Every element below is built from this rule:

- gravity                 F = m_i g at the centre of mass, no moment                         (eq. 10.11)
- point force / torque    a given F(t) or n(t), global or fixed in the body                 (eq. 10.10)
- TSDA                    spring-damper-actuator along the line P_i P_j                       (eq. 10.12)
- RSDA                    rotational spring-damper-actuator about a revolute axis           (eq. 10.13)

Elements have the interface of the planar ones (``planar.forces``): ``forces(qi, qj, qdi, qdj, t)``
gives (Q_i, Q_j), two (7,) blocks, plus ``potential``, ``dissipated_power`` and ``applied_power``.
Spring-damper-actuators use the course's sign: the force f is positive in tension (it pulls the
points together, or turns body j back towards body i).

``SpatialForceModel`` adds up Q for the dynamics layer like the planar ``ForceModel``; its
``generalized_forces`` also includes the quadratic-velocity term Q_v of the mass matrix (``mass``),
the right side of M q'' + Psi_q^T lambda = Q + Q_v.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..functions import function_from_spec
from ..io.model import Model, ModelError
from ..planar.forces import (  # shared with the planar force elements
    Actuator,
    ForceElement,
    TimeActuator,
    no_actuator,
)
from ..rotations import g_matrix, l_matrix, rotation_matrix, skew
from .bodies import body_vector, point_vector, point_vector_dot
from .build import FileFrames, joint_axes, joint_frames
from .mass import quadratic_velocity_vector

ZERO7 = np.zeros(7)
GROUND = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])


# -- the generalized forces of the course ----------------------------------------------------------
def gravity_force(mass: float, gravity: np.ndarray) -> np.ndarray:
    """Q_i = [m_i g ; 0]: the weight acts at the centre of mass (eq. 10.11)."""
    ### BEGIN SOLUTION hw3
    out = np.zeros(7)
    out[:3] = mass * np.asarray(gravity)
    return out
    ### END SOLUTION


def point_force(q: np.ndarray, s: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Q_i = [F ; 2 L^T s'~ A^T F]: a global force F at body point s' (eq. 10.10)."""
    ### BEGIN SOLUTION hw3
    p = q[3:7]
    moment = skew(s) @ (rotation_matrix(p).T @ force)
    return np.concatenate([force, 2.0 * l_matrix(p).T @ moment])
    ### END SOLUTION


def torque_force(q: np.ndarray, torque: np.ndarray, frame: str = "global") -> np.ndarray:
    """Q_i = [0 ; 2 G^T n] for a global torque n, [0 ; 2 L^T n'] for a body-frame torque n' (eq. 10.10)."""
    ### BEGIN SOLUTION hw3
    p = q[3:7]
    matrix = g_matrix(p) if frame == "global" else l_matrix(p)
    return np.concatenate([np.zeros(3), 2.0 * matrix.T @ torque])
    ### END SOLUTION


def angular_velocity(q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """omega = 2 G(p) p' (global)."""
    return 2.0 * g_matrix(q[3:7]) @ qd[3:7]


# -- the elements ---------------------------------------------------------------------------------
@dataclass
class PointForce(ForceElement):
    """A force F(t) at body point s' of body i; ``body_fixed`` turns it with the body (F = A_i F')."""

    point: np.ndarray = field(default_factory=lambda: np.zeros(3))
    components: tuple = ()
    body_fixed: bool = False

    def force(self, qi: np.ndarray, t: float) -> np.ndarray:
        """The global force vector F at time t."""
        force = np.array([c.value(t) for c in self.components])
        return body_vector(qi, force) if self.body_fixed else force

    def forces(self, qi, qj, qdi, qdj, t):
        return point_force(qi, self.point, self.force(qi, t)), ZERO7

    def applied_power(self, qi, qj, qdi, qdj, t):
        return float(qdi @ self.forces(qi, qj, qdi, qdj, t)[0])  # = F^T v_P

    def measures(self, qi, qj, qdi, qdj, t):
        """The global force: 'Fx', 'Fy', 'Fz'."""
        return dict(zip(("Fx", "Fy", "Fz"), map(float, self.force(qi, t)), strict=True))


@dataclass
class Torque(ForceElement):
    """A torque n(t) on body i, global or (``body_fixed``) in the body frame."""

    components: tuple = ()
    body_fixed: bool = False

    def forces(self, qi, qj, qdi, qdj, t):
        torque = np.array([c.value(t) for c in self.components])
        return torque_force(qi, torque, "body" if self.body_fixed else "global"), ZERO7

    def applied_power(self, qi, qj, qdi, qdj, t):
        return float(qdi @ self.forces(qi, qj, qdi, qdj, t)[0])  # = n^T omega

    def measures(self, qi, qj, qdi, qdj, t):
        """The global torque: 'Mx', 'My', 'Mz'."""
        torque = np.array([c.value(t) for c in self.components])
        return dict(
            zip(("Mx", "My", "Mz"), map(float, body_vector(qi, torque) if self.body_fixed else torque), strict=True)
        )


@dataclass
class TSDA(ForceElement):
    """Translational spring-damper-actuator between P_i (s_i' on body i) and P_j (s_j' on body j) (eq. 10.12).

    With d = d_ij, l = |d|, u = d / l, l' = u^T d': tension f = k (l - l0) + c l' + f_a(t, l, l'); the
    force f u acts on P_i and -f u on P_j. Potential 1/2 k (l - l0)^2, dissipated power c l'^2,
    actuator power -f_a l'.
    """

    si: np.ndarray = None
    sj: np.ndarray = None
    stiffness: float = 0.0
    damping: float = 0.0
    free_length: float = 0.0
    actuator: Actuator = no_actuator

    @property
    def is_conservative(self) -> bool:
        return self.damping == 0.0 and self.actuator is no_actuator

    def state(self, qi, qj, qdi, qdj) -> tuple[float, float, np.ndarray]:
        """(l, l', u)."""
        d = point_vector(qi, self.si, qj, self.sj)
        length = math.sqrt(d @ d)
        if length < 1e-12:
            raise ValueError(f"spring-damper {self.name}: its two points coincide (length 0): no line of action")
        u = d / length
        return length, float(u @ point_vector_dot(qi, self.si, qj, self.sj, qdi, qdj)), u

    def tension(self, t: float, length: float, velocity: float) -> float:
        """f = k (l - l0) + c l' + f_a (eq. 10.12)."""
        return (
            self.stiffness * (length - self.free_length) + self.damping * velocity + self.actuator(t, length, velocity)
        )

    def forces(self, qi, qj, qdi, qdj, t):
        ### BEGIN SOLUTION hw3
        length, velocity, u = self.state(qi, qj, qdi, qdj)
        f = self.tension(t, length, velocity)
        return point_force(qi, self.si, f * u), point_force(qj, self.sj, -f * u)
        ### END SOLUTION

    def potential(self, qi, qj):
        length = math.sqrt(np.sum(point_vector(qi, self.si, qj, self.sj) ** 2))
        return 0.5 * self.stiffness * (length - self.free_length) ** 2

    def dissipated_power(self, qi, qj, qdi, qdj, t):
        return self.damping * self.state(qi, qj, qdi, qdj)[1] ** 2

    def applied_power(self, qi, qj, qdi, qdj, t):
        length, velocity, _ = self.state(qi, qj, qdi, qdj)
        return -self.actuator(t, length, velocity) * velocity

    def measures(self, qi, qj, qdi, qdj, t):
        """The tension f = k (l - l0) + c l' + f_a, positive when it pulls the points together (eq. 10.12)."""
        length, velocity, _ = self.state(qi, qj, qdi, qdj)
        return {"force": self.tension(t, length, velocity)}


@dataclass
class RSDA(ForceElement):
    """Rotational spring-damper-actuator about the axis h of a revolute (or cylindrical) joint (eq. 10.13).

    With the joint frame axes f_i, g_i, h_i of body i and f_j of body j, the rotation of j relative
    to i is theta = atan2(g_i^T f_j, f_i^T f_j) and theta' = h_i^T (omega_j - omega_i). The torque
    f = k (theta - theta0) + c theta' + f_a acts as f h_i on body i and -f h_i on body j. theta is
    taken in (theta0 - pi, theta0 + pi]: the spring winds less than half a turn either way.
    """

    fi: np.ndarray = None
    gi: np.ndarray = None
    hi: np.ndarray = None
    fj: np.ndarray = None
    stiffness: float = 0.0
    damping: float = 0.0
    free_angle: float = 0.0
    actuator: Actuator = no_actuator

    @property
    def is_conservative(self) -> bool:
        return self.damping == 0.0 and self.actuator is no_actuator

    def angle(self, qi, qj) -> float:
        fj = body_vector(qj, self.fj)
        theta = math.atan2(body_vector(qi, self.gi) @ fj, body_vector(qi, self.fi) @ fj)
        return self.free_angle + math.remainder(theta - self.free_angle, 2.0 * math.pi)

    def rate(self, qi, qj, qdi, qdj) -> float:
        return float(body_vector(qi, self.hi) @ (angular_velocity(qj, qdj) - angular_velocity(qi, qdi)))

    def torque(self, t: float, angle: float, velocity: float) -> float:
        """f = k (theta - theta0) + c theta' + f_a (eq. 10.13)."""
        return self.stiffness * (angle - self.free_angle) + self.damping * velocity + self.actuator(t, angle, velocity)

    def forces(self, qi, qj, qdi, qdj, t):
        ### BEGIN SOLUTION hw3
        f = self.torque(t, self.angle(qi, qj), self.rate(qi, qj, qdi, qdj))
        h = body_vector(qi, self.hi)
        return torque_force(qi, f * h), torque_force(qj, -f * h)
        ### END SOLUTION

    def potential(self, qi, qj):
        return 0.5 * self.stiffness * (self.angle(qi, qj) - self.free_angle) ** 2

    def dissipated_power(self, qi, qj, qdi, qdj, t):
        return self.damping * self.rate(qi, qj, qdi, qdj) ** 2

    def applied_power(self, qi, qj, qdi, qdj, t):
        angle, velocity = self.angle(qi, qj), self.rate(qi, qj, qdi, qdj)
        return -self.actuator(t, angle, velocity) * velocity

    def measures(self, qi, qj, qdi, qdj, t):
        """The torque f = k (theta - theta0) + c theta' + f_a about h_i, positive when it turns body j back
        (eq. 10.13)."""
        return {"torque": self.torque(t, self.angle(qi, qj), self.rate(qi, qj, qdi, qdj))}


# -- the force model of a spatial system ------------------------------------------------------------
UserForce = Callable[[np.ndarray, np.ndarray, float], np.ndarray]


@dataclass
class SpatialForceModel:
    """Q(q, q', t) of a spatial model: constant gravity, force elements, user callables, and the
    quadratic-velocity term Q_v (the same interface as the planar ``ForceModel``)."""

    model: Model
    gravity: np.ndarray
    elements: list[ForceElement] = field(default_factory=list)
    user_forces: list[UserForce] = field(default_factory=list)

    def __post_init__(self):
        self.n_coordinates = 7 * len(self.model.bodies)

    @property
    def is_empty(self) -> bool:
        """Never: Q_v is there whenever a body turns."""
        return False

    @property
    def is_constant(self) -> bool:
        """Never: Q_v depends on q and q'."""
        return False

    @property
    def is_conservative(self) -> bool:
        """True when every force has a potential (Q_v does no work)."""
        return not self.user_forces and all(e.is_conservative for e in self.elements)

    def add(self, force: UserForce) -> SpatialForceModel:
        """Add a user force callable Q_user(q, q', t) -> (n,) array; returns self."""
        self.user_forces.append(force)
        return self

    def _pair(self, element: ForceElement, x: np.ndarray, ground: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xi = ground if element.i < 0 else x[7 * element.i : 7 * element.i + 7]
        xj = ground if element.j < 0 else x[7 * element.j : 7 * element.j + 7]
        return xi, xj

    def _pairs(self, element, q, qd):
        return (*self._pair(element, q, GROUND), *self._pair(element, qd, ZERO7))

    def element_state(self, element: ForceElement, q: np.ndarray, qd: np.ndarray) -> tuple:
        """(q_i, q_j, q_i', q_j') of an element's two bodies (ground's for -1)."""
        return self._pairs(element, q, qd)

    def applied_forces(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        """Q of gravity, the elements and the user forces (eq. 10.14), without Q_v."""
        Q = self.gravity.copy()
        for e in self.elements:
            Qi, Qj = e.forces(*self._pairs(e, q, qd), t)
            if e.i >= 0:
                Q[7 * e.i : 7 * e.i + 7] += Qi
            if e.j >= 0:
                Q[7 * e.j : 7 * e.j + 7] += Qj
        for force in self.user_forces:
            Q += force(q, qd, t)
        return Q

    def generalized_forces(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        """Q + Q_v: the right side of M q'' + Psi_q^T lambda = Q + Q_v (eq. 10.5, 8.14)."""
        return self.applied_forces(q, qd, t) + quadratic_velocity_vector(self.model, q, qd)

    def potential_energy(self, q: np.ndarray) -> float:
        """V(q) = -sum_k m_k g^T r_k + sum of spring potentials."""
        energy = -float(self.gravity @ q)
        for e in self.elements:
            energy += e.potential(*self._pair(e, q, GROUND))
        return energy

    def dissipated_power(self, q: np.ndarray, qd: np.ndarray, t: float) -> float:
        """Power taken out by the dampers (>= 0)."""
        return sum(e.dissipated_power(*self._pairs(e, q, qd), t) for e in self.elements)

    def actuator_power(self, q: np.ndarray, qd: np.ndarray, t: float) -> float:
        """Power put in by actuators, point forces, torques and user forces."""
        power = sum(e.applied_power(*self._pairs(e, q, qd), t) for e in self.elements)
        for force in self.user_forces:
            power += float(qd @ force(q, qd, t))
        return power

    def powers(self, q: np.ndarray, qd: np.ndarray, t: float) -> tuple[float, float]:
        """(dissipated_power, actuator_power) in one pass over the elements."""
        dissipated = applied = 0.0
        for e in self.elements:
            d, a = e.powers(*self._pairs(e, q, qd), t)
            dissipated, applied = dissipated + d, applied + a
        for force in self.user_forces:
            applied += float(qd @ force(q, qd, t))
        return dissipated, applied


# -- from the model file ------------------------------------------------------------------------------
def _components(value, where: str, model: Model, what: str) -> tuple:
    if not isinstance(value, list) or len(value) != 3:
        raise ModelError(
            f"{model.source}: {where}.value: a spatial {what} takes three components, e.g. [0.0, 0.0, 1.0]"
        )
    return tuple(function_from_spec(v) for v in value)


def spring_damper_element(spec: dict, where: str, model: Model) -> ForceElement:
    """A TSDA or RSDA of the file. A missing free length or free angle is the file configuration's.

    An RSDA acts about the axis of the revolute or cylindrical joint named by ``joint``, or about
    ``axis`` between ``body1`` and ``body2``.
    """
    frames = FileFrames(model)
    name, frame = spec["name"], spec.get("frame", "global")
    i, j = model.body_index(spec["body1"]), model.body_index(spec["body2"])
    actuator = TimeActuator(function_from_spec(spec["actuator"])) if "actuator" in spec else no_actuator
    stiffness = float(spec.get("spring_coefficient", 0.0))
    damping = float(spec.get("damping_coefficient", 0.0))
    if spec["type"] == "RSDA":
        if "joint" in spec:
            joints = {j["name"]: j for j in model.joints}
            if spec["joint"] not in joints or joints[spec["joint"]]["type"] not in ("revolute", "cylindrical"):
                raise ModelError(f"{model.source}: {where}.joint: name a revolute or cylindrical joint of the model")
            joint = joints[spec["joint"]]
            if {joint["body1"], joint["body2"]} != {spec["body1"], spec["body2"]}:
                raise ModelError(f"{model.source}: {where}.joint: '{spec['joint']}' does not connect body1 and body2")
            if joint["body1"] != spec["body1"]:
                i, j = j, i
            frame_i, frame_j = joint_frames(joint, where, model, frames)
        elif "axis" in spec:
            f, g, h = joint_axes(frames.global_axis(i, spec["axis"], frame))
            origin = frames.origin(j)
            frame_i, frame_j = frames.joint_frame(i, origin, f, g, h), frames.joint_frame(j, origin, f, g, h)
        else:
            raise ModelError(
                f"{model.source}: {where}: a spatial RSDA needs 'joint' (a revolute joint) or 'axis' (its axis)"
            )
        return RSDA(
            name, i, j, fi=frame_i.f, gi=frame_i.g, hi=frame_i.h, fj=frame_j.f, stiffness=stiffness,
            damping=damping, free_angle=float(spec.get("free_angle", 0.0)), actuator=actuator,
        )  # fmt: skip
    si = frames.local_point(i, frames.global_point(i, spec["point1"], frame))
    sj = frames.local_point(j, frames.global_point(j, spec["point2"], frame))
    tsda = TSDA(name, i, j, si=si, sj=sj, stiffness=stiffness, damping=damping, actuator=actuator)
    length = float(np.linalg.norm(point_vector(frames.q(i), si, frames.q(j), sj)))
    if length < 1e-12:
        raise ModelError(f"{model.source}: {where}.point2: coincides with point1; a TSDA needs two distinct points")
    tsda.free_length = float(spec.get("free_length", length))
    return tsda


def load_element(spec: dict, where: str, model: Model) -> ForceElement:
    """A point force or a torque of the file (``value``: three constants or functions of time)."""
    frames = FileFrames(model)
    name, frame = spec["name"], spec.get("frame", "global")
    i = model.body_index(spec["body"])
    if i < 0:
        raise ModelError(f"{model.source}: {where}.body: a load on ground does nothing; name a moving body")
    if spec["type"] == "torque":
        return Torque(
            name, i, -1, components=_components(spec["value"], where, model, "torque"), body_fixed=frame == "body"
        )
    default = [0.0, 0.0, 0.0] if frame == "body" else frames.origin(i)
    point = frames.local_point(i, frames.global_point(i, spec.get("point", default), frame))
    components = _components(spec["value"], where, model, "force")
    return PointForce(name, i, -1, point=point, components=components, body_fixed=frame == "body")


def gravity_vector(model: Model) -> np.ndarray:
    """[m_k g ; 0] for every body k, stacked (eq. 10.11)."""
    return np.concatenate([gravity_force(body.mass, model.gravity) for body in model.bodies])


def build_forces(model: Model, user_forces: list[UserForce] | None = None) -> SpatialForceModel:
    """The force model of a spatial model: gravity, spring-dampers, loads, user forces (and Q_v)."""
    elements = [
        spring_damper_element(s, f"model.spring_dampers[{k}]", model) for k, s in enumerate(model.spring_dampers)
    ]
    elements += [load_element(s, f"model.forces[{k}]", model) for k, s in enumerate(model.forces)]
    return SpatialForceModel(model, gravity_vector(model), elements, list(user_forces or []))


__all__ = [
    "RSDA",
    "TSDA",
    "ForceElement",
    "PointForce",
    "SpatialForceModel",
    "TimeActuator",
    "Torque",
    "build_forces",
    "gravity_force",
    "gravity_vector",
    "no_actuator",
    "point_force",
    "torque_force",
]
