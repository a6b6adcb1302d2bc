"""The numpy engine's residual and reaction columns (solutions/output_history.py: from Psi, Psi_q and Psi_t stored at
every output time, all times at once) against the functions at one state that students write:
``dynamics.constraint_residuals`` (Psi and Psi_q evaluated anew) and ``reactions.joint_reactions`` (joint by joint,
eq. 5.70-5.71, 10.20-10.21); a mechanism without joints has no reaction columns."""

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.dynamics import constraint_residuals, forward_dynamics
from solutions.io import load_model
from solutions.reactions import joint_reactions

MODELS = [  # revolute, prismatic and loads (planar); spherical joints (spatial)
    "course/models/slider_crank_flywheel.yaml",
    "course/models/spatial_double_pendulum.yaml",
]


@pytest.mark.parametrize("path", MODELS)
def test_run_columns_match_the_functions_at_one_state(path):
    system, q0, qd0 = build_system(load_model(path))
    run = forward_dynamics(system, q0, qd0, 0.2, 8, "baumgarte", "dop853", rtol=1e-8, atol=1e-8, engine="numpy")
    expected = constraint_residuals(system, run.t, run.q, run.qd)
    for key, value in expected.items():
        assert np.allclose(run.points[key], value, rtol=1e-10, atol=1e-15), key
    expected = joint_reactions(system, run.q, run.lam, run.t)
    assert [key for key in run.reactions if key in expected] == list(expected)  # the CSV's order
    size = max(float(np.max(np.abs(v))) for v in expected.values())
    for key, value in expected.items():
        assert np.max(np.abs(run.reactions[key] - value)) <= 1e-12 * size, key


def test_a_free_body_has_no_reactions_and_falls_freely():
    model = {"model": {"name": "free", "dimension": 2, "gravity": [0.0, -9.81], "bodies": [
        {"name": "b", "mass": 2.0, "inertia": 0.1, "location": [0.0, 0.0], "orientation": 0.0,
         "velocity": [1.0, 0.0], "angular_velocity": 3.0}]}}  # fmt: skip
    system, q0, qd0 = build_system(load_model(model))
    run = forward_dynamics(system, q0, qd0, 0.5, 5, "baumgarte", "dop853", rtol=1e-10, atol=1e-12, engine="numpy")
    assert not [key for key in run.reactions if key.endswith((".Fx", ".Fy", ".Mz"))]
    t = run.t
    assert np.allclose(run.q, np.stack([t, -0.5 * 9.81 * t**2, 3.0 * t], axis=1), rtol=0, atol=1e-10)
    assert np.all(run.points["residual.position"] == 0.0)
