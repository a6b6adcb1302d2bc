"""Grading inside nbgrader: the notebook runs in the grader's sandbox, the points come from the grader.

A graded test cell is one call, ``check("hw1", "revolute")`` (``mbdkit.check``). Under ``nbgrader
autograde``, ``course/nbgrader_config.py`` puts three steps of this module into nbgrader's autograde
preprocessors (``autograde_steps``):

- ``SandboxedExecute`` (in place of nbgrader's ``Execute``) runs the notebook in ipykernel inside the grader's
  bubblewrap sandbox (``autograder.kernel``): its cells see none of the course, the gradebook or the secret,
  and whatever they do there stays there. In it, ``check`` prints one line and returns: it grades nothing.
- ``GraderPoints`` (before nbgrader's ``SaveAutoGrades``) grades the submission's ``modules/`` with the
  grader itself, outside the notebook: every check of the homework in the grader's sandbox, as ``mbd grade``
  does (``autograder.grading.run_checks``, the student's id being nbgrader's), and puts in place of each test
  cell's output the grader's report of that cell's group, with its points as the cell's result, which is
  what nbgrader's ``SaveAutoGrades`` then records; the outcomes of the graded cells' checks are kept in the
  notebook's metadata (``autograder.nbpages.OUTCOMES``: the feedback page's summary).
- ``SaveGraderPoints`` (after ``SaveAutoGrades``) writes the same points through nbgrader's gradebook API
  (``Gradebook.find_grade``, ``auto_score``) for every test cell of the notebook as the instructor released
  it, also a cell the student deleted: nothing the notebook does changes them.

Which group a test cell grades is read from the cell's source in the gradebook (the instructor's), never from
the submitted notebook. A submission thus scores in nbgrader what ``mbd grade`` gives it, check for check.
"""

from __future__ import annotations

import ast
from pathlib import Path

from nbclient.exceptions import CellTimeoutError, DeadKernelError
from nbformat.v4 import new_output
from nbgrader.api import Gradebook
from nbgrader.preprocessors import Execute, NbGraderPreprocessor
from nbgrader.utils import is_grade, is_solution

from .kernel import SandboxedKernelManager
from .nbpages import OUTCOMES, written_outcomes

POINTS = "grader_points"
"""Where ``GraderPoints`` leaves the points, per test cell, in nbgrader's resources for ``SaveGraderPoints``."""


def check_call(source: str) -> tuple[str, str] | None:
    """(homework, group) of a test cell's source that is one call ``check("hwN", "group")``; else None."""
    try:
        body = ast.parse(source).body
    except SyntaxError:
        return None
    if len(body) != 1 or not isinstance(body[0], ast.Expr) or not isinstance(body[0].value, ast.Call):
        return None
    call = body[0].value
    name = call.func.id if isinstance(call.func, ast.Name) else getattr(call.func, "attr", None)
    arguments = [a.value for a in call.args if isinstance(a, ast.Constant) and isinstance(a.value, str)]
    if name != "check" or len(arguments) != 2 or len(call.args) != 2 or call.keywords:
        return None
    return arguments[0], arguments[1]


def graded_cells(gradebook: Gradebook, notebook: str, assignment: str) -> dict[str, tuple[tuple[str, str], float]]:
    """{grade id: ((homework, group), max points)} of the notebook's test cells as the instructor released it."""
    cells = {}
    for cell in gradebook.find_notebook(notebook, assignment).grade_cells:
        if cell.cell_type != "code":
            continue
        group = check_call(gradebook.find_source_cell(cell.name, notebook, assignment).source)
        if group is not None:
            cells[cell.name] = (group, float(cell.max_score))
    return cells


def group_report(outcomes: list, earned: float, max_points: float) -> str:
    """The grader's lines for one test cell: every check of its group (hidden ones without numbers)."""
    lines = [f"graded by the instructor's grader, outside the notebook: {earned:g} of {max_points:g} points"]
    for o in outcomes:
        lines.append(f"{'ok  ' if o.passed else 'FAIL'} {o.name} ({o.points:g}/{o.max_points:g})")
        if not o.passed:
            lines.append(f"     {o.message}")
    return "\n".join(lines) + "\n"


def grade_folder(folder: Path, student: str, groups: set[tuple[str, str]]) -> dict[tuple[str, str], list]:
    """The outcomes of every check of each homework named in ``groups``, by group, for one submission: one run
    of the grader (``autograder.grading.run_checks``, in its sandbox) per homework, as ``mbd grade`` runs it."""
    from mbdkit.homework import load_homework

    from .grading import run_checks

    outcomes: dict[tuple[str, str], list] = {group: [] for group in groups}
    for homework in sorted({hw for hw, _ in groups}):
        spec = load_homework(homework)
        known = {c.group for c in spec.checks}
        unknown = sorted(group for hw, group in groups if hw == homework and group not in known)
        if unknown:
            raise ValueError(f"{homework} has no checks in group {unknown[0]!r} (groups: {', '.join(sorted(known))})")
        others = (folder.parent.parent,)  # every student's folder (nbgrader's autograded/), as mbd grade forbids
        for outcome in run_checks(spec.checks, folder, spec.name, student, forbidden=others, budget=spec.budget):
            outcomes.setdefault((homework, outcome.group), []).append(outcome)
    return outcomes


