"""numpy engine against compiled engine: run time, agreement, compile time (first run and cached).

    .venv/bin/python benchmarks/engines.py                 # benchmark scenes at rtol = 1e-6, 1e-9
    .venv/bin/python benchmarks/engines.py --autograder    # DOP853 rtol 1e-12 atol 1e-14, autograder scenes
    .venv/bin/python benchmarks/engines.py --first         # also a first run in a fresh cache (child process)
    .venv/bin/python benchmarks/engines.py --calibrate     # the auto rule against measurement (new processes)

For each dynamic scene: the numpy engine's wall time, the compiled engine's warm wall time (module loaded,
machine code in memory: what a run costs once compiled), the largest difference of q between the two
relative to max |q|, and right-hand-side evaluations. ``--first`` times, in child processes with an empty
scene cache (``MBD_COMPILED_CACHE``), the first run of a scene (generate + compile this scene's right-hand
side; the loops and kernels are compiled once per machine and cached beside the package) and a second
process with that cache (load only). Wall times are medians of ``--repeats`` runs; BLAS pinned to one thread.
Prints Markdown tables. Never asserted anywhere: timing depends on the machine.
"""

from __future__ import annotations

import argparse
import glob
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from solutions.assembly import build_system  # noqa: E402
from solutions.dynamics import forward_dynamics  # noqa: E402
from solutions.io import load_model  # noqa: E402

BENCH_SCENES = {  # the scenes of benchmarks/results/bench.md that the compiled engine covers
    "double_pendulum": ("course/models/double_pendulum.yaml", 2.0),
    "slider_crank_flywheel": ("course/models/slider_crank_flywheel.yaml", 1.0),
    "spatial_double_pendulum": ("course/models/spatial_double_pendulum.yaml", 2.0),
    "four_bar_spring": ("course/models/four_bar_spring.yaml", 2.0),
    "heavy_top": ("course/models/heavy_top.yaml", 2.0),
}


def timed(system, q0, qd0, t_end, engine, repeats, **kwargs):
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = forward_dynamics(system, q0, qd0, t_end, 100, engine=engine, **kwargs)
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def compare(name, path, t_end, rtol, atol, repeats):
    system, q0, qd0 = build_system(load_model(ROOT / path))
    kwargs = dict(formulation="baumgarte", integrator="DOP853", rtol=rtol, atol=atol)
    forward_dynamics(system, q0, qd0, t_end, 100, engine="compiled", **kwargs)  # compile or load: not timed
    t_numpy, a = timed(system, q0, qd0, t_end, "numpy", repeats, **kwargs)
    t_compiled, b = timed(system, q0, qd0, t_end, "compiled", repeats, **kwargs)
    engine = b.info["chosen"]["engine"]
    diff = float(np.max(np.abs(a.q - b.q)) / max(np.max(np.abs(a.q)), 1e-300))
    return (
        f"| {name} | {t_end:g} | {rtol:g} | {engine} | {t_numpy * 1e3:.1f} | {t_compiled * 1e3:.1f} | "
        f"{t_numpy / t_compiled:.1f} | {diff:.1e} | {a.info['rhs_evaluations']} | {b.info['rhs_evaluations']} |"
    )


FIRST_RUN = """
import sys, time
t = time.perf_counter()
from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.io import load_model
system, q0, qd0 = build_system(load_model(sys.argv[1]))
r = forward_dynamics(system, q0, qd0, 0.01, 2, formulation="baumgarte", integrator="DOP853", engine="compiled")
print(time.perf_counter() - t, r.info["chosen"]["engine"])
"""


