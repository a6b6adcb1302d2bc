"""The oral exam's marking sheet of one student (``mbd oral hwN SUBMISSION``), drawn from their own code.

    mbd oral hw1 build/submitted/ada/hw1 --out build/oral/ada-hw1.md

The oral exam starts from the student's homework code (``course/syllabus.md``). The sheet, for the examiner,
draws ``--functions`` (3) of the functions the student wrote in the homework (``mbd todo``'s list: the
release's solution regions; one still a stub is drawn only when too few are written), shows each as the student
wrote it (their file, read as text and never run: ``autograder.documentation``), and asks two questions about
it from ``course/exam/oral.toml``: one about its kind (a Jacobian, a force, ...) and one of the general ones,
each with the equation its stub cites. Then one problem of the written test's bank at the board, from the
homework's chapters, with the student's own numbers and the answers. Every question has its points and a blank
for the mark; the total over the points is the oral's mark in percent for the marks CSV (column ``oral``).

The draw is seeded by the student id, the homework and ``--seed`` (the semester's): the same sheet every time
for a student, another set of functions and questions for the next. The sheet also carries the documentation
rubric's automatic part and a blank for its manual points (marks CSV, column ``hwN_doc``).
"""

from __future__ import annotations

import ast
import fnmatch
import re
import textwrap
import tomllib
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from autograder.documentation import Documentation, measure, parse, read_files
from mbdkit import staging
from mbdkit.runner import PACKAGE
from solutions.cli import UsageError

from .exam import PROBLEMS, variant
from .release.generator import all_regions

BANK = Path(__file__).resolve().parent / "exam" / "oral.toml"
EXCERPT_LINES, EXCERPT_WIDTH = 40, 160
"""Lines of a function shown at most (the rest is counted), and characters of a line."""


@dataclass(frozen=True)
class Question:
    """A question of the bank: the functions it is about (patterns), its points and its text."""

    about: tuple[str, ...]
    points: float
    text: str

    def fits(self, function: str) -> bool:
        return any(fnmatch.fnmatchcase(function, pattern) for pattern in self.about)

    @property
    def general(self) -> bool:
        return "*" in self.about


@dataclass(frozen=True)
class Drawn:
    """A function drawn for the sheet: where it is, what its stub says, and whether the student wrote it."""

    path: str
    function: str
    what: str
    equation: str
    written: bool
    why: str
    """The rubric's verdict on it: whether it is documented, or why it is not written or cannot be read."""


def read_bank(path: Path = BANK) -> tuple[list[Question], dict]:
    """The questions and the board problem's settings of the bank."""
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    questions = [Question(tuple(q["about"]), float(q["points"]), q["text"]) for q in data["question"]]
    return questions, data["board"]


EQUATION = re.compile(r"\beqs?\.\s*\d+(?:\.\d+)*(?:(?:, | and |-)\d+(?:\.\d+)*)*")


def stubs(homework: str) -> dict[tuple[str, str], tuple[str, str]]:
    """{(file, function): (what it computes, the equation it cites: 'eq. 3.17', or 'the notes')} from the
    release's stub messages ('Revolute.gamma: gamma, the right side of ..., see eq. 3.17')."""
    found = {}
    for region in all_regions():
        if region.tag == homework:
            what, _, cited = region.pointer.split(": ", 1)[1].rpartition(", see ")
            equation = EQUATION.search(cited)
            found.setdefault((region.path, region.function), (what, equation[0] if equation else "the notes"))
    return found


def student_id(submission: Path) -> str:
    """The student's id from the folder: ``STUDENT/hwN`` (nbgrader's layout) or ``STUDENT``."""
    name = submission.resolve().name
    return submission.resolve().parent.name if re.fullmatch(r"hw\d+", name) else name


def rng_for(student: str, homework: str, seed: int) -> np.random.Generator:
    return np.random.default_rng([seed, zlib.crc32(student.encode()), zlib.crc32(homework.encode())])


def draw_functions(documentation: Documentation, homework: str, count: int, rng: np.random.Generator) -> list[Drawn]:
    """``count`` functions of the homework, the written ones first, in a random order of the student's."""
    said = stubs(homework)
    written = [v for v in documentation.verdicts if v.written]
    others = [v for v in documentation.verdicts if v not in written]
    chosen = [written[k] for k in rng.permutation(len(written))]
    chosen += [others[k] for k in rng.permutation(len(others))]
    return [Drawn(v.path, v.function, *said[(v.path, v.function)], v.written, v.why) for v in chosen[:count]]


def questions_for(function: str, bank: list[Question], rng: np.random.Generator) -> list[Question]:
    """One question about the function's kind (when the bank has one) and one general question."""
    kind = [q for q in bank if not q.general and q.fits(function)]
    general = [q for q in bank if q.general]
    picked = [kind[rng.integers(len(kind))]] if kind else []
    return picked + [general[rng.integers(len(general))]]


