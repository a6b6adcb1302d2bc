"""Fair grading: a time budget per submission, complex numbers refused, and hidden scenes kept in a child
of their own (nothing a hidden or per-student scene sends a child can surface in a public check)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from autograder.grading import grade
from mbdkit import isolation as osi
from mbdkit.homework import load_homework
from mbdkit.sandbox import Limits

from .conftest import copy_reference

PROBLEM = osi.problem()
ISOLATION = "os" if PROBLEM is None else "local"  # the wall is the same for this; the OS one where it runs


def plant(root: Path, student: str, edits: list[tuple[str, str, str]]) -> None:
    """The reference as ``student``'s package, with each (file, old, new) replaced once."""
    package = copy_reference(root / student)
    for relpath, old, new in edits:
        text = (package / relpath).read_text()
        assert text.count(old) == 1, (relpath, old)
        (package / relpath).write_text(text.replace(old, new))


def results(out: Path, student: str) -> dict[str, dict]:
    data = json.loads((out / "results" / f"{student}.json").read_text())
    return {t["name"]: t for t in data["tests"]}


ECHO = """def kinematic_analysis(*args, **kwargs):
    from . import assembly

    raise RuntimeError("seen: " + "|".join(assembly.SEEN))


def _unused_kinematic_analysis(
"""


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    root = tmp_path_factory.mktemp("fair")
    copy_reference(root / "honest")
    plant(  # sleeps in every build of a system: each check is quick enough, all of them are not
        root,
        "slow",
        [("assembly.py", "def build_system(model: Model)", "import time\n\n\ndef build_system(model: Model)")],
    )
    text = (root / "slow" / "modules" / "assembly.py").read_text()
    marker = '    """The assembled system of a model with the file\'s (approximate) q0 and q0\'."""\n'
    (root / "slow" / "modules" / "assembly.py").write_text(text.replace(marker, marker + "    time.sleep(0.4)\n"))
    plant(
        root,
        "complex",
        [
            (
                "planar/joints.py",
                "return -point_vector(qi, self.si, qj, self.sj)",
                "return -point_vector(qi, self.si, qj, self.sj) + 1e-3j",
            )
        ],
    )
    plant(  # remembers every model it is given and tells them in the public runs' messages
        root,
        "echo",
        [
            ("assembly.py", "def build_system(model: Model)", "SEEN = []\n\n\ndef build_system(model: Model)"),
            (
                "assembly.py",
                "    if model.dimension == 3:  # spatial",
                "    SEEN.append(model.name)\n    if model.dimension == 3:  # spatial",
            ),
            ("kinematics.py", "def kinematic_analysis(\n", ECHO),
        ],
    )
    plant(  # the u^T d phi_i'^2 term of the prismatic joint's gamma dropped: zero when body i is the ground
        root,
        "prismatic_term",
        [("planar/joints.py", "gamma = value * qdi[2] ** 2 - 2.0", "gamma = 0.0 * value * qdi[2] ** 2 - 2.0")],
    )
    # 15 s: an honest hw1 takes some 8 s on a busy two-core machine (three children: public, own variants, hidden)
    homework = dataclasses.replace(load_homework("hw1"), budget=15.0)
    out = root / "out"
    book = grade(homework, root, out, jobs=2, progress=False, resume=False, limits=Limits(), isolation=ISOLATION)
    return book, out


def test_the_honest_classmate_is_untouched(graded):
    book, _ = graded
    assert book.score("honest") == book.max_score


def test_a_submission_that_uses_up_its_budget_loses_the_checks_not_run(graded):
    book, out = graded
    tests = results(out, "slow")
    skipped = [t for t in tests.values() if "time budget" in t["output"]]
    assert skipped and all(t["score"] == 0 for t in skipped)
    public = [t for t in skipped if t["extra_data"]["kind"] == "public"]  # the others: in the grader's words
    assert all("15 s for all its checks" in t["output"] for t in public)
    assert all(": could not run: " in t["output"] for t in skipped if t not in public)
    assert any(t["status"] == "passed" for t in tests.values())  # what ran in time still counts
    assert 0 < book.score("slow") < book.max_score


def test_complex_numbers_are_refused_not_cut_to_their_real_part(graded):
    _, out = graded
    message = results(out, "complex")["four_bar.constraints.revolute"]["output"]
    assert "complex numbers" in message


