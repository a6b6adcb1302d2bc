"""The course notes resolve every citation: each `eq. N.M` / `(N.M)` cited in the course is a labelled
equation of course/notes, each `sec. N.M` a numbered section, each `ch. N` a chapter; the notes build as HTML.

The notebooks themselves are executed with the lectures in test_notebooks.py.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from course.notes import chapter_number, chapters, equation_labels, markdown_sources, section_numbers
from course.release.generator import REPO

CITING = ("solutions", "modules", "assignments", "autograder", "mbdkit", "course")
SUFFIXES = {".py", ".ipynb", ".md", ".toml", ".yaml"}
NUMBER = r"\d+\.\d+"
EQUATION = re.compile(rf"\b(?:eqs?\.|equations?)\s*\(?({NUMBER}(?:\s*(?:,|-|–|to|and)\s*{NUMBER})*)", re.IGNORECASE)
"""eq. 3.17 / eqs. 4.5, 4.6 / eq. 6.50-6.53 / equation (5.29) / eq. 9.14 to 9.19"""
PARENTHESIS = re.compile(rf"(?<![\w.])\(({NUMBER})\)")
"""(4.8) in prose: markdown cells and .md files only (in code, (0.0) is a number)"""
SECTION = re.compile(rf"\bsec\.\s*({NUMBER})", re.IGNORECASE)
CHAPTER = re.compile(r"\b(?:ch\.|chapters?)\s*(\d+)\b", re.IGNORECASE)
TEXTBOOK = re.compile(r"\b(?:1[89]\d\d|20\d\d)\b|Solving ODEs|Golub")
NOTES = re.compile(r"course notes|\bnotes\b")


def of_a_textbook(before: str) -> bool:
    """A sec. or ch. after a reference such as 'Nikravesh 1988, sec. 13.4' or 'Haug (1989) ch. 6' in the same
    clause (line, up to a semicolon), with no 'course notes' between them, is the textbook's, not the notes'."""
    line = re.split(r"[\n;]", before)[-1]
    book = [m.end() for m in TEXTBOOK.finditer(line)]
    notes = [m.end() for m in NOTES.finditer(line)]
    return bool(book) and (not notes or book[-1] > notes[-1])


def expand(group: str) -> list[str]:
    """'6.50-6.53' -> 6.50, 6.51, 6.52, 6.53; '8.12, 8.14' -> both; '9.14 to 9.19' -> the range."""
    numbers = re.findall(NUMBER, group)
    out = []
    for part in re.split(r"\s*(?:,|and)\s*", group):
        ends = re.findall(NUMBER, part)
        if len(ends) == 2 and ends[0].split(".")[0] == ends[1].split(".")[0]:
            chapter, low, high = ends[0].split(".")[0], int(ends[0].split(".")[1]), int(ends[1].split(".")[1])
            out.extend(f"{chapter}.{k}" for k in range(low, high + 1))
        else:
            out.extend(ends)
    return out or numbers


def texts(path: Path) -> list[tuple[str, bool]]:
    """(text, is prose) pieces of a file: a notebook's cells, or the whole file."""
    if path.suffix == ".ipynb":
        cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
        return [("".join(c["source"]), c["cell_type"] == "markdown") for c in cells]
    return [(path.read_text(encoding="utf-8", errors="replace"), path.suffix == ".md")]


def citations(text: str, prose: bool) -> dict[str, set[str]]:
    """{'equation' | 'section' | 'chapter': numbers cited} in one piece of text."""
    found: dict[str, set[str]] = {"equation": set(), "section": set(), "chapter": set()}
    for m in EQUATION.finditer(text):
        found["equation"].update(expand(m.group(1)))
    if prose:
        found["equation"].update(PARENTHESIS.findall(text))
    for kind, pattern in (("section", SECTION), ("chapter", CHAPTER)):
        for m in pattern.finditer(text):
            if not of_a_textbook(text[max(0, m.start() - 200) : m.start()]):
                found[kind].add(m.group(1))
    return found


def course_files(root: Path = REPO) -> list[Path]:
    files = []
    for top in CITING:
        for path in sorted((root / top).rglob("*")):
            if path.suffix in SUFFIXES and path.is_file() and ".ipynb_checkpoints" not in path.parts:
                files.append(path)
    return files


def all_citations(root: Path = REPO) -> dict[str, dict[str, set[str]]]:
    """{kind: {number: files citing it}} over the whole course (the repository at ``root``)."""
    cited: dict[str, dict[str, set[str]]] = {"equation": {}, "section": {}, "chapter": {}}
    for path in course_files(root):
        for text, prose in texts(path):
            for kind, numbers in citations(text, prose).items():
                for number in numbers:
                    cited[kind].setdefault(number, set()).add(str(path.relative_to(root)))
    return cited


