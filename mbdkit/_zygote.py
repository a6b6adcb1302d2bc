"""The zygote of a grading sandbox: inside bubblewrap, it imports numpy and scipy once and forks the children.

One bubblewrap sandbox serves one submission (``isolation.IsolatedHost``): its public checks and, after
those, its hidden and per-student checks, each set in a child of its own, and a fresh child after a
timeout or a crash. Starting the sandbox and importing numpy and scipy is most of a child's start-up, so
this process does both once and forks a child per request of the grader:

- ``fork`` (with three file descriptors: the child's socket to the grader, its capture file for stdout and
  stderr, its stack-dump file): fork; the child serves the grader (``_child.main``); reply its pid;
- ``reap`` (a pid the grader has killed or seen exit): wait for it, kill every other process in the
  sandbox (``kill(-1)``) and reap them (the zygote is their subreaper), so that nothing the child left
  running meets the next child; then empty ``/tmp`` (the only writable folder) and remove every SysV
  shared memory segment, message queue and semaphore set of the sandbox's IPC namespace (POSIX message
  queues cannot be made: RLIMIT_MSGQUEUE is 0; ``/dev/shm`` is read-only), so that no file or IPC object
  of the child meets the next either; reply its wait status and whether that cleaning succeeded (when it
  did not, e.g. a tree too large to remove, the grader starts a new sandbox for the next child).

The zygote runs no student code and holds no grading data (a scene reaches only the child that runs it).
It is not dumpable, so a child (same uid) cannot read or write its memory through ``/proc``; a child that
kills it costs its own submission a new sandbox, nothing else (the grader starts one). Standard library,
numpy and scipy only; the grader's messages are JSON.
"""

from __future__ import annotations

import ctypes
import importlib
import json
import os
import signal
import socket
import sys

PRELOAD = (
    "numpy",
    "scipy.linalg",
    "scipy.integrate",
    "scipy.optimize",
    "scipy.sparse",
    "yaml",
    "fastjsonschema",
    "jsonschema",  # validates a model in milliseconds once imported (``solutions.io.model.schema_errors``)
)
"""What the children inherit already imported (what a solver package imports; never the reference)."""
INTEGRATION = ("scipy.integrate", "scipy.optimize", "scipy.sparse")
"""What only the children that integrate need (0.4 s of a sandbox's 1.1 s of imports): left out of the
preload of a sandbox whose checks are all kinematic (``preload`` "kinematic"); a child that needs one (a
singular position's search imports scipy.optimize) imports it itself."""
LEVELS = {"all": PRELOAD, "kinematic": tuple(m for m in PRELOAD if m not in INTEGRATION), "bare": ()}
"""The zygote's imports by the ``preload`` the grader asks for; "bare" for the probe of ``isolation.problem``,
which asks only whether a sandbox starts and forks a child."""

PR_SET_DUMPABLE = 4
PR_SET_CHILD_SUBREAPER = 36
TMP = "/tmp"
"""The sandbox's only writable folder (``isolation.INNER_TMP``), emptied between two children."""
MAX_REMOVED = 200_000
"""Entries of /tmp the zygote removes at most; beyond, the grader starts a new sandbox instead."""
IPC_RMID = 0
SYSV = {"shm": "shmctl", "msg": "msgctl", "sem": "semctl"}
"""/proc/sysvipc/<kind> lists the namespace's objects of a kind; libc's <call>(id, IPC_RMID, 0) removes one."""


def _send(control: socket.socket, message: dict) -> None:
    control.sendall(json.dumps(message).encode() + b"\n")


def _fork(control: socket.socket, fds: list[int]) -> None:
    child_socket, capture, hang = fds
    pid = os.fork()
    if pid == 0:
        try:
            control.close()
            ctypes.CDLL(None).prctl(PR_SET_DUMPABLE, 1, 0, 0, 0)  # its own /proc as before; the zygote's stays closed
            os.setsid()
            os.dup2(capture, 1)
            os.dup2(capture, 2)
            os.close(capture)
            from mbdkit import _child

            _child.main(child_socket, hang_fd=hang)
        finally:
            os._exit(3)
    for fd in fds:
        os.close(fd)
    _send(control, {"pid": pid})


