"""A model as an FMU: FMI 3.0 co-simulation of its analysis, for any tool that imports FMUs (issue 28).

``export_fmu(MODEL, OUT)`` (``mbd export MODEL --to fmu``, or ``python -m solutions.io.fmu MODEL --out FILE.fmu``)
writes a Functional Mock-up Unit built with pythonfmu3 (FMI 3.0, co-simulation). What it holds:

- ``resources/model.yaml``: the model file as written, with its ``simulation`` settings;
- ``resources/solutions/``: this package's source (all but the compiled engine), and ``resources/fastjsonschema/``
  (pure Python, with its licence), so that the FMU runs wherever Python with numpy, scipy and pyyaml is installed,
  without mbd-course (``resources/requirements.txt`` names them, for ``pythonfmu3 deploy``);
  ``resources/fmu_slave.py`` (``fmu_slave.py`` beside this file), the slave class, and ``resources/pythonfmu3/``,
  the library's side of it;
- ``binaries/``: pythonfmu3's prebuilt loader (Linux x86_64, Windows x86_64), which runs the slave in the Python
  interpreter of the importing process, and ``sources/``, the loader's C++ to build it elsewhere. The loader
  links to no libpython: an importer that is not itself Python loads one first (on Linux, e.g.
  ``LD_PRELOAD=libpython3.11.so``), whose interpreter must find numpy, scipy and pyyaml. Where a host unloads it,
  the loader finalizes that interpreter, which can crash once numpy and scipy were imported (seen in a C host at
  its exit, tests/solutions/io/fmi3_host.c; a pythonfmu3 FMU that only imports them does the same): the results
  are complete by then.

An FMU carries the reference solver's source: the formulas the students write. It is an instructor's and an
engineer's file, not one to hand out during the course.

**Co-simulation.** The importer calls doStep(t, h) for each communication step; the slave (``start_stepper``)
advances the analysis ``mbd run`` makes of the file, on the numpy engine, from the state it holds at t to t + h:

- forward dynamics (``DynamicStepper``), with the model's formulation and integrator and the relative tolerance of
  the parameter ``rtol`` (by default the one ``mbd run`` uses for the file: ``simulation.rtol``, or the rule of
  ``dynamics.default_rtol`` over the file's span). Consistent initial conditions and the method are found once, at
  initialization; the state (coordinates, velocities, the accumulated energies) is carried from step to step and
  the integrator restarts at every communication point (an explicit Runge-Kutta method loses only its step size
  there: the double pendulum at the file's output interval stays within 1e-8 of ``mbd run``, every dynamic
  example within rtol times the size of each column, benchmarks/results/fmu.md);
- a kinematic analysis where the drivers leave no degree of freedom (``KinematicStepper``): at each communication
  point the step of ``mbd run`` (predictor, Newton-Raphson, velocities and accelerations), so the same numbers.

The index-3 integrators, an inverse analysis and a kinematic one through singular positions are refused (their
loops are not stepped). The default experiment is the file's span and output interval.

**Outputs** are the columns of ``mbd run --out FILE.csv`` (DESIGN section 5) but ``t`` (FMI's independent
variable ``time``): coordinates ``BODY.x``, velocities ``BODY.x_d``, accelerations ``BODY.x_dd``, the residuals
and energies (``residual.position``, ``energy.kinetic``, ...), joint reactions ``JOINT.Fx`` and driver efforts
``DRIVER.effort``. The FMU's names follow FMI's structured naming convention, in which a CSV column is already a
legal name (``upper.x``: the identifiers ``upper`` and ``x``); a name part with a '-' (model files allow it) is
quoted, as the convention says: column ``slider-1.x`` is the variable ``'slider-1'.x`` (``fmi_name``). Every
output's description names its CSV column.

**Parameters** (fixed: set before initialization) are the numbers of the file that a study varies: each body's
``BODY.mass`` and ``BODY.inertia`` (spatial: ``BODY.inertia[i]`` or ``BODY.inertia[i,j]``, 1-based), each spring's
``NAME.spring_coefficient``, ``NAME.damping_coefficient``, ``NAME.free_length``, ``NAME.free_angle`` and its
actuator function's numbers, each motor's function numbers (``drive.function.coefficients[2]``,
``drive.function.amplitude``, or ``drive.function`` for a constant), where the file gives them; an element without
a name is named by its place (``spring_dampers[1].spring_coefficient``); and, for forward dynamics, ``rtol`` and
``atol``. A changed parameter edits the model file's data and the run starts from it: the FMU then gives what
``mbd run`` gives for the edited file.
"""

