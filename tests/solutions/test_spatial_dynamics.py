"""Spatial dynamics against references that do not come from the code under test.

- the heavy symmetric top (course/models/heavy_top.yaml): its energy and the angular momentum about
  the vertical and about the symmetry axis are conserved, and it nods between the two roots of the
  cubic in u = cos(theta) (Lagrange's top, e.g. Goldstein, Classical Mechanics, sec. 5.7);
- a torque-free (and a torqued) rigid body against Euler's equations J' w'' + w' x J' w' = n'
  integrated on their own by scipy;
- a spatial double pendulum whose revolute axes are all parallel against the planar solver;
- the collar on a cylindrical joint (course/models/cylindrical.yaml) against its closed form;
- energy conservation in the conservative examples, for every formulation;
- the joint reactions and driver efforts of static configurations against statics by hand;
- the spatial slider-crank's driver power against the rate of change of T + V (inverse dynamics).
"""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import scipy.integrate

from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.inverse_dynamics import inverse_dynamics
from solutions.io.model import load_model
from solutions.rotations import angular_velocity, from_axis_angle, rotation_matrix
from solutions.spatial.mass import kinetic_energy

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
G = 9.81


def run(model, t_end, steps, **options):
    system, q0, qd0 = build_system(model)
    settings = {"integrator": "DOP853", "rtol": 1e-10, "atol": 1e-12, **options}
    return system, forward_dynamics(system, q0, qd0, t_end, steps, **settings)


# -- the heavy symmetric top ----------------------------------------------------------------------
@cache
def top_run():
    model = load_model(MODELS / "heavy_top.yaml")
    return model, *run(model, 0.4, 800)


def top_parameters(model):
    body = model.bodies[0]
    m, J = body.mass, body.inertia
    l = float(np.linalg.norm(body.location))
    return m, l, J[0, 0] + m * l * l, J[2, 2]  # m, l, I1 about the tip, I3


def top_invariants(model, q, qd):
    """(E, L_z, L_3): energy, angular momentum about the tip along the vertical and along the body axis."""
    m, l, _, _ = top_parameters(model)
    J = model.bodies[0].inertia
    out = []
    for qk, qdk in zip(q, qd, strict=True):
        A = rotation_matrix(qk[3:])
        omega = angular_velocity(qk[3:], qdk[3:])
        L = A @ J @ A.T @ omega + m * np.cross(qk[:3], qdk[:3])
        energy = kinetic_energy(model, qk, qdk) + m * G * qk[2]
        out.append((energy, L[2], L @ A[:, 2]))
    return np.array(out)


def test_heavy_top_conserves_energy_and_both_angular_momenta():
    model, _, result = top_run()
    invariants = top_invariants(model, result.q, result.qd)
    spread = np.abs(invariants - invariants[0]).max(axis=0)
    scale = np.abs(invariants[0])
    assert spread[0] < 1e-8 * scale[0], spread  # energy
    assert spread[1] < 1e-8 * scale[2], spread  # about the vertical (compare with the spin's momentum)
    assert spread[2] < 1e-8 * scale[2], spread  # about the symmetry axis: I3 w3
    assert scale[2] == pytest.approx(top_parameters(model)[3] * 60.0, rel=1e-12)


