"""Planar joints evaluated per type in one pass: every revolute joint of a system at once, and so on.

The element methods of ``joints.py`` define the constraint equations, one joint at a time. Here the
same rows are computed for all the elements of one type together, with array operations over the
elements (no Python call per joint): a mechanism with many joints of few types costs a few dozen
array operations per evaluation instead of a few Python calls per joint. The formulas are those of
``joints.py`` (course notes, ch. 3), written for arrays: revolute eq. 3.17, relative angle eq. 3.21,
pin in a slot eq. 3.24, distance eq. 3.27, drivers eq. 3.34-3.35.

Every planar joint is made of body-fixed vectors v' (a point's s', a slot's normal, an axis) and what
they become at a configuration and a velocity (eq. 2.1, 2.5, 2.6):

    A_b v'                     the vector in the ground frame, and B_b v' = A_b R90 v' = dA_b/dphi_b v'
    r_b, P = r_b + A_b v'      the body's origin and the point, when v' locates one (s')
    r_b', P' = r_b' + B_b v' phi_b'   their velocities
    A_b v' phi_b'^2            the centripetal term every gamma is made of (eq. 4.4)

``RotatedVectors`` computes these arrays once per evaluation for the vectors of every group of a
system together (one cos and one sin per vector for the whole system, by index maps found once), and
each group takes its rows from them by slices: a group's 2K vectors are K on body i (rows ``on_i``),
then K on body j (rows ``on_j``), so that, e.g., a revolute joint's Psi is ``P[on_i] - P[on_j]``.

A group is built once from the elements of its type (``make_groups``) and evaluated from

    X   the (nb + 1, 3) array of body coordinates, row b = (x_b, y_b, phi_b), last row ground (zeros),
        so the body index -1 of ground picks it (numpy's negative indexing)

as ``terms_from(X, A, B, R, P)`` (what its formulas share at one configuration, from its rows of the
rotated vectors A v', B v', origins r_b and points P), then ``constraints(X, terms, t)``, ``jacobian(X,
terms, t) -> (Psi_qi, Psi_qj)``, ``psi_t(X, terms, t)`` and ``gamma(X, motion, terms, t)``, ``motion`` the
velocity arrays (r_b', P', A v' phi'^2, phi'). The Jacobian blocks hold only the columns of
(x_b, y_b, phi_b) that depend on q (``columns``: a revolute joint's phi column); the others are constant
(``constant_blocks``, the +-I of a revolute joint), written once.
``assembly.System`` scatters the rows into the system arrays and checks every group once against the
element methods; it falls back to the element loop for any group that disagrees. This module stays with
the instructor (a student package has none): there the System evaluates the element methods one by one.
"""

from __future__ import annotations

import numpy as np

from ..functions import Constant
from .joints import BodyCoordinate, Distance, PinInSlot, RelativeAngle, Revolute, Translation

R90 = np.array([[0.0, -1.0], [1.0, 0.0]])


def _column(values) -> np.ndarray:
    return np.asarray(values, dtype=float)


def _perpendicular(s: np.ndarray) -> np.ndarray:
    """R90 s' for every row of s' (K, 2)."""
    return s @ R90.T


def rows(X: np.ndarray, bodies: np.ndarray) -> np.ndarray:
    """The (K, 3) rows (x_b, y_b, phi_b) of X (or (x_b', y_b', phi_b') of V) of bodies b (K,): ``X[bodies]``."""
    return X.take(bodies, axis=0)


def positions(X: np.ndarray, bodies: np.ndarray) -> np.ndarray:
    """r_b = (x_b, y_b) of bodies b (K,) as a (K, 2) array: the rows of X, then their first two columns.

    (``X.take(bodies, axis=0)[:, :2]`` is ``X[bodies, :2]``; gathering whole rows first is several
    times cheaper for small arrays, and a system is evaluated thousands of times.)
    """
    return X.take(bodies, axis=0)[:, :2]


