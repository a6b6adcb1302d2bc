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
    homework = dataclasses.replace(load_homework("hw1"), budget=8.0)
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
    assert "8 s for all its checks" in skipped[0]["output"]
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
