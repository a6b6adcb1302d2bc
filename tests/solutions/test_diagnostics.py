"""Each diagnostic of a kinematic analysis, triggered by a model that deserves it.

- redundant constraints: a revolute given twice; a parallelogram with an extra parallel link; a second motor
- wrong number of drivers: mechanisms with degrees of freedom left and no motor for them
- lock-up: a crank-rocker driven from its rocker past the toggle position (crank and coupler in line)
- branch point: an isosceles slider-crank at crank angle 90 degrees, where the slider meets the crank pivot
- non-convergence: a linkage whose links cannot close
"""

from __future__ import annotations

import copy
import math
import re

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError, rank_report
from solutions.io.model import load_model
from solutions.kinematics import assemble, kinematic_analysis, newton_raphson


def analyse(model, t_end=1.0, steps=20):
    system, q0, _ = build_system(load_model(model))
    return kinematic_analysis(system, q0, t_end, steps)


def joints_named(message: str) -> set[str]:
    """The joint names listed after 'joints' in a message."""
    match = re.search(r"joints(?: involved)?:? ((?:[\w-]+, )*[\w-]+)", message)
    assert match, message
    return set(match.group(1).split(", "))


# -- redundant constraints ------------------------------------------------------------------------------------
def test_doubled_revolute_is_redundant(four_bar):
    model = four_bar.model(0.3)
    twin = copy.deepcopy(model["model"]["joints"][1])  # joint A, once more
    twin["name"] = "A_again"
    model["model"]["joints"].append(twin)
    with pytest.raises(AnalysisError) as err:
        analyse(model)
    message = str(err.value)
    assert "2 redundant constraint equation(s)" in message
    assert joints_named(message) == {"A", "A_again"}
    system, q0, _ = build_system(load_model(model))
    report = rank_report(system.jacobian(q0, 0.0), system.row_owners)
    assert (report.n_constraints, report.rank, report.n_redundant) == (11, 9, 2)
    assert report.redundant_joints == ["A", "A_again"]


def parallelogram(extra_link: bool, crank=0.2, ground=0.5, theta=math.pi / 3):
    """Crank and rocker of equal length 0.2 on pivots 0.5 apart, coupler 0.5: the coupler translates.
    The extra link, a third crank pivoted at (0.25, 0), is parallel to the other two and adds nothing."""
    A = crank * np.array([math.cos(theta), math.sin(theta)])

    def body(name, centre, phi):
        return {"name": name, "mass": 1.0, "inertia": 0.01, "location": list(map(float, centre)), "orientation": phi}

    bodies = [
        body("crank", A / 2, theta),
        body("coupler", A + [ground / 2, 0], 0.0),
        body("rocker", [ground, 0] + A / 2, theta),
    ]
    joints = [
        {"name": "O", "type": "revolute", "body1": "ground", "body2": "crank", "location": [0.0, 0.0]},
        {"name": "A", "type": "revolute", "body1": "crank", "body2": "coupler", "location": A.tolist()},
        {
            "name": "B",
            "type": "revolute",
            "body1": "coupler",
            "body2": "rocker",
            "location": (A + [ground, 0]).tolist(),
        },
        {"name": "D", "type": "revolute", "body1": "ground", "body2": "rocker", "location": [ground, 0.0]},
    ]
    if extra_link:
        bodies.append(body("extra", [ground / 2, 0] + A / 2, theta))
        joints += [
            {"name": "E1", "type": "revolute", "body1": "ground", "body2": "extra", "location": [ground / 2, 0.0]},
            {
                "name": "E2",
                "type": "revolute",
                "body1": "extra",
                "body2": "coupler",
                "location": (A + [ground / 2, 0]).tolist(),
            },
        ]
    motors = [
        {"name": "drive", "type": "angle", "joint": "O", "function": {"type": "polynomial", "coefficients": [0, 1]}}
    ]
    return {"model": {"name": "parallelogram", "bodies": bodies, "joints": joints, "motors": motors}}


def test_parallelogram_without_extra_link_runs():
    """The control case: the plain parallelogram is not redundant, and its coupler translates (phi = 0)."""
    result = analyse(parallelogram(extra_link=False), 1.0, 10)
    assert np.max(np.abs(result.coordinate("coupler.phi"))) < 1e-12
    theta = math.pi / 3 + result.t
    assert np.max(np.abs(result.coordinate("coupler.x") - (0.2 * np.cos(theta) + 0.25))) < 1e-12


def test_parallelogram_with_extra_parallel_link_is_redundant():
    model = parallelogram(extra_link=True)
    with pytest.raises(AnalysisError) as err:
        analyse(model)
    message = str(err.value)
    assert "1 redundant constraint equation(s)" in message
    named = joints_named(message)
    assert {"E1", "E2"} <= named <= {"O", "A", "B", "D", "E1", "E2"}
    system, q0, _ = build_system(load_model(model))
    report = rank_report(system.jacobian(q0, 0.0), system.row_owners)
    assert report.n_redundant == 1 and report.degrees_of_freedom == 0


