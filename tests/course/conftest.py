"""Shared fixtures of the release tests: importing a built student package, and reference calls to replay.

``reference_calls`` runs the reference solver on every example model of ``course/models`` (short runs)
and records, for every function that holds a solution region, the arguments of its first call. Replaying
such a call on a student package's function and on the reference's tells whether a filled-in function
behaves exactly like the reference, and whether a stub raises where it should -- on real states of real
scenes rather than on made-up arguments.
"""

from __future__ import annotations

import copy
import dataclasses
import importlib
import importlib.util
import sys
from pathlib import Path
from types import ModuleType, SimpleNamespace

import numpy as np
import pytest

from course.release.generator import REPO, Region, all_regions

SCENE_T_END = 0.02
SCENE_STEPS = 2


def load_package(path: Path, name: str) -> ModuleType:
    """Import the package in folder ``path`` under the name ``name`` (its imports are relative)."""
    for key in [k for k in sys.modules if k == name or k.startswith(name + ".")]:
        del sys.modules[key]
    spec = importlib.util.spec_from_file_location(name, path / "__init__.py", submodule_search_locations=[str(path)])
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def module_name(region: Region) -> str:
    return Path(region.path).with_suffix("").as_posix().replace("/", ".")


def resolve(package: str, region: Region):
    """The function object of a region's function in ``package`` (None if it cannot be reached by name)."""
    obj = importlib.import_module(f"{package}.{module_name(region)}")
    for part in region.function.split("."):
        obj = getattr(obj, part, None) if isinstance(obj, ModuleType) else vars(obj).get(part)
        if isinstance(obj, staticmethod | classmethod):
            obj = obj.__func__
        if isinstance(obj, property):
            obj = obj.fget
        if obj is None:
            return None
    return obj


def call(func, arguments: dict):
    """('return', value) or ('raise', exception) of func called with a deep copy of recorded arguments."""
    code = func.__code__
    arguments = copy.deepcopy(arguments)
    positional = [arguments.pop(name) for name in code.co_varnames[: code.co_argcount]]
    try:
        return "return", func(*positional, **arguments)
    except Exception as err:  # noqa: BLE001 -- the exception is the result being compared
        return "raise", err


def same(a, b) -> bool:
    """Exact equality of two results: arrays elementwise (NaN equal to NaN), containers and objects by content."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.dtype.kind in "fc" and b.dtype.kind in "fc":
            return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=True))
        return a.shape == b.shape and bool(np.all(a == b))
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (np.isnan(a) and np.isnan(b))
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return type(a) is type(b) and len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, BaseException) and isinstance(b, BaseException):
        return type(a).__name__ == type(b).__name__ and str(a) == str(b)
    if dataclasses.is_dataclass(a) and dataclasses.is_dataclass(b):
        return type(a).__name__ == type(b).__name__ and same(vars(a), vars(b))
    return a == b


def _record(regions: list[Region]) -> dict[tuple[str, str], dict]:
    from solutions.analysis import choose_analysis, run_analysis
    from solutions.assembly import build_system
    from solutions.io.model import load_model
    from solutions.kinematics import assemble
    from solutions.settings import read_settings

    targets = {}
    for region in regions:
        func = resolve("solutions", region)
        if func is not None:
            targets[func.__code__] = (region.path, region.function)
    records: dict[tuple[str, str], dict] = {}

    def profile(frame, event, arg):
        if event == "call":
            key = targets.get(frame.f_code)
            if key is not None and key not in records:
                code = frame.f_code
                names = code.co_varnames[: code.co_argcount + code.co_kwonlyargcount]
                records[key] = copy.deepcopy({name: frame.f_locals[name] for name in names})

    for path in sorted((REPO / "course" / "models").glob("*.yaml")):
        sys.setprofile(profile)
        try:
            model = load_model(path)
            system, q0, qd0 = build_system(model)
            kinematic = choose_analysis(system, assemble(system, q0)[0]) == "kinematic"
            for analysis in ("kinematic", "inverse") if kinematic else ("dynamic",):
                settings = read_settings(model.simulation, analysis=analysis, t_end=SCENE_T_END, steps=SCENE_STEPS)
                run_analysis(system, q0, qd0, settings)
        except Exception:  # noqa: BLE001, S110 -- a scene the reference cannot run still yields the calls made
            pass
        finally:
            sys.setprofile(None)
    return records


@pytest.fixture(scope="session")
def regions() -> list[Region]:
    return all_regions()


@pytest.fixture(scope="session")
def reference_calls(regions) -> dict[tuple[str, str], dict]:
    """{(file, function): arguments of its first call} over short runs of every example model."""
    return _record(regions)


@pytest.fixture(scope="session")
def tools() -> SimpleNamespace:
    return SimpleNamespace(load_package=load_package, resolve=resolve, call=call, same=same, module_name=module_name)
