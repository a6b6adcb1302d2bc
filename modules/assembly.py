# Generated from solutions/assembly.py by `make modules` (every homework stubbed): do not edit by hand.
"""Automatic assembly of the system equations from the elements of a model.

The constraint vector, its Jacobian, Psi_t and gamma of the whole system stack those of the elements
(course notes, eq. 4.1-4.4): element k owns rows ``rows[k]`` and writes its blocks into the columns of
its two bodies. Ground has no columns: its coordinates are the constant zero vector.

Two ways to evaluate them, with the same results:

- the element loop (``System(model, elements, vectorized=False)``): one call of each element's method,
  its blocks added into the Jacobian by slices -- the definition, and the straightforward path;
- per type in one pass (the default): the elements of one type are evaluated together with array
  operations (``planar/batched.py``, ``spatial/batched.py``), and the Jacobian is scattered into place
  through index arrays found once from the sparsity pattern (which rows and columns each block
  fills). Each group is checked once against the element methods at a random state; a group that
  disagrees, or cannot be built, is evaluated by the element loop instead. Elements without a
  batched form (gears, cams, drivers of spatial joints) always are.

The batched forms stay with the instructor, like the compiled engine: a student package has none, and
its System evaluates every element by the loop (``batched_forms`` is None there).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

import numpy as np

from .elements import ConstraintElement
from .io.model import Model
from .linalg import largest
from .planar.build import build_elements, initial_coordinates

COORDINATES_PER_BODY = {2: 3, 3: 7}
"""Planar bodies have q_i = (x, y, phi); spatial bodies q_i = (x, y, z, e0, e1, e2, e3)."""

GROUND_COORDINATES = {2: np.zeros(3), 3: np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])}
COORDINATE_NAMES = {2: ("x", "y", "phi"), 3: ("x", "y", "z", "e0", "e1", "e2", "e3")}


@dataclass
class System:
    """A multibody system: its bodies' coordinates and its constraint elements.

    Planar and spatial systems share this assembly; only the elements (and the number of
    coordinates per body) differ.
    """

    model: Model
    elements: list[ConstraintElement]
    vectorized: bool = True

    def __post_init__(self):
        self.n_bodies = len(self.model.bodies)
        self.coordinates_per_body = COORDINATES_PER_BODY[self.model.dimension]
        self.n_coordinates = self.coordinates_per_body * self.n_bodies
        self.rows: list[slice] = []
        start = 0
        for element in self.elements:
            self.rows.append(slice(start, start + element.n_equations))
            start += element.n_equations
        self.n_constraints = start
        self._ground = GROUND_COORDINATES[self.model.dimension]
        self._ground_velocity = np.zeros(self.coordinates_per_body)
        self._columns = (
            [self._body_columns(e.i) for e in self.elements],
            [self._body_columns(e.j) for e in self.elements],
        )
        self.groups: list = []  # batched element groups, with their scatter indices
        self._timed_groups: list = []
        self._constant_rows = np.zeros(self.n_constraints * self.n_coordinates + 1)  # Psi_q's constant rows, flat
        self._last = None  # (bytes of q, its configuration): the one-entry cache of _configuration
        self._vectors = None  # planar groups: their body-frame vectors, rotated together (batched.RotatedVectors)
        self._loop = list(range(len(self.elements)))  # elements evaluated one by one
        if self.vectorized:
            self._make_groups()
        # whether Psi_t can be nonzero (drivers, or elements evaluated one by one); if not, Psi' = Psi_q q'
        self.rheonomic = bool(self._timed_groups) or bool(self._loop)

    # -- bookkeeping -------------------------------------------------------------------------
    @property
    def labels(self) -> list[str]:
        """One label per constraint row, e.g. 'O.x' for the x equation of joint O."""
        return [label for e in self.elements for label in e.labels]

    @property
    def row_owners(self) -> list[str]:
        """For each constraint row, the name of the joint or driver it belongs to."""
        return [e.name for e in self.elements for _ in e.labels]

    @property
    def coordinate_names(self) -> list[str]:
        names = COORDINATE_NAMES[self.model.dimension]
        return [f"{b.name}.{c}" for b in self.model.bodies for c in names]

    @property
    def degrees_of_freedom(self) -> int:
        """n - m: the count before any redundancy is taken into account."""
        return self.n_coordinates - self.n_constraints

    def _body_columns(self, body: int) -> slice | None:
        if body < 0:
            return None
        return slice(self.coordinates_per_body * body, self.coordinates_per_body * (body + 1))

    def _pair(self, k: int, x: np.ndarray, ground: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Coordinates (or velocities) of the two bodies of element k; ground's are constant."""
        ground = self._ground if ground is None else ground
        ci, cj = self._columns[0][k], self._columns[1][k]
        return (ground if ci is None else x[ci]), (ground if cj is None else x[cj])

    # -- the system arrays ---------------------------------------------------------------------
    def constraints(self, q: np.ndarray, t: float) -> np.ndarray:
        """Psi(q, t), the stacked constraint equations (eq. 4.1)."""
        return self._constraints(q, t, self._configuration(q))

    def jacobian(self, q: np.ndarray, t: float) -> np.ndarray:
        """Psi_q(q, t), the constraint Jacobian (m x n) (eq. 4.2)."""
        if not self.vectorized:
            return self._jacobian_by_slices(q, t)
        return self._jacobian(q, t, self._configuration(q))

    def psi_t(self, q: np.ndarray, t: float) -> np.ndarray:
        """Psi_t(q, t): nonzero only in driver rows (eq. 4.3)."""
        return self._psi_t(q, t)

    def gamma(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        """gamma(q, q', t), right side of the acceleration equation Psi_q q'' = gamma (eq. 4.4)."""
        return self._gamma(q, qd, t, self._configuration(q))

    def evaluate(
        self, q: np.ndarray, qd: np.ndarray, t: float, constraints: bool = True, psi_t: bool = True
    ) -> tuple[np.ndarray | None, np.ndarray, np.ndarray | None, np.ndarray]:
        """(Psi, Psi_q, Psi_t, gamma) at one state in one pass: what the groups share at q (rotated body
        vectors) is computed once. Psi and Psi_t are skipped (None) when not asked for."""
        if not self.vectorized:
            return (
                self.constraints(q, t) if constraints else None,
                self.jacobian(q, t),
                self.psi_t(q, t) if psi_t else None,
                self.gamma(q, qd, t),
            )
        state = self._configuration(q)
        return (
            self._constraints(q, t, state) if constraints else None,
            self._jacobian(q, t, state),
            self._psi_t(q, t) if psi_t else None,
            self._gamma(q, qd, t, state),
        )

    # -- one pass over the groups, then the elements left ------------------------------------------
    def _configuration(self, q: np.ndarray):
        """(X, terms of every group, rotated vectors) at q, or None without groups. The last one is kept:
        Newton-Raphson, the velocity and the acceleration analysis ask for Psi, Psi_q, Psi_t and gamma at the same q
        in turn.

        The cache key is q's bytes: equal bytes are equal values, and comparing them costs far less than
        np.array_equal. Planar groups have their body-frame vectors rotated together, once for all groups
        (``_vectors``: A v', B v', r_b and the points P of all of them; A v' and B v' kept for gamma's velocity
        terms)."""
        if not self.groups:
            return None
        key = np.asarray(q, dtype=float).tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        X = self._bodies(q, self._ground)
        if self._vectors is None:
            state = (X, [group.terms(X) for group in self.groups], None)
        else:
            A, B, R, P = self._vectors.configuration(X.ravel())
            terms = [group.terms_from(X, A, B, R, P) for group in self.groups]  # each from its rows (``place``)
            state = (X, terms, (A, B))
        self._last = (key, state)
        return state

    def _constraints(self, q, t, state) -> np.ndarray:
        psi = np.empty(self.n_constraints)
        if state is not None:
            X, terms, _ = state
            for group, shared in zip(self.groups, terms, strict=True):
                psi[group.rows] = group.constraints(X, shared, t)
        for k in self._loop:
            qi, qj = self._pair(k, q)
            psi[self.rows[k]] = self.elements[k].constraints(qi, qj, t)
        return psi

    def _jacobian(self, q, t, state) -> np.ndarray:
        """Psi_q scattered into place through the index arrays of the sparsity pattern (found once), on a copy of
        the entries that never change (``_constant_rows``: a revolute joint's +-I, drivers' angle and coordinate
        rows): each planar group gives the columns that depend on q (``group.columns``)."""
        flat = self._constant_rows.copy()  # the last entry takes ground's columns
        if state is not None:
            X, terms, _ = state
            for group, shared in zip(self.groups, terms, strict=True):
                if group.constant_jacobian:
                    continue
                jac_i, jac_j = group.jacobian(X, shared, t)
                flat[group.index_i] = jac_i  # the index arrays have the blocks' shapes
                flat[group.index_j] = jac_j
        for k in self._loop:
            qi, qj = self._pair(k, q)
            jac_i, jac_j = self.elements[k].jacobian(qi, qj, t)
            flat[self._index[k][0]] = np.ravel(jac_i)
            flat[self._index[k][1]] = np.ravel(jac_j)
        return flat[:-1].reshape(self.n_constraints, self.n_coordinates)

    def _jacobian_by_slices(self, q: np.ndarray, t: float) -> np.ndarray:
        """Psi_q element by element, each block added into its rows and body columns (the plain loop)."""
        jac = np.zeros((self.n_constraints, self.n_coordinates))
        for k, element in enumerate(self.elements):
            qi, qj = self._pair(k, q)
            jac_i, jac_j = element.jacobian(qi, qj, t)
            ci, cj = self._columns[0][k], self._columns[1][k]
            if ci is not None:
                jac[self.rows[k], ci] += jac_i
            if cj is not None:
                jac[self.rows[k], cj] += jac_j
        return jac

    def _psi_t(self, q, t) -> np.ndarray:
        out = np.zeros(self.n_constraints)
        for group in self._timed_groups:  # the groups' Psi_t depends on t alone (drivers)
            out[group.rows] = group.psi_t(None, None, t)
        for k in self._loop:
            qi, qj = self._pair(k, q)
            out[self.rows[k]] = self.elements[k].psi_t(qi, qj, t)
        return out

    def _gamma(self, q, qd, t, state) -> np.ndarray:
        out = np.zeros(self.n_constraints)
        if state is not None:
            X, terms, rotated = state
            V = self._bodies(qd, self._ground_velocity)
            if rotated is not None:  # planar groups: r', P', A v' phi'^2 and phi' of every vector at once
                moving = self._vectors.motion(V.ravel(), *rotated)
            else:  # spatial groups: each from the velocities
                moving = V
            for group, shared in zip(self.groups, terms, strict=True):
                if group.constant_jacobian and not group.time_dependent:
                    continue  # a constant Psi_q and no f(t): gamma = -(Psi_q q')_q q' - Psi_tt = 0 (eq. 4.4)
                out[group.rows] = group.gamma(X, moving, shared, t)
        for k in self._loop:
            qi, qj = self._pair(k, q)
            qdi, qdj = self._pair(k, qd, self._ground_velocity)
            out[self.rows[k]] = self.elements[k].gamma(qi, qj, qdi, qdj, t)
        return out

    # -- structure, found once -------------------------------------------------------------------
    def _bodies(self, x: np.ndarray, ground: np.ndarray) -> np.ndarray:
        """The (nb + 1, c) array of body coordinates (or velocities), ground's in the last row (index -1)."""
        X = np.empty((self.n_bodies + 1, self.coordinates_per_body))
        X[:-1] = x.reshape(self.n_bodies, self.coordinates_per_body)
        X[-1] = ground
        return X

    def _scatter_index(self, rows: np.ndarray, bodies: np.ndarray, columns=None) -> np.ndarray:
        """Flat indices into the (m x n) Jacobian of a (len(rows), len(columns)) block of rows for the given bodies.

        Entry (r, k) goes to row rows[r], column c * bodies[r] + columns[k] (columns: all c of a body by default);
        ground's entries (body -1) go to the spare last entry of the flat array, which is dropped.
        """
        c, n = self.coordinates_per_body, self.n_coordinates
        columns = np.arange(c) if columns is None else np.asarray(columns, dtype=int)
        index = rows[:, None] * n + c * bodies[:, None] + columns[None, :]
        index[bodies < 0] = self.n_constraints * n
        return index.ravel()

    def _make_groups(self) -> None:
        """Group the elements by type, find their scatter indices, and keep each group that agrees with the
        element methods at a random state; the other elements are evaluated one by one (all of them in a
        package without the batched forms)."""
        forms = batched_forms(self.model.dimension)
        try:
            groups, _ = forms.make_groups(self.elements) if forms is not None else ([], [])
        except Exception:  # noqa: BLE001 -- a group built on a function that raises (NotImplementedError): the loop
            groups = []
        rng = np.random.default_rng(20240607)
        q = self._random_coordinates(rng)
        qd, t = rng.standard_normal(self.n_coordinates), 0.3183
        self._index = []
        for k, element in enumerate(self.elements):
            rows = np.arange(self.rows[k].start, self.rows[k].stop)
            self._index.append(
                (
                    self._scatter_index(rows, np.full(rows.size, element.i)),
                    self._scatter_index(rows, np.full(rows.size, element.j)),
                )
            )
        kept, batched = [], set()
        for group, members in groups:
            group.rows = np.concatenate([np.arange(self.rows[k].start, self.rows[k].stop) for k in members])
            per_row = [k for k in members for _ in range(self.elements[k].n_equations)]
            bodies_i = np.array([self.elements[k].i for k in per_row])
            bodies_j = np.array([self.elements[k].j for k in per_row])
            columns = getattr(group, "columns", None)  # planar groups: the columns that depend on q; spatial: all
            group.index_i = self._scatter_index(group.rows, bodies_i, columns)
            group.index_j = self._scatter_index(group.rows, bodies_j, columns)
            group.constant_index = self._scatter_index(group.rows, bodies_i), self._scatter_index(group.rows, bodies_j)
            group.time_dependent = bool(getattr(group, "timed", ()))  # Psi_t nonzero somewhere
            if self._agrees(group, members, q, qd, t):
                kept.append(group)
                batched.update(members)
        self.groups = kept
        self._timed_groups = [group for group in kept if group.time_dependent]
        for group in kept:
            group.constant_jacobian = getattr(group, "constant_jacobian", False)  # spatial groups: none is
            if hasattr(group, "constant_blocks"):  # the entries of Psi_q that never change, written once
                for index, block in zip(group.constant_index, group.constant_blocks(), strict=True):
                    self._constant_rows[index] = np.ravel(block)
        self._constant_rows[-1] = 0.0  # ground's spare entry
        X = self._bodies(q, self._ground)
        for group in kept:  # the scatter indices in the shapes of the blocks ``jacobian`` returns
            block_i, block_j = group.jacobian(X, group.terms(X), t)
            group.index_i, group.index_j = (
                group.index_i.reshape(np.shape(block_i)),
                group.index_j.reshape(np.shape(block_j)),
            )
        if kept and self.model.dimension == 2:  # the groups' vectors placed in arrays of all (``Group.place``)
            self._vectors = forms.RotatedVectors(kept, self.n_bodies)
        self._loop = [k for k in range(len(self.elements)) if k not in batched]

    def _random_coordinates(self, rng: np.random.Generator) -> np.ndarray:
        q = rng.standard_normal(self.n_coordinates)
        if self.model.dimension == 3:  # unit Euler parameters, as on the constraint manifold
            p = q.reshape(self.n_bodies, 7)[:, 3:]
            p /= np.linalg.norm(p, axis=1, keepdims=True)
        return q

    def _agrees(self, group, members: list[int], q: np.ndarray, qd: np.ndarray, t: float) -> bool:
        """True when the group's Psi, Psi_q (its constant entries and those that depend on q), Psi_t and gamma
        equal the element methods' at (q, q', t)."""
        try:
            X, V = self._bodies(q, self._ground), self._bodies(qd, self._ground_velocity)
            if hasattr(group, "rotate"):  # planar: the group's own rotation, and P', A v' phi'^2, phi' from it
                A, B, R, P = group.rotate(X)
                terms = group.terms_from(X, A, B, R, P)
                moving = None if A is None else _planar_motion(V, group.ends, A, B)
            else:
                terms, moving = group.terms(X), V
            blocks = [np.ravel(block) for block in group.jacobian(X, terms, t)]
            if hasattr(group, "constant_blocks"):  # the whole rows: constant entries, then those that depend on q
                whole = [np.array(block, dtype=float) for block in group.constant_blocks()]
                for block, moving_columns in zip(whole, blocks, strict=True):
                    block[:, list(group.columns)] = moving_columns.reshape(block.shape[0], len(group.columns))
                blocks = [np.ravel(block) for block in whole]
            got = [group.constraints(X, terms, t), *blocks, group.psi_t(X, terms, t), group.gamma(X, moving, terms, t)]
            expected = [[], [], [], [], []]
            for k in members:
                element = self.elements[k]
                qi, qj = self._pair(k, q)
                qdi, qdj = self._pair(k, qd, self._ground_velocity)
                jac_i, jac_j = element.jacobian(qi, qj, t)
                expected[0].append(element.constraints(qi, qj, t))
                expected[1].append(np.ravel(jac_i))
                expected[2].append(np.ravel(jac_j))
                expected[3].append(element.psi_t(qi, qj, t))
                expected[4].append(element.gamma(qi, qj, qdi, qdj, t))
            expected = [np.concatenate(e) for e in expected]
            if any(np.shape(a) != np.shape(b) for a, b in zip(got, expected, strict=True)):
                return False
            return _close(np.concatenate([np.ravel(a) for a in got]), np.concatenate(expected))
        except Exception:  # noqa: BLE001 -- a stub (NotImplementedError) or a broken group: use the element loop
            return False


def _close(a: np.ndarray, b: np.ndarray, tolerance: float = 1e-9) -> bool:
    """``np.allclose(a, b, rtol=tolerance, atol=tolerance)``, the same verdict (|a - b| <= atol + rtol |b|, equal
    infinities close, NaN never) in one comparison of all a group's values: ``np.allclose`` costs 10-20 us a
    call, five a group, at every System's construction (a formulation's: issue 25)."""
    with np.errstate(invalid="ignore"):
        return bool(np.all((a == b) | (np.isfinite(b) & (np.abs(a - b) <= tolerance + tolerance * np.abs(b)))))


def _planar_motion(V: np.ndarray, ends: np.ndarray, A: np.ndarray, B: np.ndarray):
    """r', P', A v' phi'^2 and phi' of one planar group's rotated vectors (``planar.batched.motion``)."""
    from .planar.batched import motion  # only planar groups rotate vectors

    return motion(V, ends, A, B)


def batched_forms(dimension: int):
    """The module of the per-type (batched) forms of planar (2) or spatial (3) elements, imported when a System
    first groups its elements; None in a package without it (a student's: the forms stay with the instructor).
    """
    name = f"{__package__}.{'spatial' if dimension == 3 else 'planar'}.batched"
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as err:
        if err.name != name:  # a module the batched forms import is missing: a broken install, not a student's
            raise
        return None


def build_system(model: Model) -> tuple[System, np.ndarray, np.ndarray]:
    """The assembled system of a model with the file's (approximate) q0 and q0'."""
    if model.dimension == 3:  # spatial elements; a planar scene never imports them
        from .spatial import build as spatial

        q0, qd0 = spatial.initial_coordinates(model)
        return System(model, spatial.build_elements(model)), q0, qd0
    q0, qd0 = initial_coordinates(model)
    return System(model, build_elements(model)), q0, qd0


def mechanism_size(system: System, q: np.ndarray, extent: float | None = None) -> float:
    """L: the largest distance of a body centre or a joint point from the origin, at least 1 mm (``Guard``);
    ``extent``: the joint points' (``joint_extent``) where known."""
    extent = joint_extent(system.model) if extent is None else extent
    return max(largest(body_positions(system, q)), extent, 1e-3)


def body_positions(system: System, q: np.ndarray) -> np.ndarray:
    """The body centres' coordinates in q (planar x, y; spatial x, y, z)."""
    per, dim = system.coordinates_per_body, system.model.dimension
    return q.reshape(-1, per)[:, :dim]


def joint_extent(model) -> float:
    """The largest |coordinate| of a joint point: one array of all of them where they have one length (a model's
    dimension; 3 us where one max a joint took 3 us each: 49 us a run of the loop chain N = 4), else joint by
    joint. The same maximum either way."""
    points = [j["location"] for j in model.joints if "location" in j]
    if not points:
        return 0.0
    try:
        return float(np.abs(np.array(points, dtype=float)).max())
    except ValueError:  # points of different lengths
        return max(float(np.max(np.abs(np.asarray(p, dtype=float)))) for p in points)
