"""Build the course notes as a documentation site: the chapters and the lectures as pages, math offline, search.

    python -m course.notes.build [--out build/notes] [--no-execute]      (also: mbd notes, make notes)

Each notebook (``course/notes/chNN_*.ipynb``, ``course/lectures/LNN_*.ipynb``) is executed (optional; chapters in
``course/notes``, lectures in ``course/lectures``, whose code reads ``../models``), given an anchor ``eq-N.M`` just
before each labelled equation, and staged with an index page; Sphinx with MyST-NB (``conf.py``) makes the site:
``index.html`` (the contents and every equation with the section it is in), a page per chapter and lecture
(``chNN_name.html``, ``LNN_name.html``), ``search.html``. Nothing in it is fetched from the network: MathJax 2.7 is
copied from the jupyter-server-mathjax wheel into ``_static/mathjax`` (``write_mathjax``), plotly.js (a chapter's
mechanism views, ``solutions.viewer.embed_views``) into ``_static``. A link to ``chNN_name.html#eq-N.M`` lands on
the equation.
"""

from __future__ import annotations

import argparse
import fcntl
import hashlib
import html
import io
import os
import re
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path

from . import NOTES, TAG, chapters

DEFAULT_OUT = Path("build") / "notes"
LECTURES = NOTES.parent / "lectures"
PLOTLY = "plotly.min.js"
"""plotly.js, written once into the site's _static when a page shows a mechanism's motion (the plotly wheel's copy)."""


def lectures() -> list[Path]:
    """The lecture notebooks in order."""
    return sorted(LECTURES.glob("L[0-9][0-9]_*.ipynb"))


@dataclass
class Page:
    """A staged notebook: its page name, title and labelled equations with the section each is in."""

    name: str
    title: str
    equations: list[tuple[str, str]] = field(default_factory=list)


def _title(nb) -> str:
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            for line in cell.source.splitlines():
                if line.startswith("# "):
                    return line[2:].strip()
    return "untitled"


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


def _anchor_equations(nb) -> list[tuple[str, str]]:
    """Anchor every labelled equation of ``nb`` (``anchored``); return (label, the heading of its section)."""
    found, section = [], ""
    for cell in nb.cells:
        if cell.cell_type != "markdown":
            continue
        pieces = re.split(r"^(#{1,3} .*)$", cell.source, flags=re.M)  # text, heading, text, heading, ...
        for k, piece in enumerate(pieces):
            if k % 2:
                section = piece.lstrip("#").strip()
            else:
                found += [(label, section) for label in TAG.findall(piece)]
        if TAG.search(cell.source):
            cell.source, _ = anchored(cell.source)
    return found


CITED_FILE = re.compile(r"\bsolutions((?:/[A-Za-z0-9_.]+)*/?)")
"""A file or folder of the reference solver cited in a page: solutions/planar/bodies.py, solutions/io/."""
FOR_STUDENTS = (
    (re.compile(r"\bcourse/models\b"), "models"),
    (re.compile(r"\btests/[A-Za-z0-9_/]*?([A-Za-z0-9_]+\.py)"), r"the course's test \1 (not in the kit)"),
    (re.compile(r"\bcourse/exam/"), "the course's exam bank (not in the kit)"),
)
"""What else a page cites that a kit holds elsewhere (the example models: ``models/``) or not at all."""


def for_students(nb, modules: Path) -> None:
    """Make ``nb`` cite what a student has: ``solutions/X`` becomes ``modules/X`` (the student package's file of
    the same name) where the kit's ``modules/`` holds X, and "the reference solver's X" where it does not (the
    compiled engine); ``FOR_STUDENTS`` the rest; code cells use the student's package and the kit's models."""

    def cited(match: re.Match) -> str:
        rest = match.group(1)
        return f"modules{rest}" if (modules / rest.strip("/")).exists() else f"the reference solver's {rest.strip('/')}"

    for cell in nb.cells:
        for pattern, replacement in FOR_STUDENTS:
            cell.source = pattern.sub(replacement, cell.source)
        if cell.cell_type == "markdown":
            cell.source = CITED_FILE.sub(cited, cell.source)
        elif cell.cell_type == "code":
            cell.source = re.sub(r"\bsolutions\b", "modules", cell.source)


