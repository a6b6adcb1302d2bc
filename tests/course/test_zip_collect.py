"""``nbgrader zip_collect`` with the course's configuration: a platform's download collected with a preset
(``LmsCollector.lms``), the course's own layout (one zip per student id) without one, a count instead of a
warning per file, and exit code 2 with one line when nothing was collected.

nbgrader's ZipCollectApp runs in this process on a scratch course root (the course configuration with its root
moved there); the downloads are built from the platforms' documented names (tests/autograder/test_lms.py).
"""

from __future__ import annotations

import os
from pathlib import Path

import nbformat
import pytest
from nbgrader.apps.zipcollectapp import ZipCollectApp
from traitlets.config.loader import PyFileConfigLoader

from course.nbcheck import students
from course.release.generator import REPO

from ..autograder.test_lms import NOTEBOOK, download, kit, zipped

HW = "hw1"


@pytest.fixture(scope="module")
def course_config():
    return PyFileConfigLoader("nbgrader_config.py", path=str(REPO / "course")).load_config()


@pytest.fixture
def course(tmp_path, monkeypatch) -> Path:
    """A course root with hw1 released and an empty archive folder; the commands run there."""
    release = tmp_path / "build" / "release" / HW
    release.mkdir(parents=True)
    nbformat.write(nbformat.v4.new_notebook(), release / f"{HW}.ipynb")
    (tmp_path / "build" / "downloaded" / HW / "archive").mkdir(parents=True)
    monkeypatch.chdir(tmp_path)  # no nbgrader_config.py of the repository read
    return tmp_path


def zip_collect(course: Path, config, lms: str = "") -> int:
    """``nbgrader zip_collect hw1 [--LmsCollector.lms=LMS]`` with the course configuration rooted at ``course``:
    its exit code."""
    config = config.copy()
    config.CourseDirectory.root = str(course)
    app = ZipCollectApp(config=config)
    try:
        app.initialize([HW, *([f"--LmsCollector.lms={lms}"] if lms else [])])
        app.start()
    except SystemExit as stop:
        return stop.code
    return 0


def archive(course: Path) -> Path:
    return course / "build" / "downloaded" / HW / "archive"


def test_a_moodle_download_is_collected_per_participant_in_a_few_lines(course, course_config, capsys):
    download(
        archive(course) / "MBD-hw1-412.zip",
        {
            "Ada Lovelace_101_assignsubmission_file/hw1-handin.zip": kit("101"),
            "Cy Dee_103_assignsubmission_file_hw1-handin.zip": kit("103", notebook="hw1 (1).ipynb"),
            "Eve Online_105_assignsubmission_onlinetext/onlinetext.html": b"<p>done</p>",
        },
    )
    assert zip_collect(course, course_config, "moodle") == 0
    submitted = course / "build" / "submitted"
    for student in ("101", "103"):
        assert (submitted / student / HW / f"{HW}.ipynb").read_bytes() == NOTEBOOK
        assert (submitted / student / HW / "modules" / "planar" / "bodies.py").read_text() == f"# {student}\n"
    assert sorted(p.name for p in submitted.iterdir()) == ["101", "103"]
    printed = capsys.readouterr().err
    assert "Moodle preset: 2 students, 6 files collected" in printed
    assert "Skipped submission" not in printed and "Directory not found" not in printed
    assert students(course, HW) == ["101", "103"]  # mbd nbcheck: not the download's folder as a student


def test_a_canvas_download_with_the_moodle_preset_exits_2_naming_canvas(course, course_config, capsys):
    download(archive(course) / "canvas.zip", {"lovelaceada_LATE_5001_9001_hw1-handin.zip": kit("5001")})
    assert zip_collect(course, course_config, "moodle") == 2
    err = capsys.readouterr().err
    line = next(x for x in err.splitlines() if x.startswith("0 submissions found in"))
    assert "no file matched the Moodle preset's names" in line
    assert line.endswith("is it Canvas's download? nbgrader zip_collect hw1 --LmsCollector.lms=canvas")
    assert not (course / "build" / "submitted").exists()


def test_without_a_preset_the_course_layout_is_collected_as_before(course, course_config, capsys):
    (archive(course) / "ada.zip").write_bytes(kit("ada", top="kit/"))
    (archive(course) / "ben.zip").write_bytes(kit("ben", top="kit/", notebook="hw1-copy.ipynb"))
    (archive(course) / "cy.zip").write_bytes(zipped({"notes.txt": b""}))
    assert zip_collect(course, course_config) == 0
    submitted = course / "build" / "submitted"
    assert (submitted / "ada" / HW / "modules" / "planar" / "bodies.py").read_text() == "# ada\n"
    assert (submitted / "ada" / HW / f"{HW}.ipynb").read_bytes() == NOTEBOOK
    assert sorted(p.name for p in (submitted / "ben" / HW).iterdir()) == ["modules"]  # strict: the copy dropped
    assert sorted(p.name for p in submitted.iterdir()) == ["ada", "ben"]
    assert "named_regexp: 2 students, 6 files matched" in capsys.readouterr().err


def test_nothing_downloaded_is_one_line_and_exit_2(course, course_config, capsys):
    assert zip_collect(course, course_config, "canvas") == 2
    assert f"{os.sep}archive is empty or missing" in capsys.readouterr().err
