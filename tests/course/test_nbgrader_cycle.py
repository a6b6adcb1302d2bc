"""The whole nbgrader cycle, headless, for each homework: generate, a submission in ``submitted/``,
autograde, generate feedback, export; the exported grades equal ``mbd grade``'s for the same submissions.

Each homework runs in a scratch copy of the course (``course.demo.scratch_course``: notebooks, nbgrader
configuration, reference, grader data) with nbgrader's own commands: hw1's from the course root (through the
root ``nbgrader_config.py``), the others' from ``course/``; none of them writes anything outside ``build/``.
The graded cells call ``mbdkit.check``, which, while nbgrader autogrades, runs every check of its
group (hidden and per-student ones too) and returns the points as the cell's partial credit: so nbgrader's
score of a submission is the autograder's, check for check.
"""

from __future__ import annotations

import csv
import hashlib
import html
import os
import re
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import nbformat
import pytest

from autograder.grading import grade
from course.demo import MUTATIONS, _mutate, scratch_course
from course.release import HOMEWORKS, build_package, release
from course.release.generator import REPO

pytestmark = pytest.mark.filterwarnings("ignore:Object of type <Submitted")  # nbgrader's own SQLAlchemy notes

STUDENTS = {
    "hw1": {"ada": None, "ben": "bug_revolute_gamma", "sam": "skeleton", "eve": "forged_checker"},
    "hw2": {"ada": None},
    "hw3": {"ada": None},
}
"""Per homework, the demo students submitted: the reference (None), a mutant of course/demo.py, the skeleton,
the skeleton with the kit's checker changed to award a point in every graded cell."""

FORGED = """

def check(homework, group, path=None):  # forged by the student: a point for every graded cell
    return 1.0
"""


def submit(course: Path, homework: str, student: str, kind: str | None) -> Path:
    """A submission as nbgrader collects it: the released folder, with the student's package."""
    released = course / "build" / "release" / homework
    folder = course / "build" / "submitted" / student / homework
    shutil.copytree(released, folder, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    if kind == "forged_checker":
        with open(folder / "mbdkit" / "api.py", "a") as f:
            f.write(FORGED)
    elif kind != "skeleton":
        build_package(folder / "modules", None, course / "solutions", header=None)
    if kind in MUTATIONS:
        relpath, anchor, correct, buggy, _ = MUTATIONS[kind]
        _mutate(folder / "modules", relpath, anchor, correct, buggy, student)
    return folder


WHERE = {"hw1": "."}
"""Where each homework's nbgrader commands run, relative to the course root (``course/`` when not listed)."""


def nbgrader(course: Path, *args: str, where: str = "course") -> str:
    """An nbgrader command, run where an nbgrader_config.py is (the root or ``course/``), as an instructor would."""
    environment = dict(os.environ, PATH=os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")]))
    environment.pop("NBGRADER_EXECUTION", None)
    done = subprocess.run(
        [sys.executable, "-m", "nbgrader", *args],
        cwd=course / where,
        env=environment,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, f"nbgrader {' '.join(args)}:\n{done.stderr[-3000:]}"
    return done.stdout + done.stderr


def outside_build(course: Path) -> dict[str, str]:
    """Every file of the course outside build/ (Python's caches aside), with a digest of its content."""
    files = {}
    for path in sorted(course.rglob("*")):
        relative = path.relative_to(course)
        if path.is_file() and relative.parts[0] != "build" and "__pycache__" not in relative.parts:
            files[relative.as_posix()] = hashlib.sha256(path.read_bytes()).hexdigest()
    return files


def autograde_and_export(course: Path, homework: str) -> dict[str, dict]:
    """``nbgrader autograde``, ``generate_feedback`` and ``export`` (to its configured file, build/grades.csv)
    for every submission of one homework; the course outside build/ stays as it was."""
    where = WHERE.get(homework, "course")
    before = outside_build(course)
    nbgrader(course, "autograde", homework, "--force", where=where)
    nbgrader(course, "generate_feedback", homework, "--force", where=where)
    nbgrader(course, "export", where=where)
    assert outside_build(course) == before, f"{homework}: nbgrader wrote outside build/"
    with open(course / "build" / "grades.csv", newline="") as f:
        return {row["student_id"]: row for row in csv.DictReader(f) if row["assignment"] == homework}


@pytest.fixture(scope="module")
def cycle(tmp_path_factory):
    """Every homework through nbgrader, each in a scratch copy of the course of its own (so that two run at
    once): generate (``mbd release``), submissions, autograde, feedback, export; then ``mbd grade`` of the
    same submitted/ folder."""
    root = tmp_path_factory.mktemp("nbgrader")
    courses = {}
    for homework in HOMEWORKS:
        course = courses[homework] = scratch_course(root / homework)
        shutil.copy2(REPO / "nbgrader_config.py", course / "nbgrader_config.py")  # nbgrader run from the root
        release(homework, course)  # nbgrader's generate step, the student package, the leak check
        for student, kind in STUDENTS[homework].items():
            submit(course, homework, student, kind)
    with ThreadPoolExecutor(max_workers=2) as pool:  # separate processes, folders and gradebooks
        futures = {hw: pool.submit(autograde_and_export, course, hw) for hw, course in courses.items()}
        exported = {hw: future.result() for hw, future in futures.items()}
    books = {
        hw: grade(hw, course / "build" / "submitted", course / "build" / "grades", jobs=2, progress=False, resume=False)
        for hw, course in courses.items()
    }
    return courses, exported, books


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_exported_grades_equal_the_autograders(cycle, homework):
    courses, exported, books = cycle
    course, book = courses[homework], books[homework]
    source = nbformat.read(course / "assignments" / homework / f"{homework}.ipynb", as_version=4)
    written = sum(
        c.metadata["nbgrader"]["points"]
        for c in source.cells
        if c.metadata.get("nbgrader", {}).get("grade") and c.metadata["nbgrader"].get("solution")
    )
    for student in STUDENTS[homework]:
        row = exported[homework][student]
        assert float(row["raw_score"]) == pytest.approx(book.score(student), abs=1e-6), (student, row)
        assert float(row["max_score"]) == pytest.approx(book.max_score + written)  # written answers: by hand


def test_the_demo_students_get_what_they_deserve(cycle):
    _, exported, books = cycle
    book = books["hw1"]
    assert book.score("ada") == book.max_score and book.score("sam") == 0.0
    assert book.score("eve") == 0.0  # a checker handed in with the submission is not what grades it
    assert float(exported["hw1"]["eve"]["raw_score"]) == 0.0
    assert 0.0 < book.score("ben") < book.max_score
    assert float(exported["hw1"]["ben"]["raw_score"]) == pytest.approx(book.score("ben"))


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_feedback_pages_show_the_graders_messages(cycle, homework):
    course = cycle[0][homework]
    pages = {}
    for student in STUDENTS[homework]:
        page = course / "build" / "feedback" / student / homework / f"{homework}.html"
        pages[student] = html.unescape(re.sub(r"<[^>]+>", "", page.read_text()))
        assert f'check("{homework}", "hidden")' in pages[student] and " hidden/" in pages[student]  # they ran
        assert "Model answer" not in pages[student]
    assert "ok   hidden/" in pages["ada"]
    if homework == "hw1":
        assert "FAIL four_bar.gamma.revolute" in pages["ben"] and "Likely cause: a sign error" in pages["ben"]
        assert "not implemented yet" in pages["sam"]
