"""The feedback page a student reads: points per group and each cause once, the costliest first, before every
check; nothing of a hidden check before it is published; the student's own text escaped."""

from __future__ import annotations

import html
import re

import numpy as np

from autograder.feedback import feedback_html
from mbdkit.checks import Outcome


def outcome(name, group, scene, passed, points, max_points, message="", kind="public", plot=None) -> Outcome:
    return Outcome(name, group, scene, kind, points, max_points, passed, message, "visible", plot)


STUB = "not implemented yet: rotation: A(phi), see eq. 2.2 (modules/planar/bodies.py:22 in rotation)"


def test_each_cause_once_with_what_it_costs_and_the_groups_summed():
    outcomes = [
        outcome("four_bar.constraints.revolute", "revolute", "four_bar", False, 0, 1.5, f"four_bar: {STUB}"),
        outcome("slider_crank.gamma.revolute", "revolute", "slider_crank", False, 0, 2, f"slider_crank: {STUB}"),
        outcome("cam.gamma.cam", "cam", "cam", False, 0, 1.5, f"cam: {STUB}"),
        outcome("cam.jacobian.cam", "cam", "cam", False, 0.5, 1.5, "cam: a sign error <script>alert(1)</script>"),
        outcome("cam.constraints.cam", "cam", "cam", True, 1.5, 1.5, "passed"),
        outcome("hidden/cam_b.gamma", "hidden", "hidden/cam_b", False, 0, 9, f"hidden/cam_b: {STUB}", kind="hidden"),
    ]
    page = feedback_html("sam", "hw1", "Planar kinematics", outcomes)
    text = html.unescape(re.sub(r"<[^>]+>", "", page))
    assert text.count(STUB) == 1, "one cause, said once"
    first, second = text.index("3 checks, 5 points (revolute, cam): "), text.index("1 check, 1 points (cam): ")
    assert first < second < text.index("Every check")  # the costliest first, before the table
    assert page.count("cause 1 above") == 3 and page.count("cause 2 above") == 1
    assert "<script>" not in page and "&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert 'revolute</td><td class="points">0 / 3.5</td><td>0 of 2 passed' in page
    assert 'cam</td><td class="points">2 / 4.5</td><td>1 of 3 passed' in page
    assert "hidden/" not in page and "9 points" in page  # held back: its points are said, not its check


def test_a_failed_run_is_drawn_with_its_difference():
    t = np.linspace(0.0, 1.0, 11)
    plot = {"t": t, "expected": np.sin(t), "got": np.sin(t) + 1e-4, "label": "crank.phi", "quantity": "positions"}
    failed = outcome("four_bar.kinematic_run.q", "kinematic", "four_bar", False, 0, 1.5, "four_bar: off", plot=plot)
    page = feedback_html("ben", "hw1", "Planar kinematics", [failed])
    assert page.count("<img") == 1 and "your run against the reference, and the difference" in page
