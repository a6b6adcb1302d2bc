# Generated from solutions/dynamics.py by `make modules` (every homework stubbed): do not edit by hand.
"""Forward dynamics: the motion of a mechanism under forces, from consistent initial conditions.

A run (course notes, chapter 6):

1. **Consistent initial conditions.** The file's configuration is assembled, Psi(q0, 0) = 0, by
   Newton-Raphson; the file's velocities are projected onto Psi_q q' = -Psi_t with the correction
   of least kinetic-energy norm. The result's info reports how far both moved. A point mass that its
   joints leave free to turn about its centre gets a nominal inertia on that turn alone, at rest
   (``nominal_inertia``): the turn moves no mass, and M becomes regular on the motions allowed.
2. **Integration.** The chosen formulation (``formulations.py``) turns M q'' + Psi_q^T lambda = Q,
   Psi_q q'' = gamma into a first-order ODE y' = f(t, y), which the chosen integrator
   (``integrators.py``) advances. When the scene has dampers, actuators, loads or drivers, the
   dissipated energy and the work put in are integrated with it as three extra states, for the
   energy balance (``energy.py``).
3. **Output.** At every output time: q, q', q'', lambda, the constraint residuals |Psi| and
   |Psi_q q' + Psi_t|, the energies and the balance error E(t) - E(0).

4. **Guards.** No run returns a wrong answer silently: the integrators stop on their evaluation
   budget and report stiffness (``integrators.py``); the run's ``Guard`` (``guard.py``) stops a run whose
   positions leave the constraints, that passes a singular configuration, or that leaves the assembly branch it
   came along there (its velocities jump), each with the time and the condition.

The mass matrix is built once and the force loop is skipped for a scene with gravity only.
``formulation="auto"`` and ``integrator="auto"`` pick the cheapest adequate method (``choose_method``).

In the code, ``forward_dynamics`` runs a plan (``run_plan``) as named stages, flowing one way:
``dynamic_model`` (M and the forces) -> ``consistent_initial_conditions`` (1; ``consistent_start``, which hands
its Psi_q to the start's rank) -> ``plan_method`` (the method and the tolerance rule, computed once; the three are
``start_motion``) -> ``ode_motion`` (the equations of motion and the Guard; an FMU's co-simulation, ``io/fmu.py``,
advances them step by step) -> ``integrate_motion`` (2 and 4: the numpy engine, or the compiled one where it covers
the run; ``index3_run`` for the implicit index-3 integrators) -> ``build_result`` (3) -> ``run_info`` and the
warnings. When ``auto``'s method stops at a singular position (``SingularStop``), the run is made again from the
start with the one fallback plan: a formulation that passes it. ``forward_dynamics`` is one run of a ``prepare``d
one (``Prepared``): what does not depend on the initial state (M, the forces, the compiled plan and module) is made
once for many runs from other initial states.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import re
import time as _time
from dataclasses import dataclass

import numpy as np

from . import output_history
from .assembly import System, body_positions, joint_extent, mechanism_size
from .diagnostics import (
    NEAR_SINGULAR,
    AnalysisError,
    RankReport,
    SingularConfigurationError,
    rank_at,
)
from .divergence import Divergence, companion_factor, departure, estimate, needed_rtol, scaled
from .energy import driver_power, energy_history
from .formulations import FORMULATIONS, Formulation, make_formulation
from .generalized_forces import ForceModel, build_forces, element_columns
from .guard import Guard, gyration_weights, judge_pause, judge_stop, shallow_copy, singular_dip
from .integrators import (
    FIXED_STEP_METHODS,
    STABILITY_LIMIT,
    integrate,
    spectral_radius,
    stiffness_message,
)
from .joint_coordinates import open_tree
from .kinematics import assemble, point_columns
from .linalg import RANK_EPS, largest, numerical_rank
from .mass_matrix import mass_at, mass_matrix, singular_inertia
from .reactions import REDUNDANT_NOTE, joint_reactions, minimum_norm_multipliers
from .results import DynamicInfo, Progress, Result
from .settings import (
    DEFAULT_ACCURACY,
    DRIFT_LIMIT,
    FORMULATION_NAMES,
    INDEX3_INTEGRATORS,
    INTEGRATOR_NAMES,
    SINGULAR_RATIO,
    Settings,
    default_settings,
)

MULTISTEP_INTEGRATORS = ("BDF", "LSODA")
DIFFERENCING_INTEGRATORS = ("Radau", "BDF", "LSODA")
"""scipy's implicit methods: their Newton iterations take the Jacobian of the right-hand side by finite differences."""
DEFAULT_RTOL = 1e-8
"""The integrators' relative tolerance when none is given, for runs of up to DEFAULT_ACCURACY / DEFAULT_RTOL = 100
periods of the fastest motion squared (``default_rtol`` tightens it for longer runs)."""
MIN_RTOL = 1e-13
"""The tightest relative tolerance ``default_rtol`` asks for (a few hundred times machine epsilon)."""
HELD_RTOL = 1e-12
"""The tightest tolerance an explicit run holds in double precision: below it the rounding errors of the
stages, not the tolerance, set the local error, so ``accuracy_warnings`` takes at least this (measured:
the 2000 s pendulum of benchmarks/accuracy.md asked for 3.4e-13 and erred as 1e-12 predicts)."""
THROUGH_SINGULAR = ("augmented-lagrangian",)
"""Formulations that carry a mechanism through singular positions and take redundant constraints: with them
the ``Guard`` records a singular crossing (``info['singular_positions']``) instead of stopping the run."""
RESTARTING = ("projection", "augmented-lagrangian")
"""Formulations that correct the state after every step, so the integrator restarts: no multistep methods."""

PARTITIONING_VELOCITIES = 10.0
"""Coordinate partitioning's velocity error over the other formulations', for the same rtol: its integrator
controls the error of the independent coordinates and their rates only; the dependent velocities follow from them,
v' = -Psi_v^-1 Psi_u u' (eq. 5.40), outside that control. Measured against baumgarte at rtol 1e-12 (relative to
the largest speed V, over the position error's fraction of the size): Andrews' squeezer 0.03 s at rtol 1e-8,
1.9e-6 of V where the estimate said 3.8e-7 (5 times); the four-bar with a 1e5 N/m spring, 3.9e-6 against 5.8e-7
(6.7 times). Its velocity estimate is this many times the others', and its default rtol this many times smaller
(``default_rtol``, ``plan_method``): Andrews at rtol 1e-9 is within 3.8e-8 of V."""


def consistent_initial_conditions(
    system: System, M: np.ndarray, q0: np.ndarray, qd0: np.ndarray, t: float = 0.0
) -> tuple[np.ndarray, np.ndarray, dict]:
    """q on Psi(q, t) = 0 (assembly) and q' on Psi_q q' + Psi_t = 0, with a report of the corrections.

    The velocity correction is the one of least kinetic-energy norm (eq. 6.2):

        q' = q0' - M^-1 Psi_q^T x,   (Psi_q M^-1 Psi_q^T) x = Psi_q q0' + Psi_t

    solved in the least-squares sense, so redundant constraints are fine; where q0' satisfies the velocity
    constraints exactly (a mechanism released at rest), x = 0 and nothing is solved.
    """
    return consistent_start(system, M, q0, qd0, t)[:3]


def consistent_start(
    system: System, M: np.ndarray, q0: np.ndarray, qd0: np.ndarray, t: float = 0.0, singular: list[int] | None = None
) -> tuple[np.ndarray, np.ndarray, dict, np.ndarray | None]:
    """``consistent_initial_conditions``, and Psi_q at the consistent q where the velocity correction made it (None
    where it did not: q0' satisfies the velocity constraints and Psi_t = 0, e.g. released at rest), which the run's
    start hands to its rank (``rank_at``) instead of making the same matrix again (a driven mechanism's start:
    20-50 us a call). ``singular``: the model's point masses (``point_masses``) where the caller knows them."""
    q, assembly = assemble(system, q0, t)
    psi_t = system.psi_t(q, t)
    at_rest = not np.asarray(qd0).any()  # Psi_q 0 = 0: the residual is Psi_t, and Psi_q is made only to correct q0'
    jacobian = None if at_rest else system.jacobian(q, t)
    residual = psi_t if at_rest else jacobian @ qd0 + psi_t
    before = float(np.abs(residual).max()) if residual.size else 0.0
    if not before:  # q0' satisfies the velocity constraints exactly (e.g. at rest): x = 0, nothing to correct
        qd = np.array(qd0, dtype=float)
        report = {"velocity_residual_before": 0.0, "velocity_correction": 0.0, "velocity_residual": 0.0}
        return q, qd, {"assembly": assembly, **report}, jacobian
    if jacobian is None:  # at rest, with a Psi_t to correct (a driven mechanism released at rest)
        jacobian = system.jacobian(q, t)
    if singular is None:
        singular = point_masses(system.model)
    if singular:  # M singular: the same minimum, from [M Psi_q^T; Psi_q 0] (eq. 5.30's matrix)
        n, m = jacobian.shape[1], jacobian.shape[0]
        kkt = np.block([[mass_at(M, q), jacobian.T], [jacobian, np.zeros((m, m))]])
        qd = qd0 + np.linalg.lstsq(kkt, np.concatenate([np.zeros(n), -residual]), rcond=None)[0][:n]
    else:
        weighted = np.linalg.solve(mass_at(M, q), jacobian.T)
        x = np.linalg.lstsq(jacobian @ weighted, residual, rcond=None)[0]
        qd = qd0 - weighted @ x
    report = {
        "assembly": assembly,
        "velocity_residual_before": before,
        "velocity_correction": largest(qd - qd0),
        "velocity_residual": largest(jacobian @ qd + psi_t),
    }
    return q, qd, report, jacobian


def effort_columns(system: System, q: np.ndarray, lam: np.ndarray, t: np.ndarray) -> dict[str, np.ndarray]:
    """'DRIVER.effort' for every driver over a run: the name an inverse analysis gives them too. The effort of
    ``reactions.driver_efforts``, -lambda dPsi/ds, over all output times at once: -lambda of the driver's row, times
    the driven distance L(t) for a distance driver."""
    if not system.model.motors:  # no driver: no effort, and no pass over the output times
        return {}
    motors, lam = {m["name"] for m in system.model.motors}, np.asarray(lam, dtype=float)
    efforts: dict[str, np.ndarray] = {}
    for k, element in enumerate(system.elements):
        if element.name in motors:
            length = getattr(element, "length", None)
            scale = 1.0 if length is None else np.array([length.value(float(time)) for time in t])
            efforts[element.name] = -lam[:, system.rows[k]][:, 0] * scale
    return {f"{name}.effort": values for name, values in efforts.items()}


def point_masses(model) -> list[int]:
    """Indices of the bodies with a singular inertia (``mass_matrix.singular_inertia``): point masses (inertia 0,
    spatial [0, 0, 0]) and spatial bodies with a zero principal moment."""
    return singular_inertia(model)


@dataclass(frozen=True)
class FreeTurns:
    """The motions a run's constraints allow that carry no kinetic energy (``free_turns``): ``motions`` (n, k)
    spans them; ``axes`` {body index: body-frame axes (3, r), orthonormal (planar: [[1.0]])} are what they turn."""

    motions: np.ndarray
    axes: dict


