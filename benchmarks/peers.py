"""Peers for ``bench.py``: the same scenes built in MuJoCo and Exudyn, when installed (extra ``[bench]``).

Each peer model is built from the scene's own ``Model`` (masses, inertias, joint points and initial
state read from the course model file), so both codes integrate the same mechanism from the same state,
and each run is judged by ``bench.py`` against the same reference on the same output grid (the largest
position error of any body centre, m).

The peers have no error control on these models, so each configuration is searched widely (``search``): every
integrator a peer offers for the model, with steps h = (output interval) / k over a fine grid of k (SUBSTEPS, up
to 1024), from coarse to fine until the run reaches 1e-9, takes longer than SECONDS, or stops improving; the
first step of each configuration to reach 1e-3, 1e-6 and 1e-9 is timed again (median of up to ``repeats`` runs).
``bench.py`` takes the fastest configuration per target. The time of a run is the simulation alone (model built
outside the timing): MuJoCo's by ``mujoco.rollout`` (its step loop in C), Exudyn's ``SolveDynamic``.

- MuJoCo (minimal coordinates): RK4, Euler, implicit and implicitfast, on the MJCF of ``mbd export --to mjcf``
  (``mujoco_exported``): the double pendulum (two hinges), the free slider-crank (a hinge-hinge tree plus the piston
  on a slide joint, the loop closed by a ``connect`` equality, which MuJoCo enforces softly: with the constraint
  time constant at two steps and a stiff solimp, or at MuJoCo's defaults), the spatial double pendulum (two ball
  joints).
- Exudyn: the double pendulum in minimal coordinates (``ObjectKinematicTree``, its explicit RK44 and RK67) and
  in redundant body coordinates (2D rigid bodies with revolute joints), the free slider-crank and the spatial
  double pendulum in redundant coordinates: generalized-alpha (index 3) and the trapezoidal rule (index 2).

Exudyn's step-size-controlled solvers (DOPRI5, ODE23) are scanned over tolerances instead of steps. ``mbd bench``
times our fastest run against each peer's fastest again in interleaved rounds (``interleaved``) for its ratios.
"""

from __future__ import annotations

import math
import re
import statistics
import time
from dataclasses import dataclass

import numpy as np

try:
    import mujoco
except ImportError:  # the [bench] extra is optional
    mujoco = None
try:
    import exudyn
except ImportError:
    exudyn = None


def versions() -> dict[str, str]:
    out = {}
    if mujoco is not None:
        out["MuJoCo"] = mujoco.__version__
    if exudyn is not None:
        out["Exudyn"] = exudyn.GetVersionString() if hasattr(exudyn, "GetVersionString") else exudyn.__version__
    return out


@dataclass
class PeerRun:
    scene: str
    config: str
    setting: float
    family: str = "peer"
    error: float = float("nan")
    ms: float = float("nan")
    evaluations: int = 0
    repeats: int = 0
    failure: str = ""
    chosen: str = ""
    setting_name: str = "h"
    """What ``setting`` is: the step h (s), or the tolerance of a method with step-size control."""

    @property
    def ok(self) -> bool:
        return not self.failure and np.isfinite(self.error)

    @property
    def described(self) -> str:
        """The configuration with its setting, e.g. 'MuJoCo RK4, h = 2.5e-03'."""
        return f"{self.config}, {self.setting_name} = {self.setting:.2g}"


# -- MuJoCo ----------------------------------------------------------------------------------------------------
def _joint(model, name: str) -> np.ndarray:
    return np.asarray(next(j for j in model.joints if j["name"] == name)["location"], dtype=float)


def _rotation(p):
    from solutions.rotations import rotation_matrix

    return rotation_matrix(np.asarray(p, dtype=float))


def mujoco_exported(model, dt: float) -> tuple[str, np.ndarray, np.ndarray]:
    """The scene's MJCF as ``mbd export --to mjcf`` writes it (``solutions.io.mjcf``: a spanning tree of hinges,
    slides and balls, a loop closed by a ``connect`` equality at a time constant of two steps and a stiff solimp),
    with the step dt, and the initial state of its keyframe (the state ``mbd run`` starts from)."""
    from solutions.io.mjcf import Stiffness, export_mjcf

    xml = export_mjcf(model, Stiffness(timestep=dt))
    m = mujoco.MjModel.from_xml_string(xml)
    return xml, m.key_qpos[0].copy(), m.key_qvel[0].copy()