from __future__ import annotations

import argparse
import copy
import importlib.metadata
import re
import shutil
import sys
import tempfile
import zipfile
from collections.abc import Mapping
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ..analysis import choose_analysis
from ..assembly import build_system
from ..diagnostics import AnalysisError
from ..dynamics import Run, build_result, guarded_after_step, ode_motion, start_motion
from ..integrators import integrate
from ..kinematics import KinematicSteps, assemble, kinematic_step, require_no_freedom
from ..results import Result
from ..settings import INDEX3_INTEGRATORS, read_settings
from .model import ModelError, load_model, read_text
from .results import result_columns

MODEL_FILE = "model.yaml"
"""The model file's name in the FMU's resources."""
SLAVE = Path(__file__).with_name("fmu_slave.py")
"""The slave class's source: the FMU's entry point (its module is imported by pythonfmu3's loader)."""
LEFT_OUT = ("compiled",)
"""Folders of ``solutions/`` the FMU does not carry: the compiled engine (numba), which co-simulation does not use."""
INSTALL = "pip install 'mbd-course[dev]'"
RUNTIME = ("numpy", "scipy", "pyyaml")
"""What the FMU needs where it runs (its resources' requirements.txt, which ``pythonfmu3 deploy`` installs)."""
IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
FUNCTION_PARAMETERS = {"spring_dampers": "actuator", "motors": "function"}
"""The function of an element whose numbers are parameters, by section."""
SPRING_PARAMETERS = ("spring_coefficient", "damping_coefficient", "free_length", "free_angle")
"""The keys of a spring-damper whose numbers are parameters (besides its actuator's)."""
TIME_TOLERANCE = 1e-9
"""How far (relative) a communication point may be from the time the FMU reached: rounding of t + h sums."""


class FmuError(ModelError):
    """A model that cannot be exported as an FMU, or an FMU that cannot be built here: the reason and the fix."""


# -- names ------------------------------------------------------------------------------------------------------


def fmi_part(name: str) -> str:
    """One part of a structured FMI name: the name itself when it is an identifier, else quoted ('slider-1')."""
    return name if IDENTIFIER.fullmatch(name) else f"'{name}'"


def fmi_name(column: str) -> str:
    """The FMI 3.0 structured name of a result column: each dot-separated part an identifier or quoted
    ('slider-1.x' -> "'slider-1'.x"; 'upper.phi_d' stays)."""
    return ".".join(fmi_part(part) for part in column.split("."))


def _indexed(name: str, value, path: tuple) -> dict[str, tuple[tuple, float]]:
    """{FMI name: (path, value)} of a number, a list of numbers (name[i]) or a matrix (name[i,j]), 1-based."""
    if isinstance(value, bool) or not isinstance(value, int | float | list):
        return {}
    if not isinstance(value, list):
        return {name: (path, float(value))}
    found = {}
    for i, item in enumerate(value, start=1):
        if isinstance(item, list):
            found.update({f"{name}[{i},{j}]": ((*path, i - 1, j - 1), float(x)) for j, x in enumerate(item, start=1)})
        elif isinstance(item, int | float) and not isinstance(item, bool):
            found[f"{name}[{i}]"] = ((*path, i - 1), float(item))
    return found


def _function_parameters(label: str, function, path: tuple) -> dict[str, tuple[tuple, float]]:
    """The numbers of a function (a constant, or a mapping's numbers and lists of numbers but its type)."""
    if not isinstance(function, Mapping):
        return _indexed(label, function, path)
    found = {}
    for key, value in function.items():
        if key != "type":
            found.update(_indexed(f"{label}.{key}", value, (*path, key)))
    return found


