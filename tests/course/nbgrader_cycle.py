"""The whole nbgrader cycle, headless, for each homework (the tests of every homework: test_nbgrader_cycle_hwN.py
imports them with its HOMEWORK; hw1's own tests are there): generate, a submission in ``submitted/``,
autograde, generate feedback, export; the exported grades equal ``mbd grade``'s for the same submissions.

Each homework runs in a scratch copy of the course (``course.demo.scratch_course``: notebooks, nbgrader
configuration, reference, grader data) with nbgrader's own commands: hw1's from the course root (through the
root ``nbgrader_config.py``), the others' from ``course/``; none of them writes anything outside ``build/``.
nbgrader runs the notebook in the grader's sandbox (``autograder.kernel``), where ``mbdkit.check`` only prints a
line; the points of every graded cell come from the grader's own run of the submission, written into the
gradebook from outside the kernel (``autograder.api``): so nbgrader's score of a submission is the autograder's,
check for check, and hostile notebooks and packages score there what the untouched skeleton scores.
"""

from __future__ import annotations

import csv
import hashlib
import html
import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

import nbformat
import pytest

from autograder.api import check_call
from autograder.grading import grade
from course.demo import MUTATIONS, _mutate, scratch_course
from course.release import build_package, release
from course.release.generator import REPO
from mbdkit.homework import load_homework
from mbdkit.scenes import HIDDEN

from ..autograder import test_hostile_grader as crash
from ..autograder import test_wall as wall
from ..autograder import test_withheld as leak
from ..conftest import TEST_SECRET

STUDENTS = {
    "hw1": {
        "ada": None,
        "ben": "bug_revolute_gamma",
        "sam": "skeleton",
        "eve": "forged_checker",
        "mal": "forged_package",
        "rex": "hostile_notebook",
        "dan": "damaged_notebook",
        "fay": "zipped_copy",
        "pia": "crash:printed",
        "lin": "modules_link",
        "fox": "wall:forks",
    },
    "hw2": {
        "ada": None,
        "sam": "skeleton",
        "lee": "leak:leech",
        "xia": "leak:exit",
        "cal": "leak:class",
        "sta": "leak:stash",
        "eli": "crash:element_list",
        "dis": "wall:disk",
    },
    "hw3": {"ada": None, "sam": "skeleton", "lee": "leak:leech", "stu": "leak:stuck", "cal": "leak:class"},
}
"""Per homework, the class submitted: the reference (None), a mutant of course/demo.py, the skeleton,
and the skeleton with an attack on the points: the kit's checker changed to award a point in every graded cell;
``modules/__init__.py`` made to replace whatever grades the cells by full points; a notebook whose own cell
redefines ``check`` (a test cell with no output and no error has full credit in nbgrader) and whose other cell
reads the course, the gradebook and the environment and writes into a classmate's submission; the skeleton with
the joints written (their checks pass, the rest fail at once), its notebook saved as 'hw1 (1).ipynb', a graded test cell
pasted twice and another deleted (``damaged_notebook``);
the skeleton in a zip whose notebook is 'hw1-copy.ipynb', which ``nbgrader zip_collect`` drops
(``zipped_copy``). The check before autograde (course/nbcheck.py) repairs the last two.

With them, the hostile class of issue 23, each the skeleton with one attack of ``tests/autograder``'s (their
tests say what each does to the grader, alone): ``crash:*`` a reply the grader could not parse
(``test_hostile_grader``), ``leak:*`` hidden and per-student scenes sent back through an exit, a spin, an
exception class, a file left for the next child, or answers taken from what the grader sends
(``test_withheld``), ``wall:*`` the memory of three forks and a disk filled, the audit hook switched off
(``test_wall``), and ``modules`` a link to the course's ``solutions/`` (a tar or zip keeps it)."""

HONEST = {"hw1": ("ada", "ben", "sam"), "hw2": ("ada", "sam"), "hw3": ("ada", "sam")}
"""The honest classmates: each scores in the class exactly what it scores graded alone."""
ALONE = {"ada": 100.0, "sam": 0.0}
"""What the reference and the untouched skeleton score graded alone, whoever the student (every homework is out of
100: tests/autograder/test_grading.py grades both alone, on variants of their own); the other honest classmates
are graded alone here."""