def free_turns(system: System, M, q: np.ndarray) -> FreeTurns:
    """Motions Z v the constraints allow (Z spanning the null space of Psi_q) with no kinetic energy, v^T Z^T M Z v
    = 0 (eq. 5.44): the rotation of a point mass about its own centre (a bead pinned at its centre; a point mass on a
    spherical joint about the line to the joint), which moves no mass. Which bodies they turn and about which
    body-frame axes (omega' = 2 L(p) p' of a spatial body, eq. 8.16)."""
    jacobian = system.jacobian(q, 0.0)
    _, sigma, vt = np.linalg.svd(jacobian)
    Z = vt[numerical_rank(sigma, jacobian.shape) :].T
    reduced = Z.T @ mass_at(M, q) @ Z
    values, vectors = np.linalg.eigh(0.5 * (reduced + reduced.T)) if Z.shape[1] else (np.zeros(0), Z[:0, :0])
    motions = Z @ vectors[:, ~(values > RANK_EPS * max(values.max(initial=0.0), 0.0))]
    axes, per = {}, system.coordinates_per_body
    for k in point_masses(system.model) if motions.size else ():
        block = motions[per * k : per * k + per]
        turn = block[2:3] if per == 3 else 2.0 * _l_matrix(q[per * k + 3 : per * k + 7]) @ block[3:]
        U, s, _ = np.linalg.svd(turn)
        if s.size and s[0] > RANK_EPS:
            axes[k] = U[:, : int(np.sum(s > RANK_EPS * s[0]))]
    return FreeTurns(motions, axes)


def nominal_inertia(run: Run, M, q: np.ndarray) -> tuple[Run, FreeTurns, list[str]]:
    """A run whose point masses turn about their free axes (``free_turns``) with a nominal inertia m L^2 about those
    axes alone (L the mechanism's size), and what the result says of it.

    Such a rotation moves no mass, so M q'' + Psi_q^T lambda = Q leaves it undetermined (M singular on it); with the
    nominal inertia it is decoupled: no constraint or force turns it (a torque on it is refused), it starts at rest
    (its speed taken out of q' by the caller, ``without_turns``) and stays so, and every mass moves as before, in
    every formulation (eq. 5.44: Z^T M Z becomes regular). A run whose free motions are not such turns is refused.

    Raises
    ------
    AnalysisError
        Naming the body: a free motion that is not a point mass's turn, or a torque on a free turn.
    """
    system, model = run.system, run.system.model
    turns = free_turns(system, M, q)
    if not turns.motions.size:
        return run, turns, []
    size = mechanism_size(system, q)
    bodies = list(model.bodies)
    for k, axes in turns.axes.items():
        check_free_torque(run, q, k, axes)
        moment = model.bodies[k].mass * size**2
        planar = model.dimension == 2
        inertia = moment if planar else np.asarray(model.bodies[k].inertia, dtype=float) + moment * axes @ axes.T
        bodies[k] = dataclasses.replace(model.bodies[k], inertia=inertia)
    spun = copy.copy(system)
    spun.model = dataclasses.replace(model, bodies=bodies)
    check_point_masses(spun, mass_matrix(spun.model), q)  # a free motion left: no point mass's turn, refused
    names = ", ".join(f"'{model.bodies[k].name}'" for k in turns.axes)
    note = (
        f"{names}: singular inertia (a point mass) free to turn about its centre, which moves no mass; given a "
        f"nominal inertia m L^2 (L = {size:.3g} m) about the free axes only, at rest: every mass moves as without it"
    )
    return dataclasses.replace(run, system=spun), turns, [note]


def check_free_torque(run: Run, q: np.ndarray, k: int, axes: np.ndarray) -> None:
    """Refuse a torque on the free turn of point mass k (its axes, body frame): applied forces off its centre, or a
    torque, would spin it without bound. Q of the model's forces at q, at rest and t = 0: its rotation rows are the
    moment (planar), or 2 L^T n' with n' the body-frame moment (spatial, eq. 10.10: n' = L Q_p / 2)."""
    if run.forces is not None:  # the caller's own forces: theirs to judge
        return
    model = run.system.model
    Q = build_forces(model).generalized_forces(q, np.zeros_like(q), 0.0)
    if model.dimension == 2:
        moment = Q[3 * k + 2 : 3 * k + 3]
    else:
        moment = 0.5 * _l_matrix(q[7 * k + 3 : 7 * k + 7]) @ Q[7 * k + 3 : 7 * k + 7]
    if np.linalg.norm(axes.T @ moment) > 1e-12 * max(np.linalg.norm(Q), 1.0):
        raise AnalysisError(
            f"{model.source}: model.bodies[{k}].inertia: '{model.bodies[k].name}' has a singular inertia and a "
            "torque acts on the rotation its joints leave free (a load or a spring off its centre), which would "
            "spin it without bound; give it an inertia > 0, or apply the load at its centre"
        )


def without_turns(turns: FreeTurns, qd: np.ndarray) -> np.ndarray:
    """q' less its part along the free turns of point masses (``free_turns``): they move no mass and satisfy the
    velocity constraints, so the masses' velocities and Psi_q q' are unchanged; the turns start at rest."""
    if not turns.motions.size:
        return qd
    return qd - turns.motions @ np.linalg.lstsq(turns.motions, qd, rcond=None)[0]


def _l_matrix(p: np.ndarray) -> np.ndarray:
    """L(p) of a spatial body (omega' = 2 L p', eq. 8.16), imported only for a spatial model: a planar run loads no
    spatial code."""
    from .rotations import l_matrix

    return l_matrix(p)


def check_point_masses(system: System, M, q: np.ndarray) -> None:
    """Refuse a run whose mass matrix is singular on a motion the constraints allow that is not a point mass's
    free turn (``nominal_inertia`` takes those): Z^T M Z must be positive definite for Z spanning the null space of
    Psi_q (eq. 5.44), which makes the matrix of eq. 5.30 regular.

    Raises
    ------
    AnalysisError
        Naming the body with a singular inertia that the motion moves, with the fix.
    """
    bodies = point_masses(system.model)
    turns = free_turns(system, M, q)
    if not bodies or not turns.motions.size:
        return
    motion = turns.motions[:, 0]  # a motion the constraints allow that has no kinetic energy
    size = 3 if system.model.dimension == 2 else 7
    turning = max(bodies, key=lambda k: float(np.linalg.norm(motion[size * k : size * k + size])))
    name = system.model.bodies[turning].name
    raise AnalysisError(
        f"{system.model.source}: model.bodies[{turning}].inertia: '{name}' is a point mass (inertia 0) that the "
        "joints leave free to move without kinetic energy, so the mass matrix is singular on that motion; give it "
        "an inertia > 0, or fix its rotation (e.g. a rigid joint)"
    )


class EquationsOfMotion:
    """The ODE an integrator advances: the formulation's state, plus (when the scene needs them) three
    accumulated energies z = (y, D, W_applied, W_drivers) with D' = P_dissipated, W' = P (eq. 5.60)."""

    def __init__(self, formulation: Formulation, forces: ForceModel, has_drivers: bool, compiled_plans=None):
        self.formulation, self.forces = formulation, forces
        self.has_drivers = has_drivers
        self.compiled_plans: dict | None = compiled_plans
        """The compiled plans a prepared run keeps between its runs (``Prepared``), or None: made for this one."""
        self.extra = 0 if forces.is_conservative and not has_drivers else 3

    def initial_state(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        """z0: the formulation's state (a new array), then the accumulated energies (zero) where there are any."""
        y = self.formulation.initial_state(q, qd, t)
        return np.concatenate([y, np.zeros(self.extra)]) if self.extra else y

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
        if not self.has_drivers:  # lambda enters only the drivers' power: the formulation's own rhs will do
            derivative, q, qd = self.formulation.derivative(t, y)
            return np.concatenate([derivative, self.forces.powers(q, qd, t), [0.0]])
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
    formulation: str | None = None,
    integrator: str | None = None,
    *,
    settings: Settings | None = None,
    masses: np.ndarray | None = None,
    forces: ForceModel | None = None,
    points: dict[str, tuple[int, np.ndarray]] | None = None,
    progress: Progress | None = None,
    **options,
) -> Result:
    """The motion on the output grid t = 0, t_end/steps, ..., t_end, by the stages of ``run_plan``: the same
    as ``prepare(system, t_end, steps, ...).run(q0, qd0)`` (one run of a prepared one; many runs of one scene
    from other initial states: ``prepare``).

    Parameters
    ----------
    system : the assembled system; q0, qd0 its (approximate) initial coordinates and velocities
    formulation, integrator, options : settings of the run, over ``settings`` when given (``settings.Settings``
        says what each takes and does: ``formulation``, ``integrator``, ``rtol``, ``atol``, ``step``,
        ``accuracy``, ``engine``, ``max_evaluations``, ``stiffness``, ``drift_limit``, ``singular_ratio``,
        ``alpha``, ...); other keywords are options of the formulation's constructor (e.g. ``tol``)
    masses, forces : the mass matrix and ``ForceModel`` to use instead of the model's (e.g. with user
        forces added: ``build_forces(model).add(f)``)
    points : optional {label: (body index, body-frame point)} to add as result columns
    progress : optional ``progress(t)``, called with each output time as the numpy engine reaches it (a long
        run's progress, e.g. in ``mbd serve``); the compiled engine's loop reports nothing until it returns

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
        Assembly failure, redundant constraints with a formulation that cannot take them, an unknown
        formulation or integrator (``SettingError``), an integrator failure: by name.
    """
    start = _time.perf_counter()
    prepared = prepare(
        system, t_end, steps, formulation, integrator, settings=settings, masses=masses, forces=forces, points=points,
        **options,
    )  # fmt: skip
    result = prepared.run(q0, qd0, progress)
    result.info["wall_time"] = _time.perf_counter() - start
    return result


def prepare(
    system: System,
    t_end: float,
    steps: int,
    formulation: str | None = None,
    integrator: str | None = None,
    *,
    settings: Settings | None = None,
    masses: np.ndarray | None = None,
    forces: ForceModel | None = None,
    points: dict[str, tuple[int, np.ndarray]] | None = None,
    **options,
) -> Prepared:
    """A forward-dynamics run made ready for many initial states: ``prepare(...).run(q0, qd0)`` gives bit for bit
    what ``forward_dynamics(system, q0, qd0, t_end, steps, ...)`` gives with the same arguments (which is this, run
    once). The arguments are ``forward_dynamics``'s (its docstring); bad settings raise here, as there.

    What does not depend on the initial state is made once, by the first run that needs it, and kept for the next
    (``Prepared``): the mass matrix and the force model (``dynamic_model``), the settings, and per formulation the
    compiled engine's plan of the scene (its description, packed data, loaded module). What does stays per run:
    consistent initial conditions, the start rates, ``auto``'s choice, the tolerance rule, the Guard, the
    divergence check. This is MuJoCo's split of ``mjModel`` (the model compiled once) from ``mjData`` (one
    simulation's state; Todorov, Erez & Tassa 2012, MuJoCo documentation "Overview: Model and data"): a sweep over
    initial states, a controller's design loop or a benchmark pays the preparation once.

    The object captures ``system`` as it is now: a model changed afterwards (``Model`` is mutable) needs a new
    ``prepare``; nothing is cached behind the caller's back, keyed on an object's identity.
    """
    named = {k: v for k, v in (("formulation", formulation), ("integrator", integrator)) if v is not None}
    settings = (settings or default_settings()).replace(t_end=t_end, steps=steps, **named, **options)
    return Prepared(system, settings, masses, forces, points)