class SandboxedExecute(Execute):
    """nbgrader's ``Execute`` with its kernel in the grader's sandbox (``autograder.kernel``). A kernel that dies
    (killed by a cell, or by its limits) or stops answering ends the execution there: the cells after it keep no
    output, and the notebook goes on to be graded (its points never came from the kernel)."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("kernel_manager_class", SandboxedKernelManager)
        super().__init__(*args, **kwargs)

    def preprocess(self, nb, resources=None, km=None):
        try:
            return super().preprocess(nb, resources, km)
        except (DeadKernelError, CellTimeoutError) as err:
            reason = "died" if isinstance(err, DeadKernelError) else "stopped answering"
            self.log.warning("the notebook's kernel %s: its later cells did not run", reason)
            return nb, resources


class GraderPoints(NbGraderPreprocessor):
    """Grade the submission with the grader, outside the notebook; each test cell's output becomes the grader's
    report of its group and its points (nbgrader's partial credit). Before ``SaveAutoGrades``."""

    def preprocess(self, nb, resources):
        ids = resources["nbgrader"]
        folder = Path(resources["metadata"]["path"])
        with Gradebook(ids["db_url"]) as gradebook:
            cells = graded_cells(gradebook, ids["notebook"], ids["assignment"])
        outcomes = grade_folder(folder, ids["student"], {group for group, _ in cells.values()})
        points, reports = {}, {}
        for name, (group, max_points) in cells.items():
            earned = round(min(sum(o.points for o in outcomes[group]), max_points), 6)
            points[name], reports[name] = earned, group_report(outcomes[group], earned, max_points)
        for cell in nb.cells:
            name = cell.metadata.get("nbgrader", {}).get("grade_id")
            if not is_grade(cell) or is_solution(cell) or cell.cell_type != "code":
                continue
            if name not in points:
                self.log.warning("graded cell %s is not one check(homework, group) call: nbgrader grades it", name)
            else:
                cell.outputs = [
                    new_output("stream", name="stdout", text=reports[name]),
                    new_output("execute_result", data={"text/plain": repr(points[name])}, execution_count=None),
                ]
        resources[POINTS] = points
        graded = [o for group in dict.fromkeys(group for group, _ in cells.values()) for o in outcomes[group]]
        nb.metadata[OUTCOMES] = {"outcomes": written_outcomes(graded)}  # the feedback page's summary (nbpages.py)
        return nb, resources


class SaveGraderPoints(NbGraderPreprocessor):
    """Write the grader's points of every test cell into nbgrader's gradebook (``auto_score``), over what
    ``SaveAutoGrades`` recorded from the notebook. After ``SaveAutoGrades``."""

    def preprocess(self, nb, resources):
        ids = resources["nbgrader"]
        points = resources.get(POINTS)
        if points is None:
            raise RuntimeError("SaveGraderPoints needs GraderPoints before it (autograder.api.autograde_steps)")
        with Gradebook(ids["db_url"]) as gradebook:
            for name, earned in points.items():
                grade = gradebook.find_grade(name, ids["notebook"], ids["assignment"], ids["student"])
                grade.auto_score = earned
                grade.needs_manual_grade = grade.manual_score is not None
            gradebook.db.commit()
        return nb, resources


def autograde_steps(default: list) -> list:
    """nbgrader's autograde preprocessors ``default`` with the notebook in the sandbox and the points from the
    grader: ``Execute`` replaced by ``SandboxedExecute``, ``GraderPoints`` before ``SaveAutoGrades`` and
    ``SaveGraderPoints`` after it. With ``MBD_UNSAFE_NO_ISOLATION=1`` the notebook runs in nbgrader's own
    kernel (the grader then grades without bubblewrap too, and says so); its points still come from the grader."""
    from nbgrader.preprocessors import SaveAutoGrades

    from mbdkit.isolation import unsafe_requested

    steps = []
    for step in default:
        if step is Execute:
            steps.append(Execute if unsafe_requested() else SandboxedExecute)
        elif step is SaveAutoGrades:
            steps += [GraderPoints, SaveAutoGrades, SaveGraderPoints]
        else:
            steps.append(step)
    if GraderPoints not in steps or not {Execute, SandboxedExecute} & set(steps):
        raise RuntimeError("nbgrader's autograde steps have no Execute or SaveAutoGrades: see autograder/api.py")
    return steps
