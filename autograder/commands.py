"""The grader's commands of ``mbd`` (instructor): ``grade`` and ``secret``.

Registered in the course's ``pyproject.toml`` (entry-point group ``mbd.commands``, ``solutions.cli.COMMANDS``);
the grader is imported only when the command runs (``autograder.cli``, ``autograder.secret``).
"""

from __future__ import annotations

import argparse


def add_grade(sub) -> None:
    """``mbd grade hwN SUBMISSIONS [...]`` (``autograder.cli.grade_command``)."""
    grade = sub.add_parser("grade", help="grade every submission of homework hwN (instructor)")
    grade.add_argument("homework", help="hw1, hw2 or hw3")
    grade.add_argument(
        "submissions",
        help="nbgrader's submitted/ folder, a folder of student folders, or a platform's download (--lms)",
    )
    grade.add_argument("--out", help="folder for the gradebook, results and feedback (default: grades-hwN)")
    grade.add_argument(
        "--jobs",
        type=int,
        help="submissions graded in parallel (default: the cores, at most 8; 1: here; more: a local Dask cluster)",
    )
    grade.add_argument(
        "--cluster",
        metavar="local|tcp://HOST:PORT",
        help="grade on Dask: 'local' (a LocalCluster of --jobs workers, the default when --jobs > 1) or a scheduler",
    )
    grade.add_argument(
        "--unsafe-no-isolation",
        action="store_true",
        help="grade even where bubblewrap cannot isolate student code (unsafe: the results say so)",
    )
    grade.add_argument(
        "--publish-hidden",
        action="store_true",
        help="show the hidden checks' results on the feedback pages (held back until then; unchanged "
        "submissions are not graded again, their pages are rewritten)",
    )
    grade.add_argument(
        "--roster",
        metavar="CSV",
        help="the class list (a column 'student'): a student without a submission is 'missing' in the gradebook",
    )
    grade.add_argument(
        "--lms",
        metavar="moodle|canvas|REGEXP",
        help="SUBMISSIONS is this platform's 'download all submissions' (its zip or unpacked folder): collected into "
        "one folder per student id first; REGEXP names one student's folder or file with (?P<student_id>...)",
    )
    grade.set_defaults(handler=_grade)


def _grade(args: argparse.Namespace) -> int:
    from .cli import grade_command

    return grade_command(
        args.homework,
        args.submissions,
        out=args.out,
        jobs=args.jobs,
        unsafe_no_isolation=args.unsafe_no_isolation,
        cluster=args.cluster,
        publish_hidden=args.publish_hidden,
        roster=args.roster,
        lms=args.lms,
    )


def add_secret(sub) -> None:
    """``mbd secret [--init]`` (``autograder.secret.secret_command``)."""
    secret = sub.add_parser("secret", help="where the course secret of hidden and per-student scenes is (instructor)")
    secret.add_argument("--init", action="store_true", help="make one (a random string, mode 0600) unless it exists")
    secret.set_defaults(handler=_secret)


def _secret(args: argparse.Namespace) -> int:
    from .secret import secret_command

    return secret_command(init=args.init)