class Prepared:
    """A prepared forward-dynamics run (``prepare``): its system and settings, and what its runs share, made by the
    first run that needs it: the model's M and forces (``model``), its point masses, the Guard's weights and the
    joints' extent (``fixed``), the joint-coordinates formulation object (``formulation``) and the compiled plans of
    its formulations (``compiled_plans``: by formulation and, for a spatial prismatic joint in joint coordinates,
    the sign its initial state gives the joint's rotation, which the compiled tree's data holds). One run at a time:
    a run's objects are handed to the next."""

    def __init__(self, system: System, settings: Settings, masses=None, forces=None, points=None):
        self.system, self.settings, self.masses, self.forces, self.points = system, settings, masses, forces, points
        self._model: tuple[np.ndarray, ForceModel] | None = None
        self._fixed: Fixed | None = None
        self._formulations: dict[str, Formulation] = {}
        self.compiled_plans: dict = {}

    def model(self) -> tuple[np.ndarray, ForceModel]:
        """(M, the force model) of the runs (``dynamic_model``), made at the first call."""
        if self._model is None:
            self._model = dynamic_model(self.system, self.masses, self.forces)
        return self._model

    def fixed(self) -> Fixed:
        """What the runs' start and Guard read of the model alone (``Fixed``), made at the first call."""
        if self._fixed is None:
            model = self.system.model
            self._fixed = Fixed(point_masses(model), joint_extent(model), self.system)
        return self._fixed

    def formulation(self, name: str, M, forces: ForceModel, options: dict) -> Formulation:
        """The formulation object ``name`` for a run's start rates (``StartRates``): made anew, but for joint
        coordinates (REUSED) made once and handed to each run as a new one would be (``start_over``: its last
        evaluation and compiled plan forgotten; the joints' ``u0``, the only other thing a run changes, set anew by
        the run's initial state). The others keep what a run leaves (the partition of ``partitioning``, the counters
        of ``projection`` and the augmented Lagrangian, its penalty set at the first state)."""
        if name not in REUSED:
            return make_formulation(name, self.system, M, forces, **options)
        made = self._formulations.get(name)
        if made is None:
            made = self._formulations[name] = make_formulation(name, self.system, M, forces, **options)
        else:
            made.start_over()
        return made

    def run(self, q0: np.ndarray, qd0: np.ndarray, progress: Progress | None = None) -> Result:
        """The motion from the (approximate) initial state q0, qd0: ``forward_dynamics``'s result."""
        start = _time.perf_counter()
        q0, qd0 = initial_arrays(self.system, q0, qd0)
        run = Run(self.system, q0, qd0, self.settings, self.masses, self.forces, self.points, progress, self)
        settings = self.settings
        try:
            result, made = run_stages(run, settings.formulation, settings.integrator)
        except SingularStop as stop:  # ``auto`` met a singular position: the formulation that passes it, from the start
            fallback = THROUGH_SINGULAR[0]
            result, made = run_stages(run, fallback, settings.integrator)
            result.info["chosen"] = {
                "formulation": fallback,
                "integrator": result.info["integrator"],
                "why": f"{fallback}: {stop.formulation} stopped near a singular configuration ({stop.first}), "
                "which it passes; " + stop.why,
            }
            result.info["restarted"] = {
                "t": stop.t,
                "stopped": stop.formulation,
                "formulation": fallback,
                "why": stop.reason,
            }
        result = judge_divergence(run, result, made)  # stage 5's last guard: a second run, where motion may be chaotic
        result.info["wall_time"] = _time.perf_counter() - start
        return result


REUSED = ("joint-coordinates",)
"""The formulations whose object a prepared run hands from one run to the next (``Prepared.formulation``)."""


@dataclass(frozen=True)
class Fixed:
    """What a prepared run's stages read of the model alone, made once (``Prepared.fixed``): the point masses
    (``point_masses``), the joints' extent (``joint_extent``, of the mechanism's size) and the Guard's speed weights
    (``weights``)."""

    point_masses: list[int]
    extent: float
    system: System = dataclasses.field(repr=False, compare=False)

    @functools.cached_property
    def weights(self) -> np.ndarray:
        """The Guard's speed weights (``gyration_weights``), made by the first run whose Guard judges branches (none
        for an open tree in joint coordinates: 8-20 us a call saved)."""
        return gyration_weights(self.system)


def initial_arrays(system: System, q0, qd0) -> tuple[np.ndarray, np.ndarray]:
    """q0, qd0 as float arrays of the system's coordinates; an AnalysisError that says what was given where they
    are not."""
    n = system.n_coordinates
    arrays = []
    for name, value in (("q0", q0), ("qd0", qd0)):
        array = np.asarray(value, dtype=float)
        if array.shape != (n,):
            raise AnalysisError(
                f"{name} has shape {array.shape}: give the {n} coordinates of the system "
                f"({', '.join(system.coordinate_names)}), as build_system returns them"
            )
        arrays.append(array)
    return arrays[0], arrays[1]


@dataclass(frozen=True)
class Run:
    """What a forward-dynamics run is asked: the system, its initial state, the settings and what the caller
    gives instead of the model's (masses, forces) or besides (points)."""

    system: System
    q0: np.ndarray
    qd0: np.ndarray
    settings: Settings
    masses: np.ndarray | None
    forces: ForceModel | None
    points: dict | None
    progress: Progress | None = None
    prepared: Prepared | None = None
    """The prepared run this one is of (``prepare``): what its runs share."""


@dataclass(frozen=True)
class Plan:
    """Stage 2: the method and tolerances of a run, chosen once (``plan_method``)."""

    formulation: str
    integrator: str
    rtol: float
    atol: float
    rtol_given: bool
    periods: float | None
    size: float
    chosen: dict | None
    rate: float | None = None
    """w of ``motion_rate`` (1/s): the fastest rate of the motion at the start; None where it was not estimated."""
    numpy_seconds: float | None = None
    """The numpy run's estimated seconds where the engine's choice before the start rates made them at this rtol, or
    at a looser one and found the run worth compiling (``StartRates``): the engine's choice takes them instead of
    estimating again."""


class SingularStop(AnalysisError):
    """``auto``'s method stopped at a singular position: ``forward_dynamics`` runs again with one that passes it.
    ``t`` is when it stopped: the Guard's time, or (an integrator that lost its step next to a singular position)
    the time of the closest approach the Guard saw."""

    def __init__(self, err: AnalysisError, formulation: str, why: str, t: float | None):
        super().__init__(str(err))
        self.formulation, self.why, self.first, self.t = formulation, why, str(err).split(":")[0], t
        kind = re.sub(r"\s*(at|between) t = .*$", "", self.first)  # 'singular configuration', 'integrator x failed'
        self.reason = kind if isinstance(err, SingularConfigurationError) else f"{kind} next to a singular position"


@dataclass(frozen=True)
class Start:
    """Stages 1 and 2 of a run (``start_motion``): the run as it is integrated (point masses free to turn about
    their centres given a nominal inertia on those axes: ``nominal_inertia``), M and the forces, the consistent
    initial state with its report, the plan, and the notes said on the way."""

    run: Run
    M: np.ndarray
    forces: ForceModel
    q: np.ndarray
    qd: np.ndarray
    initial: dict
    plan: Plan
    notes: list[str]
    rates: StartRates | None = None
    rank: RankReport | None = None
    """Psi_q's rank at q (``rank_at``), made once at the start for the method's choice, the redundancy checks,
    the Guard and the divergence check; None for a run without constraints."""


@dataclass(frozen=True)
class Made:
    """What a run made on the way to its result (``run_stages``): its start (stages 1 and 2), the plan as it was
    integrated (tolerances held: ``held_tolerances``) and its equations of motion; None for an index-3 run, which
    makes its own. A second run from the same start at another tolerance needs no more (``companion_centres``)."""

    start: Start
    plan: Plan | None = None
    equations: EquationsOfMotion | None = None


def start_motion(run: Run, formulation: str, integrator: str) -> Start:
    """Stages 1 and 2: the model's M and forces, consistent initial conditions, the method and tolerances."""
    prepared = run.prepared
    M, forces = prepared.model() if prepared is not None else dynamic_model(run.system, run.masses, run.forces)
    notes, turns = [], None
    points = prepared.fixed().point_masses if prepared is not None else point_masses(run.system.model)
    singular = points if run.masses is None else []  # the model's M: singular where point masses turn freely
    if singular:  # M singular: free turns of point masses
        run, turns, notes = nominal_inertia(run, M, assemble(run.system, run.q0)[0])
        M, forces = dynamic_model(run.system, None, run.forces)
        run = dataclasses.replace(run, prepared=None)  # its system is this run's own: nothing to share
        points = None  # its system's own (``consistent_start`` finds them)
    q, qd, initial, jacobian = consistent_start(run.system, M, run.q0, run.qd0, singular=points)  # stage 1
    if turns is not None:
        qd = without_turns(turns, qd)
    settings = run.settings
    options, compiled = settings.formulation_options, settings.engine == "compiled"
    rates = StartRates(run.system, M, forces, q, qd, options, compiled, settings, run.prepared)  # engine's choice first
    rank = rank_at(run.system, q, jacobian)
    plan = plan_method(run, M, forces, q, qd, formulation, integrator, rates, rank)  # stage 2
    return Start(run, M, forces, q, qd, initial, plan, notes, rates, rank)


def ode_motion(run: Run, start: Start) -> tuple[Plan, EquationsOfMotion, Guard, list[str]]:
    """What an ODE integrator advances for a plan that is not index-3: the plan with the tolerances the formulation
    holds (``held_tolerances``), the equations of motion, the run's ``Guard`` and the warnings said on the way."""
    system, plan = run.system, start.plan
    _check_redundancy(start.rank, plan.formulation)
    if plan.formulation in RESTARTING and plan.integrator in MULTISTEP_INTEGRATORS:
        raise AnalysisError(
            f"the {plan.formulation} formulation restarts the integrator after every step, which a multistep "
            f"method ({plan.integrator}) cannot afford: use rk4, RK45, DOP853 or Radau"
        )
    made = start.rates.take(plan.formulation) if start.rates is not None else None  # made for the start rates
    if made is None:
        made = make_formulation(plan.formulation, system, start.M, start.forces, **run.settings.formulation_options)
    if plan.integrator in DIFFERENCING_INTEGRATORS and hasattr(made, "differenced"):
        made.differenced = True  # the augmented Lagrangian's iterations stop by a fixed rule (``converged``)
    plans = run.prepared.compiled_plans if run.prepared is not None else None
    equations = EquationsOfMotion(made, start.forces, has_drivers=bool(system.model.motors), compiled_plans=plans)
    plan, raised = held_tolerances(plan, equations)
    return plan, equations, make_guard(run, plan, equations, start.q, start.rank), raised


def run_plan(run: Run, formulation: str, integrator: str) -> Result:
    """One run of the stages: initial conditions -> method -> engine -> result."""
    return run_stages(run, formulation, integrator)[0]


def run_stages(run: Run, formulation: str, integrator: str) -> tuple[Result, Made]:
    """``run_plan``'s result, and what it made on the way (``Made``: its start, plan and equations of motion)."""
    start = start_motion(run, formulation, integrator)
    run, q, qd, initial, notes = start.run, start.q, start.qd, start.initial, start.notes
    system, settings = run.system, run.settings
    if start.plan.integrator in INDEX3_INTEGRATORS:
        result = index3_run(run, start.plan, start.M, start.forces, q, qd, initial, start.rank)
        if notes:
            result.info["notes"] = notes + result.info.get("notes", [])
        return result, Made(start)
    plan, equations, guard, raised = ode_motion(run, start)
    times = output_grid(settings.t_end, settings.steps)
    try:  # stage 3: the engine
        history, stats, compiled, chosen = integrate_motion(
            run, plan, equations, guard, start_state(start, equations), times
        )
    except AnalysisError as err:
        if formulation == "auto" and restartable(err, guard, plan):
            t = getattr(err, "t", None)
            t = (guard.closest or {}).get("t") if t is None else t
            raise SingularStop(err, plan.formulation, (plan.chosen or {}).get("why", ""), t) from err
        raise
    result, energies = build_result(run, equations, guard, history, compiled, times)  # stage 4
    result.info = run_info(run, plan, equations, guard, stats, result, energies, initial)
    if chosen is not None:
        result.info["chosen"] = chosen
    if compiled is not None:  # what the compiled engine's start cost: loading (or compiling) the scene's module
        result.info["compiled"] = {"cached": compiled.cached, "load_seconds": compiled.load_seconds}
    notes = notes + ([REDUNDANT_NOTE] if guard.rank < system.n_constraints else [])  # start.notes kept as made
    if notes:
        result.info["notes"] = notes
    result.info["warnings"] = drift_warnings(result.info, guard.size, plan.formulation, settings.formulation_options)
    speed = largest(body_positions(system, result.qd))  # V: the largest speed, m/s
    found = result.info["accuracy_estimate"] = accuracy_estimate(result.info, guard.size, plan.periods)
    held = max(HELD_RTOL, getattr(equations.formulation, "held_rtol", 0.0))
    result.info["held_rtol"] = held
    result.info["warnings"] += raised + accuracy_warnings(
        result.info, guard.size, settings.accuracy, plan.periods, speed, held, found
    )
    result.info["warnings"] += guard.warnings
    if not plan.rtol_given and plan.periods is not None:
        result.info["rtol_rule"] = (
            f"rtol = max({MIN_RTOL:g}, min({DEFAULT_RTOL:g}, accuracy / periods^2)) with {plan.periods:.3g} periods"
        )
    return result, Made(start, plan, equations)


