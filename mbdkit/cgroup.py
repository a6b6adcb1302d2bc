"""A control group per grading sandbox: memory, processes and CPU bounded for all its processes together.

The rlimits of a sandbox's child are per process (RLIMIT_AS) or per user (RLIMIT_NPROC), and they do not
count the pages of a tmpfs: three forks each just below RLIMIT_AS hold three times it, and a sandbox with
many busy processes takes the CPU from the classmates graded beside it. A cgroup bounds all of it at once:

- **memory**: every process of the sandbox and the pages of its tmpfs and SysV shared memory
  (``Limits.memory + Limits.tmp_size`` unless ``Limits.sandbox_memory``), no swap beyond it; beyond it
  the kernel kills a process of that sandbox only;
- **processes**: ``Limits.processes`` and the few of the sandbox itself (bubblewrap, the zygote);
- **CPU**: the same share for every sandbox however many processes it runs, and at most ``Limits.cpus``
  cores, so a sandbox's busy processes slow only that sandbox.

cgroup v2 (``memory.max``, ``memory.swap.max``, ``pids.max``, ``cpu.weight``, ``cpu.max``) where a
cgroup2 hierarchy has these controllers, else cgroup v1 (``memory.limit_in_bytes``,
``memory.memsw.limit_in_bytes``, ``pids.max``, ``cpu.shares``, ``cpu.cfs_quota_us``). v1 groups are made
below the grader's own group of each controller (so the grader's own limits still hold), v2 groups below
``mbd-sandboxes`` at the hierarchy's root (v2 allows no processes in a group that has controlled groups
below it). The root helper ``_launch`` puts itself in the group before it drops privileges and starts
bubblewrap, so every process of the sandbox is in it from the start; the grader's processes stay outside.

Making a cgroup needs root (or a delegated v2 hierarchy) and the controllers; where none can be made
(``problem()`` says why; ``MBD_NO_CGROUP=1`` asks for none) the sandbox keeps its rlimits only.
"""

from __future__ import annotations

import functools
import itertools
import os
import signal
import time

DISABLE_ENV = "MBD_NO_CGROUP"
"""Set to 1 to start sandboxes without a cgroup (their rlimits only)."""
PREFIX = "mbd-sandbox-"
V2_PARENT = "mbd-sandboxes"
CONTROLLERS = ("memory", "pids", "cpu")
EXTRA_PROCESSES = 6
"""Processes of a sandbox besides the student's: the launcher-turned-bubblewrap, bubblewrap's reaper, the zygote."""

STALE = 600.0
"""Seconds after which an empty group of a dead grader is removed by the next grader."""

_counter = itertools.count()


def _mounts() -> list[tuple[str, str, str, set[str]]]:
    """(mount point, root inside the hierarchy, type, options) of every cgroup mount of this process."""
    found = []
    with open("/proc/self/mountinfo") as f:
        for line in f:
            left, _, right = line.partition(" - ")
            fields, tail = left.split(), right.split()
            if len(tail) >= 3 and tail[0] in ("cgroup", "cgroup2"):
                found.append((fields[4], fields[3], tail[0], set(tail[2].split(","))))
    return found


def _own_groups() -> dict[str, str]:
    """This process's group in each hierarchy: {controller or '' (v2): path}."""
    groups = {}
    with open("/proc/self/cgroup") as f:
        for line in f:
            _, names, path = line.rstrip("\n").split(":", 2)
            for name in names.split(",") if names else [""]:
                groups[name] = path
    return groups


def _inside(point: str, root: str, path: str) -> str:
    """The folder of the group ``path`` in a hierarchy mounted at ``point`` whose root is ``root``."""
    relative = path[len(root) :] if root != "/" and path.startswith(root) else path
    return os.path.join(point, relative.lstrip("/"))


def _write(path: str, value: str) -> None:
    with open(path, "w") as f:
        f.write(value)


def _read(path: str) -> str:
    with open(path) as f:
        return f.read()


def _v2_parent() -> str | None:
    """The v2 folder below which sandbox groups are made (controllers enabled for them), or None."""
    for point, _root, kind, _ in _mounts():
        if kind != "cgroup2":
            continue
        try:
            available = set(_read(os.path.join(point, "cgroup.controllers")).split())
        except OSError:
            continue
        if not set(CONTROLLERS) <= available:
            continue
        parent = os.path.join(point, V2_PARENT)
        enable = " ".join(f"+{c}" for c in CONTROLLERS)
        try:
            _write(os.path.join(point, "cgroup.subtree_control"), enable)
            os.makedirs(parent, exist_ok=True)
            _write(os.path.join(parent, "cgroup.subtree_control"), enable)
        except OSError:
            continue
        return parent
    return None


def _v1_parents() -> dict[str, str]:
    """{controller: folder of this process's group} of the v1 hierarchies that hold a wanted controller."""
    own = _own_groups()
    parents = {}
    for point, root, kind, options in _mounts():
        for controller in CONTROLLERS:
            if kind == "cgroup" and controller in options and controller in own:
                parents[controller] = _inside(point, root, own[controller])
    return parents


