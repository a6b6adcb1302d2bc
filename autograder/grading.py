"""Grade a folder of submissions: ``grade("hw1", "submitted", "grades")``.

A submission is a folder holding the student's package ``modules/`` (beside their notebook). Accepted
layouts: nbgrader's ``submitted/{student}/{assignment}/`` (the course root or its ``submitted`` folder),
or a plain folder of student folders. Students are graded one by one here (``jobs=1``) or in parallel on
Dask (``solutions.batch``: a LocalCluster of ``jobs`` worker processes, or a scheduler's workers); each
runs one student's checks in a sandbox (``sandbox``), one probe at a time, and returns the result.

On Dask a task whose worker dies (killed, out of memory) runs again on another worker and a student's result
is taken once; a task that fails on every retry is that student's internal error. On a cluster of several
machines every worker must see the submissions folder at the same path (a shared file system) and have
bubblewrap, the course repository (or the installed ``mbd-course``), its stored references and secret.

Only this process writes, to ``out_dir``, as each student finishes, so an interrupted run resumes where it
stopped:

- ``results/{student}.json``  Gradescope-like: score, max_score, output, tests (name, score, max_score,
  status, output, visibility); a result is reused when the submission, the checks and the reference
  are unchanged (its fingerprint);
- ``feedback/{student}.html`` every check with its message, plots of failed public runs; the hidden checks'
  results only once published (``publish_hidden``, ``publish_feedback``);
- ``gradebook.csv``           one row per student, a column per check (points), LMS-friendly, and the share of
  the homework's functions the student documented (``documentation``, percent: ``autograder.documentation``);
- ``errors/{student}.txt``    for the instructor: the traceback of an internal error (a bug of the grader,
  or its sandbox failing) while grading that student, whose result then says so and is graded again on
  the next run; the other students are graded as usual (``grade_one`` never raises for one submission).

Nothing of a submission is trusted: ``modules`` must be a folder of regular files (``mbdkit.staging``:
links, hard links, FIFOs and devices are left out and named), names may be any bytes (shown readably),
and what the student's code sends back is validated (``mbdkit.wire``).

A student on the roster (a folder of theirs, nbgrader's gradebook, or ``roster=``) who handed nothing in
for the homework (no ``modules/`` and no notebook) is *missing*: an empty score and ``status`` "missing" in
the gradebook, no result, no feedback page, and left out of the statistics (``Gradebook.graded``).

Ctrl-C (``KeyboardInterrupt``) stops a run as ``GradingInterrupted``: the results written so far stay, and
the same command resumes from them.
"""

from __future__ import annotations

import csv
import hashlib
import json
import os
import sys
import time
import traceback
from dataclasses import dataclass, field
from importlib.util import find_spec
from pathlib import Path

from mbdkit import isolation as osi
from mbdkit import runner, staging
from mbdkit.checks import Measure, Mistakes, Outcome
from mbdkit.homework import CheckSpec, Homework, load_homework
from mbdkit.probes import Job
from mbdkit.runner import PACKAGE, PublicData, failed
from mbdkit.sandbox import SANDBOX_ENV, Limits, Sandbox, without_main
from mbdkit.scenes import PUBLIC
from mbdkit.stored import Reference
from solutions import batch
from solutions.batch import write_atomic

from .documentation import measure as measure_documentation
from .feedback import feedback_html, publish
from .reference import (
    FORMAT,
    HERE,
    WARM_MIN_STUDENTS,
    cache_dir,
    hidden_reference,
    load_reference,
    probe_specs,
    reference_dir,
    reference_file,
    solutions_fingerprint,
    student_reference,
    warm,
)
from .scenes import HIDDEN, STUDENT, Scene, course_cache, hidden_override, load_scene, scene_kind
from .secret import config_dir, course_secret, secret_digest
from .tolerances import invariants

GRADER_VERSION = "6"  # 6: the documentation rubric's automatic part (autograder.documentation) in every result

ISOLATION_NOTE = {
    "os": "isolated by the operating system (bubblewrap: namespaces, uid 65534 or the user's, seccomp)",
    "local": "NOT isolated by the operating system (--unsafe-no-isolation): the audit hook was the only wall",
}


