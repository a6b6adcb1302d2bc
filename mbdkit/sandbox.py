"""The grader's side of the sandbox: run a student's package in a child process, one probe at a time.

``Sandbox(submission).run(...)`` sends one request to a child process (see ``_child``) and waits for the
reply at most the request's wall-clock timeout. Whatever goes wrong in the child costs that request only:

- an exception (also ``sys.exit``, ``MemoryError`` at the address-space limit) is an ``error`` reply;
- a timeout: the grader asks the child for its stack a few times (SIGUSR1, faulthandler), kills it,
  and names the function that was stuck; a fresh child runs the next request with that function
  replaced by one that fails at once (a module stuck while it is imported is not imported again), so
  a hang costs one timeout per submission, not one per check;
- CPU limit, ``os._exit`` (with where it was called), a crash: the reply says so, a fresh child runs
  the next request.

Two backends start the child:

- ``isolation="os"`` (the instructor's grader; Linux): a fresh ``python -I`` under bubblewrap that sees
  none of the course, in its own user, PID and network namespaces, as an unprivileged uid, with a seccomp
  filter (``isolation``, ``seccomp``). The audit hook stays as a friendly first layer.
- ``isolation="local"`` (a student's own ``mbd selfcheck`` and notebook ``check()``, on any system):
  children forked from a forkserver that has preloaded numpy, scipy, yaml and the schema validators (and never the
  reference package), so a fresh child costs milliseconds; the audit hook is its only wall.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import json
import multiprocessing
import os
import re
import shutil
import signal
import tempfile
import time
from dataclasses import dataclass, field
from multiprocessing import spawn
from pathlib import Path

import numpy as np

from . import _child, _zygote, wire

PRELOAD = ["mbdkit._child", *(name for name in _zygote.PRELOAD if name != "jsonschema")]
"""Modules the forkserver imports once; children inherit them. Never the reference package. Not ``jsonschema``
(imported where an invalid model file's errors are listed): outside the grader's sandbox it imports the
``rfc3987_syntax`` that Jupyter's dependencies install, which builds a grammar at import, about 2 s of every
forkserver's start (a notebook's first check, each ``mbd selfcheck``); the OS sandbox does not show it."""

SANDBOX_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
STARTUP_TIMEOUT = 120.0
SAMPLES = 3
"""Stack dumps taken from a child that timed out (when it cannot answer itself where it is stuck)."""
STUCK_WINDOW = 0.3
"""Seconds during which a child that timed out counts calls, to tell where it is stuck."""
STUCK_PATIENCE = 2.0
"""Seconds more given to a child that has written nothing of where it is stuck: one starved by the submission's
own busy processes (they share its sandbox's CPU) answers late, and a function whose hang is not located is run
again by the next check (seen once under a full test run's load)."""
FRAME_GRACE = 1.0
"""Seconds a reply that has begun by its deadline may take to arrive whole (the grader waits no longer)."""
CLOSE_TIMEOUT = 2.0
"""Seconds the grader waits for a child to take its last message."""
MAX_LINE = 8192
"""Longest line of a stack dump the grader reads (the child writes it: any longer one is ignored)."""
MALFORMED = "the sandbox child sent a malformed reply"


@dataclass
class Limits:
    """Resource limits of a sandbox process."""

    memory: int = 3 * 2**30
    """Address space (RLIMIT_AS), bytes: an allocation beyond it raises MemoryError in the child."""
    file_size: int = 16 * 2**20
    """Largest file the child may write (RLIMIT_FSIZE), which bounds the capture of its output."""
    output: int = 256 * 2**10
    """Output (stdout + stderr) one request may print before its checks fail."""
    cpu_total: int = 3600
    """CPU seconds one child process may use over all its requests (hard RLIMIT_CPU)."""
    timeout_scale: float = 1.0
    """Multiplies every wall-clock timeout (for a slow machine)."""
    isolate_network: bool = True
    """Run the child in a new network namespace when the kernel allows it (the local backend)."""
    processes: int = 32
    """Processes and threads the child may have at once (RLIMIT_NPROC, in its own user namespace; the
    operating-system backend)."""
    tmp_size: int = 64 * 2**20
    """Size of the child's private /tmp (the operating-system backend)."""
    sandbox_memory: int = 0
    """Memory of all the processes of a submission's sandbox and its /tmp together (its cgroup, the
    operating-system backend); 0: ``memory + tmp_size``."""
    cpus: float = 1.0
    """CPU cores a submission's sandbox may use at once (its cgroup, the operating-system backend)."""


@dataclass
class Reply:
    """What a probe in the sandbox gave: outputs, or how it failed."""

    status: str
    """ok | error (the child's reply) | timeout | cpu | died | malformed | sandbox (the grader's finding)"""
    outputs: dict = field(default_factory=dict)
    error: dict | None = None
    element_errors: list = field(default_factory=list)
    printed: int = 0
    output_head: str = ""
    seconds: float = 0.0
    stuck_in: str = ""
    """For a timeout: 'modules/file.py:line in function', where the code was stuck."""

    @property
    def ok(self) -> bool:
        return self.status == "ok"


class Replies:
    """Replies kept by request, for a caller that runs the same checks again on an unchanged package (a
    student's notebook: each graded cell, then ``selfcheck``): a request met again is answered from here,
    without a child or the student's code. Kept: what the student's code answered (ok or an error) in a child
    where nothing hung; a timeout or a crash runs again. The caller keeps one store per package content
    (``mbdkit.api``); the grader keeps none."""

    def __init__(self) -> None:
        self._replies: dict[str, Reply] = {}
        self.sandbox: Sandbox | None = None
        """The child that answered them (a student's public checks, local backend), kept for the next call."""

    def close(self) -> None:
        """Stop the kept child (the package changed, or the process ends)."""
        if self.sandbox is not None:
            self.sandbox.close()
            self.sandbox = None

    @staticmethod
    def key(probe: str, key: str, model: dict, inputs: dict, options: dict) -> str:
        digest = hashlib.sha256(json.dumps([probe, key, model, options], sort_keys=True, default=repr).encode())
        for name in sorted(inputs):
            value = np.ascontiguousarray(inputs[name])
            digest.update(f"|{name}|{value.dtype}|{value.shape}|".encode() + value.tobytes())
        return digest.hexdigest()

    def get(self, request: str) -> Reply | None:
        reply = self._replies.get(request)
        return None if reply is None else copy.deepcopy(reply)

    def keep(self, request: str, reply: Reply) -> None:
        if reply.status in ("ok", "error"):
            self._replies[request] = copy.deepcopy(reply)


class SandboxError(RuntimeError):
    """The sandbox itself could not run (not the student's fault)."""


ISOLATIONS = ("local", "os")


class _LocalProcess:
    """The local backend's child: forked from a multiprocessing forkserver."""

    def __init__(self):
        self.process = None

    def start(self, config: dict, dumps) -> object:
        context = _context()
        ours, theirs = context.Pipe(duplex=True)
        self.process = context.Process(target=_child.serve, args=(theirs, config), daemon=True)
        with without_main():
            self.process.start()
        theirs.close()
        return ours

    @property
    def pid(self) -> int | None:
        return None if self.process is None else self.process.pid

    def is_alive(self) -> bool:
        return self.process is not None and self.process._popen is not None and self.process.is_alive()

    def kill(self) -> int | None:
        if self.process is None or self.process._popen is None:
            self.process = None
            return None
        if self.process.is_alive():
            self.process.kill()
        self.process.join(10)
        code = self.process.exitcode
        self.process = None
        return code


def _context():
    for key, value in SANDBOX_ENV.items():
        os.environ.setdefault(key, value)
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(PRELOAD)
    return context


@contextlib.contextmanager
def without_main():
    """Start multiprocessing children (spawn, forkserver) without re-running the main module in them.

    multiprocessing imports ``__main__`` (the ``mbd`` script, pytest, a script without the
    ``if __name__ == "__main__"`` guard) in every child it starts; that module may import the
    reference package, which must never be in a sandbox's memory, and may not be safe to re-run.
    """
    original = spawn.get_preparation_data

    def without(name):
        data = original(name)
        data.pop("init_main_from_path", None)
        data.pop("init_main_from_name", None)
        return data

    spawn.get_preparation_data = without
    try:
        yield
    finally:
        spawn.get_preparation_data = original


# The stack-dump file is written by the child (faulthandler, ``_child``), so by the student's code too:
# a line is read only when it has the exact form, ASCII digits of a bounded length, an absolute path and a
# name of printable characters; anything else in the file is ignored.
_FRAME = re.compile(r'^\s*File "(?P<file>/[^"\x00]{0,4095})", line (?P<line>[0-9]{1,9}) in (?P<name>\S{1,1000})$', re.A)
_STUCK = re.compile(r"^STUCK\t(?P<file>/[^\t\x00]{0,4095})\t(?P<line>[0-9]{1,9})\t(?P<name>[^\t]{1,1000})$", re.A)
_EXIT = re.compile(
    r"^EXIT\t(?P<file>(?:/[^\t\x00]{0,4095})?)\t(?P<line>[0-9]{1,9})\t(?P<name>[^\t]{0,1000})\t(?P<code>-?[0-9]{1,9})$",
    re.A,
)


def _lines(text: str) -> list[str]:
    """The lines of a stack dump that may be read (bounded length, printable)."""
    return [line for line in text.split("\n") if len(line) <= MAX_LINE and line.replace("\t", " ").isprintable()]


def _stuck_line(text: str) -> tuple[str, int, str] | None:
    """The child's own answer to where it is stuck (see ``_child._find_stuck``), if it gave one."""
    for line in _lines(text):
        match = _STUCK.match(line)
        if match:
            return match["file"], int(match["line"]), match["name"]
    return None


def stack_samples(text: str) -> list[list[tuple[str, int, str]]]:
    """The stacks in a faulthandler dump, each as [(file, line, function)] from the outermost call in."""
    samples, current = [], None
    for line in _lines(text):
        if "most recent call first" in line:
            current = []
            samples.append(current)
            continue
        match = _FRAME.match(line)
        if match and current is not None:
            current.append((match["file"], int(match["line"]), match["name"]))
    return [list(reversed(s)) for s in samples if s]


def _exit_line(text: str) -> tuple[str, int, str, int] | None:
    """Where the child called os._exit (see ``_child._exit``): (file, line, function, code), if it did."""
    for line in _lines(text):
        match = _EXIT.match(line)
        if match:
            return match["file"], int(match["line"]), match["name"], int(match["code"])
    return None


def stuck_function(
    samples: list[list[tuple[str, int, str]]], root: str, resolve=os.path.realpath
) -> tuple[str, int, str] | None:
    """The deepest function of the student's package present in every sample: where a loop spins.

    (A loop in F that calls G shows F in every sample and G in some; F is the one to blame.) ``resolve``
    turns a path of the dump into one comparable with ``root`` (the operating-system backend's paths are
    the child's own, not the grader's: normalized only).
    """
    stacks = [[frame for frame in s if resolve(frame[0]).startswith(root + os.sep)] for s in samples]
    stacks = [s for s in stacks if s]
    if not stacks:
        return None
    common = None
    for depth in range(min(len(s) for s in stacks)):
        frames = {(resolve(s[depth][0]), s[depth][2]) for s in stacks}
        if len(frames) != 1:
            break
        common = depth
    if common is None:
        return None
    file, line, name = stacks[0][common]
    return resolve(file), line, name


class Sandbox:
    """A student's package, run in a child process under ``limits``; one request at a time.

    Parameters
    ----------
    submission : folder holding the student's package (``modules/``)
    forbidden : folders the child may not read (the grader, the reference, other submissions, outputs);
        under ``isolation="os"`` they are not there at all, and the audit hook names them in its refusals
    hide : folders removed from the child's import path (the local backend)
    isolation : ``"local"`` (forkserver; a student's own checks) or ``"os"`` (bubblewrap; the grader):
        the os backend stages a private copy of the package at construction (``skipped`` lists what it
        left out) and raises ``IsolationUnavailable`` when bwrap is missing
    host : for ``"os"``, an ``isolation.IsolatedHost`` of this submission that several sandboxes use one
        after the other (one bubblewrap start per submission); by default the sandbox makes its own
    replies : a ``Replies`` store of earlier requests on the same package, answered from it (a student's
        notebook); None runs every request
    """

    def __init__(
        self,
        submission: Path,
        package: str = "modules",
        forbidden: tuple[Path, ...] = (),
        hide: tuple[Path, ...] = (),
        limits: Limits | None = None,
        isolation: str = "local",
        host=None,
        replies: Replies | None = None,
    ):
        if isolation not in ISOLATIONS:
            raise ValueError(f"isolation must be one of {ISOLATIONS}, not {isolation!r}")
        self.submission = os.path.realpath(submission)
        self.package = package
        self.limits = limits or Limits()
        self.forbidden = [os.path.realpath(p) for p in forbidden]
        self.hide = [os.path.realpath(p) for p in hide]
        self.isolation = isolation
        self.tmp = tempfile.mkdtemp(prefix="mbd-sandbox-")
        self.hung: list[dict] = []
        self.replies = replies
        self.process = None
        self.connection = None
        self.network_isolated = None
        self.starts = 0
        self.request: dict = {}
        self.skipped: list[str] = []
        """Files of the package the operating-system backend did not copy (symlinks, special, too big)."""
        self._own_host = None
        if isolation == "os":
            from . import isolation as osi

            if host is None:
                try:
                    host = self._own_host = osi.IsolatedHost(
                        self.submission, package, self.limits.tmp_size, self.limits
                    )
                except BaseException:
                    shutil.rmtree(self.tmp, ignore_errors=True)
                    raise
            self.skipped = host.skipped
            self.inner_submission = osi.INNER_SUBMISSION
            self._backend = osi.IsolatedProcess(host, self.tmp)
        else:
            self.inner_submission = self.submission
            self._backend = _LocalProcess()
        self.inner_root = os.path.join(self.inner_submission, package)
        """The package's folder as the child sees it (paths in its stack dumps and replies)."""

    # -- life cycle -------------------------------------------------------------------------------
    def _config(self) -> dict:
        common = {
            "backend": self.isolation,
            "package": self.package,
            "forbidden": self.forbidden,
            "memory": int(self.limits.memory),
            "file_size": int(self.limits.file_size),
            "cpu_total": int(self.limits.cpu_total),
            "hung": list(self.hung),
        }
        if self.isolation == "os":
            from . import isolation as osi

            return {
                **common,
                "submission": osi.INNER_SUBMISSION,
                "package_root": self.inner_root,
                "tmp": osi.INNER_TMP,
                "hide_paths": [],
                "processes": int(self.limits.processes),
            }
        work = os.path.join(self.tmp, "work")
        os.makedirs(work, exist_ok=True)
        return {
            **common,
            "submission": self.submission,
            "package_root": self.inner_root,
            "tmp": work,
            "capture": os.path.join(self.tmp, "output.txt"),
            "hang_file": os.path.join(self.tmp, "stack.txt"),
            "hide_paths": self.hide,
            "isolate_network": self.limits.isolate_network,
        }

    def start(self) -> None:
        """Start the child now (``run`` starts it when needed); SandboxError when it cannot start."""
        if self.process is None or not self.process.is_alive():
            self._start()

    def _start(self) -> None:
        self.process = self._backend
        self.connection = self.process.start(self._config(), wire.dumps)
        self.starts += 1
        try:
            ready = wire.ready(wire.receive(self.connection.fileno(), time.monotonic() + STARTUP_TIMEOUT))
        except wire.FrameTimeout:
            self._kill()
            raise SandboxError("the sandbox process did not start") from None
        except (EOFError, OSError, wire.WireError) as err:
            self._kill()
            said = self._read("output.txt").strip()[-400:]
            raise SandboxError(f"the sandbox process failed to start: {said or err}") from None
        if ready.get("status") != "ready":
            self._kill()
            raise SandboxError(f"the sandbox process failed to start: {ready.get('message')}")
        self.network_isolated = ready.get("network_isolated")

    def _kill(self, wait: float = 0.0) -> int | None:
        """Stop the child (after ``wait`` seconds for it to end by itself); its exit code (< 0: a signal)."""
        code = None
        if self.process is not None:
            deadline = time.monotonic() + wait
            while self.process.is_alive() and time.monotonic() < deadline:
                time.sleep(0.005)
            code = self.process.kill()
        if self.connection is not None:
            self.connection.close()
        self.process = self.connection = None
        return code

    def close(self) -> None:
        """Stop the child and remove its temporary folder."""
        if self.process is not None and self.process.is_alive():
            try:
                wire.send(self.connection.fileno(), wire.dumps({"op": "exit"}), time.monotonic() + CLOSE_TIMEOUT)
                self._kill(wait=2.0)
            except (OSError, wire.FrameTimeout):
                pass
        self._kill()
        if self._own_host is not None:
            self._own_host.close()
        shutil.rmtree(self.tmp, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- one request --------------------------------------------------------------------------------
    def _read(self, name: str) -> str:
        try:
            with open(os.path.join(self.tmp, name), "rb") as f:
                return f.read(2**20).decode("utf-8", "replace")
        except OSError:
            return ""

    def run(self, probe: str, key: str, model: dict, inputs: dict, options: dict, timeout: float) -> Reply:
        """Run ``probe`` on the scene in the child (or answer from ``replies``, a request met before); the reply
        says how it went, it never raises for the student's code (only SandboxError when the sandbox itself
        cannot run)."""
        if self.replies is None:
            return self._request(probe, key, model, inputs, options, timeout)
        request = Replies.key(probe, key, model, inputs, options)
        reply = self.replies.get(request)
        if reply is None:
            reply = self._request(probe, key, model, inputs, options, timeout)
            if not self.hung:
                self.replies.keep(request, reply)
        return reply

    def _request(self, probe: str, key: str, model: dict, inputs: dict, options: dict, timeout: float) -> Reply:
        timeout = float(timeout) * self.limits.timeout_scale
        if self.process is None or not self.process.is_alive():
            self._start()
        self.request = {"probe": probe, "key": key}
        request = {
            "op": "probe",
            "probe": probe,
            "key": key,
            "model": model,
            "inputs": inputs,
            "options": options,
            "timeout": timeout,
            "cpu": 2.0 * timeout + 1.0,
        }
        start, deadline = time.perf_counter(), time.monotonic() + timeout
        fd = self.connection.fileno()
        try:  # the request sent and the whole reply read by the deadline (a child that stalls: a timeout)
            try:
                wire.send(fd, wire.dumps(request), deadline)
            except wire.FrameTimeout:  # it does not take the request: stuck since the last one
                return self._timed_out(timeout, time.perf_counter() - start)
            message = wire.reply(wire.receive(fd, deadline, FRAME_GRACE))
        except wire.FrameTimeout as late:
            return self._timed_out(timeout, time.perf_counter() - start, partial=late.partial)
        except (EOFError, OSError):
            return self._died(time.perf_counter() - start)
        except wire.WireError as err:  # the child (the student's code can write to its socket) is not trusted
            self._kill()
            error = {"type": "malformed", "message": f"{MALFORMED} ({err})", "during": self._during()}
            return Reply("malformed", error=error, seconds=time.perf_counter() - start)
        return Reply(
            status=message["status"],
            outputs=message.get("outputs", {}),
            error=message.get("error"),
            element_errors=message.get("element_errors", []),
            printed=message.get("printed", 0),
            output_head=message.get("output_head", "")[:400],
            seconds=float(message.get("seconds", 0.0)),
        )

    def _where(self, file: str, line: int, name: str) -> str:
        """'modules/file.py:line in function' (or 'at import') for a place in the child's package."""
        relative = os.path.relpath(file, self.inner_submission) if file else "?"
        return f"{relative}:{line} at import (module level)" if name == "<module>" else f"{relative}:{line} in {name}"

    def _resolve(self, path: str) -> str:
        return os.path.realpath(path) if self.isolation == "local" else os.path.normpath(path)

    def _timed_out(self, timeout: float, seconds: float, partial: bool = False) -> Reply:
        """Sample where the child is stuck, kill it; ``partial``: it had begun a reply it did not finish."""
        pid = self.process.pid if self.process is not None else None
        signals = [(signal.SIGUSR2, STUCK_WINDOW), (signal.SIGUSR2, 0.1)] + [(signal.SIGUSR1, 0.05)] * SAMPLES
        for number, pause in signals:
            try:
                os.kill(pid, number)
            except (OSError, TypeError):
                break
            time.sleep(pause)
        deadline = time.monotonic() + STUCK_PATIENCE  # nothing written yet: a starved child, not a silent one
        while not self._read("stack.txt").strip() and pid is not None and time.monotonic() < deadline:
            time.sleep(0.1)
        self._kill()
        stuck = self._stuck()
        where = ""
        if stuck is not None:
            file, line, name = stuck
            self.hung.append({"file": file, "line": line, "name": name})
            where = self._where(file, line, name)
        error = {"type": "timeout", "message": "it began a reply and did not finish it"} if partial else None
        return Reply("timeout", error=error, seconds=seconds, stuck_in=where, printed=self._captured())

    def _stuck(self) -> tuple[str, int, str] | None:
        """Where the child is stuck, from its stack-dump file: its own answer, or its stack samples."""
        text = self._read("stack.txt")
        return _stuck_line(text) or stuck_function(stack_samples(text), self.inner_root, self._resolve)

    def _captured(self) -> int:
        try:
            return os.path.getsize(os.path.join(self.tmp, "output.txt"))
        except OSError:
            return 0

    def _during(self) -> str:
        probe, key = self.request.get("probe"), self.request.get("key")
        return f"{probe} on {str(key).split('#')[0]}" if probe and key else ""

    def _died(self, seconds: float) -> Reply:
        printed = self._captured()
        code = self._kill(wait=2.0)
        stack = self._read("stack.txt")
        exited = _exit_line(stack)
        samples = stack_samples(stack)
        root = self.inner_root
        frames = [f for s in samples[-1:] for f in s if self._resolve(f[0]).startswith(root + os.sep)]
        where = self._where(*frames[-1]) if frames else ""
        if code is not None and code < 0 and -code == signal.SIGXCPU:
            status, message = "cpu", "used up its CPU time (an endless loop?)"
        elif exited is not None:
            file, line, name, number = exited
            where = self._where(file, line, name) if file else ""
            status, message = "died", f"the process ended with exit code {number}: os._exit({number}) was called"
        elif code is not None and code < 0:
            name = signal.Signals(-code).name if -code in signal.Signals._value2member_map_ else str(-code)
            status, message = "died", f"the process was killed by signal {name}"
            fatal = [line for line in _lines(stack) if line.startswith("Fatal Python error")]
            if fatal:
                message = fatal[0].strip()[:200]
        else:
            status, message = "died", f"the process ended with exit code {code} (os._exit or a crash)"
        error = {"type": status, "message": message, "where": where, "during": self._during()}
        return Reply(status, error=error, seconds=seconds, printed=printed)
