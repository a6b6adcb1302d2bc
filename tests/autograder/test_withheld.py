"""Hidden stays hidden: a class of hostile submissions graded once, and nothing of a hidden scene or a student's
own variant in any file written for students.

Each hostile student is the reference package (or the untouched skeleton) with code that finds the grader's job
on the stack when a hidden scene is probed, packs the hidden model and inputs as base64, and tries to send them
out through a channel the grader used to print: a function named by them that calls ``os._exit`` (the EXIT line)
or spins until the timeout (the STUCK line), an exception class named by them, a per-student check after the
hidden ones (a global, a file in /tmp), the numbers of a comparison (how many values are off, where, by how
much), or, the skeleton's, answers computed from what the grader sends. The checks: hw2's and hw3's hidden
function checks, hw1's per-student kinematic run, and their public twins.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from autograder.grading import grade, publish_feedback
from autograder.scenes import load_scene
from mbdkit import withheld
from mbdkit.homework import Homework, load_homework
from mbdkit.sandbox import Limits
from mbdkit.scenes import HIDDEN, PUBLIC, STUDENT

from .conftest import copy_reference, make_skeleton

LIMITS = Limits(timeout_scale=0.4)
HIDDEN_CHECKS = [
    c for hw in ("hw2", "hw3") for c in load_homework(hw).checks if c.kind == HIDDEN and not c.probe.endswith("_run")
]
OWN = [c for c in load_homework("hw1").checks if c.kind == STUDENT and c.probe == "kinematic_run"][:1]
EVERY = [c for hw in ("hw1", "hw2", "hw3") for c in load_homework(hw).checks]
TWINS = list(dict.fromkeys(t for c in HIDDEN_CHECKS + OWN if (t := withheld.twin(c, EVERY)) is not None))
CHECKS = TWINS + OWN + HIDDEN_CHECKS
SPIN_SCENE = next(c.scene for c in HIDDEN_CHECKS if c.probe == "accelerations")  # one timeout, not one per check

LEAK = '''"""What a hostile submission adds: find the grader's job on the stack and pack what it holds."""
import base64
import json
import os
import sys
import types

ATTACK = "@@ATTACK@@"
SPIN_SCENE = "@@SPIN@@"
SEEN = []
STASH = os.path.join(os.environ.get("TMPDIR", "/tmp"), "stash.txt")


def job(prefixes=("hidden/",)):
    frame = sys._getframe(1)
    while frame is not None:
        found = frame.f_locals.get("job")
        if found is not None and str(getattr(found, "key", "")).startswith(prefixes):
            return found
        frame = frame.f_back
    return None


def payload(found) -> str:
    inputs = {k: v.tolist() for k, v in found.inputs.items()}
    text = json.dumps({"inputs": inputs, "model": found.model}, sort_keys=True)
    return base64.b64encode(text.encode()).decode()


def _exit():
    os._exit(3)


def _spin():
    while True:
        pass


def named(name, function):
    return types.FunctionType(function.__code__.replace(co_name=name, co_qualname=name), function.__globals__)


def on_load():
    """Called first in load_model: every probe of a scene passes here."""
    found = job(("hidden/", "student/"))
    if found is None:
        return
    secret = payload(found)
    if ATTACK == "stash":
        if SEEN or os.path.exists(STASH):  # what another scene's child left: tell it
            told = SEEN[0] if SEEN else open(STASH).read()
            raise RuntimeError("stash:" + told)
        SEEN.append(secret)
        with open(STASH, "w") as f:
            f.write(secret)
        return
    if not found.key.startswith("hidden/"):
        return
    if ATTACK == "exit":
        named(secret, _exit)()
    elif ATTACK == "stuck" and found.key.startswith(SPIN_SCENE + "#"):
        named(secret, _spin)()
    elif ATTACK == "class":
        raise type(secret, (Exception,), {})()


def _covert(original):
    """Right answers, but as many values wrong as the first mass's digits say, where its next digit says."""
    import numpy as np

    def probe(pkg, job):
        out = original(pkg, job)
        if str(job.key).startswith("hidden/"):
            mass = job.model["model"]["bodies"][0]["mass"]
            digits = [int(d) for d in f"{mass:.4f}".replace(".", "") if d.isdigit()]
            for name, value in out.items():
                flat = np.array(value, dtype=float).ravel()
                flat[: digits[-1] + 1] = np.nan
                flat[digits[-2] % flat.size] += 10.0 ** digits[-3]
                out[name] = flat.reshape(np.shape(value))
        return out

    return probe


