"""Hostile submissions graded with the operating system's isolation on (bubblewrap, seccomp, uid 65534).

Each hostile student is the reference package with one attack planted in ``Revolute.constraints`` (the
check ``four_bar.constraints.revolute``): the attack first switches the audit hook off where it says so
(the flag in its closure found with ``gc``, or ``BLOCKED_IMPORTS`` rebound), so what stops it is the
operating system, not Python; then it reports what it got in the exception it raises, which the grader
puts in that check's message. Every attack costs that one check (or the checks its module breaks) and
nothing else, and the classmates graded in the same run, at the same time, keep full marks.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
import uuid
from pathlib import Path

import pytest

from autograder.grading import grade
from autograder.reference import reference_dir
from mbdkit import isolation as osi
from mbdkit import seccomp
from mbdkit.homework import Homework, load_homework
from mbdkit.sandbox import Limits

from .conftest import REPO, copy_reference, make_mutant

PROBLEM = osi.problem()
needs_isolation = pytest.mark.skipif(PROBLEM is not None, reason=f"no operating-system isolation here: {PROBLEM}")

LIMITS = Limits(timeout_scale=0.3)
CHECKS = [
    "four_bar.constraints.revolute",  # where the attacks are planted
    "four_bar.jacobian.revolute",
    "slider_crank.newton",
    "four_bar.newton",
    "slider_crank.velocity",
]
TOKEN = uuid.uuid4().hex[:10]
SECRET = f"secret-{TOKEN}"
HIDDEN_NPZ = reference_dir("hidden") / "test-isolation.npz"
"""A file in the folder where the grader caches hidden references (the fixture puts one there)."""
GIT_DIR = (
    subprocess.run(["git", "rev-parse", "--git-common-dir"], cwd=REPO, capture_output=True, text=True).stdout.strip()
    or ".git"
)
GIT_DIR = str((REPO / GIT_DIR).resolve())

HOOK_OFF = """
        import gc
        for obj in gc.get_objects():
            named = getattr(obj, "__name__", "") == "hook"
            if callable(obj) and named and getattr(obj, "__module__", "") == "mbdkit._child":
                for cell in obj.__closure__ or ():
                    if isinstance(cell.cell_contents, list) and cell.cell_contents == [False]:
                        cell.cell_contents[0] = True
                        report.append("hook=off")
"""
REBIND = """
        import mbdkit._child as child
        child.BLOCKED_IMPORTS = ()
        child._under = lambda path, roots: any(path.startswith(r) for r in ("/",))
        report.append("hook=rebound")
"""


def attempt(name: str, code: str) -> str:
    """One attempt: ``name=<repr of what it got>`` or ``name:<exception type>:<errno>``."""
    return f"""
        try:
            got = ({code})
            report.append("{name}=" + repr(got)[:200])
        except BaseException as err:
            report.append("{name}:" + type(err).__name__ + ":" + str(getattr(err, "errno", "")))
"""


FORK_EXEC = """
        import _posixsubprocess, os
        def fork_exec(argv, setsid):
            err_r, err_w = os.pipe()
            args = [[os.fsencode(a) for a in argv], [os.fsencode(argv[0])], True, (err_w,), None, None,
                    -1, -1, -1, -1, -1, -1, err_r, err_w, True, setsid, -1, None, None, None, -1, None]
            try:
                pid = _posixsubprocess.fork_exec(*args, True)
            except TypeError:
                pid = _posixsubprocess.fork_exec(*args)
            os.close(err_w)
            said = os.read(err_r, 200)
            os.close(err_r)
            os.waitpid(pid, 0)
            return said.decode(errors="replace") or "ran"
