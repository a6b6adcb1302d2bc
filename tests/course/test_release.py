"""`mbd release hwN` end to end with nbgrader, on a fresh copy of the course (a git work tree of its own)."""

from __future__ import annotations

import importlib
import json
import re
import shutil
import subprocess
from pathlib import Path

import nbformat
import numpy as np
import pytest
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError

from course.release import HOMEWORKS, ReleaseError, build_modules, find_leaks, release
from course.release.generator import REPO, all_regions, source_files
from course.release.release import load_config
from mbdkit.homework import load_homework

from ..conftest import execute_notebook

COPIED = ("solutions", "course", "assignments", "autograder", "mbdkit", "pyproject.toml")
IGNORED = shutil.ignore_patterns("__pycache__", "build", ".ipynb_checkpoints")
GIT = shutil.which("git")


def git(folder: Path, *args: str) -> str:
    command = [GIT, "-c", "user.name=test", "-c", "user.email=test@example.org", "-c", "commit.gpgsign=false", *args]
    return subprocess.run(command, cwd=folder, check=True, capture_output=True, text=True).stdout


def fresh_clone(root: Path) -> Path:
    """The course's files as a fresh clone has them: modules/ regenerated and everything committed."""
    for name in COPIED:
        if (REPO / name).is_file():
            shutil.copy2(REPO / name, root / name)
        elif (REPO / name).exists():
            shutil.copytree(REPO / name, root / name, ignore=IGNORED)
    build_modules(root / "modules", root / "solutions")
    if GIT:
        git(root, "init", "--quiet")
        git(root, "add", "--all")
        git(root, "commit", "--quiet", "-m", "course")
    return root


@pytest.fixture(scope="module")
def released(tmp_path_factory):
    """One release of every homework, into one fresh copy of the course."""
    course = fresh_clone(tmp_path_factory.mktemp("course"))
    return course, {homework: release(homework, course) for homework in HOMEWORKS}


@pytest.fixture
def clone(tmp_path):
    return fresh_clone(tmp_path)


def load_student_package(folder: Path, name: str, tools):
    package = tools.load_package(folder / "modules", name)
    return lambda module: importlib.import_module(f"{package.__name__}.{module}")


def run_notebook(notebook: Path, folder: Path) -> None:
    nb = nbformat.read(notebook, as_version=4)
    client = NotebookClient(nb, timeout=120, kernel_name="python3", resources={"metadata": {"path": str(folder)}})
    execute_notebook(client)