def angles(X: np.ndarray, bodies: np.ndarray) -> np.ndarray:
    """phi_b (or phi_b' from V) of bodies b (K,): the phi column of X, then its entries (``X[bodies, 2]``)."""
    return X[:, 2].take(bodies)


def dot_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a_k^T b_k for every row k of two (K, 2) arrays."""
    return _vecdot(a, b)


_vecdot = getattr(np, "vecdot", None) or (lambda a, b: np.einsum("ki,ki->k", a, b))  # np.vecdot: NumPy >= 2.0


def rotated(X: np.ndarray, bodies: np.ndarray, s: np.ndarray, s_perp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A_b s' and B_b s' = A_b R90 s' for body-frame vectors s' (K, 2) of bodies b (K,) (eq. 2.1, 2.5).

    With c = cos(phi_b), s = sin(phi_b): A s' = c s' + s R90 s',  B s' = c R90 s' - s s'.
    """
    phi = angles(X, bodies)
    c, sn = np.cos(phi)[:, None], np.sin(phi)[:, None]
    return c * s + sn * s_perp, c * s_perp - sn * s


def motion(V: np.ndarray, bodies: np.ndarray, A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, ...]:
    """(r_b', P', A v' phi'^2, phi') of rotated vectors A = A_b v', B = B_b v' (K, 2) of bodies b (K,):
    P' = r_b' + B_b v' phi_b' (eq. 2.6), the centripetal A_b v' phi_b'^2 (eq. 4.4), phi_b' as a (K, 1) column."""
    Vb = V.take(bodies, axis=0)
    r_dot, w = Vb[:, :2], Vb[:, 2:]
    return r_dot, r_dot + B * w, A * (w * w), w


class RotatedVectors:
    """The body-frame vectors v' of every group of a system, rotated together: A v', B v', P = r_b + A v' of all of
    them in a few whole-array operations per configuration (eq. 2.1, 2.5), P' and A v' phi'^2 per velocity (eq. 2.6,
    4.4); each group's part is a slice (``parts``).

    Index maps found once pick, from the flat coordinates (q, then ground's zeros), phi_b of each vector twice
    (``angle_index``, (K, 2): the same shape as the vectors) and (x_b, y_b) (``position_index``), so that every
    product below is between arrays of one shape: A v' = cos(phi_b) v' + sin(phi_b) R90 v',
    B v' = cos(phi_b) R90 v' - sin(phi_b) v'.
    """

    def __init__(self, groups: list, n_bodies: int):
        start = 0
        for group in groups:  # each group's rows in the arrays of all (``Group.place``)
            group.place(start)
            start += group.ends.size
        ends = np.concatenate([group.ends for group in groups])
        self.vectors = np.concatenate([group.vectors for group in groups]).reshape(-1, 2)
        self.vectors_perp = _perpendicular(self.vectors)
        first = 3 * np.where(ends < 0, n_bodies, ends)  # ground (-1): the three entries after the bodies'
        self.angle_index = np.column_stack([first + 2, first + 2])
        self.position_index = np.column_stack([first, first + 1])

    def configuration(self, x: np.ndarray) -> tuple[np.ndarray, ...]:
        """(A v', B v', r_b, P = r_b + A v') of every vector from the flat body coordinates x (eq. 2.1, 2.5)."""
        phi = x.take(self.angle_index)
        c, s = np.cos(phi), np.sin(phi)
        v, v_perp = self.vectors, self.vectors_perp
        A, r = c * v + s * v_perp, x.take(self.position_index)
        return A, c * v_perp - s * v, r, r + A

    def motion(self, v: np.ndarray, A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, ...]:
        """(r_b', P' = r_b' + B v' phi_b', A v' phi_b'^2, phi_b') of every vector from the flat velocities v
        (eq. 2.6)."""
        w, r_dot = v.take(self.angle_index), v.take(self.position_index)
        return r_dot, r_dot + B * w, A * (w * w), w


