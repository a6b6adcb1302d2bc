"""Point masses in every formulation (issue 29): a body given with inertia 0 (spatial [0, 0, 0]) is a point mass.
Where its joints hold it off its centre (a bob at the end of a massless link) its rotation moves its mass and M
stays regular on the motions the joints allow; where they leave it free to turn about its centre (a bead pinned at
its centre, a bob on a spherical joint turning about the line to the joint) that turn moves no mass and the run
gives it a nominal inertia on those axes alone, at rest. Either way every formulation, projection included, gives
the motion of the particles, checked here against their own equations integrated by scipy at tight tolerance."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError
from solutions.dynamics import forward_dynamics
from solutions.formulations import FORMULATIONS
from solutions.io.model import load_model

G = 9.81
FORMULATION_NAMES = [*FORMULATIONS, "joint-coordinates"]
SPAN, STEPS = 1.0, 10


def run(data: dict, formulation: str):
    return forward_dynamics(
        *build_system(load_model(data)), SPAN, STEPS, formulation=formulation, rtol=1e-10, atol=1e-10, engine="numpy"
    )


def spherical_bob(spin: float = 0.0) -> dict:
    """A 1 kg point mass on a spherical joint at the origin, 1 m away along x, thrown along y; ``spin`` about the
    line to the joint, which a point cannot have."""
    bob = {"name": "bob", "mass": 1.0, "inertia": [0, 0, 0], "location": [1.0, 0.0, 0.0], "velocity": [0, 1.5, 0.5]}
    bob["angular_velocity"] = [spin, 0.0, 0.0]
    joint = {"name": "O", "type": "spherical", "body1": "ground", "body2": "bob", "location": [0, 0, 0]}
    return {"model": {"name": "bob", "dimension": 3, "gravity": [0, 0, -G], "bodies": [bob], "joints": [joint]}}


def particle_on_sphere(t: np.ndarray) -> np.ndarray:
    """The bob's path from r'' = g + mu r on |r| = 1, mu = -(|r'|^2 + g.r) (the joint's pull per unit mass)."""

    def rhs(_, y):
        r, v = y[:3], y[3:]
        g = np.array([0.0, 0.0, -G])
        return np.concatenate([v, g - (v @ v + g @ r) * r])

    y0 = [1.0, 0.0, 0.0, 0.0, 1.5, 0.5]
    return solve_ivp(rhs, (0.0, t[-1]), y0, method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t).y[:3].T


@pytest.fixture(scope="module")
def sphere_reference() -> np.ndarray:
    return particle_on_sphere(np.linspace(0.0, SPAN, STEPS + 1))


@pytest.mark.parametrize("formulation", FORMULATION_NAMES)
def test_a_point_mass_on_a_spherical_joint_turns_freely_about_the_link(formulation, sphere_reference):
    result = run(spherical_bob(), formulation)
    path = result.q[:, :3]
    np.testing.assert_allclose(path, sphere_reference, atol=1e-7)
    assert "'bob': singular inertia (a point mass) free to turn" in result.info["notes"][0]
    omega = np.einsum("kij,kj->ki", _g(result), result.qd[:, 3:])
    np.testing.assert_allclose(np.sum(path * omega, axis=1), 0.0, atol=1e-7)  # the turn along the link stays at rest


def _g(result) -> np.ndarray:
    """2 G(p) of every output time (omega = 2 G p', global; Nikravesh 1988, eq. 6.62)."""
    e0, e1, e2, e3 = result.q[:, 3:].T
    return 2 * np.stack(
        [
            np.stack([-e1, e0, -e3, e2], axis=1),
            np.stack([-e2, e3, e0, -e1], axis=1),
            np.stack([-e3, -e2, e1, e0], axis=1),
        ],
        axis=1,
    )


def test_a_spin_given_to_a_point_mass_is_taken_out(sphere_reference):
    """The file's angular velocity along the link is a turn that moves no mass: the run starts it at rest, and the
    bob moves as without it (a spin kept would couple through the nominal inertia's gyroscopic term)."""
    result = run(spherical_bob(spin=7.0), "baumgarte")
    np.testing.assert_allclose(result.q[:, :3], sphere_reference, atol=1e-7)


def bead_on_a_rod(torque: float = 0.0) -> dict:
    """A 1 m rod (2 kg) pinned at the origin, released level, with a 0.5 kg point mass pinned at its far end at the
    point mass's centre: the bead turns freely on its pin."""
    bodies = [
        {"name": "rod", "mass": 2.0, "inertia": 2.0 / 12, "location": [0.5, 0.0]},
        {"name": "bead", "mass": 0.5, "inertia": 0.0, "location": [1.0, 0.0]},
    ]
    joints = [
        {"name": "O", "type": "revolute", "body1": "ground", "body2": "rod", "location": [0.0, 0.0]},
        {"name": "A", "type": "revolute", "body1": "rod", "body2": "bead", "location": [1.0, 0.0]},
    ]
    model = {"name": "bead", "dimension": 2, "gravity": [0.0, -G], "bodies": bodies, "joints": joints}
    if torque:
        model["forces"] = [{"name": "twist", "type": "torque", "body": "bead", "value": torque}]
    return {"model": model}


def compound_pendulum(t: np.ndarray) -> np.ndarray:
    """theta(t) of the rod with the bead at its tip: I_O theta'' = -(m_r L / 2 + m_b L) g cos(theta)."""
    inertia, moment = 2.0 / 3 + 0.5, (2.0 * 0.5 + 0.5) * G
    solution = solve_ivp(
        lambda _, y: [y[1], -moment * math.cos(y[0]) / inertia], (0, t[-1]), [0.0, 0.0], method="DOP853",
        rtol=1e-13, atol=1e-13, t_eval=t,
    )  # fmt: skip
    return solution.y[0]


@pytest.fixture(scope="module")
def rod_reference() -> np.ndarray:
    return compound_pendulum(np.linspace(0.0, SPAN, STEPS + 1))


@pytest.mark.parametrize("formulation", FORMULATION_NAMES)
def test_a_bead_pinned_at_its_centre(formulation, rod_reference):
    result = run(bead_on_a_rod(), formulation)
    names = result.coordinate_names
    np.testing.assert_allclose(result.q[:, names.index("rod.phi")], rod_reference, atol=1e-7)
    tip = np.column_stack([np.cos(rod_reference), np.sin(rod_reference)])
    np.testing.assert_allclose(result.q[:, [names.index("bead.x"), names.index("bead.y")]], tip, atol=1e-7)


def test_a_torque_on_a_free_turn_is_refused():
    with pytest.raises(AnalysisError, match=r"bodies\[1\].inertia: 'bead' has a singular inertia and a torque acts"):
        run(bead_on_a_rod(torque=0.1), "baumgarte")


@pytest.mark.parametrize("formulation", ["projection", "augmented-lagrangian"])
def test_a_point_mass_at_the_end_of_a_link_in_the_projecting_formulations(formulation):
    """A 1 kg point mass 1 m from its pin (its rotation moves it: M regular on the joints' motions, singular
    itself): projection corrects through the matrix of eq. 5.30 instead of M^-1, which does not exist."""
    bob = {"name": "bob", "mass": 1.0, "inertia": 0.0, "location": [1.0, 0.0]}
    joint = {"name": "O", "type": "revolute", "body1": "ground", "body2": "bob", "location": [0.0, 0.0]}
    data = {"model": {"name": "p", "dimension": 2, "gravity": [0.0, -G], "bodies": [bob], "joints": [joint]}}
    result = run(data, formulation)
    t = result.t
    theta = solve_ivp(
        lambda _, y: [y[1], -G * math.cos(y[0])], (0, t[-1]), [0.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-13,
        t_eval=t,
    ).y[0]  # fmt: skip
    np.testing.assert_allclose(result.q[:, 0], np.cos(theta), atol=1e-7)
    np.testing.assert_allclose(result.q[:, 1], np.sin(theta), atol=1e-7)
    assert "notes" not in result.info  # no free turn here: nothing nominal