# -- what a release holds --------------------------------------------------------------------------------


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_release_folder_holds_the_notebook_without_solutions_and_the_student_package(released, homework):
    course, reports = released
    report = reports[homework]
    folder = course / "build" / "release" / homework
    assert report.folder == folder and report.notebooks == [f"{homework}.ipynb"]
    nb = nbformat.read(folder / f"{homework}.ipynb", as_version=4)
    solution_cells = [c for c in nb.cells if c.metadata.get("nbgrader", {}).get("solution")]
    graded_cells = [c for c in nb.cells if c.metadata.get("nbgrader", {}).get("grade")]
    stubs = {"code": "raise NotImplementedError()", "markdown": "YOUR ANSWER HERE"}  # code, or a written answer
    assert solution_cells and all(stubs[c.cell_type] in c.source for c in solution_cells)
    assert graded_cells and all(c.metadata["nbgrader"]["points"] > 0 for c in graded_cells)
    tests = sum(c.metadata["nbgrader"]["points"] for c in graded_cells if c not in solution_cells)
    kit = load_homework(folder / "mbdkit" / "data" / f"{homework}.toml")  # the self-check's: public checks only
    assert kit.out_of == tests == 100 and kit.max_score < kit.out_of  # it says the homework's scale, not 75
    assert sorted(report.files) == sorted(p.as_posix() for p in source_files(folder / "modules"))
    assert find_leaks(folder, homework, course) == []
    summary = report.summary()
    assert f"released {homework} into {folder}" in summary and "leak check:       clean" in summary
    assert report.exchange is None and not (course / "assignments" / homework / "modules").exists()


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_the_kit_holds_the_notes_citing_only_what_it_holds(released, homework):
    """Every kit has the course notes' site (each chapter with its equations' anchors, the lectures, search, MathJax
    beside them) and the example models; no page cites a file the kit does not have: no solutions/, tests/,
    course/ or DESIGN, and every modules/X or models/X a page names is in the kit."""
    course, reports = released
    folder = course / "build" / "release" / homework
    notes = folder / "notes"
    pages = {p.name: p.read_text(encoding="utf-8") for p in notes.glob("*.html")}
    assert {"index.html", "search.html", "ch03_planar_constraints.html", "L01_planar_kinematics.html"} <= set(pages)
    assert 'id="eq-3.17"' in pages["ch03_planar_constraints.html"] and (notes / "_static/mathjax/MathJax.js").exists()
    assert (folder / "models" / "slider_crank.yaml").exists() and "notes/index.html" in reports[homework].kit
    text = "\n".join(re.sub(r"<[^>]+>", "", page) for page in pages.values())  # what a reader sees
    assert re.findall(r"\b(?:solutions|tests|course|DESIGN)/\S*", text) == []
    cited = set(re.findall(r"\b((?:modules|models)/[\w/]+\.(?:py|yaml))", text))
    assert len(cited) > 10 and [path for path in sorted(cited) if not (folder / path).exists()] == []
    assert "course notes:     " in reports[homework].summary()
    statement = "\n".join(c.source for c in nbformat.read(folder / f"{homework}.ipynb", as_version=4).cells)
    links = re.findall(r"\]\((notes/[\w.]+\.html)#eq-(\d+\.\d+)\)", statement)  # eq. N.M of the statement
    assert len(links) >= 5 and all((folder / page).exists() and f'id="eq-{n}"' in pages[page[6:]] for page, n in links)
    equations = json.loads((folder / "mbdkit" / "data" / "equations.json").read_text())  # what a check cites
    assert len(equations) > 150 and all((notes / page).exists() for page, _ in equations.values())


def test_each_release_stubs_its_own_homework_and_fills_in_the_earlier_ones(released):
    _, reports = released
    tagged = {r.qualified_name: r.homework for r in all_regions()}
    for index, homework in enumerate(HOMEWORKS, start=1):
        report = reports[homework]
        assert set(report.to_write) == {name for name, h in tagged.items() if h == index}
        assert set(report.given) == {name for name, h in tagged.items() if h < index}
        assert set(report.later) == {name for name, h in tagged.items() if h > index}


def test_hw2_release_has_hw1_working_and_hw2_raising_with_its_pointer(released, reference_calls, tools):
    course, reports = released
    folder = course / "build" / "release" / "hw2"
    module = load_student_package(folder, "released_hw2", tools)

    # hw1, given: the slider-crank against its closed form x_B = r cos(theta) + sqrt(l^2 - r^2 sin^2(theta))
    model = module("io.model").load_model(course / "course" / "models" / "slider_crank.yaml")
    system, q0, _ = module("assembly").build_system(model)
    result = module("kinematics").kinematic_analysis(system, q0, 2 * np.pi / 10, 40)
    theta = 10.0 * result.t
    expected = 0.1 * np.cos(theta) + np.sqrt(0.3**2 - (0.1 * np.sin(theta)) ** 2)
    np.testing.assert_allclose(result.q[:, 6], expected, rtol=0, atol=1e-10)

    # hw2: every function to write raises NotImplementedError with its pointer
    hw2 = [r for r in all_regions() if r.tag == "hw2"]
    assert hw2 and reports["hw2"].to_write
    for region in hw2:
        func = tools.resolve("released_hw2", region)
        code = func.__code__
        arguments = reference_calls.get((region.path, region.function))  # a real call, else all None
        if arguments is None:
            arguments = dict.fromkeys(code.co_varnames[: code.co_argcount + code.co_kwonlyargcount])
        outcome = tools.call(func, arguments)
        assert outcome[0] == "raise" and isinstance(outcome[1], NotImplementedError), (region.function, outcome)
        assert str(outcome[1]) == region.pointer


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_the_instructors_notebook_stops_at_the_students_stubs(released, homework, monkeypatch):
    """The instructor's notebook on the released package hits a stub of this homework. (On the reference it
    passes every cell: tests/course/test_notebooks.py::test_source_notebook_passes_every_graded_cell_...)"""
    course, _ = released
    monkeypatch.setenv("MBD_ANIMATIONS", "0")  # the kernel inherits it: no animation rendering here
    source = course / "assignments" / homework / f"{homework}.ipynb"
    student = course / "build" / "release" / homework
    with pytest.raises(CellExecutionError, match="NotImplementedError|not implemented yet") as caught:
        run_notebook(source, student)  # the same solution on the released package hits a stub of hwN
    assert any(f"{r.function}: " in str(caught.value) for r in all_regions() if r.tag == homework)


