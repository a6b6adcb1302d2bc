"""Issue 14: mechanisms through singular positions, over-constrained loops, and defaults a user can trust.

Every reference is computed here from the mechanism's own one-degree-of-freedom equation, derived by hand
(``mechanisms.py``) and integrated by scipy at tight tolerance, or from a closed form:

- a chain of N parallelogram loops (N = 1, 2, 10) released under gravity turns through several singular
  positions (every bar on the ground line, Psi_q short of one rank per loop): the crank angle against
  ((n + 1)/3 + n) L theta'' = -g cos(theta) ((n + 1)/2 + n); driven, its kinematics against theta = pi/2 + w t
  and its singular positions against the times theta = k pi, with and without ``through_singular``;
- the Sarrus linkage (over-constrained spatial 6R loop, Psi_q of rank n - 1 everywhere) against Lagrange's
  equation in its link angle;
- the Bennett linkage (over-constrained spatial 4R loop, mobility 1 where the Gruebler count gives -2) against
  Lagrange's equation in its input angle, built on Bennett's closed-form relation between the joint angles;
- a pendulum released level over 300 s against the elliptic-integral solution (Jacobi's sn);
- the implicit integrators (hht, generalized-alpha) against DOP853 at rtol 1e-12: within the accuracy
  bound, or their result says it is not.
"""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import scipy.special

from solutions.assembly import build_system, mechanism_size
from solutions.diagnostics import AnalysisError, SingularConfigurationError, rank_report
from solutions.dynamics import DEFAULT_ACCURACY, forward_dynamics
from solutions.io.model import load_model
from solutions.kinematics import kinematic_analysis, locate_singular_position
from solutions.linalg import independent_rows, minimum_norm_solution, numerical_rank

from .mechanisms import (
    SARRUS,
    bennett,
    bennett_centres,
    bennett_theta,
    chain_theta,
    parallelogram_chain,
    sarrus,
    sarrus_theta,
)

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"


def chain(n: int):
    return build_system(load_model(parallelogram_chain(n)))


# -- singular positions: the chain of parallelograms -------------------------------------------------------
@pytest.mark.parametrize("n, formulation", [(1, "auto"), (2, "auto"), (10, "augmented-lagrangian")])
def test_parallelogram_chain_passes_its_singular_positions_on_the_physical_branch(n, formulation):
    """3 s: theta from pi/2 down past 0, -pi and -2pi, three singular positions; every crank and coupler
    follows the one-dof motion (cranks at theta, couplers level at x = k L + L/2 + L cos theta)."""
    system, q0, qd0 = chain(n)
    result = forward_dynamics(system, q0, qd0, 3.0, 150, formulation=formulation)
    theta = chain_theta(n, result.t)
    assert theta[-1] < -2 * math.pi  # three crossings, not a test that passes by stopping early
    names = system.coordinate_names
    for k in range(n + 1):
        np.testing.assert_allclose(result.q[:, names.index(f"crank{k}.phi")], theta, atol=2e-6)
    for k in range(n):
        np.testing.assert_allclose(result.q[:, names.index(f"coupler{k}.x")], k + 0.5 + np.cos(theta), atol=2e-6)
        np.testing.assert_allclose(result.q[:, names.index(f"coupler{k}.phi")], 0.0, atol=2e-6)
    assert result.info["formulation"] == "augmented-lagrangian"
    assert result.info["singular_positions"], "the crossings are reported"
    crossing = result.info["singular_positions"][0]
    assert abs(np.interp(crossing["t"], result.t, theta)) < 0.3 and "O0" in crossing["joints"]
    if formulation == "auto":
        assert "stopped near a singular configuration" in result.info["chosen"]["why"]


def test_baumgarte_stops_at_the_singular_position_by_name():
    system, q0, qd0 = chain(1)
    with pytest.raises(SingularConfigurationError, match=r"singular configuration.*O0.*augmented-lagrangian"):
        forward_dynamics(system, q0, qd0, 3.0, 150, formulation="baumgarte")


def _driven_chain(n: int, w: float):
    data = parallelogram_chain(n)
    data["model"]["motors"] = [
        {"name": "drive", "type": "angle", "joint": "O0", "function": {"type": "polynomial", "coefficients": [0, w]}}
    ]
    return build_system(load_model(data))


