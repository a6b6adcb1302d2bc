"""A seccomp filter for the grading sandbox's child: the system calls student code may not make.

The grader's sandbox child (``_child``, started by ``sandbox.Sandbox`` with bubblewrap) installs this
filter after it has imported what it needs and before any student code runs. It is a classic BPF program
(built here with ``struct.pack``, installed with ``prctl(PR_SET_NO_NEW_PRIVS)`` and
``seccomp(SECCOMP_SET_MODE_FILTER, SECCOMP_FILTER_FLAG_TSYNC)`` through ctypes, so every thread has it and
every process the child starts inherits it; it can never be removed). bubblewrap's own ``--seccomp`` is
not used: it applies before bubblewrap runs the interpreter, and so would forbid that very ``execve``.

The filter kills the process for any architecture but x86-64 (no 32-bit or x32 system calls to get
around it) and answers ``DENIED`` with an error; everything else is allowed (the mount, PID, network and
user namespaces, the unprivileged uid and the rlimits do the rest).
"""

from __future__ import annotations

import ctypes
import errno
import os
import platform
import struct

AUDIT_ARCH_X86_64 = 0xC000003E
X32_SYSCALL_BIT = 0x40000000

SECCOMP_RET_KILL_PROCESS = 0x80000000
SECCOMP_RET_ERRNO = 0x00050000
SECCOMP_RET_ALLOW = 0x7FFF0000
SECCOMP_SET_MODE_FILTER = 1
SECCOMP_FILTER_FLAG_TSYNC = 1
PR_SET_NO_NEW_PRIVS = 38
SYS_SECCOMP = 317  # x86-64

# classic BPF opcodes
LD_W_ABS = 0x20  # BPF_LD | BPF_W | BPF_ABS
JEQ_K = 0x15  # BPF_JMP | BPF_JEQ | BPF_K
JGE_K = 0x35  # BPF_JMP | BPF_JGE | BPF_K
JSET_K = 0x45  # BPF_JMP | BPF_JSET | BPF_K
RET_K = 0x06  # BPF_RET | BPF_K

# offsets in struct seccomp_data
NR, ARCH, ARG0 = 0, 4, 16

CLONE_NAMESPACES = 0x00020000 | 0x02000000 | 0x04000000 | 0x08000000 | 0x10000000 | 0x20000000 | 0x40000000
"""CLONE_NEWNS, NEWCGROUP, NEWUTS, NEWIPC, NEWUSER, NEWPID, NEWNET: clone() with any of them is refused."""

DENIED: dict[str, tuple[int, int, str]] = {
    # name: (x86-64 number, errno returned, why)
    "execve": (59, errno.EPERM, "run another program (the child runs only Python and the student's package)"),
    "execveat": (322, errno.EPERM, "run another program, by file descriptor"),
    "ptrace": (101, errno.EPERM, "inspect or change another process (or the sandbox's own helper)"),
    "process_vm_readv": (310, errno.EPERM, "read another process's memory"),
    "process_vm_writev": (311, errno.EPERM, "write another process's memory"),
    "socket": (41, errno.EPERM, "open a new socket (the network namespace has none anyway; no Unix sockets)"),
    "socketpair": (53, errno.EPERM, "make a new pair of connected sockets"),
    "io_uring_setup": (425, errno.EPERM, "io_uring: could open files and sockets without these system calls"),
    "io_uring_enter": (426, errno.EPERM, "io_uring"),
    "io_uring_register": (427, errno.EPERM, "io_uring"),
    "unshare": (272, errno.EPERM, "new namespaces (a user namespace would give back capabilities)"),
    "setns": (308, errno.EPERM, "enter another namespace"),
    "mount": (165, errno.EPERM, "mount a file system (uncover or replace what the sandbox shows)"),
    "umount2": (166, errno.EPERM, "unmount (uncover what a mount hides)"),
    "pivot_root": (155, errno.EPERM, "change the root file system"),
    "chroot": (161, errno.EPERM, "change the root directory"),
    "open_tree": (428, errno.EPERM, "the new mount API"),
    "move_mount": (429, errno.EPERM, "the new mount API"),
    "fsopen": (430, errno.EPERM, "the new mount API"),
    "fsconfig": (431, errno.EPERM, "the new mount API"),
    "fsmount": (432, errno.EPERM, "the new mount API"),
    "fspick": (433, errno.EPERM, "the new mount API"),
    "mount_setattr": (442, errno.EPERM, "change mount flags (make a read-only mount writable)"),
    "open_by_handle_at": (304, errno.EPERM, "open a file by handle, around path permissions"),
    "name_to_handle_at": (303, errno.EPERM, "file handles (see open_by_handle_at)"),
    "pidfd_getfd": (438, errno.EPERM, "take a file descriptor from another process"),
    "process_madvise": (440, errno.EPERM, "act on another process's memory"),
    "kcmp": (312, errno.EPERM, "compare other processes' kernel objects"),
    "bpf": (321, errno.EPERM, "load BPF programs"),
    "perf_event_open": (298, errno.EPERM, "performance counters (side channels, kernel attack surface)"),
    "userfaultfd": (323, errno.EPERM, "user fault handling (a classic kernel exploit aid)"),
    "keyctl": (250, errno.EPERM, "the kernel keyring (not namespaced)"),
    "add_key": (248, errno.EPERM, "the kernel keyring"),
    "request_key": (249, errno.EPERM, "the kernel keyring"),
    "syslog": (103, errno.EPERM, "read the kernel log"),
    "fanotify_init": (300, errno.EPERM, "watch file system events"),
    "kexec_load": (246, errno.EPERM, "load a new kernel"),
    "kexec_file_load": (320, errno.EPERM, "load a new kernel"),
    "init_module": (175, errno.EPERM, "load a kernel module"),
    "finit_module": (313, errno.EPERM, "load a kernel module"),
    "delete_module": (176, errno.EPERM, "unload a kernel module"),
    "uselib": (134, errno.EPERM, "obsolete library loading"),
    "acct": (163, errno.EPERM, "process accounting"),
    "quotactl": (179, errno.EPERM, "disk quotas"),
    "swapon": (167, errno.EPERM, "swap"),
    "swapoff": (168, errno.EPERM, "swap"),
    "reboot": (169, errno.EPERM, "reboot"),
    "sethostname": (170, errno.EPERM, "host name"),
    "setdomainname": (171, errno.EPERM, "domain name"),
    "vhangup": (153, errno.EPERM, "hang up the terminal"),
    "clone3": (
        435,
        errno.ENOSYS,
        "its flags sit in memory where the filter cannot see them: ENOSYS makes the C "
        "library fall back to clone(), whose flags are checked",
    ),
}
"""Each denied system call: its number, the error it returns and why it is denied. Also refused: clone()
with a namespace flag (``CLONE_NAMESPACES``: fork and threads stay allowed), any x32 system call (number
with bit 30 set: EPERM), any other architecture (the process is killed)."""


