"""Rotations: identities and round trips on random rotations, in every quadrant and in gimbal lock.

The references are independent of the Euler-parameter formulas under test: elementary rotation
matrices written out with cos and sin, Rodrigues' formula, and finite differences of A(t) for the
angular velocity (A' A^T = omega~).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solutions import rotations as rot

RNG = np.random.default_rng(20240611)


def random_unit_quaternions(count: int) -> np.ndarray:
    p = RNG.normal(size=(count, 4))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def Rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def Ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def Rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def same_rotation(p, q, tol=1e-12):
    """p and -p are the same rotation."""
    return min(np.abs(p - q).max(), np.abs(p + q).max()) < tol


@pytest.mark.parametrize("p", random_unit_quaternions(50))
def test_rotation_matrix_is_proper_orthogonal(p):
    A = rot.rotation_matrix(p)
    assert np.allclose(A.T @ A, np.eye(3), atol=1e-14)
    assert np.linalg.det(A) == pytest.approx(1.0, abs=1e-14)
    assert np.allclose(rot.rotation_matrix(-p), A, atol=1e-15)


@pytest.mark.parametrize("p", random_unit_quaternions(50))
def test_rotation_matrix_matches_rodrigues(p):
    """A(p) against Rodrigues' formula with the axis and angle read off p by hand."""
    angle = 2.0 * math.atan2(np.linalg.norm(p[1:]), p[0])
    A = np.eye(3) + 0  # Rodrigues written out here, independent of rotations.rodrigues
    u = p[1:] / np.linalg.norm(p[1:])
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    A = A + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K
    assert np.allclose(rot.rotation_matrix(p), A, atol=1e-14)
    assert np.allclose(rot.rodrigues(u, angle), A, atol=1e-14)


@pytest.mark.parametrize("p", random_unit_quaternions(50))
def test_euler_parameters_round_trip(p):
    back = rot.euler_parameters(rot.rotation_matrix(p))
    assert back[0] >= 0.0
    assert same_rotation(back, p)


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("angle", [0.0, 1e-9, 0.5, math.pi / 2, 3.0, math.pi - 1e-9, math.pi, 4.0, 2 * math.pi - 1e-3])
def test_euler_parameters_every_quadrant(axis, angle):
    """Each branch of Shepperd's method (largest of e0, e1, e2, e3), including half turns (tr A = -1)."""
    tilt = rot.from_axis_angle([0.3, -0.2, 0.9], 0.2) if angle > 0 else rot.IDENTITY
    u = np.eye(3)[axis] + 0.1 * rot.rotation_matrix(tilt)[:, axis]
    p = rot.from_axis_angle(u, angle)
    A = rot.rodrigues(u, angle)
    back = rot.euler_parameters(A)
    assert same_rotation(back, p, 1e-14)
    assert np.allclose(rot.rotation_matrix(back), A, atol=1e-14)


def test_euler_parameters_near_half_turn_keep_accuracy():
    """The naive e0 = sqrt(1 + tr A) / 2 loses half the digits near chi = pi; Shepperd's method does not."""
    u = np.array([1.0, 2.0, 2.0]) / 3.0
    angle = math.pi - 1e-7
    p = rot.from_axis_angle(u, angle)
    back = rot.euler_parameters(rot.rodrigues(u, angle))
    assert back[0] == pytest.approx(p[0], rel=1e-7)
    assert np.allclose(back, p, atol=1e-15)


@pytest.mark.parametrize("pair", random_unit_quaternions(20).reshape(10, 2, 4))
def test_quaternion_product_composes_rotations(pair):
    a, b = pair
    assert np.allclose(
        rot.rotation_matrix(rot.quaternion_product(a, b)), rot.rotation_matrix(a) @ rot.rotation_matrix(b)
    )
    assert np.allclose(rot.rotation_matrix(rot.conjugate(a)), rot.rotation_matrix(a).T)


@pytest.mark.parametrize("p", random_unit_quaternions(20))
def test_g_and_l_identities(p):
    G, L = rot.g_matrix(p), rot.l_matrix(p)
    assert np.allclose(G @ G.T, np.eye(3)) and np.allclose(L @ L.T, np.eye(3))
    assert np.allclose(G @ p, 0) and np.allclose(L @ p, 0)
    assert np.allclose(G @ L.T, rot.rotation_matrix(p))
    assert np.allclose(G.T @ G, np.eye(4) - np.outer(p, p))


@pytest.mark.parametrize("seed", range(10))
def test_angular_velocity_from_euler_parameter_rates(seed):
    """omega = 2 G p' and omega' = 2 L p' against A' A^T = omega~ by central differences of A(p(t))."""
    rng = np.random.default_rng(seed)
    p0 = rng.normal(size=4)
    p0 /= np.linalg.norm(p0)
    omega = rng.normal(size=3)

    def p_at(t):  # the exact motion with constant global omega: p(t) = exp(omega t) p0
        return rot.quaternion_product(rot.from_axis_angle(omega, np.linalg.norm(omega) * t), p0)

    h = 1e-6
    pd = (p_at(h) - p_at(-h)) / (2 * h)
    A_dot = (rot.rotation_matrix(p_at(h)) - rot.rotation_matrix(p_at(-h))) / (2 * h)
    W = A_dot @ rot.rotation_matrix(p0).T
    omega_fd = np.array([W[2, 1], W[0, 2], W[1, 0]])
    assert np.allclose(omega_fd, omega, atol=1e-8)
    assert np.allclose(rot.angular_velocity(p0, pd), omega, atol=1e-8)
    body = rot.rotation_matrix(p0).T @ omega
    assert np.allclose(rot.body_angular_velocity(p0, pd), body, atol=1e-8)
    assert np.allclose(rot.euler_parameter_rates(p0, omega), pd, atol=1e-8)
    assert np.allclose(rot.euler_parameter_rates(p0, body, frame="body"), pd, atol=1e-8)
    assert abs(p0 @ rot.euler_parameter_rates(p0, omega)) < 1e-15


