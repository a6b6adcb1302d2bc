"""The leak check finds every kind of planted leak, and nothing in a clean release."""

from __future__ import annotations

import shutil

import nbformat
import numpy as np
import pytest

from course.release.generator import HOMEWORKS, REPO, all_regions, build_package
from course.release.leakcheck import (
    LECTURE_SOLUTIONS,
    MIN_LINE,
    MIN_PROSE_LINE,
    find_leaks,
    lecture_solution_lines,
    secret_lines,
)

HIDDEN_SCENE = """\
# hidden variation of the slider-crank: longer rod, heavier slider
model:
  name: slider-crank-hidden
  bodies:
    - {name: crank,  mass: 1.3, inertia: 9.1e-4, location: [0.05, 0.0], orientation: 0.0}
    - {name: rod,    mass: 1.7, inertia: 1.1e-2, location: [0.27, 0.0], orientation: 0.0}
"""


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    """A course tree with the real solutions/, the real lecture solutions and planted grader data."""
    root = tmp_path_factory.mktemp("course")
    shutil.copytree(REPO / "solutions", root / "solutions", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(REPO / LECTURE_SOLUTIONS, root / LECTURE_SOLUTIONS)
    hidden = root / "autograder" / "scenes" / "hidden"
    hidden.mkdir(parents=True)
    (hidden / "slider_crank_long.yaml").write_text(HIDDEN_SCENE)
    reference = root / "autograder" / "reference" / "hidden"
    reference.mkdir(parents=True)
    rng = np.random.default_rng(5)
    np.savez(reference / "slider_crank_long.npz", t=np.linspace(0, 1, 11), q=rng.normal(size=(11, 9)))
    return root


def clean_release(tmp_path, homework: str):
    folder = tmp_path / homework
    build_package(folder / "modules", homework)
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell("# Homework")])
    nbformat.write(nb, folder / f"{homework}.ipynb")
    return folder


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_a_clean_release_has_no_leak(tmp_path, course, homework):
    assert find_leaks(clean_release(tmp_path, homework), homework, course) == []


def test_secret_lines_are_non_trivial_and_not_public():
    secret = secret_lines("hw2", REPO / "solutions")
    assert secret, "hw2 has solution regions: some of their lines are secret"
    assert all(len(line) >= MIN_LINE for line in secret)
    hw1 = {(f"solutions/{r.path}", r.function) for r in all_regions() if r.tag == "hw1"}
    places = {(where.split(":")[0], where.rsplit(" ", 1)[1].strip("()")) for where in secret.values()}
    assert places and not places & hw1


def _hw2_line():
    region = next(r for r in all_regions() if r.tag == "hw2" and any(len("".join(x.split())) >= 30 for x in r.text))
    return region, next(x for x in region.text if len("".join(x.split())) >= 30)


def test_a_solution_line_pasted_into_a_notebook_is_a_leak(tmp_path, course):
    folder = clean_release(tmp_path, "hw2")
    region, line = _hw2_line()
    nb = nbformat.read(folder / "hw2.ipynb", as_version=4)
    nb.cells.append(nbformat.v4.new_markdown_cell(f"Hint: try\n\n    {line.strip()}\n"))
    nbformat.write(nb, folder / "hw2.ipynb")
    leaks = find_leaks(folder, "hw2", course)
    assert [(leak.path, leak.kind) for leak in leaks] == [("hw2.ipynb", "solution text")]
    assert f"({region.function})" in leaks[0].detail


def test_the_same_line_is_public_once_its_homework_is_past(tmp_path, course):
    folder = clean_release(tmp_path, "hw3")
    _, line = _hw2_line()
    (folder / "notes.md").write_text(f"Recall from hw2: {line.strip()}\n")
    assert find_leaks(folder, "hw3", course) == []


def test_a_solutions_file_or_an_unstubbed_package_is_a_leak(tmp_path, course):
    folder = clean_release(tmp_path, "hw1")
    shutil.copy(REPO / "solutions" / "kinematics.py", folder / "kinematics.py")
    build_package(folder / "answers", None, header=None)
    leaks = find_leaks(folder, "hw1", course)
    assert any(leak.path == "kinematics.py" and leak.kind == "copied file" for leak in leaks)
    assert {leak.path for leak in leaks if leak.kind == "solution text"} >= {
        "answers/kinematics.py",
        "answers/planar/joints.py",
    }