def model_parameters(data: Mapping) -> dict[str, tuple[tuple, float]]:
    """The FMU's parameters of a model file's data: {FMI name: (key path under ``model``, value in the file)}.

    Each body's mass and inertia; each spring's coefficients, free length or angle and actuator's numbers; each
    motor's function numbers; those the file gives (module docstring)."""
    model = data["model"]
    found: dict[str, tuple[tuple, float]] = {}
    for k, body in enumerate(model.get("bodies", [])):
        label = fmi_part(body["name"])
        for key in ("mass", "inertia"):
            if key in body:
                found.update(_indexed(f"{label}.{key}", body[key], ("bodies", k, key)))
    for section, function_key in FUNCTION_PARAMETERS.items():
        for k, item in enumerate(model.get(section, [])):
            label = fmi_part(item["name"]) if "name" in item else f"{section}[{k + 1}]"
            keys = SPRING_PARAMETERS if section == "spring_dampers" else ()
            for key in (key for key in keys if key in item):
                found.update(_indexed(f"{label}.{key}", item[key], (section, k, key)))
            if function_key in item:
                path = (section, k, function_key)
                found.update(_function_parameters(f"{label}.{function_key}", item[function_key], path))
    return found


def with_parameters(data: Mapping, values: Mapping[str, float]) -> dict:
    """A copy of a model file's data with the parameters ``values`` {FMI name: value} written in."""
    edited = copy.deepcopy(dict(data))
    paths = model_parameters(data)
    for name, value in values.items():
        *keys, last = paths[name][0]
        where = edited["model"]
        for key in keys:
            where = where[key]
        where[last] = float(value)
    return edited


# -- the co-simulation ------------------------------------------------------------------------------------------


def start_stepper(data: Mapping, rtol: float | None = None, atol: float | None = None) -> Stepper:
    """The co-simulation of a model file's data: its forward dynamics (``DynamicStepper``), or its kinematic
    analysis where the drivers leave no degree of freedom (``KinematicStepper``), as ``mbd run`` chooses; ``rtol``
    and ``atol`` over the file's (forward dynamics only).

    Raises
    ------
    ModelError, AnalysisError
        A model that cannot be read or run, as ``mbd run`` says it; FmuError for what an FMU does not advance step
        by step: an inverse analysis, the index-3 integrators, a kinematic analysis through singular positions.
    """
    model = load_model(data)
    system, q0, qd0 = build_system(model)
    settings = read_settings(model.simulation, rtol=rtol, atol=atol, engine="numpy")
    analysis = settings.analysis
    if analysis == "auto":
        analysis = choose_analysis(system, assemble(system, q0)[0])
    if analysis == "dynamic":
        return DynamicStepper(Run(system, q0, qd0, settings, None, None, None))
    if analysis == "kinematic" and not settings.through_singular:
        return KinematicStepper(system, q0, settings)
    said = "simulation.through_singular" if analysis == "kinematic" else f"simulation.analysis {analysis}"
    raise FmuError(f"{model.name}: {said}: an FMU runs a forward dynamic or a kinematic analysis step by step")


class Stepper:
    """An analysis advanced one communication step at a time (FMI's doStep), its state carried from step to step.

    ``columns`` holds the result columns (``io.results.result_columns``) at the time ``t`` reached; ``method``
    says how the steps are taken; ``tolerances`` are the (rtol, atol) the steps hold, or None."""

    t: float
    columns: dict[str, float]
    method: str
    tolerances: tuple[float, float] | None = None

    def __init__(self, system, settings):
        self.system, self.model, self.settings = system, system.model, settings
        self.t = 0.0

    def advance(self, t_end: float, t_from: float | None = None) -> None:
        """Advance from ``t`` to ``t_end`` and take the columns there. ``t_from``: the time the importer believes
        reached (FMI's currentCommunicationPoint), which must be ``t`` but for rounding."""
        if t_from is not None:
            if abs(t_from - self.t) > TIME_TOLERANCE * max(1.0, abs(self.t)):
                raise AnalysisError(
                    f"a communication step from t = {t_from:.9g} s: the FMU's state is at t = {self.t:.9g} s (it "
                    "steps forward from where it is, without going back)"
                )
            self.t = t_from
        self._step(t_end)
        self.t = t_end

    def _step(self, t_end: float) -> None:
        raise NotImplementedError


