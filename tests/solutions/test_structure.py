"""Speed by structure, checked for correctness: per-type evaluation, the lean integrators, the guards.

Every fast path is compared with something it does not share code with: the per-type (batched) system
arrays with the element methods (the definition) and with finite differences of Psi; the lean rk45 and
dop853 with closed-form solutions; the stiffness monitor with a linear system whose eigenvalues are known.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from solutions.assembly import System, build_system
from solutions.diagnostics import AnalysisError
from solutions.dynamics import choose_method, forward_dynamics
from solutions.generalized_forces import build_forces
from solutions.guard import Guard
from solutions.integrators import BudgetError, StiffnessError, integrate, spectral_radius
from solutions.io.model import load_model
from solutions.mass_matrix import mass_matrix

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
EXAMPLES = sorted(MODELS.glob("*.yaml"))


def _random_state(system: System, rng: np.random.Generator, q0: np.ndarray):
    q = q0 + 0.3 * rng.standard_normal(q0.size)
    if system.model.dimension == 3:
        p = q.reshape(-1, 7)[:, 3:]
        p /= np.linalg.norm(p, axis=1, keepdims=True)
    return q, rng.standard_normal(q0.size), float(rng.uniform(0.1, 2.0))


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_per_type_evaluation_equals_the_element_loop(path):
    model = load_model(path)
    system, q0, _ = build_system(model)
    loop = System(model, system.elements, vectorized=False)
    assert system.groups, "no element group was formed"
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, qd, t = _random_state(system, rng, q0)
        fast, plain = system.evaluate(q, qd, t), loop.evaluate(q, qd, t)
        for a, b in zip(fast, plain, strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(system.jacobian(q, t), loop.jacobian(q, t), rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("name", ["andrews", "quick_return", "spatial_slider_crank", "revolute_revolute_skew"])
def test_scattered_jacobian_against_finite_differences(name):
    model = load_model(MODELS / f"{name}.yaml")
    system, q0, _ = build_system(model)
    q, _, t = _random_state(system, np.random.default_rng(5), q0)
    h = 1e-6
    numeric = np.column_stack(
        [(system.constraints(q + h * e, t) - system.constraints(q - h * e, t)) / (2 * h) for e in np.eye(q.size)]
    )
    np.testing.assert_allclose(system.jacobian(q, t), numeric, atol=1e-6)


def test_a_group_that_disagrees_with_its_elements_is_left_to_the_element_loop(monkeypatch):
    from solutions.planar import batched

    original = batched.RevoluteGroup.constraints
    monkeypatch.setattr(
        batched.RevoluteGroup, "constraints", lambda self, X, terms, t: original(self, X, terms, t) + 1e-3
    )
    model = load_model(MODELS / "four_bar.yaml")
    system, q0, _ = build_system(model)
    assert "RevoluteGroup" not in [type(g).__name__ for g in system.groups]
    loop = System(model, system.elements, vectorized=False)
    np.testing.assert_array_equal(system.constraints(q0, 0.1), loop.constraints(q0, 0.1))


def test_a_stubbed_group_falls_back_to_the_element_loop(monkeypatch):
    from solutions.planar import batched

    def stub(*args):
        raise NotImplementedError("rotated: see eq. 2.1")

    monkeypatch.setattr(batched, "rotated", stub)
    system, q0, _ = build_system(load_model(MODELS / "slider_crank.yaml"))
    kinds = [type(g).__name__ for g in system.groups]
    assert "RevoluteGroup" not in kinds and "AlongDirectionGroup" not in kinds
    assert "RelativeAngleGroup" in kinds  # needs no rotation


def _mixed_system():
    """Three bodies and every batched planar element type, several of each, interleaved, ground on either side:
    the groups' vectors share one rotation (``planar.batched.RotatedVectors``), each group in its own rows."""
    from solutions.functions import Constant, Harmonic, Polynomial
    from solutions.planar.joints import BodyCoordinate, Distance, PinInSlot, RelativeAngle, Revolute, Translation

    bodies = [{"name": n, "mass": 1.0, "inertia": 0.1, "location": [float(k), 0.0]} for k, n in enumerate("abc")]
    model = load_model({"model": {"name": "mixed", "bodies": bodies}})
    rng = np.random.default_rng(11)

    def vec():
        return rng.uniform(-0.5, 0.5, 2)

    def unit():
        angle = rng.uniform(-math.pi, math.pi)
        return np.array([math.cos(angle), math.sin(angle)])

    elements = [
        Revolute("R1", 0, -1, si=vec(), sj=vec()),
        PinInSlot("P1", 1, 0, si=vec(), sj=vec(), axis=unit()),
        Distance("D1", -1, 2, si=vec(), sj=vec(), length=Harmonic(0.2, 2.5, 0.3, offset=0.9)),
        Revolute("R2", 1, 2, si=vec(), sj=vec()),
        RelativeAngle("A1", 0, 2, phi0=0.3, function=Polynomial((0.1, 2.0, -0.7, 0.3))),
        Translation("T1", -1, 1, si=vec(), sj=vec(), axis=unit(), d0=0.2, pinion_radius=0.3, side=-1.0),
        Distance("D2", 2, 0, si=vec(), sj=vec(), length=Constant(0.8)),
        PinInSlot("P2", -1, 2, si=vec(), sj=vec(), axis=unit()),
        BodyCoordinate("B1", -1, 1, index=0, function=Polynomial((0.2, 0.5))),
        Translation("T2", 2, 1, si=vec(), sj=vec(), axis=unit(), d0=-0.1, function=Harmonic(0.1, 2.0, 0.0)),
        Revolute("R3", -1, 1, si=vec(), sj=vec()),
    ]
    return System(model, elements), System(model, elements, vectorized=False)


