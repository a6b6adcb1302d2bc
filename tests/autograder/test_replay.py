"""Known mistakes replayed on the reference package, and stored with the expected values."""

from __future__ import annotations

import importlib
import sys

import numpy as np

from autograder import replay
from autograder.reference import load_reference
from mbdkit import diagnosis


def copy_module(name: str):
    """A module of the private copy of the reference package that the mistakes are made in."""
    return importlib.import_module(f"{replay.COPY}.{name}")


def test_patched_restores_the_copy_and_never_touches_the_reference():
    from solutions.planar import bodies as reference_bodies
    from solutions.planar import joints as reference_joints

    bodies, joints = copy_module("planar.bodies"), copy_module("planar.joints")
    original = bodies.rotation_derivative
    with replay.patched(replay.REPLAY, "planar.bodies.rotation_derivative", replay._transposed):
        assert joints.rotation_derivative is not original
        assert np.allclose(joints.rotation_derivative(0.3), original(0.3).T)
        assert reference_joints.rotation_derivative is reference_bodies.rotation_derivative  # while it is on
        assert np.allclose(reference_joints.rotation_derivative(0.3), original(0.3))
    assert joints.rotation_derivative is original and bodies.rotation_derivative is original
    with replay.patched(replay.REPLAY, "planar.joints.Revolute.psi_t", replay._negated):
        assert "psi_t" in vars(joints.Revolute) and "psi_t" not in vars(reference_joints.Revolute)
    assert "psi_t" not in vars(joints.Revolute)  # inherited again, as before


def test_a_module_first_imported_during_a_replay_keeps_no_mistake():
    """The grader imports the reference lazily: a module imported while a mistake is replayed binds the
    mistaken function by name, and must get the right one back afterwards."""
    bodies = copy_module("planar.bodies")
    original = bodies.rotation
    name = f"{replay.COPY}.reactions"
    saved = importlib.import_module(name)
    del sys.modules[name]
    try:
        with replay.patched(replay.REPLAY, "planar.bodies.rotation", replay._transposed):
            fresh = importlib.import_module(name)
            assert fresh.rotation is not original
        assert fresh.rotation is original and bodies.rotation is original
    finally:
        sys.modules[name] = saved


def test_stored_mistakes_name_the_cause_without_the_reference_package():
    """A kit diagnoses from stored data: the replayed output of a known mistake, stored with the expected
    values, matches a student who makes that mistake."""
    reference = load_reference("four_bar")
    stored = reference.replays("gamma", "gamma")
    causes = [cause for cause, _ in stored]
    assert any("quadratic-velocity" in cause for cause in causes)
    cause, mistaken = next((c, a) for c, a in stored if "quadratic-velocity" in c)
    expected = reference.outputs("gamma")["gamma"]
    failing = np.abs(mistaken - expected) > 1e-6 * np.abs(expected) + 1e-8
    allowed = 1e-6 * np.abs(expected) + 1e-8
    assert diagnosis.likely_cause("gamma", "gamma", expected, mistaken, failing, allowed, stored) == cause


def test_every_replay_leaves_the_reference_as_it_was():
    """G(p) standing in for L(p) (and L for G) must not rebind G or L for later checks."""
    from mbdkit.probes import Job
    from mbdkit.scenes import job_key, load_public_scene
    from solutions import rotations

    g, l = rotations.g_matrix, rotations.l_matrix
    scene = load_public_scene("revolute_spherical")
    reference = load_reference("revolute_spherical")
    job = Job(job_key(scene), scene.data, reference.inputs, {})
    causes, _ = replay.stored_replays("rotation_matrices", job, reference.outputs("rotation_matrices"))
    assert any("G(p) used where L(p)" in c for c in causes) and any("L(p) used where G(p)" in c for c in causes)
    assert rotations.g_matrix is g and rotations.l_matrix is l
