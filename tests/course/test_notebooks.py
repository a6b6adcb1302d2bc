"""The course's notebooks: the three released homework and the lectures, executed headless.

- every source notebook (``assignments/hwN``) runs with the reference as the student's package and passes
  every graded cell: test_kit.py runs it so, as the released notebook in a student's fresh venv (the release
  keeps every code cell as it is; test_kit checks that too, and this file the source's cells and points);
- every released notebook with its untouched skeleton package runs to the end, and every graded cell
  fails cleanly (an AssertionError with the grader's message, never a crash or a hang);
- every lecture notebook (``course/lectures``) and every chapter of the course notes (``course/notes``) runs
  without an error.

Each notebook is executed once (module-scoped fixtures), two at a time, in a kernel of this venv.
"""

from __future__ import annotations

import asyncio
import json
import os
import re
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from course.notes import chapters
from course.release import HOMEWORKS, build_package, release
from course.release.generator import INSTRUCTOR_ONLY, REPO
from mbdkit.homework import load_homework
from solutions.viewer import MIME as VIEW

LECTURES = sorted((REPO / "course" / "lectures").glob("*.ipynb"))
NOTES = chapters()
SKELETON_ERRORS = {"NotImplementedError", "NameError", "AssertionError"}
"""What a released notebook may raise on the skeleton: a stub, a result never computed, a failed check."""


def execute(notebook: Path, folder: Path, **env: str) -> nbformat.NotebookNode:
    """Run every cell (on to the end after an error) with ``folder`` as the working directory, on an event loop
    that ``asyncio.run`` closes afterwards (nbclient's ``execute`` would leave one open per thread, and its sockets)."""
    nb = nbformat.read(notebook, as_version=4)
    environment = {k: v for k, v in os.environ.items() if not k.startswith("NBGRADER")}
    environment.update(env)
    client = NotebookClient(
        nb, timeout=300, kernel_name="python3", allow_errors=True, resources={"metadata": {"path": str(folder)}}
    )
    asyncio.run(client.async_execute(env=environment))
    return nb


def execute_all(jobs: dict) -> dict:
    """Execute several notebooks, two kernels at a time."""
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = {
            key: pool.submit(execute, *args[:2], **(args[2] if len(args) > 2 else {})) for key, args in jobs.items()
        }
        return {key: future.result() for key, future in futures.items()}


def graded_cells(nb) -> list:
    return [c for c in nb.cells if c.cell_type == "code" and c.metadata.get("nbgrader", {}).get("grade")]


def errors(cell) -> list:
    return [o for o in cell.get("outputs", []) if o.output_type == "error"]


def stderr(cell) -> str:
    return "".join(o.text for o in cell.get("outputs", []) if o.output_type == "stream" and o.name == "stderr")


def group_of(cell) -> str:
    """The group a graded cell checks: the second argument of its check("hwN", "group") call."""
    call = cell.source.strip().splitlines()[-1]
    assert call.startswith("check(") and call.count('"') == 4, call
    return call.split('"')[3]


