# Generated from solutions/sweep.py by `make modules` (every homework stubbed): do not edit by hand.
"""Parameter sweeps: one model file run over a grid or a random sample of its parameters (``mbd sweep``).

A parameter is a key path into the model file and the values it takes::

    bodies[crank].mass=0.5,1.0,2.0                 a list
    spring_dampers[spring].stiffness=10:100:10     a range start:stop:num (both ends included)
    motors[drive].function.frequency=uniform(5, 15, n=20, seed=1)    a sample (uniform or normal)
    bodies[rod].location[0]=0.2:0.3:3              one element of a vector
    simulation.end_time=0.5,1.0

Sections are selected by element name or index (``bodies[0]``); the ``model.`` prefix may be left out;
``stiffness``, ``damping`` and ``omega`` are accepted for ``spring_coefficient``, ``damping_coefficient``
and a harmonic function's ``frequency``. The sets are the full grid of the parameters' values, or the
values taken together (``zipped=True``: all parameters give the same number of values).

Outputs are summaries of one column of the result (``max(slider.x)``, ``min``, ``mean``, ``rms``,
``absmax``, ``final``, ``initial``) or ``residual`` (the run's largest constraint residual). A motor's
``MOTOR.torque`` / ``MOTOR.force`` is its ``MOTOR.effort`` (an inverse analysis computes it). A run that
fails gives NaN outputs, ``status`` 'failed' and the reason.

Every key, value and output is checked before any run starts (``SweepError``: the message names the key
and the fix). Runs go where ``batch.cluster_for`` says: one by one in this process (``jobs=1``) or over a
Dask cluster (a ``LocalCluster`` of ``jobs`` worker processes, or an existing scheduler by address); only
this process writes the table, atomically, so a stopped sweep resumes where it stopped. Results are the same
wherever they run: each run depends only on its parameter set (the numpy engine, one BLAS thread per worker:
``solutions`` sets it before numpy loads, in this process and so in the workers it starts).
"""

from __future__ import annotations

import copy
import csv
import difflib
import hashlib
import itertools
import json
import math
import re
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import batch
from .batch import write_atomic
from .settings import SettingError, read_settings

SECTIONS = ("bodies", "joints", "motors", "spring_dampers", "forces")
SECTION_KIND = {"joints": "joint", "motors": "motor", "spring_dampers": "spring", "forces": "force"}
"""Default names of unnamed elements, as the model loader gives them (``spring1``, ``force2``, ...)."""
ALIASES = {"stiffness": "spring_coefficient", "damping": "damping_coefficient", "omega": "frequency"}
SUMMARIES = ("max", "min", "mean", "rms", "absmax", "final", "initial")
"""What an output may take of a column: ``max(slider.x)``, ``rms(drive.effort)``, ..."""
DISTRIBUTIONS = ("uniform", "normal")
ENGINES = ("numpy", "compiled")
"""Engines a sweep runs on: never ``auto``, whose choice depends on each machine's compile cache."""
WRITE_EVERY = 1.0
"""Seconds between rewrites of the partial table while a sweep runs (and always at its end)."""


class SweepError(ValueError):
    """A sweep that cannot start: a bad key, value, output or option (the message says the fix)."""


# -- parameters ---------------------------------------------------------------------------------------------
@dataclass
class Parameter:
    """One swept key: its path in the file's data and the values it takes."""

    key: str
    path: list
    values: np.ndarray
    integer: bool = False


_TOKEN = re.compile(r"\.?([A-Za-z_][A-Za-z0-9_]*)|\[([^\]]*)\]")


def _tokens(key: str) -> list[str | int | tuple]:
    """'bodies[crank].location[0]' -> ['bodies', ('crank',), 'location', 0]; a name selector is a tuple."""
    out: list = []
    pos = 0
    for match in _TOKEN.finditer(key):
        if match.start() != pos:
            break
        name, selector = match.groups()
        if name is not None:
            out.append(name)
        else:
            selector = selector.strip()
            out.append(int(selector) if re.fullmatch(r"-?\d+", selector) else (selector,))
        pos = match.end()
    if pos != len(key) or not out or not isinstance(out[0], str):
        raise SweepError(
            f"--set {key}: not a key path; write e.g. bodies[crank].mass, motors[drive].function.frequency, "
            "spring_dampers[0].spring_coefficient or simulation.end_time"
        )
    return out


