"""``mbd nbcheck hwN [--repair]`` (course/nbcheck.py): every collected notebook checked against the release
before nbgrader's autograde; the report names each damage and what nbgrader will do with it, and the repair
fixes what is safe (a renamed notebook, a duplicated or deleted test cell).

A small damaged class in a folder laid out as the course's build/ (the release's notebook with nbgrader's
checksums, as ``generate_assignment`` writes them); nbgrader's own autograde of such a class is in
nbgrader_cycle.py (test_nbgrader_cycle_hw1.py).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import nbformat
import pytest
from nbgrader.utils import compute_checksum

from course.nbcheck import check_class, command
from course.release.generator import REPO

HW = "hw1"


def _gid(cell) -> str | None:
    return cell.get("metadata", {}).get("nbgrader", {}).get("grade_id")


def release_notebook(course: Path) -> nbformat.NotebookNode:
    """assignments/hw1/hw1.ipynb released as nbgrader does: locked and graded cells get their checksum."""
    notebook = nbformat.read(REPO / "assignments" / HW / f"{HW}.ipynb", as_version=4)
    for cell in notebook.cells:
        meta = cell.get("metadata", {}).get("nbgrader", {})
        if meta.get("locked") or meta.get("grade") or meta.get("solution"):
            meta["checksum"] = compute_checksum(cell)
    folder = course / "build" / "release" / HW
    folder.mkdir(parents=True)
    nbformat.write(notebook, folder / f"{HW}.ipynb")
    return notebook


def damaged_class(course: Path) -> dict[str, Path]:
    """ada as released; ben with a graded test cell twice; cat without a test cell and an answer cell; dan's
    notebook saved as 'hw1 (1).ipynb'; eve's archive holds 'hw1-copy.ipynb', which zip_collect dropped; fay
    with a locked cell edited; gus with two notebooks, neither the released one."""
    release = release_notebook(course)
    folders = {}
    for student in ("ada", "ben", "cat", "dan", "fay", "gus"):
        folders[student] = course / "build" / "submitted" / student / HW
        (folders[student] / "modules").mkdir(parents=True)
    write = nbformat.write
    write(release, folders["ada"] / f"{HW}.ipynb")
    ben = nbformat.from_dict(release)
    index = next(i for i, c in enumerate(ben.cells) if _gid(c) == "test_hw1_revolute")
    copy = nbformat.from_dict(ben.cells[index])
    copy.id = "pasted-copy"  # Jupyter gives a pasted cell an id of its own
    ben.cells.insert(index + 3, copy)
    write(ben, folders["ben"] / f"{HW}.ipynb")
    cat = nbformat.from_dict(release)
    cat.cells = [c for c in cat.cells if _gid(c) not in ("test_hw1_newton", "hw1_answer_slider")]
    write(cat, folders["cat"] / f"{HW}.ipynb")
    write(release, folders["dan"] / f"{HW} (1).ipynb")
    eve = course / "build" / "downloaded" / HW / "extracted" / "eve" / "kit"
    (eve / "modules").mkdir(parents=True)
    write(release, eve / f"{HW}-copy.ipynb")
    (course / "build" / "submitted" / "eve" / HW / "modules").mkdir(parents=True)  # zip_collect took modules/ only
    fay = nbformat.from_dict(release)
    next(c for c in fay.cells if _gid(c) == "test_hw1_gear").source += "\nprint('mine')"
    write(fay, folders["fay"] / f"{HW}.ipynb")
    write(release, folders["gus"] / "draft.ipynb")
    write(release, folders["gus"] / "final.ipynb")
    (course / "build" / "submitted" / "hal" / "hw2").mkdir(parents=True)  # hal has only hw2: not this check's
    return folders


@pytest.fixture
def course(tmp_path) -> Path:
    damaged_class(tmp_path)
    return tmp_path


def _by_student(report) -> dict[str, list[str]]:
    found = {}
    for finding in report.findings:
        found.setdefault(finding.student, []).append(finding.line())
    return found


def test_the_report_names_each_damage_and_what_nbgrader_will_do(course, capsys):
    report = check_class(HW, course)
    found = _by_student(report)
    assert report.students == ["ada", "ben", "cat", "dan", "eve", "fay", "gus"]  # hal: only hw2
    assert "ada" not in found
    assert any(
        "test_hw1_revolute is in the notebook twice" in f and "fails the whole submission" in f for f in found["ben"]
    )
    assert any("test cell test_hw1_newton deleted (3.75 points)" in f and "0, silently" in f for f in found["cat"])
    assert any("answer cell hw1_answer_slider deleted (3 points)" in f for f in found["cat"])
    assert any("'hw1 (1).ipynb', not 'hw1.ipynb'" in f and "--repair: hw1 (1).ipynb renamed" in f for f in found["dan"])
    assert any("'hw1-copy.ipynb'" in f and "zip_collect dropped it" in f for f in found["eve"])
    assert any("locked cell test_hw1_gear changed" in f and "puts the released text back" in f for f in found["fay"])
    assert any("several notebooks: 'draft.ipynb', 'final.ipynb'" in f for f in found["gus"])
    assert report.exit_code == 1
    assert command(HW, course=course) == 1
    printed = capsys.readouterr().out
    assert all(name in printed for name in ("ben", "cat", "dan", "eve", "fay", "gus"))


def test_the_repair_fixes_what_is_safe_and_says_what_is_left(course):
    before = {p: p.read_bytes() for p in (course / "build" / "submitted" / "ada").rglob("*.ipynb")}
    report = check_class(HW, course, repair=True)
    assert {p: p.read_bytes() for p in before} == before  # an intact notebook is not rewritten
    release = nbformat.read(course / "build" / "release" / HW / f"{HW}.ipynb", as_version=4)
    graded = [_gid(c) for c in release.cells if c.metadata.get("nbgrader", {}).get("grade")]
    submitted = course / "build" / "submitted"
    for student in ("ben", "cat", "dan", "eve"):
        notebook = nbformat.read(submitted / student / HW / f"{HW}.ipynb", as_version=4)
        ids = [_gid(c) for c in notebook.cells if c.metadata.get("nbgrader", {}).get("grade")]
        expected = [g for g in graded if not (student == "cat" and g == "hw1_answer_slider")]
        assert ids == expected, student  # each graded cell once, in the release's order
    assert not (submitted / "dan" / HW / f"{HW} (1).ipynb").exists()
    again = check_class(HW, course)
    left = [f for f in again.findings if f.differs]
    assert {f.student for f in left} == {"cat", "gus"}  # the lost answer, and two notebooks: not safe to pick
    assert any("hw1_answer_slider" in f.what for f in left)
    assert again.exit_code == 1 and report.exit_code == 1


def test_a_class_as_released_passes(tmp_path):
    release = release_notebook(tmp_path)
    folder = tmp_path / "build" / "submitted" / "ada" / HW
    folder.mkdir(parents=True)
    nbformat.write(release, folder / f"{HW}.ipynb")
    report = check_class(HW, tmp_path)
    assert report.findings == [] and report.exit_code == 0
    assert "every notebook as released" in report.text()


def test_nothing_collected_for_a_student_exits_non_zero(tmp_path):
    release_notebook(tmp_path)
    (tmp_path / "build" / "downloaded" / HW / "extracted" / "ivy").mkdir(parents=True)  # an empty archive
    report = check_class(HW, tmp_path)
    assert [f.what for f in report.findings] == ["nothing collected for this homework"]
    assert report.exit_code == 1


def test_no_release_is_one_line_and_exit_2(tmp_path, capsys):
    shutil.rmtree(tmp_path, ignore_errors=True)
    tmp_path.mkdir()
    assert command(HW, course=tmp_path) == 2
    err = capsys.readouterr().err
    assert err.startswith("mbd: error: no released notebook of hw1") and len(err.strip().splitlines()) == 1
