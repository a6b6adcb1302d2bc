"""Spatial joints evaluated per type in one pass: every basic constraint of a kind at once.

The joints of ``joints.py`` are stacks of four basic constraints (spherical, dot-1, dot-2; Haug 1989)
plus the Euler-parameter normalization of every body. Here each kind is evaluated for all the joints
of a system together with array operations (course notes, sec. 9.2: spherical eq. 9.12, dot-1
eq. 9.10, dot-2 eq. 9.11, normalization eq. 9.9). One fact makes it short: B(p, a') is linear in p,

    B(p, a') = e0 C_0(a') + e1 C_1(a') + e2 C_2(a') + e3 C_3(a'),      C_k(a') = B(unit vector k, a')

so the four 3 x 4 matrices C_k of every body vector are computed once (from ``bodies.b_matrix``), and
at every evaluation B for all of them is one matrix product; then A(p) a' = B(p, a') p / 2 (A a' is a
homogeneous quadratic form in p), a' rates B(p, a') p' and the velocity parts B(p', a') p' follow.

The groups are built by ``make_groups`` and evaluated from the (nb + 1, 7) array X of body coordinates
(last row ground) and V of velocities, with ``terms(X)`` (B and A a' of every body vector) computed
once per configuration, like the planar ones (``planar/batched.py``); ``assembly.System``
checks them once against the element methods and uses the element loop for any group that disagrees
(and in a student package, which has no batched forms, for every element). Drivers are always evaluated
element by element.
"""

from __future__ import annotations

import numpy as np

from .bodies import b_matrix
from .joints import Dot1, Dot2, EulerNormalization, Joint, Spherical


