"""Before nbgrader's autograde: a check of every collected notebook against the release (``mbd nbcheck hwN``).

nbgrader grades a submission by the grade ids of its cells, in the notebook named as the released one; an
ordinary slip of a student changes its total with no warning, while ``mbd grade`` (which grades the package
``modules/``) does not see it. For each student of ``build/submitted/`` this says what nbgrader will do, and
with ``--repair`` repairs what is safe to repair:

- **the notebook renamed** (``hw1 (1).ipynb``, ``hw1-copy.ipynb``), the only one: nbgrader grades only
  ``hw1.ipynb``, so nothing (and ``zip_collect`` drops such a file with exit 0). Repair: renamed to the
  released name (or copied so from the archive zip_collect unpacked, ``build/downloaded/hwN/extracted/``);
- **several notebooks, none the released one**: nbgrader grades none. No repair: which one is unclear;
- **a cell twice** (the same grade id): nbgrader fails the whole submission (its log says ``nbgrader update
  .``, which does not help). Repair: a locked cell's later copies removed (nbgrader puts the released text
  of a locked cell back anyway); an answer cell's copies appended to the first (nothing is lost);
- **a graded test cell deleted**: nbgrader loses its points, silently. Repair: restored from the release,
  after the cell that precedes it there (its points come from ``modules/``, as ``mbd grade`` gives them);
- **a graded answer cell deleted**: its points are lost. No repair: the answer is gone;
- **a locked cell changed** (its checksum): nbgrader puts the released text back (``OverwriteCells``);
- **nothing collected** for a student with an archive: nothing to grade. No repair: see the archive.

The exit code is 1 while anything is left that makes nbgrader's total differ from ``mbd grade``'s (or a
student has nothing collected), else 0. nbgrader's ``autograde`` runs this check first (with the repairs:
``course/nbgrader_config.py``).
"""

from __future__ import annotations

import copy
import csv
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path

import nbformat

from autograder.lms import COLLECTED

ROOT = Path(__file__).resolve().parents[1]
FORMAT = 4


@dataclass
class Finding:
    """One problem of one student's submission."""

    student: str
    what: str
    nbgrader: str
    repair: str = ""
    """What ``--repair`` does (or did); empty: nothing is safe to do."""
    repaired: bool = False

    @property
    def differs(self) -> bool:
        """Whether nbgrader's total will differ from ``mbd grade``'s because of it (not repaired)."""
        return not self.repaired and not self.nbgrader.startswith(HARMLESS)

    def line(self) -> str:
        done = f"; repaired: {self.repair}" if self.repaired else (f"; --repair: {self.repair}" if self.repair else "")
        return f"  {self.student}: {self.what}; nbgrader {self.nbgrader}{done}"


HARMLESS = ("puts the released text back", "ignores")


@dataclass
class Report:
    """What the check found in one homework's collected submissions."""

    homework: str
    students: list[str] = field(default_factory=list)
    findings: list[Finding] = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        return 1 if any(f.differs for f in self.findings) else 0

    def text(self) -> str:
        head = f"{self.homework}: {len(self.students)} submissions checked"
        if not self.findings:
            return head + ", every notebook as released"
        lines = [head + f", {len(self.findings)} problems:", *(f.line() for f in self.findings)]
        left = [f for f in self.findings if f.differs]
        if left:
            lines.append(f"{len(left)} left that change nbgrader's total (run mbd nbcheck {self.homework} --repair)")
        return "\n".join(lines)


# -- the release --------------------------------------------------------------------------------------------
def released_notebooks(course: Path, homework: str) -> dict[str, nbformat.NotebookNode]:
    """The released notebooks of ``homework`` by file name (build/release/hwN/, else assignments/hwN/)."""
    for folder in (course / "build" / "release" / homework, course / "assignments" / homework):
        found = sorted(folder.glob("*.ipynb"))
        if found:
            return {p.name: nbformat.read(p, as_version=FORMAT) for p in found}
    raise FileNotFoundError(f"no released notebook of {homework} (run mbd release {homework})")


