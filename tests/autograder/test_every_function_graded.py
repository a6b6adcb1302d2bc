"""Every function a homework asks students to write is graded: with only that function's solution region
put back to ``raise NotImplementedError``, a submission scores less than the reference.

For each homework, one mutant per solution region of that homework (``### BEGIN SOLUTION hwN``): the
reference package with that region's body, and nothing else, replaced by a raise. (The per-type array
versions, ``planar/batched.py`` and ``spatial/batched.py``, have no regions: they stay with the instructor,
and a student's System evaluates the element methods.)

The reference is graded with every check of the homework and scores full marks on each. A mutant is graded,
in the grader's sandbox as a submission is, on the checks that run its region: the functions each check calls
are recorded once per homework by running the reference's probes in this process in the grader's order (a
profile hook), and a mutant's checks are those whose calls entered the function that holds the region: first
the grader's first such probe call alone, then, if the mutant passed it, all of them. Since the reference
passes every check, a mutant that fails one of them scores less than the reference with every check; a check
that never enters the function runs the same code as the reference and passes. A mutant that loses nothing on
its checks (or has none) is reported.

The mutants run on the grader's ``local`` backend (a forked child per set of checks, the grader's own scenes,
references and checks): which check a raising function fails does not depend on the wall around the child,
and the wall's own tests (test_isolation, test_wall, test_hostile_grader, the nbgrader cycle) grade in it. Here
it would cost a bubblewrap sandbox per mutant (about a second each, 90 mutants) for nothing this test asks.
"""

from __future__ import annotations

import ast
import dataclasses
import sys
import types
from pathlib import Path

import pytest

from autograder.grading import GraderData, Submission, grade, grade_submission
from course.release.generator import HOMEWORKS, REPO, Region, all_regions
from mbdkit import probes
from mbdkit.homework import CheckSpec, load_homework
from mbdkit.runner import KINDS, _order
from mbdkit.sandbox import Limits
from mbdkit.scenes import job_key, scene_kind

SOLUTIONS = REPO / "solutions"
TRACED = "mbd-trace"
"""The student name of the traced run and of every mutant: one set of per-student variants (the scenes the trace
ran), whose references are computed once."""


def asked_regions(homework: str) -> list[Region]:
    """The solution regions students write in ``homework``."""
    return [r for r in all_regions() if r.tag == homework]


def stub_region(package: Path, region: Region) -> None:
    """Replace the region (its markers and body) by ``raise NotImplementedError`` at the marker's indent."""
    path = package / region.path
    lines = path.read_text().split("\n")
    begin, end = lines[region.begin - 1], lines[region.end - 1]
    assert "### BEGIN SOLUTION" in begin and "### END SOLUTION" in end, f"{region.path}:{region.begin}: not a region"
    indent = begin[: len(begin) - len(begin.lstrip())]
    lines[region.begin - 1 : region.end] = [f"{indent}raise NotImplementedError('mutant: {region.function}')"]
    text = "\n".join(lines)
    ast.parse(text, filename=str(path))
    path.write_text(text)


def test_every_homework_asks_for_functions():
    for homework in HOMEWORKS:
        assert asked_regions(homework), homework


def innermost_function(region: Region) -> tuple[str, int, str]:
    """(file, first line, name) of the innermost function of the reference that holds the region."""
    path = SOLUTIONS / region.path
    best = None

    def visit(code: types.CodeType) -> None:
        nonlocal best
        lines = [line for _, _, line in code.co_lines() if line is not None]
        if code.co_name != "<module>" and lines and code.co_firstlineno <= region.begin < max(lines):
            if best is None or code.co_firstlineno > best[1]:
                best = (str(path), code.co_firstlineno, code.co_name)
        for const in code.co_consts:
            if isinstance(const, types.CodeType):
                visit(const)

    visit(compile(path.read_text(), str(path), "exec"))
    assert best is not None, f"solutions/{region.path}:{region.begin}: in no function"
    return best


