"""The course's final grade (``mbd gradebook``): homework, written test and oral exam in one CSV an LMS imports.

    mbd gradebook build/grades/hw1/gradebook.csv build/grades/hw2/gradebook.csv build/grades/hw3/gradebook.csv \\
        --marks marks.csv --out final.csv

The homework grades come from either route, each in its own scale: ``mbd grade``'s ``gradebook.csv`` (one file
per homework: its name ``hwN`` in the path, or given as ``hwN=FILE``) or nbgrader's export (``nbgrader export``:
one file, a row per student and assignment). Each homework counts as its percentage of its own maximum, so a
homework out of 100 on one route and 110 on the other weighs the same. The marks CSV has a column ``student`` and
one per other part of the grade (``test``, ``oral``), in percent; an empty cell is a mark not (yet) given.

The weights are the course's (``course/grading.toml``: 50 % homework, the mean of the homework percentages,
25 % test, 25 % oral), or ``--weights homework=50,test=25,oral=25``. A missing part (a homework not handed in, a
mark not given) is written as ``missing``, never as 0: the final grade of such a student is left empty and the
``status`` column names what is missing (``--missing-as-zero`` counts it as 0 instead, at the end of a term).

Students document their code: each homework's grade is (100 - share) % of its checks' percent and share % of its
documentation's (``[documentation]`` in ``course/grading.toml``: 10 %). The documentation's percent is the
rubric's points over its maximum: the automatic part, ``automatic`` points times the share of the homework's
functions the student documented (``mbd grade``'s gradebook, column ``documentation``), and the manual part,
points the instructor enters in the marks CSV (column ``hwN_doc``, 0 to ``manual``). Either part not given
leaves the homework's documentation missing, as any other part. nbgrader's export has no automatic part:
``--submitted FOLDER`` measures it from the submissions (nbgrader's ``submitted/{student}/{hwN}/``, as ``mbd
grade`` finds them: read, never run). ``--documentation-share 0`` leaves documentation out.

Every input is checked before anything is written: a file, column or number that is not what it should be is
one line naming the file, the row and what to do (exit code 2).
"""

from __future__ import annotations

import csv
import math
import re
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

from solutions.batch import write_atomic

CONFIGURATION = Path(__file__).resolve().parent / "grading.toml"
MISSING = "missing"
NBGRADER_COLUMNS = {"assignment", "student_id", "score", "max_score"}
MBD_COLUMNS = {"student", "score", "max_score", "status"}


class GradebookError(ValueError):
    """An input that cannot be combined (one line: the file, the row, what to do)."""


@dataclass
class Grades:
    """Percent per student for each part: {part: {student: percent, or None when missing}}."""

    parts: dict[str, dict[str, float | None]]

    def students(self) -> list[str]:
        return sorted({student for marks in self.parts.values() for student in marks})


def read_weights(text: str | None = None, path: Path = CONFIGURATION) -> dict[str, float]:
    """The weights of the parts, in percent: ``text`` ('homework=50,test=25,oral=25') or the course's file."""
    if text is None:
        weights = {k: float(v) for k, v in tomllib.loads(path.read_text())["weights"].items()}
    else:
        weights = {}
        for item in text.split(","):
            name, _, value = item.partition("=")
            try:
                weights[name.strip()] = float(value)
            except ValueError:
                raise GradebookError(
                    f"--weights {text}: write NAME=PERCENT,..., e.g. homework=50,test=25,oral=25"
                ) from None
    if "homework" not in weights or any(w < 0 for w in weights.values()) or abs(sum(weights.values()) - 100) > 1e-9:
        raise GradebookError(f"weights {weights}: a 'homework' weight and the others, >= 0, summing to 100")
    return weights


@dataclass(frozen=True)
class Rubric:
    """The documentation rubric: its share of each homework's grade (percent) and its points."""

    share: float
    automatic: float
    manual: float

    def percent(self, automatic: float | None, manual: float | None) -> float | None:
        """The documentation's percent from the automatic part's percent and the manual points; None when a
        part that has points is not given."""
        if (self.automatic and automatic is None) or (self.manual and manual is None):
            return None
        points = self.automatic * (automatic or 0.0) / 100 + (manual or 0.0)
        return 100.0 * points / (self.automatic + self.manual)


