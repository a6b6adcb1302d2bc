"""The sandbox child: runs a student's package on the grader's requests, under limits.

Two ways in (see ``sandbox``):

- the operating-system backend (the grader): ``python -I -S`` under bubblewrap runs ``main(fd)``, which
  reads its configuration from the inherited socket ``fd``. The process sees none of the course (mount,
  PID, network and user namespaces, an unprivileged uid, a cleared environment: ``isolation``); its
  stdout and stderr are the grader's capture file, its stack dumps go to an inherited descriptor;
- the local backend (a student's ``mbd selfcheck``): forked from a clean forkserver, ``serve``.

In both the process has imported only the standard library, numpy and this package's ``probes`` and
``wire`` (never the reference solution, never reference data): whatever the student's code inspects in
memory holds nothing to copy. Setup, in order:

1. stdout and stderr go to a capture file (the grader counts and truncates it per request);
2. (local) a new user and network namespace when the kernel allows it: no network at all;
3. a clean environment, the submission folder as working directory and first on ``sys.path``, and no
   way to find the reference package (editable-install finders and the repository are removed);
4. resource limits: address space (RLIMIT_AS), CPU time (RLIMIT_CPU), file size (RLIMIT_FSIZE), no
   core dumps, few open files, no POSIX message queues (RLIMIT_MSGQUEUE), (OS backend) few processes
   (RLIMIT_NPROC); the OS backend's cgroup bounds the memory, processes and CPU of the whole sandbox;
5. (OS backend) the seccomp filter of ``seccomp`` (no exec, ptrace, new sockets, namespaces, mounts...):
   from here on no process of the sandbox can get rid of it;
6. an audit hook (PEP 578): no reading of the grader's, the reference's or other students' files, no
   writing outside a private temporary folder, no sockets, subprocesses, signals to other processes or
   ctypes, no importing of the grader or the reference package. In the OS backend this is a friendly
   first layer that turns refusals into clear messages; the operating system is the wall.

Then it serves requests one at a time: run one probe, reply with the outputs or the error. At a
timeout the grader sends SIGUSR1 a few times (faulthandler writes the stack each time, which tells
where the code is stuck) and then kills the process. ``os._exit`` writes where it was called before the
process ends. An audit hook is not a security boundary against a determined attacker (it can be
bypassed from Python or C): without the OS backend, see autograder/README.md.
"""

from __future__ import annotations

import ctypes
import faulthandler
import io
import os
import resource
import signal
import sys
import time
import types

import numpy as np

from . import probes, wire

CLONE_NEWUSER = 0x10000000
CLONE_NEWNET = 0x40000000
MAX_OUTPUT_VALUES = 2_000_000
"""Most numbers a probe may return (16 MB): more is refused as an error of the check."""

DENIED_EVENTS = (
    "socket.",
    "subprocess.",
    "os.exec",
    "os.spawn",
    "os.posix_spawn",
    "os.fork",
    "os.forkpty",
    "os.system",
    "os.kill",
    "os.killpg",
    "signal.pthread_kill",
    "ctypes.",
    "pty.",
    "urllib.",
    "http.",
    "ftplib.",
    "smtplib.",
    "poplib.",
    "imaplib.",
    "nntplib.",
    "telnetlib.",
    "webbrowser.",
    "os.startfile",
)
PATH_EVENTS = {  # event -> positions of its path arguments, all of which must be writable
    "os.remove": (0,),
    "os.rmdir": (0,),
    "os.rename": (0, 1),
    "os.mkdir": (0,),
    "os.symlink": (0, 1),
    "os.link": (0, 1),
    "os.chmod": (0,),
    "os.chown": (0,),
    "os.truncate": (0,),
    "os.utime": (0,),
    "os.chflags": (0,),
    "os.lchflags": (0,),
    "os.lchmod": (0,),
    "os.lchown": (0,),
    "os.mkfifo": (0,),
    "os.mknod": (0,),
    "shutil.rmtree": (0,),
    "shutil.copyfile": (1,),
    "shutil.copymode": (1,),
    "shutil.copystat": (1,),
    "shutil.copytree": (1,),
    "shutil.move": (0, 1),
    "shutil.make_archive": (0,),
    "shutil.chown": (0,),
}
LISTING_EVENTS = ("os.listdir", "os.scandir", "glob.glob", "os.chdir")
BLOCKED_IMPORTS = ("solutions", "autograder", "course", "benchmarks", "tests", "nbgrader")
WRITE_FLAGS = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_APPEND


