"""Mechanisms written for the tests of singular positions and redundant constraints (issue 14), with the
one-degree-of-freedom equations of motion derived by hand from their geometry (not from the solver).

- ``parallelogram_chain(n)``: n parallelogram loops side by side (Gonzalez et al. 2006, problem A03 of the
  IFToMM benchmark library): n + 1 cranks of length L pinned to ground at x = 0, L, ..., n L, their tips
  joined by n couplers of length L. Every bar is a uniform rod (mass m, length L). Released with the cranks
  upright and the tips moving at ``speed`` to +x, it falls under gravity; every loop stays a parallelogram,
  so the cranks turn by one angle theta and the couplers translate. Twice a turn (theta = 0, pi) every bar
  lies on the ground line and Psi_q loses one rank per loop.
- ``sarrus(...)``: the Sarrus linkage, an over-constrained spatial 6R loop: a top plate joined to ground
  by two legs of two links, the three hinge axes of one leg parallel to x, those of the other to y. The
  Gruebler count gives 0 degrees of freedom (6 x 5 - 5 x 6); the geometry gives 1, the plate's height.
"""

from __future__ import annotations

import math

import numpy as np

G = 9.81


# -- the chain of parallelogram loops ----------------------------------------------------------------
def parallelogram_chain(n: int, length: float = 1.0, mass: float = 1.0, speed: float = 1.0, end_time: float = 1.0):
    """The model (a mapping for ``load_model``) of n parallelogram loops, cranks upright, tips at ``speed``."""
    L, m = length, mass
    rod = m * L * L / 12.0
    omega = -speed / L  # theta' < 0: the upright cranks' tips move to +x
    bodies, joints = [], []
    for k in range(n + 1):
        bodies.append(
            {
                "name": f"crank{k}",
                "mass": m,
                "inertia": rod,
                "location": [k * L, L / 2],
                "orientation": math.pi / 2,
                "velocity": [-omega * L / 2, 0.0],
                "angular_velocity": omega,
            }
        )
        joints.append(
            {"name": f"O{k}", "type": "revolute", "body1": "ground", "body2": f"crank{k}", "location": [k * L, 0.0]}
        )
    for k in range(n):
        bodies.append(
            {
                "name": f"coupler{k}",
                "mass": m,
                "inertia": rod,
                "location": [k * L + L / 2, L],
                "orientation": 0.0,
                "velocity": [-omega * L, 0.0],
                "angular_velocity": 0.0,
            }
        )
        joints.append(
            {"name": f"A{k}", "type": "revolute", "body1": f"crank{k}", "body2": f"coupler{k}", "location": [k * L, L]}
        )
        joints.append(
            {
                "name": f"B{k}",
                "type": "revolute",
                "body1": f"crank{k + 1}",
                "body2": f"coupler{k}",
                "location": [(k + 1) * L, L],
            }
        )
    model = {
        "name": f"parallelogram-chain-{n}",
        "dimension": 2,
        "gravity": [0.0, -G],
        "bodies": bodies,
        "joints": joints,
    }
    return {"model": model, "simulation": {"analysis": "dynamic", "end_time": end_time, "output_steps": 100}}


def chain_theta(n: int, t: np.ndarray, length: float = 1.0, speed: float = 1.0, rtol: float = 1e-12) -> np.ndarray:
    """theta(t) of the chain from its own equation of motion, J theta'' = -dV/dtheta, integrated by scipy.

    With every loop a parallelogram: n + 1 cranks turning about their pivots (m L^2 / 3 each) and n
    couplers translating with their tips (m L^2 theta'^2 / 2 each), so with V = m g L sin(theta) ((n+1)/2 + n)

        ((n + 1) / 3 + n) L theta'' = -g cos(theta) ((n + 1) / 2 + n)
    """
    import scipy.integrate

    k = G * ((n + 1) / 2 + n) / (length * ((n + 1) / 3 + n))
    solution = scipy.integrate.solve_ivp(
        lambda _, y: [y[1], -k * math.cos(y[0])],
        (0.0, float(t[-1])),
        [math.pi / 2, -speed / length],
        method="DOP853",
        rtol=rtol,
        atol=1e-14,
        t_eval=t,
    )
    return solution.y[0]


# -- the Sarrus linkage --------------------------------------------------------------------------------
SARRUS = {"L": 0.5, "c": 0.3, "m": 1.0, "m_top": 2.0, "theta0": 0.6}
"""Link length L, half-width c of the plate, link mass m, plate mass m_top, initial link angle from the vertical."""