def start_state(start: Start, equations: EquationsOfMotion) -> np.ndarray:
    """z0 of ``equations`` at the run's start (q, q'): the one its start rates evaluated (``StartRates.initial_state``,
    the same numbers: a joint-coordinates state costs 15-80 us of Python), else made anew. The run and the divergence
    check's compiled companion (``companion_centres``) start from it."""
    if start.rates is not None:
        return start.rates.initial_state(equations)
    return equations.initial_state(start.q, start.qd, 0.0)


def output_grid(t_end: float, steps: int) -> np.ndarray:
    """The output times t_k = k (t_end / steps), k = 0 ... steps, the last exactly t_end: ``np.linspace(0, t_end,
    steps + 1)``'s own arithmetic (the same bits), without its dispatch (4 us; 13 at a call's cold start)."""
    times = np.arange(steps + 1) * (t_end / steps)
    times[-1] = t_end
    return times


def judge_divergence(run: Run, result: Result, made: Made) -> Result:
    """The run's position error from a companion run at k x rtol (eqs. 6.62-6.64, ``divergence``), where the motion
    can be chaotic (``cannot_be_chaotic``) and the integrator controls its error. Within the accuracy: the result,
    with the estimate in info['divergence']. Above it, a run at the default rtol runs again at the rtol of eq. 6.64
    (info['tightened']), on the same engine with the same method; a run at a given rtol, or one that no rtol held in
    double precision can bring within it, warns with the figure (a chaotic one: how often its errors double and up
    to which time it meets the accuracy)."""
    info, settings = result.info, run.settings
    if settings.divergence == "skip" or info.get("integrator") in (*FIXED_STEP_METHODS, *INDEX3_INTEGRATORS):
        return result
    start = made.start
    why = cannot_be_chaotic(run, start.rank, start.forces) or too_short_to_diverge(start.plan, info["rtol"], settings)
    if why is not None:
        info["divergence"] = {"positions": None, "why": why}
        return result
    extent = run.prepared.fixed().extent if run.prepared is not None else None  # the joints': made once
    rtol, size = info["rtol"], mechanism_size(run.system, result.q[0], extent)
    k = companion_factor(rtol)
    try:
        companion = companion_centres(made, result, k * rtol, k * info["atol"])
    except AnalysisError as err:
        info["divergence"] = {"positions": None, "why": f"the run at {k:g} x rtol stopped: {err}"}
        return result
    found = estimate(result.t, departure(centres(run.system, result.q), companion), size, k)
    bound, held = settings.accuracy * size, info.get("held_rtol", HELD_RTOL)
    info["divergence"] = divergence_info(found, rtol, k)
    if found.final <= bound:
        return result
    need = needed_rtol(found, rtol, bound)
    if settings.rtol is None and need >= held:  # the default rtol: run again at the one eq. 6.64 asks
        try:
            tightened = run_plan(same_method(run, result, rtol=need), *_method(result))
        except AnalysisError as err:
            info["warnings"].append(divergence_warning(found, rtol, k, size, settings.accuracy, held) + f" ({err})")
            return result
        for key in ("chosen", "restarted"):
            if key in info:
                tightened.info[key] = info[key]
        tightened.info["divergence"] = divergence_info(found, rtol, k, scale=need)
        tightened.info["tightened"] = {"rtol": need, "was": rtol, "estimate": found.final, "bound": bound}
        return tightened
    if not found.chaotic and any(w.startswith("accuracy: estimated position error") for w in info["warnings"]):
        return result  # the tolerance rule's estimate says it already
    info["warnings"].append(divergence_warning(found, rtol, k, size, settings.accuracy, held))
    return result


def cannot_be_chaotic(run: Run, rank: RankReport | None, forces: ForceModel) -> str | None:
    """Why the run's motion cannot be chaotic, or None: no degree of freedom left by the joints and drivers at its
    start q (the motion is prescribed), or one and nothing that changes with time (no driver, no actuator, every
    force from a potential or a damper): the state (q, q') then moves on a plane or cylinder, where by the
    Poincare-Bendixson theorem no motion is chaotic; a regular motion's error is eq. 6.61's. ``rank``, ``forces``:
    Psi_q's rank and the force model, as the run's start made them (``Start``: not made again)."""
    system = run.system
    freedom = system.n_coordinates - (rank.rank if rank is not None else 0)
    if freedom == 0:
        return "no degree of freedom left by the joints and drivers: the motion is prescribed"
    if system.model.motors or freedom > 1:
        return None
    if not autonomous(forces):
        return None
    return "one degree of freedom and no driver or force that changes with time: no chaotic motion (Poincare-Bendixson)"


def autonomous(forces: ForceModel) -> bool:
    """True when no force changes with time: gravity, springs and dampers without an actuator (Q(q, q') only)."""
    from .planar.forces import no_actuator

    def timeless(element) -> bool:
        return element.is_conservative or getattr(element, "actuator", None) is no_actuator

    return not forces.user_forces and all(timeless(e) for e in forces.elements)


def companion_centres(made: Made, result: Result, rtol: float, atol: float) -> np.ndarray:
    """The body centres (N, bodies, dimension) at ``result``'s output times of the run again at rtol and atol (the
    companion of eq. 6.62), from its start by the same method and engine: the integration alone.

    The companion is a second opinion on the positions, and takes only them: no q'', lambda or energies at the
    output times, and none of the Guard's checks where the run's own Guard saw no position near a singular one
    (``info['closest_singularity']`` above NEAR_SINGULAR, no crossing). There the companion cannot silently leave
    the assembly branch: to leave it, it would have to pass close to a singular position that the run, following
    the same motion, stayed away from, and a companion on another branch is off by the size of the mechanism, a
    departure D that eq. 6.62 reads as a large error (the run is tightened, whose own run the Guard checks, or
    warns), never as a small one; its drift from the constraints (no drift check) adds to D the same way.
    Where the run did come near a singular position, the companion is a whole run with its Guard
    (``guarded_companion``): a stop there is said as 'the run at k x rtol stopped'.

    The compiled engine's companion reuses the run's compiled plan and loaded module (``dispatch.positions``: no
    tolerance is built into them); the numpy engine's makes its own formulation object (the run's may keep state
    from its last evaluation: the partition of ``partitioning``, the penalty's counters) and keeps the formulation's
    correction after each step (``projection``, ``augmented-lagrangian``)."""
    start, info = made.start, result.info
    closest = info.get("closest_singularity")
    if made.equations is None or info.get("singular_positions") or (closest and closest["ratio"] < NEAR_SINGULAR):
        return guarded_companion(made.start, result, rtol, atol)
    plan, _ = held_tolerances(dataclasses.replace(made.plan, rtol=rtol, atol=atol, rtol_given=True), made.equations)
    if "compiled" in info:
        from .compiled import dispatch

        job = dispatch.compiled_plan(made.equations, plan.formulation)
        z0 = start_state(start, made.equations)
        q = dispatch.positions(job, z0, result.t, plan, start.run.settings)
    else:
        q = numpy_positions(start, plan, result.t)
    return centres(start.run.system, q)


def numpy_positions(start: Start, plan: Plan, times: np.ndarray) -> np.ndarray:
    """q at the output times of the numpy engine's run from ``start`` by ``plan`` (its integration alone: the
    formulation's correction after each step, none of the Guard's checks; ``companion_centres``).

    Leaner than the run, the same positions: no stiffness monitor unless a finding stops the run
    (``stiffness="error"``; reported, it would be dropped here), and where the state is y = (q, q') with y' = (q',
    q'') (``second_order_state``), a dense output of q alone (``integrate``'s ``positions``: one evaluation less per
    step that passes an output time)."""
    system, settings = start.run.system, start.run.settings
    options = settings.formulation_options
    formulation = make_formulation(plan.formulation, system, start.M, start.forces, **options)
    if plan.integrator in DIFFERENCING_INTEGRATORS and hasattr(formulation, "differenced"):
        formulation.differenced = True  # as ``ode_motion``
    equations = EquationsOfMotion(formulation, start.forces, has_drivers=bool(system.model.motors))
    q = np.empty((times.size, system.n_coordinates))

    def record(k: int, t: float, z: np.ndarray) -> None:
        q[k] = formulation.coordinates(t, equations.split(z)[0])[0]

    integrate(
        equations.rhs, equations.initial_state(start.q, start.qd, 0.0), times, record, method=plan.integrator,
        rtol=plan.rtol, atol=plan.atol, step=settings.step, after_step=equations.after_step,
        max_evaluations=settings.max_evaluations, stiffness="error" if settings.stiffness == "error" else "off",
        positions=system.n_coordinates if second_order_state(formulation) else None,
    )  # fmt: skip
    return q


def second_order_state(formulation) -> bool:
    """True when the formulation's state is y = (q, q') and f(t, y) = (q', q''): ``Formulation``'s own coordinates
    and state derivative (not the partitioning's independent coordinates, nor joint coordinates), and no correction
    after a step. A correction reads what the last evaluation of f left (``Projection``'s mass-orthogonal step uses
    the spatial M(q) of the last evaluation, ``mass_solve``): an evaluation left out would move it."""
    kind = type(formulation)
    return (
        kind.coordinates is Formulation.coordinates
        and kind.state_derivative is Formulation.state_derivative
        and kind.after_step is Formulation.after_step
    )


def guarded_companion(start: Start, result: Result, rtol: float, atol: float) -> np.ndarray:
    """``companion_centres`` by a whole run's engine stage with its Guard (``ode_motion``, ``integrate_motion``),
    for a run that came near a singular position."""
    run = same_method(start.run, result)
    plan = dataclasses.replace(start.plan, rtol=rtol, atol=atol, rtol_given=True)
    plan, equations, guard, _ = ode_motion(run, dataclasses.replace(start, run=run, plan=plan))
    z0 = equations.initial_state(start.q, start.qd, 0.0)
    history = integrate_motion(run, plan, equations, guard, z0, result.t)[0]
    return centres(run.system, history.q)


FASTEST = 2.0
"""How many times the fastest rate of the motion at its start (``motion_rate``) errors are taken to grow at, at most:
measured, a double pendulum released level has lambda = 1.2 to 1.3/s against w = 3.1/s at its start."""


def too_short_to_diverge(plan: Plan, rtol: float, settings: Settings) -> str | None:
    """Why a run is too short for its errors to grow exponentially from rtol past the accuracy, or None: growing at
    FASTEST w (``motion_rate``), they take ln(accuracy / rtol) / (FASTEST w) to, longer than the run."""
    needed = math.log(settings.accuracy / rtol)
    if plan.rate is None or FASTEST * plan.rate * settings.t_end >= needed:
        return None
    return (
        f"too short to diverge: errors growing at {FASTEST:g} x the motion's fastest rate at the start "
        f"({plan.rate:.3g}/s) would take {needed / (FASTEST * plan.rate):.3g} s to grow from rtol to the accuracy"
    )


def same_method(run: Run, result: Result, **changes) -> Run:
    """The run again with ``changes`` to its settings, by the formulation, integrator and engine that made
    ``result`` (no points, no progress: a second run for the guards)."""
    engine = "compiled" if "compiled" in result.info else "numpy"
    formulation, integrator = _method(result)
    settings = run.settings.replace(formulation=formulation, integrator=integrator, engine=engine, **changes)
    return dataclasses.replace(run, settings=settings, points=None, progress=None)


def _method(result: Result) -> tuple[str, str]:
    return result.info["formulation"], result.info["integrator"]


