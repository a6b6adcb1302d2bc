"""The result of an analysis: time history of q, q', q'', multipliers, reactions and how it was got."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TypedDict

import numpy as np

DERIVED = ("residual.", "energy.")
"""Prefixes of the result columns every dynamic run makes (constraint residuals, energies), not coordinates."""

Progress = Callable[[float], None]
"""``progress(t)``: told each output time t an analysis has reached (``forward_dynamics``, ``kinematic_analysis``)."""


class Info(TypedDict, total=False):
    """How a result was obtained (DESIGN section 5): the keys every analysis may write, with their types.

    Each analysis writes the keys of its record below and no others (``tests/solutions/test_results.py``
    checks every analysis, engine and formulation against them)."""

    analysis: str
    """'kinematic', 'dynamic' or 'inverse'."""
    steps: int
    assembly: dict
    """The assembly at t = 0 (``kinematics.assemble``): residual, Newton iterations, how far each body moved."""
    max_constraint_residual: float
    wall_time: float
    warnings: list[str]
    notes: list[str]
    chosen: dict
    """What ``auto`` chose and why: the method (``formulation``, ``integrator``, ``why``), the engine
    (``engine``, ``engine_why``)."""


class KinematicInfo(Info, total=False):
    """A kinematic analysis (``kinematics.kinematic_analysis``)."""

    newton_iterations: int
    singular_positions: list[dict]
    """With through_singular: each singular position passed (t, the output times around it, joints)."""


class InverseInfo(KinematicInfo, total=False):
    """An inverse dynamic analysis (``inverse_dynamics.inverse_dynamics``)."""

    max_equation_residual: float
    """max |M q'' + Psi_q^T lambda - Q| over the run."""


class DynamicInfo(Info, total=False):
    """A forward dynamic analysis (``dynamics.forward_dynamics``)."""

    formulation: str
    integrator: str
    rtol: float
    atol: float
    step: float | None
    rtol_rule: str
    """How the default rtol followed from the accuracy and the motion's periods (``dynamics.default_rtol``)."""
    rhs_evaluations: int
    integrator_steps: int
    rejected_steps: int
    restarts: int
    """How often the integrator started afresh after a correction of the state (projection, ...)."""
    restarted: dict
    """``auto``'s run made again from t = 0 with another formulation (``SingularStop``): the time the first one
    stopped at ``t``, its formulation ``stopped`` and why (``why``: 'singular configuration', ...), the new
    ``formulation``."""
    stiffness: str | None
    closest_singularity: dict | None
    singular_positions: list[dict]
    """Each singular position passed (t, ratio, joints) and the branch the motion took there ('branch': 'kept', or
    'cannot tell' when the output times are too coarse to judge: ``guard.Guard.check_branches``)."""
    max_velocity_residual: float
    energy_drift: float
    energy_drift_relative: float
    accuracy_estimate: dict | None
    """The estimated errors (``dynamics.accuracy_estimate``): positions (m), velocities and energy (relative)."""
    held_rtol: float
    """The tightest rtol the run's formulation holds in double precision (``dynamics.HELD_RTOL`` or its own)."""
    divergence: dict
    """The position error (m) estimated from a second run at 100 x rtol (``dynamics.judge_divergence``, eqs.
    6.62-6.63): ``positions``, ``how``, ``measured_until``, ``growth``, ``doubling_time`` (chaotic motion); or
    ``positions`` None and ``why`` no second run was made."""
    tightened: dict
    """A run at the default rtol made again at ``rtol`` (eq. 6.64), the first (at ``was``) estimated ``estimate`` m
    off, more than ``bound`` (accuracy x size)."""
    initial_conditions: dict
    """How far assembly and the velocity projection moved the file's initial state."""
    compiled: dict
    """The compiled engine's start: ``cached``, ``load_seconds``."""
    alpha: float
    beta: float
    repartitions: int
    partitions: list
    projections: int
    unconverged_iterations: int
    augmented_iterations: int
    """The augmented Lagrangian's iterations of eq. 5.52 over the run (``AugmentedLagrangian.converged``)."""


class Index3Info(DynamicInfo, total=False):
    """A forward dynamic analysis by an implicit index-3 method (``implicit.integrate_index3``, eq. 6.52)."""

    rho_inf: float
    alpha_m: float
    alpha_f: float
    gamma: float
    newton_iterations: int
    newton_failures: int
    tangent_updates: int
    factorizations: int


@dataclass
class Result:
    """Time history on the output grid ``t`` (N points) of an analysis.

    q, qd, qdd have shape (N, n) with columns ``coordinate_names``; ``lam`` (N, m) holds the Lagrange
    multipliers when the analysis computes them; ``reactions`` maps a column name such as 'O.Fx' to
    its (N,) history; ``points`` likewise holds requested body points ('P.x', 'P.x_d', ...); ``forces`` what
    each force element exerts and its power ('SPRING.force', 'SPRING.power', ...: ``element_columns``) in the
    analyses that have forces (dynamic, inverse).
    ``info`` says how the result was obtained (``Info``: ``KinematicInfo``, ``DynamicInfo``, ...).
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
    forces: dict[str, np.ndarray] = field(default_factory=dict)
    info: Info = field(default_factory=Info)

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

    def summary(self) -> dict[str, float]:
        """The run in a few numbers, by name: the final time, the final q and q' of every coordinate, the largest
        |lambda| and reaction (when the analysis computes them), the largest constraint residual and the largest
        energy error |E(t) - E(0)| (a dynamic run). The golden summaries of the example models
        (``tests/solutions/golden_summaries.json``, ``make golden``) are these numbers."""
        out = {"t_end": float(self.t[-1])}
        for k, name in enumerate(self.coordinate_names):
            out[f"q.{name}"] = float(self.q[-1, k])
            out[f"qd.{name}"] = float(self.qd[-1, k])
        if self.lam is not None and self.lam.size:
            out["max_abs_lambda"] = float(np.max(np.abs(self.lam)))
        if self.reactions:
            out["max_abs_reaction"] = float(max(np.max(np.abs(column)) for column in self.reactions.values()))
        if "max_constraint_residual" in self.info:
            out["max_constraint_residual"] = float(self.info["max_constraint_residual"])
        if "energy.error" in self.points:
            out["energy_drift"] = float(np.max(np.abs(self.points["energy.error"])))
        return out
