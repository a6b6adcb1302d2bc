"""Energy of a multibody system and its balance over a run (course notes, sec. 5.6).

With T = 1/2 q'^T M q' the kinetic energy and V(q) the potential of gravity and springs, the work
theorem for M q'' + Psi_q^T lambda = Q gives, along any motion,

    d/dt (T + V) = - P_dissipated + P_applied + P_constraints                         (eq. 5.60)

    P_dissipated = sum c l'^2 + sum c theta'^2              power taken out by dampers (>= 0)
    P_applied    = q'^T Q_applied                           actuators, point forces, torques, user forces
    P_constraints = -q'^T Psi_q^T lambda = lambda^T Psi_t   zero for joints, the work of the drivers

so the balance  E = T + V + D - W_applied - W_drivers  (D, W the time integrals of those powers)
stays at its initial value. A run computes D and W as extra states of its ODE (so they are as accurate
as the integration) and reports the error E(t) - E(0): in a conservative scene it is T + V - const.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .assembly import System
from .generalized_forces import ForceModel


def kinetic_energy(M: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """T = 1/2 q'^T M q' for one state (qd of shape (n,)) or a history (shape (N, n)) (eq. 5.2): the products
    M q' of every row by one matrix product."""
    return 0.5 * np.sum((qd @ M) * qd, axis=-1)


def potential_energy(forces: ForceModel, q: np.ndarray) -> np.ndarray:
    """V(q) of gravity and springs for one state or a history (rows)."""
    q = np.asarray(q)
    if q.ndim == 1:
        return np.array(forces.potential_energy(q))
    if not forces.elements:  # gravity alone: -Q_gravity^T q of every row at once
        return -(q @ forces.gravity)
    return np.array([forces.potential_energy(row) for row in q])


def driver_power(system: System, q: np.ndarray, lam: np.ndarray, t: float) -> float:
    """Power of the constraint forces -Psi_q^T lambda: -(Psi_q q')^T lambda = lambda^T Psi_t on the
    velocity constraints Psi_q q' = -Psi_t. Psi_t is zero in the rows of joints, which do no work: what
    is left is the power the drivers put in (eq. 5.61)."""
    return float(lam @ system.psi_t(q, t))


def constraint_power(jacobian: np.ndarray, qd: np.ndarray, lam: np.ndarray) -> float:
    """Power of the constraint forces -Psi_q^T lambda at any (q, q'): -(Psi_q q')^T lambda. On the
    velocity constraints it equals ``driver_power``; off them it also counts the work of the drift."""
    return -float((jacobian @ qd) @ lam)


@dataclass
class EnergyHistory:
    """Energies over a run (arrays on the output times) and the balance error."""

    kinetic: np.ndarray
    potential: np.ndarray
    dissipated: np.ndarray
    applied: np.ndarray
    drivers: np.ndarray

    @property
    def total(self) -> np.ndarray:
        """E = T + V + D - W_applied - W_drivers: constant along an exact motion (eq. 5.60)."""
        return self.kinetic + self.potential + self.dissipated - self.applied - self.drivers

    @property
    def error(self) -> np.ndarray:
        """E(t) - E(0)."""
        total = self.total
        return total - total[0]

    @property
    def scale(self) -> float:
        """An energy scale to judge the error against: the largest of T, |V - V(0)|, D, |W|."""
        parts = (self.kinetic, self.potential - self.potential[0], self.dissipated, self.applied, self.drivers)
        return float(max(np.abs(p).max() for p in parts)) or 1.0  # the array's max: no np.max dispatch (~2 us each)

    def columns(self) -> dict[str, np.ndarray]:
        """Result columns 'energy.kinetic', ..., 'energy.error'."""
        return {
            "energy.kinetic": self.kinetic,
            "energy.potential": self.potential,
            "energy.dissipated": self.dissipated,
            "energy.applied": self.applied,
            "energy.drivers": self.drivers,
            "energy.error": self.error,
        }


def energy_history(
    M: np.ndarray,
    forces: ForceModel,
    q: np.ndarray,
    qd: np.ndarray,
    dissipated: np.ndarray | None = None,
    applied: np.ndarray | None = None,
    drivers: np.ndarray | None = None,
    kinetic: np.ndarray | None = None,
    potential: np.ndarray | None = None,
) -> EnergyHistory:
    """The energies of a run from its q, q' histories and the accumulated D, W (zero when not given); ``kinetic``,
    ``potential``: T, V at every output time when the caller has them already (the compiled engine's,
    ``compiled.history``, ``compiled.element_history``)."""
    zero = np.zeros(len(q))
    if kinetic is None:  # a spatial model's M(q) (spatial/mass.py) knows its exact T(q, q')
        kinetic = M.kinetic_energy_history(q, qd) if callable(M) else kinetic_energy(M, qd)
    return EnergyHistory(
        kinetic=kinetic,
        potential=potential_energy(forces, q) if potential is None else potential,
        dissipated=zero if dissipated is None else np.asarray(dissipated),
        applied=zero if applied is None else np.asarray(applied),
        drivers=zero if drivers is None else np.asarray(drivers),
    )


def balance_error(history: EnergyHistory) -> tuple[float, float]:
    """(max |E(t) - E(0)|, the same divided by the energy scale)."""
    error = float(np.max(np.abs(history.error)))
    return error, error / history.scale


__all__ = [
    "EnergyHistory",
    "balance_error",
    "constraint_power",
    "driver_power",
    "energy_history",
    "kinetic_energy",
    "potential_energy",
]
