"""The viewer: a result as data (a Plotly figure), checked against the mechanism's closed-form positions, its
size, its controls, and the self-contained page."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from solutions.animation import frame_indices, mechanism_geometry
from solutions.assembly import build_system
from solutions.cli import main
from solutions.dynamics import forward_dynamics
from solutions.io.model import load_model
from solutions.kinematics import kinematic_analysis
from solutions.viewer import MIME, View, model_view, notebook_animation, polyline_view, result_view, size_of

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
R, L = 0.1, 0.3
"""The slider-crank's crank and rod (course/models/slider_crank.yaml)."""


@pytest.fixture(scope="module")
def slider_crank():
    model = load_model(MODELS / "slider_crank.yaml")
    system, q0, _ = build_system(model)
    return model, system, kinematic_analysis(system, q0, 2 * math.pi / 10, 200)


@pytest.fixture(scope="module")
def spatial():
    model = load_model(MODELS / "spatial_double_pendulum.yaml")
    system, q0, qd0 = build_system(model)
    return model, system, forward_dynamics(system, q0, qd0, 1.0, 200)


def joints_of(frame: dict, figure: dict) -> dict[str, np.ndarray]:
    """{joint name: position} in one frame (the joints' trace carries the names)."""
    index = next(k for k, trace in enumerate(figure["data"]) if trace.get("name") == "joints")
    trace = frame["data"][figure["frames"][0]["traces"].index(index)]
    names = figure["data"][index]["text"]
    axes = [a for a in "xyz" if a in trace]
    return {name: np.array([trace[a][k] for a in axes]) for k, name in enumerate(names)}


def strict_json(text: str):
    """JSON as a browser reads it: NaN or Infinity would be refused."""

    def refuse(constant):
        raise ValueError(f"{constant} in the figure")

    return json.loads(text, parse_constant=refuse)


def test_the_frames_place_the_joints_where_the_closed_form_puts_them(slider_crank):
    """Crank pin A = r (cos theta, sin theta), slider pin B = (r cos theta + sqrt(l^2 - r^2 sin^2 theta), 0),
    theta = 10 t, at every frame's time (the slider's label), to the 1e-5 of the size the figure keeps."""
    model, system, result = slider_crank
    view = result_view(model, system, result, max_frames=40)
    figure = strict_json(view.to_json())
    shown = frame_indices(result.t, 40)
    assert [f["name"] for f in figure["frames"]] == [f"{result.t[i]:.3f}" for i in shown]
    assert [s["label"] for s in figure["layout"]["sliders"][0]["steps"]] == [f["name"] for f in figure["frames"]]
    for frame, index in zip(figure["frames"], shown, strict=True):
        theta = 10.0 * result.t[index]
        joints = joints_of(frame, figure)
        assert np.allclose(joints["O"], [0.0, 0.0], atol=1e-5)
        assert np.allclose(joints["A"], [R * math.cos(theta), R * math.sin(theta)], atol=1e-5)
        x_b = R * math.cos(theta) + math.sqrt(L**2 - (R * math.sin(theta)) ** 2)
        assert np.allclose(joints["B"], [x_b, 0.0], atol=1e-5)


def test_the_view_fits_the_motion_at_equal_scale_and_plays(slider_crank):
    model, system, result = slider_crank
    figure = result_view(model, system, result).figure
    layout = figure["layout"]
    x, y = layout["xaxis"]["range"], layout["yaxis"]["range"]
    assert layout["yaxis"]["scaleanchor"] == "x"
    assert x[0] < -R < R + L < x[1] and y[0] < -R < R < y[1]  # every position of the crank pin and the slider
    assert (x[1] - x[0]) < 1.8 * (2 * R + L)  # not a fixed large box: the motion and the slider's rail
    play, pause = layout["updatemenus"][0]["buttons"]
    assert (play["label"], play["method"], play["args"][0]) == ("Play", "animate", None)
    assert pause["args"][0] == [None]
    assert len(figure["frames"]) == len(frame_indices(result.t, 120))


def test_an_animation_is_data_of_at_most_200_kB(slider_crank, spatial):
    """The notebook budget of an animation: 120 frames with a trace and a plot, planar and spatial."""
    model, system, result = slider_crank
    assert size_of(result_view(model, system, result, trace=["A"], plots=["crank.phi", "slider.x_d"])) < 200_000
    model, system, result = spatial
    view = result_view(model, system, result, trace=["A"])
    assert size_of(view) < 200_000
    assert all(trace["type"] == "scatter3d" for trace in view.figure["frames"][0]["data"])


