"""The settings of a run: one frozen object for the API, the command line, the model file and sweeps.

Everything a run is asked besides the mechanism (which analysis, how long, which formulation and
integrator, how accurate, which checks) is one field of ``Settings``. Each field states, once, its
default, the key of the model file's ``simulation`` block that sets it, what values it takes and what it
does; the command line's options (``mbd run --rtol``), the file's keys (``simulation.rtol``) and a sweep's
overrides are all read through the same table (``read_settings``), and checked there, so a value no
analysis takes is refused before any run, in the words the user wrote it.

From Python: ``forward_dynamics(system, q0, qd0, t_end, steps, rtol=1e-9)`` builds one from its keywords;
``Settings(formulation="qr").replace(rtol=1e-9)`` is one made by hand.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
import numbers
import os
from dataclasses import dataclass, field, fields

from .diagnostics import AnalysisError
from .formulations import FORMULATIONS
from .integrators import DEFAULT_MAX_EVALUATIONS, INTEGRATORS

INDEX3_INTEGRATORS = ("hht", "generalized-alpha")
"""Implicit integrators of the index-3 form (``implicit.py``); they take the place of formulation + ODE."""
ANALYSES = ("auto", "kinematic", "dynamic", "inverse")
"""What ``analysis`` takes; ``auto`` is ``analysis.choose_analysis``."""
FORMULATION_NAMES = ("auto", *FORMULATIONS)
"""What ``formulation`` takes: ``auto`` (``dynamics.choose_method``) or a formulation of ``formulations.py``."""
INTEGRATOR_NAMES = ("auto", *INTEGRATORS, *INDEX3_INTEGRATORS)
"""What ``integrator`` takes: ``auto`` (``dynamics.choose_method``), an ODE integrator or an index-3 one."""
ENGINES = ("auto", "numpy", "compiled", "cached")
"""What ``engine`` takes (``compiled.dispatch``): numba is imported only when a run is compiled."""
ENGINE_VARIABLE = "MBD_ENGINE"
"""The environment variable that names the engine of every run that does not name one (default ``auto``): e.g.
``MBD_ENGINE=numpy`` for the reference code's numbers in every run of a session, script or test suite."""
STIFFNESS = ("report", "error", "off")
"""What ``stiffness`` takes (``integrators.integrate``)."""
DIVERGENCE = ("check", "skip")
"""What ``divergence`` takes (``dynamics.judge_divergence``)."""
DRIFT_LIMIT = 1e-3
"""Default ``drift_limit``: positions off the constraints by a thousandth of the mechanism's size are a wrong answer."""
SINGULAR_RATIO = 1e-8
"""Default ``singular_ratio``: sigma_min / sigma_max of Psi_q below which a configuration counts as singular."""
DEFAULT_ACCURACY = 1e-6
"""Default ``accuracy``: a millionth of the mechanism's size (``assembly.mechanism_size``)."""

NAME, FLAG, WHOLE, POSITIVE, OFF_AT_ZERO = "name", "flag", "whole", "positive", "off at zero"
"""What a setting takes: one of its names; true or false; a whole number >= 1; a number > 0; a number >= 0."""


def setting(default, key: str, takes: str, help: str, names: tuple = ()):
    """A field of ``Settings``: its default (a value, or a function that gives it), the model file's key, what it
    takes and what it does."""
    metadata = {"key": key, "takes": takes, "help": help, "names": names}
    if callable(default):
        return field(default_factory=default, metadata=metadata)
    return field(default=default, metadata=metadata)


def default_engine() -> str:
    """The engine of a run that names none: ``$MBD_ENGINE`` when set, else ``auto``."""
    engine = os.environ.get(ENGINE_VARIABLE) or "auto"
    if engine not in ENGINES:
        raise SettingError(f"{ENGINE_VARIABLE}={engine!r}: unknown engine (one of: {', '.join(ENGINES)})")
    return engine


class SettingError(AnalysisError, ValueError):
    """A setting that no analysis takes: the message names it as the user wrote it and says what it takes."""


