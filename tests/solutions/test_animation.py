"""The mechanism drawing and its animation: geometry from the model file, placed by body coordinates."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from solutions.animation import (
    animate_result,
    body_frame,
    draw_mechanism,
    joint_paths,
    mechanism_geometry,
    planar_rotation,
    spatial_rotation,
    zigzag,
)
from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.io.model import load_model
from solutions.kinematics import assemble, kinematic_analysis

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"


@pytest.fixture(scope="module")
def slider_crank():
    model = load_model(MODELS / "slider_crank.yaml")
    system, q0, qd0 = build_system(model)
    return model, system, kinematic_analysis(system, q0, 2 * math.pi / 10, 40)


def test_rotations_match_rodrigues():
    phi = 0.83
    assert np.allclose(planar_rotation(phi) @ [1.0, 0.0], [math.cos(phi), math.sin(phi)])
    u, chi = np.array([2.0, -1.0, 2.0]) / 3.0, 1.1
    u_tilde = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    rodrigues = np.eye(3) + math.sin(chi) * u_tilde + (1 - math.cos(chi)) * u_tilde @ u_tilde
    p = np.concatenate([[math.cos(chi / 2)], u * math.sin(chi / 2)])
    assert np.allclose(spatial_rotation(p), rodrigues, atol=1e-14)
    assert np.allclose(spatial_rotation(3.0 * p), rodrigues, atol=1e-14)  # normalized first


def test_geometry_places_the_file_points_in_the_file_configuration(slider_crank):
    model, system, _ = slider_crank
    geometry = mechanism_geometry(model)
    q0 = np.concatenate([[*b.location, b.orientation] for b in model.bodies])
    placed = {name: a.at(q0, 2) for name, a in geometry.joints}
    for spec in model.joints:
        assert np.allclose(placed[spec["name"]], spec["location"], atol=1e-12)
    assert [len(shapes) for shapes in geometry.shapes] == [1, 1, 1]
    assert len(geometry.rails) == 1 and np.allclose(geometry.rails[0][2], [1.0, 0.0])


def test_both_halves_of_every_joint_stay_together_along_a_run(slider_crank):
    """A joint's point as fixed in body1 and as fixed in body2 coincide wherever Psi = 0 holds."""
    model, system, result = slider_crank
    geometry = mechanism_geometry(model)
    # the body-frame points of the geometry are those of the constraint elements
    for element in system.elements:
        if hasattr(element, "si") and type(element).__name__ == "Revolute":
            for q in result.q[::7]:
                ri, Ai = body_frame(q, element.i, 2)
                rj, Aj = body_frame(q, element.j, 2)
                assert np.allclose(ri + Ai @ element.si, rj + Aj @ element.sj, atol=1e-9)
    crank_pin = dict(geometry.joints)["A"]
    path = joint_paths(geometry, result)["A"]
    assert np.allclose(np.hypot(path[:, 0], path[:, 1]), 0.1, atol=1e-9)  # the crank pin runs on its circle
    assert np.allclose(path[0], crank_pin.at(result.q[0], 2))
    with pytest.raises(ValueError, match="no moving joint named X"):
        joint_paths(geometry, result, ["X"])


def test_a_body_held_at_one_point_is_drawn_as_a_uniform_link():
    model = load_model(MODELS / "double_pendulum.yaml")
    geometry = mechanism_geometry(model)
    lower = geometry.shapes[1][0]  # held at A only: A, its centre, and the mirror of A
    assert len(lower) == 3 and np.allclose(lower[0], -lower[-1]) and np.allclose(lower[1], 0.0)


def test_zigzag_spans_the_two_points_within_its_width():
    start, end = np.array([0.0, 0.0]), np.array([3.0, 4.0])
    line = zigzag(start, end, width=0.2, coils=6)
    assert np.allclose(line[0], start) and np.allclose(line[-1], end)
    u = (end - start) / 5.0
    offsets = (line - start) @ np.array([-u[1], u[0]])
    assert np.max(np.abs(offsets)) == pytest.approx(0.1)
    spatial = zigzag(np.zeros(3), np.array([0.0, 0.0, 2.0]), width=0.1)
    assert (
        np.allclose(spatial[:, 2], np.clip(spatial[:, 2], 0.0, 2.0)) and np.max(np.abs(spatial[:, :2])) <= 0.05 + 1e-12
    )


def test_animation_writes_a_gif(slider_crank, tmp_path):
    model, system, result = slider_crank
    anim = animate_result(model, system, result, tmp_path / "run.gif", max_frames=8, trace=["B"])
    with Image.open(tmp_path / "run.gif") as gif:
        assert gif.n_frames == len(range(0, 41, math.ceil(41 / 8))) + 1  # every 6th point, and the last
    assert anim is not None


def test_animation_refusals(slider_crank, tmp_path):
    model, system, result = slider_crank
    with pytest.raises(ValueError, match=r"\.gif or \.mp4 files \(a page, by viewer.py: \.html\)"):
        animate_result(model, system, result, tmp_path / "run.avi", max_frames=2)
    other = load_model(MODELS / "double_pendulum.yaml")
    with pytest.raises(ValueError, match="the result has 9 coordinates, the model 'double-pendulum' has 6"):
        animate_result(other, build_system(other)[0], result, None)


def test_spatial_mechanism_draws_and_animates_in_3d(tmp_path):
    model = load_model(MODELS / "spatial_double_pendulum.yaml")
    system, q0, qd0 = build_system(model)
    q, _ = assemble(system, q0)
    geometry = mechanism_geometry(model)
    placed = dict((name, a.at(q, 3)) for name, a in geometry.joints)
    assert np.allclose(placed["A"], [1.0, 0.0, 0.0]) and np.allclose(placed["O"], 0.0)
    fig = draw_mechanism(model, q)
    assert fig.axes[0].name == "3d"
    result = forward_dynamics(system, q0, qd0, 0.2, 4)
    animate_result(model, system, result, tmp_path / "spatial.gif", max_frames=5)
    with Image.open(tmp_path / "spatial.gif") as gif:
        assert gif.n_frames == 5