def test_a_spatial_scene_stands_on_its_gravity_and_fits_the_motion(spatial):
    model, system, result = spatial
    scene = result_view(model, system, result).figure["layout"]["scene"]
    gravity = np.asarray(model.gravity, dtype=float)
    up = np.array([scene["camera"]["up"][a] for a in "xyz"])
    assert np.allclose(up, -gravity / np.linalg.norm(gravity))
    points = np.vstack([result.q[:, 0:3], result.q[:, 7:10]])  # the centres of mass stay inside the box
    for k, axis in enumerate("xyz"):
        low, high = scene[f"{axis}axis"]["range"]
        assert low <= points[:, k].min() and points[:, k].max() <= high


def test_linked_plots_follow_the_frames(slider_crank):
    model, system, result = slider_crank
    figure = result_view(model, system, result, max_frames=10, plots=["slider.x"]).figure
    line = next(t for t in figure["data"] if t.get("name") == "slider.x")
    assert np.allclose(line["y"], result.coordinate("slider.x"))
    shown = frame_indices(result.t, 10)
    for frame, index in zip(figure["frames"], shown, strict=True):
        marker = frame["data"][-1]  # the plot's marker at the frame's time
        assert marker["x"] == [pytest.approx(result.t[index])]
        assert marker["y"] == [pytest.approx(result.coordinate("slider.x")[index])]


def test_refusals_name_what_exists(slider_crank):
    model, system, result = slider_crank
    with pytest.raises(ValueError, match=r"no result column nope \(columns: t, crank.x"):
        result_view(model, system, result, plots=["nope"])
    with pytest.raises(ValueError, match=r"nothing to trace named Z \(joints: A, B, O, S; points of the result: none"):
        result_view(model, system, result, trace=["Z"])
    other = load_model(MODELS / "double_pendulum.yaml")
    with pytest.raises(ValueError, match="the result has 9 coordinates, the model 'double-pendulum' has 6"):
        result_view(other, build_system(other)[0], result)


def test_a_notebook_gets_plotlys_mime_bundle_and_nothing_while_nbgrader_validates(slider_crank, monkeypatch, capsys):
    model, system, result = slider_crank
    view = notebook_animation(model, system, result, max_frames=5)
    bundle = view._repr_mimebundle_()
    assert set(bundle) == {MIME, "text/plain"} and bundle[MIME]["frames"]  # data, no HTML, no script
    monkeypatch.setenv("NBGRADER_EXECUTION", "autograde")  # for the feedback page (autograder/views.py)
    assert notebook_animation(model, system, result, max_frames=5).figure == view.figure
    monkeypatch.setenv("NBGRADER_EXECUTION", "validate")
    assert notebook_animation(model, system, result) is None
    assert "skipped while nbgrader validates" in capsys.readouterr().out


def test_the_page_is_self_contained(slider_crank, tmp_path):
    """plotly.js inside the page; no script, style sheet or frame taken from anywhere else."""
    model, system, result = slider_crank
    page = result_view(model, system, result, max_frames=5).write_html(tmp_path / "run.html").read_text()
    assert "Plotly.newPlot" in page and len(page) > 3_000_000  # plotly.js is in the file
    assert not re.search(r"<(script|link|img|iframe)[^>]*\b(src|href)=", page)
    figure = page.split("const figure = ", 1)[1].split(";\nPlotly.newPlot", 1)[0]
    assert strict_json(figure)["frames"]


def test_mbd_run_animate_writes_the_page_and_a_model_view_draws_the_file(tmp_path):
    out = tmp_path / "crank.html"
    assert main(["run", str(MODELS / "slider_crank.yaml"), "--steps", "10", "--animate", str(out)]) == 0
    assert "Plotly.newPlot" in out.read_text()
    model = load_model(MODELS / "spatial_slider_crank.yaml")
    view = model_view(model)
    assert isinstance(view, View) and view.figure["data"][0]["type"] == "scatter3d"
    bodies = [t for t in view.figure["data"] if t.get("name") in {b.name for b in model.bodies}]
    assert len(bodies) == len(model.bodies)