SECRET = TEST_SECRET
"""The course secret in the environment of every grading process (nbgrader's and ``mbd grade``'s): the test
session's, so that the hidden scenes' references, computed once per secret (15 CPU s for hw3's), are those
the other grading tests computed or use (``$XDG_CACHE_HOME/mbd-course/references``)."""

FORGED = """

def check(homework, group, path=None):  # forged by the student: a point for every graded cell
    return 1.0
"""

FORGED_PACKAGE = """

# Appended by the student: full points from whatever grades this notebook's cells.
try:
    import autograder.api as _grader

    _grader.grade_group = lambda *args, **kwargs: 1000.0
except Exception:
    pass
try:
    import mbdkit.api as _kit

    _kit.check.__code__ = (lambda homework, group, path=None: 1000.0).__code__
except Exception:
    pass
"""

OWN_CHECK = """def check(homework, group, path=None):  # the student's own: no output, no error
    return None"""

PROBE = """import json, os
seen = {}
def attempt(name, action):
    try:
        seen[name] = repr(action())[:200]
    except BaseException as err:
        seen[name] = "refused: " + type(err).__name__
attempt("course file", lambda: open(COURSE + "/autograder/hw1.toml").read())
attempt("gradebook", lambda: open(COURSE + "/build/gradebook.db", "rb").read(16))
attempt("classmate", lambda: open(COURSE + "/build/submitted/ada/hw1/modules/__init__.py", "a").write("1/0"))
seen["environment"] = dict(os.environ)
print(json.dumps(seen))"""


def hostile_notebook(folder: Path, course: Path) -> None:
    """Two cells of the student's own after the set-up cell: ``check`` redefined, and the probe."""
    path = folder / "hw1.ipynb"
    nb = nbformat.read(path, as_version=4)
    setup = next(i for i, c in enumerate(nb.cells) if c.metadata.get("nbgrader", {}).get("grade_id") == "hw1_setup")
    probe = f"COURSE = {str(course)!r}\n" + PROBE
    nb.cells[setup + 1 : setup + 1] = [nbformat.v4.new_code_cell(OWN_CHECK), nbformat.v4.new_code_cell(probe)]
    nb.cells.append(nbformat.v4.new_markdown_cell(MARKUP))  # for the instructor's formgrader and the feedback page
    nb.cells.append(nbformat.v4.new_code_cell(f"from IPython.display import HTML\nHTML({MARKUP!r})"))
    nbformat.write(nb, path)


MARKUP = "<script>fetch('/api/contents')</script><img src=x onerror=\"fetch('/api/sessions')\">"
"""A script and an event handler, written by a hostile student into a markdown cell and made a cell's output."""


