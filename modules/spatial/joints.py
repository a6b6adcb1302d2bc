# Generated from solutions/spatial/joints.py by `make modules` (every homework stubbed): do not edit by hand.
"""Spatial joints (kinematic pairs) as constraint equations Psi(q_i, q_j, t) = 0.

Every joint is built from four **basic constraints** (Haug 1989, the basic constraints of spatial
kinematics; course notes, sec. 9.2), between vectors a_i = A_i a_i', a_j = A_j a_j' fixed in bodies
i and j and the vector d_ij = r_j + A_j s_j' - r_i - A_i s_i' between body points P_i and P_j:

    dot-1       a_i^T a_j = 0           the two vectors stay perpendicular             (eq. 9.10)
    dot-2       a_i^T d_ij = 0          P_j stays in the plane through P_i normal to a_i   (eq. 9.11)
    spherical   r_i + A_i s_i' - r_j - A_j s_j' = 0   (= -d_ij, 3 equations)           (eq. 9.12)
    distance    (d_ij^T d_ij - L^2) / 2 = 0                                             (eq. 9.13)

A joint's definition frame (origin P, unit axes f, g, h, h along the joint axis) is fixed in both
bodies and the two copies coincide in the model file's configuration; then (eq. 9.14-9.19)

    spherical    spherical(P)                                                       3 equations
    universal    spherical(P), dot-1(h_i, h_j)  (h_i, h_j the two cross arms)      4
    revolute     spherical(P), dot-1(f_i, h_j), dot-1(g_i, h_j)                    5
    cylindrical  dot-1(f_i, h_j), dot-1(g_i, h_j), dot-2(f_i, d), dot-2(g_i, d)    4
    prismatic    cylindrical, dot-1(f_i, g_j)                                      5
    rigid        spherical(P), dot-1(f_i, g_j), dot-1(g_i, h_j), dot-1(h_i, f_j)   6

Drivers add time: a rotation theta(t) about the joint axis h (revolute, cylindrical) or a translation
s(t) along it (prismatic, cylindrical), see ``RotationDriver`` and ``TranslationDriver``. Every body
also has the Euler-parameter normalization constraint p^T p - 1 = 0 (``EulerNormalization``).

Each element gives, like the planar ones,

- ``constraints``  Psi                        (m,)
- ``jacobian``     (Psi_qi, Psi_qj)           two (m, 7) blocks
- ``psi_t``        dPsi/dt                    (m,)    zero for a joint, non-zero for a driver
- ``gamma``        right side of Psi_q q'' = gamma, gamma = -(Psi_q q')_q q' - 2 Psi_qt q' - Psi_tt

Vectors and points (primed in the notes) are in the body frames. In every gamma below,
a_i' = B(p_i, a_i') p_i' is the time derivative of a_i and (.)_v the velocity part of a second
derivative, e.g. (a_i'')_v = B(p_i', a_i') p_i' (see ``bodies``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..elements import ConstraintElement
from ..functions import Constant, ScalarFunction
from .bodies import (
    b_matrix,
    body_vector,
    body_vector_dot,
    body_vector_quadratic,
    point_vector,
    point_vector_dot,
    point_vector_quadratic,
)


def _rows(r_part: np.ndarray | None, p_part: np.ndarray) -> np.ndarray:
    """A (1, 7) or (3, 7) Jacobian block from its r columns (None: zero) and its p columns."""
    p_part = np.atleast_2d(p_part)
    out = np.zeros((p_part.shape[0], 7))
    if r_part is not None:
        out[:, :3] = r_part
    out[:, 3:] = p_part
    return out


# -- the basic constraints ------------------------------------------------------------------------
@dataclass(frozen=True)
class Dot1:
    """dot-1: a_i^T a_j = 0 (eq. 9.10).

    Psi_qi = [0, a_j^T B(p_i, a_i')],  Psi_qj = [0, a_i^T B(p_j, a_j')]
    gamma = -a_j^T B(p_i', a_i') p_i' - a_i^T B(p_j', a_j') p_j' - 2 a_i'^T a_j'
    """

    ai: np.ndarray
    aj: np.ndarray
    tag: str = "dot1"

    @property
    def labels(self) -> tuple[str, ...]:
        return (self.tag,)

    def value(self, qi, qj) -> np.ndarray:
        raise NotImplementedError('Dot1.value: value() (dot-1: a_i^T a_j = 0), see eq. 9.10')

    def jacobian(self, qi, qj) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError('Dot1.jacobian: the Jacobian Psi_q (dot-1: a_i^T a_j = 0), see eq. 9.10')

    def gamma(self, qi, qj, qdi, qdj) -> np.ndarray:
        raise NotImplementedError("Dot1.gamma: gamma, the right side of Psi_q q'' = gamma (dot-1: a_i^T a_j = 0), see eq. 9.10")


@dataclass(frozen=True)
class Dot2:
    """dot-2: a_i^T d_ij = 0 (eq. 9.11).

    Psi_qi = [-a_i^T, d^T B(p_i, a_i') - a_i^T B(p_i, s_i')],  Psi_qj = [a_i^T, a_i^T B(p_j, s_j')]
    gamma = -d^T B(p_i', a_i') p_i' - 2 a_i'^T d' - a_i^T (d'')_v
    """

    ai: np.ndarray
    si: np.ndarray
    sj: np.ndarray
    tag: str = "dot2"

    @property
    def labels(self) -> tuple[str, ...]:
        return (self.tag,)

    def value(self, qi, qj) -> np.ndarray:
        raise NotImplementedError('Dot2.value: value() (dot-2: a_i^T d_ij = 0), see eq. 9.11')

    def jacobian(self, qi, qj) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError('Dot2.jacobian: the Jacobian Psi_q (dot-2: a_i^T d_ij = 0), see eq. 9.11')

    def gamma(self, qi, qj, qdi, qdj) -> np.ndarray:
        raise NotImplementedError("Dot2.gamma: gamma, the right side of Psi_q q'' = gamma (dot-2: a_i^T d_ij = 0), see eq. 9.11")


@dataclass(frozen=True)
class Spherical:
    """spherical: r_i + A_i s_i' - r_j - A_j s_j' = -d_ij = 0, three equations (eq. 9.12).

    Psi_qi = [I, B(p_i, s_i')],  Psi_qj = [-I, -B(p_j, s_j')],
    gamma = (d_ij'')_v = B(p_j', s_j') p_j' - B(p_i', s_i') p_i'
    """

    si: np.ndarray
    sj: np.ndarray
    tag: str = ""

    @property
    def labels(self) -> tuple[str, ...]:
        return ("x", "y", "z")

    def value(self, qi, qj) -> np.ndarray:
        raise NotImplementedError("Spherical.value: value() (spherical: r_i + A_i s_i' - r_j - A_j s_j' = -d_ij = 0, three equations), see eq. 9.12")

    def jacobian(self, qi, qj) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError("Spherical.jacobian: the Jacobian Psi_q (spherical: r_i + A_i s_i' - r_j - A_j s_j' = -d_ij = 0, three equations), see eq. 9.12")

    def gamma(self, qi, qj, qdi, qdj) -> np.ndarray:
        raise NotImplementedError("Spherical.gamma: gamma, the right side of Psi_q q'' = gamma (spherical: r_i + A_i s_i' - r_j - A_j s_j' = -d_ij = 0, three equations), see eq. 9.12")


def distance_terms(qi, si, qj, sj, qdi=None, qdj=None):
    """The distance constraint's building blocks for P_i, P_j (eq. 9.13):

    (d^T d / 2, Psi_qi, Psi_qj, gamma_v) with Psi_qi = [-d^T, -d^T B(p_i, s_i')],
    Psi_qj = [d^T, d^T B(p_j, s_j')] and the velocity part of -(d^T d / 2)'', gamma_v = -d'^T d' - d^T (d'')_v.
    Pass ``qdi = qdj = None`` to skip gamma_v.
    """
    raise NotImplementedError("distance_terms: The distance constraint's building blocks for P_i, P_j, see eq. 9.13")


# -- elements: joints, drivers, normalization -----------------------------------------------------
class SpatialElement(ConstraintElement):
    """A spatial constraint element (``elements.ConstraintElement``): q_i = (r_i, p_i), Psi_q blocks (m, 7)."""


@dataclass
class Joint(SpatialElement):
    """A joint: its basic constraints stacked (eq. 9.14-9.19). ``kind`` names the pair (e.g. 'revolute');
    ``frames`` are its definition frame as fixed in body i and in body j (for reactions in the joint frame)."""

    kind: str = ""
    parts: tuple = ()
    frames: tuple = ()

    def __post_init__(self):
        self.labels = tuple(f"{self.name}.{label}" for part in self.parts for label in part.labels)

    def constraints(self, qi, qj, t):
        return np.concatenate([part.value(qi, qj) for part in self.parts])

    def jacobian(self, qi, qj, t):
        blocks = [part.jacobian(qi, qj) for part in self.parts]
        return np.vstack([b[0] for b in blocks]), np.vstack([b[1] for b in blocks])

    def gamma(self, qi, qj, qdi, qdj, t):
        return np.concatenate([part.gamma(qi, qj, qdi, qdj) for part in self.parts])


@dataclass(frozen=True)
class JointFrame:
    """A joint definition frame in one body: origin s' and unit axes f', g', h' (h' along the joint axis)."""

    origin: np.ndarray
    f: np.ndarray
    g: np.ndarray
    h: np.ndarray


def spherical_joint(name: str, i: int, j: int, fi: JointFrame, fj: JointFrame) -> Joint:
    """Ball joint: the origins coincide (3 equations, eq. 9.14)."""
    return Joint(name, i, j, kind="spherical", parts=(Spherical(fi.origin, fj.origin),), frames=(fi, fj))


def universal_joint(name: str, i: int, j: int, fi: JointFrame, fj: JointFrame) -> Joint:
    """Hooke joint: origins coincide and the cross arms h_i (in i) and h_j (in j) stay perpendicular (eq. 9.15)."""
    parts = (Spherical(fi.origin, fj.origin), Dot1(fi.h, fj.h, "hi.hj"))
    return Joint(name, i, j, kind="universal", parts=parts, frames=(fi, fj))


def revolute_joint(name: str, i: int, j: int, fi: JointFrame, fj: JointFrame) -> Joint:
    """Pin: origins coincide and h_j stays normal to f_i and g_i, i.e. along h_i (5 equations, eq. 9.16)."""
    parts = (Spherical(fi.origin, fj.origin), Dot1(fi.f, fj.h, "fi.hj"), Dot1(fi.g, fj.h, "gi.hj"))
    return Joint(name, i, j, kind="revolute", parts=parts, frames=(fi, fj))


def _axis_parts(fi: JointFrame, fj: JointFrame) -> tuple:
    """Parallel axes through P_i and P_j: dot-1(f_i, h_j), dot-1(g_i, h_j), dot-2(f_i, d), dot-2(g_i, d)."""
    return (
        Dot1(fi.f, fj.h, "fi.hj"),
        Dot1(fi.g, fj.h, "gi.hj"),
        Dot2(fi.f, fi.origin, fj.origin, "fi.d"),
        Dot2(fi.g, fi.origin, fj.origin, "gi.d"),
    )


def cylindrical_joint(name: str, i: int, j: int, fi: JointFrame, fj: JointFrame) -> Joint:
    """Cylindrical: the axes stay on one line; slide along and turn about it (4 equations, eq. 9.17)."""
    return Joint(name, i, j, kind="cylindrical", parts=_axis_parts(fi, fj), frames=(fi, fj))


def prismatic_joint(name: str, i: int, j: int, fi: JointFrame, fj: JointFrame) -> Joint:
    """Translational: cylindrical without the turn, dot-1(f_i, g_j) (5 equations, eq. 9.18)."""
    parts = (*_axis_parts(fi, fj), Dot1(fi.f, fj.g, "fi.gj"))
    return Joint(name, i, j, kind="prismatic", parts=parts, frames=(fi, fj))


def rigid_joint(name: str, i: int, j: int, fi: JointFrame, fj: JointFrame) -> Joint:
    """Weld: origins coincide and the frames keep their relative orientation (6 equations, eq. 9.19)."""
    parts = (
        Spherical(fi.origin, fj.origin),
        Dot1(fi.f, fj.g, "fi.gj"),
        Dot1(fi.g, fj.h, "gi.hj"),
        Dot1(fi.h, fj.f, "hi.fj"),
    )
    return Joint(name, i, j, kind="rigid", parts=parts, frames=(fi, fj))


JOINTS = {
    "spherical": spherical_joint,
    "universal": universal_joint,
    "revolute": revolute_joint,
    "cylindrical": cylindrical_joint,
    "prismatic": prismatic_joint,
    "rigid": rigid_joint,
}
"""The spatial joint types of a model file and the functions that build them."""


@dataclass
class RotationDriver(SpatialElement):
    """Rotation theta(t) = theta0 + f(t) of frame j about the common axis h of a revolute or cylindrical
    joint, measured from f_i towards g_i (eq. 9.21).

    f_j must lie along c = cos(theta) f_i + sin(theta) g_i, so it is normal to
    n = A_i n', n' = -sin(theta) f_i' + cos(theta) g_i' (a dot-1 with a turning vector):

        Psi = n^T f_j = sin(theta_actual - theta(t)),        dn'/dtheta = -c',  dc'/dtheta = n'
        Psi_qi = [0, f_j^T B(p_i, n')],  Psi_qj = [0, n^T B(p_j, f_j')],  Psi_t = -theta' c^T f_j
        gamma = -f_j^T [B(p_i', n') p_i' - 2 theta' B(p_i, c') p_i' - theta'' c - theta'^2 n]
                - 2 n'_t^T f_j' - n^T B(p_j', f_j') p_j',      n'_t = B(p_i, n') p_i' - theta' c

    (n'_t is the total time derivative of n). Psi = 0 also at theta_actual = theta + pi; Newton-Raphson
    from the previous step never jumps there.
    """

    fi: np.ndarray = None
    gi: np.ndarray = None
    fj: np.ndarray = None
    angle0: float = 0.0
    function: ScalarFunction = field(default_factory=lambda: Constant(0.0))

    def __post_init__(self):
        self.labels = (f"{self.name}.angle",)

    def _directions(self, t):
        theta = self.angle0 + self.function.value(t)
        c, s = math.cos(theta), math.sin(theta)
        return -s * self.fi + c * self.gi, c * self.fi + s * self.gi  # n', c'

    def constraints(self, qi, qj, t):
        raise NotImplementedError('RotationDriver.constraints: the constraint equations Psi (Rotation theta(t) = theta0 + f(t) of frame j about the common axis h of a revolute or cylindrical joint, measured from f_i towards g_i), see eq. 9.21')

    def jacobian(self, qi, qj, t):
        raise NotImplementedError('RotationDriver.jacobian: the Jacobian Psi_q (Rotation theta(t) = theta0 + f(t) of frame j about the common axis h of a revolute or cylindrical joint, measured from f_i towards g_i), see eq. 9.21')

    def psi_t(self, qi, qj, t):
        raise NotImplementedError('RotationDriver.psi_t: Psi_t, the partial time derivative of Psi (Rotation theta(t) = theta0 + f(t) of frame j about the common axis h of a revolute or cylindrical joint, measured from f_i towards g_i), see eq. 9.21')

    def gamma(self, qi, qj, qdi, qdj, t):
        raise NotImplementedError("RotationDriver.gamma: gamma, the right side of Psi_q q'' = gamma (Rotation theta(t) = theta0 + f(t) of frame j about the common axis h of a revolute or cylindrical joint, measured from f_i towards g_i), see eq. 9.21")


@dataclass
class TranslationDriver(SpatialElement):
    """Translation along the axis h_i of a prismatic or cylindrical joint: h_i^T d_ij - s0 - f(t) = 0,
    a dot-2 with a time function (eq. 9.22): Psi_t = -f', gamma = gamma(dot-2) + f''."""

    axis: np.ndarray = None
    si: np.ndarray = None
    sj: np.ndarray = None
    offset: float = 0.0
    function: ScalarFunction = field(default_factory=lambda: Constant(0.0))

    def __post_init__(self):
        self.labels = (f"{self.name}.s",)
        self._dot2 = Dot2(self.axis, self.si, self.sj)

    def constraints(self, qi, qj, t):
        return self._dot2.value(qi, qj) - self.offset - self.function.value(t)

    def jacobian(self, qi, qj, t):
        return self._dot2.jacobian(qi, qj)

    def psi_t(self, qi, qj, t):
        return np.array([-self.function.first(t)])

    def gamma(self, qi, qj, qdi, qdj, t):
        return self._dot2.gamma(qi, qj, qdi, qdj) + self.function.second(t)


@dataclass
class DistanceDriver(SpatialElement):
    """Distance between P_i and P_j equals L(t): (d^T d - L^2) / 2 = 0 (eq. 9.13).

    Psi_t = -L L', gamma = -d'^T d' - d^T (d'')_v + L'^2 + L L''.
    """

    si: np.ndarray = None
    sj: np.ndarray = None
    length: ScalarFunction = None

    def __post_init__(self):
        self.labels = (f"{self.name}.length",)

    def constraints(self, qi, qj, t):
        half_square, _, _, _ = distance_terms(qi, self.si, qj, self.sj)
        return np.array([half_square - 0.5 * self.length.value(t) ** 2])

    def jacobian(self, qi, qj, t):
        _, row_i, row_j, _ = distance_terms(qi, self.si, qj, self.sj)
        return row_i, row_j

    def psi_t(self, qi, qj, t):
        return np.array([-self.length.value(t) * self.length.first(t)])

    def gamma(self, qi, qj, qdi, qdj, t):
        _, _, _, gamma = distance_terms(qi, self.si, qj, self.sj, qdi, qdj)
        L, Ld, Ldd = self.length.value(t), self.length.first(t), self.length.second(t)
        return np.array([gamma + Ld * Ld + L * Ldd])


@dataclass
class CoordinateDriver(SpatialElement):
    """Driver of a position coordinate of body j (x, y or z): r_j[k] - f(t) = 0; body i is ground."""

    index: int = 0
    function: ScalarFunction = None

    def __post_init__(self):
        self.labels = (f"{self.name}.{'xyz'[self.index]}",)
        self._row = np.eye(7)[self.index][None, :]

    def constraints(self, qi, qj, t):
        return np.array([qj[self.index] - self.function.value(t)])

    def jacobian(self, qi, qj, t):
        return np.zeros((1, 7)), self._row

    def psi_t(self, qi, qj, t):
        return np.array([-self.function.first(t)])

    def gamma(self, qi, qj, qdi, qdj, t):
        return np.array([self.function.second(t)])


@dataclass
class EulerNormalization(SpatialElement):
    """p_j^T p_j - 1 = 0 for body j (body i is ground) (eq. 9.9).

    Psi_qj = [0, 2 p_j^T],  gamma = -2 p_j'^T p_j'.
    """

    def __post_init__(self):
        self.labels = (self.name,)

    def constraints(self, qi, qj, t):
        raise NotImplementedError('EulerNormalization.constraints: the constraint equations Psi (p_j^T p_j - 1 = 0 for body j (body i is ground)), see eq. 9.9')

    def jacobian(self, qi, qj, t):
        raise NotImplementedError('EulerNormalization.jacobian: the Jacobian Psi_q (p_j^T p_j - 1 = 0 for body j (body i is ground)), see eq. 9.9')

    def gamma(self, qi, qj, qdi, qdj, t):
        raise NotImplementedError("EulerNormalization.gamma: gamma, the right side of Psi_q q'' = gamma (p_j^T p_j - 1 = 0 for body j (body i is ground)), see eq. 9.9")


__all__ = [
    "JOINTS",
    "CoordinateDriver",
    "DistanceDriver",
    "Dot1",
    "Dot2",
    "EulerNormalization",
    "Joint",
    "JointFrame",
    "RotationDriver",
    "SpatialElement",
    "Spherical",
    "TranslationDriver",
    "distance_terms",
]