@pytest.fixture(scope="module")
def cited():
    return all_citations()


# -- the collector itself: it must find what it is meant to find ------------------------------------------------
def test_the_collector_finds_every_form_of_citation():
    text = "Psi (course notes, eq. 3.17); eqs. 4.5, 4.6; eq. 6.50-6.53; equation (5.29); eq. 9.14 to 9.19; (0.0)"
    assert citations(text, prose=False)["equation"] == {
        "3.17", "4.5", "4.6", "6.50", "6.51", "6.52", "6.53", "5.29", "9.14", "9.15", "9.16", "9.17", "9.18", "9.19"
    }  # fmt: skip
    assert citations("the Newton step (4.8) and 1.5 (2.0)", prose=True)["equation"] == {"4.8", "2.0"}
    assert citations("x = f(0.0) + g(1.5)", prose=False)["equation"] == set()
    sections = citations("course notes, sec. 5.6; Nikravesh 1988, sec. 13.4; chapter 5; ch. 3", prose=False)
    assert sections["section"] == {"5.6"} and sections["chapter"] == {"5", "3"}
    books = citations("Reading: Haug (1989) ch. 11 (sec. 11.1-11.4); Haug 1989, then course notes, sec. 9.2", False)
    assert books["section"] == {"9.2"} and books["chapter"] == set()


def test_a_citation_of_a_missing_equation_is_reported_with_its_file(tmp_path):
    (tmp_path / "solutions").mkdir()
    (tmp_path / "solutions" / "x.py").write_text('"""Psi (eq. 3.17) and a wrong one (eq. 3.99)."""\n')
    found = all_citations(tmp_path)["equation"]
    assert found == {"3.17": {"solutions/x.py"}, "3.99": {"solutions/x.py"}}
    assert unresolved(found, labelled()) == {"3.99": ["solutions/x.py"]}


# -- the notes -----------------------------------------------------------------------------------------------------
def labelled() -> set[str]:
    return {label for path in chapters() for label in equation_labels(path)}


def unresolved(cited_equations: dict[str, set[str]], labels: set[str]) -> dict[str, list[str]]:
    return {number: sorted(files) for number, files in sorted(cited_equations.items()) if number not in labels}


def test_there_is_one_notes_chapter_per_number_from_1_to_10():
    assert [chapter_number(path) for path in chapters()] == list(range(1, 11))


@pytest.mark.parametrize("path", chapters(), ids=lambda p: p.stem)
def test_a_chapter_numbers_its_equations_in_order_within_its_chapter(path):
    labels = equation_labels(path)
    assert labels, f"{path.name} labels no equation"
    assert all(int(label.split(".")[0]) == chapter_number(path) for label in labels), labels
    minor = [int(label.split(".")[1]) for label in labels]
    assert minor == sorted(minor) and len(set(minor)) == len(minor), f"{path.name}: {labels}"
    markdown = "\n".join(markdown_sources(path))
    assert re.search(r"Haug|Nikravesh|Shabana|García de Jalón", markdown), "a chapter cites the syllabus's textbooks"
    assert "## Exercises" in markdown or chapter_number(path) == 1


def test_every_equation_the_course_cites_is_labelled_in_the_notes(cited):
    assert len(cited["equation"]) > 100  # the collector did find the course's citations
    assert unresolved(cited["equation"], labelled()) == {}