@pytest.mark.parametrize("n", [1, 2, 10])
def test_driven_chain_kinematics_reports_then_passes_the_singular_positions(n):
    """theta = pi/2 + w t passes theta = pi, 2 pi, 3 pi (every bar on the ground line, Psi_q short of n ranks: an
    even n leaves the sign of det Psi_q as it was); each is reported at its time and the motion stays on the
    parallelogram branch."""
    w = 2.0
    system, q0, _ = _driven_chain(n, w)
    result = kinematic_analysis(system, q0, 4.0, 200, through_singular=True)
    theta = math.pi / 2 + w * result.t
    names = system.coordinate_names
    for k in range(n + 1):
        np.testing.assert_allclose(result.q[:, names.index(f"crank{k}.phi")], theta, atol=1e-10)
    for k in range(n):
        np.testing.assert_allclose(result.qd[:, names.index(f"coupler{k}.x")], -w * np.sin(theta), atol=1e-10)
        np.testing.assert_allclose(result.qdd[:, names.index(f"coupler{k}.x")], -w * w * np.cos(theta), atol=1e-9)
    expected = [(j * math.pi + math.pi / 2) / w for j in range(3)]  # theta = pi, 2 pi, 3 pi
    found = result.info["singular_positions"]
    assert len(found) == 3 and np.allclose([c["t"] for c in found], expected, atol=1e-6)
    assert all(c["after"] <= c["t"] <= c["until"] for c in found)
    assert all(c.get("rank_loss", n) == n for c in found)
    assert all({"O0", f"B{n - 1}"} <= set(c["joints"]) for c in found)
    assert len(result.info["warnings"]) == 3
    # output steps 0.27 rad apart, the last crossing (t = 3.927 s) between the last two: found all the same
    coarse = kinematic_analysis(system, q0, 4.0, 30, through_singular=True).info["singular_positions"]
    assert np.allclose([c["t"] for c in coarse], expected, atol=1e-5)


@pytest.mark.parametrize("n", [1, 2, 10])
def test_driven_chain_kinematics_stops_by_name_without_the_flag(n):
    """The default run stops at the first singular position, theta = pi at t = pi / (2 w) = 0.785 s, whether
    det Psi_q changes sign there (odd n) or not (even n: n ranks lost at once)."""
    system, q0, _ = _driven_chain(n, 2.0)
    with pytest.raises(AnalysisError, match=r"between t = 0\.78 s and t = 0\.8 s.*O0.*through-singular") as caught:
        kinematic_analysis(system, q0, 4.0, 200)
    if n % 2 == 0:
        assert f"loses {n} rank(s) at t = 0.785398 s" in str(caught.value)


def test_a_near_singular_pass_is_no_singular_position():
    """A chain driven to theta = pi - 0.01 and back (theta = pi/2 + (pi/2 - 0.01) sin t) comes near the singular
    position and turns back: no report, and the default run goes on, on the parallelogram branch. The search
    itself (``locate_singular_position``) finds the rank loss of theta = pi in an interval that holds it, to
    1e-7 s, and none in an interval that ends 0.01 rad before it (sigma_min / sigma_max about 1e-3 there)."""
    amplitude = math.pi / 2 - 0.01
    data = parallelogram_chain(2)
    function = {"type": "harmonic", "amplitude": amplitude, "frequency": 1.0}
    data["model"]["motors"] = [{"name": "drive", "type": "angle", "joint": "O0", "function": function}]
    system, q0, _ = build_system(load_model(data))
    result = kinematic_analysis(system, q0, 4.0, 80)
    theta = math.pi / 2 + amplitude * np.sin(result.t)
    np.testing.assert_allclose(result.q[:, system.coordinate_names.index("crank2.phi")], theta, atol=1e-10)
    assert kinematic_analysis(system, q0, 4.0, 80, through_singular=True).info["singular_positions"] == []

    w = 2.0
    system, q0, _ = _driven_chain(2, w)
    run = kinematic_analysis(system, q0, 0.7, 35)  # the state at t = 0.7 s, theta = pi/2 + 1.4
    state = (run.t[-1], run.q[-1], run.qd[-1], run.qdd[-1])
    t_star = math.pi / (2 * w)
    found = locate_singular_position(system, *state, 0.8)
    assert found is not None and abs(found["t"] - t_star) < 1e-7 and found["rank_loss"] == 2
    assert locate_singular_position(system, *state, t_star - 0.01 / w) is None


