"""``mbd gradebook``: the final grade from the homework gradebooks (either route, each on its own scale) and the
written-test and oral marks, weighted as the course says; a missing part is never a 0."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from autograder.grading import GRADED, MISSING, Gradebook
from course.gradebook import read_weights
from solutions.cli import main


def mbd_gradebook(folder: Path, homework: str, scores: dict[str, float | None], top: float) -> Path:
    """A gradebook.csv as ``mbd grade`` writes it (its own writer): one check worth ``top`` points."""
    out = folder / homework
    out.mkdir(parents=True)
    book = Gradebook(homework, ["only"], {"only": top}, out_dir=out)
    for student, score in scores.items():
        row = {"score": score, "checks": {"only": score}, "status": GRADED if score is not None else MISSING}
        book.rows[student] = row
    book.write_csv()
    return book.csv_path


def nbgrader_export(path: Path, rows: list[tuple[str, str, float, float, bool]]) -> Path:
    """nbgrader's CSV export (its CsvExportPlugin's columns): a row per assignment and student."""
    keys = ["assignment", "duedate", "timestamp", "student_id", "last_name", "first_name", "email", "raw_score",
            "late_submission_penalty", "score", "max_score"]  # fmt: skip
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, keys)
        writer.writeheader()
        for assignment, student, score, top, submitted in rows:
            stamp = "2026-11-20 10:00:00" if submitted else ""
            writer.writerow({"assignment": assignment, "student_id": student, "timestamp": stamp, "raw_score": score,
                             "late_submission_penalty": 0.0, "score": score, "max_score": top})  # fmt: skip
    return path


@pytest.fixture
def term(tmp_path):
    """ada did everything; bob handed in no hw2 and sat no oral; hw3 came through nbgrader, out of 110."""
    hw1 = mbd_gradebook(tmp_path / "grades", "hw1", {"ada": 80.0, "bob": 60.0}, 100.0)
    hw2 = mbd_gradebook(tmp_path / "grades", "hw2", {"ada": 90.0, "bob": None}, 100.0)
    hw3 = [("hw3", "ada", 110.0, 110.0, True), ("hw3", "bob", 55.0, 110.0, True)]
    hw3 = nbgrader_export(tmp_path / "grades.csv", hw3)
    marks = tmp_path / "marks.csv"
    marks.write_text("student,test,oral\nada,70,60\nbob,50,\n")
    return tmp_path, [str(hw1), str(hw2), str(hw3)], marks


def read(path: Path) -> dict[str, dict[str, str]]:
    with open(path, newline="") as f:
        return {row["student"]: row for row in csv.DictReader(f)}


def test_the_final_grade_weighs_each_homework_on_its_own_scale_and_keeps_missing_apart(term, capsys):
    folder, homework, marks = term
    out = folder / "final.csv"
    assert main(["gradebook", *homework, "--marks", str(marks), "--out", str(out)]) == 0
    assert "2 students, 1 complete, 1 with a part missing" in capsys.readouterr().out
    rows = read(out)
    ada = rows["ada"]  # homework (80 + 90 + 100) / 3 = 90: 0.5 * 90 + 0.25 * 70 + 0.25 * 60 = 77.5
    assert (ada["hw1"], ada["hw2"], ada["hw3"], ada["homework"]) == ("80.0", "90.0", "100.0", "90.0")
    assert (ada["final"], ada["status"]) == ("77.5", "complete")
    bob = rows["bob"]
    assert (bob["hw2"], bob["homework"], bob["oral"], bob["final"]) == (MISSING, MISSING, MISSING, MISSING)
    assert bob["status"] == "missing: hw2, oral" and bob["hw3"] == "50.0"  # 55 of 110
    assert main(["gradebook", *homework, "--marks", str(marks), "--out", str(out), "--missing-as-zero"]) == 0
    bob = read(out)["bob"]  # homework (60 + 0 + 50) / 3 = 36.67: 0.5 * 36.67 + 0.25 * 50 + 0 = 30.83
    assert (bob["homework"], bob["final"], bob["status"]) == ("36.7", "30.8", "missing: hw2, oral")


def test_the_weights_and_a_roster_are_the_instructors(term):
    folder, homework, marks = term
    out = folder / "final.csv"
    roster = folder / "roster.txt"
    roster.write_text("ada\nbob\ncyd\n")
    weights = "homework=60,test=40"
    assert main(["gradebook", *homework, "--marks", str(marks), "--weights", weights, "--roster", str(roster),
                 "--out", str(out)]) == 0  # fmt: skip
    rows = read(out)
    assert "oral" not in rows["ada"] and rows["ada"]["final"] == "82.0"  # 0.6 * 90 + 0.4 * 70
    assert rows["cyd"]["status"] == "missing: hw1, hw2, hw3, test" and rows["cyd"]["final"] == MISSING
    assert read_weights() == {"homework": 50.0, "test": 25.0, "oral": 25.0}  # course/grading.toml


@pytest.mark.parametrize(
    "change, said",
    [
        (lambda f, h, m: (h[:1] + [str(f / "nope.csv")], m, None), "nope.csv: no such file"),
        (lambda f, h, m: (h, m.write_text("student,test,oral\nada,seventy,60\n") and m, None), "row 2, column test"),
        (lambda f, h, m: (h, m.write_text("student,test,oral\nada,170,60\n") and m, None), "over 100"),
        (lambda f, h, m: (h, m.write_text("student,test\nada,70\n") and m, None), "no column oral"),
        (lambda f, h, m: (h, m, "homework=50,test=25"), "summing to 100"),
        (lambda f, h, m: ([*h, h[0]], m, None), "hw1 is given twice"),
    ],
)
def test_bad_input_is_one_line_and_nothing_is_written(term, change, said, capsys):
    folder, homework, marks = term
    homework, marks, weights = change(folder, homework, marks)
    argv = ["gradebook", *homework, "--marks", str(marks), "--out", str(folder / "final.csv")]
    assert main(argv + (["--weights", weights] if weights else [])) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("mbd: error: ") and said in err, err
    assert not (folder / "final.csv").exists()


def test_an_assignment_nbgrader_never_received_is_missing_not_zero(tmp_path):
    from course.gradebook import read_homework

    export = nbgrader_export(
        tmp_path / "grades.csv", [("hw1", "ada", 0.0, 110.0, False), ("hw1", "bob", 0.0, 110.0, True)]
    )
    assert read_homework(str(export)) == {"hw1": {"ada": None, "bob": 0.0}}  # nbgrader writes 0 for both