def centres(system: System, q: np.ndarray) -> np.ndarray:
    """The body centres of a history of coordinates: (N, bodies, dimension)."""
    per, dim = system.coordinates_per_body, system.model.dimension
    return q.reshape(len(q), -1, per)[:, :, :dim]


def divergence_info(found: Divergence, rtol: float, k: float, scale: float | None = None) -> dict:
    """info['divergence']: the estimated position error (m) of eqs. 6.62-6.63 at the end of the span, of the run
    (or, a tightened run, of one at rtol ``scale``: the estimate of the first, scaled), and how it was found."""
    return {
        "positions": found.final * (1.0 if scale is None else scaled(rtol, scale)),
        "how": f"a run at {k:g} x rtol {rtol:.2g} departs by (k^beta - 1) x the error (eq. 6.62)"
        + (f", scaled to rtol {scale:.2g}" if scale is not None else ""),
        "measured_until": found.measured_until,
        "growth": found.growth,
        "doubling_time": found.doubling_time,
    }


def divergence_warning(found: Divergence, rtol: float, k: float, size: float, accuracy: float, held: float) -> str:
    """The line for an estimated error (eqs. 6.62-6.63) above ``accuracy`` x size, with the rtol of eq. 6.64, or,
    below what double precision holds (``held``), the time up to which the results meet the accuracy."""
    bound, need = accuracy * size, needed_rtol(found, rtol, accuracy * size)
    figure = (
        f"estimated position error about {min(found.final, size):.2g} m by t = {found.t[-1]:.3g} s (the run at "
        f"{k:g} x rtol departs from this one by (k^beta - 1) x its error, eq. 6.62), more than the accuracy "
        f"{accuracy:g} x {size:.3g} m = {bound:.2g} m"
    )
    if need >= held:
        return f"accuracy: {figure}; use rtol <= {need:.2g}"
    until, best = found.meets_until(bound), found.meets_until(bound, scaled(rtol, held))
    said = "the motion is chaotic: " if found.chaotic else ""
    doubling = f"errors double every {found.doubling_time:.2g} s; " if found.chaotic else ""
    return (
        f"accuracy: {said}{doubling}{figure}; results meet it up to t = {until:.3g} s"
        + (f" (at rtol {held:g}, the tightest double precision holds, up to t = {best:.3g} s)" if best > until else "")
        + "; no rtol holds it over the whole span: split the run, or ask for less (accuracy)"
    )


def dynamic_model(system: System, masses, forces) -> tuple[np.ndarray, ForceModel]:
    """The mass matrix M (eq. 5.4) and the force model of the run: the model's, or those given."""
    if masses is None:
        system.model.require_masses("dynamic")
    M = mass_matrix(system.model) if masses is None else masses
    return M, build_forces(system.model) if forces is None else forces


def plan_method(
    run: Run,
    M,
    forces,
    q,
    qd,
    formulation: str,
    integrator: str,
    rates: StartRates | None = None,
    rank: RankReport | None = None,
) -> Plan:
    """Stage 2: the formulation and integrator (``choose_method`` for ``auto``) and the tolerance rule
    (``default_rtol`` over the motion's periods), computed once; ``rates``, ``rank``: the run's ``StartRates`` and
    Psi_q's rank at q (``rank_at``), made here when not given."""
    system, model, settings = run.system, run.system.model, run.settings
    options = settings.formulation_options
    chosen = None
    if formulation == "joint-coordinates" and run.masses is not None and model.dimension == 3:
        raise AnalysisError(
            "the joint-coordinates formulation takes a spatial model's masses and inertias from the model: "
            "drop masses=, or choose another formulation"
        )
    if rank is None:
        rank = rank_at(system, q)
    if formulation != "auto" and integrator not in INDEX3_INTEGRATORS:
        _check_redundancy(rank, formulation)  # before ``auto`` evaluates the equations of motion
    if rates is None:
        rates = StartRates(system, M, forces, q, qd, options, settings.engine == "compiled", settings)
    if "auto" in (formulation, integrator):
        own_masses = run.masses is not None and model.dimension == 3  # the spatial tree takes the model's masses
        chosen = choose_method(
            system,
            M,
            forces,
            q,
            qd,
            settings.t_end,
            settings.rtol,
            formulation,
            integrator,
            trees=not own_masses,
            rates=rates,
            rank=rank,
            **options,
        )
        formulation, integrator = chosen["formulation"], chosen["integrator"]
    size = mechanism_size(system, q, run.prepared.fixed().extent if run.prepared is not None else None)
    periods = rate = None
    if integrator not in INDEX3_INTEGRATORS and integrator not in FIXED_STEP_METHODS:
        rate = motion_rate(system, M, forces, q, qd, formulation, options, rates, size)
        periods = periods_at(rate, settings.t_end)
    rtol = settings.rtol if settings.rtol is not None else default_rtol(periods, settings.accuracy)
    if settings.rtol is None and formulation == "partitioning":  # its dependent velocities: outside the control
        rtol = max(MIN_RTOL, rtol / PARTITIONING_VELOCITIES)
    estimated = rates.numpy_seconds.get(formulation)  # (rtol, seconds, compiled): the engine's choice's estimate
    expected = estimated[1] if estimated is not None and (estimated[0] == rtol or estimated[2]) else None
    given = settings.rtol is not None
    return Plan(formulation, integrator, rtol, settings.atol, given, periods, size, chosen, rate, expected)


def index3_run(run: Run, plan: Plan, M, forces, q, qd, initial: dict, rank: RankReport | None = None) -> Result:
    """The implicit index-3 integrators (HHT-alpha, generalized-alpha, ``implicit.py``): formulation and ODE in one;
    ``rank``: Psi_q's rank at q as the run's start made it (``Start.rank``)."""
    from .implicit import integrate_index3

    system, settings = run.system, run.settings.replace(integrator=plan.integrator, rtol=plan.rtol)
    guard = index3_guard(run, plan, q, rank)
    result = integrate_index3(system, M, forces, q, qd, settings, guard)
    for label, (body, point) in (run.points or {}).items():
        result.points.update(point_columns(result, label, body, point))
    result.reactions.update(joint_reactions(system, result.q, result.lam, result.t))
    result.reactions.update(effort_columns(system, result.q, result.lam, result.t))
    result.forces.update(element_columns(forces, result.t, result.q, result.qd))
    result.info.update(assembly=initial["assembly"], initial_conditions=initial)
    result.info.update(closest_singularity=guard.closest, singular_positions=guard.crossings)
    why = "numpy engine asked for" if run.settings.engine == "numpy" else "not compiled: no index-3 integrator is"
    result.info["chosen"] = {**(plan.chosen or {}), "engine": "numpy", "engine_why": why}  # one verdict: numpy's
    result.info["warnings"] = accuracy_warnings(result.info, plan.size, run.settings.accuracy, None) + guard.warnings
    return result


INDEX3_DRIFT_REMEDY = (
    "take a smaller rtol or step: the index-3 equations hold Psi = 0 only as far as their Newton iterations "
    "converge (newton_tol, in units of rtol)"
)
"""What it advises for an index-3 run (hht, generalized-alpha), which solves Psi(q) = 0 itself at every step."""


def index3_guard(run: Run, plan: Plan, q: np.ndarray, rank: RankReport | None = None) -> Guard:
    """The ``Guard`` of an index-3 run (``implicit.GuardedSteps`` makes its checks): drift as ``make_guard``'s, and
    singular positions recorded as passed (``through``), as with the augmented Lagrangian: the index-3 equations
    carry the motion through them, and the branch check judges the branch it took at each."""
    drift_limit = run.settings.drift_limit
    loose = 100.0 * plan.rtol if run.settings.step is None else 0.0  # a loose tolerance drifts further
    drift_limit = None if drift_limit is None else max(drift_limit, loose)
    known = None if rank is None else rank.rank  # None: the Guard makes it
    guard = Guard(run.system, q, drift_limit, run.settings.singular_ratio, through=True, size=plan.size, rank=known)
    guard.remedy = INDEX3_DRIFT_REMEDY
    return guard


def held_tolerances(plan: Plan, equations: EquationsOfMotion) -> tuple[Plan, list[str]]:
    """The plan with rtol and atol raised to what the formulation holds (its ``held_rtol``, a penalty's
    rounding), and the warning that says so."""
    held = getattr(equations.formulation, "held_rtol", None)
    rtol, atol = plan.rtol, plan.atol
    if held is None or plan.integrator in FIXED_STEP_METHODS or min(rtol, atol) >= held:
        return plan, []
    said = (
        f"rtol {rtol:.2g}, atol {atol:.2g} raised to {max(rtol, held):.2g}, {max(atol, held):.2g}: the "
        f"tightest the {plan.formulation} formulation holds is {held:.2g} (its accelerations carry the rounding "
        "errors of its penalty; a smaller step cannot remove them)"
    )
    return dataclasses.replace(plan, rtol=max(rtol, held), atol=max(atol, held)), [said]


def make_guard(run: Run, plan: Plan, equations: EquationsOfMotion, q: np.ndarray, rank: RankReport | None) -> Guard:
    """The run's ``Guard``: drift at least 100 rtol for a loose tolerance; none for an open tree in joint
    coordinates, on the constraints by construction with a full-rank Psi_q everywhere."""
    drift_limit, singular_ratio = run.settings.drift_limit, run.settings.singular_ratio
    loose = 100.0 * plan.rtol if plan.integrator not in FIXED_STEP_METHODS else 0.0  # a loose tolerance drifts further
    if plan.formulation == "joint-coordinates" and not equations.formulation.cut_rows:  # an open tree
        drift_limit = singular_ratio = None  # nothing for the Guard to see
    return Guard(
        run.system,
        q,
        None if drift_limit is None else max(drift_limit, loose),
        singular_ratio,
        through=plan.formulation in THROUGH_SINGULAR,
        size=plan.size,
        weights=run.prepared.fixed().weights if run.prepared is not None and singular_ratio else None,
        rank=0 if rank is None else rank.rank,
    )


def integrate_motion(run: Run, plan: Plan, equations, guard: Guard, z0: np.ndarray, times: np.ndarray) -> tuple:
    """Stage 3: the history at the output times from the state z0, by the compiled engine where it covers the
    run, else numpy. Returns (history, integrator statistics, the compiled run or None, what was chosen)."""
    settings = run.settings.replace(
        formulation=plan.formulation, integrator=plan.integrator, rtol=plan.rtol, atol=plan.atol
    )
    history = _History(times.size, run.system.n_coordinates, run.system.n_constraints, equations.extra)
    chosen = plan.chosen
    if settings.engine != "numpy":  # the compiled engine (numba), imported only when asked for
        compiled, stats, engine_choice = compiled_motion(settings, equations, guard, z0, times, history, plan)
        chosen = {**(chosen or {}), **engine_choice}
        if compiled is not None:
            return history, stats, compiled, chosen

    history.allocate()
    filled = [0]  # output times stored so far

    def record(k: int, t: float, z: np.ndarray) -> None:
        guard.flush()  # the checks after the steps before this output time, in time order
        y, energies = equations.split(z)
        q, qd = equations.formulation.coordinates(t, y)
        history.constraints(k, run.system, q, t)  # Psi, Psi_q, Psi_t: the drift check's and the result's
        guard.check_drift(q, t, history.psi[k], history.jac[k])
        history.store(k, q, qd, *equations.formulation.accelerations(q, qd, t), energies)
        filled[0] = k + 1
        if run.progress is not None:
            run.progress(float(t))

    try:
        stats = integrate(
            equations.rhs, z0, times, record, method=settings.integrator, rtol=settings.rtol, atol=settings.atol,
            step=settings.step, after_step=guarded_after_step(equations, guard, deferred=True),
            max_evaluations=settings.max_evaluations, stiffness=settings.stiffness,
        )  # fmt: skip
    except Exception as err:  # a branch switch before the stop is its cause: said first, as the compiled run
        k = filled[0]
        try:  # the steps not judged yet come before the stop: a singular one is what stopped a check after every step
            guard.flush()
        except AnalysisError as judged:
            guard.check_branches_before(judged, times[:k], history.q[:k], history.qd[:k], history.qdd[:k])
            raise judged from None
        if not isinstance(err, AnalysisError):
            raise
        guard.check_branches_before(err, times[:k], history.q[:k], history.qd[:k], history.qdd[:k])
        raise
    guard.flush()
    if guard.judges_branches(times):  # the branch at every singular position passed (as the compiled run's)
        guard.check_branches(times, history.q, history.qd, history.qdd, history.jac)
    return history, stats, None, chosen


