"""``mbd sweep`` / ``solutions.sweep``: key paths, values and outputs checked before any run, closed-form
results, failed runs with their reason, resuming, and the same table here, on a Dask LocalCluster and on
one whose worker is killed mid-run."""

from __future__ import annotations

import csv
import os
import re
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from solutions.cli import main
from solutions.sweep import SweepError, make_sweep, parse_values, read_table, run_sweep, write_table

from ..shell import as_from_a_shell

ROOT = Path(__file__).resolve().parents[2]
SLIDER_CRANK = ROOT / "course" / "models" / "slider_crank.yaml"
PENDULUM = ROOT / "course" / "models" / "simple_pendulum.yaml"


def _rows(path: Path) -> list[list[str]]:
    with open(path, newline="") as f:
        return list(csv.reader(f))


def test_values_list_range_and_seeded_sample():
    assert parse_values("0.5, 1,2").tolist() == [0.5, 1.0, 2.0]
    assert parse_values("1:2:5").tolist() == [1.0, 1.25, 1.5, 1.75, 2.0]
    a, b = parse_values("uniform(1, 2, n=50, seed=3)"), parse_values("uniform(1, 2, n=50, seed=3)")
    assert a.size == 50 and np.array_equal(a, b) and a.min() >= 1 and a.max() <= 2
    assert not np.array_equal(a, parse_values("uniform(1, 2, n=50, seed=4)"))
    normal = parse_values("normal(10, 0.1, n=400, seed=1)")
    assert abs(normal.mean() - 10) < 0.05 and 0.08 < normal.std() < 0.12


