"""nbgrader's kernel in the grader's sandbox: what a notebook's cells see and can do while nbgrader autogrades.

One notebook of hostile cells runs through ``SandboxedExecute`` (nbgrader's ``Execute`` with the sandboxed kernel)
in a folder laid out as nbgrader's ``autograded/STUDENT/hw1/``, beside a stand-in gradebook, while this process
holds a grading secret; its last cell kills the kernel. A second kernel outlives its wall-clock limit.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import nbformat
import pytest

from autograder.api import SandboxedExecute
from autograder.kernel import KernelLimits, SandboxedKernelManager
from mbdkit import isolation as osi
from mbdkit.api import GRADED_OUTSIDE

pytestmark = pytest.mark.skipif(osi.problem() is not None, reason=f"no bubblewrap sandbox: {osi.problem()}")

REPO = Path(__file__).resolve().parents[2]
SECRET = "kernel-test-secret-7f3a"

PROBE = r"""
import json, os, socket, sys
seen = {}
def attempt(name, action):
    try:
        seen[name] = repr(action())[:200]
    except BaseException as err:
        seen[name] = "refused: " + type(err).__name__
attempt("course file", lambda: open(COURSE + "/autograder/hw1.toml").read())
attempt("solutions", lambda: os.listdir(COURSE + "/solutions"))
attempt("gradebook", lambda: open(GRADEBOOK, "rb").read(16))
attempt("import autograder", lambda: __import__("autograder"))
attempt("import solutions", lambda: __import__("solutions"))
attempt("write the submission", lambda: open("modules/__init__.py", "a").write("raise SystemExit\n"))
attempt("write the classmate", lambda: open(CLASSMATE, "a").write("raise SystemExit\n"))
attempt("write the sockets' folder", lambda: open("/kernel/ipc/extra", "w"))
attempt("network", lambda: socket.create_connection(("1.1.1.1", 53), timeout=2))
attempt("write /tmp", lambda: open("/tmp/scratch", "w").write("fine"))
seen["secret"] = [k for k, v in os.environ.items() if "SECRET" in k or v == SECRET]
seen["uid"], seen["cwd"], seen["root"] = os.getuid(), os.getcwd(), sorted(os.listdir("/"))
seen["processes"] = len([p for p in os.listdir("/proc") if p.isdigit()])
seen["modules"] = __import__("modules").__file__
print(json.dumps(seen))
"""


def notebook(cells: list[str]):
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nb.cells = [nbformat.v4.new_code_cell(source) for source in cells]
    return nb


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    """The hostile notebook, run; (its cells, the submission folder, the classmate's file)."""
    root = tmp_path_factory.mktemp("kernel")
    folder = root / "autograded" / "mal" / "hw1"
    (folder / "modules").mkdir(parents=True)
    (folder / "modules" / "__init__.py").write_text("WHO = 'mal'\n")
    classmate = root / "autograded" / "ada" / "hw1" / "modules" / "__init__.py"
    classmate.parent.mkdir(parents=True)
    classmate.write_text("WHO = 'ada'\n")
    (root / "gradebook.db").write_bytes(b"SQLite format 3\x00")
    constants = f"COURSE, GRADEBOOK, CLASSMATE, SECRET = {str(REPO)!r}, {str(root / 'gradebook.db')!r}, "
    constants += f"{str(classmate)!r}, {SECRET!r}"
    nb = notebook(
        [
            constants,
            PROBE,
            "from mbdkit import check\ncheck('hw1', 'revolute')",
            "import os\nos._exit(3)",  # the kernel dies: nbgrader goes on with the notebook
            "print('never')",
        ]
    )
    with pytest.MonkeyPatch.context() as patch:  # as nbgrader runs it, with the grader's secret in its environment
        patch.setenv("MBD_GRADER_SECRET", SECRET)
        patch.setenv("NBGRADER_EXECUTION", "autograde")
        SandboxedExecute(timeout=120, startup_timeout=120).preprocess(nb, {"metadata": {"path": str(folder)}})
    return nb.cells, folder, classmate


def text(cell, stream: str = "stdout") -> str:
    return "".join(o.get("text", "") for o in cell.outputs if o.output_type == "stream" and o.name == stream)


def test_the_kernel_sees_nothing_of_the_course(hostile):
    cells, _, _ = hostile
    seen = json.loads(text(cells[1]))
    for attempt in ("course file", "solutions", "gradebook", "import autograder", "import solutions", "network"):
        assert seen[attempt].startswith("refused"), (attempt, seen[attempt])
    assert seen["secret"] == [] and seen["cwd"] == osi.INNER_SUBMISSION
    assert seen["modules"] == f"{osi.INNER_SUBMISSION}/modules/__init__.py"  # the student's package, a copy
    hidden_tops = {REPO.parts[1], "home", "work"} - {osi.INNER_TMP.strip("/")}  # a course under /tmp: its own /tmp
    assert not hidden_tops & set(seen["root"])
    assert seen["processes"] < 8  # its own PID namespace
    assert seen["uid"] == (osi.SANDBOX_UID if os.geteuid() == 0 else os.geteuid())


def test_the_kernel_changes_nothing_outside(hostile):
    cells, folder, classmate = hostile
    seen = json.loads(text(cells[1]))
    for attempt in ("write the submission", "write the classmate", "write the sockets' folder"):
        assert seen[attempt].startswith("refused"), (attempt, seen[attempt])
    assert seen["write /tmp"] == "4"  # its own /tmp works
    assert (folder / "modules" / "__init__.py").read_text() == "WHO = 'mal'\n"
    assert classmate.read_text() == "WHO = 'ada'\n"
    assert sorted(p.name for p in folder.iterdir()) == ["modules"]


def test_check_prints_one_line_and_grades_nothing(hostile):
    cells, _, _ = hostile
    assert text(cells[2]) == GRADED_OUTSIDE.format(what="hw1 revolute") + "\n"
    assert text(cells[2], "stderr") == "" and not [o for o in cells[2].outputs if o.output_type == "error"]


def test_a_dead_kernel_ends_the_run_not_the_grading(hostile):
    cells, _, _ = hostile
    assert cells[-1].outputs == []  # never ran; SandboxedExecute returned the notebook


def test_a_cell_is_interrupted_after_its_timeout_and_the_kernel_killed_after_its_wall_clock_limit(tmp_path):
    class Impatient(SandboxedKernelManager):
        limits = KernelLimits(wall=12.0)
        folders: list[str] = []

        async def start_kernel(self, **kw):
            await super().start_kernel(**kw)
            self.folders.append(self.sandbox.tmp)

    (tmp_path / "hw1").mkdir()
    deaf = "import signal, time\nsignal.signal(signal.SIGINT, signal.SIG_IGN)\nwhile True:\n"
    deaf += "    print('still here', flush=True)\n    time.sleep(0.5)"  # deaf to interrupts, never silent
    nb = notebook(["while True:\n    pass", deaf, "print('never')"])
    execute = SandboxedExecute(timeout=3, kernel_manager_class=Impatient)
    execute.preprocess(nb, {"metadata": {"path": str(tmp_path / "hw1")}})
    assert "KeyboardInterrupt" in {o.get("ename") for o in nb.cells[0].outputs}  # interrupted by a message
    assert nb.cells[2].outputs == []  # the kernel was killed in the deaf cell
    assert len(Impatient.folders) == 1 and not os.path.exists(Impatient.folders[0])  # the sandbox is gone
