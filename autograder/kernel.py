"""nbgrader's kernel inside the grader's sandbox: ipykernel under bubblewrap, with nothing of the course in sight.

While nbgrader autogrades, the notebook's cells (and the ``import modules...`` of its set-up cell) are student
code. ``SandboxedKernelManager`` (the kernel manager of ``autograder.api.SandboxedExecute``) starts the kernel
in the same sandbox as the grader's children (``mbdkit.isolation.Plan``), and the kernel talks to nbgrader over
unix sockets (jupyter_client's ``ipc`` transport) in a folder bound into the sandbox, so the sandbox keeps a
network namespace of its own, with no network at all.

What the kernel sees, all read-only but ``/tmp``:

- the interpreter (``sys.base_prefix``), the system's shared libraries;
- in ``/opt/grader/site-packages``, the allowed distributions of the grader's sandbox (numpy, scipy, PyYAML,
  matplotlib, ...) and ipykernel with what it requires (IPython, pyzmq, jupyter_client, ...);
- the checker ``mbdkit`` alone, at ``/opt/grader/mbdkit`` (its ``check`` prints one line while nbgrader
  autogrades: the points come from the grader, outside the notebook);
- ``/submission``, its working folder: a private copy of the notebook's folder (regular files only, size
  capped, ``mbdkit.isolation.stage_package``), so nothing it writes reaches the submission;
- ``/kernel/connection.json`` and ``/kernel/ipc/`` (its sockets; closed to it once they exist);
- a private tmpfs ``/tmp`` (``HOME``: IPython's and matplotlib's folders), capped;
- no ``/work``, no course root, ``solutions/``, ``autograder/``, gradebook or ``.git``; an environment cleared
  but for ``PATH``, ``HOME``, ``TMPDIR``, the thread variables, ``LANG`` and ``NBGRADER_EXECUTION`` (no secret).

Namespaces: user, PID, network, IPC, UTS, cgroup, a new session; uid and gid 65534 when nbgrader runs as root;
``--die-with-parent``. Limits (``KernelLimits``): address space, CPU time, file size, open files, processes
(RLIMIT_*, set before ipykernel starts, soft = hard), and the kernel's whole life in wall-clock time (then it
is killed; nbgrader records the cells it ran).
"""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import stat
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from jupyter_client.connect import write_connection_file
from jupyter_client.kernelspec import KernelSpec
from jupyter_client.manager import AsyncKernelManager

from mbdkit import isolation as osi

KERNEL_DISTRIBUTIONS = ("ipykernel",)
"""What the kernel's sandbox shows besides the grader's ``ALLOWED_DISTRIBUTIONS`` (with what they require)."""

INNER_KERNEL = "/kernel"
INNER_CONNECTION = f"{INNER_KERNEL}/connection.json"
INNER_IPC = f"{INNER_KERNEL}/ipc"
INNER_IP = f"{INNER_IPC}/kernel"
"""The kernel's connection file and socket prefix inside the sandbox (its sockets: ``/kernel/ipc/kernel-N``)."""

KERNEL_BOOT = (
    "import json, resource, sys\n"
    "for name, value in json.loads(sys.argv[2]).items():\n"
    "    limit = getattr(resource, name)\n"
    "    hard = resource.getrlimit(limit)[1]\n"
    "    value = value if hard == resource.RLIM_INFINITY else min(value, hard)\n"
    "    resource.setrlimit(limit, (value, value))\n"
    "sys.path += sys.argv[1].split(':')\n"
    "from ipykernel.kernelapp import IPKernelApp\n"
    "IPKernelApp.launch_instance(sys.argv[3:])\n"
)
"""What the sandbox runs (``python -I -S -c KERNEL_BOOT PATHS LIMITS -f CONNECTION ...``): the limits, the import
path (the grader's ``mbdkit``, the shown packages, then the submission), then ipykernel."""


@dataclass(frozen=True)
class KernelLimits:
    """Resource limits of nbgrader's kernel (the notebook's cells, which run simulations and plot)."""

    memory: int = 4 * 2**30
    """Address space (RLIMIT_AS), bytes."""
    cpu: int = 1800
    """CPU seconds over the kernel's life (RLIMIT_CPU: the kernel is killed beyond it)."""
    file_size: int = 16 * 2**20
    """Largest file the kernel may write (RLIMIT_FSIZE)."""
    open_files: int = 1024
    """Open file descriptors (RLIMIT_NOFILE)."""
    processes: int = 64
    """Processes and threads at once (RLIMIT_NPROC, in the sandbox's own user namespace)."""
    tmp_size: int = 256 * 2**20
    """Size of the private /tmp."""
    wall: float = 3600.0
    """Seconds of wall-clock time the kernel may live (then it is killed, like a dead kernel)."""
    startup: float = 120.0
    """Seconds the kernel may take to open its sockets."""

    def rlimits(self) -> dict[str, int]:
        return {
            "RLIMIT_AS": self.memory,
            "RLIMIT_CPU": self.cpu,
            "RLIMIT_FSIZE": self.file_size,
            "RLIMIT_NOFILE": self.open_files,
            "RLIMIT_NPROC": self.processes,
            "RLIMIT_CORE": 0,
        }


