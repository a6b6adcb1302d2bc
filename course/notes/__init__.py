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


DISPLAY = re.compile(r"\$\$(.*?)\$\$", re.S)
"""A display equation of a chapter's markdown."""


def equation_texts(path: Path) -> dict[str, str]:
    """{label: the TeX of the display that holds ``\\tag{label}``, tag left out} of a chapter."""
    texts = {}
    for source in markdown_sources(path):
        for display in DISPLAY.finditer(source):
            for label in TAG.findall(display.group(1)):
                texts[label] = " ".join(TAG.sub("", display.group(1)).split())
    return texts


LITERAL = re.compile(r"(`[^`]*`|\$\$.*?\$\$|\$[^$]*\$)", re.S)
"""Code spans and math, left as they are."""


def linked(source: str, pages: dict[str, str]) -> str:
    """Markdown ``source`` with each 'eq. N.M' of its prose a link to ``pages[N.M]#eq-N.M`` (``pages``: the
    label's page in the notes' site as seen from the notebook, e.g. 'notes/ch03_planar_constraints.html');
    code spans, math and labels the notes do not hold are left as they are (``mbdkit.notes.link_citations``,
    what the checker's messages are linked by)."""
    from mbdkit.notes import link_citations

    def link(label: str) -> str:
        return f"[{label}]({pages[label]}#eq-{label})"

    parts = LITERAL.split(source)
    return "".join(part if k % 2 else link_citations(part, link, pages) for k, part in enumerate(parts))


def note_pages(folder: str = "notes") -> dict[str, str]:
    """{label: its chapter's page in the site ``folder``} for every labelled equation of the notes."""
    return {label: f"{folder}/{path.stem}.html" for path in chapters() for label in equation_labels(path)}