class DynamicStepper(Stepper):
    """Forward dynamics: the numpy engine of ``dynamics.forward_dynamics``, its stages 1 and 2 (consistent initial
    conditions, method and tolerances) done once; at each communication step the integrator starts again from the
    state held (coordinates, velocities, accumulated energies)."""

    def __init__(self, run: Run):
        super().__init__(run.system, run.settings)
        start = start_motion(run, run.settings.formulation, run.settings.integrator)
        if start.plan.integrator in INDEX3_INTEGRATORS:
            raise FmuError(
                f"{self.model.name}: simulation.integrator {start.plan.integrator}: the index-3 integrators are "
                "not advanced step by step in an FMU; choose an ODE integrator (e.g. DOP853, RK45, Radau)"
            )
        self.run = run = start.run  # with a nominal inertia where point masses turn freely (dynamics.start_motion)
        self.plan, self.equations, self.guard, self.warnings = ode_motion(run, start)
        self.method = f"forward dynamics, {self.plan.formulation} formulation, {self.plan.integrator}"
        self.tolerances = (self.plan.rtol, self.plan.atol)
        self.z = self.equations.initial_state(start.q, start.qd, 0.0)
        self.first = self._row(self.t, self.z)
        self.columns = self._columns(self.first)
        self.rhs_evaluations = 0

    def _row(self, t: float, z: np.ndarray) -> tuple:
        """(t, q, q', q'', lambda, accumulated energies) of the state z at t, as an output time of a run has them."""
        y, energies = self.equations.split(z)
        q, qd = self.equations.formulation.coordinates(t, y)
        return (t, q, qd, *self.equations.formulation.accelerations(q, qd, t), energies)

    def _columns(self, row: tuple) -> dict[str, float]:
        """The result columns at ``row``: those of a run's result over the two output times 0 and t, whose last
        values they are (energy.error is E(t) - E(0))."""
        times, *arrays = (np.array(pair) for pair in zip(self.first, row, strict=True))
        history = SimpleNamespace(**dict(zip(("q", "qd", "qdd", "lam", "energies"), arrays, strict=True)))
        result, _ = build_result(self.run, self.equations, self.guard, history, None, times)
        return {name: float(values[-1]) for name, values in result_columns(result).items() if name != "t"}

    def _step(self, t_end: float) -> None:
        """Integrate from ``t`` to ``t_end`` (the integrator restarted from the state held); the Guard watches the
        run as in ``forward_dynamics``."""
        reached = []
        plan, settings = self.plan, self.settings

        def record(k: int, t: float, z: np.ndarray) -> None:
            if k:
                reached.append(np.array(z))

        stats = integrate(
            self.equations.rhs, self.z, np.array([self.t, t_end]), record, method=plan.integrator, rtol=plan.rtol,
            atol=plan.atol, step=settings.step, after_step=guarded_after_step(self.equations, self.guard),
            max_evaluations=settings.max_evaluations, stiffness=settings.stiffness,
        )  # fmt: skip
        self.rhs_evaluations += stats.rhs_evaluations
        row = self._row(t_end, reached[-1])
        self.guard.check_drift(row[1], t_end)
        self.z, self.columns = reached[-1], self._columns(row)


class KinematicStepper(Stepper):
    """A kinematic analysis (``kinematics.kinematic_analysis``, numpy engine): the file's configuration assembled
    at t = 0, then at each communication point the step of eq. 4.8 (predictor and Newton-Raphson), q' (eq. 4.5) and
    q'' (eq. 4.6), with its stop at a singular position passed (``kinematics.kinematic_step``). The branch check at
    the last point reached sees no ratio after it, as ``mbd run``'s at its end time."""

    method = "kinematic analysis (the drivers leave no degree of freedom)"

    def __init__(self, system, q0: np.ndarray, settings):
        super().__init__(system, settings)
        q, _ = assemble(system, q0, 0.0)
        require_no_freedom(system, q, 0.0)
        self.march = KinematicSteps.empty(system, np.zeros(1))
        kinematic_step(self.march, 0, q)
        self.columns = self._columns()

    def _columns(self) -> dict[str, float]:
        march = self.march
        names = [b.name for b in self.model.bodies]
        result = Result(march.times, march.Q, march.QD, march.QDD, self.system.coordinate_names, names)
        return {name: float(values[-1]) for name, values in result_columns(result).items() if name != "t"}

    def _step(self, t_end: float) -> None:
        march = self.march
        march.times = np.append(march.times, t_end)
        for name in ("Q", "QD", "QDD"):
            setattr(march, name, np.vstack([getattr(march, name), np.empty(self.system.n_coordinates)]))
        kinematic_step(march, march.times.size - 1, march.predict(march.times.size - 1))
        self.columns = self._columns()


# -- the export -------------------------------------------------------------------------------------------------