MUJOCO_INTEGRATORS = ("RK4", "Euler", "implicit", "implicitfast")
"""Every integrator MuJoCo offers."""


def mujoco_xml(scene, build, dt: float, integrator: str, solref: str | None) -> tuple[str, np.ndarray, np.ndarray]:
    """The scene's MJCF (``build``) with ``integrator`` and, for a closed loop, the equality's solref: "2h" (a time
    constant of two steps, the stiffest MuJoCo keeps stable; the builder's) or MuJoCo's default (solref 0.02 s and
    the default solimp)."""
    xml, qpos, qvel = build(scene.load(), dt)
    xml = xml.replace('integrator="RK4"', f'integrator="{integrator}"', 1)
    if solref == "default":
        xml = re.sub(r'\s+solref="[^"]*"', "", xml)
        xml = re.sub(r'\s+solimp="[^"]*"', "", xml)
    return xml, qpos, qvel


def mujoco_run(scene, build, dt: float, integrator: str = "RK4", solref: str | None = None):
    """Seconds of the whole simulation (``mujoco.rollout``: the step loop in C, no Python per step) and the body
    centres (N, nb, dim) at the output times, from the states it returns."""
    from mujoco import rollout

    xml, qpos, qvel = mujoco_xml(scene, build, dt, integrator, solref)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    interval = scene.t_end / scene.outputs
    per_output = round(interval / dt)
    if abs(per_output * dt - interval) > 1e-9 * interval:
        raise ValueError(f"step {dt} does not divide the output interval {interval}")
    d.qpos[:], d.qvel[:] = qpos, qvel
    mujoco.mj_forward(m, d)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state, spec)
    start = time.perf_counter()
    states, _ = rollout.rollout(m, d, state[None], nstep=scene.outputs * per_output)
    elapsed = time.perf_counter() - start
    ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body.name) for body in scene.load().bodies]
    out = np.empty((scene.outputs + 1, len(ids), scene.dimension))
    out[0] = _centres(m, d, qpos, ids, scene.dimension)
    for k, q in enumerate(states[0, per_output - 1 :: per_output, 1 : 1 + m.nq], start=1):
        out[k] = _centres(m, d, q, ids, scene.dimension)
    return elapsed, out


def _centres(m, d, qpos: np.ndarray, ids: list[int], dimension: int) -> np.ndarray:
    """The centres of the model's bodies (MuJoCo's bodies ``ids``, in the model's order)."""
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    return d.xipos[ids, :dimension].copy()


# -- Exudyn ----------------------------------------------------------------------------------------------------
EXUDYN_SOLVERS = {"RK4": "RK44", "RK67": "RK67", "DOPRI5": "DOPRI5", "ODE23": "ODE23",
                  "GeneralizedAlpha": "GeneralizedAlpha", "TrapezoidalIndex2": "TrapezoidalIndex2"}  # fmt: skip
"""Exudyn's solvers tried, by the name the tables give them: its explicit Runge-Kutta methods (RK44, RK67; DOPRI5
and ODE23 with their own step-size control) for the minimal-coordinate tree, its implicit index-3 generalized-alpha
and index-2 trapezoidal rule for the redundant models."""
ADAPTIVE = ("DOPRI5", "ODE23")


