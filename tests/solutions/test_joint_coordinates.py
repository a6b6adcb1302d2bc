"""The joint-coordinate (tree) formulation against independent references.

- Simple pendulum: the angle's own ODE (J + m c^2) phi'' = -m g c cos(phi), solved here with solve_ivp.
- Planar double pendulum: Lagrange's equations in the two link angles, written here, solved with solve_ivp.
- Spatial scenes (spherical, prismatic + revolute, skew revolutes, heavy top) and two trees built here
  (a planar slider with a pendulum, a spatial chain with a reversed joint): the redundant-coordinate
  formulations (projection, baumgarte) at tight tolerance.
- Energy T + V of conservative scenes, computed from q and q' alone.
- D = dq/dtheta and xi = D' theta' against finite differences of ``coordinates``; every configuration it
  makes satisfies Psi = 0 and Psi_q q' = 0 to rounding; lambda equals the augmented system's.
- Closed loops and drivers (cut joints): the free slider-crank, the free four-bar and the four-bar with
  spring against baumgarte and projection; the driven four-bar against baumgarte and its drive's own angle;
  energy T + V of the free loops from q, q' and the masses; the cut rows' residual, recomputed from q.
- Scenes it cannot take (a body not reached by supported joints, redundant constraints) are refused with
  one clear line.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.integrate import solve_ivp

from solutions.assembly import System, build_system
from solutions.diagnostics import AnalysisError
from solutions.dynamics import choose_method, consistent_initial_conditions, forward_dynamics
from solutions.formulations import FORMULATIONS, make_formulation
from solutions.generalized_forces import build_forces
from solutions.io.model import load_model
from solutions.joint_coordinates import JointCoordinates, cut_elements, supports, tree_order
from solutions.mass_matrix import mass_matrix

from .test_diagnostics import parallelogram

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
G = 9.81

# -- two trees that the example models do not have: a planar prismatic joint, a reversed joint, forces
PLANAR_SLIDER = {
    "model": {
        "name": "slider-pendulum",
        "dimension": 2,
        "gravity": [0.0, -G],
        "bodies": [
            {"name": "pendulum", "mass": 0.7, "inertia": 0.02, "location": [0.35, -0.3], "orientation": -0.7},
            {"name": "slider", "mass": 2.0, "inertia": 0.05, "location": [0.2, 0.1], "orientation": 0.4,
             "velocity": [0.9, 0.4], "angular_velocity": 0.0},
            {"name": "bead", "mass": 0.3, "inertia": 0.001, "location": [0.45, -0.4], "orientation": -0.7},
        ],
        "joints": [  # the slider's rail tilted 0.4 rad; the pendulum's pin given with the pendulum as body1;
            # a bead slides along the pendulum
            {"name": "rail", "type": "prismatic", "body1": "ground", "body2": "slider", "location": [0.2, 0.1],
             "axis": [math.cos(0.4), math.sin(0.4)]},
            {"name": "pin", "type": "revolute", "body1": "pendulum", "body2": "slider", "location": [0.2, 0.1]},
            {"name": "rod", "type": "prismatic", "body1": "pendulum", "body2": "bead", "location": [0.45, -0.4],
             "axis": [math.cos(-0.7), math.sin(-0.7)]},
        ],
        "spring_dampers": [
            {"name": "spring", "type": "TSDA", "body1": "ground", "body2": "slider", "point1": [-0.5, 0.0],
             "point2": [0.2, 0.1], "spring_coefficient": 40.0, "damping_coefficient": 1.5, "free_length": 0.6},
        ],
        "forces": [{"name": "push", "type": "torque", "body": "pendulum", "value": 0.3}],
    }
}  # fmt: skip

SPATIAL_CHAIN = {
    "model": {
        "name": "spatial-chain",
        "dimension": 3,
        "gravity": [0.0, 0.0, -G],
        "bodies": [
            {"name": "cart", "mass": 1.5, "inertia": [0.01, 0.02, 0.025], "location": [0.0, 0.0, 0.0],
             "velocity": [0.5, 0.0, 0.0]},
            {"name": "arm", "mass": 0.8, "inertia": [0.002, 0.03, 0.03], "location": [0.3, 0.0, -0.1],
             "orientation": [0.9950041652780258, 0.0, 0.09983341664682815, 0.0], "angular_velocity": [0.0, 0.0, 2.0]},
            {"name": "bob", "mass": 0.5, "inertia": [0.004, 0.005, 0.006], "location": [0.6, 0.1, -0.25],
             "angular_velocity": [1.0, -0.5, 0.3]},
            {"name": "ring", "mass": 0.2, "inertia": [0.001, 0.002, 0.0015], "location": [0.6, 0.1, -0.3]},
        ],
        "joints": [  # the cart slides along (1, 1, 0); the arm swings on a tilted revolute; the bob hangs from
            # a ball joint given with the bob as body1 (so its parent is body2); a ring slides on the bob
            {"name": "rail", "type": "prismatic", "body1": "ground", "body2": "cart", "location": [0.0, 0.0, 0.0],
             "axis": [1.0, 1.0, 0.0]},
            {"name": "hinge", "type": "revolute", "body1": "cart", "body2": "arm", "location": [0.0, 0.0, 0.0],
             "axis": [0.0, 0.3, 1.0]},
            {"name": "ball", "type": "spherical", "body1": "bob", "body2": "arm", "location": [0.6, 0.0, -0.2]},
            {"name": "sleeve", "type": "prismatic", "body1": "bob", "body2": "ring", "location": [0.6, 0.1, -0.3],
             "axis": [0.2, 1.0, -0.5]},
        ],
        "spring_dampers": [
            {"name": "spring", "type": "TSDA", "body1": "ground", "body2": "arm", "point1": [-0.4, -0.4, 0.0],
             "point2": [0.4, 0.05, -0.1], "spring_coefficient": 30.0, "damping_coefficient": 0.4},
        ],
        "forces": [{"name": "twist", "type": "torque", "body": "bob", "value": [0.1, 0.0, -0.05]}],
    }
}  # fmt: skip

SCENES = {
    "simple_pendulum": MODELS / "simple_pendulum.yaml",
    "double_pendulum": MODELS / "double_pendulum.yaml",
    "spatial_double_pendulum": MODELS / "spatial_double_pendulum.yaml",
    "carriage_pendulum": MODELS / "carriage_pendulum.yaml",
    "revolute_revolute_skew": MODELS / "revolute_revolute_skew.yaml",
    "heavy_top": MODELS / "heavy_top.yaml",
    "planar_slider": PLANAR_SLIDER,
    "spatial_chain": SPATIAL_CHAIN,
}


def setup(source):
    """(system, M, forces, consistent q, q', the formulation)."""
    model = load_model(source)
    system, q0, qd0 = build_system(model)
    M, forces = mass_matrix(model), build_forces(model)
    q, qd, _ = consistent_initial_conditions(system, M, q0, qd0)
    return system, M, forces, q, qd, JointCoordinates(system, M, forces)


def random_state(formulation: JointCoordinates, rng: np.random.Generator) -> np.ndarray:
    """A joint state with random angles, slides, unit Euler parameters and velocities."""
    y = rng.normal(size=formulation.n_positions + formulation.tree.k)
    for joint in formulation.joints:
        if joint.kind == "spherical":
            e = y[joint.position : joint.position + 4]
            e /= np.linalg.norm(e)
    return y


# -- against minimal-coordinate ODEs written here --------------------------------------------------------
def test_simple_pendulum_against_its_angle_ode():
    """Rod of m = 1, L = 1 pinned at one end, released horizontal: (J + m c^2) phi'' = -m g c cos(phi)."""
    m, J, c = 1.0, 1.0 / 12.0, 0.5
    system, q0, qd0 = build_system(load_model(MODELS / "simple_pendulum.yaml"))
    result = forward_dynamics(
        system, q0, qd0, 2.0, 20, formulation="joint-coordinates", integrator="dop853", rtol=1e-12, atol=1e-12
    )
    reference = solve_ivp(
        lambda t, y: [y[1], -m * G * c * math.cos(y[0]) / (J + m * c * c)],
        (0.0, 2.0), [0.0, 0.0], method="DOP853", t_eval=result.t, rtol=1e-12, atol=1e-12,
    )  # fmt: skip
    phi, w = reference.y
    expected = np.column_stack([c * np.cos(phi), c * np.sin(phi), phi])
    assert np.ptp(phi) > 2.0  # it swings through the bottom
    np.testing.assert_allclose(result.q, expected, atol=1e-10)
    np.testing.assert_allclose(result.qd[:, 2], w, atol=1e-9)


def double_pendulum_rhs(t, y):
    """Lagrange's equations of course/models/double_pendulum.yaml in the rods' angles phi1, phi2 (from x):
    rods m1 = 1, L1 = 1, J1 = 1/12 and m2 = 0.6, L2 = 0.8, J2 = 0.032 about their centres, c_i = L_i / 2;
    T = 1/2 (J1 + m1 c1^2 + m2 L1^2) w1^2 + m2 L1 c2 cos(phi1 - phi2) w1 w2 + 1/2 (J2 + m2 c2^2) w2^2,
    V = (m1 c1 + m2 L1) g sin(phi1) + m2 c2 g sin(phi2)."""
    (m1, L1, J1), (m2, J2), c1, c2 = (1.0, 1.0, 1.0 / 12.0), (0.6, 0.032), 0.5, 0.4
    phi1, phi2, w1, w2 = y
    b = m2 * L1 * c2
    matrix = [
        [J1 + m1 * c1 * c1 + m2 * L1 * L1, b * math.cos(phi1 - phi2)],
        [b * math.cos(phi1 - phi2), J2 + m2 * c2 * c2],
    ]
    rhs = [
        -b * math.sin(phi1 - phi2) * w2 * w2 - (m1 * c1 + m2 * L1) * G * math.cos(phi1),
        b * math.sin(phi1 - phi2) * w1 * w1 - m2 * c2 * G * math.cos(phi2),
    ]
    return [w1, w2, *np.linalg.solve(matrix, rhs)]


def test_planar_double_pendulum_against_lagrange():
    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    result = forward_dynamics(
        system, q0, qd0, 3.0, 30, formulation="joint-coordinates", integrator="dop853", rtol=1e-12, atol=1e-12
    )
    reference = solve_ivp(
        double_pendulum_rhs, (0.0, 3.0), [-math.pi / 6, 0.0, 0.0, 0.0], method="DOP853", t_eval=result.t,
        rtol=1e-13, atol=1e-13,
    )  # fmt: skip
    phi1, phi2, w1, w2 = reference.y
    x1, y1 = 0.5 * np.cos(phi1), 0.5 * np.sin(phi1)
    x2, y2 = np.cos(phi1) + 0.4 * np.cos(phi2), np.sin(phi1) + 0.4 * np.sin(phi2)
    np.testing.assert_allclose(result.q, np.column_stack([x1, y1, phi1, x2, y2, phi2]), atol=1e-9)
    np.testing.assert_allclose(result.qd[:, [2, 5]], np.column_stack([w1, w2]), atol=1e-8)


# -- against the redundant-coordinate formulations ----------------------------------------------------------
@pytest.mark.parametrize(
    ("scene", "t_end", "reference"),
    [
        ("spatial_double_pendulum", 1.0, "projection"),
        ("carriage_pendulum", 1.0, "baumgarte"),
        ("revolute_revolute_skew", 1.0, "baumgarte"),
        ("heavy_top", 0.5, "projection"),
        ("planar_slider", 1.0, "baumgarte"),
        ("spatial_chain", 1.0, "projection"),
    ],
)
def test_trees_agree_with_the_augmented_formulations(scene, t_end, reference):
    system, q0, qd0 = build_system(load_model(SCENES[scene]))
    settings = {"integrator": "dop853", "rtol": 1e-11, "atol": 1e-11}
    ours = forward_dynamics(system, q0, qd0, t_end, 10, formulation="joint-coordinates", **settings)
    theirs = forward_dynamics(system, q0, qd0, t_end, 10, formulation=reference, **settings)
    assert np.ptp(theirs.q, axis=0).max() > 0.05  # something moved
    np.testing.assert_allclose(ours.q, theirs.q, atol=1e-7)
    np.testing.assert_allclose(ours.qd, theirs.qd, atol=1e-6)
    assert ours.info["max_constraint_residual"] < 1e-13  # positions come from the joints: on the constraints
    for joint in ours.reactions:
        scale = max(1.0, np.abs(theirs.reactions[joint]).max())
        np.testing.assert_allclose(ours.reactions[joint], theirs.reactions[joint], atol=1e-6 * scale)


@pytest.mark.parametrize("scene", ["spatial_double_pendulum", "carriage_pendulum", "heavy_top"])
def test_conservative_scenes_keep_their_energy(scene):
    system, q0, qd0 = build_system(load_model(SCENES[scene]))
    result = forward_dynamics(
        system, q0, qd0, 2.0, 20, formulation="joint-coordinates", integrator="dop853", rtol=1e-11, atol=1e-11
    )
    assert result.info["energy_drift_relative"] < 1e-8


# -- D, xi, the constraints and lambda at random states ------------------------------------------------------
@pytest.mark.parametrize("scene", list(SCENES))
def test_d_and_xi_are_the_derivatives_of_the_coordinates(scene):
    """D = dq/dtheta column by column, and xi = q'' with theta'' = 0, by central differences of coordinates():
    positions moved along the rate of the position coordinates that one velocity coordinate gives."""
    system, _, _, _, _, formulation = setup(SCENES[scene])
    rng = np.random.default_rng(7)
    k, n_pos = formulation.tree.k, formulation.n_positions
    for _ in range(2):
        y = random_state(formulation, rng)
        D, xi = formulation.joint_matrix(y), formulation.convective(y)
        _, qd = formulation.coordinates(0.0, y)
        np.testing.assert_allclose(D @ y[n_pos:], qd, atol=1e-12)
        h = 1e-6
        for col in range(k):
            unit = np.zeros(k)
            unit[col] = 1.0
            rates = formulation.tree.motion(y[:n_pos], unit).rates
            ahead = formulation.coordinates(0.0, np.concatenate([y[:n_pos] + h * rates, unit]))[0]
            behind = formulation.coordinates(0.0, np.concatenate([y[:n_pos] - h * rates, unit]))[0]
            np.testing.assert_allclose((ahead - behind) / (2 * h), D[:, col], atol=1e-8)
        rates = formulation.tree.motion(y[:n_pos], y[n_pos:]).rates
        ahead = formulation.coordinates(0.0, np.concatenate([y[:n_pos] + h * rates, y[n_pos:]]))[1]
        behind = formulation.coordinates(0.0, np.concatenate([y[:n_pos] - h * rates, y[n_pos:]]))[1]
        np.testing.assert_allclose((ahead - behind) / (2 * h), xi, atol=1e-6 * max(1.0, np.abs(xi).max()))


@pytest.mark.parametrize("scene", list(SCENES))
def test_coordinates_satisfy_the_constraints(scene):
    system, _, _, _, _, formulation = setup(SCENES[scene])
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, qd = formulation.coordinates(0.0, random_state(formulation, rng))
        assert np.abs(system.constraints(q, 0.0)).max() < 1e-13
        assert np.abs(system.jacobian(q, 0.0) @ qd).max() < 1e-13 * max(1.0, np.abs(qd).max())
        # and back: the joint state of these coordinates makes them again
        np.testing.assert_allclose(
            formulation.coordinates(0.0, formulation.initial_state(q, qd, 0.0))[0], q, atol=1e-13
        )


@pytest.mark.parametrize("scene", list(SCENES))
def test_accelerations_and_lambda_equal_the_augmented_systems(scene):
    """At the same state: q'' and lambda of M q'' + Psi_q^T lambda = Q, Psi_q q'' = gamma (eq. 5.30)."""
    system, M, forces, q, qd, formulation = setup(SCENES[scene])
    augmented = make_formulation("baumgarte", system, M, forces, alpha=0.0, beta=0.0)
    rng = np.random.default_rng(11)
    for y in (formulation.initial_state(q, qd, 0.0), random_state(formulation, rng)):
        q, qd = formulation.coordinates(0.0, y)
        qdd, lam = formulation.accelerations(q, qd, 0.0)
        qdd_ref, lam_ref = augmented.accelerations(q, qd, 0.0)
        np.testing.assert_allclose(qdd, qdd_ref, atol=1e-9 * max(1.0, np.abs(qdd_ref).max()))
        np.testing.assert_allclose(lam, lam_ref, atol=1e-9 * max(1.0, np.abs(lam_ref).max()))
        # state_derivative and rhs agree, from the cached motion and from (q, q', q'') alone
        expected = formulation.rhs(0.0, y)
        np.testing.assert_allclose(formulation.state_derivative(q, qd, qdd), expected, atol=1e-12)
        np.testing.assert_allclose(
            formulation.state_derivative(q.copy(), qd.copy(), qdd.copy()), expected, atol=1e-9 * np.abs(expected).max()
        )


# -- what it refuses ------------------------------------------------------------------------------------------
def test_registered():
    assert FORMULATIONS["joint-coordinates"] is JointCoordinates


def test_body_not_reached_by_supported_joints_is_named():
    system, _, _ = build_system(load_model(MODELS / "cylindrical.yaml"))
    assert supports(system) == (
        "body 'collar' is not reached from ground by revolute/prismatic/spherical joints "
        "(the joint coordinates of a spanning tree)"
    )
    joints = SPATIAL_CHAIN["model"]["joints"]
    spec = {"model": {**SPATIAL_CHAIN["model"], "joints": joints[:2] + joints[3:]}}
    system, q0, qd0 = build_system(load_model(spec))
    assert supports(system).startswith("body 'bob' is not reached from ground")
    with pytest.raises(AnalysisError, match="body 'bob' is not reached from ground") as error:
        forward_dynamics(system, q0, qd0, 0.1, 1, formulation="joint-coordinates")
    assert "\n" not in str(error.value)


def test_redundant_constraints_are_refused_with_the_svd_hint():
    system, q0, qd0 = build_system(load_model(parallelogram(extra_link=True)))
    reason = supports(system)
    assert "redundant constraint equation(s)" in reason and "svd" in reason and "\n" not in reason
    with pytest.raises(AnalysisError, match="svd"):
        forward_dynamics(system, q0, qd0, 0.1, 1, formulation="joint-coordinates")
    system, _, _ = build_system(load_model(parallelogram(extra_link=False)))  # the control: independent rows
    assert supports(system) is None


@pytest.mark.parametrize("scene", list(SCENES))
def test_trees_are_supported(scene):
    system, _, _ = build_system(load_model(SCENES[scene]))
    assert supports(system) is None


@pytest.mark.parametrize("scene", list(SCENES))
def test_open_trees_have_no_cut_rows(scene):
    """An open tree is what it was: no cut System, no Baumgarte terms, and no Guard (nothing can drift)."""
    *_, formulation = setup(SCENES[scene])
    assert formulation.cut is None and formulation.cut_rows == 0
    assert formulation.alpha == formulation.beta == 0.0


# -- closed loops and drivers: cut joints ---------------------------------------------------------------------


def model_file(name: str, **changes) -> dict:
    """A course model with some of its sections replaced (e.g. motors=[]: the mechanism let free)."""
    data = yaml.safe_load((MODELS / name).read_text())
    data["model"].update(changes)
    return data


CLOSED = {
    "free_four_bar": model_file("four_bar.yaml", motors=[]),  # at rest, falls under gravity
    "free_slider_crank": model_file("slider_crank_flywheel.yaml", forces=[]),  # coasting under gravity
    "four_bar_spring": MODELS / "four_bar_spring.yaml",
}


def test_the_spanning_tree_is_breadth_first_and_the_rest_is_cut():
    system, _, _ = build_system(load_model(MODELS / "four_bar.yaml"))
    order, reason = tree_order(system)
    assert reason is None
    assert [spec["name"] for spec, _ in order] == ["O2", "O4", "A"]  # ground's two joints first, then the crank's
    assert [element.name for element in cut_elements(system, order)] == ["B", "drive"]
    *_, formulation = setup(MODELS / "four_bar.yaml")
    assert formulation.cut_rows == 3  # B's two rows and the driver's one


@pytest.mark.parametrize("reference", ["baumgarte", "projection"])
@pytest.mark.parametrize("scene", list(CLOSED))
def test_closed_loops_agree_with_the_augmented_formulations(scene, reference):
    system, q0, qd0 = build_system(load_model(CLOSED[scene]))
    settings = {"integrator": "dop853", "rtol": 1e-11, "atol": 1e-11}
    ours = forward_dynamics(system, q0, qd0, 0.5, 10, formulation="joint-coordinates", **settings)
    theirs = forward_dynamics(system, q0, qd0, 0.5, 10, formulation=reference, **settings)
    assert np.ptp(theirs.q, axis=0).max() > 0.05  # something moved
    np.testing.assert_allclose(ours.q, theirs.q, atol=1e-7)
    np.testing.assert_allclose(ours.qd, theirs.qd, atol=1e-6)
    for joint in theirs.reactions:
        scale = max(1.0, np.abs(theirs.reactions[joint]).max())
        np.testing.assert_allclose(ours.reactions[joint], theirs.reactions[joint], atol=1e-6 * scale)


def test_driven_four_bar_follows_its_drive_and_agrees_with_baumgarte():
    """A dynamic run with a motor: the crank turns at 10 rad/s (the drive, phi = 10 t, holds to the
    integrator's tolerance), and q and the reactions, the driver's torque among them, are baumgarte's."""
    system, q0, qd0 = build_system(load_model(MODELS / "four_bar.yaml"))
    settings = {"integrator": "dop853", "rtol": 1e-11, "atol": 1e-11}
    ours = forward_dynamics(system, q0, qd0, 0.6, 12, formulation="joint-coordinates", **settings)
    theirs = forward_dynamics(system, q0, qd0, 0.6, 12, formulation="baumgarte", **settings)
    np.testing.assert_allclose(ours.q[:, 2], 10.0 * ours.t, atol=1e-9)  # crank.phi
    np.testing.assert_allclose(ours.q, theirs.q, atol=1e-7)
    assert "drive" in " ".join(theirs.reactions)
    for joint in theirs.reactions:
        scale = max(1.0, np.abs(theirs.reactions[joint]).max())
        np.testing.assert_allclose(ours.reactions[joint], theirs.reactions[joint], atol=1e-6 * scale)


def energy(model, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """T + V of a planar model from q, q' and its masses alone: sum 1/2 m v^2 + 1/2 J phi'^2 - m g . r."""
    total = np.zeros(len(q))
    for b, body in enumerate(model.bodies):
        r, v, w = q[:, 3 * b : 3 * b + 2], qd[:, 3 * b : 3 * b + 2], qd[:, 3 * b + 2]
        total += 0.5 * body.mass * np.sum(v**2, axis=1) + 0.5 * body.inertia * w**2 - body.mass * r @ model.gravity
    return total


@pytest.mark.parametrize("scene", ["free_four_bar", "free_slider_crank"])
def test_free_closed_loops_keep_their_energy_and_their_constraints(scene):
    model = load_model(CLOSED[scene])
    system, q0, qd0 = build_system(model)
    result = forward_dynamics(
        system, q0, qd0, 2.0, 40, formulation="joint-coordinates", integrator="dop853", rtol=1e-10, atol=1e-10
    )
    E = energy(model, result.q, result.qd)
    assert np.ptp(result.q, axis=0).max() > 0.1
    assert np.abs(E - E[0]).max() < 1e-7 * max(1.0, np.abs(E).max())
    residual = max(np.abs(system.constraints(q, t)).max() for q, t in zip(result.q, result.t, strict=True))
    assert residual < 1e-9  # the cut rows, held by the augmented system and Baumgarte's terms


def test_the_guard_watches_the_cut_rows_and_not_an_open_tree():
    """Without Baumgarte's terms and with a coarse fixed step, the cut rows drift and the Guard stops the run;
    an open tree has no rows to drift."""
    system, q0, qd0 = build_system(load_model(CLOSED["free_four_bar"]))
    settings = {"formulation": "joint-coordinates", "integrator": "rk4", "drift_limit": 1e-12}
    with pytest.raises(AnalysisError, match="constraint drift"):
        forward_dynamics(system, q0, qd0, 1.0, 20, alpha=0.0, beta=0.0, **settings)
    system, q0, qd0 = build_system(load_model(SCENES["double_pendulum"]))
    forward_dynamics(system, q0, qd0, 1.0, 20, **settings)


def test_auto_takes_joint_coordinates_for_open_trees_only():
    """With cut joints the formulation measured slower than baumgarte (benchmarks), so ``auto`` keeps it for trees."""
    for source, expected in ((SCENES["double_pendulum"], "joint-coordinates"), (CLOSED["free_four_bar"], "baumgarte")):
        system, M, forces, q, qd, _ = setup(source)
        assert choose_method(system, M, forces, q, qd, 1.0, 1e-8)["formulation"] == expected


def test_the_cut_system_is_made_once_per_system_and_evaluates_as_a_fresh_one():
    """A run's formulation shares the cut elements' ``System`` the system's earlier runs made
    (``joint_coordinates.cut_system``: making it checks its batched groups, 0.4 ms a run of a loop chain), one per
    ``vectorized`` setting; it gives the Psi, Psi_q, Psi_t and gamma of a System built anew from the same cut
    elements, and a second run from it is the first run to the last bit."""
    system, q0, qd0 = build_system(load_model(MODELS / "slider_crank.yaml"))
    M, forces = mass_matrix(system.model), build_forces(system.model)
    first, second = (JointCoordinates(system, M, forces) for _ in range(2))
    assert first.cut is not None and first.cut is second.cut
    fresh = System(system.model, cut_elements(system, tree_order(system)[0]))
    rng = np.random.default_rng(7)
    q, qd = q0 + 0.1 * rng.standard_normal(q0.size), rng.standard_normal(q0.size)
    for got, expected in zip(first.cut.evaluate(q, qd, 0.3), fresh.evaluate(q, qd, 0.3), strict=True):
        assert np.array_equal(got, expected)
    system.vectorized = False  # the element loop: a System of its own
    looped = JointCoordinates(system, M, forces).cut
    assert looped is not first.cut and not looped.vectorized
    system.vectorized = True
    runs = [forward_dynamics(system, q0, qd0, 0.05, 5, "joint-coordinates", "DOP853", engine="numpy") for _ in "ab"]
    assert np.array_equal(runs[0].q, runs[1].q) and np.array_equal(runs[0].lam, runs[1].lam)
