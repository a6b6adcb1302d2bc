"""Forward dynamics: the motion of a mechanism under forces, from consistent initial conditions.

A run (course notes, chapter 6):

1. **Consistent initial conditions.** The file's configuration is assembled, Psi(q0, 0) = 0, by
   Newton-Raphson; the file's velocities are projected onto Psi_q q' = -Psi_t with the correction
   of least kinetic-energy norm. The result's info reports how far both moved.
2. **Integration.** The chosen formulation (``formulations.py``) turns M q'' + Psi_q^T lambda = Q,
   Psi_q q'' = gamma into a first-order ODE y' = f(t, y), which the chosen integrator
   (``integrators.py``) advances. When the scene has dampers, actuators, loads or drivers, the
   dissipated energy and the work put in are integrated with it as three extra states, for the
   energy balance (``energy.py``).
3. **Output.** At every output time: q, q', q'', lambda, the constraint residuals |Psi| and
   |Psi_q q' + Psi_t|, the energies and the balance error E(t) - E(0).

The mass matrix is built once and the force loop is skipped for a scene with gravity only.
"""

from __future__ import annotations

import time as _time

import numpy as np

from .assembly import System
from .diagnostics import AnalysisError, rank_report
from .energy import driver_power, energy_history
from .formulations import FORMULATIONS, Formulation, make_formulation
from .generalized_forces import ForceModel, build_forces
from .integrators import INTEGRATORS, integrate
from .kinematics import assemble, point_columns
from .mass_matrix import mass_at, mass_matrix
from .reactions import joint_reactions
from .results import Result

INDEX3_INTEGRATORS = ("hht", "generalized-alpha")
"""Implicit integrators of the index-3 form (``implicit.py``); they take the place of formulation + ODE."""
MULTISTEP_INTEGRATORS = ("BDF", "LSODA")


def consistent_initial_conditions(
    system: System, M: np.ndarray, q0: np.ndarray, qd0: np.ndarray, t: float = 0.0
) -> tuple[np.ndarray, np.ndarray, dict]:
    """q on Psi(q, t) = 0 (assembly) and q' on Psi_q q' + Psi_t = 0, with a report of the corrections.

    The velocity correction is the one of least kinetic-energy norm (eq. 6.2):

        q' = q0' - M^-1 Psi_q^T x,   (Psi_q M^-1 Psi_q^T) x = Psi_q q0' + Psi_t

    solved in the least-squares sense, so redundant constraints are fine.
    """
    q, assembly = assemble(system, q0, t)
    jacobian = system.jacobian(q, t)
    residual = jacobian @ qd0 + system.psi_t(q, t)
    weighted = np.linalg.solve(mass_at(M, q), jacobian.T)
    x = np.linalg.lstsq(jacobian @ weighted, residual, rcond=None)[0]
    qd = qd0 - weighted @ x
    report = {
        "assembly": assembly,
        "velocity_residual_before": float(np.max(np.abs(residual), initial=0.0)),
        "velocity_correction": float(np.max(np.abs(qd - qd0), initial=0.0)),
        "velocity_residual": float(np.max(np.abs(jacobian @ qd + system.psi_t(q, t)), initial=0.0)),
    }
    return q, qd, report


