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
