"""The nbgrader cycle of hw1 (tests/course/nbgrader_cycle.py: the class, the cycle and the tests of every
homework), and the tests of hw1's own class: the demo students, the attacks on the points, a
hostile cell, damaged notebooks."""

from __future__ import annotations

import json
import re

import nbformat
import pytest

from .nbgrader_cycle import *  # noqa: F403 (the cycle fixture and the tests of every homework)
from .nbgrader_cycle import SECRET

HOMEWORK = "hw1"


def test_the_demo_students_get_what_they_deserve(cycle):
    book, exported = cycle.book, cycle.exported
    assert book.score("ada") == book.max_score and book.score("sam") == 0.0
    assert book.score("eve") == 0.0  # a checker handed in with the submission is not what grades it
    assert float(exported["eve"]["raw_score"]) == 0.0
    assert 0.0 < book.score("ben") < book.max_score
    assert float(exported["ben"]["raw_score"]) == pytest.approx(book.score("ben"))


def test_attacks_on_the_points_score_what_the_skeleton_scores(cycle):
    book, rows = cycle.book, cycle.exported
    for student in ("eve", "mal", "rex"):
        assert book.score(student) == book.score("sam"), student  # mbd grade's route
        assert float(rows[student]["raw_score"]) == float(rows["sam"]["raw_score"]), student  # nbgrader's
    assert book.score("ada") == book.max_score  # the classmate rex wrote into kept every point


def test_a_hostile_cell_sees_nothing_of_the_course(cycle):
    course = cycle.course
    nb = nbformat.read(course / "build" / "autograded" / "rex" / "hw1" / "hw1.ipynb", as_version=4)
    probe = next(c for c in nb.cells if "attempt(" in c.source)
    seen = json.loads("".join(o.get("text", "") for o in probe.outputs if o.output_type == "stream"))
    for attempt in ("course file", "gradebook", "classmate"):
        assert seen[attempt].startswith("refused"), (attempt, seen[attempt])
    assert "MBD_GRADER_SECRET" not in seen["environment"] and SECRET not in json.dumps(seen)
    page = (course / "build" / "feedback" / "rex" / "hw1" / "hw1.html").read_text()
    assert SECRET not in page
    assert "fetch('/api/contents')" in nb.cells[-2].source and "<script>fetch(" not in page and "<img" not in page


def test_the_check_before_autograde_names_and_repairs_the_damaged_notebooks(cycle):
    """dan's and fay's notebooks were damaged as students damage them; the check that autograde runs first
    named each damage, repaired it, and nbgrader's totals equal mbd grade's (test_exported_grades_...)."""
    course, book = cycle.course, cycle.book
    log = (course / "build" / "autograde.log").read_text()
    assert "dan: cell test_hw1_bodies is in the notebook twice" in log and "fails the whole submission" in log
    assert re.search(r"dan: graded test cell test_hw1_revolute deleted \(10 points\).*repaired: restored", log)
    assert "dan: the notebook is 'hw1 (1).ipynb', not 'hw1.ipynb'" in log
    assert "fay: the notebook is 'hw1-copy.ipynb', not 'hw1.ipynb' (zip_collect dropped it" in log
    assert "repaired: hw1-copy.ipynb collected as hw1.ipynb" in log
    assert book.score("dan") >= 10.0 and book.score("fay") == 0.0  # the bodies and joints, the revolute among them
    assert float(cycle.exported["dan"]["raw_score"]) == pytest.approx(book.score("dan"))
    assert (course / "build" / "autograded" / "fay" / "hw1" / "hw1.ipynb").is_file()