def test_every_planar_group_in_one_shared_rotation_against_the_element_loop_and_finite_differences():
    """The arrays of a system whose groups share one rotation (each group placed in rows of all the vectors)
    equal the element methods' (the definition), and Psi_q and gamma equal finite differences of Psi alone:
    gamma = -d^2/ds^2 Psi(q + s q', t + s) at s = 0 (eq. 4.4 along a path of zero acceleration)."""
    system, loop = _mixed_system()
    kinds = {type(group).__name__ for group in system.groups}
    assert kinds == {"RevoluteGroup", "AlongDirectionGroup", "DistanceGroup", "RelativeAngleGroup",
                     "BodyCoordinateGroup"} and not system._loop  # fmt: skip
    rng = np.random.default_rng(4)
    h = 1e-3
    for _ in range(3):
        q, qd, t = rng.standard_normal(9), rng.standard_normal(9), float(rng.uniform(0.1, 2.0))
        for a, b in zip(system.evaluate(q, qd, t), loop.evaluate(q, qd, t), strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-13)

        def psi(s, q=q, qd=qd, t=t):
            return system.constraints(q + s * qd, t + s)

        second = (-psi(2 * h) + 16 * psi(h) - 30 * psi(0.0) + 16 * psi(-h) - psi(-2 * h)) / (12 * h * h)
        np.testing.assert_allclose(system.gamma(q, qd, t), -second, rtol=1e-6, atol=1e-6)
        numeric = np.column_stack(
            [(system.constraints(q + 1e-6 * e, t) - system.constraints(q - 1e-6 * e, t)) / 2e-6 for e in np.eye(9)]
        )
        np.testing.assert_allclose(system.jacobian(q, t), numeric, atol=1e-7)


# -- the lean embedded Runge-Kutta loops ------------------------------------------------------------------------
def _oscillator(omega: float):
    return lambda t, y: np.array([y[1], -omega * omega * y[0]])


