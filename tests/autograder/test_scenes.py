"""Grading scenes: per-student variants are the same mechanism with other numbers."""

from __future__ import annotations

import numpy as np
import pytest

from autograder.reference import probe_specs, student_reference
from autograder.scenes import load_scene, student_seed, variant_factors
from mbdkit.homework import available_homeworks, load_homework
from solutions.assembly import build_system
from solutions.io.model import load_model
from solutions.kinematics import kinematic_analysis


def test_student_variants_differ_between_students_and_not_between_runs():
    assert student_seed("alice", "hw1", "slider_crank") == student_seed("alice", "hw1", "slider_crank")
    assert student_seed("alice", "hw1", "slider_crank") != student_seed("bob", "hw1", "slider_crank")
    a = load_scene("student/slider_crank", student="alice", homework="hw1").data
    b = load_scene("student/slider_crank", student="bob", homework="hw1").data
    assert a != b


def test_a_variant_is_the_scaled_mechanism():
    """Lengths times s, driver b times faster: the variant's slider position is s times the public
    one's at time t / b (the closed form of the slider-crank scales the same way)."""
    seed = student_seed("carol", "hw1", "slider_crank")
    s, b = variant_factors(seed)["length"], variant_factors(seed)["rate"]
    public = load_scene("slider_crank").data
    scaled = load_scene("student/slider_crank", student="carol", homework="hw1").data
    runs = []
    for data, t_end in ((public, 0.5), (scaled, 0.5 / b)):
        system, q0, _ = build_system(load_model(data))
        runs.append(kinematic_analysis(system, q0, t_end, 10).coordinate("slider.x"))
    assert np.allclose(runs[1], s * runs[0], rtol=1e-9)


@pytest.mark.parametrize("homework", available_homeworks())
def test_every_homework_names_known_scenes_and_reaches_100_points(homework):
    spec = load_homework(homework)
    assert spec.max_score == pytest.approx(100.0, abs=2.5)
    for check in spec.checks:
        if check.kind != "student":
            load_scene(check.scene)
    assert len({c.name for c in spec.checks}) == len(spec.checks)


def test_student_reference_is_made_at_grading():
    checks = load_homework("hw1").select(["student/four_bar.kinematic_run.q"]).checks
    specs = probe_specs(checks)["student/four_bar"]
    ref = student_reference("student/four_bar", "dave", "hw1", specs)
    assert ref.outputs("kinematic_run")["q"].shape == (41, 9)