def _insn(code: int, jt: int, jf: int, k: int) -> bytes:
    return struct.pack("=HBBI", code, jt, jf, k & 0xFFFFFFFF)


def program() -> bytes:
    """The filter as classic BPF (struct sock_filter[]), for x86-64."""
    errno_ret = lambda e: SECCOMP_RET_ERRNO | e  # noqa: E731
    code = [
        _insn(LD_W_ABS, 0, 0, ARCH),
        _insn(JEQ_K, 1, 0, AUDIT_ARCH_X86_64),
        _insn(RET_K, 0, 0, SECCOMP_RET_KILL_PROCESS),
        _insn(LD_W_ABS, 0, 0, NR),
        _insn(JGE_K, 0, 1, X32_SYSCALL_BIT),
        _insn(RET_K, 0, 0, errno_ret(errno.EPERM)),
        # clone(flags, ...): refuse new namespaces; fork and threads pass
        _insn(JEQ_K, 0, 4, 56),
        _insn(LD_W_ABS, 0, 0, ARG0),  # the low 32 bits of flags (little-endian)
        _insn(JSET_K, 0, 1, CLONE_NAMESPACES),
        _insn(RET_K, 0, 0, errno_ret(errno.EPERM)),
        _insn(RET_K, 0, 0, SECCOMP_RET_ALLOW),
    ]
    for number, error, _ in DENIED.values():
        code.append(_insn(JEQ_K, 0, 1, number))
        code.append(_insn(RET_K, 0, 0, errno_ret(error)))
    code.append(_insn(RET_K, 0, 0, SECCOMP_RET_ALLOW))
    return b"".join(code)


def supported() -> bool:
    """The filter is written for Linux on x86-64."""
    return platform.system() == "Linux" and platform.machine() in ("x86_64", "AMD64")


def install() -> None:
    """Install the filter in this process (all its threads, all its future children). Irreversible.

    Raises OSError when the kernel refuses it (the sandbox then does not start: the wall is incomplete).
    """
    if not supported():
        raise OSError(errno.ENOSYS, f"the seccomp filter is written for Linux x86-64, not {platform.machine()}")
    libc = ctypes.CDLL(None, use_errno=True)
    code = program()
    filters = ctypes.create_string_buffer(code, len(code))

    class SockFprog(ctypes.Structure):
        _fields_ = [("len", ctypes.c_ushort), ("filter", ctypes.c_void_p)]

    fprog = SockFprog(len(code) // 8, ctypes.addressof(filters))
    libc.prctl.argtypes = [ctypes.c_int, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong]
    if libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0:
        err = ctypes.get_errno()
        raise OSError(err, f"prctl(PR_SET_NO_NEW_PRIVS): {os.strerror(err)}")
    libc.syscall.restype = ctypes.c_long
    result = libc.syscall(
        ctypes.c_long(SYS_SECCOMP),
        ctypes.c_long(SECCOMP_SET_MODE_FILTER),
        ctypes.c_long(SECCOMP_FILTER_FLAG_TSYNC),
        ctypes.byref(fprog),
    )
    if result != 0:
        err = ctypes.get_errno()
        raise OSError(err, f"seccomp(SECCOMP_SET_MODE_FILTER): {os.strerror(err) if err else result}")