@dataclass(frozen=True)
class Settings:
    """What a run is asked, besides the mechanism (the model file's ``simulation`` block)."""

    analysis: str = setting(
        "auto", "analysis", NAME,
        "auto (the default): kinematic when the drivers leave no degree of freedom, dynamic otherwise; kinematic: "
        "the motion the drivers prescribe; dynamic: forward dynamics under the forces; inverse: the driver forces "
        "and joint reactions of the prescribed motion",
        ANALYSES,
    )  # fmt: skip
    t_end: float = setting(1.0, "end_time", POSITIVE, "end time in s (the file's simulation.end_time, default 1)")
    steps: int = setting(100, "output_steps", WHOLE, "number of output intervals (simulation.output_steps: 100)")
    formulation: str = setting(
        "auto", "formulation", NAME,
        "dynamic formulation: auto (the default: the cheapest adequate one), baumgarte, partitioning, qr, svd, "
        "projection, augmented-lagrangian (singular positions, redundant constraints), joint-coordinates (open trees)",
        FORMULATION_NAMES,
    )  # fmt: skip
    integrator: str = setting(
        "auto", "integrator", NAME,
        "integrator: auto (the default), dop853, rk45 (this package's loops), RK45, DOP853, Radau, BDF, LSODA "
        "(scipy's solve_ivp), rk4 (fixed step), hht, generalized-alpha (implicit, index 3)",
        INTEGRATOR_NAMES,
    )  # fmt: skip
    engine: str = setting(
        default_engine, "engine", NAME,
        "auto (the default, or $MBD_ENGINE): compiled where the compiled engine takes the run and its code is on "
        "disk (mbd compile, once per machine) unless the run is shorter than loading it, numpy elsewhere, saying "
        "why; numpy (the reference code); compiled (numba, compiling what is not on disk; numpy, saying why, "
        "where it does not cover the run); cached (compiled whenever its code is on disk)",
        ENGINES,
    )  # fmt: skip
    rtol: float | None = setting(
        None, "rtol", POSITIVE,
        "relative tolerance of the integrator (default: dynamics.default_rtol, from accuracy and the run's length)",
    )  # fmt: skip
    atol: float = setting(1e-10, "atol", POSITIVE, "absolute tolerance of the integrator (default 1e-10)")
    step: float | None = setting(
        None, "step", POSITIVE, "the fixed step of rk4 (default: the output spacing); the largest step of the others"
    )
    accuracy: float = setting(
        DEFAULT_ACCURACY, "accuracy", POSITIVE,
        "error allowed in positions, as a fraction of the mechanism's size (default 1e-6), in velocities, of the "
        "largest speed, and in the energy balance, of the energy scale: the default rtol follows it, and the result "
        "warns when an estimated error exceeds it (dynamics.accuracy_estimate)",
    )  # fmt: skip
    through_singular: bool = setting(
        False, "through_singular", FLAG,
        "kinematic analysis: go on through singular positions along the branch of the velocities (listed as "
        "warnings) instead of stopping there",
    )  # fmt: skip
    alpha: float | None = setting(
        None, "alpha", OFF_AT_ZERO,
        "Baumgarte's alpha in 1/s (baumgarte, qr, svd, ...; default 5 for baumgarte): "
        "gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi (eq. 5.29)",
    )  # fmt: skip
    beta: float | None = setting(None, "beta", OFF_AT_ZERO, "Baumgarte's beta in 1/s (default 5 for baumgarte)")
    penalty: float | None = setting(
        None, "penalty", POSITIVE,
        "augmented-lagrangian: penalty relative to the largest mass over sigma_max(Psi_q)^2 (default 1e7)",
    )  # fmt: skip
    rank_tol: float | None = setting(
        None, "rank_tol", POSITIVE,
        "svd: singular values of Psi_q below rank_tol sigma_1 count as zero (default: the package's rank rule)",
    )  # fmt: skip
    repartition_ratio: float | None = setting(
        None, "repartition_ratio", POSITIVE,
        "partitioning: choose new independent coordinates when cond(Psi_v) grows by this factor (default 10)",
    )  # fmt: skip
    max_evaluations: int | None = setting(
        DEFAULT_MAX_EVALUATIONS, "max_evaluations", WHOLE,
        "forward dynamics: budget of right-hand-side evaluations; past it the run stops, saying where (and the "
        "stiffness, when found)",
    )  # fmt: skip
    drift_limit: float | None = setting(
        DRIFT_LIMIT, "drift_limit", OFF_AT_ZERO,
        "forward dynamics: stop when the positions are off the constraints by this fraction of the mechanism's "
        "size (default 1e-3, at least 100 rtol; 0: no limit)",
    )  # fmt: skip
    singular_ratio: float | None = setting(
        SINGULAR_RATIO, "singular_ratio", OFF_AT_ZERO,
        "forward dynamics: stop at a singular position, where the smallest singular value of Psi_q falls below "
        "this fraction of the largest (default 1e-8; 0: no check)",
    )  # fmt: skip
    stiffness: str = setting(
        "report", "stiffness", NAME,
        "forward dynamics, explicit integrators bounded by stability: report (the default, in the result's info), "
        "error (stop at once), off",
        STIFFNESS,
    )  # fmt: skip
    divergence: str = setting(
        "check", "divergence", NAME,
        "forward dynamics, adaptive integrators: check (the default) compares the run with one at 100 x rtol "
        "(eq. 6.62) where the motion can be chaotic (two degrees of freedom or more, or a force or driver that "
        "changes with time): a default rtol is tightened where the estimated error exceeds the accuracy, a given "
        "one warns; skip: no second run (a YAML file reads off as false)",
        DIVERGENCE,
    )  # fmt: skip
    options: dict = field(default_factory=dict)
    """Further options of the formulation's constructor, from Python only (e.g. ``tol``, ``independent``)."""

    def __post_init__(self):
        for f in _table():
            if f.name not in FORMULATION_OPTIONS:  # those the formulation checks, saying why (e.g. eq. 5.29)
                check_setting(f.name, getattr(self, f.name))
            if f.name in CHECKS and getattr(self, f.name) == 0:
                object.__setattr__(self, f.name, None)  # 0: no such check

    def replace(self, **changes) -> Settings:
        """A copy with ``changes``; keywords that are not settings are options of the formulation. Only the
        changed settings are checked (``__post_init__`` checked the others when this object was made): a run makes
        several copies, each of which checked every setting anew (a tenth of a millisecond). A value equal to the
        one it replaces was checked with it (a run's plan repeats most of its settings: no check, 1-2 us each)."""
        names = _metadata()
        copied = object.__new__(type(self))  # a frozen dataclass's shallow copy, without ``copy.copy``'s protocol
        copied.__dict__.update(self.__dict__)
        extra = {}
        for name, value in changes.items():
            if name not in names:
                extra[name] = value
                continue
            if name in CHECKS and value == 0:
                value = None
            if value is not None and value == self.__dict__[name] and type(value) is type(self.__dict__[name]):
                continue  # checked when this object was made
            if name not in FORMULATION_OPTIONS:
                check_setting(name, value)
            copied.__dict__[name] = value
        copied.__dict__["options"] = {**self.options, **extra}
        return copied

    @property
    def formulation_options(self) -> dict:
        """The options of the formulation's constructor: the ones set of alpha, beta, penalty, rank_tol,
        repartition_ratio, and ``options``."""
        given = {name: getattr(self, name) for name in FORMULATION_OPTIONS if getattr(self, name) is not None}
        return {**given, **self.options}


