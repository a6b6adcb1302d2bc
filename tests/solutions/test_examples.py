"""The example models of course/models: each loads, each kinematic one runs a full cycle, and the geometry
each header states holds (closed forms derived by hand from that geometry, not from the solver).
Also: the kinematics benchmark runs (``--quick``; no timing is checked).
"""

from __future__ import annotations

import math
import subprocess
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import scipy.special

from solutions.analysis import choose_analysis, run_analysis
from solutions.assembly import build_system
from solutions.cli import main
from solutions.diagnostics import rank_report
from solutions.io.model import load_model
from solutions.kinematics import assemble, kinematic_analysis
from solutions.settings import read_settings

REPO = Path(__file__).resolve().parents[2]
MODELS = sorted((REPO / "course" / "models").glob("*.yaml"))


def _is_kinematic(path: Path) -> bool:
    """Drivers leave no degree of freedom, by the rank of Psi_q as ``mbd run`` decides (``choose_analysis``: a
    count n - m says 0 for parallel_swing.yaml, whose redundant row leaves it one); a file that fails to load fails
    its own test below."""
    try:
        system, q0, _ = build_system(load_model(path))
        return choose_analysis(system, q0) == "kinematic"
    except Exception:
        return False


KINEMATIC = [p for p in MODELS if _is_kinematic(p)]


@cache
def simulate(name: str):
    """Kinematic analysis of a model file over its ``simulation`` block: (system, result)."""
    model = load_model(REPO / "course" / "models" / name)
    system, q0, _ = build_system(model)
    result = kinematic_analysis(system, q0, model.simulation["end_time"], model.simulation["output_steps"])
    return system, result


def test_the_examples_are_there():
    names = {p.name for p in MODELS}
    for expected in (
        "slider_crank.yaml",
        "offset_slider_crank.yaml",
        "four_bar.yaml",
        "quick_return.yaml",
        "six_bar.yaml",
        "gear_train.yaml",
        "rack_pinion.yaml",
        "cam_follower.yaml",
        "cam_flat_follower.yaml",
    ):
        assert expected in names
        assert REPO / "course" / "models" / expected in KINEMATIC


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.name)
def test_example_loads_and_builds(path):
    model = load_model(path)
    system, q0, _ = build_system(model)
    assert system.n_coordinates == q0.size
    assert model.simulation["end_time"] > 0 and model.simulation["output_steps"] > 0


@pytest.mark.parametrize("path", KINEMATIC, ids=lambda p: p.name)
def test_kinematic_example_runs_a_full_cycle(path):
    system, result = simulate(path.name)
    model = system.model
    assert result.t[-1] == pytest.approx(model.simulation["end_time"])
    assert result.t.size == model.simulation["output_steps"] + 1
    residual = max(np.max(np.abs(system.constraints(q, t))) for q, t in zip(result.q, result.t, strict=True))
    assert residual < 1e-9
    assert np.all(np.isfinite(result.qd)) and np.all(np.isfinite(result.qdd))


@pytest.mark.parametrize("path", KINEMATIC, ids=lambda p: p.name)
def test_file_configuration_is_close_to_the_assembled_one(path):
    """The file's configuration is (nearly) consistent, so assembly stays on the branch the file draws."""
    system, q0, _ = build_system(load_model(path))
    q, _ = assemble(system, q0, 0.0)
    assert np.max(np.abs(q - q0)) < 1e-3
    # and a configuration a little off (1 mm; planar angles 0.01 rad) assembles back onto the same one
    scale = np.full(q0.size, 1e-3)
    if system.coordinates_per_body == 3:
        scale[2::3] = 1e-2
    perturbed = q0 + np.random.default_rng(2).uniform(-1.0, 1.0, q0.size) * scale
    q_again, _ = assemble(system, perturbed, 0.0)
    assert np.max(np.abs(q_again - q)) < 1e-9


