"""Automatic assembly of the system equations from the elements of a model.

The constraint vector, its Jacobian, Psi_t and gamma of the whole system stack those of the elements
(course notes, eq. 4.1-4.4): element k owns rows ``rows[k]`` and writes its blocks into the columns of
its two bodies. Ground has no columns: its coordinates are the constant zero vector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .io.model import Model
from .planar.build import build_elements, initial_coordinates
from .planar.joints import PlanarElement

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
    elements: list[PlanarElement]

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
        psi = np.empty(self.n_constraints)
        for k, element in enumerate(self.elements):
            qi, qj = self._pair(k, q)
            psi[self.rows[k]] = element.constraints(qi, qj, t)
        return psi

    def jacobian(self, q: np.ndarray, t: float) -> np.ndarray:
        """Psi_q(q, t), the constraint Jacobian (m x n) (eq. 4.2)."""
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

    def psi_t(self, q: np.ndarray, t: float) -> np.ndarray:
        """Psi_t(q, t): nonzero only in driver rows (eq. 4.3)."""
        out = np.empty(self.n_constraints)
        for k, element in enumerate(self.elements):
            qi, qj = self._pair(k, q)
            out[self.rows[k]] = element.psi_t(qi, qj, t)
        return out

    def gamma(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        """gamma(q, q', t), right side of the acceleration equation Psi_q q'' = gamma (eq. 4.4)."""
        out = np.empty(self.n_constraints)
        for k, element in enumerate(self.elements):
            qi, qj = self._pair(k, q)
            qdi, qdj = self._pair(k, qd, self._ground_velocity)
            out[self.rows[k]] = element.gamma(qi, qj, qdi, qdj, t)
        return out


def build_system(model: Model) -> tuple[System, np.ndarray, np.ndarray]:
    """The assembled system of a model with the file's (approximate) q0 and q0'."""
    if model.dimension == 3:  # spatial elements; a planar scene never imports them
        from .spatial import build as spatial

        q0, qd0 = spatial.initial_coordinates(model)
        return System(model, spatial.build_elements(model)), q0, qd0
    q0, qd0 = initial_coordinates(model)
    return System(model, build_elements(model)), q0, qd0