FORMULATION_OPTIONS = ("alpha", "beta", "penalty", "rank_tol", "repartition_ratio")
"""Settings that are options of a formulation's constructor (``formulations.FORMULATIONS``)."""
CHECKS = ("drift_limit", "singular_ratio")
"""Settings of a check that 0 turns off."""
DYNAMIC_ONLY = (
    "formulation", "integrator", "rtol", "atol", "step", "accuracy", *FORMULATION_OPTIONS, "max_evaluations",
    *CHECKS, "stiffness", "divergence",
)  # fmt: skip
"""Settings that only a forward dynamic analysis uses."""


def default_settings() -> Settings:
    """``Settings()``, made and checked once per value of ``$MBD_ENGINE`` (a frozen object: every run that is given
    none starts from the same one, and ``replace`` makes its own)."""
    return _default_settings(os.environ.get(ENGINE_VARIABLE))


@functools.lru_cache(maxsize=8)
def _default_settings(engine: str | None) -> Settings:
    return Settings()


@functools.cache
def _table() -> tuple[dataclasses.Field, ...]:
    return tuple(f for f in fields(Settings) if "key" in f.metadata)


def table() -> list[dataclasses.Field]:
    """The settings, in order: every field of ``Settings`` but ``options``."""
    return list(_table())


