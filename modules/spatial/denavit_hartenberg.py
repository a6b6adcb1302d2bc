# Generated from solutions/spatial/denavit_hartenberg.py by `make modules` (every homework stubbed): do not edit by hand.
"""Denavit-Hartenberg parameters and dual numbers: the two classical notations of spatial linkages (course notes,
sec. 8.7).

**Denavit-Hartenberg (DH) parameters** (Denavit and Hartenberg 1955). Each joint axis of a chain or a loop is the
z axis of a frame; the x axis of the next frame lies on the common normal of two successive joint axes. Four
numbers then carry frame i-1 to frame i: a turn theta and a slide d along z_{i-1}, a slide a (the link's length)
and a turn alpha (its twist) along x_i. The homogeneous transform is (eq. 8.22)

    T_i = Rot_z(theta_i) Trans_z(d_i) Trans_x(a_i) Rot_x(alpha_i)

and a closed loop of n joints closes when T_1 T_2 ... T_n = I (eq. 8.23): a revolute joint's variable is its
theta, a prismatic joint's its d; the other three are the links' constant dimensions.

**Dual numbers** a + eps a0 with eps^2 = 0 (Clifford; Study) carry a line's direction and its moment, an angle and
a distance, in one number (eq. 8.24-8.26). A function of one is f(a + eps a0) = f(a) + eps a0 f'(a). A rigid
displacement x -> A x + t is the **dual quaternion** p + eps (1/2) t p (eq. 8.27), the product of two is the
displacement of the two in turn (eq. 8.28), and the screw of Chasles' theorem (eq. 8.20) is its polar form
cos(chi^/2) + s^ sin(chi^/2), with the dual angle chi^ = chi + eps h and the line s^ = u + eps rho x u (eq. 8.29).
A DH transform is two screws about coordinate axes, with the dual angles theta + eps d and alpha + eps a
(eq. 8.30; Yang and Freudenstein 1964); as 3 x 3 dual matrices, the rotation block of T_i with the dual angles put
in for the angles is A + eps t~ A (eq. 8.31: the principle of transference).

Rotation matrices come from ``rotation_matrices`` (written once for the whole package) and Euler parameters from
``rotations.euler_parameters``: nothing here is homework, and it runs in a student package whose rotations are
still stubs.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..rotation_matrices import euler_rotation, quaternion_product_entries
from ..rotations import euler_parameters, skew

IDENTITY = np.eye(4)
"""The homogeneous transform of no displacement."""


# -- Denavit-Hartenberg transforms ---------------------------------------------------------------------------------
def dh_transform(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """T = Rot_z(theta) Trans_z(d) Trans_x(a) Rot_x(alpha) (4 x 4, eq. 8.22): frame i-1 to frame i, the rotation
    block R_z(theta) R_x(alpha) (eq. 8.5) and the origin of frame i at (a cos(theta), a sin(theta), d)."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def homogeneous(A: np.ndarray, t: np.ndarray) -> np.ndarray:
    """[[A, t], [0, 1]]: the displacement x -> A x + t as one 4 x 4 matrix acting on (x, 1)."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = A, t
    return T


def chain(transforms: Iterable[np.ndarray]) -> np.ndarray:
    """T_1 T_2 ... T_n: frame 0 to frame n (eq. 8.23's left-hand side)."""
    product = np.eye(4)
    for T in transforms:
        product = product @ T
    return product


def loop_closure_error(transforms: Iterable[np.ndarray]) -> float:
    """max |T_1 ... T_n - I| (eq. 8.23): zero where the loop closes. Rotation entries are numbers, translation
    entries lengths: the two kinds are mixed here, so use it on a mechanism of size about 1 (or scale it)."""
    return float(np.max(np.abs(chain(transforms) - IDENTITY)))


# -- dual numbers --------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Dual:
    """The dual number real + eps dual, eps^2 = 0 (eq. 8.24). Both parts may be arrays of one shape: a dual vector
    (a line, eq. 8.26) or a dual matrix (eq. 8.31), with ``@`` as the matrix product."""

    real: float | np.ndarray
    dual: float | np.ndarray

    def __add__(self, other: Dual | float) -> Dual:
        other = _dual(other)
        return Dual(self.real + other.real, self.dual + other.dual)

    __radd__ = __add__

    def __neg__(self) -> Dual:
        return Dual(-self.real, -self.dual)

    def __sub__(self, other: Dual | float) -> Dual:
        return self + (-_dual(other))

    def __mul__(self, other: Dual | float) -> Dual:
        """(a + eps a0)(b + eps b0) = a b + eps (a b0 + a0 b): the eps^2 term vanishes (eq. 8.24)."""
        other = _dual(other)
        return Dual(self.real * other.real, self.real * other.dual + self.dual * other.real)

    __rmul__ = __mul__

    def __matmul__(self, other: Dual) -> Dual:
        """The product of dual matrices, (A + eps D)(B + eps E) = A B + eps (A E + D B)."""
        return Dual(self.real @ other.real, self.real @ other.dual + self.dual @ other.real)


def _dual(x: Dual | float) -> Dual:
    return x if isinstance(x, Dual) else Dual(x, 0.0 * np.asarray(x))


def cos(x: Dual) -> Dual:
    """cos(a + eps a0) = cos a - eps a0 sin a (eq. 8.25, f(a) + eps a0 f'(a))."""
    return Dual(np.cos(x.real), -x.dual * np.sin(x.real))


def sin(x: Dual) -> Dual:
    """sin(a + eps a0) = sin a + eps a0 cos a (eq. 8.25)."""
    return Dual(np.sin(x.real), x.dual * np.cos(x.real))


def line(direction: np.ndarray, point: np.ndarray) -> Dual:
    """The line through ``point`` along the unit ``direction`` u as a dual unit vector u + eps rho x u (eq. 8.26):
    its Pluecker coordinates, the direction and its moment about the origin."""
    u = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    return Dual(u, np.cross(point, u))


def dot(x: Dual, y: Dual) -> Dual:
    """The scalar product of two dual vectors. For two lines (eq. 8.26) it is cos(theta + eps d), theta the angle
    between them and d their distance along the common normal: u1.u2 + eps (u1.m2 + m1.u2)."""
    return Dual(float(x.real @ y.real), float(x.real @ y.dual + x.dual @ y.real))


# -- dual quaternions ----------------------------------------------------------------------------------------------
def _product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array(quaternion_product_entries(*map(float, a), *map(float, b)))


def _pure(v: np.ndarray) -> np.ndarray:
    """The vector v as the quaternion (0, v)."""
    return np.array([0.0, *map(float, v)])


@dataclass(frozen=True)
class DualQuaternion:
    """p + eps p0 with a unit quaternion p (the Euler parameters of the rotation, eq. 8.10) and p0 = (1/2) t p for
    the displacement x -> A(p) x + t (eq. 8.27); p^T p0 = 0. The product composes: q1 q2 is q2 followed by q1."""

    real: np.ndarray
    dual: np.ndarray

    def __mul__(self, other: DualQuaternion) -> DualQuaternion:
        """(p + eps p0)(q + eps q0) = p q + eps (p q0 + p0 q) (eq. 8.28)."""
        return DualQuaternion(
            _product(self.real, other.real), _product(self.real, other.dual) + _product(self.dual, other.real)
        )

    @classmethod
    def from_displacement(cls, A: np.ndarray, t: np.ndarray) -> DualQuaternion:
        """The dual quaternion of x -> A x + t: p from A (Shepperd's method, eq. 8.13), p0 = (1/2) t p (eq. 8.27)."""
        p = euler_parameters(A)
        return cls(p, 0.5 * _product(_pure(t), p))

    @classmethod
    def from_screw(cls, axis: np.ndarray, point: np.ndarray, angle: float, slide: float) -> DualQuaternion:
        """cos(chi^/2) + s^ sin(chi^/2) with chi^ = angle + eps slide and s^ the axis line (eq. 8.29): the screw
        motion that turns by ``angle`` about the line through ``point`` along ``axis`` and slides along it."""
        half = Dual(0.5 * angle, 0.5 * slide)
        c, s, axis_line = cos(half), sin(half), line(axis, point)
        vector = s * axis_line  # dual vector: sin(chi^/2) (u + eps rho x u)
        return cls(np.array([c.real, *vector.real]), np.array([c.dual, *vector.dual]))

    def displacement(self) -> tuple[np.ndarray, np.ndarray]:
        """(A, t) back: A = A(p) (eq. 8.12), t = 2 p0 p* (the vector part; eq. 8.27 solved for t)."""
        conjugate = self.real * np.array([1.0, -1.0, -1.0, -1.0])
        return euler_rotation(self.real), 2.0 * _product(self.dual, conjugate)[1:]

    def matrix(self) -> np.ndarray:
        """The 4 x 4 homogeneous transform of the same displacement."""
        return homogeneous(*self.displacement())

    def distance(self, other: DualQuaternion) -> float:
        """max |self - other| over the eight numbers, up to the sign (q and -q are one displacement)."""
        mine, theirs = np.concatenate([self.real, self.dual]), np.concatenate([other.real, other.dual])
        return float(min(np.max(np.abs(mine - theirs)), np.max(np.abs(mine + theirs))))


ONE = DualQuaternion(np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(4))
"""The dual quaternion of no displacement: a loop closes when the product around it is +-ONE (eq. 8.30)."""


def axis_screw(k: int, angle: Dual) -> DualQuaternion:
    """The screw about coordinate axis k (0 = x, 1 = y, 2 = z) through the origin by the dual angle angle.real +
    eps angle.dual: a turn and a slide along the same axis (eq. 8.29 with rho = 0)."""
    unit = np.zeros(3)
    unit[k] = 1.0
    return DualQuaternion.from_screw(unit, np.zeros(3), float(angle.real), float(angle.dual))


def dh_dual_quaternion(theta: float, d: float, a: float, alpha: float) -> DualQuaternion:
    """The DH transform (eq. 8.22) in dual form: the screw about z by theta + eps d, then about the new x by
    alpha + eps a (eq. 8.30)."""
    return axis_screw(2, Dual(theta, d)) * axis_screw(0, Dual(alpha, a))


def dh_dual_matrix(theta: float, d: float, a: float, alpha: float) -> Dual:
    """Yang and Freudenstein's 3 x 3 dual matrix of a DH transform: the rotation block R_z(theta) R_x(alpha) of
    eq. 8.22 with the dual angles theta + eps d and alpha + eps a put in for the angles (eq. 8.31). Its real part
    is the rotation A, its dual part t~ A with t the frame's origin (``dual_matrix``)."""
    ct, st = cos(Dual(theta, d)), sin(Dual(theta, d))
    ca, sa = cos(Dual(alpha, a)), sin(Dual(alpha, a))
    zero = Dual(0.0, 0.0)
    rows = [[ct, -(st * ca), st * sa], [st, ct * ca, -(ct * sa)], [zero, sa, ca]]
    return Dual(np.array([[x.real for x in row] for row in rows]), np.array([[x.dual for x in row] for row in rows]))


def dual_matrix(A: np.ndarray, t: np.ndarray) -> Dual:
    """The dual matrix A + eps t~ A of the displacement x -> A x + t (eq. 8.31): it maps a line u + eps m (eq.
    8.26) to the displaced line A u + eps (A m + t x A u)."""
    return Dual(np.asarray(A, dtype=float), skew(np.asarray(t, dtype=float)) @ A)


__all__ = [
    "IDENTITY",
    "ONE",
    "Dual",
    "DualQuaternion",
    "axis_screw",
    "chain",
    "cos",
    "dh_dual_matrix",
    "dh_dual_quaternion",
    "dh_transform",
    "dot",
    "dual_matrix",
    "homogeneous",
    "line",
    "loop_closure_error",
    "sin",
]