def guarded_after_step(equations: EquationsOfMotion, guard: Guard, deferred: bool = False):
    """What the numpy engine does after every step: the formulation's correction, then the Guard's look at the
    configuration (when it watches for singular ones); ``deferred``: kept for the Guard's next ``flush``, which the
    caller makes at every output time and before it raises anything else."""
    if not guard.singular_ratio:
        return equations.after_step
    check = guard.queue if deferred else guard.check_configuration

    def after_step(t: float, z: np.ndarray) -> np.ndarray | None:
        corrected = equations.after_step(t, z)
        check(equations.formulation, t, equations.split(z if corrected is None else corrected)[0])
        return corrected

    return after_step


def compiled_motion(settings: Settings, equations, guard, z0, times, history, plan: Plan | None = None) -> tuple:
    """The compiled engine's run into ``history`` when it covers it (``compiled.dispatch``); (the compiled run or
    None, integrator statistics or None, what was chosen and why).

    One verdict on either engine: the compiled loop runs without the Guard, which then judges its output times;
    a run that stopped early is judged where it stopped too (``judge_stop``), and one that passed close to a
    singular position between output times (``singular_dip``) is handed back to the numpy engine, whose Guard
    judges every step (issue 29)."""
    try:
        from .compiled import dispatch
    except ImportError:  # a student package: the compiled engine stays with the instructor
        return None, None, {"engine": "numpy", "engine_why": "this package has no compiled engine"}
    scene, chosen = dispatch.choose(settings, equations, z0, plan.numpy_seconds if plan is not None else None)
    if scene is None:
        return None, None, chosen
    guard.banded = True  # numba is loaded: the output times' checks may take the band of a large Psi_q
    on_pause = None  # the checks between steps (``judge_pause``): only where the Guard watches for singular positions
    if guard.singular_ratio and guard.rank and not guard.through:
        pauses = shallow_copy(guard)  # sees the pauses in time order, apart from the output times' checks
        on_pause = lambda *state: judge_pause(pauses, *state)  # noqa: E731
    compiled, stats = dispatch.run(scene, z0, times, settings, on_pause=on_pause)
    n = equations.formulation.n
    Y, k = compiled.Y, compiled.reached
    stopped = dispatch.stop(compiled, stats, settings, times[-1] - times[0])
    if stopped is not None:  # the numpy engine's Guard saw every step up to the stop: this one sees where it stopped
        try:
            judge_stop(guard, compiled, times, n)
        except AnalysisError as err:  # a branch switch before the stop is its cause: said first, as the numpy run
            guard.check_branches_before(err, times[:k], Y[:k, :n], Y[:k, n : 2 * n], compiled.qdd[:k])
            raise
        guard.check_branches_before(stopped, times[:k], Y[:k, :n], Y[:k, n : 2 * n], compiled.qdd[:k])
        raise stopped
    # the checks at the output times (the numpy engine: drift at output times, configuration after every
    # step), from Psi and Psi_q the compiled module gives for all of them at once
    judged = shallow_copy(guard)
    try:
        judged.check_outputs(times, Y[:, :n], compiled.psi, compiled.jac)
    except AnalysisError as err:  # a branch switch before the stop is its cause: said first, as the numpy run
        k = int(np.searchsorted(times, judged.judged, side="left"))
        guard.check_branches_before(err, times[:k], Y[:k, :n], Y[:k, n : 2 * n], compiled.qdd[:k])
        raise
    near = judged.closest is not None and judged.closest["ratio"] < NEAR_SINGULAR  # else no output time dips
    dip = singular_dip(judged, times, compiled.jac) if near and not guard.through else None
    if dip is not None:  # it passed one between output times, unseen: the numpy engine's verdict
        why = (
            f"the compiled run passed near a singular position at t = {dip[0]:.6g} s (smallest singular value "
            f"{dip[1]:.2g} of the largest at an output time), where only the numpy engine checks every step"
        )
        return None, None, {**chosen, "engine": "numpy", "engine_why": why}
    guard.__dict__.update(judged.__dict__)
    history.q, history.qd = Y[:, :n].copy(), Y[:, n : 2 * n].copy()
    history.qdd, history.lam, history.energies = compiled.qdd, compiled.lam, Y[:, 2 * n :]
    history.psi, history.jac, history.psit = compiled.psi, compiled.jac, compiled.psit
    guard.check_branches(times, history.q, history.qd, history.qdd, compiled.jac)
    return compiled, stats, chosen


def restartable(err: AnalysisError, guard: Guard, plan: Plan) -> bool:
    """Whether ``auto`` stopped at a singular position (by the Guard, or by an integrator that lost its step next
    to one the Guard saw coming: an even rank loss, e.g. one per loop of a chain, keeps the sign of det) with a
    method that a formulation passing it can replace (not a multistep integrator)."""
    near = guard.closest is not None and guard.closest["ratio"] < NEAR_SINGULAR
    singular = isinstance(err, SingularConfigurationError) or near
    return singular and plan.formulation not in THROUGH_SINGULAR and plan.integrator not in MULTISTEP_INTEGRATORS


def build_result(run: Run, equations, guard, history, compiled, times) -> tuple[Result, object]:
    """Stage 4: q, q', q'', lambda with the residuals, energies, points, joint reactions (eq. 5.70) and what the
    force elements exert (from q, q': the same whichever engine ran); and
    the energy history (``energy.energy_history``)."""
    system = run.system
    result = Result(
        t=times,
        q=history.q,
        qd=history.qd,
        qdd=history.qdd,
        coordinate_names=system.coordinate_names,
        body_names=[b.name for b in system.model.bodies],
        lam=history.lam,
    )
    if getattr(history, "jac", None) is None:  # a history kept without Psi at its output times (an FMU's steps)
        history.psi, history.jac, history.psit = constraint_arrays(system, times, history.q)
    masses, kinetic, elements = equations.formulation.masses, None, None
    if compiled is None:
        residuals = output_history.residuals(history.psi, history.jac, history.psit, history.qd)
    else:  # over each row's nonzero columns, in compiled loops; T by the model's M (``kinetic_energy``)
        from .compiled import history as compiled_history

        residuals = compiled_history.residuals(compiled.psi, compiled.jac, compiled.psit, history.qd, system)
        kinetic = compiled_history.kinetic_energy(masses, history.q, history.qd)
        elements = compiled_elements(equations.forces, system.model.dimension, times, history.q, history.qd)
    columns, potential = elements if elements is not None else (None, None)
    accumulated = history.energies.T if equations.extra else ()
    energies = energy_history(
        masses, equations.forces, history.q, history.qd, *accumulated, kinetic=kinetic, potential=potential
    )
    result.points.update(residuals)
    result.points.update(energies.columns())
    for label, (body, point) in (run.points or {}).items():
        result.points.update(point_columns(result, label, body, point))
    redundant = guard.rank < system.n_constraints
    if redundant:  # multipliers are not unique: report the minimum-norm set (eq. 5.73)
        result.lam = history.lam = minimum_norm_multipliers(system, history.q, history.lam, times)
    if redundant:
        result.reactions.update(joint_reactions(system, history.q, history.lam, times))
    elif compiled is None:  # every joint at every output time at once, from the Psi_q there (eq. 5.70, 10.20)
        result.reactions.update(output_history.joint_reactions(system, history.q, history.lam, history.jac))
    else:  # the same, in compiled loops over an index layout made once per system
        result.reactions.update(compiled_history.joint_reactions(system, history.q, history.lam, compiled.jac))
    result.reactions.update(effort_columns(system, history.q, history.lam, times))
    if columns is None:  # each element's per-state methods at every output time (the numpy engine's)
        columns = element_columns(equations.forces, times, history.q, history.qd)
    result.forces.update(columns)
    return result, energies


def compiled_elements(forces, dimension: int, times: np.ndarray, q: np.ndarray, qd: np.ndarray) -> tuple | None:
    """(the force elements' result columns, V) at the output times of a compiled run, in compiled loops
    (``compiled.element_history``); None where the model has no force element (V of gravity alone is one product)
    or one the compiled kernels do not cover."""
    if not forces.elements:
        return None
    from .compiled.element_history import element_history

    return element_history(forces, dimension, times, q, qd)


def run_info(run: Run, plan: Plan, equations, guard, stats, result, energies, initial: dict) -> DynamicInfo:
    """How the result was obtained (DESIGN section 5)."""
    drift = largest(result.points["energy.error"])  # max |E(t) - E(0)|: the result's column (``EnergyHistory.error``)
    return {
        "analysis": "dynamic",
        "formulation": plan.formulation,
        "integrator": plan.integrator,
        "rtol": plan.rtol,
        "atol": plan.atol,
        "step": run.settings.step,
        "steps": run.settings.steps,
        "rhs_evaluations": stats.rhs_evaluations,
        "integrator_steps": stats.steps,
        "rejected_steps": stats.rejected,
        "restarts": stats.restarts,
        "stiffness": None if stats.stiffness is None else stiffness_message(plan.integrator, stats.stiffness),
        "closest_singularity": guard.closest,
        "singular_positions": guard.crossings,
        "max_constraint_residual": float(result.points["residual.position"].max()),
        "max_velocity_residual": float(result.points["residual.velocity"].max()),
        "energy_drift": drift,
        "energy_drift_relative": drift / energies.scale,
        "assembly": initial["assembly"],
        "initial_conditions": initial,
        **_formulation_info(equations.formulation),
    }


