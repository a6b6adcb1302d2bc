"""Psi_q, Psi_t and gamma of every planar element, and of assembled systems, against finite differences.

What is checked, at random configurations q, velocities q' and times t (not on the constraint manifold:
the identities hold everywhere):

- Psi_q = dPsi/dq                          fourth-order central differences of ``constraints`` in each q_k
- Psi_t = dPsi/dt                          the same in t
- gamma = -(Psi_q q')_q q' - 2 Psi_qt q' - Psi_tt
        = -d^2/ds^2 Psi(q + q' s, t + s) at s = 0

The last line holds because along the straight path q(s) = q + q' s (zero acceleration) the second
derivative of Psi(q(s), t + s) is q'^T Psi_qq q' + 2 Psi_qt q' + Psi_tt, which is minus gamma by the
definition above. It is taken by the five-point stencil for f'', so gamma is checked against ``constraints``
alone, never against the element's own Jacobian.

Elements are evaluated through ``System`` so that ground (body index -1, q = 0, no columns) is covered:
each element is placed between two bodies, and between ground and a body in both orders.
"""

from __future__ import annotations

import math
import zlib
from pathlib import Path

import numpy as np
import pytest

from solutions.assembly import System, build_system
from solutions.functions import Constant, EccentricCircle, Fourier, Harmonic, Polynomial, SmoothRamp
from solutions.io.model import load_model
from solutions.planar.joints import (
    BodyCoordinate,
    Distance,
    FlatFaceCam,
    Gear,
    PinInSlot,
    RelativeAngle,
    Revolute,
    RollerCam,
    Translation,
)

REPO = Path(__file__).resolve().parents[2]
H = 1e-3  # step of the difference stencils
N_CONFIGURATIONS = 6


# -- finite differences ---------------------------------------------------------------------------------------
def d_ds(f, h=H):
    """f'(0) by the fourth-order central stencil."""
    return (-f(2 * h) + 8 * f(h) - 8 * f(-h) + f(-2 * h)) / (12 * h)


def d2_ds2(f, h=H):
    """f''(0) by the fourth-order central stencil."""
    return (-f(2 * h) + 16 * f(h) - 30 * f(0.0) + 16 * f(-h) - f(-2 * h)) / (12 * h * h)


def fd_jacobian(system: System, q, t, scale=None):
    """Column k: dPsi/dq_k, with the step H scaled by ``scale[k]`` (a length typical of the model)."""
    scale = np.ones_like(q) if scale is None else scale
    columns = []
    for k in range(q.size):
        e = np.zeros_like(q)
        e[k] = scale[k]
        columns.append(d_ds(lambda s, e=e: system.constraints(q + s * e, t)) / scale[k])
    return np.array(columns).T


def fd_psi_t(system: System, q, t):
    return d_ds(lambda s: system.constraints(q, t + s))


def fd_gamma(system: System, q, qd, t):
    return -d2_ds2(lambda s: system.constraints(q + s * qd, t + s))


def check_system(system: System, q, qd, t, what="", scale=None):
    """Compare Psi_q, Psi_t and gamma of ``system`` at (q, q', t) with finite differences."""
    jac = system.jacobian(q, t)
    assert jac.shape == (system.n_constraints, system.n_coordinates)
    np.testing.assert_allclose(jac, fd_jacobian(system, q, t, scale), rtol=1e-7, atol=1e-8, err_msg=f"Psi_q {what}")
    np.testing.assert_allclose(
        system.psi_t(q, t), fd_psi_t(system, q, t), rtol=1e-7, atol=1e-8, err_msg=f"Psi_t {what}"
    )
    gamma = system.gamma(q, qd, t)
    expected = fd_gamma(system, q, qd, t)
    scale = 1.0 + np.abs(expected)
    assert np.all(np.abs(gamma - expected) < 1e-6 * scale), f"gamma {what}: {gamma} against {expected}"


# -- the elements ---------------------------------------------------------------------------------------------
def _vec(rng, size=0.5):
    return rng.uniform(-size, size, 2)


def _unit(rng):
    angle = rng.uniform(-math.pi, math.pi)
    return np.array([math.cos(angle), math.sin(angle)])