def test_heavy_top_nods_between_the_roots_of_the_cubic():
    """u = cos(theta) obeys u'^2 = f(u) = (alpha - beta u)(1 - u^2) - (a - b u)^2 (Lagrange's top).

    With I1 about the tip, I3 about the axis, w3 the spin and the initial state theta0, theta' = 0,
    psi' = 0: a = p_psi / I1 = b u0, b = I3 w3 / I1, alpha = 2 (E - I3 w3^2 / 2) / I1 = beta u0,
    beta = 2 m g l / I1. u0 is one root; theta swings between theta0 and the root u1 < u0 in (-1, 1).
    """
    model, _, result = top_run()
    m, l, I1, I3 = top_parameters(model)
    u0, w3 = math.cos(math.radians(30.0)), 60.0
    b, beta = I3 * w3 / I1, 2 * m * G * l / I1
    a, alpha = b * u0, beta * u0
    # f(u) = (alpha - beta u)(1 - u^2) - (a - b u)^2 as a cubic in u
    cubic = np.polynomial.Polynomial([alpha, -beta]) * np.polynomial.Polynomial([1.0, 0.0, -1.0])
    cubic = cubic - np.polynomial.Polynomial([a, -b]) ** 2
    roots = np.sort(cubic.roots().real)
    inside = roots[(roots > -1) & (roots < 1)]
    assert np.any(np.abs(inside - u0) < 1e-12)
    u1 = inside[np.argmin(np.where(np.abs(inside - u0) < 1e-12, np.inf, np.abs(inside - u0)))]
    assert u1 < u0
    u = np.array([rotation_matrix(qk[3:])[2, 2] for qk in result.q])  # cos(theta) = z component of the axis
    # 800 output points over 0.4 s: about 50 per nutation period (2 pi I1 / (I3 w3) = 0.12 s), so the
    # sampled extremes come within (w dt / 2)^2 / 2 of a nutation amplitude of the true ones
    amplitude = u0 - u1
    assert u.max() == pytest.approx(u0, abs=1e-8)
    assert u.min() == pytest.approx(u1, abs=2e-3 * amplitude)
    assert u.min() > u1 - 1e-8  # never beyond the turning point
    # and precession: psi' = (a - b u) / (1 - u^2) >= 0, reaching its largest value at u1
    assert np.all(np.diff(np.unwrap(np.arctan2(result.q[:, 0], -result.q[:, 1]))) >= -1e-9)


# -- a free rigid body against Euler's equations ----------------------------------------------------
def free_body(torque=None):
    body = {
        "name": "brick", "mass": 2.0, "inertia": [[0.3, 0.02, 0.0], [0.02, 0.2, 0.01], [0.0, 0.01, 0.1]],
        "location": [0.1, 0.2, 0.3], "orientation": [0.9, 0.1, -0.3, 0.2], "velocity": [0.5, 0.0, -0.2],
        "angular_velocity": [1.0, -2.0, 3.0],
    }  # fmt: skip
    forces = [] if torque is None else [{"type": "torque", "body": "brick", "frame": "body", "value": torque}]
    return load_model({"model": {"dimension": 3, "gravity": [0.0, 0.0, 0.0], "bodies": [body], "forces": forces}})


@pytest.mark.parametrize("torque", [None, [0.1, 0.0, -0.2]])
def test_free_body_follows_eulers_equations(torque):
    model = free_body(torque)
    _, result = run(model, 2.0, 20, formulation="qr")
    body = model.bodies[0]
    J = body.inertia
    n = np.zeros(3) if torque is None else np.array(torque)
    p0 = body.orientation
    w0 = rotation_matrix(p0).T @ body.angular_velocity

    def euler(t, y):  # body-frame angular velocity and p' = 1/2 L^T w'
        w, p = y[:3], y[3:]
        e0, e1, e2, e3 = p
        L = np.array([[-e1, e0, e3, -e2], [-e2, -e3, e0, e1], [-e3, e2, -e1, e0]])
        return np.concatenate([np.linalg.solve(J, n - np.cross(w, J @ w)), 0.5 * L.T @ w])

    reference = scipy.integrate.solve_ivp(euler, (0, 2.0), np.concatenate([w0, p0]), t_eval=result.t,
                                          method="DOP853", rtol=1e-12, atol=1e-12)  # fmt: skip
    for k in range(result.t.size):
        q, qd = result.q[k], result.qd[k]
        A = rotation_matrix(q[3:])
        w_body = A.T @ angular_velocity(q[3:], qd[3:])
        assert np.allclose(w_body, reference.y[:3, k], atol=1e-7)
        assert np.allclose(A, rotation_matrix(reference.y[3:, k]), atol=1e-8)
        assert np.allclose(q[:3], body.location + body.velocity * result.t[k], atol=1e-9)