def test_autograde_keeps_the_students_modules(released):
    course, _ = released
    config = load_config(course)
    files = sorted(f"modules/{p.as_posix()}" for p in source_files(course / "solutions"))
    for homework in HOMEWORKS:
        assert sorted(config.Autograde.exclude_overwriting[homework]) == files
    assert config.IgnorePattern.enabled and config.IgnorePattern.pattern
    assert config.CourseDirectory.source_directory == "assignments"
    assert config.Execute.timeout > 0


# -- refusals ---------------------------------------------------------------------------------------------


def test_unknown_homework_is_refused(clone):
    with pytest.raises(ReleaseError, match=r"unknown homework 'hw4': this course has hw1, hw2, hw3"):
        release("hw4", clone)


def test_stale_modules_is_refused(clone):
    kinematics = clone / "modules" / "kinematics.py"
    kinematics.write_text(kinematics.read_text() + "\n# edited by hand\n")
    with pytest.raises(ReleaseError, match=r"modules/ is stale(.|\n)*out of date: modules/kinematics.py"):
        release("hw1", clone)
    assert not (clone / "build" / "release" / "hw1").exists()


@pytest.mark.skipif(GIT is None, reason="needs git")
def test_dirty_modules_is_refused(clone):
    functions = clone / "solutions" / "functions.py"
    functions.write_text(functions.read_text() + "\n# a comment\n")
    build_modules(clone / "modules", clone / "solutions")  # in sync, but not committed
    with pytest.raises(ReleaseError, match=r"modules/ is dirty(.|\n)*modules/functions.py"):
        release("hw1", clone)
    git(clone, "commit", "--quiet", "--all", "-m", "regenerated")
    assert release("hw1", clone).to_write


def test_a_leak_is_refused_and_the_release_folder_deleted(clone):
    hidden = clone / "autograder" / "scenes" / "hidden"
    hidden.mkdir(parents=True, exist_ok=True)
    scene = "model:\n  name: hidden-four-bar\n  bodies: []\n"
    (hidden / "four_bar_variant.yaml").write_text(scene)
    (clone / "assignments" / "hw1" / "extra.yaml").write_text(scene)
    with pytest.raises(ReleaseError, match=r"hw1 not released(.|\n)*extra.yaml: copied file"):
        release("hw1", clone)
    assert not (clone / "build" / "release" / "hw1").exists()


def test_release_through_a_configured_exchange(clone):
    exchange = clone / "exchange"
    with open(clone / "course" / "nbgrader_config.py", "a") as config:
        config.write(f'\nc.CourseDirectory.course_id = "mbd"\nc.Exchange.root = {str(exchange)!r}\n')
    if GIT:
        git(clone, "commit", "--quiet", "--all", "-m", "exchange")
    report = release("hw2", clone)
    outbound = exchange / "mbd" / "outbound" / "hw2"
    assert report.exchange == str(outbound)
    assert (outbound / "hw2.ipynb").is_file() and (outbound / "modules" / "kinematics.py").is_file()
    assert find_leaks(outbound, "hw2", clone) == []
    assert "released to" in report.summary()


def test_the_command_prints_the_release_or_the_refusal(clone, capsys):
    from course.release import command

    assert command("hw0", clone) == 2
    assert capsys.readouterr().err.startswith("mbd: error: unknown homework 'hw0'")
    assert command("hw3", clone) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"released hw3 into {clone / 'build' / 'release' / 'hw3'}")
    assert "functions raise NotImplementedError for hw3" in out
    folder = clone / "build" / "release" / "hw3"
    size = sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())
    said = next(line for line in out.splitlines() if line.lstrip().startswith("size:"))
    assert f"{size / 1e6:.1f} MB to hand out" in said and "numpy" in said and "numba" not in said and "dask" not in said