def _meta(cell) -> dict:
    return cell.get("metadata", {}).get("nbgrader", {}) or {}


def _grade_id(cell) -> str | None:
    return _meta(cell).get("grade_id")


def _graded(cell) -> bool:
    return bool(_meta(cell).get("grade"))


def _checksum(cell) -> str:
    from nbgrader.utils import compute_checksum

    return compute_checksum(cell)


# -- one notebook ------------------------------------------------------------------------------------------
def check_cells(student: str, notebook, release, repair: bool) -> tuple[list[Finding], bool]:
    """Grade ids duplicated or missing, locked cells changed; (findings, whether the notebook was changed)."""
    findings, changed = [], False
    released = {_grade_id(c): c for c in release.cells if _grade_id(c)}
    seen: dict[str, int] = {}
    keep = []
    for cell in notebook.cells:
        gid = _grade_id(cell)
        if gid is None or gid not in seen:
            if gid is not None:
                seen[gid] = len(keep)
            keep.append(cell)
            continue
        first = keep[seen[gid]]
        locked = bool(_meta(first).get("locked"))
        what = f"cell {gid} is in the notebook twice" + (" (a graded cell)" if _graded(first) else "")
        fate = "fails the whole submission (its log says `nbgrader update .`, which does not help)"
        if locked:
            fix = "the later copy removed (a locked cell: nbgrader puts the released text back anyway)"
        else:
            fix = "the later copy's text appended to the first (nothing of the answer is lost) and the copy removed"
            if repair:
                first.source = first.source.rstrip("\n") + "\n\n" + cell.source
        findings.append(Finding(student, what, fate, fix, repaired=repair))
        if not repair:
            keep.append(cell)
    if repair and len(keep) != len(notebook.cells):
        notebook.cells, changed = keep, True
    present = {_grade_id(c) for c in notebook.cells}
    order = [_grade_id(c) for c in release.cells]
    for index, gid in enumerate(order):
        cell = released.get(gid)
        if gid is None or gid in present or not _graded(cell):
            continue
        points = _meta(cell).get("points", 0)
        if _meta(cell).get("solution"):
            findings.append(
                Finding(student, f"graded answer cell {gid} deleted ({points:g} points)", "gives it 0, silently")
            )
            continue
        fix = "restored from the release (a test cell: its points come from modules/, as mbd grade gives them)"
        findings.append(
            Finding(student, f"graded test cell {gid} deleted ({points:g} points)", "gives it 0, silently", fix, repair)
        )
        if repair:
            before = [g for g in order[:index] if g in {_grade_id(c) for c in notebook.cells}]
            at = next(i for i, c in enumerate(notebook.cells) if _grade_id(c) == before[-1]) + 1 if before else 0
            notebook.cells.insert(at, copy.deepcopy(cell))
            changed = True
    for cell in notebook.cells:
        gid, meta = _grade_id(cell), _meta(cell)
        source = released.get(gid)
        if not meta.get("locked") or source is None or "checksum" not in _meta(source):
            continue
        if cell.get("cell_type") == source.get("cell_type") and _checksum(cell) != _meta(source)["checksum"]:
            restored = "puts the released text back (OverwriteCells)"
            findings.append(Finding(student, f"locked cell {gid} changed", restored))
    return findings, changed


# -- one student --------------------------------------------------------------------------------------------
def _extracted(course: Path, homework: str, student: str) -> list[Path]:
    """The notebooks of a student's archive as zip_collect unpacked it (build/downloaded/hwN/extracted/)."""
    folder = course / "build" / "downloaded" / homework / "extracted" / student
    return sorted(p for p in folder.rglob("*.ipynb") if ".ipynb_checkpoints" not in p.parts) if folder.is_dir() else []


