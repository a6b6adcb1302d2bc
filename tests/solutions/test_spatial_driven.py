"""Driven variants of the spatial examples: kinematic and inverse analyses against independent references.

Every spatial example of course/models/ is run fully driven (``*_driven.yaml``; the spatial slider-crank
is driven already):

1. Kinematic analysis: the constraint residual stays below 1e-9 and the driven bodies follow the motor
   laws, written here in closed form -- rotations from axis and angle by scipy's ``Rotation``, leg lengths
   from Euler parameters by the textbook formula -- never through the solver's functions or builders.
2. Inverse dynamics: the driver efforts, fed back as applied loads in a forward-dynamic run of the same
   model with its motors removed, reproduce the prescribed motion. The loads are built here from their
   physical meaning (a torque about the joint axis on body2 and its reaction on body1; a force along the
   prismatic axis or along the leg at the joint's point), their generalized forces from
   Q = [F ; 2 G^T ((P - r) x F + n)] (omega = 2 G p'), and the efforts are interpolated in time by a
   quintic spline. For the carriage-pendulum and the collar the efforts also match Lagrange's equations
   in the joint coordinates, derived by hand.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest
import scipy.interpolate
import yaml
from scipy.spatial.transform import Rotation

from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.generalized_forces import build_forces
from solutions.inverse_dynamics import inverse_dynamics
from solutions.io.model import load_model
from solutions.kinematics import kinematic_analysis

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
G = 9.81
PI = np.pi
DRIVEN = [
    "revolute_revolute_skew_driven",
    "carriage_pendulum_driven",
    "cylindrical_driven",
    "heavy_top_driven",
    "spatial_double_pendulum_driven",
    "spatial_slider_crank",
]
T_END, STEPS = 1.0, 100  # kinematic runs
T_INVERSE, STEPS_INVERSE = 0.4, 80  # inverse runs: spline knots every 5 ms


# -- independent rigid-body helpers -----------------------------------------------------------------
def rot(p: np.ndarray) -> np.ndarray:
    """A = (2 e0^2 - 1) I + 2 (e e^T + e0 e~): the rotation matrix of Euler parameters."""
    e0, e = p[0], np.asarray(p[1:])
    tilde = np.array([[0.0, -e[2], e[1]], [e[2], 0.0, -e[0]], [-e[1], e[0], 0.0]])
    return (2.0 * e0 * e0 - 1.0) * np.eye(3) + 2.0 * (np.outer(e, e) + e0 * tilde)


def g_mat(p: np.ndarray) -> np.ndarray:
    """G = [-e, e~ + e0 I], so that the global angular velocity is omega = 2 G p' (checked below)."""
    e0, e = p[0], np.asarray(p[1:])
    tilde = np.array([[0.0, -e[2], e[1]], [e[2], 0.0, -e[0]], [-e[1], e[0], 0.0]])
    return np.column_stack([-e, tilde + e0 * np.eye(3)])


def test_helpers_against_scipy_and_finite_differences():
    """rot(p) is scipy's rotation of the quaternion; 2 G p' is the axial vector of A' A^T."""
    rng = np.random.default_rng(4)
    for _ in range(5):
        p = rng.normal(size=4)
        p /= np.linalg.norm(p)
        pd = rng.normal(size=4)
        pd -= (pd @ p) * p
        assert np.max(np.abs(rot(p) - Rotation.from_quat([*p[1:], p[0]]).as_matrix())) < 1e-14
        h = 1e-6
        spin = (rot(p + h * pd) - rot(p - h * pd)) / (2.0 * h) @ rot(p).T
        assert np.max(np.abs([spin[2, 1], spin[0, 2], spin[1, 0]] - 2.0 * g_mat(p) @ pd)) < 1e-8


def turn(axis, angle: float) -> np.ndarray:
    """Rotation by ``angle`` about ``axis`` (scipy)."""
    axis = np.asarray(axis, dtype=float)
    return Rotation.from_rotvec(angle * axis / np.linalg.norm(axis)).as_matrix()


def body_q(result, names: list[str], name: str, k=slice(None)) -> tuple[np.ndarray, np.ndarray]:
    """(r, p) of body ``name`` at output index k."""
    b = names.index(name)
    return result.q[k, 7 * b : 7 * b + 3], result.q[k, 7 * b + 3 : 7 * b + 7]


