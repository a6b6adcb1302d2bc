"""Benchmark of the start-up of ``mbd run``: a one-step run against importing what every run needs.

Issue 16, item 3: ``mbd run`` of a one-step model should finish in at most 1.5 times the time of

    python -c "import numpy, scipy.linalg, yaml"

(the baseline: what any run of this package imports). Both are started as fresh processes, alternately
(baseline, run A, run B, ..., baseline, run A, ...), so that the load of a shared machine falls on all of
them alike; the script prints the median wall time of each command and its ratio to the baseline's median.

``mbd run`` is started as the console script does (``from solutions.cli import main``) from this
repository, with ``--steps 1 --t-end T`` (one output interval; T = 0.01 s by default). The default runs:

- slider_crank.yaml, a kinematic run (no scipy.integrate);
- double_pendulum.yaml with its file's integrator (DOP853, scipy's solve_ivp: imports scipy.integrate);
- double_pendulum.yaml with ``--integrator rk4`` (this package's fixed-step RK4: no scipy.integrate).

Bytecode: an installed package has its ``.pyc`` files, but a checkout run with PYTHONDONTWRITEBYTECODE set
compiles every module of ``solutions`` from source at every start. The children therefore run with
PYTHONPYCACHEPREFIX pointing at a scratch folder (and PYTHONDONTWRITEBYTECODE unset), and ``--warmup``
runs of each command fill it, and the schema validator's cache (``solutions.io.model.validator_cache``),
before anything is timed. ``--cold`` instead keeps the caller's environment.

This is a benchmark, not a test: the numbers depend on the machine. Run::

    .venv/bin/python benchmarks/start.py                 # 15 rounds, about a minute
    .venv/bin/python benchmarks/start.py --rounds 40
    .venv/bin/python benchmarks/start.py --model course/models/four_bar.yaml
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BASELINE = "import numpy, scipy.linalg, yaml"
ONE_THREAD = (
    "import os\n"
    "for name in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):\n"
    "    os.environ.setdefault(name, '1')\n" + BASELINE
)
"""The baseline with BLAS on one thread, as ``import solutions`` sets it: starting no BLAS threads makes
``import numpy`` cheaper, an advantage of every ``mbd`` run over the plain baseline, shown for comparison."""
MBD = "import sys; from solutions.cli import main; sys.exit(main())"
TARGET = 1.5
DEFAULT_RUNS = (
    ("course/models/slider_crank.yaml",),
    ("course/models/double_pendulum.yaml",),
    ("course/models/double_pendulum.yaml", "--integrator", "rk4"),
)


def commands(runs, t_end: float) -> dict[str, list[str]]:
    """Label -> argv: the baseline first, then one ``mbd run`` per entry of ``runs`` (model file, options)."""
    table = {
        "baseline: python -c " + repr(BASELINE): [sys.executable, "-c", BASELINE],
        "the same, BLAS on one thread (as solutions/__init__.py sets it)": [sys.executable, "-c", ONE_THREAD],
    }
    for model, *options in runs:
        args = ["run", model, "--steps", "1", "--t-end", f"{t_end:g}", *options]
        table["mbd " + " ".join(args)] = [sys.executable, "-c", MBD, *args]
    return table


def environment(pycache: str | None) -> dict[str, str]:
    """The children's environment: this repository first on the path; bytecode cached in ``pycache``."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), *filter(None, [env.get("PYTHONPATH")])])
    if pycache is not None:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = pycache
    return env


def run_once(argv: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall time of one process, start to exit, and its CPU time (user + system, all its threads); a
    failing command stops the benchmark."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(argv, env=env, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    elapsed = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{shlex.join(argv)} exited with {done.returncode}:\n{done.stderr}")
    return elapsed, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def measure(table: dict[str, list[str]], env: dict[str, str], rounds: int, warmup: int) -> dict[str, list]:
    """``warmup`` untimed runs of each command, then ``rounds`` rounds, each running every command once:
    label -> [(wall, cpu), ...]."""
    for _ in range(warmup):
        for argv in table.values():
            run_once(argv, env)
    times: dict[str, list] = {label: [] for label in table}
    for _ in range(rounds):
        for label, argv in table.items():
            times[label].append(run_once(argv, env))
    return times


def report(times: dict[str, list], rounds: int, cold: bool) -> str:
    """A Markdown table: medians of wall and CPU time, quartiles of the wall time, and the ratios of the
    medians to the baseline's (and of the wall time to the one-thread baseline's), with the verdict (on the
    wall-time ratio to the baseline) per run."""
    labels = list(times)
    base_wall = statistics.median(wall for wall, _ in times[labels[0]])
    base_cpu = statistics.median(cpu for _, cpu in times[labels[0]])
    one_thread = statistics.median(wall for wall, _ in times[labels[1]])
    lines = [
        f"Start-up, {rounds} alternating rounds, {platform.python_implementation()} {platform.python_version()}, "
        f"{os.cpu_count()} cores, load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}; "
        + ("caller's environment (bytecode as it is)" if cold else "bytecode and validator cached (warm-up runs)"),
        "",
        "| command | wall median (s) | wall quartiles (s) | ratio | CPU median (s) | CPU ratio | ratio to one "
        "thread | ratio <= 1.5 |",
        "|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for label in labels:
        walls = sorted(wall for wall, _ in times[label])
        cpu = statistics.median(c for _, c in times[label])
        q1, median, q3 = statistics.quantiles(walls, n=4) if len(walls) > 1 else (walls[0],) * 3
        ratio = median / base_wall
        verdict = "" if label in labels[:2] else ("met" if ratio <= TARGET else "missed")
        lines.append(
            f"| `{label}` | {median:.3f} | {q1:.3f} - {q3:.3f} | {ratio:.2f} | {cpu:.3f} | {cpu / base_cpu:.2f} "
            f"| {median / one_thread:.2f} | {verdict} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=15, help="timed rounds (default 15)")
    parser.add_argument("--warmup", type=int, default=2, help="untimed runs of each command first (default 2)")
    parser.add_argument("--t-end", type=float, default=0.01, help="end time of each run in s (default 0.01)")
    parser.add_argument(
        "--model",
        action="append",
        help="a model file to run instead of the default runs (repeatable; options after it: quote them, "
        "e.g. --model 'course/models/double_pendulum.yaml --integrator rk4')",
    )
    parser.add_argument("--cold", action="store_true", help="keep the caller's environment (no bytecode cache)")
    args = parser.parse_args(argv)
    runs = [shlex.split(text) for text in args.model] if args.model else DEFAULT_RUNS
    table = commands(runs, args.t_end)
    with tempfile.TemporaryDirectory(prefix="mbd-start-pycache-") as pycache:
        times = measure(table, environment(None if args.cold else pycache), args.rounds, args.warmup)
    print(report(times, args.rounds, args.cold))
    return 0


if __name__ == "__main__":
    sys.exit(main())
