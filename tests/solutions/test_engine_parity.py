"""One verdict per command (issue 29): ``mbd run`` gives the same outcome on the numpy and the compiled engine.

Every example model of ``course/models`` (0.3 s, at the defaults: ``auto`` picks the analysis, formulation and
integrator) and the singular and redundant mechanisms of the test suite (``mechanisms.py``: the chain of
parallelogram loops for N = 1 and 2 through its first flat, singular position, written with centre-of-mass
frames and with joint-origin frames and ``com:``; the Sarrus linkage) run as a user runs them, once with
``--engine numpy`` and once with ``--engine compiled``. The outcome must be the same: the same exit code, the
same error message or warnings (numbers aside: they carry the engines' rounding), the same formulation (``auto``'s
restart with the augmented Lagrangian after a Baumgarte stop at a singular position included), and body
coordinates within the accuracy both runs promise (1e-6 of the mechanism's size). The two ways of writing the
chain give the same verdict and the same motion, to that accuracy, on both engines.

The verdict must not depend on what the compiled engine has cached: the chain of two loops also runs with an
empty cache (``MBD_COMPILED_CACHE`` a fresh folder: it compiles), the others with the test run's cache.
"""

from __future__ import annotations

import contextlib
import copy
import io
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from solutions.assembly import build_system
from solutions.cli import main
from solutions.diagnostics import SingularConfigurationError
from solutions.dynamics import forward_dynamics
from solutions.io.model import load_model
from solutions.settings import DEFAULT_ACCURACY

pytest.importorskip("numba")

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mechanisms import parallelogram_chain, sarrus  # noqa: E402
from test_model_forms import matrix_of, with_com  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
MODELS = sorted((ROOT / "course" / "models").glob("*.yaml"))
NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")
CHAIN_END = 1.6
"""The chain of loops falls from upright at 1 m/s: its cranks lie flat (a singular position) at 1.23 s."""


def joint_origin(data: dict) -> dict:
    """The chain written as CAD files give it: each body's frame at its first joint (a crank's at its ground pivot,
    a coupler's at its left pin), x along the bar, the centre of mass ``com: [L/2, 0]`` in that frame."""
    data = copy.deepcopy(data)
    pins = {j["body2"]: j["location"] for j in data["model"]["joints"] if j["body1"] == "ground"}
    pins.update({j["body2"]: j["location"] for j in data["model"]["joints"] if j["name"].startswith("A")})
    for body in data["model"]["bodies"]:
        half = [0.5, 0.0]  # L / 2 along the bar (L = 1)
        body["location"], body["com"] = pins[body["name"]], half
        if body["name"].startswith("crank"):
            body["velocity"] = [0.0, 0.0]  # the pivot is at rest
    return data


def cad_frames(data: dict) -> dict:
    """An example model written as CAD files give it: each body's frame at the global location of its first joint
    that has one (else 10 mm off its centre along every axis), axes unchanged, ``com:`` the centre in that frame
    (``test_model_forms.with_com``, which moves the file's body-frame points with the frame)."""
    model = load_model(data)
    offsets = {}
    for body in model.bodies:
        pins = [
            j["location"]
            for j in data["model"]["joints"]
            if body.name in (j.get("body1"), j.get("body2")) and "location" in j and j.get("frame") != "body"
        ]
        centre = np.asarray(body.location, dtype=float)
        origin = np.asarray(pins[0], dtype=float) if pins else centre + 0.01
        if np.allclose(origin, centre):
            origin = centre + 0.01
        A = matrix_of(body.orientation) if model.dimension == 3 else planar(body.orientation)
        offsets[body.name] = (A.T @ (centre - origin)).tolist()
    return with_com(data, offsets)


def planar(phi: float) -> np.ndarray:
    return np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])


def scenes(tmp: Path) -> dict[str, Path]:
    """name -> model file: the example models in both forms, the chains in both forms, the Sarrus linkage."""
    files = {path.stem: path for path in MODELS}
    for path in MODELS:
        files[f"{path.stem}-joint-origin"] = written = tmp / f"{path.stem}-joint-origin.yaml"
        written.write_text(yaml.safe_dump(cad_frames(yaml.safe_load(path.read_text()))))
    for n in (1, 2):
        chain = parallelogram_chain(n, end_time=CHAIN_END)
        for form, data in (("com", chain), ("joint-origin", joint_origin(chain))):
            files[f"chain{n}-{form}"] = path = tmp / f"chain{n}-{form}.yaml"
            path.write_text(yaml.safe_dump(data))
    driven = parallelogram_chain(2, end_time=4.0)  # theta = pi/2 + 2 t: every bar on the ground line at 0.785 s
    driven["model"]["motors"] = [
        {"name": "drive", "type": "angle", "joint": "O0", "function": {"type": "polynomial", "coefficients": [0, 2]}}
    ]
    driven["simulation"].update(analysis="kinematic", output_steps=200)
    files["chain2-driven"] = files["chain2-driven-through"] = path = tmp / "chain2-driven.yaml"
    path.write_text(yaml.safe_dump(driven))
    files["sarrus"] = path = tmp / "sarrus.yaml"
    path.write_text(yaml.safe_dump(sarrus(end_time=0.3)))
    return files


