"""The documentation rubric's automatic part (``autograder.documentation``): what the student added to the
homework's functions over the skeleton, read from the files (never run), on small synthetic packages whose
verdicts are worked out by hand here; and ``mbd grade`` writing it (gradebook column, feedback page)."""

from __future__ import annotations

import ast
import csv
import textwrap
from pathlib import Path

import pytest

from autograder.documentation import Given, given, measure
from autograder.grading import grade
from course.release.generator import REPO, all_regions
from mbdkit.homework import Homework
from mbdkit.todo import functions_of

SOURCE = {
    "shapes.py": '''
        """Shapes."""


        def area(r):
            """Area of a circle of radius r (eq. 1.1)."""
            ### BEGIN SOLUTION hw1
            # pi r squared, inside the region: not in the kit
            return 3.14 * r * r
            ### END SOLUTION


        def perimeter(r):
            """Perimeter."""
            # the given hint stays in the kit
            ### BEGIN SOLUTION hw1
            return 2 * 3.14 * r
            ### END SOLUTION


        class Disk:
            def volume(self, h):
                ### BEGIN SOLUTION hw1
                return area(self.r) * h
                ### END SOLUTION


        def later(x):
            """Written in hw2."""
            ### BEGIN SOLUTION hw2
            return x
            ### END SOLUTION
        ''',
    "other.py": """
        def f():
            ### BEGIN SOLUTION hw1
            return 1
            ### END SOLUTION
        """,
}
"""The course's source: four functions of hw1 (one in a file of its own), one of hw2."""

STUDENT = {
    "shapes.py": '''
        """Shapes."""


        def area(r):
            """Area of a circle of radius r (eq. 1.1)."""
            # the circle's area, eq. 1.1: pi times r squared
            return 3.14159 * r * r


        def perimeter(r):
            """Perimeter."""
            # the given hint stays in the kit
            # return 2 * 3.14 * r
            return 2 * 3.14159 * r  # noqa: E501


        class Disk:
            def volume(self, h):
                """Volume of the cylinder: area of the disk times the height h."""
                return area(self.r) * h


        def later(x):
            """Written in hw2."""
            raise NotImplementedError("later: Written in hw2, see the notes")
        ''',
    "other.py": """
        def f():
            raise NotImplementedError("f: f(), see the notes")
        """,
}
"""A student's hw1: area explained by a comment, perimeter only the kit's comment, commented-out code and a
pragma, Disk.volume a docstring of 12 words where the skeleton had none, f left a stub."""


