"""The engine of a run that names none (settings.default_engine): ``auto``, or ``$MBD_ENGINE``, the same from Python,
a model file and the command line; ``auto`` takes the compiled engine where its code is on disk and the run is
longer than loading it, and numpy elsewhere, saying why (compiled.dispatch, compiled.kinematic)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.generalized_forces import build_forces
from solutions.io.model import load_model
from solutions.kinematics import kinematic_analysis
from solutions.settings import ENGINE_VARIABLE, SettingError, Settings, read_settings

REPO = Path(__file__).resolve().parents[2]
MODELS = REPO / "course" / "models"


@pytest.fixture
def default(monkeypatch):
    """No ``$MBD_ENGINE`` (the test session sets it to numpy): the default users get."""
    monkeypatch.delenv(ENGINE_VARIABLE, raising=False)


def test_the_default_is_auto_and_the_variable_replaces_it(default, monkeypatch):
    assert Settings().engine == "auto"
    assert read_settings({}).engine == "auto"
    monkeypatch.setenv(ENGINE_VARIABLE, "numpy")
    assert Settings().engine == read_settings({}).engine == "numpy"
    assert read_settings({"engine": "compiled"}).engine == "compiled"  # the file's key, over the variable
    assert read_settings({"engine": "compiled"}, engine="cached").engine == "cached"  # the option, over both
    monkeypatch.setenv(ENGINE_VARIABLE, "fast")
    with pytest.raises(SettingError, match=r"MBD_ENGINE='fast': unknown engine \(one of: auto, numpy"):
        Settings()


def test_a_short_run_stays_on_numpy_and_a_longer_one_takes_the_code_on_disk(default, monkeypatch):
    """Forward dynamics from Python with no engine named: a run shorter than loading the compiled code (0.5 s) on
    numpy, whatever is on disk; the same run counted longer (LOAD_SECONDS = 0) on the compiled engine, its code
    being on disk, with the reason; user forces (Python callables) on numpy, with the reason."""
    from solutions.compiled import dispatch

    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    options = dict(formulation="baumgarte", integrator="dop853", rtol=1e-8)
    forward_dynamics(system, q0, qd0, 0.05, 2, engine="compiled", **options)  # the code on disk
    short = forward_dynamics(system, q0, qd0, 0.05, 2, **options).info["chosen"]
    assert short["engine"] == "numpy", short
    assert (
        short["engine_why"].startswith("numpy run estimated at ")
        and "less than loading the compiled" in (short["engine_why"])
    )
    monkeypatch.setattr(dispatch, "LOAD_SECONDS", 0.0)
    longer = forward_dynamics(system, q0, qd0, 0.05, 2, **options)
    assert longer.info["chosen"]["engine"] == "compiled", longer.info["chosen"]
    reference = forward_dynamics(system, q0, qd0, 0.05, 2, engine="numpy", **options)
    assert abs(longer.q - reference.q).max() < 1e-9  # the same motion
    forces = build_forces(system.model).add(lambda t, q, qd: 0.0 * q)
    user = forward_dynamics(system, q0, qd0, 0.05, 2, forces=forces, **options).info["chosen"]
    assert user["engine"] == "numpy" and "user forces (Python callables)" in user["engine_why"], user


def test_a_first_compilation_says_so_on_stderr(default, monkeypatch, capsys):
    """Where the code is not on disk and the run repays compiling it, one line on stderr says what is compiled,
    that it happens once per machine and that ``mbd compile`` makes all of it (here the code is on disk and
    ``is_cached`` is told otherwise: what the run would print, without a compilation's minute)."""
    import solutions.compiled as compiled
    from solutions.compiled import dispatch

    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    options = dict(formulation="baumgarte", integrator="dop853", rtol=1e-8)
    forward_dynamics(system, q0, qd0, 0.05, 2, engine="compiled", **options)  # the code on disk
    capsys.readouterr()
    monkeypatch.setattr(compiled, "is_cached", lambda job: False)
    monkeypatch.setattr(dispatch, "LOAD_SECONDS", 0.0)
    monkeypatch.setattr(dispatch, "COMPILE_SECONDS", 0.0)
    run = forward_dynamics(system, q0, qd0, 0.05, 2, **options)
    assert run.info["chosen"]["engine"] == "compiled"
    assert "more than a first compilation (0 s)" in run.info["chosen"]["engine_why"]
    lines = capsys.readouterr().err.splitlines()
    assert lines == [
        "mbd: compiling the engine of planar baumgarte runs, once per machine (10-60 s; mbd compile makes all of "
        "it) ..."
    ], lines
    monkeypatch.setattr(dispatch, "COMPILE_SECONDS", 1e9)  # not worth compiling: numpy, saying how to get it
    chosen = forward_dynamics(system, q0, qd0, 0.05, 2, **options).info["chosen"]
    assert chosen["engine"] == "numpy" and chosen["engine_why"].endswith(
        "mbd compile makes the compiled engine once per machine"
    ), chosen
    assert capsys.readouterr().err == ""


def test_kinematic_analysis_takes_the_same_default(default, monkeypatch):
    from solutions.compiled import kinematic

    system, q0, _ = build_system(load_model(MODELS / "slider_crank.yaml"))
    kinematic_analysis(system, q0, 0.1, 10, engine="compiled")  # the code on disk
    short = kinematic_analysis(system, q0, 0.1, 10).info["chosen"]
    assert short["engine"] == "numpy" and "less than loading the compiled code" in short["engine_why"], short
    monkeypatch.setattr(kinematic, "LOAD_SECONDS", 0.0)
    assert kinematic_analysis(system, q0, 0.1, 10).info["chosen"]["engine"] == "compiled"
    monkeypatch.setenv(ENGINE_VARIABLE, "numpy")
    assert "chosen" not in kinematic_analysis(system, q0, 0.1, 10).info  # the numpy steps, nothing to choose


def test_mbd_run_says_which_engine_ran_and_why(default):
    """The command line as a user runs it (no MBD_ENGINE): a short run prints numpy and the estimate behind it;
    with MBD_ENGINE=numpy nothing was chosen and no engine line is printed."""
    env = {k: v for k, v in os.environ.items() if k != ENGINE_VARIABLE}
    command = [sys.executable, "-m", "solutions.cli", "run", str(MODELS / "heavy_top.yaml"), "--t-end", "0.01"]
    command += ["--steps", "2"]
    out = subprocess.run(command, cwd=REPO, env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    line = next(line for line in out.stdout.splitlines() if line.startswith("engine:"))
    assert line.startswith("engine: numpy (numpy run estimated at ") and "less than loading the compiled" in line
    out = subprocess.run(
        command, cwd=REPO, env={**env, ENGINE_VARIABLE: "numpy"}, capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0 and "engine:" not in out.stdout, out.stdout


def test_auto_stays_on_numpy_where_the_compiled_engine_cannot_load(default, monkeypatch):
    """A package with the compiled engine but no numba to load it (a sandbox without numba's metadata, an install
    without it): ``auto`` runs numpy and says why; ``compiled``, asked for by name, raises."""
    from importlib.metadata import PackageNotFoundError

    import solutions.compiled as compiled
    from solutions.compiled import dispatch

    def missing(job):
        raise PackageNotFoundError("No package metadata was found for numba")

    monkeypatch.setattr(compiled, "is_cached", missing)
    monkeypatch.setattr(dispatch, "LOAD_SECONDS", 0.0)
    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    run = forward_dynamics(system, q0, qd0, 0.05, 2, formulation="baumgarte", integrator="dop853")
    assert run.info["chosen"]["engine"] == "numpy"
    assert run.info["chosen"]["engine_why"].startswith("the compiled engine cannot load here (No package metadata")
    with pytest.raises(PackageNotFoundError):
        forward_dynamics(system, q0, qd0, 0.05, 2, formulation="baumgarte", integrator="dop853", engine="compiled")


@pytest.mark.parametrize("name", ["quarter_car", "parallel_swing"])
def test_the_trial_estimates_the_numpy_runs_evaluations(default, monkeypatch, name):
    """``auto``'s trial (``dispatch.trial_rate``) against the evaluations the whole numpy integration takes, the same
    right-hand side, method, tolerances and span (counted here by the loop itself): within a factor of two on the
    quarter-car, whose first steps the controller rejects in turn (its eighth accepted step was 40 times shorter
    than its sixteenth: the last step's figure said 51 times the run), and on the parallel swing, whose step grows
    from a tiny starting one (8 steps' mean rate said 25 times)."""
    import numpy as np

    from solutions.compiled import dispatch
    from solutions.integrators import integrate

    class Taken(Exception):
        pass

    taken = []

    def take(equations, z0, settings, threshold=None):
        taken.append((equations.rhs, z0, settings))
        raise Taken

    monkeypatch.setattr(dispatch, "estimated_numpy_seconds", take)
    system, q0, qd0 = build_system(load_model(MODELS / f"{name}.yaml"))
    with pytest.raises(Taken):
        forward_dynamics(system, q0, qd0, 1.0, 5, rtol=1e-6, divergence="skip")
    f, z0, settings = taken[0]
    assert settings.integrator.lower() == "dop853"
    expected, per_evaluation = dispatch.trial_rate(f, z0, 1.0, settings.integrator, 1e-6, settings.atol, settings.step)
    whole = integrate(f, z0, np.array([0.0, 1.0]), lambda k, t, y: None, "dop853", 1e-6, settings.atol, settings.step,
                      max_evaluations=None, stiffness="off")  # fmt: skip
    assert whole.steps > dispatch.TRIAL_STEPS  # a real extrapolation, not the trial finishing the run
    assert 0.5 < expected / whole.rhs_evaluations < 2.0, (expected, whole.rhs_evaluations)
    assert per_evaluation > 0.0
