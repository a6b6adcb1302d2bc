"""A prepared run (``dynamics.prepare``): ``prepare(...).run(q0, qd0)`` is ``forward_dynamics(system, q0, qd0, ...)``
bit for bit, run after run from other initial states, on either engine.

What a prepared run keeps between its runs (M, the forces, the compiled plans) must not carry one run's state into
the next: each run below from a second initial state is compared with a fresh ``forward_dynamics`` call from that
state (not with the first run), on a planar tree, a closed loop (cut joints; coordinate partitioning, whose object
keeps its partition), a spatial tree with a prismatic joint (whose rotation's sign, ``u0``, follows the initial
state and is data of the compiled tree) and ``auto``'s choices with the divergence check.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError
from solutions.dynamics import Prepared, forward_dynamics, prepare
from solutions.io.model import load_model

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
SHORT = dict(t_end=0.3, steps=6)
"""A short span: the comparison is bit for bit, so a few steps say as much as many."""


@pytest.fixture(scope="module")
def scenes() -> dict:
    """(system, q0, qd0) of the models the tests run, built once."""
    names = ("double_pendulum", "slider_crank", "spatial_double_pendulum", "carriage_pendulum")
    return {name: build_system(load_model(MODELS / f"{name}.yaml")) for name in names}


def other_state(system, q0: np.ndarray, qd0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Another (approximate) initial state: every body's velocity and angle moved a little (the run's assembly and
    velocity projection make it consistent)."""
    q, qd = q0.copy(), qd0.copy()
    per = system.coordinates_per_body
    qd[: per * len(system.model.bodies)] += 0.3
    if system.model.dimension == 2:
        q[2::3] += 0.05
    return q, qd


def same(a, b) -> None:
    """Assert two results equal bit for bit: every array, and ``info`` but for the wall time and the compiled
    module's load time."""
    for name in ("t", "q", "qd", "qdd", "lam"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None and y is None) or np.array_equal(x, y), name
    for group in ("points", "reactions", "forces"):
        x, y = getattr(a, group), getattr(b, group)
        assert x.keys() == y.keys(), group
        for key in x:
            assert np.array_equal(x[key], y[key], equal_nan=True), (group, key)
    assert _comparable(a.info) == _comparable(b.info)


def _comparable(info: dict) -> dict:
    kept = {k: v for k, v in info.items() if k != "wall_time"}
    if "compiled" in kept:  # whether the module was loaded already (it was, by the first run): not how long it took
        kept["compiled"] = {k: v for k, v in kept["compiled"].items() if k != "load_seconds"}
    return _with_nan(kept)


