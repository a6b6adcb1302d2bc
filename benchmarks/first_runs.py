"""After ``mbd compile``, a model's first run on the machine compiles nothing (issue 25, deliverable 3).

``mbd compile`` compiles the engine once per machine from two pendulums (``solutions/compiled/precompile.py``); every
later run should find its machine code on disk. Whether it does depends on numba's disk cache: a version is filed
under the signature it was compiled for and a run looks it up by its arguments' types, so a version compiled under
another key (a full signature with its return type, another array layout, an argument of another width) is compiled
again at a user's first run, with nothing failing. Only a run on fresh caches sees that, so this script:

1. makes two empty caches (``MBD_COMPILED_CACHE`` for the generated modules, ``NUMBA_CACHE_DIR`` for numba's files)
   and runs ``python -m solutions.cli compile --quiet`` on them (its wall time and CPU are reported);
2. in one new process on those caches, runs every model of ``course/models`` (kinematic analysis where the drivers
   leave no freedom, else forward dynamics in every compiled formulation) and the three chain families of
   ``benchmarks/chains.py`` (N = 2 ... 32, every compiled formulation), each on the compiled engine, 1 s or a short
   span, and records numba's ``numba:compile`` events of each run: the functions compiled (the package's and numba's
   own helpers, apart) and the CPU they took.

A function compiled at one run is not compiled again at a later run of the same process, so a gap shows at the first
run that meets it. The table lists every run; the script exits with status 1 if any run compiled any function.

    .venv/bin/python benchmarks/first_runs.py                        # ~2 min of compile, then ~2 min of runs
    .venv/bin/python benchmarks/first_runs.py --sizes 2 8 --families loops --no-models
    .venv/bin/python benchmarks/first_runs.py --out benchmarks/results/first_runs.md

``--caches DIR`` uses (and keeps) the caches under DIR. ``--no-compile`` uses the caches as they are (``--caches``, or
else the caller's own, as ``MBD_COMPILED_CACHE`` and ``NUMBA_CACHE_DIR`` name them): a smoke run, or a second look.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FAMILIES = ("loops", "planar", "spatial")
SIZES = (2, 4, 8, 16, 32)
FORMULATIONS = ("joint-coordinates", "baumgarte", "projection")
PACKAGE = "solutions."


def environment(caches: Path | None) -> dict:
    """The child processes' environment: this checkout first on the path, the two caches under ``caches`` (None: the
    caller's caches, as its environment names them)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    if caches is not None:
        env |= {"MBD_COMPILED_CACHE": str(caches / "compiled"), "NUMBA_CACHE_DIR": str(caches / "numba")}
    return env