# -- parallel revolute axes: the planar double pendulum ------------------------------------------------
def double_pendulum(dimension: int) -> dict:
    """Two rods (1.0 m, 1.0 kg; 0.8 m, 0.6 kg) pinned end to end, gravity -y, released at rest from
    30 deg below and 20 deg above the horizontal; in 3D with both revolute axes along z."""
    lengths, masses, angles = (1.0, 0.8), (1.0, 0.6), (-math.pi / 6, math.pi / 9)
    joint_a = np.array([math.cos(angles[0]), math.sin(angles[0])])
    pins = [np.zeros(2), joint_a]
    bodies, joints = [], []
    for k, name in enumerate(("upper", "lower")):
        centre = pins[k] + 0.5 * lengths[k] * np.array([math.cos(angles[k]), math.sin(angles[k])])
        J = masses[k] * lengths[k] ** 2 / 12
        if dimension == 2:
            bodies.append(
                {"name": name, "mass": masses[k], "inertia": J, "location": centre.tolist(), "orientation": angles[k]}
            )
        else:
            p = from_axis_angle([0.0, 0.0, 1.0], angles[k]).tolist()
            bodies.append(
                {"name": name, "mass": masses[k], "inertia": [1e-3, J, J], "location": [*centre, 0.0], "orientation": p}
            )
        location = pins[k].tolist() + ([0.0] if dimension == 3 else [])
        joint = {
            "name": "OA"[k],
            "type": "revolute",
            "body1": ("ground", "upper")[k],
            "body2": name,
            "location": location,
        }
        if dimension == 3:
            joint["axis"] = [0.0, 0.0, 1.0]
        joints.append(joint)
    gravity = [0.0, -G] + ([0.0] if dimension == 3 else [])
    return {"model": {"dimension": dimension, "gravity": gravity, "bodies": bodies, "joints": joints}}


def test_parallel_revolute_axes_reproduce_the_planar_double_pendulum():
    settings = {"formulation": "qr", "rtol": 1e-12, "atol": 1e-14}
    _, planar = run(load_model(double_pendulum(2)), 1.5, 30, **settings)
    _, spatial = run(load_model(double_pendulum(3)), 1.5, 30, **settings)
    for k, name in enumerate(("upper", "lower")):
        x, y, phi = planar.q[:, 3 * k], planar.q[:, 3 * k + 1], planar.q[:, 3 * k + 2]
        q = spatial.q[:, 7 * k : 7 * k + 7]
        angle = np.unwrap(2 * np.arctan2(q[:, 6], q[:, 3]))
        assert np.abs(q[:, 0] - x).max() < 1e-8, name
        assert np.abs(q[:, 1] - y).max() < 1e-8, name
        assert np.abs(angle - phi).max() < 1e-8, name
        assert np.abs(q[:, [2, 4, 5]]).max() < 1e-12  # stays in the plane, turning about z only
    assert np.abs(planar.q[-1, 2] - planar.q[0, 2]) > 0.5  # it did move


# -- the collar on a cylindrical joint: closed form ------------------------------------------------------
def test_cylindrical_collar_matches_its_closed_form():
    model = load_model(MODELS / "cylindrical.yaml")
    _, result = run(model, 1.0, 50)
    t = result.t
    w, v = 10.0, math.sqrt(0.5 / 0.03)
    z = -G / 100 + (G / 100) * np.cos(w * t) + (0.5 / w) * np.sin(w * t)
    twist = (2.0 / v) * np.sin(v * t)
    q = result.q
    assert np.abs(q[:, 2] - z).max() < 1e-8
    assert np.abs(2 * np.arctan2(q[:, 6], q[:, 3]) - twist).max() < 1e-8
    assert np.abs(q[:, [0, 1, 4, 5]]).max() < 1e-12


