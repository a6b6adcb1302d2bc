"""The operating system's wall around a student's code: the grader's sandbox process, under bubblewrap.

The instructor's grader (``mbd grade``, ``autograder.grading.grade``, nbgrader's autograde path) runs a
student's package in a child process that the course does not exist for (DESIGN section 9):

- **mounts** (a new mount namespace; bubblewrap's root is an empty tmpfs, remounted read-only with ``/dev``
  once all is mounted), all read-only but ``/tmp``: the interpreter (``sys.base_prefix``, at its own path,
  its site-packages shown empty: ``installed_packages``), the system's shared libraries (``/usr/lib``,
  ``/usr/lib64``, ``/lib``, ``/lib64``, ``/etc/ld.so.cache``), the allowed site-packages one entry each
  (``ALLOWED_DISTRIBUTIONS`` and what they require, in ``/opt/grader/site-packages``), the checker
  ``mbdkit`` alone (``/opt/grader/mbdkit``; never ``autograder/``, ``solutions/``, the course or its
  ``.git``), a private copy of the student's ``modules/`` staged by the grader (``/submission/modules``:
  regular files only, no symlink followed, size-capped, so a child sees no other student's files), a new
  ``/proc`` and a minimal ``/dev``, and a private size-capped tmpfs ``/tmp`` (``HOME`` and ``TMPDIR``);
- **namespaces**: user, PID (every process the student starts dies with the sandbox; it sees and signals
  only its own), network (no interface but a downed loopback), IPC (as root made and capped by
  ``_launch``: ``ipc_limits``), UTS, cgroup; no further user namespaces; a new session; bubblewrap kills
  the sandbox when the grader dies (``--die-with-parent``);
- **a cgroup** per submission (``cgroup``; as root): memory of all its processes and its tmpfs, tasks, CPU
  share and cores, joined by ``_launch`` before bubblewrap starts;
- **uid**: when the grader runs as root (CI, a grading server), bubblewrap itself runs as uid and gid
  65534 with no supplementary group (``_launch.py`` drops them), so student code is unprivileged on the
  host too; otherwise bubblewrap's user namespace maps the invoking user;
- **environment**: cleared (``--clearenv``): PATH, HOME, TMPDIR and the thread variables only, no secret,
  also not in ``/proc/self/environ``;
- in the child (``_child``): rlimits (address space, CPU, file size, no core, open files, processes), a
  seccomp filter (``seccomp.DENIED``: no exec, ptrace, process_vm_*, new sockets, namespaces, mounts,
  keyring, io_uring, bpf...) installed after its own imports and before any student code, and the audit
  hook as a friendly first layer (clear messages), never as the wall.

The sandbox's first process is a zygote (``_zygote``) that imports numpy and scipy once and forks the
children: one sandbox per submission (``IsolatedHost``), a child for its public checks and, after that
child is dead and everything it started is killed, one for its hidden checks.

The grader talks to the child over an inherited socket (``multiprocessing.connection.Connection``
framing, ``wire``'s JSON messages, never pickle); the child's stdout and stderr go to a capture file and
its stack dumps to a second one, both opened by the grader and passed on as file descriptors: no host
folder is writable from inside. A child's pid as the grader sees it is found below the zygote (bubblewrap's
reaper's only child) by its pid inside the sandbox (``NSpid``), so the grader can sample a hung child's
stack and kill it.

Requires Linux with user namespaces and ``bwrap`` (Debian/Ubuntu: ``apt-get install bubblewrap``).
"""

from __future__ import annotations

import functools
import importlib.metadata
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
from multiprocessing.connection import Connection
from pathlib import Path

from . import cgroup, staging

BWRAP_ENV = "MBD_BWRAP"
"""Path of bwrap to use (default: ``bwrap`` on PATH); tests point it at a missing file."""
UNSAFE_ENV = "MBD_UNSAFE_NO_ISOLATION"
"""Set to 1 to grade without the operating system's isolation (``mbd grade --unsafe-no-isolation``)."""

SANDBOX_UID = SANDBOX_GID = 65534
"""The unprivileged uid and gid (``nobody``) bubblewrap runs as when the grader is root."""

