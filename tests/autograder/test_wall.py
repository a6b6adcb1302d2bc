"""Limits that are limits, and a sandbox that shows only what it must (the grader's operating-system wall).

Hostile submissions (the reference package with one attack at the start of ``Revolute.constraints``, the
check ``four_bar.constraints.revolute``; the attack switches the audit hook off first, so what stops it is
the operating system) are graded through ``autograder.grading.grade`` with ``jobs=2`` beside honest
classmates: writes to the read-only root, forks that together hold more than the sandbox's memory, SysV
shared memory beyond its cap, packages installed beside the interpreter, and 29 busy processes beside a
correct but slow classmate. Each costs that one check; the classmates keep their scores (the slow one
exactly its score alone). Then, in one sandbox: a file and SysV IPC objects the first child leaves are
gone for the next; and without a cgroup the grader says so once and grades with the rlimits.

Without the cgroup (``MBD_NO_CGROUP=1`` and the cgroup tests forced to run) the three forks all hold their
memory and the slow classmate loses its first check; without the zygote's cleaning the second child finds
the first one's file and IPC objects: these tests fail.
"""

from __future__ import annotations

import json
import os
import re
import sys
import sysconfig
import textwrap
import threading
import uuid
from pathlib import Path

import pytest

from autograder.grading import grade
from mbdkit import cgroup
from mbdkit import isolation as osi
from mbdkit.homework import Homework, load_homework
from mbdkit.sandbox import Limits

from .conftest import copy_reference

PROBLEM = osi.problem()
needs_isolation = pytest.mark.skipif(PROBLEM is not None, reason=f"no operating-system isolation here: {PROBLEM}")
needs_cgroup = pytest.mark.skipif(
    PROBLEM is not None or cgroup.problem() is not None, reason=f"no cgroup for the sandboxes: {cgroup.problem()}"
)
needs_root = pytest.mark.skipif(os.geteuid() != 0, reason="the IPC caps are set by the root helper")

MiB = 2**20
CHECKS = ["four_bar.constraints.revolute", "four_bar.jacobian.revolute"]
ATTACKED = "four_bar.constraints.revolute"
LIMITS = Limits(tmp_size=16 * MiB, sandbox_memory=640 * MiB)
"""Small caps: a /tmp of 16 MiB, 640 MiB for all the processes of a sandbox (an honest one held at most 72
MiB grading all of hw1 or hw3: the cgroup's peak)."""
FORK_BYTES = 448 * MiB
"""What each of three forks allocates: well inside RLIMIT_AS (3 GiB), 1344 MiB together. One fits in the sandbox's 640
MiB beside the grader's own, two exceed it by far, more than reclaiming the group's file pages could free, so the
kernel's OOM killer acts (with 320 MiB, two forks and the grader were a few percent over the bound, and on a loaded
machine the group could stall in reclaim past the check's time limit instead: a flake of 2026-12-04, "did not finish
within the time limit")."""
BURN = 1.0
"""CPU seconds the slow classmate spends in Revolute.constraints: alone (or with one core) well inside the
check's 10 s; with 2/31 of the 2 cores that 29 busy processes would leave it, not."""
BUSY = 29
LINGER = 12.0
"""Seconds the busy submission's 29 processes spin, and its check sleeps: longer than its own timeout (10 s),
whose end kills them, and than the slow classmate's check, which starts about when they do."""
TOKEN = uuid.uuid4().hex[:6]

BASE_SITE = sysconfig.get_paths(vars={"base": os.path.realpath(sys.base_prefix)})["purelib"]
"""The interpreter's own site-packages (on the host: everything installed beside the standard library)."""
ALLOWED = {entry.split(".")[0] for _, entry in osi.site_entries()}


def _not_allowed() -> str | None:
    """A package in the interpreter's own site-packages that the sandbox must not show, if there is one."""
    try:
        names = sorted(os.listdir(BASE_SITE))
    except OSError:
        return None
    for name in names:
        if name not in ALLOWED and (Path(BASE_SITE) / name / "__init__.py").is_file():
            return name
    return None


