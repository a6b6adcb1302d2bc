"""The peers' search (benchmarks/peers.py: ``search``) on configurations whose error is known: where a scan stops,
and which attempts are timed again. (The peers themselves are an optional extra; these need neither.)"""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import peers  # noqa: E402

SCENE = SimpleNamespace(key="fake", t_end=1.0, outputs=10, dimension=2, ref_positions=np.zeros((11, 1, 2)))


def family(label: str, error, calls: list) -> peers.Family:
    """A configuration whose run at step h has the position error ``error(h)`` and takes 1 ms."""

    def attempt(h):
        calls.append((label, h))
        return 1e-3, np.full((11, 1, 2), error(h))

    return peers.Family(label, attempt, tuple(0.1 / k for k in peers.SUBSTEPS))


@pytest.fixture
def scan(monkeypatch):
    calls: list = []

    def run(**errors):
        found = [family(label, error, calls) for label, error in errors.items()]
        monkeypatch.setattr(peers, "families", lambda scene, quick: found)
        return peers.search(SCENE, False, 3), calls

    return run


def test_a_scan_ends_where_it_reaches_the_finest_target_and_times_the_first_run_at_each_target_again(scan):
    runs, calls = scan(fourth=lambda h: 1e3 * h**4)  # 1e-3 at h = 0.032, 1e-6 at 0.0056, 1e-9 at 0.001
    errors = [r.error for r in runs]
    assert errors[-1] <= 1e-9 < errors[-2]  # no step finer than needed
    firsts = [next(r for r in runs if r.error <= target) for target in peers.TARGETS]
    assert len({id(r) for r in firsts}) == 3
    for run in runs:  # timed again (a run of 1 ms: all three repeats) only if first at a target
        assert run.repeats == (3 if any(run is r for r in firsts) else 1), run
    assert len(calls) == len(runs) + 3 * 3  # every attempt once, and three repeats for each target's first


def test_a_scan_ends_when_the_error_stops_falling(scan):
    runs, _ = scan(floor=lambda h: 2e-3 + h**2)  # a soft constraint's error: a floor it never passes
    assert len(runs) < len(peers.SUBSTEPS)
    best = min(r.error for r in runs)
    assert best > 1e-3 and sum(r.error >= 0.5 * best for r in runs[-peers.STALLED :]) == peers.STALLED


def test_a_failing_configuration_is_reported_and_the_others_go_on(scan):
    def broken(h):
        raise RuntimeError("unstable")

    runs, _ = scan(broken=broken, fourth=lambda h: 1e3 * h**4)
    failed = [r for r in runs if r.config == "broken"]
    assert failed and all(r.failure == "RuntimeError: unstable" for r in failed)
    assert any(r.config == "fourth" and r.error <= 1e-9 for r in runs)


def test_interleaved_rounds_alternate_the_order_and_give_one_ratio_a_round():
    calls = []

    def ours():
        calls.append("ours")
        return 3.0 if len(calls) < 3 else 1.0  # the machine slows down in the first round only

    def theirs():
        calls.append("theirs")
        return 2.0 if len(calls) < 3 else 1.0

    ratios = peers.interleaved(ours, theirs, 4)
    assert calls == ["theirs", "ours", "ours", "theirs", "theirs", "ours", "ours", "theirs"]
    assert ratios == [1.5, 1.0, 1.0, 1.0]


def test_the_peer_table_gives_the_paired_median_and_range():
    from benchmarks import bench

    ours = bench.Run("fake", "compiled joint-coordinates dop853", "compiled", 1e-6, error=1e-7, ms=2.0)
    peer = peers.PeerRun("fake", "MuJoCo RK4", 1e-3, error=1e-7, ms=4.0)
    assert bench.ratio_cell(ours, peer, [0.4, 0.7, 0.5]) == "0.50 (0.40-0.70)"
    assert bench.ratio_cell(ours, peer, None) == "0.50"  # no rounds: the two medians' ratio
    assert bench.ratio_cell(ours, None, None) == "ours only"


def test_paired_rounds_set_our_fastest_run_against_the_peers_fastest_at_each_target():
    from benchmarks import bench

    scene = next(s for s in bench.scenes() if s.key == "double_pendulum")
    scene.t_end, scene.outputs = 0.05, 5
    config = bench.Config("baumgarte dop853", "baumgarte", "DOP853")
    own = [
        bench.Run(scene.key, config.label, "", 1e-4, error=5e-4, ms=1.0),  # reaches 1e-3 only
        bench.Run(scene.key, config.label, "", 1e-7, error=5e-7, ms=3.0),  # the fastest to 1e-6
        bench.Run(scene.key, config.label, "", 1e-8, error=5e-8, ms=4.0),
    ]
    calls = []
    tried = [peers.PeerRun(scene.key, "MuJoCo RK4", h, error=e, ms=1.0) for h, e in ((1e-2, 1e-4), (1e-3, 1e-7))]
    fake = peers.Family("MuJoCo RK4", lambda h: (calls.append(h) or 1e-3, None), (1e-2, 1e-3))
    pairs = bench.paired_rounds(scene, own, tried, {config.label: config}, {"MuJoCo RK4": fake}, 3)
    assert [(p.target, p.ours, p.theirs) for p in pairs] == [
        (1e-3, "baumgarte dop853 1e-04", "MuJoCo RK4, h = 0.01"),
        (1e-6, "baumgarte dop853 1e-07", "MuJoCo RK4, h = 0.001"),
    ]  # nothing of either reaches 1e-9
    assert calls == [1e-2] * 3 + [1e-3] * 3 and all(len(p.ratios) == 3 and min(p.ratios) > 0 for p in pairs)