def _builder():
    """pythonfmu3's FmuBuilder, imported when an FMU is built (a dev dependency)."""
    try:
        from pythonfmu3 import FmuBuilder
    except ImportError:
        raise FmuError(f"an FMU is built with pythonfmu3, which is not installed: {INSTALL}") from None
    return FmuBuilder


def _copy_package(source: Path, target: Path, leave_out: tuple[str, ...] = ()) -> None:
    """The .py and .json files of a package tree, without caches and the folders ``leave_out``."""
    for path in sorted(source.rglob("*")):
        relative = path.relative_to(source)
        if path.suffix in (".py", ".json") and not {"__pycache__", *leave_out} & set(relative.parts):
            (target / relative).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(path, target / relative)


def requirements() -> list[str]:
    """What the FMU needs installed (RUNTIME), with mbd-course's bounds on them when it is installed."""
    try:
        declared = importlib.metadata.requires("mbd-course") or []
    except importlib.metadata.PackageNotFoundError:  # run from a checkout that is not installed
        declared = []
    bounds = {re.split(r"[<>=!~\[ ;]", r)[0].lower(): r for r in declared if ";" not in r}
    return [bounds.get(name, name) for name in RUNTIME]


def _stage(folder: Path, model_path: Path) -> list[Path]:
    """The files the FMU's resources carry besides the slave (module docstring), written into ``folder``."""
    import fastjsonschema

    shutil.copy2(model_path, folder / MODEL_FILE)
    (folder / "requirements.txt").write_text("\n".join(requirements()) + "\n")
    _copy_package(Path(__file__).parents[1], folder / "solutions", LEFT_OUT)
    _copy_package(Path(fastjsonschema.__file__).parent, folder / "fastjsonschema")
    for file in importlib.metadata.distribution("fastjsonschema").files or []:
        if file.name in ("LICENSE", "AUTHORS"):
            shutil.copy2(file.locate(), folder / "fastjsonschema" / file.name)
    return [folder / name for name in (MODEL_FILE, "requirements.txt", "solutions", "fastjsonschema")]


def export_fmu(model_path: str | Path, out: str | Path) -> Path:
    """Write the FMU of a model file (module docstring) to ``out`` (FILE.fmu); returns its path.

    The model is read and its forward dynamics started first, so that a model the FMU could not run is refused
    here, with ``mbd run``'s words.

    Raises
    ------
    ModelError, AnalysisError
        The model cannot be read or run; FmuError: not a forward dynamic run, the builder is not installed,
        ``out`` is not FILE.fmu in an existing folder.
    """
    model_path, out = Path(model_path), Path(out)
    if out.suffix.lower() != ".fmu":
        raise FmuError(f"{out}: an FMU is written as FILE.fmu")
    if not out.parent.is_dir():
        raise FmuError(f"{out}: no folder {out.parent} (make it first, or write elsewhere)")
    builder = _builder()
    start_stepper(read_text(model_path))  # refuses what the FMU could not run, before building
    with tempfile.TemporaryDirectory(prefix="mbd-fmu-") as tmp:
        stage, built = Path(tmp) / "stage", Path(tmp) / "built"
        stage.mkdir()
        fmu = builder.build_FMU(
            SLAVE, dest=built, project_files=_stage(stage, model_path), canHandleVariableCommunicationStepSize=True
        )
        _deflate(fmu, out)
    return out


def _deflate(source: Path, target: Path) -> None:
    """The FMU ``source`` (pythonfmu3 stores its files uncompressed) as a deflated zip, which FMI allows: a third
    of the size."""
    with zipfile.ZipFile(source) as stored, zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as deflated:
        for item in stored.infolist():
            deflated.writestr(item.filename, stored.read(item))


def main(argv: list[str] | None = None) -> int:
    """``python -m solutions.io.fmu MODEL [--out FILE.fmu]``: exit 0, or 2 with one line for a user error."""
    parser = argparse.ArgumentParser(prog="python -m solutions.io.fmu", description=__doc__.split("\n")[0])
    parser.add_argument("model", help="the model file (YAML)")
    parser.add_argument("--out", help="the FMU to write (default: MODEL's name .fmu, here)")
    args = parser.parse_args(argv)
    out = Path(args.out or Path(args.model).with_suffix(".fmu").name)
    try:
        path = export_fmu(args.model, out)
    except (ModelError, AnalysisError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(f"FMU written to {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
