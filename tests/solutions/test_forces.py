"""Mass matrix and generalized forces against independent derivations.

Every expected Q below is obtained in the test from something other than the formula under test:
minus the gradient of a potential written here from global point positions, minus the gradient of
Rayleigh's dissipation function, or the principle of virtual work Q = (dP/dq)^T F, all by central
finite differences of positions computed here with a rotation matrix of our own.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solutions.generalized_forces import build_forces
from solutions.io.model import ModelError, load_model
from solutions.mass_matrix import mass_matrix

G = 9.81
RNG = np.random.default_rng(3)


def rot(phi):
    return np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])


def global_point(q, body, s):
    """r + A(phi) s' of body ``body`` (-1: ground, where s is already global)."""
    if body < 0:
        return np.asarray(s, dtype=float)
    return q[3 * body : 3 * body + 2] + rot(q[3 * body + 2]) @ s


def gradient(function, x, h=1e-6):
    """Central finite differences of a scalar function."""
    out = np.empty(x.size)
    for k in range(x.size):
        e = np.zeros(x.size)
        e[k] = h
        out[k] = (function(x + e) - function(x - e)) / (2 * h)
    return out


def two_bodies(spring_dampers=(), forces=(), gravity=(0.0, -G)):
    return {
        "model": {
            "name": "two-bodies",
            "gravity": list(gravity),
            "bodies": [
                {"name": "a", "mass": 2.0, "inertia": 0.3, "location": [0.1, 0.2], "orientation": 0.4},
                {"name": "b", "mass": 1.5, "inertia": 0.2, "location": [0.9, -0.3], "orientation": -0.7},
            ],
            "spring_dampers": list(spring_dampers),
            "forces": list(forces),
        }
    }


def random_state(n=6):
    return RNG.normal(size=n) * 0.5, RNG.normal(size=n)


def test_mass_matrix_is_block_diagonal_of_m_m_J():
    model = load_model(two_bodies())
    expected = np.diag([2.0, 2.0, 0.3, 1.5, 1.5, 0.2])
    assert np.array_equal(mass_matrix(model), expected)


def test_gravity_is_minus_gradient_of_m_g_y():
    model = load_model(two_bodies(gravity=(1.0, -G)))
    forces = build_forces(model)
    q, qd = random_state()

    def potential(q):  # V = -sum m g . r, written here
        return -(2.0 * (1.0 * q[0] - G * q[1]) + 1.5 * (1.0 * q[3] - G * q[4]))

    assert forces.is_constant and not forces.is_empty
    np.testing.assert_allclose(forces.generalized_forces(q, qd, 0.0), -gradient(potential, q), atol=1e-8)
    assert forces.potential_energy(q) == pytest.approx(potential(q), abs=1e-12)


def test_no_forces_is_empty():
    forces = build_forces(load_model(two_bodies(gravity=(0.0, 0.0))))
    assert forces.is_empty
    assert np.array_equal(forces.generalized_forces(np.ones(6), np.ones(6), 0.0), np.zeros(6))


TSDA = {
    "name": "s",
    "type": "TSDA",
    "body1": "a",
    "body2": "b",
    "point1": [0.3, 0.25],
    "point2": [0.7, -0.1],
    "spring_coefficient": 120.0,
    "free_length": 0.3,
}


def tsda_length(q, s1, s2):
    return float(np.linalg.norm(global_point(q, 1, s2) - global_point(q, 0, s1)))


def test_tsda_spring_is_minus_gradient_of_its_potential():
    model = load_model(two_bodies([TSDA], gravity=(0.0, 0.0)))
    forces = build_forces(model)
    (spring,) = forces.elements
    s1, s2 = spring.si, spring.sj
    # the file's global points, turned into the body frames, come back at the file's configuration
    q0 = np.array([0.1, 0.2, 0.4, 0.9, -0.3, -0.7])
    np.testing.assert_allclose(global_point(q0, 0, s1), TSDA["point1"], atol=1e-15)
    np.testing.assert_allclose(global_point(q0, 1, s2), TSDA["point2"], atol=1e-15)
    for _ in range(3):
        q, qd = random_state()

        def potential(q):
            return 0.5 * 120.0 * (tsda_length(q, s1, s2) - 0.3) ** 2

        np.testing.assert_allclose(forces.generalized_forces(q, qd, 0.0), -gradient(potential, q), atol=1e-7)
        assert forces.potential_energy(q) == pytest.approx(potential(q), rel=1e-12)
        assert forces.is_conservative


def test_tsda_damper_is_minus_gradient_of_rayleigh_function():
    """Q_damping = -dR/dq', R = 1/2 c l'^2, l' = dl/dq q' (l' computed here by differences along q')."""
    spec = dict(TSDA, spring_coefficient=0.0, damping_coefficient=7.0)
    forces = build_forces(load_model(two_bodies([spec], gravity=(0.0, 0.0))))
    (damper,) = forces.elements
    q, qd = random_state()
    grad_l = gradient(lambda x: tsda_length(x, damper.si, damper.sj), q)

    def rayleigh(qd):
        return 0.5 * 7.0 * (grad_l @ qd) ** 2

    np.testing.assert_allclose(forces.generalized_forces(q, qd, 0.0), -gradient(rayleigh, qd), atol=1e-7)
    assert forces.dissipated_power(q, qd, 0.0) == pytest.approx(7.0 * (grad_l @ qd) ** 2, rel=1e-7)
    assert not forces.is_conservative