def execute_notebook(nb, folder: Path, timeout: int = 600) -> None:
    """Run every cell of ``nb`` in ``folder`` (a fresh python3 kernel); an error stops the build. Outside a running
    event loop (a command, a test) on a loop of its own that ``asyncio.run`` closes afterwards: nbclient's ``execute``
    would leave one open in the calling thread, which Python reports as unclosed when it is collected."""
    import asyncio

    from nbclient import NotebookClient

    environment = dict(os.environ, MPLBACKEND="module://matplotlib_inline.backend_inline")
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3", resources={"metadata": {"path": str(folder)}})
    try:
        asyncio.get_running_loop()
    except RuntimeError:  # no loop runs in this thread
        asyncio.run(client.async_execute(env=environment))
    else:  # inside a running loop (a notebook): nbclient's own way
        client.execute(env=environment)


def stage_notebook(path: Path, stage: Path, execute: bool, modules: Path | None = None) -> Page:
    """Write ``path`` into ``stage`` as the site will show it (executed in its folder, equations anchored, views
    playable; for students, ``for_students`` with their package's folder ``modules``); return its page."""
    import nbformat

    from solutions.viewer import embed_views, plotly_js

    nb = nbformat.read(path, as_version=4)
    if execute:
        execute_notebook(nb, path.parent)
    if embed_views(nb, f'<script src="_static/{PLOTLY}"></script>', f"{path.stem}-view"):
        (stage / "_static" / PLOTLY).write_text(plotly_js(), encoding="utf-8")
    page = Page(path.stem, _title(nb), _anchor_equations(nb))
    if modules is not None:
        for_students(nb, modules)
    nb.metadata.setdefault("language_info", {"name": "python"})  # the code cells' highlighting
    nbformat.write(nb, stage / path.name)
    return page


def write_mathjax(target: Path) -> int:
    """Write MathJax into ``target``: the files of the jupyter-server-mathjax wheel a page loads, the same set
    nbgrader's feedback pages carry (``autograder.nbpages.mathjax_files``); return its size in bytes."""
    from autograder.nbpages import mathjax_files

    files = mathjax_files()
    for name, data in files.items():
        (target / name).parent.mkdir(parents=True, exist_ok=True)
        (target / name).write_bytes(data)
    return sum(len(data) for data in files.values())


def index_page(chapter_pages: list[Page], lecture_pages: list[Page]) -> str:
    """The site's front page (MyST): the contents, then every equation by chapter with its section, linked."""
    lines = ["# Computational multibody dynamics: course notes", ""]
    lines += [
        "The chapters carry the theory and number its equations; the lectures work through it with the solver.",
        "Every *eq. N.M* cited in the homework, its stubs and its checks is listed below.",
        "",
    ]
    for caption, pages in (("Chapters", chapter_pages), ("Lectures", lecture_pages)):
        if pages:
            lines += ["```{toctree}", f":caption: {caption}", ":maxdepth: 1", "", *(p.name for p in pages), "```", ""]
    rows = []
    for page in chapter_pages:
        if not page.equations:
            continue
        rows.append(f'<h3><a href="{page.name}.html">{html.escape(page.title)}</a></h3>\n<table class="equations">')
        for label, section in page.equations:
            link = f'<a href="{page.name}.html#eq-{label}">({label})</a>'
            rows.append(f"<tr><td>{link}</td><td>{html.escape(section)}</td></tr>")
        rows.append("</table>")
    if rows:
        lines += ["## Equations", "", "```{raw} html", *rows, "```", ""]
    return "\n".join(lines)


def sphinx_build(stage: Path, out: Path) -> None:
    """Sphinx's HTML build of ``stage`` into ``out`` with ``conf.py``; a warning stops it (SphinxWarning)."""
    from sphinx.application import Sphinx
    from sphinx.util.docutils import docutils_namespace, patch_docutils

    warnings = io.StringIO()
    with patch_docutils(NOTES), docutils_namespace():  # as sphinx-build: docutils' registries for this build only
        app = Sphinx(
            str(stage), str(NOTES), str(out), str(stage / ".doctrees"), "html",
            status=None, warning=warnings, freshenv=True, warningiserror=True,
            confoverrides={"html_static_path": [str(stage / "_static")]},  # conf.py's folder is not the stage
        )  # fmt: skip
        app.build()
    if app.statuscode:
        raise RuntimeError(f"the notes' site did not build:\n{warnings.getvalue()}")


