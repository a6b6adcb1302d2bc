"""Forward dynamics runs against independent references.

- Simple (physical) pendulum at 115 degrees amplitude: after one exact period T = 4 K(sin(theta0/2)) / omega0
  (complete elliptic integral, scipy.special.ellipk) it is back where it started, at rest.
- Double pendulum: Lagrange's equations in the link angles (tests/solutions/test_formulations.py),
  integrated by solve_ivp at rtol = atol = 1e-12; every formulation within 1e-8 at t = 2 s (issue 3).
- Classical RK4: the error falls 16-fold when the step is halved (fourth order).
- Mass-spring-damper built from a TSDA, torsional oscillator from an RSDA: closed-form responses.
- Hanging pendulum: the joint holds it with m g; at the bottom of a swing with m (g + c w^2).
- Quarter car: the file's configuration is its static equilibrium (free lengths derived by hand in the
  file), and after the road's 5 cm curb it settles 5 cm higher.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import ellipk

from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError
from solutions.dynamics import consistent_initial_conditions, forward_dynamics
from solutions.formulations import FORMULATIONS
from solutions.io.model import load_model
from solutions.mass_matrix import mass_matrix

from .test_formulations import DoublePendulum

REPO = Path(__file__).resolve().parents[2]
MODELS = REPO / "course" / "models"
G = 9.81


def pendulum(phi0: float, omega0: float = 0.0, mass: float = 1.0, length: float = 1.0) -> dict:
    """A uniform rod pinned at one end at the origin, at angle phi0 from the x axis, turning at omega0."""
    c = length / 2
    e, n = np.array([math.cos(phi0), math.sin(phi0)]), np.array([-math.sin(phi0), math.cos(phi0)])
    rod = {
        "name": "rod",
        "mass": mass,
        "inertia": mass * length**2 / 12,
        "location": (c * e).tolist(),
        "orientation": phi0,
        "velocity": (c * omega0 * n).tolist(),
        "angular_velocity": omega0,
    }
    joint = {"name": "O", "type": "revolute", "body1": "ground", "body2": "rod", "location": [0.0, 0.0]}
    return {"model": {"name": "pendulum", "gravity": [0.0, -G], "bodies": [rod], "joints": [joint]}}


# -- simple pendulum: exact period ----------------------------------------------------------------------------
AMPLITUDE = 2.0  # rad from the hanging position


def exact_period(amplitude: float) -> float:
    """T = 4 K(k) / omega0, k = sin(amplitude / 2), omega0^2 = m g c / (J + m c^2) for the rod (c = 1/2, J = 1/12)."""
    omega0 = math.sqrt(G * 0.5 / (1.0 / 12.0 + 0.25))
    return 4.0 * ellipk(math.sin(amplitude / 2) ** 2) / omega0  # scipy's ellipk takes m = k^2


CASES = [(name, "DOP853", {}) for name in FORMULATIONS] + [
    ("partitioning", "DOP853", {"independent": ["rod.y"]}),  # a partition that turns singular at the bottom
    ("baumgarte", "rk4", {"step": 1e-3}),
]


@pytest.mark.parametrize(("formulation", "integrator", "options"), CASES)
def test_simple_pendulum_returns_after_one_exact_period(formulation, integrator, options):
    phi0 = -math.pi / 2 + AMPLITUDE
    system, q0, qd0 = build_system(load_model(pendulum(phi0)))
    period = exact_period(AMPLITUDE)
    tol = 1e-7 if integrator == "rk4" else 1e-11
    result = forward_dynamics(
        system, q0, qd0, period, 4, formulation=formulation, integrator=integrator, rtol=tol, atol=tol, **options
    )
    # a quarter period: hanging, all the potential energy turned into kinetic (drop of c (1 - cos(amplitude)))
    w_bottom = math.sqrt(2 * G * 0.5 * (1 - math.cos(AMPLITUDE)) / (1 / 12 + 0.25))
    assert result.coordinate("rod.phi")[1] == pytest.approx(-math.pi / 2, abs=1e-7)
    assert result.coordinate("rod.phi", 1)[1] == pytest.approx(-w_bottom, rel=1e-7)
    # after one period: back at phi0, at rest; an error dT in the period would leave phi' = phi''(T) dT. The
    # augmented Lagrangian's accelerations carry the rounding of M + alpha Psi_q^T Psi_q (condition ~ its penalty,
    # 1e7: ~2e-9 relative, AugmentedLagrangian.held_rtol): over a period 1.2e-8 rad on one machine, 4e-9 on another
    floor = 5e-8 if formulation == "augmented-lagrangian" else 1e-8
    assert result.coordinate("rod.phi")[-1] == pytest.approx(phi0, abs=floor)
    assert abs(result.coordinate("rod.phi", 1)[-1]) < 1e-7
    if "independent" in options:  # it had to leave the partition it was given on the way down
        assert result.info["repartitions"] >= 1
        assert result.info["partitions"][1][1] != ["rod.y"]


# -- double pendulum against Lagrange's equations ----------------------------------------------------------------
@pytest.fixture(scope="module")
def lagrange_reference():
    """q at t = 2 s of course/models/double_pendulum.yaml from Lagrange's equations, rtol = atol = 1e-12."""
    dp = DoublePendulum()
    phi0 = [-math.pi / 6, 0.0]  # upper rod 60 degrees from hanging, lower rod horizontal, at rest
    solution = solve_ivp(dp.rhs, (0.0, 2.0), [*phi0, 0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-12)
    phi, w = solution.y[:2, -1], solution.y[2:, -1]
    q, qd, _ = dp.body_state(phi, w, dp.angular_accelerations(phi, w))
    return q, qd


@pytest.fixture(scope="module")
def double_pendulum():
    return build_system(load_model(MODELS / "double_pendulum.yaml"))


@pytest.mark.parametrize("formulation", list(FORMULATIONS))
def test_double_pendulum_matches_lagrange_to_1e_8_at_2_s(double_pendulum, lagrange_reference, formulation):
    system, q0, qd0 = double_pendulum
    result = forward_dynamics(
        system, q0, qd0, 2.0, 2, formulation=formulation, integrator="DOP853", rtol=1e-12, atol=1e-12
    )
    q_ref, qd_ref = lagrange_reference
    assert np.abs(result.q[-1] - q_ref).max() < 1e-8
    assert np.abs(result.qd[-1] - qd_ref).max() < 1e-7


@pytest.mark.parametrize("integrator", ["RK45", "Radau", "BDF", "LSODA"])
def test_other_integrators_at_their_tolerance(double_pendulum, lagrange_reference, integrator):
    system, q0, qd0 = double_pendulum
    result = forward_dynamics(system, q0, qd0, 2.0, 2, integrator=integrator, rtol=1e-9, atol=1e-9)
    assert np.abs(result.q[-1] - lagrange_reference[0]).max() < 1e-5
    assert result.info["rhs_evaluations"] > 0


def test_rk4_is_fourth_order(double_pendulum, lagrange_reference):
    system, q0, qd0 = double_pendulum
    errors = []
    for h in (0.01, 0.005):
        result = forward_dynamics(system, q0, qd0, 2.0, 1, formulation="qr", integrator="rk4", step=h)
        errors.append(np.abs(result.q[-1] - lagrange_reference[0]).max())
        assert result.info["rhs_evaluations"] == 4 * round(2.0 / h)
    assert 16 / 1.3 < errors[0] / errors[1] < 16 * 1.3


# -- closed-form oscillators built from a TSDA and an RSDA ------------------------------------------------------
def test_mass_spring_damper_with_actuator():
    """A 2 kg block on a horizontal prismatic joint, TSDA to the wall at x = 0 (k = 50, c = 2, l0 = 1) with
    a constant actuator tension 10 N: m x'' = -k (x - l0) - c x' - F, from x0 = 1.3 at rest. Closed form:
    x = x_eq + e^(-zeta w t) (A cos(wd t) + B sin(wd t)), x_eq = l0 - F / k."""
    m, k, c, F, l0, x0 = 2.0, 50.0, 2.0, 10.0, 1.0, 1.3
    model = {
        "model": {
            "name": "msd",
            "gravity": [0.0, -G],
            "bodies": [{"name": "block", "mass": m, "inertia": 0.1, "location": [x0, 0.0]}],
            "joints": [
                {
                    "name": "rail",
                    "type": "prismatic",
                    "body1": "ground",
                    "body2": "block",
                    "location": [x0, 0.0],
                    "axis": [1.0, 0.0],
                }
            ],
            "spring_dampers": [
                {
                    "name": "spring",
                    "type": "TSDA",
                    "body1": "ground",
                    "body2": "block",
                    "point1": [0.0, 0.0],
                    "point2": [x0, 0.0],
                    "spring_coefficient": k,
                    "damping_coefficient": c,
                    "free_length": l0,
                    "actuator": F,
                }
            ],
        }
    }
    system, q0, qd0 = build_system(load_model(model))
    result = forward_dynamics(system, q0, qd0, 2.0, 20, integrator="DOP853", rtol=1e-11, atol=1e-12)
    w = math.sqrt(k / m)
    zeta = c / (2 * math.sqrt(k * m))
    wd = w * math.sqrt(1 - zeta**2)
    x_eq = l0 - F / k
    A = x0 - x_eq
    B = zeta * w * A / wd
    t = result.t
    x = x_eq + np.exp(-zeta * w * t) * (A * np.cos(wd * t) + B * np.sin(wd * t))
    np.testing.assert_allclose(result.coordinate("block.x"), x, atol=1e-9)
    np.testing.assert_allclose(result.coordinate("block.y"), 0.0, atol=1e-12)


def test_torsional_oscillator_from_an_rsda():
    """A disc on a revolute joint at its centre, RSDA to ground (k = 8, c = 0.4), J = 0.5, from 0.3 rad at
    rest, no gravity: J theta'' = -k theta - c theta' (underdamped closed form)."""
    J, k, c, theta0 = 0.5, 8.0, 0.4, 0.3
    model = {
        "model": {
            "name": "torsion",
            "bodies": [{"name": "disc", "mass": 1.0, "inertia": J, "location": [0.0, 0.0], "orientation": theta0}],
            "joints": [
                {"name": "axle", "type": "revolute", "body1": "ground", "body2": "disc", "location": [0.0, 0.0]}
            ],
            "spring_dampers": [
                {
                    "name": "torsion",
                    "type": "RSDA",
                    "body1": "ground",
                    "body2": "disc",
                    "spring_coefficient": k,
                    "damping_coefficient": c,
                    "free_angle": 0.0,
                }
            ],
        }
    }
    system, q0, qd0 = build_system(load_model(model))
    result = forward_dynamics(system, q0, qd0, 3.0, 30, integrator="DOP853", rtol=1e-11, atol=1e-12)
    w, zeta = math.sqrt(k / J), c / (2 * math.sqrt(k * J))
    wd = w * math.sqrt(1 - zeta**2)
    t = result.t
    theta = theta0 * np.exp(-zeta * w * t) * (np.cos(wd * t) + zeta * w / wd * np.sin(wd * t))
    np.testing.assert_allclose(result.coordinate("disc.phi"), theta, atol=1e-9)


# -- reactions from the multipliers --------------------------------------------------------------------------
def joint_force_on_rod(result, system, k: int) -> np.ndarray:
    """-Psi_q^T lambda on the rod's x, y columns at output k: the force the joint O puts on the rod."""
    return -(system.jacobian(result.q[k], result.t[k]).T @ result.lam[k])[:2]


@pytest.mark.parametrize("formulation", list(FORMULATIONS))
def test_hanging_pendulum_is_held_by_m_g(formulation):
    mass = 2.5
    system, q0, qd0 = build_system(load_model(pendulum(-math.pi / 2, mass=mass)))
    result = forward_dynamics(system, q0, qd0, 1.0, 4, formulation=formulation)
    for k in range(result.t.size):
        np.testing.assert_allclose(joint_force_on_rod(result, system, k), [0.0, mass * G], atol=1e-9)
    np.testing.assert_allclose(result.q, np.tile(q0, (5, 1)), atol=1e-12)


def test_pendulum_swinging_through_the_bottom_is_held_by_m_g_plus_m_c_w2():
    """At the bottom phi'' = 0, so the centre of mass accelerates only centripetally: F - m g = m c w^2."""
    mass, omega = 1.5, 3.0
    system, q0, qd0 = build_system(load_model(pendulum(-math.pi / 2, omega, mass=mass)))
    result = forward_dynamics(system, q0, qd0, 0.0001, 1, integrator="DOP853", rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(joint_force_on_rod(result, system, 0), [0.0, mass * (G + 0.5 * omega**2)], atol=1e-9)


# -- consistent initial conditions ---------------------------------------------------------------------------
def test_inconsistent_initial_state_is_corrected_and_reported():
    """The file's rod is 1 cm off its pin (given in the body frame) and its velocity breaks the pin: assembly
    moves it back, the velocity is projected onto Psi_q q' = 0 with the correction M-orthogonal to the allowed
    motions."""
    spec = pendulum(-1.0, 2.0)
    spec["model"]["bodies"][0]["location"][0] += 0.01
    spec["model"]["joints"][0].update(frame="body", point1=[0.0, 0.0], point2=[-0.5, 0.0])
    del spec["model"]["joints"][0]["location"]
    spec["model"]["bodies"][0]["velocity"] = [0.3, -0.2]
    model = load_model(spec)
    system, q0, qd0 = build_system(model)
    M = mass_matrix(model)
    q, qd, report = consistent_initial_conditions(system, M, q0, qd0)
    jac = system.jacobian(q, 0.0)
    assert np.abs(system.constraints(q, 0.0)).max() < 1e-12
    assert np.abs(jac @ qd).max() < 1e-13
    # allowed motions at q: rotation about the pin, dq = (-y, x, 1); the correction has no M-component along it
    allowed = np.array([-q[1], q[0], 1.0])
    assert abs(allowed @ M @ (qd - qd0)) < 1e-12
    assert report["assembly"]["moved"]["rod"]["translation"] > 1e-3
    assert report["velocity_correction"] > 0.1
    assert report["velocity_residual"] < 1e-13
    # a consistent state is left alone
    q2, qd2, report2 = consistent_initial_conditions(system, M, q, qd)
    assert np.abs(qd2 - qd).max() < 1e-14 and report2["velocity_correction"] < 1e-14


# -- example models -------------------------------------------------------------------------------------------
def test_quarter_car_rests_in_its_static_equilibrium_then_settles_5_cm_higher():
    system, q0, qd0 = build_system(load_model(MODELS / "quarter_car.yaml"))
    result = forward_dynamics(system, q0, qd0, 3.0, 30, rtol=1e-8, atol=1e-10)
    before = result.t < 0.2  # the curb starts at t = 0.2 s
    np.testing.assert_allclose(result.q[before], np.tile(q0, (before.sum(), 1)), atol=1e-9)
    lift = np.tile([0.0, 0.05, 0.0], 4)  # every body 5 cm up, springs at their static lengths again
    np.testing.assert_allclose(result.q[-1], q0 + lift, atol=2e-4)


@pytest.mark.parametrize(
    "name", ["simple_pendulum", "double_pendulum", "slider_crank_flywheel", "four_bar_spring", "quarter_car"]
)
def test_example_models_run_with_their_settings(name):
    model = load_model(MODELS / f"{name}.yaml")
    system, q0, qd0 = build_system(model)
    sim = model.simulation
    options = {k: sim[k] for k in ("formulation", "integrator", "rtol", "atol") if k in sim}
    result = forward_dynamics(system, q0, qd0, 0.2, 10, **options)
    assert result.info["analysis"] == "dynamic"
    assert result.lam.shape == (11, system.n_constraints)
    assert result.info["max_constraint_residual"] < 1e-6
    for column in ("residual.position", "residual.velocity", "energy.kinetic", "energy.error"):
        assert result.points[column].shape == (11,)


def test_bad_integrator_choices_are_refused_by_name(double_pendulum):
    system, q0, qd0 = double_pendulum
    with pytest.raises(AnalysisError, match="unknown integrator 'RK54'"):
        forward_dynamics(system, q0, qd0, 1.0, 10, integrator="RK54")
    with pytest.raises(AnalysisError, match="projection.*LSODA"):
        forward_dynamics(system, q0, qd0, 1.0, 10, formulation="projection", integrator="LSODA")


def test_a_drifting_run_says_so_and_a_stabilized_one_does_not(capsys):
    """An unstabilized formulation at a loose tolerance leaves the constraints (eq. 5.44): the result warns,
    naming the residual and the remedy, and ``mbd run`` prints it; a stabilized run carries no warning."""
    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    drifting = forward_dynamics(system, q0, qd0, 5.0, 50, "qr", "dop853", rtol=1e-5, atol=1e-5)
    assert drifting.info["max_constraint_residual"] > 1e-5
    (warning,) = [w for w in drifting.info["warnings"] if w.startswith("constraint drift")]
    assert "constraint drift" in warning and "qr without stabilization" in warning and "projection" in warning
    stabilized = forward_dynamics(system, q0, qd0, 5.0, 50, "baumgarte", "dop853", rtol=1e-8, atol=1e-8)
    assert stabilized.info["warnings"] == [] and stabilized.info["max_constraint_residual"] < 1e-6
    from solutions.cli import main

    argv = ["run", str(MODELS / "double_pendulum.yaml"), "--analysis", "dynamic", "--t-end", "5", "--steps", "50"]
    assert main([*argv, "--formulation", "qr", "--integrator", "dop853", "--rtol", "1e-5", "--atol", "1e-5"]) == 0
    assert "warning: constraint drift" in capsys.readouterr().out
    assert main(argv) == 0
    assert "warning" not in capsys.readouterr().out


def test_augmented_lagrangian_raises_a_tolerance_it_cannot_hold(double_pendulum):
    """The penalty formulation's accelerations carry rounding errors of about its penalty times eps: asked for
    rtol 1e-13 it runs at its held_rtol and says so, instead of spending its evaluations on ever smaller steps."""
    system, q0, qd0 = double_pendulum
    result = forward_dynamics(
        system, q0, qd0, 1.0, 2, formulation="augmented-lagrangian", integrator="DOP853", rtol=1e-13, atol=1e-13
    )
    assert result.info["rtol"] == pytest.approx(1e-11)
    assert any("raised to 1e-11, 1e-11" in w for w in result.info["warnings"]), result.info["warnings"]
    assert result.info["rhs_evaluations"] < 5000


def test_null_space_bases_are_orthonormal_bases_of_each_jacobians_null_space():
    """The batched guard's null spaces (``guard.null_space_bases``, from a QR of Psi_q^T): n - m
    orthonormal columns that Psi_q maps to zero, for each matrix of a stack, as the SVD's last columns of V."""
    from solutions.guard import null_space_bases

    rng = np.random.default_rng(7)
    stack = rng.standard_normal((5, 3, 7))
    bases = null_space_bases(stack)
    assert bases.shape == (5, 7, 4)
    for jacobian, basis in zip(stack, bases, strict=True):
        assert np.allclose(jacobian @ basis, 0.0, atol=1e-12)
        assert np.allclose(basis.T @ basis, np.eye(4), atol=1e-12)
        v = np.linalg.svd(jacobian)[2][3:].T  # the SVD's basis of the same space: T^T V is orthogonal
        assert np.allclose(np.abs(np.linalg.det(basis.T @ v)), 1.0, atol=1e-12)


@pytest.mark.parametrize("shape", [(6, 3, 7), (4, 1, 3), (3, 26, 27), (2, 5, 5)])
def test_null_space_bases_are_the_complete_qrs_last_columns(shape):
    """The reflectors applied to the identity's last columns (``null_space_bases``) give the columns of Q that
    numpy's complete QR forms (LAPACK's dorgqr), to rounding: the same basis, not only the same space."""
    from solutions.guard import null_space_bases

    stack = np.random.default_rng(11).standard_normal(shape)
    q_full, _ = np.linalg.qr(np.swapaxes(stack, 1, 2), mode="complete")
    bases = null_space_bases(stack)
    assert bases.shape == (shape[0], shape[2], shape[2] - shape[1])
    assert np.allclose(bases, q_full[:, :, shape[1] :], rtol=0.0, atol=1e-13)


@pytest.mark.parametrize("shape", [(40, 3, 7), (40, 1, 3), (10, 26, 27), (40, 5, 5)])
def test_null_space_signs_are_the_determinants_of_the_bordered_matrices(shape):
    """``null_space_bases(..., signs=True)``: the sign of det [Psi_q; T^T] read off the QR (det R_1 times the
    reflectors' -1 each) is numpy's determinant's sign, both signs occurring."""
    from solutions.guard import null_space_bases

    stack = np.random.default_rng(13).standard_normal(shape)
    bases, signs = null_space_bases(stack, signs=True)
    expected = np.sign(np.linalg.det(np.concatenate([stack, np.swapaxes(bases, 1, 2)], axis=1)))
    assert np.array_equal(signs, expected)
    assert np.array_equal(bases, null_space_bases(stack))
    if shape[0] >= 40:
        assert set(signs) == {-1.0, 1.0}


def test_progress_is_told_every_output_time_in_order():
    """``progress(t)`` (what ``mbd serve`` shows of a run): each output time once, in order, up to t_end; the same
    from ``run_analysis`` for a kinematic model."""
    from solutions.analysis import run_analysis
    from solutions.kinematics import kinematic_analysis
    from solutions.settings import Settings

    system, q0, qd0 = build_system(load_model("course/models/double_pendulum.yaml"))
    told: list[float] = []
    result = forward_dynamics(system, q0, qd0, 0.5, 20, integrator="DOP853", engine="numpy", progress=told.append)
    assert told == list(result.t) and told[-1] == 0.5
    crank, q0, qd0 = build_system(load_model("course/models/slider_crank.yaml"))
    kinematic: list[float] = []
    result = kinematic_analysis(crank, q0, 0.3, 6, progress=kinematic.append)
    assert kinematic == list(result.t)
    through: list[float] = []
    run_analysis(crank, q0, qd0, Settings(analysis="kinematic", t_end=0.3, steps=6), progress=through.append)
    assert through == kinematic


def test_the_drift_stop_names_its_own_limit_and_the_remedy_of_the_method():
    """The Guard's drift stop says the limit it was given, as a fraction of the mechanism's size (not always the
    default thousandth), and a remedy that fits the run: stabilization for an index-1 formulation, a tighter rtol
    or step for an index-3 integrator, which solves Psi = 0 itself."""
    from solutions.dynamics import Plan, Run, index3_guard
    from solutions.guard import Guard
    from solutions.settings import Settings

    system, q0, qd0 = build_system(load_model(MODELS / "slider_crank_flywheel.yaml"))
    off = q0.copy()
    off[0] += 0.05  # the crank's centre 5 cm off its pin
    with pytest.raises(AnalysisError, match=r"0\.01 of the mechanism's size.*use baumgarte") as index1:
        Guard(system, q0, 1e-2, None).check_drift(off, 0.3)
    assert "thousandth" not in str(index1.value)
    settings = Settings(t_end=1.0, drift_limit=1e-2)
    run = Run(system, q0, qd0, settings, None, None, None)
    plan = Plan("index-3", "hht", 1e-6, 1e-6, True, None, 1.0, None)
    with pytest.raises(AnalysisError, match=r"0\.01 of the mechanism's size.*smaller rtol or step") as index3:
        index3_guard(run, plan, q0).check_drift(off, 0.3)
    assert "baumgarte" not in str(index3.value)


def test_the_mechanism_size_is_the_farthest_body_centre_or_joint_point():
    """L (``assembly.mechanism_size``): the four-bar's body centres reach 0.25 m (the rocker's x), its joint O4 sits
    at x = 0.3 m (the file's numbers), so L = 0.3; joint points of different lengths, or none, are read too."""
    from types import SimpleNamespace

    from solutions.assembly import joint_extent, mechanism_size

    system, q0, _ = build_system(load_model(MODELS / "four_bar.yaml"))
    assert mechanism_size(system, q0) == 0.3
    mixed = SimpleNamespace(joints=[{"location": [0.1, 0.2]}, {"location": [0.0, -0.5, 0.1]}, {"name": "no point"}])
    assert joint_extent(mixed) == 0.5
    assert joint_extent(SimpleNamespace(joints=[{"name": "no point"}])) == 0.0
