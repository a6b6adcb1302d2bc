"""nbgrader without traps: the same configuration from the repository root and from ``course/``, everything
nbgrader writes under ``build/``, and ``nbgrader generate_assignment`` by hand giving the whole student kit.

The commands run as an instructor types them: ``python -m nbgrader`` in a scratch copy of the course, with the
virtualenv's ``bin/`` not on PATH (the configuration has to find nbgrader's ``alembic`` itself).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from nbgrader.coursedir import CourseDirectory
from traitlets.config.loader import PyFileConfigLoader

from course.demo import scratch_course
from course.release.generator import REPO, source_files

ROOT_CONFIG = REPO / "nbgrader_config.py"
COURSE_CONFIG = REPO / "course" / "nbgrader_config.py"


def load(path: Path):
    return PyFileConfigLoader(path.name, path=str(path.parent)).load_config()


def plain(value):
    """A config as plain data, functions by name (each file's load defines its own function objects)."""
    if isinstance(value, dict):
        return {key: plain(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [plain(item) for item in value]
    if callable(value):
        return f"{value.__module__}.{value.__qualname__}"
    return value


def settings(config) -> dict:
    """The CourseDirectory nbgrader builds from a config: every setting, the config object itself aside."""
    values = CourseDirectory(config=config).trait_values()
    return {key: value for key, value in values.items() if key not in ("config", "parent", "log")}


def nbgrader(cwd: Path, *args: str) -> subprocess.CompletedProcess:
    """An nbgrader command as the instructor runs it, without the virtualenv's bin/ on PATH."""
    bin_dir = str(Path(sys.executable).parent)
    path = os.pathsep.join(p for p in os.environ.get("PATH", "").split(os.pathsep) if p and p != bin_dir)
    environment = dict(os.environ, PATH=path or os.defpath)
    environment.pop("NBGRADER_EXECUTION", None)
    return subprocess.run(
        [sys.executable, "-m", "nbgrader", *args], cwd=cwd, env=environment, capture_output=True, text=True, timeout=300
    )


def tree(root: Path) -> dict[str, str]:
    """Every file outside build/ (and Python's caches), with a digest of its content."""
    files = {}
    for path in sorted(root.rglob("*")):
        relative = path.relative_to(root)
        if path.is_file() and relative.parts[0] != "build" and "__pycache__" not in relative.parts:
            files[relative.as_posix()] = hashlib.sha256(path.read_bytes()).hexdigest()
    return files


def kit(folder: Path) -> list[str]:
    """Every file of a release folder."""
    return sorted(path.relative_to(folder).as_posix() for path in folder.rglob("*") if path.is_file())


# -- one configuration, two places ----------------------------------------------------------------------------


def test_the_root_configuration_is_the_course_configuration():
    root, course = load(ROOT_CONFIG), load(COURSE_CONFIG)
    assert plain(root) == plain(course)
    assert settings(root) == settings(course)
    assert CourseDirectory(config=root).root == str(REPO)


def test_everything_nbgrader_writes_is_under_build():
    config = load(COURSE_CONFIG)
    coursedir = CourseDirectory(config=config)
    for name in ("release", "submitted", "autograded", "feedback", "solution", "source_with_tests"):
        assert Path(getattr(coursedir, f"{name}_directory")).parts[0] == "build", name
    assert coursedir.source_directory == "assignments"
    assert coursedir.db_url == f"sqlite:///{REPO / 'build' / 'gradebook.db'}"
    assert config.ExportPlugin.to == str(REPO / "build" / "grades.csv")
    assert Path(config.ZipCollectApp.downloaded_directory).parts[0] == "build"


@pytest.fixture(scope="module")
def scratch(tmp_path_factory) -> Path:
    """A fresh copy of the course (no build/ yet), with both nbgrader configurations."""
    course = scratch_course(tmp_path_factory.mktemp("nbgrader-config") / "course")
    shutil.copy2(ROOT_CONFIG, course / "nbgrader_config.py")
    return course


def test_generate_assignment_by_hand_builds_the_whole_kit_or_nothing(scratch):
    """``nbgrader generate_assignment hwN --force`` hands over to ``mbd release``: the folder is what a release
    gives; refused (a stale modules/), it fails and leaves no release folder that looks complete."""
    folder = scratch / "build" / "release" / "hw1"
    done = nbgrader(scratch / "course", "generate_assignment", "hw1", "--force")
    assert done.returncode == 0, done.stderr[-3000:]
    assert "completing the student kit with `mbd release hw1`" in done.stderr
    assert done.stdout.startswith(f"released hw1 into {folder}")
    assert "CRITICAL" not in done.stderr  # no exchange is configured: nothing to shout about
    released = kit(folder)  # what `mbd release` wrote, nbgrader's step having run before it
    assert "hw1.ipynb" in released and "scenes/four_bar.yaml" in released
    assert {f"modules/{path.as_posix()}" for path in source_files(scratch / "solutions")} <= set(released)

    stale = scratch / "modules" / "kinematics.py"
    text = stale.read_text()
    stale.write_text(text + "\n# edited by hand\n")
    try:
        done = nbgrader(scratch / "course", "generate_assignment", "hw1", "--force")
    finally:
        stale.write_text(text)
    assert done.returncode == 2
    assert "error: modules/ is stale" in done.stderr and "nbgrader alone does not build the student kit" in done.stderr
    assert not folder.exists()


def test_nbgrader_export_from_the_root_writes_its_csv_into_build_and_nothing_else(scratch):
    """From the course root, build/grades.csv and nothing else. (From course/, after a whole grading cycle:
    tests/course/nbgrader_cycle.py.)"""
    before = tree(scratch)
    done = nbgrader(scratch, "export")
    assert done.returncode == 0, done.stderr[-3000:]
    assert f"Exporting grades to {scratch / 'build' / 'grades.csv'}" in done.stderr
    assert (scratch / "build" / "grades.csv").read_text().startswith("assignment,duedate,timestamp,student_id")
    assert tree(scratch) == before  # nothing written outside build/ (no grades.csv where it ran)