# -- redundant constraints: the Sarrus linkage ---------------------------------------------------------------
@cache
def sarrus_system():
    return build_system(load_model(sarrus()))


def top_height_error(system, result) -> float:
    z = result.q[:, system.coordinate_names.index("top.z")]
    return float(np.max(np.abs(z - 2 * SARRUS["L"] * np.cos(sarrus_theta(result.t)))))


def test_sarrus_is_one_redundant_equation_and_one_degree_of_freedom():
    system, q0, _ = sarrus_system()
    report = rank_report(system.jacobian(q0, 0.0), system.row_owners)
    assert (system.n_coordinates, system.n_constraints) == (35, 35)
    assert report.rank == 34 and report.degrees_of_freedom == 1 and report.n_redundant == 1


@pytest.mark.parametrize("formulation", ["auto", "svd"])
def test_sarrus_runs_by_default_against_its_one_dof_equation(formulation):
    system, q0, qd0 = sarrus_system()
    result = forward_dynamics(system, q0, qd0, 1.0, 50, formulation=formulation)
    assert top_height_error(system, result) < 1e-6
    if formulation == "auto":
        assert result.info["formulation"] == "augmented-lagrangian"
        assert result.info["max_constraint_residual"] < 1e-7
    assert "not unique" in result.info["notes"][0]
    # minimum-norm multipliers: orthogonal to the left null space of Psi_q (the redundant combination)
    k = 25
    u = np.linalg.svd(system.jacobian(result.q[k], result.t[k]))[0][:, -1]
    assert abs(u @ result.lam[k]) < 1e-8 * np.linalg.norm(result.lam[k])


def test_sarrus_with_an_implicit_integrator_reaches_its_reference_or_says_not():
    system, q0, qd0 = sarrus_system()
    result = forward_dynamics(system, q0, qd0, 0.5, 25, integrator="hht")
    error = top_height_error(system, result)
    assert error < 1e-3  # it runs, on the right motion
    bound = DEFAULT_ACCURACY * mechanism_size(system, q0)
    warned = any(w.startswith("accuracy:") for w in result.info["warnings"])
    assert error <= bound or warned
    assert warned  # second order at rtol 1e-8: about 1e-5 m here, above the bound


@cache
def bennett_system():
    return build_system(load_model(bennett()))


def test_bennett_is_three_redundant_equations_and_one_degree_of_freedom():
    system, q0, _ = bennett_system()
    report = rank_report(system.jacobian(q0, 0.0), system.row_owners)
    assert (system.n_coordinates, system.n_constraints) == (21, 23)
    assert report.rank == 20 and report.degrees_of_freedom == 1 and report.n_redundant == 3


def test_bennett_falls_under_gravity_by_default_against_its_one_dof_equation():
    """1 s released at rest: J1 turns by more than 5 rad, from 1.2 rad through 0 and -pi; every link's centre
    against the closed form at theta1(t) from the one-dof equation (``mechanisms.bennett_theta``)."""
    system, q0, qd0 = bennett_system()
    result = forward_dynamics(system, q0, qd0, 1.0, 50, formulation="auto")
    assert result.info["formulation"] == "augmented-lagrangian"
    assert result.info["max_constraint_residual"] < 1e-7
    theta = bennett_theta(result.t)
    assert theta.min() < -math.pi  # the motion goes through the folded positions theta1 = 0 and -pi
    names = system.coordinate_names
    columns = [[names.index(f"link{i}.{axis}") for axis in "xyz"] for i in (1, 2, 3)]
    expected = np.array([bennett_centres(th) for th in theta])  # (steps, link, xyz)
    got = np.stack([result.q[:, c] for c in columns], axis=1)
    assert float(np.max(np.abs(got - expected))) < 1e-6


