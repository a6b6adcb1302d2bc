"""What ``mbd grade`` and ``mbd selfcheck`` call (``solutions/cli.py`` wires them).

    mbd grade hwN SUBMISSIONS [--out DIR] [--jobs N]  ->  grade_command(homework, submissions, out, jobs)
    mbd selfcheck hwN [PATH]                            ->  selfcheck_command(homework, path)

Both return the exit code: 0 done (selfcheck: every public check passes), 1 selfcheck found failures,
2 a user error (unknown homework, no such folder, a missing reference), printed as one line to stderr.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from .api import selfcheck
from .grading import grade
from .homework import available_homeworks

USER_ERROR = 2


def grade_command(
    homework: str, submissions: str | Path, out: str | Path | None = None, jobs: int | None = None
) -> int:
    """Grade every submission; print where the gradebook is and the score distribution."""
    if homework not in available_homeworks():
        print(f"mbd grade: unknown homework {homework!r} (known: {', '.join(available_homeworks())})", file=sys.stderr)
        return USER_ERROR
    out = Path(out or f"grades-{homework}")
    jobs = jobs or min(os.cpu_count() or 1, 8)
    try:
        book = grade(homework, submissions, out, jobs=jobs)
    except FileNotFoundError as err:
        print(f"mbd grade: {err}", file=sys.stderr)
        return USER_ERROR
    scores = sorted(book.score(s) for s in book.rows)
    if scores:
        median = scores[len(scores) // 2]
        print(
            f"{homework}: graded {len(scores)} submissions, median {median:g} / {book.max_score:g}, "
            f"range {scores[0]:g} .. {scores[-1]:g}"
        )
    print(f"gradebook: {book.csv_path}\nresults:   {out / 'results'}\nfeedback:  {out / 'feedback'}")
    return 0


def selfcheck_command(homework: str, path: str | Path | None = None) -> int:
    """The public checks of a homework on the student's ``modules/`` (in PATH or the working directory)."""
    if homework not in available_homeworks():
        print(
            f"mbd selfcheck: unknown homework {homework!r} (known: {', '.join(available_homeworks())})", file=sys.stderr
        )
        return USER_ERROR
    try:
        return selfcheck(homework, path)
    except (FileNotFoundError, ValueError) as err:
        print(f"mbd selfcheck: {err}", file=sys.stderr)
        return USER_ERROR
