"""Peers for ``bench.py``: the same scenes built in MuJoCo and Exudyn, when installed (extra ``[bench]``).

Each peer model is built from the scene's own ``Model`` (masses, inertias, joint points and initial
state read from the course model file), so both codes integrate the same mechanism from the same state,
and each run is judged by ``bench.py`` against the same reference on the same output grid (the largest
position error of any body centre, m). The peers have no error control, so each runs a sweep of step
sizes; the time of a run is the median of up to ``repeats`` runs of the whole simulation loop (model
built once, outside the timing), recording the body centres at the output times.

- MuJoCo (minimal coordinates, its RK4): the double pendulum (two hinges), the free slider-crank (a
  hinge-hinge tree plus the piston on a slide joint, the loop closed by a ``connect`` equality, which
  MuJoCo enforces softly with the constraint time constant set to two steps), the spatial double
  pendulum (two ball joints).
- Exudyn: the double pendulum in minimal coordinates (``ObjectKinematicTree``, its explicit RK4) and in
  redundant body coordinates (2D rigid bodies with revolute joints, generalized-alpha, index 3), the
  free slider-crank and the spatial double pendulum in redundant coordinates (generalized-alpha).
"""

from __future__ import annotations

import math
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

    @property
    def ok(self) -> bool:
        return not self.failure and np.isfinite(self.error)


# -- MuJoCo ----------------------------------------------------------------------------------------------------
def _joint(model, name: str) -> np.ndarray:
    return np.asarray(next(j for j in model.joints if j["name"] == name)["location"], dtype=float)


def _v(x) -> str:
    return " ".join(f"{float(c):.17g}" for c in x)


def _planar_inertial(body, offset) -> str:
    j = float(body.inertia)
    return f'<inertial pos="{_v([*offset, 0.0])}" mass="{body.mass}" diaginertia="{j} {j} {j}"/>'


def mujoco_double_pendulum(model, dt: float) -> tuple[str, np.ndarray, np.ndarray]:
    """Two hinges about z; body frames at the joints, parallel to the world in the file's configuration."""
    upper, lower = model.bodies
    o, a = _joint(model, "O"), _joint(model, "A")
    gravity = [*model.gravity, 0.0]
    xml = f"""<mujoco><option gravity="{_v(gravity)}" integrator="RK4" timestep="{dt}"/>
<worldbody><body name="upper" pos="{_v([*o, 0])}"><joint type="hinge" axis="0 0 1"/>
{_planar_inertial(upper, upper.location - o)}
<body name="lower" pos="{_v([*(a - o), 0])}"><joint type="hinge" axis="0 0 1"/>
{_planar_inertial(lower, lower.location - a)}</body></body></worldbody></mujoco>"""
    qvel = [upper.angular_velocity, lower.angular_velocity - upper.angular_velocity]
    return xml, np.zeros(2), np.array(qvel, dtype=float)


def mujoco_slider_crank(model, dt: float) -> tuple[str, np.ndarray, np.ndarray]:
    """Crank and rod as a hinge-hinge tree, the piston on a slide joint, the loop closed at B by ``connect``."""
    crank, rod, piston = model.bodies
    o, a, b = _joint(model, "O"), _joint(model, "A"), _joint(model, "B")
    gravity = [*model.gravity, 0.0]
    xml = f"""<mujoco><option gravity="{_v(gravity)}" integrator="RK4" timestep="{dt}"/>
<worldbody><body name="crank" pos="{_v([*o, 0])}"><joint type="hinge" axis="0 0 1"/>
{_planar_inertial(crank, crank.location - o)}
<body name="rod" pos="{_v([*(a - o), 0])}"><joint type="hinge" axis="0 0 1"/>
{_planar_inertial(rod, rod.location - a)}</body></body>
<body name="piston" pos="{_v([*b, 0])}"><joint type="slide" axis="1 0 0"/>
{_planar_inertial(piston, piston.location - b)}</body></worldbody>
<equality><connect body1="rod" body2="piston" anchor="{_v([*(b - a), 0])}" solref="{2 * dt} 1"
solimp="0.9999 0.9999 0.001"/></equality></mujoco>"""
    qvel = [crank.angular_velocity, rod.angular_velocity - crank.angular_velocity, piston.velocity[0]]
    return xml, np.zeros(3), np.array(qvel, dtype=float)