class Refused(PermissionError):
    """An operation the grader does not allow a submission."""


class HungEarlier(TimeoutError):
    """A function that did not finish in an earlier check of this submission; it is not run again."""


class _HungImports:
    """A meta path finder: modules whose import did not finish in an earlier check are not imported again."""

    def __init__(self, modules: dict[str, str]):
        self.modules = modules

    def find_spec(self, fullname, path=None, target=None):
        where = self.modules.get(fullname)
        if where is not None:
            raise HungEarlier(
                f"importing {fullname} did not finish in an earlier check (stuck at {where}, module level); "
                "not imported again"
            )
        return None

    def invalidate_caches(self) -> None:
        pass


_state: dict = {}
_real_exit = os._exit
"""The real ``os._exit``: the sandbox's own exits do not go through the hook that reports the student's."""


def _under(path: str, roots) -> bool:
    return any(path == root or path.startswith(root.rstrip(os.sep) + os.sep) for root in roots)


def _make_hook(config: dict):
    forbidden = tuple(config["forbidden"])
    allowed = (config["submission"],)
    writable = (config["tmp"],)
    realpath = os.path.realpath
    busy = [False]

    def resolve(path) -> str | None:
        if path is None or isinstance(path, int):
            return None
        try:
            return realpath(os.fsdecode(path))
        except (TypeError, ValueError):
            return None

    def check_read(path) -> None:
        p = resolve(path)
        if p is None:
            return
        for root in forbidden:
            # the submission's own folder may lie inside a forbidden one (the folder of all submissions)
            if _under(p, (root,)) and not (_under(p, allowed) and _under(allowed[0], (root,))):
                raise Refused(f"the grader does not allow a submission to read {p}")

    def check_write(path) -> None:
        p = resolve(path)
        if p is not None and not _under(p, writable):
            raise Refused(f"the grader does not allow a submission to write or change files ({p})")

    def hook(event: str, args: tuple) -> None:
        if busy[0]:
            return
        busy[0] = True
        try:
            if event == "open":
                path, mode, flags = (tuple(args) + (None, None, None))[:3]
                if isinstance(mode, str):
                    writing = any(c in mode for c in "wax+")
                else:
                    writing = isinstance(flags, int) and bool(flags & WRITE_FLAGS)
                if writing:
                    check_write(path)
                check_read(path)
            elif event in PATH_EVENTS:
                for position in PATH_EVENTS[event]:
                    if position < len(args):
                        check_write(args[position])
            elif event in LISTING_EVENTS:
                if args:
                    check_read(args[0])
            elif event == "import":
                name = str(args[0]) if args else ""
                if name.split(".")[0] in BLOCKED_IMPORTS:
                    raise ImportError(f"the grader does not allow a submission to import {name}")
            elif event in ("object.__setattr__", "object.__delattr__"):
                if args and (args[0] is hook or getattr(args[0], "__module__", None) == __name__):
                    raise Refused("the grader's sandbox cannot be changed")
            elif event.startswith(DENIED_EVENTS):
                raise Refused(f"the grader does not allow a submission to use {event} (no network, no processes)")
        finally:
            busy[0] = False

    return hook


