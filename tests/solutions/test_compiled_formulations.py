"""The compiled engine's joint-coordinates and projection formulations against the numpy reference engine.

Joint coordinates (``solutions/compiled/tree.py``): open trees, planar and spatial, revolute, prismatic and
spherical joints, a spring; closed loops cut into trees, with a driver. Projection
(``solutions/compiled/projection.py``): closed loops with a driver and with a spring-damper-actuator, through
every compiled integrator loop. At rtol = 1e-10 the trajectories, q'', lambda, energies and reactions agree to
1e-8 (issue 16). numba compiles each formulation's module once per dimension (a tree's too:
whether it has cut rows is data), cached on disk.
"""

from pathlib import Path

import numpy as np
import pytest
import yaml

from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError
from solutions.dynamics import forward_dynamics
from solutions.generalized_forces import build_forces
from solutions.io import load_model

pytest.importorskip("numba")

TREES = {  # planar revolute; spatial spherical (two); spatial revolute; prismatic + revolute + TSDA
    "double_pendulum": "course/models/double_pendulum.yaml",
    "spatial_double_pendulum": "course/models/spatial_double_pendulum.yaml",
    "heavy_top": "course/models/heavy_top.yaml",
    "revolute_revolute_skew": "course/models/revolute_revolute_skew.yaml",
    "carriage_pendulum": "course/models/carriage_pendulum.yaml",
}
PLANAR_CARRIAGE = {  # a planar open tree with a prismatic joint, both joints given child first, a damped spring
    "model": {
        "name": "planar-carriage-pendulum",
        "dimension": 2,
        "gravity": [0.0, -9.81],
        "bodies": [
            {"name": "carriage", "mass": 2.0, "inertia": 0.02, "location": [0.1, 0.0], "orientation": 0.3,
             "velocity": [0.5, 0.0]},
            {"name": "pendulum", "mass": 0.5, "inertia": 0.01, "location": [0.35, -0.1], "orientation": 0.2},
        ],
        "joints": [
            {"name": "rail", "type": "prismatic", "body1": "carriage", "body2": "ground", "location": [0.1, 0.0],
             "axis": [1.0, 0.2]},
            {"name": "pivot", "type": "revolute", "body1": "pendulum", "body2": "carriage", "location": [0.1, 0.0]},
        ],
        "spring_dampers": [
            {"name": "spring", "type": "TSDA", "body1": "ground", "body2": "carriage", "point1": [-0.5, 0.0],
             "point2": [0.0, 0.0], "spring_coefficient": 50.0, "damping_coefficient": 0.3, "free_length": 0.5},
        ],
    }
}  # fmt: skip
TREES["planar_carriage_pendulum"] = PLANAR_CARRIAGE
LOOPS = {  # a driven slider-crank (Psi_t); a four-bar with a damped, actuated spring (energy states)
    "slider_crank": "course/models/slider_crank.yaml",
    "four_bar_spring": "course/models/four_bar_spring.yaml",
}


def _both(path, formulation: str, integrator: str = "DOP853", t_end: float = 0.5, **kwargs):
    system, q0, qd0 = build_system(load_model(path))
    kwargs = dict(formulation=formulation, integrator=integrator, rtol=1e-10, atol=1e-12, **kwargs)
    numpy_run = forward_dynamics(system, q0, qd0, t_end, 50, engine="numpy", **kwargs)
    compiled_run = forward_dynamics(system, q0, qd0, t_end, 50, engine="compiled", **kwargs)
    return numpy_run, compiled_run


def _close(a: np.ndarray, b: np.ndarray) -> float:
    scale = max(float(np.max(np.abs(a))), 1e-12)
    return float(np.max(np.abs(a - b))) / scale


def _agree(reference, compiled) -> None:
    assert compiled.info["chosen"]["engine"] == "compiled", compiled.info["chosen"]
    for name in ("q", "qd", "qdd", "lam"):
        assert _close(getattr(reference, name), getattr(compiled, name)) < 1e-8, name
    for key in ("energy.kinetic", "energy.potential", "energy.dissipated", "energy.applied", "residual.position"):
        assert np.allclose(reference.points[key], compiled.points[key], rtol=1e-8, atol=1e-10), key
    size = max(float(np.max(np.abs(value))) for value in reference.reactions.values())
    for key, value in reference.reactions.items():
        assert np.max(np.abs(value - compiled.reactions[key])) < 1e-8 * size, key
    assert compiled.info["warnings"] == reference.info["warnings"]


@pytest.mark.parametrize("scene", list(TREES))
def test_joint_coordinates_agree(scene):
    reference, compiled = _both(TREES[scene], "joint-coordinates")
    _agree(reference, compiled)
    assert abs(compiled.info["integrator_steps"] - reference.info["integrator_steps"]) <= 1  # the last step's rounding


