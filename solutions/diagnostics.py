"""Diagnostics by name: degrees of freedom, redundant constraints, singular configurations.

All of them read the singular value decomposition of the Jacobian, Psi_q = U S V^T (course notes,
eq. 4.20): the numerical rank r counts the independent constraints, n - r is the number of degrees
of freedom, and the left singular vectors of the zero (or tiny) singular values tell which constraint
rows depend on each other, hence which joints are redundant or locked.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


class AnalysisError(RuntimeError):
    """An analysis that cannot go on, with a message that says why and what to do."""


class SingularConfigurationError(AnalysisError):
    """A run stopped at a singular configuration of Psi_q (``formulation="auto"`` then takes a formulation
    that passes it: the augmented Lagrangian one)."""


@dataclass
class RankReport:
    """What the SVD of Psi_q says about a configuration."""

    n_coordinates: int
    n_constraints: int
    rank: int
    singular_values: np.ndarray
    redundant_joints: list[str]

    @property
    def degrees_of_freedom(self) -> int:
        return self.n_coordinates - self.rank

    @property
    def n_redundant(self) -> int:
        return self.n_constraints - self.rank

    @property
    def condition_number(self) -> float:
        s = self.singular_values
        return float(s[0] / s[-1]) if s.size and s[-1] > 0 else float("inf")


def involved_joints(vectors: np.ndarray, row_owner: list[str], share: float = 1e-6) -> list[str]:
    """Joints whose rows carry a visible share of the given left singular vectors (columns)."""
    weight = np.sqrt(np.sum(vectors**2, axis=1)) if vectors.ndim == 2 else np.abs(vectors)
    names: list[str] = []
    for row in np.flatnonzero(weight > share * max(weight.max(initial=0.0), 1e-300)):
        if row_owner[row] not in names:
            names.append(row_owner[row])
    return names


def rank_report(jacobian: np.ndarray, row_owner: list[str], rtol: float = 1e-9) -> RankReport:
    """Numerical rank of Psi_q (singular values above rtol * largest) and the redundant joints."""
    m, n = jacobian.shape
    u, s, _ = np.linalg.svd(jacobian)
    rank = int(np.sum(s > rtol * s[0])) if s.size and s[0] > 0 else 0
    redundant = involved_joints(u[:, rank:], row_owner) if m > rank else []
    padded = np.concatenate([s, np.zeros(max(0, min(m, n) - s.size))])
    return RankReport(n, m, rank, padded, redundant)


def singular_joints(jacobian: np.ndarray, row_owner: list[str]) -> tuple[float, list[str]]:
    """Condition number of Psi_q and the joints in its weakest direction (for lock-up reports)."""
    u, s, _ = np.linalg.svd(jacobian)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
    if jacobian.shape[0] > s.size:  # more rows than columns: include the whole left null space
        return cond, involved_joints(u[:, s.size - 1 :], row_owner, share=0.1)
    return cond, involved_joints(u[:, -1], row_owner, share=0.1)
