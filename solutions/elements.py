"""The constraint element: the interface every planar and spatial joint and driver declares.

An element connects body i and body j (either may be ground, body -1) and contributes m rows to the system's
constraint equations (course notes, ch. 4), each a function of the two bodies' coordinates and time only:

- ``constraints(q_i, q_j, t)``        Psi, the constraint equations Psi(q_i, q_j, t) = 0      (m,)   eq. 4.1
- ``jacobian(q_i, q_j, t)``           (Psi_qi, Psi_qj), its two blocks of the Jacobian Psi_q  (m, n_i) twice, eq. 4.2
- ``psi_t(q_i, q_j, t)``              Psi_t = dPsi/dt: zero for a joint, nonzero for a driver (m,)   eq. 4.3;
                                      the right side of the velocity equation is nu = -Psi_t  (eq. 4.5)
- ``gamma(q_i, q_j, q_i', q_j', t)``  gamma = -(Psi_q q')_q q' - 2 Psi_qt q' - Psi_tt, the right side of
                                      the acceleration equation Psi_q q'' = gamma             (m,)   eq. 4.4

with n_i coordinates per body (3 planar, 7 spatial; ground's are constant and get no columns). ``labels``
names the rows ('O.x' for the x row of joint O) and sets m. The system (``assembly.System``) stacks the rows
of its elements; nothing else about an element is assumed. ``planar.joints.PlanarElement`` and
``spatial.joints.SpatialElement`` are this element with their coordinates.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np


@dataclass
class ConstraintElement(ABC):
    """A constraint element (module docstring): its name, the two bodies (-1 is ground) and its row labels."""

    name: str
    i: int
    j: int
    labels: tuple[str, ...] = field(default=(), init=False)

    @property
    def n_equations(self) -> int:
        """m, the number of constraint rows."""
        return len(self.labels)

    @abstractmethod
    def constraints(self, qi: np.ndarray, qj: np.ndarray, t: float) -> np.ndarray:
        """Psi(q_i, q_j, t) (m,) (eq. 4.1)."""

    @abstractmethod
    def jacobian(self, qi: np.ndarray, qj: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(Psi_qi, Psi_qj), the two (m, n_i) blocks of Psi_q (eq. 4.2)."""

    def psi_t(self, qi: np.ndarray, qj: np.ndarray, t: float) -> np.ndarray:
        """Psi_t = 0: a joint does not depend explicitly on time (eq. 4.3)."""
        return np.zeros(self.n_equations)

    @abstractmethod
    def gamma(self, qi: np.ndarray, qj: np.ndarray, qdi: np.ndarray, qdj: np.ndarray, t: float) -> np.ndarray:
        """gamma, the right side of Psi_q q'' = gamma (m,) (eq. 4.4)."""


__all__ = ["ConstraintElement"]