def raw(name: str) -> dict:
    return yaml.safe_load((MODELS / f"{name}.yaml").read_text())["model"]


@cache
def kinematic_run(name: str):
    model = load_model(MODELS / f"{name}.yaml")
    system, q0, _ = build_system(model)
    return model, kinematic_analysis(system, q0, T_END, STEPS)


@cache
def inverse_run(name: str):
    model = load_model(MODELS / f"{name}.yaml")
    system, q0, _ = build_system(model)
    return model, inverse_dynamics(system, q0, T_INVERSE, STEPS_INVERSE)


# -- 1. kinematic analysis ----------------------------------------------------------------------------
@pytest.mark.parametrize("name", DRIVEN)
def test_kinematic_residual(name):
    model, result = kinematic_run(name)
    system, _, _ = build_system(model)
    assert result.info["max_constraint_residual"] < 1e-9
    worst = max(np.max(np.abs(system.constraints(q, t))) for q, t in zip(result.q, result.t, strict=True))
    assert worst < 1e-9
    for p in (body_q(result, result.body_names, b.name)[1] for b in model.bodies):
        assert np.max(np.abs(np.linalg.norm(p, axis=1) - 1.0)) < 1e-12


def assert_pose(result, body: str, t, r_expected, a_expected, tol=1e-9):
    r, p = body_q(result, result.body_names, body)
    for k in range(t.size):
        assert np.max(np.abs(r[k] - r_expected[k])) < tol, (body, t[k], r[k], r_expected[k])
        assert np.max(np.abs(rot(p[k]) - a_expected[k])) < tol, (body, t[k])


def test_revolute_revolute_skew_follows_the_joint_angles():
    """A_1 = R_y(theta1), A_2 = A_1 R_u(theta2); r_1 = A_1 (0.5, 0, 0), r_2 = A_1 [(1, 0, 0) + R_u (0.5, 0, 0)]."""
    _, result = kinematic_run("revolute_revolute_skew_driven")
    t = result.t
    theta1, theta2 = 0.6 * np.sin(PI * t), np.sin(2 * PI * t)
    u, x = np.array([0.0, 1.0, 1.0]), np.array([1.0, 0.0, 0.0])
    a1 = [turn([0, 1, 0], th) for th in theta1]
    a2 = [a @ turn(u, th) for a, th in zip(a1, theta2, strict=True)]
    assert_pose(result, "link1", t, [a @ (0.5 * x) for a in a1], a1)
    r2 = [a @ (x + turn(u, th) @ (0.5 * x)) for a, th in zip(a1, theta2, strict=True)]
    assert_pose(result, "link2", t, r2, a2)
    assert np.ptp(theta2) > 1.9  # the elbow really turns


def test_carriage_pendulum_follows_the_rail_and_pivot_laws():
    """x = 0.3 sin(pi t), theta = 0.4 sin(2 pi t); pendulum centre (x - d sin(theta), 0, -d cos(theta)), R_y(theta)."""
    _, result = kinematic_run("carriage_pendulum_driven")
    t, d = result.t, 0.25
    x, theta = 0.3 * np.sin(PI * t), 0.4 * np.sin(2 * PI * t)
    assert_pose(result, "carriage", t, [[xk, 0.0, 0.0] for xk in x], [np.eye(3)] * t.size)
    centre = [[xk - d * np.sin(th), 0.0, -d * np.cos(th)] for xk, th in zip(x, theta, strict=True)]
    assert_pose(result, "pendulum", t, centre, [turn([0, 1, 0], th) for th in theta])
    b = result.body_names.index("carriage")
    assert np.max(np.abs(result.qd[:, 7 * b] - 0.3 * PI * np.cos(PI * t))) < 1e-9
    assert np.max(np.abs(result.qdd[:, 7 * b] + 0.3 * PI**2 * np.sin(PI * t))) < 1e-8


def test_cylindrical_collar_follows_lift_and_turn():
    """r = (0, 0, 0.1 sin(2 pi t)), A = R_z(sin(pi t))."""
    _, result = kinematic_run("cylindrical_driven")
    t = result.t
    z, theta = 0.1 * np.sin(2 * PI * t), np.sin(PI * t)
    assert_pose(result, "collar", t, [[0.0, 0.0, zk] for zk in z], [turn([0, 0, 1], th) for th in theta])


