"""Scaling on Dask: sweep runs per second and graded submissions per minute against the number of worker
processes, and the overhead per task of Dask against the local process pool.

    .venv/bin/python benchmarks/scaling.py [--workers 1 2] [--runs 48] [--students 6] [--homework hw1]
                                           [--out benchmarks/results/scaling.md]

1. Overhead per task: ``--tasks`` empty tasks through a ``ProcessPoolExecutor`` (spawn: a baseline, which
   ``mbd grade`` and ``mbd sweep`` no longer use, ``solutions/batch.py``) and through a ``LocalCluster``
   (one single-threaded worker process each, started beforehand).
2. Sweep: ``--runs`` forward-dynamic runs of ``course/models/simple_pendulum.yaml`` (4 s, 400 outputs,
   a grid of mass and initial angular velocity): in this process (``--jobs 1``) and on a LocalCluster of
   1, 2, ... workers, started and warmed beforehand (the workers have imported the solver).
3. Grading: ``--students`` submissions of the whole homework (benchmarks/grading.py's class: reference,
   skeleton, a mutant) one by one in this process and on a LocalCluster of 1, 2, ... workers, bubblewrap
   sandbox per submission, start-up included (as a user sees it).

Writes a Markdown table (``--out``) with the figures, and the number of workers a class of 500 needs to be
graded in 10 minutes at the measured per-worker rate. Wall-clock figures depend on what else the machine
runs: the table says how many cores there were.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from solutions.sweep import make_sweep, run_sweep  # noqa: E402

PENDULUM = REPO / "course" / "models" / "simple_pendulum.yaml"


def _nothing(x: int) -> int:
    return x


def local_cluster(workers: int):
    """A LocalCluster of ``workers`` single-threaded worker processes that import from this repository."""
    from dask.distributed import LocalCluster

    env = {"PYTHONPATH": os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)}
    return LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        memory_limit=0,
        dashboard_address=":0",
        silence_logs=logging.CRITICAL,
        env=env,
    )


def overhead(tasks: int) -> dict:
    """Seconds per empty task: process pool (1 worker) and Dask LocalCluster (1 worker), both warm."""
    from dask.distributed import Client, wait

    with ProcessPoolExecutor(1, mp_context=get_context("spawn")) as pool:
        pool.submit(_nothing, 0).result()
        start = time.perf_counter()
        list(pool.map(_nothing, range(tasks)))
        pool_time = (time.perf_counter() - start) / tasks
    start = time.perf_counter()
    with local_cluster(1) as lc, Client(lc) as client:
        startup = time.perf_counter() - start
        client.submit(_nothing, -1).result()
        start = time.perf_counter()
        wait([client.submit(_nothing, i, pure=False) for i in range(tasks)])
        dask_time = (time.perf_counter() - start) / tasks
    return {"pool": pool_time, "dask": dask_time, "startup": startup}


def sweep_rates(runs: int, workers: list[int]) -> dict:
    """Runs per second: here and on LocalClusters (started beforehand), with identical tables checked."""
    masses = max(1, runs // 12)
    keys = [f"bodies[rod].mass=1:2:{masses}", f"bodies[rod].angular_velocity=0:3:{runs // masses}"]
    sweep = make_sweep(PENDULUM, keys)
    warm = make_sweep(PENDULUM, ["bodies[rod].mass=1:2:4"], t_end=0.1, steps=5)
    rates = {}
    with tempfile.TemporaryDirectory(prefix="scaling-") as tmp:
        start = time.perf_counter()
        run_sweep(sweep, Path(tmp) / "here", jobs=1, progress=False, plots=False)
        rates["here"] = len(sweep.sets) / (time.perf_counter() - start)
        reference = (Path(tmp) / "here" / "sweep.csv").read_bytes()
        for n in workers:
            with local_cluster(n) as lc:
                run_sweep(warm, None, cluster=lc.scheduler_address, progress=False)  # workers import the solver
                start = time.perf_counter()
                run_sweep(sweep, Path(tmp) / f"w{n}", cluster=lc.scheduler_address, progress=False, plots=False)
                rates[n] = len(sweep.sets) / (time.perf_counter() - start)
            assert (Path(tmp) / f"w{n}" / "sweep.csv").read_bytes() == reference, "tables differ"
    return {"runs": len(sweep.sets), "rates": rates}


def grading_rates(homework: str, students: int, workers: list[int]) -> dict:
    """Submissions per minute: one by one here (jobs 1) and LocalClusters of each size (start-up included)."""
    from autograder.grading import grade
    from benchmarks.grading import make_submissions

    rates = {}
    with tempfile.TemporaryDirectory(prefix="scaling-grade-") as tmp:
        root = Path(tmp)
        make_submissions(root / "submitted", homework, students)
        books = {}
        for label, options in [("here", {"jobs": 1})] + [(n, {"jobs": n, "cluster": "local"}) for n in workers]:
            start = time.perf_counter()
            book = grade(homework, root / "submitted", root / f"out-{label}", progress=False, resume=False, **options)
            rates[label] = 60.0 * students / (time.perf_counter() - start)
            books[label] = (root / f"out-{label}" / "gradebook.csv").read_text()
            assert len(book.rows) == students
        assert len(set(books.values())) == 1, "gradebooks differ"
    return {"students": students, "homework": homework, "rates": rates}


def report(over: dict, sweeps: dict, grading: dict, workers: list[int]) -> str:
    lines = [
        "# Scaling on Dask (benchmarks/scaling.py)",
        "",
        f"Machine: {os.cpu_count()} cores (shared with other work while measured); "
        f"`python benchmarks/scaling.py --workers {' '.join(map(str, workers))} --runs {sweeps['runs']} "
        f"--students {grading['students']} --homework {grading['homework']}`.",
        "",
        "## Overhead per task (empty task, one warm worker)",
        "",
        "| engine | ms per task |",
        "| --- | ---: |",
        f"| local process pool (spawn) | {1e3 * over['pool']:.2f} |",
        f"| Dask LocalCluster | {1e3 * over['dask']:.2f} |",
        "",
        f"Starting a LocalCluster of one worker took {over['startup']:.1f} s.",
        "",
        f"## Sweep: {sweeps['runs']} forward-dynamic runs of the simple pendulum (4 s, 400 outputs)",
        "",
        "| where | runs/s |",
        "| --- | ---: |",
        f"| this process (--jobs 1) | {sweeps['rates']['here']:.2f} |",
    ]
    lines += [f"| LocalCluster, {n} worker(s) | {sweeps['rates'][n]:.2f} |" for n in workers]
    lines += [
        "",
        f"## Grading: {grading['students']} submissions of {grading['homework']} (bubblewrap sandbox each, "
        "start-up included)",
        "",
        "| engine | submissions/min |",
        "| --- | ---: |",
        f"| this process (--jobs 1) | {grading['rates']['here']:.1f} |",
    ]
    lines += [f"| LocalCluster, {n} worker(s) | {grading['rates'][n]:.1f} |" for n in workers]
    per_worker = grading["rates"][min(workers)] / min(workers)
    need = math.ceil(500 / (10 * per_worker))
    best = max(grading["rates"], key=lambda k: grading["rates"][k])
    lines += [
        "",
        f"A class of 500 in 10 minutes needs 50 submissions/min. One worker grades {per_worker:.1f} "
        f"{grading['homework']} submissions/min here, so at least {need} workers on free cores, plus a core for "
        f"the client and scheduler. On this machine the best configuration ({best}) gave "
        f"{grading['rates'][best]:.1f}/min, i.e. 500 in {500 / grading['rates'][best]:.1f} min: with {os.cpu_count()} "
        "cores, more workers do not add cores, and the workers, sandboxes, client and other work share them. "
        "Plan on one worker per free core at the one-worker rate, with a margin for the homework's cost "
        "(hw2 and hw3 run more and longer checks than hw1: measure them with `--homework`).",
        "",
        f"Load average while measured: {over.get('load', 'n/a')}. Tables and gradebooks were identical in every "
        "configuration (asserted).",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--runs", type=int, default=48, help="runs in the sweep")
    parser.add_argument("--students", type=int, default=6, help="submissions graded")
    parser.add_argument("--homework", default="hw1")
    parser.add_argument("--tasks", type=int, default=300, help="empty tasks for the overhead")
    parser.add_argument("--out", default=str(REPO / "benchmarks" / "results" / "scaling.md"))
    args = parser.parse_args(argv)
    os.environ["MBD_GRADER_SECRET"] = "benchmark-secret"  # the benchmark's own course secret, never the course's
    load = os.getloadavg()[0]
    over = overhead(args.tasks)
    print(f"overhead per task: pool {1e3 * over['pool']:.2f} ms, dask {1e3 * over['dask']:.2f} ms", flush=True)
    sweeps = sweep_rates(args.runs, args.workers)
    print(f"sweep runs/s: {sweeps['rates']}", flush=True)
    grading = grading_rates(args.homework, args.students, args.workers)
    print(f"grading submissions/min: {grading['rates']}", flush=True)
    over["load"] = f"{load:.1f} at the start, {os.getloadavg()[0]:.1f} at the end"
    text = report(over, sweeps, grading, args.workers)
    Path(args.out).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