class Group:
    """The elements of one type, with the data of every element stacked in arrays.

    ``vectors`` are the body-frame vectors v' (s_i', s_j', slot normals, ...) the formulas need rotated, and
    ``ends`` the body each belongs to: K vectors on body i (rows ``on_i`` of the rotated arrays), then K on
    body j (rows ``on_j``); ``terms_from`` makes what the formulas share from their rotated forms.
    """

    kind: type = object
    rows_per_element = 1
    columns: tuple[int, ...] = (0, 1, 2)
    """The columns of a body's (x_b, y_b, phi_b) whose Psi_q entries depend on q: ``jacobian`` gives these."""
    constant_jacobian = False
    """Psi_q of the group does not depend on q or t (a driver's angle or coordinate rows): the System writes it once."""

    def __init__(self, elements: list):
        self.elements = elements
        self.i = np.array([e.i for e in elements], dtype=int)
        self.j = np.array([e.j for e in elements], dtype=int)
        self.size = len(elements)
        self.ends = np.zeros(0, dtype=int)
        self.vectors = self.vectors_perp = np.zeros((0, 2))
        self.place(0)

    def _rotate(self, ends: np.ndarray, vectors: np.ndarray) -> None:
        """Set the body-frame vectors (2K, 2) to rotate, K on body i then K on body j, and the bodies (2K,)."""
        self.ends, self.vectors, self.vectors_perp = ends, vectors, _perpendicular(vectors)

    def place(self, start: int) -> None:
        """The rows of the group's vectors in the rotated arrays it is given, from ``start``: 0 in its own
        (``rotate``), its place among all the system's (``RotatedVectors``)."""
        K = self.size
        self.on_i, self.on_j = slice(start, start + K), slice(start + K, start + 2 * K)

    def rotate(self, X: np.ndarray):
        """(A v', B v', r_b, P) of the group's own vectors (``RotatedVectors.configuration`` for one group), or
        Nones."""
        if not self.ends.size:
            return None, None, None, None
        A, B = rotated(X, self.ends, self.vectors, self.vectors_perp)
        r = positions(X, self.ends)
        return A, B, r, r + A

    def terms(self, X: np.ndarray):
        """What the element formulas share at one configuration, from the group's own rotation."""
        return self.terms_from(X, *self.rotate(X))

    def terms_from(self, X: np.ndarray, A: np.ndarray | None, B: np.ndarray | None, R=None, P=None):
        """The shared terms from A = A_b v', B = B_b v', R = r_b and P = r_b + A_b v' (the group's ``vectors`` in
        rows ``on_i`` and ``on_j``)."""
        return None

    def constant_blocks(self) -> tuple[np.ndarray, np.ndarray]:
        """The (rows, 3) blocks of Psi_qi and Psi_qj in the columns that do not depend on q (zeros in the others)."""
        zeros = np.zeros((self.size * self.rows_per_element, 3))
        return zeros, zeros.copy()

    def psi_t(self, X: np.ndarray, terms, t: float) -> np.ndarray:
        """Psi_t = 0: joints do not depend on time."""
        return np.zeros(self.size * self.rows_per_element)

    def _blocks(self, last_i: np.ndarray, last_j: np.ndarray, first_i: np.ndarray, first_j: np.ndarray):
        """(K, 3) Jacobian rows [x, y columns, phi column] of bodies i and j."""
        return (
            np.concatenate([first_i, last_i[:, None]], axis=1),
            np.concatenate([first_j, last_j[:, None]], axis=1),
        )