INNER_SUBMISSION = "/submission"
INNER_GRADER = "/opt/grader"
INNER_SITE = "/opt/grader/site-packages"
INNER_TMP = "/tmp"
INNER_PATH = [INNER_GRADER, INNER_SITE]
"""Added to the child's sys.path (after the standard library): mbdkit's parent and the allowed packages."""

ALLOWED_DISTRIBUTIONS = ("numpy", "scipy", "PyYAML", "fastjsonschema", "jsonschema", "matplotlib")
"""What a student's package may import besides the standard library (with what these require, no extras)."""

MAX_SUBMISSION_BYTES = 32 * 2**20
MAX_FILE_BYTES = 8 * 2**20
MAX_FILES = 2000
"""Caps of the staged copy of a student's package: files beyond them are not copied."""

LIBRARIES = ("/usr/lib", "/usr/lib64", "/lib", "/lib64", "/usr/lib32", "/lib32")
CHILD_ENV = {
    "PATH": "/usr/bin:/bin",
    "HOME": INNER_TMP,
    "TMPDIR": INNER_TMP,
    "OPENBLAS_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "MPLBACKEND": "Agg",
    "LANG": "C.UTF-8",
}
BOOT = (
    "import sys; sys.path += sys.argv[1].split(':'); import mbdkit._zygote as z; z.main(int(sys.argv[2]), sys.argv[3])"
)
"""What the sandbox runs (``python -I -S -c BOOT PATHS FD PRELOAD``): mbdkit from its read-only mount, then the
zygote (``_zygote``), which imports the modules of PRELOAD (``_zygote.LEVELS``) and forks the children that
serve the grader (``_child``)."""
ZYGOTE_TIMEOUT = 30.0
"""Seconds the zygote may take to answer a fork or a reap (it answers in milliseconds)."""

MBDKIT = Path(__file__).resolve().parent
LAUNCHER = MBDKIT / "_launch.py"


NOT_INSTALLED = "bubblewrap (bwrap) is not installed: the grader runs student code in it (apt-get install bubblewrap)"


class IsolationUnavailable(RuntimeError):
    """The operating system's isolation cannot run here (no bwrap, or the kernel refuses namespaces)."""


def unsafe_requested() -> bool:
    """True when ``MBD_UNSAFE_NO_ISOLATION`` asks to grade without the operating system's isolation."""
    return os.environ.get(UNSAFE_ENV, "").strip().lower() not in ("", "0", "no", "false")


def bwrap_path() -> str | None:
    """The bwrap executable, or None."""
    configured = os.environ.get(BWRAP_ENV)
    if configured:
        return configured if os.path.isfile(configured) and os.access(configured, os.X_OK) else None
    return shutil.which("bwrap")


@functools.lru_cache(maxsize=4)
def _bwrap_options(bwrap: str) -> frozenset[str]:
    try:
        text = subprocess.run([bwrap, "--help"], capture_output=True, text=True, timeout=10).stdout
    except (OSError, subprocess.SubprocessError):
        return frozenset()
    return frozenset(re.findall(r"^\s+(--[a-z0-9-]+)", text, re.M))


