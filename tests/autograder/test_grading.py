"""``grade`` on folders of real submissions: the reference scores full marks, the untouched skeleton
zero, each mutant the partial score and the message it deserves; grading in parallel gives the same
grades as one by one; an interrupted run resumes.

The expected partial scores are not copied from the grader: they follow from which probes a mutant
breaks (a function that hangs breaks every check whose probe calls it, and nothing else).
"""

from __future__ import annotations

import csv
import json
import re

import pytest

from autograder.grading import grade
from mbdkit.homework import CheckSpec, Homework, load_homework
from mbdkit.sandbox import Limits

LIMITS = Limits(timeout_scale=0.3)  # a hang costs 3 s here instead of 10

HW1 = {
    "ref": "reference",
    "skel": "skeleton",
    "gamma_sign": "gamma_sign",
    "jacobian_transposed": "jacobian_transposed",
    "hang": "hang",
    "memory": "memory",
    "exit": "exit",
    "flood": "flood",
}
HW2 = {
    "ref": "reference",
    "skel": "skeleton",
    "mass_missing": "mass_missing",
    "baumgarte_sign": "baumgarte_sign",
    "rk4_weight": "rk4_weight",
}
HW3 = {"ref": "reference", "skel": "skeleton", "qv_missing": "quadratic_velocity_missing"}


def _results(out, student) -> dict[str, dict]:
    data = json.loads((out / "results" / f"{student}.json").read_text())
    return {t["name"]: t for t in data["tests"]}


@pytest.fixture(scope="module")
def hw1(make_submissions, tmp_path_factory):
    folder = make_submissions("hw1-subs", HW1, "hw1")
    out = tmp_path_factory.mktemp("hw1-out")
    return grade("hw1", folder, out, jobs=2, limits=LIMITS, progress=False), out, folder


@pytest.fixture(scope="module")
def hw2(make_submissions, tmp_path_factory):
    folder = make_submissions("hw2-subs", HW2, "hw2")
    out = tmp_path_factory.mktemp("hw2-out")
    return grade("hw2", folder, out, jobs=2, limits=LIMITS, progress=False), out, folder


@pytest.fixture(scope="module")
def hw3(make_submissions, tmp_path_factory):
    folder = make_submissions("hw3-subs", HW3, "hw3")
    out = tmp_path_factory.mktemp("hw3-out")
    return grade("hw3", folder, out, jobs=2, limits=LIMITS, progress=False), out, folder


@pytest.mark.parametrize("graded", ["hw1", "hw2", "hw3"])
def test_reference_full_marks_skeleton_zero(graded, request):
    book, out, _ = request.getfixturevalue(graded)
    assert book.max_score == pytest.approx(100.0)  # every homework is out of 100
    assert book.score("ref") == book.max_score, [t for t in _results(out, "ref").values() if t["status"] != "passed"]
    assert book.score("skel") == 0.0
    skeleton = _results(out, "skel")
    assert all("not implemented yet" in t["output"] for t in skeleton.values()), "the skeleton fails by its stubs"


def _failing(homework: str, probes: set[str]) -> set[str]:
    return {c.name for c in load_homework(homework).checks if c.probe in probes}


@pytest.mark.parametrize(
    "student, probes, message",
    [
        (
            "hang",
            {"velocity", "loop_velocity", "kinematic_run"},
            "skipped: velocity_analysis did not finish in an earlier check",
        ),
        ("memory", {"acceleration", "loop_acceleration", "kinematic_run"}, "ran out of memory"),
        ("exit", {"newton", "loop_newton", "kinematic_run"}, "exit code 3"),
        ("flood", {"velocity", "loop_velocity", "kinematic_run"}, "printed"),
    ],
)
def test_misbehaving_code_costs_only_the_checks_it_touches(hw1, student, probes, message):
    book, out, _ = hw1
    results = _results(out, student)
    expected = _failing("hw1", probes)
    failed = {name for name, t in results.items() if t["status"] == "failed"}
    assert failed == expected
    lost = sum(c.points for c in load_homework("hw1").checks if c.name in expected)
    assert book.score(student) == pytest.approx(book.max_score - lost)
    public = {c.name for c in load_homework("hw1").checks if c.kind == "public"}
    assert all(
        message in results[name]["output"] or "did not finish" in results[name]["output"] for name in public & expected
    )
    statuses = {"hang": "timed out", "memory": "crashed", "exit": "crashed", "flood": "failed"}  # the grader's words
    assert all(f": {statuses[student]}: " in results[name]["output"] for name in expected - public)


def test_a_hang_costs_one_timeout_and_names_the_function(hw1):
    _, out, _ = hw1
    outputs = [t["output"] for t in _results(out, "hang").values() if t["status"] == "failed"]
    timeouts = [o for o in outputs if "did not finish within the time limit" in o]
    assert len(timeouts) == 1
    assert "stuck in modules/kinematics.py" in timeouts[0] and "velocity_analysis" in timeouts[0]
    assert float((out / "timing" / "hang.txt").read_text()) < 60  # the instructor's, not in the result
    assert "seconds" not in json.loads((out / "results" / "hang.json").read_text())["extra_data"]