ELEMENTS = {
    "revolute": lambda r, i, j: Revolute("R", i, j, si=_vec(r), sj=_vec(r)),
    "relative_angle": lambda r, i, j: RelativeAngle("A", i, j, phi0=r.uniform(-1, 1)),
    "relative_angle_driver": lambda r, i, j: RelativeAngle(
        "A", i, j, phi0=0.3, function=Polynomial((0.1, 2.0, -0.7, 0.3))
    ),
    "relative_angle_harmonic": lambda r, i, j: RelativeAngle("A", i, j, function=Harmonic(0.4, 3.0, 0.2, 0.1)),
    "pin_in_slot": lambda r, i, j: PinInSlot("P", i, j, si=_vec(r), sj=_vec(r), axis=_unit(r)),
    "distance_constant": lambda r, i, j: Distance("D", i, j, si=_vec(r), sj=_vec(r), length=Constant(0.8)),
    "distance_driver": lambda r, i, j: Distance(
        "D", i, j, si=_vec(r), sj=_vec(r), length=Harmonic(0.2, 2.5, 0.3, offset=0.9)
    ),
    "distance_ramp": lambda r, i, j: Distance("D", i, j, si=_vec(r), sj=_vec(r), length=SmoothRamp(0.0, 3.0, 0.5, 1.1)),
    "prismatic_driver": lambda r, i, j: Translation(
        "T", i, j, si=_vec(r), sj=_vec(r), axis=_unit(r), d0=0.2, function=Polynomial((0.0, 0.5, -1.0, 0.2))
    ),
    "rack_pinion_left": lambda r, i, j: Translation(
        "K", i, j, si=_vec(r), sj=_vec(r), axis=_unit(r), d0=0.1, pinion_radius=0.3, side=1.0
    ),
    "rack_pinion_right": lambda r, i, j: Translation(
        "K", i, j, si=_vec(r), sj=_vec(r), axis=_unit(r), pinion_radius=0.45, side=-1.0
    ),
    "gear_external": lambda r, i, j: Gear("G", i, j, si=_vec(r), sj=_vec(r), radius_i=0.3, radius_j=0.5, c0=0.2),
    "gear_internal": lambda r, i, j: Gear(
        "G", i, j, si=_vec(r), sj=_vec(r), radius_i=0.2, radius_j=0.7, sigma=-1.0, c0=-0.1
    ),
    "roller_cam_eccentric": lambda r, i, j: RollerCam(
        "C", i, j, si=_vec(r, 0.2), sj=_vec(r, 0.2), profile=EccentricCircle(0.6, 0.25)
    ),
    "roller_cam_fourier": lambda r, i, j: RollerCam(
        "C", i, j, si=_vec(r, 0.2), sj=_vec(r, 0.2), profile=Fourier(0.8, (0.1, -0.05, 0.02), (0.03, 0.04, -0.01))
    ),
    "flat_face_cam_fourier": lambda r, i, j: FlatFaceCam(
        "F", i, j, si=_vec(r), sj=_vec(r), normal=_unit(r), profile=Fourier(0.5, (0.1, 0.02), (-0.05, 0.03))
    ),
    "flat_face_cam_harmonic": lambda r, i, j: FlatFaceCam(
        "F", i, j, si=_vec(r), sj=_vec(r), normal=_unit(r), profile=Harmonic(0.15, 1.0, 0.4, 0.6)
    ),
}

PAIRS = [(0, 1), (1, 0), (-1, 0), (1, -1)]


def two_body_model():
    bodies = [
        {"name": "a", "mass": 1.0, "inertia": 0.1, "location": [0.0, 0.0]},
        {"name": "b", "mass": 1.0, "inertia": 0.1, "location": [1.0, 0.0]},
    ]
    return load_model({"model": {"name": "two bodies", "bodies": bodies}})


def continuous_near(system: System, q, qd, t) -> bool:
    """False when Psi jumps within the difference stencils: an angle-based element (gear, roller cam)
    near the branch cut of its atan2, which only matters far from the constraint manifold."""
    psi = system.constraints(q, t)
    steps = [s * e for e in np.eye(q.size) for s in (-2 * H, 2 * H)]
    nearby = [system.constraints(q + dq, t) for dq in steps]
    nearby += [system.constraints(q + s * qd, t + s) for s in (-2 * H, 2 * H)]
    return all(np.max(np.abs(p - psi)) < 0.2 for p in nearby)