def _reap(control: socket.socket, pid: int) -> None:
    try:
        _, status = os.waitpid(pid, 0)
    except ChildProcessError:
        status = None
    try:
        os.kill(-1, signal.SIGKILL)  # all but this process and the sandbox's init: what the child left
    except ProcessLookupError:
        pass
    while True:  # orphans come to this process (a subreaper): reap them all, so none is left
        try:
            os.waitpid(-1, 0)
        except ChildProcessError:
            break
    clean = _empty(TMP) and _remove_ipc()
    _send(control, {"status": status, "clean": clean})


def _empty(folder: str) -> bool:
    """Remove everything in ``folder`` (nothing runs that could add to it). Iterative and relative to open
    folders, so no depth or path length stops it; folders a child made unreadable are opened up first.
    True when ``folder`` is empty at the end."""
    try:
        os.chmod(folder, 0o755)  # a child may have closed it
        stack = [(os.open(folder, os.O_RDONLY | os.O_DIRECTORY), "")]
    except OSError:
        return False
    removed = 0
    try:
        while stack and removed < MAX_REMOVED:
            fd = stack[-1][0]
            below = None
            with os.scandir(fd) as entries:
                for entry in entries:
                    removed += 1
                    if entry.is_dir(follow_symlinks=False):
                        below = entry.name
                        break
                    os.unlink(entry.name, dir_fd=fd)
            if below is not None:
                os.chmod(below, 0o700, dir_fd=fd)  # a folder (not a link): nothing else runs to swap it
                flags = os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW
                stack.append((os.open(below, flags, dir_fd=fd), below))
                continue
            done, name = stack.pop()
            os.close(done)
            if stack:  # an emptied folder below ``folder``
                os.rmdir(name, dir_fd=stack[-1][0])
    except OSError:
        pass
    finally:
        for fd, _ in stack:
            os.close(fd)
    try:
        return not os.listdir(folder)
    except OSError:
        return False


def _remove_ipc() -> bool:
    """Remove every SysV IPC object of this namespace; True when none is left."""
    libc = ctypes.CDLL(None)
    left = False
    for kind, call in SYSV.items():
        try:
            with open(f"/proc/sysvipc/{kind}") as f:
                ids = [int(line.split()[1]) for line in f.readlines()[1:] if line.strip()]
        except (OSError, ValueError, IndexError):
            continue  # no SysV IPC in this kernel: nothing to remove
        for ipc_id in ids:
            if kind == "sem":
                libc.semctl(ipc_id, 0, IPC_RMID, 0)
            else:
                getattr(libc, call)(ipc_id, IPC_RMID, None)
        with open(f"/proc/sysvipc/{kind}") as f:
            left = left or len(f.readlines()) > 1
    return not left


def main(fd: int, preload: str = "all") -> None:
    """Serve the grader on the inherited socket ``fd`` until it closes it; ``preload``: import the modules of
    that level first (``LEVELS``)."""
    control = socket.socket(fileno=fd)
    for name in LEVELS.get(preload, PRELOAD):
        try:
            importlib.import_module(name)
        except ImportError:
            pass
    importlib.import_module("mbdkit._child")
    libc = ctypes.CDLL(None)
    libc.prctl(PR_SET_DUMPABLE, 0, 0, 0, 0)
    libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)
    _send(control, {"status": "ready"})
    buffer = b""
    while True:
        try:
            data, fds, _, _ = socket.recv_fds(control, 4096, 3)
        except OSError:
            break
        if not data:
            break
        buffer += data
        while b"\n" in buffer:
            line, buffer = buffer.split(b"\n", 1)
            request = json.loads(line)
            if request.get("op") == "fork" and len(fds) == 3:
                _fork(control, fds)
                fds = []
            elif request.get("op") == "reap":
                _reap(control, int(request["pid"]))
        for fd in fds:
            os.close(fd)
    sys.stdout.flush()
    os._exit(0)