def resolve_key(data: dict, key: str) -> list:
    """The path of ``key`` in a model file's data (``data['model']['bodies'][0]['mass']`` as a list of keys).

    Raises
    ------
    SweepError
        If the key does not name a number in the file; the message lists what is there.
    """
    tokens = _tokens(key)
    if tokens[0] == "model":
        tokens = tokens[1:]
    path: list = ["simulation"] if tokens and tokens[0] == "simulation" else ["model"]
    if path == ["simulation"]:
        tokens = tokens[1:]
        node = data.setdefault("simulation", {})
    else:
        node = data["model"]
    where = path[0]
    for k, token in enumerate(tokens):
        if isinstance(token, str):
            if not isinstance(node, dict):
                raise SweepError(f"--set {key}: {where} is not a mapping (it holds {node!r})")
            if token not in node and token in ALIASES and ALIASES[token] in node:
                token = ALIASES[token]
            if token not in node and k == len(tokens) - 1 and _optional_number(data, [*path, token], node):
                path.append(token)
                return path  # a number the file leaves at its default (e.g. a body's angular_velocity)
            if token not in node:
                if where == "model" and token in ("bodies", *SECTIONS):
                    raise SweepError(f"--set {key}: the model has no {token}")
                keys = [k2 for k2 in node if k2 != "name"]
                close = difflib.get_close_matches(token, [*keys, *ALIASES], n=1)
                hint = f"; did you mean {ALIASES.get(close[0], close[0])}?" if close else ""
                if where == "simulation":
                    hint += "; a setting must be in the file's simulation block to be swept"
                raise SweepError(f"--set {key}: {where} has no key '{token}' (keys: {', '.join(keys)}){hint}")
            node, where = node[token], f"{where}.{token}" if where else token
            path.append(token)
            continue
        index = _list_index(key, node, token, path, where)
        label = node[index].get("name", index) if isinstance(node[index], dict) else index
        node, where = node[index], f"{where}[{label}]"
        path.append(index)
    if isinstance(node, bool) or not isinstance(node, int | float):
        if isinstance(node, list):
            raise SweepError(f"--set {key}: {where} is a list of {len(node)}; sweep one element, e.g. {key}[0]")
        if isinstance(node, dict):
            raise SweepError(f"--set {key}: {where} is a mapping (keys: {', '.join(node)}); sweep one of its numbers")
        raise SweepError(f"--set {key}: {where} holds {node!r}, not a number; only numbers can be swept")
    return path


def _list_index(key: str, node, token: int | tuple, path: list, where: str) -> int:
    """The index in the list ``node`` that ``token`` names: a number, or (name,) an element's name (an unnamed
    element of a section is called as the model loader calls it: ``spring1``, ``force2``, ...)."""
    if not isinstance(node, list):
        raise SweepError(f"--set {key}: {where} is not a list")
    if not isinstance(token, tuple):
        if not -len(node) <= token < len(node):
            raise SweepError(f"--set {key}: {where} has {len(node)} elements, no index {token}")
        return token
    section = path[-1] if len(path) == 2 and path[0] == "model" else None
    default = SECTION_KIND.get(section or "")
    names = [
        item.get("name", f"{default}{i + 1}" if default else str(i)) if isinstance(item, dict) else str(i)
        for i, item in enumerate(node)
    ]
    if token[0] not in names:
        raise SweepError(f"--set {key}: no element named '{token[0]}' in {where} (names: {', '.join(names)})")
    return names.index(token[0])


def _optional_number(data: dict, path: list, node: dict) -> bool:
    """Whether the file may set the number at ``path``, absent from it: the model stays valid with it, and it is
    not a key of a function mapping (whose keys depend on its type)."""
    from .functions import FUNCTION_TYPES
    from .io.model import ModelError, load_model

    if node.get("type") in FUNCTION_TYPES:
        return False
    trial = copy.deepcopy(data)
    _assign(trial, path, 1.0)
    try:
        load_model(trial)
    except ModelError as err:
        return "no key" not in str(err) and "unknown" not in str(err) and "not allowed" not in str(err)
    return True