def test_any_motion_of_polylines_plays_in_a_box_that_holds_it():
    """A unit segment turning about the z axis (the L13 screw motion's way of using the viewer)."""
    angles = np.linspace(0.0, np.pi, 7)
    frames = [[np.array([[0.0, 0.0, 0.0], [np.cos(a), np.sin(a), 0.5]])] for a in angles]
    figure = strict_json(polyline_view(frames, [f"{a:.2f}" for a in angles], "turning").to_json())
    assert [f["name"] for f in figure["frames"]] == [f"{a:.2f}" for a in angles]
    last = figure["frames"][-1]["data"][0]
    assert np.allclose([last["x"][1], last["y"][1], last["z"][1]], [-1.0, 0.0, 0.5], atol=1e-5)
    scene = figure["layout"]["scene"]
    assert scene["xaxis"]["range"][0] < -1.0 and scene["xaxis"]["range"][1] > 1.0 and scene["zaxis"]["range"][1] > 0.5
    assert scene["camera"]["up"] == {"x": 0.0, "y": 0.0, "z": 1.0}


BENT = """
model:
  name: bent
  dimension: 2
  gravity: [0.0, -9.81]
  bodies:
    - {name: rod, mass: 1.0, inertia: 0.02, location: [0.505, 0.0], orientation: 0.0}
  joints:
    - {name: O, type: revolute, body1: ground, body2: rod, frame: body, point1: [0.0, 0.0], point2: [-0.5, 0.0]}
"""
"""A pendulum whose file places the rod 5 mm off its pivot (the joint's points are in the body frames)."""


def test_mbd_view_draws_the_file_and_the_assembled_mechanism_with_the_checks(tmp_path):
    """The page shows the rod where the file puts it, in grey, and where assembly puts it (5 mm left, on the
    pivot), in colour, with mbd check's report."""
    (tmp_path / "bent.yaml").write_text(BENT)
    assert main(["view", str(tmp_path / "bent.yaml"), "--out", str(tmp_path / "bent.html")]) == 0
    page = (tmp_path / "bent.html").read_text()
    assert "degrees of freedom: 1" in page and "redundant equations: none" in page
    assert re.search(r"rod moved 0\.005\d* m", page)
    figure = strict_json(page.split("const figure = ", 1)[1].split(";\nPlotly.newPlot", 1)[0])
    grey = next(t for t in figure["data"] if t.get("name") == "as the file places it")
    coloured = next(t for t in figure["data"] if t.get("name") == "rod")
    assert min(grey["x"]) == pytest.approx(0.005, abs=1e-4) and min(coloured["x"]) == pytest.approx(0.0, abs=1e-4)
    assert "frames" not in figure


def test_mbd_view_of_a_result_and_its_refusals(tmp_path, capsys):
    csv = tmp_path / "crank.csv"
    assert main(["run", str(MODELS / "slider_crank.yaml"), "--steps", "20", "--out", str(csv)]) == 0
    out = tmp_path / "crank.html"
    assert main(["view", str(MODELS / "slider_crank.yaml"), str(csv), "--out", str(out), "--plot", "slider.x"]) == 0
    figure = strict_json(out.read_text().split("const figure = ", 1)[1].split(";\nPlotly.newPlot", 1)[0])
    assert len(figure["frames"]) == 21
    npz = tmp_path / "crank.npz"  # the same run as NPZ, with a column beside the coordinates plotted
    assert (
        main(["run", str(MODELS / "slider_crank.yaml"), "--steps", "20", "--out", str(npz), "--point", "P=rod:0.25,0"])
        == 0
    )
    assert main(["view", str(MODELS / "slider_crank.yaml"), str(npz), "--out", str(out), "--plot", "P.x"]) == 0
    figure = strict_json(out.read_text().split("const figure = ", 1)[1].split(";\nPlotly.newPlot", 1)[0])
    assert next(t for t in figure["data"] if t.get("name") == "P.x")["y"]
    spring = tmp_path / "spring.csv"  # a dynamic run: its reactions and its spring-damper-actuator as arrows
    four_bar = str(MODELS / "four_bar_spring.yaml")
    assert main(["run", four_bar, "--t-end", "0.2", "--steps", "10", "--out", str(spring)]) == 0
    arrows = ["--reactions", "A", "B", "--forces", "spring"]
    assert main(["view", four_bar, str(spring), "--out", str(out), *arrows]) == 0
    figure = strict_json(out.read_text().split("const figure = ", 1)[1].split(";\nPlotly.newPlot", 1)[0])
    assert {"reaction forces", "applied forces"} <= {t.get("name") for t in figure["data"]}
    capsys.readouterr()
    for argv, said in (
        (["view", four_bar, str(spring), "--out", str(out), "--forces", "nope"], "no force element nope to draw"),
        (
            ["view", str(MODELS / "slider_crank.yaml"), str(csv), "--out", str(out), "--plot", "nope"],
            "no result column",
        ),
        (["view", str(MODELS / "four_bar.yaml"), str(csv), "--out", str(out)], "not a result of this model"),
        (["view", str(MODELS / "slider_crank.yaml"), str(tmp_path / "none.csv")], "cannot read a result"),
        (["view", str(MODELS / "slider_crank.yaml"), "--out", str(tmp_path / "x.png")], "the view is a page"),
    ):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert said in err and "Traceback" not in err and len(err.strip().splitlines()) == 1, err


