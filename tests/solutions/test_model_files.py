"""Model files: malformed ones give one clear ModelError naming the file, the key path and the fix;
JSON is accepted; points given in body frames mean the same mechanism as global ones."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from solutions.assembly import build_system
from solutions.io.model import ModelError, load_model
from solutions.kinematics import kinematic_analysis

REPO = Path(__file__).resolve().parents[2]
SLIDER_CRANK = (REPO / "course" / "models" / "slider_crank.yaml").read_text()

FOUR_BAR = """\
model:
  name: four-bar
  bodies:
    - {name: crank,   mass: 1.0, inertia: 0.01, location: [0.05, 0.0]}
    - {name: coupler, mass: 1.0, inertia: 0.01, location: [0.2, 0.14]}
    - {name: rocker,  mass: 1.0, inertia: 0.01, location: [0.35, 0.14]}
  joints:
    - {name: O, type: revolute, body1: ground,  body2: crank,   location: [0.0, 0.0]}
    - {name: A, type: revolute, body1: crank,   body2: coupler, location: [0.1, 0.0]}
    - {name: B, type: revolute, body1: coupler, body2: couplr,  location: [0.3, 0.28]}
    - {name: D, type: revolute, body1: ground,  body2: rocker,  location: [0.4, 0.0]}
"""


def error_of(tmp_path, text: str, name: str = "model.yaml") -> str:
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(ModelError) as err:
        load_model(path)
    message = str(err.value)
    assert message.startswith(f"{name}: "), message  # names the file first
    assert "\n" not in message and "Traceback" not in message
    return message


def slider_crank_with(old: str, new: str) -> str:
    assert SLIDER_CRANK.count(old) == 1, old
    return SLIDER_CRANK.replace(old, new)


ROD = "mass: 1.0, inertia: 7.5e-3"  # the rod's mass properties: bodies[1]

# (file text, expected fragments of the message: key path, what is wrong, what to write)
MALFORMED = {
    "missing mass": (
        slider_crank_with(ROD, "inertia: 7.5e-3"),
        ["model.bodies[1].mass: missing key 'mass'", "write e.g. mass: 1.0"],
    ),
    "missing joint location": (
        slider_crank_with(
            "{name: A, type: revolute,  body1: crank,  body2: rod,    location: [0.1, 0.0]}",
            "{name: A, type: revolute,  body1: crank,  body2: rod}",
        ),
        ["model.joints[1].location: missing key 'location'", "write e.g. location:", "revolute"],
    ),
    "missing bodies": ("model:\n  name: nothing\n", ["model.bodies: missing key 'bodies'", "write e.g. bodies:"]),
    "no model key": ("simulation: {end_time: 1.0}\n", ["missing key 'model'", "write e.g. model:"]),
    "mass of wrong type": (
        slider_crank_with(ROD, "mass: heavy, inertia: 7.5e-3"),
        ["model.bodies[1].mass: expected number, got 'heavy'"],
    ),
    "location of wrong type": (
        slider_crank_with("location: [0.25, 0.0]", "location: '0.25, 0.0'"),
        ["model.bodies[1].location: expected array"],
    ),
    "zero mass": (slider_crank_with(ROD, "mass: 0, inertia: 7.5e-3"), ["model.bodies[1].mass: must be > 0, got 0"]),
    "negative mass": (
        slider_crank_with(ROD, "mass: -2.0, inertia: 7.5e-3"),
        ["model.bodies[1].mass: must be > 0, got -2.0"],
    ),
    "negative inertia": (
        slider_crank_with(ROD, "mass: 1.0, inertia: -7.5e-3"),
        ["model.bodies[1].inertia:", "positive number"],
    ),
    "unknown body": (
        slider_crank_with("body1: rod,    body2: slider", "body1: rod,    body2: slidr"),
        ["model.joints[2].body2: no body named 'slidr' (did you mean 'slider'?", "bodies: crank, rod, slider"],
    ),
    "unknown joint type": (
        slider_crank_with("type: revolute,  body1: crank", "type: revolut,  body1: crank"),
        ["model.joints[1].type: unknown value 'revolut' (did you mean 'revolute'?", "one of: revolute, prismatic"],
    ),
    "spatial joint in a planar model": (
        slider_crank_with("type: revolute,  body1: crank", "type: spherical,  body1: crank"),
        ["model.joints[1].type: 'spherical' is a spatial joint", "planar joints are revolute"],
    ),
    "unknown function type": (
        slider_crank_with("type: polynomial", "type: polynomal"),
        ["model.motors[0].function.type: unknown value 'polynomal' (did you mean 'polynomial'?"],
    ),
    "unknown motor joint": (
        slider_crank_with("joint: O,", "joint: Q,"),
        ["model.motors[0].joint: no joint named 'Q'", "joints: O, A, B, S"],
    ),
    "angle motor on a prismatic joint": (
        slider_crank_with("joint: O,", "joint: S,"),
        ["model.motors[0].joint: an angle motor drives a revolute joint, but 'S' is prismatic"],
    ),
    "3-vector in a planar model": (
        slider_crank_with("location: [0.1, 0.0]}", "location: [0.1, 0.0, 0.0]}"),
        ["model.joints[1].location: expected 2 numbers for a 2D model"],
    ),
    "body name used twice": (
        slider_crank_with("name: slider,", "name: rod,"),
        ["model.bodies: the body name 'rod' is used twice"],
    ),
    "zero axis": (
        slider_crank_with("axis: [1.0, 0.0]", "axis: [0.0, 0.0]"),
        ["model.joints[3].axis: the axis is zero", "e.g. [1.0, 0.0]"],
    ),
    "joint to itself": (
        slider_crank_with("body1: rod,    body2: slider", "body1: rod,    body2: rod"),
        ["model.joints[2].body2: connects 'rod' to itself"],
    ),
    "malformed YAML (bracket)": (
        slider_crank_with("- {name: A, type: revolute,", "- {name: A, type: revolute"),
        ["line 13, column", "malformed YAML", "check indentation and brackets"],
    ),
    "malformed YAML (indentation)": (
        "model:\n  bodies:\n   - name: a\n  - name: b\n",
        ["line 4, column 3: malformed YAML"],
    ),
    "empty file": ("", ["the file is empty", "model:"]),
    "blank file": ("  \n\n", ["the file is empty"]),
    "a list, not a mapping": ("- crank\n- rod\n", ["expected a mapping with the key 'model'"]),
}


@pytest.mark.parametrize("case", MALFORMED)
def test_malformed_model_file(tmp_path, case):
    text, fragments = MALFORMED[case]
    message = error_of(tmp_path, text)
    for fragment in fragments:
        assert fragment in message, f"{case}: {fragment!r} not in {message!r}"


def test_unknown_body_in_a_four_bar(tmp_path):
    """The issue's own example."""
    message = error_of(tmp_path, FOUR_BAR, "four_bar.yaml")
    assert message.startswith("four_bar.yaml: model.joints[2].body2: no body named 'couplr' (")
    assert "did you mean 'coupler'?" in message
    assert "bodies: crank, coupler, rocker" in message