def test_every_section_and_chapter_the_course_cites_exists(cited):
    sections = {number for path in chapters() for number in section_numbers(path)}
    assert {"5.6", "6.5", "9.2"} <= set(cited["section"])
    assert {n: sorted(f) for n, f in cited["section"].items() if n not in sections} == {}
    numbers = {str(chapter_number(path)) for path in chapters()}
    assert {n: sorted(f) for n, f in cited["chapter"].items() if n not in numbers} == {}


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The chapters and lecture 1 built as ``mbd notes`` builds the site, as written (not executed)."""
    from course.notes.build import build_notes, lectures

    out = tmp_path_factory.mktemp("notes") / "site"
    build_notes(out, execute=False, paths=chapters(), lecture_paths=lectures()[:1])
    return out


def test_the_notes_build_as_a_site_with_an_anchor_for_every_equation(site):
    few = chapters()[2:4]
    page = (site / few[0].with_suffix(".html").name).read_text()
    assert "<html" in page and 'id="eq-3.17"' in page and "\\tag{3.17}" in page
    anchor, tag = page.index('id="eq-3.17"'), page.index("\\tag{3.17}")
    assert page.index("\\tag{3.13}") < anchor < tag and "\\tag{" not in page[anchor:tag]  # the link lands on it
    assert "\\begin{split}" not in page  # a display holding \\ is given as written (a tag inside split is an error)
    index = (site / "index.html").read_text()
    for path in few:
        for label in equation_labels(path):
            assert f'href="{path.stem}.html#eq-{label}"' in index
    row = re.search(r'#eq-3\.17">\(3\.17\)</a></td><td>([^<]*)</td>', index)
    assert row and row.group(1).startswith("3.3 "), "the index gives each equation's section"
    assert 'href="L01_planar_kinematics.html"' in index and (site / "L01_planar_kinematics.html").exists()
    assert (site / "search.html").exists() and "Computational" in (site / "searchindex.js").read_text()


def test_the_site_asks_nothing_of_the_network(site):
    """Every script and style a page loads is a file of the site; MathJax is the wheel's copy in _static."""
    from course.notes.build import write_mathjax

    page = (site / "ch03_planar_constraints.html").read_text()
    sources = re.findall(r'<(?:script|link)[^>]*(?:src|href)="([^"]+)"', page)
    assert any(src.startswith("_static/mathjax/MathJax.js?config=") for src in sources)
    assert [src for src in sources if "://" in src or src.startswith("//")] == []
    for src in sources:
        assert (site / src.split("?")[0].split("#")[0]).exists(), src
    assert "cdn" not in page.lower() and "window.MathJax =" not in page  # no MathJax 3 object to stop MathJax 2
    notice = page.index("<noscript>")  # where scripts are off (JupyterLab's viewer): what to do, first thing
    assert page.index("<body") < notice < page.index("sphinxsidebar") and "Trust HTML" in page[notice:]
    size = write_mathjax(site.parent / "mathjax")
    assert 1e6 < size < 4e6, size  # what loads (no SVG output, no translations): a kit carries it


def test_a_kits_pages_cite_the_students_package(tmp_path):
    """In a kit, solutions/X becomes the package's modules/X, a file the student has, or names the reference
    solver's file the kit does not hold; code imports from the student's package."""
    import nbformat

    from course.notes.build import for_students

    modules = tmp_path / "modules"
    (modules / "planar").mkdir(parents=True)
    (modules / "planar" / "bodies.py").write_text("")
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_markdown_cell(
            "Code: `solutions/planar/bodies.py`, `solutions/compiled/tree.py`, solutions/. Run "
            "`mbd run course/models/four_bar.yaml` (tests/solutions/test_x.py; course/exam/)."
        ),
        nbformat.v4.new_code_cell("from solutions.planar.bodies import rotation\nimport solutions.linalg as s"),
    ]
    for_students(nb, modules)
    assert nb.cells[0].source == (
        "Code: `modules/planar/bodies.py`, `the reference solver's compiled/tree.py`, modules/. Run "
        "`mbd run models/four_bar.yaml` (the course's test test_x.py (not in the kit); the course's exam bank (not "
        "in the kit))."
    )
    assert nb.cells[1].source == "from modules.planar.bodies import rotation\nimport modules.linalg as s"


def test_kits_share_one_site_per_content_of_the_sources(tmp_path, monkeypatch, capsys):
    """kit_notes builds the site once for given sources (a class's releases, the test run's): executed unless
    MBD_KIT_NOTES=as-written, an executed one taken whenever it is there; new sources build anew, the old go."""
    from course.notes import build

    built = []

    def fake_build(out, execute, modules):
        built.append((out.name, execute))
        out.mkdir(parents=True)
        (out / "index.html").write_text("site")

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv("MBD_KIT_NOTES", "as-written")
    monkeypatch.setattr(build, "build_notes", fake_build)
    monkeypatch.setattr(build, "sources_digest", lambda execute: f"v1-{execute}")
    first, executed = build.kit_notes()
    assert executed is False and first.name == "v1-False" and build.kit_notes() == (first, False)
    assert built == [("v1-False", False)] and capsys.readouterr().err == ""
    cache = tmp_path / "mbd-course" / "kit-notes"
    assert build.kit_notes(execute=True) == (cache / "v1-True", True)
    assert build.kit_notes() == (cache / "v1-True", True)  # the executed one, whenever it is there
    monkeypatch.setattr(build, "sources_digest", lambda execute: f"v2-{execute}")
    assert build.kit_notes()[0].name == "v2-False" and not first.exists()
    monkeypatch.delenv("MBD_KIT_NOTES")
    assert build.kit_notes() == (cache / "v2-True", True)  # a release as users run it: executed, once
    assert "executed (about a minute" in capsys.readouterr().err
    assert built == [("v1-False", False), ("v1-True", True), ("v2-False", False), ("v2-True", True)]


def test_the_sources_digest_follows_every_page_and_the_package():
    from course.notes.build import sources_digest

    assert sources_digest(True) != sources_digest(False)
    assert len(sources_digest(False)) == 64 and sources_digest(False) == sources_digest(False)


