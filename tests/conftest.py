"""Shared fixture: a planar four-bar linkage with its closed-form kinematics (loop closure).

Ground pivots O2 = (0, 0) and O4 = (d, 0); crank a (angle theta2), coupler b (theta3), rocker c (theta4):
    a e(theta2) + b e(theta3) - c e(theta4) - d e_x = 0,   e(theta) = (cos theta, sin theta).
Position: B is where the circle of radius b about A = a e(theta2) meets the circle of radius c about O4,
on the "open" branch (B to the left of A -> O4):  theta3 = angle(O4 - A) + acos((b^2 + f^2 - c^2) / (2 b f)),
f = |O4 - A|. Velocity and acceleration: the loop equation differentiated once and twice, dotted with
e(theta4) and e(theta3) to eliminate one unknown at a time (e_perp(i) . e(j) = sin(theta_j - theta_i)):
    w3 = a w2 sin(t4 - t2) / (b sin(t3 - t4)),   w4 = a w2 sin(t3 - t2) / (c sin(t3 - t4))
    al3 = (a al2 sin(t4 - t2) - a w2^2 cos(t2 - t4) - b w3^2 cos(t3 - t4) + c w4^2) / (b sin(t3 - t4))
    al4 = (a al2 sin(t3 - t2) - a w2^2 cos(t2 - t3) - b w3^2 + c w4^2 cos(t4 - t3)) / (c sin(t3 - t4))
Bodies have their centres of mass at the link midpoints and phi equal to the link angle.
"""

from __future__ import annotations

import contextlib
import math
import os
import resource
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

_ISOLATION: dict[str, str | None] = {}


COMPILED_CACHE = Path(__file__).resolve().parents[1] / "build" / "test-cache" / "compiled"
"""The compiled engine's cache of the test run (``$MBD_COMPILED_CACHE``, unless set already): one folder that every
pytest-xdist worker and every subprocess of the run inherits, so that each compiled module is compiled once per
run and clone (never the user's own cache, which a clean clone's run does not find warm either)."""

TEST_SECRET = "mbd-course-test-session-secret"
"""The course secret of the test session (``$MBD_GRADER_SECRET``): grading refuses to start without one."""


def pytest_configure(config):
    """The grader's sandbox is bubblewrap. Where it truly cannot run (not installed, or the kernel refuses
    its namespaces), the isolation tests skip with the reason and the other grading tests run on the local
    backend (``MBD_UNSAFE_NO_ISOLATION=1``, inherited by grading workers and nbgrader's kernels).

    The compiled engine's cache is the run's (COMPILED_CACHE). A run that names no engine runs the numpy
    engine (``MBD_ENGINE=numpy``): a test of the reference code tests it, whatever the tests before it compiled
    (the default ``auto`` takes the compiled engine for a long run once its code is on disk); the tests of the
    default engine (tests/solutions/test_default_engine.py) remove the variable. Every test and its subprocesses
    grade with the session's own course secret (never the user's), from which the hidden and per-student scenes
    are derived; their references are cached in the user's cache folder."""
    from mbdkit import isolation
    from solutions.settings import ENGINE_VARIABLE

    os.environ["MBD_GRADER_SECRET"] = TEST_SECRET
    os.environ.setdefault("MBD_COMPILED_CACHE", str(COMPILED_CACHE))  # before pytest-xdist starts its workers
    os.environ.setdefault(ENGINE_VARIABLE, "numpy")
    os.environ.setdefault("MBD_KIT_NOTES", "as-written")  # a release's kit notes in 4 s, not executed (1 min)

    _join_cpu_group()
    _ISOLATION["problem"] = problem = isolation.problem()
    if problem is not None:
        os.environ[isolation.UNSAFE_ENV] = "1"