def read_rubric(share: str | None = None, path: Path = CONFIGURATION) -> Rubric:
    """The course's documentation rubric; ``share`` (from ``--documentation-share``) replaces its share."""
    data = tomllib.loads(path.read_text()).get("documentation", {"share": 0, "automatic": 1, "manual": 0})
    try:
        rubric = Rubric(*(float(data[key]) for key in ("share", "automatic", "manual")))
        rubric = rubric if share is None else Rubric(float(share), rubric.automatic, rubric.manual)
    except (KeyError, ValueError):
        raise GradebookError(
            f"--documentation-share {share} or {path} [documentation]: numbers share, automatic, manual"
        ) from None
    if not 0 <= rubric.share <= 100 or min(rubric.automatic, rubric.manual) < 0 or not rubric.automatic + rubric.manual:
        raise GradebookError(
            f"documentation share {rubric.share:g} (0 to 100), automatic {rubric.automatic:g} and manual "
            f"{rubric.manual:g} points (>= 0, not both 0): fix {path} or --documentation-share"
        )
    return rubric


def _rows(path: Path) -> list[dict[str, str]]:
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            return list(csv.DictReader(f))
    except FileNotFoundError:
        raise GradebookError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError, csv.Error) as err:
        raise GradebookError(f"{path}: cannot read it as CSV ({err})") from None


def _number(text: str, path: Path, row: int, column: str) -> float | None:
    """A percentage or score cell: None when empty; GradebookError when not a finite number >= 0."""
    if text is None or not text.strip():
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or value < 0:
        raise GradebookError(
            f"{path}, row {row}, column {column}: {text!r} is not a number >= 0 (leave it empty if missing)"
        )
    return value


def _percent(score: float | None, top: float | None, path: Path, row: int) -> float | None:
    if score is None:
        return None
    if not top:
        raise GradebookError(f"{path}, row {row}: max_score is empty or 0, so the score has no percentage")
    return 100.0 * score / top


def homework_name(text: str) -> tuple[str | None, Path]:
    """'hw2=FILE' -> ('hw2', FILE); a FILE with hwN in its path -> (hwN, FILE); else (None, FILE)."""
    name, sep, rest = text.partition("=")
    if sep and re.fullmatch(r"hw\d+", name):
        return name, Path(rest)
    found = [part for part in Path(text).parts if re.fullmatch(r"hw\d+", part)]
    return (found[-1] if found else None), Path(text)


def read_homework(text: str) -> dict[str, dict[str, float | None]]:
    """{homework: {student: percent or None}} from one file: ``mbd grade``'s gradebook.csv or nbgrader's export."""
    name, path = homework_name(text)
    rows = _rows(path)
    columns = set(rows[0]) if rows else set()
    grades: dict[str, dict[str, float | None]] = {}
    if NBGRADER_COLUMNS <= columns:  # nbgrader's export: every assignment in one file
        for number, row in enumerate(rows, start=2):
            score = _number(row["score"], path, number, "score")
            top = _number(row["max_score"], path, number, "max_score")
            percent = None if not row.get("timestamp", "x") else _percent(score, top, path, number)
            grades.setdefault(row["assignment"], {})[row["student_id"]] = percent
        return grades
    if not MBD_COLUMNS <= columns:
        raise GradebookError(
            f"{path}: neither mbd grade's gradebook.csv (columns {', '.join(sorted(MBD_COLUMNS))}) nor nbgrader's "
            f"export (columns {', '.join(sorted(NBGRADER_COLUMNS))})"
        )
    if name is None:
        raise GradebookError(f"{path}: which homework is it? Name it: hw1={path}")
    grades[name] = {}
    for number, row in enumerate(rows, start=2):
        score = None if row["status"] == MISSING else _number(row["score"], path, number, "score")
        grades[name][row["student"]] = _percent(
            score, _number(row["max_score"], path, number, "max_score"), path, number
        )
    return grades