def parse_values(text: str, key: str = "KEY") -> np.ndarray:
    """VALUES of ``--set KEY=VALUES``: '1,2,3', 'start:stop:num', 'uniform(low, high, n=N, seed=S)' or
    'normal(mean, std, n=N, seed=S)' (seed defaults to 0, so a sample is the same on every run)."""
    text = text.strip()
    fix = (
        f"--set {key}={text}: write a list (0.5,1,2), a range start:stop:num (0.5:2:4) or a sample "
        "uniform(low, high, n=20, seed=1) / normal(mean, std, n=20, seed=1)"
    )
    match = re.fullmatch(r"([a-z]+)\((.*)\)", text)
    try:
        if match:
            kind, inside = match.groups()
            if kind not in DISTRIBUTIONS:
                raise SweepError(f"--set {key}={text}: unknown distribution '{kind}' (one of: uniform, normal)")
            args, options = [], {}
            for part in (p.strip() for p in inside.split(",")):
                if "=" in part:
                    name, _, value = part.partition("=")
                    options[name.strip()] = value.strip()
                else:
                    args.append(float(part))
            unknown = set(options) - {"n", "seed"}
            if len(args) != 2 or "n" not in options or unknown:
                raise SweepError(fix)
            n, seed = int(options["n"]), int(options.get("seed", 0))
            if n < 1:
                raise SweepError(f"--set {key}={text}: n must be >= 1")
            rng = np.random.default_rng(seed)
            if kind == "uniform":
                values = rng.uniform(args[0], args[1], n)
            else:
                if args[1] < 0:
                    raise SweepError(f"--set {key}={text}: the standard deviation must be >= 0")
                values = rng.normal(args[0], args[1], n)
        elif text.count(":") == 2:
            start, stop, num = text.split(":")
            if not re.fullmatch(r"\s*\d+\s*", num) or int(num) < 1:
                raise SweepError(f"--set {key}={text}: num in start:stop:num must be a whole number >= 1")
            values = np.linspace(float(start), float(stop), int(num))
        else:
            values = np.array([float(v) for v in text.split(",") if v.strip()], dtype=float)
    except SweepError:
        raise
    except ValueError:
        raise SweepError(fix) from None
    if values.size == 0:
        raise SweepError(fix)
    if not np.all(np.isfinite(values)):
        raise SweepError(f"--set {key}={text}: every value must be a finite number")
    return values


def parse_set(text: str) -> tuple[str, np.ndarray]:
    """'KEY=VALUES' -> (key, values)."""
    key, sep, values = text.partition("=")
    if not sep or not key.strip():
        raise SweepError(f"--set {text}: write KEY=VALUES, e.g. bodies[crank].mass=0.5:2:4")
    return key.strip(), parse_values(values, key.strip())


def _get(data: dict, path: list):
    node = data
    for token in path:
        node = node[token]
    return node


def _assign(data: dict, path: list, value: float) -> None:
    node = data
    for token in path[:-1]:
        node = node[token]
    node[path[-1]] = value


def apply(data: dict, parameters: list[Parameter], values: Iterable[float]) -> dict:
    """A copy of the file's data with each parameter set to its value."""
    data = copy.deepcopy(data)
    for parameter, value in zip(parameters, values, strict=True):
        _assign(data, parameter.path, int(round(value)) if parameter.integer else float(value))
    return data


# -- outputs ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Output:
    """A summary of a run: ``summary(column)``, or ``residual`` (the largest constraint residual)."""

    text: str
    summary: str
    column: str | None = None


def parse_output(text: str) -> Output:
    """'max(slider.x)', 'rms(drive.torque)', 'final(rocker.phi)', 'residual'."""
    text = text.strip()
    if text == "residual":
        return Output(text, "residual")
    match = re.fullmatch(r"([a-z]+)\(\s*([^()\s]+)\s*\)", text)
    if not match or match[1] not in SUMMARIES:
        raise SweepError(
            f"--output {text}: write SUMMARY(COLUMN) with SUMMARY one of {', '.join(SUMMARIES)} "
            "(e.g. max(slider.x), rms(drive.effort)), or residual"
        )
    column = match[2]
    head, _, tail = column.rpartition(".")
    if tail in ("torque", "force"):
        column = f"{head}.effort"
    return Output(text, match[1], column)


def summarize(output: Output, columns: dict[str, np.ndarray], info: dict) -> float:
    """The value of ``output`` for one result (its columns and info)."""
    if output.summary == "residual":
        return float(info.get("max_constraint_residual", math.nan))
    values = np.asarray(columns[output.column], dtype=float)
    if output.summary == "max":
        return float(np.max(values))
    if output.summary == "min":
        return float(np.min(values))
    if output.summary == "mean":
        return float(np.mean(values))
    if output.summary == "rms":
        return float(np.sqrt(np.mean(values**2)))
    if output.summary == "absmax":
        return float(np.max(np.abs(values)))
    if output.summary == "final":
        return float(values[-1])
    return float(values[0])