def check_student(course: Path, homework: str, student: str, release: dict, repair: bool) -> list[Finding]:
    """Every problem of one student's collected submission (``build/submitted/STUDENT/hwN/``)."""
    folder = course / "build" / "submitted" / student / homework
    expected = sorted(release)
    notebooks = sorted(folder.glob("*.ipynb")) if folder.is_dir() else []
    findings = []
    names = {p.name for p in notebooks}
    for name in expected:
        if name in names:
            continue
        others = [p for p in notebooks if p.name not in release]
        source = others if others else [p for p in _extracted(course, homework, student) if p.name not in release]
        dropped = "" if others else " (zip_collect dropped it: not the released name, exit 0)"
        if len(source) == 1:
            fix = f"{source[0].name} renamed to {name}" if others else f"{source[0].name} collected as {name}"
            findings.append(
                Finding(
                    student,
                    f"the notebook is {source[0].name!r}, not {name!r}{dropped}",
                    "grades nothing of it: 0",
                    fix,
                    repair,
                )
            )
            if repair:
                folder.mkdir(parents=True, exist_ok=True)
                (shutil.move if others else shutil.copy2)(source[0], folder / name)
                notebooks = sorted(folder.glob("*.ipynb"))
        elif source:
            listed = ", ".join(repr(p.name) for p in source)
            findings.append(Finding(student, f"no {name!r} but several notebooks: {listed}", "grades none of them: 0"))
        elif not folder.is_dir():
            findings.append(Finding(student, "nothing collected for this homework", "has nothing to grade"))
        else:
            findings.append(Finding(student, f"no notebook {name!r} handed in", "grades nothing: 0"))
    for path in notebooks:
        if path.name not in release:
            if any(f.what.startswith(f"the notebook is {path.name!r}") for f in findings):
                continue
            findings.append(Finding(student, f"an extra notebook {path.name!r}", "ignores it"))
            continue
        try:
            notebook = nbformat.read(path, as_version=FORMAT)
        except Exception as err:  # noqa: BLE001 -- any unreadable file is this student's finding, not a crash
            findings.append(Finding(student, f"{path.name} is no notebook ({type(err).__name__})", "fails it: 0"))
            continue
        found, changed = check_cells(student, notebook, release[path.name], repair)
        findings += found
        if changed:
            nbformat.write(notebook, path)
    return findings


def students(course: Path, homework: str) -> list[str]:
    """The students with a folder in build/submitted/ or an archive unpacked for ``homework``: a folder of
    extracted/ per student, or, after a platform's download (``LmsCollector.lms``), the students of its
    ``collected.csv`` (extracted/ then holds the download's own folders)."""
    downloaded = course / "build" / "downloaded" / homework
    record = downloaded / COLLECTED
    names = set()
    for folder in (course / "build" / "submitted", *([] if record.is_file() else [downloaded / "extracted"])):
        if folder.is_dir():
            names |= {p.name for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")}
    if record.is_file():
        with open(record, newline="") as f:
            names |= {row["student"] for row in csv.DictReader(f) if row.get("student")}
    return sorted(names)


def check_class(homework: str, course: str | Path = ROOT, repair: bool = False) -> Report:
    """Check (and with ``repair`` repair) every collected submission of ``homework`` in the course root."""
    course = Path(course)
    release = released_notebooks(course, homework)
    report = Report(homework)
    for student in students(course, homework):
        submitted = course / "build" / "submitted" / student
        if submitted.is_dir() and not (submitted / homework).is_dir() and not _extracted(course, homework, student):
            continue  # a student of the course who has only other homeworks here: "missing", not a problem
        report.students.append(student)
        report.findings += check_student(course, homework, student, release, repair)
    return report


def command(homework: str, repair: bool = False, course: str | Path = ROOT) -> int:
    """``mbd nbcheck hwN [--repair]``: print the report; exit 1 while something changes nbgrader's total."""
    try:
        report = check_class(homework, course, repair)
    except FileNotFoundError as err:
        print(f"mbd: error: {err}", file=sys.stderr)
        return 2
    print(report.text())
    return report.exit_code
