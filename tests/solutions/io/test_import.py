"""``mbd import`` and models run straight from URDF and MJCF files (solutions/io/importers.py).

The imported models are checked against codes and formulas that share nothing with the import: MuJoCo loading the
same files (it compiles URDF itself), run with RK4 at a fine step, no contacts, limits, damping or armature, and
a stiff equality solref for the loop; and the exact period of a physical pendulum (an elliptic integral), with the
URDF's frames composed by scipy's rotations rather than the importer's.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.special import ellipk

from solutions.analysis import run_analysis
from solutions.assembly import build_system
from solutions.cli import main
from solutions.io.importers import import_file, rpy_matrix
from solutions.io.model import load_model
from solutions.io.results import read_csv
from solutions.rotation_matrices import euler_rotation
from solutions.settings import read_settings

mujoco = pytest.importorskip("mujoco")

DATA = Path(__file__).resolve().parents[2] / "data" / "import"
ARM = DATA / "two_link_arm.urdf"
FOUR_BAR = DATA / "four_bar.xml"
OUTPUTS = 20


def centres(path: Path, t_end: float, **options) -> tuple[list[str], np.ndarray]:
    """This project's forward dynamics of a file (imported on the fly): body names, centres (outputs, body, 3)."""
    model = load_model(path)
    system, q0, qd0 = build_system(model)
    settings = read_settings(model.simulation, t_end=t_end, steps=OUTPUTS, rtol=1e-10, atol=1e-10, **options)
    result = run_analysis(system, q0, qd0, settings)
    names = [b.name for b in model.bodies]
    return names, np.stack([result.q[:, 7 * k : 7 * k + 3] for k in range(len(names))], axis=1)


def mujoco_centres(path: Path, names: list[str], t_end: float, dt: float = 1e-4, loop: bool = False) -> np.ndarray:
    """MuJoCo's run of the same file: RK4 at step dt, contacts off, no limits, damping or armature; a loop's
    equality with a time constant of two steps (the stiffest MuJoCo keeps stable) and a hard solimp."""
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    m.opt.timestep = dt
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    m.jnt_limited[:] = 0
    m.dof_damping[:] = 0.0
    m.dof_armature[:] = 0.0
    if loop:
        m.eq_solref[:] = [2 * dt, 1.0]
        m.eq_solimp[:] = [0.9999, 0.9999, 0.001, 0.5, 2.0]
    d = mujoco.MjData(m)
    ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name) for name in names]
    assert min(ids) > 0, f"MuJoCo has bodies {[m.body(i).name for i in range(m.nbody)]}, the import {names}"
    per_output = round(t_end / OUTPUTS / dt)
    mujoco.mj_forward(m, d)
    out = [d.xipos[ids].copy()]
    for _ in range(OUTPUTS):
        mujoco.mj_step(m, d, nstep=per_output)
        mujoco.mj_forward(m, d)
        out.append(d.xipos[ids].copy())
    return np.array(out)


@pytest.fixture(scope="module")
def arm():
    names, ours = centres(ARM, 1.5)
    return names, ours, mujoco_centres(ARM, names, 1.5)


def test_a_ros_style_urdf_arm_moves_as_mujoco_runs_the_same_file(arm):
    names, ours, theirs = arm
    assert names == ["upper_arm", "forearm"]  # base_link fixed to the world, the tool fixed to the forearm: merged
    assert np.max(np.abs(ours - ours[0])) > 0.5  # it falls and swings, in 3D
    assert np.ptp(ours[:, 1, 1]) > 0.05 and np.ptp(ours[:, 1, 2]) > 0.3
    assert np.max(np.abs(ours - theirs)) < 1e-8  # measured 3.7e-11 m


def test_a_four_bar_closed_by_equality_connect_moves_as_mujoco_runs_it():
    names, ours = centres(FOUR_BAR, 1.0)
    theirs = mujoco_centres(FOUR_BAR, names, 1.0, loop=True)
    assert names == ["crank", "coupler", "rocker"]
    assert np.max(np.abs(ours - ours[0])) > 0.1
    assert np.max(np.abs(ours[:, :, 1])) < 1e-9  # the planar mechanism stays in its plane, in a spatial model
    assert np.max(np.abs(ours - theirs)) < 1e-6  # measured 1.1e-7 m (MuJoCo's soft loop constraint)