def test_missing_file(tmp_path):
    with pytest.raises(ModelError, match="nowhere.yaml: cannot read the file"):
        load_model(tmp_path / "nowhere.yaml")


def test_error_from_a_mapping_names_the_source():
    data = yaml.safe_load(SLIDER_CRANK)
    data["model"]["bodies"][0]["mass"] = -1.0
    with pytest.raises(ModelError, match=r"^<model>: model.bodies\[0\].mass: must be > 0"):
        load_model(data)


def test_json_is_accepted(tmp_path):
    data = yaml.safe_load(SLIDER_CRANK)
    path = tmp_path / "slider_crank.json"
    path.write_text(json.dumps(data, indent=2))
    from_json = load_model(path)
    from_yaml = load_model(REPO / "course" / "models" / "slider_crank.yaml")
    assert from_json.source == "slider_crank.json"
    assert [b.name for b in from_json.bodies] == [b.name for b in from_yaml.bodies]
    assert from_json.joints == from_yaml.joints and from_json.motors == from_yaml.motors
    results = []
    for model in (from_json, from_yaml):
        system, q0, _ = build_system(model)
        results.append(kinematic_analysis(system, q0, 0.2, 10))
    assert np.array_equal(results[0].q, results[1].q)
    assert np.array_equal(results[0].qdd, results[1].qdd)


def test_malformed_json_is_reported(tmp_path):
    message = error_of(tmp_path, '{"model": {"bodies": [}', "broken.json")
    assert "malformed YAML" in message and "line 1" in message


def test_body_frame_points_mean_the_same_mechanism(four_bar):
    """A four-bar at crank angle 0.4 (every body rotated in the file) with joint points given globally
    and with the same points given in the body frames (link ends at -L/2 and +L/2 along each link)."""
    in_global = load_model(four_bar.model(0.4))
    in_body = load_model(four_bar.model(0.4, frame="body"))
    elements_global, elements_body = build_system(in_global)[0].elements, build_system(in_body)[0].elements
    for a, b in zip(elements_global, elements_body, strict=True):
        assert type(a) is type(b) and a.name == b.name
        if hasattr(a, "si"):
            np.testing.assert_allclose(a.si, b.si, atol=1e-14)
            np.testing.assert_allclose(a.sj, b.sj, atol=1e-14)
    results = []
    for model in (in_global, in_body):
        system, q0, _ = build_system(model)
        results.append(kinematic_analysis(system, q0, 1.0, 20))
    np.testing.assert_allclose(results[0].q, results[1].q, atol=1e-12)
    np.testing.assert_allclose(results[0].qdd, results[1].qdd, atol=1e-10)


