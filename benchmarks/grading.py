"""Grading throughput: submissions graded per minute, per homework, with ``autograder.grading.grade``.

For each homework a folder of N submissions is made in a temporary directory: copies of the reference
(every check runs to the end and passes), the untouched skeleton (every check fails fast) and a mutant
(checks fail with numbers, so the grader replays known mistakes to name the cause), in the proportions
6 : 2 : 2 by default. The whole ``grade`` call is timed, start-up of the worker processes and their
sandbox forkservers included, and reported with the mean time per student that the results record.

    .venv/bin/python benchmarks/grading.py [--jobs 2] [--n 20] [--isolation os|local] [hw1 hw2 hw3]

Prints the time a sandbox takes to start (to its first "ready"; a student's own imports come later, in
the first check) and a Markdown table. ``--isolation os`` (the default, as ``mbd grade``): each student
in a fresh bubblewrap sandbox; ``local``: the forkserver sandbox (``--unsafe-no-isolation``).

Before timing, the compiled engine of the per-student references is compiled (``reference.warm``, once per
machine; ``grade`` does it itself for 50 submissions or more).

Where the machine lets it (cgroup v1 ``cpuacct``, as root), the table also gives the CPU seconds the whole
grading used (grader, workers, every sandbox process) per student, and the throughput those CPU seconds
allow on the cores there are: wall-clock figures depend on what else the machine runs, CPU seconds much less.
"""

from __future__ import annotations

import argparse
import atexit
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from autograder.grading import grade  # noqa: E402
from autograder.reference import warm  # noqa: E402
from mbdkit.homework import available_homeworks  # noqa: E402
from mbdkit.sandbox import Sandbox  # noqa: E402

MUTANTS = {  # one typical mistake per homework: (file in solutions/, text, replacement)
    "hw1": (
        "planar/joints.py",
        "return point_vector_quadratic(qi, self.si",
        "return -point_vector_quadratic(qi, self.si",
    ),  # noqa: E501
    "hw2": (
        "formulations.py",
        "return gamma - 2.0 * alpha * psi_dot - beta**2 * psi",
        "return gamma + 2.0 * alpha * psi_dot + beta**2 * psi",
    ),
    "hw3": ("spatial/mass.py", "return 8.0 * Ld.T @ (inertia @ (Ld @ p))", "return 0.0 * Ld.T @ (inertia @ (Ld @ p))"),
}


def make_submissions(root: Path, homework: str, n: int) -> dict[str, str]:
    """n student folders: 60 % reference, 20 % skeleton, 20 % mutant. Returns {student: kind}."""
    from course.release.generator import build_package

    kinds = {}
    for k in range(n):
        kind = ("reference", "reference", "reference", "skeleton", "mutant")[k % 5]
        kind = "reference" if k % 10 == 9 else kind
        folder = root / f"student{k:03d}"
        if kind == "skeleton":
            build_package(folder / "modules", homework, header=None)
        else:
            shutil.copytree(REPO / "solutions", folder / "modules", ignore=shutil.ignore_patterns("__pycache__"))
            if kind == "mutant":
                relpath, old, new = MUTANTS[homework]
                path = folder / "modules" / relpath
                path.write_text(path.read_text().replace(old, new, 1))
        kinds[folder.name] = kind
    return kinds


def startup(isolation: str, repeat: int = 5) -> float:
    """Median seconds from a new Sandbox to its child's "ready" (the reference package as the submission;
    the local backend's first start also starts its forkserver, which the median leaves out)."""
    with tempfile.TemporaryDirectory(prefix="bench-start-") as tmp:
        shutil.copytree(REPO / "solutions", Path(tmp) / "modules", ignore=shutil.ignore_patterns("__pycache__"))
        times = []
        for _ in range(repeat):
            start = time.perf_counter()
            with Sandbox(Path(tmp), "modules", isolation=isolation) as sandbox:
                sandbox.start()
                times.append(time.perf_counter() - start)
    return statistics.median(times)


CPUACCT = Path("/sys/fs/cgroup/cpuacct")


class CpuAccount:
    """CPU seconds of this process and every process it starts (a cgroup v1 cpuacct group), or None."""

    def __init__(self):
        self.group = None
        try:
            group = CPUACCT / f"mbd-bench-{os.getpid()}"
            group.mkdir()
            (group / "cgroup.procs").write_text(str(os.getpid()))
            self.group = group
            atexit.register(self.remove)
        except OSError:
            pass

    def remove(self) -> None:
        """Back to the root group, and the group removed (once its processes are gone)."""
        try:
            (CPUACCT / "cgroup.procs").write_text(str(os.getpid()))
            self.group.rmdir()
        except OSError:
            pass

    def seconds(self) -> float | None:
        if self.group is None:
            return None
        return int((self.group / "cpuacct.usage").read_text()) / 1e9


def bench(homework: str, n: int, jobs: int, isolation: str = "os", account: CpuAccount | None = None) -> dict:
    with tempfile.TemporaryDirectory(prefix=f"bench-{homework}-") as tmp:
        root = Path(tmp)
        kinds = make_submissions(root / "submitted", homework, n)
        cpu = account.seconds() if account else None
        start = time.perf_counter()
        book = grade(
            homework, root / "submitted", root / "out", jobs=jobs, progress=False, resume=False, isolation=isolation
        )
        wall = time.perf_counter() - start
        cpu = account.seconds() - cpu if cpu is not None else None
        seconds = {
            kind: [float((root / "out" / "timing" / f"{s}.txt").read_text()) for s, k in kinds.items() if k == kind]
            for kind in ("reference", "skeleton", "mutant")
        }
        scores = {kind: sorted({book.score(s) for s, k in kinds.items() if k == kind}) for kind in seconds}
    return {"homework": homework, "n": n, "wall": wall, "cpu": cpu, "seconds": seconds, "scores": scores}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("homeworks", nargs="*", default=available_homeworks())
    parser.add_argument("--n", type=int, default=20, help="submissions per homework")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes")
    parser.add_argument("--isolation", choices=["os", "local"], default="os", help="the sandbox (default: os)")
    args = parser.parse_args(argv)
    os.environ["MBD_GRADER_SECRET"] = "benchmark-secret"  # the benchmark's own course secret, never the course's
    print(f"sandbox start ({args.isolation}, to ready, median of 5): {startup(args.isolation):.3f} s\n")
    print(
        f"Grading throughput, {args.jobs} worker processes, {args.n} submissions per homework, "
        f"isolation {args.isolation}\n"
    )
    for homework in args.homeworks:  # per-student references on the compiled engine, as a class of 50+ gets
        warm(homework)
    account = CpuAccount()
    cores = os.cpu_count() or 1
    print(
        "| homework | submissions | wall [s] | per minute | s per student (reference / skeleton / mutant) "
        f"| CPU s per student | per minute by CPU on {cores} cores |"
    )
    print("|---|---|---|---|---|---|---|")
    for homework in args.homeworks:
        r = bench(homework, args.n, args.jobs, args.isolation, account)
        mean = " / ".join(f"{statistics.mean(v):.2f}" if v else "-" for v in r["seconds"].values())
        cpu = "-" if r["cpu"] is None else f"{r['cpu'] / r['n']:.2f}"
        bound = "-" if r["cpu"] is None else f"{60 * cores * r['n'] / r['cpu']:.0f}"
        print(
            f"| {homework} | {r['n']} | {r['wall']:.1f} | {60 * r['n'] / r['wall']:.0f} | {mean} | {cpu} | {bound} |",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