SLOW = {
    "course/test_nbgrader_cycle_hw3.py": "nbgrader",
    "course/test_nbgrader_cycle_hw1.py": "nbgrader",
    "autograder/test_grading.py": "isolation",
    "course/test_notebooks.py": "notebooks",
    "solutions/test_compiled_formulations.py": "compiled",
    "course/test_kit.py": "kit",
    "autograder/test_every_function_graded.py": "isolation",
    "course/test_release.py": "notebooks",
    "course/test_nbgrader_cycle_hw2.py": "nbgrader",
    "autograder/test_hostile_grader.py": "isolation",
    "solutions/test_compiled_models.py": "compiled",
    "autograder/test_isolation.py": "isolation",
    "autograder/test_fairness.py": "isolation",
    "solutions/test_compiled_history.py": "compiled",
    "course/test_nbgrader_config.py": "nbgrader",
    "autograder/test_withheld.py": "isolation",
    "autograder/test_wall.py": "isolation",
    "solutions/test_sweep.py": "cluster",
    "solutions/test_singular_redundant.py": "long",
    "solutions/test_viewer_browser.py": "browser",
    "solutions/test_symbolic.py": "long",
    "autograder/test_gradebook.py": "isolation",
    "solutions/test_compiled_kinematics.py": "compiled",
    "autograder/test_kernel.py": "isolation",
    "autograder/test_reference.py": "long",
    "benchmarks/test_bench_smoke.py": "bench",
    "autograder/test_cluster.py": "cluster",
    "course/test_notes.py": "notebooks",
    "solutions/test_compiled.py": "compiled",
    "solutions/test_precompile.py": "compiled",  # after the other compiled files: it finds most modules on disk
    "autograder/test_fair_diagnosis.py": "isolation",
    "autograder/test_sandbox.py": "isolation",
    "autograder/test_api.py": "isolation",
    "course/test_nbcheck.py": "nbgrader",
    "solutions/test_serve.py": "browser",
}
"""The slow tier, by test file (relative to tests/) and family: notebooks run by nbgrader or nbclient, the
nbgrader cycle, kits installed in fresh venvs, classes graded in sandboxes, Dask clusters, numba compiles, long
runs (singular positions, symbolic derivations, every stored reference run again).
``make test-fast`` (``-m "not slow"``) leaves them out; ``make test`` (CI) runs everything. Listed longest
first (the per-file durations of benchmarks/results/tests.md): they are collected first, then the files that hold
one of SLOW_TESTS, so that pytest-xdist hands the longest units out first and no worker is left with a long one
at the end."""
SLOW_TESTS = {
    "solutions/test_cli.py::test_bench_quick_writes_its_table": "bench",
    "solutions/test_examples.py::test_kinematics_benchmark_quick_runs": "bench",
    "autograder/test_secret.py::test_hidden_scenes_assemble_and_run_for_many_secrets": "long",
    "solutions/test_batch.py::test_executors_return_the_same_results": "cluster",
    "solutions/test_batch.py::test_a_scheduler_that_does_not_answer_is_one_error": "cluster",
}
"""Single slow tests of otherwise fast files."""


def pytest_collection_modifyitems(config, items):
    """Mark the slow tier (``slow`` and the family's marker) and put its files first, longest first. ``make test``
    runs ``--dist loadfile --no-loadscope-reorder``: each test file is one pytest-xdist work unit, handed out in
    this order, its module-scoped fixtures built once on its worker. (A file that should be several units is
    several files: the nbgrader cycle is one file per homework.)"""
    tests = Path(__file__).parent
    order = {name: k for k, name in enumerate([*SLOW, *(test.split("::")[0] for test in SLOW_TESTS)])}

    def where(item) -> str:
        return Path(item.fspath).relative_to(tests).as_posix()

    for item in items:
        relative = where(item)
        family = SLOW.get(relative) or SLOW_TESTS.get(f"{relative}::{item.name.split('[')[0]}")
        if family is not None:
            item.add_marker(pytest.mark.slow)
            item.add_marker(getattr(pytest.mark, family))
    items.sort(key=lambda item: order.get(where(item), len(order)))  # stable: the rest keep their order


CPUACCT = Path("/sys/fs/cgroup/cpuacct")
"""cgroup v1's CPU accounting hierarchy: a group of its own per test process counts every process that process
starts, waited for or not (the grader's sandboxes too: ``mbdkit.cgroup`` moves them in the memory, pids and cpu
hierarchies only)."""
_CPU_GROUP: dict[str, Path] = {}