def _leech(original, name):
    """The skeleton's answers: whatever follows from the inputs the grader sends."""
    import numpy as np

    def probe(pkg, job):
        x = job.inputs
        if name == "gamma" and "gamma_pert" in x:
            return {"gamma": x["gamma_pert"]}
        if name == "generalized_forces" and "Q_pert" in x:
            return {"Q": x["Q_pert"]}
        if name == "mass_matrix" and "M" in x:
            return {"M": x["M"]}
        if name in ("accelerations", "augmented_accelerations") and "M_pert" in x:
            alpha, beta = float(job.options.get("alpha", 5.0)), float(job.options.get("beta", 5.0))
            qdd, lam = [], []
            for k in range(len(x["M_pert"])):
                M, J, Q = x["M_pert"][k], x["jacobian_pert"][k], x["Q_pert"][k]
                g = x["gamma_pert"][k] - 2 * alpha * x["psi_dot_pert"][k] - beta**2 * x["psi_pert"][k]
                n, m = M.shape[0], J.shape[0]
                A = np.block([[M, J.T], [J, np.zeros((m, m))]])
                s = np.linalg.solve(A, np.concatenate([Q, g]))
                qdd.append(s[:n])
                lam.append(s[n:])
            return {"qdd": np.array(qdd), "lam": np.array(lam)}
        if name == "newton" and "q" in x:
            return {"q": x["q"]}
        if name == "velocity" and "qd" in x:
            return {"qd": x["qd"]}
        return original(pkg, job)

    return probe


probes = sys.modules.get("mbdkit.probes")
if probes is not None and ATTACK == "covert":
    probes.PROBES["accelerations"] = _covert(probes.PROBES["accelerations"])
    probes.PROBES["gamma"] = _covert(probes.PROBES["gamma"])
if probes is not None and ATTACK == "leech":
    for _name in list(probes.PROBES):
        probes.PROBES[_name] = _leech(probes.PROBES[_name], _name)
