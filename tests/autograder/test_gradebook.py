"""A gradebook that tells the truth: a student who handed nothing in is "missing" (no score, no page, not in
the statistics), and Ctrl-C stops ``mbd grade`` with one line, to be resumed (``mbd sweep``: test_sweep).

The class is small and the homework cut to two cheap checks, so that grading takes a few seconds.
"""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from autograder.cli import summary
from autograder.grading import grade, read_roster
from mbdkit.homework import Homework, load_homework

from ..shell import as_from_a_shell

REPO = Path(__file__).resolve().parents[2]


def small_homework() -> Homework:
    hw1 = load_homework("hw1")
    return Homework("hw1", "small", hw1.select(["slider_crank.gamma.revolute", "slider_crank.newton"]).checks)


def _rows(out: Path) -> dict[str, dict]:
    with open(out / "gradebook.csv", newline="") as f:
        return {row["student"]: row for row in csv.DictReader(f)}


@pytest.fixture(scope="module")
def plain_class(make_submissions, tmp_path_factory):
    """ada and bob hand in, cat's folder holds only a note, dan's is empty, eve is on the roster only."""
    folder = make_submissions("missing-plain", {"ada": "reference", "bob": "skeleton"}, "hw1")
    (folder / "cat").mkdir()
    (folder / "cat" / "notes.txt").write_text("I will hand it in next week\n")
    (folder / "dan").mkdir()
    roster = tmp_path_factory.mktemp("roster") / "class.csv"
    roster.write_text("name,student\nAda,ada\nBob,bob\nCat,cat\nDan,dan\nEve,eve\n")
    out = tmp_path_factory.mktemp("missing-out")
    book = grade(small_homework(), folder, out, jobs=1, progress=False, roster=read_roster(roster))
    return book, out, folder


def test_a_student_who_handed_nothing_in_is_missing_not_zero(plain_class):
    book, out, _ = plain_class
    rows = _rows(out)
    assert set(rows) == {"ada", "bob", "cat", "dan", "eve"}
    assert book.graded == ["ada", "bob"] and book.missing == ["cat", "dan", "eve"]
    for student in ("cat", "dan", "eve"):
        row = rows[student]
        assert row["status"] == "missing" and row["score"] == "" and row["percent"] == ""
        assert all(row[c] == "" for c in book.checks)
        assert not (out / "feedback" / f"{student}.html").exists()
        assert not (out / "results" / f"{student}.json").exists()
    assert rows["ada"]["status"] == "graded" and float(rows["ada"]["score"]) == book.max_score
    assert rows["bob"]["status"] == "graded" and float(rows["bob"]["score"]) == 0.0
    assert (out / "feedback" / "bob.html").exists()


def test_the_summary_counts_only_graded_submissions(plain_class):
    book, _, _ = plain_class
    line = summary(book)
    top = f"{book.max_score:g}"
    # ada max, bob 0: the median of the two graded is ada's (the upper one), 0 .. max; the 3 missing apart
    assert f"graded 2 submissions, median {top} / {top}, range 0 .. {top}" in line
    assert "3 missing" in line and "cat, dan, eve" in line


def test_a_student_who_hands_in_later_is_graded_and_one_who_withdraws_loses_the_page(plain_class, reference_copy):
    book, out, folder = plain_class
    reference_copy(folder / "dan")  # dan hands in now
    moved = folder / "bob" / "modules"
    moved.rename(folder / "bob" / "old-modules")  # bob's submission is taken back
    try:
        again = grade(small_homework(), folder, out, jobs=1, progress=False)
    finally:
        (folder / "bob" / "old-modules").rename(moved)
        import shutil

        shutil.rmtree(folder / "dan" / "modules")
    assert again.score("dan") == again.max_score and not again.rows["ada"]["status"] == "missing"
    assert again.rows["ada"]["resumed"]
    assert again.status("bob") == "missing" and not (out / "feedback" / "bob.html").exists()