@pytest.mark.parametrize("method", ["rk45", "dop853"])
@pytest.mark.parametrize("tol", [1e-6, 1e-10])
def test_lean_integrators_follow_the_harmonic_oscillator(method, tol):
    omega = 3.0
    times = np.linspace(0.0, 5.0, 37)  # output times fall inside steps: the dense output is checked too
    got = np.empty((times.size, 2))

    def record(k, t, y):
        got[k] = y

    stats = integrate(_oscillator(omega), np.array([1.0, 0.0]), times, record, method=method, rtol=tol, atol=tol)
    exact = np.column_stack([np.cos(omega * times), -omega * np.sin(omega * times)])
    assert np.max(np.abs(got - exact)) < 200 * tol
    assert stats.rhs_evaluations > 0 and stats.steps > 0


@pytest.mark.parametrize("lean, reference", [("rk45", "RK45"), ("dop853", "DOP853")])
def test_lean_integrators_take_the_steps_of_solve_ivp(lean, reference):
    """Same pair, same controller: the same number of steps as scipy's class on the same problem."""
    times = np.array([0.0, 4.0])
    counts = []
    for method in (lean, reference):
        stats = integrate(_oscillator(2.0), np.array([1.0, 0.0]), times, lambda k, t, y: None, method=method,
                          rtol=1e-8, atol=1e-8)  # fmt: skip
        counts.append(stats.steps)
    assert abs(counts[0] - counts[1]) <= max(2, 0.05 * counts[1])


# -- stiffness and the evaluation budget ---------------------------------------------------------------------------
def test_spectral_radius_of_a_linear_system():
    A = np.array([[0.0, 1.0, 0.0], [-400.0, 0.0, 0.0], [0.0, 0.0, -3.0]])  # eigenvalues +-20 i and -3

    def f(t, y):
        return A @ y

    y = np.array([1.0, 0.5, -0.2])
    assert spectral_radius(f, 0.0, y, f(0.0, y), iterations=30) == pytest.approx(20.0, rel=1e-3)


def _stiff(t, y):
    return np.array([-1e5 * (y[0] - math.cos(t)), y[0]])


def test_the_stiffness_monitor_reports_a_stiff_problem():
    stats = integrate(_stiff, np.array([1.0, 0.0]), np.array([0.0, 1.0]), lambda k, t, y: None, method="RK45",
                      rtol=1e-6, atol=1e-6)  # fmt: skip
    assert stats.stiffness is not None and stats.stiffness["rho"] == pytest.approx(1e5, rel=0.05)
    with pytest.raises(StiffnessError, match=r"t = .* bounded by stability"):
        integrate(_stiff, np.array([1.0, 0.0]), np.array([0.0, 1.0]), lambda k, t, y: None, method="dop853",
                  rtol=1e-6, atol=1e-6, stiffness="error")  # fmt: skip


def test_no_stiffness_is_reported_for_a_smooth_problem():
    stats = integrate(_oscillator(2.0), np.array([1.0, 0.0]), np.linspace(0, 20, 5), lambda k, t, y: None,
                      method="dop853", rtol=1e-8, atol=1e-8)  # fmt: skip
    assert stats.stiffness is None


def test_the_evaluation_budget_stops_a_run_with_the_time_reached():
    with pytest.raises(BudgetError, match=r"budget of 500 .* by t = "):
        integrate(_stiff, np.array([1.0, 0.0]), np.array([0.0, 10.0]), lambda k, t, y: None, method="RK45",
                  rtol=1e-8, atol=1e-8, max_evaluations=500)  # fmt: skip


# -- guards of forward dynamics ------------------------------------------------------------------------------------
def test_negative_baumgarte_parameters_are_refused():
    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    with pytest.raises(AnalysisError, match="must be >= 0"):
        forward_dynamics(system, q0, qd0, 1.0, 10, "baumgarte", "dop853", alpha=-5.0, beta=-5.0)


def test_the_drift_guard_names_the_time_and_the_constraint():
    system, q0, _ = build_system(load_model(MODELS / "double_pendulum.yaml"))
    guard = Guard(system, q0, 1e-3, 1e-8)
    guard.check_drift(q0, 0.0)  # on the constraints: fine
    moved = q0.copy()
    moved[3] += 0.05  # the lower rod pulled off its pin A by 5 cm: the nearest assembled state is 5 / sqrt(2) cm off
    with pytest.raises(AnalysisError, match=r"drift at t = 0.5 s: the positions are 0.035 m off constraint A\.x"):
        guard.check_drift(moved, 0.5)


