"""What the force elements exert at the output times, compiled (solutions/compiled/element_history.py): every column
of ``generalized_forces.element_columns`` (the per-state methods students write) and V of ``energy.potential_energy``,
on every course model with springs, dampers, actuators or loads, planar and spatial, to rounding; and a compiled run's
result reports them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.energy import potential_energy
from solutions.generalized_forces import build_forces, element_columns
from solutions.io import load_model

pytest.importorskip("numba")

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
WITH_ELEMENTS = [
    path.stem for path in sorted(MODELS.glob("*.yaml")) if build_forces(load_model(str(path))).elements
]  # fmt: skip


def _states(name: str, count: int = 25):
    """The model's force model and states around its initial one (q, q' off the constraints: the columns are functions
    of any q, q'), at times over 2 s (the actuators' and loads' functions of time)."""
    model = load_model(str(MODELS / f"{name}.yaml"))
    _, q0, qd0 = build_system(model)
    rng = np.random.default_rng(7)
    q = q0 + 0.05 * rng.standard_normal((count, q0.size))
    qd = qd0 + rng.standard_normal((count, q0.size))
    return model, build_forces(model), np.linspace(0.0, 2.0, count), q, qd


def _close(got: np.ndarray, expected: np.ndarray) -> bool:
    """Equal to rounding: within 1e-13 of the column's largest magnitude."""
    return np.allclose(got, expected, rtol=0.0, atol=1e-13 * max(np.max(np.abs(expected)), 1e-300))


def test_the_course_has_planar_and_spatial_models_with_each_kind_of_element():
    kinds = set()
    for name in WITH_ELEMENTS:
        model, forces, *_ = _states(name, 1)
        kinds |= {(model.dimension, type(e).__name__) for e in forces.elements}
    assert {(2, "TSDA"), (2, "RSDA"), (2, "Torque"), (3, "TSDA"), (3, "RSDA")} <= kinds


@pytest.mark.parametrize("name", WITH_ELEMENTS)
def test_every_column_and_the_potential_are_the_per_state_methods(name):
    from solutions.compiled.element_history import element_history

    model, forces, t, q, qd = _states(name)
    columns, potential = element_history(forces, model.dimension, t, q, qd)
    expected = element_columns(forces, t, q, qd)
    assert list(columns) == list(expected)  # every column, in the per-state loop's order
    for label, values in expected.items():
        assert _close(columns[label], values), label
    assert _close(potential, potential_energy(forces, q))


@pytest.mark.parametrize("name, formulation", [("four_bar_spring", "joint-coordinates"), ("cylindrical", "baumgarte")])
def test_a_compiled_run_reports_them(name, formulation):
    system, q0, qd0 = build_system(load_model(str(MODELS / f"{name}.yaml")))
    run = forward_dynamics(system, q0, qd0, 0.2, 10, formulation=formulation, rtol=1e-6, atol=1e-8, engine="compiled")
    assert run.info["chosen"]["engine"] == "compiled"
    forces = build_forces(system.model)
    expected = element_columns(forces, run.t, run.q, run.qd)
    assert list(run.forces) == list(expected)
    assert all(_close(run.forces[label], values) for label, values in expected.items())
    assert _close(run.points["energy.potential"], potential_energy(forces, run.q))


def test_a_spring_whose_points_meet_is_refused_as_by_the_per_state_methods():
    from solutions.compiled.element_history import element_history
    from solutions.planar.bodies import rotation

    model, forces, t, q, qd = _states("four_bar_spring", 3)
    spring = next(e for e in forces.elements if type(e).__name__ == "TSDA")
    i, j = spring.i, spring.j
    point_i = q[1, 3 * i : 3 * i + 2] + rotation(q[1, 3 * i + 2]) @ spring.si if i >= 0 else spring.si
    q[1, 3 * j : 3 * j + 2] = point_i - rotation(q[1, 3 * j + 2]) @ spring.sj + 5e-13  # P_j ~on P_i at time 2
    for columns in (element_columns, lambda *args: element_history(forces, 2, *args[1:])):
        with pytest.raises(ValueError, match="two points coincide"):
            columns(forces, t, q, qd)
