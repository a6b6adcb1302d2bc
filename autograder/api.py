"""The public checks for students: in a notebook test cell and from ``mbd selfcheck hwN``.

They are the grader's own checks on the public scenes, with the same messages, run the same way (the
student's ``modules/`` in a sandbox process). A notebook test cell is one line::

    from autograder.api import check
    check("hw1", "revolute")      # raises AssertionError with the grader's message when a check fails

``check`` prints one line to stdout when everything passes and nothing at all to stderr (nbgrader
zeroes a cell that writes to stderr), so no grading logic lives in a notebook a student can damage.

While nbgrader autogrades (it sets ``NBGRADER_EXECUTION=autograde``), the same cell grades: ``check``
runs *every* check of its group -- public, hidden and the student's own variants, the student's id being
the name of the folder above the notebook's (``autograded/{student}/{assignment}/``), as ``mbd grade``
names it -- prints each outcome (hidden ones without numbers) and returns the points earned, which
nbgrader takes as the cell's partial credit. A notebook graded by nbgrader thus scores what ``mbd grade``
gives the same submission. A group with no public checks (``hidden``) runs only then.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from .checks import Outcome
from .grading import PACKAGE, run_checks
from .homework import load_homework
from .sandbox import Limits


def _folder(path: str | Path | None) -> Path:
    """The folder holding ``modules/``: the given one, or the working directory (the notebook's)."""
    folder = Path(path or ".").resolve()
    if folder.name == PACKAGE and (folder / "__init__.py").is_file():
        folder = folder.parent
    return folder


def run_public(
    homework: str, path: str | Path | None = None, group: str | None = None, limits: Limits | None = None
) -> list[Outcome]:
    """The outcomes of the public checks of ``homework`` (of one group, or all) on the package at ``path``."""
    spec = load_homework(homework)
    checks = [c for c in spec.public() if group is None or c.group == group]
    if not checks:
        groups = sorted({c.group for c in spec.public()})
        raise ValueError(f"{homework} has no public checks in group {group!r} (groups: {', '.join(groups)})")
    return run_checks(checks, _folder(path), spec.name, None, limits)


def grading() -> bool:
    """True while nbgrader autogrades a notebook (not while a student validates it)."""
    return os.environ.get("NBGRADER_EXECUTION") == "autograde"


def grade_group(homework: str, group: str, path: str | Path | None = None, student: str | None = None) -> float:
    """Run every check of one group (public, hidden, the student's variants); print them; return the points.

    ``student`` defaults to the name of the folder above ``path`` (nbgrader's ``autograded/{student}/{hw}``).
    """
    spec = load_homework(homework)
    checks = [c for c in spec.checks if c.group == group]
    if not checks:
        groups = sorted({c.group for c in spec.checks})
        raise ValueError(f"{homework} has no checks in group {group!r} (groups: {', '.join(groups)})")
    folder = _folder(path)
    outcomes = run_checks(checks, folder, spec.name, student or folder.parent.name)
    for o in outcomes:
        print(f"{'ok  ' if o.passed else 'FAIL'} {o.name} ({o.points:g}/{o.max_points:g})")
        if not o.passed:
            print(f"     {o.message}")
    return round(min(sum(o.points for o in outcomes), sum(c.points for c in checks)), 6)


def check(homework: str, group: str, path: str | Path | None = None) -> float | None:
    """Run the public checks of one group; raise AssertionError with every failure's message.

    While nbgrader autogrades, grade the whole group instead and return its points (``grade_group``).

    Parameters
    ----------
    homework : 'hw1', 'hw2' or 'hw3'
    group : a group of the homework's checks (e.g. 'revolute', 'newton', 'kinematic')
    path : the folder holding ``modules/`` (default: the working directory)
    """
    if grading():
        return grade_group(homework, group, path)
    spec = load_homework(homework)
    if not any(c.group == group for c in spec.public()) and any(c.group == group for c in spec.checks):
        print(f"{homework} {group}: checked when the instructor grades (hidden scenes, your own variants)")
        return None
    outcomes = run_public(homework, path, group)
    failed = [o for o in outcomes if not o.passed]
    if failed:
        lines = [f"{len(failed)} of {len(outcomes)} checks of {homework} {group} failed:"]
        lines += [f"- {o.name}: {o.message}" for o in failed]
        raise AssertionError("\n".join(lines))
    print(f"{homework} {group}: all {len(outcomes)} checks passed")
    return None


def selfcheck(homework: str, path: str | Path | None = None, stream=None) -> int:
    """Run every public check of a homework and print a report; 0 when all pass, 1 otherwise."""
    stream = stream or sys.stdout
    outcomes = run_public(homework, path)
    score = sum(o.points for o in outcomes)
    total = sum(o.max_points for o in outcomes)
    for o in outcomes:
        mark = "ok  " if o.passed else "FAIL"
        stream.write(f"{mark} {o.name} ({o.points:g}/{o.max_points:g})\n")
        if not o.passed:
            stream.write(f"     {o.message}\n")
    passed = sum(o.passed for o in outcomes)
    stream.write(
        f"\n{homework}: {passed} of {len(outcomes)} public checks pass, {score:g} of {total:g} points. "
        "The grader also runs hidden variants of these scenes and your own variant of each.\n"
    )
    return 0 if passed == len(outcomes) else 1