def _parallelogram(angle: float) -> dict:
    """Two 0.2 m cranks hanging from (0, 0) and (1, 0), turned by ``angle``, tips joined by a 1 m coupler."""
    tip = 0.2 * np.array([math.sin(angle), -math.cos(angle)])
    bodies, joints = [], []
    for k, x in enumerate((0.0, 1.0)):
        centre = np.array([x, 0.0]) + tip / 2
        bodies.append({"name": f"crank{k}", "mass": 0.5, "inertia": 0.5 * 0.04 / 12, "location": list(centre),
                       "orientation": math.atan2(tip[1], tip[0])})  # fmt: skip
        joints.append({"name": f"O{k}", "type": "revolute", "body1": "ground", "body2": f"crank{k}",
                       "location": [x, 0.0]})  # fmt: skip
    bodies.append({"name": "coupler", "mass": 1.0, "inertia": 1.0 / 12, "location": list(tip + [0.5, 0.0]),
                   "orientation": 0.0})  # fmt: skip
    for k, x in enumerate((0.0, 1.0)):
        joints.append({"name": f"P{k}", "type": "revolute", "body1": f"crank{k}", "body2": "coupler",
                       "location": list(tip + [x, 0.0])})  # fmt: skip
    return {"model": {"name": "parallelogram", "dimension": 2, "gravity": [0.0, -9.81], "bodies": bodies,
                      "joints": joints}}  # fmt: skip


def test_passing_a_change_point_stops_with_the_time_and_the_joints():
    """Released 115 deg from hanging, the parallelogram swings through its collinear (change-point) position,
    where it may turn into an antiparallelogram: the run must not pass silently onto the other branch."""
    system, q0, qd0 = build_system(load_model(_parallelogram(2.0)))
    with pytest.raises(AnalysisError, match=r"singular configuration between t = \S+ s and t = \S+ s.*joints"):
        forward_dynamics(system, q0, qd0, 1.0, 100, "baumgarte", "dop853", rtol=1e-9, atol=1e-9)


def test_a_swing_below_the_change_point_passes_and_reports_its_closest_approach():
    """Released 46 deg from hanging, the parallelogram swings as a compound pendulum: every crank turns by
    theta, (2 (J_c + m_c r^2 / 4) + m r^2) theta'' = -g (2 m_c r / 2 + m r) sin theta."""
    from scipy.integrate import solve_ivp

    system, q0, qd0 = build_system(load_model(_parallelogram(0.8)))
    result = forward_dynamics(system, q0, qd0, 1.0, 100, "baumgarte", "dop853", rtol=1e-10, atol=1e-10)
    assert 0.01 < result.info["closest_singularity"]["ratio"] < 1.0
    r, m_c, m, g = 0.2, 0.5, 1.0, 9.81
    inertia, torque = 2 * (m_c * r * r / 12 + m_c * r * r / 4) + m * r * r, g * (m_c * r + m * r)
    exact = solve_ivp(lambda t, y: [y[1], -torque / inertia * math.sin(y[0])], (0, 1.0), [0.8, 0.0],
                      t_eval=result.t, rtol=1e-12, atol=1e-12).y[0]  # fmt: skip
    np.testing.assert_allclose(result.q[:, 2] + math.pi / 2, exact, atol=1e-7)


def test_partitioning_refuses_a_singular_choice_of_independent_coordinates():
    """The engine's file configuration is at a dead centre, where the piston position fixes nothing."""
    system, q0, qd0 = build_system(load_model(MODELS / "slider_crank_flywheel.yaml"))
    with pytest.raises(AnalysisError, match=r"partitioning at t = 0 s: .*piston\.x.*condition number"):
        forward_dynamics(system, q0, qd0, 0.1, 10, "partitioning", "dop853", independent=["piston.x"])