def _exudyn_solve(mbs, sensors, scene, dt: float, solver: str) -> tuple[float, np.ndarray]:
    """Run Exudyn's dynamic solver ``solver`` (EXUDYN_SOLVERS) with step dt, or for DOPRI5 and ODE23 with its
    step-size control at rtol = atol = dt (its largest step the output interval); body centres from position
    sensors at the output times."""
    import exudyn as exu

    settings = exu.SimulationSettings()
    settings.timeIntegration.endTime = scene.t_end
    settings.timeIntegration.verboseMode = 0
    settings.solutionSettings.writeSolutionToFile = False
    settings.solutionSettings.sensorsWritePeriod = scene.t_end / scene.outputs
    settings.displayStatistics = False
    settings.displayComputationTime = False
    if solver in ADAPTIVE:
        settings.timeIntegration.numberOfSteps = scene.outputs
        settings.timeIntegration.automaticStepSize = True
        settings.timeIntegration.absoluteTolerance = dt
        settings.timeIntegration.relativeTolerance = dt
    else:
        settings.timeIntegration.numberOfSteps = round(scene.t_end / dt)
    if solver == "GeneralizedAlpha":
        settings.timeIntegration.generalizedAlpha.spectralRadius = 0.9
    if solver in ("GeneralizedAlpha", "TrapezoidalIndex2"):
        settings.timeIntegration.newton.relativeTolerance = 1e-10
        settings.timeIntegration.newton.absoluteTolerance = 1e-10
    start = time.perf_counter()
    mbs.SolveDynamic(settings, solverType=getattr(exu.DynamicSolverType, EXUDYN_SOLVERS[solver]))
    elapsed = time.perf_counter() - start
    series = [mbs.GetSensorStoredData(s) for s in sensors]
    times = series[0][:, 0]
    grid = np.linspace(0.0, scene.t_end, scene.outputs + 1)
    out = np.empty((grid.size, len(sensors), scene.dimension))
    for b, data in enumerate(series):
        for c in range(scene.dimension):
            out[:, b, c] = np.interp(grid, times, data[:, 1 + c])  # sensor times are the grid up to rounding
    return elapsed, out


def _exudyn_system():
    import exudyn as exu

    container = exu.SystemContainer()
    return container, container.AddSystem()


def exudyn_double_pendulum_tree(scene, dt: float, solver: str = "RK4") -> tuple[float, np.ndarray]:
    """Minimal coordinates: an ObjectKinematicTree of two RevoluteZ links, an explicit method."""
    import exudyn as exu
    from exudyn.itemInterface import SensorKinematicTree
    from exudyn.utilities import HTtranslate, RigidBodyInertia, TreeLink

    model = scene.load()
    upper, lower = model.bodies
    o, a = _joint(model, "O"), _joint(model, "A")
    container, mbs = _exudyn_system()
    links = []
    for body, joint, offset, parent in ((upper, o, o, -1), (lower, a, a - o, 0)):
        inertia = RigidBodyInertia(
            mass=body.mass,
            inertiaTensor=np.diag([body.inertia] * 3),
            com=[*(body.location - joint), 0.0],
            inertiaTensorAtCOM=True,
        )
        links.append(
            TreeLink(
                linkInertia=inertia,
                jointType=exu.JointType.RevoluteZ,
                jointHT=HTtranslate([*offset, 0]),
                parent=parent,
                graphicsDataList=[],
            )
        )
    velocities = [upper.angular_velocity, lower.angular_velocity - upper.angular_velocity]
    tree = mbs.CreateKinematicTree(
        listOfTreeLinks=links, gravity=[*model.gravity, 0.0], initialCoordinates_t=velocities, show=False
    )
    sensors = [
        mbs.AddSensor(
            SensorKinematicTree(
                objectNumber=tree,
                linkNumber=k,
                localPosition=[*(b.location - j), 0.0],
                outputVariableType=exu.OutputVariableType.Position,
                storeInternal=True,
                writeToFile=False,
            )
        )
        for k, (b, j) in enumerate(((upper, o), (lower, a)))
    ]
    mbs.Assemble()
    return _exudyn_solve(mbs, sensors, scene, dt, solver)


def _exudyn_rigid_2d(mbs, body, gravity):
    from exudyn.utilities import RigidBodyInertia, RotationMatrixZ

    inertia = RigidBodyInertia(mass=body.mass, inertiaTensor=np.diag([body.inertia] * 3))
    return mbs.CreateRigidBody(
        referencePosition=[*body.location, 0.0],
        referenceRotationMatrix=RotationMatrixZ(body.orientation),
        initialVelocity=[*body.velocity, 0.0],
        initialAngularVelocity=[0.0, 0.0, body.angular_velocity],
        inertia=inertia,
        gravity=[*gravity, 0.0],
        create2D=True,
    )


