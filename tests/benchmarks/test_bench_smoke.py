"""Smoke runs of the benchmark and the stress study: they run and write their tables (no timing is judged)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import bench, stress  # noqa: E402


def test_bench_quick_writes_its_tables_and_diagrams(tmp_path, capsys):
    argv = ["--quick", "--no-peers", "--no-progress", "--repeats", "1", "--out", str(tmp_path), "--keep-cache"]
    assert bench.main(argv) == 0
    text = (tmp_path / "bench.md").read_text()
    assert "## Summary: fastest configuration at equal error" in text
    assert "## Microseconds per right-hand side" in text
    assert "straightforward: element loop + solve_ivp RK45" in text
    assert "| planar double pendulum | compiled baumgarte dop853 |" in text  # the compiled engine's row
    for key in ("double_pendulum", "heavy_top"):
        assert (tmp_path / f"{key}.png").stat().st_size > 1000
    runs = json.loads((tmp_path / "bench.json").read_text())["runs"]
    assert runs and all(r["failure"] == "" for r in runs)
    compiled = [r for r in runs if r["family"] == "compiled"]
    assert compiled and all(r["compile_seconds"] > 0 and r["us_per_step"] > 0 for r in compiled)
    # the references are independent of the solver and the runs are judged against them: errors are small
    assert all(r["error"] < 1e-3 for r in runs)
    assert "Summary" in capsys.readouterr().out


def test_bench_times_ours_as_a_prepared_run_when_asked(monkeypatch):
    """``--prepared``: our timed call is ``run`` of one ``prepare`` (the same result as the call), its preparation
    timed apart and reported."""
    import numpy as np

    from solutions.assembly import build_system
    from solutions.dynamics import forward_dynamics

    scene = next(s for s in bench.scenes() if s.key == "double_pendulum")
    scene.t_end, scene.outputs = 0.2, 4
    system, q0, qd0 = build_system(scene.load())
    settings = bench.Config("baumgarte dop853", "baumgarte", "dop853").settings(1e-6)
    run = bench.Run(scene.key, "baumgarte dop853", "", 1e-6)
    monkeypatch.setattr(bench, "PREPARED", [True])
    call = bench.our_call(system, q0, qd0, scene, settings, run)
    assert run.prepare_seconds > 0
    assert np.array_equal(call().q, forward_dynamics(system, q0, qd0, 0.2, 4, **settings).q)
    assert bench.preparation({scene.key: [run]}).endswith(")."), "the range and median of the preparations"


def test_bench_references_agree_with_a_tight_run():
    """The minimal-coordinate references (written in bench.py) and the solver agree: neither is copied."""
    for scene in bench.scenes():
        if scene.key in ("double_pendulum", "heavy_top", "carriage_pendulum"):
            scene.t_end, scene.outputs = 0.5, 10
            bench.prepare_reference(scene, quick=True)
            difference = float(scene.ref_note.rsplit("differs by ", 1)[1].split()[0])
            assert difference < 1e-8, (scene.key, scene.ref_note)


@pytest.mark.parametrize("study", ["redundant", "mass", "singular"])
def test_stress_quick_studies_end_passed_or_diagnosed(tmp_path, study):
    assert stress.main(["--quick", "--study", study, "--out", str(tmp_path)]) == 0
    text = (tmp_path / "stress_quick.md").read_text()
    assert "| study | case | method | outcome |" in text
    assert "SILENT WRONG ANSWER |" not in text


def test_bench_runs_the_stress_study_beside_it(tmp_path, capsys):
    """``mbd bench --stress`` starts stress.py in a second process and reports its summary line at the end."""
    child = bench.start_stress_study(tmp_path, quick=True, studies=("redundant",))
    assert bench.finish_stress_study(child, tmp_path, quick=True) == 0
    summary = capsys.readouterr().out
    assert summary.startswith("Stress study (stress_quick.md): quick run") and "0 SILENT" in summary
    assert "| redundant |" in (tmp_path / "stress_quick.md").read_text()


@pytest.mark.parametrize("clock", [[], ["--cpu"], ["--cpu", "--prepared"]], ids=["wall", "cpu", "prepared"])
def test_call_cost_times_every_stage_of_a_compiled_call(capsys, clock):
    """benchmarks/call_cost.py: every stage it wraps is still where it looks, and each was timed in the call, by
    the wall clock or (--cpu) this thread's CPU time; with --prepared, in prepared.run, the preparation apart."""
    from benchmarks import call_cost

    call_cost.main(["--scene", "double_pendulum", "--calls", "1", *clock])
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].endswith("thread CPU)" if clock else "wall)")
    assert ("prepared.run" in lines[0]) == ("--prepared" in clock)
    rows = [line.split(" | ") for line in lines[4:]]  # | stage | ms |
    cells = {label.strip("| ").replace("&nbsp;", " "): value.strip(" |*") for label, value in rows}
    if "--prepared" in clock:
        assert float(cells.pop("preparation (prepare + first run)")) > 0
    assert list(cells)[2] == "whole call with the divergence check" and float(cells[list(cells)[2]]) > 0
    labels = list(dict.fromkeys(label for _, _, label in call_cost.STAGES + call_cost.COMPANION))
    assert labels == list(cells)[3:]
    two_pass = "    constraints at the output times"  # a Psi_q above ONE_PASS_LARGEST entries only: not this one
    assert cells.pop(two_pass) == "-"
    assert all(float(value) > 0 for value in list(cells.values())[3:]), cells


def test_viewer_cost_measures_the_player_and_the_viewer_of_one_result():
    """benchmarks/viewer_cost.py: one row, both builds timed, both sizes counted."""
    from benchmarks import viewer_cost

    cells = [c.strip() for c in viewer_cost.measure("slider_crank", 3, 1).strip("|").split("|")]
    assert cells[0] == "slider_crank" and all(float(c) > 0 for c in cells[1:])


def test_process_accounting_reads_version_3_records_and_sums_them(tmp_path):
    """benchmarks/process_accounting.py: records written as the kernel writes them (struct acct_v3, comp_t times)
    read back and summed by name; where this process may turn accounting on, a real child is found in it."""
    from benchmarks import process_accounting as acct

    def record(pid, ppid, name, ticks):  # comp_t: 13-bit mantissa, base-8 exponent
        exponent = 0
        while ticks >= 1 << 13:
            ticks, exponent = ticks >> 3, exponent + 1
        return acct.RECORD.pack(0, 3, 0, 0, 0, 0, pid, ppid, 0, 250.0, ticks | exponent << 13, 0, 0, 0, 0, 0, 0, 0,
                                name.encode())  # fmt: skip

    path = tmp_path / "acct"
    path.write_bytes(record(10, 1, "python", 150) + record(11, 10, "python", 16384) + record(12, 10, "bwrap", 7))
    processes = acct.read(str(path))
    expected = [(10, "python", 1.5), (11, "python", 163.84), (12, "bwrap", 0.07)]
    assert [(p.pid, p.name, p.cpu) for p in processes] == expected
    assert processes[0].seconds == 2.5
    text = acct.table(processes)
    assert text.startswith("3 processes, 165 CPU s") and "| python | 2 | 165.3 |" in text
    try:
        acct.accounting(str(tmp_path / "real"))
    except OSError:
        return  # not root, or no accounting in this kernel
    try:
        subprocess.run([sys.executable, "-c", "sum(range(3_000_000))"], check=True)
    finally:
        acct.accounting(None)
    assert any(p.name.startswith("python") and p.cpu > 0 for p in acct.read(str(tmp_path / "real")))
