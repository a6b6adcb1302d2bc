"""The course's commands of ``mbd`` (instructor): ``release``, ``nbcheck``, ``notes``, ``bench``, ``gradebook``,
``oral``.

Registered in the course's ``pyproject.toml`` (entry-point group ``mbd.commands``, ``solutions.cli.COMMANDS``);
each ``add_*`` adds its subparser to ``mbd``'s. The work is imported only when the command runs, so that
listing the commands costs nothing.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def add_release(sub) -> None:
    """``mbd release hwN``: the student's kit of a homework (``course.release``)."""
    release = sub.add_parser("release", help="build and release homework hwN to students (instructor)")
    release.add_argument("homework", help="hw1, hw2 or hw3")
    release.set_defaults(handler=lambda args: _release(args.homework))


def _release(homework: str) -> int:
    from course.release import command

    return command(homework)


def add_nbcheck(sub) -> None:
    """``mbd nbcheck hwN [--repair]``: what nbgrader will do with each collected notebook (``course.nbcheck``)."""
    nbcheck = sub.add_parser(
        "nbcheck", help="check the collected notebooks of hwN before nbgrader's autograde (instructor)"
    )
    nbcheck.add_argument("homework", help="hw1, hw2 or hw3")
    nbcheck.add_argument(
        "--repair", action="store_true", help="repair what is safe: a renamed notebook, a duplicated or lost test cell"
    )
    nbcheck.set_defaults(handler=lambda args: _nbcheck(args.homework, args.repair))


def _nbcheck(homework: str, repair: bool) -> int:
    from course.nbcheck import command

    return command(homework, repair)


def add_notes(sub) -> None:
    """``mbd notes [options]``: the course notes as HTML (``course/notes/build.py``; its options: --help)."""
    notes = sub.add_parser("notes", help="build the course notes as HTML (build/notes/index.html)", add_help=False)
    notes.set_defaults(handler=_notes, options=True)


def _notes(args: argparse.Namespace) -> int:
    from course.notes.build import main

    return main(args.options)


def add_bench(sub) -> None:
    """``mbd bench [options]``: the repository's ``benchmarks/bench.py`` (run time against error)."""
    bench = sub.add_parser(
        "bench",
        help="run time against error per scene, formulation and integrator (see benchmarks/README.md)",
        add_help=False,
    )
    bench.set_defaults(handler=_bench, options=True)


def _bench(args: argparse.Namespace) -> int:
    import importlib.util

    from solutions.cli import UsageError

    script = REPO / "benchmarks" / "bench.py"
    if not script.is_file():
        raise UsageError("mbd bench runs the course repository's benchmarks/bench.py: run it in the repository")
    spec = importlib.util.spec_from_file_location("mbd_bench", script)
    bench = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = bench  # its dataclasses look their module up there
    spec.loader.exec_module(bench)
    return bench.main(args.options)


def add_gradebook(sub) -> None:
    """``mbd gradebook HOMEWORK.csv ... --marks MARKS.csv --out FINAL.csv``: the final grade (``course.gradebook``)."""
    book = sub.add_parser(
        "gradebook", help="combine the homework grades with test and oral marks into the final grade (instructor)"
    )
    book.add_argument(
        "homework", nargs="+", metavar="GRADES.csv",
        help="each homework's grades: mbd grade's gradebook.csv (hwN in its path, or hwN=FILE) or nbgrader's export",
    )  # fmt: skip
    book.add_argument(
        "--marks", help="CSV with columns student, test, oral (percent; empty: not given) and hwN_doc (the "
        "documentation rubric's manual points)",
    )  # fmt: skip
    book.add_argument("--weights", help="percent per part, e.g. homework=50,test=25,oral=25 (course/grading.toml)")
    book.add_argument(
        "--documentation-share", metavar="PERCENT",
        help="the documentation's share of each homework's grade (course/grading.toml: 10; 0 leaves it out)",
    )  # fmt: skip
    book.add_argument(
        "--submitted", metavar="FOLDER",
        help="the submissions (nbgrader's submitted/): the documentation's automatic part of nbgrader's homework",
    )  # fmt: skip
    book.add_argument("--roster", help="a file of student ids, one per line: who should be in the table")
    book.add_argument("--missing-as-zero", action="store_true", help="count a missing part as 0 (end of term)")
    book.add_argument("--out", required=True, help="the final grades, FILE.csv")
    book.set_defaults(handler=_gradebook)


def _gradebook(args: argparse.Namespace) -> int:
    from course.gradebook import command

    return command(args)


def add_oral(sub) -> None:
    """``mbd oral hwN SUBMISSION [--out FILE.md]``: a student's oral-exam marking sheet (``course.oral``)."""
    oral = sub.add_parser(
        "oral", help="the oral exam's marking sheet of one student, from their own code and the bank (instructor)"
    )
    oral.add_argument("homework", help="hw1, hw2 or hw3")
    oral.add_argument("submission", metavar="SUBMISSION", help="the student's folder, the one holding modules/")
    oral.add_argument("--student", help="the student's id (default: the folder's name, or its parent's for .../hwN)")
    oral.add_argument("--seed", type=int, default=0, help="the semester's seed of the draw (default 0)")
    oral.add_argument("--functions", type=int, default=3, help="functions of the student's to ask about (default 3)")
    oral.add_argument("--out", help="the sheet, FILE.md (default: STUDENT-hwN-oral.md here)")
    oral.set_defaults(handler=_oral)


def _oral(args: argparse.Namespace) -> int:
    from course.oral import command

    return command(args)