def _position_sensor(mbs, body):
    import exudyn as exu
    from exudyn.itemInterface import SensorBody

    return mbs.AddSensor(
        SensorBody(
            bodyNumber=body, outputVariableType=exu.OutputVariableType.Position, storeInternal=True, writeToFile=False
        )
    )


def exudyn_planar(scene, dt: float, solver: str = "GeneralizedAlpha") -> tuple[float, np.ndarray]:
    """Redundant coordinates: 2D rigid bodies, revolute (and prismatic) joints, an implicit index-3 or 2 method."""
    model = scene.load()
    container, mbs = _exudyn_system()
    ground = mbs.CreateGround()
    bodies = [_exudyn_rigid_2d(mbs, b, model.gravity) for b in model.bodies]

    def item(name):
        return ground if name == "ground" else bodies[model.body_index(name)]

    def marker(name, point, rigid=False):
        """A marker at a global point of the file's configuration, in the body's frame."""
        from exudyn.itemInterface import MarkerBodyPosition, MarkerBodyRigid

        if name == "ground":
            local = [*point, 0.0]
        else:
            body = model.bodies[model.body_index(name)]
            c, s_ = math.cos(body.orientation), math.sin(body.orientation)
            d = np.asarray(point, float) - body.location
            local = [c * d[0] + s_ * d[1], -s_ * d[0] + c * d[1], 0.0]
        kind = MarkerBodyRigid if rigid else MarkerBodyPosition
        return mbs.AddMarker(kind(bodyNumber=item(name), localPosition=local))

    from exudyn.itemInterface import ObjectJointPrismatic2D, ObjectJointRevolute2D

    for joint in model.joints:
        point = joint["location"]
        if joint["type"] == "revolute":
            markers = [marker(joint["body1"], point), marker(joint["body2"], point)]
            mbs.AddObject(ObjectJointRevolute2D(markerNumbers=markers))
        else:
            axis = np.asarray(joint["axis"], float)
            markers = [marker(joint["body1"], point, True), marker(joint["body2"], point, True)]
            mbs.AddObject(
                ObjectJointPrismatic2D(
                    markerNumbers=markers,
                    axisMarker0=[*axis, 0.0],
                    normalMarker1=[-axis[1], axis[0], 0.0],
                    constrainRotation=True,
                )
            )
    sensors = [_position_sensor(mbs, b) for b in bodies]
    mbs.Assemble()
    return _exudyn_solve(mbs, sensors, scene, dt, solver)


def exudyn_spatial_double_pendulum(scene, dt: float, solver: str = "GeneralizedAlpha") -> tuple[float, np.ndarray]:
    """Redundant coordinates: Euler-parameter rigid bodies with spherical joints, an implicit method."""
    from exudyn.utilities import RigidBodyInertia

    model = scene.load()
    container, mbs = _exudyn_system()
    ground = mbs.CreateGround()
    bodies = []
    for body in model.bodies:
        inertia = np.asarray(body.inertia, float)
        inertia = RigidBodyInertia(mass=body.mass, inertiaTensor=inertia if inertia.ndim == 2 else np.diag(inertia))
        bodies.append(
            mbs.CreateRigidBody(
                referencePosition=body.location,
                referenceRotationMatrix=_rotation(body.orientation),
                inertia=inertia,
                gravity=model.gravity,
            )
        )
    for joint in model.joints:
        pair = [
            ground if joint["body1"] == "ground" else bodies[model.body_index(joint["body1"])],
            bodies[model.body_index(joint["body2"])],
        ]
        mbs.CreateSphericalJoint(bodyNumbers=pair, position=joint["location"], show=False)
    sensors = [_position_sensor(mbs, b) for b in bodies]
    mbs.Assemble()
    return _exudyn_solve(mbs, sensors, scene, dt, solver)