def test_spatial_slider_crank_follows_its_closed_form():
    """Crank A = R_x(2 pi t); slider y_B = R cos(theta) + sqrt(L^2 - d^2 - R^2 sin^2(theta))."""
    _, result = kinematic_run("spatial_slider_crank")
    t, R, L, d = result.t, 0.08, 0.3, 0.2
    theta = 2 * PI * t
    a = [turn([1, 0, 0], th) for th in theta]
    assert_pose(result, "crank", t, [ak @ [0.0, 0.5 * R, 0.0] for ak in a], a)
    r_slider, _ = body_q(result, result.body_names, "slider")
    y = R * np.cos(theta) + np.sqrt(L**2 - d**2 - (R * np.sin(theta)) ** 2)
    assert np.max(np.abs(r_slider[:, 1] - y)) < 1e-9
    assert np.max(np.abs(r_slider[:, [0, 2]] - [d, 0.0])) < 1e-9


def leg_points(model_spec: dict, motor: dict):
    """(ground point G, body name, body-frame point s') of a distance motor from ground, as the file gives it."""
    body = next(b for b in model_spec["bodies"] if b["name"] == motor["body2"])
    r0 = np.array(body["location"], dtype=float)
    a0 = rot(np.array(body.get("orientation", [1.0, 0.0, 0.0, 0.0]), dtype=float))
    point1, point2 = np.array(motor["point1"], dtype=float), np.array(motor["point2"], dtype=float)
    local = point2 if motor.get("frame") == "body" else a0.T @ (point2 - r0)
    return point1, body["name"], local


@pytest.mark.parametrize("name", ["heavy_top_driven", "spatial_double_pendulum_driven"])
def test_spherical_examples_follow_their_leg_lengths(name):
    """|r + A(p) s' - G| = L0 + a sin(w t) for every leg, with L0 the leg's length in the file."""
    spec = raw(name)
    _, result = kinematic_run(name)
    motors = spec["motors"]
    assert motors and all(m["type"] == "distance" and m["body1"] == "ground" for m in motors)
    dof = 6 * len(spec["bodies"]) - 3 * len(spec["joints"])  # spherical joints: 3 equations each
    assert len(motors) == dof
    for motor in motors:
        ground, body, s = leg_points(spec, motor)
        f = motor["function"]
        r0, p0 = (
            np.array(next(b for b in spec["bodies"] if b["name"] == body)[k]) for k in ("location", "orientation")
        )
        assert abs(np.linalg.norm(r0 + rot(p0) @ s - ground) - f["offset"]) < 1e-12  # consistent file
        r, p = body_q(result, result.body_names, body)
        length = np.array([np.linalg.norm(rk + rot(pk) @ s - ground) for rk, pk in zip(r, p, strict=True)])
        expected = f["offset"] + f["amplitude"] * np.sin(f["frequency"] * result.t)
        assert np.max(np.abs(length - expected)) < 1e-9, motor["name"]


def test_heavy_top_tip_stays_on_the_pivot():
    """The centre of mass stays l = 0.05 m up the body z axis from the fixed tip: r = A(p) (0, 0, l)."""
    _, result = kinematic_run("heavy_top_driven")
    r, p = body_q(result, result.body_names, "top")
    assert max(np.max(np.abs(rk - rot(pk) @ [0.0, 0.0, 0.05])) for rk, pk in zip(r, p, strict=True)) < 1e-9
    tilt = np.degrees(np.arccos([rot(pk)[2, 2] for pk in p]))
    assert np.ptp(tilt) > 1.0  # the legs really move it


# -- 2. inverse dynamics --------------------------------------------------------------------------------
def point_load(q: np.ndarray, body: int, force: np.ndarray, point: np.ndarray, torque=None) -> np.ndarray:
    """Generalized force on body of a global force at global ``point`` plus a global torque."""
    out = np.zeros(q.size)
    r, p = q[7 * body : 7 * body + 3], q[7 * body + 3 : 7 * body + 7]
    moment = np.cross(point - r, force) + (np.zeros(3) if torque is None else torque)
    out[7 * body : 7 * body + 3] = force
    out[7 * body + 3 : 7 * body + 7] = 2.0 * g_mat(p).T @ moment
    return out


