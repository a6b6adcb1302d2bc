"""Compile the engine once per machine (``mbd compile``): the loops and every generated module, before any run.

The model is data (``codegen.py``): a generated module depends on the dimension and the formulation, never on the
model's bodies, elements or numbers. A planar and a spatial pendulum (``PENDULUMS``) therefore make every module
that any model of the course's element types runs: for each dimension, the scene's module (Baumgarte and the
other body-coordinate formulations), the projection's, the tree's (joint coordinates) and the kinematic one; with
the integrator loops and the kinematic step loop, which every module shares. numba keeps the machine code on disk
(``codegen.cache_directory()`` for the modules, beside the sources for the loops and kernels): afterwards no run
on the machine waits for a compilation, and ``engine="cached"`` (or ``auto``) finds them all.
"""

from __future__ import annotations

import argparse
import functools
import time
from collections.abc import Callable
from dataclasses import dataclass

PENDULUMS = {
    "planar": {"model": {
        "name": "compile-planar", "dimension": 2, "gravity": [0.0, -9.81],
        "bodies": [{"name": "bar", "mass": 1.0, "inertia": 0.02, "location": [0.25, 0.0], "orientation": 0.0}],
        "joints": [{"name": "pin", "type": "revolute", "body1": "ground", "body2": "bar", "location": [0.0, 0.0]}],
    }},
    "spatial": {"model": {
        "name": "compile-spatial", "dimension": 3, "gravity": [0.0, 0.0, -9.81],
        "bodies": [{"name": "bar", "mass": 1.0, "inertia": [0.001, 0.02, 0.02], "location": [0.25, 0.0, 0.0],
                    "orientation": [1.0, 0.0, 0.0, 0.0]}],
        "joints": [{"name": "ball", "type": "spherical", "body1": "ground", "body2": "bar",
                    "location": [0.0, 0.0, 0.0]}],
    }},
}  # fmt: skip
"""One body on one joint per dimension: the smallest models whose scenes make every module of their dimension."""

FORMULATIONS = ("baumgarte", "projection", "joint-coordinates")
"""The compiled formulations with a module of their own (the other body-coordinate ones run the scene's module)."""


@dataclass(frozen=True)
class Part:
    """One part of the engine: what it is, the seconds it took, and whether it was on disk already."""

    name: str
    seconds: float
    cached: bool


def _loops() -> bool:
    from numba.core.registry import CPUDispatcher

    from . import branches, history_kernels, kinematic_loop, loops, singular, structure  # compiled or loaded, at import

    modules = (loops, kinematic_loop, singular, history_kernels, branches, structure)  # history_kernels: reactions
    functions = [f for m in modules for f in vars(m).values() if isinstance(f, CPUDispatcher)]
    return not any(sum(f.stats.cache_misses.values()) for f in functions)


@functools.cache
def _pendulum(dimension: str):
    """The assembled ``System`` of the dimension's pendulum (``PENDULUMS``), built once per process."""
    from ..assembly import build_system
    from ..io import load_model

    return build_system(load_model(PENDULUMS[dimension]))[0]


def _dynamic(dimension: str, formulation: str) -> Callable[[], bool]:
    def load() -> bool:
        from .. import compiled
        from ..formulations import make_formulation
        from ..generalized_forces import build_forces
        from ..mass_matrix import mass_matrix

        system = _pendulum(dimension)
        M, forces = mass_matrix(system.model), build_forces(system.model)
        made = make_formulation(formulation, system, M, forces)
        return compiled.load(compiled.plan(system, M, forces, formulation, made))[2]

    return load


def _kinematic(dimension: str) -> Callable[[], bool]:
    def load() -> bool:
        from . import kinematic
        from .codegen import load_kinematic

        return load_kinematic(kinematic.describe(_pendulum(dimension)))[1]

    return load


LOOPS = "integrator and kinematic loops"


def parts(dimension: str) -> list[tuple[str, Callable[[], bool]]]:
    """(name, load) of the parts of one dimension, the loops first (every module imports them); ``load()``
    compiles the part or loads it from disk and returns whether its machine code was on disk already."""
    steps = [(LOOPS, _loops)]
    steps += [(f"{dimension} {formulation}", _dynamic(dimension, formulation)) for formulation in FORMULATIONS]
    return [*steps, (f"{dimension} kinematic", _kinematic(dimension))]


def _chain(dimension: str, report) -> None:
    """Compile the parts of one dimension in this process, one after the other, each put on ``report`` when done."""
    for name, load in parts(dimension):
        start = time.perf_counter()
        cached = load()
        report.put(Part(name, time.perf_counter() - start, cached))


def compile_engine(progress: bool = True, jobs: int | None = None) -> list[Part]:
    """Compile (or load from disk) every part of the engine, with a progress bar: the dimensions side by side in
    ``jobs`` processes (default: one per dimension, at most one per core; each compiles the loops it needs, or
    loads them when another has put them on disk first), every part reported once."""
    import multiprocessing
    import os
    import queue
    from concurrent.futures import ProcessPoolExecutor

    from tqdm.auto import tqdm

    jobs = jobs or max(1, min(len(PENDULUMS), os.cpu_count() or 1))
    names = list(dict.fromkeys(name for dimension in PENDULUMS for name, _ in parts(dimension)))
    done: dict[str, Part] = {}
    context = multiprocessing.get_context("spawn")  # a fresh interpreter: no numba or LLVM state inherited
    with context.Manager() as manager, ProcessPoolExecutor(jobs, mp_context=context) as pool:
        report = manager.Queue()
        chains = [pool.submit(_chain, dimension, report) for dimension in PENDULUMS]
        with tqdm(total=len(names), desc="compiling the engine", unit="part", disable=not progress) as bar:
            while len(done) < len(names):
                try:
                    part = report.get(timeout=0.5)
                except queue.Empty:
                    for chain in chains:
                        if chain.done():
                            chain.result()  # a chain that failed raises here
                    continue
                if part.name not in done:
                    done[part.name] = part
                    bar.set_postfix_str(part.name)
                    bar.update()
        for chain in chains:
            chain.result()
    return [done[name] for name in names]


def add_compile(sub) -> None:
    """``mbd compile``: compile the engine once per machine (an entry point of ``mbd.commands``)."""
    command = sub.add_parser("compile", help="compile the numba engine once per machine: no run waits for it later")
    command.add_argument("--quiet", action="store_true", help="no progress bar")
    command.add_argument("--jobs", type=_positive, help="processes side by side (default: one per dimension and core)")
    command.set_defaults(handler=_command)


def _positive(text: str) -> int:
    if not text.isdigit() or int(text) < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number of at least 1")
    return int(text)


def _command(args: argparse.Namespace) -> int:
    from .codegen import cache_directory

    start = time.perf_counter()
    done = compile_engine(progress=not args.quiet, jobs=args.jobs)
    for part in done:
        print(f"{part.name:32s} {part.seconds:7.1f} s  {'on disk already' if part.cached else 'compiled'}")
    print(f"the engine is compiled ({time.perf_counter() - start:.1f} s); its modules are in {cache_directory()}")
    return 0


__all__ = ["FORMULATIONS", "LOOPS", "PENDULUMS", "Part", "add_compile", "compile_engine", "parts"]