def outcome(model: Path, engine: str, out: Path, *options: str) -> dict:
    """What ``mbd run MODEL --engine ENGINE [OPTIONS]`` says and gives: exit code, error, warnings, formulation,
    result."""
    span = []  # the mechanisms of the test suite: their files' spans; the example models: at most 0.3 s
    if not model.stem.startswith(("chain", "sarrus")):
        span = ["--steps", "30"] + (["--t-end", "0.3"] if load_model(model).simulation.get("end_time", 1) > 0.3 else [])
    printed, errors = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(errors):
        code = main(["run", str(model), "--engine", engine, *span, *options, "--out", str(out)])
    lines = printed.getvalue().splitlines()
    said = {key: value for key, _, value in (line.partition(": ") for line in lines)}
    return {
        "code": code,
        "error": [NUMBER.sub("#", line) for line in errors.getvalue().splitlines() if "compiling" not in line],
        "warnings": sorted(NUMBER.sub("#", line) for line in lines if line.startswith("warning")),
        "formulation": said.get("formulation"),
        "engine": said.get("engine", "").split(" ")[0],
        "result": np.genfromtxt(out, delimiter=",", names=True, deletechars="") if code == 0 else None,
    }


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict:
    """Every scene on both engines; the chain of two loops also compiled with an empty cache."""
    tmp = tmp_path_factory.mktemp("parity")
    found = {}
    for name, model in scenes(tmp).items():
        for engine in ("numpy", "compiled"):
            options = ["--through-singular"] if name.endswith("-through") else []
            found[name, engine] = outcome(model, engine, tmp / f"{name}-{engine}.csv", *options)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MBD_COMPILED_CACHE", str(tmp / "empty-cache"))
        found["chain2-com", "empty"] = outcome(tmp / "chain2-com.yaml", "compiled", tmp / "empty.csv")
    return found


def positions(result) -> np.ndarray:
    """The body centres' coordinates (every 'NAME.x', 'NAME.y', 'NAME.z' column) of a run's CSV."""
    return np.column_stack([result[c] for c in result.dtype.names if c.endswith((".x", ".y", ".z"))])


def same_motion(a, b) -> bool:
    """Body centres within the accuracy both runs promise, DEFAULT_ACCURACY of the mechanism's size."""
    pa, pb = positions(a), positions(b)
    return float(np.max(np.abs(pa - pb))) <= DEFAULT_ACCURACY * max(1.0, float(np.max(np.abs(pa))))


NAMES = [path.stem for path in MODELS]
SCENES = [*NAMES, *(f"{name}-joint-origin" for name in NAMES), "chain1-com", "chain2-com", "sarrus", "chain2-driven",
          "chain2-driven-through"]  # fmt: skip


@pytest.mark.parametrize("name", SCENES)
def test_both_engines_give_the_same_verdict(runs, name):
    numpy_run, compiled_run = runs[name, "numpy"], runs[name, "compiled"]
    for key in ("code", "error", "warnings"):
        assert numpy_run[key] == compiled_run[key], (name, key, numpy_run[key], compiled_run[key])
    if numpy_run["code"] == 0:
        assert same_motion(numpy_run["result"], compiled_run["result"]), name


@pytest.mark.parametrize("name", NAMES)
def test_an_example_model_written_with_joint_origin_frames_runs_the_same(runs, name):
    """Every example model with its bodies' frames at their joints and ``com:``: the same verdict on both engines
    as the file as written, the same initial state to round-off (the loader's location + A c) and the same motion
    within the accuracy the runs promise (a last-bit change of the initial state grows to the integrator's
    tolerance over a run: measured, Andrews' mechanism 4.7e-9 m, the others at most 1.7e-16 m)."""
    reference = runs[name, "numpy"]
    for engine in ("numpy", "compiled"):
        found = runs[f"{name}-joint-origin", engine]
        for key in ("code", "error", "warnings"):
            assert found[key] == reference[key], (engine, key, found[key], reference[key])
        if reference["code"] == 0:
            start, written = positions(reference["result"])[0], positions(found["result"])[0]
            assert np.allclose(start, written, rtol=0.0, atol=1e-14 * max(1.0, float(np.max(np.abs(start))))), engine
            assert same_motion(reference["result"], found["result"]), engine