def test_tsda_actuator_pulls_along_the_line_and_its_power():
    """A tension f_a(t) gives Q = -f_a dl/dq (virtual work of a pull), power -f_a l'."""
    spec = dict(TSDA, spring_coefficient=0.0, actuator={"type": "polynomial", "coefficients": [1.0, 2.0]})
    forces = build_forces(load_model(two_bodies([spec], gravity=(0.0, 0.0))))
    (actuator,) = forces.elements
    q, qd = random_state()
    grad_l = gradient(lambda x: tsda_length(x, actuator.si, actuator.sj), q)
    t = 0.75
    f = 1.0 + 2.0 * t
    np.testing.assert_allclose(forces.generalized_forces(q, qd, t), -f * grad_l, atol=1e-7)
    assert forces.actuator_power(q, qd, t) == pytest.approx(-f * grad_l @ qd, rel=1e-7)


def test_tsda_actuator_of_the_state_through_the_api():
    from solutions.planar.forces import TSDA as TSDAElement

    forces = build_forces(load_model(two_bodies(gravity=(0.0, 0.0))))
    s1, s2 = np.array([0.1, 0.0]), np.array([-0.2, 0.1])
    forces.elements.append(TSDAElement("api", 0, 1, si=s1, sj=s2, actuator=lambda t, length, rate: 3.0 * length))
    q, qd = random_state()
    length = tsda_length(q, s1, s2)
    grad_l = gradient(lambda x: tsda_length(x, s1, s2), q)
    np.testing.assert_allclose(forces.generalized_forces(q, qd, 0.0), -3.0 * length * grad_l, atol=1e-7)


def test_rsda_spring_damper_actuator():
    """theta = phi_b - phi_a; V = 1/2 k (theta - theta0)^2, R = 1/2 c theta'^2, actuator torque f_a."""
    spec = {
        "name": "r",
        "type": "RSDA",
        "body1": "a",
        "body2": "b",
        "spring_coefficient": 4.0,
        "damping_coefficient": 0.5,
        "actuator": 0.25,
    }
    forces = build_forces(load_model(two_bodies([spec], gravity=(0.0, 0.0))))
    theta0 = -0.7 - 0.4  # free angle defaults to the file's relative angle
    q, qd = random_state()

    def potential(q):
        return 0.5 * 4.0 * (q[5] - q[2] - theta0) ** 2

    def rayleigh(qd):
        return 0.5 * 0.5 * (qd[5] - qd[2]) ** 2

    dtheta = np.array([0, 0, -1.0, 0, 0, 1.0])
    expected = -gradient(potential, q) - gradient(rayleigh, qd) - 0.25 * dtheta
    np.testing.assert_allclose(forces.generalized_forces(q, qd, 0.0), expected, atol=1e-7)
    assert forces.potential_energy(q) == pytest.approx(potential(q), rel=1e-12)
    assert forces.dissipated_power(q, qd, 0.0) == pytest.approx(0.5 * (qd[5] - qd[2]) ** 2)
    assert forces.actuator_power(q, qd, 0.0) == pytest.approx(-0.25 * (qd[5] - qd[2]))


@pytest.mark.parametrize("frame", ["global", "body"])
def test_point_force_by_virtual_work(frame):
    """Q = (dP/dq)^T F: the virtual work of F at the moving point P equals Q . dq."""
    spec = {
        "name": "f",
        "type": "force",
        "body": "b",
        "point": [1.1, -0.2] if frame == "global" else [0.2, 0.1],
        "value": [{"type": "harmonic", "amplitude": 2.0, "frequency": 3.0}, -4.0],
        "frame": frame,
    }
    forces = build_forces(load_model(two_bodies(forces=[spec], gravity=(0.0, 0.0))))
    (load,) = forces.elements
    s = load.point
    if frame == "body":
        np.testing.assert_array_equal(s, [0.2, 0.1])
    else:  # the global point, in b's frame at the file's configuration
        np.testing.assert_allclose(global_point(np.array([0, 0, 0, 0.9, -0.3, -0.7]), 1, s), [1.1, -0.2], atol=1e-15)
    q, qd = random_state()
    t = 0.4
    F = np.array([2.0 * math.sin(3.0 * t), -4.0])
    if frame == "body":
        F = rot(q[5]) @ F  # a body-fixed direction turns with the body
    jac = np.column_stack([gradient(lambda x, k=k: global_point(x, 1, s)[k], q) for k in range(2)])
    np.testing.assert_allclose(forces.generalized_forces(q, qd, t), jac @ F, atol=1e-7)
    assert forces.actuator_power(q, qd, t) == pytest.approx(F @ (jac.T @ qd), rel=1e-7)


def test_torque_and_user_force():
    spec = {"name": "T", "type": "torque", "body": "a", "value": {"type": "polynomial", "coefficients": [0.0, 1.0]}}
    forces = build_forces(load_model(two_bodies(forces=[spec], gravity=(0.0, 0.0))))
    forces.add(lambda q, qd, t: -0.1 * qd)
    q, qd = random_state()
    expected = -0.1 * qd
    expected[2] += 2.0
    np.testing.assert_allclose(forces.generalized_forces(q, qd, 2.0), expected, atol=1e-15)
    assert forces.actuator_power(q, qd, 2.0) == pytest.approx(2.0 * qd[2] - 0.1 * qd @ qd)


def test_bad_loads_are_refused_by_name():
    torque_as_vector = {"name": "T", "type": "torque", "body": "a", "value": [1.0, 2.0]}
    with pytest.raises(ModelError, match=r"forces\[0\].value"):
        build_forces(load_model(two_bodies(forces=[torque_as_vector])))
    force_as_number = {"name": "F", "type": "force", "body": "a", "value": 3.0}
    with pytest.raises(ModelError, match="two components"):
        build_forces(load_model(two_bodies(forces=[force_as_number])))
    same_points = dict(TSDA, body1="ground", point1=[0.9, -0.3], body2="b", point2=[0.9, -0.3])
    with pytest.raises(ModelError, match="coincides"):
        build_forces(load_model(two_bodies([same_points])))