def test_no_hidden_or_per_student_model_reaches_a_public_check(graded):
    _, out = graded
    tests = results(out, "echo")
    public = [t for name, t in tests.items() if t["extra_data"]["kind"] == "public" and "kinematic_run" in name]
    assert public and all("seen: " in t["output"] for t in public)  # the echo ran
    for t in public:
        seen = t["output"].split("seen: ", 1)[1].split(" (", 1)[0].split("|")
        assert not [name for name in seen if name.endswith(("-b", "-variant"))], t["output"]
    hidden = [t for t in tests.values() if t["extra_data"]["kind"] == "hidden" and t["status"] == "failed"]
    assert hidden and all("seen" not in t["output"] for t in hidden)  # the grader's words only


def test_a_prismatic_term_of_a_moving_body1_shows_in_the_prismatic_checks(graded):
    book, out = graded
    tests = results(out, "prismatic_term")
    assert tests["sliding_arm.gamma.prismatic"]["status"] == "failed"
    assert tests["hidden/sliding_arm_b.gamma.prismatic"]["status"] == "failed"
    assert book.score("prismatic_term") < book.max_score


MISTAKES = {
    "hw2": (  # Baumgarte's alpha and beta swapped: only probes with alpha != beta tell
        "formulations.py",
        "return gamma - 2.0 * alpha * psi_dot - beta**2 * psi",
        "return gamma - 2.0 * beta * psi_dot - alpha**2 * psi",
        ["double_pendulum.baumgarte_gamma", "four_bar_spring.baumgarte_gamma"],
    ),
    "hw3": (  # the factor 2 of the dot-2 constraint's gamma dropped: only shows when both bodies move
        "spatial/joints.py",
        "+ 2.0 * ai_dot @ d_dot +",
        "+ ai_dot @ d_dot +",
        ["revolute_prismatic.gamma.prismatic"],
    ),
}


@pytest.mark.parametrize("homework", sorted(MISTAKES))
def test_subtle_mistakes_cost_points(homework, tmp_path):
    relpath, old, new, failing = MISTAKES[homework]
    plant(tmp_path / "class", "subtle", [(relpath, old, new)])
    book = grade(homework, tmp_path / "class", tmp_path / "out", jobs=1, progress=False, isolation=ISOLATION)
    tests = results(tmp_path / "out", "subtle")
    assert book.score("subtle") < book.max_score
    assert all(tests[name]["status"] == "failed" for name in failing), {n: tests[n]["output"] for n in failing}


LIAR = """
class Liar(np.ndarray):
    def __eq__(self, other):
        return np.ones(np.shape(other), dtype=bool)

    def __sub__(self, other):
        return np.zeros(np.shape(other))

    __rsub__ = __sub__

    def __abs__(self):
        return np.zeros(self.shape)

    def tolist(self):
        return [1.0] * self.size


"""


def test_a_lying_array_and_a_forged_result_change_nothing(tmp_path):
    """What a child returns reaches the grader as plain numbers (no object survives the wire), and it
    cannot write the grader's results: the class's outcomes are what the numbers say."""
    root, out = tmp_path / "class", tmp_path / "out"
    copy_reference(root / "honest")
    forge = str(out / "results" / "honest.json")
    plant(
        root,
        "liar",
        [
            ("planar/joints.py", "@dataclass\nclass Revolute(", LIAR + "@dataclass\nclass Revolute("),
            (
                "planar/joints.py",
                "return -point_vector(qi, self.si, qj, self.sj)",
                "try:\n"
                f"            open({forge!r}, 'w').write('forged')\n"
                "        except OSError:\n"
                "            pass\n"
                "        return np.zeros(2).view(Liar)",
            ),
        ],
    )
    homework = load_homework("hw1").select(["four_bar.constraints.revolute", "four_bar.jacobian.revolute"])
    book = grade(homework, root, out, jobs=1, progress=False, isolation=ISOLATION)
    assert book.score("honest") == book.max_score
    assert json.loads((out / "results" / "honest.json").read_text())["score"] == book.max_score
    tests = results(out, "liar")
    assert tests["four_bar.constraints.revolute"]["status"] == "failed"
    assert tests["four_bar.jacobian.revolute"]["status"] == "passed"
