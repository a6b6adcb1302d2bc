"""Formulations of forward dynamics at single states, against independent derivations.

- Double pendulum: every formulation's q'' against Lagrange's equations in the two link angles
  (written here), and the joint reactions -Psi_q^T lambda against Newton-Euler for each link.
- A block on a frictionless incline held by two parallel prismatic joints (redundant constraints):
  the SVD formulation gives the closed form a = g sin(theta) and the normal force m g cos(theta).
- Baumgarte: Psi_q q'' = gamma - 2 alpha Psi' - beta^2 Psi at an inconsistent state.
- Projection: the corrected state is on the constraints and the correction is mass-orthogonal to them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError
from solutions.dynamics import forward_dynamics
from solutions.formulations import FORMULATIONS, make_formulation, project_positions, project_velocities
from solutions.generalized_forces import build_forces
from solutions.io.model import load_model
from solutions.mass_matrix import mass_matrix

REPO = Path(__file__).resolve().parents[2]
G = 9.81


# -- the double pendulum of course/models/double_pendulum.yaml, by Lagrange ---------------------------------
class DoublePendulum:
    """Two uniform rods pinned end to end; angles phi1, phi2 from the x axis (the bodies' phi).

    T = 1/2 [phi']^T M(phi) [phi'],  M11 = m1 c1^2 + J1 + m2 L1^2,  M12 = m2 L1 c2 cos(phi1 - phi2),
    M22 = m2 c2^2 + J2;  V = (m1 c1 + m2 L1) g sin(phi1) + m2 c2 g sin(phi2);  Lagrange's equations:
        M phi'' + m2 L1 c2 sin(phi1 - phi2) [phi2'^2, -phi1'^2] + [dV/dphi1, dV/dphi2] = 0
    """

    m1, L1, J1 = 1.0, 1.0, 1.0 / 12.0
    m2, L2, J2 = 0.6, 0.8, 0.032
    c1, c2 = L1 / 2, L2 / 2

    def angular_accelerations(self, phi, w):
        s, c = math.sin(phi[0] - phi[1]), math.cos(phi[0] - phi[1])
        m1, m2, L1, c1, c2 = self.m1, self.m2, self.L1, self.c1, self.c2
        M = np.array([[m1 * c1**2 + self.J1 + m2 * L1**2, m2 * L1 * c2 * c], [m2 * L1 * c2 * c, m2 * c2**2 + self.J2]])
        rhs = -np.array(
            [
                m2 * L1 * c2 * s * w[1] ** 2 + (m1 * c1 + m2 * L1) * G * math.cos(phi[0]),
                -m2 * L1 * c2 * s * w[0] ** 2 + m2 * c2 * G * math.cos(phi[1]),
            ]
        )
        return np.linalg.solve(M, rhs)

    def rhs(self, t, y):
        return [y[2], y[3], *self.angular_accelerations(y[:2], y[2:])]

    def body_state(self, phi, w, alpha):
        """q, q', q'' of the two bodies (centres of mass) from the angles and their rates."""

        def e(a):
            return np.array([math.cos(a), math.sin(a)])

        def n(a):
            return np.array([-math.sin(a), math.cos(a)])

        r1 = self.c1 * e(phi[0])
        v1 = self.c1 * w[0] * n(phi[0])
        a1 = self.c1 * (alpha[0] * n(phi[0]) - w[0] ** 2 * e(phi[0]))
        r2 = self.L1 * e(phi[0]) + self.c2 * e(phi[1])
        v2 = self.L1 * w[0] * n(phi[0]) + self.c2 * w[1] * n(phi[1])
        a2 = self.L1 * (alpha[0] * n(phi[0]) - w[0] ** 2 * e(phi[0])) + self.c2 * (
            alpha[1] * n(phi[1]) - w[1] ** 2 * e(phi[1])
        )
        q = np.array([*r1, phi[0], *r2, phi[1]])
        qd = np.array([*v1, w[0], *v2, w[1]])
        qdd = np.array([*a1, alpha[0], *a2, alpha[1]])
        return q, qd, qdd


@pytest.fixture(scope="module")
def pendulum_setup():
    model = load_model(REPO / "course/models/double_pendulum.yaml")
    system, _, _ = build_system(model)
    return system, mass_matrix(model), build_forces(model)


def joint_force(system, lam, q, joint, body):
    """-Psi_q^T lambda restricted to one joint's rows and one body's x, y columns: the force the joint
    puts on that body."""
    rows = [k for k, owner in enumerate(system.row_owners) if owner == joint]
    force = -system.jacobian(q, 0.0)[rows].T @ lam[rows]
    return force[3 * body : 3 * body + 2]


@pytest.mark.parametrize("name", list(FORMULATIONS))
def test_accelerations_and_reactions_of_the_double_pendulum(pendulum_setup, name):
    system, M, forces = pendulum_setup
    dp = DoublePendulum()
    formulation = make_formulation(name, system, M, forces)
    for phi, w in [((-0.3, 0.4), (1.5, -2.0)), ((-2.0, -1.0), (-0.7, 3.1))]:
        alpha = dp.angular_accelerations(phi, w)
        q, qd, qdd_expected = dp.body_state(phi, w, alpha)
        if name == "partitioning":
            formulation.initial_state(q, qd, 0.0)
        qdd, lam = formulation.accelerations(q, qd, 0.0)
        np.testing.assert_allclose(qdd, qdd_expected, atol=1e-11)
        # Newton-Euler: m2 a2 = F_A + m2 g (lower rod),  m1 a1 = F_O - F_A + m1 g (upper rod)
        gravity = np.array([0.0, -G])
        F_A = dp.m2 * qdd_expected[3:5] - dp.m2 * gravity
        F_O = dp.m1 * qdd_expected[0:2] + F_A - dp.m1 * gravity
        np.testing.assert_allclose(joint_force(system, lam, q, "A", 1), F_A, atol=1e-10)
        np.testing.assert_allclose(joint_force(system, lam, q, "A", 0), -F_A, atol=1e-10)
        np.testing.assert_allclose(joint_force(system, lam, q, "O", 0), F_O, atol=1e-10)


def test_baumgarte_asks_for_the_stabilized_gamma(pendulum_setup):
    """At a state off the constraints Psi_q q'' = gamma - 2 alpha Psi' - beta^2 Psi (DESIGN section 3)."""
    system, M, forces = pendulum_setup
    rng = np.random.default_rng(1)
    q, qd, _ = DoublePendulum().body_state((-0.3, 0.4), (1.5, -2.0), (0.0, 0.0))
    q, qd = q + 1e-3 * rng.normal(size=6), qd + 1e-2 * rng.normal(size=6)
    alpha, beta = 7.0, 3.0
    qdd, _ = make_formulation("baumgarte", system, M, forces, alpha=alpha, beta=beta).accelerations(q, qd, 0.0)
    jac = system.jacobian(q, 0.0)
    psi, psi_dot = system.constraints(q, 0.0), jac @ qd
    assert np.abs(psi).max() > 1e-4 and np.abs(psi_dot).max() > 1e-3
    expected = system.gamma(q, qd, 0.0) - 2 * alpha * psi_dot - beta**2 * psi
    np.testing.assert_allclose(jac @ qdd, expected, atol=1e-12)


def test_projection_lands_on_the_constraints_mass_orthogonally(pendulum_setup):
    system, M, forces = pendulum_setup
    rng = np.random.default_rng(2)
    q, qd, _ = DoublePendulum().body_state((-0.3, 0.4), (1.5, -2.0), (0.0, 0.0))
    formulation = make_formulation("projection", system, M, forces)
    q_bad, qd_bad = q + 1e-4 * rng.normal(size=6), qd + 1e-3 * rng.normal(size=6)
    q_new, _ = project_positions(formulation, q_bad, 0.0)
    qd_new = project_velocities(formulation, q_new, qd_bad, 0.0)
    jac = system.jacobian(q_new, 0.0)
    assert np.abs(system.constraints(q_new, 0.0)).max() < 1e-12
    assert np.abs(jac @ qd_new).max() < 1e-12
    Z = scipy.linalg.null_space(jac)  # directions along the constraints
    assert np.abs(Z.T @ M @ (qd_new - qd_bad)).max() < 1e-12  # the velocity change is M-orthogonal to them
    assert np.abs(Z.T @ M @ (q_new - q_bad)).max() < 1e-7  # (to first order for the nonlinear positions)


def test_spatial_projection_weights_by_the_mass_matrix_at_the_projected_state():
    """A spatial M(q): the step's projection is weighted by M at the state it projects, whatever state the
    formulation evaluated last (an integrator's last stage), as the compiled engine's; the velocity change is then
    M(q)-orthogonal to the motions the joints allow."""
    model = load_model(REPO / "course/models/spatial_double_pendulum.yaml")
    system, q0, qd0 = build_system(model)
    forces = build_forces(model)
    rng = np.random.default_rng(5)
    q_bad, qd_bad = q0 + 1e-5 * rng.normal(size=q0.size), qd0 + 1e-3 * rng.normal(size=q0.size)
    fresh = make_formulation("projection", system, mass_matrix(model), forces)
    after_other = make_formulation("projection", system, mass_matrix(model), forces)
    elsewhere = q0.copy()
    elsewhere[3:7] = [math.cos(0.6), math.sin(0.6), 0.0, 0.0]  # the first body turned: another M(q)
    fresh.accelerations(q_bad, qd_bad, 0.0)  # its last evaluation at the state it projects
    after_other.accelerations(elsewhere, qd0, 0.0)  # its last at another state (an integrator's stage)
    y = np.concatenate([q_bad, qd_bad])
    projected, other = fresh.after_step(0.0, y), after_other.after_step(0.0, y)
    np.testing.assert_array_equal(projected, other)
    n = q0.size
    q_new, qd_new = projected[:n], projected[n:]
    Z = scipy.linalg.null_space(system.jacobian(q_new, 0.0))
    assert np.abs(Z.T @ fresh.mass(q_bad) @ (qd_new - qd_bad)).max() < 1e-12


# -- redundant constraints: a block held by two parallel prismatic joints on an incline --------------------
def incline_block(theta=math.pi / 6):
    """A 2 kg block on a frictionless incline going down at angle theta, held on the line by two prismatic
    joints 0.2 m apart along it: the second joint's two equations repeat the first's."""
    axis = [math.cos(theta), -math.sin(theta)]
    return {
        "model": {
            "name": "incline",
            "gravity": [0.0, -G],
            "bodies": [{"name": "block", "mass": 2.0, "inertia": 0.01, "location": [0.0, 0.0]}],
            "joints": [
                {
                    "name": "rail1",
                    "type": "prismatic",
                    "body1": "ground",
                    "body2": "block",
                    "location": [0.0, 0.0],
                    "axis": axis,
                },
                {
                    "name": "rail2",
                    "type": "prismatic",
                    "body1": "ground",
                    "body2": "block",
                    "location": [0.2 * axis[0], 0.2 * axis[1]],
                    "axis": axis,
                },
            ],
        }
    }


def test_svd_copes_with_redundant_constraints():
    theta = math.radians(30.0)
    model = load_model(incline_block(theta))
    system, q0, qd0 = build_system(model)
    formulation = make_formulation("svd", system, mass_matrix(model), build_forces(model))
    qdd, lam = formulation.accelerations(q0, qd0, 0.0)
    down = np.array([math.cos(theta), -math.sin(theta)])
    np.testing.assert_allclose(qdd, [*(G * math.sin(theta) * down), 0.0], atol=1e-12)
    # the joints together push with the normal force m g cos(theta), perpendicular to the incline
    normal = np.array([math.sin(theta), math.cos(theta)])
    total = -system.jacobian(q0, 0.0).T @ lam
    np.testing.assert_allclose(total, [*(2.0 * G * math.cos(theta) * normal), 0.0], atol=1e-12)

    result = forward_dynamics(system, q0, qd0, 1.0, 10, formulation="svd", integrator="DOP853", rtol=1e-10, atol=1e-12)
    s = 0.5 * G * math.sin(theta) * result.t**2  # distance slid down the incline
    np.testing.assert_allclose(result.q[:, :2], np.outer(s, down), atol=1e-10)


@pytest.mark.parametrize("name", ["baumgarte", "qr", "partitioning", "projection"])
def test_other_formulations_refuse_redundant_constraints_by_name(name):
    system, q0, qd0 = build_system(load_model(incline_block()))
    with pytest.raises(AnalysisError, match="redundant.*svd"):
        forward_dynamics(system, q0, qd0, 1.0, 10, formulation=name)


def test_unknown_formulation_and_option():
    system, q0, qd0 = build_system(load_model(REPO / "course/models/simple_pendulum.yaml"))
    with pytest.raises(AnalysisError, match="unknown formulation 'baumgarten'.*baumgarte"):
        forward_dynamics(system, q0, qd0, 1.0, 10, formulation="baumgarten")
    with pytest.raises(AnalysisError, match="formulation 'qr'"):
        forward_dynamics(system, q0, qd0, 1.0, 10, formulation="qr", colour="red")


def test_partitioning_survives_loose_tolerances():
    """At rtol 1e-4 DOP853 tries steps that push an independent coordinate beyond the pendulum's reach; the
    dependent Newton then has no solution, the step is rejected and retried shorter instead of stopping."""
    model = load_model(REPO / "course/models/double_pendulum.yaml")
    system, q0, qd0 = build_system(model)
    loose = forward_dynamics(system, q0, qd0, 2.0, 20, "partitioning", "DOP853", rtol=1e-4, atol=1e-6)
    tight = forward_dynamics(system, q0, qd0, 2.0, 20, "qr", "DOP853", rtol=1e-11, atol=1e-13)
    assert np.max(np.abs(loose.q[-1] - tight.q[-1])) < 1e-2
    assert loose.info["max_constraint_residual"] < 1e-10


def test_rk4_beyond_its_stability_limit_stops_with_a_diagnostic():
    """A stiff spring (k = 1e8 N/m on 1 kg: period 0.6 ms) integrated by RK4 with 10 ms steps blows up;
    the run must stop and say so, not return NaN or garbage."""
    spec = {
        "model": {
            "gravity": [0.0, -9.81],
            "bodies": [{"name": "bob", "mass": 1.0, "inertia": 0.01, "location": [0.0, -1.0]}],
            "joints": [
                {
                    "name": "slide",
                    "type": "prismatic",
                    "body1": "ground",
                    "body2": "bob",
                    "location": [0.0, -1.0],
                    "axis": [0.0, 1.0],
                }
            ],
            "spring_dampers": [
                {
                    "type": "TSDA",
                    "body1": "ground",
                    "body2": "bob",
                    "point1": [0.0, 0.0],
                    "point2": [0.0, -1.0],
                    "spring_coefficient": 1.0e8,
                    "free_length": 0.999,
                }
            ],
        }
    }
    system, q0, qd0 = build_system(load_model(spec))
    with pytest.raises(AnalysisError, match="stability limit"):
        forward_dynamics(system, q0, qd0, 1.0, 100, "baumgarte", "rk4", step=0.01)


# -- the augmented Lagrangian's stopping rule (AugmentedLagrangian.converged) ------------------------------
def test_augmented_lagrangian_stops_within_a_few_iterations_at_full_accuracy(pendulum_setup):
    """Where Psi_q has full rank (the double pendulum) or is redundant but regular (the incline block held by two
    rails), eq. 5.52's iterations stop after a few, with q'' at Lagrange's equations and the closed form
    g sin(theta) to rounding: the rule stops at the rounding floor, not above it (the old one ran all 25)."""
    system, M, forces = pendulum_setup
    dp = DoublePendulum()
    formulation = make_formulation("augmented-lagrangian", system, M, forces)
    states = [((-0.3, 0.4), (1.5, -2.0)), ((-2.0, -1.0), (-0.7, 3.1)), ((0.2, 2.9), (-4.0, 6.0))]
    for phi, w in states:
        q, qd, qdd_expected = dp.body_state(phi, w, dp.angular_accelerations(phi, w))
        qdd, _ = formulation.accelerations(q, qd, 0.0)
        np.testing.assert_allclose(qdd, qdd_expected, atol=1e-11 * np.max(np.abs(qdd_expected)))
    assert formulation.unconverged == 0 and formulation.iterations <= 5 * len(states)

    theta = math.radians(30.0)
    model = load_model(incline_block(theta))
    system, q0, qd0 = build_system(model)
    block = make_formulation("augmented-lagrangian", system, mass_matrix(model), build_forces(model))
    qdd, _ = block.accelerations(q0, qd0, 0.0)
    np.testing.assert_allclose(qdd[:2], G * math.sin(theta) * np.array([math.cos(theta), -math.sin(theta)]), atol=1e-11)
    assert block.unconverged == 0 and block.iterations <= 5


def test_augmented_lagrangian_rule_tells_rounding_from_slow_convergence(pendulum_setup):
    """The rule on sequences of changes ||q''_k+1 - q''_k||_M (size 1, penalty 1e7: rounding bound 2.2e-9):
    fast contraction, then changes that stop shrinking at rounding size, stops; the same sizes shrinking slowly
    (a singular position's small sigma) go on; a change above the rounding bound that stops shrinking goes on."""
    formulation = make_formulation("augmented-lagrangian", *pendulum_setup)
    assert formulation.converged([1e-6, 1e-12], 1.0)  # (a): theta 1e-6, nothing left above eps
    assert not formulation.converged([1e-6], 1.0)  # the first change: no theta yet
    assert formulation.converged([1e-6, 3e-11, 5e-11], 1.0)  # (b): fast to 3e-11, then rounding
    assert not formulation.converged([1e-6, 3e-11, 2e-11], 1.0)  # still shrinking: estimate 4e-11 > eps
    assert not formulation.converged([1e-9, 9e-10, 8.1e-10, 8.2e-10], 1.0)  # slow (theta 0.9): no proof
    assert not formulation.converged([1e-3, 1e-6, 1e-8, 1.1e-8], 1.0)  # stopped shrinking above 2.2e-9
    assert formulation.converged([1e-6, 0.0], 1.0)  # a fixed point


def test_augmented_lagrangian_run_keeps_its_accuracy_with_few_iterations():
    """The double pendulum over 1 s by the augmented Lagrangian at the defaults: against baumgarte at rtol 1e-12
    (an independent formulation), within 1e-7 (units of m and rad), with under 6 iterations of eq. 5.52 per
    evaluation on average (14.5 with the old rule) and none ending at max_iterations in more than 5 %."""
    system, q0, qd0 = build_system(load_model(REPO / "course/models/double_pendulum.yaml"))
    reference = forward_dynamics(system, q0, qd0, 1.0, 20, "baumgarte", "DOP853", rtol=1e-12, atol=1e-14)
    result = forward_dynamics(system, q0, qd0, 1.0, 20, "augmented-lagrangian", "DOP853", engine="numpy")
    assert float(np.max(np.abs(result.q - reference.q))) < 1e-7
    evaluations = result.info["rhs_evaluations"]
    assert result.info["augmented_iterations"] < 6 * evaluations
    assert result.info["unconverged_iterations"] < 0.05 * evaluations


def test_augmented_lagrangian_under_radau_stops_by_the_fixed_rule():
    """Under an implicit integrator (Radau differences q'' for its Jacobian) the iterations of eq. 5.52 stop on a
    change below 1e-14 (1 + max |q''|), the same count for neighbouring states, not at the rounding floor: more
    iterations per evaluation than the same run under DOP853 (the rounding rule), and the motion as accurate."""
    system, q0, qd0 = build_system(load_model(REPO / "course/models/double_pendulum.yaml"))
    reference = forward_dynamics(system, q0, qd0, 0.3, 6, "baumgarte", "DOP853", rtol=1e-12, atol=1e-14)
    per_evaluation = {}
    for integrator in ("Radau", "DOP853"):
        result = forward_dynamics(system, q0, qd0, 0.3, 6, "augmented-lagrangian", integrator, rtol=1e-8, atol=1e-10,
                                  engine="numpy", divergence="skip")  # fmt: skip
        assert float(np.max(np.abs(result.q - reference.q))) < 1e-6, integrator
        per_evaluation[integrator] = result.info["augmented_iterations"] / result.info["rhs_evaluations"]
    assert per_evaluation["Radau"] > 1.5 * per_evaluation["DOP853"], per_evaluation