def _join_cpu_group() -> None:
    """Put this process (and so whatever it starts) into a cpuacct group of its own, where one can be made (root,
    cgroup v1 with a cpuacct hierarchy of its own); elsewhere the CPU seconds come from ``getrusage``."""
    if not (CPUACCT / "cpuacct.usage").is_file() or (CPUACCT / "cpu.shares").exists():  # absent, or one with cpu
        return
    for stale in CPUACCT.glob("mbd-tests-*"):  # of earlier runs whose processes outlived the test process
        with contextlib.suppress(OSError):
            stale.rmdir()  # only an empty group goes: a running test process's is never empty
    group = CPUACCT / f"mbd-tests-{os.getpid()}"
    try:
        group.mkdir(exist_ok=True)
        (group / "cgroup.procs").write_text(str(os.getpid()))
    except OSError:
        return
    _CPU_GROUP["group"] = group


def pytest_unconfigure(config):
    """This process back into the cpuacct hierarchy's root and its group removed (if a process it started is
    still in it, the next run's ``_join_cpu_group`` removes it)."""
    group = _CPU_GROUP.pop("group", None)
    if group is not None:
        try:
            (CPUACCT / "cgroup.procs").write_text(str(os.getpid()))
            group.rmdir()
        except OSError:
            pass


def _cpu_seconds() -> float:
    """CPU seconds of this process and all it started: its cpuacct group's usage where it has one, else the user
    and system time of this process and of its children that have ended and been waited for (kernels,
    subprocesses, a Dask cluster's workers; not what runs in a sandbox, whose processes bubblewrap reaps)."""
    group = _CPU_GROUP.get("group")
    if group is not None:
        try:
            return int((group / "cpuacct.usage").read_text()) / 1e9
        except (OSError, ValueError):
            pass
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