# -- energy in conservative scenes --------------------------------------------------------------------
@pytest.mark.parametrize("formulation", ["baumgarte", "partitioning", "qr", "svd", "projection"])
def test_energy_is_conserved_for_every_formulation(formulation):
    model = load_model(MODELS / "revolute_revolute_skew.yaml")
    _, result = run(model, 0.6, 30, formulation=formulation)
    assert result.info["energy_drift_relative"] < 1e-7
    # T + V by hand: the two links' kinetic energy and their weight (1 kg each)
    kinetic = np.array([kinetic_energy(model, q, qd) for q, qd in zip(result.q, result.qd, strict=True)])
    energy = kinetic + G * (result.q[:, 2] + result.q[:, 9])
    assert np.ptp(energy) < 1e-7 * kinetic.max()
    assert np.ptp(result.q[:, 2]) > 0.1  # it fell


@pytest.mark.parametrize("name", ["spatial_double_pendulum", "carriage_pendulum"])
def test_energy_is_conserved_in_the_conservative_examples(name):
    model = load_model(MODELS / f"{name}.yaml")
    _, result = run(model, 0.5, 10)
    assert result.info["energy_drift_relative"] < 1e-7
    assert result.info["max_constraint_residual"] < 1e-8


@pytest.mark.parametrize("integrator", ["hht", "generalized-alpha"])
def test_implicit_index3_integrators_run_spatial_models(integrator):
    model = load_model(MODELS / "spatial_double_pendulum.yaml")
    _, result = run(model, 0.3, 10, integrator=integrator, rtol=1e-6, atol=1e-8)
    _, reference = run(model, 0.3, 10)
    assert result.info["max_constraint_residual"] < 1e-10
    assert np.abs(result.q - reference.q).max() < 1e-3


# -- statics by hand ------------------------------------------------------------------------------------
def test_static_reactions_of_a_rod_on_a_vertical_pin():
    """A horizontal rod (m, length l along x) on a revolute joint with a vertical axis, held by an angle
    motor: the pin carries the weight, F = (0, 0, m g), and the bending moment M_y = -m g l / 2 about
    the pin (the weight's moment is r x W = (0, m g l / 2, 0)); the motor carries nothing."""
    m, l = 3.0, 0.8
    body = {"name": "rod", "mass": m, "inertia": [1e-3, m * l * l / 12, m * l * l / 12], "location": [l / 2, 0.0, 0.0]}
    joint = {"name": "O", "type": "revolute", "body1": "ground", "body2": "rod", "location": [0.0, 0.0, 0.0],
             "axis": [0.0, 0.0, 1.0]}  # fmt: skip
    motor = {"name": "hold", "type": "angle", "joint": "O", "function": 0.0}
    model = load_model(
        {"model": {"dimension": 3, "gravity": [0, 0, -G], "bodies": [body], "joints": [joint], "motors": [motor]}}
    )
    system, q0, _ = build_system(model)
    result = inverse_dynamics(system, q0, 0.1, 1)
    r = {k: v[0] for k, v in result.reactions.items()}
    expected = {"O.Fx": 0, "O.Fy": 0, "O.Fz": m * G, "O.Mx": 0, "O.My": -m * G * l / 2, "O.Mz": 0, "hold.effort": 0}
    for key, value in expected.items():
        assert r[key] == pytest.approx(value, abs=1e-10), key
    assert r["O.Fz_joint"] == pytest.approx(m * G) and r["O.Mz_joint"] == pytest.approx(0.0, abs=1e-10)