@functools.cache
def _metadata() -> dict:
    """Each setting's metadata by name (what it takes, its names, its key)."""
    return {f.name: f.metadata for f in _table()}


def check_setting(name: str, value, source: str | None = None) -> None:
    """Refuse a value that the setting ``name`` does not take; ``source`` is how the user wrote it ('--rtol'
    on the command line, 'simulation.rtol' in the file; None: a keyword from Python). None leaves the default."""
    if value is None:
        return
    meta = _metadata()[name]
    takes = meta["takes"]
    if takes == NAME:
        if value not in meta["names"]:
            named = f"unknown {name} {value!r}" if source is None else f"{_said(name, value, source)}: unknown {name}"
            raise SettingError(f"{named} (one of: {', '.join(meta['names'])})")
        return
    if takes == FLAG:
        if not isinstance(value, bool):
            raise SettingError(f"{_said(name, value, source)}: must be true or false")
        return
    exact = type(value) is int or (type(value) is float and takes != WHOLE)  # the usual ones, without the ABCs' check
    kind = numbers.Integral if takes == WHOLE else numbers.Real
    number = exact or (isinstance(value, kind) and not isinstance(value, bool))
    if not number or not math.isfinite(value) or value < 0 or (takes != OFF_AT_ZERO and value == 0):
        wanted = {WHOLE: "a whole number >= 1", OFF_AT_ZERO: "a number >= 0"}.get(takes, "a number > 0")
        raise SettingError(f"{_said(name, value, source)}: must be {wanted}")


def _said(name: str, value, source: str | None) -> str:
    """How the user wrote a refused value: 'rtol = -1.0' from Python, '--rtol -1.0' or 'simulation.rtol -1.0'."""
    return f"{name} = {value!r}" if source is None else f"{source} {value!r}"


def formulations_taking(option: str) -> list[str]:
    """The formulations whose constructor takes ``option`` (e.g. alpha: baumgarte, qr, svd, ...)."""
    return [name for name, cls in FORMULATIONS.items() if option in inspect.signature(cls.__init__).parameters]


def check_formulation_options(settings: Settings) -> None:
    """Refuse a formulation option (alpha, penalty, ...) that the run's formulation does not take, naming the
    formulations that take it."""
    for option in FORMULATION_OPTIONS:
        if getattr(settings, option) is None:
            continue
        takes = formulations_taking(option)
        if settings.formulation not in takes:
            raise SettingError(
                f"--{option.replace('_', '-')} (simulation.{option}) is an option of the {', '.join(takes)} "
                f"formulation{'s' if len(takes) > 1 else ''}, not of {settings.formulation}: "
                f"add --formulation {takes[0]}"
            )


def read_settings(simulation: dict, **given) -> Settings:
    """The model file's ``simulation`` block, overridden by every given value that is not None (the command
    line's options, a sweep's): each checked in the words the user wrote it.

    Raises
    ------
    SettingError
        Naming the option ('--rtol') or the file's key ('simulation.rtol') and what it takes.
    """
    values = {}
    for f in table():
        key, option = f.metadata["key"], f"--{f.name.replace('_', '-')}"
        if given.get(f.name) is not None:
            values[f.name], source = given[f.name], option
        elif key in simulation:
            values[f.name], source = simulation[key], f"simulation.{key}"
        else:
            continue
        check_setting(f.name, values[f.name], source)
    settings = Settings(**values)
    check_formulation_options(settings)
    return settings