# -- the method chosen for a scene ----------------------------------------------------------------------------------
def test_auto_takes_an_explicit_method_for_a_smooth_scene_and_radau_for_a_stiff_one():
    model = load_model(MODELS / "double_pendulum.yaml")
    system, q0, qd0 = build_system(model)
    chosen = choose_method(system, mass_matrix(model), build_forces(model), q0, qd0, 10.0, 1e-8)
    assert chosen["formulation"] == "joint-coordinates" and chosen["integrator"] == "dop853"  # an open tree
    closed = load_model(MODELS / "four_bar_spring.yaml")
    system, q0, qd0 = build_system(closed)
    chosen = choose_method(system, mass_matrix(closed), build_forces(closed), q0, qd0, 2.0, 1e-8)
    assert chosen["formulation"] == "baumgarte" and "closed loop" in chosen["why"], chosen
    data = load_model(MODELS / "four_bar_spring.yaml")
    data.spring_dampers[0]["spring_coefficient"] = 1e9
    system, q0, qd0 = build_system(data)
    chosen = choose_method(system, mass_matrix(data), build_forces(data), q0, qd0, 20.0, 1e-8)
    assert chosen["integrator"] == "Radau", chosen


def test_auto_runs_and_says_what_it_chose():
    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    result = forward_dynamics(system, q0, qd0, 0.5, 10, "auto", "auto", rtol=1e-8, atol=1e-8)
    assert result.info["formulation"] == "joint-coordinates" and result.info["integrator"] == "dop853"
    default = forward_dynamics(system, q0, qd0, 0.5, 10, rtol=1e-8, atol=1e-8)  # auto is the default
    assert default.info["formulation"] == "joint-coordinates" and default.info["chosen"] == result.info["chosen"]
    with_options = forward_dynamics(system, q0, qd0, 0.5, 10, rtol=1e-8, atol=1e-8, alpha=10.0, beta=10.0)
    assert with_options.info["formulation"] == "baumgarte"  # options of a formulation keep it among those taking them
    assert "spectral radius" in result.info["chosen"]["why"]


def test_a_spatial_run_with_its_own_masses_is_not_given_to_the_tree_formulation():
    """The spatial joint-coordinate formulation takes masses and inertias from the model, so a run given
    ``masses=`` keeps to the formulations that use them: ``auto`` passes it by, an explicit request is refused."""
    model = load_model(MODELS / "revolute_revolute_skew.yaml")
    system, q0, qd0 = build_system(model)
    masses = mass_matrix(model)
    result = forward_dynamics(system, q0, qd0, 0.1, 2, masses=masses, rtol=1e-8, atol=1e-8)
    assert result.info["formulation"] == "baumgarte" and "masses given" in result.info["chosen"]["why"]
    with pytest.raises(AnalysisError, match="joint-coordinates.*masses"):
        forward_dynamics(system, q0, qd0, 0.1, 2, "joint-coordinates", masses=masses)


@pytest.mark.parametrize(
    "a, b",
    [
        ([1.0, 2.0], [1.0, 2.0 + 2.5e-9]),  # inside atol + rtol |b|
        ([1.0, 2.0], [1.0, 2.0 + 3.5e-9]),  # outside
        ([np.inf, 0.0], [np.inf, 0.0]),  # equal infinities are close
        ([np.inf, 0.0], [-np.inf, 0.0]),
        ([1.0, 0.0], [np.inf, 0.0]),
        ([np.nan, 0.0], [np.nan, 0.0]),  # NaN never
        ([1e6, 0.0], [1e6 * (1 + 0.9e-9), 0.0]),  # the relative part
    ],
)
def test_a_groups_check_gives_np_allclose_verdict(a, b):
    """The batched groups' check at construction (``assembly._close``, one comparison in place of five
    ``np.allclose``) keeps or drops a group exactly where ``np.allclose(rtol=atol=1e-9)`` would."""
    from solutions.assembly import _close

    a, b = np.array(a), np.array(b)
    assert _close(a, b) == np.allclose(a, b, rtol=1e-9, atol=1e-9)