class RevoluteGroup(Group):
    """Revolute joints (eq. 3.17): Psi = r_i + A_i s_i' - r_j - A_j s_j' (= P_i - P_j),
    Psi_q = [I, B_i s_i', -I, -B_j s_j'], gamma = A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2; two rows (x, y) per joint.
    The +-I columns are constant: ``jacobian`` gives the phi columns."""

    kind = Revolute
    rows_per_element = 2
    columns = (2,)

    def __init__(self, elements):
        super().__init__(elements)
        # s_i' of every joint, then s_j'
        self._rotate(
            np.concatenate([self.i, self.j]),
            np.concatenate([_column([e.si for e in elements]), _column([e.sj for e in elements])]),
        )

    def terms_from(self, X, A, B, R, P):
        """B_i s_i', B_j s_j', P_i = r_i + A_i s_i', r_j and A_j s_j' of every joint."""
        return B[self.on_i], B[self.on_j], P[self.on_i], R[self.on_j], A[self.on_j]

    def constant_blocks(self):
        """I and -I in the x, y columns of every joint's two rows."""
        block_i = np.zeros((self.size, 2, 3))
        block_i[:, 0, 0] = block_i[:, 1, 1] = 1.0
        return block_i.reshape(-1, 3), -block_i.reshape(-1, 3)

    def constraints(self, X, terms, t):
        """r_i + A_i s_i' - r_j - A_j s_j', summed left to right in the order of eq. 3.17 (not P_i - P_j: the same
        bits as before the shared pass; at a singular position the last bits of Psi decide where Newton-Raphson's
        iterate lands)."""
        _, _, Pi, rj, Asj = terms
        return (Pi - rj - Asj).ravel()

    def jacobian(self, X, terms, t):
        """The phi columns: B_i s_i' and -B_j s_j', (K, 2) each: the (x, y) rows of joint k in row k."""
        return terms[0], -terms[1]

    def gamma(self, X, motion, terms, t):
        """A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2 of every joint."""
        centripetal = motion[2]
        return (centripetal[self.on_i] - centripetal[self.on_j]).ravel()


class _TimedGroup(Group):
    """Elements with a function of time f(t) each: f, f', f'' evaluated element by element (scalars)."""

    def __init__(self, elements, functions):
        super().__init__(elements)
        self.functions = functions
        self.timed = [k for k, f in enumerate(functions) if not isinstance(f, Constant)]
        self._values = np.array([f.value(0.0) for f in functions], dtype=float)
        self._values.flags.writeable = False
        self.moves = bool(self.timed) or bool(np.any(self._values))  # f(t) = 0 for all: nothing to subtract

    def values(self, t: float) -> np.ndarray:
        """f(t) of every element (read only: constant functions share one array)."""
        if not self.timed:
            return self._values
        out = self._values.copy()
        for k in self.timed:
            out[k] = self.functions[k].value(t)
        return out

    def derivatives(self, t: float, order: int) -> np.ndarray:
        out = np.zeros(self.size)
        for k in self.timed:
            f = self.functions[k]
            out[k] = f.first(t) if order == 1 else f.second(t)
        return out

    def psi_t(self, X, terms, t):
        return -self.derivatives(t, 1)


class _ConstantRows(_TimedGroup):
    """Elements whose Psi_q rows are constant (``rows``: (Psi_qi, Psi_qj)): Psi_t = -f', gamma = f''."""

    columns = ()
    constant_jacobian = True

    def offsets(self, t: float) -> np.ndarray:
        """The constant part of Psi and f(t): phi0 + f(t) of a relative angle, f(t) of a coordinate driver."""
        return self._offsets + self.values(t) if self.timed else self._offsets

    def constant_blocks(self):
        return self._rows

    def jacobian(self, X, terms, t):
        return np.zeros((self.size, 0)), np.zeros((self.size, 0))

    def gamma(self, X, motion, terms, t):
        return self.derivatives(t, 2)