# -- one run ------------------------------------------------------------------------------------------------
@dataclass
class Sweep:
    """A checked sweep: the model file's data, its parameters, the sets of values, outputs and settings."""

    source: str
    data: dict
    parameters: list[Parameter]
    sets: np.ndarray
    outputs: list[Output]
    settings: dict = field(default_factory=dict)
    zipped: bool = False

    @property
    def fingerprint(self) -> str:
        """Changes with the model's content, the parameters and their values, the outputs and the settings."""
        digest = hashlib.sha256(json.dumps(self.data, sort_keys=True, default=str).encode())
        digest.update(json.dumps([p.key for p in self.parameters]).encode())
        digest.update(np.ascontiguousarray(self.sets).tobytes())
        digest.update(json.dumps([o.text for o in self.outputs]).encode())
        digest.update(json.dumps(self.settings, sort_keys=True, default=str).encode())
        return digest.hexdigest()[:16]

    @property
    def columns(self) -> list[str]:
        """Columns of the table: run, each parameter, each output, status, reason."""
        return ["run", *[p.key for p in self.parameters], *[o.text for o in self.outputs], "status", "reason"]


def run_one(data: dict, parameters: list[Parameter], values: tuple, outputs: list[Output], settings: dict) -> dict:
    """Run one parameter set; returns {'outputs': [...], 'status': 'ok' | 'failed', 'reason': str}.

    Never raises for a run that fails (a mechanism that cannot assemble, an integrator that stops): the
    reason is in the row. Depends on nothing but its arguments, so it gives the same numbers anywhere.
    """
    from .analysis import run_analysis
    from .assembly import build_system
    from .io.model import load_model
    from .io.results import result_columns

    try:
        model = load_model(apply(data, parameters, values))
        system, q0, qd0 = build_system(model)
        result = run_analysis(system, q0, qd0, read_settings(model.simulation, **settings))
        columns = result_columns(result)
        row = [summarize(o, columns, result.info) for o in outputs]
        return {"outputs": row, "status": "ok", "reason": ""}
    except Exception as err:  # noqa: BLE001 - a failed run is a result of the sweep, with its reason
        reason = f"{type(err).__name__}: {err}".replace("\n", " ")
        return {"outputs": [math.nan] * len(outputs), "status": "failed", "reason": reason[:500]}


def _run_task(sweep_data: tuple, index: int) -> dict:
    """One task of ``batch.run``: the row of set number ``index``."""
    data, parameters, sets, outputs, settings = sweep_data
    return run_one(data, parameters, tuple(sets[index]), outputs, settings)


# -- building and checking a sweep -------------------------------------------------------------------------------
def _available_columns(data: dict, settings: dict) -> tuple[set[str], str]:
    """The result columns of the base model's analysis, from a 2-step run of 1/1000 of its duration."""
    from .analysis import run_analysis
    from .assembly import build_system
    from .io.model import load_model
    from .io.results import result_columns

    model = load_model(data)
    system, q0, qd0 = build_system(model)
    probe = read_settings(model.simulation, **settings)
    probe = probe.replace(t_end=probe.t_end * 1e-3, steps=2)
    result = run_analysis(system, q0, qd0, probe)
    return set(result_columns(result)), result.info.get("analysis", "")