def test_markers_compiled_code_and_forbidden_folders_are_leaks(tmp_path, course):
    folder = clean_release(tmp_path, "hw2")
    (folder / "stub.py").write_text("def f():\n    ### BEGIN SOLUTION hw2\n    pass\n    ### END SOLUTION\n")
    (folder / "modules" / "__pycache__").mkdir()
    (folder / "modules" / "__pycache__" / "kinematics.cpython-311.pyc").write_bytes(b"\x00\x01")
    (folder / "solutions").mkdir()
    kinds = {(leak.path, leak.kind) for leak in find_leaks(folder, "hw2", course)}
    assert kinds == {
        ("stub.py:2", "solution marker"),
        ("stub.py:4", "solution marker"),
        ("modules/__pycache__", "compiled code"),
        ("modules/__pycache__/kinematics.cpython-311.pyc", "compiled code"),
        ("solutions", "forbidden folder"),
    }


def test_a_hidden_scene_is_found_copied_renamed_reformatted_or_embedded(tmp_path, course):
    folder = clean_release(tmp_path, "hw1")
    (folder / "scene.yaml").write_text(HIDDEN_SCENE)
    (folder / "crlf.yml").write_bytes(HIDDEN_SCENE.replace("\n", "\r\n").encode())
    nb = nbformat.read(folder / "hw1.ipynb", as_version=4)
    nb.cells.append(nbformat.v4.new_code_cell(f'SCENE = """\n{HIDDEN_SCENE}"""'))
    nbformat.write(nb, folder / "hw1.ipynb")
    leaks = {(leak.path, leak.kind) for leak in find_leaks(folder, "hw1", course)}
    assert leaks == {("scene.yaml", "copied file"), ("crlf.yml", "copied file"), ("hw1.ipynb", "embedded file")}


def test_a_hidden_reference_run_is_a_leak(tmp_path, course):
    folder = clean_release(tmp_path, "hw1")
    shutil.copy(course / "autograder" / "reference" / "hidden" / "slider_crank_long.npz", folder / "data.npz")
    leaks = find_leaks(folder, "hw1", course)
    assert [(leak.path, leak.kind) for leak in leaks] == [("data.npz", "copied file")]
    assert "autograder/reference/hidden/slider_crank_long.npz" in leaks[0].detail


def test_stored_values_of_a_hidden_or_per_student_scene_are_a_leak(tmp_path, course):
    """Made anew (other bytes than any file of the course), a hidden scene's values still show by name."""
    import json

    folder = clean_release(tmp_path, "hw1")
    for scene, name in (("hidden/four_bar_b", "a.npz"), ("student/four_bar", "b.npz"), ("four_bar", "public.npz")):
        np.savez(folder / name, q=np.zeros(3), meta=np.array(json.dumps({"scene": scene})))
    leaks = sorted((leak.path, leak.kind) for leak in find_leaks(folder, "hw1", course))
    assert leaks == [("a.npz", "grader data"), ("b.npz", "grader data")]


def test_the_compiled_engine_never_reaches_a_student(tmp_path, course):
    """The compiled engine's kernels write out every formula students write, outside any region: no student
    package holds them, and a release that does (the folder, or a kernel file under another name) leaks."""
    assert not (REPO / "modules" / "compiled").exists()
    assert (REPO / "solutions" / "compiled" / "kernels.py").is_file()
    folder = clean_release(tmp_path, "hw3")
    assert not (folder / "modules" / "compiled").exists()
    shutil.copytree(REPO / "solutions" / "compiled", folder / "compiled", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "solutions" / "compiled" / "kernels.py", folder / "modules" / "fast.py")
    leaks = {(leak.path, leak.kind) for leak in find_leaks(folder, "hw3", course)}
    assert ("compiled", "forbidden folder") in leaks
    assert ("modules/fast.py", "copied file") in leaks and ("compiled/kernels.py", "copied file") in leaks


def test_the_batched_forms_never_reach_a_student(tmp_path, course):
    """The per-type (batched) forms write out the joints' formulas outside any region: no student package holds
    them, and a release that does (under their own name, even stubbed, or their text under another name) leaks."""
    folder = clean_release(tmp_path, "hw3")
    assert not (folder / "modules" / "planar" / "batched.py").exists()
    assert not (folder / "modules" / "spatial" / "batched.py").exists()
    stub = "def make_groups(elements):\n    raise NotImplementedError\n"
    (folder / "modules" / "planar" / "batched.py").write_text(stub)
    shutil.copy(REPO / "solutions" / "spatial" / "batched.py", folder / "modules" / "arrays.py")
    leaks = {(leak.path, leak.kind) for leak in find_leaks(folder, "hw3", course)}
    assert leaks == {("modules/planar/batched.py", "instructor-only file"), ("modules/arrays.py", "copied file")}