def random_states(rng, system):
    """Random (q, q', t), away from discontinuities of Psi."""
    count = 0
    for _ in range(20 * N_CONFIGURATIONS):
        q = np.concatenate([[*rng.uniform(-1.0, 1.0, 2), rng.uniform(-math.pi, math.pi)] for _ in range(2)])
        qd = rng.uniform(-2.0, 2.0, system.n_coordinates)
        t = rng.uniform(0.0, 2.0)
        if continuous_near(system, q, qd, t):
            count += 1
            yield q, qd, t
        if count == N_CONFIGURATIONS:
            return
    raise AssertionError("too few random configurations where Psi is continuous")


@pytest.mark.parametrize("pair", PAIRS, ids=lambda p: f"i{p[0]}-j{p[1]}")
@pytest.mark.parametrize("kind", ELEMENTS)
def test_element_derivatives(kind, pair):
    rng = np.random.default_rng(zlib.crc32(f"{kind}{pair}".encode()))
    element = ELEMENTS[kind](rng, *pair)
    system = System(two_body_model(), [element])
    for q, qd, t in random_states(rng, system):
        check_system(system, q, qd, t, f"of {kind} between {pair} at q={q}, qd={qd}, t={t}")


@pytest.mark.parametrize("body", [0, 1])
@pytest.mark.parametrize("index", [0, 1, 2])
def test_body_coordinate_driver(index, body):
    rng = np.random.default_rng(index + 10 * body)
    element = BodyCoordinate("M", -1, body, index=index, function=Harmonic(0.3, 2.0, 0.1, 0.5))
    system = System(two_body_model(), [element])
    for q, qd, t in random_states(rng, system):
        check_system(system, q, qd, t, f"of BodyCoordinate {index} on body {body}")
        assert system.constraints(q, t)[0] == pytest.approx(q[3 * body + index] - (0.5 + 0.3 * math.sin(2 * t + 0.1)))


def test_elements_give_their_own_blocks():
    """The element methods directly: (Psi_qi, Psi_qj) are the two 1x3 or 2x3 column blocks of Psi_q."""
    rng = np.random.default_rng(7)
    for kind, make in ELEMENTS.items():
        element = make(rng, 0, 1)
        system = System(two_body_model(), [element])
        q, qd, t = next(random_states(rng, system))
        jac_i, jac_j = element.jacobian(q[:3], q[3:], t)
        full = fd_jacobian(system, q, t)
        np.testing.assert_allclose(np.hstack([jac_i, jac_j]), full, rtol=1e-7, atol=1e-8, err_msg=kind)
        assert element.constraints(q[:3], q[3:], t).shape == (element.n_equations,)
        assert element.gamma(q[:3], q[3:], qd[:3], qd[3:], t).shape == (element.n_equations,)


def test_joint_without_time_has_zero_psi_t():
    rng = np.random.default_rng(3)
    for kind in ("revolute", "pin_in_slot", "distance_constant", "rack_pinion_left", "gear_external"):
        element = ELEMENTS[kind](rng, 0, 1)
        q = rng.uniform(-1, 1, 6)
        assert np.all(element.psi_t(q[:3], q[3:], 0.7) == 0.0), kind