def test_gamma_sign_mutant(hw1):
    book, out, _ = hw1
    results = _results(out, "gamma_sign")
    failed = {name for name, t in results.items() if t["status"] == "failed"}
    runs = {c.name for c in load_homework("hw1").checks if c.probe == "kinematic_run" and c.outputs == ("qdd",)}
    expected = {"four_bar.gamma.revolute", "slider_crank.gamma.revolute", "hidden/four_bar_b.gamma"}
    expected |= _failing("hw1", {"acceleration"}) | runs
    assert failed == expected
    points = {c.name: c.points for c in load_homework("hw1").checks}
    assert book.score("gamma_sign") == pytest.approx(book.max_score - sum(points[name] for name in expected))
    assert "a sign error" in results["four_bar.gamma.revolute"]["output"]
    assert "row O2.x (revolute O2)" in results["four_bar.gamma.revolute"]["output"]
    assert "gamma with the wrong sign in Revolute.gamma" in results["quick_return.acceleration"]["output"]
    assert "the positions and velocities agree" in results["slider_crank.kinematic_run.qdd"]["output"] or (
        "Likely cause" in results["slider_crank.kinematic_run.qdd"]["output"]
    )


def test_transposed_block_mutant(hw1):
    book, out, _ = hw1
    results = _results(out, "jacobian_transposed")
    for name in ("four_bar.jacobian.revolute", "slider_crank.jacobian.revolute"):
        assert results[name]["status"] == "failed"
        assert "transposed block: B(phi)^T used where B(phi)" in results[name]["output"]
    for name in ("four_bar.constraints.revolute", "four_bar.gamma.revolute", "slider_crank.jacobian.driver"):
        assert results[name]["status"] == "passed"
    assert 0 < book.score("jacobian_transposed") < book.max_score


def test_feedback_pages(hw1):
    book, out, _ = hw1
    page = (out / "feedback" / "gamma_sign.html").read_text()
    assert page.count("<img") == 3  # the failed public runs, plotted against the reference (no variant's)
    assert "hidden/" not in page and "checks, on hidden scenes" in page  # held back until published
    shown = [c for c in load_homework("hw1").checks if c.kind != "hidden"]
    score = sum(p for name, p in book.points("gamma_sign").items() if name in {c.name for c in shown})
    assert f"Score on the checks shown: <b>{score:g} / {sum(c.points for c in shown):g}</b>" in page


def test_hidden_checks_reveal_no_numbers(hw1, hw2):
    for _, out, folder in (hw1, hw2):
        for student in (p.name for p in folder.iterdir()):
            results = _results(out, student)
            for name, test in results.items():
                if name.startswith("hidden/") and test["status"] == "failed":
                    assert "got" not in test["output"] and "t = " not in test["output"]
                    values = re.sub(r"relative error [-+.\de]+", "", test["output"])  # its one allowed number
                    assert not re.search(r"\d\.\d{3,}", values), test["output"]
                    assert test["visibility"] == "after_published"


def test_hw2_mutants(hw2):
    book, out, _ = hw2
    mass = _results(out, "mass_missing")
    assert all(mass[f"{s}.mass_matrix"]["status"] == "failed" for s in ("double_pendulum", "four_bar_spring"))
    assert "a missing term" in mass["double_pendulum.mass_matrix"]["output"]
    for name in ("rk4_step", "double_pendulum.baumgarte_gamma", "double_pendulum.generalized_forces"):
        assert mass[name]["status"] == "passed"

    baumgarte = _results(out, "baumgarte_sign")
    assert "Baumgarte's terms with the wrong sign" in baumgarte["double_pendulum.baumgarte_gamma"]["output"]
    assert "Baumgarte's terms with the wrong sign" in baumgarte["double_pendulum.accelerations"]["output"]
    for name in ("rk4_step", "double_pendulum.mass_matrix", "double_pendulum.augmented_accelerations"):
        assert baumgarte[name]["status"] == "passed"

    rk4 = _results(out, "rk4_weight")
    failed = {name for name, t in rk4.items() if t["status"] == "failed"}
    assert failed == {"rk4_step", "double_pendulum.rk4_run"}  # RK45 runs do not use rk4_step
    assert "not 4" in rk4["rk4_step"]["output"]
    for student in ("mass_missing", "baumgarte_sign", "rk4_weight"):
        assert 0 < book.score(student) < book.max_score


def test_hw3_mutant(hw3):
    book, out, _ = hw3
    results = _results(out, "qv_missing")
    assert "a missing term" in results["spherical_spherical.quadratic_velocity"]["output"]
    assert "Q_v = 8 L(p')^T J' L(p') p is missing" in results["revolute_spherical.generalized_forces"]["output"]
    for name in ("revolute_spherical.rotation_matrix", "spherical_spherical.jacobian.spherical"):
        assert results[name]["status"] == "passed"
    assert 0 < book.score("qv_missing") < book.max_score