def sarrus(end_time: float = 1.0, theta0: float = SARRUS["theta0"]):
    """The Sarrus linkage (a mapping for ``load_model``), released at rest with its links theta0 off vertical.

    Leg a lies in the plane x = 0 beside the hinge line y = -c (hinges along x), leg b in the plane
    y = 0 beside x = c (hinges along y); each knee points outwards. The plate (a 2c x 2c square, at
    height z = 2 L cos(theta)) only translates vertically.
    """
    L, c, m, mt = SARRUS["L"], SARRUS["c"], SARRUS["m"], SARRUS["m_top"]
    s, h = L * math.sin(theta0), L * math.cos(theta0)
    rod = [m * L * L / 12.0] * 3  # the same about every axis: m L^2 / 12 about its hinge, whatever its tilt
    plate = [mt * (2 * c) ** 2 / 12.0, mt * (2 * c) ** 2 / 12.0, mt * (2 * c) ** 2 / 6.0]
    bodies = [
        {"name": "a1", "mass": m, "inertia": rod, "location": [0.0, -c - s / 2, h / 2]},
        {"name": "a2", "mass": m, "inertia": rod, "location": [0.0, -c - s / 2, 3 * h / 2]},
        {"name": "top", "mass": mt, "inertia": plate, "location": [0.0, 0.0, 2 * h]},
        {"name": "b2", "mass": m, "inertia": rod, "location": [c + s / 2, 0.0, 3 * h / 2]},
        {"name": "b1", "mass": m, "inertia": rod, "location": [c + s / 2, 0.0, h / 2]},
    ]
    x, y = [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]
    joints = [
        {"name": "A0", "type": "revolute", "body1": "ground", "body2": "a1", "location": [0.0, -c, 0.0], "axis": x},
        {"name": "A1", "type": "revolute", "body1": "a1", "body2": "a2", "location": [0.0, -c - s, h], "axis": x},
        {"name": "A2", "type": "revolute", "body1": "a2", "body2": "top", "location": [0.0, -c, 2 * h], "axis": x},
        {"name": "B2", "type": "revolute", "body1": "top", "body2": "b2", "location": [c, 0.0, 2 * h], "axis": y},
        {"name": "B1", "type": "revolute", "body1": "b2", "body2": "b1", "location": [c + s, 0.0, h], "axis": y},
        {"name": "B0", "type": "revolute", "body1": "b1", "body2": "ground", "location": [c, 0.0, 0.0], "axis": y},
    ]
    model = {"name": "sarrus", "dimension": 3, "gravity": [0.0, 0.0, -G], "bodies": bodies, "joints": joints}
    return {"model": model, "simulation": {"analysis": "dynamic", "end_time": end_time, "output_steps": 100}}


def sarrus_theta(t: np.ndarray, theta0: float = SARRUS["theta0"], rtol: float = 1e-12) -> np.ndarray:
    """The links' angle theta(t) from the vertical, from Lagrange's equation in theta alone, by scipy.

    Per leg: the lower link turns about its ground hinge (J = I + m L^2 / 4); the upper link's centre is at
    (L sin / 2, 3 L cos / 2) in the leg's plane, it turns at -theta'; the plate rises at z' = -2 L sin theta'.
    T = J(theta) theta'^2 / 2, V(theta) = g cos(theta) L (4 m + 2 m_top) (both legs: m L/2 + 3 m L/2 each),
    J(theta) = 2 [2 I + m L^2 / 4 + m L^2 (cos^2 / 4 + 9 sin^2 / 4)] + 4 m_top L^2 sin^2,
    and J theta'' + J'(theta) theta'^2 / 2 + V'(theta) = 0.
    """
    import scipy.integrate

    L, m, mt = SARRUS["L"], SARRUS["m"], SARRUS["m_top"]
    inertia = m * L * L / 12.0

    def J(th):
        return 2 * (2 * inertia + m * L * L / 4 + m * L * L * (math.cos(th) ** 2 / 4 + 9 * math.sin(th) ** 2 / 4)) + (
            4 * mt * L * L * math.sin(th) ** 2
        )

    def dJ(th):
        return 8 * (m + mt) * L * L * math.sin(th) * math.cos(th)

    def dV(th):
        return -G * math.sin(th) * L * (4 * m + 2 * mt)

    def rhs(_, y):
        th, w = y
        return [w, -(0.5 * dJ(th) * w * w + dV(th)) / J(th)]

    solution = scipy.integrate.solve_ivp(
        rhs, (0.0, float(t[-1])), [theta0, 0.0], method="DOP853", rtol=rtol, atol=1e-14, t_eval=t
    )
    return solution.y[0]