# -- closed forms of the geometry in the headers -------------------------------------------------------------
def offset_slider_crank(t, r=0.1, l=0.41, e=0.09, w=10.0):
    """Slider on the line y = e: x = r cos(theta) + sqrt(l^2 - (r sin(theta) - e)^2), theta = w t.

    With u = r sin(theta) - e, u' = r cos(theta), u'' = -r sin(theta), S = sqrt(l^2 - u^2):
    dx/dtheta = -r sin(theta) - u u' / S,
    d2x/dtheta2 = -r cos(theta) - (u'^2 + u u'') / S - u^2 u'^2 / S^3; x' = w dx/dtheta, x'' = w^2 d2x/dtheta2.
    """
    theta = w * t
    u, du, ddu = r * np.sin(theta) - e, r * np.cos(theta), -r * np.sin(theta)
    s = np.sqrt(l**2 - u**2)
    x = r * np.cos(theta) + s
    dx = -r * np.sin(theta) - u * du / s
    ddx = -r * np.cos(theta) - (du**2 + u * ddu) / s - u**2 * du**2 / s**3
    return x, w * dx, w**2 * ddx


def test_offset_slider_crank_closed_form():
    _, result = simulate("offset_slider_crank.yaml")
    x, xd, xdd = offset_slider_crank(result.t)
    assert np.max(np.abs(result.coordinate("slider.x") - x)) < 1e-9
    assert np.max(np.abs(result.coordinate("slider.x", 1) - xd)) < 1e-9
    assert np.max(np.abs(result.coordinate("slider.x", 2) - xdd)) < 1e-9
    assert np.max(np.abs(result.coordinate("slider.y") - 0.09)) < 1e-12
    # the mechanism really is offset: the slider's dead centres are not half a turn apart
    theta_far = 10.0 * result.t[np.argmax(result.coordinate("slider.x"))]
    assert theta_far == pytest.approx(math.asin(0.09 / 0.51), abs=0.05)


def quick_return_ram(t):
    """Crank C = (0, 0.3), r = 0.15, theta = pi/2 + 2 pi t; lever O-D = 0.6 through the pin; link 0.25; ram y = 0.67."""
    theta = math.pi / 2 + 2 * math.pi * t
    pin = np.array([0.15 * math.cos(theta), 0.3 + 0.15 * math.sin(theta)])
    d = 0.6 * pin / np.linalg.norm(pin)
    return d[0] + math.sqrt(0.25**2 - (0.67 - d[1]) ** 2)


def cam_roller(t, e=0.01, a=0.05):
    """Roller centre on the pitch circle (radius a, centre e (cos, sin)(phi)) and on the line x = 0."""
    phi = math.pi / 2 + 10 * math.pi * t
    return e * math.sin(phi) + math.sqrt(a**2 - (e * math.cos(phi)) ** 2)


@pytest.mark.parametrize(
    "name, column, expected",
    [
        ("quick_return.yaml", "ram.x", quick_return_ram),
        ("gear_train.yaml", "gear2.phi", lambda t: -10.0 * 0.04 / 0.08 * t),
        ("gear_train.yaml", "gear3.phi", lambda t: 10.0 * 0.04 / 0.06 * t),
        ("rack_pinion.yaml", "rack.x", lambda t: 0.05 * 2 * math.pi * t),
        ("cam_follower.yaml", "follower.y", lambda t: cam_roller(t) + 0.075),  # centre 75 mm above the roller
        ("cam_flat_follower.yaml", "follower.y", lambda t: 0.04 + 0.01 * math.cos(10 * math.pi * t) + 0.075),
    ],
)
def test_example_closed_form_position(name, column, expected):
    _, result = simulate(name)
    exact = np.array([expected(t) for t in result.t])
    assert np.max(np.abs(result.coordinate(column) - exact)) < 1e-9


def test_quick_return_time_ratio():
    """Cutting stroke (ram moving -x) 240 deg of crank, return 120 deg: ram extremes at theta = 210, 330 deg."""
    _, result = simulate("quick_return.yaml")
    theta = np.degrees(math.pi / 2 + 2 * math.pi * result.t)
    assert theta[np.argmin(result.coordinate("ram.x"))] == pytest.approx(210.0, abs=1.0)
    assert theta[np.argmax(result.coordinate("ram.x"))] == pytest.approx(330.0, abs=1.0)


