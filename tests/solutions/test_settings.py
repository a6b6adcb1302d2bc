"""One settings object for the API, the command line, the model file and sweeps (``solutions.settings``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError
from solutions.dynamics import forward_dynamics
from solutions.io.model import load_model
from solutions.settings import DRIFT_LIMIT, SettingError, Settings, read_settings, table

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"


def test_every_setting_states_its_file_key_what_it_takes_and_what_it_does():
    for f in table():
        assert f.metadata["key"] and f.metadata["takes"] and len(f.metadata["help"]) > 20, f.name
        if f.metadata["takes"] == "name":
            default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
            assert default in f.metadata["names"], f.name


def test_the_file_gives_a_setting_and_an_option_overrides_it():
    simulation = {"end_time": 2.0, "rtol": 1e-7, "formulation": "qr"}
    settings = read_settings(simulation, rtol=1e-9, steps=None)
    assert (settings.t_end, settings.rtol, settings.formulation, settings.steps) == (2.0, 1e-9, "qr", 100)
    assert settings.engine == Settings().engine  # the same default from a file and from Python


@pytest.mark.parametrize(
    ("simulation", "given", "message"),
    [
        ({"rtol": -1.0}, {}, "simulation.rtol -1.0: must be a number > 0"),
        ({}, {"rtol": 0.0}, "--rtol 0.0: must be a number > 0"),
        ({"integrator": "RK54"}, {}, "simulation.integrator 'RK54': unknown integrator (one of: auto,"),
        ({}, {"steps": 2.5}, "--steps 2.5: must be a whole number >= 1"),
        ({"through_singular": 1}, {}, "simulation.through_singular 1: must be true or false"),
        ({}, {"alpha": 3.0}, "--alpha (simulation.alpha) is an option of the baumgarte"),
    ],
)
def test_a_bad_setting_is_named_as_the_user_wrote_it(simulation, given, message):
    with pytest.raises(SettingError) as raised:
        read_settings(simulation, **given)
    assert str(raised.value).startswith(message), str(raised.value)


def test_from_python_a_bad_setting_is_an_analysis_error_naming_the_keyword():
    with pytest.raises(AnalysisError, match=r"^unknown formulation 'baumgarten' \(one of: auto, baumgarte"):
        Settings(formulation="baumgarten")
    with pytest.raises(ValueError, match=r"^accuracy = 0: must be a number > 0"):
        Settings(accuracy=0)


def test_zero_turns_a_check_off_and_other_keywords_are_options_of_the_formulation():
    settings = Settings(drift_limit=0, singular_ratio=0.0)
    assert settings.drift_limit is None and settings.singular_ratio is None
    assert Settings().drift_limit == DRIFT_LIMIT
    changed = Settings(formulation="baumgarte").replace(alpha=2.0, rtol=1e-9, tol=1e-13)
    assert changed.rtol == 1e-9 and changed.options == {"tol": 1e-13}
    assert changed.formulation_options == {"alpha": 2.0, "tol": 1e-13}


def test_replace_checks_what_it_changes_and_keeps_what_it_does_not():
    """``replace`` checks a changed value, and one equal to the old but of another type (steps = 100.0 is no whole
    number); values equal to the old ones (a run's plan repeats them) stay as they are, the options merged."""
    settings = Settings(steps=100, rtol=1e-6, options={"tol": 1e-12})
    same = settings.replace(steps=100, rtol=1e-6, formulation=settings.formulation)
    assert same == settings and same is not settings and same.options is not settings.options
    with pytest.raises(ValueError, match="steps = 100.0: must be a whole number"):
        settings.replace(steps=100.0)
    with pytest.raises(ValueError, match="rtol = -1e-06: must be a number > 0"):
        settings.replace(rtol=-1e-6)
    assert settings.replace(drift_limit=0).drift_limit is None and settings.replace(penalty=5.0).penalty == 5.0


def test_a_settings_object_and_keywords_give_the_same_run():
    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    settings = Settings(formulation="baumgarte", integrator="DOP853", rtol=1e-9, alpha=2.0, beta=2.0)
    by_object = forward_dynamics(system, q0, qd0, 0.2, 4, settings=settings)
    by_keywords = forward_dynamics(system, q0, qd0, 0.2, 4, "baumgarte", "DOP853", rtol=1e-9, alpha=2.0, beta=2.0)
    np.testing.assert_array_equal(by_object.q, by_keywords.q)
    assert by_object.info["formulation"] == "baumgarte" and by_object.info["rtol"] == 1e-9
    assert (by_object.info["alpha"], by_object.info["beta"]) == (2.0, 2.0)
