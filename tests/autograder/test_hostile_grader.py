"""Submissions that attack the grader itself rather than the sandbox (issue 23): what the child sends back,
the stack dumps it writes, the names and links of the submitted files.

Each hostile student is the untouched skeleton with one attack, graded in one class with two honest
classmates (the reference and the skeleton), once through ``autograder.grading.grade(..., jobs=2)`` and
once through ``mbd grade --jobs 2``, each run twice (the second resumes). Before issue 23 each of these
stopped the run with a traceback (or hung it), on every rerun, or scored full marks (``modules`` a link to
``solutions/``), or showed a root-only file in the feedback (a hard link).

Attacks on what the child sends are planted at the end of ``modules/__init__.py``, so they run in every
child, at import, before any probe: the attack writes to the child's socket (the ``connection`` of
``_child.serve``, found up the stack) or to its stack-dump descriptor, as the student's code can.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
import textwrap
import uuid
from pathlib import Path

import pytest

from autograder.grading import grade
from mbdkit import isolation as osi
from mbdkit.homework import Homework, load_homework
from mbdkit.sandbox import Limits

from .conftest import REPO, SOLUTIONS, copy_reference, make_skeleton

PROBLEM = osi.problem()
pytestmark = pytest.mark.skipif(PROBLEM is not None, reason=f"no operating-system isolation here: {PROBLEM}")

CHECKS = ["four_bar.constraints.revolute", "slider_crank.newton", "four_bar.velocity"]
"""A check with ``rows`` (element errors are matched against its joints), a solver and a velocity check."""
LIMITS = Limits(timeout_scale=0.3)
TOKEN = uuid.uuid4().hex
SECRET = {"MBD_GRADER_SECRET": f"crash-{TOKEN[:8]}"}

CONNECTION = """
import sys as _sys
_frame = _sys._getframe()
while "connection" not in _frame.f_locals:  # up to _child.serve
    _frame = _frame.f_back
_connection = _frame.f_locals["connection"]
"""
ATTACKS = {
    # a reply frame whose "printed" is not a number (int() in the grader)
    "printed": CONNECTION + """_connection.send_bytes(b'{"status": "ok", "outputs": {}, "printed": "lots"}')\n""",
    # an element error whose element is a list (unhashable where the grader matches it to the check's joints)
    "element_list": CONNECTION
    + """_connection.send_bytes(b'{"status": "ok", "outputs": {}, "element_errors": '
    b'[{"element": ["revolute"], "method": "constraints", "type": "E", "message": ""}]}')
""",
    # a STUCK line whose line number is the digit "²" (str.isdigit() is true, int() fails), then a hang
    "stuck_digit": """
import os as _os, sys as _sys
_line = "STUCK\\t" + __file__ + "\\t\\u00b2\\t<module>\\n"
_os.write(_sys.modules["mbdkit._child"]._state["hang"], _line.encode())
while True:
    pass
""",
    # a frame that announces 1000 bytes and sends 1, then nothing, with the child's own watchdog off (the
    # grader read the frame with no deadline: it waited forever)
    "partial_frame": CONNECTION
    + """
import faulthandler as _faulthandler, os as _os, struct as _struct, time as _time
_faulthandler.cancel_dump_traceback_later()
_os.write(_connection.fileno(), _struct.pack("!i", 1000) + b"{")
_time.sleep(3600)
""",
    # the contents of a root-only file, through a hard link in the package, raised in every check
    "hard_link": """
try:
    _said = open(__file__[: -len("__init__.py")] + "leak.txt").read()
except OSError as _err:
    _said = type(_err).__name__
raise RuntimeError("LEAK:" + _said)
""",
}
HONEST = {"ann": "reference", "sam": "skeleton"}
CAFE = "caf\\xe9"
"""The student whose folder's name and a file's name hold the byte 0xe9 (not UTF-8), as the grader names it."""
HOSTILE = [*ATTACKS, CAFE, "modules_link", "inner_links"]


def plant(package: Path, attack: str) -> None:
    """``attack`` appended to the package's ``__init__.py``."""
    init = package / "__init__.py"
    init.write_text(init.read_text() + "\n" + textwrap.dedent(ATTACKS[attack]))


def make_class(root: Path, private: Path) -> Path:
    """The class: honest classmates and one student per attack; ``private`` holds the root-only file."""
    folder = root / "submitted"
    copy_reference(folder / "ann")
    make_skeleton(folder / "sam", "hw1")
    for attack in ATTACKS:
        make_skeleton(folder / attack, "hw1")
        plant(folder / attack / "modules", attack)
    secret = private / "root-only.txt"
    secret.write_text(f"TOPSECRET-{TOKEN}")
    secret.chmod(0o600)
    os.link(secret, folder / "hard_link" / "modules" / "leak.txt")
    cafe = Path(os.fsdecode(os.fsencode(folder) + b"/caf\xe9"))
    make_skeleton(cafe, "hw1")
    with open(os.fsencode(cafe / "modules") + b"/caf\xe9.py", "w") as f:
        f.write("VALUE = 1\n")
    (folder / "modules_link").mkdir()
    (folder / "modules_link" / "modules").symlink_to(SOLUTIONS)  # as an unpacked tar or zip keeps it
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(SOLUTIONS, folder / "inner_links" / "modules", copy_function=os.symlink, ignore=ignore)
    return folder


