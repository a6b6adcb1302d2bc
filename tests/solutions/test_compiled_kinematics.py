"""The compiled kinematic analysis (solutions/compiled/kinematic*.py) against the numpy loop of kinematic_analysis.

The compiled steps solve the same equations (eq. 4.8, 4.5, 4.6) with the same predictor and the same Newton-Raphson
stopping rule, from the constraint kernels of the compiled engine: on every example model that the kernels cover
the two engines agree to rounding (the tests ask for 1e-10 relative) with the same Newton iterations. Where
anything unusual happens the compiled steps stop and the numpy loop goes on: the errors at singular positions
are the numpy engine's, word for word. numba compiles the step loop and each dimension's
``evaluate`` once per machine (cached on disk).
"""

import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from solutions import kinematics
from solutions.analysis import choose_analysis, run_analysis
from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError
from solutions.io.model import load_model
from solutions.kinematics import assemble, kinematic_analysis
from solutions.settings import read_settings

from .mechanisms import parallelogram_chain

pytest.importorskip("numba")

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"


def _kinematic_models() -> list[str]:
    """The example models whose drivers leave no degree of freedom (``mbd run`` analyses them kinematically)."""
    names = []
    for path in sorted(MODELS.glob("*.yaml")):
        system, q0, _ = build_system(load_model(path))
        if choose_analysis(system, assemble(system, q0)[0]) == "kinematic":
            names.append(path.name)
    return names


KINEMATIC_MODELS = _kinematic_models()
NOT_COVERED: set[str] = set()
"""Kinematic examples with elements the compiled kernels do not have: none (the kernels are the dynamic engine's)."""
COVERED = set(KINEMATIC_MODELS) - NOT_COVERED
"""Planar joints and drivers (the slider-cranks, four- and six-bar, quick-return, rack and pinion, cams, gears) and
spatial joints with translation, rotation and distance drivers (carriage, cylindrical, heavy top, skew arm, double
pendulum, spatial slider-crank)."""


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    """|a - b| relative to max |a|, with a floor of 1e-9 for rounding noise (the accelerations of a gear train
    turning at constant speed are 1e-32 on both engines)."""
    return float(np.max(np.abs(a - b))) / max(float(np.max(np.abs(a))), 1e-9)


def _both(system, q0, t_end: float, steps: int, **options):
    """(numpy run, compiled run), or the two AnalysisError messages where the numpy run stops."""
    runs = []
    for engine in ("numpy", "compiled"):
        try:
            runs.append(kinematic_analysis(system, q0, t_end, steps, engine=engine, **options))
        except AnalysisError as err:
            runs.append(str(err))
    return runs


def _agree(reference, compiled) -> None:
    for name in ("q", "qd", "qdd"):
        assert _relative(getattr(reference, name), getattr(compiled, name)) < 1e-10, name
    assert compiled.info["newton_iterations"] == reference.info["newton_iterations"]
    residual = reference.info["max_constraint_residual"]
    assert compiled.info["max_constraint_residual"] == pytest.approx(residual, abs=1e-14)
    assert compiled.info["assembly"] == reference.info["assembly"]


def test_the_kinematic_examples_are_found():
    assert len(COVERED) >= 15, KINEMATIC_MODELS


@pytest.mark.parametrize("name", KINEMATIC_MODELS)
def test_engines_agree_on_the_kinematic_examples(name):
    """Every kinematic example over its own simulation block: the compiled steps where the kernels cover the
    model, else the numpy loop with the reason in info['chosen']."""
    model = load_model(MODELS / name)
    system, q0, _ = build_system(model)
    t_end, steps = float(model.simulation.get("end_time", 1.0)), int(model.simulation.get("output_steps", 100))
    reference, compiled = _both(system, q0, t_end, steps)
    assert not isinstance(reference, str), reference
    chosen = compiled.info["chosen"]
    if name in COVERED:
        assert chosen == {"engine": "compiled", "engine_why": "compiled engine asked for"}
        _agree(reference, compiled)
    else:
        assert chosen["engine"] == "numpy" and chosen["engine_why"].startswith("not compiled: a "), chosen
        np.testing.assert_array_equal(reference.q, compiled.q)


def _driven_chain(n: int, function: dict):
    data = parallelogram_chain(n)
    data["model"]["motors"] = [{"name": "drive", "type": "angle", "joint": "O0", "function": function}]
    return build_system(load_model(data))


@pytest.mark.parametrize("n", [1, 2, 3])
def test_a_singular_position_stops_both_engines_with_the_same_error(n):
    """The driven parallelogram chain passes theta = pi at t = 0.785 s: det Psi_q changes sign (odd n), or the
    pivot ratio dips and the rank rule finds n ranks lost (even n). The compiled steps stop there and the numpy
    loop raises its error, the same words as a numpy run."""
    system, q0, _ = _driven_chain(n, {"type": "polynomial", "coefficients": [0.0, 2.0]})
    reference, compiled = _both(system, q0, 4.0, 200)
    assert isinstance(reference, str) and "between t = 0.78 s and t = 0.8 s" in reference
    assert without_noise(compiled) == without_noise(reference)


def without_noise(message: str) -> str:
    """A message with its numbers in exponent notation masked, each checked to be below 1e-8 (at a singular
    position the pivot ratio is rounding noise: 4.4e-11 on one machine, 4e-11 on another)."""
    tiny = re.findall(r"\d(?:\.\d+)?e-\d+", message)
    assert all(float(x) < 1e-8 for x in tiny), tiny
    return re.sub(r"\d(?:\.\d+)?e-\d+", "<rounding>", message)


