"""``mbd export --to urdf`` proven by MuJoCo, which compiles URDF: every open-tree example whose every element URDF
holds is exported, loaded by MuJoCo (gravity and the step set on the compiled model, URDF has neither), run with RK4
and compared with ``mbd run`` over the model's span within 1e-4 m; loops and joints URDF has no type for are
refused by name, what URDF does not hold (gravity, motors, springs) named in notes."""

from __future__ import annotations

import numpy as np
import pytest

from solutions.cli import main
from solutions.io.model import load_model
from solutions.io.urdf import export_urdf, rpy

from .test_mjcf import MODELS, TOLERANCE, centres, ours, step_for

mujoco = pytest.importorskip("mujoco")

OPEN_TREES = ("double_pendulum", "simple_pendulum", "revolute_revolute_skew")
"""The open-tree examples with nothing URDF leaves out but gravity (set on MuJoCo's model here)."""


def mujoco_urdf_run(model, text: str, times: np.ndarray, step: float) -> np.ndarray:
    m = mujoco.MjModel.from_xml_string(text)
    m.opt.timestep, m.opt.integrator = step, mujoco.mjtIntegrator.mjINT_RK4
    m.opt.gravity[:] = np.pad(model.gravity, (0, 3 - model.dimension))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b.name) for b in model.bodies]
    out = np.empty((times.size, len(ids), model.dimension))
    for k, t in enumerate(times):
        for _ in range(round((t - d.time) / step)):
            mujoco.mj_step(m, d)
        out[k] = d.xipos[ids, : model.dimension]
    return out


@pytest.mark.parametrize("stem", OPEN_TREES)
def test_mujoco_runs_the_urdf_as_mbd_run_does(stem, tmp_path, capsys):
    source = MODELS / f"{stem}.yaml"
    model = load_model(source)
    out = tmp_path / f"{stem}.urdf"
    assert main(["export", str(source), "--to", "urdf", "--out", str(out)]) == 0
    assert "note: URDF holds no gravity" in capsys.readouterr().out
    result = ours(model)
    step = step_for(result.t)
    theirs = mujoco_urdf_run(model, out.read_text(), result.t, step)
    assert np.max(np.abs(theirs - centres(model, result.q))) < TOLERANCE


@pytest.mark.parametrize(
    ("stem", "named"),
    [
        ("four_bar", "model.joints[3] (O4): closes a loop"),
        ("spatial_double_pendulum", "model.joints[0] (O): a spherical joint"),
        ("cylindrical", "model.joints[0] (shaft): a cylindrical joint"),
    ],
)
def test_what_urdf_cannot_hold_is_refused_by_name(stem, named, tmp_path, capsys):
    assert main(["export", str(MODELS / f"{stem}.yaml"), "--to", "urdf", "--out", str(tmp_path / "x.urdf")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{stem}.yaml: {named}" in err


def test_left_out_elements_are_named():
    _, notes = export_urdf(load_model(MODELS / "carriage_pendulum.yaml"))
    assert "URDF holds no spring-dampers: left out spring" in notes
    assert any(note.startswith("URDF holds no initial velocities") and "carriage" in note for note in notes)


def test_rpy_is_urdfs_fixed_axis_convention():
    """R = Rz(yaw) Ry(pitch) Rx(roll), built independently here."""
    roll, pitch, yaw = 0.3, -0.4, 1.1
    c, s = np.cos, np.sin
    Rx = np.array([[1, 0, 0], [0, c(roll), -s(roll)], [0, s(roll), c(roll)]])
    Ry = np.array([[c(pitch), 0, s(pitch)], [0, 1, 0], [-s(pitch), 0, c(pitch)]])
    Rz = np.array([[c(yaw), -s(yaw), 0], [s(yaw), c(yaw), 0], [0, 0, 1]])
    assert rpy(Rz @ Ry @ Rx) == pytest.approx([roll, pitch, yaw])
