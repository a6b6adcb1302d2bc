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


def _compiled(*names: str) -> bool:
    """Import the engine's modules ``names`` (compiled at import, or loaded from disk; a loop compiled at its first
    call, ``loops.AtFirstCall``, and a module's ``AT_FIRST_CALL`` functions, ``singular``'s, compiled here) and say
    whether none of their functions was compiled (all on disk already)."""
    import importlib

    from numba.core.registry import CPUDispatcher

    modules = [importlib.import_module(f"{__package__}.{name}") for name in names]
    for module in modules:  # the functions a module compiles at their first call, under their signatures
        for name, signature in getattr(module, "AT_FIRST_CALL", {}).items():
            getattr(module, name).compile(signature)
    found = [f for m in modules for f in vars(m).values()]
    if "loops" in names:  # (the kinematic half never imports the loops: it would compile them in its process too)
        from .loops import AtFirstCall

        found += [f.compiled() for f in found if isinstance(f, AtFirstCall)]  # the loops compiled at their first call
    functions = [f for f in found if isinstance(f, CPUDispatcher)]
    return not any(sum(f.stats.cache_misses.values()) for f in functions)


def _integrator_loops() -> bool:
    """The integrator loops and the loops over the output times (``history_kernels``, ``spatial_history_kernels``:
    residuals, reactions, energy; ``element_history_kernels``, ``spatial_element_history_kernels``: what the force
    elements exert), which every dynamic run imports."""
    histories = ("history_kernels", "spatial_history_kernels", "element_history_kernels")
    return _compiled("loops", *histories, "spatial_element_history_kernels")


def _kinematic_loops() -> bool:
    """The kinematic step loop (which the kinematic modules import) and the checks' compiled code (``singular``:
    the Guard, ``branches``, ``structure``: the cut solve's sparsity), which no generated module imports."""
    return _compiled("kinematic_loop", "singular", "branches", "structure")


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
SHARED = {"integrator loops": _integrator_loops, "kinematic loops": _kinematic_loops}
"""The two halves of ``LOOPS``, compiled side by side: neither imports the other."""


def parts(dimension: str) -> list[tuple[str, Callable[[], bool]]]:
    """(name, load) of the generated modules of one dimension; ``load()`` compiles the module or loads it from disk
    and returns whether its machine code was on disk already."""
    steps = [(f"{dimension} {formulation}", _dynamic(dimension, formulation)) for formulation in FORMULATIONS]
    return [*steps, (f"{dimension} kinematic", _kinematic(dimension))]


def _load_parts(names: tuple[str, ...]) -> list[Part]:
    """Compile (or load) parts one after the other in this worker process: a half of the loops, or a group of
    modules (``GROUPS``)."""
    loads = dict(SHARED) | {part: load for dimension in PENDULUMS for part, load in parts(dimension)}
    done = []
    for name in names:
        start = time.perf_counter()
        cached = loads[name]()
        done.append(Part(name, time.perf_counter() - start, cached))
    return done


def _modules(*kinds: str) -> tuple[str, ...]:
    """The modules of the given kinds (formulations, or "kinematic"), of both dimensions, the planar first."""
    return tuple(f"{dimension} {kind}" for kind in kinds for dimension in PENDULUMS)


GROUPS = (
    (("integrator loops",), _modules("joint-coordinates")),
    (tuple(SHARED), _modules("kinematic", "baumgarte", "projection")),
)
"""The modules in two groups (the halves of the loops they need on disk, the modules), each compiled in one process,
one module after the other. The two tree modules (joint coordinates) in one process: their kernels
(``tree_kernels``, ``articulated``: not cached on disk, compiled into the module that calls them) are compiled once
for both where their types agree, where two processes compiled them each (``tree_kernels`` 12.5 -> 10.6 s of CPU in
``mbd compile``'s compile events; ``cut_accelerations`` keeps a version per dimension). They start as soon as the
integrator loops are on disk, while the other process still compiles the kinematic half (the Guard's code, the
longer half), and the other modules' kernels (``kernels.py``, cached) then find much of theirs on disk."""


def compile_engine(progress: bool = True, jobs: int | None = None) -> list[Part]:
    """Compile (or load from disk) every part of the engine, with a progress bar, in ``jobs`` processes (default: one
    per core, at most two): the two halves of the loops first, side by side, then each group of modules (``GROUPS``)
    once the halves it imports are on disk, so that no two processes compile the same code. Every part is compiled
    once, in one process. The loops are reported as one part (``LOOPS``, their two halves' seconds)."""
    import multiprocessing
    import os
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    from tqdm.auto import tqdm

    jobs = jobs or max(1, min(2, os.cpu_count() or 1))
    modules = [name for dimension in PENDULUMS for name, _ in parts(dimension)]
    done: dict[str, Part] = {}
    waiting = list(GROUPS)
    context = multiprocessing.get_context("spawn")  # a fresh interpreter: no numba or LLVM state inherited
    with ProcessPoolExecutor(jobs, mp_context=context) as pool:
        running = {pool.submit(_load_parts, (name,)) for name in SHARED}
        with tqdm(total=1 + len(modules), desc="compiling the engine", unit="part", disable=not progress) as bar:
            while running:
                finished, running = wait(running, return_when=FIRST_COMPLETED)
                for future in finished:
                    for part in future.result():  # a part that failed raises here
                        done[part.name] = part
                        bar.set_postfix_str(part.name)
                        bar.update(part.name not in SHARED or all(name in done for name in SHARED))
                ready = [group for group in waiting if all(name in done for name in group[0])]
                running |= {pool.submit(_load_parts, group[1]) for group in ready}
                waiting = [group for group in waiting if group not in ready]
    halves = [done.pop(name) for name in SHARED]
    loops = Part(LOOPS, sum(half.seconds for half in halves), all(half.cached for half in halves))
    return [loops, *(done[name] for name in modules)]


def add_compile(sub) -> None:
    """``mbd compile``: compile the engine once per machine (an entry point of ``mbd.commands``)."""
    command = sub.add_parser("compile", help="compile the numba engine once per machine: no run waits for it later")
    command.add_argument("--quiet", action="store_true", help="no progress bar")
    command.add_argument("--jobs", type=_positive, help="processes side by side (default: one per core, at most two)")
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


__all__ = ["FORMULATIONS", "GROUPS", "LOOPS", "PENDULUMS", "Part", "SHARED", "add_compile", "compile_engine", "parts"]
