"""``mbd oral hwN SUBMISSION``: a student's oral-exam marking sheet drawn from the functions they wrote, with
their own code, questions of the bank with points and blanks, and a board problem; another student gets another
sheet, the same student the same one."""

from __future__ import annotations

import re
import shutil

import pytest

from course.oral import read_bank, stubs
from course.release import build_package
from solutions.cli import main

ROTATION = '''def rotation(phi: float) -> np.ndarray:
    """Planar rotation matrix A(phi) = [[cos, -sin], [sin, cos]] (eq. 2.2)."""
    cosine, sine = math.cos(phi), math.sin(phi)  # ada's own names for the entries of eq. 2.2
    return np.array([[cosine, -sine], [sine, cosine]])
'''
"""How the student wrote ``rotation``: lines the reference does not have."""


@pytest.fixture(scope="module")
def skeleton(tmp_path_factory):
    package = tmp_path_factory.mktemp("oral") / "modules"
    build_package(package, "hw1")
    return package


def hand_in(skeleton, folder, written: bool = True):
    """A submission of hw1 with the five functions of planar/bodies.py written (rotation in the student's words)."""
    shutil.copytree(skeleton, folder / "modules")
    if written:
        bodies = folder / "modules" / "planar" / "bodies.py"
        text = re.sub(r"raise NotImplementedError\((['\"]).*\1\)", "return R90", bodies.read_text())
        start = text.index("def rotation(")
        end = text.index("def rotation_derivative(")
        bodies.write_text(text[:start] + ROTATION + "\n\n" + text[end:])
    return folder


def sheet_of(folder, *options) -> str:
    out = folder.parent / f"{folder.name}.md"
    assert main(["oral", "hw1", str(folder), "--out", str(out), *options]) == 0
    return out.read_text()


def drawn(text: str) -> list[str]:
    return re.findall(r"^## (\S+) \(modules/", text, re.MULTILINE)


def test_the_sheet_asks_about_the_functions_the_student_wrote_with_their_code(skeleton, tmp_path):
    ada = hand_in(skeleton, tmp_path / "ada")
    text = sheet_of(ada, "--functions", "5")
    assert text.startswith("# Oral exam, hw1: ada\n")
    assert sorted(drawn(text)) == sorted(
        ["rotation", "rotation_derivative", "point_vector", "point_vector_dot", "point_vector_quadratic"]
    )  # the five written, not one of the 35 stubs
    assert "cosine, sine = math.cos(phi), math.sin(phi)  # ada's own names" in text  # their code, as written
    assert "*Its stub:* Planar rotation matrix A(phi) = [[cos, -sin], [sin, cos]] (eq. 2.2)." in text
    questions = re.findall(r"^\*\*Q\d+\*\* \((\d+) points\)", text, re.MULTILINE)
    marks = re.findall(r"^Mark: ____ / (\d+)$", text, re.MULTILINE)
    assert len(questions) == 2 * 5 + 1 and marks == questions  # two per function, one at the board
    total = int(re.search(r"^____ / (\d+) points", text, re.MULTILINE)[1])
    assert total == sum(int(p) for p in questions)
    assert "## At the board:" in text and "*Answers (examiner):*" in text
    assert "1 of 40 functions of hw1 documented beyond the skeleton" in text  # rotation's comment


def test_another_student_gets_another_sheet_the_same_student_the_same(skeleton, tmp_path):
    ada = hand_in(skeleton, tmp_path / "ada")
    bob = hand_in(skeleton, tmp_path / "bob")  # the same files: only the id differs
    first, again, other = sheet_of(ada), sheet_of(ada), sheet_of(bob)
    assert first == again
    assert len(drawn(first)) == len(drawn(other)) == 3
    questions = [re.findall(r"^\*\*Q\d+\*\*.*$", text, re.MULTILINE) for text in (first, other)]
    assert questions[0] != questions[1]
    assert sheet_of(ada, "--seed", "7") != first  # the semester's seed


def test_a_package_with_nothing_written_or_unparsable_still_gets_a_sheet(skeleton, tmp_path):
    cyd = hand_in(skeleton, tmp_path / "cyd", written=False)
    (cyd / "modules" / "kinematics.py").write_text("def newton_raphson(:\n")
    text = sheet_of(cyd, "--functions", "40")  # every function of hw1
    assert len(drawn(text)) == 40 and text.count("ask how they would write it.*") == 40
    assert text.count("*Not the student's code (not written: it still raises NotImplementedError)") == 37
    unparsed = "modules/kinematics.py does not parse (line 1: invalid syntax)"
    assert text.count(f"*Not the student's code ({unparsed})") == 3  # newton_raphson, velocity_ and acceleration_
    assert text.count(f"*Not shown: {unparsed}.*") == 3


def test_every_function_of_the_homeworks_has_a_question_of_its_kind():
    bank, board = read_bank()
    for homework in ("hw1", "hw2", "hw3"):
        lacking = [f for _, f in stubs(homework) if not any(q.fits(f) and not q.general for q in bank)]
        assert not lacking, (homework, lacking)
        assert board[homework]


@pytest.mark.parametrize(
    "argv, said",
    [
        (["hw9", "{ada}"], "hw9: no such homework"),
        (["hw1", "{nowhere}"], "no such folder"),
        (["hw1", "{empty}"], "no modules/ in it"),
        (["hw1", "{ada}", "--out", "{tmp}/sheet.html"], "write FILE.md"),
        (["hw1", "{ada}", "--out", "{tmp}/no/such/sheet.md"], "no folder"),
        (["hw1", "{ada}", "--functions", "0"], "draw at least 1"),
        (["hw1", "{ada}", "--seed", "x"], "--seed"),
    ],
)
def test_bad_input_is_one_line(skeleton, tmp_path, capsys, argv, said):
    places = {"ada": tmp_path / "ada", "nowhere": tmp_path / "nowhere", "empty": tmp_path / "empty", "tmp": tmp_path}
    (tmp_path / "ada" / "modules").mkdir(parents=True)
    (tmp_path / "empty").mkdir()
    try:
        code = main(["oral", *(a.format(**places) for a in argv)])
    except SystemExit as stop:  # said by the parser (a number that is not one)
        code = stop.code
    assert code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("mbd: error: ") and said in err, err
    assert not list(tmp_path.rglob("*.md")) and not list(tmp_path.rglob("*.html"))


def test_the_excerpt_keeps_its_fence_and_cuts_long_lines():
    from course.oral import excerpt

    text = 'def rotation(phi):\r\n    """```"""\r\n    return "' + "x" * 500 + '"\r\n'
    shown = excerpt(text, "planar/bodies.py", "rotation")
    assert shown.startswith("modules/planar/bodies.py, line 1:\n\n````python\ndef rotation(phi):\n")
    assert shown.endswith("\n````") and '    """```"""\n' in shown
    assert '    return "' + "x" * 148 + " ...\n" in shown  # 160 characters of the line