_CPU_START = pytest.StashKey[float]()
_STARTED = pytest.StashKey[float]()


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    item.stash[_CPU_START] = _cpu_seconds()
    item.stash[_STARTED] = time.time()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Each test's CPU seconds (setup, call and teardown; a module fixture's on the test that built it;
    ``_cpu_seconds``) as the JUnit property ``cpu``: what a test costs the run on a CPU-bound machine, whatever
    the other worker does meanwhile (``python benchmarks/durations.py build/junit.xml`` lists it beside the wall
    time); when its setup started (``started``, seconds since the epoch) and on which pytest-xdist worker
    (``worker``): where each worker was busy, idle or done before the run ended (durations.py's workers table)."""
    if call.when == "teardown" and _CPU_START in item.stash:
        item.user_properties.append(("cpu", f"{_cpu_seconds() - item.stash[_CPU_START]:.2f}"))
        item.user_properties.append(("started", f"{item.stash[_STARTED]:.3f}"))
        item.user_properties.append(("worker", os.environ.get("PYTEST_XDIST_WORKER", "main")))
    yield


class LazyModule:
    """The module ``name``, imported at the first use of one of its names, not at collection: for a test file whose
    module compiles machine code when it is imported (``solutions.compiled.singular`` 42 s, ``loops`` 15 s on a fresh
    cache). Imported at collection, such a module was compiled by every pytest-xdist worker at once before any test
    ran (69 s of a clean clone's start-up, both workers, in the run of 2026-12-06); imported where a test first needs
    it, it is compiled by one worker while the other runs tests (tests/test_suite.py checks that collecting imports
    none). Dunder names and ``_mock_name`` are pytest's probes of every module-level object at collection: refused,
    not imported for. Setting a name (``monkeypatch.setattr``) sets the module's."""

    __slots__ = ("_module_name",)

    def __init__(self, name: str):
        object.__setattr__(self, "_module_name", name)

    @property
    def __dict__(self):  # monkeypatch reads what it will put back from here
        return self._module().__dict__

    def _module(self):
        import importlib

        return importlib.import_module(self._module_name)

    def __getattr__(self, attribute: str):
        if attribute.startswith("__") or attribute == "_mock_name":
            raise AttributeError(attribute)
        return getattr(self._module(), attribute)

    def __setattr__(self, attribute: str, value) -> None:  # monkeypatch.setattr: the module's own name
        setattr(self._module(), attribute, value)


COLLECTED: dict[str, set] = {}
"""The modules imported once the tests were collected (``pytest_collection_finish``; tests/test_suite.py)."""


def pytest_collection_finish(session):
    import sys

    COLLECTED["modules"] = set(sys.modules)


def pytest_report_header(config):
    problem = _ISOLATION.get("problem")
    if problem is None:
        return "grading sandbox: bubblewrap (operating-system isolation)"
    return f"grading sandbox: NONE ({problem}); isolation tests skipped, grading tests use the local backend"


def e(theta):
    return np.array([np.cos(theta), np.sin(theta)])


def e_perp(theta):
    return np.array([-np.sin(theta), np.cos(theta)])


@dataclass
class FourBar:
    a: float = 0.1  # crank
    b: float = 0.35  # coupler
    c: float = 0.3  # rocker
    d: float = 0.4  # ground

    def angles(self, theta2: float) -> tuple[float, float]:
        """theta3, theta4 on the open branch."""
        A = self.a * e(theta2)
        D = np.array([self.d, 0.0]) - A
        f = float(np.hypot(*D))
        theta3 = math.atan2(D[1], D[0]) + math.acos((self.b**2 + f**2 - self.c**2) / (2 * self.b * f))
        B = A + self.b * e(theta3)
        theta4 = math.atan2(B[1], B[0] - self.d)
        return theta3, theta4

    def link_rates(self, theta2, w2, al2):
        """(theta, w, alpha) of crank, coupler and rocker."""
        t3, t4 = self.angles(theta2)
        a, b, c = self.a, self.b, self.c
        s34 = math.sin(t3 - t4)
        w3 = a * w2 * math.sin(t4 - theta2) / (b * s34)
        w4 = a * w2 * math.sin(t3 - theta2) / (c * s34)
        al3 = (
            a * al2 * math.sin(t4 - theta2)
            - a * w2**2 * math.cos(theta2 - t4)
            - b * w3**2 * math.cos(t3 - t4)
            + c * w4**2
        ) / (b * s34)
        al4 = (
            a * al2 * math.sin(t3 - theta2)
            - a * w2**2 * math.cos(theta2 - t3)
            - b * w3**2
            + c * w4**2 * math.cos(t4 - t3)
        ) / (c * s34)
        return (theta2, w2, al2), (t3, w3, al3), (t4, w4, al4)

    def body_states(self, theta2, w2=0.0, al2=0.0):
        """q, q', q'' (9 each: crank, coupler, rocker) from the closed form."""
        crank, coupler, rocker = self.link_rates(theta2, w2, al2)

        def along(base, link, length):  # point at distance ``length`` along a link from a moving base point
            (p, v, acc), (th, w, al) = base, link
            return (
                p + length * e(th),
                v + length * w * e_perp(th),
                acc + length * al * e_perp(th) - length * w**2 * e(th),
            )

        origin = (np.zeros(2), np.zeros(2), np.zeros(2))
        pivot4 = (np.array([self.d, 0.0]), np.zeros(2), np.zeros(2))
        joint_a = along(origin, crank, self.a)
        centres = [
            along(origin, crank, self.a / 2),
            along(joint_a, coupler, self.b / 2),
            along(pivot4, rocker, self.c / 2),
        ]
        q, qd, qdd = (
            np.concatenate([[*centres[k][n], link[n]] for k, link in enumerate((crank, coupler, rocker))])
            for n in range(3)
        )
        return q, qd, qdd

    def model(self, theta2: float = 0.0, motor: str | None = "angle", function=None, frame: str = "global") -> dict:
        """The four-bar as a model mapping, assembled at crank angle theta2.

        motor: 'angle' (revolute O, relative to the file's configuration), 'coordinate' (crank phi,
        absolute), 'rocker' (angle motor on the rocker's pivot D), or None. frame: 'global' gives
        joint locations; 'body' gives each joint's points in the body frames (link lengths).
        """
        q, _, _ = self.body_states(theta2)
        names = ("crank", "coupler", "rocker")
        bodies = [
            {
                "name": n,
                "mass": 1.0,
                "inertia": 0.01,
                "location": [float(q[3 * k]), float(q[3 * k + 1])],
                "orientation": float(q[3 * k + 2]),
            }
            for k, n in enumerate(names)
        ]
        t3, t4 = self.angles(theta2)
        A = self.a * e(theta2)
        B = A + self.b * e(t3)
        if frame == "global":
            joints = [
                {"name": "O", "type": "revolute", "body1": "ground", "body2": "crank", "location": [0.0, 0.0]},
                {"name": "A", "type": "revolute", "body1": "crank", "body2": "coupler", "location": A.tolist()},
                {"name": "B", "type": "revolute", "body1": "coupler", "body2": "rocker", "location": B.tolist()},
                {"name": "D", "type": "revolute", "body1": "ground", "body2": "rocker", "location": [self.d, 0.0]},
            ]
        else:
            a, b, c = self.a / 2, self.b / 2, self.c / 2
            joints = [
                {
                    "name": "O",
                    "type": "revolute",
                    "body1": "ground",
                    "body2": "crank",
                    "point1": [0.0, 0.0],
                    "point2": [-a, 0.0],
                },
                {
                    "name": "A",
                    "type": "revolute",
                    "body1": "crank",
                    "body2": "coupler",
                    "point1": [a, 0.0],
                    "point2": [-b, 0.0],
                },
                {
                    "name": "B",
                    "type": "revolute",
                    "body1": "coupler",
                    "body2": "rocker",
                    "point1": [b, 0.0],
                    "point2": [c, 0.0],
                },
                {
                    "name": "D",
                    "type": "revolute",
                    "body1": "ground",
                    "body2": "rocker",
                    "point1": [self.d, 0.0],
                    "point2": [-c, 0.0],
                },
            ]
            for joint in joints:
                joint["frame"] = "body"
        function = function if function is not None else {"type": "polynomial", "coefficients": [0.0, 1.0]}
        motors = {
            None: [],
            "angle": [{"name": "drive", "type": "angle", "joint": "O", "function": function}],
            "coordinate": [
                {"name": "drive", "type": "coordinate", "body": "crank", "coordinate": "phi", "function": function}
            ],
            "rocker": [{"name": "drive", "type": "angle", "joint": "D", "function": function}],
        }[motor]
        return {"model": {"name": "four-bar", "bodies": bodies, "joints": joints, "motors": motors}}


@pytest.fixture
def four_bar() -> FourBar:
    """A Grashof crank-rocker: crank 0.1, coupler 0.35, rocker 0.3, ground 0.4 (s + l = 0.5 < p + q = 0.65)."""
    return FourBar()


@pytest.fixture(scope="module")
def cluster():
    """One Dask LocalCluster of 2 worker processes per test module that asks for it (startup costs a few
    seconds); its workers import this checkout (PYTHONPATH). Yields (scheduler address, client)."""
    import logging
    from pathlib import Path

    distributed = pytest.importorskip("dask.distributed")
    root = str(Path(__file__).resolve().parents[1])
    env = {"PYTHONPATH": os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p)}
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, memory_limit=0, dashboard_address=":0", silence_logs=logging.CRITICAL,
        env=env,
    ) as lc, distributed.Client(lc) as client:  # fmt: skip
        yield lc.scheduler_address, client


def execute_notebook(client) -> None:
    """``client.execute()`` (an nbclient NotebookClient) on an event loop that ``asyncio.run`` closes afterwards:
    nbclient's ``execute`` (jupyter_core's ``run_sync``) makes a loop of its own per thread and leaves it open, even
    where the caller set one, which a later test on the worker meets as an unclosed-loop ResourceWarning."""
    import asyncio

    asyncio.run(client.async_execute())
