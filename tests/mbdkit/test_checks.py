"""Comparison and messages of the checks: NaN-safe, diagnoses that fit everywhere, invariants that count
only for a run that moves like the reference."""

from __future__ import annotations

import numpy as np
import pytest

from autograder.reference import load_reference
from autograder.tolerances import invariants
from mbdkit import diagnosis
from mbdkit.checks import compare, evaluate
from mbdkit.homework import load_homework
from mbdkit.sandbox import Limits, Reply
from mbdkit.scenes import load_public_scene


def check(homework: str, name: str):
    return next(c for c in load_homework(homework).checks if c.name == name)


def test_the_worst_entry_is_a_failing_one_never_a_nan_of_the_reference():
    spec = check("hw1", "four_bar.gamma.revolute")
    reference = load_reference("four_bar")
    rows = [i for i, kind in enumerate(reference.meta["row_kinds"]) if kind == "revolute"]
    expected = reference.arrays[f"{spec.probe_key}/gamma"].copy()
    expected[0, rows[0]] = np.nan  # the reference has no value there: never compared, never "the worst"
    reference.arrays[f"{spec.probe_key}/gamma"] = expected
    got = np.nan_to_num(expected.copy(), nan=0.0)
    got[2, rows[1]] = np.nan
    passed, message, _ = compare(spec, "gamma", got, reference, hidden=False)
    assert not passed and "got nan" in message and "expected nan" not in message and "tolerance nan" not in message
    assert "state 3" in message and reference.meta["row_labels"][rows[1]] in message


def test_a_known_mistake_must_fit_every_entry_not_only_the_failing_ones():
    from solutions.rotations import g_matrix, l_matrix

    p = np.array([0.8, 0.2, -0.4, 0.4])
    p /= np.linalg.norm(p)
    expected, mistaken = l_matrix(p), g_matrix(p)
    allowed = 1e-6 * np.abs(expected) + 1e-9
    flip = next(index for index in np.ndindex(expected.shape) if np.isclose(mistaken[index], -expected[index]))
    got = expected.copy()
    got[flip] = -got[flip]  # one flipped sign: where it fails, G(p) happens to agree
    failing = np.abs(got - expected) > allowed
    assert np.allclose(mistaken[failing], got[failing])
    cause = diagnosis.likely_cause("rotation_matrices", "L", expected, got, failing, allowed, [("G for L", mistaken)])
    assert cause != "G for L"
    whole = diagnosis.likely_cause(
        "rotation_matrices",
        "L",
        expected,
        mistaken,
        np.abs(mistaken - expected) > allowed,
        allowed,
        [("G for L", mistaken)],
    )
    assert whole == "G for L"


@pytest.mark.parametrize(
    "scene, name",
    [
        ("double_pendulum", "double_pendulum.dynamic_run.energy"),
        ("double_pendulum", "double_pendulum.dynamic_run.drift"),
        ("slider_crank_actuator", "slider_crank_actuator.dynamic_run.drift"),
    ],
)
def test_a_frozen_or_zero_run_earns_no_invariant_points(scene, name):
    spec = check("hw2", name)
    reference = load_reference(scene)
    data = load_public_scene(scene).data
    own = reference.outputs(spec.probe_key)

    def measure(outputs):
        return invariants(data, outputs["t"], outputs["q"], outputs["qd"])

    def outcome(q, qd):
        reply = Reply("ok", outputs={"t": own["t"], "q": q, "qd": qd})
        return evaluate(spec, reply, reference, measure, Limits(), scene)

    assert outcome(own["q"], own["qd"]).passed  # the reference's own run
    frozen = outcome(np.repeat(own["q"][:1], len(own["t"]), axis=0), np.zeros_like(own["qd"]))
    zero = outcome(np.zeros_like(own["q"]), np.zeros_like(own["qd"]))
    for result in (frozen, zero):
        assert not result.passed and result.points == 0
        assert "does not follow the reference's" in result.message


def test_a_run_that_leaves_the_reference_points_at_the_integration_too():
    spec = check("hw2", "double_pendulum.dynamic_run.q")
    reference = load_reference("double_pendulum")
    own = reference.outputs(spec.probe_key)
    off = own["q"] + 1e-3 * np.linspace(0, 1, len(own["t"]))[:, None]
    reply = Reply("ok", outputs={"t": own["t"], "q": off, "qd": own["qd"]})
    result = evaluate(spec, reply, reference, lambda outputs: {}, Limits(), "double_pendulum")
    assert not result.passed and "rtol, atol and step" in result.message
