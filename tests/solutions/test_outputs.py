"""Outputs users ask for (issue 18): --point for spatial bodies and in every analysis, angular velocities and
rotation matrices of spatial bodies, driver efforts under one name, drift advice that names something new."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from solutions.cli import main
from solutions.dynamics import drift_warnings
from solutions.io.model import load_model

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"


def hand_matrix(p) -> np.ndarray:
    e0, e1, e2, e3 = p / np.linalg.norm(p)
    return 2 * np.array(
        [
            [e0**2 + e1**2 - 0.5, e1 * e2 - e0 * e3, e1 * e3 + e0 * e2],
            [e1 * e2 + e0 * e3, e0**2 + e2**2 - 0.5, e2 * e3 - e0 * e1],
            [e1 * e3 - e0 * e2, e2 * e3 + e0 * e1, e0**2 + e3**2 - 0.5],
        ]
    )


@pytest.mark.parametrize("analysis", ["kinematic", "inverse"])
def test_spatial_point_is_r_plus_A_s(tmp_path, analysis):
    model = load_model(MODELS / "spatial_slider_crank.yaml")
    rod = model.bodies[1]
    P = np.array([0.05, 0.1, 0.01])
    s = hand_matrix(rod.orientation).T @ (P - rod.location)
    out = tmp_path / "r.npz"
    argv = ["run", str(MODELS / "spatial_slider_crank.yaml"), "--analysis", analysis, "--t-end", "0.2"]
    assert main([*argv, "--steps", "200", "--point", "P=rod:0.05,0.1,0.01", "--rotations", "--out", str(out)]) == 0
    z = np.load(out)
    r = np.column_stack([z["rod.x"], z["rod.y"], z["rod.z"]])
    p = np.column_stack([z[f"rod.e{k}"] for k in range(4)])
    A = np.array([hand_matrix(pk) for pk in p])
    expected = r + A @ s
    got = np.column_stack([z["P.x"], z["P.y"], z["P.z"]])
    np.testing.assert_allclose(got, expected, atol=1e-12)
    h = z["t"][1] - z["t"][0]
    velocity = np.column_stack([z["P.x_d"], z["P.y_d"], z["P.z_d"]])
    acceleration = np.column_stack([z["P.x_dd"], z["P.y_dd"], z["P.z_dd"]])
    np.testing.assert_allclose(velocity[1:-1], (got[2:] - got[:-2]) / (2 * h), atol=1e-5)
    np.testing.assert_allclose(acceleration[1:-1], (velocity[2:] - velocity[:-2]) / (2 * h), atol=1e-3)
    np.testing.assert_allclose(
        np.column_stack([z[f"rod.A{i}{j}"] for i in (1, 2, 3) for j in (1, 2, 3)]), A.reshape(-1, 9), atol=1e-14
    )
    omega = np.column_stack([z["rod.wx"], z["rod.wy"], z["rod.wz"]])
    local = np.column_stack([z["rod.wx_body"], z["rod.wy_body"], z["rod.wz_body"]])
    np.testing.assert_allclose(np.einsum("kji,kj->ki", A, omega), local, atol=1e-12)
    # omega~ = A' A^T: the angular velocity from the rotation matrices by finite differences
    Ad = (A[2:] - A[:-2]) / (2 * h)
    W = Ad @ np.transpose(A[1:-1], (0, 2, 1))
    np.testing.assert_allclose(np.column_stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]]), omega[1:-1], atol=1e-4)
    if analysis == "inverse":
        assert "drive.effort" in z.files


def test_point_in_a_dynamic_run_and_one_effort_name(tmp_path):
    model = load_model(MODELS / "slider_crank.yaml")
    b = model.bodies[1]
    P = b.location + np.array([0.1, 0.05])
    out = tmp_path / "d.npz"
    path = str(MODELS / "slider_crank.yaml")
    point = f"P={b.name}:{float(P[0])!r},{float(P[1])!r}"
    assert (
        main(
            [
                "run",
                path,
                "--analysis",
                "dynamic",
                "--t-end",
                "0.1",
                "--steps",
                "5",
                "--point",
                point,
                "--out",
                str(out),
            ]
        )
        == 0
    )
    z = np.load(out)
    c, s = np.cos(b.orientation), np.sin(b.orientation)
    local = np.array([[c, s], [-s, c]]) @ (P - b.location)
    phi = z[f"{b.name}.phi"]
    expected_x = z[f"{b.name}.x"] + np.cos(phi) * local[0] - np.sin(phi) * local[1]
    np.testing.assert_allclose(z["P.x"], expected_x, atol=1e-12)
    efforts = [k for k in z.files if k.endswith(".effort")]
    assert efforts == [f"{m['name']}.effort" for m in model.motors]


def test_rotations_of_a_planar_model_are_refused(capsys):
    assert main(["run", str(MODELS / "four_bar.yaml"), "--rotations"]) == 2
    assert "--rotations: a planar body" in capsys.readouterr().err


@pytest.mark.parametrize("formulation", ["baumgarte", "projection", "augmented-lagrangian", "qr", "svd"])
def test_drift_advice_names_something_new(formulation):
    info = {"max_constraint_residual": 1e-3}
    (warning,) = drift_warnings(info, 1.0, formulation, {})
    advice = warning.split("try ", 1)[1]
    assert f"--formulation {formulation}" not in advice, warning
    assert "--" in advice
