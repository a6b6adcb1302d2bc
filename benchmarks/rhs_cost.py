"""Microseconds per right-hand side of the compiled engine, per formulation, on the benchmark scenes.

    .venv/bin/python benchmarks/rhs_cost.py                                   # every scene and formulation
    .venv/bin/python benchmarks/rhs_cost.py --scene double_pendulum --formulation joint-coordinates

For each scene of ``benchmarks/bench.py`` and each compiled formulation (baumgarte, projection,
joint-coordinates, loops cut into trees): the scene's generated ``scene_rhs`` is called at the
initial state ``--calls`` times inside compiled code (``repeat`` below: through the same
first-class function the integrator loops call, so the figure is what one evaluation costs in a run), best of
``--repeats``; beside it, one numpy evaluation (``EquationsOfMotion.rhs``, best of as many calls as take
about 0.2 s). A projection run evaluates the Baumgarte right-hand side with alpha = beta = 0 and adds one
projection per step, timed as well from the initial state with its positions moved off the constraints by 1e-9
(relative; a step's error): one Newton correction of the positions, the check, the correction of the velocities.
A scene or formulation the compiled engine does not take prints why.
The first run compiles each structure (seconds each; cached on disk afterwards: ``MBD_COMPILED_CACHE``).
Prints a Markdown table; nothing is asserted (timing depends on the machine).
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import functools  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import yaml  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
MODELS = ROOT / "course" / "models"

from solutions.assembly import build_system  # noqa: E402
from solutions.dynamics import EquationsOfMotion, consistent_initial_conditions  # noqa: E402
from solutions.formulations import make_formulation  # noqa: E402
from solutions.generalized_forces import build_forces  # noqa: E402
from solutions.io import load_model  # noqa: E402
from solutions.mass_matrix import mass_matrix  # noqa: E402


def free_slider_crank() -> dict:
    """slider_crank_flywheel.yaml without its gas force and load torque (as ``bench.free_slider_crank``)."""
    data = yaml.safe_load((MODELS / "slider_crank_flywheel.yaml").read_text())
    data["model"]["forces"] = []
    data["model"]["name"] = "slider-crank-free"
    return data


SCENES = {  # the scenes of benchmarks/bench.py
    "double_pendulum": "double_pendulum.yaml",
    "slider_crank": free_slider_crank,
    "four_bar_spring": "four_bar_spring.yaml",
    "andrews": "andrews.yaml",
    "spatial_double_pendulum": "spatial_double_pendulum.yaml",
    "carriage_pendulum": "carriage_pendulum.yaml",
    "revolute_revolute_skew": "revolute_revolute_skew.yaml",
    "heavy_top": "heavy_top.yaml",
}
FORMULATIONS = ("baumgarte", "projection", "joint-coordinates")


@functools.cache
def repeaters():
    """(repeat, repeat_projection), compiled on first use (cached on disk, as the loops are): ``repeat`` calls
    scene_rhs at (t, z) ``times`` times, ``repeat_projection`` project from the state z ``times`` times, each
    through the same first-class function the integrator loops call, so that the time per call is a run's."""
    from numba import types

    from solutions.compiled import loops

    @loops.jit(types.float64(loops._RHS, types.float64, loops._vector, loops.P_TYPE, loops.D_TYPE, types.int64))
    def repeat(scene_rhs, t, z, P, D, times):
        out = np.empty(z.size)
        total = 0.0
        for _ in range(times):
            scene_rhs(t, z, P, D, out)
            total += out[-1]
        return total

    @loops.jit(types.float64(loops._PROJECT, types.float64, loops._vector, loops.P_TYPE, loops.D_TYPE, types.int64))
    def repeat_projection(project, t, z, P, D, times):
        y, info = np.empty(z.size), np.zeros(1)
        total = 0.0
        for _ in range(times):
            y[:] = z
            total += project(t, y, P, D, info)
        return total

    return repeat, repeat_projection


def cost(source, formulation: str, calls: int, repeats: int) -> tuple[str, str, str, str]:
    """(compiled us per rhs, numpy us per rhs, compiled us per projection, note) of one scene and formulation."""
    from solutions import compiled

    repeat, repeat_projection = repeaters()
    system, q0, qd0 = build_system(load_model(source() if callable(source) else MODELS / source))
    M, forces = mass_matrix(system.model), build_forces(system.model)
    q, qd, _ = consistent_initial_conditions(system, M, q0, qd0)
    try:
        formulation_object = make_formulation(formulation, system, M, forces)
    except Exception as err:  # noqa: BLE001 -- e.g. joint coordinates of a scene that is no tree
        return "-", "-", "-", str(err).split(";")[0]
    equations = EquationsOfMotion(formulation_object, forces, bool(system.model.motors))
    z0 = equations.initial_state(q, qd, 0.0)
    job = compiled.plan(compiled.describe(system, M, forces), formulation, formulation_object)
    why_not = compiled.unsupported(job.scene, formulation, "DOP853", {})
    numpy_us = numpy_cost(equations, z0)
    if why_not is not None:
        return "-", f"{numpy_us:.1f}", "-", f"not compiled: {why_not}"
    start = time.perf_counter()
    module, project, cached = compiled.load(job)
    P, D = compiled.parameters(job.scene, *job.numbers), job.scene.data()
    repeat(module.scene_rhs, 0.0, z0, P, D, 10)
    load = time.perf_counter() - start
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        repeat(module.scene_rhs, 0.0, z0, P, D, calls)
        best = min(best, (time.perf_counter() - start) / calls)
    projection = "-"
    if formulation == "projection":
        n = system.n_coordinates
        off = z0.copy()
        off[:n] += 1e-9 * np.max(np.abs(z0[:n])) * np.random.default_rng(0).standard_normal(n)
        step = np.inf
        for _ in range(repeats):
            start = time.perf_counter()
            repeat_projection(project, 0.0, off, P, D, calls // 10)
            step = min(step, (time.perf_counter() - start) / (calls // 10))
        projection = f"{step * 1e6:.2f}"
    note = "cached" if cached else f"compiled in {load:.1f} s"
    return f"{best * 1e6:.2f}", f"{numpy_us:.1f}", projection, note


def numpy_cost(equations, z0: np.ndarray) -> float:
    """us per numpy evaluation: best of batches of 50 calls over about 0.2 s."""
    best, spent = np.inf, 0.0
    while spent < 0.2:
        start = time.perf_counter()
        for _ in range(50):
            equations.rhs(0.0, z0)
        elapsed = time.perf_counter() - start
        best, spent = min(best, elapsed / 50), spent + elapsed
    return best * 1e6


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--scene", action="append", choices=list(SCENES), help="only these scenes (repeatable)")
    parser.add_argument("--formulation", action="append", choices=FORMULATIONS, help="only these (repeatable)")
    parser.add_argument("--calls", type=int, default=200_000, help="evaluations per timing (default 200000)")
    parser.add_argument("--repeats", type=int, default=5, help="timings per figure, the best kept (default 5)")
    args = parser.parse_args(argv)
    print("| scene | formulation | compiled us / rhs | numpy us / rhs | compiled us / projection | note |")
    print("|---|---|---:|---:|---:|---|")
    for scene in args.scene or SCENES:
        for formulation in args.formulation or FORMULATIONS:
            compiled_us, numpy_us, projection_us, note = cost(SCENES[scene], formulation, args.calls, args.repeats)
            print(f"| {scene} | {formulation} | {compiled_us} | {numpy_us} | {projection_us} | {note} |", flush=True)


if __name__ == "__main__":
    main()