def test_kinematics_benchmark_quick_runs():
    done = subprocess.run(
        [sys.executable, str(REPO / "benchmarks" / "kinematics.py"), "--quick"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=REPO,
    )
    assert done.returncode == 0, done.stderr
    for row in ("| four_bar.yaml |", "| six_bar.yaml |", "| 1 | 3 | 9 |", "| 4 | 9 | 27 |"):
        assert row in done.stdout
    assert "failed" not in done.stdout


# -- redundant constraints: the parallel swing ---------------------------------------------------------------
def test_mbd_check_and_run_report_the_parallel_swings_redundant_equation(capsys):
    """12 coordinates and 12 equations count no freedom; the rank says one equation repeats the others."""
    assert main(["check", str(REPO / "course" / "models" / "parallel_swing.yaml")]) == 0
    out = capsys.readouterr().out
    assert "coordinates: 12, constraint equations: 12, rank: 11" in out
    assert "degrees of freedom: 1" in out and "redundant equations: 1 (joints: " in out
    assert main(["run", str(REPO / "course" / "models" / "parallel_swing.yaml"), "--t-end", "0.05"]) == 0
    out = capsys.readouterr().out  # mbd run says what the redundancy means for the reactions
    assert "formulation: augmented-lagrangian" in out and "note: redundant constraints: the multipliers" in out


def test_parallel_swing_translates_and_swings_as_its_pendulum():
    """``mbd run``'s analysis of the file (auto) against the closed form of its header: the platform keeps its
    angle, its middle pin stays on the middle arm's circle, and the arms' angle psi from the downward vertical is
    the pendulum psi'' = -omega0^2 sin(psi) released at psi0 = 60 deg: sin(psi / 2) = k sn(K(k) - omega0 t; k)."""
    model = load_model(REPO / "course" / "models" / "parallel_swing.yaml")
    system, q0, qd0 = build_system(model)
    result = run_analysis(system, q0, qd0, read_settings(model.simulation))
    assert result.info["formulation"] == "augmented-lagrangian" and "not unique" in result.info["notes"][0]
    for q in result.q[::50]:  # rank 11 of 12 all along, not at the start only
        assert rank_report(system.jacobian(q, 0.0), system.row_owners).n_redundant == 1
    bodies = {body.name: body for body in model.bodies}
    arm, platform, g, length = bodies["arm1"], bodies["platform"], 9.81, 0.4
    moment = 3 * (arm.inertia + arm.mass * length**2 / 4) + platform.mass * length**2  # about the pivots
    omega0 = math.sqrt(g * length * (1.5 * arm.mass + platform.mass) / moment)
    k = math.sin(math.radians(60) / 2)
    psi = 2 * np.arcsin(k * scipy.special.ellipj(scipy.special.ellipk(k * k) - omega0 * result.t, k * k)[0])
    assert np.max(np.abs(psi)) == pytest.approx(math.radians(60), abs=1e-3)  # it swings to both sides
    for name in ("arm1", "arm2", "arm3"):  # body x axis along the arm, from the pivot down
        assert np.max(np.abs(result.coordinate(f"{name}.phi") - (psi - math.pi / 2))) < 1e-7
    assert np.max(np.abs(result.coordinate("platform.phi"))) < 1e-12
    x, y = result.coordinate("platform.x"), result.coordinate("platform.y")
    assert np.max(np.abs(x - (0.3 + length * np.sin(psi)))) < 1e-7
    assert np.max(np.abs(y + length * np.cos(psi))) < 1e-7
    # the joint forces are not unique, their resultant on the swing is: the three pivots carry the momentum's rate
    masses = np.array([body.mass for body in model.bodies])
    momentum_rate = sum(m * result.qdd[:, 3 * k : 3 * k + 2] for k, m in enumerate(masses)) + [0.0, g * masses.sum()]
    pivots = sum(np.stack([result.reactions[f"O{k}.Fx"], result.reactions[f"O{k}.Fy"]], axis=1) for k in (1, 2, 3))
    assert np.max(np.abs(pivots - momentum_rate)) < 1e-7 * np.max(np.abs(momentum_rate))