def torque_load(q: np.ndarray, body: int, torque: np.ndarray) -> np.ndarray:
    return point_load(q, body, np.zeros(3), q[7 * body : 7 * body + 3], torque)


class FileBody:
    """A body's pose in the model file, to carry global points and axes of the file with the body."""

    def __init__(self, spec: dict | None):
        self.r0 = np.zeros(3) if spec is None else np.array(spec["location"], dtype=float)
        self.a0 = np.eye(3) if spec is None else rot(np.array(spec.get("orientation", [1, 0, 0, 0]), dtype=float))

    def point(self, q, body, global0):
        if body < 0:
            return np.asarray(global0, dtype=float)
        return q[7 * body : 7 * body + 3] + rot(q[7 * body + 3 : 7 * body + 7]) @ (self.a0.T @ (global0 - self.r0))

    def axis(self, q, body, global0):
        if body < 0:
            return np.asarray(global0, dtype=float) / np.linalg.norm(global0)
        h = rot(q[7 * body + 3 : 7 * body + 7]) @ (self.a0.T @ np.asarray(global0, dtype=float))
        return h / np.linalg.norm(h)


def motor_loads(spec: dict, efforts: dict):
    """Q_user(q, q', t): every motor replaced by its effort(t), applied as the physical load it stands for."""
    names = [b["name"] for b in spec["bodies"]]
    index = {"ground": -1, **{n: k for k, n in enumerate(names)}}
    bodies = {k: FileBody(None if k < 0 else spec["bodies"][k]) for k in index.values()}
    joints = {j["name"]: j for j in spec["joints"]}

    def load(q, qd, t):
        Q = np.zeros(q.size)
        for motor in spec["motors"]:
            effort = float(efforts[motor["name"]](t))
            if motor["type"] == "distance":
                i, j = index[motor["body1"]], index[motor["body2"]]
                global1 = np.array(motor["point1"], dtype=float)
                global2 = np.array(motor["point2"], dtype=float)
                if motor.get("frame") == "body":  # to the file's global points
                    global1 = bodies[i].r0 + bodies[i].a0 @ global1
                    global2 = bodies[j].r0 + bodies[j].a0 @ global2
                pi, pj = bodies[i].point(q, i, global1), bodies[j].point(q, j, global2)
                u = (pj - pi) / np.linalg.norm(pj - pi)
                Q += point_load(q, j, effort * u, pj)  # a positive effort pushes the points apart
                if i >= 0:
                    Q += point_load(q, i, -effort * u, pi)
                continue
            joint = joints[motor["joint"]]
            i, j = index[joint["body1"]], index[joint["body2"]]
            h = bodies[i].axis(q, i, np.array(joint["axis"], dtype=float))
            if motor["type"] == "angle":  # torque about the joint axis on body2, reaction on body1
                Q += torque_load(q, j, effort * h)
                if i >= 0:
                    Q += torque_load(q, i, -effort * h)
            else:  # linear: force along the axis at the joint point on body2, reaction on body1 there
                point = bodies[j].point(q, j, np.array(joint["location"], dtype=float))
                Q += point_load(q, j, effort * h, point)
                if i >= 0:
                    Q += point_load(q, i, -effort * h, point)
        return Q

    return load


@pytest.mark.parametrize("name", DRIVEN)
def test_inverse_efforts_reproduce_the_motion(name):
    """Forward dynamics without motors, loaded by the inverse-dynamics efforts, follows the driven motion."""
    model, inverse = inverse_run(name)
    assert inverse.info["max_equation_residual"] < 1e-9
    spec = raw(name)
    efforts = {
        m["name"]: scipy.interpolate.make_interp_spline(inverse.t, inverse.reactions[f"{m['name']}.effort"], k=5)
        for m in spec["motors"]
    }
    free_spec = {**spec, "motors": []}
    free = load_model({"model": free_spec})
    system, _, _ = build_system(free)
    forces = build_forces(free).add(motor_loads(spec, efforts))
    run = forward_dynamics(
        system,
        inverse.q[0],
        inverse.qd[0],
        T_INVERSE,
        STEPS_INVERSE,
        integrator="DOP853",
        rtol=1e-11,
        atol=1e-12,
        forces=forces,
    )
    assert run.info["initial_conditions"]["velocity_correction"] < 1e-12
    error = np.max(np.abs(run.q - inverse.q))
    assert error < 1e-6, error
    assert np.max(np.abs(run.qd - inverse.qd)) < 1e-5
    # and without the loads the free mechanism goes elsewhere: the check can fail
    unloaded = forward_dynamics(
        system, inverse.q[0], inverse.qd[0], T_INVERSE, 12, integrator="DOP853", rtol=1e-8, atol=1e-10
    )
    assert np.max(np.abs(unloaded.q[-1] - inverse.q[-1])) > 1e-3


