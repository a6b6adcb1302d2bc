"""Root helper of the grading sandbox: private mounts, then an unprivileged uid, then bubblewrap.

Run by the grader, as root only, as ``python -I -S _launch.py SPEC`` (SPEC is JSON). bubblewrap runs
as an unprivileged uid (65534) so that student code is unprivileged on the host too; that uid cannot
reach what it must show (the interpreter may live in root's home, which is closed to others). So this
helper, still root, enters a private mount namespace and binds each such folder on an empty, reachable
mount point (in the sandbox's own temporary folder, invisible to every other process); joins the
sandbox's cgroup (``cgroup``: memory, processes and CPU of every process started from here on); enters a
new IPC namespace, the sandbox's, and caps its SysV shared memory, message queues and semaphores and
its POSIX message queues (the namespace's sysctls, which only root may write); then drops to the
unprivileged uid and group (no supplementary groups), asks for SIGKILL when the grader dies, and
executes bubblewrap, which binds the mount points read-only inside the sandbox. Nothing else: it reads no
student file and writes none.

Standard library only (it runs before, and apart from, everything else).
"""

import ctypes
import json
import os
import signal
import sys

CLONE_NEWNS = 0x00020000
CLONE_NEWIPC = 0x08000000
MS_BIND = 4096
MS_REC = 16384
MS_PRIVATE = 1 << 18
PR_SET_PDEATHSIG = 1


def fail(message: str) -> None:
    os.write(2, f"mbd sandbox launcher: {message}\n".encode())
    os._exit(127)


def main() -> None:
    spec = json.loads(sys.argv[1])
    libc = ctypes.CDLL(None, use_errno=True)
    libc.mount.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_ulong, ctypes.c_void_p]
    if libc.unshare(CLONE_NEWNS) != 0:
        fail(f"unshare(CLONE_NEWNS): {os.strerror(ctypes.get_errno())}")
    if libc.mount(b"none", b"/", None, MS_REC | MS_PRIVATE, None) != 0:
        fail(f"making / private: {os.strerror(ctypes.get_errno())}")
    for source, target in spec["mounts"]:
        if libc.mount(os.fsencode(source), os.fsencode(target), None, MS_BIND | MS_REC, None) != 0:
            fail(f"bind {source} on {target}: {os.strerror(ctypes.get_errno())}")
    for procs in spec.get("cgroup", []):
        try:
            with open(procs, "w") as f:
                f.write(str(os.getpid()))
        except OSError as err:
            fail(f"joining the cgroup {procs}: {err.strerror}")
    if spec.get("ipc") is not None:
        if libc.unshare(CLONE_NEWIPC) != 0:
            fail(f"unshare(CLONE_NEWIPC): {os.strerror(ctypes.get_errno())}")
        for name, value in spec["ipc"].items():  # this namespace's own values
            try:
                with open(f"/proc/sys/{name}", "w") as f:
                    f.write(str(value))
            except OSError as err:
                fail(f"setting {name}: {err.strerror}")
    uid, gid = int(spec["uid"]), int(spec["gid"])
    os.setgroups([])
    os.setresgid(gid, gid, gid)
    os.setresuid(uid, uid, uid)
    if os.getresuid() != (uid, uid, uid) or os.getgroups():
        fail("could not drop privileges")
    # after the uid change (which clears it): die with the grader
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != int(spec["parent"]):
        os._exit(126)  # the grader is already gone
    os.execve(spec["argv"][0], spec["argv"], {})


if __name__ == "__main__":
    main()