HOOK_OFF = """
import gc
for obj in gc.get_objects():
    if callable(obj) and getattr(obj, "__name__", "") == "hook" and getattr(obj, "__module__", "") == "mbdkit._child":
        for cell in obj.__closure__ or ():
            if isinstance(cell.cell_contents, list) and cell.cell_contents == [False]:
                cell.cell_contents[0] = True
                report.append("hook=off")
"""

ATTACKS = {
    # 1 GiB to bubblewrap's root, /etc, /dev/shm, and (in files of 8 MiB) to /tmp
    "disk": """
import errno
def fill(paths):
    written, said = 0, "none"
    for path in paths:
        try:
            with open(path, "wb", buffering=0) as f:
                for _ in range(8):
                    written += f.write(b"x" * MiB)
        except OSError as err:
            said = errno.errorcode.get(err.errno, str(err.errno))
            break
    return f"{written // MiB}:{said}"
for name, folder in (("root", "/"), ("etc", "/etc"), ("shm", "/dev/shm"), ("tmp", "/tmp")):
    report.append(name + "=" + fill([f"{folder}/big{k}" for k in range(128)]))
""",
    # three forks each allocating FORK_BYTES (inside RLIMIT_AS) and holding it until all have (or 3 s)
    "forks": """
import numpy as np, select, time
ready_r, ready_w = os.pipe()
go_r, go_w = os.pipe()
pids = []
for _ in range(3):
    pid = os.fork()
    if pid == 0:
        try:
            block = np.ones(FORK_BYTES // 8)
            os.write(ready_w, b"1")
            os.read(go_r, 1)
        finally:
            os._exit(0)
    pids.append(pid)
os.close(ready_w)
ready, deadline = 0, time.monotonic() + 3
while ready < 3 and select.select([ready_r], [], [], max(0, deadline - time.monotonic()))[0]:
    if not os.read(ready_r, 1):
        break  # every fork has ended
    ready += 1
os.write(go_w, b"123")
codes = [os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) for pid in pids]
report.append(f"held={codes.count(0)} killed={codes.count(-9)}")
""",
    # SysV shared memory of 1 GiB, then segments of 4 MiB until refused; message queues until refused
    "shm": """
import ctypes
libc = ctypes.CDLL(None, use_errno=True)
def made(call, *args):
    result = call(*args)
    return f"{result >= 0}:{ctypes.get_errno() if result < 0 else 0}"
report.append("big=" + made(libc.shmget, 0, 2**30, 0o1600))
segments = 0
while segments < 64 and libc.shmget(0, 4 * MiB, 0o1600) >= 0:
    segments += 1
report.append(f"segments={segments}:{ctypes.get_errno()}")
queues = 0
while queues < 64 and libc.msgget(0, 0o1600) >= 0:
    queues += 1
report.append(f"queues={queues}:{ctypes.get_errno()}")
""",
    # what is installed beside the interpreter: listed, then imported from its folder put on sys.path
    "site": """
import sys
try:
    report.append("listing=" + repr(sorted(os.listdir(BASE_SITE))))
except OSError as err:
    report.append("listing:" + type(err).__name__)
sys.path.append(BASE_SITE)
try:
    __import__(NOT_ALLOWED)
    report.append("import=ok")
except ImportError as err:
    report.append("import:" + type(err).__name__)
""",
    # 29 processes in sessions of their own, spinning LINGER seconds from when all are started
    "busy": """
import ctypes, time
go_r, go_w = os.pipe()
started = 0
for _ in range(BUSY):
    try:
        pid = os.fork()
    except OSError:
        break
    if pid == 0:
        try:
            os.setsid()
            ctypes.CDLL(None).prctl(15, b"mbdbusy-TOKEN", 0, 0, 0)
            os.read(go_r, 1)
            end = time.monotonic() + LINGER
            while time.monotonic() < end:
                pass
        finally:
            os._exit(0)
    started += 1
os.write(go_w, b"x" * started)
time.sleep(LINGER)
""",
}