PENDULUM = """<robot name="pendulum">
  <link name="support"/>
  <joint name="pivot" type="continuous">
    <parent link="support"/><child link="bob"/>
    <origin xyz="0.1 -0.2 1.0" rpy="{roll} 0 0.7"/>
    <axis xyz="1 0 0"/>
  </joint>
  <link name="bob">
    <inertial>
      <origin xyz="0.05 0.1 -0.4" rpy="0.2 0.5 -0.1"/>
      <mass value="2.0"/>
      <inertia ixx="0.02" ixy="0.003" ixz="-0.002" iyy="0.03" iyz="0.001" izz="0.015"/>
    </inertial>
  </link>
</robot>
"""


def test_a_urdf_pendulum_returns_after_its_exact_period(tmp_path):
    """Released at theta0 from hanging, a physical pendulum's period is 4 sqrt(J / (m g d)) K(sin(theta0 / 2)),
    J about the axis through the pivot (the tensor turned to the joint frame, plus m d^2)."""
    roll = 0.9
    path = tmp_path / "pendulum.urdf"
    path.write_text(PENDULUM.format(roll=roll))
    c = np.array([0.05, 0.1, -0.4])  # centre of mass in the link frame, which is the joint frame
    d = math.hypot(c[1], c[2])  # distance from the axis (x)
    theta0 = math.atan2(c[1], -c[2]) + roll  # from hanging (-z), about x
    R = Rotation.from_euler("xyz", [0.2, 0.5, -0.1]).as_matrix()  # URDF rpy: extrinsic x, y, z
    Jc = np.array([[0.02, 0.003, -0.002], [0.003, 0.03, 0.001], [-0.002, 0.001, 0.015]])
    J = (R @ Jc @ R.T)[0, 0] + 2.0 * d**2
    period = 4.0 * math.sqrt(J / (2.0 * 9.81 * d)) * ellipk(math.sin(theta0 / 2) ** 2)
    names, ours = centres(path, period)
    assert names == ["bob"]
    assert np.linalg.norm(ours[OUTPUTS // 2, 0] - ours[0, 0]) > 0.5 * d  # swung across
    assert np.linalg.norm(ours[-1, 0] - ours[0, 0]) < 1e-7  # and back after one period


def test_rpy_is_fixed_axis_roll_pitch_yaw():
    rpy = [0.3, -1.1, 2.4]
    np.testing.assert_allclose(rpy_matrix(rpy), Rotation.from_euler("xyz", rpy).as_matrix(), atol=1e-15)


HINGE = """<mujoco model="spring">
  <compiler angle="degree"/>
  <worldbody>
    <body name="arm" pos="0 0 0.5" euler="0 0 30">
      <joint name="pin" type="hinge" axis="0 1 0" ref="20" damping="0.05" stiffness="4" springref="-40"/>
      <inertial pos="0.2 0 0" mass="0.5" diaginertia="1e-4 7e-3 7e-3"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_an_mjcf_hinge_spring_and_damper_become_an_rsda_that_moves_as_mujoco(tmp_path):
    path = tmp_path / "spring.xml"
    path.write_text(HINGE)
    imported = import_file(path)
    spring = imported.data["model"]["spring_dampers"][0]
    assert spring["type"] == "RSDA" and spring["joint"] == "pin"
    assert spring["free_angle"] == pytest.approx(math.radians(-60.0))  # springref - ref
    names, ours = centres(path, 1.0)
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.integrator, m.opt.timestep = mujoco.mjtIntegrator.mjINT_RK4, 1e-4
    d = mujoco.MjData(m)
    mujoco.mj_step(m, d, nstep=10000)
    mujoco.mj_forward(m, d)
    assert np.linalg.norm(ours[-1, 0] - ours[0, 0]) > 0.05
    assert np.max(np.abs(ours[-1, 0] - d.xipos[1])) < 1e-8


UNIVERSAL = """<mujoco model="cardan">
  <compiler angle="radian"/>
  <worldbody>
    <body name="shaft" pos="0 0 1" xyaxes="0 1 0 0 0 1">
      <joint name="cross.1" type="hinge" axis="1 0 0" pos="0 0 0"/>
      <joint name="cross.2" type="hinge" axis="0 1 0" pos="0 0 0"/>
      <inertial pos="0.3 0.05 -0.1" mass="1.5" diaginertia="2e-3 4e-2 4.1e-2"/>
    </body>
  </worldbody>
  <keyframe><key name="initial" qpos="0.3 -0.2" qvel="1.0 2.0"/></keyframe>
</mujoco>
"""


def test_two_hinges_of_one_body_are_a_universal_joint_started_from_the_initial_keyframe(tmp_path):
    """MuJoCo turns a body by its joints in turn, so the first hinge's axis is fixed in the parent and the second's
    in the body: a universal joint; the keyframe 'initial' places and starts it (qpos, qvel)."""
    path = tmp_path / "cardan.xml"
    path.write_text(UNIVERSAL)
    joint = import_file(path).data["model"]["joints"][0]
    assert joint["name"] == "cross" and joint["type"] == "universal"
    names, ours = centres(path, 1.0)
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.integrator, m.opt.timestep = mujoco.mjtIntegrator.mjINT_RK4, 1e-4
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(ours[0, 0], d.xipos[1], atol=1e-12)
    mujoco.mj_step(m, d, nstep=10000)
    mujoco.mj_forward(m, d)
    assert np.linalg.norm(ours[-1, 0] - ours[0, 0]) > 0.1
    assert np.max(np.abs(ours[-1, 0] - d.xipos[1])) < 1e-8


GEOM_ARM = DATA / "geom_arm.xml"


def test_mass_from_geoms_is_mujocos_and_moves_as_mujoco_runs_it():
    """Bodies without <inertial> take the mass of their solids (density or mass, by default class): the import's
    mass, centre and inertia tensor are those MuJoCo's compiler gives (body_mass, xipos, body_inertia turned by
    ximat), and the arm moves as MuJoCo runs it."""
    model = load_model(GEOM_ARM)
    m = mujoco.MjModel.from_xml_path(str(GEOM_ARM))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    for k, body in enumerate(model.bodies, start=1):
        A, R = euler_rotation(body.orientation), d.ximat[k].reshape(3, 3)
        assert body.mass == pytest.approx(m.body_mass[k], rel=1e-12)
        np.testing.assert_allclose(body.location, d.xipos[k], atol=1e-12)
        np.testing.assert_allclose(A @ body.inertia @ A.T, R @ np.diag(m.body_inertia[k]) @ R.T, atol=1e-12)
    names, ours = centres(GEOM_ARM, 1.0)
    assert np.max(np.abs(ours - ours[0])) > 0.2
    assert np.max(np.abs(ours - mujoco_centres(GEOM_ARM, names, 1.0))) < 1e-8


def test_mbd_run_takes_the_urdf_in_one_command_and_says_what_it_dropped(tmp_path):
    out = tmp_path / "arm.csv"
    done = subprocess.run(
        [sys.executable, "-m", "solutions.cli", "run", str(ARM), "--t-end", "0.2", "--steps", "4", "--out", str(out)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    for dropped in ("<limit> of 'shoulder'", "2 <transmission>", "<visual>/<collision>", "'tool' into 'forearm'"):
        assert sum(dropped in line for line in lines) == 1, (dropped, lines)
    assert all(line.startswith("mbd: import two_link_arm.urdf: ") for line in lines)
    assert "forearm.z" in read_csv(out)


def test_mbd_import_writes_a_model_file_that_runs_as_the_file_itself(tmp_path, capsys):
    model = tmp_path / "four_bar.yaml"
    assert main(["import", str(FOUR_BAR), "--out", str(model)]) == 0
    captured = capsys.readouterr()
    assert "<actuator> 'drive': dropped (no force while the control stays 0" in captured.err
    assert "<sensor> (jointpos)" in captured.err
    assert "<equality> solref/solimp" in captured.err
    text = model.read_text()
    assert text.startswith("# Imported from four_bar.xml") and "<actuator> 'drive'" in text
    assert "type: spherical" in text and "rotation_matrix" in text and "com: [0.128, 0.0, 0.003]" in text
    args = ["--t-end", "0.1", "--steps", "2"]
    assert main(["run", str(model), *args, "--out", str(tmp_path / "a.csv")]) == 0
    assert main(["run", str(FOUR_BAR), *args, "--out", str(tmp_path / "b.csv")]) == 0
    a, b = read_csv(tmp_path / "a.csv"), read_csv(tmp_path / "b.csv")
    assert list(a) == list(b)
    for column in a:
        np.testing.assert_array_equal(a[column], b[column])
    assert main(["check", str(FOUR_BAR)]) == 0
    assert "degrees of freedom: 1" in capsys.readouterr().out
    assert main(["view", str(ARM), "--out", str(tmp_path / "arm.html")]) == 0
    assert "'tool' into 'forearm'" in capsys.readouterr().err and "forearm" in (tmp_path / "arm.html").read_text()


REFUSED = {
    "planar.urdf": (
        '<robot name="r"><link name="a"/><link name="b"><inertial><mass value="1"/>'
        '<inertia ixx="1" iyy="1" izz="1"/></inertial></link><joint name="slide" type="planar">'
        '<parent link="a"/><child link="b"/></joint></robot>',
        "joint 'slide' type=\"planar\"",
    ),
    "loop.urdf": (
        '<robot name="r"><link name="a"/><link name="b"/><link name="c"/>'
        '<joint name="j1" type="revolute"><parent link="a"/><child link="b"/></joint>'
        '<joint name="j2" type="revolute"><parent link="c"/><child link="b"/></joint></robot>',
        "link 'b' is the child of two joints",
    ),
    "massless.urdf": (
        '<robot name="r"><link name="a"/><link name="b"/><link name="c"><inertial><mass value="1"/>'
        '<inertia ixx="1" iyy="1" izz="1"/></inertial></link>'
        '<joint name="j1" type="revolute"><parent link="a"/><child link="b"/></joint>'
        '<joint name="j2" type="revolute"><parent link="b"/><child link="c"/></joint></robot>',
        "body 'b': no mass",
    ),
    "broken.urdf": ('<robot name="r"><link name="a">', "malformed XML"),
    "mesh.xml": (
        '<mujoco><worldbody><body name="b"><joint/><geom type="mesh" mesh="m"/></body></worldbody></mujoco>',
        "body 'b' <geom type='mesh'>: import computes the mass of sphere, capsule",
    ),
    "two_joints.xml": (
        '<mujoco><worldbody><body name="b"><joint name="h1"/><joint name="h2" axis="1 0 0" pos="0.1 0 0"/>'
        '<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body></worldbody></mujoco>',
        "body 'b': joints 'h1', 'h2' in one body",
    ),
    "coupled.xml": (
        '<mujoco><worldbody><body name="b"><joint name="h1"/><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>'
        '</body></worldbody><equality><joint joint1="h1"/></equality></mujoco>',
        "<equality><joint>",
    ),
    "other.xml": ("<sdf version='1.6'/>", "not a URDF (<robot>) or MJCF (<mujoco>) file"),
}


@pytest.mark.parametrize("name", sorted(REFUSED))
def test_what_the_model_cannot_hold_is_refused_in_one_line(tmp_path, capsys, name):
    text, expected = REFUSED[name]
    path = tmp_path / name
    path.write_text(text)
    assert main(["import", str(path), "--out", str(tmp_path / "m.yaml")]) == 2
    assert main(["run", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and all(line.startswith(f"mbd: error: {name}: ") for line in err), err
    assert expected in err[0], err
    assert not (tmp_path / "m.yaml").exists()


def test_import_refuses_a_yaml_model_and_an_output_that_is_not_yaml(tmp_path, capsys):
    assert main(["import", str(tmp_path / "m.yaml")]) == 2
    assert main(["import", str(ARM), "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert "import reads URDF (.urdf) and MJCF (.xml)" in err and "FILE.yaml" in err


# -- import(export(model)): the same motion (mbd export, solutions/io/mjcf.py and urdf.py) ---------------------------
MODELS = Path(__file__).resolve().parents[3] / "course" / "models"
ROUND_TRIP_MJCF = {
    "andrews": 0.003,  # its stiff spring makes the spatial run slow: a tenth of its span
    "carriage_pendulum": None,
    "cylindrical": None,
    "double_pendulum": None,
    "heavy_top": None,
    "parallel_swing": None,
    "revolute_revolute_skew": None,
    "simple_pendulum": None,
    "spatial_double_pendulum": None,
}
"""The undriven example models MJCF holds (span: the model's own unless given): gravity, initial velocities
(MJCF's keyframe 'initial'), springs (spatial tendons, hinge stiffness), a constant torque (an actuator's bias),
loops (connect), cylindrical joints. A driven model's motor is exported as an equality between joint values
(a clock), which import refuses (the test below)."""
ROUND_TRIP_URDF = ("revolute_revolute_skew",)
"""The example models URDF holds whole: an open tree at rest under gravity along -z (URDF gives no gravity, so
import takes -z), without springs or motors."""


def motion(model, simulation: dict, t_end: float | None) -> dict[str, np.ndarray]:
    """Body centres (outputs, 3) by name: a planar model's (x, y, 0), the numpy engine at a tight tolerance, with
    the original file's ``simulation`` (an exported file holds the model, not its analysis)."""
    system, q0, qd0 = build_system(model)
    options = {"t_end": t_end} if t_end else {}
    settings = read_settings(simulation, engine="numpy", analysis="dynamic", rtol=1e-10, atol=1e-10, **options)
    q = run_analysis(system, q0, qd0, settings).q
    per = 3 if model.dimension == 2 else 7
    out = {}
    for k, body in enumerate(model.bodies):
        centre = q[:, per * k : per * k + model.dimension]
        out[body.name] = np.column_stack([centre, np.zeros(len(q))]) if model.dimension == 2 else centre
    return out


def exported(stem: str, to: str, folder: Path) -> Path:
    from solutions.io.mjcf import Stiffness, export_mjcf
    from solutions.io.urdf import export_urdf

    model = load_model(MODELS / f"{stem}.yaml")
    path = folder / f"{stem}.{'xml' if to == 'mjcf' else 'urdf'}"
    path.write_text(export_mjcf(model, Stiffness()) if to == "mjcf" else export_urdf(model)[0])
    return path


@pytest.mark.parametrize(
    ("stem", "to"), [*((s, "mjcf") for s in ROUND_TRIP_MJCF), *((s, "urdf") for s in ROUND_TRIP_URDF)]
)
def test_an_exported_model_imports_back_to_the_same_motion(tmp_path, stem, to):
    original = load_model(MODELS / f"{stem}.yaml")
    back = load_model(exported(stem, to, tmp_path))
    assert back.dimension == 3 and sorted(b.name for b in back.bodies) == sorted(b.name for b in original.bodies)
    t_end = ROUND_TRIP_MJCF.get(stem) if to == "mjcf" else None
    ours, theirs = motion(original, original.simulation, t_end), motion(back, original.simulation, t_end)
    assert max(float(np.max(np.abs(ours[name] - theirs[name]))) for name in ours) < 1e-8  # largest 1.8e-10 m


def test_a_driven_export_is_refused_by_import_naming_its_motor(tmp_path):
    path = exported("four_bar", "mjcf", tmp_path)
    with pytest.raises(Exception, match=r'<equality><joint name="drive">: an equality between joint'):
        load_model(path)


def test_a_floating_urdf_link_is_a_free_body_that_falls_as_a_stone(tmp_path):
    path = tmp_path / "free.urdf"
    path.write_text(
        '<robot name="drop"><link name="world"/><link name="stone"><inertial><origin xyz="0.1 0 0"/>'
        '<mass value="2"/><inertia ixx="0.01" iyy="0.02" izz="0.03" ixy="0.001"/></inertial></link>'
        '<joint name="float" type="floating"><parent link="world"/><child link="stone"/>'
        '<origin xyz="0 0 3" rpy="0.2 0.3 0.4"/></joint></robot>'
    )
    model = import_file(path).data["model"]
    assert "joints" not in model and model["bodies"][0]["name"] == "stone"
    names, ours = centres(path, 0.5)
    start = np.array([0.0, 0.0, 3.0]) + Rotation.from_euler("xyz", [0.2, 0.3, 0.4]).apply([0.1, 0.0, 0.0])
    np.testing.assert_allclose(ours[-1, 0], start - [0.0, 0.0, 0.5 * 9.81 * 0.5**2], atol=1e-9)