def test_second_motor_on_a_four_bar_is_redundant(four_bar):
    model = four_bar.model(0.3)
    model["model"]["motors"].append({"name": "drive2", "type": "angle", "joint": "D", "function": 0.0})
    with pytest.raises(AnalysisError, match="1 redundant constraint") as err:
        analyse(model)
    assert {"drive", "drive2"} <= joints_named(str(err.value))


# -- wrong number of drivers ----------------------------------------------------------------------------------
def free_body_model():
    bodies = [{"name": "puck", "mass": 1.0, "inertia": 0.01, "location": [0.0, 0.0]}]
    return {"model": {"name": "free body", "bodies": bodies}}


@pytest.mark.parametrize(
    "case, dof",
    [("four-bar without motor", 1), ("four-bar and a free body", 4), ("free body", 3)],
)
def test_degrees_of_freedom_left_are_refused(four_bar, case, dof):
    if case == "free body":
        model = free_body_model()
    else:
        model = four_bar.model(0.3, motor=None)
        if case == "four-bar and a free body":
            model["model"]["bodies"] += free_body_model()["model"]["bodies"]
    with pytest.raises(AnalysisError) as err:
        analyse(model)
    message = str(err.value)
    assert f"leave {dof} degree(s) of freedom" in message
    assert f"needs {dof} more motor(s)" in message
    assert "dynamic" in message  # what to do instead


# -- lock-up and branch points --------------------------------------------------------------------------------
def test_four_bar_driven_past_its_toggle_position(four_bar):
    """A crank-rocker driven from the rocker at 1 rad/s. The rocker's range ends where crank and coupler lie in
    line, |O2 B| = b - a: |O2 B|^2 = d^2 + c^2 + 2 c d cos(theta4) gives the limit theta4 in closed form."""
    a, b, c, d = four_bar.a, four_bar.b, four_bar.c, four_bar.d
    model = four_bar.model(0.0, motor="rocker", function={"type": "polynomial", "coefficients": [0.0, 1.0]})
    _, theta4_start = four_bar.angles(0.0)
    theta4_limit = math.acos(((b - a) ** 2 - d**2 - c**2) / (2 * c * d))
    t_toggle = theta4_limit - theta4_start
    steps, t_end = 100, 1.0
    dt = t_end / steps
    with pytest.raises(AnalysisError) as err:
        analyse(model, t_end, steps)
    message = str(err.value)
    assert "lock-up or branch point" in message
    t_reported = float(re.search(r"near t = ([0-9.eE+-]+) s", message).group(1))
    assert t_toggle < t_reported <= t_toggle + dt + 1e-12, (t_toggle, message)
    cond = float(re.search(r"condition number ([0-9.eE+-]+)", message).group(1))
    system, q0, _ = build_system(load_model(model))
    q, _ = assemble(system, q0)
    s = np.linalg.svd(system.jacobian(q, 0.0), compute_uv=False)
    assert cond > 5.0 * s[0] / s[-1], "the reported condition number should show the near-singular Jacobian"
    assert {"A", "B"} <= joints_named(message)  # the crank-coupler-rocker chain that locks


def isosceles_slider_crank(r=0.1):
    """Crank r, rod r: at crank angle 90 degrees the slider sits on the crank pivot and may go either way."""

    def body(name, x):
        return {"name": name, "mass": 1.0, "inertia": 0.01, "location": [x, 0.0]}

    joints = [
        {"name": "O", "type": "revolute", "body1": "ground", "body2": "crank", "location": [0.0, 0.0]},
        {"name": "A", "type": "revolute", "body1": "crank", "body2": "rod", "location": [r, 0.0]},
        {"name": "B", "type": "revolute", "body1": "rod", "body2": "slider", "location": [2 * r, 0.0]},
        {
            "name": "S",
            "type": "prismatic",
            "body1": "ground",
            "body2": "slider",
            "location": [2 * r, 0.0],
            "axis": [1, 0],
        },
    ]
    motors = [
        {"name": "drive", "type": "angle", "joint": "O", "function": {"type": "polynomial", "coefficients": [0, 10]}}
    ]
    bodies = [body("crank", r / 2), body("rod", 1.5 * r), body("slider", 2 * r)]
    return {"model": {"name": "isosceles slider-crank", "bodies": bodies, "joints": joints, "motors": motors}}


def test_branch_point_of_isosceles_slider_crank():
    """The output grid hits t = pi/20 (crank at 90 degrees) exactly: Psi_q is singular there."""
    with pytest.raises(AnalysisError) as err:
        analyse(isosceles_slider_crank(), math.pi / 10, 10)
    message = str(err.value)
    assert "lock-up or branch point" in message
    assert float(re.search(r"t = ([0-9.eE+-]+) s", message).group(1)) == pytest.approx(math.pi / 20, rel=1e-5)
    assert float(re.search(r"condition number ([0-9.eE+-]+)", message).group(1)) > 1e10
    assert {"A", "B", "S"} <= joints_named(message)


