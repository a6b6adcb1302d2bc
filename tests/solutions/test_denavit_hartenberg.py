"""solutions/spatial/denavit_hartenberg.py: DH transforms and dual numbers (course notes, sec. 8.7).

- the DH transform (eq. 8.22) against the four elementary motions written here as matrices, and its rotation block
  against the solver's own A(p) of the composed Euler parameters (eq. 8.12);
- dual numbers (eq. 8.24, 8.25): eps^2 = 0, a function's dual part is its derivative;
- dual quaternions (eq. 8.27-8.30): back to (A, t), composition as the matrix product, the screw form against the
  screw of eq. 8.20 (``rotations.screw_parameters``), the DH screws against the DH matrix;
- the dual matrix (eq. 8.31): Yang and Freudenstein's DH form equals A + eps t~ A and moves lines;
- the planar slider-crank's loop closure (eq. 8.23) written with DH parameters here, at the positions the solver's
  kinematic analysis of course/models/slider_crank.yaml computes: the loop closes in all three forms, and 1 mm off
  it does not.
"""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.io.model import load_model
from solutions.kinematics import kinematic_analysis
from solutions.rotations import axis_rotation, quaternion_product, rodrigues, rotation_matrix, screw_parameters
from solutions.spatial.denavit_hartenberg import (
    ONE,
    Dual,
    DualQuaternion,
    chain,
    cos,
    dh_dual_matrix,
    dh_dual_quaternion,
    dh_transform,
    dot,
    dual_matrix,
    line,
    loop_closure_error,
    sin,
)

REPO = Path(__file__).resolve().parents[2]
RNG_SEEDS = range(5)


def parameters(seed: int) -> tuple[float, float, float, float]:
    theta, d, a, alpha = np.random.default_rng(seed).uniform(-3.0, 3.0, 4)
    return float(theta), float(d), float(a), float(alpha)


def elementary(kind: str, value: float) -> np.ndarray:
    """Rot_z, Rot_x (eq. 8.5) and Trans_z, Trans_x as 4 x 4 homogeneous matrices."""
    T, c, s = np.eye(4), math.cos(value), math.sin(value)
    if kind == "Rot_z":
        T[:2, :2] = [[c, -s], [s, c]]
    elif kind == "Rot_x":
        T[1:3, 1:3] = [[c, -s], [s, c]]
    else:
        T[{"Trans_x": 0, "Trans_z": 2}[kind], 3] = value
    return T


# -- the DH transform ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_dh_transform_is_the_four_elementary_motions_in_turn(seed):
    theta, d, a, alpha = parameters(seed)
    expected = (
        elementary("Rot_z", theta) @ elementary("Trans_z", d) @ elementary("Trans_x", a) @ elementary("Rot_x", alpha)
    )
    np.testing.assert_allclose(dh_transform(theta, d, a, alpha), expected, atol=1e-15)


@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_dh_rotation_is_the_solvers_rotation_of_the_two_turns(seed):
    theta, d, a, alpha = parameters(seed)
    p = quaternion_product(axis_rotation(2, theta), axis_rotation(0, alpha))  # R_z(theta) R_x(alpha)
    T = dh_transform(theta, d, a, alpha)
    np.testing.assert_allclose(T[:3, :3], rotation_matrix(p), atol=1e-15)
    np.testing.assert_allclose(T[:3, 3], [a * math.cos(theta), a * math.sin(theta), d], atol=1e-15)


# -- dual numbers ----------------------------------------------------------------------------------------------------
def test_eps_squared_is_zero_and_the_dual_part_of_a_function_is_its_derivative():
    eps = Dual(0.0, 1.0)
    product = eps * eps
    assert (product.real, product.dual) == (0.0, 0.0)
    x = Dual(0.7, 0.3)
    assert (x * x).dual == pytest.approx(2 * 0.7 * 0.3)  # (a + eps a0)^2 = a^2 + eps 2 a a0
    for f, derivative in ((cos, -math.sin(0.7)), (sin, math.cos(0.7))):
        assert f(x).dual == pytest.approx(0.3 * derivative, abs=1e-15)  # eq. 8.25
    identity = cos(x) * cos(x) + sin(x) * sin(x)
    assert identity.real == pytest.approx(1.0) and identity.dual == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_two_joint_axes_make_the_dual_angle_of_their_twist_and_length(seed):
    """z_{i-1} (the z axis) and z_i (through (a, 0, 0), turned by alpha about x): cos of alpha + eps a (eq. 8.26)."""
    _, _, a, alpha = parameters(seed)
    axis = line([0.0, 0.0, 1.0], np.zeros(3))
    other = line([0.0, -math.sin(alpha), math.cos(alpha)], [a, 0.0, 0.0])
    product, expected = dot(axis, other), cos(Dual(alpha, a))
    assert product.real == pytest.approx(expected.real, abs=1e-15)
    assert product.dual == pytest.approx(expected.dual, abs=1e-15)