def test_grid_and_zip_sets_and_closed_form(tmp_path):
    # slider-crank driven at omega: at t = T the slider is at r cos(wT) + sqrt(l^2 - r^2 sin^2(wT))
    omegas = [5.0, 10.0, 15.0]
    sweep = make_sweep(
        SLIDER_CRANK,
        [f"motors[drive].function.coefficients[1]={','.join(map(str, omegas))}", "bodies[slider].mass=1,2"],
        ["final(slider.x)", "max(slider.x)", "residual"],
        t_end=0.3,
        steps=30,
    )
    assert sweep.sets.shape == (6, 2)  # the full grid
    result = run_sweep(sweep, tmp_path / "grid", progress=False, plots=False)
    r, l, T = 0.1, 0.3, 0.3
    w = result.column("motors[drive].function.coefficients[1]")
    closed = r * np.cos(w * T) + np.sqrt(l**2 - (r * np.sin(w * T)) ** 2)
    assert np.max(np.abs(result.column("final(slider.x)") - closed)) < 1e-9
    assert np.all(result.column("residual") < 1e-9)
    zipped = make_sweep(SLIDER_CRANK, ["bodies[crank].mass=1,2,3", "bodies[rod].mass=4,5,6"], zipped=True)
    assert zipped.sets.tolist() == [[1, 4], [2, 5], [3, 6]]
    with pytest.raises(SweepError, match="same number of values"):
        make_sweep(SLIDER_CRANK, ["bodies[crank].mass=1,2,3", "bodies[rod].mass=4,5"], zipped=True)


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--set", "bodies[crank].mas=1,2"], "bodies\\[crank\\] has no key 'mas'.*did you mean mass"),
        (["--set", "bodies[crnk].mass=1,2"], "no element named 'crnk' in model.bodies \\(names: crank, rod, slider\\)"),
        (["--set", "bodies[crank].mass=1,-2"], "--set bodies\\[crank\\].mass=-2: .*must be > 0"),
        (["--set", "bodies[crank].mass=1:2"], "start:stop:num"),
        (["--set", "bodies[crank].mass=lognormal(1, 2, n=3)"], "unknown distribution 'lognormal'"),
        (["--set", "bodies[crank].location=1,2"], "a list of 2; sweep one element, e.g. .*location\\[0\\]"),
        (["--set", "joints[O].type=1"], "holds 'revolute', not a number"),
        (["--set", "bodies[crank].mass=1", "--output", "max(slider.xx)"], "no column slider.xx"),
        (["--set", "bodies[crank].mass=1", "--output", "rms(drive.torque)"], "come from --analysis inverse"),
        (["--set", "bodies[crank].mass=1", "--output", "peak(slider.x)"], "SUMMARY\\(COLUMN\\)"),
        (["--set", "bodies[crank].mass=1", "--cluster", "somewhere"], "tcp://HOST:8786"),
        (["--output", "residual"], "give at least one --set"),
    ],
)
def test_bad_input_is_refused_before_any_run(tmp_path, capsys, arguments, message):
    out = tmp_path / "out"
    assert main(["sweep", str(SLIDER_CRANK), *arguments, "--out", str(out), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("mbd: error: ") and "\n" not in err and "Traceback" not in err
    assert re.search(message, err), err
    assert not out.exists()  # refused before any run: nothing written


def test_cli_failed_runs_keep_their_reason_and_resume(tmp_path, capsys):
    out = tmp_path / "sweep"
    arguments = [
        "sweep", str(SLIDER_CRANK), "--analysis", "inverse", "--t-end", "0.2", "--steps", "20",
        "--set", "joints[A].location[0]=0.1,0.35", "--set", "motors[drive].function.coefficients[1]=5,10",
        "--output", "max(slider.x)", "--output", "rms(drive.torque)", "--out", str(out), "--no-progress",
    ]  # fmt: skip
    assert main(arguments) == 0
    rows = _rows(out / "sweep.csv")
    assert rows[0] == [
        "run", "joints[A].location[0]", "motors[drive].function.coefficients[1]",
        "max(slider.x)", "rms(drive.torque)", "status", "reason",
    ]  # fmt: skip
    by_crank = {row[1]: row for row in rows[1:]}
    assert len(rows) == 5 and by_crank["0.1"][5] == "ok"
    failed = [row for row in rows[1:] if row[1] == "0.35"]  # a crank longer than the rod cannot turn
    assert [row[5] for row in failed] == ["failed", "failed"]
    assert all(row[3] == "nan" and "AnalysisError" in row[6] for row in failed)
    data = np.load(out / "sweep.npz")
    assert list(data["status"]) == [row[5] for row in rows[1:]]
    assert np.array_equal(data["max(slider.x)"], np.array([float(row[3]) for row in rows[1:]]), equal_nan=True)
    assert (out / "plots" / "max_slider_x.png").stat().st_size > 1000
    assert (out / "plots" / "rms_drive_torque.png").is_file()
    before = (out / "sweep.csv").read_text()
    # a sweep stopped after two runs resumes with the other two
    sweep = make_sweep(
        SLIDER_CRANK,
        ["joints[A].location[0]=0.1,0.35", "motors[drive].function.coefficients[1]=5,10"],
        ["max(slider.x)", "rms(drive.torque)"],
        analysis="inverse",
        t_end=0.2,
        steps=20,
    )
    rows_done = read_table(sweep, out)
    assert len(rows_done) == 4
    write_table(sweep, {k: rows_done[k] for k in (0, 3)}, out)
    capsys.readouterr()
    assert main(arguments) == 0
    assert "4 runs, 2 failed, 2 resumed" in capsys.readouterr().out
    assert (out / "sweep.csv").read_text() == before
    # another sweep in the same folder starts afresh
    assert main([*arguments[:-3], "--out", str(out), "--t-end", "0.1", "--no-progress"]) == 0
    assert "resumed" not in capsys.readouterr().out


# -- the same table on Dask -----------------------------------------------------------------------------------------
def _pendulum_sweep():
    return make_sweep(
        PENDULUM,
        ["bodies[rod].mass=1,2", "bodies[rod].angular_velocity=0:3:6"],
        ["max(rod.phi)", "final(rod.phi_d)", "rms(O.Fy)", "residual"],
        t_end=1.0,
        steps=50,
    )


def test_same_table_here_and_on_a_cluster(cluster, tmp_path):
    address, _ = cluster
    sweep = _pendulum_sweep()
    here = run_sweep(sweep, tmp_path / "here", jobs=1, progress=False, plots=False)
    run_sweep(sweep, tmp_path / "there", cluster=address, progress=False, plots=False)
    assert here.failed == 0 and len(here.rows) == 12
    assert (tmp_path / "here" / "sweep.csv").read_bytes() == (tmp_path / "there" / "sweep.csv").read_bytes()
    a, b = np.load(tmp_path / "here" / "sweep.npz"), np.load(tmp_path / "there" / "sweep.npz")
    assert all(np.array_equal(a[k], b[k]) for k in a.files)


def test_a_worker_killed_mid_run_loses_nothing_and_counts_nothing_twice(cluster, tmp_path):
    address, client = cluster
    sweep = make_sweep(
        PENDULUM, ["bodies[rod].angular_velocity=0:4:24"], ["max(rod.phi)", "final(rod.phi_d)"], t_end=2.0, steps=100
    )
    reference = run_sweep(sweep, tmp_path / "here", jobs=1, progress=False, plots=False)
    pids = client.run(os.getpid)
    killed = []

    def kill_a_busy_worker():
        deadline = time.time() + 60
        while time.time() < deadline and not killed:
            busy = [w for w, tasks in client.processing().items() if any("sweep-" in str(t) for t in tasks)]
            if busy:
                os.kill(pids[busy[0]], signal.SIGKILL)
                killed.append(busy[0])
            time.sleep(0.01)

    killer = threading.Thread(target=kill_a_busy_worker)
    killer.start()
    result = run_sweep(sweep, tmp_path / "killed", cluster=address, progress=False, plots=False)
    killer.join()
    assert killed, "no worker was busy to kill"
    assert killed[0] not in client.scheduler_info()["workers"] or client.run(os.getpid)[killed[0]] != pids[killed[0]]
    assert sorted(result.rows) == list(range(24)) and result.failed == 0
    rows = _rows(tmp_path / "killed" / "sweep.csv")
    assert [row[0] for row in rows[1:]] == [str(k) for k in range(24)]  # each run once
    assert (tmp_path / "here" / "sweep.csv").read_bytes() == (tmp_path / "killed" / "sweep.csv").read_bytes()
    assert reference.failed == 0


def test_cli_jobs_2_runs_on_a_local_cluster_with_the_same_table(tmp_path, capsys):
    arguments = ["sweep", str(PENDULUM), "--set", "bodies[rod].mass=1:2:4", "--output", "max(rod.phi_d)"]
    arguments += ["--t-end", "0.5", "--steps", "20", "--no-progress"]
    assert main([*arguments, "--out", str(tmp_path / "one")]) == 0
    assert main([*arguments, "--out", str(tmp_path / "two"), "--jobs", "2"]) == 0
    assert "on a local Dask cluster" in capsys.readouterr().out
    assert (tmp_path / "one" / "sweep.csv").read_bytes() == (tmp_path / "two" / "sweep.csv").read_bytes()


def test_ctrl_c_stops_mbd_sweep_with_one_line_and_the_next_run_resumes(tmp_path):
    """SIGINT to ``mbd sweep`` once its table is first written (after WRITE_EVERY seconds of runs: the 400 runs
    take several seconds, so that the signal comes while they run; 100 of them took one second in session 21 and
    were all done when the first table came): one line, exit 130, and the same command resumes from the runs it
    had."""
    import subprocess
    import sys

    out = tmp_path / "sweep"
    command = [
        sys.executable, "-m", "solutions.cli", "sweep", str(SLIDER_CRANK), "--set", "bodies[crank].mass=0.5:2:400",
        "--t-end", "0.5", "--steps", "50", "--out", str(out),
    ]  # fmt: skip
    process = subprocess.Popen(
        command, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=as_from_a_shell
    )
    deadline = time.monotonic() + 300
    while not (out / "sweep.csv").is_file() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)  # polling for the table (written after the first second of runs), not a fixed wait
    assert process.poll() is None, "the sweep ended before it could be interrupted"
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 130, err[-2000:]
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith("mbd:")]
    assert len(lines) == 1 and "runs done, run the same command again to resume" in lines[0]
    before = len(_rows(out / "sweep.csv")) - 1
    assert 0 < before < 400
    again = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True)
    assert again.returncode == 0, again.stderr[-2000:]
    assert f"400 runs, 0 failed, {before} resumed" in again.stdout
