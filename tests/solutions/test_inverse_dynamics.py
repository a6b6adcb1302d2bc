"""Inverse dynamics of a driven slider-crank against a Newton-Euler solution derived by hand.

The crank (radius r, centre at r/2) turns at the constant rate w; the rod (length l, centre at its
middle) joins it to a slider moving on the x axis whose centre sits hs above the pin B, so the
prismatic joint must also carry a moment. Gravity and a gas force F(t) on the slider act. Every
expected value below comes from the free-body diagrams, solved from the slider back to the crank.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError
from solutions.inverse_dynamics import inverse_dynamics
from solutions.io.model import load_model

G = 9.81
R, L, W = 0.1, 0.3, 10.0  # crank, rod, crank rate
M1, I1, M2, I2, M3, I3 = 0.8, 9e-4, 1.2, 1.1e-2, 2.0, 2e-3
HS = 0.02  # slider centre above the pin
GAS = (-20.0, -100.0)  # F_gas(t) = -20 - 100 t in x, at the slider's centre


def slider_crank(motor: bool = True) -> dict:
    bodies = [
        {"name": "crank", "mass": M1, "inertia": I1, "location": [R / 2, 0.0]},
        {"name": "rod", "mass": M2, "inertia": I2, "location": [R + L / 2, 0.0]},
        {"name": "slider", "mass": M3, "inertia": I3, "location": [R + L, HS]},
    ]
    joints = [
        {"name": "O", "type": "revolute", "body1": "ground", "body2": "crank", "location": [0.0, 0.0]},
        {"name": "A", "type": "revolute", "body1": "crank", "body2": "rod", "location": [R, 0.0]},
        {"name": "B", "type": "revolute", "body1": "rod", "body2": "slider", "location": [R + L, 0.0]},
        {"name": "S", "type": "prismatic", "body1": "ground", "body2": "slider", "location": [R + L, 0.0],
         "axis": [1.0, 0.0]},
    ]  # fmt: skip
    drive = {"type": "polynomial", "coefficients": [0, W]}
    motors = [{"name": "drive", "type": "angle", "joint": "O", "function": drive}]
    gas = {"type": "polynomial", "coefficients": list(GAS)}
    forces = [{"name": "gas", "type": "force", "body": "slider", "value": [gas, 0.0]}]
    model = {"name": "slider-crank", "gravity": [0.0, -G], "bodies": bodies, "joints": joints, "forces": forces}
    model["motors"] = motors if motor else []
    return {"model": model}


def cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def newton_euler(t: float) -> dict[str, float]:
    """Reactions and driver torque at time t from the free-body diagrams.

    Kinematics (theta = w t, rod angle phi with r sin(theta) + l sin(phi) = 0, differentiated twice):
        phi' = -r w cos(theta) / (l cos(phi)),  phi'' = (r w^2 sin(theta) + l phi'^2 sin(phi)) / (l cos(phi))
        a_A = -r w^2 e1,  a_G2 = a_A + l/2 (phi'' e2_perp - phi'^2 e2),  a_B = a_A + l (phi'' e2_perp - phi'^2 e2)
    Forces (F_B: rod on slider, F_A: crank on rod, F_O: ground on crank, g = (0, -G)):
        slider x:             M3 a_Bx = F_Bx + F_gas
        rod, moments about G2: I2 phi'' = -(l/2) e2 x F_A - (l/2) e2 x F_B,  F_A = M2 (a_G2 - g) + F_B
                               -> F_By from  l e2 x F_B = -I2 phi'' - (l/2) e2 x M2 (a_G2 - g)
        slider y:             0 = F_By + N - M3 G
        slider, moments about its centre: (0, -hs) x (F_B + (0, N)) + M_S = 0  -> M_S = -hs F_Bx
        crank:                F_O = M1 (a_G1 - g) + F_A,  T = (r/2) e1 x (F_O + F_A)
    """
    theta = W * t
    e1 = np.array([math.cos(theta), math.sin(theta)])
    s2 = -R * math.sin(theta) / L
    c2 = math.sqrt(1.0 - s2 * s2)
    e2, e2p = np.array([c2, s2]), np.array([-s2, c2])
    w2 = -R * W * math.cos(theta) / (L * c2)
    al2 = (R * W**2 * math.sin(theta) + L * w2**2 * s2) / (L * c2)
    a_A = -R * W**2 * e1
    a_G1 = -R / 2 * W**2 * e1
    a_G2 = a_A + L / 2 * (al2 * e2p - w2**2 * e2)
    a_B = a_A + L * (al2 * e2p - w2**2 * e2)
    assert abs(a_B[1]) < 1e-9  # the slider stays on its line
    g = np.array([0.0, -G])
    gas = GAS[0] + GAS[1] * t
    F_Bx = M3 * a_B[0] - gas
    rod_inertia = M2 * (a_G2 - g)
    # l (c2 F_By - s2 F_Bx) = -I2 al2 - (l/2) e2 x rod_inertia
    F_By = (-I2 * al2 - L / 2 * cross(e2, rod_inertia) + L * s2 * F_Bx) / (L * c2)
    F_B = np.array([F_Bx, F_By])
    N = M3 * G - F_By
    F_A = rod_inertia + F_B
    F_O = M1 * (a_G1 - g) + F_A
    T = R / 2 * (cross(e1, F_O) + cross(e1, F_A))
    return {
        "O.Fx": F_O[0],
        "O.Fy": F_O[1],
        "A.Fx": F_A[0],
        "A.Fy": F_A[1],
        "B.Fx": F_B[0],
        "B.Fy": F_B[1],
        "S.Fx": 0.0,
        "S.Fy": N,
        "S.Mz": -HS * F_Bx,
        "drive.Mz": T,
        "drive.effort": T,
    }


def test_driven_slider_crank_against_newton_euler():
    system, q0, _ = build_system(load_model(slider_crank()))
    t_end, steps = 2 * math.pi / W, 48
    result = inverse_dynamics(system, q0, t_end, steps)
    expected = {key: np.array([newton_euler(t)[key] for t in result.t]) for key in newton_euler(0.0)}
    for key, values in expected.items():
        scale = max(1.0, float(np.max(np.abs(values))))
        np.testing.assert_allclose(result.reactions[key], values, rtol=0, atol=1e-9 * scale, err_msg=key)
    for key in ("O.Mz", "A.Mz", "B.Mz", "drive.Fx", "drive.Fy"):
        np.testing.assert_allclose(result.reactions[key], 0.0, atol=1e-9, err_msg=key)
    assert np.ptp(expected["drive.Mz"]) > 1.0  # the torque really varies over the turn
    assert result.lam.shape == (steps + 1, system.n_constraints)
    assert result.info["analysis"] == "inverse"
    assert result.info["max_equation_residual"] < 1e-9


def test_inverse_dynamics_needs_a_fully_driven_mechanism():
    system, q0, _ = build_system(load_model(slider_crank(motor=False)))
    with pytest.raises(AnalysisError, match="degree"):
        inverse_dynamics(system, q0, 0.1, 2)