def make_sweep(
    model: str | Path | dict,
    sets: list[str] | dict[str, Iterable[float] | str],
    outputs: list[str] | None = None,
    *,
    zipped: bool = False,
    analysis: str | None = None,
    t_end: float | None = None,
    steps: int | None = None,
    engine: str = "numpy",
) -> Sweep:
    """Check a sweep before any run: every key resolves to a number in the file, every value makes a valid
    model file, every output names a column the analysis gives.

    Parameters
    ----------
    model : model file path, or its data ``{"model": ..., "simulation": ...}``
    sets : ``["KEY=VALUES", ...]`` as on the command line, or ``{KEY: values or 'VALUES'}``
    outputs : ``["max(slider.x)", "residual", ...]`` (default: ``["residual"]``)
    zipped : take the parameters' values together (same count) instead of their full grid
    analysis, t_end, steps : override the file's simulation block
    engine : 'numpy' (default) or 'compiled'

    Raises
    ------
    SweepError
        Naming the key, value or output and the fix. A model file that cannot be read raises ``ModelError``.
    """
    from .io.model import load_model, read_text

    if isinstance(model, dict):
        data, source = copy.deepcopy(model), "<model>"
    else:
        data, source = read_text(Path(model)), str(model)
    base = load_model(data)  # the file itself is valid (ModelError naming the file otherwise)
    label = base.source if source == "<model>" else Path(source).name
    pairs = list(sets.items()) if isinstance(sets, dict) else [parse_set(text) for text in sets]
    if not pairs:
        raise SweepError("nothing to sweep: give at least one --set KEY=VALUES")
    if engine not in ENGINES:
        raise SweepError(f"--engine {engine}: a sweep runs on one of: {', '.join(ENGINES)}")
    settings = {"analysis": analysis, "t_end": t_end, "steps": steps, "engine": engine}
    try:
        read_settings(base.simulation, **settings)
    except SettingError as err:
        raise SweepError(str(err)) from None
    parameters, seen = [], set()
    for key, values in pairs:
        parameters.append(make_parameter(data, key, values, seen))
    table = parameter_table(parameters, zipped)
    parsed = [parse_output(o) for o in (outputs or ["residual"])]
    if len({o.text for o in parsed}) != len(parsed):
        raise SweepError("--output: an output is given twice")
    if any(o.column for o in parsed):
        check_outputs(data, parsed, settings, label)
    settings = {k: v for k, v in settings.items() if v is not None}
    return Sweep(source, data, parameters, table, parsed, settings, zipped)


def make_parameter(data: dict, key: str, values, seen: set) -> Parameter:
    """One swept key: its path in the file, its values (whole numbers where the file has one), each value
    checked to make a valid model file; ``seen`` holds the paths taken so far (a key set twice is refused)."""
    from .io.model import ModelError, load_model

    values = parse_values(values, key) if isinstance(values, str) else np.asarray(list(values), dtype=float)
    path = resolve_key(data, key)
    if tuple(path) in seen:
        raise SweepError(f"--set {key}: this key is set twice; give its values once")
    seen.add(tuple(path))
    try:
        current = _get(data, path)
    except KeyError:  # a number the file leaves at its default
        current = None
    integer = isinstance(current, int) and not isinstance(current, bool)
    if integer and not np.all(values == np.round(values)):
        raise SweepError(f"--set {key}: {key} takes whole numbers (the file has {current})")
    parameter = Parameter(key, path, values, integer)
    for value in np.unique(values):
        try:
            load_model(apply(data, [parameter], [value]))
        except ModelError as err:
            message = str(err).removeprefix("<model>: ")
            raise SweepError(f"--set {key}={value:g}: {message}") from None
    return parameter


def parameter_table(parameters: list[Parameter], zipped: bool) -> np.ndarray:
    """The sets of values, one row per run: the full grid of the parameters' values, or (``zipped``) their
    values taken together."""
    if not zipped:
        return np.array(list(itertools.product(*[p.values for p in parameters])), dtype=float)
    counts = {p.key: p.values.size for p in parameters}
    if len(set(counts.values())) != 1:
        listed = ", ".join(f"{k}: {n}" for k, n in counts.items())
        raise SweepError(f"--zip takes the same number of values for every key ({listed}); or drop --zip")
    return np.column_stack([p.values for p in parameters])


def check_outputs(data: dict, outputs: list[Output], settings: dict, label: str) -> None:
    """Refuse an output whose column the analysis does not give (from a short run of the base model)."""
    try:
        available, ran = _available_columns(data, settings)
    except Exception as err:  # noqa: BLE001 - the base model must run to say what columns it has
        raise SweepError(f"{label}: the model as the file gives it does not run ({err})") from None
    for o in outputs:
        if o.column and o.column not in available:
            hint = ""
            if o.column.endswith((".effort", ".Fx", ".Fy", ".Fz", ".Mx", ".My", ".Mz")):
                hint = "; driver efforts come from --analysis inverse, joint reactions from inverse or dynamic"
            names = ", ".join(sorted(available - {"t"}))
            said = f"--output {o.text}: the {ran} analysis gives no column {o.column}"
            raise SweepError(f"{said}{hint} (columns: {names})")