def write(folder: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(textwrap.dedent(text).lstrip())
    return folder


@pytest.fixture
def course(tmp_path) -> Path:
    return write(tmp_path / "solutions", SOURCE)


def student(tmp_path: Path, files: dict[str, str]) -> Path:
    write(tmp_path / "ada" / "modules", files)
    return tmp_path / "ada"


def verdicts(documentation) -> dict[str, tuple[bool, str]]:
    return {v.function: (v.documented, v.why) for v in documentation.verdicts}


def test_the_skeleton_gives_the_docstring_and_the_comments_outside_the_regions(course):
    assert given("hw1", course) == {
        ("other.py", "f"): Given("", frozenset()),
        ("shapes.py", "area"): Given("Area of a circle of radius r (eq. 1.1).", frozenset()),
        ("shapes.py", "perimeter"): Given("Perimeter.", frozenset({"the given hint stays in the kit"})),
        ("shapes.py", "Disk.volume"): Given("", frozenset()),
    }
    assert list(given("hw2", course)) == [("shapes.py", "later")]


def test_a_function_counts_when_written_and_explained_by_the_student(course, tmp_path):
    result = measure("hw1", student(tmp_path, STUDENT), course)
    assert verdicts(result) == {
        "f": (False, "not written: it still raises NotImplementedError"),
        "area": (True, "documented: 1 comment line(s) of yours"),
        "perimeter": (False, "not documented: no comment of yours, and the docstring is the skeleton's"),
        "Disk.volume": (True, "documented: your docstring (+12 words)"),
    }
    assert (result.documented, result.percent) == (2, 50.0)
    assert "2 of 4 functions of hw1 documented beyond the skeleton (50.0 %)" in result.line()


def test_a_file_that_does_not_parse_scores_zero_with_the_reason_and_the_others_count(course, tmp_path):
    broken = dict(STUDENT, **{"other.py": "def f(:\n    return 1\n"})
    result = measure("hw1", student(tmp_path, broken), course)
    assert verdicts(result)["f"] == (False, "modules/other.py does not parse (line 1: invalid syntax)")
    assert result.percent == 50.0  # f was not documented anyway; shapes.py still counts
    nothing = dict(STUDENT, **{"shapes.py": "def area(r:\n"})
    result = measure("hw1", student(tmp_path / "b", nothing), course)
    assert result.percent == 0.0 and "modules/shapes.py does not parse (line 1: " in result.line()


@pytest.mark.parametrize(
    "text, said",
    [
        ("def f():\n    return 1\x00\n", "(source code string cannot contain null bytes)"),
        ("def f():\n    return " + "-" * 200_000 + "x\n", "(too deeply nested for Python's parser)"),
        ("x = " + "(" * 300 + ")" * 300 + "\n", "(line 1: too many nested parentheses)"),
    ],
)
def test_hostile_files_score_zero_with_the_reason(course, tmp_path, text, said):
    result = measure("hw1", student(tmp_path, dict(STUDENT, **{"other.py": text})), course)
    assert verdicts(result)["f"] == (False, f"modules/other.py does not parse {said}")


def test_a_deleted_docstring_a_link_and_a_missing_package_count_nothing(course, tmp_path):
    text = textwrap.dedent(STUDENT["shapes.py"]).replace('    """Area of a circle of radius r (eq. 1.1)."""\n', "")
    folder = student(tmp_path, dict(STUDENT, **{"shapes.py": text}))
    (folder / "modules" / "other.py").unlink()
    (folder / "modules" / "other.py").symlink_to(folder / "modules" / "shapes.py")  # never followed
    found = verdicts(measure("hw1", folder, course))
    assert found["area"] == (False, "not documented: the skeleton's docstring was deleted")
    assert found["f"] == (False, "modules/other.py is a symbolic link: not read")
    assert measure("hw1", tmp_path / "nobody", course).percent == 0.0


def test_the_course_homework_functions_and_their_skeleton_docstrings():
    """The functions are the release's (its regions, in its order), each skeleton's docstring the one the
    student package has; the untouched package documents none."""
    for homework in ("hw1", "hw2", "hw3"):
        gifts = given(homework)
        assert list(gifts) == list(dict.fromkeys((r.path, r.function) for r in all_regions() if r.tag == homework))
        for (path, name), gift in gifts.items():
            node = functions_of(ast.parse((REPO / "modules" / path).read_text()))[name]
            assert gift.docstring == (ast.get_docstring(node) or ""), (path, name)
    skeleton = measure("hw1", REPO)  # REPO/modules: every homework stubbed
    assert skeleton.percent == 0.0 and {v.why for v in skeleton.verdicts} == {
        "not written: it still raises NotImplementedError"
    }


def test_mbd_grade_writes_the_share_in_the_gradebook_and_on_the_feedback_page(make_submissions, tmp_path):
    """No check to run: the rubric alone. The reference's hw1 explains one function by a comment of its own
    (Gear.jacobian); the student adds one to rotation: 2 of hw1's 40 functions, 5 %."""
    folder = make_submissions("documented", {"skel": "skeleton", "ref": "reference"}, "hw1")
    bodies = folder / "ref" / "modules" / "planar" / "bodies.py"
    body = "    c, s = math.cos(phi), math.sin(phi)\n    return np.array([[c, -s], [s, c]])\n"
    assert body in bodies.read_text()
    bodies.write_text(
        bodies.read_text().replace(body, "    # A(phi) of eq. 2.2: its columns are the body axes\n" + body)
    )
    book = grade(Homework("hw1", "documentation only", []), folder, tmp_path / "out", jobs=1, progress=False)
    with open(tmp_path / "out" / "gradebook.csv", newline="") as f:
        rows = {row["student"]: row for row in csv.DictReader(f)}
    assert (rows["ref"]["documentation"], rows["skel"]["documentation"]) == ("5.0", "0.0")
    assert book.rows["ref"]["documentation"] == 5.0
    page = (tmp_path / "out" / "feedback" / "ref.html").read_text()
    assert "Documentation (automatic part): 2 of 40 functions of hw1 documented beyond the skeleton (5.0 %)" in page
    assert "<code>rotation</code>: documented: 1 comment line(s) of yours" in page