def test_a_model_view_draws_each_bodys_frame_and_the_spatial_joints_axes():
    """spatial_slider_crank.yaml: the crank turns about the x axis through O (the file's axis [1, 0, 0]); each
    body's x, y, z axes start at its centre of mass along the columns of A(p) = (2 e0^2 - 1) I + 2 (e e^T + e0 e~)
    of its Euler parameters in the file (eq. 8.12, written out here)."""
    model = load_model(MODELS / "spatial_slider_crank.yaml")
    figure = strict_json(model_view(model).to_json())
    traces = {t["name"]: t for t in figure["data"]}
    axes = traces["joint axes"]
    names = [j["name"] for j in model.joints if "axis" in j and j["type"] in ("revolute", "cylindrical", "universal")]
    assert names and "O" in names
    first = np.array([[axes[a][k] for a in "xyz"] for k in range(2)])  # O's axis: the first segment
    assert np.allclose(np.cross(first[1] - first[0], [1.0, 0.0, 0.0]), 0.0, atol=1e-6)
    assert np.allclose((first[0] + first[1]) / 2, [0.0, 0.0, 0.0], atol=1e-6)  # through O
    for k, axis in enumerate("xyz"):
        frame = traces[f"body {axis} axes"]
        assert frame["visible"] is True
        for b, body in enumerate(model.bodies):  # segment b: from body b's centre of mass along A's column k
            start = np.array([frame[a][3 * b] for a in "xyz"])
            end = np.array([frame[a][3 * b + 1] for a in "xyz"])
            assert np.allclose(start, body.location, atol=1e-6)
            direction = (end - start) / np.linalg.norm(end - start)
            assert np.allclose(direction, euler_parameters_rotation(body.orientation)[:, k], atol=3e-4), (
                body.name
            )  # 1e-5 rounding over 0.08


def euler_parameters_rotation(p) -> np.ndarray:
    e0, e = p[0] / np.linalg.norm(p), np.asarray(p[1:], dtype=float) / np.linalg.norm(p)
    tilde = np.array([[0.0, -e[2], e[1]], [e[2], 0.0, -e[0]], [-e[1], e[0], 0.0]])
    return (2 * e0**2 - 1) * np.eye(3) + 2 * (np.outer(e, e) + e0 * tilde)