# -- the table ---------------------------------------------------------------------------------------------------
def _format(value: float) -> str:
    return repr(float(value)) if not math.isnan(value) else "nan"


def write_table(sweep: Sweep, rows: dict[int, dict], out_dir: Path) -> Path:
    """``sweep.csv`` (rows done so far, by run number) and ``sweep.json`` (what the sweep is), atomically."""
    out_dir.mkdir(parents=True, exist_ok=True)

    def write_csv(tmp: Path) -> None:
        with open(tmp, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(sweep.columns)
            for index in sorted(rows):
                row = rows[index]
                params = [_format(v) for v in sweep.sets[index]]
                writer.writerow([index, *params, *[_format(v) for v in row["outputs"]], row["status"], row["reason"]])

    manifest = {
        "model": sweep.source,
        "fingerprint": sweep.fingerprint,
        "parameters": [p.key for p in sweep.parameters],
        "outputs": [o.text for o in sweep.outputs],
        "settings": sweep.settings,
        "zipped": sweep.zipped,
        "runs": len(sweep.sets),
    }
    write_atomic(out_dir / "sweep.json", lambda tmp: tmp.write_text(json.dumps(manifest, indent=1)))
    path = out_dir / "sweep.csv"
    write_atomic(path, write_csv)
    return path


def read_table(sweep: Sweep, out_dir: Path) -> dict[int, dict]:
    """Rows of an earlier run of the same sweep in ``out_dir`` (none when the sweep or its files differ)."""
    try:
        manifest = json.loads((out_dir / "sweep.json").read_text())
        if manifest.get("fingerprint") != sweep.fingerprint:
            return {}
        with open(out_dir / "sweep.csv", newline="") as f:
            reader = csv.reader(f)
            if next(reader) != sweep.columns:
                return {}
            rows = {}
            n_out = len(sweep.outputs)
            first = 1 + len(sweep.parameters)
            for line in reader:
                index = int(line[0])
                values = [float(v) for v in line[first : first + n_out]]
                rows[index] = {"outputs": values, "status": line[-2], "reason": line[-1]}
            return {k: v for k, v in rows.items() if 0 <= k < len(sweep.sets)}
    except (OSError, ValueError, StopIteration, IndexError):
        return {}


def write_npz(sweep: Sweep, rows: dict[int, dict], out_dir: Path) -> Path:
    """``sweep.npz``: run, each parameter and output by its text, status, reason (same as the CSV)."""
    order = sorted(rows)
    arrays: dict[str, np.ndarray] = {"run": np.array(order, dtype=int)}
    for k, p in enumerate(sweep.parameters):
        arrays[p.key] = sweep.sets[order, k] if order else np.zeros(0)
    for k, o in enumerate(sweep.outputs):
        arrays[o.text] = np.array([rows[i]["outputs"][k] for i in order], dtype=float)
    arrays["status"] = np.array([rows[i]["status"] for i in order], dtype=str)
    arrays["reason"] = np.array([rows[i]["reason"] for i in order], dtype=str)
    path = out_dir / "sweep.npz"

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)

    write_atomic(path, write)
    return path


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_")