def _command_start(args: list[str], executable: str) -> int:
    """Where the sandboxed command starts in a bubblewrap command line (``python -I ...`` at its end)."""
    for index in range(len(args) - 2, -1, -1):
        if args[index] == executable and args[index + 1] == "-I":
            return index
    raise osi.IsolationUnavailable("the sandbox's command line has no interpreter: mbdkit.isolation changed?")


def _after_submission(args: list[str]) -> int:
    """The position just after the bind of the staged submission (``... SOURCE /submission``)."""
    for index in range(2, len(args)):
        if args[index] == osi.INNER_SUBMISSION and args[index - 2] in ("--ro-bind", "--bind"):
            return index + 1
    raise osi.IsolationUnavailable("the sandbox's command line binds no submission: mbdkit.isolation changed?")


class KernelPlan(osi.Plan):
    """The grader's sandbox (``mbdkit.isolation.Plan``) with ipykernel in it, its connection file and sockets."""

    def __init__(self, tmp: str, staged: str, limits: KernelLimits, ipc: str, connection: str):
        super().__init__(tmp, staged, limits.tmp_size)
        self.limits, self.ipc, self.connection = limits, ipc, connection
        self.extra_arguments: list[str] = []
        shown = set(osi.site_entries())
        self.kernel_entries = [e for e in osi.distribution_entries(KERNEL_DISTRIBUTIONS) if e not in shown]
        for k, folder in enumerate(sorted({folder for folder, _ in self.kernel_entries} - set(self.sites))):
            self._show(f"kernel{k}", folder)

    def _show(self, name: str, folder: str) -> None:
        """A further folder to bind from (as root: on a reachable mount point, as ``Plan`` does its own)."""
        self.sources[name] = folder
        if self.root:
            point = os.path.join(self.tmp, "mnt", name)
            os.makedirs(point, mode=0o755, exist_ok=True)
            self.mounts.append((folder, point))

    def _site_name(self, folder: str) -> str:
        if folder in self.sites:
            return f"site{self.sites.index(folder)}"
        return next(name for name, source in self.sources.items() if name.startswith("kernel") and source == folder)

    def bwrap_args(self, fd: int) -> list[str]:
        """The grader's sandbox (mounts, namespaces, environment) running ipykernel instead of the zygote."""
        args = super().bwrap_args(fd)
        start = _command_start(args, self.executable)
        head, at = args[:start], _after_submission(args)
        shown = []
        for folder, entry in self.kernel_entries:
            source = os.path.join(self.source(self._site_name(folder)), entry)
            shown += ["--ro-bind", source, f"{osi.INNER_SITE}/{entry}"]
        shown += ["--bind", self.ipc, INNER_IPC, "--ro-bind", self.connection, INNER_CONNECTION]
        head = head[:at] + shown + head[at:]
        head += ["--unsetenv", "MPLBACKEND", "--setenv", "JPY_PARENT_PID", "1"]  # ipykernel's own backend; no banner
        head += ["--setenv", "NBGRADER_EXECUTION", os.environ.get("NBGRADER_EXECUTION", "")]
        paths = ":".join([*osi.INNER_PATH, osi.INNER_SUBMISSION])
        boot = [self.executable, "-I", "-S", "-c", KERNEL_BOOT, paths, json.dumps(self.limits.rlimits())]
        return head + boot + ["-f", INNER_CONNECTION, *self.extra_arguments]


