"""``Result.info`` is a typed record: every analysis writes only the keys its record declares, with their types."""

from __future__ import annotations

import types
import typing
from pathlib import Path

import pytest

from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.inverse_dynamics import inverse_dynamics
from solutions.io.model import load_model
from solutions.kinematics import kinematic_analysis
from solutions.results import DynamicInfo, Index3Info, InverseInfo, KinematicInfo

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"


def system_of(name: str):
    return build_system(load_model(MODELS / name))


def pendulum(*args, **options):
    return forward_dynamics(*system_of("double_pendulum.yaml"), 0.1, 2, *args, **options)


def crank(analysis, **options):
    system, q0, _ = system_of("slider_crank.yaml")
    return analysis(system, q0, 0.1, 2, **options)


RUNS = {  # each analysis, formulation family and engine: (its record, the run)
    "auto": (DynamicInfo, lambda: pendulum()),  # the method chosen, the rtol rule
    "partitioning": (DynamicInfo, lambda: pendulum("partitioning", "rk45")),
    "projection": (DynamicInfo, lambda: pendulum("projection", "RK45")),
    "rk4": (DynamicInfo, lambda: pendulum("baumgarte", "rk4")),
    "augmented-lagrangian": (DynamicInfo, lambda: pendulum("augmented-lagrangian", "dop853")),
    "compiled": (DynamicInfo, lambda: pendulum("baumgarte", "DOP853", engine="compiled")),
    "hht": (Index3Info, lambda: pendulum(integrator="hht")),
    "kinematic": (KinematicInfo, lambda: crank(kinematic_analysis)),
    "through-singular": (KinematicInfo, lambda: crank(kinematic_analysis, through_singular=True)),
    "inverse": (InverseInfo, lambda: crank(inverse_dynamics)),
}


def matches(value, hint) -> bool:
    """isinstance against a type hint: a class, ``X | None``, ``list[str]``."""
    if hint is float:
        return isinstance(value, int | float) and not isinstance(value, bool)
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        return any(matches(value, arg) for arg in typing.get_args(hint))
    if hint is type(None):
        return value is None
    return isinstance(value, origin or hint)


@pytest.mark.parametrize("run", RUNS)
def test_every_key_of_info_is_declared_with_its_type(run):
    record, analysis = RUNS[run]
    result = analysis()
    hints = typing.get_type_hints(record)
    undeclared = set(result.info) - set(hints)
    assert not undeclared, f"{record.__name__} does not declare {sorted(undeclared)}"
    for key, value in result.info.items():
        assert matches(value, hints[key]), (record.__name__, key, value, hints[key])
    assert result.info["analysis"] in ("kinematic", "dynamic", "inverse")