"""

ATTACKS: dict[str, str] = {
    # the audit hook's flag flipped through gc, then the reference package, hidden data and the .git
    "bypass_gc": HOOK_OFF
    + attempt("solutions", "__import__('solutions')")
    + attempt("hidden", f"open({str(HIDDEN_NPZ)!r}, 'rb').read(10)")
    + attempt("git", f"os.listdir({GIT_DIR + '/objects/pack'!r})")
    + attempt("worktree_git", f"open({str(REPO / '.git')!r}).read()")
    + attempt("root", "sorted(os.listdir('/'))"),
    # BLOCKED_IMPORTS and _under rebound: the imports are not refused, and still not there
    "bypass_rebind": REBIND
    + attempt("solutions", "__import__('solutions')")
    + attempt("autograder", "__import__('autograder.grading')")
    + attempt("hidden", f"open({str(HIDDEN_NPZ)!r}, 'rb').read(10)"),
    # no audit event for _posixsubprocess.fork_exec: the hook is not even needed off
    "fork_exec": FORK_EXEC
    + attempt("cat", f"fork_exec(['/bin/cat', {str(HIDDEN_NPZ)!r}], False)")
    + attempt("sleep", "fork_exec(['/bin/sleep', '600'], True)")
    + attempt("exec", "os.execv('/bin/sh', ['sh'])"),
    # a symlink in the submission and the host's /etc/passwd
    "symlink": HOOK_OFF
    + attempt("link", "open(os.path.join(os.path.dirname(__file__), 'passwd.txt')).read()")
    + attempt("passwd", "open('/etc/passwd').read()"),
    # the grader's secret in the environment of any process the sandbox can see
    "environ": HOOK_OFF
    + attempt("environ", "open('/proc/self/environ').read()")
    + attempt("procs", "[open('/proc/' + p + '/environ', 'rb').read() for p in os.listdir('/proc') if p.isdigit()]")
    + attempt("secret", f"any({SECRET!r} in str(v) for v in os.environ.values())"),
    # a classmate's submission, by its path on the grader's machine
    "tamper": HOOK_OFF
    + attempt("write", "open(CLASSMATE, 'a').write('raise SystemExit')")
    + attempt("list", "os.listdir(os.path.dirname(CLASSMATE))"),
    # new sockets of every family
    "sockets": HOOK_OFF
    + "        import socket\n"
    + attempt("inet", "socket.socket(socket.AF_INET, socket.SOCK_STREAM)")
    + attempt("unix", "socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)")
    + attempt("pair", "socket.socketpair()"),
    # a detached process that tries to rewrite the gradebook after the run
    "detached": HOOK_OFF
    + """
        import ctypes, time
        pid = os.fork()
        if pid == 0:
            try:
                os.setsid()
                ctypes.CDLL(None).prctl(15, b"mbdleft-TOKEN", 0, 0, 0)
                for _ in range(600):
                    try:
                        open(GRADEBOOK, "w").write("forged")
                    except BaseException:
                        pass
                    time.sleep(0.1)
            finally:
                os._exit(0)
        report.append("detached=" + str(pid))
""",
    # a fork bomb: 50 processes that would live a minute each
    "fork_bomb": HOOK_OFF
    + """
        import ctypes, time
        forked, refused = 0, 0
        for _ in range(50):
            try:
                pid = os.fork()
            except OSError:
                refused += 1
                continue
            if pid == 0:
                try:
                    ctypes.CDLL(None).prctl(15, b"mbdbomb-TOKEN", 0, 0, 0)
                    time.sleep(60)
                finally:
                    os._exit(0)
            forked += 1
        report.append(f"forked={forked} refused={refused}")
""",
}

TEMPLATE = """        global _ATTACK
        if "_ATTACK" not in globals():
            import os

            report = []
@@CODE@@
            _ATTACK = " | ".join(report)
        raise RuntimeError("ATTACK:" + _ATTACK)
