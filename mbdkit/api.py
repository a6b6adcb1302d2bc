"""The public checks for students: in a notebook test cell and from ``mbd selfcheck hwN``.

They are the grader's own checks on the public scenes, with the same messages, run the same way (the
student's ``modules/`` in a sandbox process). A notebook test cell is one line::

    from mbdkit import check
    check("hw1", "revolute")      # raises AssertionError with the grader's message when a check fails

``check`` prints one line to stdout when everything passes and nothing at all to stderr (nbgrader
zeroes a cell that writes to stderr), so no grading logic lives in a notebook a student can damage.
A process runs each check's requests once, in one sandbox child, while the package's files stay as they are
(``remembered``): the graded cells that share a run, and ``selfcheck`` after them, reuse it; an edited file
runs everything again in a new child.

While nbgrader autogrades (it sets ``NBGRADER_EXECUTION=autograde``), the notebook runs in the grader's
sandbox, where nothing of the course is visible: ``check`` and ``selfcheck`` then print one line and do
nothing else. The instructor's grader runs the submission's package in its own sandbox, outside the
notebook, and nbgrader's step ``autograder.api.SandboxPoints`` writes those points into the gradebook,
cell by cell: nothing the notebook does can change them.
"""

from __future__ import annotations

import atexit
import hashlib
import os
import sys
from pathlib import Path

from . import notes, staging
from .checks import Outcome
from .homework import load_homework
from .runner import PACKAGE, PublicData, run_checks
from .sandbox import Limits, Replies


def folder_of(path: str | Path | None) -> Path:
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
    folder = folder_of(path)
    if not folder.is_dir():
        raise FileNotFoundError(f"no folder {folder}")
    if not (folder / PACKAGE / "__init__.py").is_file():
        raise FileNotFoundError(f"no package {PACKAGE}/ (with __init__.py) in {folder}: run it where your notebook is")
    return run_checks(checks, folder, PublicData(), limits, replies=remembered(folder))


_REMEMBERED: dict[Path, tuple[str, Replies]] = {}


def remembered(folder: Path) -> Replies:
    """The replies of this process's earlier checks on ``folder``'s package and the child that gave them, while
    its files are unchanged (``package_digest``): a notebook's graded cells and its ``selfcheck`` run each
    scene once, in one child; an edited file starts afresh (a new child imports it)."""
    digest = package_digest(folder / PACKAGE)
    if folder not in _REMEMBERED or _REMEMBERED[folder][0] != digest:
        if folder in _REMEMBERED:
            _REMEMBERED[folder][1].close()  # its child imported the files as they were
        _REMEMBERED[folder] = digest, Replies()
    return _REMEMBERED[folder][1]


@atexit.register
def _forget() -> None:
    for _, replies in _REMEMBERED.values():
        replies.close()


def package_digest(package: Path) -> str:
    """A hash of the package's files as a check takes them (``staging.scan``: names and contents)."""
    digest = hashlib.sha256()
    for file in staging.scan(package.parent, package.name).files:
        digest.update(os.fsencode(file.path) + b"\0" + (package / file.path).read_bytes() + b"\0")
    return digest.hexdigest()


def grading() -> bool:
    """True while nbgrader autogrades a notebook (not while a student validates it)."""
    return os.environ.get("NBGRADER_EXECUTION") == "autograde"


GRADED_OUTSIDE = "{what}: graded outside the notebook, by the instructor's grader in its sandbox"
"""What ``check`` prints while nbgrader autogrades (the points come from the grader, not from this cell)."""


def check(homework: str, group: str, path: str | Path | None = None) -> None:
    """Run the public checks of one group; raise AssertionError with every failure's message.

    While nbgrader autogrades, print one line and return: the grader runs the checks outside the notebook.

    Parameters
    ----------
    homework : 'hw1', 'hw2' or 'hw3'
    group : a group of the homework's checks (e.g. 'revolute', 'newton', 'kinematic')
    path : the folder holding ``modules/`` (default: the working directory)
    """
    if grading():
        print(GRADED_OUTSIDE.format(what=f"{homework} {group}"))
        return None
    spec = load_homework(homework)
    if spec.graded_later(group):
        print(f"{homework} {group}: checked when the instructor grades (hidden scenes, your own variants)")
        return None
    outcomes = run_public(homework, path, group)
    failed = [o for o in outcomes if not o.passed]
    if failed:
        lines = [f"{len(failed)} of {len(outcomes)} checks of {homework} {group} failed:"]
        lines += [f"- {o.name}: {o.message}" for o in failed]
        show_equations("\n".join(lines), Path(path or "."))
        raise AssertionError("\n".join(lines))
    print(f"{homework} {group}: all {len(outcomes)} checks passed")
    return None


def show_equations(text: str, folder: Path) -> None:
    """In a notebook, display the equations ``text`` cites, rendered, each linked into the kit's notes
    (``notes.markdown``); elsewhere, or with nothing cited, nothing."""
    shown = notes.markdown(text, folder)
    if shown is None or "IPython" not in sys.modules:
        return
    from IPython import get_ipython
    from IPython.display import Markdown, display

    if get_ipython() is not None:
        display(Markdown(shown))


def selfcheck(homework: str, path: str | Path | None = None, stream=None) -> int:
    """Run every public check of a homework and print a report; 0 when all pass, 1 otherwise.

    While nbgrader autogrades, print one line and return 0: the grader runs every check outside the notebook.
    """
    stream = stream or sys.stdout
    if grading():
        stream.write(GRADED_OUTSIDE.format(what=homework) + "\n")
        return 0
    outcomes = run_public(homework, path)
    score = sum(o.points for o in outcomes)
    total = sum(o.max_points for o in outcomes)
    for o in outcomes:
        mark = "ok  " if o.passed else "FAIL"
        stream.write(f"{mark} {o.name} ({o.points:g}/{o.max_points:g})\n")
        if not o.passed:
            stream.write(f"     {o.message}\n")
    passed = sum(o.passed for o in outcomes)
    cited = notes.terminal_lines("\n".join(o.message for o in outcomes if not o.passed), Path(path or "."))
    if cited:
        stream.write("\nThe equations cited above, in the course notes (open in a browser):\n")
        stream.write("\n".join(cited) + "\n")
    scale = load_homework(homework).out_of  # the homework's total as it is graded (a kit holds the public checks)
    stream.write(
        f"\n{homework}: {passed} of {len(outcomes)} public checks pass, {score:g} of the {total:g} points they carry. "
        f"The homework is out of {scale:g}: the other {scale - total:g} points are the hidden variants of these "
        "scenes and your own variant of each, which the grader runs when the instructor grades.\n"
    )
    return 0 if passed == len(outcomes) else 1