def submit(course: Path, homework: str, student: str, kind: str | None) -> Path:
    """A submission as nbgrader collects it: the released folder, with the student's package (``zipped_copy``:
    a zip for ``nbgrader zip_collect`` in build/downloaded/hwN/archive/)."""
    released = course / "build" / "release" / homework
    folder = course / "build" / "submitted" / student / homework
    if kind == "zipped_copy":
        return zipped_copy(course, homework, student)
    shutil.copytree(released, folder, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    if kind == "damaged_notebook":  # the joints done (cheap function checks), the rest still stubs
        damage_notebook(folder, homework)
        for name in ("bodies.py", "joints.py"):
            shutil.copy2(course / "solutions" / "planar" / name, folder / "modules" / "planar" / name)
        kind = "skeleton"
    if kind == "forged_checker":
        with open(folder / "mbdkit" / "api.py", "a") as f:
            f.write(FORGED)
    elif kind == "forged_package":
        with open(folder / "modules" / "__init__.py", "a") as f:
            f.write(FORGED_PACKAGE)
    elif kind == "hostile_notebook":
        hostile_notebook(folder, course)
    elif kind == "modules_link":  # as an unpacked tar or zip keeps it
        shutil.rmtree(folder / "modules")
        (folder / "modules").symlink_to(course / "solutions")
    elif kind and kind.startswith(("crash:", "leak:", "wall:")):
        plant(folder / "modules", homework, kind)
    elif kind not in ("skeleton", "forged_package", "hostile_notebook"):
        build_package(folder / "modules", None, course / "solutions", header=None)
    if kind in MUTATIONS:
        relpath, anchor, correct, buggy, _ = MUTATIONS[kind]
        _mutate(folder / "modules", relpath, anchor, correct, buggy, student)
    return folder


WALL = """
import builtins, os
MiB = 2**20
report = getattr(builtins, "_attack_report", None)
if report is None:  # once per process: a package whose import fails is imported again by every check
    report = builtins._attack_report = []
@@HOOK_OFF@@
@@ATTACK@@
raise RuntimeError("ATTACK:" + " | ".join(report))
"""
"""A wall attack of ``tests/autograder/test_wall.py`` at the import of the package, once in every process that
imports it (nbgrader's kernel, each of the grader's children): its memory or disk, not its repetition, is what
the wall must hold; run at each of a child's 30-60 checks it cost 20-30 CPU seconds per route."""


def plant(package: Path, homework: str, kind: str) -> None:
    """The attack ``kind`` ("crash:NAME", "leak:NAME" or "wall:NAME") planted in the untouched skeleton."""
    family, name = kind.split(":")
    if family == "crash":
        crash.plant(package, name)
    elif family == "wall":
        once = {"@@HOOK_OFF@@": wall.HOOK_OFF, "@@ATTACK@@": wall._fill(wall.ATTACKS[name])}
        code = WALL
        for mark, attack in once.items():
            code = code.replace(mark, textwrap.indent(attack.strip("\n"), "    "))
        with open(package / "__init__.py", "a") as f:
            f.write(code)
    else:  # the spin: on the hidden scene whose checks' timeouts add up to the least (one short timeout)
        hidden = [c for c in load_homework(homework).checks if c.kind == HIDDEN]
        spin = min({c.scene for c in hidden}, key=lambda scene: sum(c.timeout for c in hidden if c.scene == scene))
        leak.plant(package, name, spin)


def damage_notebook(folder: Path, homework: str) -> None:
    """The first graded test cell pasted a second time, the second deleted, the notebook saved as 'hwN (1)'."""
    path = folder / f"{homework}.ipynb"
    notebook = nbformat.read(path, as_version=4)
    ids = [c.metadata.get("nbgrader", {}).get("grade_id", "") for c in notebook.cells]
    tests = [i for i, gid in enumerate(ids) if gid.startswith("test_")]
    pasted = nbformat.from_dict(notebook.cells[tests[0]])
    pasted.id = "pasted"
    del notebook.cells[tests[1]]
    notebook.cells.insert(tests[0] + 2, pasted)
    nbformat.write(notebook, folder / f"{homework} (1).ipynb")
    path.unlink()


def zipped_copy(course: Path, homework: str, student: str) -> Path:
    """The released kit zipped by the student as kit/, its notebook renamed 'hwN-copy.ipynb'."""
    import zipfile

    released = course / "build" / "release" / homework
    archive = course / "build" / "downloaded" / homework / "archive" / f"{student}.zip"
    archive.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(archive, "w") as zipped:
        zipped.write(released / f"{homework}.ipynb", f"kit/{homework}-copy.ipynb")
        for path in sorted((released / "modules").rglob("*.py")):
            zipped.write(path, f"kit/{path.relative_to(released).as_posix()}")
    return archive


WHERE = {"hw1": "."}
"""Where each homework's nbgrader commands run, relative to the course root (``course/`` when not listed)."""


def nbgrader(course: Path, *args: str, where: str = "course") -> str:
    """An nbgrader command, run where an nbgrader_config.py is (the root or ``course/``), as an instructor would."""
    environment = dict(os.environ, PATH=os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")]))
    environment.pop("NBGRADER_EXECUTION", None)
    environment["MBD_GRADER_SECRET"] = SECRET
    done = subprocess.run(
        [sys.executable, "-m", "nbgrader", *args],
        cwd=course / where,
        env=environment,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, f"nbgrader {' '.join(args)}:\n{done.stderr[-3000:]}"
    return done.stdout + done.stderr


def outside_build(course: Path) -> dict[str, str]:
    """Every file of the course outside build/ (Python's caches aside), with a digest of its content."""
    files = {}
    for path in sorted(course.rglob("*")):
        relative = path.relative_to(course)
        if path.is_file() and relative.parts[0] != "build" and "__pycache__" not in relative.parts:
            files[relative.as_posix()] = hashlib.sha256(path.read_bytes()).hexdigest()
    return files


def autograde_and_export(course: Path, homework: str) -> dict[str, dict]:
    """``nbgrader autograde``, ``generate_feedback`` and ``export`` (to its configured file, build/grades.csv)
    for every submission of one homework; the course outside build/ stays as it was. What autograde's check of
    the notebooks (course/nbcheck.py) printed is kept in build/autograde.log."""
    where = WHERE.get(homework, "course")
    before = outside_build(course)
    log = nbgrader(course, "autograde", homework, "--force", where=where)
    (course / "build" / "autograde.log").write_text(log)
    nbgrader(course, "generate_feedback", homework, "--force", where=where)
    nbgrader(course, "export", where=where)
    assert outside_build(course) == before, f"{homework}: nbgrader wrote outside build/"
    with open(course / "build" / "grades.csv", newline="") as f:
        return {row["student_id"]: row for row in csv.DictReader(f) if row["assignment"] == homework}


def mbd_grade(course: Path, homework: str, *options: str) -> tuple[subprocess.CompletedProcess, float]:
    """``mbd grade hwN build/submitted --out build/grades --jobs 2`` as the instructor runs it; its wall time."""
    environment = dict(os.environ, MBD_GRADER_SECRET=SECRET)
    command = [sys.executable, "-m", "solutions.cli", "grade", homework, "build/submitted", "--out", "build/grades"]
    start = time.monotonic()
    done = subprocess.run(
        [*command, "--jobs", "2", *options], cwd=course, env=environment, capture_output=True, text=True, timeout=1800
    )
    return done, time.monotonic() - start


@dataclass(frozen=True)
class Cycle:
    """One homework's cycle: its scratch course, nbgrader's exported rows by student, ``grade``'s gradebook,
    ``mbd grade --jobs 2``'s (process, seconds) and the honest classmates' scores graded alone (``ALONE``'s
    aside)."""

    homework: str
    course: Path
    exported: dict[str, dict]
    book: object
    run: tuple[subprocess.CompletedProcess, float]
    alone: dict[str, float]


@pytest.fixture(scope="module")
def cycle(request, tmp_path_factory) -> Cycle:
    """One homework through nbgrader, in a scratch copy of the course of its own: generate (``mbd release``),
    submissions, autograde, feedback, export; then ``mbd grade --jobs 2`` of the same submitted/ folder (its
    gradebook read back by a resuming ``grade``, which grades nothing again), and the honest classmates graded
    alone. The homework is the test module's HOMEWORK: each homework's tests are a file of their own
    (test_nbgrader_cycle_hw1.py, ...), a work unit of pytest-xdist's ``--dist loadfile``, so that the three cycles
    run on different workers, each built once."""
    homework = request.module.HOMEWORK
    root = tmp_path_factory.mktemp(f"nbgrader-{homework}")
    course = scratch_course(root / homework)
    shutil.copy2(REPO / "nbgrader_config.py", course / "nbgrader_config.py")  # nbgrader run from the root
    release(homework, course)  # nbgrader's generate step, the student package, the leak check
    for student, kind in STUDENTS[homework].items():
        submit(course, homework, student, kind)
    if "zipped_copy" in STUDENTS[homework].values():
        nbgrader(course, "zip_collect", homework, where=WHERE.get(homework, "course"))
    exported = autograde_and_export(course, homework)
    alone = {}
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MBD_GRADER_SECRET", SECRET)
        run = mbd_grade(course, homework)
        submitted, out = course / "build" / "submitted", course / "build" / "grades"
        book = grade(homework, submitted, out, jobs=1, progress=False)
        for student in (s for s in HONEST[homework] if s not in ALONE):
            shutil.copytree(submitted / student, root / "alone" / student / student, symlinks=True)
            alone_out = root / "alone" / f"{student}-out"
            alone[student] = grade(homework, root / "alone" / student, alone_out, progress=False).score(student)
    return Cycle(homework, course, exported, book, run, alone)


def test_exported_grades_equal_the_autograders(cycle):
    homework, course, book = cycle.homework, cycle.course, cycle.book
    source = nbformat.read(course / "assignments" / homework / f"{homework}.ipynb", as_version=4)
    written = sum(
        c.metadata["nbgrader"]["points"]
        for c in source.cells
        if c.metadata.get("nbgrader", {}).get("grade") and c.metadata["nbgrader"].get("solution")
    )
    for student in STUDENTS[homework]:
        row = cycle.exported[student]
        assert float(row["raw_score"]) == pytest.approx(book.score(student), abs=1e-6), (student, row)
        assert float(row["max_score"]) == pytest.approx(book.max_score + written)  # written answers: by hand


def test_the_per_check_export_adds_up_to_nbgraders_total(cycle, tmp_path):
    """`nbgrader export --exporter course.nbexport.ChecksExportPlugin`: a column per graded cell whose scores add
    up to the total nbgrader's own export gives, every graded cell of the homework a column."""
    from nbgrader.api import Gradebook

    from course.nbexport import ChecksExportPlugin

    homework, course = cycle.homework, cycle.course
    target = tmp_path / "checks.csv"
    with Gradebook(f"sqlite:///{course / 'build' / 'gradebook.db'}") as gradebook:
        ChecksExportPlugin(to=str(target), assignment=[homework]).export(gradebook)
    with open(target, newline="") as f:
        rows = {row["student_id"]: row for row in csv.DictReader(f)}
    source = nbformat.read(course / "assignments" / homework / f"{homework}.ipynb", as_version=4)
    graded = [c.metadata["nbgrader"]["grade_id"] for c in source.cells if c.metadata.get("nbgrader", {}).get("grade")]
    for student, exported in cycle.exported.items():
        row = rows[student]
        assert row["status"] == "submitted" and {k for k in row if k in graded} == set(graded)
        assert sum(float(row[cell]) for cell in graded) == pytest.approx(float(exported["raw_score"]))
        assert float(row["score"]) == pytest.approx(float(exported["raw_score"]))


def test_feedback_pages_show_the_graders_messages(cycle):
    homework, course = cycle.homework, cycle.course
    pages = {}
    for student in STUDENTS[homework]:
        page = course / "build" / "feedback" / student / homework / f"{homework}.html"
        pages[student] = html.unescape(re.sub(r"<[^>]+>", "", page.read_text()))
        assert f'check("{homework}", "hidden")' in pages[student] and " hidden/" in pages[student]  # they ran
        assert "Model answer" not in pages[student]
    assert "ok   hidden/" in pages["ada"]
    source = nbformat.read(course / "assignments" / homework / f"{homework}.ipynb", as_version=4)
    animations = sum("notebook_animation(" in c.source for c in source.cells if c.cell_type == "code")
    ada = (course / "build" / "feedback" / "ada" / homework / f"{homework}.html").read_text()
    assert animations and ada.count('class="mbd-view"') == animations  # the student's motion, played in the page
    assert ada.count('<script id="plotly-js">') == 1
    if homework == "hw1":
        assert "FAIL four_bar.gamma.revolute" in pages["ben"] and "Likely cause: a sign error" in pages["ben"]
        assert "not implemented yet" in pages["sam"]
    groups = [
        check_call(c.source)[1]
        for c in source.cells
        if c.metadata.get("nbgrader", {}).get("grade_id", "")[:5] == "test_"
    ]
    for student in STUDENTS[homework]:
        page = course / "build" / "feedback" / student / homework / f"{homework}.html"
        read_as_the_course_returns_it(page, homework, cycle.book.score(student), cycle.book.max_score, groups)
    if homework == "hw1":  # the likely cause before the cells, once for its two checks
        text = pages["ben"]
        assert text.index("What to fix, the costliest first") < text.index("Checks: bodies")
        assert text.count("Likely cause: a sign error: you get minus the expected value") == 1 + 2  # summary, cell


def read_as_the_course_returns_it(page: Path, homework: str, score: float, max_score: float, groups: list[str]):
    """nbgrader's feedback page with the course's template (autograder/nbpages.py): one total, the checks' points
    on the homework's scale (what mbd grade gives); every graded cell named by its group, none "Test cell";
    long lines wrapped; MathJax from the folder beside the page, none from the network."""
    text = page.read_text()
    plain = html.unescape(
        re.sub(r"<[^>]+>", "", re.sub(r"<script\b.*?</script>|<style\b.*?</style>", "", text, flags=re.S))
    )
    totals = re.findall(r"\b\d+(?:\.\d+)? / (\d+(?:\.\d+)?) points", plain)
    assert totals == [f"{round(max_score, 2)}"] and f"{homework}: {round(score, 2)} / " in plain, (page, totals)
    assert "Test cell" not in plain and "Grade cell" not in plain and "/ 110" not in plain
    assert [g for g in groups if f"Checks: {g}" not in plain] == [], page
    assert "white-space: pre-wrap" in text
    sources = re.findall(r'<script[^>]* src="([^"]*)"', text)
    assert sources == ["mathjax/MathJax.js?config=TeX-AMS-MML_HTMLorMML-full,Safe"], sources
    assert "cdnjs.cloudflare.com/ajax/libs/mathjax" not in text
    beside = page.parent / sources[0].split("?")[0]
    assert beside.is_file() and (beside.parent / "config" / "TeX-AMS-MML_HTMLorMML-full.js").is_file()
    assert (beside.parent / "fonts" / "HTML-CSS" / "STIX-Web" / "woff" / "STIXMathJax_Main-Regular.woff").is_file()


ATTACKS = ("forged_", "hostile_notebook", "modules_link", "crash:", "leak:", "wall:")


def hostile(homework: str) -> list[str]:
    return [s for s, kind in STUDENTS[homework].items() if kind and kind.startswith(ATTACKS)]


def test_mbd_grade_ends_the_hostile_class_within_its_budget(cycle):
    """``mbd grade --jobs 2``: exit 0, no traceback, every student graded (the resuming run grades nothing
    again), within the budget of the class (each submission's budget, two at a time)."""
    homework, (done, seconds) = cycle.homework, cycle.run
    assert done.returncode == 0 and "Traceback" not in done.stdout + done.stderr, done.stderr[-3000:]
    book = cycle.book
    assert set(book.graded) == set(STUDENTS[homework]) and not book.internal_errors
    assert not [s for s, row in book.rows.items() if not row["resumed"]]
    assert seconds < len(STUDENTS[homework]) * load_homework(homework).budget / 2


def test_hostile_students_score_at_most_the_skeleton_on_both_routes(cycle):
    book, rows = cycle.book, cycle.exported
    for student in hostile(cycle.homework):
        assert book.score(student) <= book.score("sam"), (student, book.score(student))
        assert float(rows[student]["raw_score"]) <= float(rows["sam"]["raw_score"]), (student, rows[student])


def test_honest_classmates_score_exactly_their_score_alone(cycle):
    book, alone = cycle.book, {**ALONE, **cycle.alone}
    assert book.max_score == ALONE["ada"]
    for student in HONEST[cycle.homework]:
        assert book.score(student) == alone[student], student
        assert float(cycle.exported[student]["raw_score"]) == pytest.approx(alone[student], abs=1e-6)


def returned_files(course: Path) -> dict[str, str]:
    """Every file a student gets back: nbgrader's feedback pages and ``mbd grade``'s, without what the pages'
    templates bring (style sheets, scripts, plotly.js) and the plots' PNG data; the views' figures are kept
    (their numbers are the student's notebook's: autograder/views.py)."""
    pages = [*(course / "build" / "feedback").rglob("*.html"), *(course / "build" / "grades" / "feedback").glob("*")]
    template = re.compile(r"<style\b.*?</style>|<script\b.*?</script>|data:image/png;base64,[A-Za-z0-9+/=]+", re.DOTALL)

    def unless_a_view(found: re.Match) -> str:
        return found.group(0) if found.group(0).startswith("<script>(() => {\nconst figure = ") else ""

    return {str(p): template.sub(unless_a_view, p.read_text()) for p in pages}


def secrets(course: Path, homework: str) -> tuple[set[str], set[str]]:
    """(numbers, names) of the homework's hidden scenes and of every student's own variant, but those that a
    student already has (in the released notebook and package, or a public scene)."""
    from autograder.scenes import load_scene
    from mbdkit.scenes import PUBLIC, STUDENT

    checks = load_homework(homework).checks
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MBD_GRADER_SECRET", SECRET)
        models = [load_scene(c.scene).data for c in checks if c.kind == HIDDEN]
        models += [
            load_scene(c.scene, student=s, homework=homework).data
            for c in checks
            if c.kind == STUDENT
            for s in STUDENTS[homework]
        ]
    public = set().union(*(leak.secret_numbers(load_scene(c.scene).data) for c in checks if c.kind == PUBLIC))
    kit = (course / "build" / "release" / homework).rglob("*")
    released = "".join(p.read_bytes().decode(errors="replace") for p in kit if p.is_file())
    numbers = {n for data in models for n in leak.secret_numbers(data)} - public
    numbers = {n for n in numbers if n not in released}
    names = {data["model"]["name"] for data in models}
    return numbers, {n for n in names if not any(n in c.name for c in checks) and n not in released}


def test_nothing_hidden_reaches_a_file_returned_to_students(cycle):
    """No hidden or own-variant model text, name or number in a feedback page of either route, with the hidden
    checks held back and after ``mbd grade --publish-hidden`` (which grades nothing again)."""
    homework, course = cycle.homework, cycle.course
    numbers, names = secrets(course, homework)
    held = returned_files(course)
    done, _ = mbd_grade(course, homework, "--publish-hidden")
    assert done.returncode == 0, done.stderr[-3000:]
    published = returned_files(course)
    assert published != held  # the hidden checks' results are on the pages now
    for pages in (held, published):
        for path, text in pages.items():
            assert not re.search(r"[A-Za-z0-9+/]{80,}", text), (path, "a long base64 run")
            assert not [name for name in names if name in text], path
            prose = VIEW.sub("", text)  # a view's thousands of coordinates: compared whole below instead
            assert leak.secret_number_in(prose, numbers) is None, (path, leak.secret_number_in(prose, numbers))
            views = [json.loads(found) for found in VIEW.findall(text)]
            assert views == kernel_views(course, homework, Path(path)), path  # what the student's notebook made


VIEW = re.compile(r"<script>\(\(\) => \{\nconst figure = (.*?);\nPlotly\.newPlot.*?</script>", re.DOTALL)
"""A view's player in a feedback page (``solutions.viewer.embedded``), its figure's JSON the group."""


def kernel_views(course: Path, homework: str, page: Path) -> list[dict]:
    """The views that the student's notebook made in nbgrader's kernel (the autograded notebook's outputs), as
    the feedback step draws them (``autograder.views.safe_figure``), for a page of nbgrader's feedback; none for
    ``mbd grade``'s pages."""
    from autograder.views import safe_figure
    from solutions.viewer import MIME

    if "feedback" not in page.parts or "grades" in page.parts:
        return []
    student = page.relative_to(course / "build" / "feedback").parts[0]
    graded = nbformat.read(course / "build" / "autograded" / student / homework / f"{homework}.ipynb", as_version=4)
    outputs = [o for c in graded.cells if c.cell_type == "code" for o in c.get("outputs", [])]
    figures = [safe_figure(o["data"][MIME]) for o in outputs if MIME in o.get("data", {})]
    return [json.loads(json.dumps(f)) for f in figures if f is not None]
