"""Outputs engineers ask for (issue 29, item 5): body-frame points (--point BODY:x,y@body), angular
accelerations (--rotations), what each force element exerts and its power (SPRING.force, SPRING.torque,
SPRING.power), the restart ``auto`` makes said on stderr, and errors in the command line's words.

Every expected value is computed here by hand from the result's own q, q', q'' (r + A s', k (l - l0) + c l',
d(T + V)/dt of the bodies), by finite differences, or from the one-degree-of-freedom reference of
``mechanisms.py``."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from solutions.assembly import build_system
from solutions.cli import main
from solutions.diagnostics import SingularConfigurationError, command_line_words, setting_words
from solutions.dynamics import forward_dynamics
from solutions.io.model import load_model

from .mechanisms import chain_theta, parallelogram_chain

MODELS = Path(__file__).resolve().parents[2] / "course" / "models"
SPATIAL = MODELS / "spatial_slider_crank.yaml"
G = np.array([0.0, -9.81])
M, I, L = 2.0, 0.2, 1.0  # the pendulum below: mass, inertia about the centre, length
K, C, L0, KR, CR = 40.0, 0.8, 0.9, 3.0, 0.05  # its spring-damper and rotational spring-damper
ANCHOR, TIP = np.array([1.2, 0.3]), np.array([0.5, 0.05])  # the spring's ground point; its point on the rod


def rotation(phi):
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]]).transpose(2, 0, 1) if np.ndim(phi) else np.array([[c, -s], [s, c]])


def pendulum_file(tmp_path: Path) -> Path:
    """A rod pinned at one end, written in a joint-origin frame (location at the pin, com half-way), with a
    spring-damper from a ground point to a point given in that frame, and a rotational spring-damper to ground."""
    data = {
        "model": {
            "name": "sprung-pendulum",
            "dimension": 2,
            "gravity": G.tolist(),
            "bodies": [
                {
                    "name": "rod",
                    "mass": M,
                    "inertia": I,
                    "location": [0.0, 0.0],
                    "orientation": -0.4,
                    "com": [L / 2, 0.0],
                    "angular_velocity": 1.5,
                },
            ],  # fmt: skip
            "joints": [{"name": "O", "type": "revolute", "body1": "ground", "body2": "rod", "location": [0.0, 0.0]}],
            "spring_dampers": [
                {
                    "name": "spring",
                    "type": "TSDA",
                    "body1": "ground",
                    "body2": "rod",
                    "frame": "body",
                    "point1": ANCHOR.tolist(),
                    "point2": (TIP + [L / 2, 0.0]).tolist(),
                    "spring_coefficient": K,
                    "damping_coefficient": C,
                    "free_length": L0,
                },
                {
                    "name": "torsion",
                    "type": "RSDA",
                    "body1": "ground",
                    "body2": "rod",
                    "spring_coefficient": KR,
                    "damping_coefficient": CR,
                    "free_angle": 0.0,
                },
            ],  # fmt: skip
        },
        "simulation": {"analysis": "dynamic", "end_time": 0.6, "output_steps": 60},
    }
    path = tmp_path / "pendulum.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(scope="module")
def pendulum(tmp_path_factory) -> dict:
    """The pendulum's dynamic run through mbd run, with a body-frame point at the spring's end (NPZ)."""
    folder = tmp_path_factory.mktemp("pendulum")
    out = folder / "run.npz"
    point = f"P=rod:{TIP[0] + L / 2},{TIP[1]}@body"  # in the file's frame: from the pin, as frame: body reads it
    assert main(["run", str(pendulum_file(folder)), "--rtol", "1e-10", "--point", point, "--out", str(out)]) == 0
    return dict(np.load(out))


def test_body_frame_point_is_r_plus_A_s(pendulum):
    """--point rod:x,y@body takes x, y in the file's body frame (origin at the pin for a body with com:), as the
    model file's frame: body does: its path is r + A(phi) s' with s' = (x, y) - com."""
    r = np.column_stack([pendulum["rod.x"], pendulum["rod.y"]])
    expected = r + rotation(pendulum["rod.phi"]) @ TIP
    np.testing.assert_allclose(np.column_stack([pendulum["P.x"], pendulum["P.y"]]), expected, atol=1e-13)
    pin = r + rotation(pendulum["rod.phi"]) @ np.array([-L / 2, 0.0])
    np.testing.assert_allclose(pin, 0.0, atol=1e-8)  # the frame's origin stays on the pin: com read as the file says


