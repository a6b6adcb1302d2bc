"""``mbd gradebook``: the final grade from the homework gradebooks (either route, each on its own scale) and the
written-test and oral marks, weighted as the course says, with the documentation rubric's share of each homework;
a missing part is never a 0."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from autograder.grading import GRADED, MISSING, Gradebook
from course.gradebook import read_weights
from solutions.cli import main


def mbd_gradebook(
    folder: Path, homework: str, scores: dict[str, float | None], top: float, documented: dict | None = None
) -> Path:
    """A gradebook.csv as ``mbd grade`` writes it (its own writer): one check worth ``top`` points;
    ``documented``: the percent of the homework's functions each student documented (None: not measured)."""
    out = folder / homework
    out.mkdir(parents=True)
    book = Gradebook(homework, ["only"], {"only": top}, out_dir=out)
    for student, score in scores.items():
        row = {"score": score, "checks": {"only": score}, "status": GRADED if score is not None else MISSING}
        row["documentation"] = (documented or {}).get(student)
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
    no_docs = ["--documentation-share", "0"]  # the scheme without the rubric (below: with it)
    assert main(["gradebook", *homework, "--marks", str(marks), "--out", str(out), *no_docs]) == 0
    assert "2 students, 1 complete, 1 with a part missing" in capsys.readouterr().out
    rows = read(out)
    ada = rows["ada"]  # homework (80 + 90 + 100) / 3 = 90: 0.5 * 90 + 0.25 * 70 + 0.25 * 60 = 77.5
    assert (ada["hw1"], ada["hw2"], ada["hw3"], ada["homework"]) == ("80.0", "90.0", "100.0", "90.0")
    assert (ada["final"], ada["status"]) == ("77.5", "complete")
    bob = rows["bob"]
    assert (bob["hw2"], bob["homework"], bob["oral"], bob["final"]) == (MISSING, MISSING, MISSING, MISSING)
    assert bob["status"] == "missing: hw2, oral" and bob["hw3"] == "50.0"  # 55 of 110
    assert main(["gradebook", *homework, "--marks", str(marks), "--out", str(out), "--missing-as-zero", *no_docs]) == 0
    bob = read(out)["bob"]  # homework (60 + 0 + 50) / 3 = 36.67: 0.5 * 36.67 + 0.25 * 50 + 0 = 30.83
    assert (bob["homework"], bob["final"], bob["status"]) == ("36.7", "30.8", "missing: hw2, oral")


def test_the_weights_and_a_roster_are_the_instructors(term):
    folder, homework, marks = term
    out = folder / "final.csv"
    roster = folder / "roster.txt"
    roster.write_text("ada\nbob\ncyd\n")
    weights = "homework=60,test=40"
    assert main(["gradebook", *homework, "--marks", str(marks), "--weights", weights, "--roster", str(roster),
                 "--out", str(out), "--documentation-share", "0"]) == 0  # fmt: skip
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
        (lambda f, h, m: (h, m.write_text("student,test,oral,hw1_doc\nada,70,60,7\n") and m, None), "7 is over 5"),
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


def test_documentation_is_its_share_of_each_homework_automatic_and_manual_points(tmp_path, capsys):
    """course/grading.toml: documentation is 10 % of a homework's grade, 5 automatic points (times the share of
    functions documented) and 5 manual points (column hwN_doc); a part not given leaves it missing."""
    hw1 = mbd_gradebook(tmp_path / "grades", "hw1", {"ada": 80.0, "bob": 60.0}, 100.0, {"ada": 40.0, "bob": 0.0})
    hw2 = mbd_gradebook(tmp_path / "grades", "hw2", {"ada": 90.0, "bob": 70.0}, 100.0, {"ada": 100.0})
    marks = tmp_path / "marks.csv"
    marks.write_text("student,test,oral,hw1_doc,hw2_doc\nada,71,60,4,5\nbob,50,41,2,\n")
    out = tmp_path / "final.csv"
    assert main(["gradebook", str(hw1), str(hw2), "--marks", str(marks), "--out", str(out)]) == 0
    ada = read(out)["ada"]  # hw1_doc (5 * 0.4 + 4) / 10 = 60 %: 0.9 * 80 + 0.1 * 60 = 78; hw2_doc 100 %: 91
    assert (ada["hw1"], ada["hw1_doc"], ada["hw2"], ada["hw2_doc"], ada["homework"]) == (
        "80.0",
        "60.0",
        "90.0",
        "100.0",
        "84.5",
    )
    assert (ada["final"], ada["status"]) == ("75.0", "complete")  # 0.5 * 84.5 + 0.25 * 71 + 0.25 * 60
    bob = read(out)["bob"]  # hw1_doc (0 + 2) / 10 = 20 %; hw2: neither part of the rubric given
    assert (bob["hw1_doc"], bob["hw2_doc"], bob["final"]) == ("20.0", MISSING, MISSING)
    assert bob["status"] == "missing: hw2 documentation"
    assert main(["gradebook", str(hw1), str(hw2), "--marks", str(marks), "--out", str(out), "--missing-as-zero"]) == 0
    bob = read(out)["bob"]  # (0.9 * 60 + 0.1 * 20 + 0.9 * 70) / 2 = 59.5: 0.5 * 59.5 + 0.25 * 50 + 0.25 * 41
    assert (bob["homework"], bob["final"]) == ("59.5", "52.5")
    capsys.readouterr()
    assert main(["gradebook", str(hw1), "--marks", str(marks), "--out", str(out), "--documentation-share", "x"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--documentation-share x" in err


def test_the_automatic_part_of_nbgrader_homework_is_measured_from_the_submissions(term):
    """hw3 came through nbgrader's export, which has no documentation column: --submitted measures it from
    nbgrader's submitted/{student}/hw3/ (ada explains Dot1.value, one of hw3's 33 functions; bob has no folder)."""
    folder, homework, marks = term
    package = folder / "submitted" / "ada" / "hw3" / "modules" / "spatial"
    package.mkdir(parents=True)
    (package / "joints.py").write_text(
        "class Dot1:\n    def value(self, qi, qj, t):\n        # a_i^T a_j of eq. 9.10: the axes stay perpendicular\n"
        "        return 0.0\n"
    )
    marks.write_text("student,test,oral,hw3_doc\nada,70,60,4\nbob,50,,5\n")
    out = folder / "final.csv"
    argv = ["gradebook", *homework, "--marks", str(marks), "--out", str(out)]
    assert main([*argv, "--submitted", str(folder / "submitted")]) == 0
    ada, bob = read(out)["ada"], read(out)["bob"]
    assert ada["hw3_doc"] == "41.5"  # (5 points x 1/33 + 4) / 10 = 41.52 %
    assert bob["hw3_doc"] == MISSING and "hw3 documentation" in bob["status"]
    assert main(argv) == 0 and read(out)["ada"]["hw3_doc"] == MISSING  # not measured without --submitted
