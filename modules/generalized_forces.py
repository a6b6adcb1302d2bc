# Generated from solutions/generalized_forces.py by `make modules` (every homework stubbed): do not edit by hand.
"""The generalized force vector Q(q, q', t) of the equations of motion M q'' + Psi_q^T lambda = Q.

Q sums the contributions of every force element into the rows of its bodies (course notes, eq. 5.16),
just as the constraint Jacobian stacks the joints' blocks:

    Q = Q_gravity + sum over elements e of [ Q_i^e in the rows of body i, Q_j^e in those of body j ]
        + sum of user force callables

Gravity's part is constant in planar body coordinates, so it is computed once; a scene with gravity
only, or with no forces at all, never runs the element loop. The same ``ForceModel`` gives the
energies of the balance  T + V + (energy dissipated) - (work applied) = const:  the potential V of
gravity and springs, the power taken out by dampers and the power put in by actuators and loads.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .io.model import Model
from .planar.build import force_elements
from .planar.forces import ForceElement, gravity_force

UserForce = Callable[[np.ndarray, np.ndarray, float], np.ndarray]
"""A user force: Q_user(q, q', t), an (n,) array of generalized forces, counted as applied work."""


def gravity_vector(model: Model) -> np.ndarray:
    """Q_gravity: [m_k g_x, m_k g_y, 0] for every body k, stacked (eq. 5.11)."""
    raise NotImplementedError('gravity_vector: Q_gravity: [m_k g_x, m_k g_y, 0] for every body k, stacked, see eq. 5.11')


@dataclass
class ForceModel:
    """The applied forces of a planar model: constant gravity, force elements, user callables."""

    n_coordinates: int
    gravity: np.ndarray
    elements: list[ForceElement] = field(default_factory=list)
    user_forces: list[UserForce] = field(default_factory=list)

    def __post_init__(self):
        self._ground = np.zeros(3)

    # -- what the scene has --------------------------------------------------------------------
    @property
    def is_empty(self) -> bool:
        """True when Q is identically zero: no gravity, no element, no user force."""
        return not (np.any(self.gravity) or self.elements or self.user_forces)

    @property
    def is_constant(self) -> bool:
        """True when Q is gravity alone (or zero): independent of q, q' and t."""
        return not (self.elements or self.user_forces)

    @property
    def is_conservative(self) -> bool:
        """True when every force has a potential: gravity and undamped, unactuated springs."""
        return not self.user_forces and all(e.is_conservative for e in self.elements)

    def add(self, force: UserForce) -> ForceModel:
        """Add a user force callable Q_user(q, q', t) -> (n,) array; returns self."""
        self.user_forces.append(force)
        return self

    # -- Q -------------------------------------------------------------------------------------
    def _pair(self, element: ForceElement, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xi = self._ground if element.i < 0 else x[3 * element.i : 3 * element.i + 3]
        xj = self._ground if element.j < 0 else x[3 * element.j : 3 * element.j + 3]
        return xi, xj

    def generalized_forces(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        """Q(q, q', t), the (n,) generalized force vector (eq. 5.16)."""
        Q = self.gravity.copy()
        if self.is_constant:
            return Q
        raise NotImplementedError("ForceModel.generalized_forces: Q(q, q', t), the (n,) generalized force vector, see eq. 5.16")
        for force in self.user_forces:
            Q += force(q, qd, t)
        return Q

    def element_state(self, element: ForceElement, q: np.ndarray, qd: np.ndarray) -> tuple:
        """(q_i, q_j, q_i', q_j') of an element's two bodies (ground's for -1)."""
        return (*self._pair(element, q), *self._pair(element, qd))

    # -- energies ------------------------------------------------------------------------------
    def potential_energy(self, q: np.ndarray) -> float:
        """V(q) = -sum_k m_k g^T r_k + sum of spring potentials (eq. 5.20).

        Gravity's part is -Q_gravity^T q: Q_gravity is zero in the angle rows.
        """
        energy = -float(self.gravity @ q)
        for e in self.elements:
            energy += e.potential(*self._pair(e, q))
        return energy

    def dissipated_power(self, q: np.ndarray, qd: np.ndarray, t: float) -> float:
        """Power taken out by the dampers, sum c l'^2 + sum c theta'^2 (>= 0)."""
        return sum(e.dissipated_power(*self._pair(e, q), *self._pair(e, qd), t) for e in self.elements)

    def powers(self, q: np.ndarray, qd: np.ndarray, t: float) -> tuple[float, float]:
        """(dissipated_power, actuator_power) in one pass over the elements."""
        dissipated = applied = 0.0
        for e in self.elements:
            d, a = e.powers(*self._pair(e, q), *self._pair(e, qd), t)
            dissipated, applied = dissipated + d, applied + a
        for force in self.user_forces:
            applied += float(qd @ force(q, qd, t))
        return dissipated, applied

    def actuator_power(self, q: np.ndarray, qd: np.ndarray, t: float) -> float:
        """Power put in by actuators, point forces, torques and user forces (q'^T Q of those forces)."""
        power = sum(e.applied_power(*self._pair(e, q), *self._pair(e, qd), t) for e in self.elements)
        for force in self.user_forces:
            power += float(qd @ force(q, qd, t))
        return power


def element_columns(forces, t: np.ndarray, q: np.ndarray, qd: np.ndarray) -> dict[str, np.ndarray]:
    """Result columns of every force element e of a planar or spatial force model over a run (rows of q, q'):
    what it exerts ('E.force', the tension of a spring-damper-actuator, positive pulling; 'E.torque' of a
    rotational one or of a planar torque; 'E.Fx' .. of a point force, 'E.Mx' .. of a spatial torque, global)
    and 'E.power' = q_i'^T Q_i^e + q_j'^T Q_j^e, the power it puts into the bodies (eq. 5.60: -f l' for a
    spring-damper; the powers of all elements and the drivers add up to d(T + V_gravity)/dt)."""
    columns: dict[str, list[float]] = {}
    for e in forces.elements:
        for k in range(len(t)):
            state = forces.element_state(e, q[k], qd[k])
            for suffix, value in e.measures(*state, t[k]).items():
                columns.setdefault(f"{e.name}.{suffix}", []).append(value)
            Qi, Qj = e.forces(*state, t[k])
            columns.setdefault(f"{e.name}.power", []).append(float(state[2] @ Qi + state[3] @ Qj))
    return {name: np.array(values) for name, values in columns.items()}


def build_forces(model: Model, user_forces: list[UserForce] | None = None) -> ForceModel:
    """The ForceModel of a planar model: gravity, its spring-dampers and loads, and optional user forces."""
    if model.dimension == 3:  # spatial elements, and the quadratic-velocity term of M(q)
        from .spatial.forces import build_forces as build_spatial_forces

        return build_spatial_forces(model, user_forces)
    n = 3 * len(model.bodies)
    return ForceModel(n, gravity_vector(model), force_elements(model), list(user_forces or []))


__all__ = ["ForceModel", "UserForce", "build_forces", "element_columns", "gravity_vector"]
