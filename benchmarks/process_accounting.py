"""Where a command's CPU goes, process by process: Linux process accounting (acct(2)) around the command.

    sudo python benchmarks/process_accounting.py -- .venv/bin/python -m pytest -n 2 tests/course

Every process of the machine that ends while the command runs (the sandboxed ones too, whatever their
namespace; run it on a quiet machine) writes one record: its name (the first 15 characters of the
executable's), parent, CPU seconds and lifetime. The table sums them by name and lists the costliest processes
with their parents; a process of the grader's sandbox is ``python3.11`` (the interpreter itself), one of the
venv ``python``. Used for issue 24 (benchmarks/results/tests.md, "eleventh session"). Needs root
(CAP_SYS_PACCT) and a kernel with BSD process accounting (version 3 records).
"""

from __future__ import annotations

import argparse
import collections
import ctypes
import os
import struct
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

RECORD = struct.Struct("<BBHIIIIIIfHHHHHHHH16s")
"""``struct acct_v3`` (linux/acct.h): flag, version, tty, exit code, uid, gid, pid, ppid, start time, elapsed
(float, in AHZ ticks), user and system time (comp_t), memory, I/O, ..., the command's name."""
AHZ = 100


@dataclass(frozen=True)
class Process:
    pid: int
    ppid: int
    name: str
    cpu: float
    seconds: float


def comp(value: int) -> int:
    """A ``comp_t``: 13 bits of mantissa, 3 of base-8 exponent."""
    return (value & 0x1FFF) << (3 * (value >> 13))


def read(path: str) -> list[Process]:
    data = Path(path).read_bytes()
    processes = []
    for start in range(0, len(data) - RECORD.size + 1, RECORD.size):
        fields = RECORD.unpack_from(data, start)
        if fields[1] != 3:  # not a version-3 record
            continue
        name = fields[-1].split(b"\0")[0].decode(errors="replace")
        cpu = (comp(fields[10]) + comp(fields[11])) / AHZ
        processes.append(Process(fields[6], fields[7], name, cpu, fields[9] / AHZ))
    return processes


def accounting(path: str | None) -> None:
    """Process accounting on, to ``path``, or off (None)."""
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.acct(path.encode() if path else None) != 0:
        raise OSError(ctypes.get_errno(), f"acct({path}): {os.strerror(ctypes.get_errno())} (root needed)")


def table(processes: list[Process], top: int = 25) -> str:
    by_name: dict[str, list[float]] = collections.defaultdict(lambda: [0, 0.0])
    for p in processes:
        by_name[p.name][0] += 1
        by_name[p.name][1] += p.cpu
    lines = [f"{len(processes)} processes, {sum(p.cpu for p in processes):.0f} CPU s", ""]
    lines += ["| name | processes | CPU s |", "|---|---:|---:|"]
    for name, (count, cpu) in sorted(by_name.items(), key=lambda item: -item[1][1])[:top]:
        lines.append(f"| {name} | {count} | {cpu:.1f} |")
    lines += ["", "| pid | parent | name | CPU s | seconds |", "|---:|---:|---|---:|---:|"]
    for p in sorted(processes, key=lambda p: -p.cpu)[:top]:
        lines.append(f"| {p.pid} | {p.ppid} | {p.name} | {p.cpu:.1f} | {p.seconds:.1f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("command", nargs="+", help="the command (after --)")
    parser.add_argument("--top", type=int, default=25)
    args = parser.parse_args(argv)
    with tempfile.NamedTemporaryFile(prefix="acct-", delete=False) as log:
        path = log.name
    try:
        accounting(path)
        try:
            done = subprocess.run(args.command)
        finally:
            accounting(None)
        print(table(read(path), args.top))
        return done.returncode
    except OSError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    finally:
        os.unlink(path)


if __name__ == "__main__":
    sys.exit(main())