def test_a_reaction_is_an_arrow_at_its_joint_along_the_force():
    """A pendulum hanging at rest: the pin holds it up with m g (closed form), so the arrow at O points straight
    up from the pin, as long as the longest of the run (0.4 of the mechanism's size), its head at the tip; a
    swinging double pendulum's arrows follow the reaction columns frame by frame."""
    data = yaml.safe_load((MODELS / "simple_pendulum.yaml").read_text())
    data["model"]["bodies"][0].update(location=[0.0, -0.5], orientation=-np.pi / 2)
    data["model"]["joints"][0]["location"] = [0.0, 0.0]
    model = load_model(data)
    system, q0, qd0 = build_system(model)
    result = forward_dynamics(system, q0, qd0, 0.2, 10)
    assert np.allclose(result.reactions["O.Fy"], 9.81, rtol=1e-6)
    assert np.allclose(result.reactions["O.Fx"], 0.0, atol=1e-8)
    view = result_view(model, system, result, reactions=["O"])
    arrows = next(t for t in view.figure["data"] if t.get("name") == "reaction forces")
    scale = mechanism_geometry(model).scale
    assert arrows["x"][:2] == pytest.approx([0.0, 0.0], abs=1e-5)
    assert arrows["y"][:2] == pytest.approx([0.0, 0.4 * scale], rel=1e-4, abs=1e-5)
    assert arrows["y"][3:6][1] == pytest.approx(0.4 * scale, rel=1e-4) and max(arrows["y"][3:6]) == arrows["y"][4]

    model = load_model(MODELS / "double_pendulum.yaml")
    system, q0, qd0 = build_system(model)
    result = forward_dynamics(system, q0, qd0, 1.0, 20)
    view = result_view(model, system, result, reactions=["A"])
    index = len(view.figure["data"]) - 2  # the arrows: after the mechanism's parts, before the ground
    force = np.array([result.reactions["A.Fx"], result.reactions["A.Fy"]]).T
    largest = np.linalg.norm(force, axis=1).max()
    for k, frame in enumerate(view.figure["frames"]):
        shaft = frame["data"][index]
        tip = np.array([shaft["x"][1] - shaft["x"][0], shaft["y"][1] - shaft["y"][0]])
        assert tip == pytest.approx(0.4 * mechanism_geometry(model).scale * force[k] / largest, abs=2e-5)
    with pytest.raises(ValueError, match="no reaction of Z in the result \\(reactions of: A, O;"):
        result_view(model, system, result, reactions=["Z"])


def test_a_chosen_body_point_is_traced_where_the_closed_form_puts_it():
    """A point of the slider-crank's rod, 5 cm off its centre across it (``points=``, ``mbd run --point``):
    its path and its marker in every frame at r_rod + A(phi_rod) s' with the rod placed by the closed form
    (A on the crank circle, B at x_B = r cos(theta) + sqrt(l^2 - r^2 sin^2(theta)), theta = 10 t)."""
    model = load_model(MODELS / "slider_crank.yaml")
    system, q0, _ = build_system(model)
    result = kinematic_analysis(system, q0, 2 * math.pi / 10, 40, points={"M": (1, np.array([0.0, 0.05]))})
    view = result_view(model, system, result, trace=["M", "A"])
    theta = 10.0 * result.t
    a = np.column_stack([0.1 * np.cos(theta), 0.1 * np.sin(theta)])
    b = np.column_stack([a[:, 0] + np.sqrt(0.3**2 - a[:, 1] ** 2), np.zeros_like(theta)])
    phi = np.arctan2(b[:, 1] - a[:, 1], b[:, 0] - a[:, 0])
    exact = (a + b) / 2 + 0.05 * np.column_stack([-np.sin(phi), np.cos(phi)])
    path = next(t for t in view.figure["data"] if t.get("name") == "path of M")
    assert np.column_stack([path["x"], path["y"]]) == pytest.approx(exact, abs=1e-5)
    index = next(k for k, t in enumerate(view.figure["data"]) if t.get("name") == "points")
    for frame in view.figure["frames"]:
        k = int(np.argmin(np.abs(result.t - float(frame["name"]))))
        marker = frame["data"][index]
        assert [marker["x"][0], marker["y"][0]] == pytest.approx(exact[k], abs=1e-5)
    with pytest.raises(ValueError, match="nothing to trace named Q \\(joints: A, B, O, S; points of the result: M\\)"):
        result_view(model, system, result, trace=["Q"])


def _arrow_shafts(view: View, name: str) -> list[list[np.ndarray]]:
    """Per frame, the shafts (base, tip) of the arrows of the trace ``name``: every second polyline (a shaft, then
    its head)."""
    index = next(k for k, t in enumerate(view.figure["data"]) if t.get("name") == name)
    shafts = []
    for frame in view.figure["frames"]:
        trace = frame["data"][index]
        axes = [a for a in "xyz" if a in trace]
        coordinates = np.array([[np.nan if v is None else v for v in trace[a]] for a in axes]).T
        lines = np.split(coordinates, np.flatnonzero(np.isnan(coordinates[:, 0])))
        lines = [line[~np.isnan(line[:, 0])] for line in lines]
        shafts.append([line for line in lines if len(line)][0::2])
    return shafts


