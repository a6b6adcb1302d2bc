"""The course notes: one Jupyter notebook per chapter (``chNN_*.ipynb``), with numbered equations.

Equations carry ``\\tag{N.M}`` in display math; every ``eq. N.M`` that ``solutions/``, the homework, the
autograder and the lectures cite is one of them (``tests/course/test_notes.py``). ``build.py`` turns the
chapters into a set of HTML pages (``mbd notes``, ``make notes``).
"""

from __future__ import annotations

import re
from pathlib import Path

NOTES = Path(__file__).resolve().parent
TAG = re.compile(r"\\tag\{(\d+\.\d+)\}")
"""An equation label in a chapter's display math: $$ ... \\tag{3.17} $$."""


def chapters() -> list[Path]:
    """The chapter notebooks in order."""
    return sorted(NOTES.glob("ch[0-9][0-9]_*.ipynb"))


def chapter_number(path: Path) -> int:
    """Chapter N of ``chNN_name.ipynb``."""
    return int(path.name[2:4])


def markdown_sources(path: Path) -> list[str]:
    """The markdown cells of a notebook, as text."""
    import nbformat

    return [cell.source for cell in nbformat.read(path, as_version=4).cells if cell.cell_type == "markdown"]


def equation_labels(path: Path) -> list[str]:
    """The equation numbers a chapter labels, in the order they appear."""
    return [label for source in markdown_sources(path) for label in TAG.findall(source)]


def section_numbers(path: Path) -> list[str]:
    """The numbered sections of a chapter: headings '## N.M title'."""
    return [m.group(1) for source in markdown_sources(path) for m in re.finditer(r"^##\s+(\d+\.\d+)\s", source, re.M)]