def _quat_conj(p):
    return np.array([p[0], -p[1], -p[2], -p[3]])


def _quat_mul(a, b):
    a0, av, b0, bv = a[0], a[1:], b[0], b[1:]
    return np.concatenate([[a0 * b0 - av @ bv], a0 * bv + b0 * av + np.cross(av, bv)])


def _rotation(p):
    from solutions.rotations import rotation_matrix

    return rotation_matrix(np.asarray(p, dtype=float))


def mujoco_spatial_double_pendulum(model, dt: float) -> tuple[str, np.ndarray, np.ndarray]:
    """Two ball joints; each body frame at its joint with the body's orientation from the file."""
    rod1, rod2 = model.bodies
    o, a = _joint(model, "O"), _joint(model, "A")
    p1, p2 = np.asarray(rod1.orientation, float), np.asarray(rod2.orientation, float)
    r1, r2 = _rotation(p1), _rotation(p2)

    def inertial(body, rot, joint):
        inertia = np.asarray(body.inertia, float)
        inertia = np.diag(inertia) if inertia.ndim == 2 else inertia
        return f'<inertial pos="{_v(rot.T @ (body.location - joint))}" mass="{body.mass}" diaginertia="{_v(inertia)}"/>'

    xml = f"""<mujoco><option gravity="{_v(model.gravity)}" integrator="RK4" timestep="{dt}"/>
<worldbody><body name="rod1" pos="{_v(o)}" quat="{_v(p1)}"><joint type="ball"/>{inertial(rod1, r1, o)}
<body name="rod2" pos="{_v(r1.T @ (a - o))}" quat="{_v(_quat_mul(_quat_conj(p1), p2))}"><joint type="ball"/>
{inertial(rod2, r2, a)}</body></body></worldbody></mujoco>"""
    qpos = np.array([1.0, 0, 0, 0, 1.0, 0, 0, 0])
    return xml, qpos, np.zeros(6)


MUJOCO_SCENES = {
    "double_pendulum": (mujoco_double_pendulum, (1e-2, 5e-3, 2e-3, 1e-3, 5e-4)),
    "slider_crank": (mujoco_slider_crank, (1e-3, 5e-4, 2e-4, 1e-4)),
    "spatial_double_pendulum": (mujoco_spatial_double_pendulum, (5e-3, 2e-3, 1e-3, 5e-4)),
}


def mujoco_run(scene, build, dt: float) -> tuple[float, np.ndarray]:
    """Seconds for the whole simulation loop and the body centres (N, nb, dim) at the output times."""
    xml, qpos, qvel = build(scene.load(), dt)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    interval = scene.t_end / scene.outputs
    per_output = round(interval / dt)
    if abs(per_output * dt - interval) > 1e-9 * interval:
        raise ValueError(f"step {dt} does not divide the output interval {interval}")
    out = np.empty((scene.outputs + 1, m.nbody - 1, scene.dimension))
    start = time.perf_counter()
    d.qpos[:], d.qvel[:] = qpos, qvel
    mujoco.mj_forward(m, d)
    out[0] = d.xipos[1:, : scene.dimension]
    for k in range(1, scene.outputs + 1):
        for _ in range(per_output):
            mujoco.mj_step(m, d)
        out[k] = d.xipos[1:, : scene.dimension]
    return time.perf_counter() - start, out


# -- Exudyn ----------------------------------------------------------------------------------------------------
def _exudyn_solve(mbs, sensors, scene, dt: float, solver: str) -> tuple[float, np.ndarray]:
    """Run Exudyn's dynamic solver with step dt; body centres from position sensors at the output times."""
    import exudyn as exu

    settings = exu.SimulationSettings()
    settings.timeIntegration.endTime = scene.t_end
    settings.timeIntegration.numberOfSteps = round(scene.t_end / dt)
    settings.timeIntegration.verboseMode = 0
    settings.solutionSettings.writeSolutionToFile = False
    settings.solutionSettings.sensorsWritePeriod = scene.t_end / scene.outputs
    settings.displayStatistics = False
    settings.displayComputationTime = False
    if solver == "RK4":
        solver_type = exu.DynamicSolverType.RK44
    else:
        solver_type = exu.DynamicSolverType.GeneralizedAlpha
        settings.timeIntegration.generalizedAlpha.spectralRadius = 0.9
        settings.timeIntegration.newton.relativeTolerance = 1e-10
        settings.timeIntegration.newton.absoluteTolerance = 1e-10
    start = time.perf_counter()
    mbs.SolveDynamic(settings, solverType=solver_type)
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