"""


def plant(package: Path, attack: str, classmate: Path, gradebook: Path) -> None:
    """Put ``attack`` at the start of ``Revolute.constraints`` (the rest of the package is the reference)."""
    joints = package / "planar" / "joints.py"
    text = joints.read_text()
    anchor = "        return -point_vector(qi, self.si, qj, self.sj)\n"
    assert text.count(anchor) == 1, "Revolute.constraints was rewritten: update the anchor"
    code = ATTACKS[attack].replace("TOKEN", TOKEN)
    code = code.replace("CLASSMATE", repr(str(classmate))).replace("GRADEBOOK", repr(str(gradebook)))
    code = textwrap.indent(textwrap.dedent(code), " " * 12)
    joints.write_text(text.replace(anchor, TEMPLATE.replace("@@CODE@@\n", code) + anchor))


def import_hang(package: Path) -> None:
    """A module-level endless loop in kinematics.py (imported by the newton and velocity probes only)."""
    kinematics = package / "kinematics.py"
    text = kinematics.read_text()
    anchor = "\n\ndef "
    kinematics.write_text(text.replace(anchor, "\n\nwhile True:  # an endless loop at import\n    pass\n\n\ndef ", 1))


def homework() -> Homework:
    return Homework("hw1", "hostile", load_homework("hw1").select(CHECKS).checks)


def results(out: Path, student: str) -> dict[str, dict]:
    data = json.loads((out / "results" / f"{student}.json").read_text())
    return {t["name"]: t for t in data["tests"]}


def processes_named(prefix: str) -> list[int]:
    """Processes of this machine whose name (comm) starts with ``prefix``: a /proc scan."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                if Path(f"/proc/{entry}/comm").read_text().startswith(prefix[:15]):
                    found.append(int(entry))
            except OSError:
                continue
    return found


def commands_like(argv: list[str]) -> list[int]:
    wanted = "\0".join(argv).encode()
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                if Path(f"/proc/{entry}/cmdline").read_bytes().startswith(wanted):
                    found.append(int(entry))
            except OSError:
                continue
    return found


@pytest.fixture(scope="module")
def hostile(tmp_path_factory):
    """The hostile class and two honest classmates, graded once with the isolation on (2 jobs)."""
    root = tmp_path_factory.mktemp("hostile")
    folder, out = root / "submitted", root / "out"
    for student in ("ann", "bob"):
        copy_reference(folder / student)
    classmate = folder / "bob" / "modules" / "kinematics.py"
    before = classmate.read_bytes()
    for attack in ATTACKS:
        plant(copy_reference(folder / attack), attack, classmate, out / "gradebook.csv")
    (folder / "symlink" / "modules" / "passwd.txt").symlink_to("/etc/passwd")
    import_hang(copy_reference(folder / "import_hang"))
    make_mutant(folder / "os_exit", "exit")
    HIDDEN_NPZ.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy(reference_dir("public") / "four_bar.npz", HIDDEN_NPZ)
    old = os.environ.get("MBD_GRADER_SECRET")
    os.environ["MBD_GRADER_SECRET"] = SECRET  # inherited by the grading workers
    try:
        start = time.perf_counter()
        book = grade(homework(), folder, out, jobs=2, limits=LIMITS, progress=False, isolation="os")
        seconds = time.perf_counter() - start
    finally:
        if old is None:
            os.environ.pop("MBD_GRADER_SECRET")
        else:
            os.environ["MBD_GRADER_SECRET"] = old
    gradebook = (out / "gradebook.csv").read_bytes()
    time.sleep(1.0)  # a detached process would have rewritten the gradebook by now
    return {
        "book": book,
        "out": out,
        "seconds": seconds,
        "classmate": (classmate, before),
        "gradebook": gradebook,
    }


def attack_report(hostile, student: str) -> str:
    test = results(hostile["out"], student)["four_bar.constraints.revolute"]
    assert test["status"] == "failed"
    assert "ATTACK:" in test["output"], test["output"]
    return test["output"].split("ATTACK:", 1)[1].split(" (modules/")[0]


ATTACKED = {"four_bar.constraints.revolute", "slider_crank.newton", "four_bar.newton"}
"""The checks whose probes call Revolute.constraints (Newton-Raphson solves Psi = 0): an attack costs these."""


def only_the_attacked_checks_fail(hostile, student: str) -> None:
    failed = {n for n, t in results(hostile["out"], student).items() if t["status"] == "failed"}
    assert failed == ATTACKED, failed
    book = hostile["book"]
    lost = sum(c.points for c in homework().checks if c.name in ATTACKED)
    assert book.score(student) == book.max_score - lost