def plot_sweep(sweep: Sweep, rows: dict[int, dict], out_dir: Path) -> list[Path]:
    """One PNG per output, ``plots/OUTPUT.png``: the output against each parameter (a panel each);
    failed runs are marked with a cross on the axis."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = out_dir / "plots"
    folder.mkdir(parents=True, exist_ok=True)
    order = sorted(rows)
    paths = []
    for k, output in enumerate(sweep.outputs):
        y = np.array([rows[i]["outputs"][k] for i in order], dtype=float)
        failed = np.array([rows[i]["status"] != "ok" for i in order], dtype=bool)
        n = len(sweep.parameters)
        fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 3.4), squeeze=False, constrained_layout=True)
        for j, (ax, parameter) in enumerate(zip(axes[0], sweep.parameters, strict=True)):
            x = sweep.sets[order, j]
            ax.plot(x[~failed], y[~failed], "o", ms=4, alpha=0.8)
            if failed.any():
                base = np.nanmin(y) if np.isfinite(y).any() else 0.0
                ax.plot(x[failed], np.full(failed.sum(), base), "x", color="red", label="failed")
                ax.legend(loc="best", fontsize=8)
            ax.set_xlabel(parameter.key)
            ax.set_ylabel(output.text)
            ax.grid(True, alpha=0.3)
        fig.suptitle(f"{Path(sweep.source).stem}: {output.text}")
        path = folder / f"{_slug(output.text)}.png"
        write_atomic(path, lambda tmp, fig=fig: fig.savefig(tmp, dpi=110, format="png"))
        plt.close(fig)
        paths.append(path)
    return paths


# -- the whole sweep ------------------------------------------------------------------------------------------------
@dataclass
class SweepResult:
    """What ``run_sweep`` did: the rows by run number, the files it wrote, how many were resumed."""

    sweep: Sweep
    rows: dict[int, dict]
    files: list[Path] = field(default_factory=list)
    resumed: int = 0
    seconds: float = 0.0

    @property
    def failed(self) -> int:
        return sum(row["status"] != "ok" for row in self.rows.values())

    def column(self, name: str) -> np.ndarray:
        """A parameter's values or an output's values over the runs, in run order."""
        order = sorted(self.rows)
        keys = [p.key for p in self.sweep.parameters]
        if name in keys:
            return self.sweep.sets[order, keys.index(name)]
        texts = [o.text for o in self.sweep.outputs]
        return np.array([self.rows[i]["outputs"][texts.index(name)] for i in order])


def run_sweep(
    sweep: Sweep,
    out_dir: str | Path | None = None,
    jobs: int = 1,
    cluster: str | None = None,
    *,
    progress: bool = True,
    resume: bool = True,
    plots: bool = True,
) -> SweepResult:
    """Run every parameter set of ``sweep``; write ``sweep.csv``, ``sweep.npz`` and ``plots/`` to ``out_dir``.

    Where the runs go is ``batch.cluster_for(jobs, cluster)``: ``jobs=1`` without ``cluster`` runs here, one
    set after another; otherwise on Dask: a LocalCluster of ``jobs`` worker processes (``cluster`` None or
    'local') or an existing scheduler ('tcp://HOST:PORT'). Only this process writes files, atomically, so a
    sweep that is stopped resumes (``resume``) from the rows it has. A worker that dies has its runs retried
    elsewhere; each run is counted once.

    Raises
    ------
    SweepError
        For a bad ``jobs`` or ``cluster``, or a scheduler that cannot be reached.
    """
    start = time.perf_counter()
    out = Path(out_dir) if out_dir is not None else None
    rows: dict[int, dict] = read_table(sweep, out) if (out is not None and resume) else {}
    resumed = len(rows)
    try:
        _run_sets(sweep, rows, out, jobs, cluster, progress)
        files = _write_outputs(sweep, rows, out, plots)
    except batch.BatchError as err:
        raise SweepError(str(err)) from None
    except KeyboardInterrupt:  # while running, or while writing the files at the end
        if out is not None and rows:
            write_table(sweep, rows, out)  # every finished run, so that the same command resumes from it
        raise KeyboardInterrupt(
            f"{len(rows)} of {len(sweep.sets)} runs done, run the same command again to resume"
        ) from None
    return SweepResult(sweep, rows, files, resumed, time.perf_counter() - start)


def _write_outputs(sweep: Sweep, rows: dict[int, dict], out: Path | None, plots: bool) -> list[Path]:
    """The table, the histories (.npz) and the plots of a finished sweep, in ``out`` (nothing without it)."""
    if out is None:
        return []
    files = [write_table(sweep, rows, out), write_npz(sweep, rows, out)]
    return files + (plot_sweep(sweep, rows, out) if plots and rows else [])


def _run_sets(sweep: Sweep, rows: dict[int, dict], out: Path | None, jobs: int, cluster: str | None, progress: bool):
    """Run the sets not in ``rows`` (``batch.run``), adding each row as it arrives; the table is rewritten at
    most every WRITE_EVERY seconds."""
    payload = (sweep.data, sweep.parameters, sweep.sets, sweep.outputs, sweep.settings)
    sets = {index: index for index in range(len(sweep.sets))}
    last_write = time.perf_counter()
    with batch.executor(jobs, cluster, tasks=len(sets) - len(rows)) as where:
        for finished in batch.run(_run_task, sets, where, shared=payload, done=rows, name="sweep", progress=progress):
            if finished.error is not None:
                raise finished.error
            rows[finished.key] = finished.value
            if out is not None and time.perf_counter() - last_write > WRITE_EVERY:
                write_table(sweep, rows, out)
                last_write = time.perf_counter()