def build_notes(
    out: Path = DEFAULT_OUT,
    execute: bool = True,
    paths: list[Path] | None = None,
    lecture_paths: list[Path] | None = None,
    modules: Path | None = None,
) -> Path:
    """Build the site of the chapters ``paths`` (default all) and the lectures ``lecture_paths`` (default all with
    all chapters, none with a choice of chapters) into ``out``; return its index page. ``modules``: the site of
    a student kit, whose pages cite that student package (``for_students``) instead of the reference solver."""
    out = Path(out).resolve()
    stage = out.parent / f".{out.name}-pages"
    shutil.rmtree(stage, ignore_errors=True)
    (stage / "_static").mkdir(parents=True)
    chapter_paths = chapters() if paths is None else list(paths)
    lecture_paths = (lectures() if paths is None else []) if lecture_paths is None else list(lecture_paths)
    chapter_pages = [stage_notebook(path, stage, execute, modules) for path in chapter_paths]
    lecture_pages = [stage_notebook(path, stage, execute, modules) for path in lecture_paths]
    (stage / "index.md").write_text(index_page(chapter_pages, lecture_pages), encoding="utf-8")
    write_mathjax(stage / "_static" / "mathjax")
    shutil.rmtree(out, ignore_errors=True)
    sphinx_build(stage, stage / "site")  # MyST-NB writes its outputs beside the build folder: in the stage
    shutil.move(stage / "site", out)
    shutil.rmtree(stage, ignore_errors=True)
    return out / "index.html"


MODULES = NOTES.parent.parent / "modules"
"""The student package of this course (generated from solutions/), whose files a kit's notes cite."""


def sources_digest(execute: bool) -> str:
    """SHA-256 of everything a kit's site is made of: the chapters, the lectures, this file, conf.py, the student
    package's files (the pages cite them) and whether the notebooks were executed."""
    digest = hashlib.sha256(b"executed" if execute else b"as written")
    for path in [*chapters(), *lectures(), NOTES / "build.py", NOTES / "conf.py", *sorted(MODULES.rglob("*.py"))]:
        digest.update(path.relative_to(NOTES.parent.parent).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def notes_cache() -> Path:
    """Where the kits' sites are kept: ``$XDG_CACHE_HOME/mbd-course/kit-notes`` (else ``~/.cache/...``)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "mbd-course" / "kit-notes"


AS_WRITTEN = "MBD_KIT_NOTES"
"""Set to ``as-written``, releases give kits the notes as written (text and equations, built in 4 s) where they
would execute every notebook first (figures and outputs, about a minute once per change of the notes): the
tests' and the demo's setting."""


def kit_notes(execute: bool | None = None) -> tuple[Path, bool]:
    """The notes' site a kit holds (pages citing the student package, ``for_students``) and whether its notebooks
    were executed. One site per content of the sources (``sources_digest``) in ``notes_cache()``, built once:
    the executed one (figures and outputs) whenever it is there; else, with ``execute`` None, the one
    ``$MBD_KIT_NOTES`` asks for (executed unless ``as-written``), built if missing, with a line on stderr when
    that takes a minute. Releases at once (tests, a class's homework) build it once: the first holds a lock."""
    if execute is None:
        execute = os.environ.get(AS_WRITTEN, "") != "as-written"
    root = notes_cache()
    root.mkdir(parents=True, exist_ok=True)
    with open(root / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        digests = {executed: sources_digest(executed) for executed in (True, False)}
        for executed in (True, execute):
            if (root / digests[executed] / "index.html").exists():
                return root / digests[executed], executed
        for old in root.iterdir():  # sites of earlier sources
            if old.is_dir() and old.name not in digests.values():
                shutil.rmtree(old, ignore_errors=True)
        folder = root / digests[execute]
        if execute:
            print(
                "building the course notes for the kits: every chapter and lecture executed (about a minute, once "
                f"per change of the notes; {AS_WRITTEN}=as-written builds them as written in seconds)",
                file=sys.stderr,
            )
        build_notes(folder, execute=execute, modules=MODULES)
        return folder, execute


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="mbd notes", description="Build the course notes as a site of HTML pages.")
    parser.add_argument("--out", default=str(DEFAULT_OUT), help=f"output folder (default: {DEFAULT_OUT})")
    parser.add_argument("--no-execute", action="store_true", help="build without running the notebooks' code")
    parser.add_argument("--kit", action="store_true", help="the site mbd release puts in every kit (cited: modules/)")
    args = parser.parse_args(argv)
    if args.kit:
        folder, _ = kit_notes(execute=not args.no_execute)
        index = folder / "index.html"
    else:
        index = build_notes(Path(args.out), execute=not args.no_execute)
    print(f"course notes: {index} ({len(chapters())} chapters, {len(lectures())} lectures; offline, search.html)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