@needs_isolation
def test_classmates_keep_full_marks_and_the_run_is_quick(hostile):
    book = hostile["book"]
    for student in ("ann", "bob"):
        assert book.score(student) == book.max_score, results(hostile["out"], student)
    assert book.isolation == "os"
    data = json.loads((hostile["out"] / "results" / "ann.json").read_text())
    assert data["extra_data"]["isolation"] == "os"
    assert hostile["seconds"] < 90


@needs_isolation
def test_audit_hook_flag_flipped_through_gc(hostile):
    report = attack_report(hostile, "bypass_gc")
    assert "hook=off" in report  # the bypass itself works: the operating system is the wall
    assert "solutions:ModuleNotFoundError" in report
    assert "hidden:FileNotFoundError" in report
    assert "git:FileNotFoundError" in report and "worktree_git:FileNotFoundError" in report
    listing = report.split("root=", 1)[1]
    for name in ("submission", "tmp", "opt"):
        assert repr(name) in listing
    for name in ("work", "home", "var", "srv", "mnt"):
        assert repr(name) not in listing, listing
    only_the_attacked_checks_fail(hostile, "bypass_gc")


@needs_isolation
def test_blocked_imports_rebound(hostile):
    report = attack_report(hostile, "bypass_rebind")
    assert "hook=rebound" in report
    assert "solutions:ModuleNotFoundError" in report and "autograder:ModuleNotFoundError" in report
    assert "hidden:FileNotFoundError" in report
    only_the_attacked_checks_fail(hostile, "bypass_rebind")


@needs_isolation
def test_posixsubprocess_fork_exec_cannot_run_programs(hostile):
    report = attack_report(hostile, "fork_exec")
    assert "cat='OSError:1:" in report and "sleep='OSError:1:" in report, report  # EPERM from seccomp
    assert "exec:Refused" in report  # os.execv has an audit event: the hook's friendly refusal comes first
    assert not commands_like(["/bin/sleep", "600"]) and not commands_like(["sleep", "600"])
    only_the_attacked_checks_fail(hostile, "fork_exec")


@needs_isolation
def test_symlink_and_host_files_are_not_there(hostile):
    report = attack_report(hostile, "symlink")
    assert "link:FileNotFoundError" in report and "passwd:FileNotFoundError" in report
    for student in results(hostile["out"], "symlink").values():
        assert "root:x:" not in student["output"]
    only_the_attacked_checks_fail(hostile, "symlink")


@needs_isolation
def test_no_secret_in_the_environment(hostile):
    report = attack_report(hostile, "environ")
    assert "secret=False" in report
    assert "HOME=/tmp" in report
    for path in (hostile["out"] / "results").glob("*.json"):
        assert SECRET not in path.read_text()
    only_the_attacked_checks_fail(hostile, "environ")


@needs_isolation
def test_a_classmate_cannot_be_touched(hostile):
    report = attack_report(hostile, "tamper")
    assert "write:FileNotFoundError" in report and "list:FileNotFoundError" in report
    path, before = hostile["classmate"]
    assert path.read_bytes() == before
    only_the_attacked_checks_fail(hostile, "tamper")


@needs_isolation
def test_no_new_sockets(hostile):
    report = attack_report(hostile, "sockets")
    for family in ("inet", "unix", "pair"):
        assert f"{family}:PermissionError:1" in report, report
    only_the_attacked_checks_fail(hostile, "sockets")


@needs_isolation
def test_a_detached_process_dies_with_the_sandbox(hostile):
    report = attack_report(hostile, "detached")
    assert "detached=" in report  # it did fork
    assert (hostile["out"] / "gradebook.csv").read_bytes() == hostile["gradebook"]
    assert b"forged" not in hostile["gradebook"]
    assert not processes_named(f"mbdleft-{TOKEN}")
    only_the_attacked_checks_fail(hostile, "detached")


