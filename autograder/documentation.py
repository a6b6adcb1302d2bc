"""The documentation rubric's automatic part: how many of the homework's functions the student documented.

Students document their code (``course/syllabus.md``: the oral exam starts from it). The skeleton they get
already has docstrings, so a docstring-coverage count (ruff's pydocstyle D1 rules, interrogate) credits the
student with the course's text and sees no comment: on the untouched skeleton ruff's D1 passes 9 of hw1's 40
functions, all 17 of hw2's and 15 of hw3's. What is measured here is what the student added, function by
function, over what the skeleton gave (``given``: read from the solution regions of ``solutions/``):

- **documented**: written (no ``raise NotImplementedError`` left in it, as ``mbd todo`` says) and explained by
  the student: a comment line of theirs in its body (one the skeleton does not have, of two words or more, not
  a pragma such as ``# noqa`` and not commented-out code), or a docstring at least ``MIN_WORDS`` words longer
  than the skeleton's. A function whose given docstring was deleted is not documented;
- **not documented**, with the reason: left as a stub, not found, its file does not parse or cannot be read.

The result is the share of the homework's functions documented, in percent (``mbd grade`` writes it in the
gradebook's ``documentation`` column and on the feedback page); ``mbd gradebook`` turns it into points beside
the instructor's manual part (``course/grading.toml``). Student files are hostile: they are read as text, only
regular files (``mbdkit.staging``: no link followed, a size cap), and parsed with ``ast`` and ``tokenize``;
nothing of the student's is imported or run, and a file that does not parse scores 0 with the reason.
"""

from __future__ import annotations

import ast
import functools
import html
import io
import os
import re
import tokenize
from dataclasses import dataclass
from pathlib import Path

from mbdkit import staging
from mbdkit.runner import PACKAGE
from mbdkit.todo import functions_of, stub_message

SOLUTIONS = Path(__file__).resolve().parents[1] / "solutions"
BEGIN, END = "### BEGIN SOLUTION", "### END SOLUTION"
MIN_WORDS = 5
"""Words a student's docstring must add to the skeleton's to count as their documentation."""
MAX_BYTES = 2 * 2**20
"""A file of the student's larger than this is not read (no homework file comes near it)."""
UNDOCUMENTED = "not documented: "
PRAGMAS = ("noqa", "type:", "fmt:", "pragma", "pylint", "mypy", "ruff:", "isort", "begin solution", "end solution")
"""Comments that talk to a tool (nbgrader's region markers too), not to a reader."""


@dataclass(frozen=True)
class Given:
    """What the skeleton gives one function students write: its docstring and its comments' text."""

    docstring: str
    comments: frozenset[str]


@dataclass(frozen=True)
class Verdict:
    """One function of the homework: documented or not, and why (in the student's terms)."""

    path: str
    function: str
    documented: bool
    why: str

    @property
    def written(self) -> bool:
        """Whether the student wrote it (documented or not): not a stub, and its file parses."""
        return self.documented or self.why.startswith(UNDOCUMENTED)


@dataclass
class Documentation:
    """The automatic part of the rubric for one submission: a verdict per function of the homework."""

    homework: str
    verdicts: list[Verdict]

    @property
    def documented(self) -> int:
        return sum(v.documented for v in self.verdicts)

    @property
    def percent(self) -> float | None:
        """The share of the homework's functions documented, in percent (None: the homework asks for none)."""
        return 100.0 * self.documented / len(self.verdicts) if self.verdicts else None

    def line(self) -> str:
        """One sentence: how many functions are documented, and the files that could not be read."""
        if not self.verdicts:
            return f"Documentation: {self.homework} asks for no function of {PACKAGE}/."
        unread = sorted({v.why for v in self.verdicts if v.why.startswith(PACKAGE)})
        problems = f"; {'; '.join(unread)}" if unread else ""
        return (
            f"Documentation (automatic part): {self.documented} of {len(self.verdicts)} functions of "
            f"{self.homework} documented beyond the skeleton ({self.percent:.1f} %){problems}."
        )

    def to_json(self) -> dict:
        return {
            "percent": self.percent,
            "documented": self.documented,
            "functions": len(self.verdicts),
            "verdicts": [[v.path, v.function, v.documented, v.why] for v in self.verdicts],
        }

    def html(self) -> str:
        """The feedback page's part: the sentence, then every function's verdict (folded)."""
        items = "".join(
            f"<li><code>{html.escape(v.path)}</code> <code>{html.escape(v.function)}</code>: {html.escape(v.why)}</li>"
            for v in self.verdicts
        )
        rule = (
            "A function counts when you wrote it and explained it yourself: a comment of yours in its body, or "
            f"a docstring at least {MIN_WORDS} words longer than the skeleton's. The instructor adds the "
            "points of the rubric's manual part."
        )
        return (
            f"<h2>Documentation</h2><p>{html.escape(self.line())}</p><p>{rule}</p>"
            f"<details><summary>function by function</summary><ul>{items}</ul></details>"
        )


