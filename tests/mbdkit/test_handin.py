"""``mbd handin``: a zip of exactly what is graded, which grades as the folder does; refusals in one line."""

from __future__ import annotations

import shutil
import zipfile

import pytest

from autograder.grading import grade
from course.release import build_package
from course.release.generator import REPO
from mbdkit.cli import handin_command

NOTEBOOK = REPO / "assignments" / "hw1" / "hw1.ipynb"


@pytest.fixture
def folder(tmp_path):
    """A homework folder as a student leaves it: the notebook, modules/ (the reference with a mistake: the sign
    of the revolute joint's gamma) and what else such a folder holds (a venv, build/, egg-info, the kit, scenes,
    caches, checkpoints)."""
    work = tmp_path / "hw1"
    build_package(work / "modules", None, header=None)
    joints = work / "modules" / "planar" / "joints.py"
    right = "        return point_vector_quadratic(qi, self.si, qj, self.sj, qdi, qdj)"
    assert joints.read_text().count(right) == 1
    joints.write_text(joints.read_text().replace(right, right.replace("return ", "return -")))
    shutil.copy(NOTEBOOK, work / "hw1.ipynb")
    for junk in (".venv/lib/site.py", "build/lib/x.py", "mbd_course_hw1.egg-info/PKG-INFO", "scenes/four_bar.yaml",
                 "mbdkit/api.py", ".ipynb_checkpoints/hw1-checkpoint.ipynb", "modules/__pycache__/x.cpython-311.pyc",
                 "modules/.ipynb_checkpoints/kinematics-checkpoint.py"):  # fmt: skip
        (work / junk).parent.mkdir(parents=True, exist_ok=True)
        (work / junk).write_bytes(b"x" * 300_000)
    return work


def test_the_zip_holds_the_notebook_and_the_package_only_and_grades_as_the_folder(folder, tmp_path, capsys):
    assert handin_command("hw1", folder) == 0
    said = capsys.readouterr().out
    zipped = folder / "hw1-handin.zip"
    assert said.startswith(f"wrote {zipped} (") and "hw1.ipynb" in said
    with zipfile.ZipFile(zipped) as archive:
        names = archive.namelist()
        archive.extractall(tmp_path / "unzipped" / "bea")
    made = {"__pycache__", ".ipynb_checkpoints"}  # by Python and JupyterLab, not the student
    files = [p for p in (folder / "modules").rglob("*") if p.is_file() and not made & set(p.parts)]
    package = sorted(p.relative_to(folder).as_posix() for p in files)
    assert names == ["hw1.ipynb", *package]
    assert zipped.stat().st_size < 1_000_000  # the bound for hw1 before Run All
    shutil.copytree(folder, tmp_path / "folder" / "bea", ignore=shutil.ignore_patterns("*.zip"))
    by_folder = grade("hw1", tmp_path / "folder", tmp_path / "out1", jobs=1, progress=False)
    by_zip = grade("hw1", tmp_path / "unzipped", tmp_path / "out2", jobs=1, progress=False)
    assert by_zip.score("bea") == by_folder.score("bea") < by_folder.max_score  # the mistake costs the same


def test_what_cannot_be_graded_is_refused_in_one_line_and_nothing_is_written(folder, tmp_path, capsys):
    joints = folder / "modules" / "planar" / "joints.py"
    joints.write_text(joints.read_text() + "\nbroken = (\n")
    assert handin_command("hw1", folder) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not import" in err and "SyntaxError" in err
    (folder / "hw1.ipynb").write_text("{not json")
    assert handin_command("hw1", folder) == 2
    assert "is not a notebook" in capsys.readouterr().err
    (folder / "hw1.ipynb").unlink()
    assert handin_command("hw1", folder) == 2
    assert "no hw1.ipynb" in capsys.readouterr().err
    assert handin_command("hw9", folder) == 2
    assert not list(folder.glob("*.zip")) and not list(folder.glob("*.partial"))
    shutil.copy(NOTEBOOK, folder / "hw1.ipynb")
    joints.write_text(joints.read_text().replace("\nbroken = (\n", "\n"))
    assert handin_command("hw1", folder, str(tmp_path / "no-such-folder" / "x.zip")) == 2
    assert "no folder" in capsys.readouterr().err


def test_a_linked_package_is_refused_as_the_grader_refuses_it(folder, tmp_path, capsys):
    """The hand-in takes modules/ as the grader stages it (mbdkit.staging): a modules that is a link to a
    folder elsewhere (the course's solutions, say) would grade as nothing, so it is not handed in."""
    shutil.move(folder / "modules", tmp_path / "elsewhere")
    (folder / "modules").symlink_to(tmp_path / "elsewhere")
    assert handin_command("hw1", folder) == 2
    assert "modules is a symbolic link" in capsys.readouterr().err and not list(folder.glob("*.zip"))
