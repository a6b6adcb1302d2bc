"""The ``mbd`` command of a student kit: the self-check, and your own solver on model files.

    mbd selfcheck hwN [PATH]     the public checks of homework N on the modules/ in PATH (default: here)
    mbd todo hwN [PATH]          the functions of homework N left to write, file by file
    mbd handin hwN [PATH]        a zip of what the instructor grades: the notebook and modules/
    mbd run MODEL [options]      run a model file with your own package (modules/cli.py)
    mbd check MODEL              validate and assemble a model file with your own package

``run`` and ``check`` are your package's own command line (``modules/cli.py``, the course solver's, with
the functions you write): they work as far as your homework has come (a function still to write is named
in one line). A user error prints one line ``mbd: error: ...`` and exits with code 2.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .homework import available_homeworks
from .runner import PACKAGE

USER_ERROR = 2


def error(message: str) -> int:
    print(f"mbd: error: {message}", file=sys.stderr)
    return USER_ERROR


def selfcheck_command(homework: str, path: str | Path | None = None, strict: bool = False) -> int:
    """Print the public checks of a homework on the student's ``modules/`` (in PATH or here).

    Exit code 0 when the report was made (whatever the score; ``strict``: 1 when a check fails), 2 for an
    unknown homework or a folder without ``modules/``.
    """
    from .api import selfcheck

    if homework not in available_homeworks():
        return error(f"unknown homework {homework!r} (known: {', '.join(available_homeworks())})")
    try:
        failing = selfcheck(homework, path)
    except (FileNotFoundError, ValueError) as err:
        return error(str(err))
    return 1 if strict and failing else 0


def todo_command(homework: str, path: str | Path | None = None) -> int:
    """Print the functions of a homework still to write in ``modules/`` (in PATH or here); 0, or 2 for an unknown
    homework or a folder without ``modules/``."""
    from .api import folder_of
    from .homework import load_homework
    from .todo import every_stub, left_to_write, report

    if homework not in available_homeworks():
        return error(f"unknown homework {homework!r} (known: {', '.join(available_homeworks())})")
    package = folder_of(path) / PACKAGE
    if not (package / "__init__.py").is_file():
        return error(f"no {PACKAGE}/ (with __init__.py) in {package.parent}: run it where your notebook is")
    to_write = list(load_homework(homework).to_write)
    every = not to_write  # the course's own homework files list none: every stub of the package
    to_write = to_write or every_stub(package)
    print(report(homework, PACKAGE, to_write, left_to_write(package, to_write), every), end="")
    return 0


def handin_command(homework: str, path: str | Path | None = None, out: str | None = None) -> int:
    """Write the hand-in zip; 0, or 2 (one line) when the folder cannot be handed in."""
    from .api import folder_of
    from .handin import HandinError, handin, summary

    if homework not in available_homeworks():
        return error(f"unknown homework {homework!r} (known: {', '.join(available_homeworks())})")
    folder = folder_of(path)
    try:
        zipped, names = handin(homework, folder, Path(out) if out else None)
    except HandinError as err:
        return error(str(err))
    print(summary(zipped, names, folder), end="")
    return 0


def own_solver(argv: list[str]) -> int:
    """``mbd run`` / ``mbd check``: the command line of the package in ./modules (the student's own)."""
    here = Path.cwd()
    if not (here / PACKAGE / "__init__.py").is_file():
        return error(f"no {PACKAGE}/ in {here}: run mbd in your homework folder (the one with your notebook)")
    sys.path.insert(0, str(here))
    try:
        from modules.cli import main as solver
    except ImportError as err:
        return error(f"cannot import your {PACKAGE}/cli.py ({err})")
    except Exception as err:  # noqa: BLE001 - the student's own package fails on import: say where
        return error(f"your {PACKAGE}/ fails on import: {type(err).__name__}: {err}")
    try:
        return solver(argv)
    except NotImplementedError as err:  # a function of a homework still to come, or still to write
        return error(f"not implemented yet in your {PACKAGE}/: {err}")


def add_selfcheck(sub) -> None:
    """``mbd selfcheck hwN [PATH] [--strict]``: in the kit's ``mbd`` and, registered in the course's
    ``pyproject.toml`` (entry-point group ``mbd.commands``), in the course's."""
    check = sub.add_parser("selfcheck", help="run the public checks of hwN on your own modules/ (students)")
    check.add_argument("homework", help="hw1, hw2 or hw3")
    check.add_argument("path", nargs="?", help="folder holding your modules/ (default: the current folder)")
    check.add_argument("--strict", action="store_true", help="exit with code 1 when a check fails")
    check.set_defaults(handler=lambda args: selfcheck_command(args.homework, args.path, args.strict))


def add_todo(sub) -> None:
    """``mbd todo hwN [PATH]`` (the kit's and, through ``mbd.commands``, the course's)."""
    todo = sub.add_parser("todo", help="list the functions of hwN you still have to write, file by file (students)")
    todo.add_argument("homework", help="hw1, hw2 or hw3")
    todo.add_argument("path", nargs="?", help="folder holding your modules/ (default: the current folder)")
    todo.set_defaults(handler=lambda args: todo_command(args.homework, args.path))


def add_handin(sub) -> None:
    """``mbd handin hwN [PATH] [--out FILE]`` (the kit's and, through ``mbd.commands``, the course's)."""
    handin = sub.add_parser("handin", help="zip what the instructor grades: hwN.ipynb and modules/ (students)")
    handin.add_argument("homework", help="hw1, hw2 or hw3")
    handin.add_argument("path", nargs="?", help="your homework folder (default: the current folder)")
    handin.add_argument("--out", help="the zip to write (default: hwN-handin.zip in the folder)")
    handin.set_defaults(handler=lambda args: handin_command(args.homework, args.path, args.out))


class Parser(argparse.ArgumentParser):
    """Errors in one line ``mbd: error: ...`` (exit code 2), with the closest command to a misspelt one."""

    def error(self, message: str):
        import difflib
        import re

        commands = next((a.choices for a in self._actions if isinstance(a, argparse._SubParsersAction)), {})
        words = re.findall(r"invalid choice: '([^']*)'", message)
        guesses = [g for word in words for g in difflib.get_close_matches(word, list(commands), n=1, cutoff=0.6)]
        hint = f"; did you mean {guesses[0]}?" if guesses else ""
        self.exit(USER_ERROR, f"mbd: error: {message}{hint} (mbd --help lists them)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="mbd", description="The course's student kit: self-check and your solver.")
    sub = parser.add_subparsers(dest="command", required=True)
    add_selfcheck(sub)
    add_todo(sub)
    add_handin(sub)
    sub.add_parser("run", help="run a model file with your own package (mbd run --help)", add_help=False)
    sub.add_parser("check", help="validate and assemble a model file with your own package", add_help=False)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the kit's ``mbd``; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in ("run", "check"):
        return own_solver(argv)
    args = build_parser().parse_args(argv)
    return args.handler(args)


if __name__ == "__main__":
    sys.exit(main())
