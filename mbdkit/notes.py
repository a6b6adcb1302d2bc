"""The course notes' equations a check cites, as links into the kit's notes and as rendered equations.

Every message of the checker, every stub of the student package and ``mbd todo`` cite the notes as "eq. 3.17".
A kit holds the notes as a site (``notes/`` beside ``modules/``: ``notes/ch03_planar_constraints.html#eq-3.17``
lands on eq. 3.17) and, in the checker's data, the TeX of every labelled equation (``equations.json``, written
by ``mbd release``). So a failed check in a notebook shows the equations it cites, rendered by JupyterLab, each
with its link into the notes; in a terminal, each cited equation's page as a file URL a terminal opens.
"""

from __future__ import annotations

import html
import json
import re
from functools import cache
from pathlib import Path

from .paths import COURSE_DATA, data_dir

CITATION = re.compile(r"\b(eqs?\.\s*)(\d+\.\d+(?:\s*(?:,|-|–|and|to)\s*\d+\.\d+)*)")
"""'eq. 3.17', 'eqs. 4.5, 4.6', 'eq. 2.1-2.5': the word, then the numbers it names (a range names its two ends)."""
LABEL = re.compile(r"\d+\.\d+")
NOTES = "notes"
"""The kit's folder of the notes' site."""
COURSE_NOTES = COURSE_DATA.parent / "course" / "notes"
"""The course's notes (chapter notebooks), where the checker runs from the course repository (``mbd grade``)."""


@cache
def equations() -> dict[str, tuple[str, str]]:
    """{label: (page of the notes' site, TeX)} of the kit's ``equations.json``; in the course repository (no such
    file), the labels and pages read off the chapters' files, without their TeX."""
    path = data_dir() / "equations.json"
    if path.is_file():
        return {label: (page, tex) for label, (page, tex) in json.loads(path.read_text(encoding="utf-8")).items()}
    chapters = sorted(COURSE_NOTES.glob("ch[0-9][0-9]_*.ipynb"))
    return {
        label: (f"{p.stem}.html", "") for p in chapters for label in re.findall(r"tag\{(\d+\.\d+)\}", p.read_text())
    }


def cited(text: str) -> list[str]:
    """The equation labels ``text`` cites, in order, once each, that the notes hold."""
    labels = [n for _, group in CITATION.findall(text) for n in LABEL.findall(group)]
    known = equations()
    return [label for label in dict.fromkeys(labels) if label in known]


def link(label: str) -> str:
    """The link into the kit's notes that lands on eq. ``label``, relative to the kit's folder."""
    return f"{NOTES}/{equations()[label][0]}#eq-{label}"


def markdown(text: str, folder: Path) -> str | None:
    """Markdown of the equations ``text`` cites, each rendered and linked into the notes (None: none cited, or
    no notes beside the package in ``folder``)."""
    labels = [label for label in cited(text) if equations()[label][1]]
    if not labels or not (Path(folder) / NOTES).is_dir():
        return None
    lines = ["**The equations these messages cite** (course notes):", ""]
    for label in labels:
        lines += [f"[eq. {label}]({link(label)}): $$ {equations()[label][1]} \\tag{{{label}}} $$", ""]
    return "\n".join(lines)


def link_citations(text: str, linked, known) -> str:
    """``text`` with each number of each citation ('eq. 3.17', 'eqs. 4.5, 4.6') that ``known`` holds replaced by
    ``linked(label)``; the rest as it is."""

    def numbers(match: re.Match) -> str:
        each = LABEL.sub(lambda m: linked(m.group(0)) if m.group(0) in known else m.group(0), match.group(2))
        return match.group(1) + each

    return CITATION.sub(numbers, text)


def html_links(escaped: str) -> str:
    """HTML text ``escaped`` with each 'eq. N.M' it cites a link into ``notes/`` (a page kept beside the kit's
    notes: the feedback a student gets, saved in the homework's folder)."""
    return link_citations(escaped, lambda label: f'<a href="{html.escape(link(label))}">{label}</a>', equations())


def terminal_lines(text: str, folder: Path) -> list[str]:
    """One line per equation ``text`` cites: its label and the file URL of its place in the kit's notes."""
    notes = Path(folder).resolve() / NOTES
    if not notes.is_dir():
        return []
    return [f"  eq. {label}: {(notes / equations()[label][0]).as_uri()}#eq-{label}" for label in cited(text)]