# -- fixtures ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Every notebook executed once, two kernels at a time: {("skeleton" | "lecture" | "notes", name): notebook}.

    skeleton: each homework released (`mbd release hwN` on a scratch copy of the course), with its skeleton;
    lecture: each lecture notebook, in course/lectures; notes: each chapter of the course notes.
    """
    from course.demo import scratch_course

    course = scratch_course(tmp_path_factory.mktemp("course") / "course")
    jobs = {}
    for homework in HOMEWORKS:
        released = release(homework, course).folder
        jobs["skeleton", homework] = (released / f"{homework}.ipynb", released)
    for path in LECTURES:
        jobs["lecture", path.stem] = (path, path.parent)
    for path in NOTES:
        jobs["notes", path.stem] = (path, path.parent)
    return execute_all(jobs)


@pytest.fixture(scope="module")
def skeleton_runs(runs):
    return {name: nb for (kind, name), nb in runs.items() if kind == "skeleton"}


@pytest.fixture(scope="module")
def lecture_runs(runs):
    return {name: nb for (kind, name), nb in runs.items() if kind == "lecture"}


@pytest.fixture(scope="module")
def notes_runs(runs):
    return {name: nb for (kind, name), nb in runs.items() if kind == "notes"}


# -- the source notebooks (executed by test_kit.py, released, in a fresh venv) --------------------------------------
@pytest.mark.parametrize("homework", HOMEWORKS)
def test_graded_cells_are_the_homeworks_check_groups_with_their_points(homework):
    nb = nbformat.read(REPO / "assignments" / homework / f"{homework}.ipynb", as_version=4)
    spec = load_homework(homework)
    groups: dict[str, float] = {}
    for check in spec.checks:
        groups[check.group] = groups.get(check.group, 0.0) + check.points
    ids = [c.metadata["nbgrader"]["grade_id"] for c in nb.cells if "nbgrader" in c.metadata]
    assert len(ids) == len(set(ids)) and all(
        c.metadata["nbgrader"]["schema_version"] == 3 for c in nb.cells if "nbgrader" in c.metadata
    )
    cells = {group_of(c): c for c in graded_cells(nb)}
    assert sorted(cells) == sorted(groups), "one graded cell per group of autograder/" + homework + ".toml"
    for group, cell in cells.items():
        meta = cell.metadata["nbgrader"]
        assert meta["points"] == pytest.approx(groups[group]), group
        assert (
            meta["locked"] and not meta["solution"] and cell.source.strip().endswith(f'check("{homework}", "{group}")')
        )
    answers = [c for c in nb.cells if c.metadata.get("nbgrader", {}).get("solution")]
    assert answers and all(c.cell_type == "markdown" and c.metadata["nbgrader"]["grade"] for c in answers)
    assert all(c.metadata["nbgrader"]["points"] > 0 for c in answers)


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_the_statement_lists_every_function_to_write(homework, tmp_path):
    report = build_package(tmp_path / "modules", homework)
    index = HOMEWORKS.index(homework) + 1
    nb = nbformat.read(REPO / "assignments" / homework / f"{homework}.ipynb", as_version=4)
    text = "\n".join(c.source for c in nb.cells if c.cell_type == "markdown")
    asked = [r for r in report.stubbed if r.homework == index]
    assert asked
    assert sorted({f"{r.path}: {r.function}" for r in asked if f"`{r.function}`" not in text}) == []
    assert all(f"`modules/{path}`" in text for path in {r.path for r in report.stubbed if r.homework == index})
    assert not [path for path in INSTRUCTOR_ONLY if f"modules/{path}" in text]  # not in the student's package


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_the_public_scenes_ship_with_the_assignment_as_the_grader_has_them(homework):
    shipped = {p.name: p.read_bytes() for p in (REPO / "assignments" / homework / "scenes").glob("*.yaml")}
    public = {c.scene for c in load_homework(homework).checks if c.kind == "public"}
    assert sorted(shipped) == sorted(f"{scene}.yaml" for scene in public)
    for name, data in shipped.items():
        assert data == (REPO / "autograder" / "scenes" / name).read_bytes(), (
            f"assignments/{homework}/scenes/{name} is stale"
        )


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_source_notebook_has_no_outputs_and_runs_the_python3_kernel(homework):
    data = json.loads((REPO / "assignments" / homework / f"{homework}.ipynb").read_text())
    assert data["metadata"]["kernelspec"]["name"] == "python3"
    assert all(
        not c.get("outputs") and c.get("execution_count") is None for c in data["cells"] if c["cell_type"] == "code"
    )


# -- the released notebooks on the skeleton --------------------------------------------------------------------
@pytest.mark.parametrize("homework", HOMEWORKS)
def test_released_notebook_with_the_skeleton_runs_to_the_end_and_fails_cleanly(skeleton_runs, homework):
    nb = skeleton_runs[homework]
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert all(c.execution_count is not None for c in code)  # to the end: nothing hung or killed the kernel
    raised = {e.ename for c in code for e in errors(c)}
    assert raised <= SKELETON_ERRORS, raised
    assert all(stderr(c) == "" for c in code)
    public = {c.group for c in load_homework(homework).public()}
    for cell in graded_cells(nb):
        group = group_of(cell)
        if group in public:
            assert [e.ename for e in errors(cell)] == ["AssertionError"], cell.source
            assert "not implemented yet" in errors(cell)[0].evalue  # the grader's message names the stub
        else:
            assert not errors(cell) and "checked when the instructor grades" in cell.outputs[0].text
    answers = [c for c in nb.cells if c.metadata.get("nbgrader", {}).get("solution")]
    assert answers and all("Model answer" not in c.source for c in answers)


# -- the lectures ---------------------------------------------------------------------------------------------------
STILL = {"L08", "L12", "L15"}
"""Lectures whose point is not a motion (forces at a state, rotations, the program's map): no animation."""


@pytest.mark.parametrize("lecture", [p.stem for p in LECTURES])
def test_lecture_notebook_executes(lecture_runs, lecture):
    nb = lecture_runs[lecture]
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code and all(c.execution_count is not None for c in code)
    failures = [(c.source.splitlines()[0], errors(c)[0].evalue[:300]) for c in code if errors(c)]
    assert failures == []
    data = [o.get("data", {}) for c in code for o in c.outputs]
    if lecture[:3] not in STILL:
        views = [d[VIEW] for d in data if VIEW in d]
        assert views and all(v["frames"] for v in views), "the viewer where motion is the point"
    assert nb.cells[-1].cell_type == "markdown" and nb.cells[-1].source.startswith("## Exercises")


@pytest.mark.parametrize("chapter", [p.stem for p in NOTES])
def test_notes_chapter_executes_with_numbers_from_the_solver(notes_runs, chapter):
    nb = notes_runs[chapter]
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code and all(c.execution_count is not None for c in code)
    failures = [(c.source.splitlines()[0], errors(c)[0].evalue[:300]) for c in code if errors(c)]
    assert failures == []
    assert all(stderr(c) == "" for c in code), [stderr(c) for c in code if stderr(c)]
    assert any("from solutions" in c.source for c in code)  # the worked example runs the solver
    printed = [o for c in code for o in c.outputs if o.output_type == "stream" and o.name == "stdout"]
    assert printed, "a worked example prints its numbers"


def test_there_are_sixteen_lectures_listed_in_the_schedule_and_the_syllabus_with_their_notes():
    """Fifteen weeks of one lecture and L16 (Denavit-Hartenberg and dual numbers), beside L13 or as reading."""
    assert [path.name[:3] for path in LECTURES] == [f"L{k:02d}" for k in range(1, 17)]
    schedule = (REPO / "course" / "schedule.md").read_text()
    syllabus = (REPO / "course" / "syllabus.md").read_text()
    chapters_there = {int(path.name[2:4]) for path in NOTES}
    for path in LECTURES:
        lecture = path.name[:3]
        rows = [line for line in schedule.splitlines() if line.startswith("|") and f"| {lecture} |" in line]
        assert len(rows) == 1 and f"`{path.name}`" in rows[0], lecture
        listed = [line for line in syllabus.splitlines() if line.startswith(f"| {lecture} |")]
        assert len(listed) == 1, lecture
        for row in (rows[0], listed[0]):
            notes = re.search(r"\| ch\. ([0-9, -]+) \|", row)
            assert notes, f"{lecture}: no notes chapters in {row}"
            numbers = set()
            for part in notes.group(1).split(","):
                low, _, high = part.strip().partition("-")
                numbers.update(range(int(low), int(high or low) + 1))
            assert numbers and numbers <= chapters_there, (lecture, numbers)


def test_nothing_in_the_course_names_a_lecture_that_does_not_exist():
    lectures = {path.name[:3] for path in LECTURES}
    texts = [p for p in (REPO / "course").rglob("*") if p.suffix in (".md", ".ipynb", ".py") and p.is_file()]
    named = {(m, str(p.relative_to(REPO))) for p in texts for m in re.findall(r"\bL\d\d\b", p.read_text())}
    assert sorted((m, f) for m, f in named if m not in lectures) == []


def test_every_exercise_of_the_lectures_and_notes_has_an_instructor_solution():
    """course/lectures/solutions/LNN.md (chNN.md) answers each numbered exercise of lecture LNN (notes chapter
    NN), in order, and nothing else (the folder is the instructor's: a release refuses it, test_leakcheck.py)."""
    folder = REPO / "course" / "lectures" / "solutions"
    for path in [*LECTURES, *NOTES]:
        cells = nbformat.read(path, as_version=4).cells
        text = "\n".join(cell.source for cell in cells if cell.cell_type == "markdown")
        exercises = text.partition("## Exercises")[2]
        asked = [int(n) for n in re.findall(r"^(\d+)\. ", exercises, re.MULTILINE)]
        if not asked and path in NOTES:
            continue  # a chapter without exercises (chapter 1)
        answers = folder / f"{path.name[:4] if path in NOTES else path.name[:3]}.md"
        assert answers.is_file(), f"no solutions for {path.name}: write {answers.relative_to(REPO)}"
        answered = [int(n) for n in re.findall(r"^\*\*Exercise (\d+)\.\*\*", answers.read_text(), re.MULTILINE)]
        assert asked == list(range(1, len(asked) + 1)) and answered == asked, (path.name, asked, answered)