class RelativeAngleGroup(_ConstantRows):
    """phi_j - phi_i - phi0 - f(t) = 0 (eq. 3.21, 3.34): constant Jacobian rows [0, 0, -1], [0, 0, 1]."""

    kind = RelativeAngle

    def __init__(self, elements):
        super().__init__(elements, [e.function for e in elements])
        self.phi0 = _column([e.phi0 for e in elements])
        self._offsets = self.phi0 + self._values if not self.timed else self.phi0  # phi0 + f(t) of constant f
        block_j = np.zeros((self.size, 3))
        block_j[:, 2] = 1.0
        self._rows = -block_j, block_j

    def constraints(self, X, terms, t):
        return angles(X, self.j) - angles(X, self.i) - self.offsets(t)


class BodyCoordinateGroup(_ConstantRows):
    """q_j[k] - f(t) = 0 (eq. 3.34): a unit Jacobian row."""

    kind = BodyCoordinate

    def __init__(self, elements):
        super().__init__(elements, [e.function for e in elements])
        self.index = np.array([e.index for e in elements], dtype=int)
        self._offsets = self._values if not self.timed else np.zeros(self.size)
        block_j = np.zeros((self.size, 3))
        block_j[np.arange(self.size), self.index] = 1.0
        self._rows = np.zeros((self.size, 3)), block_j

    def constraints(self, X, terms, t):
        return X[self.j, self.index] - self.offsets(t)


class AlongDirectionGroup(_TimedGroup):
    """u_i^T d_ij + rolling (phi_j - phi_i) - d0 - f(t) = 0 with u_i = A_i u_i', d_ij = P_j - P_i (eq. 3.13): the
    pin in a slot (u' the slot normal, eq. 3.24), the prismatic driver (eq. 3.35) and the rack and pinion (eq. 3.31).

    Since u_i^T A_i s_i' = u_i'^T A_i^T A_i s_i' = u_i'^T s_i' is constant, u_i^T d_ij = u_i^T e - u_i'^T s_i' with
    e = P_j - r_i (body i's origin to the point of j): the rows need u_i and s_j' rotated, not s_i'. With
    w = B_i u_i' (= R90 u_i, so u^T B_j s_j' = -w^T A_j s_j'):

    Psi_qi = [-u^T, w^T e - rolling],  Psi_qj = [u^T, u^T B_j s_j' + rolling]
    gamma = u^T e phi_i'^2 + u^T A_j s_j' phi_j'^2 - 2 phi_i' w^T e' + f'',  e' = P_j' - r_i'
    (the element methods' form, eq. 3.13, with d = e - A_i s_i' and w^T B_i s_i' = u^T A_i s_i').
    """

    kind = (PinInSlot, Translation)

    def __init__(self, elements):
        slot = [isinstance(e, PinInSlot) for e in elements]
        zero = Constant(0.0)
        super().__init__(elements, [zero if s else e.function for e, s in zip(elements, slot, strict=True)])
        u = _column([e._normal if s else e.axis for e, s in zip(elements, slot, strict=True)])
        # u_i' of body i, s_j' of body j
        self._rotate(np.concatenate([self.i, self.j]), np.concatenate([u, _column([e.sj for e in elements])]))
        self.rolling = _column([0.0 if s else e.side * e.pinion_radius for e, s in zip(elements, slot, strict=True)])
        d0 = _column([0.0 if s else e.d0 for e, s in zip(elements, slot, strict=True)])
        self.shift = d0 + dot_rows(u, _column([e.si for e in elements]))  # d0 + u_i'^T s_i'
        self.rolls = bool(np.any(self.rolling))  # a rack and pinion among them: the rolling terms are needed
        self.shifted = self.moves or bool(np.any(self.shift))  # d0 + u_i'^T s_i' + f(t) nonzero somewhere

    def terms_from(self, X, A, B, R, P):
        """u = A_i u_i', w = B_i u_i', B_j s_j' and e = P_j - r_i of every element."""
        return A[self.on_i], B[self.on_i], B[self.on_j], P[self.on_j] - R[self.on_i]

    def constraints(self, X, terms, t):
        u, _, _, e = terms
        psi = dot_rows(u, e)
        if self.shifted:  # d0 + u_i'^T s_i' + f(t)
            psi = psi - self.shift - self.values(t)
        if self.rolls:
            psi += self.rolling * (angles(X, self.j) - angles(X, self.i))
        return psi

    def jacobian(self, X, terms, t):
        u, w, Bsj, e = terms
        angle_i, angle_j = dot_rows(w, e), dot_rows(u, Bsj)
        if self.rolls:
            angle_i, angle_j = angle_i - self.rolling, angle_j + self.rolling
        return self._blocks(angle_i, angle_j, -u, u)

    def gamma(self, X, motion, terms, t):
        u, w, _, e = terms
        origin_velocity, velocity, centripetal, rate = motion
        wi = rate[self.on_i]  # phi_i' of every element, twice per row
        e_dot = velocity[self.on_j] - origin_velocity[self.on_i]  # P_j' - r_i'
        gamma = dot_rows(u, e * (wi * wi) + centripetal[self.on_j]) - 2.0 * wi[:, 0] * dot_rows(w, e_dot)
        return gamma + self.derivatives(t, 2) if self.timed else gamma