def test_an_applied_force_is_an_arrow_at_its_point_along_the_force():
    """Force elements of ``forces`` are arrows at their points, on the bodies they act on: the four-bar's spring
    (no damper, no actuator) pulls the rocker's point towards the ground anchor with k (l - l0) (l from the points
    placed by r + A s' of the file's placement); the carriage's spring (spatial) pushes it back with -k x along the
    rail; a constant point force is an arrow of fixed length 0.4 of the mechanism's size; a torque has no point."""
    data = yaml.safe_load((MODELS / "four_bar_spring.yaml").read_text())
    spring = data["model"]["spring_dampers"][0]
    spring.pop("actuator")
    spring["damping_coefficient"] = 0.0
    model = load_model(data)
    system, q0, qd0 = build_system(model)
    result = forward_dynamics(system, q0, qd0, 0.5, 10)
    rocker = [b.name for b in model.bodies].index("rocker")
    start = np.array(data["model"]["bodies"][rocker]["location"], dtype=float)
    angle = float(data["model"]["bodies"][rocker].get("orientation", 0.0))

    def rotation(phi: float) -> np.ndarray:
        return np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])

    local = rotation(angle).T @ (np.array(spring["point2"]) - start)  # the rocker's point in its own frame
    anchor = np.array(spring["point1"])
    view = result_view(model, system, result, forces=["spring"])
    forces, points = [], []
    for q in result.q:
        point = q[3 * rocker : 3 * rocker + 2] + rotation(q[3 * rocker + 2]) @ local
        length = float(np.linalg.norm(point - anchor))
        forces.append(-spring["spring_coefficient"] * (length - spring["free_length"]) * (point - anchor) / length)
        points.append(point)
    scale = 0.4 * mechanism_geometry(model).scale / max(np.linalg.norm(f) for f in forces)
    for k, shafts in enumerate(_arrow_shafts(view, "applied forces")):
        (shaft,) = shafts  # the rocker's end only: the ground's is not drawn
        assert shaft[0] == pytest.approx(points[k], abs=2e-5)
        assert shaft[1] - shaft[0] == pytest.approx(scale * forces[k], abs=2e-5)

    model = load_model(MODELS / "carriage_pendulum.yaml")
    system, q0, qd0 = build_system(model)
    result = forward_dynamics(system, q0, qd0, 0.5, 10)
    x = result.q[:, 0]
    view = result_view(model, system, result, forces=["spring"])
    scale = 0.4 * mechanism_geometry(model).scale / np.max(np.abs(50.0 * x))
    for k, shafts in enumerate(_arrow_shafts(view, "applied forces")):
        if x[k] == 0.0:  # the spring at its free length: no force, no arrow
            assert shafts == []
            continue
        (shaft,) = shafts
        assert shaft[0] == pytest.approx(result.q[k, :3], abs=2e-5)
        assert shaft[1] - shaft[0] == pytest.approx([-scale * 50.0 * x[k], 0.0, 0.0], abs=2e-5)

    data = yaml.safe_load((MODELS / "simple_pendulum.yaml").read_text())
    push = {"name": "push", "type": "force", "body": "rod", "point": [1.0, 0.0], "value": [2.0, 0.0]}
    data["model"]["forces"] = [push]
    model = load_model(data)
    system, q0, qd0 = build_system(model)
    result = forward_dynamics(system, q0, qd0, 0.5, 10)
    view = result_view(model, system, result, forces=["push"])
    tip = np.array([1.0, 0.0])  # the rod's end: its centre at (0.5, 0) + A(phi) (0.5, 0)
    for k, (shaft,) in enumerate(_arrow_shafts(view, "applied forces")):
        x, y, phi = result.q[k]
        assert shaft[0] == pytest.approx([x + 0.5 * math.cos(phi), y + 0.5 * math.sin(phi)], abs=2e-5)
        assert shaft[1] - shaft[0] == pytest.approx([0.4 * mechanism_geometry(model).scale, 0.0], abs=2e-5)
    assert tip == pytest.approx(_arrow_shafts(view, "applied forces")[0][0][0], abs=2e-5)

    model = load_model(MODELS / "andrews.yaml")
    system, q0, qd0 = build_system(model)
    result = forward_dynamics(system, q0, qd0, 0.001, 2)
    torque = r"no force element mom to draw \(mom: a torque, with no point to draw it at\)"
    with pytest.raises(ValueError, match=torque):
        result_view(model, system, result, forces=["mom"])
    with pytest.raises(ValueError, match=r"no force element gas to draw \(forces with a point: spring\)"):
        result_view(model, system, result, forces=["gas"])