SLOW = """
        global _SLOW
        if "_SLOW" not in globals():  # correct, and slow: BURN seconds of CPU at its first call
            import time as _time

            _SLOW = _time.thread_time()
            while _time.thread_time() - _SLOW < BURN:
                pass
"""

TEMPLATE = """
global _ATTACK
if "_ATTACK" not in globals():
    import os
    MiB = 2**20
    report = []
@@CODE@@
    _ATTACK = " | ".join(report)
raise RuntimeError("ATTACK:" + _ATTACK)
"""

ANCHOR = "        return -point_vector(qi, self.si, qj, self.sj)\n"
CONSTANTS = {
    "FORK_BYTES": FORK_BYTES,
    "BUSY": BUSY,
    "LINGER": LINGER,
    "TOKEN": TOKEN,
    "BURN": BURN,
    "BASE_SITE": repr(BASE_SITE),
    "NOT_ALLOWED": repr(_not_allowed() or "no_such_package_here"),
}


def _fill(code: str) -> str:
    for name, value in CONSTANTS.items():
        code = re.sub(rf"\b{name}\b", str(value), code)
    return code


def plant(package: Path, code: str) -> None:
    """``code`` at the start of ``Revolute.constraints`` (the rest of the package is the reference)."""
    joints = package / "planar" / "joints.py"
    text = joints.read_text()
    assert text.count(ANCHOR) == 1, "Revolute.constraints was rewritten: update the anchor"
    joints.write_text(text.replace(ANCHOR, code + ANCHOR))


def attack(package: Path, name: str) -> None:
    body = textwrap.indent(textwrap.dedent(HOOK_OFF) + textwrap.dedent(_fill(ATTACKS[name])), " " * 4)
    plant(package, textwrap.indent(TEMPLATE.replace("@@CODE@@\n", body), " " * 8))


def homework() -> Homework:
    return Homework("hw1", "wall", load_homework("hw1").select(CHECKS).checks)


def results(out: Path, student: str) -> dict[str, dict]:
    data = json.loads((out / "results" / f"{student}.json").read_text())
    return {t["name"]: t for t in data["tests"]}


def report(out: Path, student: str) -> str:
    test = results(out, student)[ATTACKED]
    assert test["status"] == "failed" and "ATTACK:" in test["output"], test["output"]
    return test["output"].split("ATTACK:", 1)[1].split(" (modules/")[0]


def only_the_attacked_check_fails(out: Path, student: str) -> None:
    failed = {name for name, test in results(out, student).items() if test["status"] == "failed"}
    assert failed == {ATTACKED}, results(out, student)


def _grade(root: Path, students: dict[str, str | None], jobs: int = 2) -> tuple[object, Path]:
    folder, out = root / "submitted", root / "out"
    for student, kind in students.items():
        package = copy_reference(folder / student)
        if kind == "slow":
            plant(package, _fill(SLOW))
        elif kind is not None:
            attack(package, kind)
    book = grade(homework(), folder, out, jobs=jobs, limits=LIMITS, progress=False, isolation="os")
    return book, out


def _busy_processes() -> int:
    """How many of the busy submission's processes run now (a /proc scan, by the name they give themselves)."""
    count = 0
    for entry in os.listdir("/proc"):
        try:
            count += entry.isdigit() and Path(f"/proc/{entry}/comm").read_text().startswith(f"mbdbusy-{TOKEN}")
        except OSError:
            continue
    return count


@pytest.fixture(scope="module")
def walled(tmp_path_factory):
    """The hostile class beside an honest classmate, graded once (2 jobs)."""
    students = {"ann": None, "disk": "disk", "forks": "forks", "shm": "shm", "site": "site"}
    return _grade(tmp_path_factory.mktemp("walled"), students)


