"""Energy conservation and the energy balance over runs (the work theorem, eq. 5.60).

Conservative scenes keep T + V constant; with dampers, actuators, loads and drivers the balance
T + V + D - W_applied - W_drivers stays constant while T + V alone changes by far more, so a missing
or wrong term (a sign, a factor, the drivers' work) shows. T and V are recomputed here from the
run's q, q' with the masses and geometry of the scene, not with the code under test.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.formulations import FORMULATIONS
from solutions.io.model import load_model

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
G = 9.81


def run(model, t_end, steps=50, **options):
    model = load_model(model)
    system, q0, qd0 = build_system(model)
    options = {"integrator": "DOP853", "rtol": 1e-10, "atol": 1e-12, **options}
    return model, forward_dynamics(system, q0, qd0, t_end, steps, **options)


def mechanical_energy(model, result) -> np.ndarray:
    """T + V_gravity from the masses and inertias of the file (no spring)."""
    energy = np.zeros(result.t.size)
    for k, body in enumerate(model.bodies):
        v = result.qd[:, 3 * k : 3 * k + 3]
        energy += 0.5 * body.mass * (v[:, 0] ** 2 + v[:, 1] ** 2) + 0.5 * body.inertia * v[:, 2] ** 2
        energy -= body.mass * (result.q[:, 3 * k : 3 * k + 2] @ model.gravity)
    return energy


@pytest.mark.parametrize("formulation", list(FORMULATIONS))
def test_double_pendulum_conserves_energy(formulation):
    model, result = run(MODELS / "double_pendulum.yaml", 2.0, formulation=formulation)
    energy = mechanical_energy(model, result)
    scale = np.ptp(0.5 * np.einsum("ij,ij->i", result.qd, result.qd))  # something of order T
    assert scale > 1.0
    # augmented-lagrangian: its regularized projections (penalty 1e7) move the energy by about 4e-8 here: a
    # known shortfall beside the exact mass-orthogonal projection (issue 14 report), bounded at 1e-7
    loose = formulation == "augmented-lagrangian"
    assert np.abs(energy - energy[0]).max() < (1e-7 if loose else 1e-8)
    np.testing.assert_allclose(result.points["energy.error"], energy - energy[0], atol=1e-12)
    assert result.info["energy_drift_relative"] < (1e-8 if loose else 1e-9)


def four_bar_spring(damping=0.5, actuator=True) -> dict:
    import yaml

    spec = yaml.safe_load((MODELS / "four_bar_spring.yaml").read_text())
    spring = spec["model"]["spring_dampers"][0]
    spring["damping_coefficient"] = damping
    if not actuator:
        del spring["actuator"]
    return spec


def test_spring_four_bar_without_damper_conserves_t_plus_v():
    """Spring only: T + V_gravity + 1/2 k (l - l0)^2 constant, with l computed here from the rocker's pin B."""
    model, result = run(four_bar_spring(damping=0.0, actuator=False), 1.0)
    rocker = result.q[:, 6:9]
    # B in the rocker's frame from the file's configuration, s_B = A(phi)^T (B - r)
    r0, phi0 = np.array([0.25, 0.12]), 1.96559
    c, s = math.cos(phi0), math.sin(phi0)
    s_B = np.array([[c, s], [-s, c]]) @ (np.array([0.2, 0.24]) - r0)
    cos, sin = np.cos(rocker[:, 2]), np.sin(rocker[:, 2])
    B = rocker[:, :2] + np.column_stack([cos * s_B[0] - sin * s_B[1], sin * s_B[0] + cos * s_B[1]])
    length = np.linalg.norm(B - [0.0, 0.3], axis=1)
    energy = mechanical_energy(model, result) + 0.5 * 50.0 * (length - 0.15) ** 2
    assert np.ptp(result.points["energy.kinetic"]) > 0.05
    assert np.abs(energy - energy[0]).max() < 1e-9


@pytest.mark.parametrize("formulation", ["baumgarte", "partitioning", "svd"])
def test_damped_actuated_four_bar_balances(formulation):
    model, result = run(four_bar_spring(), 1.0, formulation=formulation)
    p = result.points
    assert np.all(np.diff(p["energy.dissipated"]) >= 0) and p["energy.dissipated"][-1] > 1e-3
    assert np.abs(p["energy.applied"]).max() > 1e-3
    t_plus_v = p["energy.kinetic"] + p["energy.potential"]
    assert np.ptp(t_plus_v) > 1e-2  # so a balance to 1e-9 means something
    assert np.abs(p["energy.error"]).max() < 1e-9
    np.testing.assert_allclose(p["energy.kinetic"] + p["energy.potential"] - t_plus_v, 0.0)


