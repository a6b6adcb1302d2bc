"""The rates at the start of a forward-dynamic run (``dynamics.StartRates``): the spectral radius rho of the ODE's
Jacobian and q'', which the integrator's choice (``choose_method``) and the tolerance rule (``motion_periods``)
share.

- rho is estimated once per run (21 right-hand sides), not once for each of the two;
- a dissipative scene (its state carries the energy integrals) gets them too: its q'' at the start is the
  formulation's own accelerations, and its periods are counted (they were taken as 1, a failure to evaluate);
- a run asked to be compiled estimates them with the compiled right-hand side, never numpy's, and the two
  engines' estimates agree;
- the formulation object and compiled plan the compiled start rates made are the run's own (one of each per run).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from solutions import dynamics
from solutions.assembly import build_system, mechanism_size
from solutions.dynamics import (
    EquationsOfMotion,
    StartRates,
    consistent_initial_conditions,
    forward_dynamics,
    motion_periods,
)
from solutions.formulations import make_formulation
from solutions.generalized_forces import build_forces
from solutions.io.model import load_model
from solutions.mass_matrix import mass_matrix

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"


def _start(name: str):
    system, q0, qd0 = build_system(load_model(MODELS / f"{name}.yaml"))
    M, forces = mass_matrix(system.model), build_forces(system.model)
    q, qd, _ = consistent_initial_conditions(system, M, q0, qd0)
    return system, M, forces, q, qd


def test_the_spectral_radius_is_estimated_once_per_run(monkeypatch):
    calls = []
    original = dynamics.spectral_radius

    def counted(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(dynamics, "spectral_radius", counted)
    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    run = forward_dynamics(system, q0, qd0, 1.0, 10, engine="numpy")  # formulation and integrator: auto
    assert run.info["chosen"]["integrator"] == "dop853" and "spectral radius" in run.info["chosen"]["why"]
    assert len(calls) == 1  # shared by choose_method and motion_periods
    assert "periods" in run.info["rtol_rule"]


def test_a_dissipative_scene_gets_its_start_rates():
    system, M, forces, q, qd = _start("four_bar_spring")
    assert not forces.is_conservative  # its state carries the energy integrals
    rates = StartRates(system, M, forces, q, qd, {})
    start = rates("baumgarte")
    assert start is not None
    made = make_formulation("baumgarte", system, M, forces)
    qdd, _ = made.accelerations(q, qd, 0.0)
    assert np.allclose(start[1], qdd, rtol=1e-12, atol=1e-12)
    assert start[0] > 1.0  # the spring and Baumgarte's terms give the linearized motion its rates
    periods = motion_periods(system, M, forces, q, qd, 20.0, "baumgarte", {}, rates=rates)
    assert periods == pytest.approx(20.0 * max(start[0], np.max(np.abs(qd)) / mechanism_size(system, q),
                                               (np.max(np.abs(qdd)) / mechanism_size(system, q)) ** 0.5)
                                    / (2 * np.pi), rel=1e-12)  # fmt: skip


@pytest.mark.parametrize(
    ("name", "formulation"),
    [("double_pendulum", "baumgarte"), ("slider_crank", "baumgarte"), ("four_bar_spring", "baumgarte"),
     ("spatial_double_pendulum", "joint-coordinates"), ("carriage_pendulum", "joint-coordinates")],
)  # fmt: skip
def test_a_compiled_run_takes_its_start_rates_from_the_compiled_engine(monkeypatch, name, formulation):
    pytest.importorskip("numba")
    system, M, forces, q, qd = _start(name)
    numpy_start = StartRates(system, M, forces, q, qd, {})(formulation)
    evaluations = []
    original = EquationsOfMotion.rhs

    def counted(self, t, z):
        evaluations.append(1)
        return original(self, t, z)

    monkeypatch.setattr(EquationsOfMotion, "rhs", counted)
    compiled_start = StartRates(system, M, forces, q, qd, {}, compiled=True)(formulation)
    assert evaluations == []  # not one numpy right-hand side
    assert compiled_start[0] == pytest.approx(numpy_start[0], rel=1e-4)  # finite differences of two codes
    assert np.allclose(compiled_start[1], numpy_start[1], rtol=1e-10, atol=1e-10)


def test_a_compiled_run_makes_its_formulation_once(monkeypatch):
    """The formulation object the compiled start rates made is the run's own (``StartRates.take``), with the
    compiled plan made for it (``dispatch.compiled_plan``): one of each per run, where both the start rates and the
    run used to make their own; a second take finds none (the next run makes its own)."""
    pytest.importorskip("numba")
    from solutions.compiled import dispatch

    made, described = [], []
    original_make, original_plan = dynamics.make_formulation, dispatch.compiled_plan

    def counted_make(*args, **kwargs):
        made.append(original_make(*args, **kwargs))
        return made[-1]

    def counted_plan(equations, formulation):
        described.append(id(equations.formulation))
        return original_plan(equations, formulation)

    monkeypatch.setattr(dynamics, "make_formulation", counted_make)
    monkeypatch.setattr(dispatch, "compiled_plan", counted_plan)
    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    # divergence skipped: its companion run (a second run, judge_divergence) makes its own, as any run does
    options = dict(formulation="baumgarte", integrator="DOP853", rtol=1e-6, atol=1e-8, divergence="skip")
    run = forward_dynamics(system, q0, qd0, 0.2, 4, engine="compiled", **options)
    assert run.info["chosen"]["engine"] == "compiled"
    assert len(made) == 1 and set(described) == {id(made[0])}  # the start rates and the engine: one object
    numpy_run = forward_dynamics(system, q0, qd0, 0.2, 4, engine="numpy", **options)
    assert len(made) == 3  # numpy's start rates evaluate theirs: the run makes its own
    assert np.allclose(run.q, numpy_run.q, rtol=0, atol=1e-7)

    system, M, forces, q, qd = _start("double_pendulum")
    rates = StartRates(system, M, forces, q, qd, {}, compiled=True)
    rates("baumgarte")
    assert rates.take("baumgarte") is made[-1] and rates.take("baumgarte") is None
    numpy_rates = StartRates(system, M, forces, q, qd, {})
    numpy_rates("baumgarte")
    assert numpy_rates.take("baumgarte") is None  # evaluated by numpy: not handed over


def test_a_run_starts_from_the_state_its_start_rates_made(monkeypatch):
    """The run's z0 is the state the start rates were evaluated at where it runs their formulation object
    (``StartRates.initial_state``): the formulation's initial state is made once per compiled run (it was twice),
    with the energy states the run's equations carry (a driven scene: three, zero at the start); an object the start
    rates did not make (numpy's start rates keep theirs) makes its own. Either way the state the formulation gives."""
    pytest.importorskip("numba")
    from solutions.joint_coordinates import JointCoordinates

    made = []
    original = JointCoordinates.initial_state

    def counted(self, q, qd, t):
        made.append(id(self))
        return original(self, q, qd, t)

    monkeypatch.setattr(JointCoordinates, "initial_state", counted)
    system, q0, qd0 = build_system(load_model(MODELS / "carriage_pendulum_driven.yaml"))
    options = dict(integrator="DOP853", rtol=1e-6, divergence="skip")
    run = forward_dynamics(system, q0, qd0, 0.1, 2, "joint-coordinates", engine="compiled", **options)
    assert run.info["chosen"]["engine"] == "compiled" and len(made) == 1
    system, M, forces, q, qd = _start("carriage_pendulum_driven")
    for compiled in (True, False):
        rates = StartRates(system, M, forces, q, qd, {}, compiled=compiled)
        rates("joint-coordinates")
        formulation = rates.take("joint-coordinates") or make_formulation("joint-coordinates", system, M, forces)
        equations = EquationsOfMotion(formulation, forces, has_drivers=True)
        expected = np.concatenate([original(formulation, q, qd, 0.0), np.zeros(3)])
        made.clear()
        assert np.array_equal(rates.initial_state(equations), expected)
        assert len(made) == (0 if compiled else 1)


def test_a_run_the_engine_will_compile_takes_the_compiled_start_rates(monkeypatch):
    """The engine is chosen before the start rates: a run on engine ``cached`` (its code on disk) or ``auto`` (a
    numpy run estimated longer than loading it: LOAD_SECONDS = 0 here) takes rho from the compiled right-hand side,
    as on engine ``compiled``: the same rate (so the same default rtol, eq. 6.60) to the last bit, and the formulation
    object those rates made goes to the run; a short ``auto`` run stays on numpy with numpy's rate. Finite
    differences of two codes differ in the last digits: the rate says which engine estimated it."""
    pytest.importorskip("numba")
    from solutions.compiled import dispatch

    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    forward_dynamics(system, q0, qd0, 0.05, 1, "baumgarte", "DOP853", engine="compiled")  # the code on disk

    def start(engine: str):
        settings = dynamics.default_settings().replace(
            t_end=1.0, steps=10, formulation="baumgarte", integrator="DOP853", engine=engine
        )
        begun = dynamics.start_motion(dynamics.Run(system, q0, qd0, settings, None, None, None), "baumgarte", "DOP853")
        return begun.plan.rate, begun.rates.take("baumgarte") is not None

    compiled, numpy_rate = start("compiled"), start("numpy")
    assert compiled[1] and not numpy_rate[1] and compiled[0] != numpy_rate[0]
    assert compiled[0] == pytest.approx(numpy_rate[0], rel=1e-6)
    assert start("cached") == compiled
    assert start("auto") == numpy_rate  # 1 s of a double pendulum: about 0.1 s of numpy (estimated 0.06 s)
    monkeypatch.setattr(dispatch, "LOAD_SECONDS", 0.0)
    assert start("auto") == compiled


def test_a_short_run_on_the_default_engine_imports_no_numba():
    """A one-step run on ``auto`` (the default engine) stays on numpy without importing numba, even with the compiled
    code on disk: the engine's choice before the start rates estimates the numpy run first (results/startup.md)."""
    code = (
        "import sys; from solutions.assembly import build_system; from solutions.io.model import load_model; "
        "from solutions.dynamics import forward_dynamics; "
        f"r = forward_dynamics(*build_system(load_model({str(MODELS / 'double_pendulum.yaml')!r})), 0.01, 1); "
        "print(r.info['chosen']['engine'], 'numba' in sys.modules)"
    )
    env = {k: v for k, v in os.environ.items() if k != "MBD_ENGINE"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    assert out.split() == ["numpy", "False"], out


def test_an_auto_run_estimates_its_numpy_run_once(monkeypatch):
    """The engine's choice before the start rates estimates the numpy run (numpy evaluations, perhaps a trial of
    TRIAL_STEPS steps); the engine's choice after the plan takes that estimate where it was made at the run's rtol
    (here the rule's DEFAULT_RTOL: a short run): one estimate per run, as before the order changed."""
    from solutions.compiled import dispatch

    calls = []
    original = dispatch.estimated_numpy_seconds
    monkeypatch.setattr(dispatch, "estimated_numpy_seconds", lambda *a, **k: calls.append(1) or original(*a, **k))
    system, q0, qd0 = build_system(load_model(MODELS / "double_pendulum.yaml"))
    run = forward_dynamics(system, q0, qd0, 0.05, 2, "baumgarte", "DOP853", engine="auto", divergence="skip")
    assert run.info["chosen"]["engine"] == "numpy" and run.info["rtol"] == dynamics.DEFAULT_RTOL
    assert len(calls) == 1