def test_body_frame_revolute_needs_both_points(four_bar):
    model = four_bar.model(0.4, frame="body")
    del model["model"]["joints"][1]["point2"]
    with pytest.raises(ModelError, match=r"model.joints\[1\].point2: missing key 'point2'"):
        load_model(model)


def test_body_frame_prismatic_axis(tmp_path):
    """A prismatic joint whose axis is given in the frame of body1, here a guide turned by 90 degrees: the
    slider moves along global y."""
    text = """\
model:
  bodies:
    - {name: guide,  mass: 1.0, inertia: 0.01, location: [0.0, 0.0], orientation: 1.5707963267948966}
    - {name: slider, mass: 1.0, inertia: 0.01, location: [0.0, 0.3]}
  joints:
    - {name: fix, type: rigid, body1: ground, body2: guide}
    - {name: S, type: prismatic, body1: guide, body2: slider, frame: body, point1: [0.3, 0.0], point2: [0.0, 0.0],
       axis: [1.0, 0.0]}
  motors:
    - {name: push, type: linear, joint: S, function: {type: polynomial, coefficients: [0.0, 0.5]}}
"""
    path = tmp_path / "guide.yaml"
    path.write_text(text)
    system, q0, _ = build_system(load_model(path))
    result = kinematic_analysis(system, q0, 1.0, 4)
    np.testing.assert_allclose(result.coordinate("slider.y"), 0.3 + 0.5 * result.t, atol=1e-12)
    np.testing.assert_allclose(result.coordinate("slider.x"), 0.0, atol=1e-12)


def test_a_misspelt_key_is_named_with_the_right_spelling(tmp_path):
    text = slider_crank_with("{name: crank,  mass: 1.0,", "{name: crank,  mas: 1.0,")
    message = error_of(tmp_path, text)
    assert "model.bodies[0].mas: unknown key 'mas' (did you mean 'mass'?)" in message


def test_a_file_of_comments_only_is_called_empty(tmp_path):
    message = error_of(tmp_path, "# a model will go here\n# soon\n")
    assert "only comments" in message and "model:" in message


def _models_and_cases() -> list[tuple[str, object]]:
    folders = (REPO / "course" / "models", REPO / "autograder" / "scenes")
    files = [path for folder in folders for path in sorted(folder.glob("*.yaml"))]
    cases = [(path.name, yaml.safe_load(path.read_text())) for path in files]
    for name, (text, _) in MALFORMED.items():
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError:
            continue
        if isinstance(data, dict):
            cases.append((name, data))
    return cases


def test_the_fast_validator_and_jsonschema_agree():
    """fastjsonschema decides validity (it starts fast), jsonschema explains errors: on every example model,
    grading scene and malformed case they must give the same verdict (the schema uses nothing only one knows)."""
    import fastjsonschema
    import jsonschema

    from solutions.io.model import _fast_validator, _schema

    full = jsonschema.Draft202012Validator(_schema())
    cases = _models_and_cases()
    assert len(cases) > 30
    verdicts = {"valid": 0, "invalid": 0}
    for name, data in cases:
        try:
            _fast_validator()(data)
            fast = True
        except fastjsonschema.JsonSchemaException:
            fast = False
        assert fast == full.is_valid(data), name
        verdicts["valid" if fast else "invalid"] += 1
    assert verdicts["valid"] > 10 and verdicts["invalid"] > 5, verdicts


def test_the_cached_validator_is_the_compiled_one(tmp_path, monkeypatch):
    """The compiled validator is kept in the user's cache: the next process loads it instead of compiling
    (fastjsonschema is not asked again), and it gives the fresh one's verdict on every case; a cache file
    that is not whole, or a cache folder that cannot be made, only means compiling again."""
    import fastjsonschema

    from solutions.io import model

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    cache = model.validator_cache()
    assert cache.is_relative_to(tmp_path)
    name, fresh = model._validator_code()
    [stored] = cache.glob("validator-*.marshal")

    def no_compiling(*args, **kwargs):
        raise AssertionError("compiled again although the cache holds the validator")

    with monkeypatch.context() as patch:
        patch.setattr(fastjsonschema, "compile_to_code", no_compiling)
        cached_name, cached = model._validator_code()
    assert cached_name == name and cached == fresh  # code objects compare by their bytecode and constants

    def verdict(code, data) -> bool:
        namespace = {}
        exec(code, namespace)
        try:
            namespace[name](data)
        except fastjsonschema.JsonSchemaException:
            return False
        return True

    for case, data in _models_and_cases():
        assert verdict(cached, data) == verdict(fresh, data), case

    stored.write_bytes(stored.read_bytes()[:1000])  # cut short, as by a full disk
    assert model._validator_code()[1] == fresh
    assert stored.stat().st_size > 1000  # written again, whole
    monkeypatch.setenv("XDG_CACHE_HOME", str(stored))  # a file where the folder should be: nothing is cached
    assert model._validator_code()[1] == fresh