def excerpt(text: str | ValueError, path: str, function: str) -> str:
    """The student's function as they wrote it, in a Markdown code block (or why it cannot be shown)."""
    functions = parse(text, path)
    if isinstance(functions, str):
        return f"*Not shown: {functions}.*"
    if function not in functions:
        return f"*Not shown: {function} is not in {PACKAGE}/{path} (renamed or deleted?).*"
    node: ast.FunctionDef = functions[function]
    first = min([node.lineno] + [d.lineno for d in node.decorator_list])
    lines = re.split(r"\r\n|\r|\n", text)[first - 1 : node.end_lineno]  # Python's line ends, as ast counts
    more = len(lines) - EXCERPT_LINES
    cut = [line if len(line) <= EXCERPT_WIDTH else line[:EXCERPT_WIDTH] + " ..." for line in lines[:EXCERPT_LINES]]
    body = textwrap.dedent("\n".join(cut))
    fence = "`" * max(3, 1 + max((len(run) for run in re.findall(r"`+", body)), default=0))
    tail = f"\n*... {more} more lines ({PACKAGE}/{path}, line {node.end_lineno}).*" if more > 0 else ""
    return f"{PACKAGE}/{path}, line {node.lineno}:\n\n{fence}python\n{body}\n{fence}{tail}"


def board_problem(homework: str, board: dict, student: str, seed: int, rng: np.random.Generator):
    """The student's variant of one bank problem of the homework's chapters (None when it has none)."""
    chapters = set(board.get(homework, []))
    problems = [p for p in PROBLEMS if p.chapter in chapters]
    if not problems:
        return None
    return variant(problems[rng.integers(len(problems))], student, seed)


def sheet(homework: str, submission: Path, student: str, seed: int = 0, count: int = 3, bank: Path = BANK) -> str:
    """The Markdown marking sheet of one student."""
    questions, board = read_bank(bank)
    documentation = measure(homework, submission)
    rng = rng_for(student, homework, seed)
    drawn = draw_functions(documentation, homework, count, rng)
    texts = read_files(submission, [d.path for d in drawn])
    parts = [
        f"# Oral exam, {homework}: {student}\n",
        f"Examiner's sheet (seed {seed}): not for the student. Mark each question from 0 to its points; the "
        "oral's mark (marks CSV, column `oral`) is 100 x total / maximum.\n",
    ]
    total, number = 0.0, 0
    for item in drawn:
        parts.append(f"\n## {item.function} ({PACKAGE}/{item.path})\n\n*Its stub:* {item.what} ({item.equation}).\n")
        if not item.written:
            parts.append(f"\n*Not the student's code ({item.why}): ask how they would write it.*\n")
        parts.append("\n" + excerpt(texts[item.path], item.path, item.function) + "\n")
        for question in questions_for(item.function, questions, rng):
            number += 1
            total += question.points
            text = question.text.format(function=item.function, what=item.what, equation=item.equation)
            parts.append(f"\n**Q{number}** ({question.points:g} points). {text}\n\nMark: ____ / {question.points:g}\n")
    problem = board_problem(homework, board, student, seed, rng)
    if problem is not None:
        number += 1
        total += float(board["points"])
        answers = ", ".join(f"{name} = {value:.6g}" for name, value in problem.answers.items())
        parts.append(
            f"\n## At the board: {problem.problem.title} (notes, chapter {problem.problem.chapter})\n\n"
            f"**Q{number}** ({float(board['points']):g} points). {problem.statement}\n\n"
            f"*Answers (examiner):* {answers}\n\nMark: ____ / {float(board['points']):g}\n"
        )
    parts.append(f"\n## Total\n\n____ / {total:g} points: oral mark ____ %\n")
    parts.append(
        f"\n## Documentation of {homework}\n\n{documentation.line()}\n\nManual part (marks CSV, column "
        f"`{homework}_doc`): ____ points (course/grading.toml, [documentation] manual)\n"
    )
    return "".join(parts)


def command(args) -> int:
    """``mbd oral``: write the sheet; a bad argument is one line (``UsageError``, exit 2)."""
    homework, submission = args.homework, Path(args.submission)
    if not stubs(homework):
        raise UsageError(f"{homework}: no such homework; the course has hw1, hw2, hw3")
    if not submission.is_dir():
        raise UsageError(f"{submission}: no such folder (give the student's submission, the folder with {PACKAGE}/)")
    refused = staging.refusal(submission, PACKAGE)
    if refused is not None or not (submission / PACKAGE).is_dir():
        raise UsageError(f"{submission}: {refused or f'no {PACKAGE}/ in it (the student package)'}")
    if args.functions < 1:
        raise UsageError(f"--functions {args.functions}: draw at least 1")
    student = args.student or student_id(submission)
    out = Path(args.out or f"{student}-{homework}-oral.md")
    if out.suffix != ".md":
        raise UsageError(f"--out {out}: the sheet is Markdown, write FILE.md")
    if not out.resolve().parent.is_dir():
        raise UsageError(f"--out {out}: no folder {out.parent}")
    out.write_text(sheet(homework, submission, student, args.seed, args.functions), encoding="utf-8")
    print(f"wrote {out}: the oral sheet of {student} for {homework}")
    return 0