def isolation_mode(isolation: str | None = None) -> str:
    """The sandbox backend the grader uses: ``os`` unless asked otherwise (``MBD_UNSAFE_NO_ISOLATION=1``,
    ``mbd grade --unsafe-no-isolation``: ``local``)."""
    if isolation is not None:
        if isolation not in ("os", "local"):
            raise ValueError(f"isolation must be 'os' or 'local', not {isolation!r}")
        return isolation
    return "local" if osi.unsafe_requested() else "os"


@dataclass
class Submission:
    """One student's folder (it should hold ``modules/``); ``missing`` when nothing was handed in."""

    student: str
    path: Path
    missing: bool = False

    @property
    def package(self) -> Path:
        return self.path / PACKAGE


@dataclass
class Gradebook:
    """The grades of one run: per student the total and the points of every check."""

    homework: str
    checks: list[str]
    max_points: dict[str, float]
    rows: dict[str, dict] = field(default_factory=dict)
    out_dir: Path | None = None
    isolation: str = "os"
    """How student code was isolated: ``os`` (bubblewrap) or ``local`` (unsafe, --unsafe-no-isolation)."""

    @property
    def max_score(self) -> float:
        return sum(self.max_points.values())

    def score(self, student: str) -> float | None:
        """The student's total, or None when they handed nothing in (missing)."""
        return self.rows[student]["score"]

    def status(self, student: str) -> str:
        """``graded`` or ``missing``."""
        return self.rows[student].get("status", GRADED)

    @property
    def graded(self) -> list[str]:
        """The students whose submission was graded: the statistics are over these only."""
        return sorted(s for s in self.rows if self.status(s) == GRADED)

    @property
    def missing(self) -> list[str]:
        """The students on the roster who handed nothing in."""
        return sorted(s for s in self.rows if self.status(s) == MISSING)

    def points(self, student: str) -> dict[str, float]:
        return self.rows[student]["checks"]

    @property
    def internal_errors(self) -> list[str]:
        """Students whose grading failed by an internal error (graded again on the next run)."""
        return sorted(s for s, row in self.rows.items() if row.get("internal_error"))

    @property
    def csv_path(self) -> Path | None:
        return None if self.out_dir is None else self.out_dir / "gradebook.csv"

    def write_csv(self) -> None:
        """The gradebook: student, score, max_score, percent, status, documentation (the share of the homework's
        functions documented, percent), then one column per check; a missing student's score, percent,
        documentation and points are empty (not 0: an LMS must not average them in)."""
        if self.out_dir is None:
            return
        write_atomic(self.csv_path, self._write_rows)

    def _write_rows(self, path: Path) -> None:
        with open(path, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(["student", "score", "max_score", "percent", "status", "documentation", *self.checks])
            for student in sorted(self.rows):
                row = self.rows[student]
                if self.status(student) == MISSING:
                    empty = ["" for _ in self.checks]
                    writer.writerow([student, "", f"{self.max_score:g}", "", MISSING, "", *empty])
                    continue
                percent = 100.0 * row["score"] / self.max_score if self.max_score else 0.0
                points = [row["checks"].get(name, 0.0) for name in self.checks]
                score, top = f"{row['score']:g}", f"{self.max_score:g}"
                documented = "" if row.get("documentation") is None else f"{row['documentation']:.1f}"
                cells = [student, score, top, f"{percent:.1f}", GRADED, documented, *[f"{p:g}" for p in points]]
                writer.writerow(cells)


# -- finding submissions ---------------------------------------------------------------------------------
GRADED, MISSING = "graded", "missing"


def handed_in(folder: Path) -> bool:
    """Whether a student's submission folder holds anything to grade: the package or a notebook (nbgrader's
    ``submitted/{student}/`` without ``{homework}/`` holds neither)."""
    if not folder.is_dir():
        return False
    return (folder / PACKAGE).exists() or any(folder.glob("*.ipynb"))


def find_submissions(submissions_dir: Path, homework: str, roster: list[str] = ()) -> list[Submission]:
    """The submissions in a folder: nbgrader's ``submitted/{student}/{homework}/``, a plain folder of
    student folders (each holding ``modules/`` or ``{homework}/modules/``), or one submission.

    Every student of the ``roster`` and of nbgrader's gradebook (``gradebook.db`` of the course root) and
    every student folder is listed; one who handed nothing in for ``homework`` is ``missing``. In nbgrader's
    layout a student folder without ``{homework}/`` is missing; in a plain folder, one without ``modules/``
    and without a notebook."""
    given = Path(submissions_dir)
    root = given
    if not root.is_dir():
        raise FileNotFoundError(f"no folder {root}")
    if (root / "submitted").is_dir():
        root = root / "submitted"
    if (root / PACKAGE).is_dir():
        return [Submission(staging.readable(root.resolve().name), root.resolve())]
    found = {}
    for folder in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith((".", "_"))):
        nested = folder / homework
        path = (nested if nested.is_dir() else folder).resolve()
        student = staging.readable(folder.name)  # a name of any bytes, as text (results, gradebook, seeds)
        found[student] = Submission(student, path, missing=not handed_in(path))
    for student in [*roster, *gradebook_students(given)]:
        if student not in found:
            found[student] = Submission(student, (root / student / homework).resolve(), missing=True)
    return [found[s] for s in sorted(found)]


