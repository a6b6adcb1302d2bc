"""Grading inside nbgrader: what a notebook's test cell runs while nbgrader autogrades.

A test cell is ``mbdkit.check("hw1", "revolute")``. While nbgrader autogrades (``NBGRADER_EXECUTION``
is ``autograde``) that call comes here: every check of the group runs -- public, hidden and the
student's own variants, the student's id being the name of the folder above the notebook's
(``autograded/{student}/{assignment}/``), as ``mbd grade`` names it -- each outcome is printed (hidden
ones without numbers) and the points earned are returned, which nbgrader takes as the cell's partial
credit. A notebook graded by nbgrader thus scores what ``mbd grade`` gives the same submission.
"""

from __future__ import annotations

from pathlib import Path

from mbdkit.api import folder_of
from mbdkit.homework import load_homework

from .grading import run_checks


def grade_group(homework: str, group: str, path: str | Path | None = None, student: str | None = None) -> float:
    """Run every check of one group (public, hidden, the student's variants); print them; return the points.

    ``student`` defaults to the name of the folder above ``path`` (nbgrader's ``autograded/{student}/{hw}``).
    """
    spec = load_homework(homework)
    checks = [c for c in spec.checks if c.group == group]
    if not checks:
        groups = sorted({c.group for c in spec.checks})
        raise ValueError(f"{homework} has no checks in group {group!r} (groups: {', '.join(groups)})")
    folder = folder_of(path)
    outcomes = run_checks(checks, folder, spec.name, student or folder.parent.name, budget=spec.budget)
    for o in outcomes:
        print(f"{'ok  ' if o.passed else 'FAIL'} {o.name} ({o.points:g}/{o.max_points:g})")
        if not o.passed:
            print(f"     {o.message}")
    return round(min(sum(o.points for o in outcomes), sum(c.points for c in checks)), 6)