# -- the search -------------------------------------------------------------------------------------------------
MUJOCO_SCENES = {
    "double_pendulum": mujoco_exported,
    "slider_crank": mujoco_exported,
    "spatial_double_pendulum": mujoco_exported,
}
LOOP_SCENES = ("slider_crank",)
"""Scenes whose MuJoCo model closes a loop by an equality constraint: its solref is searched too."""

EXUDYN_SCENES = {
    "double_pendulum": [
        ("Exudyn tree", exudyn_double_pendulum_tree, ("RK4", "RK67")),
        ("Exudyn redundant", exudyn_planar, ("GeneralizedAlpha", "TrapezoidalIndex2")),
    ],
    "slider_crank": [("Exudyn redundant", exudyn_planar, ("GeneralizedAlpha", "TrapezoidalIndex2"))],
    "spatial_double_pendulum": [
        ("Exudyn redundant", exudyn_spatial_double_pendulum, ("GeneralizedAlpha", "TrapezoidalIndex2"))
    ],
}
"""Exudyn's models of each scene and the solvers tried on each. Not tried: a minimal-coordinate model of the spatial
double pendulum (Exudyn's kinematic tree has revolute and prismatic joints only, and a ball as three revolutes is
singular where two of their axes align); DOPRI5 and ODE23 with step-size control (``_exudyn_solve`` can run them):
their sensors record at the steps' times, not on the output grid, so the error measured after interpolating them
(1e-3 at tol 1e-12 on the double pendulum) is the interpolation's, and ODE23 at tol 1e-12 ran at its minimum step
for minutes without ending (Exudyn 1.13.6)."""

SUBSTEPS = (1, 2, 3, 4, 5, 6, 8, 10, 12, 16, 20, 25, 32, 40, 50, 64, 80, 100, 128, 160, 200, 256, 320, 400, 512,
            640, 800, 1024)  # fmt: skip
"""Steps per output interval: h = (output interval) / k, every divisor-friendly k up to 1024."""
TOLERANCES = tuple(10.0**-e for e in range(3, 13))
"""rtol = atol of Exudyn's methods with step-size control."""
TARGETS = (1e-3, 1e-6, 1e-9)
"""The errors at which each peer's fastest configuration is wanted: a scan stops once the finest is reached."""
SECONDS = 4.0
"""A run longer than this ends the scan of its configuration (smaller steps would be longer still)."""
BUDGET = 12.0
"""Seconds of runs after which the scan of a configuration ends."""
STALLED = 10
"""Attempts in a row that do not halve the best error end the scan of a configuration: the step shrunk about
tenfold for nothing (a soft loop closure's error stays near 2e-3 from h = 1.7e-2 to 6e-3 before it falls)."""


@dataclass(frozen=True)
class Family:
    """One configuration of a peer scanned over its settings (steps h, or tolerances), coarse to fine."""

    label: str
    attempt: object  # attempt(setting) -> (seconds, body centres)
    settings: tuple[float, ...]
    setting_name: str = "h"


def families(scene, quick: bool) -> list[Family]:
    """Every configuration of every installed peer for the scene: MuJoCo's integrators (and, for a loop, the
    equality's solref), Exudyn's models and solvers."""
    interval = scene.t_end / scene.outputs
    steps = tuple(interval / k for k in (SUBSTEPS[:8] if quick else SUBSTEPS))
    found = []
    if mujoco is not None and scene.key in MUJOCO_SCENES:
        build = MUJOCO_SCENES[scene.key]
        solrefs = ("2h", "default") if scene.key in LOOP_SCENES else (None,)
        for integrator in MUJOCO_INTEGRATORS[:1] if quick else MUJOCO_INTEGRATORS:
            for solref in solrefs:
                label = f"MuJoCo {integrator}" + ("" if solref is None else f", solref {solref}")

                def attempt(dt, integrator=integrator, solref=solref, build=build):
                    return mujoco_run(scene, build, dt, integrator, solref)

                found.append(Family(label, attempt, steps))
    if exudyn is not None:
        for model, build, solvers in EXUDYN_SCENES.get(scene.key, []):
            for solver in solvers[:1] if quick else solvers:
                adaptive = solver in ADAPTIVE

                def attempt(setting, build=build, solver=solver):
                    return build(scene, setting, solver)

                settings = (TOLERANCES[:3] if quick else TOLERANCES) if adaptive else steps
                found.append(Family(f"{model} {solver}", attempt, settings, "tol" if adaptive else "h"))
    return found


