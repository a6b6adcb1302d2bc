"""Every solver option that decides whether or how a run succeeds is a simulation key and a command-line
option of the same name (issue 18), validated like the rest of the file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from solutions.assembly import build_system
from solutions.cli import build_parser, main
from solutions.dynamics import forward_dynamics
from solutions.io.model import _schema, load_model
from solutions.settings import table

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
NEW = (
    "alpha",
    "beta",
    "penalty",
    "rank_tol",
    "repartition_ratio",
    "max_evaluations",
    "drift_limit",
    "singular_ratio",
    "stiffness",
)


def test_every_setting_is_a_file_key_and_an_option():
    keys = _schema()["properties"]["simulation"]["properties"]
    parser = build_parser()
    options = {a.dest: a for a in parser._subparsers._group_actions[0].choices["run"]._actions}
    file_key = {f.name: f.metadata["key"] for f in table()}
    for option, key in file_key.items():
        assert key in keys, key
        assert option in options and options[option].help, option
    for option in NEW:
        assert file_key[option] == option and "description" in keys[option]
        assert f"--{option.replace('_', '-')}" in options[option].option_strings


def write(tmp_path, name: str, simulation: dict) -> Path:
    data = yaml.safe_load((MODELS / name).read_text())
    data["simulation"] = {**data.get("simulation", {}), **simulation}
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def test_options_in_the_file_reach_the_run(tmp_path):
    path = write(
        tmp_path,
        "double_pendulum.yaml",
        {
            "end_time": 0.2,
            "output_steps": 4,
            "formulation": "baumgarte",
            "integrator": "DOP853",
            "alpha": 0.0,
            "beta": 0.0,
        },
    )
    out = tmp_path / "r.npz"
    assert main(["run", str(path), "--rtol", "1e-10", "--out", str(out)]) == 0
    system, q0, qd0 = build_system(load_model(path))
    direct = forward_dynamics(
        system,
        q0,
        qd0,
        0.2,
        4,
        formulation="baumgarte",
        integrator="DOP853",
        rtol=1e-10,
        atol=1e-12,
        alpha=0.0,
        beta=0.0,
    )
    default = forward_dynamics(
        system, q0, qd0, 0.2, 4, formulation="baumgarte", integrator="DOP853", rtol=1e-10, atol=1e-12
    )
    written = np.load(out)
    np.testing.assert_allclose(written["q"], direct.q, rtol=0, atol=1e-13)
    assert np.max(np.abs(written["q"] - default.q)) > 1e-11  # alpha = beta = 0 is another run than the default 5, 5


@pytest.mark.parametrize(
    ("simulation", "argv", "fragment"),
    [
        ({"rank_tol": -1e-9}, [], "simulation.rank_tol"),
        ({"max_evaluations": 2.5}, [], "simulation.max_evaluations"),
        ({"stiffness": "loud"}, [], "simulation.stiffness: unknown value 'loud'"),
        ({}, ["--max-evaluations", "0"], "--max-evaluations 0: must be a whole number >= 1"),
        ({}, ["--penalty", "0"], "--penalty 0.0: must be a number > 0"),
        ({}, ["--alpha", "-1"], "--alpha -1.0: must be a number >= 0"),
        ({"formulation": "qr"}, ["--penalty", "1e6"], "option of the augmented-lagrangian formulation, not of qr"),
        ({"formulation": "projection"}, ["--alpha", "2"], "not of projection: add --formulation baumgarte"),
        ({"formulation": "baumgarte", "integrator": "DOP853"}, ["--max-evaluations", "20"], "budget of 20"),
    ],
)
def test_bad_or_misplaced_options_exit_2(tmp_path, capsys, simulation, argv, fragment):
    path = write(tmp_path, "double_pendulum.yaml", {"end_time": 0.5, **simulation})
    assert main(["run", str(path), *argv]) == 2
    err = capsys.readouterr().err
    assert fragment in err and "Traceback" not in err and err.count("\n") == 1, err


def test_checks_can_be_turned_off_by_zero(tmp_path, capsys):
    path = write(
        tmp_path,
        "double_pendulum.yaml",
        {"end_time": 0.1, "output_steps": 2, "drift_limit": 0, "singular_ratio": 0, "stiffness": "off"},
    )
    assert main(["run", str(path), "--formulation", "svd", "--rank-tol", "1e-10"]) == 0


SLIDER = str(MODELS / "slider_crank.yaml")


def _one_line(capsys) -> str:
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.startswith("mbd: error: "), (out, err)
    return err


@pytest.mark.parametrize(
    "argv, said",
    [
        (["rnu", SLIDER], "did you mean run?"),
        (["run", SLIDER, "--tend", "2"], "unrecognized arguments: --tend 2; did you mean --t-end? (mbd run --help"),
        (["run", SLIDER, "--formulaton", "qr"], "did you mean --formulation?"),
        (["run", SLIDER, "--t-end", "abc"], "argument --t-end: invalid float value: 'abc' (mbd run --help"),
    ],
)
def test_a_misspelt_command_option_or_number_is_one_line_with_the_closest_name(argv, said, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert said in _one_line(capsys)


@pytest.mark.parametrize(
    "option, path, said",
    [
        ("--out", "r.xlsx", "results are written as FILE.csv (a table) or FILE.npz"),
        ("--out", "no-such-folder/r.csv", "no folder no-such-folder"),
        ("--plot", "p.txt", "a plot is written as one of "),
        ("--animate", "a.avi", "animations are .gif or .mp4 files"),
        ("--animate", "no-such-folder/a.html", "no folder no-such-folder"),
    ],
)
def test_an_output_that_cannot_be_written_is_refused_before_the_run(option, path, said, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["run", SLIDER, option, path]) == 2
    assert said in _one_line(capsys)  # nothing printed on stdout: the run's summary never came
    assert list(tmp_path.iterdir()) == []


def test_the_kits_mbd_names_the_closest_command(capsys):
    from mbdkit.cli import main as kit

    with pytest.raises(SystemExit) as stop:
        kit(["slefcheck", "hw1"])
    assert stop.value.code == 2 and "did you mean selfcheck?" in _one_line(capsys)


def test_stiffness_off_unquoted_in_a_yaml_file_is_the_word(tmp_path):
    """YAML 1.1 reads an unquoted ``off`` as false; ``simulation: {stiffness: off}`` means the setting's word."""
    data = yaml.safe_load((MODELS / "double_pendulum.yaml").read_text())
    path = tmp_path / "off.yaml"
    path.write_text(yaml.safe_dump({"model": data["model"]}) + "simulation:\n  stiffness: off\n")
    assert yaml.safe_load(path.read_text())["simulation"]["stiffness"] is False  # what PyYAML makes of it
    assert load_model(path).simulation["stiffness"] == "off"