def test_a_chapters_mechanism_views_play_in_its_page(tmp_path):
    """A view output (``solutions.viewer``, which nbconvert does not draw) becomes the page's own player: an element
    and a script per view, plotly.js once from beside the pages (offline); nothing in a figure's text ends the
    script. (Played in chromium: tests/solutions/test_viewer_browser.py.)"""
    import nbformat

    from course.notes.build import PLOTLY, build_notes
    from solutions.io.model import load_model
    from solutions.viewer import MIME, model_view

    view = model_view(load_model(REPO / "course" / "models" / "slider_crank.yaml"), title="a </script><b> & title")
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("# Chapter 9. Views"), nbformat.v4.new_code_cell("view")]
    nb.cells[1].outputs = [nbformat.v4.new_output("display_data", data=view._repr_mimebundle_())] * 2
    path = tmp_path / "ch09_views.ipynb"
    nbformat.write(nb, path)
    build_notes(tmp_path / "out", execute=False, paths=[path])
    page = (tmp_path / "out" / "ch09_views.html").read_text()
    loader = f'<script src="_static/{PLOTLY}"></script>'
    assert page.count(loader) == 1 and (tmp_path / "out" / "_static" / PLOTLY).stat().st_size > 1e6
    assert page.count('class="mbd-view"') == 2 and 'id="ch09_views-view-2"' in page
    assert "a </script>" not in page and "a \\u003c/script\\u003e\\u003cb\\u003e \\u0026 title" in page
    kept = nbformat.read(path, as_version=4).cells[1].outputs[0]["data"]
    assert MIME in kept and "text/html" not in kept  # the chapter's file as it was


def test_an_anchor_sits_before_the_display_that_holds_its_tag():
    from course.notes.build import anchored

    source = "# Ch. 3\n\nText $$ p \\tag{3.1} $$ and $x$, $$y$$, then\n$$\\begin{aligned} c \\end{aligned} \\tag{3.2}$$"
    out, labels = anchored(source)
    assert labels == ["3.1", "3.2"]
    # mid-line: just before its $$; at a line's start: in a paragraph of its own, the $$ still opening the line
    assert out == source.replace("$$ p", '<a id="eq-3.1"></a>$$ p').replace(
        "$$\\begin", '<a id="eq-3.2"></a>\n\n$$\\begin'
    )


@pytest.mark.parametrize("path", chapters(), ids=lambda path: path.stem)
def test_every_heading_and_display_of_a_chapter_is_on_its_page(site, path):
    """The page of each chapter, anchors and all, has every heading and every display equation of its markdown
    (an anchor in front of a display's line once made a parser read the display as text, and its closing $$ opened
    a block that swallowed the headings up to the next display: ch. 3 showed 3 of its 9 section headings)."""
    markdown = "\n".join(markdown_sources(path))
    headings = len(re.findall(r"^#{1,3} ", markdown, flags=re.M))
    displays = markdown.count("$$") // 2
    page = (site / path.with_suffix(".html").name).read_text()
    page = page[page.index('role="main"') : page.index('class="footer"')]  # the chapter, not the sidebar
    assert len(re.findall(r"<h[123][ >]", page)) == headings
    assert page.count('<div class="math notranslate nohighlight">') == displays


def test_a_statement_links_each_equation_it_cites_into_the_notes():
    from course.notes import linked, note_pages

    pages = note_pages()
    text = "Write eq. 3.17 (see `eq. 3.17` and $eq. 3.17$); eqs. 4.5, 4.6; eq. 2.1-2.5; eq. 99.9."
    assert linked(text, pages) == (
        "Write eq. [3.17](notes/ch03_planar_constraints.html#eq-3.17) (see `eq. 3.17` and $eq. 3.17$); "
        "eqs. [4.5](notes/ch04_assembly_kinematic_analysis.html#eq-4.5), "
        "[4.6](notes/ch04_assembly_kinematic_analysis.html#eq-4.6); "
        "eq. [2.1](notes/ch02_planar_body_kinematics.html#eq-2.1)-"
        "[2.5](notes/ch02_planar_body_kinematics.html#eq-2.5); "
        "eq. 99.9."
    )


def test_executing_a_page_leaves_no_event_loop_open(tmp_path):
    """``build.execute_notebook`` (every chapter of a kit's notes, at ``mbd release``) closes the event loop it ran
    the kernel on: nbclient's ``execute`` left one open in the calling thread, which Python later reported as an
    unclosed-loop ResourceWarning in whatever test ran next on that worker."""
    import asyncio
    import gc

    import nbformat

    from course.notes import build

    def open_loops() -> int:
        gc.collect()
        return sum(isinstance(o, asyncio.AbstractEventLoop) and not o.is_closed() for o in gc.get_objects())

    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell("6 * 7")])
    before = open_loops()
    build.execute_notebook(nb, tmp_path)
    assert nb.cells[0].outputs[0]["data"]["text/plain"] == "42"
    assert open_loops() == before
