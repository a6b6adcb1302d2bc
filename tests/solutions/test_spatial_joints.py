"""Spatial constraint elements: finite-difference checks of every Jacobian, Psi_t and gamma, the motions
each joint allows and forbids, and the assembled example models.

gamma is checked without its formula: along the path q(t) = q0 + q' (t - t0) + q'' (t - t0)^2 / 2,
Psi(q(t), t)'' = Psi_q q'' - gamma at t0 for any q'', and the left side is a central second
difference of Psi along that path.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.functions import Constant, Harmonic, Polynomial
from solutions.io.model import ModelError, load_model
from solutions.rotations import from_axis_angle, quaternion_product, rotation_matrix
from solutions.spatial import joints as sj
from solutions.spatial.build import joint_axes

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
SPATIAL_MODELS = [
    "spatial_double_pendulum",
    "revolute_revolute_skew",
    "carriage_pendulum",
    "cylindrical",
    "heavy_top",
    "spatial_slider_crank",
]
GROUND = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])


def random_state(rng, unit=True):
    q = rng.normal(size=7)
    if unit:
        q[3:] /= np.linalg.norm(q[3:])
    return q, rng.normal(size=7)


def random_frame(rng) -> sj.JointFrame:
    f, g, h = joint_axes(rng.normal(size=3))
    return sj.JointFrame(rng.normal(size=3), f, g, h)


def elements(rng) -> list:
    """One of every element, between bodies 0 and 1, with random body-frame data."""
    fi, fj = random_frame(rng), random_frame(rng)
    drive = Harmonic(amplitude=0.7, frequency=2.3, phase=0.4, offset=0.2)
    out = [factory("J", 0, 1, fi, fj) for factory in sj.JOINTS.values()]
    out += [
        sj.Joint("d1", 0, 1, kind="dot1", parts=(sj.Dot1(rng.normal(size=3), rng.normal(size=3)),)),
        sj.Joint("d2", 0, 1, kind="dot2", parts=(sj.Dot2(*rng.normal(size=(3, 3))),)),
        sj.RotationDriver("rot", 0, 1, fi=fi.f, gi=fi.g, fj=fj.f, angle0=0.3, function=drive),
        sj.TranslationDriver("lin", 0, 1, axis=fi.h, si=fi.origin, sj=fj.origin, offset=0.1, function=drive),
        sj.DistanceDriver("dist", 0, 1, si=fi.origin, sj=fj.origin, length=Polynomial((1.0, 0.5, -0.3))),
        sj.CoordinateDriver("z", -1, 1, index=2, function=drive),
        sj.EulerNormalization("body.p", -1, 1),
    ]
    return out


def numerical_jacobian(element, qi, qj, t, h=1e-6):
    jac_i, jac_j = np.zeros((element.n_equations, 7)), np.zeros((element.n_equations, 7))
    for k in range(7):
        e = np.zeros(7)
        e[k] = h
        jac_i[:, k] = (element.constraints(qi + e, qj, t) - element.constraints(qi - e, qj, t)) / (2 * h)
        jac_j[:, k] = (element.constraints(qi, qj + e, t) - element.constraints(qi, qj - e, t)) / (2 * h)
    return jac_i, jac_j


CASES = [(seed, k) for seed in range(4) for k in range(len(elements(np.random.default_rng(0))))]


@pytest.mark.parametrize(("seed", "k"), CASES)
@pytest.mark.parametrize("unit", [True, False])
def test_jacobian_psi_t_and_gamma_by_finite_differences(seed, k, unit):
    rng = np.random.default_rng(seed)
    element = elements(rng)[k]
    qi, qdi = random_state(rng, unit)
    qj, qdj = random_state(rng, unit)
    if element.i < 0:
        qi, qdi = GROUND, np.zeros(7)
    t = 0.37
    jac_i, jac_j = element.jacobian(qi, qj, t)
    num_i, num_j = numerical_jacobian(element, qi, qj, t)
    assert np.allclose(jac_i, num_i, atol=1e-8), element.name
    assert np.allclose(jac_j, num_j, atol=1e-8), element.name
    h = 1e-6
    psi_t = (element.constraints(qi, qj, t + h) - element.constraints(qi, qj, t - h)) / (2 * h)
    assert np.allclose(element.psi_t(qi, qj, t), psi_t, atol=1e-8), element.name
    # gamma through the second derivative of Psi along a path with arbitrary accelerations
    qddi, qddj = (np.zeros(7) if element.i < 0 else rng.normal(size=7)), rng.normal(size=7)

    def psi_along(tau):
        return element.constraints(qi + qdi * tau + 0.5 * qddi * tau**2, qj + qdj * tau + 0.5 * qddj * tau**2, t + tau)

    h = 1e-4
    second = (psi_along(h) - 2 * psi_along(0.0) + psi_along(-h)) / h**2
    expected = jac_i @ qddi + jac_j @ qddj - element.gamma(qi, qj, qdi, qdj, t)
    assert np.allclose(second, expected, atol=1e-5 * max(1.0, np.abs(expected).max())), element.name


# -- what each joint lets through ---------------------------------------------------------------
def moved(q, axis, angle, point, slide=0.0):
    """Body coordinates after turning by ``angle`` about the line (point, axis) and sliding along it."""
    u = np.asarray(axis) / np.linalg.norm(axis)
    A = rotation_matrix(from_axis_angle(u, angle))
    r = point + A @ (q[:3] - point) + slide * u
    return np.concatenate([r, quaternion_product(from_axis_angle(u, angle), q[3:])])


def frames_at(point, f, g, h, qi, qj):
    """One global frame as fixed in body i and in body j."""

    def local(q):
        A = rotation_matrix(q[3:])
        return sj.JointFrame(A.T @ (point - q[:3]), A.T @ f, A.T @ g, A.T @ h)

    return local(qi), local(qj)


@pytest.fixture
def placed():
    rng = np.random.default_rng(7)
    qi, _ = random_state(rng)
    qj, _ = random_state(rng)
    point = rng.normal(size=3)
    f, g, h = joint_axes(rng.normal(size=3))
    fi, fj = frames_at(point, f, g, h, qi, qj)
    return qi, qj, point, (f, g, h), fi, fj


ALLOWED = {  # joint: (turn about h, slide along h, turn about f, turn about g)
    "spherical": (True, False, True, True),
    "universal": (False, False, True, True),  # the two cross arms: f (body i) and h' (body j), see below
    "revolute": (True, False, False, False),
    "cylindrical": (True, True, False, False),
    "prismatic": (False, True, False, False),
    "rigid": (False, False, False, False),
}


@pytest.mark.parametrize("kind", list(sj.JOINTS))
def test_joint_allows_exactly_its_motions(kind, placed):
    qi, qj, point, (f, g, h), fi, fj = placed
    if kind == "universal":  # arms: h_i = f (fixed in i), h_j = g (fixed in j), perpendicular
        fi = sj.JointFrame(fi.origin, fi.g, fi.h, fi.f)
        fj = sj.JointFrame(fj.origin, fj.h, fj.f, fj.g)
    joint = sj.JOINTS[kind]("J", 0, 1, fi, fj)
    assert np.allclose(joint.constraints(qi, qj, 0.0), 0.0, atol=1e-14)
    assert (
        joint.n_equations
        == {"spherical": 3, "universal": 4, "revolute": 5, "cylindrical": 4, "prismatic": 5, "rigid": 6}[kind]
    )
    turn_h, slide_h, turn_f, turn_g = ALLOWED[kind]
    checks = [(moved(qj, h, 0.8, point), turn_h), (moved(qj, h, 0.0, point, 0.3), slide_h)]
    if kind == "universal":  # body j turns about its arm g, and together with it about i's arm f
        checks += [(moved(qj, g, 0.6, point), True), (moved(moved(qj, g, 0.6, point), f, 0.5, point), True)]
        checks += [(moved(qj, h, 0.6, point), False)]
    else:
        checks += [(moved(qj, f, 0.5, point), turn_f), (moved(qj, g, 0.5, point), turn_g)]
    for q_new, allowed in checks:
        residual = np.abs(joint.constraints(qi, q_new, 0.0)).max()
        assert (residual < 1e-12) == allowed, (kind, residual)


def test_rotation_driver_measures_the_turn_about_the_axis(placed):
    qi, qj, point, (f, g, h), fi, fj = placed
    driver = sj.RotationDriver("drive", 0, 1, fi=fi.f, gi=fi.g, fj=fj.f, function=Polynomial((0.0, 1.0)))
    for angle in (0.0, 0.4, 2.0, -2.5):
        assert abs(driver.constraints(qi, moved(qj, h, angle, point), angle)[0]) < 1e-12
        assert abs(driver.constraints(qi, moved(qj, h, angle + 0.1, point), angle)[0]) == pytest.approx(math.sin(0.1))


def test_translation_driver_measures_the_slide(placed):
    qi, qj, point, (f, g, h), fi, fj = placed
    driver = sj.TranslationDriver("drive", 0, 1, axis=fi.h, si=fi.origin, sj=fj.origin, function=Polynomial((0.0, 1.0)))
    for slide in (0.0, 0.3, -1.2):
        assert abs(driver.constraints(qi, moved(qj, h, 0.0, point, slide), slide)[0]) < 1e-12


# -- assembled models ---------------------------------------------------------------------------
@pytest.mark.parametrize("name", SPATIAL_MODELS)
def test_example_models_hold_in_their_file_configuration(name):
    system, q0, qd0 = build_system(load_model(MODELS / f"{name}.yaml"))
    assert system.coordinates_per_body == 7
    assert np.abs(system.constraints(q0, 0.0)).max() < 1e-12
    rng = np.random.default_rng(3)
    q = q0 + 0.05 * rng.normal(size=q0.size)
    qd = rng.normal(size=q0.size)
    jac = system.jacobian(q, 0.2)
    h = 1e-6
    num = np.column_stack(
        [(system.constraints(q + h * e, 0.2) - system.constraints(q - h * e, 0.2)) / (2 * h) for e in np.eye(q.size)]
    )
    assert np.allclose(jac, num, atol=1e-8)
    second = (system.constraints(q + qd * h * 100, 0.2 + h * 100) - 2 * system.constraints(q, 0.2)
              + system.constraints(q - qd * h * 100, 0.2 - h * 100)) / (h * 100) ** 2  # fmt: skip
    psi_tt_free = second - (-system.gamma(q, qd, 0.2))  # Psi'' with q'' = 0 is -gamma
    assert np.abs(psi_tt_free).max() < 1e-5 * max(1.0, np.abs(second).max())


def test_planar_and_spatial_joint_types_are_kept_apart():
    body = {"name": "b", "mass": 1.0, "inertia": [1.0, 1.0, 1.0], "location": [0.0, 0.0, 0.0]}
    joint = {"name": "J", "type": "gear", "body1": "ground", "body2": "b", "radius1": 1.0, "radius2": 1.0}
    with pytest.raises(ModelError, match="is a planar joint; spatial joints are"):
        load_model({"model": {"dimension": 3, "bodies": [body], "joints": [joint]}})
    planar = {"name": "b", "mass": 1.0, "inertia": 1.0, "location": [0.0, 0.0]}
    joint = {"name": "J", "type": "spherical", "body1": "ground", "body2": "b", "location": [0.0, 0.0]}
    with pytest.raises(ModelError, match="is a spatial joint; planar joints are"):
        load_model({"model": {"bodies": [planar], "joints": [joint]}})


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"orientation": [0.0, 0.0, 0.0, 0.0]}, "Euler parameters are zero"),
        ({"orientation": 0.3}, "4 Euler parameters"),
        ({"inertia": 1.0}, "3 principal moments"),
        ({"inertia": [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}, "symmetric and positive definite"),
        ({"angular_velocity": 1.0}, "3-vector"),
    ],
)
def test_spatial_body_errors_name_the_fix(change, message):
    body = {"name": "b", "mass": 1.0, "inertia": [1.0, 1.0, 1.0], "location": [0.0, 0.0, 0.0], **change}
    with pytest.raises(ModelError, match=message):
        load_model({"model": {"dimension": 3, "bodies": [body]}})


def test_orientation_is_normalised_and_inertia_expanded():
    body = {
        "name": "b",
        "mass": 1.0,
        "inertia": [1.0, 2.0, 3.0],
        "location": [0.0, 0.0, 0.0],
        "orientation": [2.0, 0.0, 0.0, 0.0],
    }
    model = load_model({"model": {"dimension": 3, "bodies": [body]}})
    assert np.allclose(model.bodies[0].orientation, [1, 0, 0, 0])
    assert np.allclose(model.bodies[0].inertia, np.diag([1.0, 2.0, 3.0]))


def test_universal_arms_must_be_perpendicular():
    bodies = [{"name": "b", "mass": 1.0, "inertia": [1.0, 1.0, 1.0], "location": [0.0, 0.0, 0.0]}]
    joint = {"name": "U", "type": "universal", "body1": "ground", "body2": "b", "location": [0.0, 0.0, 0.0],
             "axis": [1.0, 0.0, 0.0], "axis2": [1.0, 1.0, 0.0]}  # fmt: skip
    with pytest.raises(ModelError, match="must be perpendicular"):
        build_system(load_model({"model": {"dimension": 3, "bodies": bodies, "joints": [joint]}}))


def test_constant_is_a_valid_driver_function():
    """A constant angle motor holds the joint: Psi_t = 0 and gamma has no time part."""
    rng = np.random.default_rng(1)
    fi = random_frame(rng)
    driver = sj.RotationDriver("hold", 0, 1, fi=fi.f, gi=fi.g, fj=fi.f, function=Constant(0.0))
    qi, _ = random_state(rng)
    assert driver.psi_t(qi, qi, 0.0)[0] == 0.0
