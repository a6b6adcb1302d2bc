"""Written-test and oral-exam material: a bank of problems (``problems.py``) with per-student numbers.

Each student's variant of a problem draws its numbers from a generator seeded by the semester's seed, the
student's id and the problem, like the homework's per-student scenes: the same seed and id always give
the same sheet, two students get different numbers. ``python -m course.exam`` writes the sheets.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .problems import PROBLEMS, Problem

__all__ = ["PROBLEMS", "Problem", "Variant", "problem_by_key", "sheet", "variant", "write_sheets"]


@dataclass(frozen=True)
class Variant:
    """One student's numbers of one problem, with the statement and the worked solution."""

    problem: Problem
    student: str
    numbers: dict
    statement: str
    solution: str
    answers: dict[str, float]


def problem_by_key(key: str) -> Problem:
    for problem in PROBLEMS:
        if problem.key == key:
            return problem
    raise KeyError(f"no problem {key!r} (problems: {', '.join(p.key for p in PROBLEMS)})")


def variant(problem: Problem, student: str, seed: int) -> Variant:
    """The student's variant: numbers from a generator seeded by (seed, student, problem)."""
    rng = np.random.default_rng([seed, zlib.crc32(student.encode()), zlib.crc32(problem.key.encode())])
    numbers = problem.draw(rng)
    solution, answers = problem.solution(numbers)
    return Variant(problem, student, numbers, problem.statement(numbers), solution, answers)


def sheet(student: str, seed: int, keys: list[str] | None = None) -> list[Variant]:
    """A student's sheet: the problems ``keys`` (default: the whole bank), in chapter order."""
    chosen = [problem_by_key(k) for k in keys] if keys else sorted(PROBLEMS, key=lambda p: p.chapter)
    return [variant(problem, student, seed) for problem in chosen]


def write_sheets(students: list[str], seed: int, out: Path, keys: list[str] | None = None) -> list[Path]:
    """``STUDENT-test.md`` (statements) and ``STUDENT-solutions.md`` (worked solutions) for every student."""
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for student in students:
        variants = sheet(student, seed, keys)
        test = [f"# Written test: {student}\n"]
        solutions = [f"# Written test: {student}, worked solutions (seed {seed})\n"]
        for k, v in enumerate(variants, start=1):
            heading = f"\n## Problem {k}: {v.problem.title} (notes, chapter {v.problem.chapter})\n\n"
            test.append(heading + v.statement + "\n")
            answers = ", ".join(f"{name} = {value:.6g}" for name, value in v.answers.items())
            solutions.append(
                heading + v.statement + "\n\n**Solution.** " + v.solution + f"\n\n**Answers:** {answers}\n"
            )
        for name, parts in (("test", test), ("solutions", solutions)):
            path = out / f"{student}-{name}.md"
            path.write_text("".join(parts), encoding="utf-8")
            written.append(path)
    return written
