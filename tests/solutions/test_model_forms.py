"""Model files as engineers write them (issue 18): every orientation form, a centre of mass given in a
body's own (joint-origin or CAD) frame, point masses and kinematic models without masses, each checked
against the form the loader had before, or against a hand computation."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from solutions.assembly import build_system
from solutions.cli import main
from solutions.dynamics import forward_dynamics
from solutions.inverse_dynamics import inverse_dynamics
from solutions.io.model import ModelError, load_model
from solutions.kinematics import kinematic_analysis
from solutions.rotations import to_euler_123, to_euler_313

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
SPATIAL = ("spatial_slider_crank.yaml", "spatial_double_pendulum.yaml", "heavy_top.yaml")


def read(name: str) -> dict:
    return yaml.safe_load((MODELS / name).read_text())


def matrix_of(p) -> np.ndarray:
    """A(p) written out entry by entry (Nikravesh 1988, eq. 6.19), independent of the package."""
    e0, e1, e2, e3 = p
    return 2 * np.array(
        [
            [e0**2 + e1**2 - 0.5, e1 * e2 - e0 * e3, e1 * e3 + e0 * e2],
            [e1 * e2 + e0 * e3, e0**2 + e2**2 - 0.5, e2 * e3 - e0 * e1],
            [e1 * e3 - e0 * e2, e2 * e3 + e0 * e1, e0**2 + e3**2 - 0.5],
        ]
    )


def rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def loaded_matrix(orientation) -> np.ndarray:
    data = read("heavy_top.yaml")
    data["model"]["bodies"][0]["orientation"] = orientation
    return matrix_of(load_model(data).bodies[0].orientation)


def test_euler_angles_and_axis_angle_against_matrices_built_by_hand():
    a, b, c = 30.0, 40.0, 50.0
    r = np.radians([a, b, c])
    np.testing.assert_allclose(
        loaded_matrix({"euler_313": [a, b, c], "unit": "deg"}), rz(r[0]) @ rx(r[1]) @ rz(r[2]), atol=1e-14
    )
    np.testing.assert_allclose(
        loaded_matrix({"euler_123": list(r), "unit": "rad"}), rx(r[0]) @ ry(r[1]) @ rz(r[2]), atol=1e-14
    )
    # 120 degrees about (1, 1, 1) permutes the axes: x -> y -> z -> x
    turn = loaded_matrix({"axis": [2.0, 2.0, 2.0], "angle": 120.0, "unit": "deg"})
    np.testing.assert_allclose(turn, [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], atol=1e-14)
    columns = rz(0.3) @ ry(-1.1)
    np.testing.assert_allclose(loaded_matrix({"rotation_matrix": columns.tolist()}), columns, atol=1e-14)


def test_planar_angle_in_degrees():
    data = read("slider_crank.yaml")
    data["model"]["bodies"][1]["orientation"] = {"angle": -30.0, "unit": "deg"}
    assert load_model(data).bodies[1].orientation == pytest.approx(-math.pi / 6, abs=1e-15)


def forms(p: np.ndarray) -> list:
    """The same orientation in every form a file may give."""
    psi, theta, phi = to_euler_313(p)
    e = p[1:]
    chi = 2 * math.atan2(np.linalg.norm(e), p[0])
    axis = (e / np.linalg.norm(e)).tolist() if np.linalg.norm(e) > 0 else [0.0, 0.0, 1.0]
    return [
        {"euler_parameters": p.tolist()},
        {"rotation_matrix": matrix_of(p).tolist()},
        {"euler_313": np.degrees([psi, theta, phi]).tolist(), "unit": "deg"},
        {"euler_123": list(to_euler_123(p)), "unit": "rad"},
        {"axis": axis, "angle": chi, "unit": "rad"},
    ]


@pytest.mark.parametrize("name", SPATIAL)
def test_every_orientation_form_gives_the_same_model(name):
    original = read(name)
    reference = load_model(original)
    for k in range(len(reference.bodies)):
        p = reference.bodies[k].orientation
        for form in forms(p):
            data = copy.deepcopy(original)
            data["model"]["bodies"][k]["orientation"] = form
            got = load_model(data).bodies[k].orientation
            got = got if got @ p > 0 else -got  # p and -p: the same rotation
            np.testing.assert_allclose(got, p, atol=1e-12, err_msg=f"{name} body {k}: {form}")


def test_an_orientation_form_runs_the_same_motion():
    original = read("spatial_slider_crank.yaml")
    data = copy.deepcopy(original)
    p = load_model(original).bodies[1].orientation
    data["model"]["bodies"][1]["orientation"] = {"rotation_matrix": matrix_of(p).tolist()}
    runs = [kinematic_analysis(*build_system(load_model(d))[:2], 0.5, 10) for d in (original, data)]
    np.testing.assert_allclose(runs[0].q, runs[1].q, atol=1e-12)
    np.testing.assert_allclose(runs[0].qdd, runs[1].qdd, atol=1e-10)


@pytest.mark.parametrize(
    ("orientation", "fragments"),
    [
        ({"rotation_matrix": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}, ["rotation_matrix: not a rotation", "det A < 0"]),
        ({"rotation_matrix": [[1, 0.1, 0], [0, 1, 0], [0, 0, 1]]}, ["not a rotation (A^T A differs from I", "columns"]),
        ({"euler_313": [10, 20, 30]}, ["orientation.unit: missing key 'unit'", "unit: deg"]),
        ({"euler_313": [10, 20, 30], "axis": [0, 0, 1], "unit": "deg"}, ["cannot read an orientation", "exactly one"]),
        ({"axis": [0, 0, 0], "angle": 1.0, "unit": "rad"}, ["orientation.axis: the axis is zero"]),
        (0.5, ["4 Euler parameters", "euler_313"]),
    ],
)
def test_a_bad_orientation_is_named_with_the_fix(orientation, fragments):
    data = read("heavy_top.yaml")
    data["model"]["bodies"][0]["orientation"] = orientation
    with pytest.raises(ModelError) as err:
        load_model(data)
    message = str(err.value)
    assert message.startswith("<model>: model.bodies[0].orientation"), message
    for fragment in fragments:
        assert fragment in message, message


def test_a_bad_orientation_exits_with_code_2(tmp_path, capsys):
    data = read("heavy_top.yaml")
    data["model"]["bodies"][0]["orientation"] = {"euler_123": [1, 2, 3], "unit": "grad"}
    path = tmp_path / "top.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "top.yaml: model.bodies[0].orientation" in err and "Traceback" not in err


def with_com(data: dict, offsets: dict[str, list[float]]) -> dict:
    """The same mechanism with each named body's reference point moved off its centre of mass by -A c:
    the file then gives location = r - A c, com = c, and frame: body points measured from the new origin."""
    data = copy.deepcopy(data)
    model = load_model(data)
    dim = model.dimension
    for body in data["model"]["bodies"]:
        if body["name"] not in offsets:
            continue
        c = np.array(offsets[body["name"]])
        b = model.bodies[model.body_index(body["name"])]
        if dim == 2:
            A = np.array(
                [
                    [math.cos(b.orientation), -math.sin(b.orientation)],
                    [math.sin(b.orientation), math.cos(b.orientation)],
                ]
            )
            omega = b.angular_velocity
            spin = omega * np.array([-(A @ c)[1], (A @ c)[0]])
        else:
            A = matrix_of(b.orientation)
            spin = np.cross(b.angular_velocity, A @ c)
        body["location"] = (b.location - A @ c).tolist()
        body["velocity"] = (b.velocity - spin).tolist()
        body["com"] = c.tolist()
    pair = (("point1", "body1"), ("point2", "body2"))
    sections = (("joints", pair), ("motors", pair), ("spring_dampers", pair), ("forces", (("point", "body"),)))
    for section, keys in sections:
        for item in data["model"].get(section, []):
            if item.get("frame") != "body":
                continue
            if "location" in item:
                item.setdefault("point1", item["location"])
                item.setdefault("point2", item.pop("location"))
            for key, body in keys:
                if key in item and item[body] in offsets:
                    item[key] = (np.array(item[key]) + offsets[item[body]]).tolist()
    return data


def test_com_offsets_give_the_same_kinematics():
    for name, offsets in (
        ("slider_crank.yaml", {"rod": [0.07, -0.02], "crank": [0.01, 0.03]}),
        ("spatial_slider_crank.yaml", {"rod": [0.03, 0.01, -0.02], "slider": [0.0, 0.0, 0.05]}),
    ):
        original = read(name)
        runs = [
            kinematic_analysis(*build_system(load_model(d))[:2], 0.5, 10)
            for d in (original, with_com(original, offsets))
        ]
        np.testing.assert_allclose(runs[0].q, runs[1].q, atol=1e-12, err_msg=name)
        np.testing.assert_allclose(runs[0].qdd, runs[1].qdd, atol=1e-9, err_msg=name)


def test_com_offsets_with_body_frame_points_give_the_same_dynamics():
    """Andrews' mechanism gives its joint points in the body frames: with CAD-like origins off every centre
    of mass (and the points measured from them) the forward dynamics are the same to round-off."""
    original = read("andrews.yaml")
    offsets = {b["name"]: [0.002 * (k + 1), -0.001 * k] for k, b in enumerate(original["model"]["bodies"])}
    shifted = with_com(original, offsets)
    runs = [
        forward_dynamics(
            *build_system(load_model(d)), 0.002, 4, formulation="baumgarte", integrator="DOP853", rtol=1e-10
        )
        for d in (original, shifted)
    ]
    np.testing.assert_allclose(runs[0].q, runs[1].q, atol=1e-12)


def test_a_cad_frame_body_with_a_point_mass():
    """A slider-crank whose rod is given in a frame at its crank end (com half-way along) and whose slider is
    a point mass: the slider cannot rotate, so the motion is that of the original file."""
    original = read("slider_crank.yaml")
    original["model"].pop("motors")
    cad = with_com(original, {"rod": [0.15, 0.0]})
    assert cad["model"]["bodies"][1]["location"] == pytest.approx([0.1, 0.0], abs=1e-15)
    cad["model"]["bodies"][2]["inertia"] = 0.0
    runs = [
        forward_dynamics(
            *build_system(load_model(d)), 0.3, 10, formulation="baumgarte", integrator="DOP853", rtol=1e-10
        )
        for d in (original, cad)
    ]
    np.testing.assert_allclose(runs[0].q, runs[1].q, atol=1e-12)


def test_a_spatial_point_mass_that_cannot_rotate():
    original = read("spatial_slider_crank.yaml")
    original["model"].pop("motors")
    data = copy.deepcopy(original)
    data["model"]["bodies"][2]["inertia"] = [0.0, 0.0, 0.0]
    runs = [
        forward_dynamics(*build_system(load_model(d)), 0.1, 5, formulation="baumgarte", integrator="DOP853", rtol=1e-10)
        for d in (original, data)
    ]
    np.testing.assert_allclose(runs[0].q, runs[1].q, atol=1e-10)


def test_a_point_mass_free_to_rotate_turns_at_rest():
    """A point mass pinned at its centre turns without energy: the run gives it a nominal inertia on that turn
    (``dynamics.nominal_inertia``), so it hangs at the pin and says why."""
    data = read("simple_pendulum.yaml")
    data["model"]["bodies"][0]["inertia"] = 0.0
    forward_dynamics(*build_system(load_model(data)), 0.1, 2)  # a bob on a rod: its rotation moves its mass
    data["model"]["joints"][0]["location"] = [0.5, 0.0]  # pinned at its centre: it turns without energy
    result = forward_dynamics(*build_system(load_model(data)), 0.1, 2)
    np.testing.assert_allclose(result.q[:, :2], [[0.5, 0.0]] * 3, atol=1e-12)
    assert "'rod': singular inertia (a point mass) free to turn" in result.info["notes"][0]


def test_a_kinematic_model_needs_no_masses(tmp_path, capsys):
    original = read("slider_crank.yaml")
    data = copy.deepcopy(original)
    for body in data["model"]["bodies"]:
        del body["mass"], body["inertia"]
    runs = [kinematic_analysis(*build_system(load_model(d))[:2], 0.5, 10) for d in (original, data)]
    np.testing.assert_array_equal(runs[0].q, runs[1].q)
    system, q0, _ = build_system(load_model(data))
    with pytest.raises(ModelError, match=r"model.bodies\[0\]: 'crank' has no mass and inertia"):
        inverse_dynamics(system, q0, 0.5, 10)
    path = tmp_path / "kinematic.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["run", str(path), "--analysis", "dynamic", "--t-end", "0.1"]) == 2
    err = capsys.readouterr().err
    assert "kinematic.yaml: model.bodies[0]: 'crank' has no mass" in err and "Traceback" not in err
    del data["model"]["bodies"][1]["location"]
    data["model"]["bodies"][1]["mass"] = 1.0
    with pytest.raises(ModelError, match=r"model.bodies\[1\].location: missing key"):
        load_model(data)
    data["model"]["bodies"][1]["location"] = [0.25, 0.0]
    with pytest.raises(ModelError, match=r"model.bodies\[1\].inertia: missing key 'inertia' \(write e.g. inertia"):
        load_model(data)