def test_carriage_pendulum_efforts_by_hand():
    """Lagrange in (x, theta), pendulum centre (x - d sin(theta), 0, -d cos(theta)), spring k x:

    F   = (m_c + m_p) x'' - m_p d (theta'' cos(theta) - theta'^2 sin(theta)) + k x
    tau = (I + m_p d^2) theta'' - m_p d x'' cos(theta) + m_p g d sin(theta)
    """
    _, result = inverse_run("carriage_pendulum_driven")
    t = result.t
    mc, mp, d, inertia, k = 2.0, 0.5, 0.25, 0.0104167, 50.0
    x, xdd = 0.3 * np.sin(PI * t), -0.3 * PI**2 * np.sin(PI * t)
    w = 2 * PI
    th, thd, thdd = 0.4 * np.sin(w * t), 0.4 * w * np.cos(w * t), -0.4 * w * w * np.sin(w * t)
    force = (mc + mp) * xdd - mp * d * (thdd * np.cos(th) - thd**2 * np.sin(th)) + k * x
    torque = (inertia + mp * d * d) * thdd - mp * d * xdd * np.cos(th) + mp * G * d * np.sin(th)
    assert np.max(np.abs(result.reactions["traverse.effort"] - force)) < 1e-9 * np.max(np.abs(force)) + 1e-10
    assert np.max(np.abs(result.reactions["swing.effort"] - torque)) < 1e-9 * np.max(np.abs(torque)) + 1e-10
    assert np.max(np.abs(torque)) > 0.1 and np.max(np.abs(force)) > 1.0


def test_carriage_at_constant_speed_with_the_pendulum_locked():
    """x = v t, theta = 0: no inertia force, so F = k x (the spring) and tau = 0 (gravity along the rod);
    with x = a t^2 / 2 instead, F = (m_c + m_p) a + k x and tau = -m_p d a (the rod is pulled back)."""
    spec = raw("carriage_pendulum_driven")
    for coefficients, accel in (([0.0, 0.7], 0.0), ([0.0, 0.0, 0.6], 1.2)):
        spec["motors"][0]["function"] = {"type": "polynomial", "coefficients": coefficients}
        spec["motors"][1]["function"] = {"type": "constant", "value": 0.0}
        model = load_model({"model": spec})
        system, q0, _ = build_system(model)
        result = inverse_dynamics(system, q0, 0.5, 10)
        x = np.polynomial.polynomial.polyval(result.t, coefficients)
        force = 2.5 * accel + 50.0 * x
        assert np.max(np.abs(result.reactions["traverse.effort"] - force)) < 1e-10
        assert np.max(np.abs(result.reactions["swing.effort"] + 0.5 * 0.25 * accel)) < 1e-10


def test_cylindrical_collar_efforts_by_hand():
    """F = m z'' + m g + k z (the spring from (0, 0, 1) is relaxed at z = 0); tau = I_zz theta'' + 0.5 theta."""
    _, result = inverse_run("cylindrical_driven")
    t, w = result.t, 2 * PI
    z, zdd = 0.1 * np.sin(w * t), -0.1 * w * w * np.sin(w * t)
    theta, thetadd = np.sin(PI * t), -(PI**2) * np.sin(PI * t)
    assert np.max(np.abs(result.reactions["lift.effort"] - (zdd + G + 100.0 * z))) < 1e-9
    assert np.max(np.abs(result.reactions["turn.effort"] - (0.03 * thetadd + 0.5 * theta))) < 1e-10
