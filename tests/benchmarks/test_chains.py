"""The scaling study's references (benchmarks/chains.py): each chain family's ODE, written for the benchmark without
the package's code, against the package's runs of the same chain at tight tolerance. They agree to 1e-11 m or so,
so a configuration's error in the study is its own, not its reference's."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import chains  # noqa: E402
from benchmarks.bench import body_positions  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.dynamics import forward_dynamics  # noqa: E402
from solutions.io.model import load_model  # noqa: E402

TIMES = np.linspace(0.0, chains.T_END, chains.OUTPUTS + 1)


@pytest.mark.parametrize(
    ("family", "n", "formulation"),
    [
        ("planar", 3, "joint-coordinates"),
        ("spatial", 3, "joint-coordinates"),
        ("spatial", 2, "baumgarte"),
        ("loops", 2, "baumgarte"),
    ],  # fmt: skip
)
def test_each_family_s_reference_is_the_package_s_motion(family, n, formulation):
    system, q0, qd0 = build_system(load_model(chains.FAMILIES[family](n)))
    run = forward_dynamics(system, q0, qd0, chains.T_END, chains.OUTPUTS, formulation, "dop853", rtol=1e-11,
                           atol=1e-11, engine="numpy")  # fmt: skip
    truth = chains.reference(family, n, system, q0, qd0, TIMES)
    ours = body_positions(run.q, system.model.dimension)
    assert truth.shape == ours.shape
    assert np.max(np.abs(truth - truth[0])) > 0.3  # the chain moves: a reference frozen at the start would fail
    assert np.max(np.abs(ours - truth)) < 1e-8


def test_paired_rounds_alternate_and_divide_ours_by_theirs(monkeypatch):
    """``paired``: each round one call of ours and one rollout of MuJoCo's, the order alternating, the ratio ours /
    theirs per round (MuJoCo replaced by a clock that says how it was called)."""
    order = []

    class Theirs:
        def __init__(self, family, n, k, integrator):
            assert (family, n, k, integrator) == ("planar", 2, 4, "RK4")

        def __call__(self):
            order.append("theirs")
            return 0.5, None

    def ours(*args, **kwargs):
        order.append("ours")

    clock = iter(range(100))  # each call of ours lasts one tick
    monkeypatch.setattr(chains, "MujocoRun", Theirs)
    monkeypatch.setattr(chains, "forward_dynamics", ours)
    monkeypatch.setattr(chains.time, "perf_counter", lambda: float(next(clock)))
    row = chains.Row("planar", 2, "MuJoCo RK4", setting=("RK4", 4))
    ratios = chains.paired("planar", 2, chains.PAIRED, (None, None, None, 2), row, 4)
    assert ratios == [2.0, 2.0, 2.0, 2.0]
    assert order == ["theirs", "ours", "ours", "theirs", "theirs", "ours", "ours", "theirs"]


def test_mbd_bench_scaling_runs_the_study_and_writes_its_table(tmp_path, capsys):
    """``mbd bench --scaling`` hands its other options to the study: a quick run (numpy, N = 2) writes its table."""
    from benchmarks import bench

    out = tmp_path / "chains.md"
    argv = ["--scaling", "--family", "planar", "--sizes", "2", "--repeats", "1", "--configs", "numpy baumgarte dop853"]
    assert bench.main([*argv, "--out", str(out)]) == 0
    text = out.read_text()
    assert "## planar (error against an independent ODE at 1e-12" in text
    row = next(line for line in text.splitlines() if line.startswith("| 2 | numpy baumgarte dop853 |"))
    assert float(row.split("|")[6]) < 1e-4  # the error column: the run follows the reference


def test_scaling_times_ours_as_a_prepared_run_when_asked(tmp_path):
    """``--prepared``: ours is ``prepared.run`` of one ``prepare`` (the header says so), with the same error as the
    call's (the same run)."""
    from benchmarks import bench

    out = tmp_path / "chains.md"
    argv = ["--scaling", "--family", "planar", "--sizes", "2", "--repeats", "1", "--configs", "numpy baumgarte dop853"]
    try:
        assert bench.main([*argv, "--prepared", "--out", str(out)]) == 0
    finally:
        chains.PREPARED[0] = False
    text = out.read_text()
    assert "ours: prepared.run" in text
    row = next(line for line in text.splitlines() if line.startswith("| 2 | numpy baumgarte dop853 |"))
    assert float(row.split("|")[6]) < 1e-4


@pytest.fixture(scope="module")
def mujoco_loops():
    """MuJoCo (skipped without it) and the loop chain's reference at N = 1 over the study's 1 s."""
    mujoco = pytest.importorskip("mujoco")
    return mujoco, chains.loop_reference(1, TIMES)


def test_mujoco_s_loop_chain_follows_the_reference_and_its_closure_s_softness_counts(mujoco_loops):
    """The loop chain's MJCF (``mbd export --to mjcf``: hinges and a connect equality) loads and, run by MuJoCo's RK4
    at h = 2.5 ms with the stiffest closure, stays within 1e-7 m of the crank angle's ODE over 1 s (measured 1.6e-8);
    MuJoCo's default solimp lets the loop open by more than 1e-5 m at h = 10 ms (2.2e-4), the stiffest by less
    than 1e-6 (2.7e-7): the closure the search sets reaches the model and its softness is in the error."""
    _, truth = mujoco_loops
    assert np.max(np.abs(truth - truth[0])) > 0.3  # the chain swings
    stiff, _, default = chains.CLOSURES[:3]
    assert chains.mujoco_attempt("loops", 1, 4, "RK4", truth, 1, stiff)[1] < 1e-7
    assert chains.mujoco_attempt("loops", 1, 1, "RK4", truth, 1, stiff)[1] < 1e-6
    assert chains.mujoco_attempt("loops", 1, 1, "RK4", truth, 1, default)[1] > 1e-5


def test_mbd_bench_scaling_sets_mujoco_s_loop_chain_against_ours(mujoco_loops, tmp_path, monkeypatch):
    """``mbd bench --scaling --family loops --mujoco``: MuJoCo's row names its closure (the stiff solimp: RK4 at
    h = 10 ms with solref 2h, or 5 ms with 0.02 s when the machine's noise says so), reaches 1e-6 m, and the paired
    rounds run it again with that closure (ours: the numpy engine here, no compilation in a test); ``--cpu`` times
    this thread's CPU and says so."""
    from benchmarks import bench

    monkeypatch.setattr(chains, "PAIRED", chains.Config("numpy", "joint-coordinates"))
    monkeypatch.setattr(chains, "CPU", [False])  # --cpu sets the module's clock: a list of its own here
    out = tmp_path / "chains.md"
    argv = ["--scaling", "--family", "loops", "--sizes", "1", "--repeats", "1", "--mujoco", "--rounds", "1", "--cpu"]
    assert bench.main([*argv, "--configs", "numpy joint-coordinates dop853", "--out", str(out)]) == 0
    lines = out.read_text().splitlines()
    assert "times: thread CPU" in lines[2]
    row = next(line for line in lines if line.startswith("| 1 | MuJoCo RK4 h = "))
    assert "solimp 0.9999 0.9999" in row
    assert float(row.split("|")[6]) <= chains.MUJOCO_TARGET  # the error column
    paired = next(line for line in lines if line.startswith("| 1 | rtol = "))
    assert "solref" in paired.split("|")[3] and float(paired.split("|")[4]) > 0