def test_nbgraders_layout_a_student_without_the_homework_is_missing(make_submissions, tmp_path):
    """submitted/{student}/{hw}/: a student who has only another homework's folder is missing for this one."""
    course = tmp_path / "course"
    graded = make_submissions("missing-nb", {"ada": "skeleton"}, "hw1")
    (course / "submitted" / "ada").mkdir(parents=True)
    (graded / "ada").rename(course / "submitted" / "ada" / "hw1")
    (course / "submitted" / "bob" / "hw2" / "modules").mkdir(parents=True)  # bob handed in hw2 only
    book = grade(small_homework(), course, tmp_path / "out", jobs=1, progress=False)
    assert book.status("ada") == "graded" and book.status("bob") == "missing"
    assert _rows(tmp_path / "out")["bob"]["score"] == ""


def test_the_roster_file_must_name_students(tmp_path):
    roster = tmp_path / "empty.csv"
    roster.write_text("")
    with pytest.raises(ValueError, match="empty"):
        read_roster(roster)
    environment = dict(os.environ, MBD_GRADER_SECRET=os.environ.get("MBD_GRADER_SECRET") or "test")
    done = subprocess.run(
        [sys.executable, "-m", "solutions.cli", "grade", "hw1", str(tmp_path), "--roster", str(tmp_path / "none.csv")],
        capture_output=True,
        text=True,
        env=environment,
        cwd=REPO,
    )
    assert done.returncode == 2 and "--roster" in done.stderr and "Traceback" not in done.stderr


# -- Ctrl-C ------------------------------------------------------------------------------------------------------
def _interrupt(command: list[str], ready, cwd: Path) -> subprocess.CompletedProcess:
    """Run ``command`` as a shell would (``tests.shell.as_from_a_shell``), send it SIGINT once ``ready()`` holds,
    and wait for it."""
    environment = dict(os.environ, MBD_GRADER_SECRET=os.environ.get("MBD_GRADER_SECRET") or "test")
    process = subprocess.Popen(
        command,
        cwd=cwd,
        env=environment,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        preexec_fn=as_from_a_shell,
    )
    deadline = time.monotonic() + 300
    while not ready() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)  # polling for a file the run writes, not a fixed wait
    assert process.poll() is None, "the run ended before it could be interrupted"
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=120)
    return subprocess.CompletedProcess(command, process.returncode, out.decode(), err.decode())


def test_ctrl_c_stops_mbd_grade_with_one_line_and_the_next_run_resumes(make_submissions, tmp_path):
    # graded in name order, two at a time: a skeleton's result is written first, while the reference (the slowest,
    # last) is still to come, so that the interrupt lands inside the run even on a loaded machine
    kinds = {"s0": "skeleton", "s1": "skeleton", "s2": "skeleton", "s3": "reference"}
    folder = make_submissions("interrupt", kinds, "hw1")
    out = tmp_path / "grades"
    command = [sys.executable, "-m", "solutions.cli", "grade", "hw1", str(folder), "--out", str(out), "--jobs", "2"]
    results = out / "results"
    stopped = _interrupt(command, lambda: results.is_dir() and any(results.glob("*.json")), REPO)
    assert stopped.returncode == 130, stopped.stderr[-2000:]
    assert "Traceback" not in stopped.stderr
    lines = [line for line in stopped.stderr.splitlines() if line.startswith("mbd:")]
    assert len(lines) == 1 and "interrupted" in lines[0] and "run the same command again to resume" in lines[0]
    done_before = {p.stem for p in results.glob("*.json")}
    assert 0 < len(done_before) < len(kinds)
    again = subprocess.run(
        command,
        cwd=REPO,
        env=dict(os.environ, MBD_GRADER_SECRET=os.environ.get("MBD_GRADER_SECRET") or "test"),
        capture_output=True,
        text=True,
    )
    assert again.returncode == 0, again.stderr[-2000:]
    rows = _rows(out)
    assert set(rows) == set(kinds)
    top = float(rows["s3"]["max_score"])
    for student, kind in kinds.items():
        assert float(rows[student]["score"]) == (top if kind == "reference" else 0.0), student
