"""The implicit index-3 integrators (generalized-alpha, HHT) against minimal-coordinate references.

- a stiff scene: a pendulum whose bob slides along it on a spring of k = 1e8 N/m. Its radial mode has
  omega = sqrt(k/m) = 1e4 rad/s, so an explicit method needs h < 2.8/omega = 2.8e-4 s (RK4); the
  implicit methods run at h = 1e-2 s and follow the slow swing, checked against Lagrange's equations
  in (theta, r) integrated by scipy's Radau at rtol = 1e-10. RK4 at that step blows up.
- a smooth scene: the double pendulum at fixed steps h, h/2, h/4: the error at t = 1 s against
  Lagrange's equations in the joint angles (DOP853 at rtol = 1e-12) falls as h^2.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError
from solutions.dynamics import forward_dynamics
from solutions.implicit import alpha_parameters
from solutions.io.model import load_model

G = 9.81


def e(theta):
    """Unit vector at angle theta from hanging straight down: (sin, -cos)."""
    return np.array([math.sin(theta), -math.cos(theta)])


# -- stiff scene ----------------------------------------------------------------------------------------
K, L0 = 1e8, 0.8  # spring of the sliding bob
M1, LINK, M2, J2 = 1.0, 1.0, 1.0, 1e-3
THETA0 = math.radians(60.0)
R0 = L0 + M2 * G * math.cos(THETA0) / K  # the bob starts at its static stretch: the fast mode is not excited


def stiff_pendulum_model() -> dict:
    """Link pinned at O = (0, 0); bob on a prismatic joint along the link; TSDA from O to the bob."""
    axis = e(THETA0)
    return {
        "model": {
            "name": "stiff-pendulum",
            "gravity": [0.0, -G],
            "bodies": [
                {"name": "link", "mass": M1, "inertia": M1 * LINK**2 / 12, "location": list(LINK / 2 * axis),
                 "orientation": THETA0 - math.pi / 2},
                {"name": "bob", "mass": M2, "inertia": J2, "location": list(R0 * axis),
                 "orientation": THETA0 - math.pi / 2},
            ],
            "joints": [
                {"name": "O", "type": "revolute", "body1": "ground", "body2": "link", "location": [0.0, 0.0]},
                {"name": "P", "type": "prismatic", "body1": "link", "body2": "bob", "location": list(R0 * axis),
                 "axis": list(axis)},
            ],
            "spring_dampers": [
                {"name": "k", "type": "TSDA", "body1": "link", "body2": "bob", "point1": [0.0, 0.0],
                 "point2": list(R0 * axis), "spring_coefficient": K, "free_length": L0},
            ],
        }
    }  # fmt: skip


def stiff_pendulum_reference(times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """theta(t), r(t) from Lagrange's equations with T = 1/2 (I_O + J2 + m2 r^2) theta'^2 + 1/2 m2 r'^2,
    V = -(m1 g l/2 + m2 g r) cos(theta) + 1/2 k (r - l0)^2, I_O = m1 l^2 / 3:

        (I_O + J2 + m2 r^2) theta'' + 2 m2 r r' theta' + (m1 g l/2 + m2 g r) sin(theta) = 0
        m2 r'' - m2 r theta'^2 - m2 g cos(theta) + k (r - l0) = 0
    """
    inertia = M1 * LINK**2 / 3 + J2

    def f(t, y):
        theta, r, w, v = y
        wd = -(2 * M2 * r * v * w + (M1 * G * LINK / 2 + M2 * G * r) * math.sin(theta)) / (inertia + M2 * r * r)
        vd = r * w * w + G * math.cos(theta) - K / M2 * (r - L0)
        return [w, v, wd, vd]

    solution = solve_ivp(f, (0.0, times[-1]), [THETA0, R0, 0.0, 0.0], method="Radau", t_eval=times, rtol=1e-10,
                         atol=[1e-12, 1e-14, 1e-10, 1e-10])  # fmt: skip
    assert solution.success
    return solution.y[0], solution.y[1]


def pendulum_coordinates(result) -> tuple[np.ndarray, np.ndarray]:
    """theta of the link and distance r of the bob from O, from body coordinates."""
    theta = result.q[:, 2] + math.pi / 2
    r = np.hypot(result.q[:, 3], result.q[:, 4])
    return theta, r


@pytest.fixture(scope="module")
def stiff():
    system, q0, qd0 = build_system(load_model(stiff_pendulum_model()))
    times = np.linspace(0.0, 2.0, 21)
    return system, q0, qd0, times, stiff_pendulum_reference(times)


@pytest.mark.parametrize("method", ["generalized-alpha", "hht"])
def test_stiff_spring_with_steps_far_beyond_the_explicit_limit(stiff, method):
    system, q0, qd0, times, (theta_ref, r_ref) = stiff
    step = 1e-2
    explicit_limit = 2.785 / math.sqrt(K / M2)  # RK4's stability bound on the imaginary axis
    assert step > 30 * explicit_limit
    result = forward_dynamics(system, q0, qd0, times[-1], times.size - 1, integrator=method, step=step)
    theta, r = pendulum_coordinates(result)
    assert np.ptp(theta_ref) > 2.0  # a real swing, from +60 to -60 degrees
    np.testing.assert_allclose(theta, theta_ref, rtol=0, atol=3e-3)  # second order at h = 1e-2: ~1.4e-3 rad
    np.testing.assert_allclose(r, r_ref, rtol=0, atol=5e-9)  # the spring stretches by ~1e-7 m: resolved
    assert result.info["integrator_steps"] == 200
    assert result.info["max_constraint_residual"] < 1e-10


def test_explicit_rk4_fails_at_that_step(stiff):
    """The control experiment: RK4 follows the scene below its stability limit and blows up at h = 1e-2."""
    system, q0, qd0, times, (theta_ref, _) = stiff
    below = forward_dynamics(system, q0, qd0, 0.1, 1, integrator="rk4", step=1e-4)
    np.testing.assert_allclose(pendulum_coordinates(below)[0], theta_ref[:2], rtol=0, atol=1e-6)
    with np.errstate(all="ignore"):
        try:
            result = forward_dynamics(system, q0, qd0, 0.2, 2, integrator="rk4", step=1e-2)
        except (AnalysisError, np.linalg.LinAlgError, ValueError, FloatingPointError):
            return
    theta, _ = pendulum_coordinates(result)
    assert not np.all(np.isfinite(theta)) or np.max(np.abs(theta - theta_ref[:3])) > 1.0


def test_stiff_spring_with_step_control(stiff):
    """With error control the step is not limited by the fast mode either: under 2000 steps for 2 s
    (an explicit method needs over 7000) at about 1e-4 rad."""
    system, q0, qd0, times, (theta_ref, r_ref) = stiff
    result = forward_dynamics(system, q0, qd0, times[-1], times.size - 1, integrator="hht", rtol=1e-7, atol=1e-7)
    theta, r = pendulum_coordinates(result)
    np.testing.assert_allclose(theta, theta_ref, rtol=0, atol=5e-4)
    np.testing.assert_allclose(r, r_ref, rtol=0, atol=5e-8)
    assert result.info["integrator_steps"] < 2000


# -- convergence order on a smooth scene ------------------------------------------------------------------
L1, L2, MA, MB = 1.0, 0.8, 1.0, 0.7
TH1, TH2 = math.radians(90.0), math.radians(30.0)


def double_pendulum_model() -> dict:
    a1, a2 = L1 / 2, L2 / 2
    elbow = L1 * e(TH1)
    return {
        "model": {
            "name": "double-pendulum",
            "gravity": [0.0, -G],
            "bodies": [
                {"name": "upper", "mass": MA, "inertia": MA * L1**2 / 12, "location": list(a1 * e(TH1)),
                 "orientation": TH1 - math.pi / 2},
                {"name": "lower", "mass": MB, "inertia": MB * L2**2 / 12, "location": list(elbow + a2 * e(TH2)),
                 "orientation": TH2 - math.pi / 2},
            ],
            "joints": [
                {"name": "O", "type": "revolute", "body1": "ground", "body2": "upper", "location": [0.0, 0.0]},
                {"name": "E", "type": "revolute", "body1": "upper", "body2": "lower", "location": list(elbow)},
            ],
        }
    }  # fmt: skip


def double_pendulum_reference(t_end: float) -> np.ndarray:
    """(theta1, theta2) at t_end from Lagrange's equations of two uniform rods (a = l/2, I = m l^2/12):

    M11 = m1 a1^2 + I1 + m2 l1^2, M12 = m2 l1 a2 cos(t1 - t2), M22 = m2 a2^2 + I2
    M11 t1'' + M12 t2'' + m2 l1 a2 sin(t1 - t2) t2'^2 + (m1 a1 + m2 l1) g sin(t1) = 0
    M12 t1'' + M22 t2'' - m2 l1 a2 sin(t1 - t2) t1'^2 + m2 a2 g sin(t2) = 0
    """
    a1, a2 = L1 / 2, L2 / 2
    m11 = MA * a1**2 + MA * L1**2 / 12 + MB * L1**2
    m22 = MB * a2**2 + MB * L2**2 / 12

    def f(t, y):
        t1, t2, w1, w2 = y
        m12 = MB * L1 * a2 * math.cos(t1 - t2)
        s = MB * L1 * a2 * math.sin(t1 - t2)
        rhs = [-s * w2 * w2 - (MA * a1 + MB * L1) * G * math.sin(t1), s * w1 * w1 - MB * a2 * G * math.sin(t2)]
        acc = np.linalg.solve([[m11, m12], [m12, m22]], rhs)
        return [w1, w2, acc[0], acc[1]]

    solution = solve_ivp(f, (0.0, t_end), [TH1, TH2, 0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-12)
    return solution.y[:2, -1]


@pytest.mark.parametrize("method", ["generalized-alpha", "hht"])
def test_second_order_convergence(method):
    system, q0, qd0 = build_system(load_model(double_pendulum_model()))
    reference = double_pendulum_reference(1.0)
    errors = []
    for step in (0.01, 0.005, 0.0025):
        result = forward_dynamics(system, q0, qd0, 1.0, 1, integrator=method, step=step, rtol=1e-10, atol=1e-12)
        angles = np.array([result.q[-1, 2], result.q[-1, 5]]) + math.pi / 2
        errors.append(float(np.max(np.abs(angles - reference))))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[-1] < 1e-3
    assert np.all((orders > 1.8) & (orders < 2.3)), (errors, orders)


def test_parameters_and_errors():
    """Chung-Hulbert's parameters for rho_inf = 1 (the trapezoidal rule) and 0.5; bad values by name."""
    p = alpha_parameters("generalized-alpha", 1.0)
    assert (p.alpha_m, p.alpha_f, p.gamma, p.beta) == pytest.approx((0.5, 0.5, 0.5, 0.25))
    p = alpha_parameters("generalized-alpha", 0.5)
    assert (p.alpha_m, p.alpha_f) == pytest.approx((0.0, 1.0 / 3.0))
    p = alpha_parameters("hht", 0.5)  # HHT's alpha = -1/3, the most damping it allows
    assert (p.alpha_m, p.alpha_f, p.gamma, p.beta) == pytest.approx((0.0, 1 / 3, 5 / 6, 4 / 9))
    with pytest.raises(AnalysisError, match="rho_inf"):
        alpha_parameters("hht", 0.2)
    with pytest.raises(AnalysisError, match="implicit method"):
        alpha_parameters("newmark", 0.9)