def first_runs(scenes):
    print("\n| scene | first process, empty scene cache (s) | second process, cached (s) | numpy engine process (s) |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "MBD_COMPILED_CACHE": cache, "PYTHONPATH": str(ROOT)}
        for name, (path, _) in scenes.items():
            out = []
            for _ in range(2):
                run = subprocess.run([sys.executable, "-c", FIRST_RUN, str(ROOT / path)], env=env, capture_output=True,
                                     text=True, check=True)  # fmt: skip
                out.append(float(run.stdout.split()[0]))
            code = FIRST_RUN.replace('"compiled"', '"numpy"')
            run = subprocess.run(
                [sys.executable, "-c", code, str(ROOT / path)], env=env, capture_output=True, text=True
            )
            print(f"| {name} | {out[0]:.2f} | {out[1]:.2f} | {float(run.stdout.split()[0]):.2f} |")


CHILD_RUN = """
import json, sys, time
from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.io import load_model
system, q0, qd0 = build_system(load_model(sys.argv[1]))
start = time.perf_counter()
r = forward_dynamics(system, q0, qd0, float(sys.argv[2]), 100, formulation="baumgarte", integrator="dop853",
                     rtol=float(sys.argv[3]), atol=float(sys.argv[3]), engine=sys.argv[4])
info = r.info.get("compiled", {})
print(json.dumps({"wall": time.perf_counter() - start, "load": info.get("load_seconds", 0.0),
                  "cached": info.get("cached", False), "engine": r.info.get("chosen", {}).get("engine", "numpy"),
                  "why": r.info.get("chosen", {}).get("engine_why", "")}))
"""


def _child(env, path, t_end, rtol, engine):
    import json

    out = subprocess.run(
        [sys.executable, "-c", CHILD_RUN, str(ROOT / path), str(t_end), str(rtol), engine],
        env=env, capture_output=True, text=True, check=True,
    )  # fmt: skip
    return json.loads(out.stdout.strip().splitlines()[-1])


def calibrate(scenes, spans=(0.1, 1.0, 10.0, 100.0), rtol=1e-8):
    """The auto rule against measurement: for each scene and time span, in fresh processes, the numpy run, the
    compiled run with an empty cache (compiling) and with a warm one (loading), what ``auto`` chose in each case,
    and the numpy run time the rule estimated."""
    from solutions.compiled import dispatch

    print(
        f"\nAuto rule (dispatch.py): compiled when the estimated numpy run exceeds LOAD_SECONDS = "
        f"{dispatch.LOAD_SECONDS:g} s (code cached) or COMPILE_SECONDS = {dispatch.COMPILE_SECONDS:g} s (not cached). "
        f"DOP853 (this package's loop) at rtol = atol = {rtol:g}, 100 output steps; every time is a whole process's "
        "`forward_dynamics` call (wall s), each run in a new process.\n"
    )
    print(
        "| scene | t_end (s) | numpy run (s) | estimated (s) | compiled, empty cache (s) | of which compiling (s) "
        "| compiled, cached (s) | of which loading (s) | auto, empty cache | best | auto, cached | best |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---|---|---|---|")
    for name, (path, _) in scenes.items():
        for t_end in spans:
            with tempfile.TemporaryDirectory() as cache:
                env = {**os.environ, "MBD_COMPILED_CACHE": cache, "PYTHONPATH": str(ROOT)}
                numpy_run = _child(env, path, t_end, rtol, "numpy")
                auto_empty = _child(env, path, t_end, rtol, "auto")  # compiles only when it chooses to
                first = _child(env, path, t_end, rtol, "compiled")  # may already be cached by auto's run
                if first["cached"]:
                    with tempfile.TemporaryDirectory() as other:
                        first = _child({**env, "MBD_COMPILED_CACHE": other}, path, t_end, rtol, "compiled")
                cached = _child(env, path, t_end, rtol, "compiled")
                auto_cached = _child(env, path, t_end, rtol, "auto")
            estimate = float(auto_cached["why"].split("estimated at ")[1].split(" s")[0])
            best_empty = "compiled" if first["wall"] < numpy_run["wall"] else "numpy"
            best_cached = "compiled" if cached["wall"] < numpy_run["wall"] else "numpy"
            print(
                f"| {name} | {t_end:g} | {numpy_run['wall']:.3f} | {estimate:.3g} | {first['wall']:.2f} | "
                f"{first['load']:.2f} | {cached['wall']:.3f} | {cached['load']:.3f} | {auto_empty['engine']} | "
                f"{best_empty} | {auto_cached['engine']} | {best_cached} |",
                flush=True,
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--autograder", action="store_true", help="the autograder's reference settings on its scenes")
    parser.add_argument("--first", action="store_true", help="time first (compiling) and cached runs")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--calibrate", action="store_true", help="only the study behind the auto rule")
    args = parser.parse_args()
    if args.calibrate:
        calibrate(BENCH_SCENES)
        return
    header = (
        "| scene | t_end (s) | rtol | engine | numpy (ms) | compiled (ms) | speed-up | max dq / max q "
        "| evaluations numpy | compiled |\n|---|---|---|---|---|---|---|---|---|---|"
    )
    print(header)
    if args.autograder:
        for path in sorted(glob.glob(str(ROOT / "autograder/scenes/*.yaml"))):
            model = load_model(path)
            system, q0, _ = build_system(model)
            if system.degrees_of_freedom <= 0:
                continue
            t_end = float(model.simulation.get("end_time", 1.0))
            name = Path(path).stem
            print(compare(name, os.path.relpath(path, ROOT), t_end, 1e-12, 1e-14, args.repeats), flush=True)
    else:
        for name, (path, t_end) in BENCH_SCENES.items():
            for rtol in (1e-6, 1e-9):
                print(compare(name, path, t_end, rtol, rtol * 1e-2, args.repeats), flush=True)
    if args.first:
        first_runs(BENCH_SCENES)


if __name__ == "__main__":
    main()