def read_documented(text: str) -> dict[str, dict[str, float | None]]:
    """{homework: {student: percent of its functions documented, or None}} from ``mbd grade``'s gradebook.csv
    (its ``documentation`` column); {} for a file without one (nbgrader's export, an older gradebook)."""
    name, path = homework_name(text)
    rows = _rows(path)
    if not rows or "documentation" not in rows[0] or name is None:
        return {}
    cells = {row["student"]: _number(row["documentation"], path, k, "documentation") for k, row in enumerate(rows, 2)}
    return {name: cells}


def measured(folder: Path, homework: list[str]) -> dict[str, dict[str, float | None]]:
    """{homework: {student: percent of its functions documented}} measured from the submissions in ``folder``
    (``autograder.documentation``: the files are read, never run); a student who handed nothing in: None."""
    from autograder.documentation import measure
    from autograder.grading import find_submissions

    if not Path(folder).is_dir():
        raise GradebookError(f"--submitted {folder}: no such folder (nbgrader's submitted/, or a folder of students)")
    return {
        name: {s.student: None if s.missing else measure(name, s.path).percent for s in find_submissions(folder, name)}
        for name in homework
    }


def read_manual(path: Path | None, homework: list[str], top: float) -> dict[str, dict[str, float | None]]:
    """{homework: {student: the manual documentation points}} from the marks CSV's ``hwN_doc`` columns (a
    column not there: no points given yet)."""
    rows = _rows(path) if path is not None and top else []
    manual: dict[str, dict[str, float | None]] = {}
    for name in homework:
        column = f"{name}_doc"
        for number, row in enumerate(rows, start=2):
            value = _number(row.get(column), path, number, column)
            if value is not None and value > top:
                raise GradebookError(
                    f"{path}, row {number}, column {column}: {value:g} is over {top:g}, the rubric's manual points "
                    "(course/grading.toml, [documentation] manual)"
                )
            manual.setdefault(name, {})[row["student"]] = value
    return manual


def documentation_percents(
    homework: list[str], automatic: dict, manual: dict, rubric: Rubric, students: list[str]
) -> dict[str, dict[str, float | None]]:
    """{homework: {student: the documentation's percent, or None when a part is not given}}."""
    return {
        h: {s: rubric.percent(automatic.get(h, {}).get(s), manual.get(h, {}).get(s)) for s in students}
        for h in homework
    }


def read_marks(path: Path, parts: list[str]) -> dict[str, dict[str, float | None]]:
    """{part: {student: percent or None}} for the other parts of the grade (``test``, ``oral``)."""
    rows = _rows(path)
    columns = set(rows[0]) if rows else set()
    lacking = [c for c in ("student", *parts) if c not in columns]
    if lacking:
        raise GradebookError(f"{path}: no column {', '.join(lacking)} (the header is student,{','.join(parts)})")
    marks: dict[str, dict[str, float | None]] = {part: {} for part in parts}
    for number, row in enumerate(rows, start=2):
        for part in parts:
            value = _number(row[part], path, number, part)
            if value is not None and value > 100:
                raise GradebookError(
                    f"{path}, row {number}, column {part}: {value:g} is over 100 (marks are in percent)"
                )
            marks[part][row["student"]] = value
    return marks