@pytest.mark.parametrize("angle", [0.0, 1e-10, 1e-4, 1.0, 3.0, math.pi])
def test_axis_angle_round_trip(angle):
    u = np.array([2.0, -1.0, 0.5])
    u /= np.linalg.norm(u)
    axis, back = rot.to_axis_angle(rot.from_axis_angle(u, angle))
    assert back == pytest.approx(angle, rel=1e-14, abs=1e-300)
    if angle > 0:
        assert np.allclose(axis, u, atol=1e-14)


@pytest.mark.parametrize("seed", range(20))
def test_euler_313_round_trip(seed):
    rng = np.random.default_rng(seed)
    psi, phi = rng.uniform(-math.pi, math.pi, 2)
    theta = rng.uniform(0.0, math.pi)
    p = rot.from_euler_313(psi, theta, phi)
    assert np.allclose(rot.rotation_matrix(p), Rz(psi) @ Rx(theta) @ Rz(phi), atol=1e-14)
    assert np.allclose(rot.to_euler_313(p), (psi, theta, phi), atol=1e-10)


@pytest.mark.parametrize("seed", range(20))
def test_euler_123_round_trip(seed):
    rng = np.random.default_rng(100 + seed)
    phi, psi = rng.uniform(-math.pi, math.pi, 2)
    theta = rng.uniform(-math.pi / 2, math.pi / 2)
    p = rot.from_euler_123(phi, theta, psi)
    assert np.allclose(rot.rotation_matrix(p), Rx(phi) @ Ry(theta) @ Rz(psi), atol=1e-14)
    assert np.allclose(rot.to_euler_123(p), (phi, theta, psi), atol=1e-10)


@pytest.mark.parametrize("theta", [0.0, math.pi])
def test_euler_313_gimbal_lock(theta):
    """At theta = 0 or pi only psi +- phi is defined: phi = 0 is returned and the rotation is kept."""
    p = rot.from_euler_313(0.7, theta, -1.9)
    psi, theta_back, phi = rot.to_euler_313(p)
    assert phi == 0.0 and theta_back == pytest.approx(theta, abs=1e-12)
    assert np.allclose(
        rot.rotation_matrix(rot.from_euler_313(psi, theta_back, phi)), rot.rotation_matrix(p), atol=1e-14
    )


@pytest.mark.parametrize("theta", [math.pi / 2, -math.pi / 2])
def test_euler_123_gimbal_lock(theta):
    p = rot.from_euler_123(0.4, theta, 1.1)
    phi, theta_back, psi = rot.to_euler_123(p)
    assert psi == 0.0 and theta_back == pytest.approx(theta, abs=1e-7)
    assert np.allclose(
        rot.rotation_matrix(rot.from_euler_123(phi, theta_back, psi)), rot.rotation_matrix(p), atol=1e-12
    )


@pytest.mark.parametrize("seed", range(10))
def test_screw_parameters(seed):
    """The screw axis is fixed by the rotation, and its points only slide along it: A rho + d = rho + h u."""
    rng = np.random.default_rng(seed)
    p = rng.normal(size=4)
    A = rot.rotation_matrix(p / np.linalg.norm(p))
    d = rng.normal(size=3)
    screw = rot.screw_parameters(A, d)
    u, rho, h = screw.axis, screw.point, screw.translation
    assert np.allclose(A @ u, u, atol=1e-13)
    assert np.allclose(A @ rho + d, rho + h * u, atol=1e-12)
    assert abs(rho @ u) < 1e-12
    assert screw.pitch == pytest.approx(h / screw.angle)
    assert np.allclose(rot.rodrigues(u, screw.angle), A, atol=1e-13)
    # any other point of the axis slides the same way
    other = rho + 3.0 * u
    assert np.allclose(A @ other + d, other + h * u, atol=1e-12)


def test_screw_of_a_planar_rotation_about_a_point():
    """A turn by 90 deg about the vertical line through (1, 2, 0), lifting 0.5: the textbook case."""
    c = np.array([1.0, 2.0, 0.0])
    A = Rz(math.pi / 2)
    d = c - A @ c + np.array([0.0, 0.0, 0.5])
    screw = rot.screw_parameters(A, d)
    assert np.allclose(screw.axis, [0, 0, 1]) and screw.angle == pytest.approx(math.pi / 2)
    assert np.allclose(screw.point, c) and screw.translation == pytest.approx(0.5)


def test_screw_of_a_pure_translation():
    screw = rot.screw_parameters(np.eye(3), np.array([0.0, 3.0, 4.0]))
    assert screw.angle == 0.0 and screw.translation == pytest.approx(5.0) and math.isinf(screw.pitch)
    assert np.allclose(screw.axis, [0.0, 0.6, 0.8])


def test_displacement_between_two_configurations():
    q1 = np.array([1.0, 0.0, 0.0, *rot.from_axis_angle([0, 0, 1], 0.3)])
    q2 = np.array([0.0, 2.0, 1.0, *rot.from_axis_angle([1, 1, 0], 1.2)])
    A, d = rot.displacement(q1, q2)
    s = np.array([0.2, -0.4, 0.7])  # a body point
    assert np.allclose(A @ (q1[:3] + rot.rotation_matrix(q1[3:]) @ s) + d, q2[:3] + rot.rotation_matrix(q2[3:]) @ s)