class KernelSandbox:
    """The host's side of one sandboxed kernel: a private copy of the notebook's folder, the kernel's connection
    file and sockets' folder, the bubblewrap command; ``close`` removes them all."""

    def __init__(self, folder: str | Path, limits: KernelLimits):
        folder = Path(folder).resolve()
        self.limits = limits
        self.tmp = tempfile.mkdtemp(prefix="mbd-kernel-")
        try:
            stage = os.path.join(self.tmp, "stage")
            self.skipped = osi.stage_package(folder.parent, folder.name, stage)
            self.ipc = os.path.join(self.tmp, "ipc")
            self.connection = os.path.join(self.tmp, "connection.json")
            os.mkdir(self.ipc, 0o700)
            self.plan = KernelPlan(self.tmp, os.path.join(stage, folder.name), limits, self.ipc, self.connection)
            if self.plan.root:  # the unprivileged kernel creates its sockets here
                os.chown(self.ipc, osi.SANDBOX_UID, osi.SANDBOX_GID)
        except BaseException:
            shutil.rmtree(self.tmp, ignore_errors=True)
            raise
        self.host_ip = os.path.join(self.ipc, "kernel")
        self.sockets: list[str] = []

    def command(self, info: dict, extra_arguments: list[str]) -> list[str]:
        """The command that starts the kernel, given the host's connection info (``ip`` is ``host_ip``)."""
        ports = {key: info[key] for key in ("shell_port", "iopub_port", "stdin_port", "control_port", "hb_port")}
        key = info["key"] if isinstance(info["key"], bytes) else info["key"].encode()
        write_connection_file(
            self.connection,
            ip=INNER_IP,
            key=key,
            transport="ipc",
            signature_scheme=info.get("signature_scheme", "hmac-sha256"),
            kernel_name=info.get("kernel_name", ""),
            **ports,
        )
        if self.plan.root:
            os.chown(self.connection, osi.SANDBOX_UID, osi.SANDBOX_GID)
        self.sockets = [f"{self.host_ip}-{port}" for port in ports.values()]
        self.plan.extra_arguments = list(extra_arguments)
        return self.plan.command(-1)

    async def seal(self, alive) -> None:
        """Wait until the kernel has made its sockets, then close their folder to it (no student code has run
        yet: nbgrader sends the first cell after this). ``alive()`` is False once the kernel has died."""
        deadline = time.monotonic() + self.limits.startup
        while not all(self._is_socket(path) for path in self.sockets):
            if time.monotonic() > deadline:
                raise RuntimeError(f"the sandboxed kernel did not open its sockets within {self.limits.startup:g} s")
            if not await alive():
                return  # nbgrader reports the dead kernel
            await asyncio.sleep(0.02)
        if self.plan.root:
            os.chown(self.ipc, 0, 0)
        os.chmod(self.ipc, 0o755)

    @staticmethod
    def _is_socket(path: str) -> bool:
        try:
            return stat.S_ISSOCK(os.lstat(path).st_mode)
        except OSError:
            return False

    def close(self) -> None:
        shutil.rmtree(self.tmp, ignore_errors=True)


class SandboxedKernelManager(AsyncKernelManager):
    """A kernel manager (jupyter_client's, as nbclient and nbgrader use it) whose kernel is ipykernel in the
    grader's sandbox (``KernelSandbox``): its sockets are unix sockets (``transport="ipc"``), its interrupts are
    messages (a signal would reach bubblewrap, not the kernel), and it lives at most ``limits.wall`` seconds."""

    limits = KernelLimits()

    def __init__(self, **kwargs):
        kwargs["transport"] = "ipc"
        super().__init__(**kwargs)
        self.sandbox: KernelSandbox | None = None
        self._watchdog: threading.Timer | None = None

    @property
    def kernel_spec(self) -> KernelSpec:
        """Python, interrupted by a message (no kernel.json: the command is ``format_kernel_cmd``'s)."""
        return KernelSpec(
            argv=[], display_name="Python 3 (the grader's sandbox)", language="python", interrupt_mode="message"
        )

    async def start_kernel(self, **kw) -> None:
        """Start the kernel in a new sandbox showing a private copy of the folder ``cwd`` (the notebook's)."""
        self._close_sandbox()
        folder = kw.get("cwd") or os.getcwd()
        self.sandbox = KernelSandbox(folder, self.limits)
        self.ip = self.sandbox.host_ip
        kw["cwd"] = self.sandbox.tmp  # where bubblewrap starts; the kernel's own folder is /submission
        kw["env"] = {}  # bubblewrap (and the launcher) get no environment; the sandbox sets its own
        try:
            await super().start_kernel(**kw)
            await self.sandbox.seal(self.is_alive)
        except BaseException:
            self._stop_sandbox()
            self._close_sandbox()
            raise
        self._watchdog = threading.Timer(self.limits.wall, self._stop_sandbox)
        self._watchdog.daemon = True
        self._watchdog.start()

    def format_kernel_cmd(self, extra_arguments: list[str] | None = None) -> list[str]:
        assert self.sandbox is not None, "start_kernel makes the sandbox"
        return self.sandbox.command(self.get_connection_info(), extra_arguments or [])

    async def restart_kernel(self, now: bool = False, newports: bool = False, **kw) -> None:
        raise RuntimeError("a sandboxed kernel is not restarted: nbgrader starts a new one for every notebook")

    async def shutdown_kernel(self, now: bool = False, restart: bool = False) -> None:
        try:
            await super().shutdown_kernel(now=now, restart=restart)
        finally:
            self._stop_sandbox()
            self._close_sandbox()

    async def cleanup_resources(self, restart: bool = False) -> None:
        """After a kernel that died (nbclient cleans up, and shuts nothing down): its sandbox goes too."""
        try:
            await super().cleanup_resources(restart=restart)
        finally:
            self._stop_sandbox()
            self._close_sandbox()

    def _stop_sandbox(self) -> None:
        """Kill the sandbox and everything in it (the watchdog's end of a kernel that lived too long)."""
        process = getattr(self.provisioner, "process", None)
        if process is not None:
            osi.stop_sandbox(process)

    def _close_sandbox(self) -> None:
        if self._watchdog is not None:
            self._watchdog.cancel()
            self._watchdog = None
        if self.sandbox is not None:
            self.sandbox.close()
            self.sandbox = None
