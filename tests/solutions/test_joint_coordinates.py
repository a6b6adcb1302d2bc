"""The joint-coordinate (tree) formulation against independent references.

- Simple pendulum: the angle's own ODE (J + m c^2) phi'' = -m g c cos(phi), solved here with solve_ivp.
- Planar double pendulum: Lagrange's equations in the two link angles, written here, solved with solve_ivp.
- Spatial scenes (spherical, prismatic + revolute, skew revolutes, heavy top) and two trees built here
  (a planar slider with a pendulum, a spatial chain with a reversed joint): the redundant-coordinate
  formulations (projection, baumgarte) at tight tolerance.
- Energy T + V of conservative scenes, computed from q and q' alone.
- D = dq/dtheta and xi = D' theta' against finite differences of ``coordinates``; every configuration it
  makes satisfies Psi = 0 and Psi_q q' = 0 to rounding; lambda equals the augmented system's.
- Scenes that are not open trees of supported joints are refused with one clear line.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError
from solutions.dynamics import consistent_initial_conditions, forward_dynamics
from solutions.formulations import FORMULATIONS, make_formulation
from solutions.generalized_forces import build_forces
from solutions.io.model import load_model
from solutions.joint_coordinates import JointCoordinates, supports
from solutions.mass_matrix import mass_matrix

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


def test_closed_loop_is_refused_by_name():
    system, q0, qd0 = build_system(load_model(MODELS / "four_bar_spring.yaml"))
    assert "closed loop through joint" in supports(system)
    with pytest.raises(AnalysisError, match="closed loop through joint") as error:
        forward_dynamics(system, q0, qd0, 0.1, 1, formulation="joint-coordinates")
    assert "\n" not in str(error.value)


def test_drivers_are_refused():
    system, q0, qd0 = build_system(load_model(MODELS / "spatial_double_pendulum_driven.yaml"))
    assert "drivers" in supports(system)
    with pytest.raises(AnalysisError, match="drivers"):
        forward_dynamics(system, q0, qd0, 0.1, 1, formulation="joint-coordinates")


def test_unsupported_joint_and_free_body_are_named():
    system, _, _ = build_system(load_model(MODELS / "cylindrical.yaml"))
    assert (
        supports(system) == "joint 'shaft' of type cylindrical is not supported (only revolute, prismatic, spherical)"
    )
    joints = SPATIAL_CHAIN["model"]["joints"]
    spec = {"model": {**SPATIAL_CHAIN["model"], "joints": joints[:2] + joints[3:]}}
    system, _, _ = build_system(load_model(spec))
    assert supports(system) == "body 'bob' is not connected to ground by joints"


@pytest.mark.parametrize("scene", list(SCENES))
def test_trees_are_supported(scene):
    system, _, _ = build_system(load_model(SCENES[scene]))
    assert supports(system) is None