# -- dual quaternions ------------------------------------------------------------------------------------------------
def displacement_of(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(100 + seed)
    return rodrigues(rng.standard_normal(3), rng.uniform(0.1, 3.0)), rng.uniform(-1.0, 1.0, 3)


@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_dual_quaternion_round_trip_and_composition(seed):
    (A1, t1), (A2, t2) = displacement_of(seed), displacement_of(seed + 50)
    q1, q2 = DualQuaternion.from_displacement(A1, t1), DualQuaternion.from_displacement(A2, t2)
    A, t = q1.displacement()
    np.testing.assert_allclose(A, A1, atol=1e-14)
    np.testing.assert_allclose(t, t1, atol=1e-14)
    assert abs(q1.real @ q1.dual) < 1e-15  # p^T p0 = 0
    # q1 q2 is x -> A1 (A2 x + t2) + t1
    A, t = (q1 * q2).displacement()
    np.testing.assert_allclose(A, A1 @ A2, atol=1e-14)
    np.testing.assert_allclose(t, A1 @ t2 + t1, atol=1e-14)


@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_the_screw_form_is_the_screw_of_chasles_theorem(seed):
    A, t = displacement_of(seed)
    screw = screw_parameters(A, t)  # eq. 8.20
    polar = DualQuaternion.from_screw(screw.axis, screw.point, screw.angle, screw.translation)
    assert polar.distance(DualQuaternion.from_displacement(A, t)) < 1e-14
    # and the same screw with the axis line's point moved along it is the same displacement
    moved = DualQuaternion.from_screw(screw.axis, screw.point + 0.4 * screw.axis, screw.angle, screw.translation)
    assert moved.distance(polar) < 1e-14


@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_dh_in_dual_form_is_the_dh_transform(seed):
    theta, d, a, alpha = parameters(seed)
    T = dh_transform(theta, d, a, alpha)
    np.testing.assert_allclose(dh_dual_quaternion(theta, d, a, alpha).matrix(), T, atol=1e-14)
    matrix = dh_dual_matrix(theta, d, a, alpha)  # Yang and Freudenstein's dual angles in the rotation block
    expected = dual_matrix(T[:3, :3], T[:3, 3])
    np.testing.assert_allclose(matrix.real, expected.real, atol=1e-15)
    np.testing.assert_allclose(matrix.dual, expected.dual, atol=1e-14)


@pytest.mark.parametrize("seed", RNG_SEEDS)
def test_the_dual_matrix_moves_lines(seed):
    A, t = displacement_of(seed)
    rng = np.random.default_rng(200 + seed)
    u, rho = rng.standard_normal(3), rng.standard_normal(3)
    moved = dual_matrix(A, t) @ line(u, rho)
    expected = line(A @ u, A @ rho + t)  # the displaced line: direction A u, through the displaced point
    np.testing.assert_allclose(moved.real, expected.real, atol=1e-14)
    np.testing.assert_allclose(moved.dual, expected.dual, atol=1e-14)


# -- the slider-crank's loop closure -------------------------------------------------------------------------------
@cache
def slider_crank_positions():
    """(crank angle, rod angle, slider x) at 41 positions of a full turn, from the solver's kinematic analysis."""
    model = load_model(REPO / "course" / "models" / "slider_crank.yaml")
    system, q0, _ = build_system(model)
    result = kinematic_analysis(system, q0, model.simulation["end_time"], 40)
    return result.coordinate("crank.phi"), result.coordinate("rod.phi"), result.coordinate("slider.x")


def dh_table(theta: float, phi: float, x: float, crank: float = 0.1, rod: float = 0.3) -> list[tuple]:
    """(theta_i, d_i, a_i, alpha_i) of the loop O, A, B (revolute about z), S (prismatic along the global x):
    frame 0 at O with x_0 = -y (the common normal of the slider's line and O's axis), frames 1 and 2 along the
    crank and the rod, frame 3 at B with z_3 along the slider line and x_3 = +y; the slide back to O is -x."""
    return [
        (theta + math.pi / 2, 0.0, crank, 0.0),
        (phi - theta, 0.0, rod, 0.0),
        (math.pi / 2 - phi, 0.0, 0.0, math.pi / 2),
        (math.pi, -x, 0.0, math.pi / 2),
    ]


def closure_errors(theta: float, phi: float, x: float) -> tuple[float, float, float]:
    """|T_1 ... T_4 - I| (eq. 8.23), the dual quaternions' product against +-1 (eq. 8.30), the dual matrices'
    product against I + eps 0 (eq. 8.31)."""
    table = dh_table(theta, phi, x)
    matrix = loop_closure_error(dh_transform(*row) for row in table)
    product = ONE
    for row in table:
        product = product * dh_dual_quaternion(*row)
    dual = Dual(np.eye(3), np.zeros((3, 3)))
    for row in table:
        dual = dual @ dh_dual_matrix(*row)
    return matrix, product.distance(ONE), max(np.max(np.abs(dual.real - np.eye(3))), np.max(np.abs(dual.dual)))


def test_the_slider_cranks_dh_loop_closes_where_the_solver_puts_it():
    worst = np.zeros(3)
    for theta, phi, x in zip(*slider_crank_positions(), strict=True):
        worst = np.maximum(worst, closure_errors(theta, phi, x))
    assert np.all(worst < 1e-10), worst


def test_the_slider_cranks_dh_loop_does_not_close_off_the_solvers_positions():
    theta, phi, x = (values[7] for values in slider_crank_positions())
    for wrong in ((theta, phi, x + 1e-3), (theta, phi + 1e-3, x), (theta + 1e-3, phi, x)):
        assert min(closure_errors(*wrong)) > 1e-5, wrong
    origin = chain(dh_transform(*row) for row in dh_table(theta, phi, x + 1e-3))[:3, 3]
    # the slide back overshoots O by the 1 mm put in, along the global -x, which is frame 0's -y_0 (x_0 = -y)
    np.testing.assert_allclose(origin, [0.0, -1e-3, 0.0], atol=1e-12)