def search(scene, quick: bool, repeats: int, progress=None) -> list[PeerRun]:
    """Every family of ``families`` scanned from its coarsest setting to its finest, each attempt timed once, until
    one reaches the finest of TARGETS, or one takes longer than SECONDS, or the family's attempts add up to
    BUDGET seconds, or the error has stopped falling (STALLED attempts in a row not halving the best so far: a
    method at the limit of its accuracy, e.g. a soft loop closure); then the first attempt of each family to
    reach each target timed again (median of up to ``repeats``), as the fastest configurations are picked from
    those."""
    runs = []
    for family in families(scene, quick):
        scanned, best, stalled = [], math.inf, 0
        for setting in family.settings:
            run = execute(family, setting, scene, 1)
            scanned.append(run)
            if progress is not None:
                progress(run)
            if run.ok and run.error < 0.5 * best:
                best, stalled = run.error, 0
            else:
                stalled += 1
            spent = sum(r.ms for r in scanned if math.isfinite(r.ms)) / 1e3
            if best <= TARGETS[-1] or run.ms > 1e3 * SECONDS or spent > BUDGET or stalled >= STALLED:
                break
        for target in TARGETS:
            first = next((r for r in scanned if r.ok and r.error <= target), None)
            if first is not None and first.repeats < repeats:
                again = execute(family, first.setting, scene, repeats)
                first.ms, first.repeats = again.ms, again.repeats
        runs += scanned
    return runs


def interleaved(ours, theirs, rounds: int) -> list[float]:
    """Ours / the peer's time in each of ``rounds`` interleaved rounds: a round times one call of each (``ours()``
    and ``theirs()`` return their seconds), the order alternating from round to round, so that both meet the same
    state of the machine; the spread of the ratios is the measurement's own."""
    ratios = []
    for r in range(rounds):
        if r % 2:
            mine = ours()
            other = theirs()
        else:
            other = theirs()
            mine = ours()
        ratios.append(mine / other)
    return ratios


def execute(family: Family, setting: float, scene, repeats: int) -> PeerRun:
    """Time a peer run (median of up to ``repeats``, one for runs over 0.5 s) and judge it like ours."""
    run = PeerRun(scene.key, family.label, setting, setting_name=family.setting_name)
    try:
        times = []
        positions = None
        while len(times) < max(1, repeats) and (not times or sum(times) < 0.5):
            elapsed, positions = family.attempt(setting)
            times.append(elapsed)
        run.ms, run.repeats = 1e3 * statistics.median(times), len(times)
        run.evaluations = round(scene.t_end / setting) if family.setting_name == "h" else 0
        run.error = _position_error(scene, positions)
        if not math.isfinite(run.error):
            run.failure = "diverged"
    except Exception as err:  # noqa: BLE001 -- a peer that fails is reported, not fatal
        run.failure = f"{type(err).__name__}: {str(err).splitlines()[0][:80]}" if str(err) else type(err).__name__
    return run


def _position_error(scene, positions: np.ndarray) -> float:
    """The measure of ``bench.run_error``: the largest position error of any body centre on the grid (m)."""
    return float(np.max(np.abs(positions - scene.ref_positions)))


def table(runs: list[PeerRun], unit: str) -> list[str]:
    lines = [f"| peer | setting | error ({unit}) | time (ms) | steps |", "|---|---:|---:|---:|---:|"]
    for r in runs:
        setting = f"{r.setting_name} = {r.setting:.2g}"
        if r.failure:
            lines.append(f"| {r.config} | {setting} | failed: {r.failure} | | |")
        else:
            steps = r.evaluations or ""
            lines.append(f"| {r.config} | {setting} | {r.error:.1e} | {r.ms:.1f} | {steps} |")
    return lines


__all__ = ["Family", "PeerRun", "execute", "families", "search", "table", "versions"]