def test_gradebook_csv(hw1):
    book, out, folder = hw1
    with open(out / "gradebook.csv") as f:
        rows = list(csv.DictReader(f))
    assert {r["student"] for r in rows} == set(HW1)
    names = [c.name for c in load_homework("hw1").checks]
    assert list(rows[0].keys()) == ["student", "score", "max_score", "percent", "status", "documentation", *names]
    assert {r["status"] for r in rows} == {"graded"}
    for row in rows:
        assert float(row["score"]) == pytest.approx(sum(float(row[n]) for n in names))
        assert float(row["score"]) == pytest.approx(book.score(row["student"]))


def quick_homework() -> Homework:
    """Three cheap checks of hw1, one on each student's own variant of the slider-crank."""
    hw1 = load_homework("hw1")
    checks = hw1.select(["slider_crank.gamma.revolute", "slider_crank.newton"]).checks
    checks.append(
        CheckSpec("student/slider_crank.velocity", "student/slider_crank", "velocity", ("qd",), 2.0, "velocity")
    )
    return Homework("hw1", "quick", checks)


def test_parallel_grades_equal_serial_and_resume(make_submissions, tmp_path):
    kinds = ["reference", "skeleton", "gamma_sign", "jacobian_transposed", "exit"]
    folder = make_submissions("class", {f"s{k:02d}": kinds[k % len(kinds)] for k in range(10)}, "hw1")  # 2 each
    homework = quick_homework()
    parallel = grade(homework, folder, tmp_path / "parallel", jobs=2, progress=False)
    serial = grade(homework, folder, tmp_path / "serial", jobs=1, progress=False)
    assert {s: r["checks"] for s, r in parallel.rows.items()} == {s: r["checks"] for s, r in serial.rows.items()}
    for student in parallel.rows:
        a, b = _results(tmp_path / "parallel", student), _results(tmp_path / "serial", student)
        assert {n: t["output"] for n, t in a.items()} == {n: t["output"] for n, t in b.items()}
    # per-student variants: the same mutant fails on each student's own numbers, told in the grader's words
    check = "student/slider_crank.velocity"
    messages = {_results(tmp_path / "serial", s)[check]["output"] for s in ("s03", "s08")}
    assert len(messages) == 1 and ": failed: " in messages.pop()
    # an interrupted run resumes: finished students are not graded again, a changed submission is
    (folder / "s00" / "modules" / "kinematics.py").write_text(
        (folder / "s00" / "modules" / "kinematics.py")
        .read_text()
        .replace("max_iterations: int = 25", "max_iterations: int = 30")
    )
    again = grade(homework, folder, tmp_path / "parallel", jobs=2, progress=False)
    assert [s for s, r in again.rows.items() if not r["resumed"]] == ["s00"]
    assert {s: r["checks"] for s, r in again.rows.items()} == {s: r["checks"] for s, r in parallel.rows.items()}


def test_the_fingerprint_follows_no_link_and_reads_a_huge_file_only_in_part(tmp_path):
    from autograder.grading import FINGERPRINT_BYTES, Submission, submission_fingerprint
    from mbdkit.sandbox import Limits

    homework = load_homework("hw1")
    package = tmp_path / "ada" / "modules"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("")
    outside = tmp_path / "outside.txt"
    outside.write_text("first")
    (package / "link.py").symlink_to(outside)
    ada = Submission("ada", tmp_path / "ada")
    before = submission_fingerprint(ada, homework, Limits())
    outside.write_text("changed")  # what a link points to is not the submission's
    assert submission_fingerprint(ada, homework, Limits()) == before
    big = package / "big.bin"
    with open(big, "wb") as f:
        f.truncate(FINGERPRINT_BYTES * 64)  # 256 MiB, sparse
    first = submission_fingerprint(ada, homework, Limits())
    with open(big, "r+b") as f:
        f.seek(FINGERPRINT_BYTES * 32)
        f.write(b"x")
    assert submission_fingerprint(ada, homework, Limits()) == first  # read only in part
    (package / "__init__.py").write_text("# edited\n")
    assert submission_fingerprint(ada, homework, Limits()) != first


def test_a_grade_depends_only_on_the_submission_not_on_who_was_graded_before(hw2, tmp_path):
    """The class of ``hw2`` (graded by two workers) graded again one by one in this process, in the reverse of
    the usual order, mistakes first: the same points. Replaying a mistake for one student (Baumgarte's terms,
    on their own variant of a scene) must leave nothing behind for the next. (One worker against two: the
    parallel test above.)"""
    from autograder.grading import Submission, grade_submission

    book, _, folder = hw2
    homework = load_homework("hw2")
    reverse = {
        name: grade_submission(homework, Submission(name, folder / name), tmp_path, LIMITS)
        for name in ("rk4_weight", "baumgarte_sign", "ref")
    }
    assert book.score("ref") == book.max_score and 0 < book.score("baumgarte_sign") < book.max_score
    for student, row in reverse.items():
        assert book.points(student) == row["checks"], student
