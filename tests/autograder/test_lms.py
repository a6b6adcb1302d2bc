"""A learning platform's "download all submissions" collected per student (``mbd grade --lms``, autograder/lms.py).

Every download here is built from the platform's documented naming, written out in this file (not from the
code under test): Moodle (mod/assign's downloader) puts a student's files in ``Full Name_PARTICIPANT_
assignsubmission_file/`` (``..._file_/`` before 4.1) or prefixes each file with ``..._assignsubmission_file_``;
Canvas (content_zipper.rb) names each file ``lastnamefirstname[_LATE]_USERID_ATTACHMENTID_FILENAME`` or
``anon_ID_ATTACHMENTID_FILENAME``, and renames a file uploaded again ``hw1-1.ipynb``.
"""

from __future__ import annotations

import csv
import io
import zipfile
from pathlib import Path

import pytest

from autograder import cli, lms
from autograder.grading import Gradebook, find_submissions

NOTEBOOK = b'{"cells": [], "metadata": {}, "nbformat": 4, "nbformat_minor": 5}'


def zipped(files: dict[str, bytes]) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, data in files.items():
            archive.writestr(name, data)
    return buffer.getvalue()


def kit(mark: str, top: str = "", notebook: str = "hw1.ipynb") -> bytes:
    """A hand-in as ``mbd handin`` writes it (``top``: a zip of the kit folder instead); bodies.py says whose."""
    return zipped(
        {
            f"{top}{notebook}": NOTEBOOK,
            f"{top}modules/__init__.py": b"",
            f"{top}modules/planar/bodies.py": f"# {mark}\n".encode(),
            f"{top}modules/planar/__pycache__/bodies.cpython-312.pyc": b"\0",
        }
    )


def whole_kit_folder(mark: str) -> bytes:
    """A student who zipped the kit folder itself: a stale build/ copy of the package, the venv, the checker."""
    return zipped(
        {
            "hw1/hw1.ipynb": NOTEBOOK,
            "hw1/modules/__init__.py": b"",
            "hw1/modules/planar/bodies.py": f"# {mark}\n".encode(),
            "hw1/build/lib/modules/planar/bodies.py": b"# stale\n",
            "hw1/.venv/lib/python3.12/site-packages/x.py": b"",
            "hw1/mbdkit/check.py": b"",
            "hw1/scenes/four_bar.yaml": b"",
        }
    )


def download(path: Path, entries: dict[str, bytes]) -> Path:
    path.write_bytes(zipped(entries))
    return path


@pytest.fixture
def moodle(tmp_path) -> Path:
    return download(
        tmp_path / "MBD-hw1-412.zip",
        {
            "Ada Lovelace_101_assignsubmission_file/hw1-handin.zip": kit("101"),  # Moodle 4.1+
            "Ben Bitdiddle_102_assignsubmission_file_/hw1-handin.zip": kit("102"),  # Moodle 3.1 - 4.0
            "Cy Dee_103_assignsubmission_file_hw1-handin.zip": kit("103", notebook="hw1 (1).ipynb"),  # flat
            "Dora Explorer_104_assignsubmission_file/hw1.zip": whole_kit_folder("104"),
            "Eve Online_105_assignsubmission_onlinetext/onlinetext.html": b"<p>done</p>",
            "Fay Folder_106_assignsubmission_file/hw1.ipynb": NOTEBOOK,  # uploaded file by file, with folders
            "Fay Folder_106_assignsubmission_file/modules/__init__.py": b"",
            "Fay Folder_106_assignsubmission_file/modules/planar/bodies.py": b"# 106\n",
        },
    )


@pytest.fixture
def canvas(tmp_path) -> Path:
    return download(
        tmp_path / "mbd-hw1 submissions.zip",
        {
            "lovelaceada_5001_9001_hw1-handin.zip": kit("5001"),
            "bitdiddleben_LATE_5002_9002_hw1-handin.zip": kit("5002"),
            "deecy_5003_9003_hw1-1.ipynb": NOTEBOOK,  # a notebook uploaded again: Canvas's '-1'
            "explorerdora_5004_9005_hw1-handin.zip": kit("5004 first"),
            "explorerdora_5004_9006_hw1-handin-1.zip": kit("5004 second"),
            "anon_Ab1cD_9007_hw1-handin.zip": kit("anon"),
            "onlineeve_5005_text.html": b"<p>done</p>",
        },
    )