def test_spring_damper_force_and_torque_by_hand(pendulum):
    """spring.force = k (l - l0) + c l' and torsion.torque = k (phi - phi0) + c phi', from the result's q, q'."""
    P = np.column_stack([pendulum["P.x"], pendulum["P.y"]])
    v = np.column_stack([pendulum["P.x_d"], pendulum["P.y_d"]])
    d = P - ANCHOR
    length = np.linalg.norm(d, axis=1)
    rate = np.sum(d * v, axis=1) / length
    np.testing.assert_allclose(pendulum["spring.force"], K * (length - L0) + C * rate, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(pendulum["spring.power"], -pendulum["spring.force"] * rate, rtol=1e-12, atol=1e-12)
    phi, omega = pendulum["rod.phi"], pendulum["rod.phi_d"]
    np.testing.assert_allclose(pendulum["torsion.torque"], KR * phi + CR * omega, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(pendulum["torsion.power"], -pendulum["torsion.torque"] * omega, rtol=1e-12, atol=1e-12)


def test_element_powers_add_up_to_the_rate_of_kinetic_and_gravity_energy(pendulum):
    """Work theorem: d(T + V_gravity)/dt = m v.(a - g) + I omega omega' = the sum of the elements' powers at every
    output time; over the run, their integral (Simpson's rule) is the change of T + V_gravity, and with the springs'
    potentials in V (the energy columns) what is left is the energy the dampers took out, -energy.dissipated."""
    from scipy.integrate import cumulative_simpson

    v = np.column_stack([pendulum["rod.x_d"], pendulum["rod.y_d"]])
    a = np.column_stack([pendulum["rod.x_dd"], pendulum["rod.y_dd"]])
    rate = M * np.sum(v * (a - G), axis=1) + I * pendulum["rod.phi_d"] * pendulum["rod.phi_dd"]
    powers = pendulum["spring.power"] + pendulum["torsion.power"]
    np.testing.assert_allclose(powers, rate, atol=1e-7 * np.max(np.abs(rate)))
    work = cumulative_simpson(powers, x=pendulum["t"], initial=0.0)
    kinetic_gravity = pendulum["energy.kinetic"] - M * G[1] * pendulum["rod.y"]
    scale = np.max(np.abs(work))
    np.testing.assert_allclose(work, kinetic_gravity - kinetic_gravity[0], atol=1e-4 * scale)
    stretch = (pendulum["spring.force"] + C * pendulum["spring.power"] / pendulum["spring.force"]) / K  # (f - c l')/k
    springs = K / 2 * stretch**2 + KR / 2 * pendulum["rod.phi"] ** 2  # 1/2 k (l - l0)^2 + 1/2 k_r phi^2
    gravity = -M * G[1] * pendulum["rod.y"]
    np.testing.assert_allclose(springs + gravity, pendulum["energy.potential"], atol=1e-12)
    np.testing.assert_allclose(work - springs[0] + springs, -pendulum["energy.dissipated"], atol=1e-4 * scale)


def test_spatial_force_columns_against_the_collar_closed_form(tmp_path):
    """The cylindrical collar: the spring from (0, 0, 1) to the centre, relaxed at z = 0, pulls with
    k (l - l0) = -k z; the torsion spring about the shaft turns it back with 0.5 theta, theta its twist."""
    out = tmp_path / "collar.npz"
    assert main(["run", str(MODELS / "cylindrical.yaml"), "--t-end", "0.3", "--steps", "30", "--out", str(out)]) == 0
    z = np.load(out)
    np.testing.assert_allclose(z["spring.force"], -100.0 * z["collar.z"], atol=1e-12)
    np.testing.assert_allclose(z["spring.power"], z["spring.force"] * z["collar.z_d"], atol=1e-12)  # l' = -z'
    twist = 2.0 * np.arctan2(z["collar.e3"], z["collar.e0"])  # a rotation about z alone: p = (cos a/2, 0, 0, sin a/2)
    np.testing.assert_allclose(z["torsion.torque"], 0.5 * twist, atol=1e-9)


def test_angular_accelerations_are_the_rates_of_omega(tmp_path):
    """--rotations: BODY.wx_d .. (global) and BODY.wx_body_d .. (body frame) against central differences of the
    angular velocities it reports (a kinematic run of the spatial slider-crank)."""
    out = tmp_path / "r.npz"
    argv = ["run", str(SPATIAL), "--analysis", "kinematic", "--t-end", "0.2", "--steps", "400", "--rotations"]
    assert main([*argv, "--point", "P=rod:0.01,0.02,0.03@body", "--out", str(out)]) == 0
    z = np.load(out)
    h = z["t"][1] - z["t"][0]
    for frame in ("", "_body"):
        omega = np.column_stack([z[f"rod.w{axis}{frame}"] for axis in "xyz"])
        alpha = np.column_stack([z[f"rod.w{axis}{frame}_d"] for axis in "xyz"])
        scale = np.max(np.abs(alpha))
        assert scale > 1.0  # the rod's rotation accelerates: not a test that passes on zeros
        np.testing.assert_allclose(alpha[1:-1], (omega[2:] - omega[:-2]) / (2 * h), atol=1e-4 * scale)
    r = np.column_stack([z[f"rod.{axis}"] for axis in "xyz"])
    A = np.stack([z[f"rod.A{i}{j}"] for i in (1, 2, 3) for j in (1, 2, 3)], axis=1).reshape(-1, 3, 3)
    np.testing.assert_allclose(np.column_stack([z["P.x"], z["P.y"], z["P.z"]]), r + A @ [0.01, 0.02, 0.03], atol=1e-14)


def test_point_frame_misspelt_says_both_forms(capsys):
    assert main(["run", str(SPATIAL), "--point", "rod:0,0,0@bdy"]) == 2
    err = capsys.readouterr().err
    assert "BODY:x,y,z@body (in the body's frame" in err and "Traceback" not in err


@pytest.fixture(scope="module")
def chain_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("chain") / "chain.yaml"
    path.write_text(yaml.safe_dump(parallelogram_chain(1)))
    return path


def test_auto_restart_is_said_on_stderr(chain_file, capsys):
    """A parallelogram released under gravity reaches its singular position (every bar on the ground line): auto's
    first method stops there and the run is made again with the augmented Lagrangian; mbd run says so in one line,
    with the time, which the one-degree-of-freedom reference puts at the crossing (theta = 0)."""
    argv = ["run", str(chain_file), "--t-end", "1.5", "--steps", "30", "--engine", "numpy"]
    assert main(argv) == 0
    out, err = capsys.readouterr()
    (line,) = err.splitlines()
    found = re.search(r"restarted: the (\S+) formulation stopped next to a singular position at t = (\S+) s;", line)
    assert found and found[1] != "augmented-lagrangian", line
    assert line.endswith("from t = 0 with augmented-lagrangian, which passes singular positions")
    assert abs(chain_theta(1, np.array([float(found[2])]))[0]) < 0.3  # the stop is at the crossing
    assert "formulation: augmented-lagrangian" in out
    assert main([*argv, "--formulation", "augmented-lagrangian"]) == 0
    assert capsys.readouterr().err == ""  # no restart: nothing said


def test_errors_of_the_command_line_name_its_options(chain_file, capsys):
    """The singular-position stop names --singular-ratio 0 on the command line, singular_ratio=None in Python; a
    spent budget names --max-evaluations with a figure."""
    assert main(["run", str(chain_file), "--t-end", "1.5", "--formulation", "baumgarte", "--engine", "numpy"]) == 2
    err = capsys.readouterr().err
    assert "--singular-ratio 0 runs on regardless" in err and "singular_ratio" not in err, err
    system, q0, qd0 = build_system(load_model(chain_file))
    with pytest.raises(SingularConfigurationError, match=r"singular_ratio=None \(mbd run --singular-ratio 0\)"):
        forward_dynamics(system, q0, qd0, 1.5, 30, formulation="baumgarte", engine="numpy")
    argv = ["run", str(chain_file), "--t-end", "1.5", "--max-evaluations", "20", "--formulation", "baumgarte"]
    assert main([*argv, "--engine", "numpy"]) == 2
    err = capsys.readouterr().err
    assert "raise the budget, e.g. --max-evaluations 80" in err and "max_evaluations" not in err, err


def test_both_spellings_of_a_setting():
    said = f"x; {setting_words('singular_ratio', None, '0')} runs on; {setting_words('through_singular', True)} too"
    assert said == (
        "x; singular_ratio=None (mbd run --singular-ratio 0) runs on; through_singular=True (mbd run "
        "--through-singular) too"
    )
    assert command_line_words(said) == "x; --singular-ratio 0 runs on; --through-singular too"
    assert command_line_words("rtol=1e-9 (a note) and f(x)") == "rtol=1e-9 (a note) and f(x)"  # nothing else moves
    assert math.isclose(float(setting_words("rtol", 1e-9).split("=")[1].split()[0]), 1e-9)
