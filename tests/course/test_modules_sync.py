"""modules/ (the committed browsing copy, every region stubbed) is in sync with solutions/."""

from __future__ import annotations

import shutil

from course.release.generator import (
    INSTRUCTOR_ONLY,
    MODULES_HEADER,
    REPO,
    build_modules,
    modules_differences,
    package_files,
)


def test_modules_is_up_to_date():
    differences = modules_differences()
    assert not differences, "modules/ is out of date with solutions/: run `make modules`\n" + "\n".join(differences)


def test_modules_files_say_they_are_generated():
    for rel in package_files(REPO / "modules"):
        if rel.suffix == ".py":
            first = (REPO / "modules" / rel).read_text().split("\n", 1)[0] + "\n"
            assert first == MODULES_HEADER.format(path=rel.as_posix()), rel


def test_the_sync_check_fails_when_out_of_date(tmp_path):
    modules = tmp_path / "modules"
    build_modules(modules)
    assert modules_differences(modules) == []

    (modules / "kinematics.py").write_text((modules / "kinematics.py").read_text() + "\n# edited by hand\n")
    (modules / "results.py").unlink()
    (modules / "extra.py").write_text("")
    assert modules_differences(modules) == [
        "missing: modules/results.py",
        "not built from solutions/: modules/extra.py",
        "out of date: modules/kinematics.py",
    ]


def test_an_instructor_only_file_in_modules_is_out_of_sync(tmp_path):
    """modules/ never holds the batched forms (they stay with the instructor): one left there is reported."""
    modules = tmp_path / "modules"
    build_modules(modules)
    assert not [part for part in INSTRUCTOR_ONLY if (modules / part).exists()]
    shutil.copy(REPO / "solutions" / "planar" / "batched.py", modules / "planar" / "batched.py")
    assert modules_differences(modules) == ["not built from solutions/: modules/planar/batched.py"]


def test_the_sync_check_follows_a_change_in_solutions(tmp_path):
    solutions = tmp_path / "solutions"
    shutil.copytree(REPO / "solutions", solutions, ignore=shutil.ignore_patterns("__pycache__"))
    modules = tmp_path / "modules"
    build_modules(modules, solutions)
    functions = solutions / "functions.py"
    functions.write_text(functions.read_text().replace('"""', '"""Changed. ', 1))
    assert modules_differences(modules, solutions) == ["out of date: modules/functions.py"]
    assert not (tmp_path / "missing").exists()
    assert modules_differences(tmp_path / "missing", solutions)[0].endswith("does not exist: run `make modules`")
