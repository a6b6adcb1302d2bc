"""Stored reference runs: they match what solutions/ computes now, and the comparison can fail."""

from __future__ import annotations

import numpy as np

from autograder.reference import all_specs, compare_references, load_reference, make_reference
from autograder.scenes import load_scene


def test_stored_references_match_the_reference_code():
    problems = []
    for scene, specs in sorted(all_specs().items()):
        problems += compare_references(load_reference(scene), make_reference(load_scene(scene), specs))
    assert problems == []


def test_a_changed_reference_is_detected():
    stored = load_reference("slider_crank")
    fresh = make_reference(load_scene("slider_crank"), all_specs()["slider_crank"])
    key = next(k for k in fresh.arrays if k.startswith("kinematic_run/qdd"))
    fresh.arrays[key] = fresh.arrays[key] * (1 + 1e-6)
    problems = compare_references(stored, fresh)
    assert problems and "kinematic_run/qdd" in problems[0]


def test_run_tolerances_come_from_the_integrators_own_error():
    """The RK45 run of the double pendulum at rtol 1e-8 is compared with a tolerance of ten times its
    own error against DOP853 at rtol 1e-12: far below the error of a wrong term, above round-off."""
    reference = load_reference("double_pendulum")
    tol = reference.extra("dynamic_run", "tol:q")
    assert tol.shape == (6,) and np.all(tol > 1e-10) and np.all(tol < 1e-5)
    assert 0 < float(reference.extra("dynamic_run", "bound:energy")) < 1e-5
    assert 0 < float(reference.extra("dynamic_run", "bound:drift")) < 1e-6
