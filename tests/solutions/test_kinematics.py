"""Kinematic analysis against closed forms: slider-crank, four-bar, gears, rack and pinion, cams.

Every expected value below is derived by hand from the geometry (stated in each docstring), never taken
from the code under test. Errors are required below 1e-9 over a whole crank turn.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.diagnostics import rank_report
from solutions.io.model import load_model
from solutions.kinematics import assemble, kinematic_analysis

REPO = Path(__file__).resolve().parents[2]
TOL = 1e-9


def body(name, x, y, phi=0.0):
    return {"name": name, "mass": 1.0, "inertia": 0.01, "location": [x, y], "orientation": phi}


def run(model, t_end, steps, points=None):
    system, q0, _ = build_system(load_model(model))
    return kinematic_analysis(system, q0, t_end, steps, points=points)


def max_error(result, name, expected, derivative=0):
    return float(np.max(np.abs(result.coordinate(name, derivative) - expected)))


# -- slider-crank ---------------------------------------------------------------------------------------------
def slider_crank_closed_form(theta, w, r=0.1, l=0.3):
    """Crank r at angle theta = w t (w constant), rod l, slider on the x axis through the crank pivot.

    sin(beta) = -r sin(theta) / l (rod angle), x_B = r cos(theta) + l cos(beta);
    beta' = -r w cos(theta) / (l cos beta), beta'' = (r w^2 sin(theta) / l + sin(beta) beta'^2) / cos(beta)
    (from differentiating l sin(beta) = -r sin(theta) twice);
    x_B' = -r w sin(theta) - l sin(beta) beta',  x_B'' = -r w^2 cos(theta) - l cos(beta) beta'^2 - l sin(beta) beta''.
    """
    s, c = np.sin(theta), np.cos(theta)
    sb = -r * s / l
    cb = np.sqrt(1.0 - sb**2)
    beta = np.arcsin(sb)
    bd = -r * w * c / (l * cb)
    bdd = (r * w**2 * s / l + sb * bd**2) / cb
    xb = r * c + l * cb
    xbd = -r * w * s - l * sb * bd
    xbdd = -r * w**2 * c - l * cb * bd**2 - l * sb * bdd
    # rod centre = A + (l/2) e(beta), A = r e(theta)
    rod = (
        (r * c + 0.5 * l * cb, r * s + 0.5 * l * sb),
        (-r * w * s - 0.5 * l * sb * bd, r * w * c + 0.5 * l * cb * bd),
        (
            -r * w**2 * c - 0.5 * l * (sb * bdd + cb * bd**2),
            -r * w**2 * s + 0.5 * l * (cb * bdd - sb * bd**2),
        ),
    )
    return {"beta": (beta, bd, bdd), "xb": (xb, xbd, xbdd), "rod": rod}


def test_slider_crank_against_closed_form():
    path = REPO / "course" / "models" / "slider_crank.yaml"
    omega = 10.0
    steps = 200
    result = run(path, 2 * math.pi / omega, steps, points={"B": (1, np.array([0.15, 0.0]))})
    theta = omega * result.t
    cf = slider_crank_closed_form(theta, omega)
    r = 0.1
    expected = {
        "crank.x": (0.5 * r * np.cos(theta), -0.5 * r * omega * np.sin(theta), -0.5 * r * omega**2 * np.cos(theta)),
        "crank.y": (0.5 * r * np.sin(theta), 0.5 * r * omega * np.cos(theta), -0.5 * r * omega**2 * np.sin(theta)),
        "crank.phi": (theta, np.full_like(theta, omega), np.zeros_like(theta)),
        "rod.x": tuple(v[0] for v in cf["rod"]),
        "rod.y": tuple(v[1] for v in cf["rod"]),
        "rod.phi": cf["beta"],
        "slider.x": cf["xb"],
        "slider.y": (0 * theta, 0 * theta, 0 * theta),
        "slider.phi": (0 * theta, 0 * theta, 0 * theta),
    }
    for name, values in expected.items():
        for derivative in range(3):
            err = max_error(result, name, values[derivative], derivative)
            assert err < TOL, f"{name} derivative {derivative}: max error {err:.3g}"
    # the rod's end B, asked for as a body point
    for suffix, values in zip(("", "_d", "_dd"), cf["xb"], strict=True):
        assert np.max(np.abs(result.points[f"B.x{suffix}"] - values)) < TOL
        assert np.max(np.abs(result.points[f"B.y{suffix}"])) < TOL
    assert result.t[-1] == pytest.approx(2 * math.pi / omega)
    assert result.q.shape == (steps + 1, 9)
    assert result.info["analysis"] == "kinematic"
    assert result.info["max_constraint_residual"] < 1e-12


def test_slider_crank_closed_form_is_self_consistent():
    """The hand-derived derivatives above agree with differences of the closed-form position."""
    omega, h = 10.0, 1e-5
    theta = np.linspace(0.1, 6.0, 7)
    cf = slider_crank_closed_form(theta, omega)
    plus, minus = slider_crank_closed_form(theta + omega * h, omega), slider_crank_closed_form(theta - omega * h, omega)
    for key in ("beta", "xb"):
        np.testing.assert_allclose((plus[key][0] - minus[key][0]) / (2 * h), cf[key][1], rtol=1e-7, atol=1e-7)
        np.testing.assert_allclose((plus[key][1] - minus[key][1]) / (2 * h), cf[key][2], rtol=1e-7, atol=1e-6)


# -- four-bar -------------------------------------------------------------------------------------------------
CRANK = (0.0, 5.0, 3.0)  # theta2(t) = 5 t + 3 t^2: an accelerating crank
T_TURN = (-5.0 + math.sqrt(25.0 + 24.0 * math.pi)) / 6.0  # 3 T^2 + 5 T = 2 pi


def four_bar_expected(four_bar, t):
    c0, c1, c2 = CRANK
    states = [four_bar.body_states(c0 + c1 * s + c2 * s * s, c1 + 2 * c2 * s, 2 * c2) for s in t]
    return [np.array([st[n] for st in states]) for n in range(3)]


def test_four_bar_closed_form_is_self_consistent(four_bar):
    h = 1e-5
    t = np.linspace(0.05, T_TURN - 0.05, 9)
    q, qd, qdd = four_bar_expected(four_bar, t)
    qp, qdp, _ = four_bar_expected(four_bar, t + h)
    qm, qdm, _ = four_bar_expected(four_bar, t - h)
    np.testing.assert_allclose((qp - qm) / (2 * h), qd, atol=1e-7)
    np.testing.assert_allclose((qdp - qdm) / (2 * h), qdd, atol=1e-6)
    # and the loop closes: B from the coupler equals B from the rocker
    for row in q:
        B1 = row[3:5] + four_bar.b / 2 * np.array([math.cos(row[5]), math.sin(row[5])])
        B2 = row[6:8] + four_bar.c / 2 * np.array([math.cos(row[8]), math.sin(row[8])])
        assert np.allclose(B1, B2, atol=1e-14)


@pytest.mark.parametrize("motor", ["angle", "coordinate"])
def test_four_bar_crank_rocker_against_closed_form(four_bar, motor):
    model = four_bar.model(0.0, motor=motor, function={"type": "polynomial", "coefficients": list(CRANK)})
    coupler_point = np.array([0.05, 0.08])  # in the coupler frame
    result = run(model, T_TURN, 240, points={"P": (1, coupler_point)})
    expected = four_bar_expected(four_bar, result.t)
    assert result.q[-1, 2] == pytest.approx(2 * math.pi)  # a whole crank turn
    for derivative, (got, want) in enumerate(zip((result.q, result.qd, result.qdd), expected, strict=True)):
        err = np.abs(got - want)
        worst = np.unravel_index(np.argmax(err), err.shape)
        where = f"{result.coordinate_names[worst[1]]} at t={result.t[worst[0]]}"
        assert err.max() < TOL, f"derivative {derivative}: error {err.max():.3g} in {where}"
    # coupler point P = centre + A(theta3) s', from the closed-form coupler motion
    q, qd, qdd = expected
    th, w, al = q[:, 5], qd[:, 5], qdd[:, 5]
    c, s = np.cos(th), np.sin(th)
    rel = np.stack([c * coupler_point[0] - s * coupler_point[1], s * coupler_point[0] + c * coupler_point[1]], 1)
    perp = np.stack([-rel[:, 1], rel[:, 0]], 1)
    point = {
        "": q[:, 3:5] + rel,
        "_d": qd[:, 3:5] + perp * w[:, None],
        "_dd": qdd[:, 3:5] + perp * al[:, None] - rel * (w**2)[:, None],
    }
    for suffix, values in point.items():
        assert np.max(np.abs(result.points[f"P.x{suffix}"] - values[:, 0])) < TOL
        assert np.max(np.abs(result.points[f"P.y{suffix}"] - values[:, 1])) < TOL


# -- assembly -------------------------------------------------------------------------------------------------
def test_assembly_from_perturbed_coordinates(four_bar):
    """Newton-Raphson brings a configuration perturbed by ~1e-2 back onto Psi = 0 and says how far it moved."""
    system, q_exact, _ = build_system(load_model(four_bar.model(0.7)))
    rng = np.random.default_rng(2)
    q_start = q_exact + rng.uniform(-1e-2, 1e-2, q_exact.size)
    q, report = assemble(system, q_start)
    assert np.max(np.abs(q - q_exact)) < 1e-12
    assert np.max(np.abs(system.constraints(q, 0.0))) < 1e-12
    assert report["residual"] < 1e-12
    assert 1 <= report["iterations"] <= 6
    for k, name in enumerate(("crank", "coupler", "rocker")):
        dq = q_start[3 * k : 3 * k + 3] - q_exact[3 * k : 3 * k + 3]
        assert report["moved"][name]["translation"] == pytest.approx(math.hypot(dq[0], dq[1]), abs=1e-12)
        assert report["moved"][name]["rotation"] == pytest.approx(abs(dq[2]), abs=1e-12)


def test_assembly_of_an_approximate_model_file(four_bar, tmp_path):
    """A file giving link lengths in body frames and a rough configuration assembles onto the closed form."""
    theta2 = 0.4
    model = four_bar.model(theta2, motor="coordinate", function={"type": "polynomial", "coefficients": [theta2, 2.0]})
    model["model"]["joints"] = four_bar.model(theta2, frame="body")["model"]["joints"]
    q_exact, _, _ = four_bar.body_states(theta2)
    rng = np.random.default_rng(4)
    for b in model["model"]["bodies"]:
        b["location"] = [round(v + rng.uniform(-1e-2, 1e-2), 3) for v in b["location"]]
        b["orientation"] = round(b["orientation"] + rng.uniform(-1e-2, 1e-2), 3)
    system, q_file, _ = build_system(load_model(model))
    assert np.max(np.abs(q_file - q_exact)) > 1e-3  # the file really is off
    q, report = assemble(system, q_file)
    assert np.max(np.abs(q - q_exact)) < 1e-12
    for k, name in enumerate(("crank", "coupler", "rocker")):
        dq = q_exact[3 * k : 3 * k + 3] - q_file[3 * k : 3 * k + 3]
        assert report["moved"][name]["translation"] == pytest.approx(math.hypot(dq[0], dq[1]), abs=1e-12)
        assert report["moved"][name]["rotation"] == pytest.approx(abs(dq[2]), abs=1e-12)
    # a kinematic run from the approximate file starts from the assembled configuration
    result = kinematic_analysis(system, q_file, 0.5, 10)
    assert np.max(np.abs(result.q[0] - q_exact)) < 1e-12
    assert result.info["assembly"]["moved"]["coupler"]["translation"] > 1e-3
    want = four_bar.body_states(theta2 + 2.0 * 0.5, 2.0, 0.0)
    for got, expected in zip((result.q[-1], result.qd[-1], result.qdd[-1]), want, strict=True):
        assert np.max(np.abs(got - expected)) < TOL


# -- gears ----------------------------------------------------------------------------------------------------
def gear_pair_model(r1, r2, internal=False):
    """Gear 1 on a ground pivot at the origin, gear 2 on a ground pivot at R1 + R2 (external) or
    R2 - R1 (internal: gear 2 a ring around gear 1), gear 1 driven at phi1 = phi1_0 + 3 t + 0.5 t^2."""
    centre = r2 - r1 if internal else r1 + r2
    joints = [
        {"name": "O1", "type": "revolute", "body1": "ground", "body2": "g1", "location": [0.0, 0.0]},
        {"name": "O2", "type": "revolute", "body1": "ground", "body2": "g2", "location": [centre, 0.0]},
        {
            "name": "mesh",
            "type": "gear",
            "body1": "g1",
            "body2": "g2",
            "radius1": r1,
            "radius2": r2,
            "gear": "internal" if internal else "external",
        },
    ]
    motors = [
        {
            "name": "drive",
            "type": "angle",
            "joint": "O1",
            "function": {"type": "polynomial", "coefficients": [0, 3, 0.5]},
        }
    ]
    bodies = [body("g1", 0.0, 0.0, 0.2), body("g2", centre, 0.0, -0.5)]
    return {"model": {"name": "gear pair", "bodies": bodies, "joints": joints, "motors": motors}}


@pytest.mark.parametrize("internal", [False, True], ids=["external", "internal"])
def test_gear_pair_ratio(internal):
    r1, r2 = 0.04, 0.1
    result = run(gear_pair_model(r1, r2, internal), 3.0, 60)
    ratio = (r1 / r2) if internal else -(r1 / r2)  # phi2' / phi1'
    t = result.t
    phi1 = 0.2 + 3.0 * t + 0.5 * t**2
    assert max_error(result, "g1.phi", phi1) < TOL
    assert max_error(result, "g2.phi", -0.5 + ratio * (phi1 - 0.2)) < TOL
    assert max_error(result, "g2.phi", ratio * (3.0 + t), 1) < TOL
    assert max_error(result, "g2.phi", ratio * 1.0, 2) < TOL
    for name in ("g1.x", "g1.y", "g2.y"):
        assert max_error(result, name, 0.0) < TOL


def test_planetary_gear_with_moving_centre():
    """Sun gear fixed (ground, radius R1), arm turning at theta = 2 t + 0.5 t^2 about the sun's centre, planet
    (R2) on the arm's end. Rolling: R1 (0 - theta) + R2 (phi_p - theta) = const, so
    phi_p = phi_p0 + (1 + R1/R2) theta: the line of centres turns, which the gear element must account for
    (past the +-pi cut of atan2; R1/R2 = 2.5, so a jump of 2 pi there would leave the planet half a turn off)."""
    r1, r2 = 0.05, 0.02
    joints = [
        {"name": "O", "type": "revolute", "body1": "ground", "body2": "arm", "location": [0.0, 0.0]},
        {"name": "P", "type": "revolute", "body1": "arm", "body2": "planet", "location": [r1 + r2, 0.0]},
        {"name": "mesh", "type": "gear", "body1": "ground", "body2": "planet", "radius1": r1, "radius2": r2},
    ]
    motors = [
        {
            "name": "drive",
            "type": "angle",
            "joint": "O",
            "function": {"type": "polynomial", "coefficients": [0, 2, 0.5]},
        }
    ]
    bodies = [body("arm", 0.5 * (r1 + r2), 0.0), body("planet", r1 + r2, 0.0, 0.3)]
    result = run({"model": {"name": "planetary", "bodies": bodies, "joints": joints, "motors": motors}}, 2.0, 50)
    t = result.t
    theta, w, al = 2 * t + 0.5 * t**2, 2 + t, np.ones_like(t)
    k = 1 + r1 / r2
    assert max_error(result, "planet.phi", 0.3 + k * theta) < TOL
    assert max_error(result, "planet.phi", k * w, 1) < TOL
    assert max_error(result, "planet.phi", k * al, 2) < TOL
    R = r1 + r2
    assert max_error(result, "planet.x", R * np.cos(theta)) < TOL
    assert max_error(result, "planet.y", R * np.sin(theta)) < TOL
    assert max_error(result, "planet.x", -R * w * np.sin(theta), 1) < TOL
    assert max_error(result, "planet.y", -R * w**2 * np.sin(theta) + R * al * np.cos(theta), 2) < TOL


# -- rack and pinion ------------------------------------------------------------------------------------------
def test_pinion_rolling_on_fixed_rack():
    """A pinion of radius R rolls on a ground rack along y = 0, its centre guided at height R (pin in slot).
    Rolling without slip: x = x0 - R (phi - phi0)."""
    R = 0.05
    joints = [
        {
            "name": "guide",
            "type": "revolute_prismatic",
            "body1": "ground",
            "body2": "pinion",
            "location": [0.1, R],
            "axis": [1.0, 0.0],
        },
        {
            "name": "rack",
            "type": "rack_pinion",
            "body1": "ground",
            "body2": "pinion",
            "point1": [0.0, 0.0],
            "axis": [1.0, 0.0],
            "radius": R,
        },
    ]
    motors = [
        {
            "name": "spin",
            "type": "coordinate",
            "body": "pinion",
            "coordinate": "phi",
            "function": {"type": "harmonic", "amplitude": 2.0, "frequency": 3.0, "offset": 0.4},
        }
    ]
    result = run(
        {
            "model": {
                "name": "rolling pinion",
                "bodies": [body("pinion", 0.1, R, 0.4)],
                "joints": joints,
                "motors": motors,
            }
        },
        2.0,
        40,
    )
    t = result.t
    phi, w, al = 0.4 + 2 * np.sin(3 * t), 6 * np.cos(3 * t), -18 * np.sin(3 * t)
    assert max_error(result, "pinion.x", 0.1 - R * (phi - 0.4)) < TOL
    assert max_error(result, "pinion.x", -R * w, 1) < TOL
    assert max_error(result, "pinion.x", -R * al, 2) < TOL
    assert max_error(result, "pinion.y", R) < TOL


def test_rack_driven_by_fixed_pinion():
    """A pinion on a ground pivot at (0, R) drives a rack sliding on y = 0 below it: x = x0 + R phi."""
    R = 0.03
    joints = [
        {"name": "O", "type": "revolute", "body1": "ground", "body2": "pinion", "location": [0.0, R]},
        {"name": "S", "type": "prismatic", "body1": "ground", "body2": "rack", "location": [0.2, 0.0], "axis": [1, 0]},
        {
            "name": "mesh",
            "type": "rack_pinion",
            "body1": "rack",
            "body2": "pinion",
            "point1": [0.0, 0.0],
            "axis": [1.0, 0.0],
            "radius": R,
        },
    ]
    motors = [
        {"name": "drive", "type": "angle", "joint": "O", "function": {"type": "polynomial", "coefficients": [0, 4, -1]}}
    ]
    bodies = [body("pinion", 0.0, R), body("rack", 0.2, 0.0)]
    result = run({"model": {"name": "rack", "bodies": bodies, "joints": joints, "motors": motors}}, 2.0, 40)
    t = result.t
    phi = 4 * t - t**2
    assert max_error(result, "rack.x", 0.2 + R * phi) < TOL
    assert max_error(result, "rack.x", R * (4 - 2 * t), 1) < TOL
    assert max_error(result, "rack.x", -2 * R, 2) < TOL


# -- cams -----------------------------------------------------------------------------------------------------
E, RC, RR = 0.01, 0.04, 0.01  # eccentricity, disc radius, roller radius
OMEGA = 4.0


def cam_model(follower: str) -> dict:
    """An eccentric disc cam turning about the origin at theta = OMEGA t (its centre at E e(theta)),
    and a follower translating along the y axis above it."""
    theta0 = 0.0
    if follower == "roller":
        y0 = E * math.sin(theta0) + math.sqrt((RC + RR) ** 2 - (E * math.cos(theta0)) ** 2)
        cam = {
            "name": "C",
            "type": "cam",
            "follower": "roller",
            "body1": "cam",
            "body2": "follower",
            "profile": {"type": "eccentric_circle", "radius": RC + RR, "eccentricity": E},
        }
    else:
        y0 = RC + E * math.sin(theta0)
        # support function of the disc in the cam frame: p(psi) = RC + E cos(psi)
        cam = {
            "name": "C",
            "type": "cam",
            "follower": "flat",
            "body1": "cam",
            "body2": "follower",
            "point2": [0.0, y0],
            "axis": [0.0, 1.0],
            "profile": {"type": "fourier", "a0": RC, "a": [E], "b": [0.0]},
        }
    joints = [
        {"name": "O", "type": "revolute", "body1": "ground", "body2": "cam", "location": [0.0, 0.0]},
        {
            "name": "S",
            "type": "prismatic",
            "body1": "ground",
            "body2": "follower",
            "location": [0.0, y0],
            "axis": [0, 1],
        },
        cam,
    ]
    motors = [
        {"name": "drive", "type": "angle", "joint": "O", "function": {"type": "polynomial", "coefficients": [0, OMEGA]}}
    ]
    bodies = [body("cam", 0.0, 0.0, theta0), body("follower", 0.0, y0)]
    return {"model": {"name": f"cam with {follower}", "bodies": bodies, "joints": joints, "motors": motors}}


def test_eccentric_cam_with_roller_follower():
    """Roller centre on the circle of radius a = RC + RR about the disc centre, on the y axis:
    y = E s + sqrt(a^2 - E^2 c^2) (s, c = sin, cos theta); with R = sqrt(a^2 - E^2 c^2),
    dy/dtheta = E c + E^2 s c / R,  d2y/dtheta2 = -E s + E^2 (c^2 - s^2) / R - E^4 s^2 c^2 / R^3."""
    result = run(cam_model("roller"), 2 * math.pi / OMEGA, 120)
    theta = OMEGA * result.t
    s, c = np.sin(theta), np.cos(theta)
    a = RC + RR
    R = np.sqrt(a**2 - (E * c) ** 2)
    y = E * s + R
    y1 = E * c + E**2 * s * c / R
    y2 = -E * s + E**2 * (c**2 - s**2) / R - E**4 * s**2 * c**2 / R**3
    assert max_error(result, "follower.y", y) < TOL
    assert max_error(result, "follower.y", y1 * OMEGA, 1) < TOL
    assert max_error(result, "follower.y", y2 * OMEGA**2, 2) < TOL
    assert max_error(result, "follower.x", 0.0) < TOL
    assert max_error(result, "follower.phi", 0.0) < TOL


def test_eccentric_cam_with_flat_faced_follower():
    """A flat face normal to the y axis touches the disc at its top: y = RC + E sin(theta), a pure harmonic."""
    result = run(cam_model("flat"), 2 * math.pi / OMEGA, 120)
    theta = OMEGA * result.t
    assert max_error(result, "follower.y", RC + E * np.sin(theta)) < TOL
    assert max_error(result, "follower.y", E * OMEGA * np.cos(theta), 1) < TOL
    assert max_error(result, "follower.y", -E * OMEGA**2 * np.sin(theta), 2) < TOL


# -- the example models ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("path", sorted((REPO / "course" / "models").glob("*.yaml")), ids=lambda p: p.name)
def test_driven_example_models_run(path):
    """Every example whose motors leave no degree of freedom runs its own simulation block kinematically,
    starting from the file's configuration, and stays on the constraint manifold."""
    model = load_model(path)
    system, q0, _ = build_system(model)
    if rank_report(system.jacobian(q0, 0.0), system.row_owners).degrees_of_freedom != 0:  # by rank, as mbd run
        pytest.skip("not fully driven: a dynamic example")
    t_end = float(model.simulation.get("end_time", 1.0))
    result = kinematic_analysis(system, q0, t_end, int(model.simulation.get("output_steps", 100)))
    assert result.info["max_constraint_residual"] < 1e-10
    # the file's configuration was already assembled (or close)
    moved = result.info["assembly"]["moved"]
    assert max(m["translation"] for m in moved.values()) < 1e-3
    for k in range(0, result.t.size, max(1, result.t.size // 5)):
        assert np.max(np.abs(system.constraints(result.q[k], result.t[k]))) < 1e-10
        assert (
            np.max(
                np.abs(
                    system.jacobian(result.q[k], result.t[k]) @ result.qd[k] + system.psi_t(result.q[k], result.t[k])
                )
            )
            < 1e-9
        )