def test_a_student_package_runs_on_numpy_when_asked_for_the_compiled_engine(tmp_path):
    """Without the compiled engine a student's forward_dynamics(engine="compiled"|"auto") runs on numpy and
    says why (their `mbd run` defaults to auto)."""
    import subprocess
    import sys

    build_package(tmp_path / "modules", "hw3", header=None)  # hw1 and hw2 filled in: planar dynamics runs
    script = (
        "from modules.assembly import build_system\n"
        "from modules.dynamics import forward_dynamics\n"
        "from modules.io.model import load_model\n"
        f"s, q, qd = build_system(load_model({str(REPO / 'course' / 'models' / 'double_pendulum.yaml')!r}))\n"
        "for engine in ('compiled', 'auto'):\n"
        "    run = forward_dynamics(s, q, qd, 0.1, 2, engine=engine)\n"
        "    print(run.info['chosen']['engine'], '|', run.info['chosen']['engine_why'])\n"
    )
    out = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == ["numpy | this package has no compiled engine"] * 2, out.stdout


def test_a_derived_hidden_scene_is_found_by_its_text_or_its_numbers(tmp_path, course):
    """Hidden scenes are derived from the course secret (the test session's): a kit holding one, as YAML or
    JSON, whole or embedded, or only a few of its own numbers, leaks; the public scene's numbers do not."""
    import json

    import yaml

    from autograder.scenes import load_scene

    hidden, public = load_scene("hidden/four_bar_b").data, load_scene("four_bar").data
    folder = clean_release(tmp_path, "hw1")
    (folder / "scene.yaml").write_text(yaml.safe_dump(hidden, sort_keys=False))
    (folder / "public.yaml").write_text(yaml.safe_dump(public, sort_keys=False))
    nb = nbformat.read(folder / "hw1.ipynb", as_version=4)
    nb.cells.append(nbformat.v4.new_code_cell(f"SCENE = {json.dumps(hidden)!r}"))
    nbformat.write(nb, folder / "hw1.ipynb")
    masses = ", ".join(repr(b["mass"]) for b in hidden["model"]["bodies"])
    (folder / "notes.md").write_text(f"The grader's masses: {masses}\n")
    leaks = {(leak.path, leak.kind) for leak in find_leaks(folder, "hw1", course)}
    assert leaks == {
        ("scene.yaml", "copied file"),
        ("hw1.ipynb", "embedded file"),
        ("hw1.ipynb", "hidden values"),
        ("notes.md", "hidden values"),
    }


# -- the instructor's solutions of the lecture exercises -----------------------------------------------------------
def _answer_line(course, name: str = "L05.md") -> str:
    text = (course / LECTURE_SOLUTIONS / name).read_text()
    return next(line for line in text.splitlines() if "".join(line.split()) in lecture_solution_lines(course))


def test_a_lecture_solution_is_a_leak_whole_renamed_or_one_line_of_it(tmp_path, course):
    folder = clean_release(tmp_path, "hw1")
    line = _answer_line(course)
    nb = nbformat.read(folder / "hw1.ipynb", as_version=4)
    nb.cells.append(nbformat.v4.new_markdown_cell(f"A hint:\n\n{line.strip()}\n"))
    nbformat.write(nb, folder / "hw1.ipynb")
    (folder / "reading.md").write_text((course / LECTURE_SOLUTIONS / "L12.md").read_text())
    (folder / "more.md").write_text("Notes:\n" + (course / LECTURE_SOLUTIONS / "L13.md").read_text() + "\nend\n")
    found = {(leak.path, leak.kind) for leak in find_leaks(folder, "hw1", course)}
    assert ("hw1.ipynb", "lecture solution") in found
    assert ("reading.md", "copied file") in found and ("more.md", "embedded file") in found


def test_a_lecture_solutions_line_is_public_when_the_course_publishes_it(tmp_path, course):
    """A line the lecture solutions quote from a lecture or the notes is not a secret: a kit may hold it."""
    secret = lecture_solution_lines(course)
    assert len(secret) > 100 and all(len(line) >= MIN_PROSE_LINE for line in secret)
    copy = tmp_path / "course"
    shutil.copytree(course / LECTURE_SOLUTIONS, copy / LECTURE_SOLUTIONS)
    before, line = lecture_solution_lines(copy), _answer_line(course)
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell(f"Said in the lecture:\n{line}\n")])
    nbformat.write(nb, copy / "course" / "lectures" / "L05_quoted.ipynb")
    assert set(before) - set(lecture_solution_lines(copy)) == {"".join(line.split())}
