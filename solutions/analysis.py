"""Which analysis a run is, and running it: kinematic, forward dynamic or inverse dynamic (``mbd run``, sweeps).

A model file's ``simulation`` block (with the command line's options over it: ``settings.read_settings``)
names the analysis; ``auto`` takes the kinematic analysis when the drivers leave no degree of freedom (the
rank of the Jacobian of constraints and drivers equals the number of coordinates), the dynamic one otherwise.
"""

from __future__ import annotations

import numpy as np

from .assembly import System
from .diagnostics import AnalysisError, rank_report
from .dynamics import forward_dynamics
from .kinematics import assemble, kinematic_analysis, point_columns
from .results import Progress, Result
from .settings import ANALYSES, Settings


def choose_analysis(system: System, q: np.ndarray) -> str:
    """``analysis="auto"``: kinematic when the drivers leave no degree of freedom, dynamic otherwise."""
    report = rank_report(system.jacobian(q, 0.0), system.row_owners)
    return "kinematic" if report.degrees_of_freedom == 0 else "dynamic"


def run_analysis(
    system: System,
    q0: np.ndarray,
    qd0: np.ndarray,
    settings: Settings,
    points: dict | None = None,
    progress: Progress | None = None,
) -> Result:
    """The analysis ``settings.analysis`` names, over ``settings.t_end`` in ``settings.steps`` output intervals;
    ``points`` {label: (body index, body-frame point)} become result columns in every analysis; ``progress(t)``
    is told each output time reached (kinematic and forward dynamics on the numpy engine)."""
    analysis = settings.analysis
    if analysis == "auto":
        q, _ = assemble(system, q0)
        analysis = choose_analysis(system, q)
    if analysis == "kinematic":
        return kinematic_analysis(
            system, q0, settings.t_end, settings.steps, points=points, through_singular=settings.through_singular,
            engine=settings.engine, progress=progress,
        )  # fmt: skip
    if analysis == "dynamic":
        return forward_dynamics(
            system, q0, qd0, settings.t_end, settings.steps, settings=settings, points=points, progress=progress
        )
    if analysis == "inverse":
        from .inverse_dynamics import inverse_dynamics

        result = inverse_dynamics(system, q0, settings.t_end, settings.steps)
        for label, (body, point) in (points or {}).items():
            result.points.update(point_columns(result, label, body, point))
        return result
    raise AnalysisError(f"analysis {analysis!r}: not available (one of: {', '.join(ANALYSES)})")