class DistanceGroup(_TimedGroup):
    """(d^T d - L(t)^2) / 2 = 0 with d = P_j - P_i (eq. 3.27): Psi_q = d^T [-I, -B_i s_i', I, B_j s_j'],
    Psi_t = -L L', gamma = -d'^T d' - d^T (A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2) + L'^2 + L L''."""

    kind = Distance

    def __init__(self, elements):
        super().__init__(elements, [e.length for e in elements])
        self._rotate(
            np.concatenate([self.i, self.j]),
            np.concatenate([_column([e.si for e in elements]), _column([e.sj for e in elements])]),
        )

    def terms_from(self, X, A, B, R, P):
        """B_i s_i', B_j s_j' and d_ij = P_j - P_i of every element."""
        return B[self.on_i], B[self.on_j], P[self.on_j] - P[self.on_i]

    def psi_t(self, X, terms, t):
        return -self.values(t) * self.derivatives(t, 1)

    def constraints(self, X, terms, t):
        d = terms[2]
        return 0.5 * (dot_rows(d, d) - self.values(t) ** 2)

    def jacobian(self, X, terms, t):
        Bsi, Bsj, d = terms
        return self._blocks(-dot_rows(d, Bsi), dot_rows(d, Bsj), -d, d)

    def gamma(self, X, motion, terms, t):
        d = terms[2]
        _, velocity, centripetal, _ = motion
        i, j = self.on_i, self.on_j
        d_dot = velocity[j] - velocity[i]
        L, Ld, Ldd = self.values(t), self.derivatives(t, 1), self.derivatives(t, 2)
        return -dot_rows(d_dot, d_dot) - dot_rows(d, centripetal[i] - centripetal[j]) + Ld * Ld + L * Ldd


GROUPS = (RevoluteGroup, RelativeAngleGroup, BodyCoordinateGroup, AlongDirectionGroup, DistanceGroup)
"""Element types with a batched form; the others (gears, cams) are evaluated element by element."""


def make_groups(elements: list) -> tuple[list[tuple[Group, list[int]]], list[int]]:
    """Sort the elements by type: [(group, element indices)] for the types above, and the indices of the rest."""
    groups, rest = [], []
    taken = set()
    for cls in GROUPS:
        kinds = cls.kind if isinstance(cls.kind, tuple) else (cls.kind,)
        members = [k for k, e in enumerate(elements) if type(e) in kinds]
        if members:
            groups.append((cls([elements[k] for k in members]), members))
            taken.update(members)
    rest = [k for k in range(len(elements)) if k not in taken]
    return groups, rest


__all__ = [
    "GROUPS",
    "RotatedVectors",
    "Group",
    "angles",
    "dot_rows",
    "make_groups",
    "motion",
    "positions",
    "rotated",
    "rows",
]
