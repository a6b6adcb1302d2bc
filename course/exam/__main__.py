"""python -m course.exam --seed 2026 --students alice bob [--problems KEY ...] [--out build/exam] [--pdf] [--list]"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from . import PROBLEMS, write_sheets
from .pdf import PdfUnavailable, chromium, write_pdfs


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m course.exam", description="Per-student written-test sheets.")
    parser.add_argument("--seed", type=int, default=0, help="the semester's seed (keep it secret until the test)")
    parser.add_argument("--students", nargs="+", default=[], metavar="ID", help="student ids")
    parser.add_argument("--problems", nargs="+", metavar="KEY", help="problems to include (default: the whole bank)")
    parser.add_argument("--out", default="build/exam", help="output folder (default: build/exam)")
    parser.add_argument("--list", action="store_true", help="list the problems of the bank and stop")
    parser.add_argument("--pdf", action="store_true", help="also print each sheet to PDF (Chromium, Playwright)")
    args = parser.parse_args(argv)
    if args.list or not args.students:
        for problem in sorted(PROBLEMS, key=lambda p: p.chapter):
            print(f"ch. {problem.chapter:2d}  {problem.key:24s} {problem.title}")
        return 0
    try:
        if args.pdf:
            chromium()  # before anything is written
        paths = write_sheets(args.students, args.seed, Path(args.out), args.problems)
        if args.pdf:
            paths += write_pdfs(paths)
    except KeyError as err:
        print(f"course.exam: error: {err.args[0]}", file=sys.stderr)
        return 2
    except PdfUnavailable as err:
        print(f"course.exam: error: {err}", file=sys.stderr)
        return 2
    print(f"wrote {len(paths)} files to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