# -- what the skeleton gives ---------------------------------------------------------------------------------------
def _tag_index(tag: str) -> int:
    return int(tag[2:]) if re.fullmatch(r"hw\d+", tag) else 0


def comments(text: str) -> dict[int, str]:
    """The comments of a source text, by line: {line: text without '#'} ({} when it cannot be tokenized)."""
    try:
        tokens = list(tokenize.generate_tokens(io.StringIO(text).readline))
    except (tokenize.TokenError, SyntaxError, ValueError, RecursionError, MemoryError):
        return {}
    return {t.start[0]: t.string.lstrip("#").strip() for t in tokens if t.type == tokenize.COMMENT}


@functools.lru_cache(maxsize=8)
def given(homework: str, source: Path = SOLUTIONS) -> dict[tuple[str, str], Given]:
    """The functions students write in ``homework``, as (file in the package, function), with what their
    skeleton gives: a function holding a ``### BEGIN SOLUTION hwN`` region of the homework; its docstring
    (copied as it is) and its comments but those of the regions the kit stubs (this homework's and later)."""
    index = _tag_index(homework)
    found: dict[tuple[str, str], Given] = {}
    for path in sorted(source.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        if not re.search(rf"^\s*{BEGIN} {re.escape(homework)}\s*$", text, re.MULTILINE):
            continue
        notes = comments(text)
        begins, stubbed = _regions(notes, index)
        functions = functions_of(ast.parse(text))
        for begin in begins:
            inside = [(name, f) for name, f in functions.items() if f.lineno < begin <= f.end_lineno]
            name, node = max(inside, key=lambda item: item[1].lineno)  # the innermost
            lines = set(range(node.lineno, node.end_lineno + 1)) - stubbed
            kept = frozenset(note for line, note in notes.items() if line in lines)
            found[(path.relative_to(source).as_posix(), name)] = Given(ast.get_docstring(node) or "", kept)
    return found


def _regions(notes: dict[int, str], index: int) -> tuple[list[int], set[int]]:
    """The first lines of homework ``index``'s regions, and the lines the kit does not have: the markers, and
    the regions it stubs (this homework's and later ones'; earlier ones are filled in)."""
    begins, stubbed, open_at, tag = [], set(), None, 0
    for line, note in sorted(notes.items()):
        words = note.split()  # a marker's text, its '###' taken off: 'BEGIN SOLUTION hw1'
        if note.startswith(BEGIN.lstrip("# ")) and len(words) == 3:
            open_at, tag = line, _tag_index(words[2])
            begins += [line] if tag == index else []
        elif note.startswith(END.lstrip("# ")) and open_at is not None:
            stubbed |= set(range(open_at, line + 1)) if tag >= index else {open_at, line}
            open_at = None
    return begins, stubbed


# -- what the student wrote ----------------------------------------------------------------------------------------
def read_files(folder: Path, paths: list[str]) -> dict[str, str]:
    """The text of each of ``paths`` in ``folder/modules``, or why it cannot be read ('modules/x.py ...').
    Only regular files of one name are opened, without following a link (``mbdkit.staging``)."""
    found = staging.scan(folder, PACKAGE)
    files = {f.path: f for f in found.files}
    texts = {}
    for path in dict.fromkeys(paths):
        where = f"{PACKAGE}/{path}"
        file = files.get(path)
        if found.refused is not None:
            texts[path] = ValueError(found.refused)
        elif file is None:
            texts[path] = ValueError(f"{where} is {found.skipped.get(path, 'missing')}: not read")
        elif file.size > MAX_BYTES:
            texts[path] = ValueError(f"{where} is larger than {MAX_BYTES // 2**20} MiB: not read")
        else:
            texts[path] = _read(folder, file, where)
    return texts


def _read(folder: Path, file: staging.File, where: str) -> str | ValueError:
    try:
        handle = staging.open_file(folder, PACKAGE, file)
    except OSError:
        return ValueError(f"{where} cannot be read")
    with os.fdopen(handle, "rb") as f:
        data = f.read(MAX_BYTES + 1)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return ValueError(f"{where} is not UTF-8 text")


def parse(text: str | ValueError, path: str) -> dict[str, ast.FunctionDef] | str:
    """The functions of a student's file by name (``Class.method`` for a method), or why there are none."""
    if isinstance(text, ValueError):
        return str(text)
    try:
        return functions_of(ast.parse(text))
    except SyntaxError as err:
        where = f"line {err.lineno}: " if err.lineno else ""
        return f"{PACKAGE}/{path} does not parse ({where}{err.msg})"
    except (ValueError, RecursionError, MemoryError):  # nested deeper than Python's parser goes
        return f"{PACKAGE}/{path} does not parse (too deeply nested for Python's parser)"


def explains(note: str) -> bool:
    """Whether a comment is an explanation: two words or more, no pragma, no commented-out code."""
    if len(re.findall(r"\w+", note)) < 2 or note.lower().startswith(PRAGMAS):
        return False
    try:
        ast.parse(note)
    except (SyntaxError, ValueError, RecursionError, MemoryError):
        return True
    return False  # it parses: code put aside, not a sentence


def verdict(path: str, name: str, node: ast.FunctionDef, notes: dict[int, str], gift: Given) -> Verdict:
    """Documented or not, for one function the student's file has."""
    if stub_message(node) is not None:
        return Verdict(path, name, False, "not written: it still raises NotImplementedError")
    mine = [
        note
        for line, note in notes.items()
        if node.lineno <= line <= node.end_lineno and note not in gift.comments and explains(note)
    ]
    docstring = ast.get_docstring(node) or ""
    added = len(re.findall(r"\w+", docstring)) - len(re.findall(r"\w+", gift.docstring))
    if gift.docstring and not docstring:
        return Verdict(path, name, False, f"{UNDOCUMENTED}the skeleton's docstring was deleted")
    if mine:
        return Verdict(path, name, True, f"documented: {len(mine)} comment line(s) of yours")
    if added >= MIN_WORDS:
        return Verdict(path, name, True, f"documented: your docstring (+{added} words)")
    return Verdict(path, name, False, f"{UNDOCUMENTED}no comment of yours, and the docstring is the skeleton's")


def measure(homework: str, folder: str | os.PathLike, source: Path = SOLUTIONS) -> Documentation:
    """The rubric's automatic part for the submission in ``folder`` (which holds ``modules/``). Never raises
    for what the student handed in: what cannot be read or parsed scores 0 with the reason."""
    gifts = given(homework, Path(source))
    texts = read_files(Path(folder), [path for path, _ in gifts])
    trees = {path: parse(text, path) for path, text in texts.items()}
    notes = {path: comments(text) for path, text in texts.items() if not isinstance(trees[path], str)}
    verdicts = []
    for (path, name), gift in gifts.items():
        functions = trees[path]
        if isinstance(functions, str):
            verdicts.append(Verdict(path, name, False, functions))
        elif name not in functions:
            verdicts.append(Verdict(path, name, False, f"not found in {PACKAGE}/{path} (renamed or deleted?)"))
        else:
            verdicts.append(verdict(path, name, functions[name], notes[path], gift))
    return Documentation(homework, verdicts)