class StartRates:
    """rho, the spectral radius of the ODE's Jacobian at the start (``integrators.spectral_radius``: 21
    evaluations of the right-hand side), and q'' at the start, for a formulation: computed once per formulation
    and shared by the integrator's choice (``choose_method``) and the tolerance rule (``motion_periods``). A run
    that its engine's choice will compile evaluates them with the compiled engine's right-hand side
    (``compiled.dispatch.start_rates``: the same equations, microseconds instead of a numpy evaluation's
    tenths of a millisecond), as its integration will: one asked to be compiled (``compiled``), and, where
    ``settings`` are given, one on engine ``cached`` or ``auto`` that the compiled engine will take
    (``compiled.dispatch.compiled_start``: its code on disk, and for ``auto`` a numpy run estimated longer than
    loading it, at the loosest rtol the run can have: DEFAULT_RTOL or the one given). Other runs evaluate them
    with numpy's, and import no numba. None where the equations cannot be evaluated at the start (the run itself
    says why)."""

    def __init__(
        self, system: System, M, forces: ForceModel, q, qd, options: dict, compiled=False, settings=None, prepared=None
    ) -> None:
        self.system, self.M, self.forces, self.q, self.qd, self.options = system, M, forces, q, qd, options
        self.prepared = prepared  # a prepared run's (``Prepared``): its formulation objects and compiled plans
        self.compiled, self.settings = compiled, settings
        self.numpy_seconds: dict[str, tuple] = {}  # the engine's choice's estimates: (rtol, seconds, compiled)
        self.known: dict[str, tuple[float, np.ndarray] | Exception] = {}
        self.untouched: dict[str, Formulation] = {}  # made, and evaluated only by the compiled engine
        self.states: dict[str, tuple[Formulation, np.ndarray]] = {}  # the object made, its start state y

    def take(self, formulation: str) -> Formulation | None:
        """The formulation object made for the compiled start rates, handed over once (to the run itself, which
        would make the same object from the same system, M, forces and options: ``ode_motion``), or None where
        there is none or the numpy start rates were evaluated on it (a formulation may keep state between
        evaluations: the partition of ``partitioning``). An ``auto`` engine's estimate of the numpy run
        (``compiled.dispatch.compiled_start``) evaluates the right-hand side of a compiled formulation, which keeps
        nothing that changes a later result (the last motion of ``joint-coordinates``, the last M(q) of a
        spatial one: each made anew for another state)."""
        return self.untouched.pop(formulation, None)

    def __call__(self, formulation: str) -> tuple[float, np.ndarray] | None:
        """(rho, q'') at the start, or None where the equations cannot be evaluated there."""
        if formulation not in self.known:
            try:
                self.known[formulation] = self._evaluate(formulation)
            except (AnalysisError, np.linalg.LinAlgError, ValueError) as err:
                self.known[formulation] = err
        found = self.known[formulation]
        return None if isinstance(found, Exception) else found

    def required(self, formulation: str) -> tuple[float, np.ndarray]:
        """(rho, q'') at the start; raises what evaluating the equations there raised."""
        found = self(formulation)
        if found is None:
            raise self.known[formulation]
        return found

    def _evaluate(self, formulation: str) -> tuple[float, np.ndarray]:
        prepared = self.prepared
        if prepared is None:
            made = make_formulation(formulation, self.system, self.M, self.forces, **self.options)
        else:
            made = prepared.formulation(formulation, self.M, self.forces, self.options)
        plans = None if prepared is None else prepared.compiled_plans
        equations = EquationsOfMotion(made, self.forces, False, plans)  # no drivers' power: it feeds nothing back
        z = equations.initial_state(self.q, self.qd, 0.0)
        self.states[formulation] = (made, equations.split(z)[0])
        if self.compiled or self._will_compile(equations, formulation, z):
            found = _compiled_start_rates(equations, formulation, self.options, z)
            if found is not None:
                self.untouched[formulation] = made
                return found
        y, _ = equations.split(z)  # without the energy states (a dissipative scene has them)
        qdd, _ = made.accelerations(*made.coordinates(0.0, y), 0.0)
        return spectral_radius(equations.rhs, 0.0, z, equations.rhs(0.0, z)), qdd

    def initial_state(self, equations: EquationsOfMotion) -> np.ndarray:
        """z0 of ``equations`` at the start (q, q'): the state the start rates were evaluated at, where its
        formulation object is the one they made (``take``; a joint-coordinates state costs 15-150 us of Python,
        and making it sets a prismatic joint's ``u0`` on the object that made it), with the energy states the
        run's equations have (zero); else made anew."""
        for made, y in self.states.values():
            if made is equations.formulation:
                return np.concatenate([y, np.zeros(equations.extra)]) if equations.extra else y.copy()
        return equations.initial_state(self.q, self.qd, 0.0)

    def _will_compile(self, equations, formulation: str, z: np.ndarray) -> bool:
        """Whether the engine's choice will compile a run of ``formulation`` on engine ``cached`` or ``auto``
        (``compiled.dispatch.compiled_start``, decided before the start rates); its estimate of the numpy run, where
        it made one, kept in ``numpy_seconds`` for the plan."""
        settings = self.settings
        if settings is None or settings.engine not in ("cached", "auto"):
            return False
        try:
            from .compiled import dispatch
        except ImportError:  # a student package: no compiled engine
            return False
        loosest = settings.rtol if settings.rtol is not None else DEFAULT_RTOL  # the rule only tightens it
        compiled, expected = dispatch.compiled_start(settings, equations, formulation, z, loosest)
        if expected is not None:
            self.numpy_seconds[formulation] = (loosest, expected, compiled)
        return compiled


def _compiled_start_rates(equations, formulation: str, options: dict, z: np.ndarray):
    try:
        from .compiled import dispatch
    except ImportError:  # a student package: no compiled engine
        return None
    return dispatch.start_rates(equations, formulation, options, z)


def motion_periods(
    system: System,
    M,
    forces: ForceModel,
    q,
    qd,
    t_end: float,
    formulation: str,
    options: dict,
    rates: StartRates | None = None,
    size: float | None = None,
) -> float:
    """How many periods of the fastest motion a run spans: t_end w / (2 pi), with the rate w the largest of

    - rho, the spectral radius of the ODE's Jacobian at the start (``integrators.spectral_radius``: the
      largest angular frequency, or decay rate, of the linearized motion; with Baumgarte terms, theirs too),
    - |q'| / L and sqrt(|q''| / L) at the start (L the mechanism's size; the rate of a large motion, such as a
      pendulum released level, whose linearization at the start says nothing: there rho = 0).

    rho and q'' come from ``rates`` (``StartRates``, shared with ``choose_method``), made here when not given; L is
    ``size`` when given (``mechanism_size``).
    """
    return periods_at(motion_rate(system, M, forces, q, qd, formulation, options, rates, size), t_end)


def periods_at(rate: float | None, t_end: float) -> float:
    """P = t_end w / (2 pi), at least 1, of the rate w (``motion_rate``); 1 where w is unknown."""
    return 1.0 if rate is None else max(1.0, float(t_end) * rate / (2.0 * np.pi))


def motion_rate(
    system: System, M, forces, q, qd, formulation: str, options: dict, rates=None, size: float | None = None
) -> float | None:
    """w of ``motion_periods`` (1/s), or None where the equations cannot be evaluated at the start; L is ``size``
    when given (``mechanism_size``)."""
    start = (rates or StartRates(system, M, forces, q, qd, options))(formulation)
    if start is None:
        return None  # the run itself will say what is wrong
    rho, qdd = start
    size = mechanism_size(system, q) if size is None else size
    speed, acceleration = largest(qd), largest(qdd)
    rate = max(rho, speed / size, (acceleration / size) ** 0.5)
    return float(rate) if np.isfinite(rate) else None


def default_rtol(periods: float | None, accuracy: float = DEFAULT_ACCURACY) -> float:
    """The rule for the tolerance a user does not give (eq. 6.60):

        rtol = max(MIN_RTOL, min(DEFAULT_RTOL, accuracy / P^2)),   P = periods of the fastest motion (motion_periods)

    An adaptive explicit method holds the local error near rtol per step, but it does not keep the energy: the
    energy error grows with time, so does the error of the frequency, and the phase error of an oscillation
    grows with the square of the number of periods. Measured on a pendulum released level (DOP853, P = 170 and
    1700 periods, benchmarks/accuracy.md) the position error is 0.4 to 0.5 rtol P^2 L; the rule keeps it below
    ``accuracy`` L with a margin of 2. Runs of up to 10 periods keep DEFAULT_RTOL. None (implicit or
    fixed-step methods: no estimate of P) gives DEFAULT_RTOL.
    """
    if periods is None:
        return DEFAULT_RTOL
    return float(max(MIN_RTOL, min(DEFAULT_RTOL, accuracy / max(1.0, periods) ** 2)))


def accuracy_estimate(info: dict, size: float, periods: float | None) -> dict | None:
    """The estimated errors of a run (eq. 6.61), each a figure to hold against ``accuracy``; for rk4 (a fixed step
    has no error control) the energy alone; None where neither rtol nor the energy is known.

    - positions (m): rtol P^2 L for an explicit adaptive method (``default_rtol``; rtol no smaller than HELD_RTOL,
      what double precision holds), rtol N L for the second-order implicit ones (hht, generalized-alpha), whose
      local errors, each held near rtol L, add up over their N steps; and no less than what the measured energy
      error implies: a relative error e of the energy is one of e / 2 in the speed, so the phase lags by
      e / 2 x 2 pi radians a period, pi e L over the period of the large motion at least (the augmented
      Lagrangian's penalty error and a singular position passed show here: their errors are not the
      integrator's, so rtol does not bound them);
    - velocities (relative to the largest speed V of the run): the same fraction, positions / L. The rule bounds
      the phase error theta (radians) of every motion the run spans; a motion of amplitude a <= L and rate w errs
      by theta a in position and theta w a in velocity, and w a, its speed, is at most V. (Measured: a four-bar
      with a 1e5 N/m spring asked for 1e-5, whose small fast oscillation errs 7 times more in velocity than in
      position, relative to V and L: qr 1.4e-5, baumgarte 1.2e-6; the position estimate 1e-5.); for coordinate
      partitioning PARTITIONING_VELOCITIES times that (its dependent velocities are outside the integrator's
      error control);
    - energy (relative to the energy scale, ``EnergyHistory.scale``): the measured max |E(t) - E(0)| (eq. 5.60),
      for every scene (the balance counts dampers, loads and drivers).
    """
    rtol, energy = info.get("rtol"), info.get("energy_drift_relative")
    if info.get("integrator") in FIXED_STEP_METHODS:  # no error control: the measured energy alone
        return None if energy is None else {"positions": None, "velocities": None, "energy": energy, "how": ""}
    if rtol is None:
        return None
    p = 1.0 if periods is None else periods
    if info.get("integrator") in INDEX3_INTEGRATORS:
        steps = max(1, int(info.get("integrator_steps", 1)))
        positions, how = (
            rtol * steps * size,
            f"rtol x {steps} steps x size: the local errors of a second-order method add up",
        )
    else:
        positions, how = max(rtol, HELD_RTOL) * p * p * size, f"rtol x ({p:.3g} periods of the fastest motion)^2 x size"
        if rtol < HELD_RTOL:
            how += f", with rtol {rtol:.2g} held only to {HELD_RTOL:g} in double precision"
    if energy is not None and np.pi * energy * size > positions:
        positions = np.pi * energy * size
        how = f"pi x the energy error {energy:.2g} x size: a period's phase lag of a speed off by half of it"
    velocities = positions / size
    if info.get("formulation") == "partitioning":  # dependent velocities outside the integrator's control
        velocities *= PARTITIONING_VELOCITIES
        how += f"; velocities x {PARTITIONING_VELOCITIES:g} (partitioning's dependent velocities, eq. 5.40)"
    return {"positions": float(positions), "velocities": float(velocities), "energy": energy, "how": how}


def accuracy_warnings(
    info: dict,
    size: float,
    accuracy: float,
    periods: float | None,
    speed: float | None = None,
    held: float = HELD_RTOL,
    found: dict | None = None,
) -> list[str]:
    """One line for positions and velocities and one for energy when the estimated error (``accuracy_estimate``,
    ``found`` where the caller made it) exceeds ``accuracy`` (positions: times the mechanism's size; velocities:
    times ``speed``, the run's largest; energy: of the energy scale), with the figure and what to do (``held``: the
    tightest rtol the run's formulation holds, ``held_tolerances``)."""
    found = accuracy_estimate(info, size, periods) if found is None else found
    if found is None:
        return []
    rtol, energy, positions = info.get("rtol"), found["energy"], found["positions"]
    lines = []
    if energy is not None and energy > accuracy:
        lines.append(
            f"accuracy: energy balance off by {energy:.2g} of the energy scale (max |E(t) - E(0)| = "
            f"{info.get('energy_drift', float('nan')):.2g} J, eq. 5.60), more than the accuracy {accuracy:g}; "
            + _energy_remedy(found, rtol, accuracy, held, _remedy(info, found, size, accuracy, periods))
        )
    if positions is not None and positions <= accuracy * size and speed:
        if found["velocities"] > accuracy:  # partitioning's: velocities beyond, positions within
            smaller = max(rtol * accuracy / found["velocities"] / 3.0, MIN_RTOL)
            lines.append(
                f"accuracy: estimated velocity error {found['velocities'] * speed:.2g} m/s ({found['how']}) exceeds "
                f"the accuracy {accuracy:g} x {speed:.3g} m/s, the largest speed, = {accuracy * speed:.2g} m/s; use "
                f"rtol <= {smaller:.2g}"
            )
    elif positions is not None and positions > accuracy * size:
        remedy = _remedy(info, found, size, accuracy, periods)
        if found["how"].startswith("pi x the energy"):  # the position estimate is the energy's
            remedy = _energy_remedy(found, rtol, accuracy, held, remedy)
        velocities = f" and velocity error {found['velocities'] * speed:.2g} m/s" if speed else ""
        lines.append(
            f"accuracy: estimated position error {positions:.2g} m{velocities} ({found['how']}) exceeds the "
            f"accuracy {accuracy:g} x {size:.3g} m = {accuracy * size:.2g} m"
            + (f" (x {speed:.3g} m/s, the largest speed, = {accuracy * speed:.2g} m/s)" if speed else "")
            + f"; {remedy}"
        )
    return lines