def compile_engine(caches: Path) -> dict:
    """``mbd compile`` in a new process on ``caches``: its wall time and the CPU of the processes it started."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "solutions.cli", "compile", "--quiet"],
        cwd=ROOT,
        env=environment(caches),
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"mbd compile failed ({done.returncode}):\n{done.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall": wall, "cpu": cpu, "last_line": done.stdout.strip().splitlines()[-1]}


def first_runs(caches: Path | None, args: argparse.Namespace) -> list[dict]:
    """The runs of ``child`` in one new process on ``caches``: one record per run."""
    argv = ["--child", "--sizes", *map(str, args.sizes), "--families", *args.families]
    argv += ["--formulations", *args.formulations] + ([] if args.models else ["--no-models"])
    done = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), *argv],
        cwd=ROOT,
        env=environment(caches),
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        raise SystemExit(f"the runs' process failed ({done.returncode}):\n{done.stderr}")
    return [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]


class CompileEvents:
    """numba's ``numba:compile`` events: each compiled function's module and name, and the process CPU of the outermost
    compilations (a function compiled while compiling its caller counts within the caller's time)."""

    def __init__(self) -> None:
        from numba.core import event

        self.names: list[tuple[str, str]] = []
        self.seconds = 0.0
        self._depth, self._start = 0, 0.0
        events = self

        class Listener(event.Listener):
            def on_start(self, ev) -> None:
                if events._depth == 0:
                    events._start = time.process_time()
                events._depth += 1

            def on_end(self, ev) -> None:
                events._depth -= 1
                if events._depth == 0:
                    events.seconds += time.process_time() - events._start
                function = ev.data["dispatcher"].py_func
                events.names.append((function.__module__ or "", function.__qualname__))

        event.register("numba:compile", Listener())

    def take(self) -> dict:
        """What was compiled since the last ``take``: the package's functions, numba's own, and the seconds."""
        ours = sorted({f"{m.removeprefix(PACKAGE)}.{n}" for m, n in self.names if m.startswith(PACKAGE)})
        numbas = sorted({n for m, n in self.names if not m.startswith(PACKAGE)})
        taken = {"ours": ours, "numba": numbas, "compile_seconds": self.seconds}
        self.names, self.seconds = [], 0.0
        return taken


def cases(args: argparse.Namespace):
    """(label, kind, make): every course model (``--models``), then every chain family and size."""
    sys.path.insert(0, str(ROOT))
    from benchmarks import chains
    from solutions.io.model import load_model

    if args.models:
        for path in sorted((ROOT / "course" / "models").glob("*.yaml")):
            yield path.stem, "model", lambda path=path: load_model(path)
    makers = {"loops": chains.loop_chain, "planar": chains.planar_chain, "spatial": chains.spatial_chain}
    for family in args.families:
        for n in args.sizes:
            yield f"{family} N = {n}", "chain", lambda f=makers[family], n=n: load_model(f(n))


def run_case(system, q0, qd0, kind: str, formulation: str | None) -> str:
    """One run on the compiled engine (the course's ``analysis`` choice for a model); the engine that ran it, or why
    none did."""
    from solutions.dynamics import forward_dynamics
    from solutions.kinematics import kinematic_analysis

    try:
        if formulation is None:
            run = kinematic_analysis(system, q0, 0.1, 4, engine="compiled")
        else:
            span, outputs = (1.0, 100) if kind == "chain" else (0.02, 2)
            run = forward_dynamics(
                system, q0, qd0, span, outputs, formulation=formulation, rtol=1e-6, atol=1e-8, engine="compiled"
            )
    except Exception as err:  # a formulation the scene does not take: the compiled engine says why
        return f"refused ({type(err).__name__})"
    return run.info["chosen"]["engine"]


def child(args: argparse.Namespace) -> int:
    """The runs, in this process: one JSON line per run on standard output."""
    events = CompileEvents()
    from solutions.analysis import choose_analysis
    from solutions.assembly import build_system

    events.take()  # numba's imports compile nothing of ours; whatever they did is not a run's
    for label, kind, make in cases(args):
        system, q0, qd0 = build_system(make())
        kinematic = kind == "model" and choose_analysis(system, q0) == "kinematic"
        for formulation in [None] if kinematic else args.formulations:
            start = time.process_time()
            engine = run_case(system, q0, qd0, kind, formulation)
            record = {"case": label, "formulation": formulation or "kinematic", "engine": engine}
            record |= {"seconds": time.process_time() - start} | events.take()
            print(json.dumps(record), flush=True)
    return 0


def report(compiled: dict | None, runs: list[dict]) -> str:
    """The Markdown report: ``mbd compile``'s cost, then one row per run, then the verdict."""
    lines = ["# First runs after `mbd compile` (benchmarks/first_runs.py)", ""]
    if compiled is not None:
        lines += [
            f"`mbd compile` on empty caches: {compiled['wall']:.1f} s wall, {compiled['cpu']:.1f} s CPU "
            f'("{compiled["last_line"]}").',
            "",
        ]
    lines += [
        "| run | formulation | engine | CPU s | compiled (package) | compiled (numba's own) | compile s |",
        "|---|---|---|---:|---|---|---:|",
    ]
    for r in runs:
        ours, numbas = ", ".join(r["ours"]) or "-", ", ".join(r["numba"]) or "-"
        lines.append(
            f"| {r['case']} | {r['formulation']} | {r['engine']} | {r['seconds']:.3f} | {ours} | {numbas} "
            f"| {r['compile_seconds']:.3f} |"
        )
    gaps = [r for r in runs if r["ours"] or r["numba"]]
    lines += [
        "",
        f"{len(runs)} runs; {len(gaps)} compiled something"
        + ("." if not gaps else f": {', '.join(r['case'] + ' ' + r['formulation'] for r in gaps)}."),
    ]
    return "\n".join(lines) + "\n"


def parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    parser.add_argument("--families", nargs="+", choices=FAMILIES, default=list(FAMILIES))
    parser.add_argument("--formulations", nargs="+", choices=FORMULATIONS, default=list(FORMULATIONS))
    parser.add_argument("--no-models", dest="models", action="store_false", help="leave out course/models")
    parser.add_argument("--caches", type=Path, help="the caches' folder (kept); default a new temporary one")
    parser.add_argument("--no-compile", dest="compile", action="store_false", help="use the caches as they are")
    parser.add_argument("--out", type=Path, help="also write the report to this file")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    if args.child:
        return child(args)
    with tempfile.TemporaryDirectory(prefix="mbd-first-runs-") as scratch:
        caches = args.caches or (Path(scratch) if args.compile else None)
        compiled = compile_engine(caches) if args.compile else None
        runs = first_runs(caches, args)
    text = report(compiled, runs)
    print(text, end="")
    if args.out:
        args.out.write_text(text)
    return 1 if any(r["ours"] or r["numba"] for r in runs) else 0


if __name__ == "__main__":
    sys.exit(main())