def test_static_reactions_on_an_inclined_prismatic_joint():
    """A block held on an inclined rail (angle a, axis u = (cos a, 0, sin a)) by a linear motor: the motor
    pushes m g sin(a) up the rail; the rail carries the rest of the weight, normal to it, and no moment."""
    m, a = 2.0, math.radians(25.0)
    u = [math.cos(a), 0.0, math.sin(a)]
    body = {"name": "block", "mass": m, "inertia": [0.01, 0.02, 0.03], "location": [0.3, 0.1, 0.2]}
    joint = {
        "name": "rail",
        "type": "prismatic",
        "body1": "ground",
        "body2": "block",
        "location": [0.3, 0.1, 0.2],
        "axis": u,
    }
    motor = {"name": "hold", "type": "linear", "joint": "rail", "function": 0.0}
    model = load_model(
        {"model": {"dimension": 3, "gravity": [0, 0, -G], "bodies": [body], "joints": [joint], "motors": [motor]}}
    )
    system, q0, _ = build_system(model)
    result = inverse_dynamics(system, q0, 0.1, 1)
    r = {k: v[0] for k, v in result.reactions.items()}
    assert r["hold.effort"] == pytest.approx(m * G * math.sin(a), rel=1e-12)
    rail_force = np.array([r["rail.Fx"], r["rail.Fy"], r["rail.Fz"]])
    expected = np.array([0, 0, m * G]) - m * G * math.sin(a) * np.array(u)
    assert np.allclose(rail_force, expected, atol=1e-10)
    assert np.allclose([r["rail.Mx"], r["rail.My"], r["rail.Mz"]], 0.0, atol=1e-10)


def test_slider_crank_driver_power_balances_the_energy_rate():
    """Inverse dynamics of the spatial slider-crank: driver torque x crank speed = d(T + V)/dt, with T + V
    from the kinematic motion by hand and its rate by central differences."""
    model = load_model(MODELS / "spatial_slider_crank.yaml")
    system, q0, _ = build_system(model)
    result = inverse_dynamics(system, q0, 1.0, 400)
    masses = [b.mass for b in model.bodies]
    energy = np.array(
        [kinetic_energy(model, q, qd) + G * sum(mk * q[7 * k + 2] for k, mk in enumerate(masses))
         for q, qd in zip(result.q, result.qd, strict=True)]
    )  # fmt: skip
    rate = np.gradient(energy, result.t, edge_order=2)
    power = result.reactions["drive.effort"] * 2 * math.pi
    assert np.abs(power - rate)[2:-2].max() < 1e-3 * np.abs(power).max()
    assert result.info["max_equation_residual"] < 1e-10
    assert np.abs(power).max() > 0.1


# -- generalized forces: power and potential ----------------------------------------------------------
def tangent_state(rng):
    """A unit p and a p' with p^T p' = 0 (the velocity constraint of the normalization)."""
    q = rng.normal(size=7)
    q[3:] /= np.linalg.norm(q[3:])
    qd = rng.normal(size=7)
    qd[3:] -= (qd[3:] @ q[3:]) * q[3:]
    return q, qd


@pytest.mark.parametrize("body_fixed", [False, True])
def test_point_force_and_torque_do_the_work_of_statics(body_fixed):
    """q'^T Q = F^T v_P for a force at P and n^T omega for a torque, v_P = r' + omega x (A s')."""
    from solutions.functions import Constant
    from solutions.spatial.forces import PointForce, Torque

    rng = np.random.default_rng(5)
    q, qd = tangent_state(rng)
    s, value = rng.normal(size=3), rng.normal(size=3)
    components = tuple(Constant(float(v)) for v in value)
    A = rotation_matrix(q[3:])
    omega = angular_velocity(q[3:], qd[3:])
    F = A @ value if body_fixed else value
    force = PointForce("F", 0, -1, point=s, components=components, body_fixed=body_fixed)
    Q, _ = force.forces(q, None, qd, None, 0.0)
    assert Q @ qd == pytest.approx(F @ (qd[:3] + np.cross(omega, A @ s)), rel=1e-12)
    assert abs(Q[3:] @ q[3:]) < 1e-12  # no load on the normalization constraint
    torque = Torque("n", 0, -1, components=components, body_fixed=body_fixed)
    Q, _ = torque.forces(q, None, qd, None, 0.0)
    assert Q @ qd == pytest.approx(F @ omega, rel=1e-12)