def rows(folder: Path) -> dict[str, dict]:
    with open(folder / "collected.csv", newline="") as f:
        return {row["student"]: row for row in csv.DictReader(f)}


def test_moodle_download_gives_one_folder_per_participant_with_its_notebook_and_package(moodle, tmp_path):
    out = tmp_path / "submissions"
    found = lms.unpack(moodle, lms.preset("moodle"), "hw1", out)
    assert {s.id for s in found.handed_in} == {"101", "102", "103", "104", "106"}
    for student in ("101", "102", "103", "104", "106"):
        assert (out / student / "hw1.ipynb").read_bytes() == NOTEBOOK, student
        assert (out / student / "modules" / "planar" / "bodies.py").read_text() == f"# {student}\n", student
    written = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
    assert written == {"collected.csv"} | {
        f"{s}/{f}"
        for s in ("101", "102", "103", "104", "106")
        for f in ("hw1.ipynb", "modules/__init__.py", "modules/planar/bodies.py")
    }  # no cache, venv, checker, scenes or build/ copy
    names = {k: r["name"] for k, r in rows(out).items()}
    assert names == {
        "101": "Ada Lovelace",
        "102": "Ben Bitdiddle",
        "103": "Cy Dee",
        "104": "Dora Explorer",
        "106": "Fay Folder",
    }
    assert "'hw1 (1).ipynb' taken as hw1.ipynb" in rows(out)["103"]["note"]
    text = found.summary("MBD-hw1-412.zip")
    assert text.startswith("Moodle preset: 5 students, 15 files collected")
    assert "1 online text" in text and len(text.splitlines()) <= 6
    assert [s.student for s in find_submissions(out, "hw1") if not s.missing] == ["101", "102", "103", "104", "106"]
    unpacked = tmp_path / "unpacked"  # the same download unpacked by hand: the same collection
    zipfile.ZipFile(moodle).extractall(unpacked)
    again = lms.unpack(unpacked, lms.preset("moodle"), "hw1", tmp_path / "again")
    assert {s.id: s.files.keys() for s in again.handed_in} == {s.id: s.files.keys() for s in found.handed_in}


def test_canvas_download_gives_user_ids_late_and_the_latest_upload(canvas, tmp_path):
    out = tmp_path / "submissions"
    found = lms.unpack(canvas, lms.preset("canvas"), "hw1", out)
    assert {s.id for s in found.handed_in} == {"5001", "5002", "5003", "5004", "anon_Ab1cD"}
    assert {k for k, r in rows(out).items() if r["late"]} == {"5002"}
    assert rows(out)["5001"]["name"] == "lovelaceada"
    assert (out / "5003" / "hw1.ipynb").read_bytes() == NOTEBOOK  # hw1-1.ipynb, Canvas's resubmission name
    assert (out / "5004" / "modules" / "planar" / "bodies.py").read_text() == "# 5004 second\n"
    assert (out / "anon_Ab1cD" / "modules" / "planar" / "bodies.py").read_text() == "# anon\n"
    assert "late (1): 5002" in found.summary("x.zip")


def test_a_documented_regexp_names_another_platform_and_the_later_attempt_wins(tmp_path):
    archive = download(
        tmp_path / "other.zip",
        {
            "hw1_s1234567_2026-05-01T10-00_hw1-handin.zip": kit("first"),
            "hw1_s1234567_2026-05-02T09-00_hw1-handin.zip": kit("second"),
            "hw1_s7654321_2026-05-01T11-00_hw1-handin.zip": kit("other"),
        },
    )
    regexp = r"hw1_(?P<student_id>s\d+)_(?P<timestamp>[\dT-]+)_(?P<file_id>.+)"  # course/nbgrader_config.py's
    found = lms.unpack(archive, lms.preset(regexp), "hw1", tmp_path / "out")
    assert {s.id for s in found.handed_in} == {"s1234567", "s7654321"}
    assert (tmp_path / "out" / "s1234567" / "modules" / "planar" / "bodies.py").read_text() == "# second\n"
    with pytest.raises(lms.LmsError, match="student_id"):
        lms.preset(r"(?P<id>\d+)_.*")