def _isolate_network() -> bool:
    """A new user and network namespace: only a loopback device that is down. False if not allowed."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.unshare(CLONE_NEWUSER | CLONE_NEWNET) == 0
    except (OSError, AttributeError):
        return False


def _exit_hook(real_exit, pid: int):
    """``os._exit`` that first writes where it was called (the grader's message names the function)."""

    def _exit(code):
        if os.getpid() == pid and "hang" in _state:
            root = _state["config"]["package_root"]
            frame = sys._getframe(1)
            while frame is not None and not _under(os.path.realpath(frame.f_code.co_filename), (root,)):
                frame = frame.f_back
            where = ("", 0, "") if frame is None else (frame.f_code.co_filename, frame.f_lineno, frame.f_code.co_name)
            try:
                number = int(code)
            except (TypeError, ValueError):
                number = -1
            try:
                line = f"EXIT\t{where[0]}\t{where[1]}\t{where[2]}\t{number}\n"
                os.write(_state["hang"], line.encode("utf-8", "backslashreplace"))
            except OSError:
                pass
        real_exit(code)

    return _exit


def _setup(config: dict) -> dict:
    isolated_os = config.get("backend") == "os"
    sys.stdout.flush()
    sys.stderr.flush()
    devnull = os.open(os.devnull, os.O_RDONLY)
    os.dup2(devnull, 0)
    if isolated_os:
        capture = 1  # the grader's capture file, inherited as stdout and stderr
    else:
        capture = os.open(config["capture"], os.O_RDWR | os.O_CREAT | os.O_APPEND | os.O_TRUNC, 0o600)
        os.dup2(capture, 1)
        os.dup2(capture, 2)
    sys.stdout = io.TextIOWrapper(io.FileIO(1, "w", closefd=False), encoding="utf-8", errors="replace")
    sys.stderr = io.TextIOWrapper(io.FileIO(2, "w", closefd=False), encoding="utf-8", errors="replace")
    sys.stdout.reconfigure(write_through=True)
    sys.stderr.reconfigure(write_through=True)
    if isolated_os:
        hang = int(config["hang_fd"])
    else:
        hang = os.open(config["hang_file"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    faulthandler.enable(file=hang)
    faulthandler.register(signal.SIGUSR1, file=hang, all_threads=False)  # the grader samples where it hangs
    signal.signal(signal.SIGUSR2, _find_stuck)
    if isolated_os:
        isolated = True  # bubblewrap's network namespace
    else:
        isolated = _isolate_network() if config.get("isolate_network", True) else False

    os.environ.clear()
    os.environ.update(
        {
            "HOME": config["tmp"],
            "TMPDIR": config["tmp"],
            "PATH": "/usr/bin:/bin",
            "OPENBLAS_NUM_THREADS": "1",
            "OMP_NUM_THREADS": "1",
            "MKL_NUM_THREADS": "1",
            "MPLBACKEND": "Agg",
        }
    )
    os.chdir(config["submission"])
    hidden = tuple(config["forbidden"]) + tuple(config.get("hide_paths", ()))
    sys.path[:] = [config["submission"]] + [
        p for p in sys.path if p and os.path.isabs(p) and not _under(os.path.realpath(p), hidden)
    ]
    sys.meta_path[:] = [f for f in sys.meta_path if "__editable__" not in getattr(f, "__module__", "")]
    sys.path_hooks[:] = [h for h in sys.path_hooks if "__editable__" not in getattr(h, "__module__", "")]
    sys.path_importer_cache.clear()
    for name in [n for n in sys.modules if n == config["package"] or n.startswith(config["package"] + ".")]:
        del sys.modules[name]
    sys.dont_write_bytecode = True

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    resource.setrlimit(resource.RLIMIT_FSIZE, (config["file_size"], config["file_size"]))
    resource.setrlimit(resource.RLIMIT_CPU, (config["cpu_total"], config["cpu_total"]))
    resource.setrlimit(resource.RLIMIT_AS, (config["memory"], config["memory"]))
    nofile = min(256, resource.getrlimit(resource.RLIMIT_NOFILE)[1])
    resource.setrlimit(resource.RLIMIT_NOFILE, (nofile, nofile))
    if hasattr(resource, "RLIMIT_MSGQUEUE"):  # no POSIX message queue (they outlive the process)
        resource.setrlimit(resource.RLIMIT_MSGQUEUE, (0, 0))

    _state.update(capture=capture, hang=hang, config=config, stubbed=False)
    os._exit = _exit_hook(os._exit, os.getpid())
    if "posix" in sys.modules:
        sys.modules["posix"]._exit = os._exit
    ready = {"network_isolated": isolated, "seccomp": False}
    if isolated_os:
        processes = int(config.get("processes", 32))
        resource.setrlimit(resource.RLIMIT_NPROC, (processes, processes))
        from . import seccomp

        seccomp.install()  # before the audit hook: it refuses ctypes
        ready["seccomp"] = True
    sys.addaudithook(_make_hook(config))
    return ready


def _student_frames(tb, root: str) -> list[str]:
    frames = []
    while tb is not None:
        code = tb.tb_frame.f_code
        path = os.path.realpath(code.co_filename)
        if _under(path, (root,)):
            frames.append(f"{os.path.relpath(path, os.path.dirname(root))}:{tb.tb_lineno} in {code.co_name}")
        tb = tb.tb_next
    return frames


def describe(exc: BaseException) -> dict:
    """Type, message and where in the student's package an exception was raised."""
    root = _state["config"]["package_root"]
    try:
        message = str(exc)
    except Exception:  # a broken __str__ of the student's own exception
        message = "<no message>"
    frames = _student_frames(exc.__traceback__, root)
    if isinstance(exc, SyntaxError) and exc.filename and _under(os.path.realpath(exc.filename), (root,)):
        frames.append(f"{os.path.relpath(os.path.realpath(exc.filename), os.path.dirname(root))}:{exc.lineno}")
    kind = type(exc).__name__
    code = getattr(exc, "errno", None)  # an int for an OSError; a student's own exception may hold anything
    if isinstance(exc, SystemExit):
        message = f"sys.exit({exc.code!r}) was called"
    frames = [frame[:1000] for frame in frames]  # a function's name may be any length: the grader takes 4096
    return {
        "type": kind[:200],
        "message": message[:600],
        "where": frames[-1] if frames else "",
        "trace": frames[-6:],
        "code": code if isinstance(code, int) and not isinstance(code, bool) else None,
    }


def _as_array(value) -> np.ndarray:
    array = probes.real(value)
    if array.size > MAX_OUTPUT_VALUES:
        raise ValueError(f"returned {array.size} numbers; the grader accepts at most {MAX_OUTPUT_VALUES}")
    return array


def _module_name(file: str, package_dir: str) -> str:
    relative = os.path.relpath(file, package_dir)[: -len(".py")].replace(os.sep, ".")
    return relative[: -len(".__init__")] if relative.endswith(".__init__") else relative


def _stub_hung(config: dict) -> None:
    """Replace functions that hung in an earlier check by ones that raise HungEarlier at once; a module
    whose import hung is not imported again (importing it raises HungEarlier)."""
    hung = config.get("hung", [])
    if not hung:
        return
    package_dir = os.path.dirname(config["package_root"])
    at_import = {
        _module_name(h["file"], package_dir): f"{os.path.relpath(h['file'], package_dir)}:{h['line']}"
        for h in hung
        if h["name"] == "<module>"
    }
    if at_import:
        sys.meta_path.insert(0, _HungImports(at_import))
    hung = [h for h in hung if h["name"] != "<module>"]
    for item in hung:
        try:
            __import__(_module_name(item["file"], package_dir))
        except BaseException:  # noqa: BLE001 - the module's own error shows in the checks that use it
            pass
    targets = [(os.path.realpath(h["file"]), h["name"], h["line"]) for h in hung]

    def matches(obj) -> bool:
        code = getattr(getattr(obj, "__func__", obj), "__code__", None)
        if code is None:
            return False
        path = os.path.realpath(code.co_filename)
        lines = {line for _, _, line in code.co_lines() if line is not None}
        return any(path == f and code.co_name == n and line in lines for f, n, line in targets)

    def stub(function):
        def skipped(*args, **kwargs):
            raise HungEarlier(f"{function.__qualname__} did not finish in an earlier check; not run again")

        skipped.__name__ = function.__name__
        skipped.__qualname__ = function.__qualname__
        return skipped

    prefix = config["package"]
    for module in [m for n, m in list(sys.modules.items()) if n == prefix or n.startswith(prefix + ".")]:
        if not isinstance(module, types.ModuleType):
            continue
        for attr, value in list(vars(module).items()):
            if matches(value):
                setattr(module, attr, stub(value))
            elif isinstance(value, type) and value.__module__ == module.__name__:
                for name, member in list(vars(value).items()):
                    if matches(member):
                        setattr(value, name, stub(member))


def _find_stuck(signum, frame) -> None:
    """SIGUSR2 twice: count calls in between, then name the function where the code is stuck.

    The first signal starts counting calls per code object, the second stops and walks the stack from
    the innermost frame out: the first function of the student's package that was not called during
    the window is the one that spins (a loop in F calling G calls G many times and F never).
    """
    counts = _state.get("counting")
    if counts is None:
        counts = _state["counting"] = {}

        def count(f, event, arg):
            if event == "call":
                counts[f.f_code] = counts.get(f.f_code, 0) + 1

        sys.setprofile(count)
        return
    sys.setprofile(None)
    del _state["counting"]
    root = _state["config"]["package_root"]
    while frame is not None:
        path = os.path.realpath(frame.f_code.co_filename)
        if _under(path, (root,)) and not counts.get(frame.f_code):
            line = f"STUCK\t{path}\t{frame.f_lineno}\t{frame.f_code.co_name}\n"
            os.write(_state["hang"], line.encode("utf-8", "backslashreplace"))  # a name of any bytes
            return
        frame = frame.f_back


def _run(request: dict) -> dict:
    config = _state["config"]
    capture = _state["capture"]
    os.ftruncate(capture, 0)
    usage = resource.getrusage(resource.RUSAGE_SELF)
    hard = resource.getrlimit(resource.RLIMIT_CPU)[1]
    soft = int(usage.ru_utime + usage.ru_stime + request["cpu"]) + 1
    resource.setrlimit(resource.RLIMIT_CPU, (min(soft, hard), hard))
    job = probes.Job(request["key"], request["model"], request.get("inputs", {}), request.get("options", {}))
    reply: dict = {"status": "ok", "outputs": {}}
    start = time.perf_counter()
    # backstop only: the grader samples the stack and kills the process at the timeout itself
    faulthandler.dump_traceback_later(2 * request["timeout"] + 5, exit=True, file=_state["hang"])
    try:
        if not _state["stubbed"]:
            _state["stubbed"] = True
            _stub_hung(config)
        raw = probes.PROBES[request["probe"]](probes.Package(config["package"]), job)
        reply["outputs"] = {str(k): _as_array(v) for k, v in raw.items()}
        reply["element_errors"] = [{"element": e, "method": m, **describe(x)} for e, m, x in job.errors]
    except BaseException as exc:  # noqa: BLE001 - every failure of student code is reported, never raised
        reply = {"status": "error", "error": describe(exc), "outputs": {}}
        reply["element_errors"] = [{"element": e, "method": m, **describe(x)} for e, m, x in job.errors]
    finally:
        faulthandler.cancel_dump_traceback_later()
    reply["seconds"] = time.perf_counter() - start
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except BaseException:  # noqa: BLE001 - a full capture file
        pass
    reply["printed"] = os.fstat(capture).st_size
    reply["output_head"] = os.pread(capture, 400, 0).decode("utf-8", "replace")
    os.ftruncate(capture, 0)
    return reply


def main(fd: int, hang_fd: int | None = None) -> None:
    """Entry point under bubblewrap (forked by ``_zygote``): the configuration is the first message on the
    socket ``fd``; ``hang_fd`` is the stack-dump file the zygote passed on."""
    from multiprocessing.connection import Connection

    connection = Connection(fd)
    try:
        config = wire.loads(connection.recv_bytes(wire.MAX_MESSAGE))
    except (EOFError, OSError, wire.WireError):
        _real_exit(3)
    if hang_fd is not None:
        config["hang_fd"] = hang_fd
    serve(connection, config)


def serve(connection, config: dict) -> None:
    """Entry point of the sandbox process: set up, then answer requests until told to stop."""
    try:
        ready = _setup(config)
    except BaseException as exc:  # noqa: BLE001
        connection.send_bytes(wire.dumps({"status": "setup_failed", "message": repr(exc)[:2000]}))
        _real_exit(3)
    connection.send_bytes(wire.dumps({"status": "ready", **ready}))
    while True:
        try:
            request = wire.loads(connection.recv_bytes())
        except (EOFError, OSError):
            _real_exit(0)
        if request.get("op") == "exit":
            _real_exit(0)
        reply = _run(request)
        try:
            message = wire.dumps(reply)
        except BaseException as exc:  # noqa: BLE001 - e.g. out of memory while encoding
            message = wire.dumps({"status": "error", "error": {"type": type(exc).__name__, "message": str(exc)}})
        connection.send_bytes(message)