def test_slider_crank_with_gas_force_and_load_torque_balances():
    """Work of a point force (the gas force on the piston) and a torque (the load on the flywheel)."""
    model, result = run(MODELS / "slider_crank_flywheel.yaml", 0.5)
    p = result.points
    # the load torque alone does work -5 N m times the crank's turn
    turn = result.coordinate("crank.phi")[-1] - result.coordinate("crank.phi")[0]
    assert turn > 20.0
    assert np.ptp(p["energy.applied"]) > 50.0
    assert np.abs(p["energy.error"]).max() < 1e-7 * np.ptp(p["energy.applied"])
    # the applied work is the gas force's work plus -5 N m per radian: check the torque's share by hand
    gas = model.forces[0]["value"][0]
    t = result.t
    force = gas["offset"] + gas["amplitude"] * np.sin(gas["frequency"] * t + gas["phase"])
    gas_power = force * result.coordinate("piston.x", 1)
    gas_work = np.concatenate([[0.0], np.cumsum(0.5 * (gas_power[1:] + gas_power[:-1]) * np.diff(t))])
    assert p["energy.applied"][-1] == pytest.approx(gas_work[-1] - 5.0 * turn, rel=2e-2)  # trapezoid rule


def test_quarter_car_balances_with_the_road_drivers_work():
    """The road is moved by coordinate motors: their work enters through lambda^T Psi_t."""
    model, result = run(MODELS / "quarter_car.yaml", 1.0, steps=100, integrator="RK45", rtol=1e-9, atol=1e-11)
    p = result.points
    assert p["energy.drivers"][-1] > 10.0  # the road lifts 285 kg by 5 cm: about 140 J
    assert np.abs(p["energy.error"]).max() < 1e-6 * p["energy.drivers"][-1]


def test_driven_double_pendulum_balances_with_the_motor_work():
    """An angle motor swings the lower rod relative to the upper one (1 degree of freedom left)."""
    import yaml

    spec = yaml.safe_load((MODELS / "double_pendulum.yaml").read_text())
    spec["model"]["motors"] = [
        {
            "name": "elbow",
            "type": "angle",
            "joint": "A",
            "function": {"type": "harmonic", "amplitude": 0.5, "frequency": 4.0},
        }
    ]
    model, result = run(spec, 2.0)
    p = result.points
    assert np.abs(p["energy.drivers"]).max() > 0.1
    assert np.ptp(p["energy.kinetic"] + p["energy.potential"]) > 0.1
    assert np.abs(p["energy.error"]).max() < 1e-8
    np.testing.assert_allclose(
        result.coordinate("lower.phi") - result.coordinate("upper.phi"),
        math.pi / 6 + 0.5 * np.sin(4.0 * result.t),
        atol=1e-9,
    )


def test_the_energy_scale_is_the_largest_part_part_by_part_with_nan_and_inf():
    """``EnergyHistory.scale`` (from one array of the five parts) is its definition taken part by part: the
    largest of max |T|, max |V - V(0)|, max |D|, max |W_applied|, max |W_drivers| in that order, a NaN kept as
    Python's max keeps it, 1 where every part is zero; bit for bit on random histories."""
    from solutions.energy import EnergyHistory

    rng = np.random.default_rng(5)
    for _ in range(2000):
        n = int(rng.integers(1, 40))
        parts = [rng.normal(size=n) * 10.0 ** rng.integers(-20, 5) for _ in range(5)]
        for part in parts:
            draw = rng.random()
            if draw < 0.05:
                part[rng.integers(n)] = np.nan
            elif draw < 0.1:
                part[rng.integers(n)] = -np.inf
            elif draw < 0.3:
                part[:] = 0.0
        history = EnergyHistory(*parts)
        with np.errstate(invalid="ignore"):  # inf - inf in V - V(0)
            by_part = [np.abs(p).max() for p in (parts[0], parts[1] - parts[1][0], *parts[2:])]
            scale = history.scale
        expected = float(max(by_part)) or 1.0
        assert np.array([scale]).tobytes() == np.array([expected]).tobytes()
