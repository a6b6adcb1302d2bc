"""The sandbox: what student code may not do, and how the grader reads a child's replies."""

from __future__ import annotations

import numpy as np
import pytest

from autograder.grading import find_submissions, run_checks
from autograder.reference import reference_file
from mbdkit import isolation as osi
from mbdkit import wire
from mbdkit.homework import load_homework
from mbdkit.sandbox import stack_samples, stuck_function

ATTEMPTS = """
        import os, socket, subprocess, sys
        outcomes = []
        attempts = {
            "read_reference": lambda: open(REFERENCE, "rb").read(),
            "list_grader": lambda: os.listdir(GRADER),
            "import_solutions": lambda: __import__("solutions.kinematics"),
            "import_grader": lambda: __import__("autograder.reference"),
            "socket": lambda: socket.create_connection(("127.0.0.1", 9), timeout=1),
            "write_file": lambda: open(os.path.join(os.getcwd(), "planted.txt"), "w").write("x"),
            "subprocess": lambda: subprocess.run(["true"]),
            "kill_parent": lambda: os.kill(os.getppid(), 0),
            "fork": lambda: os.fork(),
            "other_student": lambda: open(OTHER, "rb").read(),
            "reference_in_memory": lambda: sys.modules["solutions"],
        }
        for name, attempt in attempts.items():
            try:
                attempt()
                outcomes.append(name + "=allowed")
            except BaseException as err:
                outcomes.append(name + "=" + type(err).__name__)
        raise RuntimeError(";".join(outcomes))
"""


@pytest.mark.parametrize(
    "isolation",
    [
        "local",
        pytest.param(
            "os", marks=pytest.mark.skipif(osi.problem() is not None, reason=f"no bubblewrap here: {osi.problem()}")
        ),
    ],
)
def test_student_code_cannot_escape(tmp_path, reference_copy, isolation):
    """Reading the reference, other students' files or the grader, importing the reference package,
    the network, writing files, subprocesses, signals and fork are all refused; the check just fails.
    The audit hook says so in both backends (under bubblewrap it is the friendly first layer: what a
    bypass of it meets is in test_isolation.py)."""
    root = tmp_path / "submissions"
    package = reference_copy(root / "alice")
    reference_copy(root / "bob")
    joints = package / "planar" / "joints.py"
    text = joints.read_text()
    old = "        return -point_vector(qi, self.si, qj, self.sj)\n"
    attempt = ATTEMPTS.replace("REFERENCE", repr(str(reference_file("four_bar"))))
    attempt = attempt.replace("GRADER", repr(str(reference_file("four_bar").parents[1])))
    attempt = attempt.replace("OTHER", repr(str(root / "bob" / "modules" / "__init__.py")))
    exits = "        return point_vector_quadratic(qi, self.si, qj, self.sj, qdi, qdj)\n"
    assert text.count(old) == 1 and text.count(exits) == 1
    joints.write_text(text.replace(old, attempt).replace(exits, "        raise SystemExit(4)\n"))
    names = ["four_bar.constraints.revolute", "four_bar.jacobian.revolute", "four_bar.gamma.revolute"]
    checks = load_homework("hw1").select(names).checks
    outcomes = run_checks(checks, root / "alice", "hw1", "alice", forbidden=(root,), isolation=isolation)
    constraints, jacobian, gamma = outcomes
    assert not constraints.passed and jacobian.passed
    assert not gamma.passed and "called sys.exit()" in gamma.message
    message = constraints.message
    assert "=allowed" not in message, message
    for name in ("read_reference", "list_grader", "other_student", "write_file", "socket", "subprocess", "fork"):
        assert f"{name}=Refused" in message, message
    assert "import_solutions=ImportError" in message and "import_grader=ImportError" in message
    assert "reference_in_memory=KeyError" in message  # the sandbox never held the reference package
    assert not (root / "alice" / "planted.txt").exists()


def test_submission_layouts(tmp_path, reference_copy):
    """nbgrader's course root or submitted/ folder, a plain folder of student folders, one submission."""
    course = tmp_path / "course"
    reference_copy(course / "submitted" / "ann" / "hw1")
    (course / "submitted" / "ben" / "hw1").mkdir(parents=True)  # submitted a notebook only
    for root in (course, course / "submitted"):
        found = {s.student: s.path for s in find_submissions(root, "hw1")}
        assert found == {"ann": course / "submitted" / "ann" / "hw1", "ben": course / "submitted" / "ben" / "hw1"}
    reference_copy(tmp_path / "plain" / "cleo")
    assert [s.student for s in find_submissions(tmp_path / "plain", "hw1")] == ["cleo"]
    assert [s.student for s in find_submissions(tmp_path / "plain" / "cleo", "hw1")] == ["cleo"]
    checks = load_homework("hw1").select(["four_bar.newton"]).checks
    (outcome,) = run_checks(checks, course / "submitted" / "ben" / "hw1", "hw1", "ben")
    assert not outcome.passed and "no package modules/" in outcome.message


def test_wire_rejects_malformed_messages():
    array = np.arange(6.0).reshape(2, 3)
    assert np.array_equal(wire.loads(wire.dumps({"a": array}))["a"], array)
    assert wire.loads(wire.dumps({"s": np.array(1.5)}))["s"].shape == ()  # a scalar stays a scalar
    for bad in (
        b"not json",
        b"[1, 2]",
        b'{"a": {"__array__": [2, 3], "data": "AAAA"}}',
        b'{"a": {"__array__": [-1], "data": ""}}',
        b"\xff\xfe",
    ):
        with pytest.raises(wire.WireError):
            wire.loads(bad)


def test_stuck_function_is_the_loop_not_its_callee():
    """A loop in F calling G shows F in every stack sample and G in some: F is to blame."""
    dump = """Stack (most recent call first):
  File "/s/modules/assembly.py", line 99 in jacobian
  File "/s/modules/kinematics.py", line 81 in velocity_analysis
  File "/g/autograder/probes.py", line 10 in velocity
Stack (most recent call first):
  File "/s/modules/kinematics.py", line 81 in velocity_analysis
  File "/g/autograder/probes.py", line 10 in velocity
Stack (most recent call first):
  File "/s/modules/planar/joints.py", line 12 in jacobian
  File "/s/modules/assembly.py", line 97 in jacobian
  File "/s/modules/kinematics.py", line 81 in velocity_analysis
  File "/g/autograder/probes.py", line 10 in velocity
"""
    samples = stack_samples(dump)
    assert len(samples) == 3 and samples[0][0][2] == "velocity"
    assert stuck_function(samples, "/s/modules") == ("/s/modules/kinematics.py", 81, "velocity_analysis")


def test_the_local_forkserver_preloads_the_solver_libraries_but_not_jsonschema():
    """A student's own checks fork from a forkserver that imports numpy and scipy once; not jsonschema, whose
    import outside the grader's sandbox builds rfc3987_syntax's grammar (about 2 s of every notebook's first
    check). The grader's OS sandbox keeps it: rfc3987_syntax is not among the distributions it shows."""
    from mbdkit import _zygote, isolation, sandbox

    assert {"mbdkit._child", "numpy", "scipy.linalg", "scipy.integrate"} <= set(sandbox.PRELOAD)
    assert "jsonschema" not in sandbox.PRELOAD and "jsonschema" in _zygote.PRELOAD
    shown = {entry for _, entry in isolation.site_entries()}
    assert not [entry for entry in shown if entry.startswith("rfc3987_syntax")]