@needs_isolation
def test_a_fork_bomb_is_bounded(hostile):
    report = attack_report(hostile, "fork_bomb")
    forked = int(report.split("forked=")[1].split()[0])
    refused = int(report.split("refused=")[1].split()[0])
    assert forked + refused == 50 and 0 < forked < LIMITS.processes and refused > 0, report
    assert not processes_named(f"mbdbomb-{TOKEN}")
    only_the_attacked_checks_fail(hostile, "fork_bomb")


@needs_isolation
def test_an_import_time_hang_costs_one_timeout(hostile):
    tests = results(hostile["out"], "import_hang")
    failed = {n for n, t in tests.items() if t["status"] == "failed"}
    assert failed == {"slider_crank.newton", "four_bar.newton", "slider_crank.velocity"}  # the kinematics checks
    timeouts = [n for n in failed if "did not finish within the time limit" in tests[n]["output"]]
    assert len(timeouts) == 1
    assert "stuck in modules/kinematics.py" in tests[timeouts[0]]["output"]
    assert "at import (module level)" in tests[timeouts[0]]["output"]
    for name in failed - set(timeouts):
        output = tests[name]["output"]
        assert "skipped: importing modules.kinematics did not finish in an earlier check" in output, output
    timeout = max(c.timeout for c in homework().checks) * LIMITS.timeout_scale
    assert float((hostile["out"] / "timing" / "import_hang.txt").read_text()) < 2 * timeout + 10


@needs_isolation
def test_os_exit_names_the_function_and_the_check(hostile):
    tests = results(hostile["out"], "os_exit")
    failed = {n for n, t in tests.items() if t["status"] == "failed"}
    assert failed == {"slider_crank.newton", "four_bar.newton"}
    for name in failed:
        output = tests[name]["output"]
        assert "exit code 3: os._exit(3) was called in modules/kinematics.py:" in output, output
        assert "in newton_raphson" in output
        assert f"while the grader ran newton on {name.split('.')[0]}" in output


def test_seccomp_filter_in_a_process_of_its_own():
    """The filter alone: exec, new sockets and new namespaces refused; fork and threads work."""
    code = """
import errno, os, socket, subprocess, threading, ctypes
from mbdkit import seccomp
seccomp.install()
out = []
for name, call in [("socket", lambda: socket.socket()), ("exec", lambda: subprocess.run(["/bin/true"]))]:
    try:
        call(); out.append(name + "=allowed")
    except OSError as err:
        out.append(f"{name}={errno.errorcode[err.errno]}")
pid = os.fork()
if pid == 0:
    os._exit(7)
out.append(f"fork={os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])}")
t = threading.Thread(target=lambda: out.append("thread=ran")); t.start(); t.join()
libc = ctypes.CDLL(None, use_errno=True)
libc.syscall(56, 0x10000000 | 17, 0, 0, 0, 0)
out.append(f"clone_newuser={errno.errorcode[ctypes.get_errno()]}")
print(" ".join(out))
"""
    if not seccomp.supported():
        pytest.skip("the filter is written for Linux x86-64")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.stdout.split() == ["socket=EPERM", "exec=EPERM", "fork=7", "thread=ran", "clone_newuser=EPERM"], (
        done.stdout + done.stderr
    )


def test_staged_copy_takes_regular_files_only(tmp_path):
    package = tmp_path / "src" / "modules"
    (package / "sub").mkdir(parents=True)
    (package / "__init__.py").write_text("x = 1\n")
    (package / "sub" / "a.py").write_text("y = 2\n")
    (package / "link.py").symlink_to("/etc/passwd")
    (package / "dirlink").symlink_to("/etc")
    (package / "big.bin").write_bytes(b"0" * (osi.MAX_FILE_BYTES + 1))
    os.mkfifo(package / "fifo")
    skipped = osi.stage_package(tmp_path / "src", "modules", tmp_path / "staged")
    staged = tmp_path / "staged" / "modules"
    assert sorted(str(p.relative_to(staged)) for p in staged.rglob("*")) == ["__init__.py", "sub", "sub/a.py"]
    assert skipped == ["big.bin", "dirlink", "fifo", "link.py"]