class EquationsOfMotion:
    """The ODE an integrator advances: the formulation's state, plus (when the scene needs them) three
    accumulated energies z = (y, D, W_applied, W_drivers) with D' = P_dissipated, W' = P (eq. 5.60)."""

    def __init__(self, formulation: Formulation, forces: ForceModel, has_drivers: bool):
        self.formulation, self.forces = formulation, forces
        self.has_drivers = has_drivers
        self.extra = 0 if forces.is_conservative and not has_drivers else 3

    def initial_state(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        return np.concatenate([self.formulation.initial_state(q, qd, t), np.zeros(self.extra)])

    def split(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        k = z.size - self.extra
        return z[:k], z[k:]

    def powers(self, q, qd, lam, t) -> list[float]:
        """(P_dissipated, P_applied, P_drivers) at one state."""
        drivers = driver_power(self.formulation.system, q, lam, t) if self.has_drivers else 0.0
        return [*self.forces.powers(q, qd, t), drivers]

    def rhs(self, t: float, z: np.ndarray) -> np.ndarray:
        if not self.extra:
            return self.formulation.rhs(t, z)
        y, _ = self.split(z)
        q, qd = self.formulation.coordinates(t, y)
        qdd, lam = self.formulation.accelerations(q, qd, t)
        return np.concatenate([self.formulation.state_derivative(q, qd, qdd), self.powers(q, qd, lam, t)])

    def after_step(self, t: float, z: np.ndarray) -> np.ndarray | None:
        y, energies = self.split(z)
        corrected = self.formulation.after_step(t, y)
        return None if corrected is None else np.concatenate([corrected, energies])


def forward_dynamics(
    system: System,
    q0: np.ndarray,
    qd0: np.ndarray,
    t_end: float,
    steps: int,
    formulation: str = "baumgarte",
    integrator: str = "RK45",
    rtol: float = 1e-8,
    atol: float = 1e-10,
    step: float | None = None,
    *,
    masses: np.ndarray | None = None,
    forces: ForceModel | None = None,
    points: dict[str, tuple[int, np.ndarray]] | None = None,
    **options,
) -> Result:
    """The motion on the output grid t = 0, t_end/steps, ..., t_end.

    Parameters
    ----------
    system : the assembled system; q0, qd0 its (approximate) initial coordinates and velocities
    formulation : one of ``baumgarte``, ``partitioning``, ``qr``, ``svd``, ``projection``
    integrator : a ``solve_ivp`` method (RK45, RK23, DOP853, Radau, BDF, LSODA), ``rk4``, or an
        implicit index-3 method (``hht``, ``generalized-alpha``)
    rtol, atol : tolerances of the adaptive integrators
    step : the fixed step of rk4 (default: the output spacing); the largest step of the others
    masses, forces : the mass matrix and ``ForceModel`` to use instead of the model's (e.g. with user
        forces added: ``build_forces(model).add(f)``)
    points : optional {label: (body index, body-frame point)} to add as result columns
    options : the formulation's options, e.g. ``alpha=10, beta=10`` (baumgarte), ``repartition_ratio``
        (partitioning), ``rank_tol`` (svd)

    Returns
    -------
    Result
        q, q', q'', lambda on the grid; ``points`` holds the histories 'residual.position' (max |Psi|),
        'residual.velocity' (max |Psi_q q' + Psi_t|), 'energy.kinetic', 'energy.potential',
        'energy.dissipated', 'energy.applied', 'energy.drivers' and 'energy.error' (E(t) - E(0));
        ``info`` says how it was obtained (DESIGN section 5) and how far the initial state was corrected.

    Raises
    ------
    AnalysisError
        Assembly failure, redundant constraints with a formulation that cannot take them, an
        unknown formulation or integrator, an integrator failure: by name.
    """
    start = _time.perf_counter()
    model = system.model
    M = mass_matrix(model) if masses is None else masses
    forces = build_forces(model) if forces is None else forces
    q, qd, initial = consistent_initial_conditions(system, M, q0, qd0)
    if integrator in INDEX3_INTEGRATORS:
        from .implicit import integrate_index3  # the implicit index-3 integrators (HHT-alpha, generalized-alpha)

        result = integrate_index3(
            system, M, forces, q, qd, t_end, steps, rtol, atol, step, method=integrator, **options
        )
        for label, (body, point) in (points or {}).items():
            result.points.update(point_columns(result, label, body, point))
        result.reactions.update(joint_reactions(system, result.q, result.lam, result.t))
        result.info.update(assembly=initial["assembly"], initial_conditions=initial)
        result.info["wall_time"] = _time.perf_counter() - start
        return result
    if integrator not in INTEGRATORS:
        known = ", ".join((*INTEGRATORS, *INDEX3_INTEGRATORS))
        raise AnalysisError(f"unknown integrator {integrator!r} (one of: {known})")
    _check_redundancy(system, q, formulation)
    if formulation == "projection" and integrator in MULTISTEP_INTEGRATORS:
        raise AnalysisError(
            f"the projection formulation restarts the integrator after every step, which a multistep method "
            f"({integrator}) cannot afford: use rk4, RK45, DOP853 or Radau"
        )
    equations = EquationsOfMotion(
        make_formulation(formulation, system, M, forces, **options), forces, has_drivers=bool(model.motors)
    )
    times = np.linspace(0.0, t_end, steps + 1)
    history = _History(times.size, system.n_coordinates, system.n_constraints, equations.extra)

    def record(k: int, t: float, z: np.ndarray) -> None:
        y, energies = equations.split(z)
        q, qd = equations.formulation.coordinates(t, y)
        history.store(k, q, qd, *equations.formulation.accelerations(q, qd, t), energies)

    stats = integrate(
        equations.rhs,
        equations.initial_state(q, qd, 0.0),
        times,
        record,
        method=integrator,
        rtol=rtol,
        atol=atol,
        step=step,
        after_step=equations.after_step,
    )
    result = Result(
        t=times,
        q=history.q,
        qd=history.qd,
        qdd=history.qdd,
        coordinate_names=system.coordinate_names,
        body_names=[b.name for b in model.bodies],
        lam=history.lam,
    )
    residuals = constraint_residuals(system, times, history.q, history.qd)
    accumulated = history.energies.T if equations.extra else ()
    energies = energy_history(M, forces, history.q, history.qd, *accumulated)
    result.points.update(residuals)
    result.points.update(energies.columns())
    for label, (body, point) in (points or {}).items():
        result.points.update(point_columns(result, label, body, point))
    result.reactions.update(joint_reactions(system, history.q, history.lam, times))
    result.info = {
        "analysis": "dynamic",
        "formulation": formulation,
        "integrator": integrator,
        "rtol": rtol,
        "atol": atol,
        "step": step,
        "steps": steps,
        "rhs_evaluations": stats.rhs_evaluations,
        "integrator_steps": stats.steps,
        "restarts": stats.restarts,
        "max_constraint_residual": float(residuals["residual.position"].max()),
        "max_velocity_residual": float(residuals["residual.velocity"].max()),
        "energy_drift": float(np.max(np.abs(energies.error))),
        "energy_drift_relative": float(np.max(np.abs(energies.error)) / energies.scale),
        "assembly": initial["assembly"],
        "initial_conditions": initial,
        **_formulation_info(equations.formulation),
        "wall_time": _time.perf_counter() - start,
    }
    return result


class _History:
    """Output arrays filled as the integrator passes the output times."""

    def __init__(self, size: int, n: int, m: int, extra: int):
        self.q, self.qd, self.qdd = (np.empty((size, n)) for _ in range(3))
        self.lam = np.empty((size, m))
        self.energies = np.zeros((size, extra))

    def store(self, k, q, qd, qdd, lam, energies) -> None:
        self.q[k], self.qd[k], self.qdd[k] = q, qd, qdd
        self.lam[k] = lam
        self.energies[k] = energies


def constraint_residuals(system: System, t: np.ndarray, q: np.ndarray, qd: np.ndarray) -> dict[str, np.ndarray]:
    """Histories of max |Psi(q, t)| and max |Psi_q q' + Psi_t| (columns 'residual.position', 'residual.velocity')."""
    position, velocity = np.empty(t.size), np.empty(t.size)
    for k, time in enumerate(t):
        position[k] = np.max(np.abs(system.constraints(q[k], time)), initial=0.0)
        jacobian = system.jacobian(q[k], time)
        velocity[k] = np.max(np.abs(jacobian @ qd[k] + system.psi_t(q[k], time)), initial=0.0)
    return {"residual.position": position, "residual.velocity": velocity}


def _check_redundancy(system: System, q: np.ndarray, formulation: str) -> None:
    """Only the SVD formulation copes with redundant constraints: refuse the others by name."""
    report = rank_report(system.jacobian(q, 0.0), system.row_owners)
    if report.n_redundant and formulation != "svd":
        raise AnalysisError(
            f"{report.n_redundant} redundant constraint equation(s) among joints "
            f"{', '.join(report.redundant_joints)}: the {formulation} formulation needs independent "
            "constraints; use --formulation svd, or remove the redundant joint"
        )


def _formulation_info(formulation: Formulation) -> dict:
    info = {}
    if hasattr(formulation, "alpha") and (formulation.alpha or formulation.beta):
        info.update(alpha=formulation.alpha, beta=formulation.beta)
    if hasattr(formulation, "repartitions"):
        info.update(repartitions=formulation.repartitions, partitions=formulation.partitions)
    if hasattr(formulation, "projections"):
        info["projections"] = formulation.projections
    return info


__all__ = [
    "FORMULATIONS",
    "INDEX3_INTEGRATORS",
    "EquationsOfMotion",
    "consistent_initial_conditions",
    "constraint_residuals",
    "forward_dynamics",
]
