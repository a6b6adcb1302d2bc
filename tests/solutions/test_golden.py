"""Every example model against its golden summary (tests/solutions/golden.py says what a summary holds and how to
regenerate the file after a change meant to change results)."""

from __future__ import annotations

import json
import math

import pytest

from .golden import ENERGY_LIMIT, GOLDEN, MODELS, RESIDUAL_LIMIT, check, summarize

STORED = json.loads(GOLDEN.read_text())
NOISE = ("max_constraint_residual", "energy_drift")
"""Numbers at the level of round-off and the integrator's tolerance: held to their limits, not to their digits."""
ABSOLUTE = 1e-8
"""The absolute agreement asked of a number near zero: 100 times tighter than the accuracy the runs ask (1e-6 of the
mechanism's size). Two machines' rounding (AVX-512 against AVX2 kernels, numba's code for each) part a chaotic run's
trajectories at the integrator's error: 2.6e-9 in q.rod2.e3 of the spatial double pendulum (2026-12-03)."""


def test_every_example_model_has_a_golden_summary():
    assert sorted(STORED) == sorted(path.stem for path in MODELS), "make golden"


def test_the_stored_summaries_pass_the_physics_checks():
    assert [problem for name, summary in STORED.items() for problem in check(name, summary)] == []


@pytest.mark.parametrize("path", MODELS, ids=lambda path: path.stem)
def test_the_model_runs_to_its_golden_summary(path):
    golden, summary = STORED[path.stem], summarize(path)
    assert sorted(summary) == sorted(golden)
    changed = {
        key: (summary[key], golden[key])
        for key in golden
        if key not in NOISE and not math.isclose(summary[key], golden[key], rel_tol=1e-7, abs_tol=ABSOLUTE)
    }
    assert changed == {}, "a result changed (make golden regenerates the summaries: review their diff)"
    assert summary.get("max_constraint_residual", 0.0) <= max(10 * golden.get("max_constraint_residual", 0.0), 1e-12)
    assert summary.get("max_constraint_residual", 0.0) <= RESIDUAL_LIMIT
    assert summary.get("energy_drift", 0.0) <= min(max(10 * golden.get("energy_drift", 0.0), 1e-10), ENERGY_LIMIT)
