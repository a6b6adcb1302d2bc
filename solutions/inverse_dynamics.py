"""Inverse dynamics: the driver efforts and joint reactions that make a fully driven mechanism move.

When the drivers leave no degree of freedom, the motion q(t), q'(t), q''(t) follows from kinematics
alone (course notes, ch. 4). The equations of motion (eq. 5.25)

    M q'' + Psi_q^T lambda = Q

then have only lambda unknown: with Psi_q square and regular (the condition for the kinematic
analysis to run at all),

    Psi_q^T lambda = Q - M q''                                            (eq. 5.80)

one linear solve per output time, with no integration and no inverse of M. The driver rows of lambda
give the driver forces and torques, the joint rows the reactions (``reactions.py``).
"""

from __future__ import annotations

import time as _time

import numpy as np
import scipy.linalg

from .assembly import System
from .generalized_forces import ForceModel, build_forces, element_columns
from .kinematics import kinematic_analysis
from .mass_matrix import mass_at, mass_matrix
from .reactions import driver_efforts, joint_reactions
from .results import Result


def multipliers(jacobian: np.ndarray, M: np.ndarray, qdd: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """lambda from Psi_q^T lambda = Q - M q'' (eq. 5.80); Psi_q is square and regular here."""
    ### BEGIN SOLUTION hw2
    return scipy.linalg.solve(jacobian.T, Q - M @ qdd)
    ### END SOLUTION


def inverse_dynamics(
    system: System,
    q0: np.ndarray,
    t_end: float,
    steps: int,
    forces: ForceModel | None = None,
    masses: np.ndarray | None = None,
) -> Result:
    """Driver efforts and every joint reaction on the grid t = 0, t_end/steps, ..., t_end.

    Parameters
    ----------
    system : assembled system whose drivers leave no degree of freedom
    q0 : approximate configuration at t = 0 (assembled by the kinematic analysis)
    t_end, steps : output grid
    forces, masses : the applied forces and the mass matrix; by default built from ``system.model``

    Returns
    -------
    Result
        The kinematic result with ``lam`` (N, m) filled, ``reactions`` holding ``JOINT.Fx JOINT.Fy
        JOINT.Mz`` for every joint and driver and ``DRIVER.effort`` for every driver (the torque or
        force along what it drives), and ``info['max_equation_residual']``, the largest
        |M q'' + Psi_q^T lambda - Q| over the run.

    Raises
    ------
    AnalysisError
        When the mechanism is not fully driven, is redundant, or locks up (from the kinematic analysis).
    """
    start = _time.perf_counter()
    if masses is None:
        system.model.require_masses("inverse")
    result = kinematic_analysis(system, q0, t_end, steps)
    M = mass_matrix(system.model) if masses is None else masses
    forces = build_forces(system.model) if forces is None else forces
    lam = np.empty((result.t.size, system.n_constraints))
    efforts: dict[str, list[float]] = {}
    residual = 0.0
    for k, t in enumerate(result.t):
        q, qd, qdd = result.q[k], result.qd[k], result.qdd[k]
        jacobian = system.jacobian(q, t)
        Q = forces.generalized_forces(q, qd, t)
        Mk = mass_at(M, q)  # constant for a planar model, M(q) for a spatial one
        lam[k] = multipliers(jacobian, Mk, qdd, Q)
        residual = max(residual, float(np.max(np.abs(Mk @ qdd + jacobian.T @ lam[k] - Q), initial=0.0)))
        for name, value in driver_efforts(system, q, lam[k], t).items():
            efforts.setdefault(name, []).append(value)
    result.lam = lam
    result.reactions = joint_reactions(system, result.q, lam, result.t)
    result.reactions.update({f"{name}.effort": np.array(values) for name, values in efforts.items()})
    result.forces = element_columns(forces, result.t, result.q, result.qd)
    result.info.update(
        analysis="inverse",
        max_equation_residual=residual,
        wall_time=_time.perf_counter() - start,
    )
    return result


__all__ = ["inverse_dynamics", "multipliers"]
