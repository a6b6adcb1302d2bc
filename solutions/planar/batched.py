"""Planar joints evaluated per type in one pass: every revolute joint of a system at once, and so on.

The element methods of ``joints.py`` define the constraint equations, one joint at a time. Here the
same rows are computed for all the elements of one type together, with array operations over the
elements (one cos and sin per joint end, no Python call per joint): a mechanism with many joints of
few types costs a few dozen array operations per evaluation instead of a few Python calls per joint.
The formulas are those of ``joints.py`` (course notes, ch. 3), written for arrays: revolute eq. 3.17,
relative angle eq. 3.21, pin in a slot eq. 3.24, distance eq. 3.27, drivers eq. 3.34-3.35.

Each group is built once from the elements of its type (``make_groups``) and evaluated from

    X   the (nb + 1, 3) array of body coordinates, row b = (x_b, y_b, phi_b), last row ground (zeros),
        so the body index -1 of ground picks it (numpy's negative indexing)
    V   the same for the velocities

and gives its rows in element order: ``terms(X)``, what the formulas share at one configuration
(the rotated body vectors A s' and B s'), computed once, then ``constraints(X, terms, t)``,
``jacobian(X, terms, t) -> (Psi_qi, Psi_qj)`` (each (rows, 3)), ``psi_t(X, terms, t)`` and
``gamma(X, V, terms, t)``. ``assembly.System`` scatters them into the
system arrays and checks them once against the element methods; it falls back to the element loop for
any group that disagrees. This module stays with the instructor (a student package has none): there the
System evaluates the element methods one by one.
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


def rotate(X: np.ndarray, bodies: np.ndarray, v: np.ndarray, v_perp: np.ndarray) -> np.ndarray:
    """A_b v' = cos(phi_b) v' + sin(phi_b) R90 v' (eq. 2.1) for rows v' of body-frame vectors of bodies b (K,).

    A row may hold several vectors side by side, (K, 2k) with R90 of each in ``v_perp``: the System rotates
    [s', R90 s'] of every vector of every group in one call, which gives A s' and B s' = A R90 s' together.
    """
    phi = angles(X, bodies)
    return np.cos(phi)[:, None] * v + np.sin(phi)[:, None] * v_perp


class Group:
    """The elements of one type, with the data of every element stacked in arrays.

    ``vectors`` are the body-frame vectors v' (s_i', s_j', slot normals, ...) the formulas need rotated, and
    ``ends`` the body each belongs to: ``terms`` rotates them (A_b v' and B_b v'), and ``terms_from`` makes what
    the formulas share from them. The System rotates the vectors of all its groups at once (one cos and sin per
    vector for the whole system) and calls ``terms_from`` with each group's part.
    """

    kind: type = object
    rows_per_element = 1
    constant_jacobian = False
    """Psi_q of the group does not depend on q or t (a driver's angle or coordinate rows): the System writes it once."""

    def __init__(self, elements: list):
        self.elements = elements
        self.i = np.array([e.i for e in elements], dtype=int)
        self.j = np.array([e.j for e in elements], dtype=int)
        self.size = len(elements)
        self.ends = np.zeros(0, dtype=int)
        self.vectors = self.vectors_perp = np.zeros((0, 2))

    def _rotate(self, ends: np.ndarray, vectors: np.ndarray) -> None:
        """Set the body-frame vectors (K, 2) to rotate, and the bodies (K,) they belong to."""
        self.ends, self.vectors, self.vectors_perp = ends, vectors, _perpendicular(vectors)

    def terms(self, X: np.ndarray):
        """What the element formulas share at one configuration (rotated body vectors), computed once."""
        if not self.ends.size:
            return self.terms_from(X, None, None)
        return self.terms_from(X, *rotated(X, self.ends, self.vectors, self.vectors_perp))

    def terms_from(self, X: np.ndarray, A: np.ndarray | None, B: np.ndarray | None):
        """The shared terms from A = A_b v' and B = B_b v' of the group's ``vectors`` (None without vectors)."""
        return None

    def psi_t(self, X: np.ndarray, terms, t: float) -> np.ndarray:
        """Psi_t = 0: joints do not depend on time."""
        return np.zeros(self.size * self.rows_per_element)

    def _blocks(self, last_i: np.ndarray, last_j: np.ndarray, first_i=None, first_j=None):
        """(K, 3) Jacobian rows for bodies i and j from their phi column and (optionally) x, y columns."""
        block_i, block_j = np.zeros((self.size, 3)), np.zeros((self.size, 3))
        if first_i is not None:
            block_i[:, :2], block_j[:, :2] = first_i, first_j
        block_i[:, 2], block_j[:, 2] = last_i, last_j
        return block_i, block_j


class RevoluteGroup(Group):
    """Revolute joints (eq. 3.17): Psi = r_i + A_i s_i' - r_j - A_j s_j',  Psi_q = [I, B_i s_i', -I, -B_j s_j'],
    gamma = A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2; two rows (x, y) per joint."""

    kind = Revolute
    rows_per_element = 2

    def __init__(self, elements):
        super().__init__(elements)
        # s_i' of every joint, then s_j': one rotation for all
        self._rotate(
            np.concatenate([self.i, self.j]),
            np.concatenate([_column([e.si for e in elements]), _column([e.sj for e in elements])]),
        )
        self._block_i = np.zeros((self.size, 2, 3))
        self._block_i[:, 0, 0] = self._block_i[:, 1, 1] = 1.0
        self._block_j = -self._block_i

    def terms_from(self, X, As, Bs):
        """A_i s_i', B_i s_i', A_j s_j', B_j s_j' of every joint: what Psi, Psi_q and gamma are made of; and
        [A_i s_i'; A_j s_j'] as one block (``gamma``)."""
        K = self.size
        return As[:K], Bs[:K], As[K:], Bs[K:], As

    def constraints(self, X, terms, t):
        Asi, _, Asj, _, _ = terms
        r = positions(X, self.ends)  # r_i of every joint (first K rows), then r_j
        K = self.size
        return (r[:K] + Asi - r[K:] - Asj).ravel()

    def jacobian(self, X, terms, t):
        _, Bsi, _, Bsj, _ = terms
        block_i, block_j = self._block_i.copy(), self._block_j.copy()
        block_i[:, :, 2], block_j[:, :, 2] = Bsi, -Bsj
        return block_i.reshape(-1, 3), block_j.reshape(-1, 3)

    def gamma(self, X, V, terms, t):
        """A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2: the centripetal terms of both ends of every joint in one product."""
        As = terms[4]
        w = V[:, 2]  # every body's phi'
        centripetal = As * (w * w).take(self.ends)[:, None]  # A s' phi'^2 of s_i' (first K rows), then of s_j'
        K = self.size
        return (centripetal[:K] - centripetal[K:]).ravel()


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


class RelativeAngleGroup(_TimedGroup):
    """phi_j - phi_i - phi0 - f(t) = 0 (eq. 3.21, 3.34): constant Jacobian rows, Psi_t = -f', gamma = f''."""

    kind = RelativeAngle
    constant_jacobian = True

    def __init__(self, elements):
        super().__init__(elements, [e.function for e in elements])
        self.phi0 = _column([e.phi0 for e in elements])
        self._rows = self._blocks(-np.ones(self.size), np.ones(self.size))

    def constraints(self, X, terms, t):
        return angles(X, self.j) - angles(X, self.i) - self.phi0 - self.values(t)

    def jacobian(self, X, terms, t):
        return self._rows

    def gamma(self, X, V, terms, t):
        return self.derivatives(t, 2)


class BodyCoordinateGroup(_TimedGroup):
    """q_j[k] - f(t) = 0 (eq. 3.34): a unit Jacobian row, Psi_t = -f', gamma = f''."""

    kind = BodyCoordinate
    constant_jacobian = True

    def __init__(self, elements):
        super().__init__(elements, [e.function for e in elements])
        self.index = np.array([e.index for e in elements], dtype=int)
        block_j = np.zeros((self.size, 3))
        block_j[np.arange(self.size), self.index] = 1.0
        self._rows = np.zeros((self.size, 3)), block_j

    def constraints(self, X, terms, t):
        return X[self.j, self.index] - self.values(t)

    def jacobian(self, X, terms, t):
        return self._rows

    def gamma(self, X, V, terms, t):
        return self.derivatives(t, 2)


class AlongDirectionGroup(_TimedGroup):
    """u_i^T d_ij + rolling (phi_j - phi_i) - d0 - f(t) = 0 with u_i = A_i u_i' (eq. 3.13): the pin in a slot
    (u' the slot normal, eq. 3.24), the prismatic driver (eq. 3.35) and the rack and pinion (eq. 3.31).

    Psi_qi = [-u^T, (B_i u_i')^T d - u^T B_i s_i' - rolling],  Psi_qj = [u^T, u^T B_j s_j' + rolling]
    gamma = u^T d phi_i'^2 - 2 phi_i' (B_i u_i')^T d' - u^T (A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2) + f''
    """

    kind = (PinInSlot, Translation)

    def __init__(self, elements):
        slot = [isinstance(e, PinInSlot) for e in elements]
        zero = Constant(0.0)
        super().__init__(elements, [zero if s else e.function for e, s in zip(elements, slot, strict=True)])
        u = _column([e._normal if s else e.axis for e, s in zip(elements, slot, strict=True)])
        # u_i', s_i', s_j': one rotation for all
        self._rotate(
            np.concatenate([self.i, self.i, self.j]),
            np.concatenate([u, _column([e.si for e in elements]), _column([e.sj for e in elements])]),
        )
        self.rolling = _column([0.0 if s else e.side * e.pinion_radius for e, s in zip(elements, slot, strict=True)])
        self.d0 = _column([0.0 if s else e.d0 for e, s in zip(elements, slot, strict=True)])
        self.rolls = bool(np.any(self.rolling))  # a rack and pinion among them: the rolling terms are needed
        self.shifted = self.moves or bool(np.any(self.d0))  # d0 + f(t) nonzero somewhere

    def terms_from(self, X, A, B):
        """u = A_i u_i', w = B_i u_i', A_i s_i', B_i s_i', A_j s_j', B_j s_j' and d_ij of every element."""
        K = self.size
        u, w, Asi, Bsi, Asj, Bsj = A[:K], B[:K], A[K : 2 * K], B[K : 2 * K], A[2 * K :], B[2 * K :]
        r = positions(X, self.ends)  # r_i (twice), then r_j: the bodies of u_i', s_i', s_j'
        d = r[2 * K :] + Asj - r[:K] - Asi
        return u, w, Asi, Bsi, Asj, Bsj, d

    def constraints(self, X, terms, t):
        u, _, _, _, _, _, d = terms
        psi = dot_rows(u, d)
        if self.shifted:  # a driver's d0 + f(t), or a pin in a slot off its line
            psi = psi - self.d0 - self.values(t)
        if self.rolls:
            psi += self.rolling * (angles(X, self.j) - angles(X, self.i))
        return psi

    def jacobian(self, X, terms, t):
        u, w, Asi, _, _, Bsj, d = terms
        # w^T d - u^T B_i s_i' = w^T (d + A_i s_i'), since u^T B_i s_i' = u_i'^T R90 s_i' = -w^T A_i s_i'
        angle_i, angle_j = dot_rows(w, d + Asi), dot_rows(u, Bsj)
        if self.rolls:
            angle_i, angle_j = angle_i - self.rolling, angle_j + self.rolling
        return self._blocks(angle_i, angle_j, -u, u)

    def gamma(self, X, V, terms, t):
        u, w, Asi, Bsi, Asj, Bsj, d = terms
        K = self.size
        Vij = rows(V, self.ends)  # body i's velocities (twice), then body j's
        Vi, Vj = Vij[:K], Vij[2 * K :]
        wi, wj = Vi[:, 2:], Vj[:, 2:]  # phi_i', phi_j' as (K, 1) columns
        d_dot = Vj[:, :2] + Bsj * wj - Vi[:, :2] - Bsi * wi
        # u^T d phi_i'^2 - u^T (A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2) in one product
        quadratic = dot_rows(u, (d - Asi) * (wi * wi) + Asj * (wj * wj))
        gamma = quadratic - 2.0 * wi[:, 0] * dot_rows(w, d_dot)
        return gamma + self.derivatives(t, 2) if self.timed else gamma


class DistanceGroup(_TimedGroup):
    """(d^T d - L(t)^2) / 2 = 0 (eq. 3.27): Psi_q = d^T [-I, -B_i s_i', I, B_j s_j'], Psi_t = -L L',
    gamma = -d'^T d' - d^T (A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2) + L'^2 + L L''."""

    kind = Distance

    def __init__(self, elements):
        super().__init__(elements, [e.length for e in elements])
        self._rotate(
            np.concatenate([self.i, self.j]),
            np.concatenate([_column([e.si for e in elements]), _column([e.sj for e in elements])]),
        )

    def terms_from(self, X, As, Bs):
        """A_i s_i', B_i s_i', A_j s_j', B_j s_j' and d_ij of every element."""
        K = self.size
        Asi, Bsi, Asj, Bsj = As[:K], Bs[:K], As[K:], Bs[K:]
        return Asi, Bsi, Asj, Bsj, positions(X, self.j) + Asj - positions(X, self.i) - Asi

    def psi_t(self, X, terms, t):
        return -self.values(t) * self.derivatives(t, 1)

    def constraints(self, X, terms, t):
        d = terms[4]
        return 0.5 * (dot_rows(d, d) - self.values(t) ** 2)

    def jacobian(self, X, terms, t):
        _, Bsi, _, Bsj, d = terms
        return self._blocks(-dot_rows(d, Bsi), dot_rows(d, Bsj), -d, d)

    def gamma(self, X, V, terms, t):
        Asi, Bsi, Asj, Bsj, d = terms
        Vi, Vj = rows(V, self.i), rows(V, self.j)
        wi, wj = Vi[:, 2:], Vj[:, 2:]
        d_dot = Vj[:, :2] + Bsj * wj - Vi[:, :2] - Bsi * wi
        quadratic = Asi * (wi * wi) - Asj * (wj * wj)
        L, Ld, Ldd = self.values(t), self.derivatives(t, 1), self.derivatives(t, 2)
        return -dot_rows(d_dot, d_dot) - dot_rows(d, quadratic) + Ld * Ld + L * Ldd


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


__all__ = ["GROUPS", "Group", "angles", "dot_rows", "make_groups", "positions", "rotate", "rotated", "rows"]