def test_hostile_hand_ins_climb_nowhere_and_cost_a_line_each(tmp_path, monkeypatch):
    evil = zipped(
        {
            "../../escaped.py": b"",
            "modules/../../../up.py": b"",
            "hw1.ipynb": NOTEBOOK,
            "modules/__init__.py": b"",
            "modules/inner.zip": kit("inner"),  # a zip in a hand-in is not opened
        }
    )
    archive = download(
        tmp_path / "d.zip",
        {
            "Mal Icious_107_assignsubmission_file/hw1-handin.zip": evil,
            "Nil Zip_108_assignsubmission_file/hw1-handin.zip": b"not a zip",
            "Big Book_109_assignsubmission_file/hw1-handin.zip": kit("109"),
        },
    )
    monkeypatch.setattr(lms, "NOTEBOOK_BYTES", len(NOTEBOOK) - 1)
    out = tmp_path / "deep" / "out"
    found = lms.unpack(archive, lms.preset("moodle"), "hw1", out)
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*.py")) == [
        "deep/out/107/modules/__init__.py",
        "deep/out/109/modules/__init__.py",
        "deep/out/109/modules/planar/bodies.py",
    ]
    assert not list(out.rglob("*.ipynb"))  # both notebooks over the (patched) size
    reasons = {reason: len(paths) for reason, paths in found.skipped.items()}
    assert reasons["with '..' in their names (not written)"] == 2
    assert reasons["zips inside a hand-in zip (not opened)"] == 1
    assert reasons["hand-in zips that cannot be opened (damaged, encrypted, over 256 MB)"] == 1
    assert reasons["too large to be graded or damaged in the zip"] == 2


def test_mbd_grade_collects_a_download_then_grades_the_student_folders(moodle, tmp_path, monkeypatch, capsys):
    seen = {}

    def grade(homework, folder, out, **_):
        seen.update({s.student: s.missing for s in find_submissions(Path(folder), homework)})
        Path(out).mkdir()  # as grade() does once it can start
        return Gradebook(homework, [], {}, out_dir=Path(out))

    monkeypatch.setattr(cli, "grade", grade)
    out = tmp_path / "grades"
    assert cli.grade_command("hw1", moodle, out, jobs=1, lms="moodle") == 0
    assert seen == {"101": False, "102": False, "103": False, "104": False, "106": False}
    assert sorted(p.name for p in (out / "submissions").iterdir()) == [
        "101",
        "102",
        "103",
        "104",
        "106",
        "collected.csv",
    ]
    printed = capsys.readouterr().out
    assert "Moodle preset: 5 students" in printed and "submissions:" in printed


def test_a_download_the_preset_does_not_fit_is_one_line_exit_2_and_names_the_preset_it_fits(
    canvas, moodle, tmp_path, capsys
):
    out = tmp_path / "grades"
    assert cli.grade_command("hw1", canvas, out, jobs=1, lms="moodle") == 2
    line = capsys.readouterr().err.strip()
    assert "\n" not in line and line.startswith(f"mbd: error: 0 submissions found in {canvas}")
    assert "Moodle preset's names ('Full Name_12345_assignsubmission_file" in line
    assert line.endswith("is it Canvas's download? --lms canvas")
    assert cli.grade_command("hw1", moodle, out, jobs=1, lms="canvas") == 2
    assert capsys.readouterr().err.strip().endswith("is it Moodle's download? --lms moodle")
    assert cli.grade_command("hw1", moodle, out, jobs=1) == 2  # a zip, no --lms: say which
    assert capsys.readouterr().err.strip().endswith("--lms moodle|canvas|REGEXP; is it Moodle's download? --lms moodle")
    assert not out.exists()