def test_tsda_force_is_minus_the_gradient_of_its_potential():
    from solutions.spatial.forces import TSDA

    rng = np.random.default_rng(8)
    (qi, qdi), (qj, qdj) = tangent_state(rng), tangent_state(rng)
    spring = TSDA("s", 0, 1, si=rng.normal(size=3), sj=rng.normal(size=3), stiffness=40.0, free_length=0.7)
    Qi, Qj = spring.forces(qi, qj, qdi, qdj, 0.0)
    h = 1e-6
    rate = (spring.potential(qi + h * qdi, qj + h * qdj) - spring.potential(qi - h * qdi, qj - h * qdj)) / (2 * h)
    assert Qi @ qdi + Qj @ qdj == pytest.approx(-rate, rel=1e-7)
    damper = TSDA("d", 0, 1, si=spring.si, sj=spring.sj, damping=3.0)
    Qi, Qj = damper.forces(qi, qj, qdi, qdj, 0.0)
    assert Qi @ qdi + Qj @ qdj == pytest.approx(-damper.dissipated_power(qi, qj, qdi, qdj, 0.0), rel=1e-12)


def test_rsda_torque_about_a_revolute_axis():
    """Body j turned by beta about the joint axis h (body i is ground): q'^T Q = -(k (beta - beta0) + c beta') beta'."""
    from solutions.spatial.build import joint_axes
    from solutions.spatial.forces import RSDA

    f, g, h = joint_axes(np.array([0.3, -0.5, 0.8]))
    spring = RSDA("r", -1, 0, fi=f, gi=g, hi=h, fj=f, stiffness=2.0, damping=0.5, free_angle=0.2)
    beta, rate = 1.1, -0.7
    q = np.concatenate([np.zeros(3), from_axis_angle(h, beta)])
    qd = np.concatenate([np.zeros(3), 0.5 * np.array(angular_velocity_transpose(q[3:], rate * h))])
    ground = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    assert spring.angle(ground, q) == pytest.approx(beta)
    assert spring.rate(ground, q, np.zeros(7), qd) == pytest.approx(rate)
    _, Q = spring.forces(ground, q, np.zeros(7), qd, 0.0)
    assert Q @ qd == pytest.approx(-(2.0 * (beta - 0.2) + 0.5 * rate) * rate, rel=1e-12)
    assert spring.potential(ground, q) == pytest.approx(0.5 * 2.0 * (beta - 0.2) ** 2)


def angular_velocity_transpose(p, omega):
    """G(p)^T omega (so p' = 1/2 G^T omega), G written out from its definition [-e, e~ + e0 I]."""
    e0, e = p[0], p[1:]
    E = np.array([[0, -e[2], e[1]], [e[2], 0, -e[0]], [-e[1], e[0], 0]]) + e0 * np.eye(3)
    return np.column_stack([-e, E]).T @ omega


def test_joints_given_in_body_frames_match_the_global_description():
    """The slider-crank's joints written with ``frame: body`` (points and axes in the bodies' frames)."""
    from solutions.rotations import normalized

    global_model = load_model(MODELS / "spatial_slider_crank.yaml")
    system, q0, _ = build_system(global_model)
    data = {"model": {"dimension": 3, "gravity": [0, 0, -G], "bodies": [], "joints": [], "motors": global_model.motors}}
    frames = {}
    for body in global_model.bodies:
        spec = {"name": body.name, "mass": body.mass, "inertia": body.inertia.tolist()}
        spec.update(location=body.location.tolist(), orientation=body.orientation.tolist())
        data["model"]["bodies"].append(spec)
        frames[body.name] = (body.location, rotation_matrix(normalized(body.orientation)))
    frames["ground"] = (np.zeros(3), np.eye(3))
    for joint in global_model.joints:
        spec = {k: v for k, v in joint.items() if k not in ("location", "axis", "axis2")}
        (r1, A1), (r2, A2) = frames[joint["body1"]], frames[joint["body2"]]
        P = np.array(joint["location"])
        spec.update(frame="body", point1=(A1.T @ (P - r1)).tolist(), point2=(A2.T @ (P - r2)).tolist())
        if "axis" in joint:
            spec["axis"] = (A1.T @ np.array(joint["axis"])).tolist()
        if "axis2" in joint:
            spec["axis2"] = (A2.T @ np.array(joint["axis2"])).tolist()
        data["model"]["joints"].append(spec)
    body_system, _, _ = build_system(load_model(data))
    rng = np.random.default_rng(2)
    q = q0 + 0.1 * rng.normal(size=q0.size)
    assert np.allclose(body_system.constraints(q, 0.3), system.constraints(q, 0.3), atol=1e-14)
    assert np.allclose(body_system.jacobian(q, 0.3), system.jacobian(q, 0.3), atol=1e-14)


