"""The test run itself: ``make test``'s pytest-xdist options keep each test file on one worker, so that a file's
module-scoped fixtures (a nbgrader course, a graded class, executed notebooks) are built once per run.

Measured in the clean-clone run of 2026-11-28: with ``--dist loadgroup`` under pytest 9 the ``xdist_group`` marks
were ignored (pytest-xdist 3.8 renames ``item._nodeid``, which pytest 9 no longer reads), every test was a unit
of its own and the nbgrader cycles, the executed notebooks and the graded classes were built on both workers.
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

from .conftest import COLLECTED

REPO = Path(__file__).resolve().parents[1]

FILE = """
import os

import pytest


@pytest.fixture(scope="module")
def built():
    with open(os.environ["BUILDS"], "a") as f:
        f.write(__name__ + "\\n")


@pytest.mark.parametrize("k", range(6))
def test_one(built, k):
    pass


@pytest.mark.parametrize("k", range(3))
def test_two(built, k):
    pass
"""


def make_test_options() -> list[str]:
    """The pytest-xdist options of ``make test`` (the Makefile's PYTEST line)."""
    line = next(line for line in (REPO / "Makefile").read_text().splitlines() if line.startswith("PYTEST :="))
    words = shlex.split(line.split(":=", 1)[1].replace("$(TEST_WORKERS)", "2"))
    return words[words.index("pytest") + 1 :]


def test_make_test_builds_each_files_module_fixtures_once(tmp_path):
    for name in ("a", "b", "c", "d"):
        (tmp_path / f"test_{name}.py").write_text(FILE)
    builds = tmp_path / "builds.txt"
    done = subprocess.run(
        [sys.executable, "-m", "pytest", *make_test_options(), "-p", "no:cacheprovider", "-q", str(tmp_path)],
        cwd=tmp_path, capture_output=True, text=True, timeout=300, env={"BUILDS": str(builds), "PATH": "/usr/bin:/bin"},
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert re.search(r"36 passed", done.stdout), done.stdout[-2000:]
    built = sorted(builds.read_text().split())
    assert len(built) == 4 and len(set(built)) == 4, built  # each file's fixture once, on one worker


ORPHAN = """
import os, time
if os.fork() == 0:  # the grandchild: half a CPU second, after its parent has gone (init reaps it, not pytest)
    start = time.process_time()
    while time.process_time() - start < 0.5:
        pass
os._exit(0)
"""


def test_a_tests_cpu_counts_a_process_it_started_and_never_waited_for(request):
    """The JUnit ``cpu`` of a test (tests/conftest.py) holds what runs in processes no one in the test waits for,
    as bubblewrap's sandbox processes: here an orphan that spins for half a CPU second."""
    import resource
    import time

    import pytest

    conftest = next(
        m
        for m in request.config.pluginmanager.get_plugins()
        if getattr(m, "__file__", None) == str(REPO / "tests" / "conftest.py")
    )

    if "group" not in conftest._CPU_GROUP:
        pytest.skip("no cpuacct group of its own here (root and cgroup v1's cpuacct hierarchy needed)")
    waited = resource.getrusage(resource.RUSAGE_CHILDREN)
    before = conftest._cpu_seconds()
    subprocess.run([sys.executable, "-c", ORPHAN], check=True)
    deadline = time.monotonic() + 30
    while conftest._cpu_seconds() - before < 0.5 and time.monotonic() < deadline:
        time.sleep(0.1)
    assert conftest._cpu_seconds() - before >= 0.5
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    assert after.ru_utime + after.ru_stime - waited.ru_utime - waited.ru_stime < 0.4  # getrusage misses it


COMPILED_AT_IMPORT = {
    "solutions.compiled.singular": 42,
    "solutions.compiled.loops": 15,
    "solutions.compiled.kinematic_loop": 6,
}
"""Modules whose import compiles machine code on a fresh cache (functions with explicit signatures), with its
seconds measured on the course's VM (``NUMBA_CACHE_DIR`` empty, ``python -c "import ..."``, 2026-12-06)."""


def test_no_test_file_compiles_machine_code_when_it_is_collected():
    """Every pytest-xdist worker collects every test file before any test runs: a module that compiles at import,
    imported by a test file at its module level, was compiled by both workers at once, with nothing else running (69 s
    of the clean-clone run's start-up). Test files use it through ``tests/conftest.py::LazyModule``: collecting the
    tests (this process's, every test file under ``make test``) imported none of them."""
    imported = COLLECTED["modules"] & set(COMPILED_AT_IMPORT)
    assert not imported, sorted(imported)