# -- what the sandbox shows -------------------------------------------------------------------------------------
def _key(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


@functools.lru_cache(maxsize=1)
def site_entries() -> tuple[tuple[str, str], ...]:
    """(site-packages folder, entry) of each allowed distribution and what it requires (no extras)."""
    return distribution_entries(ALLOWED_DISTRIBUTIONS)


@functools.lru_cache(maxsize=4)
def distribution_entries(names: tuple[str, ...]) -> tuple[tuple[str, str], ...]:
    """(site-packages folder, entry) of each of the distributions ``names`` and what they require (no extras):
    what a sandbox shows of them (``site_entries``; nbgrader's kernel adds ipykernel, ``autograder.kernel``)."""
    seen: dict[str, object] = {}
    todo = list(names)
    while todo:
        name = todo.pop()
        if _key(name) in seen:
            continue
        try:
            dist = importlib.metadata.distribution(name)
        except importlib.metadata.PackageNotFoundError:
            seen[_key(name)] = None
            continue
        seen[_key(name)] = dist
        for requirement in dist.requires or []:
            spec, _, marker = requirement.partition(";")
            if "extra" in marker:
                continue
            match = re.match(r"[A-Za-z0-9][A-Za-z0-9._-]*", spec.strip())
            if match:
                todo.append(match.group(0))
    entries = set()
    for dist in seen.values():
        if dist is None:
            continue
        folder = str(Path(dist.locate_file("")).resolve())
        for file in dist.files or []:
            top = file.parts[0] if file.parts else ""
            if top and top not in ("..", "__pycache__") and os.path.lexists(os.path.join(folder, top)):
                entries.add((folder, top))
    return tuple(sorted(entries))


def interpreter() -> tuple[str, str]:
    """(the interpreter's installation folder, its executable), as real paths."""
    prefix = os.path.realpath(sys.base_prefix)
    executable = os.path.realpath(getattr(sys, "_base_executable", None) or sys.executable)
    return prefix, executable


def _under(path: str, root: str) -> bool:
    return path == root or path.startswith(root.rstrip("/") + "/")


SITE_PATTERNS = ("lib*/python3*/*-packages", "local/lib*/python3*/*-packages", "python3*/*-packages")
"""Where packages are installed below a folder the sandbox shows: ``prefix/lib/python3.X/site-packages``,
Debian's ``/usr/lib/python3/dist-packages``, ``/usr/local/lib/python3.X/dist-packages``..."""


def installed_packages(roots: list[str]) -> list[str]:
    """The site-packages and dist-packages folders inside ``roots`` (and the interpreter's own, from
    ``sysconfig``): the sandbox shows each as an empty folder, so only the standard library and the
    allowed packages (``site_entries``, mounted one by one elsewhere) can be imported."""
    import sysconfig

    prefix = interpreter()[0]
    found = {sysconfig.get_path(name, vars={"base": prefix, "platbase": prefix}) for name in ("purelib", "platlib")}
    for root in roots:
        for pattern in SITE_PATTERNS:
            found.update(str(p) for p in Path(root).glob(pattern))
    return sorted(
        path
        for path in found
        if path and os.path.isdir(path) and not os.path.islink(path) and any(_under(path, r) for r in roots)
    )


def ipc_limits(tmp_size: int) -> dict[str, str]:
    """The sysctls of a sandbox's IPC namespace (the root helper writes them): SysV shared memory within
    the size of its /tmp, few and small message queues and semaphore sets, no POSIX message queue."""
    page = os.sysconf("SC_PAGE_SIZE")
    wanted = {
        "kernel/shmmax": str(int(tmp_size)),
        "kernel/shmall": str(max(1, int(tmp_size) // page)),
        "kernel/shmmni": "32",
        "kernel/msgmni": "16",
        "kernel/msgmnb": "65536",
        "kernel/msgmax": "8192",
        "kernel/sem": "32 256 32 16",
        "fs/mqueue/queues_max": "0",
    }
    return {name: value for name, value in wanted.items() if os.path.exists(f"/proc/sys/{name}")}


def stage_package(folder: str | Path, package: str, destination: str | Path) -> list[str]:
    """Copy ``folder/package`` into ``destination/package`` (``staging``): regular files with one name only
    (no symlink followed, no hard link, device, FIFO), no ``__pycache__``, at most ``MAX_FILES`` files of
    ``MAX_FILE_BYTES`` each and ``MAX_SUBMISSION_BYTES`` in all (Python files first), each opened without
    following a link; ``package`` itself a link: nothing. Returns what was left out, relative paths."""
    found = staging.stage(folder, package, destination, (MAX_FILES, MAX_FILE_BYTES, MAX_SUBMISSION_BYTES))
    return sorted(found.skipped) if found.refused is None else ["."]


class Plan:
    """The bubblewrap command for one sandbox, and (as root) the private mounts made before it."""

    def __init__(self, tmp: str, staged: str, tmp_size: int, cgroup: list[str] | None = None, preload: str = "all"):
        self.bwrap = bwrap_path()
        self.preload = preload
        """What the zygote imports before it answers: "all", "kinematic" or "bare" (``_zygote.LEVELS``)."""
        if self.bwrap is None:
            raise IsolationUnavailable(NOT_INSTALLED)
        self.tmp, self.staged, self.tmp_size = tmp, staged, tmp_size
        self.cgroup = list(cgroup or [])
        """The ``cgroup.procs`` files the root helper writes its pid to (the sandbox's cgroup)."""
        self.root = os.geteuid() == 0
        self.prefix, self.executable = interpreter()
        sources = {"python": self.prefix, "mbdkit": str(MBDKIT)}
        if not _under(self.executable, self.prefix):
            sources["executable"] = os.path.dirname(self.executable)
        self.sites = sorted({folder for folder, _ in site_entries()})
        for k, folder in enumerate(self.sites):
            sources[f"site{k}"] = folder
        self.sources = sources
        self.mounts: list[tuple[str, str]] = []
        if self.root:  # reachable mount points for folders the unprivileged uid may not reach
            os.chmod(tmp, 0o711)
            base = os.path.join(tmp, "mnt")
            os.makedirs(base, mode=0o755, exist_ok=True)
            for name, source in sources.items():
                point = os.path.join(base, name)
                if os.path.isdir(source):
                    os.makedirs(point, mode=0o755, exist_ok=True)
                self.mounts.append((source, point))

    def source(self, name: str) -> str:
        """Where bubblewrap finds a shown folder: its own path, or (as root) its private mount point."""
        return os.path.join(self.tmp, "mnt", name) if self.root else self.sources[name]

    def shown_roots(self) -> list[str]:
        """The host folders shown whole inside the sandbox (at their own paths)."""
        roots = [self.prefix]
        if "executable" in self.sources:
            roots.append(os.path.dirname(self.executable))
        for path in LIBRARIES:
            if not _under(path, self.prefix) and os.path.isdir(path) and not os.path.islink(path):
                roots.append(path)
        return roots

    def bwrap_args(self, fd: int) -> list[str]:
        options = _bwrap_options(self.bwrap)
        args = [self.bwrap, "--unshare-user", "--unshare-pid", "--unshare-net", "--unshare-uts"]
        if not self.root:  # as root, the helper has made the IPC namespace, with caps (``ipc_limits``)
            args.append("--unshare-ipc")
        args += ["--unshare-cgroup-try", "--die-with-parent", "--new-session", "--clearenv"]
        if "--disable-userns" in options:
            args.append("--disable-userns")
        for key, value in CHILD_ENV.items():
            args += ["--setenv", key, value]
        args += ["--ro-bind", self.source("python"), self.prefix]
        if "executable" in self.sources:
            args += ["--ro-bind", self.source("executable"), os.path.dirname(self.executable)]
        for path in LIBRARIES:
            if _under(path, self.prefix) or not os.path.lexists(path):
                continue
            if os.path.islink(path):
                args += ["--symlink", os.readlink(path), path]
            elif os.path.isdir(path):
                args += ["--ro-bind", path, path]
        empty = os.path.join(self.tmp, "empty")
        os.makedirs(empty, mode=0o755, exist_ok=True)
        for folder in installed_packages(self.shown_roots()):
            args += ["--ro-bind", empty, folder]  # the standard library only, not what is installed beside it
        if os.path.isfile("/etc/ld.so.cache"):
            args += ["--ro-bind", "/etc/ld.so.cache", "/etc/ld.so.cache"]
        for folder, entry in site_entries():
            name = f"site{self.sites.index(folder)}"
            args += ["--ro-bind", os.path.join(self.source(name), entry), f"{INNER_SITE}/{entry}"]
        args += ["--ro-bind", self.source("mbdkit"), f"{INNER_GRADER}/mbdkit"]
        args += ["--ro-bind", self.staged, INNER_SUBMISSION]
        args += ["--proc", "/proc", "--dev", "/dev"]
        if "--size" in options:
            args += ["--size", str(int(self.tmp_size))]
        args += ["--tmpfs", INNER_TMP]
        args += ["--remount-ro", "/", "--remount-ro", "/dev"]  # bubblewrap's root and /dev (/dev/shm) tmpfs
        args += ["--chdir", INNER_SUBMISSION]
        return [*args, self.executable, "-I", "-S", "-c", BOOT, ":".join(INNER_PATH), str(fd), self.preload]

    def command(self, fd: int) -> list[str]:
        """The command the grader starts: bubblewrap itself, or (as root) the launcher that drops to 65534."""
        args = self.bwrap_args(fd)
        if not self.root:
            return args
        spec = {"mounts": self.mounts, "uid": SANDBOX_UID, "gid": SANDBOX_GID, "parent": os.getpid(), "argv": args}
        spec.update(cgroup=self.cgroup, ipc=ipc_limits(self.tmp_size))
        return [self.executable, "-I", "-S", str(LAUNCHER), json.dumps(spec)]


def _children(pid: int) -> list[int]:
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as f:
            return [int(p) for p in f.read().split()]
    except (OSError, ValueError):
        pass
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
                if int(fields[1]) == pid:
                    found.append(int(entry))
            except (OSError, IndexError, ValueError):
                continue
    return found


def stop_sandbox(process: subprocess.Popen) -> None:
    """Kill a bubblewrap sandbox started as ``process`` and everything in it: its PID namespace dies with its
    reaper (bubblewrap's child), then bubblewrap itself. Safe to call from another thread; ``process`` is left
    for its owner to reap."""
    if process.poll() is not None:
        return
    for reaper in _children(process.pid):
        try:
            os.kill(reaper, signal.SIGKILL)
        except OSError:
            pass
    try:
        process.kill()
    except OSError:
        pass


def _nspid(pid: int) -> int | None:
    """A process's pid in its own (innermost) PID namespace."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("NSpid:"):
                    return int(line.split()[-1])
    except (OSError, ValueError, IndexError):
        pass
    return None


def _running(pid: int | None) -> bool:
    """True while ``pid`` exists and is not a zombie."""
    if pid is None:
        return False
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
    except (OSError, IndexError):
        return False


class IsolatedHost:
    """One bubblewrap sandbox for one submission, its zygote (``_zygote``) forking the children.

    The submission's package is staged once (``stage_package``; ``skipped`` lists what was left out). The
    public checks' child and, after it has been killed, the hidden checks' child (and a fresh child after a
    timeout or crash) are forked in it: one sandbox start and one import of numpy and scipy per
    submission. Between two children everything the first left running is killed (``_zygote``).
    """

    def __init__(self, folder: str | Path, package: str, tmp_size: int, limits=None, preload: str = "all"):
        self.tmp = tempfile.mkdtemp(prefix="mbd-sandbox-host-")
        staged = os.path.join(self.tmp, "submission")
        self.cgroup = None
        self._sizes = (limits, tmp_size)
        try:
            self.skipped = stage_package(folder, package, staged)
            self.cgroup = make_cgroup(limits, tmp_size)
            self.plan = Plan(self.tmp, staged, tmp_size, self.cgroup.procs if self.cgroup else None, preload)
        except BaseException:
            self._remove_cgroup()
            shutil.rmtree(self.tmp, ignore_errors=True)
            raise
        self.popen: subprocess.Popen | None = None
        self.control: socket.socket | None = None
        self._reader = None
        self._zygote: int | None = None
        self.starts = 0

    # -- the zygote ------------------------------------------------------------------------------------------
    def _receive(self, timeout: float) -> dict:
        self.control.settimeout(timeout)
        line = self._reader.readline()
        if not line:
            raise EOFError("the sandbox closed its connection")
        return json.loads(line)

    def _start(self) -> None:
        from .sandbox import STARTUP_TIMEOUT, SandboxError

        self._stop()
        if self.cgroup is not None and not self.cgroup.exists():  # removed while empty: a new one
            self._remove_cgroup()
            self.cgroup = make_cgroup(*self._sizes)
            self.plan.cgroup = self.cgroup.procs if self.cgroup else []
        ours, theirs = socket.socketpair()
        log = os.open(os.path.join(self.tmp, "zygote.txt"), os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        fd = theirs.fileno()
        try:
            self.popen = subprocess.Popen(
                self.plan.command(fd),
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=log,
                pass_fds=(fd,),
                env={},
                close_fds=True,
            )
        finally:
            theirs.close()
            os.close(log)
        self.starts += 1
        self.control, self._reader = ours, ours.makefile("rb")
        try:
            ready = self._receive(STARTUP_TIMEOUT)
        except (OSError, ValueError, EOFError) as err:
            self._stop()
            with open(os.path.join(self.tmp, "zygote.txt"), errors="replace") as f:
                said = f.read()[-400:].strip()
            raise SandboxError(f"the sandbox process failed to start: {said or err}") from None
        if ready.get("status") != "ready":
            self._stop()
            raise SandboxError(f"the sandbox process failed to start: {ready}")

    def _stop(self) -> None:
        """Kill the sandbox (every process in it: the PID namespace dies with its reaper)."""
        if self.control is not None:
            self._reader.close()
            self.control.close()
        self.control = self._reader = self._zygote = None
        if self.popen is None:
            return
        if self.popen.poll() is None:
            for reaper in _children(self.popen.pid):
                try:
                    os.kill(reaper, signal.SIGKILL)
                except OSError:
                    pass
            try:
                self.popen.wait(5)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait()
        self.popen = None

    def _alive(self) -> bool:
        return self.popen is not None and self.popen.poll() is None and self.control is not None

    def zygote_pid(self) -> int | None:
        """The zygote's pid as the grader sees it (bubblewrap's reaper's only child)."""
        if self._zygote is None and self.popen is not None:
            for reaper in _children(self.popen.pid):
                below = _children(reaper)
                if below:
                    self._zygote = below[0]
        return self._zygote

    # -- its children ----------------------------------------------------------------------------------------
    def spawn(self, fds: list[int]) -> int:
        """Fork a child that gets ``fds`` (its socket, capture file, stack-dump file); its pid inside. A
        sandbox that is gone (a child may kill its zygote) is started again."""
        from .sandbox import SandboxError

        for _ in range(2):
            if not self._alive():
                self._start()
            try:
                socket.send_fds(self.control, [b'{"op": "fork"}\n'], fds)
                return int(self._receive(ZYGOTE_TIMEOUT)["pid"])
            except (OSError, ValueError, KeyError, TypeError, EOFError):
                self._stop()
        raise SandboxError("the sandbox could not start a process")

    def host_pid(self, inner: int) -> int | None:
        """The grader's pid of the child that is ``inner`` inside the sandbox."""
        zygote = self.zygote_pid()
        if zygote is None:
            return None
        for pid in _children(zygote):
            if _nspid(pid) == inner:
                return pid
        return None

    def reap(self, inner: int) -> int | None:
        """Wait for the child ``inner`` (killed or ended) and kill what it left running; its exit code as
        Popen gives it (< 0: the signal), None when unknown."""
        if not self._alive():
            return None
        try:
            self.control.sendall(json.dumps({"op": "reap", "pid": inner}).encode() + b"\n")
            reply = self._receive(ZYGOTE_TIMEOUT)
            status = reply.get("status")
        except (OSError, ValueError, EOFError, AttributeError):
            self._stop()
            return None
        if reply.get("clean") is not True:  # files or IPC objects the zygote could not remove: a new sandbox
            self._stop()
        return None if not isinstance(status, int) else os.waitstatus_to_exitcode(status)

    def memory_peak(self) -> int | None:
        """The most memory this submission's sandboxes held at once (bytes; None without a cgroup)."""
        return self.cgroup.peak() if self.cgroup is not None else None

    def _remove_cgroup(self) -> None:
        if self.cgroup is not None:
            self.cgroup.remove()
            self.cgroup = None

    def close(self) -> None:
        self._stop()
        self._remove_cgroup()
        shutil.rmtree(self.tmp, ignore_errors=True)


class IsolatedProcess:
    """One child of a sandbox (``IsolatedHost``): what the grader's ``Sandbox`` needs of it."""

    def __init__(self, host: IsolatedHost, tmp: str):
        self.host, self.tmp = host, tmp
        self.inner: int | None = None
        self._pid: int | None = None

    def start(self, config: dict, dumps) -> Connection:
        """Fork the child; send it ``config`` (encoded with ``dumps``); return the connection to it."""
        ours, theirs = socket.socketpair()
        flags = os.O_RDWR | os.O_CREAT | os.O_TRUNC | os.O_APPEND
        capture = os.open(os.path.join(self.tmp, "output.txt"), flags, 0o600)
        hang = os.open(os.path.join(self.tmp, "stack.txt"), os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        try:
            self.inner = self.host.spawn([theirs.fileno(), capture, hang])
        finally:
            theirs.close()
            os.close(capture)
            os.close(hang)
        self._pid = None
        connection = Connection(ours.detach())
        connection.send_bytes(dumps(config))
        return connection

    @property
    def pid(self) -> int | None:
        """The child's pid as the grader sees it."""
        if self._pid is None and self.inner is not None:
            self._pid = self.host.host_pid(self.inner)
        return self._pid

    def is_alive(self) -> bool:
        return _running(self.pid)

    def kill(self) -> int | None:
        """Stop the child (and what it started); its exit code: < 0 a signal, as Popen's."""
        if self.inner is None:
            return None
        if self.is_alive():
            try:
                os.kill(self.pid, signal.SIGKILL)
            except OSError:
                pass
        code = self.host.reap(self.inner)
        self.inner = self._pid = None
        return code


@functools.lru_cache(maxsize=1)
def _probe() -> str | None:
    """Start a sandbox on an empty package as grading starts one (bubblewrap, namespaces, mounts, cgroup, the
    zygote) and fork its child, without the zygote's imports of numpy and scipy (the probe's child needs them
    not: about a second less before every grading)."""
    from .sandbox import Limits, Sandbox, SandboxError

    with tempfile.TemporaryDirectory(prefix="mbd-probe-") as folder:
        package = Path(folder) / "probe_package"
        package.mkdir()
        (package / "__init__.py").write_text("")
        host = None
        try:
            limits = Limits()
            host = IsolatedHost(Path(folder), "probe_package", limits.tmp_size, limits, preload="bare")
            with Sandbox(Path(folder), "probe_package", limits=limits, isolation="os", host=host) as sandbox:
                sandbox.start()
        except (SandboxError, IsolationUnavailable, OSError) as err:
            return " ".join(str(err).split())  # one line
        finally:
            if host is not None:
                host.close()
    return None


def problem() -> str | None:
    """Why the operating system's isolation cannot run here, or None when it can (checked once)."""
    if not sys.platform.startswith("linux"):
        return f"the grader's sandbox needs Linux (user namespaces, seccomp), not {sys.platform}"
    if bwrap_path() is None:
        return NOT_INSTALLED
    return _probe()


def require() -> None:
    """Raise IsolationUnavailable with the reason when the operating system's isolation cannot run; say
    once (stderr) when the sandboxes get no cgroup."""
    reason = problem()
    if reason is not None:
        raise IsolationUnavailable(reason)
    _note_cgroup()


@functools.lru_cache(maxsize=1)
def _note_cgroup() -> None:
    reason = cgroup.problem()
    if reason is not None:
        print(
            f"mbd: note: the sandboxes get no cgroup ({reason}): each keeps its rlimits, but the memory,"
            " processes and CPU of all its processes are not bounded together",
            file=sys.stderr,
        )


def make_cgroup(limits, tmp_size: int) -> cgroup.Cgroup | None:
    """A cgroup for one submission's sandbox, sized from ``limits`` (``sandbox.Limits``; default limits
    when None), or None when none can be made here (``cgroup.problem``)."""
    from .sandbox import Limits

    limits = limits or Limits(tmp_size=tmp_size)
    memory = limits.sandbox_memory or limits.memory + tmp_size
    if isinstance(cgroup.layout(), str):
        return None
    try:
        return cgroup.Cgroup.create(memory, limits.processes + cgroup.EXTRA_PROCESSES, limits.cpus)
    except OSError:
        return None