@pytest.fixture(scope="module")
def crowded(tmp_path_factory):
    """29 busy processes in one sandbox, the slow classmate in the other, graded at the same time; and the
    most busy processes seen running at once."""
    seen, done = [0], threading.Event()

    def watch():
        while not done.wait(0.25):
            seen[0] = max(seen[0], _busy_processes())

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    try:
        book, out = _grade(tmp_path_factory.mktemp("crowded"), {"busy": "busy", "slow": "slow"})
    finally:
        done.set()
        watcher.join()
    return book, out, seen[0]


@pytest.fixture(scope="module")
def alone(tmp_path_factory):
    """The slow classmate graded alone."""
    return _grade(tmp_path_factory.mktemp("alone"), {"slow": "slow"}, jobs=1)


@needs_isolation
def test_an_honest_classmate_keeps_full_marks(walled):
    book, out = walled
    assert book.score("ann") == book.max_score, results(out, "ann")


@needs_isolation
def test_the_root_is_read_only_and_tmp_is_capped(walled):
    book, out = walled
    said = dict(item.split("=") for item in report(out, "disk").split(" | ") if "=" in item)
    for name in ("root", "etc", "shm"):
        assert said[name] == "0:EROFS", said
    written, error = said["tmp"].split(":")
    assert int(written) <= LIMITS.tmp_size // MiB and error == "ENOSPC", said
    only_the_attacked_check_fails(out, "disk")


@needs_cgroup
def test_forks_share_one_memory_bound(walled):
    book, out = walled
    said = report(out, "forks")
    held, killed = (int(part.split("=")[1]) for part in said.split(" | ")[-1].split())
    # each alone fits in RLIMIT_AS, the three together (1344 MiB) not in the group's 640 MiB: the kernel kills at
    # least one; two may still end well, one after the other (held counts endings, not blocks held at once: on a
    # fast machine a fork's block was taken back before the third allocated its own). Without the group: held=3.
    assert held < 3 and killed >= 1 and 2 * FORK_BYTES >= LIMITS.sandbox_memory, said
    only_the_attacked_check_fails(out, "forks")


@needs_isolation
@needs_root
def test_sysv_ipc_is_capped(walled):
    book, out = walled
    said = dict(item.split("=") for item in report(out, "shm").split(" | ") if "=" in item)
    assert said["big"] == "False:22", said  # EINVAL: larger than the namespace's shmmax
    segments, errno = (int(x) for x in said["segments"].split(":"))
    assert segments * 4 * MiB <= LIMITS.tmp_size and errno == 28, said  # ENOSPC: shmall reached
    queues, errno = (int(x) for x in said["queues"].split(":"))
    assert queues < 64 and errno == 28, said
    only_the_attacked_check_fails(out, "shm")


@needs_isolation
def test_only_the_standard_library_and_the_allowed_packages(walled):
    book, out = walled
    said = report(out, "site")
    assert "listing=[]" in said or "listing:FileNotFoundError" in said, said
    assert "import:ModuleNotFoundError" in said, said
    only_the_attacked_check_fails(out, "site")


@needs_cgroup
def test_busy_processes_do_not_slow_a_classmate(crowded, alone):
    book, out, seen = crowded
    assert seen >= BUSY - 1  # ran at once, beside the classmate (RLIMIT_NPROC 32 may refuse the last fork)
    assert "did not finish within the time limit" in results(out, "busy")[ATTACKED]["output"]
    only_the_attacked_check_fails(out, "busy")  # its own check: it slept on
    assert book.score("slow") == alone[0].score("slow") == book.max_score, results(out, "slow")


