"""nbgrader's grades per check: one row per student and homework, a column per graded cell (course/nbgrader_config.py).

    nbgrader export --exporter course.nbexport.ChecksExportPlugin --to build/checks.csv [--assignment hw1]

nbgrader's own export gives a homework's total per student; this one gives what each graded cell scored (a
cell is a group of the homework's checks, ``test_hw1_revolute``, or a written answer), as ``mbd grade``'s
``gradebook.csv`` gives a column per check: what an LMS or a spreadsheet needs to see which parts of a homework
a class lost points on. A student with no submission is ``missing`` (status column), never 0; a submission's
total and the homework's maximum close each row.
"""

from __future__ import annotations

import csv

from nbgrader.api import Gradebook, MissingEntry
from nbgrader.plugins import ExportPlugin


class ChecksExportPlugin(ExportPlugin):
    """Export every graded cell's score of every submission (``--to``, default ``checks.csv``)."""

    def export(self, gradebook: Gradebook) -> None:
        rows, columns = [], ["assignment", "student_id", "status"]
        for assignment in gradebook.assignments:
            if self.assignment and assignment.name not in self.assignment:
                continue
            cells = [(nb.name, cell.name) for nb in assignment.notebooks for cell in nb.grade_cells]
            columns += [name for _, name in cells if name not in columns]
            for student in gradebook.students:
                if self.student and student.id not in self.student:
                    continue
                rows.append(self.row(gradebook, assignment, student.id, cells))
        columns += ["score", "max_score"]
        with open(self.to or "checks.csv", "w", newline="") as out:
            writer = csv.DictWriter(out, fieldnames=columns, restval="")
            writer.writeheader()
            writer.writerows(rows)
        self.log.info("Exported %d rows, a column per graded cell, to %s", len(rows), self.to or "checks.csv")

    @staticmethod
    def row(gradebook: Gradebook, assignment, student: str, cells: list[tuple[str, str]]) -> dict:
        """One student's scores of ``assignment``'s graded cells; empty with status 'missing' without a submission."""
        row = {"assignment": assignment.name, "student_id": student, "max_score": f"{assignment.max_score:g}"}
        try:
            submission = gradebook.find_submission(assignment.name, student)
        except MissingEntry:
            return {**row, "status": "missing"}
        for notebook, cell in cells:
            row[cell] = f"{gradebook.find_grade(cell, notebook, assignment.name, student).score:g}"
        return {**row, "status": "submitted", "score": f"{submission.score:g}"}
