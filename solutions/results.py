"""The result of an analysis: time history of q, q', q'', multipliers, reactions and how it was got."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

DERIVED = ("residual.", "energy.")
"""Prefixes of the result columns every dynamic run makes (constraint residuals, energies), not coordinates."""


@dataclass
class Result:
    """Time history on the output grid ``t`` (N points) of an analysis.

    q, qd, qdd have shape (N, n) with columns ``coordinate_names``; ``lam`` (N, m) holds the Lagrange
    multipliers when the analysis computes them; ``reactions`` maps a column name such as 'O.Fx' to
    its (N,) history; ``points`` likewise holds requested body points ('P.x', 'P.x_d', ...).
    ``info`` says how the result was obtained (analysis, tolerances, steps,
    evaluations, wall time, max constraint residual, ...).
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    coordinate_names: list[str]
    body_names: list[str]
    lam: np.ndarray | None = None
    points: dict[str, np.ndarray] = field(default_factory=dict)
    reactions: dict[str, np.ndarray] = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    def coordinate(self, name: str, derivative: int = 0) -> np.ndarray:
        """History of one coordinate, e.g. ``result.coordinate('slider.x', 1)`` for its velocity.

        Raises
        ------
        ValueError
            If ``name`` is not a coordinate of the result; the message lists the ones it has.
        """
        if name not in self.coordinate_names:
            raise ValueError(f"no coordinate {name!r} (coordinates: {', '.join(self.coordinate_names)})")
        k = self.coordinate_names.index(name)
        return (self.q, self.qd, self.qdd)[derivative][:, k]
