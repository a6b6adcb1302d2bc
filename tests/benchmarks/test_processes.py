"""The whole-process table (benchmarks/processes.py): what it reads back from `mbd run`'s CSV, that it refuses to run
without MuJoCo, and (where MuJoCo is installed) that the MuJoCo program it times computes the motion it was chosen
for."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import bench, processes  # noqa: E402


def _scene(key: str):
    scene = next(s for s in bench.scenes() if s.key == key)
    scene.t_end, scene.outputs = 0.2, 4
    bench.prepare_reference(scene, quick=True)
    return scene


def test_our_positions_are_read_back_from_the_csv_of_mbd_run(tmp_path):
    """The body centres that `mbd run` writes, read by ``our_positions``, follow the scene's reference."""
    scene = _scene("spatial_double_pendulum")
    out = tmp_path / "run.csv"
    model = bench.MODELS / scene.source
    command = [sys.executable, "-m", "solutions.cli", "run", str(model), "--t-end", "0.2", "--steps", "4", "--out",
               str(out), "--engine", "numpy"]  # fmt: skip
    subprocess.run(command, cwd=ROOT, check=True, capture_output=True)
    positions = processes.our_positions(out, scene)
    assert positions.shape == scene.ref_positions.shape == (5, 2, 3)
    assert processes.error(scene, positions) < 1e-5
    assert np.max(np.abs(positions[-1] - positions[0])) > 1e-2  # it moved: the columns are not the start's


def test_without_mujoco_it_says_what_to_install(monkeypatch, capsys):
    monkeypatch.setattr(processes.peers, "mujoco", None)
    with pytest.raises(SystemExit) as stop:
        processes.main(["--rounds", "1"])
    assert stop.value.code == 2
    assert "needs MuJoCo: pip install" in capsys.readouterr().err


@pytest.mark.parametrize("key", ["double_pendulum", "spatial_double_pendulum"])
def test_the_mujoco_program_computes_the_chosen_configuration_s_motion(tmp_path, key):
    pytest.importorskip("mujoco")
    scene = _scene(key)
    family, h, error, _ = processes.cheapest_mujoco(scene, 1e-4)
    assert error <= 1e-4
    xml, state, per_output = processes.mujoco_files(scene, family, h, tmp_path)
    program, out = tmp_path / "program.py", tmp_path / "out.csv"
    program.write_text(processes.PROGRAM)
    names = ",".join(b.name for b in scene.load().bodies)
    arguments = [str(xml), str(state), str(out), str(scene.outputs), str(per_output), str(scene.dimension), names]
    subprocess.run([sys.executable, str(program), *arguments], check=True, capture_output=True)
    written = np.loadtxt(out, delimiter=",").reshape(scene.ref_positions.shape)
    assert processes.error(scene, written) == pytest.approx(error, rel=1e-9, abs=1e-15)