# -- whole models ---------------------------------------------------------------------------------------------
def every_element_model():
    """One model with every planar joint type and every motor type (not meant to be assembled)."""
    body = lambda name, x, y, phi: {  # noqa: E731
        "name": name,
        "mass": 1.0,
        "inertia": 0.01,
        "location": [x, y],
        "orientation": phi,
    }
    bodies = [
        body("crank", 0.1, 0.05, 0.3),
        body("slider", 0.6, 0.2, -0.2),
        body("arm", 0.3, -0.4, 1.0),
        body("link", -0.5, 0.3, 2.0),
        body("wheel", 1.2, -0.3, 0.4),
        body("pinion", 0.9, 0.8, -1.1),
        body("follower", -0.2, 1.1, 0.7),
    ]
    joints = [
        {"name": "O", "type": "revolute", "body1": "ground", "body2": "crank", "location": [0.0, 0.0]},
        {
            "name": "S",
            "type": "prismatic",
            "body1": "crank",
            "body2": "slider",
            "location": [0.5, 0.1],
            "axis": [1, 0.3],
        },
        {"name": "W", "type": "rigid", "body1": "slider", "body2": "arm", "location": [0.4, -0.1]},
        {
            "name": "L",
            "type": "revolute_revolute",
            "body1": "arm",
            "body2": "link",
            "point1": [0.2, -0.3],
            "point2": [-0.4, 0.2],
        },
        {
            "name": "Q",
            "type": "revolute_prismatic",
            "body1": "link",
            "body2": "wheel",
            "location": [1.0, -0.2],
            "axis": [0.2, 1.0],
        },
        {"name": "G", "type": "gear", "body1": "wheel", "body2": "pinion", "radius1": 0.6, "radius2": 0.5},
        {
            "name": "I",
            "type": "gear",
            "gear": "internal",
            "body1": "crank",
            "body2": "arm",
            "radius1": 0.2,
            "radius2": 0.7,
        },
        {
            "name": "K",
            "type": "rack_pinion",
            "body1": "slider",
            "body2": "pinion",
            "point1": [0.6, 0.5],
            "axis": [1.0, 0.1],
            "radius": 0.3,
        },
        {
            "name": "C",
            "type": "cam",
            "follower": "roller",
            "body1": "crank",
            "body2": "follower",
            "profile": {"type": "eccentric_circle", "radius": 1.0, "eccentricity": 0.3},
        },
        {
            "name": "F",
            "type": "cam",
            "follower": "flat",
            "body1": "link",
            "body2": "follower",
            "point2": [-0.2, 1.0],
            "axis": [0.3, 1.0],
            "profile": {"type": "fourier", "a0": 0.6, "a": [0.1], "b": [0.05]},
        },
    ]
    motors = [
        {"name": "m_angle", "type": "angle", "joint": "O", "function": {"type": "polynomial", "coefficients": [0, 3]}},
        {
            "name": "m_linear",
            "type": "linear",
            "joint": "S",
            "function": {"type": "harmonic", "amplitude": 0.1, "frequency": 2.0},
        },
        {
            "name": "m_coord",
            "type": "coordinate",
            "body": "follower",
            "coordinate": "phi",
            "function": {"type": "smooth_ramp", "end": 2.0, "end_value": 1.0},
        },
        {
            "name": "m_dist",
            "type": "distance",
            "body1": "ground",
            "body2": "wheel",
            "point1": [0.0, -1.0],
            "point2": [1.2, -0.3],
            "function": {"type": "polynomial", "coefficients": [1.2, 0.2, 0.1]},
        },
    ]
    return load_model({"model": {"name": "every element", "bodies": bodies, "joints": joints, "motors": motors}})


def test_every_element_model_covers_every_element_class():
    system, _, _ = build_system(every_element_model())
    classes = {type(e).__name__ for e in system.elements}
    assert classes == {
        "Revolute",
        "RelativeAngle",
        "PinInSlot",
        "Distance",
        "Translation",
        "Gear",
        "RollerCam",
        "FlatFaceCam",
        "BodyCoordinate",
    }
    assert any(isinstance(e, Translation) and e.pinion_radius > 0 for e in system.elements)
    assert any(isinstance(e, Gear) and e.sigma < 0 for e in system.elements)


def test_every_element_model_derivatives():
    system, q0, _ = build_system(every_element_model())
    rng = np.random.default_rng(11)
    for _ in range(4):
        q = q0 + rng.uniform(-0.1, 0.1, q0.size)
        qd = rng.uniform(-2.0, 2.0, q0.size)
        t = rng.uniform(0.0, 2.0)
        check_system(system, q, qd, t, "of the every-element model")


def test_joints_hold_in_the_file_configuration():
    """Joints located by global points are satisfied exactly where the file puts the bodies."""
    system, q0, _ = build_system(every_element_model())
    psi = system.constraints(q0, 0.0)
    for label, value in zip(system.labels, psi, strict=True):
        if label.split(".")[0] in {"O", "S", "W", "L", "Q", "G", "I", "K", "m_angle", "m_linear"}:
            assert abs(value) < 1e-12, label


@pytest.mark.parametrize("path", sorted((REPO / "course" / "models").glob("*.yaml")), ids=lambda p: p.name)
def test_course_models_derivatives(path):
    """Every example model: perturbed configurations, velocities scaled to the model's size."""
    model = load_model(path)
    if model.dimension != 2:
        pytest.skip("a spatial model")
    system, q0, _ = build_system(model)
    size = max(0.01, float(np.max(np.abs(q0.reshape(-1, 3)[:, :2]))))  # a length typical of the model
    scale = np.tile([size, size, 1.0], q0.size // 3)
    rng = np.random.default_rng(5)
    for _ in range(3):
        q = q0 + 0.05 * scale * rng.uniform(-1.0, 1.0, q0.size)
        qd = 3.0 * scale * rng.uniform(-1.0, 1.0, q0.size)
        check_system(system, q, qd, rng.uniform(0.0, 1.0), path.name, scale)