# -- nothing shared between two children of one sandbox ------------------------------------------------------
LEAVE = """
import ctypes
libc = ctypes.CDLL(None, use_errno=True)
report.append("tmp=" + repr(sorted(os.listdir("/tmp"))))
report.append(f"shm={libc.shmget(4242, 0, 0)}:{ctypes.get_errno()}")
report.append(f"msg={libc.msgget(4242, 0)}:{ctypes.get_errno()}")
for name in ("shm", "msg", "sem"):
    report.append(name + "s=" + str(len(open(f"/proc/sysvipc/{name}").readlines()) - 1))
try:
    open("/tmp/left", "w").write("x")
    os.makedirs("/tmp/deep/er")
    os.chmod("/tmp/deep", 0)  # a folder the next child could not look into
except OSError as err:
    report.append("write:" + type(err).__name__)
libc.shmget(4242, 4096, 0o1600)
libc.msgget(4242, 0o1600)
libc.semget(4242, 1, 0o1600)
"""


@needs_isolation
def test_no_file_or_ipc_object_survives_into_the_next_child(tmp_path):
    from autograder.grading import stored_reference
    from autograder.scenes import load_scene
    from mbdkit.sandbox import Sandbox
    from mbdkit.scenes import job_key

    package = copy_reference(tmp_path / "eve")
    body = textwrap.indent(textwrap.dedent(HOOK_OFF) + textwrap.dedent(LEAVE), " " * 4)
    plant(package, textwrap.indent(TEMPLATE.replace("@@CODE@@\n", body), " " * 8))
    scene = load_scene("four_bar")
    said = []
    host = osi.IsolatedHost(tmp_path / "eve", "modules", LIMITS.tmp_size, LIMITS)
    try:
        for _ in range(2):
            with Sandbox(tmp_path / "eve", host=host, isolation="os", limits=LIMITS) as sandbox:
                inputs = stored_reference("four_bar").inputs
                reply = sandbox.run("constraints", job_key(scene), scene.data, inputs, {}, 30)
                messages = [e["message"] for e in reply.element_errors if "ATTACK:" in e["message"]]
                said.append(messages[0].split("ATTACK:")[1].split(" | ", 1)[1])  # after "hook=off"
        assert host.starts == 1  # one sandbox: the zygote cleaned up between the two children
        group = host.cgroup
        if group is not None:  # the sandbox's processes are in the submission's cgroup
            assert host.zygote_pid() in group.pids() and os.getpid() not in group.pids()
    finally:
        host.close()
    if group is not None:
        assert not group.exists() and host.cgroup is None  # removed with the sandbox
    for child in said:  # what the first child left: nothing the second can see
        assert "tmp=[]" in child and "shm=-1:2" in child and "msg=-1:2" in child, said  # ENOENT
        assert "shms=0" in child and "msgs=0" in child and "sems=0" in child, said


@needs_isolation
def test_without_a_cgroup_the_grader_says_so_once_and_grades(tmp_path, monkeypatch, capsys):
    from autograder.grading import stored_reference
    from autograder.scenes import load_scene
    from mbdkit.sandbox import Sandbox
    from mbdkit.scenes import job_key

    monkeypatch.setenv(cgroup.DISABLE_ENV, "1")
    cgroup.layout.cache_clear()
    osi._note_cgroup.cache_clear()
    try:
        osi.require()
        osi.require()
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("mbd: note: the sandboxes get no cgroup (MBD_NO_CGROUP is set)")
        copy_reference(tmp_path / "ann")
        scene = load_scene("four_bar")
        with Sandbox(tmp_path / "ann", isolation="os", limits=LIMITS) as sandbox:
            assert sandbox._own_host.cgroup is None
            reply = sandbox.run("constraints", job_key(scene), scene.data, stored_reference("four_bar").inputs, {}, 30)
        assert reply.ok and not reply.element_errors, reply
    finally:
        monkeypatch.delenv(cgroup.DISABLE_ENV)
        cgroup.layout.cache_clear()
        osi._note_cgroup.cache_clear()