@pytest.mark.parametrize("scene", list(LOOPS))
def test_projection_agrees(scene):
    reference, compiled = _both(LOOPS[scene], "projection")
    _agree(reference, compiled)
    for key in ("integrator_steps", "restarts", "projections"):
        assert compiled.info[key] == reference.info[key], key
    assert compiled.info["projections"] > 0


@pytest.mark.parametrize("integrator", ["dop853", "RK45", "rk4"])
def test_projection_agrees_in_every_loop(integrator):
    """The projection inside the package's own loop, the solve_ivp-like RK45 and the fixed-step rk4 (whose
    projections come after every substep, and which never counts a restart)."""
    step = {"step": 2e-3} if integrator == "rk4" else {}
    reference, compiled = _both(LOOPS["slider_crank"], "projection", integrator, t_end=0.2, **step)
    _agree(reference, compiled)
    for key in ("integrator_steps", "restarts", "projections"):
        assert compiled.info[key] == reference.info[key], key


def test_projection_that_does_not_converge_stops_as_numpy_does():
    system, q0, qd0 = build_system(load_model(LOOPS["slider_crank"]))
    messages = []
    for engine in ("numpy", "compiled"):
        with pytest.raises(AnalysisError, match="position projection did not converge") as caught:
            forward_dynamics(system, q0, qd0, 0.1, 10, formulation="projection", integrator="DOP853", rtol=1e-6,
                             engine=engine, tol=1e-300, max_iterations=2)  # fmt: skip
        messages.append(str(caught.value).split(" (residual")[0])
    assert messages[0] == messages[1]


def test_joint_coordinates_keep_the_energy():
    """Independent of the numpy engine: the conservative heavy top keeps its energy to the integrator's accuracy."""
    system, q0, qd0 = build_system(load_model(TREES["heavy_top"]))
    run = forward_dynamics(system, q0, qd0, 1.0, 50, formulation="joint-coordinates", integrator="DOP853",
                           rtol=1e-10, atol=1e-12, engine="compiled")  # fmt: skip
    assert run.info["chosen"]["engine"] == "compiled"
    assert run.info["energy_drift_relative"] < 1e-8
    assert run.info["max_constraint_residual"] < 1e-12  # joint coordinates: on the constraints by construction


def _spatial_loop() -> dict:
    """The spatial double pendulum with the free end of its second rod on a spherical joint to ground: a loop."""
    data = yaml.safe_load(Path(TREES["spatial_double_pendulum"]).read_text())
    joint = {"name": "B", "type": "spherical", "body1": "rod2", "body2": "ground", "location": [1.0, 1.0, 0.0]}
    data["model"]["joints"].append(joint)
    return data


@pytest.mark.parametrize("scene", [*LOOPS, "spatial_loop"])
def test_joint_coordinates_with_cut_joints_agree(scene):
    """Closed loops cut into a tree: the four-bar's cut revolute with a spring-damper-actuator, the slider-crank's
    cut revolute and its driver (whose power needs lambda at every evaluation), a spatial loop's cut spherical
    joint (Psi_theta = Psi_c,q dq/dtheta with the Euler parameters' rows of dq/dtheta)."""
    reference, compiled = _both(_spatial_loop() if scene == "spatial_loop" else LOOPS[scene], "joint-coordinates")
    _agree(reference, compiled)
    assert np.allclose(reference.points["energy.drivers"], compiled.points["energy.drivers"], rtol=1e-8, atol=1e-10)


def test_what_the_kernels_lack_falls_back_to_numpy_and_says_why():
    system, q0, qd0 = build_system(load_model(TREES["double_pendulum"]))
    forces = build_forces(system.model).add(lambda q, qd, t: np.zeros(q.size))
    run = forward_dynamics(system, q0, qd0, 0.05, 5, formulation="joint-coordinates", integrator="DOP853",
                           forces=forces, engine="compiled")  # fmt: skip
    assert run.info["chosen"]["engine"] == "numpy"
    assert "user forces" in run.info["chosen"]["engine_why"]


def test_cached_engine_finds_the_compiled_tree():
    system, q0, qd0 = build_system(load_model(TREES["double_pendulum"]))
    kwargs = dict(formulation="joint-coordinates", integrator="DOP853", rtol=1e-8)
    forward_dynamics(system, q0, qd0, 0.05, 5, engine="compiled", **kwargs)
    run = forward_dynamics(system, q0, qd0, 0.05, 5, engine="cached", **kwargs)
    assert run.info["chosen"]["engine"] == "compiled", run.info["chosen"]