def test_the_chain_restarts_at_its_flat_position_on_both_engines(runs):
    """Issue 29's figure: Baumgarte (auto's choice) stops at the chain's flat position; on the numpy engine the
    run was made again with the augmented Lagrangian, on the compiled one it stopped at 1.228 s."""
    said = runs["chain2-com", "numpy"]["error"]  # on stderr: the restart, in one line (mbd run's restart_line)
    assert len(said) == 1 and said[0].startswith("mbd run: restarted: the baumgarte formulation stopped"), said
    for engine in ("numpy", "compiled", "empty"):
        found = runs["chain2-com", engine]
        assert (found["code"], found["formulation"], found["error"]) == (0, "augmented-lagrangian", said), engine
    assert same_motion(runs["chain2-com", "numpy"]["result"], runs["chain2-com", "empty"]["result"])


@pytest.mark.parametrize("n", [1, 2])
def test_a_joint_origin_file_runs_as_its_centre_of_mass_file_on_both_engines(runs, n):
    """The chain written with joint-origin frames and com: the same verdict and motion as with centre-of-mass
    frames (the compiled engine's Baumgarte run of the joint-origin file passed the flat position onto the other
    branch, 0.79 m off, with exit 0: now it hands the run to the numpy engine, which judges every step)."""
    reference = runs[f"chain{n}-com", "numpy"]
    for engine in ("numpy", "compiled"):
        found = runs[f"chain{n}-joint-origin", engine]
        for key in ("code", "error", "warnings", "formulation"):
            assert found[key] == reference[key], (engine, key)
        assert same_motion(reference["result"], found["result"]), engine


@pytest.mark.parametrize("integrator", ["dop853", "DOP853", "RK45"])
def test_a_paused_compiled_run_goes_on_as_one_call(monkeypatch, integrator):
    """The compiled loop pauses every PAUSE_STEPS steps for the configuration check and resumes with its next step:
    the same states, steps and rejections as one call, one evaluation more per pause (f at the resumed state)."""
    import solutions.compiled as compiled

    system, q0, qd0 = build_system(load_model(MODELS[0].parent / "four_bar_spring.yaml"))
    kwargs = dict(formulation="baumgarte", integrator=integrator, engine="compiled", rtol=1e-10, atol=1e-10)
    whole = forward_dynamics(system, q0, qd0, 0.5, 20, **kwargs)
    monkeypatch.setattr(compiled, "PAUSE_STEPS", 7)
    paused = forward_dynamics(system, q0, qd0, 0.5, 20, **kwargs)
    assert whole.info["chosen"]["engine"] == paused.info["chosen"]["engine"] == "compiled"
    assert np.array_equal(whole.q, paused.q) and np.array_equal(whole.qd, paused.qd)
    steps = whole.info["integrator_steps"]
    assert paused.info["integrator_steps"] == steps and paused.info["rejected_steps"] == whole.info["rejected_steps"]
    assert paused.info["rhs_evaluations"] - whole.info["rhs_evaluations"] == (steps - 1) // 7


def test_a_compiled_run_checked_after_every_step_stops_as_the_numpy_run(monkeypatch):
    """Checked after every step (PAUSE_STEPS = 1), the compiled run of the chain of one loop, Baumgarte, with the
    Guard's threshold raised to 1e-2, stops with the numpy run's message, the times of the two steps and the singular
    value included: the same steps of the same arithmetic, the same checks (without the pauses' checks it stopped
    later, at the output time 0.7 s, 'about to lose rank')."""
    import solutions.compiled as compiled

    monkeypatch.setattr(compiled, "PAUSE_STEPS", 1)
    system, q0, qd0 = build_system(load_model(parallelogram_chain(1, end_time=1.0)))
    said = {}
    for engine in ("numpy", "compiled"):
        with pytest.raises(SingularConfigurationError) as stop:
            forward_dynamics(system, q0, qd0, 1.0, 10, "baumgarte", "dop853", engine=engine, singular_ratio=1e-2)
        said[engine] = str(stop.value)
    assert said["numpy"] == said["compiled"] and said["numpy"].startswith("singular configuration between t = ")


def test_a_run_that_stops_when_stiff_stays_on_the_numpy_engine():
    """``stiffness="error"`` stops an explicit run bounded by stability; the compiled loops have no stiffness monitor,
    so such a run is the numpy engine's, which says so (it stopped, or not, as the numpy run does)."""
    system, q0, qd0 = build_system(load_model(MODELS[0].parent / "simple_pendulum.yaml"))
    result = forward_dynamics(system, q0, qd0, 0.1, 5, "baumgarte", "dop853", engine="compiled", stiffness="error")
    assert result.info["chosen"]["engine"] == "numpy" and "stiffness" in result.info["chosen"]["engine_why"]