GRADE = """
import sys
from autograder.grading import grade
from mbdkit.homework import Homework, load_homework
from mbdkit.sandbox import Limits
homework = Homework("hw1", "crash", load_homework("hw1").select(sys.argv[3].split(",")).checks)
grade(homework, sys.argv[1], sys.argv[2], jobs=2, limits=Limits(timeout_scale=float(sys.argv[4])), progress=False)
"""


def run(command: list[str]) -> subprocess.CompletedProcess:
    env = {**os.environ, **SECRET}
    return subprocess.run(command, cwd=REPO, env=env, capture_output=True, text=True, timeout=600)


def scores(out: Path) -> dict[str, float]:
    with open(out / "gradebook.csv", newline="") as f:
        return {row["student"]: float(row["score"]) for row in csv.DictReader(f)}


def results(out: Path, student: str) -> dict:
    return json.loads((out / "results" / f"{student}.json").read_text())


def outputs(out: Path) -> dict[str, bytes]:
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    """The class graded through the Python API (3 checks) and ``mbd grade`` (all of hw1), each twice; the
    honest classmates graded alone with the Python API."""
    root = tmp_path_factory.mktemp("crash")
    folder = make_class(root, tmp_path_factory.mktemp("private"))
    alone = root / "alone"
    for student in HONEST:
        shutil.copytree(folder / student, alone / student, symlinks=True)
    homework = Homework("hw1", "crash", load_homework("hw1").select(CHECKS).checks)
    saved = {key: os.environ.get(key) for key in SECRET}
    os.environ.update(SECRET)
    try:
        book = grade(homework, alone, root / "alone-out", jobs=1, limits=LIMITS, progress=False)
    finally:  # the session's own secret (tests/conftest.py) back, for the tests after this one
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
    api = [sys.executable, "-c", GRADE, str(folder), str(root / "api"), ",".join(CHECKS), str(LIMITS.timeout_scale)]
    cli = [sys.executable, "-m", "solutions.cli", "grade", "hw1", str(folder), "--out", str(root / "cli")]
    cli += ["--jobs", "2"]
    runs = {}
    for route, command in (("api", api), ("cli", cli)):
        first = run(command)
        written = outputs(root / route)
        again = run(command)
        runs[route] = (first, again, written, outputs(root / route))
    return {"alone": {s: book.score(s) for s in HONEST}, "max": book.max_score, "root": root, "runs": runs}


@pytest.mark.parametrize("route", ["api", "cli"])
def test_the_run_ends_cleanly_and_resumes(graded, route):
    first, again, written, rewritten = graded["runs"][route]
    for done in (first, again):
        assert done.returncode == 0, done.stderr[-3000:]
        assert "Traceback" not in done.stdout + done.stderr, done.stderr[-3000:]
        assert "internal error" not in done.stdout
    assert rewritten == written  # the second run resumed every result: nothing graded or written again
    out = graded["root"] / route
    assert set(scores(out)) == {*HONEST, *HOSTILE}


@pytest.mark.parametrize("route", ["api", "cli"])
def test_classmates_keep_their_scores_and_attackers_gain_nothing(graded, route):
    got = scores(graded["root"] / route)
    if route == "api":
        alone = graded["alone"]
    else:  # all of hw1: the reference scores full marks and the skeleton 0 (tests/autograder/test_grading.py)
        alone = {"ann": results(graded["root"] / route, "ann")["max_score"], "sam": 0.0}
    assert {s: got[s] for s in HONEST} == alone
    assert alone["ann"] > alone["sam"]
    for student in HOSTILE:
        assert got[student] <= got["sam"], (student, results(graded["root"] / route, student)["tests"])


def messages(graded, student: str, route: str = "api") -> list[str]:
    return [t["output"] for t in results(graded["root"] / route, student)["tests"]]


@pytest.mark.parametrize("student", ["printed", "element_list"])
def test_a_malformed_reply_fails_the_check_with_the_graders_words(graded, student):
    said = messages(graded, student)
    assert said and all("the sandbox child sent a malformed reply" in m for m in said), said


def test_a_stack_dump_line_with_a_strange_digit_is_ignored(graded):
    said = messages(graded, "stuck_digit")
    stuck = [m for m in said if "did not finish within the time limit" in m]
    assert len(stuck) == 1 and "stuck in modules/__init__.py:" in stuck[0], said  # the real line, not "²"
    assert "at import (module level)" in stuck[0]
    assert all("skipped" in m for m in said if m not in stuck), said  # one timeout per submission