def exudyn_double_pendulum_tree(scene, dt: float) -> tuple[float, np.ndarray]:
    """Minimal coordinates: an ObjectKinematicTree of two RevoluteZ links, explicit RK4."""
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
    return _exudyn_solve(mbs, sensors, scene, dt, "RK4")


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


def exudyn_planar(scene, dt: float) -> tuple[float, np.ndarray]:
    """Redundant coordinates: 2D rigid bodies, revolute (and prismatic) joints, generalized-alpha (index 3)."""
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
    return _exudyn_solve(mbs, sensors, scene, dt, "GeneralizedAlpha")


def exudyn_spatial_double_pendulum(scene, dt: float) -> tuple[float, np.ndarray]:
    """Redundant coordinates: Euler-parameter rigid bodies with spherical joints, generalized-alpha."""
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
    return _exudyn_solve(mbs, sensors, scene, dt, "GeneralizedAlpha")


EXUDYN_SCENES = {
    "double_pendulum": [
        ("Exudyn tree RK4", exudyn_double_pendulum_tree, (1e-2, 5e-3, 2e-3, 1e-3)),
        ("Exudyn redundant gen-alpha", exudyn_planar, (1e-3, 2.5e-4, 1e-4)),
    ],
    "slider_crank": [("Exudyn redundant gen-alpha", exudyn_planar, (1e-3, 2.5e-4, 1e-4, 5e-5))],
    "spatial_double_pendulum": [
        ("Exudyn redundant gen-alpha", exudyn_spatial_double_pendulum, (1e-3, 2.5e-4, 1e-4, 5e-5))
    ],
}


# -- the sweep ---------------------------------------------------------------------------------------------------
def sweeps(scene_key: str, quick: bool) -> list[tuple[str, tuple]]:
    """(label, job) for every installed peer run of a scene; job = (kind, builder, step)."""
    jobs = []
    if mujoco is not None and scene_key in MUJOCO_SCENES:
        build, steps = MUJOCO_SCENES[scene_key]
        for dt in steps[:1] if quick else steps:
            jobs.append((f"MuJoCo RK4 h = {dt:.0e}", ("mujoco", build, dt)))
    if exudyn is not None:
        for label, build, steps in EXUDYN_SCENES.get(scene_key, []):
            for dt in steps[:1] if quick else steps:
                jobs.append((f"{label} h = {dt:.0e}", ("exudyn", build, dt)))
    return jobs


def execute(job: tuple, scene, label: str, repeats: int) -> PeerRun:
    """Time a peer run (median of up to ``repeats``, one for runs over 0.5 s) and judge it like ours."""
    kind, build, dt = job
    run = PeerRun(scene.key, label.rsplit(" h = ", 1)[0], dt)
    try:
        times = []
        positions = None
        while len(times) < max(1, repeats) and (not times or sum(times) < 0.5):
            if kind == "mujoco":
                elapsed, positions = mujoco_run(scene, build, dt)
            else:
                elapsed, positions = build(scene, dt)
            times.append(elapsed)
        run.ms, run.repeats = 1e3 * statistics.median(times), len(times)
        run.evaluations = round(scene.t_end / dt)
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
    lines = [f"| peer | step (s) | error ({unit}) | time (ms) | steps |", "|---|---:|---:|---:|---:|"]
    for r in runs:
        if r.failure:
            lines.append(f"| {r.config} | {r.setting:.0e} | failed: {r.failure} | | |")
        else:
            lines.append(f"| {r.config} | {r.setting:.0e} | {r.error:.1e} | {r.ms:.1f} | {r.evaluations} |")
    return lines


__all__ = ["PeerRun", "execute", "sweeps", "table", "versions"]