def gradebook_students(course: Path) -> list[str]:
    """The students of nbgrader's gradebook (``gradebook.db`` in the course root, or in ``build/`` of this
    course's layout), or none."""
    import sqlite3

    course = course.parent if course.name == "submitted" else course
    for path in (course / "gradebook.db", course.parent / "gradebook.db"):
        if path.is_file():
            try:
                with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as db:
                    return sorted(str(row[0]) for row in db.execute("SELECT id FROM student"))
            except sqlite3.Error:
                return []
    return []


def read_roster(path: str | Path) -> list[str]:
    """The student ids of a roster CSV: the column ``student``, ``student_id``, ``id`` or ``username`` (the
    first of these), or else the first column; raises ``ValueError`` when there is none."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise ValueError(f"{path}: the roster is empty")
    header = [h.strip().lower() for h in rows[0]]
    for name in ("student", "student_id", "id", "username"):
        if name in header:
            column = header.index(name)
            return [r[column].strip() for r in rows[1:] if len(r) > column and r[column].strip()]
    return [r[0].strip() for r in rows if r and r[0].strip()]


def missing_row(student: str) -> dict:
    """The gradebook row of a student who handed nothing in."""
    return {"student": student, "score": None, "checks": {}, "resumed": False, "seconds": 0.0, "status": MISSING}


def _forget(out_dir: Path, student: str) -> None:
    """A missing student has no result and no feedback page (one from an earlier run is removed)."""
    for path in (out_dir / "results" / f"{student}.json", out_dir / "feedback" / f"{student}.html"):
        path.unlink(missing_ok=True)


# -- fingerprints and protected paths ----------------------------------------------------------------------
def _reference_fingerprint(homework: Homework) -> str:
    """Changes with a stored reference, a public scene file, and (hidden and per-student scenes) the course
    secret, the hidden scenes' content and the reference package's source."""
    digest = hashlib.sha256()
    scenes = sorted({c.scene for c in homework.checks})
    for scene in scenes:
        kind = scene_kind(scene)
        if kind == HIDDEN:
            digest.update(f"{scene}:{load_scene(scene).fingerprint()}".encode())
            continue
        path = HERE / "scenes" / f"{scene.split('/', 1)[1]}.yaml" if kind == STUDENT else reference_file(scene)
        digest.update(scene.encode())
        if path.is_file():
            stat = path.stat()
            digest.update(f"{stat.st_size}:{stat.st_mtime_ns}".encode())
    if needs_secret(homework.checks):
        digest.update(f"{secret_digest()}|{solutions_fingerprint()}|{FORMAT}".encode())
    return digest.hexdigest()[:16]


def needs_secret(checks: list[CheckSpec]) -> bool:
    """Whether any of the checks runs on a hidden or per-student scene (made from the course secret)."""
    return any(scene_kind(c.scene) != PUBLIC for c in checks)


def submission_fingerprint(submission: Submission, homework: Homework, limits: Limits, isolation: str = "os") -> str:
    """Changes when the student's package, the checks, the reference, the grader or its isolation change.

    The package is read as it is staged (``mbdkit.staging``): its regular files (names as bytes, sizes and
    contents), what is left out with the reason (a link's target is never read), or why it is refused."""
    digest = hashlib.sha256(
        f"{GRADER_VERSION}|{isolation}|{homework.fingerprint()}|{_reference_fingerprint(homework)}".encode()
    )
    digest.update(repr(sorted(vars(limits).items())).encode())
    digest.update(os.fsencode(submission.student) + b"\0")
    found = staging.scan(submission.path, PACKAGE)
    digest.update(f"refused:{found.refused}\0".encode())
    for path, why in sorted(found.skipped.items()):
        digest.update(os.fsencode(path) + f"\0skipped:{why}\0".encode())
    for file in found.files:
        digest.update(os.fsencode(file.path) + b"\0" + _file_digest(submission.path, file))
    return digest.hexdigest()


FINGERPRINT_BYTES = 4 * 2**20
"""Of a submitted file, the fingerprint reads at most this much (and its size): a huge file costs no more."""


def _file_digest(folder: Path, file: staging.File) -> bytes:
    """What a regular file of the package adds to the fingerprint: its size and first FINGERPRINT_BYTES,
    read without following a link (a file that changed since the scan adds its modification time)."""
    try:
        handle = staging.open_file(folder, PACKAGE, file)
    except OSError:
        return f"changed:{file.size}:{file.mtime_ns}\0".encode()
    with os.fdopen(handle, "rb") as f:
        return f"size:{file.size}:".encode() + hashlib.sha256(f.read(FINGERPRINT_BYTES)).digest()


def protected_paths(extra: tuple[Path, ...] = ()) -> tuple[list[Path], list[Path]]:
    """(folders a sandbox may not read, folders removed from its import path)."""
    forbidden = [HERE, config_dir(), course_cache(), reference_dir("public")]
    if hidden_override() is not None:
        forbidden.append(hidden_override())
    spec = find_spec("solutions")
    if spec is not None and spec.submodule_search_locations:
        forbidden += [Path(p) for p in spec.submodule_search_locations]
    forbidden += [Path(p) for p in extra]
    hide = [HERE.parent] if (HERE.parent / "solutions").is_dir() else []
    return forbidden, hide


# -- running the checks of one submission ---------------------------------------------------------------------
_STORED: dict[str, Reference] = {}


def stored_reference(scene: str) -> Reference:
    """A public scene's stored reference (read once per process)."""
    path = reference_file(scene)
    stamp = f"{path}:{path.stat().st_mtime_ns if path.is_file() else 0}"
    if stamp not in _STORED:
        _STORED[stamp] = load_reference(scene)
    return _STORED[stamp]


def computed_hidden_reference(scene: Scene, checks: list[CheckSpec]) -> Reference:
    """A hidden scene's reference for the probes of ``checks`` on it, computed (or taken from the cache) once
    per process."""
    specs = probe_specs(checks).get(scene.name, {})
    stamp = f"{scene.name}|{scene.fingerprint()}|{sorted(specs.items())!r}"
    if stamp not in _STORED:
        _STORED[stamp] = hidden_reference(scene.name, checks)
    return _STORED[stamp]


def prepare_references(homework: Homework, progress: bool = False) -> None:
    """Every reference the homework's public and hidden checks need, before any student is graded: fails early
    (a stored reference missing, no course secret), and computes the hidden ones once, into the cache, so
    that parallel workers read them (``progress``: say so on stderr while it runs)."""
    if needs_secret(homework.checks):
        course_secret()  # SecretMissing, saying how to make one
    start = time.perf_counter()
    for scene in sorted({c.scene for c in homework.checks}):
        kind = scene_kind(scene)
        if kind == PUBLIC:
            stored_reference(scene)
        elif kind == HIDDEN:
            if progress:
                print(f"\rhidden references: {scene} ...", end="", file=sys.stderr, flush=True)
            computed_hidden_reference(load_scene(scene), homework.checks)
    if progress and any(scene_kind(c.scene) == HIDDEN for c in homework.checks):
        took = time.perf_counter() - start
        print(f"\rhidden references: ready in {took:.1f} s (cached in {cache_dir()})", file=sys.stderr)


class GraderData(PublicData):
    """Every scene of a homework for one student: public and hidden scenes with their stored references,
    the student's own variants made now; invariants measured with the reference package."""

    def __init__(self, student: str, homework: str):
        super().__init__()
        self.student, self.homework = student, homework

    def scene(self, name: str) -> Scene:
        if name not in self._scenes:
            self._scenes[name] = load_scene(name, student=self.student, homework=self.homework)
        return self._scenes[name]

    def reference(self, scene: Scene, checks: list[CheckSpec]) -> Reference:
        if scene.kind == HIDDEN:
            return computed_hidden_reference(scene, checks)
        if scene.kind != STUDENT:
            return stored_reference(scene.name)
        if scene.name not in self._references:
            specs = probe_specs(checks)[scene.name]
            self._references[scene.name] = student_reference(scene.name, self.student, self.homework, specs)
        return self._references[scene.name]

    def measure(self, scene: Scene, sandbox: Sandbox) -> Measure:
        return lambda outputs: invariants(scene.data, outputs["t"], outputs["q"], outputs["qd"])

    def mistakes(self, check: CheckSpec, scene: Scene, job: Job) -> Mistakes | None:
        if scene.kind != STUDENT:
            return None  # stored with the reference
        return lambda output: []  # a per-student check names no cause (mbdkit.withheld): nothing to replay


def run_checks(
    checks: list[CheckSpec],
    folder: Path,
    homework: str,
    student: str | None = None,
    limits: Limits | None = None,
    forbidden: tuple[Path, ...] = (),
    isolation: str | None = None,
    budget: float | None = None,
) -> list[Outcome]:
    """Run ``checks`` (public, hidden, per-student) on the package in ``folder`` for one student, within
    ``budget`` seconds of wall-clock time for them all (the homework's ``budget``).

    ``isolation``: ``os`` (default: the student's code runs under bubblewrap, ``mbdkit.isolation``; raises
    ``IsolationUnavailable`` where it cannot) or ``local`` (unsafe; ``MBD_UNSAFE_NO_ISOLATION=1``).
    """
    if needs_secret(checks):
        course_secret()  # SecretMissing (saying how to make one) before any student code runs
    blocked, hide = protected_paths(forbidden)
    data = GraderData(student or "", homework)
    mode = isolation_mode(isolation)
    return runner.run_checks(
        checks, folder, data, limits, forbidden=tuple(blocked), hide=tuple(hide), isolation=mode, budget=budget
    )


# -- one student, with its outputs -----------------------------------------------------------------------------
def result_json(
    homework: Homework,
    student: str,
    outcomes: list[Outcome],
    fingerprint: str,
    isolation: str = "os",
) -> dict:
    """The result JSON of one submission (Gradescope's format: it may be shown to the student). It holds
    nothing the student's code can steer but through the grader's own words: no timing (how long a
    submission took is the instructor's, ``OUT/timing/``)."""
    score = sum(o.points for o in outcomes)
    shown = [o for o in outcomes if o.kind != HIDDEN]
    failed = [o for o in shown if not o.passed]
    held = len(outcomes) - len(shown)
    unsafe = "" if isolation == "os" else f" [graded {ISOLATION_NOTE[isolation]}]"
    later = f"; {held} checks on hidden scenes are shown once the grades are published" if held else ""
    return {
        "score": score,
        "max_score": homework.max_score,
        "output": f"{homework.name}: {len(failed)} of {len(shown)} checks failed{later}{unsafe}",
        "visibility": "visible",
        "stdout_visibility": "hidden",
        "tests": [o.to_test() for o in outcomes],
        "extra_data": {
            "student": student,
            "homework": homework.name,
            "fingerprint": fingerprint,
            "grader_version": GRADER_VERSION,
            "isolation": isolation,
            "isolation_note": ISOLATION_NOTE[isolation],
        },
    }


def _summary(result: dict, resumed: bool, seconds: float = 0.0) -> dict:
    return {
        "student": result["extra_data"]["student"],
        "score": result["score"],
        "checks": {t["name"]: t["score"] for t in result["tests"]},
        "resumed": resumed,
        "seconds": seconds,
        "internal_error": bool(result["extra_data"].get("internal_error")),
        "status": GRADED,
        "documentation": result["extra_data"].get("documentation", {}).get("percent"),
    }


INTERNAL_ERROR = (
    "internal error while grading ({kind}): not a fault of your code; the instructor has the details "
    "and grades this submission again"
)
"""Every check's message when grading a submission failed in the grader itself (a fixed text: the
exception's own words, which might quote a hidden scene, go only to the instructor's log)."""


def _note_left_out(outcomes: list[Outcome], note: str) -> None:
    """Add what the grader left out of the package to every failed check's message."""
    for outcome in outcomes:
        if not outcome.passed:
            outcome.message += f" (note: {note})"


def _grade_checks(
    homework: Homework, submission: Submission, limits: Limits, forbidden: tuple, isolation: str
) -> tuple[list[Outcome], str]:
    """The outcomes of one submission and a note on what of its package was left out ('' if nothing)."""
    refused = staging.refusal(submission.path, PACKAGE)
    if refused is not None:  # ``modules`` is a link (to solutions/, say): nothing of the student's to grade
        return [failed(c, refused) for c in homework.checks], refused
    student, budget = submission.student, homework.budget
    outcomes = run_checks(
        homework.checks, submission.path, homework.name, student, limits, forbidden, isolation, budget
    )
    note = ""
    if isolation == "os":  # the staged copy (the unsafe local backend runs the folder as it is)
        found = staging.scan(submission.path, PACKAGE)
        staging.select(found, osi.MAX_FILES, osi.MAX_FILE_BYTES, osi.MAX_SUBMISSION_BYTES)
        note = staging.note(found, PACKAGE)
        if note:
            _note_left_out(outcomes, note)
    return outcomes, note


def grade_one(
    homework: Homework, submission: Submission, limits: Limits, forbidden: tuple = (), isolation: str = "os"
) -> tuple[dict, str, str, float]:
    """Grade one submission: (result JSON, feedback page, log for the instructor: '' or a traceback, seconds).

    Never raises an ``Exception`` for one submission: whatever goes wrong in the grader (a bug, a sandbox
    that cannot start) becomes that student's result, every check failed with ``INTERNAL_ERROR``,
    marked ``extra_data.internal_error`` (never resumed: the next run grades it again)."""
    start = time.perf_counter()
    student = submission.student
    try:
        fingerprint = submission_fingerprint(submission, homework, limits, isolation)
        outcomes, note = _grade_checks(homework, submission, limits, forbidden, isolation)
        result = result_json(homework, student, outcomes, fingerprint, isolation)
        if note:
            result["output"] += f" (note: {note})"
        documentation = measure_documentation(homework.name, submission.path)  # read, never run
        result["extra_data"]["documentation"] = documentation.to_json()
        page = feedback_html(student, homework.name, homework.title, outcomes, documentation=documentation.html())
        return result, page, "", time.perf_counter() - start
    except Exception as err:  # noqa: BLE001 - the last guard: one submission never stops the others
        log = f"{student}: internal error while grading {homework.name}\n{traceback.format_exc()}"
        result, page = internal_error(homework, student, type(err).__name__, isolation)
        return result, page, log, time.perf_counter() - start


def internal_error(homework: Homework, student: str, kind: str, isolation: str) -> tuple[dict, str]:
    """The result and feedback page of a student whose grading failed in the grader (``kind``: what)."""
    message = INTERNAL_ERROR.format(kind=kind)
    outcomes = [failed(c, message) for c in homework.checks]
    result = result_json(homework, student, outcomes, "", isolation)
    result["extra_data"]["internal_error"] = True
    result["output"] = f"{homework.name}: {message}"
    return result, feedback_html(student, homework.name, homework.title, outcomes)


def write_graded(out_dir: Path, student: str, result: dict, page: str, log: str, seconds: float | None = None) -> dict:
    """Write one student's feedback page, the instructor's log of an internal error (or remove an old
    one), the seconds grading took (``timing/``, the instructor's) and the result (last: it marks them done);
    returns the gradebook row."""
    write_atomic(out_dir / "feedback" / f"{student}.html", page)
    error_log = out_dir / "errors" / f"{student}.txt"
    if log:
        write_atomic(error_log, log)
    else:
        error_log.unlink(missing_ok=True)
    if seconds is not None:
        write_atomic(out_dir / "timing" / f"{student}.txt", f"{seconds:.3f}\n")
    write_atomic(out_dir / "results" / f"{student}.json", json.dumps(result, indent=1))
    return _summary(result, resumed=False, seconds=seconds or 0.0)


def grade_submission(
    homework: Homework,
    submission: Submission,
    out_dir: Path,
    limits: Limits,
    forbidden: tuple[Path, ...] = (),
    isolation: str = "os",
) -> dict:
    """Grade one submission and write its result JSON and feedback page; returns its gradebook row."""
    return write_graded(out_dir, submission.student, *grade_one(homework, submission, limits, forbidden, isolation))


def _resumable(path: Path, fingerprint: str) -> dict | None:
    try:
        result = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(result, dict) or not isinstance(result.get("extra_data"), dict):
        return None
    if result["extra_data"].get("fingerprint") != fingerprint or result["extra_data"].get("internal_error"):
        return None
    return result


def worker_init() -> None:
    """In this process before it starts workers, and in every Dask worker (``batch.executor``'s ``setup``,
    also in one that replaces a worker that died): one BLAS thread for the sandboxes it starts. A worker of
    a LocalCluster dies with the grader, its sandboxes with it (``solutions.batch``: ``PR_SET_PDEATHSIG``;
    bubblewrap's ``--die-with-parent``)."""
    for key, value in SANDBOX_ENV.items():
        os.environ.setdefault(key, value)


def grade_task(shared: tuple, submission: Submission) -> tuple[dict, str, str, float]:
    """One task of ``batch.run`` (here or on a worker): ``grade_one`` of ``submission``, writing nothing
    (the grader writes what it returns); ``shared`` is (homework, limits, forbidden, isolation)."""
    homework, limits, forbidden, isolation = shared
    return grade_one(homework, submission, limits, forbidden, isolation)


def grade(
    homework: str | Homework,
    submissions_dir: str | Path,
    out_dir: str | Path,
    jobs: int = 2,
    *,
    limits: Limits | None = None,
    progress: bool = True,
    resume: bool = True,
    isolation: str | None = None,
    cluster: str | None = None,
    publish_hidden: bool = False,
    roster: list[str] | tuple[str, ...] = (),
) -> Gradebook:
    """Grade every submission in ``submissions_dir`` for ``homework``; write results to ``out_dir``.

    Parameters
    ----------
    homework : 'hw1', 'hw2', 'hw3' (the checks of autograder/hwN.toml), or a ``Homework``
    submissions_dir : nbgrader's course root or ``submitted/`` folder, or a folder of student folders
    out_dir : where results/, feedback/ and gradebook.csv go (created)
    jobs : students graded at the same time: 1 grades one by one in this process, more on a Dask LocalCluster
        of ``jobs`` worker processes (``solutions.batch.cluster_for``, as ``mbd grade --jobs``)
    limits : the sandbox's resource limits (defaults: ``Limits()``)
    progress : a progress bar on stderr
    resume : reuse the result of a student whose submission, checks and reference did not change

    Per-student references run on the compiled engine where its code is cached (``reference.STUDENT_ENGINE``);
    with WARM_MIN_STUDENTS submissions or more to grade, it is compiled first (``reference.warm``).
    isolation : ``os`` (default): student code runs under bubblewrap (``mbdkit.isolation``), and grading
        refuses to start (``IsolationUnavailable``) where it cannot; ``local``: the unsafe forkserver
        sandbox (``MBD_UNSAFE_NO_ISOLATION=1`` makes it the default), said so in every result
    cluster : grade on Dask: 'local' (a LocalCluster of ``jobs`` workers) or a scheduler address
        'tcp://HOST:PORT' (every worker must see the submissions at the same path, have bubblewrap, the course
        and its secret); None (default): as ``jobs`` says
    publish_hidden : show the hidden checks' results on every feedback page (``publish_feedback``: also the
        pages of students whose result is reused); by default a page holds them back and says so
    roster : student ids expected to hand in (``read_roster``): one without a submission is *missing*, as is
        a student of nbgrader's gradebook or a student folder without this homework

    Returns
    -------
    Gradebook
        Also written as ``out_dir/gradebook.csv``.

    Raises
    ------
    SecretMissing
        No course secret is configured (``autograder.secret``; ``mbd secret --init`` makes one): the hidden and
        per-student scenes are made from it. Raised before any output folder is made.
    GradingInterrupted
        On Ctrl-C: what was graded is written; the same call resumes from it.
    BatchError
        For ``jobs`` < 1, a ``cluster`` that is neither 'local' nor an address, or a scheduler that does not
        answer (``solutions.batch``).
    """
    homework = homework if isinstance(homework, Homework) else load_homework(homework)
    batch.cluster_for(jobs, cluster)  # a bad jobs or cluster refused before any output folder is made
    limits = limits or Limits()
    isolation = isolation_mode(isolation)
    if isolation == "os":
        osi.require()  # before any output folder is made
    out_dir = Path(out_dir).resolve()
    submissions = find_submissions(Path(submissions_dir), homework.name, list(roster))
    prepare_references(homework, progress)  # fails early (no secret, a stored reference missing); hidden ones computed
    out_dir.mkdir(parents=True, exist_ok=True)  # only once the grading can start
    forbidden = (out_dir, Path(submissions_dir).resolve())
    book = Gradebook(
        homework.name,
        [c.name for c in homework.checks],
        {c.name: c.points for c in homework.checks},
        out_dir=out_dir,
        isolation=isolation,
    )
    for submission in submissions:
        if submission.missing:  # nothing handed in: no result, no page, not a 0
            book.rows[submission.student] = missing_row(submission.student)
            _forget(out_dir, submission.student)
    submissions = [s for s in submissions if not s.missing]
    try:
        _grade_all(homework, submissions, book, (limits, forbidden, isolation), jobs, cluster, resume, progress)
    except KeyboardInterrupt:
        book.write_csv()
        raise GradingInterrupted(len(book.graded), len(submissions)) from None
    if publish_hidden:
        publish_feedback(out_dir, [s.student for s in submissions])
    return book


class GradingInterrupted(Exception):
    """Ctrl-C: ``done`` of ``total`` submissions are graded (their results written); the same call resumes."""

    def __init__(self, done: int, total: int):
        super().__init__(f"interrupted; {done} of {total} submissions graded, run the same command again to resume")
        self.done, self.total = done, total


def _grade_all(
    homework: Homework,
    submissions: list[Submission],
    book: Gradebook,
    shared: tuple[Limits, tuple, str],
    jobs: int,
    cluster: str | None,
    resume: bool,
    progress: bool,
) -> None:
    """Grade the handed-in ``submissions`` into ``book``, as ``grade`` says: a submission whose stored result has
    its fingerprint is resumed; the others are graded where ``solutions.batch`` says (here, or Dask's workers),
    and only this process writes, as each result arrives."""
    limits, forbidden, isolation = shared
    if resume:
        for submission in submissions:
            result = _resumed(submission, homework, limits, isolation, book.out_dir)
            if result is not None:
                book.rows[submission.student] = _summary(result, resumed=True)
    book.write_csv()
    items = {s.student: s for s in submissions}
    todo = len([s for s in items if s not in book.rows])
    if todo >= WARM_MIN_STUDENTS:  # per-student references on the compiled engine: compile once, here
        warm(homework.name, homework.checks)
    worker_init()  # a LocalCluster's workers inherit one BLAS thread from here
    options = {"shared": (homework, *shared), "done": book.rows, "unit": "student", "progress": progress}
    with without_main(), batch.executor(jobs, cluster, worker_init, tasks=todo) as where:
        for finished in batch.run(grade_task, items, where, name=f"grade {homework.name}", **options):
            book.rows[finished.key] = _write_finished(book.out_dir, homework, finished, isolation)
            book.write_csv()


def _write_finished(out_dir: Path, homework: Homework, finished: batch.Finished, isolation: str) -> dict:
    """Write what a grading task returned; a task that failed (its worker killed, on every retry) is that
    student's internal error, graded again on the next run. Returns the gradebook row."""
    student = finished.key
    if finished.error is None:
        return write_graded(out_dir, student, *finished.value)
    log = f"{student}: the grading worker failed\n{finished.traceback}"
    result, page = internal_error(homework, student, type(finished.error).__name__, isolation)
    return write_graded(out_dir, student, result, page, log)


def _resumed(submission: Submission, homework: Homework, limits: Limits, isolation: str, out_dir: Path) -> dict | None:
    """The stored result of a submission that has not changed since it was graded, or None."""
    try:
        fingerprint = submission_fingerprint(submission, homework, limits, isolation)
    except OSError:  # a folder that cannot be read now: grade it (its worker says what went wrong)
        return None
    return _resumable(out_dir / "results" / f"{submission.student}.json", fingerprint)


def publish_feedback(out_dir: str | Path, students: list[str] | None = None) -> list[str]:
    """Add the hidden checks' results (from each results JSON) to the feedback pages of ``students`` (all with
    a result by default), which were written holding them back; returns the students whose page it wrote."""
    out_dir = Path(out_dir)
    if students is None:
        students = sorted(p.stem for p in (out_dir / "results").glob("*.json"))
    written = []
    for student in students:
        page_path = out_dir / "feedback" / f"{student}.html"
        try:
            result = json.loads((out_dir / "results" / f"{student}.json").read_text())
            page = page_path.read_text()
        except (OSError, ValueError):
            continue
        published = publish(page, result)
        if published is not None:
            write_atomic(page_path, published)
            written.append(student)
    return written