def test_a_near_singular_pass_is_judged_as_numpy_and_passed(monkeypatch):
    """A chain driven to theta = pi - 0.01 and back comes near the singular position; on a grid of 40 steps the
    pivot ratio dips (a V at t = 1.6 s; 80 steps see its smooth minimum). Both engines search the interval for a
    singular position at the same step, find none, and go on to the end with the same motion."""
    system, q0, _ = _driven_chain(2, {"type": "harmonic", "amplitude": math.pi / 2 - 0.01, "frequency": 1.0})
    searched = []
    search = kinematics.locate_singular_position

    def spy(system, t_a, q, qd, qdd, t_b):
        found = search(system, t_a, q, qd, qdd, t_b)
        searched.append((t_a, t_b, found))
        return found

    monkeypatch.setattr(kinematics, "locate_singular_position", spy)
    reference = kinematic_analysis(system, q0, 4.0, 40)
    numpy_searches, searched[:] = searched[:], []
    compiled = kinematic_analysis(system, q0, 4.0, 40, engine="compiled")
    assert numpy_searches and [s[2] for s in numpy_searches] == [None] * len(numpy_searches)
    assert [s[:2] for s in searched] == [s[:2] for s in numpy_searches]
    assert compiled.info["chosen"] == {"engine": "compiled", "engine_why": "compiled engine asked for"}
    _agree(reference, compiled)


def test_through_singular_runs_on_numpy_and_says_so():
    system, q0, _ = _driven_chain(1, {"type": "polynomial", "coefficients": [0.0, 2.0]})
    reference, compiled = _both(system, q0, 2.0, 40, through_singular=True)
    assert compiled.info["chosen"] == {"engine": "numpy", "engine_why": "through_singular runs on the numpy engine"}
    assert compiled.info["singular_positions"] == reference.info["singular_positions"]


@pytest.mark.parametrize("steps", [7, 100])
def test_a_rocker_driven_past_its_reach_stops_both_engines_with_the_same_error(steps):
    """The four-bar driven at its rocker (O4, 1 rad/s from 112.6 deg) reaches the end of the rocker's swing
    (147.8 deg) at t = 0.61 s, where crank and coupler align: Newton-Raphson cannot follow past it. The compiled
    steps stop there and the numpy loop raises its error, with the same time, condition number and joints."""
    data = yaml.safe_load((MODELS / "four_bar.yaml").read_text())
    data["model"]["motors"][0].update(joint="O4", function={"type": "polynomial", "coefficients": [0.0, 1.0]})
    system, q0, _ = build_system(load_model(data))
    reference, compiled = _both(system, q0, 1.0, steps)
    assert isinstance(reference, str) and reference.startswith("lock-up or branch point near t = 0.")
    assert compiled == reference


def test_unknown_engine_is_refused():
    system, q0, _ = build_system(load_model(MODELS / "slider_crank.yaml"))
    with pytest.raises(AnalysisError, match="unknown engine"):
        kinematic_analysis(system, q0, 0.1, 10, engine="fast")


def test_auto_and_cached_choose_by_what_pays(tmp_path, monkeypatch):
    """A short run stays on numpy under ``auto``, and a longer one (LOAD_SECONDS set to 0) takes the code on disk;
    ``cached`` takes the compiled steps when their code is on disk; with nothing on disk both stay on numpy."""
    from solutions.compiled import kinematic

    system, q0, _ = build_system(load_model(MODELS / "slider_crank.yaml"))
    kinematic_analysis(system, q0, 0.1, 10, engine="compiled")  # on disk now
    auto = kinematic_analysis(system, q0, 0.1, 10, engine="auto").info["chosen"]
    assert auto["engine"] == "numpy" and "less than loading the compiled code" in auto["engine_why"], auto
    assert kinematic_analysis(system, q0, 0.1, 10, engine="cached").info["chosen"]["engine"] == "compiled"
    monkeypatch.setattr(kinematic, "LOAD_SECONDS", 0.0)
    auto = kinematic_analysis(system, q0, 0.1, 10, engine="auto").info["chosen"]
    assert auto["engine"] == "compiled" and "more than loading the compiled code (0 s)" in auto["engine_why"], auto
    monkeypatch.setenv("MBD_COMPILED_CACHE", str(tmp_path))  # an empty cache, and no generated module loaded
    for name in [name for name in sys.modules if name.startswith("mbd_")]:
        monkeypatch.delitem(sys.modules, name)
    for engine, why in (("auto", "less than a first compilation"), ("cached", "no compiled code")):
        chosen = kinematic_analysis(system, q0, 0.1, 10, engine=engine).info["chosen"]
        assert chosen["engine"] == "numpy" and why in chosen["engine_why"], chosen


def test_mbd_run_takes_the_engine_for_a_kinematic_model():
    model = load_model(MODELS / "slider_crank.yaml")
    system, q0, qd0 = build_system(model)
    for engine in ("compiled", "numpy"):
        settings = read_settings(model.simulation, engine=engine, steps=20)
        result = run_analysis(system, q0, qd0, settings)
        assert result.info["analysis"] == "kinematic"
        assert result.info.get("chosen", {"engine": "numpy"})["engine"] == engine