def _descendants(pid: int) -> dict[int, str]:
    """{pid: start time} of every process below ``pid``."""
    parents: dict[int, int] = {}
    starts: dict[int, str] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                fields = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            parents[int(entry)], starts[int(entry)] = int(fields[1]), fields[19]
    found, todo = {}, [pid]
    while todo:
        current = todo.pop()
        for child, parent in parents.items():
            if parent == current and child not in found:
                found[child] = starts[child]
                todo.append(child)
    return found


def _alive(pid: int, start: str) -> bool:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return False
    return fields[19] == start and fields[0] != "Z"


API_GRADER = "import sys; from autograder.grading import grade; grade('hw1', sys.argv[1], sys.argv[2], jobs=2)"


@needs_isolation
@pytest.mark.parametrize("where", ["cli", "api"])
def test_sigkill_of_mbd_grade_leaves_no_process(tmp_path, where):
    """Workers die with the grader (PR_SET_PDEATHSIG), sandboxes with their worker (--die-with-parent).

    'cli': ``mbd grade --jobs 2``; 'api': ``grade(jobs=2)`` from Python: both a LocalCluster
    (``solutions.batch``), whose nannies live in the grader, each worker a child of it.
    """
    folder = tmp_path / "submitted"
    for student in ("a", "b", "c", "d"):
        make_mutant(folder / student, "hang")  # each costs a 10 s timeout: the workers would grade on
    if where == "cli":
        command = [sys.executable, "-m", "solutions.cli", "grade", "hw1", str(folder), "--out", str(tmp_path / "out")]
        command += ["--jobs", "2"]
    else:
        command = [sys.executable, "-c", API_GRADER, str(folder), str(tmp_path / "out")]
    grader = subprocess.Popen(command, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    below: dict[int, str] = {}
    while time.monotonic() < deadline:
        below = _descendants(grader.pid)
        if sum(_sandboxed_python(pid) for pid in below) >= 2:
            break  # two sandboxes (the workers', not the grader's first probe) run student code
        time.sleep(0.2)
    assert sum(_sandboxed_python(pid) for pid in below) >= 2, "the grader did not start its sandboxes"
    grader.send_signal(signal.SIGKILL)
    grader.wait()
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and any(_alive(p, s) for p, s in below.items()):
        time.sleep(0.1)
    assert not [p for p, s in below.items() if _alive(p, s)]


def _sandboxed_python(pid: int) -> bool:
    """The python child inside a sandbox (not the bwrap processes, whose command line holds it too)."""
    argv = _command(pid).split("\0")
    return argv[:2] == [osi.interpreter()[1], "-I"] and osi.BOOT in argv


def _command(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().decode(errors="replace")
    except OSError:
        return ""


def test_mbd_grade_refuses_without_isolation_unless_told(tmp_path, monkeypatch, capsys):
    from solutions.cli import main

    folder = tmp_path / "submitted"
    copy_reference(folder / "ann")
    monkeypatch.setenv(osi.BWRAP_ENV, str(tmp_path / "no-bwrap"))
    monkeypatch.delenv(osi.UNSAFE_ENV, raising=False)
    out = tmp_path / "out"
    assert main(["grade", "hw1", str(folder), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("mbd: error: cannot isolate student code: bubblewrap (bwrap)")
    assert "--unsafe-no-isolation" in err
    assert not out.exists()
    assert main(["grade", "hw1", str(folder), "--out", str(out), "--jobs", "1", "--unsafe-no-isolation"]) == 0
    said = capsys.readouterr().out
    assert "warning: graded NOT isolated by the operating system" in said
    data = json.loads((out / "results" / "ann.json").read_text())
    assert data["extra_data"]["isolation"] == "local" and "NOT isolated" in data["output"]
    assert data["score"] == data["max_score"]


# -- one bubblewrap sandbox per submission, a child forked in it for each set of checks -----------------------
ZYGOTE_ATTACKS = {
    # what a child can learn of the zygote that forked it (same uid, same namespaces)
    "peek": HOOK_OFF
    + attempt("mem", "open(f'/proc/{os.getppid()}/mem', 'rb').read(1)")
    + attempt("environ", "open(f'/proc/{os.getppid()}/environ', 'rb').read()")
    + attempt("fds", "os.listdir(f'/proc/{os.getppid()}/fd')"),
    # a process left running for the next child (hidden checks) to meet
    "leave": HOOK_OFF
    + """
        import ctypes, time
        pid = os.fork()
        if pid == 0:
            try:
                os.setsid()
                ctypes.CDLL(None).prctl(15, b"mbdnext-TOKEN", 0, 0, 0)
                time.sleep(60)
            finally:
                os._exit(0)
        report.append("left=" + str(pid))
""",
    # the zygote killed: the next child needs a new sandbox
    "kill": HOOK_OFF + "        import signal\n" + attempt("kill", "os.kill(os.getppid(), signal.SIGKILL)"),
}


def zygote_attack(package: Path, attack: str) -> None:
    """``attack`` at the start of ``Revolute.constraints``, once per child; the report in its exception."""
    joints = package / "planar" / "joints.py"
    text = joints.read_text()
    anchor = "        return -point_vector(qi, self.si, qj, self.sj)\n"
    code = textwrap.indent(textwrap.dedent(ZYGOTE_ATTACKS[attack].replace("TOKEN", TOKEN)), " " * 12)
    joints.write_text(text.replace(anchor, TEMPLATE.replace("@@CODE@@\n", code) + anchor))


def run_constraints(sandbox, may_die: bool = False) -> str | None:
    """The four-bar's constraints probe in ``sandbox`` (Revolute.constraints runs): the attack's report, or
    None when ``may_die`` and the child died before it could reply."""
    from autograder.grading import stored_reference
    from autograder.scenes import load_scene
    from mbdkit.scenes import job_key

    scene = load_scene("four_bar")
    reply = sandbox.run("constraints", job_key(scene), scene.data, stored_reference("four_bar").inputs, {}, 30.0)
    if may_die and reply.status == "died":
        return None
    said = [e.get("message", "") for e in reply.element_errors if "ATTACK:" in e.get("message", "")]
    assert said, reply
    return said[0].split("ATTACK:", 1)[1]


@needs_isolation
@pytest.mark.parametrize("attack", list(ZYGOTE_ATTACKS))
def test_children_of_one_sandbox_stay_apart(tmp_path, attack):
    """The public and the hidden checks of a submission run in two children forked one after the other in
    one bubblewrap sandbox (one start, one import of numpy and scipy): a child cannot read the zygote's
    memory, descriptors or environment; what it left running is killed before the next child starts;
    a child that kills the zygote ends that sandbox (its PID namespace ends with bubblewrap's reaper, which
    ends with the zygote: the child may die before it replies) and costs a new sandbox for the next child,
    and nothing else."""
    from mbdkit.sandbox import Sandbox

    package = copy_reference(tmp_path / "eve")
    zygote_attack(package, attack)
    host = osi.IsolatedHost(tmp_path / "eve", "modules", Limits().tmp_size)
    try:
        with Sandbox(tmp_path / "eve", host=host, isolation="os") as first:
            report = run_constraints(first, may_die=attack == "kill")
            if attack == "leave":
                deadline = time.monotonic() + 10.0  # it names itself just after the fork
                while not processes_named(f"mbdnext-{TOKEN}") and time.monotonic() < deadline:
                    time.sleep(0.05)
                assert "left=" in report and processes_named(f"mbdnext-{TOKEN}")  # it runs, for now
        assert not processes_named(f"mbdnext-{TOKEN}")  # gone with the first child
        with Sandbox(tmp_path / "eve", host=host, isolation="os") as second:
            assert run_constraints(second, may_die=attack == "kill") != ""  # the same code runs in a new child
        assert host.starts == (2 if attack == "kill" else 1)
    finally:
        host.close()
    assert not processes_named(f"mbdnext-{TOKEN}")
    if attack == "peek":
        for name in ("mem", "environ", "fds"):
            assert f"{name}:PermissionError" in report, report
    if attack == "kill":  # the signal was sent (a report when the child replied before the sandbox ended)
        assert report is None or "kill=None" in report, report
