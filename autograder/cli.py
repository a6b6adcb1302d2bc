"""What ``mbd grade`` calls (``autograder/commands.py`` registers it; ``mbd selfcheck`` is ``mbdkit.cli``).

    mbd grade hwN SUBMISSIONS [--out DIR] [--jobs N] [--cluster local|tcp://HOST:PORT] [--unsafe-no-isolation]
              [--publish-hidden] [--roster CSV] [--lms moodle|canvas|REGEXP]
        ->  grade_command(homework, submissions, out, jobs, unsafe_no_isolation, cluster, publish_hidden, roster, lms)

With ``--lms`` (or given a zip), SUBMISSIONS is a learning platform's "download all submissions", its zip or the
folder it was unpacked into: each student's notebook and ``modules/`` are collected into one folder per student
id (``autograder.lms``: Moodle's participant number, Canvas's user id), counted in a few lines, then graded; the
folders stay in ``OUT/submissions/`` with ``collected.csv`` (ids, names, late, notes). Nothing collected: one
line saying what the preset expected (and the preset the names fit), exit code 2, no output folder.

``--jobs`` N > 1 (the default: the number of cores, at most 8) grades on a Dask LocalCluster of N worker
processes (``--cluster local`` implied); ``--jobs 1`` grades one by one in this process: the rule of
``solutions.batch.cluster_for``, the same as ``grade(jobs=N)`` from Python.

Returns the exit code: 0 done (a submission whose grading failed in the grader itself is named on one line
and graded again on the next run), 2 a user error (unknown homework, no such folder, a missing reference, no
course secret (``mbd secret --init`` makes one), no sandbox: bubblewrap missing or the kernel refusing its
namespaces), printed as one line
``mbd: error: ...`` to stderr; then no output folder is made. ``--unsafe-no-isolation`` grades without the
operating system's isolation (the forkserver sandbox, whose audit hook is no wall), and says so.
The feedback pages hold the hidden checks' results back until ``--publish-hidden`` (run again once grades
are published: unchanged submissions are not graded again, every page is rewritten with them).

130: stopped by Ctrl-C, said in one line ``mbd: interrupted; N of M submissions graded, run the same command
again to resume``; the results written so far stay and the next run resumes from them.

The summary's statistics (median, range) are over the graded submissions only; students who handed
nothing in are counted apart (``3 missing: ada, bob, eve``) and are "missing" in the gradebook.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import zipfile
from pathlib import Path

from mbdkit.cli import error
from mbdkit.homework import available_homeworks
from mbdkit.isolation import IsolationUnavailable
from solutions.batch import BatchError, cluster_for

from . import lms as platforms
from .grading import ISOLATION_NOTE, Gradebook, GradingInterrupted, grade, read_roster
from .secret import SecretMissing

INTERRUPTED = 130
"""The exit code after Ctrl-C (128 + SIGINT), as a shell gives."""


def grade_command(
    homework: str,
    submissions: str | Path,
    out: str | Path | None = None,
    jobs: int | None = None,
    unsafe_no_isolation: bool = False,
    cluster: str | None = None,
    publish_hidden: bool = False,
    roster: str | Path | None = None,
    lms: str | None = None,
) -> int:
    """Grade every submission; print where the gradebook is and the score distribution."""
    if homework not in available_homeworks():
        return error(f"unknown homework {homework!r} (known: {', '.join(available_homeworks())})")
    out = Path(out or f"grades-{homework}")
    if lms is not None or Path(submissions).is_file():
        with tempfile.TemporaryDirectory(prefix="mbd-lms-") as folder:
            code = collect_download(homework, submissions, lms, Path(folder))
            if code is not None:
                return code
            code = grade_command(homework, folder, out, jobs, unsafe_no_isolation, cluster, publish_hidden, roster)
            if out.is_dir():
                shutil.rmtree(out / "submissions", ignore_errors=True)
                shutil.copytree(folder, out / "submissions")
                print(f"submissions: {out / 'submissions'} (ids, names, notes: {platforms.COLLECTED} there)")
            return code
    if not Path(submissions).is_dir():
        return error(f"no folder {submissions} (give nbgrader's submitted/ folder or a folder of student folders)")
    jobs = jobs or min(os.cpu_count() or 1, 8)
    try:
        cluster = cluster_for(jobs, cluster)  # more than one job: a LocalCluster of `jobs` worker processes
    except BatchError as err:
        return error(str(err))
    isolation = "local" if unsafe_no_isolation else "os"
    try:
        students = read_roster(roster) if roster is not None else []
    except (OSError, ValueError, UnicodeDecodeError) as err:
        return error(f"--roster {roster}: {getattr(err, 'strerror', None) or err} (give a CSV with a column 'student')")
    try:
        book = grade(
            homework,
            submissions,
            out,
            jobs=jobs,
            isolation=isolation,
            cluster=cluster,
            publish_hidden=publish_hidden,
            roster=students,
        )
    except GradingInterrupted as err:
        return interrupted(str(err))
    except FileNotFoundError as err:
        return error(str(err))
    except (BatchError, SecretMissing) as err:
        return error(str(err))
    except IsolationUnavailable as err:
        return error(f"cannot isolate student code: {err}; give --unsafe-no-isolation to grade without it (unsafe)")
    print(summary(book))
    print(f"gradebook: {book.csv_path}\nresults:   {out / 'results'}\nfeedback:  {out / 'feedback'}")
    failed = book.internal_errors
    if failed:
        print(
            f"internal error while grading {len(failed)} submission{'s' if len(failed) > 1 else ''}: "
            f"{', '.join(failed)} (tracebacks in {out / 'errors'}; run the same command again to grade them again)"
        )
    if publish_hidden:
        print("feedback pages: with the hidden checks' results (published)")
    else:
        print("feedback pages: the hidden checks' results held back (--publish-hidden shows them)")
    if book.isolation != "os":
        print(f"warning: graded {ISOLATION_NOTE[book.isolation]}")
    return 0


def collect_download(homework: str, download: str | Path, lms: str | None, folder: Path) -> int | None:
    """Unpack a platform's download into ``folder`` (one folder per student) and print what was collected; the
    exit code when nothing can be graded (2, one line), None to go on."""
    try:
        chosen = platforms.preset(lms) if lms is not None else None
    except platforms.LmsError as err:
        return error(f"--lms: {err}")
    try:
        if chosen is None:
            with platforms.Download(download) as found:
                guess = platforms.hint(found.paths, homework, "--lms {}")
            raise platforms.LmsError(
                f"{download} is a file: say which platform it was downloaded from, --lms moodle|canvas|REGEXP{guess}"
            )
        found = platforms.unpack(download, chosen, homework, folder)
    except (platforms.LmsError, OSError, zipfile.BadZipFile) as err:
        return error(str(err))
    if not found.handed_in:
        return error(found.nothing(str(download), "--lms {}"))
    print(found.summary(str(download)))
    return None


def summary(book: Gradebook) -> str:
    """One line: how many were graded, their median and range (missing students left out), who is missing."""
    scores = sorted(book.score(s) for s in book.graded)
    text = f"{book.homework}: graded {len(scores)} submissions"
    if scores:
        median = scores[len(scores) // 2]
        text += f", median {median:g} / {book.max_score:g}, range {scores[0]:g} .. {scores[-1]:g}"
    missing = book.missing
    if missing:
        names = ", ".join(missing[:10]) + (f" and {len(missing) - 10} more" if len(missing) > 10 else "")
        text += f"; {len(missing)} missing (handed nothing in, not counted): {names}"
    return text


def interrupted(text: str) -> int:
    """Ctrl-C: one line on stderr, exit code 130."""
    import sys

    print(f"mbd: {text}", file=sys.stderr)
    return INTERRUPTED
