"""Plots of results: what each figure shows, and what it refuses."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.io.model import load_model
from solutions.kinematics import kinematic_analysis
from solutions.plotting import (
    coordinates_figure,
    drift_figure,
    energy_figure,
    paths_figure,
    plot_result,
    reaction_columns,
    reactions_figure,
    residuals,
    work_precision_figure,
)

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"


@pytest.fixture(scope="module")
def kinematic():
    model = load_model(MODELS / "slider_crank.yaml")
    system, q0, _ = build_system(model)
    return model, system, kinematic_analysis(system, q0, 2 * math.pi / 10, 20)


@pytest.fixture(scope="module")
def dynamic():
    model = load_model(MODELS / "double_pendulum.yaml")
    system, q0, qd0 = build_system(model)
    return model, system, forward_dynamics(system, q0, qd0, 0.5, 20)


def lines(ax) -> dict[str, np.ndarray]:
    return {line.get_label(): np.asarray(line.get_ydata()) for line in ax.get_lines()}


def test_coordinates_figure_has_a_panel_per_kind(kinematic):
    _, _, result = kinematic
    fig = coordinates_figure(result, ["slider.x", "crank.phi", "rod.phi"])
    assert [ax.get_ylabel() for ax in fig.axes] == ["x [m]", "phi [rad]"]
    assert np.array_equal(lines(fig.axes[0])["slider.x"], result.coordinate("slider.x"))
    with pytest.raises(ValueError, match="--coords nope"):
        coordinates_figure(result, ["nope"])


def test_plot_result_writes_a_png_without_residual_or_energy_panels(dynamic, tmp_path):
    _, _, result = dynamic
    assert "energy.kinetic" in result.points and "residual.position" in result.points
    path = plot_result(result, tmp_path / "run.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    kinds = {ax.get_ylabel() for ax in coordinates_figure(result).axes}
    assert kinds == {"x [m]", "y [m]", "phi [rad]"}


def test_paths_figure_draws_the_moving_joints(kinematic):
    model, _, result = kinematic
    ax = paths_figure(model, result).axes[0]
    labels = {line.get_label() for line in ax.get_lines()}
    assert {"path of A", "path of B"} <= labels and "path of O" not in labels  # O is the fixed pivot
    with pytest.raises(ValueError, match="planar"):
        spatial = load_model(MODELS / "spatial_double_pendulum.yaml")
        paths_figure(spatial, result)


def test_reactions_from_the_multipliers_balance_the_pendulum(dynamic):
    """At every output time the upper pin's reaction on the upper rod plus the lower pin's on the lower
    rod equal sum m a - m g (Newton's law for the whole pendulum, which the multipliers do not know)."""
    model, system, result = dynamic
    columns = reaction_columns(system, result)
    masses = np.array([b.mass for b in model.bodies])
    total = np.einsum("k,nkj->nj", masses, result.qdd.reshape(len(result.t), -1, 3)[:, :, :2])
    weight = masses.sum() * np.asarray(model.gravity)
    force = np.column_stack([columns["O.Fx"], columns["O.Fy"]])
    np.testing.assert_allclose(force, total - weight, atol=1e-6)
    fig = reactions_figure(system, result, ["O"])
    assert len(fig.axes) == 1  # a pin takes no moment: no moment panel
    with pytest.raises(ValueError, match=r"no reactions of X \(joints: O, A\)"):
        reactions_figure(system, result, ["X"])


def test_reactions_need_multipliers(kinematic):
    _, system, result = kinematic
    with pytest.raises(ValueError, match="no Lagrange multipliers"):
        reaction_columns(system, result)


def test_energy_and_drift_figures(dynamic, kinematic):
    _, system, result = dynamic
    fig = energy_figure(result)
    assert np.array_equal(fig.axes[1].get_lines()[0].get_ydata(), result.points["energy.error"])
    with pytest.raises(ValueError, match="no energy columns"):
        energy_figure(kinematic[2])
    # a kinematic result has no stored residuals: they are computed from the system
    _, k_system, k_result = kinematic
    computed = residuals(k_system, k_result)
    expected = [np.abs(k_system.constraints(q, t)).max() for q, t in zip(k_result.q, k_result.t, strict=True)]
    np.testing.assert_allclose(computed["residual.position"], expected)
    fig = drift_figure({"dynamic": result}, system)
    assert len(fig.axes) == 2


def test_work_precision_figure_has_a_line_per_method():
    rows = [
        {"method": "rk4", "error": 1e-4, "seconds": 0.01},
        {"method": "rk4", "error": 1e-6, "seconds": 0.04},
        {"method": "RK45", "error": 1e-5, "seconds": 0.02},
    ]
    ax = work_precision_figure(rows).axes[0]
    assert sorted(line.get_label() for line in ax.get_lines()) == ["RK45", "rk4"]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