def test_a_planar_scene_never_imports_spatial_code():
    """One solution layer: a planar forward and inverse dynamics run loads nothing of solutions.spatial."""
    import subprocess
    import sys

    script = (
        "import sys\n"
        "from solutions.assembly import build_system\n"
        "from solutions.dynamics import forward_dynamics\n"
        "from solutions.inverse_dynamics import inverse_dynamics\n"
        "from solutions.io.model import load_model\n"
        f"s, q, qd = build_system(load_model({str(MODELS / 'double_pendulum.yaml')!r}))\n"
        "forward_dynamics(s, q, qd, 0.05, 2)\n"
        f"s, q, qd = build_system(load_model({str(MODELS / 'slider_crank.yaml')!r}))\n"
        "inverse_dynamics(s, q, 0.05, 2)\n"
        "print(sorted(m for m in sys.modules if m.startswith(('solutions.spatial', 'solutions.rotations'))))\n"
    )
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_the_kinetic_energy_of_a_history_is_that_of_the_mass_matrix():
    """``kinetic_energy_history`` (all output times at once, the results' energy column) against T = 1/2 q'^T M(q) q'
    with the mass matrix of eq. 10.4 at every state: random states of a two-body model."""
    from solutions.spatial.mass import kinetic_energy_history, mass_matrix

    model = load_model(MODELS / "spatial_double_pendulum.yaml")
    rng = np.random.default_rng(3)
    q, qd = rng.standard_normal((6, 14)), rng.standard_normal((6, 14))
    expected = [0.5 * qdk @ mass_matrix(model, qk) @ qdk for qk, qdk in zip(q, qd, strict=True)]
    assert np.allclose(kinetic_energy_history(model, q, qd), expected, rtol=1e-13, atol=0.0)


def test_the_dynamics_mass_matrix_is_the_regular_one_of_eq_10_4():
    """``SpatialMassMatrix(model)(q)``, the M(q) of every right-hand side (only the p blocks computed anew), against
    ``dynamic_mass_matrix`` to the last bit, and against the kinetic energy with omega' = 2 L p' (eq. 10.3): for unit
    p and p' tangent to |p| = 1 the regularizing 4 w p p^T adds nothing to 1/2 q'^T M q'."""
    from solutions.rotations import l_matrix
    from solutions.spatial.mass import SpatialMassMatrix, dynamic_mass_matrix

    model = load_model(MODELS / "spatial_double_pendulum.yaml")
    masses = SpatialMassMatrix(model)
    rng = np.random.default_rng(5)
    for _ in range(20):
        q, qd = rng.standard_normal(14), rng.standard_normal(14)
        assert np.array_equal(masses(q), dynamic_mass_matrix(model, q))
        energy = 0.0
        for k, body in enumerate(model.bodies):
            p = q[7 * k + 3 : 7 * k + 7] = q[7 * k + 3 : 7 * k + 7] / np.linalg.norm(q[7 * k + 3 : 7 * k + 7])
            qd[7 * k + 3 : 7 * k + 7] -= (p @ qd[7 * k + 3 : 7 * k + 7]) * p
            rd, omega = qd[7 * k : 7 * k + 3], 2.0 * l_matrix(p) @ qd[7 * k + 3 : 7 * k + 7]
            energy += 0.5 * body.mass * rd @ rd + 0.5 * omega @ body.inertia @ omega
        assert 0.5 * qd @ masses(q) @ qd == pytest.approx(energy, rel=1e-13)
