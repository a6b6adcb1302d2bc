"""``mbd todo``: the homework's functions left to write, read from the files (never imported)."""

from __future__ import annotations

import shutil

import pytest

from course.release import build_package
from course.release.generator import REPO, all_regions
from mbdkit.cli import todo_command
from mbdkit.todo import every_stub, left_to_write, report


def asked(homework: str) -> list[tuple[str, str]]:
    """What the release asks of the homework: its solution regions' (file, function), in the course's order."""
    return list(dict.fromkeys((r.path, r.function) for r in all_regions() if r.tag == homework))


@pytest.fixture(scope="module")
def skeleton(tmp_path_factory):
    package = tmp_path_factory.mktemp("todo") / "modules"
    build_package(package, "hw1")
    return package


def test_the_skeleton_has_every_function_left_in_the_course_order_with_its_equation(skeleton):
    to_write = asked("hw1")
    left = left_to_write(skeleton, to_write)
    assert [(item.path, item.function) for item in left] == to_write
    assert all(item.line > 0 and "eq." in item.says for item in left), [i for i in left if "eq." not in i.says]
    text = report("hw1", "modules", to_write, left)
    assert text.startswith(f"hw1: {len(to_write)} of {len(to_write)} functions left to write")
    assert f"Start with {to_write[0][1]} in modules/{to_write[0][0]}" in text


def test_a_written_file_leaves_the_list_and_a_kept_raise_does_not(skeleton, tmp_path):
    package = tmp_path / "modules"
    shutil.copytree(skeleton, package)
    bodies = "planar/bodies.py"
    shutil.copy(REPO / "solutions" / bodies, package / bodies)  # the reference's file: written
    to_write = asked("hw1")
    left = left_to_write(package, to_write)
    assert {(i.path, i.function) for i in left} == {pair for pair in to_write if pair[0] != bodies}
    joints = package / "planar" / "joints.py"
    text = joints.read_text()
    stub = "        raise NotImplementedError('Revolute.jacobian"
    assert stub in text
    joints.write_text(text.replace(stub, "        jac_i = None  # begun\n" + stub, 1))
    assert ("planar/joints.py", "Revolute.jacobian") in {(i.path, i.function) for i in left_to_write(package, to_write)}


def test_a_file_that_does_not_parse_or_a_renamed_function_is_named(skeleton, tmp_path):
    package = tmp_path / "modules"
    shutil.copytree(skeleton, package)
    (package / "planar" / "bodies.py").write_text("def rotation(phi:\n")
    left = left_to_write(package, [("planar/bodies.py", "rotation"), ("kinematics.py", "no_such_function")])
    assert left[0].says.startswith("a syntax error at line 1")
    assert left[1].says == "not found in this file (renamed or deleted?)"


def test_the_course_modules_list_every_stub_and_no_interface():
    stubs = every_stub(REPO / "modules")
    assert ("planar/bodies.py", "rotation") in stubs
    assert {pair for homework in ("hw1", "hw2", "hw3") for pair in asked(homework)} <= set(stubs)
    assert ("formulations.py", "Formulation.accelerations") not in stubs  # a base class's raise, not a stub


def test_user_errors_say_one_line(tmp_path, capsys):
    assert todo_command("hw9", tmp_path) == 2
    assert todo_command("hw1", tmp_path) == 2
    err = capsys.readouterr().err
    assert err.count("mbd: error:") == 2 and "no modules/" in err