def test_isosceles_slider_crank_runs_before_its_branch_point():
    """Control: up to 80 degrees the same model runs and follows x = 2 r cos(theta)."""
    result = analyse(isosceles_slider_crank(), 0.14, 14)
    assert np.max(np.abs(result.coordinate("slider.x") - 0.2 * np.cos(10 * result.t))) < 1e-10


# -- non-convergence ------------------------------------------------------------------------------------------
def test_linkage_that_cannot_close(four_bar):
    """Links 0.1 + 0.35 + 0.3 = 0.75 cannot reach a pivot 1.0 away: Newton-Raphson fails, by name."""
    model = four_bar.model(0.0, frame="body")
    for joint in model["model"]["joints"]:
        if joint["name"] == "D":
            joint["point1"] = [1.0, 0.0]
    system, q0, _ = build_system(load_model(model))
    with pytest.raises(AnalysisError) as err:
        kinematic_analysis(system, q0, 1.0, 10)
    message = str(err.value)
    assert "cannot be assembled" in message
    residual = float(re.search(r"residual ([0-9.eE+-]+)", message).group(1))
    assert residual > 0.05  # at least part of the 0.25 m gap is left
    worst = re.search(r"worst constraint (\S+)", message).group(1)
    assert worst in system.labels


def test_newton_raphson_reports_residual_and_worst_constraint(four_bar):
    """Too few iterations from far away: the message names the residual and the worst row."""
    system, q0, _ = build_system(load_model(four_bar.model(0.0)))
    q_far = q0 + 0.3
    with pytest.raises(AnalysisError) as err:
        newton_raphson(system, q_far, 0.0, max_iterations=1)
    message = str(err.value)
    assert "did not converge at t = 0 s" in message and "after 1 iterations" in message
    residual = float(re.search(r"residual ([0-9.eE+-]+)", message).group(1))
    worst = re.search(r"worst constraint (\S+)", message).group(1)
    # the reported residual is the largest |Psi| after the one step, and belongs to the named row
    q_one = q_far + np.linalg.solve(system.jacobian(q_far, 0.0), -system.constraints(q_far, 0.0))
    psi = system.constraints(q_one, 0.0)
    assert residual == pytest.approx(np.max(np.abs(psi)), rel=1e-2)
    assert worst == system.labels[int(np.argmax(np.abs(psi)))]


def test_rank_report_counts():
    """Rank by SVD on a matrix with known structure: 4 rows, row 3 = row 1 + row 2, 5 columns."""
    jac = np.array(
        [
            [1.0, 0.0, 2.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 3.0, 0.0],
            [1.0, 1.0, 2.0, 3.0, 0.0],
            [0.0, 0.0, 0.0, 0.0, 1.0],
        ]
    )
    report = rank_report(jac, ["p", "q", "r", "s"])
    assert (report.rank, report.n_redundant, report.degrees_of_freedom) == (3, 1, 2)
    assert report.redundant_joints == ["p", "q", "r"]
    assert report.condition_number > 1e12


def test_branch_point_between_output_steps_is_reported():
    """A parallelogram four-bar passes its change point (all links collinear) when the crank angle is pi;
    the grid never lands on it, yet det(Psi_q) changes sign between two steps and the run says so."""
    crank, ground, phi0 = 0.1, 0.4, 0.3
    a = [crank * math.cos(phi0), crank * math.sin(phi0)]
    spec = {
        "model": {
            "bodies": [
                {"name": "crank", "mass": 1, "inertia": 0.01, "location": [a[0] / 2, a[1] / 2], "orientation": phi0},
                {"name": "coupler", "mass": 1, "inertia": 0.01, "location": [a[0] + ground / 2, a[1]]},
                {
                    "name": "rocker",
                    "mass": 1,
                    "inertia": 0.01,
                    "location": [ground + a[0] / 2, a[1] / 2],
                    "orientation": phi0,
                },
            ],
            "joints": [
                {"name": "O", "type": "revolute", "body1": "ground", "body2": "crank", "location": [0, 0]},
                {"name": "A", "type": "revolute", "body1": "crank", "body2": "coupler", "location": a},
                {
                    "name": "B",
                    "type": "revolute",
                    "body1": "coupler",
                    "body2": "rocker",
                    "location": [a[0] + ground, a[1]],
                },
                {"name": "C", "type": "revolute", "body1": "rocker", "body2": "ground", "location": [ground, 0]},
            ],
            "motors": [
                {
                    "name": "drive",
                    "type": "angle",
                    "joint": "O",
                    "function": {"type": "polynomial", "coefficients": [0, 10.0]},
                }
            ],
        }
    }
    system, q0, _ = build_system(load_model(spec))
    t_change = (math.pi - phi0) / 10.0
    with pytest.raises(AnalysisError, match="branch point passed between") as info:
        kinematic_analysis(system, q0, t_end=0.6, steps=97)
    first, second = (float(x) for x in re.findall(r"t = ([0-9.]+) s", str(info.value)))
    assert first < t_change < second