def functions_entered(probe, package: probes.Package, job: probes.Job, root: str) -> set[tuple[str, int, str]]:
    """The functions (file, first line, name) under ``root`` that one probe call enters."""
    entered: set[tuple[str, int, str]] = set()

    def record(frame, event, arg):
        code = frame.f_code
        if event == "call" and code.co_filename.startswith(root):
            entered.add((code.co_filename, code.co_firstlineno, code.co_name))

    sys.setprofile(record)
    try:
        probe(package, job)
    finally:
        sys.setprofile(None)
    return entered


def functions_each_check_calls(homework: str) -> dict[str, set[tuple[str, int, str]]]:
    """{check name: the reference's functions (file, first line, name) its probe call entered}: every probe
    call of the homework run in this process on the reference package (``solutions``), kind by kind and in
    the grader's order (``mbdkit.runner``), the probes' per-scene cache emptied between kinds as the grader's
    children start empty."""
    spec = load_homework(homework)
    data = GraderData(TRACED, homework)
    reference = probes.Package("solutions")
    root = str(SOLUTIONS)
    calls: dict[str, set[tuple[str, int, str]]] = {}
    for kind in KINDS:
        probes._MODELS.clear()
        for scene_name, key in [call for call in _order(spec.checks) if scene_kind(call[0]) == kind]:
            group = [c for c in spec.checks if c.scene == scene_name and c.probe_key == key]
            scene = data.scene(scene_name)
            stored = data.reference(scene, [c for c in spec.checks if c.scene == scene_name])
            inputs = probes.sent_inputs(
                group[0].probe, stored.inputs, kind == "public", stored.meta.get("dimension", 2)
            )
            job = probes.Job(job_key(scene), scene.data, inputs, dict(group[0].options))
            entered = functions_entered(probes.PROBES[group[0].probe], reference, job, root)
            for check in group:
                calls[check.name] = entered
    probes._MODELS.clear()
    return calls


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_each_function_raising_costs_points(homework, make_submissions, reference_copy, tmp_path):
    spec = load_homework(homework)
    folder = make_submissions(f"{homework}-every-function", {"reference": "reference"}, homework)
    book = grade(homework, folder, tmp_path / "out", jobs=1, progress=False)
    reference = book.score("reference")
    assert reference == book.max_score, f"{homework}: the reference scores {reference} of {book.max_score}"
    full = book.points("reference")
    assert all(full[c.name] == c.points for c in spec.checks), full  # each check passed: losing one loses points

    calls = functions_each_check_calls(homework)
    order = {call: k for k, call in enumerate(_order(spec.checks))}  # the grader's order of probe calls
    unreached = []
    for number, region in enumerate(asked_regions(homework)):
        student, where = f"mutant{number:03d}", innermost_function(region)
        checks: list[CheckSpec] = sorted(
            (c for c in spec.checks if where in calls[c.name]), key=lambda c: order[c.scene, c.probe_key]
        )
        function = f"solutions/{region.path}: {region.function}"
        if not checks:
            unreached.append(f"{function} (no check calls it)")
            continue
        stub_region(reference_copy(tmp_path / "mutants" / student), region)
        first = checks[0]  # the grader's first probe call into the function, alone: enough when it loses points
        for tried in ([c for c in checks if (c.scene, c.probe_key) == (first.scene, first.probe_key)], checks):
            subset = dataclasses.replace(spec, checks=tried)
            submission = Submission(TRACED, tmp_path / "mutants" / student)
            row = grade_submission(subset, submission, tmp_path / "out", Limits(), isolation="local")
            if [c.name for c in tried if row["checks"][c.name] < c.points]:
                break
        else:
            unreached.append(f"{function} (passes the {len(checks)} checks that call it)")
    assert unreached == [], (
        f"{homework}: no check loses points when one of these functions raises NotImplementedError; "
        f"add a scene or check that calls it: {unreached}"
    )
