"""benchmarks/first_runs.py: numba's compile events are caught per run, the package's functions told apart from
numba's own, and the verdict follows them (the study itself, on fresh caches after ``mbd compile``, is a benchmark)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

numba = pytest.importorskip("numba")

from benchmarks import first_runs  # noqa: E402


def test_a_compilation_in_a_run_is_caught_and_named():
    events = first_runs.CompileEvents()
    events.take()

    @numba.njit
    def twice(x):
        return 2 * x

    assert twice(3) == 6
    taken = events.take()
    assert taken["ours"] == [] and "test_a_compilation_in_a_run_is_caught_and_named.<locals>.twice" in taken["numba"]
    assert taken["compile_seconds"] > 0
    assert twice(4) == 8  # the version is there: a second call compiles nothing
    assert events.take() == {"ours": [], "numba": [], "compile_seconds": 0.0}


def test_the_report_names_each_run_that_compiled():
    quiet = {"case": "planar N = 2", "formulation": "baumgarte", "engine": "compiled", "seconds": 0.01}
    quiet |= {"ours": [], "numba": [], "compile_seconds": 0.0}
    gap = quiet | {"case": "loops N = 2", "ours": ["compiled.singular._spectra"], "compile_seconds": 4.2}
    text = first_runs.report({"wall": 90.0, "cpu": 170.0, "last_line": "the engine is compiled"}, [quiet, gap])
    assert "90.0 s wall, 170.0 s CPU" in text
    assert "| loops N = 2 | baumgarte | compiled | 0.010 | compiled.singular._spectra | - | 4.200 |" in text
    assert text.rstrip().endswith("2 runs; 1 compiled something: loops N = 2 baumgarte.")
    assert first_runs.report(None, [quiet]).rstrip().endswith("1 runs; 0 compiled something.")


def test_a_run_on_the_callers_caches_is_reported(tmp_path):
    """``--no-compile`` without ``--caches``: the runs in a new process on this test run's caches; the exit status is
    the report's verdict."""
    out = tmp_path / "first_runs.md"
    argv = ["--no-compile", "--families", "planar", "--sizes", "2", "--formulations", "joint-coordinates"]
    status = first_runs.main([*argv, "--no-models", "--out", str(out)])
    text = out.read_text()
    assert "| planar N = 2 | joint-coordinates | compiled |" in text
    assert status == (0 if text.rstrip().endswith("1 runs; 0 compiled something.") else 1)