def _with_nan(value):
    """``value`` with every NaN replaced by a string (NaN != NaN)."""
    if isinstance(value, dict):
        return {k: _with_nan(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_with_nan(v) for v in value]
    if isinstance(value, float) and math.isnan(value):
        return "nan"
    if isinstance(value, np.ndarray):
        return _with_nan(value.tolist())
    return value


def runs_equal_calls(system, q0, qd0, **settings) -> Prepared:
    """Two runs of one prepared object, from the file's state and from another, each equal to its own
    ``forward_dynamics`` call; the prepared object, for more."""
    forward_dynamics(system, q0, qd0, SHORT["t_end"], SHORT["steps"], **settings)  # on a cold cache this compiles
    # the module (info['compiled']: cached False), which every later run in the process finds loaded
    prepared = prepare(system, SHORT["t_end"], SHORT["steps"], **settings)
    states = [(q0, qd0), other_state(system, q0, qd0), (q0, qd0)]  # back to the first: nothing left by the second
    for q, qd in states:
        same(prepared.run(q, qd), forward_dynamics(system, q, qd, SHORT["t_end"], SHORT["steps"], **settings))
    return prepared


@pytest.mark.parametrize(
    "name, formulation",
    [("double_pendulum", "joint-coordinates"), ("slider_crank", "joint-coordinates"), ("double_pendulum", "baumgarte")],
)
def test_compiled_runs_of_a_prepared_planar_scene_are_forward_dynamics_calls(scenes, name, formulation):
    system, q0, qd0 = scenes[name]
    prepared = runs_equal_calls(system, q0, qd0, formulation=formulation, integrator="DOP853", engine="compiled")
    result = prepared.run(q0, qd0)
    assert result.info["chosen"]["engine"] == "compiled"
    assert result.info["compiled"] == {"cached": True, "load_seconds": 0.0}  # loaded by its first run
    assert len(prepared.compiled_plans) == 1  # one plan for all its runs


def test_compiled_spatial_tree_takes_the_sign_of_each_initial_state(scenes):
    """The carriage's Euler parameters p and -p are one orientation; the prismatic joint's u0 takes the given sign,
    which the compiled tree holds as data: a second plan for the other sign, the same results as fresh calls."""
    system, q0, qd0 = scenes["carriage_pendulum"]
    settings = dict(formulation="joint-coordinates", integrator="DOP853", engine="compiled")
    prepared = runs_equal_calls(system, q0, qd0, **settings)
    flipped = q0.copy()
    flipped[3:7] *= -1.0  # the carriage's p
    same(prepared.run(flipped, qd0), forward_dynamics(system, flipped, qd0, **SHORT, **settings))
    assert len(prepared.compiled_plans) == 2
    system, q0, qd0 = scenes["spatial_double_pendulum"]
    runs_equal_calls(system, q0, qd0, **settings)


@pytest.mark.parametrize(
    "name, formulation",
    [("slider_crank", "baumgarte"), ("slider_crank", "partitioning"), ("carriage_pendulum", "joint-coordinates")],
)
def test_numpy_runs_of_a_prepared_scene_are_forward_dynamics_calls(scenes, name, formulation):
    """The numpy engine evaluates the formulation object at every step: the joint-coordinates object a prepared run
    hands on (``Prepared.formulation``) forgets all of it, the others are made anew."""
    system, q0, qd0 = scenes[name]
    settings = dict(formulation=formulation, integrator="dop853", engine="numpy", rtol=1e-6)
    prepared = runs_equal_calls(system, q0, qd0, **settings)
    if name == "carriage_pendulum":  # the other sign of the carriage's p: the same y, another u0
        flipped = q0.copy()
        flipped[3:7] *= -1.0
        same(prepared.run(flipped, qd0), forward_dynamics(system, flipped, qd0, **SHORT, **settings))


def test_auto_with_the_divergence_check(scenes):
    """``auto`` chooses per run (formulation, integrator, engine, tolerance by the rule) and the divergence check's
    companion runs from each run's own start."""
    system, q0, qd0 = scenes["double_pendulum"]
    prepared = prepare(system, 2.0, 10)
    for q, qd in ((q0, qd0), other_state(system, q0, qd0)):
        result = prepared.run(q, qd)
        same(result, forward_dynamics(system, q, qd, 2.0, 10))
        assert result.info["divergence"]["positions"] is not None  # the companion ran


def test_bad_input_is_refused_as_forward_dynamics_refuses_it(scenes):
    system, q0, qd0 = scenes["double_pendulum"]
    with pytest.raises(AnalysisError) as called:
        forward_dynamics(system, q0, qd0, 1.0, 10, integrator="euler")
    with pytest.raises(AnalysisError) as prepared:
        prepare(system, 1.0, 10, integrator="euler")
    assert str(prepared.value) == str(called.value)
    with pytest.raises(AnalysisError) as called:  # a run that cannot start: at its run, as the call's
        forward_dynamics(system, q0[:-1], qd0, 1.0, 10)
    with pytest.raises(AnalysisError) as prepared:
        prepare(system, 1.0, 10).run(q0[:-1], qd0)
    assert str(prepared.value) == str(called.value)