def final_rows(
    homework: dict,
    marks: dict,
    weights: dict[str, float],
    roster: list[str],
    missing_as_zero: bool,
    documentation: dict | None = None,
    share: float = 0.0,
):
    """The header and one row per student: each homework's percent (and its documentation's, when it has a
    ``share`` of the homework's grade), the mean of the homework grades, each mark, the final grade (weights
    in percent) and what is missing. A missing part leaves the grade empty, or counts as 0."""
    names = sorted(homework, key=lambda h: int(h[2:]))
    parts = [p for p in weights if p != "homework"]
    students = sorted(set(roster) | {s for g in (*homework.values(), *marks.values()) for s in g})
    documentation = documentation or {}
    columns = [c for h in names for c in ((h, f"{h}_doc") if share else (h,))]
    header = ["student", *columns, "homework", *parts, "final", "status"]
    rows = []
    for student in students:
        done = {h: homework[h].get(student) for h in names}
        documented = {h: documentation.get(h, {}).get(student) for h in names}
        given = {p: marks.get(p, {}).get(student) for p in parts}
        lacking = [h for h in names if done[h] is None]
        lacking += [f"{h} documentation" for h in names if share and documented[h] is None]
        unmarked = [p for p in parts if given[p] is None]
        grades = [(100 - share) / 100 * _zero(done[h]) + share / 100 * _zero(documented[h]) for h in names]
        mean = None if lacking and not missing_as_zero else (sum(grades) / len(names) if names else 0.0)
        final = None
        if missing_as_zero or not (lacking or unmarked):
            final = weights["homework"] / 100 * _zero(mean) + sum(weights[p] / 100 * _zero(given[p]) for p in parts)
        status = "complete" if not (lacking or unmarked) else f"{MISSING}: {', '.join(lacking + unmarked)}"
        cells = [_cell(v) for h in names for v in ((done[h], documented[h]) if share else (done[h],))]
        rows.append([student, *cells, _cell(mean), *[_cell(given[p]) for p in parts], _cell(final), status])
    return header, rows


def _zero(value: float | None) -> float:
    """A missing part counted as 0 (``--missing-as-zero``)."""
    return 0.0 if value is None else value


def _cell(value: float | None) -> str:
    return MISSING if value is None else f"{value:.1f}"


def combine(
    homework_files: list[str],
    marks: Path | None,
    out: Path,
    weights: dict[str, float],
    roster: list[str] = (),
    missing_as_zero: bool = False,
    rubric: Rubric = Rubric(0.0, 1.0, 0.0),
    submitted: Path | None = None,
) -> list[list[str]]:
    """Read every input (all checked first), write ``out``; the rows written. ``rubric``: the documentation's
    share of each homework's grade and its points (the default leaves documentation out); ``submitted``: the
    submissions, to measure the automatic part of the homeworks whose grades carry none (nbgrader's)."""
    homework: dict[str, dict[str, float | None]] = {}
    automatic: dict[str, dict[str, float | None]] = {}
    for text in homework_files:
        for name, grades in read_homework(text).items():
            if name in homework:
                raise GradebookError(f"{text}: {name} is given twice")
            homework[name] = grades
        automatic.update(read_documented(text))
    parts = [p for p in weights if p != "homework"]
    given = read_marks(marks, parts) if marks is not None else {}
    if parts and marks is None:
        raise GradebookError(f"the weights give {', '.join(parts)}: --marks FILE.csv with a column for each")
    if not Path(out).parent.is_dir():
        raise GradebookError(f"--out {out}: no folder {Path(out).parent}")
    documentation = {}
    if rubric.share and rubric.automatic and submitted is not None:
        automatic.update(measured(submitted, [h for h in homework if h not in automatic]))
    if rubric.share:
        students = sorted({s for grades in homework.values() for s in grades} | set(roster))
        manual = read_manual(marks, list(homework), rubric.manual)
        documentation = documentation_percents(list(homework), automatic, manual, rubric, students)
    header, rows = final_rows(homework, given, weights, list(roster), missing_as_zero, documentation, rubric.share)

    def write(path: Path) -> None:
        with open(path, "w", newline="") as f:
            csv.writer(f).writerows([header, *rows])

    write_atomic(Path(out), write)
    return [header, *rows]


def command(args) -> int:
    """``mbd gradebook``: 0, or 2 with one line."""
    try:
        weights = read_weights(args.weights)
        rubric = read_rubric(args.documentation_share)
        roster = []
        if args.roster:
            from autograder.grading import read_roster

            roster = read_roster(args.roster)
        marks = Path(args.marks) if args.marks else None
        submitted = Path(args.submitted) if args.submitted else None
        table = combine(args.homework, marks, Path(args.out), weights, roster, args.missing_as_zero, rubric, submitted)
    except (GradebookError, FileNotFoundError, ValueError) as err:
        print(f"mbd: error: {err}", file=sys.stderr)
        return 2
    complete = sum(row[-1] == "complete" for row in table[1:])
    students = len(table) - 1
    print(f"wrote {args.out}: {students} students, {complete} complete, {students - complete} with a part missing")
    return 0