def test_the_evaluation_budget_stops_an_index3_run_by_name():
    """``max_evaluations`` bounds the index-3 runs as it bounds the ODE integrators (a run whose step control shrinks
    its step without end meets it instead of crawling): the double pendulum at 1e-10 needs thousands of evaluations
    of Q; a budget of 300 stops it with the ODE integrators' message."""
    system, q0, qd0 = build_system(load_model(double_pendulum_model()))
    with pytest.raises(AnalysisError, match=r"integrator hht spent its budget of 300 right-hand-side evaluations by t"):
        forward_dynamics(system, q0, qd0, 1.0, 10, integrator="hht", rtol=1e-10, atol=1e-10, max_evaluations=300)
    result = forward_dynamics(system, q0, qd0, 0.05, 2, integrator="hht", max_evaluations=300)  # within it: runs
    assert 0 < result.info["rhs_evaluations"] <= 300


@pytest.mark.parametrize("method", ["hht", "generalized-alpha"])
def test_undamped_rho_inf_runs_with_fixed_steps_only(method):
    """rho_inf = 1 with step control is refused by name (its algebraic modes grow at every change of step: the
    step shrank from 6e-4 to 7e-7 s in 0.03 s before); with a fixed step it runs, within 1e-5 m of a Baumgarte run
    at rtol 1e-10."""
    system, q0, qd0 = build_system(load_model(double_pendulum_model()))
    with pytest.raises(AnalysisError, match=r"rho_inf = 1 \(no numerical damping\) cannot run with step control"):
        forward_dynamics(system, q0, qd0, 0.1, 2, integrator=method, rho_inf=1.0)
    fixed = forward_dynamics(system, q0, qd0, 0.1, 2, integrator=method, rho_inf=1.0, step=1e-3)
    reference = forward_dynamics(system, q0, qd0, 0.1, 2, "baumgarte", "dop853", rtol=1e-10, atol=1e-10)
    assert np.max(np.abs(fixed.q - reference.q)) < 1e-5
