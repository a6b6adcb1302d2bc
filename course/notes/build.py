"""Build the course notes as HTML: every chapter executed (optional) and exported, with an index page.

    python -m course.notes.build [--out build/notes] [--no-execute]      (also: mbd notes, make notes)

Each chapter becomes ``chNN_name.html``; every labelled equation gets an anchor ``#eq-N.M``, and
``index.html`` lists the chapters and every equation with a link to it. A chapter's mechanism views play in its
page (``solutions.viewer.embed_views``: plotly.js beside the pages, nothing fetched from the network). Chapters
are executed in ``course/notes`` (their code reads ``../models``), headless, before export.
"""

from __future__ import annotations

import argparse
import html
import os
import sys
from pathlib import Path

from . import NOTES, TAG, chapters

DEFAULT_OUT = Path("build") / "notes"


def _title(nb) -> str:
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            for line in cell.source.splitlines():
                if line.startswith("# "):
                    return line[2:].strip()
    return "untitled"


def _anchor_equations(nb) -> list[str]:
    """Put an HTML anchor ``eq-N.M`` just before each labelled equation's display block (``$$ ... \\tag{N.M}``),
    so that a link lands on the equation, not on the top of its cell; return the labels."""
    labels = []
    for cell in nb.cells:
        if cell.cell_type == "markdown" and TAG.search(cell.source):
            cell.source, found = anchored(cell.source)
            labels.extend(found)
    return labels


def anchored(source: str) -> tuple[str, list[str]]:
    """``source`` with ``<a id="eq-N.M"></a>`` just before the ``$$`` that opens the display
    holding ``\\tag{N.M}`` (before the tag itself when no ``$$`` opens it); and the labels, in order.
    A display whose ``$$`` starts a line keeps it there, the anchor in a paragraph of its own before it: the
    markdown parser reads a display as a block only when its ``$$`` starts the line, and a display read as
    text ends in a ``$$`` that opens a block with the next display's, swallowing what lies between."""
    pieces, labels, done = [], [], 0
    for match in TAG.finditer(source):
        label = match.group(1)
        opening = source.rfind("$$", done, match.start())
        place = opening if opening >= 0 and source.count("$$", done, opening) % 2 == 0 else match.start()
        own_line = place == opening and (place == 0 or source[place - 1] == "\n")
        pieces += [source[done:place], f'<a id="eq-{label}"></a>' + ("\n\n" if own_line else "")]
        labels.append(label)
        done = place
    return "".join(pieces) + source[done:], labels


PLOTLY = "plotly.min.js"
"""plotly.js, written once beside the pages that show a mechanism's motion (the plotly wheel's copy: offline)."""


def execute_notebook(nb, folder: Path, timeout: int = 600) -> None:
    """Run every cell of ``nb`` in ``folder`` (a fresh python3 kernel); an error stops the build."""
    from nbclient import NotebookClient

    environment = dict(os.environ, MPLBACKEND="module://matplotlib_inline.backend_inline")
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3", resources={"metadata": {"path": str(folder)}})
    client.execute(env=environment)


def build_notes(out: Path = DEFAULT_OUT, execute: bool = True, paths: list[Path] | None = None) -> Path:
    """Export the chapters (``paths``, default all) to ``out``; return the index page."""
    import nbformat
    from nbconvert import HTMLExporter

    from solutions.viewer import embed_views, plotly_js

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    exporter = HTMLExporter(template_name="lab")
    rows, equations = [], []
    for path in paths if paths is not None else chapters():
        nb = nbformat.read(path, as_version=4)
        if execute:
            execute_notebook(nb, NOTES)
        title = _title(nb)
        target = path.with_suffix(".html").name
        if embed_views(nb, f'<script src="{PLOTLY}"></script>', f"{path.stem}-view"):  # plotly.js beside the pages
            (out / PLOTLY).write_text(plotly_js(), encoding="utf-8")
        for label in _anchor_equations(nb):
            equations.append((label, target))
        body, _ = exporter.from_notebook_node(nb, resources={"metadata": {"name": title}})
        (out / target).write_text(body, encoding="utf-8")
        rows.append(f'<li><a href="{target}">{html.escape(title)}</a></li>')
    links = " ".join(f'<a href="{target}#eq-{label}">({label})</a>' for label, target in equations)
    index = out / "index.html"
    index.write_text(
        "<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>Course notes</title></head><body>\n"
        "<h1>Computational multibody dynamics: course notes</h1>\n"
        f"<ol>\n{chr(10).join(rows)}\n</ol>\n<h2>Equations</h2>\n<p>{links}</p>\n</body></html>\n",
        encoding="utf-8",
    )
    return index


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="mbd notes", description="Build the course notes as HTML pages.")
    parser.add_argument("--out", default=str(DEFAULT_OUT), help=f"output folder (default: {DEFAULT_OUT})")
    parser.add_argument("--no-execute", action="store_true", help="export without running the chapters' code")
    args = parser.parse_args(argv)
    index = build_notes(Path(args.out), execute=not args.no_execute)
    print(f"course notes: {index} ({len(chapters())} chapters)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
