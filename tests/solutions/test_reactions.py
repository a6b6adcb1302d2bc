"""Joint reactions from the Lagrange multipliers, against statics and Newton's laws worked by hand.

- a hanging pendulum at rest: the pivot carries its weight, m g, and nothing else;
- a swinging compound pendulum: the pivot force is m a_G - m g with a_G from the energy integral
  (omega^2) and the moment equation about the pivot (alpha), evaluated at the computed angle;
- a wall bracket (beam pinned to the wall, propped by a strut): every pin force from the free-body
  diagrams of the beam and the strut;
- action and reaction: for any multipliers, a joint between two moving bodies exerts equal and
  opposite forces and moments about its point (the joint's equations do not change under a rigid
  motion of the pair).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.inverse_dynamics import inverse_dynamics
from solutions.io.model import load_model
from solutions.kinematics import assemble
from solutions.reactions import joint_reactions, reactions_at

G = 9.81


def pendulum_model(theta0: float, mass: float = 2.0, length: float = 1.0) -> dict:
    """A uniform rod pinned at its top end O = (0, 0), at angle theta0 from hanging straight down.

    Its body x axis points from O along the rod: phi = theta0 - pi/2.
    """
    a = length / 2
    centre = [a * math.sin(theta0), -a * math.cos(theta0)]
    return {
        "model": {
            "name": "pendulum",
            "gravity": [0.0, -G],
            "bodies": [
                {
                    "name": "rod",
                    "mass": mass,
                    "inertia": mass * length**2 / 12,
                    "location": centre,
                    "orientation": theta0 - math.pi / 2,
                }
            ],
            "joints": [{"name": "O", "type": "revolute", "body1": "ground", "body2": "rod", "location": [0.0, 0.0]}],
        }
    }


def test_hanging_pendulum_carries_its_weight():
    mass = 2.0
    system, q0, qd0 = build_system(load_model(pendulum_model(0.0, mass)))
    result = forward_dynamics(system, q0, qd0, 1.0, 10, rtol=1e-10, atol=1e-12)
    reactions = joint_reactions(system, result.q, result.lam, result.t, both_bodies=True)
    np.testing.assert_allclose(reactions["O.Fy"], mass * G, rtol=1e-10)
    np.testing.assert_allclose(reactions["O.Fx"], 0.0, atol=1e-10)
    np.testing.assert_allclose(reactions["O.Mz"], 0.0, atol=1e-10)
    # on ground: the rod pulls the pivot down
    np.testing.assert_allclose(reactions["O.ground.Fy"], -mass * G, rtol=1e-10)
    # in the rod's frame (x axis pointing down the rod) the pivot pulls along -x, towards itself
    np.testing.assert_allclose(reactions["O.rod.Fx_local"], -mass * G, rtol=1e-10)
    np.testing.assert_allclose(reactions["O.rod.Fy_local"], 0.0, atol=1e-10)


def test_swinging_pendulum_pivot_force_from_newton_euler():
    """F_O = m a_G - m g: with the pivot distance a, I_O = m l^2 / 3 and release from rest at theta0,

    omega^2 = 2 m g a (cos theta - cos theta0) / I_O,   alpha = -m g a sin theta / I_O,
    a_G = a alpha t - a omega^2 r,   r = (sin, -cos) from O to G, t = (cos, sin).
    """
    mass, length, theta0 = 2.0, 1.0, math.radians(70.0)
    a, inertia_o = length / 2, mass * length**2 / 3
    system, q0, qd0 = build_system(load_model(pendulum_model(theta0, mass, length)))
    result = forward_dynamics(system, q0, qd0, 2.0, 40, formulation="qr", integrator="DOP853", rtol=1e-11, atol=1e-12)
    reactions = joint_reactions(system, result.q, result.lam, result.t)
    theta = np.arctan2(result.q[:, 0], -result.q[:, 1])
    omega2 = 2 * mass * G * a * (np.cos(theta) - math.cos(theta0)) / inertia_o
    alpha = -mass * G * a * np.sin(theta) / inertia_o
    radial = np.stack([np.sin(theta), -np.cos(theta)], axis=1)
    tangent = np.stack([np.cos(theta), np.sin(theta)], axis=1)
    acceleration = a * alpha[:, None] * tangent - a * omega2[:, None] * radial
    expected = mass * acceleration - mass * np.array([0.0, -G])
    assert np.ptp(theta) > 2.0  # it really swings
    np.testing.assert_allclose(reactions["O.Fx"], expected[:, 0], atol=1e-7)
    np.testing.assert_allclose(reactions["O.Fy"], expected[:, 1], atol=1e-7)


def bracket_model(L=0.8, h=0.5, m_beam=3.0, m_strut=1.5, P=40.0) -> dict:
    """Beam A-B (A = (0, 0) on the wall, B = (L, 0)), strut C-B (C = (0, -h) on the wall), load P down at B."""
    return {
        "model": {
            "name": "bracket",
            "gravity": [0.0, -G],
            "bodies": [
                {"name": "beam", "mass": m_beam, "inertia": 0.2, "location": [L / 2, 0.0]},
                {
                    "name": "strut",
                    "mass": m_strut,
                    "inertia": 0.1,
                    "location": [L / 2, -h / 2],
                    "orientation": math.atan2(h, L),
                },
            ],
            "joints": [
                {"name": "A", "type": "revolute", "body1": "ground", "body2": "beam", "location": [0.0, 0.0]},
                {"name": "B", "type": "revolute", "body1": "beam", "body2": "strut", "location": [L, 0.0]},
                {"name": "C", "type": "revolute", "body1": "ground", "body2": "strut", "location": [0.0, -h]},
            ],
            "forces": [{"name": "P", "type": "force", "body": "beam", "point": [L, 0.0], "value": [0.0, -P]}],
        }
    }


def test_wall_bracket_statics_by_hand():
    """Free bodies (F_B = (Bx, By) the strut's force on the beam at B, W = m g):

    beam, moments about A:   L By - W1 L/2 - P L = 0            -> By = W1/2 + P
    strut, moments about C:  (L, h) x (-F_B) + (L/2, h/2) x (0, -W2) = 0 -> Bx = L (By + W2/2) / h
    beam, forces:            A = (-Bx, W1 + P - By);   strut, forces: C = (Bx, By + W2)
    """
    L, h, m1, m2, P = 0.8, 0.5, 3.0, 1.5, 40.0
    W1, W2 = m1 * G, m2 * G
    By = W1 / 2 + P
    Bx = L * (By + W2 / 2) / h
    A = (-Bx, W1 + P - By)
    C = (Bx, By + W2)
    system, q0, _ = build_system(load_model(bracket_model(L, h, m1, m2, P)))
    result = inverse_dynamics(system, q0, 1.0, 2)  # a structure: no motion, statics at every time
    r = joint_reactions(system, result.q, result.lam, result.t, both_bodies=True)
    expected = {
        "A.Fx": A[0],
        "A.Fy": A[1],
        "B.Fx": -Bx,  # on the strut (the joint's second body)
        "B.Fy": -By,
        "B.beam.Fx": Bx,  # on the beam
        "B.beam.Fy": By,
        "C.Fx": C[0],
        "C.Fy": C[1],
        "A.ground.Fx": -A[0],
        "C.ground.Fy": -C[1],
    }
    for key, value in expected.items():
        np.testing.assert_allclose(r[key], value, rtol=1e-10, err_msg=key)
    for key in ("A.Mz", "B.Mz", "C.Mz", "B.beam.Mz"):
        np.testing.assert_allclose(r[key], 0.0, atol=1e-9, err_msg=key)
    # the strut's force in its own frame: along the strut's axis and across it
    angle = math.atan2(h, L)
    along = -Bx * math.cos(angle) - By * math.sin(angle)
    across = Bx * math.sin(angle) - By * math.cos(angle)
    np.testing.assert_allclose(r["B.strut.Fx_local"], along, rtol=1e-10)
    np.testing.assert_allclose(r["B.strut.Fy_local"], across, rtol=1e-10)


def four_bar_slider_model() -> dict:
    """Three moving bodies joined by a revolute, a prismatic, a revolute-revolute and a pin-in-slot joint."""
    return {
        "model": {
            "gravity": [0.0, -G],
            "bodies": [
                {"name": "a", "mass": 1.0, "inertia": 0.1, "location": [0.0, 0.0], "orientation": 0.3},
                {"name": "b", "mass": 1.0, "inertia": 0.1, "location": [0.5, 0.2], "orientation": -0.4},
                {"name": "c", "mass": 1.0, "inertia": 0.1, "location": [0.9, -0.3], "orientation": 1.1},
            ],
            "joints": [
                {"name": "R", "type": "revolute", "body1": "a", "body2": "b", "location": [0.3, 0.1]},
                {"name": "P", "type": "prismatic", "body1": "b", "body2": "c", "location": [0.8, 0.0], "axis": [1, 1]},
                {"name": "D", "type": "revolute_revolute", "body1": "a", "body2": "c", "point1": [0.0, 0.1],
                 "point2": [0.9, -0.2]},
                {"name": "S", "type": "revolute_prismatic", "body1": "a", "body2": "b", "location": [0.4, 0.3],
                 "axis": [0.0, 1.0]},
            ],
        }
    }  # fmt: skip


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_action_equals_reaction_between_moving_bodies(seed):
    rng = np.random.default_rng(seed)
    system, q0, _ = build_system(load_model(four_bar_slider_model()))
    q, _ = assemble(system, q0 + 0.05 * rng.standard_normal(q0.size))  # on Psi = 0: a moment balance needs it
    lam = rng.standard_normal(system.n_constraints)
    for reaction in reactions_at(system, q, lam):
        np.testing.assert_allclose(reaction.force[0], -reaction.force[1], atol=1e-12, err_msg=reaction.joint)
        np.testing.assert_allclose(reaction.moment[0], -reaction.moment[1], atol=1e-12, err_msg=reaction.joint)
    revolute = next(r for r in reactions_at(system, q, lam) if r.joint == "R")
    assert abs(revolute.moment[1]) < 1e-12  # a pin transmits no moment about itself
    prismatic = next(r for r in reactions_at(system, q, lam) if r.joint == "P")
    assert abs(prismatic.moment[1]) > 1e-6  # a prismatic joint does


def test_single_state_gives_floats_and_history_gives_arrays():
    system, q0, _ = build_system(load_model(pendulum_model(0.3)))
    lam = np.array([1.0, 2.0])
    single = joint_reactions(system, q0, lam)
    history = joint_reactions(system, np.vstack([q0, q0]), np.vstack([lam, lam]), [0.0, 1.0])
    assert isinstance(single["O.Fx"], float)
    assert history["O.Fx"].shape == (2,)
    # Psi = r_ground - (r + A s') for the pin, so the force on the rod is +lambda
    assert single["O.Fx"] == pytest.approx(1.0) and single["O.Fy"] == pytest.approx(2.0)
