"""Every function a homework asks students to write is graded: with only that function's solution region
put back to ``raise NotImplementedError``, a submission scores less than the reference.

For each homework, one mutant per solution region of that homework (``### BEGIN SOLUTION hwN``): the
reference package with that region's body, and nothing else, replaced by a raise. All mutants of a
homework are graded together with the reference in one ``grade`` call, with every check of the
homework. (The per-type array versions, ``planar/batched.py`` and ``spatial/batched.py``, have no regions:
they stay with the instructor, and a student's System evaluates the element methods.)
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from autograder.grading import grade
from course.release.generator import HOMEWORKS, Region, all_regions


def asked_regions(homework: str) -> list[Region]:
    """The solution regions students write in ``homework``."""
    return [r for r in all_regions() if r.tag == homework]


def stub_region(package: Path, region: Region) -> None:
    """Replace the region (its markers and body) by ``raise NotImplementedError`` at the marker's indent."""
    path = package / region.path
    lines = path.read_text().split("\n")
    begin, end = lines[region.begin - 1], lines[region.end - 1]
    assert "### BEGIN SOLUTION" in begin and "### END SOLUTION" in end, f"{region.path}:{region.begin}: not a region"
    indent = begin[: len(begin) - len(begin.lstrip())]
    lines[region.begin - 1 : region.end] = [f"{indent}raise NotImplementedError('mutant: {region.function}')"]
    text = "\n".join(lines)
    ast.parse(text, filename=str(path))
    path.write_text(text)


def test_every_homework_asks_for_functions():
    for homework in HOMEWORKS:
        assert asked_regions(homework), homework


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_each_function_raising_costs_points(homework, make_submissions, reference_copy, tmp_path):
    regions = asked_regions(homework)
    folder = make_submissions(f"{homework}-every-function", {"reference": "reference"}, homework)
    mutants = {}
    for number, region in enumerate(regions):
        student = f"mutant{number:03d}"
        stub_region(reference_copy(folder / student), region)
        mutants[student] = f"solutions/{region.path}: {region.function}"

    book = grade(homework, folder, tmp_path / "out", jobs=2, progress=False)

    reference = book.score("reference")
    assert reference == book.max_score, f"{homework}: the reference scores {reference} of {book.max_score}"
    unreached = sorted(
        f"{function} (scores {book.score(student):g})"
        for student, function in mutants.items()
        if not book.score(student) < reference
    )
    assert unreached == [], (
        f"{homework}: no check loses points when one of these functions raises NotImplementedError; "
        f"add a scene or check that calls it: {unreached}"
    )