# -- the rank rule ---------------------------------------------------------------------------------------------
def test_the_rank_rule_does_not_depend_on_units_and_never_raises():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((6, 4)) @ rng.standard_normal((4, 9))  # rank 4
    A[5] = A[0] + 1e-12 * rng.standard_normal(9)  # a redundant row, off by rounding-size noise
    for scale in (1e-6, 1.0, 1e6):
        assert numerical_rank(np.linalg.svd(scale * A, compute_uv=False), A.shape) == 4
        assert independent_rows(scale * A).size == 4
    x = minimum_norm_solution(A, A @ np.ones(9))
    np.testing.assert_allclose(A @ x, A @ np.ones(9), atol=1e-9)
    assert np.all(np.isfinite(minimum_norm_solution(np.zeros((3, 3)), np.ones(3))))


# -- defaults a user can trust ------------------------------------------------------------------------------
def pendulum_reference(t: np.ndarray) -> np.ndarray:
    """Tip of a uniform rod (L = 1 m) pinned at one end, released level at rest: psi from the downward vertical
    obeys psi'' = -(3 g / 2 L) sin psi; sin(psi / 2) = k sn(K(k) - w0 t; k), k = sin(psi0 / 2) (Jacobi)."""
    w0, k = math.sqrt(1.5 * 9.81), math.sin(math.pi / 4)
    sn = scipy.special.ellipj(scipy.special.ellipk(k * k) - w0 * t, k * k)[0]
    psi = 2 * np.arcsin(k * sn)
    return np.stack([np.sin(psi), -np.cos(psi)], axis=1)


def test_long_pendulum_at_the_defaults_meets_the_accuracy_and_a_loose_run_says_it_does_not():
    system, q0, qd0 = build_system(load_model(MODELS / "simple_pendulum.yaml"))
    bound = DEFAULT_ACCURACY * mechanism_size(system, q0)
    for rtol in (None, 1e-8):
        result = forward_dynamics(system, q0, qd0, 300.0, 600, rtol=rtol)
        phi = result.q[:, 2]
        error = float(np.max(np.abs(np.stack([np.cos(phi), np.sin(phi)], 1) - pendulum_reference(result.t))))
        warned = any(w.startswith("accuracy:") for w in result.info["warnings"])
        if rtol is None:
            assert error < bound and not warned and result.info["rtol"] < 1e-10
        else:
            assert error > bound and warned  # the warning is earned, and given


@cache
def four_bar_reference():
    system, q0, qd0 = build_system(load_model(MODELS / "four_bar_spring.yaml"))
    return forward_dynamics(system, q0, qd0, 0.5, 50, "baumgarte", "DOP853", rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("integrator", ["hht", "generalized-alpha", "dop853"])
def test_integrators_at_their_defaults_meet_the_accuracy_or_say_so(integrator):
    system, q0, qd0 = build_system(load_model(MODELS / "four_bar_spring.yaml"))
    reference = four_bar_reference()
    result = forward_dynamics(system, q0, qd0, 0.5, 50, integrator=integrator)
    error = float(np.max(np.abs(result.q - reference.q)[:, [0, 1, 3, 4, 6, 7]]))  # positions in m
    bound = DEFAULT_ACCURACY * mechanism_size(system, q0)
    warned = any(w.startswith("accuracy:") for w in result.info["warnings"])
    assert error <= bound or warned, (error, bound, result.info["warnings"])
    if integrator == "dop853":
        assert error <= bound and not warned


def test_a_tolerance_below_what_double_precision_holds_still_warns():
    """The default rule may ask for an rtol below 1e-12 (a long run of many periods); the error estimate
    then takes 1e-12, what an explicit run holds, so the run warns instead of promising the accuracy."""
    from solutions.dynamics import DEFAULT_ACCURACY, HELD_RTOL, accuracy_warnings, default_rtol

    periods = 1700.0
    rtol = default_rtol(periods)
    assert rtol < HELD_RTOL and rtol * periods**2 <= DEFAULT_ACCURACY * 1.0001
    warned = accuracy_warnings({"rtol": rtol, "integrator": "DOP853"}, 1.0, DEFAULT_ACCURACY, periods)
    assert len(warned) == 1 and "double precision" in warned[0]
    short = accuracy_warnings({"rtol": default_rtol(30.0), "integrator": "DOP853"}, 1.0, DEFAULT_ACCURACY, 30.0)
    assert short == []