def test_a_partial_frame_is_a_timeout(graded):
    said = messages(graded, "partial_frame")
    partial = [m for m in said if "did not finish its reply within the time limit" in m]
    assert len(partial) == 1, said
    assert all("skipped" in m for m in said if m not in partial), said
    timeout = max(c.timeout for c in load_homework("hw1").select(CHECKS).checks) * LIMITS.timeout_scale
    assert float((graded["root"] / "api" / "timing" / "partial_frame.txt").read_text()) < 2 * timeout + 10


def test_names_of_any_bytes_are_graded(graded):
    for route in ("api", "cli"):
        assert scores(graded["root"] / route)[CAFE] == scores(graded["root"] / route)["sam"]
        assert results(graded["root"] / route, CAFE)["extra_data"]["student"] == CAFE
    assert messages(graded, CAFE) == messages(graded, "sam")


def test_modules_a_link_to_the_solutions_is_refused(graded):
    for route in ("api", "cli"):
        said = messages(graded, "modules_link", route)
        public = [m for m in said if m.startswith(f"modules is a symbolic link (to {SOLUTIONS})")]
        withheld = [m for m in said if ": could not run: " in m]  # hidden and own-variant checks: fixed words
        assert public and len(public) + len(withheld) == len(said), said[:2]
        assert scores(graded["root"] / route)["modules_link"] == 0.0


def test_links_inside_the_package_are_left_out_and_named(graded):
    data = results(graded["root"] / "api", "inner_links")
    assert "the grader left out modules/__init__.py (a symbolic link)" in data["output"], data["output"]
    assert all("(a symbolic link)" in t["output"] for t in data["tests"] if t["status"] == "failed")


def test_a_hard_link_to_a_root_only_file_is_never_read(graded):
    for route in ("api", "cli"):
        for name, data in outputs(graded["root"] / route).items():
            assert TOKEN.encode() not in data, name
        data = results(graded["root"] / route, "hard_link")
        assert "modules/leak.txt (a hard link" in data["output"], data["output"]
    said = messages(graded, "hard_link")
    assert all("LEAK:FileNotFoundError" in m for m in said), said


def test_an_internal_error_costs_only_that_student_and_is_graded_again(tmp_path, monkeypatch, capsys):
    """The last guard (``grading.grade_one``): an exception of the grader itself while grading one student
    (here a fake bug in ``run_checks``) is that student's failed result, named on one line; the run goes
    on, ``mbd grade`` exits 0, and the next run grades that student again (the others are resumed)."""
    from autograder import grading
    from autograder.cli import grade_command
    from mbdkit.checks import Outcome

    folder = tmp_path / "submitted"
    for student in ("amy", "bob", "cid"):
        (folder / student / "modules").mkdir(parents=True)
        (folder / student / "modules" / "__init__.py").write_text("")
    bug = ["bob"]

    def run_checks(checks, path, homework, student=None, *args, **kwargs):
        if student in bug:
            raise KeyError(f"a grader bug {TOKEN}")
        return [
            Outcome(c.name, c.group, c.scene, c.kind, c.points, c.points, True, "passed", "visible") for c in checks
        ]

    monkeypatch.setattr(grading, "run_checks", run_checks)
    for key, value in SECRET.items():
        monkeypatch.setenv(key, value)
    out = tmp_path / "out"
    assert grade_command("hw1", folder, out, jobs=1) == 0
    said = capsys.readouterr()
    assert "internal error while grading 1 submission: bob (tracebacks in" in said.out and "Traceback" not in said.err
    assert f"KeyError: 'a grader bug {TOKEN}'" in (out / "errors" / "bob.txt").read_text()
    data = results(out, "bob")
    assert data["score"] == 0 and data["extra_data"]["internal_error"]
    said = [t["output"] for t in data["tests"]]
    public = [m for m in said if m.startswith("internal error while grading (KeyError)")]
    withheld = [
        m
        for m in said
        if m.endswith(
            "could not run: the grader could not run this check (its configuration, not your code); ask the instructor"
        )
    ]  # hidden, own-variant checks
    assert public and withheld and len(public) + len(withheld) == len(said), said[:2]
    assert TOKEN not in (out / "results" / "bob.json").read_text() + (out / "feedback" / "bob.html").read_text()
    assert scores(out) == {"amy": 100.0, "bob": 0.0, "cid": 100.0}
    bug.clear()  # the grader fixed: bob is graded again, amy and cid resumed
    book = grading.grade("hw1", folder, out, jobs=1, progress=False)
    assert [s for s in sorted(book.rows) if not book.rows[s]["resumed"]] == ["bob"]
    assert scores(out) == {"amy": 100.0, "bob": 100.0, "cid": 100.0} and not book.internal_errors
    assert not (out / "errors" / "bob.txt").exists()
