"""The `mbd` command line: results files, refusals with exit code 2 and one clear message."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from solutions.cli import main
from solutions.io.results import read_csv

ROOT = Path(__file__).resolve().parents[2]
SLIDER_CRANK = ROOT / "course" / "models" / "slider_crank.yaml"
PENDULUM = ROOT / "course" / "models" / "simple_pendulum.yaml"

PENDULUM_FREE = """
model:
  name: free-pendulum
  bodies:
    - {name: bob, mass: 1.0, inertia: 0.01, location: [0.5, 0.0]}
  joints:
    - {name: O, type: revolute, body1: ground, body2: bob, location: [0.0, 0.0]}
"""


def test_run_writes_design_columns_and_matches_closed_form(tmp_path):
    out = tmp_path / "r.csv"
    assert main(["run", str(SLIDER_CRANK), "--out", str(out)]) == 0
    columns = read_csv(out)
    names = list(columns)
    assert names[:4] == ["t", "crank.x", "crank.y", "crank.phi"]
    for body in ("crank", "rod", "slider"):
        for suffix in ("", "_d", "_dd"):
            assert f"{body}.phi{suffix}" in names
    t = columns["t"]
    theta = 10.0 * t  # the crank is driven at 10 rad/s from 0
    r, l = 0.1, 0.3
    x_closed = r * np.cos(theta) + np.sqrt(l**2 - (r * np.sin(theta)) ** 2)
    assert np.max(np.abs(columns["slider.x"] - x_closed)) < 1e-9


def test_run_npz_holds_the_same_arrays(tmp_path):
    out = tmp_path / "r.npz"
    assert main(["run", str(SLIDER_CRANK), "--steps", "20", "--out", str(out)]) == 0
    data = np.load(out)
    assert data["q"].shape == (21, 9)
    np.testing.assert_array_equal(data["slider.x"], data["q"][:, 6])


def test_kinematic_run_of_a_free_model_is_refused(tmp_path, capsys):
    model = tmp_path / "free.yaml"
    model.write_text(PENDULUM_FREE)
    assert main(["run", str(model), "--analysis", "kinematic"]) == 2
    err = capsys.readouterr().err
    assert "1 degree(s) of freedom" in err and "motor" in err
    assert "Traceback" not in err


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", "the file is empty"),
        ("model: [unclosed", "malformed YAML"),
        (
            "model:\n  bodies:\n    - {name: a, mass: 1.0, inertia: 1.0, location: [0, 0]}\n"
            "  joints:\n    - {type: revolute, body1: ground, body2: couplr, location: [0, 0]}\n",
            "model.joints[0].body2: no body named 'couplr'",
        ),
        ("model:\n  bodies:\n    - {name: a, mass: -1.0, inertia: 1.0, location: [0, 0]}\n", "mass: must be > 0"),
    ],
)
def test_bad_model_file_exits_2_with_one_message(tmp_path, text, expected):
    model = tmp_path / "bad.yaml"
    model.write_text(text)
    proc = subprocess.run(
        [sys.executable, "-m", "solutions.cli", "run", str(model)], capture_output=True, text=True, cwd=tmp_path
    )
    assert proc.returncode == 2
    assert expected in proc.stderr
    assert "bad.yaml" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_missing_file_and_bad_option_exit_2(tmp_path, capsys):
    assert main(["run", str(tmp_path / "nope.yaml")]) == 2
    assert "cannot read" in capsys.readouterr().err
    assert main(["run", str(SLIDER_CRANK), "--point", "nobody:0,0"]) == 2
    assert "no body named 'nobody'" in capsys.readouterr().err


def test_check_reports_dof_and_redundancy(capsys):
    assert main(["check", str(SLIDER_CRANK)]) == 0
    out = capsys.readouterr().out
    assert "degrees of freedom: 0" in out
    assert "redundant equations: none" in out


def test_plot_and_points(tmp_path):
    png = tmp_path / "p.png"
    out = tmp_path / "p.csv"
    code = main(
        [
            "run",
            str(SLIDER_CRANK),
            "--steps",
            "50",
            "--plot",
            str(png),
            "--point",
            "pin=crank:0.1,0.0",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    assert png.stat().st_size > 10_000
    columns = read_csv(out)
    theta = 10.0 * columns["t"]
    np.testing.assert_allclose(columns["pin.x"], 0.1 * np.cos(theta), atol=1e-12)
    np.testing.assert_allclose(columns["pin.y_d"], 1.0 * np.cos(theta), atol=1e-10)


def test_dynamic_run_writes_reactions_that_satisfy_newtons_law(tmp_path):
    """The pin reaction of the simple pendulum is F = m a - m g on the only body (no other force acts)."""
    out = tmp_path / "pendulum.csv"
    model = ROOT / "course" / "models" / "simple_pendulum.yaml"
    assert main(["run", str(model), "--analysis", "dynamic", "--t-end", "1", "--steps", "50", "--out", str(out)]) == 0
    columns = read_csv(out)
    from solutions.io.model import load_model

    spec = load_model(model)
    (body,) = spec.bodies
    fx = body.mass * columns[f"{body.name}.x_dd"] - body.mass * spec.gravity[0]
    fy = body.mass * columns[f"{body.name}.y_dd"] - body.mass * spec.gravity[1]
    joint = spec.joints[0]["name"]
    np.testing.assert_allclose(columns[f"{joint}.Fx"], fx, atol=1e-6 * body.mass * 9.81)
    np.testing.assert_allclose(columns[f"{joint}.Fy"], fy, atol=1e-6 * body.mass * 9.81)


def test_animate_writes_a_gif_and_refuses_an_unknown_format(tmp_path, capsys):
    gif = tmp_path / "crank.gif"
    assert main(["run", str(SLIDER_CRANK), "--steps", "10", "--animate", str(gif)]) == 0
    assert gif.read_bytes()[:6] in (b"GIF87a", b"GIF89a")
    assert main(["run", str(SLIDER_CRANK), "--steps", "10", "--animate", str(tmp_path / "crank.xyz")]) == 2
    assert ".gif" in capsys.readouterr().err


def test_bench_quick_writes_its_table(tmp_path):
    out = tmp_path / "bench"
    assert main(["bench", "--quick", "--no-progress", "--no-peers", "--out", str(out)]) == 0
    table = (out / "bench.md").read_text()
    assert "straightforward" in table


def test_unknown_option_outside_bench_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as info:
        main(["run", str(SLIDER_CRANK), "--bogus"])
    assert info.value.code == 2


def assert_one_error(err: str, *expected: str) -> None:
    """stderr is one line 'mbd: error: ...' holding every expected text, and no traceback."""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("mbd: error: ")
    assert "Traceback" not in err
    for text in expected:
        assert text in lines[0]


def test_unknown_coordinate_to_plot_is_refused_before_the_run(tmp_path, capsys):
    png = tmp_path / "p.png"
    assert main(["run", str(SLIDER_CRANK), "--plot", str(png), "--coords", "nosuch.x"]) == 2
    out, err = capsys.readouterr()
    assert_one_error(err, "--coords nosuch.x", "slider.x")
    assert out == "" and not png.exists()
    assert main(["run", str(SLIDER_CRANK), "--steps", "10", "--plot", str(png), "--coords", "slider.x"]) == 0
    assert png.is_file()


@pytest.mark.parametrize("model", [SLIDER_CRANK, PENDULUM], ids=["kinematic", "dynamic"])
@pytest.mark.parametrize(
    ("option", "value", "expected"),
    [
        ("--integrator", "foo", "--integrator 'foo': unknown integrator (one of: auto, RK45"),
        ("--formulation", "foo", "--formulation 'foo': unknown formulation (one of: auto, baumgarte"),
        ("--rtol", "-1", "--rtol -1.0: must be a number > 0"),
        ("--atol", "-1", "--atol -1.0: must be a number > 0"),
        ("--step", "0", "--step 0.0: must be a number > 0"),
        ("--t-end", "0", "--t-end 0.0: must be a number > 0"),
        ("--steps", "0", "--steps 0: must be a whole number >= 1"),
    ],
)
def test_bad_analysis_option_is_refused_on_every_model(model, option, value, expected, capsys):
    assert main(["run", str(model), option, value]) == 2
    out, err = capsys.readouterr()
    assert_one_error(err, expected)
    assert out == ""  # refused before any analysis ran


def test_bad_setting_in_the_file_is_named_by_its_key(tmp_path, capsys):
    model = tmp_path / "pendulum.yaml"
    model.write_text(PENDULUM.read_text().replace("integrator: RK45", "integrator: foo"))
    assert main(["run", str(model)]) == 2
    assert_one_error(capsys.readouterr().err, "simulation.integrator 'foo': unknown integrator")


def test_valid_options_still_run_and_unused_ones_are_noted(capsys):
    assert main(["run", str(SLIDER_CRANK), "--steps", "10", "--integrator", "rk4", "--rtol", "1e-6"]) == 0
    out, err = capsys.readouterr()
    assert "note: not used by the kinematic analysis: --integrator, --rtol" in out
    assert err == ""
    args = ["--t-end", "0.1", "--steps", "10", "--integrator", "rk4", "--step", "0.01", "--formulation", "qr"]
    assert main(["run", str(PENDULUM), *args]) == 0
    out = capsys.readouterr().out
    assert "integrator: rk4" in out and "note:" not in out


def test_analysis_option_has_help(capsys):
    with pytest.raises(SystemExit) as info:
        main(["run", "--help"])
    assert info.value.code == 0
    help_text = " ".join(capsys.readouterr().out.split())
    assert "kinematic when the drivers leave no degree of freedom, dynamic otherwise" in help_text
    assert "inverse" in help_text


def test_release_refusal_has_the_mbd_prefix(capsys):
    assert main(["release", "hw9"]) == 2
    assert_one_error(capsys.readouterr().err, "unknown homework 'hw9'")