@functools.lru_cache(maxsize=1)
def layout() -> tuple[str, dict[str, str]] | str:
    """('v2', {'': parent}) or ('v1', {controller: parent}) where sandbox groups are made; or, when none
    can be made here, why (one line)."""
    if os.environ.get(DISABLE_ENV, "").strip().lower() not in ("", "0", "no", "false"):
        return f"{DISABLE_ENV} is set"
    if not os.path.isfile("/proc/self/cgroup"):
        return "this system has no cgroups"
    if os.geteuid() != 0:
        return "the grader is not root (a sandbox's cgroup is made by its root helper)"
    try:
        parent = _v2_parent()
        if parent is not None:
            return "v2", {"": parent}
        parents = _v1_parents()
    except OSError as err:
        return f"the cgroup hierarchies cannot be read ({err})"
    if "memory" not in parents:
        return "no cgroup hierarchy with the memory controller is mounted"
    return "v1", parents


def problem() -> str | None:
    """Why no cgroup can be made here, or None when it can (checked once per process, by making one)."""
    found = layout()
    if isinstance(found, str):
        return found
    try:
        group = Cgroup.create(2**30, 8, 1.0)
    except OSError as err:
        return f"a cgroup cannot be made ({err.strerror or err})"
    group.remove()
    return None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _sweep(parent: str) -> None:
    """Remove the empty groups left by graders that died (SIGKILL) before removing them: those of a pid
    that is gone, made more than ``STALE`` seconds ago (a grader in another PID namespace may be alive)."""
    try:
        names = os.listdir(parent)
    except OSError:
        return
    for name in names:
        owner = name[len(PREFIX) :].split("-")[0]
        if not (name.startswith(PREFIX) and owner.isdigit()) or _alive(int(owner)):
            continue
        folder = os.path.join(parent, name)
        try:
            if time.time() - os.stat(folder).st_mtime > STALE:
                os.rmdir(folder)  # only an empty group can be removed
        except OSError:
            pass


class Cgroup:
    """One sandbox's group (v1: one folder per controller; v2: one folder)."""

    def __init__(self, version: str, folders: dict[str, str]):
        self.version, self.folders = version, folders

    @classmethod
    def create(cls, memory: int, processes: int, cpus: float) -> Cgroup:
        """A new group bounding ``memory`` bytes (processes, tmpfs, shm; no swap), ``processes`` tasks and
        ``cpus`` cores at an equal share; OSError when it cannot be made."""
        found = layout()
        if isinstance(found, str):
            raise OSError(found)
        version, parents = found
        name = f"{PREFIX}{os.getpid()}-{next(_counter)}"
        group = cls(version, {})
        try:
            for controller, parent in parents.items():
                _sweep(parent)
                folder = os.path.join(parent, name)
                os.mkdir(folder, 0o755)
                group.folders[controller] = folder
            group._limit(int(memory), int(processes), float(cpus))
        except OSError:
            group.remove()
            raise
        return group

    def _file(self, controller: str, name: str) -> str:
        return os.path.join(self.folders["" if self.version == "v2" else controller], name)

    def _limit(self, memory: int, processes: int, cpus: float) -> None:
        period = 100_000
        quota = max(1000, int(cpus * period))
        if self.version == "v2":
            _write(self._file("memory", "memory.max"), str(memory))
            if os.path.exists(self._file("memory", "memory.swap.max")):
                _write(self._file("memory", "memory.swap.max"), "0")
            _write(self._file("pids", "pids.max"), str(processes))
            _write(self._file("cpu", "cpu.weight"), "100")
            _write(self._file("cpu", "cpu.max"), f"{quota} {period}")
            return
        _write(self._file("memory", "memory.limit_in_bytes"), str(memory))
        if os.path.exists(self._file("memory", "memory.memsw.limit_in_bytes")):
            _write(self._file("memory", "memory.memsw.limit_in_bytes"), str(memory))
        if "pids" in self.folders:
            _write(self._file("pids", "pids.max"), str(processes))
        if "cpu" in self.folders:
            _write(self._file("cpu", "cpu.shares"), "1024")
            _write(self._file("cpu", "cpu.cfs_period_us"), str(period))
            _write(self._file("cpu", "cpu.cfs_quota_us"), str(quota))

    def exists(self) -> bool:
        """True while every folder of the group is there (another grader may have removed an empty one)."""
        return bool(self.folders) and all(os.path.isdir(folder) for folder in self.folders.values())

    @property
    def procs(self) -> list[str]:
        """The ``cgroup.procs`` files a process writes its pid to, to join the group."""
        return [os.path.join(folder, "cgroup.procs") for folder in self.folders.values()]

    def peak(self) -> int | None:
        """The most memory the group has held (bytes), where the kernel tells."""
        names = ("memory.peak",) if self.version == "v2" else ("memory.max_usage_in_bytes",)
        for name in names:
            try:
                return int(_read(self._file("memory", name)))
            except (OSError, ValueError, KeyError):
                continue
        return None

    def pids(self) -> list[int]:
        """The processes in the group now."""
        found: set[int] = set()
        for path in self.procs:
            try:
                found.update(int(p) for p in _read(path).split())
            except (OSError, ValueError):
                continue
        return sorted(found)

    def remove(self, wait: float = 5.0) -> None:
        """Kill what is still in the group and remove it."""
        deadline = time.monotonic() + wait
        for folder in list(self.folders.values()):
            while True:
                for pid in self.pids():
                    try:
                        os.kill(pid, signal.SIGKILL)
                    except OSError:
                        pass
                try:
                    os.rmdir(folder)
                    break
                except FileNotFoundError:
                    break
                except OSError:
                    if time.monotonic() > deadline:
                        break
                    time.sleep(0.02)
        self.folders = {}