def _remedy(info: dict, found: dict, size: float, accuracy: float, periods: float | None) -> str:
    """What ``accuracy_warnings`` advises for a position error beyond the accuracy: the rtol of the tolerance rule
    (eq. 6.60), dop853 for an index-3 run, a smaller step for rk4; worded only where a line says it."""
    rtol, p = info.get("rtol"), 1.0 if periods is None else periods
    if found["positions"] is None:  # rk4: a smaller step is its only remedy
        return "a smaller --step"
    if info.get("integrator") in INDEX3_INTEGRATORS:
        steps = max(1, int(info.get("integrator_steps", 1)))
        return (
            f"dop853 at the same rtol reaches about {rtol * size:.2g} m over a few periods; use it, or rtol <= "
            f"{accuracy / steps:.2g}"
        )
    factor = PARTITIONING_VELOCITIES if info.get("formulation") == "partitioning" else 1.0
    return f"use rtol <= {max(accuracy / p / p / factor, MIN_RTOL):.2g}" + (
        " (or leave rtol unset: the default follows this rule)"
        if accuracy / p / p >= HELD_RTOL
        else ", the tightest a double-precision run can hold; or split the run, or ask for less (accuracy)"
    )


def _energy_remedy(found: dict, rtol: float | None, accuracy: float, held: float, remedy: str) -> str:
    """What to do about an energy error: the rtol that brings it below a third of ``accuracy`` (it follows rtol),
    or, below what the formulation holds, that no rtol will; rk4: ``remedy`` (a smaller step)."""
    if found["positions"] is None or not found["energy"]:
        return remedy
    smaller = rtol * accuracy / found["energy"] / 3.0
    if smaller >= max(held, HELD_RTOL):
        return f"use rtol <= {smaller:.2g}"
    return (
        "a tighter rtol cannot bring it down (the error is the formulation's, e.g. at a singular position passed, "
        "not the integrator's): check the result against a run with another formulation or rtol"
    )


DRIFT_WARNING = 1e-6
"""Largest constraint residual, as a fraction of the mechanism's size, that a run returns without a warning
(between it and the Guard's drift limit a run goes on, and its result says how far it drifted, and why)."""


def drift_warnings(info: dict, size: float, formulation: str, options: dict) -> list[str]:
    """One line for a result whose positions or velocities have drifted off the constraints (info['warnings'])."""
    residual = info["max_constraint_residual"]
    if residual <= DRIFT_WARNING * size:
        return []
    unstabilized = formulation in ("qr", "svd") or (
        formulation == "baumgarte" and options.get("alpha", 1.0) == 0.0 and options.get("beta", 1.0) == 0.0
    )
    equation = {"qr": "5.45", "svd": "5.47"}.get(formulation, "5.29 with alpha = beta = 0")
    why = (
        f"{formulation} without stabilization lets the constraint error grow (eq. {equation}); "
        if unstabilized
        else "the integrator's error reaches the constraints; "
    )
    advice = {
        "baumgarte": "--formulation projection, larger --alpha and --beta, or a tighter --rtol",
        "projection": "a tighter --rtol (it projects every step) or --formulation augmented-lagrangian",
        "augmented-lagrangian": "a tighter --rtol, or --formulation projection",
    }.get(formulation, "--formulation projection, --formulation baumgarte --alpha 5 --beta 5, or a tighter --rtol")
    if unstabilized and formulation == "baumgarte":
        advice = "--alpha 5 --beta 5 (Baumgarte's stabilization), --formulation projection, or a tighter --rtol"
    return [
        f"constraint drift: max |Psi| = {residual:.2g}, above {DRIFT_WARNING:g} of the mechanism's size "
        f"({size:.3g} m): {why}try {advice}"
    ]


STIFF_STEPS = 20_000
"""``choose_method`` takes an implicit method when an explicit one would need more steps than this for
stability alone (t_end rho / stability limit)."""


def choose_method(
    system: System,
    M,
    forces: ForceModel,
    q: np.ndarray,
    qd: np.ndarray,
    t_end: float,
    rtol: float | None,
    formulation: str = "auto",
    integrator: str = "auto",
    *,
    trees: bool = True,
    rates: StartRates | None = None,
    rank: RankReport | None = None,
    **options,
) -> dict:
    """The cheapest adequate formulation and integrator for a scene (``auto``), and why (rho from ``rates``,
    shared with ``motion_periods``; made here when not given).

    - formulation: ``joint-coordinates`` when the joints form an open tree it takes (minimal
      coordinates: a k x k system per evaluation, nothing to stabilize; ``joint_coordinates.open_tree``;
      closed loops, which it takes with cut joints, measured slower than baumgarte),
      ``augmented-lagrangian`` when the constraints are redundant (it takes them and, unlike ``svd``,
      keeps the positions on the constraints), otherwise ``baumgarte``: one linear solve per evaluation,
      the cheapest of the others. When a run with ``baumgarte`` meets a singular position (the Guard
      stops it), ``forward_dynamics`` runs it again with ``augmented-lagrangian``, which passes it. Formulation options
      (``alpha``, ``rank_tol``, ...) keep the choice among the formulations that take them, and so does
      ``trees=False`` (a spatial run given its own masses: the tree takes the model's);
    - integrator: the spectral radius rho of the ODE's Jacobian at the start (``spectral_radius``)
      says how many steps an explicit method needs for stability alone, t_end rho / 6 for DOP853;
      beyond STIFF_STEPS the scene is stiff and ``Radau`` (implicit, L-stable) is taken. Otherwise
      this package's ``dop853`` at rtol <= 1e-5 (eighth order: the fewest evaluations at tight
      tolerances) and ``rk45`` at looser ones.
    """
    reasons = []
    if formulation == "auto":
        not_a_tree = "formulation options given" if options else open_tree(system) if trees else "masses given"
        report = rank if rank is not None else rank_at(system, q)
        redundant = report.n_redundant if report is not None else 0
        if not_a_tree is None:
            formulation = "joint-coordinates"
            reasons.append("joint-coordinates: an open tree of joints (minimal coordinates)")
        else:
            formulation = "augmented-lagrangian" if redundant else "baumgarte"
            kind = "redundant" if redundant else "independent"
            reasons.append(f"{formulation}: {kind} constraints; not joint-coordinates: {not_a_tree}")
    if integrator == "auto":
        rho = (rates or StartRates(system, M, forces, q, qd, options)).required(formulation)[0]
        stability_steps = t_end * rho / STABILITY_LIMIT["dop853"]
        if stability_steps > STIFF_STEPS:
            integrator = "Radau"
        else:
            integrator = "dop853" if (DEFAULT_RTOL if rtol is None else rtol) <= 1e-5 else "rk45"
        reasons.append(f"{integrator}: spectral radius {rho:.3g} 1/s, {stability_steps:.3g} steps for stability alone")
    return {"formulation": formulation, "integrator": integrator, "why": "; ".join(reasons)}


class _History:
    """Output arrays filled as the integrator passes the output times (``allocate``: a compiled run hands its own
    over instead)."""

    def __init__(self, size: int, n: int, m: int, extra: int):
        self.q = self.qd = self.qdd = self.lam = self.energies = None
        self.psi = self.jac = self.psit = None  # made at the first ``constraints``: a compiled run hands its own over
        self._sizes = (size, n, m, extra)  # (a chain of 64 loops' dense Psi_q history: 121 MB)

    def allocate(self) -> _History:
        """The arrays of q, q', q'', lambda and the energies, for the numpy engine to fill."""
        size, n, m, extra = self._sizes
        self.q, self.qd, self.qdd = (np.empty((size, n)) for _ in range(3))
        self.lam = np.empty((size, m))
        self.energies = np.zeros((size, extra))
        return self

    def constraints(self, k: int, system: System, q: np.ndarray, t: float) -> None:
        """Psi, Psi_q and Psi_t at the output time t[k] (the residuals, reactions and checks of the result)."""
        if self.jac is None:
            size, n, m, _ = self._sizes
            self.psi, self.jac, self.psit = np.empty((size, m)), np.empty((size, m, n)), np.empty((size, m))
        self.psi[k], self.jac[k], self.psit[k] = system.constraints(q, t), system.jacobian(q, t), system.psi_t(q, t)

    def store(self, k, q, qd, qdd, lam, energies) -> None:
        self.q[k], self.qd[k], self.qdd[k] = q, qd, qdd
        self.lam[k] = lam
        self.energies[k] = energies


def constraint_arrays(system: System, t: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Psi (N, m), Psi_q (N, m, n) and Psi_t (N, m) at the times t[k] and coordinates q[k]."""
    N, m, n = len(t), system.n_constraints, system.n_coordinates
    psi, jac, psit = np.empty((N, m)), np.empty((N, m, n)), np.empty((N, m))
    for k, (qk, tk) in enumerate(zip(q, t, strict=True)):
        psi[k], jac[k], psit[k] = system.constraints(qk, tk), system.jacobian(qk, tk), system.psi_t(qk, tk)
    return psi, jac, psit


def constraint_residuals(system: System, t: np.ndarray, q: np.ndarray, qd: np.ndarray) -> dict[str, np.ndarray]:
    """Histories of max |Psi(q, t)| and max |Psi_q q' + Psi_t| (columns 'residual.position', 'residual.velocity')."""
    position, velocity = np.empty(t.size), np.empty(t.size)
    for k, time in enumerate(t):
        position[k] = np.max(np.abs(system.constraints(q[k], time)), initial=0.0)
        jacobian = system.jacobian(q[k], time)
        velocity[k] = np.max(np.abs(jacobian @ qd[k] + system.psi_t(q[k], time)), initial=0.0)
    return {"residual.position": position, "residual.velocity": velocity}


def _check_redundancy(report: RankReport | None, formulation: str) -> None:
    """Only the SVD and augmented Lagrangian formulations cope with redundant constraints: refuse the others."""
    if report is not None and report.n_redundant and formulation not in ("svd", *THROUGH_SINGULAR):
        raise AnalysisError(
            f"{report.n_redundant} redundant constraint equation(s) among joints "
            f"{', '.join(report.redundant_joints)}: the {formulation} formulation needs independent "
            "constraints; use --formulation auto, augmented-lagrangian or svd, or remove the redundant joint"
        )


def _formulation_info(formulation: Formulation) -> dict:
    info = {}
    if hasattr(formulation, "alpha") and (formulation.alpha or formulation.beta):
        info.update(alpha=formulation.alpha, beta=formulation.beta)
    if hasattr(formulation, "repartitions"):
        info.update(repartitions=formulation.repartitions, partitions=formulation.partitions)
    if hasattr(formulation, "projections"):
        info["projections"] = formulation.projections
    if hasattr(formulation, "unconverged"):
        info["unconverged_iterations"] = formulation.unconverged
        info["augmented_iterations"] = formulation.iterations
    return info


__all__ = [
    "FORMULATIONS",
    "FORMULATION_NAMES",
    "INDEX3_INTEGRATORS",
    "INTEGRATOR_NAMES",
    "EquationsOfMotion",
    "DEFAULT_ACCURACY",
    "DEFAULT_RTOL",
    "accuracy_estimate",
    "accuracy_warnings",
    "DRIFT_LIMIT",
    "SINGULAR_RATIO",
    "Settings",
    "choose_method",
    "default_rtol",
    "motion_periods",
    "consistent_initial_conditions",
    "constraint_residuals",
    "forward_dynamics",
    "prepare",
    "Prepared",
]