'''
STUDENTS = {"honest": None, "skeleton": None, "leech": "leech", "exit": "exit", "stuck": "stuck"}
STUDENTS |= {"class": "class", "stash": "stash", "covert": "covert"}


def hostile(root: Path, student: str, attack: str | None) -> None:
    """The reference (the skeleton for ``skeleton`` and ``leech``) with the attack planted."""
    if student in ("skeleton", "leech"):
        make_skeleton(root / student, "hw2")
        package = root / student / "modules"
    else:
        package = copy_reference(root / student)
    if attack is not None:
        plant(package, attack, SPIN_SCENE)


def plant(package: Path, attack: str, spin_scene: str) -> None:
    """``LEAK`` with ``attack`` in ``package``, imported by its ``__init__`` and called first in ``load_model``
    (``spin_scene``: the scene whose probe the ``stuck`` attack spins in)."""
    (package / "_leak.py").write_text(LEAK.replace("@@ATTACK@@", attack).replace("@@SPIN@@", spin_scene))
    with open(package / "__init__.py", "a") as f:
        f.write("\nfrom . import _leak  # noqa\n")
    model = package / "io" / "model.py"
    text = model.read_text()
    anchor = '    """Read and validate a model file, or a mapping with the same content.\n'
    assert text.count(anchor) == 1, "load_model's docstring was rewritten: update the anchor"
    end = text.index('    """\n', text.index(anchor) + len(anchor)) + len('    """\n')
    model.write_text(text[:end] + "    from .. import _leak\n\n    _leak.on_load()\n" + text[end:])


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    root = tmp_path_factory.mktemp("withheld")
    for student, attack in STUDENTS.items():
        hostile(root / "class", student, attack)
    out = root / "out"
    homework = Homework("hw2", "hidden stays hidden", CHECKS)
    book = grade(homework, root / "class", out, jobs=2, limits=LIMITS, progress=False, resume=False)
    return book, out, homework, root / "class"


def results(out: Path, student: str) -> dict[str, dict]:
    return {t["name"]: t for t in json.loads((out / "results" / f"{student}.json").read_text())["tests"]}


def student_files(out: Path) -> dict[str, str]:
    """Every file written for students: results, feedback pages (their plots' PNG data left out), gradebook."""
    files = {str(p): p.read_text() for p in (out / "results").glob("*.json")}
    pages = {
        str(p): re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", p.read_text())
        for p in (out / "feedback").glob("*.html")
    }
    return files | pages | {"gradebook.csv": (out / "gradebook.csv").read_text()}


def status(output: str) -> str:
    """The status word of a hidden or per-student check's message ("description: status: reason; hint")."""
    if output == withheld.PASSED:
        return output
    found = [s for s in withheld.STATUSES if f": {s}: " in output or output.endswith(f": {s}")]
    assert len(found) == 1, output  # a description may hold ": " itself (lambda's sign convention)
    return found[0]


def secret_numbers(data: dict) -> set[str]:
    """The numbers of a model file with at least 3 significant digits, as a message could print them."""
    found: set[str] = set()

    def walk(value):
        if isinstance(value, dict):
            for item in value.values():
                walk(item)
        elif isinstance(value, list):
            for item in value:
                walk(item)
        elif isinstance(value, float) and value != 0:
            for text in {repr(value), f"{value:.6g}", f"{value:.4g}", f"{abs(value):.6g}", f"{abs(value):.4g}"}:
                if len(text.lstrip("-0.").replace(".", "").split("e")[0]) >= 3:
                    found.add(text)

    walk(data)
    return found


NUMBER_START = re.compile(r"(?<![\d.])[-\d.]")
"""Where a number a message prints can start: a digit, sign or point after neither a digit nor a point."""


def secret_number_in(text: str, numbers: set[str]) -> str | None:
    r"""The first of ``numbers`` that ``text`` holds whole: not after a digit or a point, not before a digit
    (the regular expression ``(?<![\d.])(n1|n2|...)(?!\d)``, which Python's ``re`` searches in time
    proportional to the text times the count of numbers: here a set lookup per start and length)."""
    if not numbers:
        return None
    assert all(NUMBER_START.match(n) for n in numbers), "every secret number starts with a digit, sign or point"
    lengths = sorted({len(n) for n in numbers})
    for start in NUMBER_START.finditer(text):
        i = start.start()
        for k in lengths:
            piece = text[i : i + k]
            if piece in numbers and not text[i + k : i + k + 1].isdecimal():
                return piece
    return None


def secrets() -> tuple[set[str], set[str]]:
    """(numbers, names) of the hidden scenes and of every student's own variant."""
    numbers, names = set(), set()
    models = [load_scene(c.scene).data for c in HIDDEN_CHECKS]
    models += [load_scene(c.scene, student=s, homework="hw2").data for c in OWN for s in STUDENTS]
    for data in models:
        numbers |= secret_numbers(data)
        names.add(data["model"]["name"])
    return numbers, {n for n in names if not any(n in c.name for c in CHECKS)}


def test_the_honest_student_passes_every_hidden_check_and_the_skeleton_none(graded):
    book, out, *_ = graded
    assert book.score("honest") == book.max_score, [t for t in results(out, "honest").values() if t["score"] == 0]
    skeleton = results(out, "skeleton")
    assert all(skeleton[c.name]["score"] == 0 for c in HIDDEN_CHECKS)
    assert all("not implemented yet" in skeleton[c.name]["output"] for c in HIDDEN_CHECKS)


def test_no_hidden_or_own_variant_text_or_number_reaches_a_student(graded):
    _, out, *_ = graded
    numbers, names = secrets()
    for path, text in student_files(out).items():
        assert not re.search(r"[A-Za-z0-9+/]{80,}", text), (path, "a long base64 run")
        assert not [name for name in names if name in text], path
        assert secret_number_in(text, numbers) is None, (path, secret_number_in(text, numbers))


@pytest.mark.parametrize("student", list(STUDENTS))
def test_a_hidden_or_own_variant_check_says_only_the_graders_words(graded, student):
    """Status, description and hint, whatever the code did: the exit, the spin, the class name, the stash,
    the wrong values placed to spell a mass."""
    _, out, homework, _ = graded
    tests = results(out, student)
    for check in homework.checks:
        if check.kind != PUBLIC:
            assert tests[check.name]["output"] in withheld.vocabulary(check, homework.checks), tests[check.name]


def test_the_attacks_ran_and_cost_only_their_checks(graded):
    book, out, *_ = graded
    state = {s: {c.name: status(results(out, s)[c.name]["output"]) for c in HIDDEN_CHECKS} for s in STUDENTS}
    assert set(state["exit"].values()) == {withheld.CRASHED}
    assert set(state["class"].values()) == {withheld.CRASHED}
    assert list(state["stuck"].values()).count(withheld.TIMED_OUT) == 1
    assert withheld.FAILED in state["covert"].values()
    for student in ("exit", "class", "stuck", "stash", "covert"):  # the public checks untouched
        assert all(results(out, student)[c.name]["score"] > 0 for c in TWINS), student


def test_answers_from_what_the_grader_sends_earn_no_hidden_point(graded):
    """The skeleton plus whatever follows from the inputs (the reference's gamma, Q, M, Psi_q, states at the
    checked times) scores on hidden checks what the skeleton does."""
    _, out, *_ = graded
    leech, skeleton = results(out, "leech"), results(out, "skeleton")
    assert sum(leech[c.name]["score"] for c in HIDDEN_CHECKS) <= sum(skeleton[c.name]["score"] for c in HIDDEN_CHECKS)


def test_the_page_holds_hidden_checks_back_until_published(graded):
    book, out, homework, folder = graded
    page = (out / "feedback" / "honest.html").read_text()
    hidden = [c for c in homework.checks if c.kind == HIDDEN]
    assert not [c.name for c in hidden if c.name in page]
    shown = sum(c.points for c in homework.checks if c.kind != HIDDEN)
    assert f"Score on the checks shown: <b>{shown:g} / {shown:g}</b>" in page
    assert f"{len(hidden)} more checks, on hidden scenes" in page and f"{book.max_score:g}</b>" not in page
    again = grade(homework, folder, out, jobs=1, limits=LIMITS, progress=False, publish_hidden=True)
    assert not [s for s, row in again.rows.items() if not row["resumed"]]  # nothing graded again
    published = (out / "feedback" / "honest.html").read_text()
    assert (
        all(c.name in published for c in hidden)
        and f"Score: <b>{book.max_score:g} / {book.max_score:g}</b>" in published
    )
    assert publish_feedback(out) == sorted(STUDENTS)
    assert (out / "feedback" / "honest.html").read_text() == published  # publishing twice changes nothing
    for student in STUDENTS:  # a Gradescope result keeps them for after publication
        tests = results(out, student)
        assert {tests[c.name]["visibility"] for c in hidden} == {"after_published"}


def test_the_secret_number_scan_finds_what_the_regular_expression_finds():
    """``secret_number_in`` against the regular expression it replaces, on texts made to hold a number with
    every kind of neighbour (a digit, a point, a sign, a letter, a superscript) and on ones without."""
    import random

    rng = random.Random(7)
    numbers = {"0.3512", "-0.3512", "1.25e-05", "351.2", "12.5", "-7.125"}
    pattern = re.compile("(?<![\\d.])(" + "|".join(map(re.escape, sorted(numbers, key=len, reverse=True))) + ")(?!\\d)")
    found = 0
    for _ in range(3000):
        noise = "".join(rng.choice("0123456789.-e x²=") for _ in range(40))
        cut = rng.randrange(len(noise))
        inside = (
            rng.choice(["", "1", ".", "-", " ", "x", "²"])
            + rng.choice(sorted(numbers))
            + rng.choice(["", "1", ".", "e", "²", " "])
        )
        text = noise[:cut] + (inside if rng.random() < 0.7 else "") + noise[cut:]
        expected = pattern.search(text)
        assert (secret_number_in(text, numbers) is None) == (expected is None), (text, expected)
        found += expected is not None
    assert 500 < found < 2900  # both outcomes, often
    assert secret_number_in("a mass of 0.35120 kg", numbers) is None  # a longer number is another number
    assert secret_number_in("x=-0.3512;", numbers) == "-0.3512"