class BodyVectors:
    """K body-fixed vectors a' (rows) of bodies b: B(p, a') for all of them in one product (eq. 9.3)."""

    def __init__(self, bodies: np.ndarray, vectors: np.ndarray):
        self.bodies = np.asarray(bodies, dtype=int)
        unit = np.eye(4)
        basis = np.array([[b_matrix(unit[k], a) for k in range(4)] for a in vectors])  # (K, 4, 3, 4)
        self._basis = basis.reshape(len(vectors), 4, 12)

    def b(self, P: np.ndarray) -> np.ndarray:
        """B(p_k, a_k') for every row p_k of P (K, 4): (K, 3, 4) (eq. 9.3)."""
        return (P[:, None, :] @ self._basis).reshape(-1, 3, 4)

    def positions(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B(p, a'), A(p) a' = B(p, a') p / 2) of every vector (eq. 9.3)."""
        P = X[self.bodies, 3:]
        B = self.b(P)
        return B, 0.5 * (B @ P[:, :, None])[:, :, 0]

    def velocities(self, B: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(a' rate B(p, a') p', velocity part of a'' B(p', a') p') of every vector."""
        Pd = V[self.bodies, 3:]
        return (B @ Pd[:, :, None])[:, :, 0], (self.b(Pd) @ Pd[:, :, None])[:, :, 0]


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ki,ki->k", a, b)


def _vector_row(a: np.ndarray, B: np.ndarray) -> np.ndarray:
    """a^T B for every row: (K, 3) with (K, 3, 4) -> (K, 4)."""
    return (a[:, None, :] @ B)[:, 0, :]


class _Vectors:
    """Collects the body vectors of a group's parts, so that all of them are rotated in one product."""

    def __init__(self):
        self.bodies, self.vectors = [], []

    def add(self, bodies, vectors) -> slice:
        start = len(self.vectors)
        self.bodies.extend(bodies)
        self.vectors.extend(vectors)
        return slice(start, len(self.vectors))


class JointGroup:
    """All joints built only of spherical, dot-1 and dot-2 constraints, evaluated kind by kind.

    Rows come out in element order (each joint's parts in its order), like the element loop; every
    body vector of every part (s_i', s_j', a_i', a_j') is rotated in one product (``BodyVectors``).
    """

    def __init__(self, elements: list[Joint]):
        self.elements = elements
        self.timed = ()
        names = {Spherical: "spherical", Dot1: "dot1", Dot2: "dot2"}
        kinds = {"spherical": [], "dot1": [], "dot2": []}
        row = 0
        for element in elements:
            for part in element.parts:
                kinds[names[type(part)]].append((part, row, element.i, element.j))
                row += len(part.labels)
        self.n_rows = row
        vectors = _Vectors()
        self.kinds = {}
        for kind, members in kinds.items():
            if not members:
                continue
            i = np.array([m[2] for m in members], dtype=int)
            j = np.array([m[3] for m in members], dtype=int)
            if kind == "spherical":
                rows = np.array([[m[1], m[1] + 1, m[1] + 2] for m in members], dtype=int)
                fields = {"si": (i, "si"), "sj": (j, "sj")}
            elif kind == "dot1":
                rows = np.array([m[1] for m in members], dtype=int)
                fields = {"ai": (i, "ai"), "aj": (j, "aj")}
            else:
                rows = np.array([m[1] for m in members], dtype=int)
                fields = {"ai": (i, "ai"), "si": (i, "si"), "sj": (j, "sj")}
            where = {key: vectors.add(b, [getattr(m[0], name) for m in members]) for key, (b, name) in fields.items()}
            self.kinds[kind] = (rows, i, j, where)
        self.vectors = BodyVectors(np.array(vectors.bodies, dtype=int), np.array(vectors.vectors, dtype=float))
        self._constant = np.zeros((self.n_rows, 7)), np.zeros((self.n_rows, 7))  # the spherical parts' I and -I
        if "spherical" in self.kinds:
            rows = self.kinds["spherical"][0]
            self._constant[0][rows, :3], self._constant[1][rows, :3] = np.eye(3), -np.eye(3)

    def terms(self, X):
        """B(p, a') and A(p) a' of every body vector of the group."""
        return self.vectors.positions(X)

    def psi_t(self, X, terms, t):
        """Psi_t = 0: joints do not depend on time."""
        return np.zeros(self.n_rows)

    def constraints(self, X, terms, t):
        """Psi of every part: -d_ij (spherical, eq. 9.12), a_i^T a_j (dot-1, eq. 9.10), a_i^T d_ij (dot-2, eq. 9.11)."""
        out = np.empty(self.n_rows)
        _, A = terms
        for kind, (rows, i, j, where) in self.kinds.items():
            if kind == "spherical":
                out[rows] = X[i, :3] + A[where["si"]] - X[j, :3] - A[where["sj"]]
            elif kind == "dot1":
                out[rows] = _dot(A[where["ai"]], A[where["aj"]])
            else:
                out[rows] = _dot(A[where["ai"]], X[j, :3] + A[where["sj"]] - X[i, :3] - A[where["si"]])
        return out

    def jacobian(self, X, terms, t):
        """(Psi_qi, Psi_qj), (rows, 7) each: [I, B_i s_i'], [-I, -B_j s_j'] (spherical); [0, a_j^T B_i],
        [0, a_i^T B_j] (dot-1); [-a_i^T, d^T B(p_i, a_i') - a_i^T B(p_i, s_i')], [a_i^T, a_i^T B(p_j, s_j')] (dot-2)."""
        jac_i, jac_j = self._constant[0].copy(), self._constant[1].copy()  # zeros, and the spherical rows' +-I
        B, A = terms
        for kind, (rows, i, j, where) in self.kinds.items():
            if kind == "spherical":
                jac_i[rows, 3:], jac_j[rows, 3:] = B[where["si"]], -B[where["sj"]]
            elif kind == "dot1":
                jac_i[rows, 3:] = _vector_row(A[where["aj"]], B[where["ai"]])
                jac_j[rows, 3:] = _vector_row(A[where["ai"]], B[where["aj"]])
            else:
                ai = A[where["ai"]]
                d = X[j, :3] + A[where["sj"]] - X[i, :3] - A[where["si"]]
                jac_i[rows, :3], jac_j[rows, :3] = -ai, ai
                jac_i[rows, 3:] = _vector_row(d, B[where["ai"]]) - _vector_row(ai, B[where["si"]])
                jac_j[rows, 3:] = _vector_row(ai, B[where["sj"]])
        return jac_i, jac_j

    def gamma(self, X, V, terms, t):
        """gamma of every part: B(p_j', s_j') p_j' - B(p_i', s_i') p_i' (spherical);
        -a_j^T B(p_i', a_i') p_i' - a_i^T B(p_j', a_j') p_j' - 2 a_i'^T a_j' (dot-1);
        -d^T B(p_i', a_i') p_i' - 2 a_i'^T d' - a_i^T (d'')_v (dot-2) (eq. 9.10-9.12)."""
        out = np.empty(self.n_rows)
        B, A = terms
        rate, quadratic = self.vectors.velocities(B, V)
        for kind, (rows, i, j, where) in self.kinds.items():
            if kind == "spherical":
                out[rows] = quadratic[where["sj"]] - quadratic[where["si"]]
            elif kind == "dot1":
                ai, aj, ai_dot, aj_dot = A[where["ai"]], A[where["aj"]], rate[where["ai"]], rate[where["aj"]]
                out[rows] = (
                    -_dot(aj, quadratic[where["ai"]]) - _dot(ai, quadratic[where["aj"]]) - 2.0 * _dot(ai_dot, aj_dot)
                )
            else:
                ai, ai_dot = A[where["ai"]], rate[where["ai"]]
                d = X[j, :3] + A[where["sj"]] - X[i, :3] - A[where["si"]]
                d_dot = V[j, :3] + rate[where["sj"]] - V[i, :3] - rate[where["si"]]
                d_quadratic = quadratic[where["sj"]] - quadratic[where["si"]]
                out[rows] = -(_dot(d, quadratic[where["ai"]]) + 2.0 * _dot(ai_dot, d_dot) + _dot(ai, d_quadratic))
        return out


class NormalizationGroup:
    """p_j^T p_j - 1 = 0 for every body (eq. 9.9): Psi_qj = [0, 2 p_j^T], gamma = -2 p_j'^T p_j'."""

    def __init__(self, elements: list[EulerNormalization]):
        self.elements = elements
        self.timed = ()
        self.j = np.array([e.j for e in elements], dtype=int)

    def terms(self, X):
        return None

    def psi_t(self, X, terms, t):
        return np.zeros(self.j.size)

    def constraints(self, X, terms, t):
        P = X[self.j, 3:]
        return np.einsum("ki,ki->k", P, P) - 1.0

    def jacobian(self, X, terms, t):
        jac_j = np.zeros((self.j.size, 7))
        jac_j[:, 3:] = 2.0 * X[self.j, 3:]
        return np.zeros((self.j.size, 7)), jac_j

    def gamma(self, X, V, terms, t):
        Pd = V[self.j, 3:]
        return -2.0 * np.einsum("ki,ki->k", Pd, Pd)


def make_groups(elements: list) -> tuple[list[tuple[object, list[int]]], list[int]]:
    """[(group, element indices)] for the joints made of basic constraints and for the normalizations,
    and the indices of the rest (drivers), which are evaluated element by element."""
    basic = (Spherical, Dot1, Dot2)
    joints = [k for k, e in enumerate(elements) if type(e) is Joint and all(type(p) in basic for p in e.parts)]
    normalizations = [k for k, e in enumerate(elements) if type(e) is EulerNormalization]
    groups = []
    if joints:
        groups.append((JointGroup([elements[k] for k in joints]), joints))
    if normalizations:
        groups.append((NormalizationGroup([elements[k] for k in normalizations]), normalizations))
    taken = set(joints) | set(normalizations)
    return groups, [k for k in range(len(elements)) if k not in taken]


__all__ = ["BodyVectors", "JointGroup", "NormalizationGroup", "make_groups"]
