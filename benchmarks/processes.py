"""What a user pays, as whole processes: ``mbd run`` of each peer scene against the program a MuJoCo user runs.

Issue 25 (item 5) asks for a whole-process table beside the in-process one of ``bench.py``. For the planar double
pendulum, the free slider-crank and the spatial double pendulum (``bench.py``'s peer scenes: their span, output
grid and reference):

- ours: ``mbd run MODEL --out CSV``, every other setting its default (formulation, integrator and engine auto,
  accuracy 1e-6 of the mechanism's size); its error read back from the CSV;
- MuJoCo: ``PROGRAM``, what a MuJoCo user writes: import mujoco and numpy, load the scene's MJCF (``peers.py``'s
  model) from a file, set the initial state, ``mujoco.rollout`` over the span, the body centres on the output grid
  written to a CSV; with the cheapest configuration (integrator, step h = interval / k, the loop's solref) whose
  error is at most our run's, or TARGET (1e-6 m) where ours is smaller (the default asks 1e-6 of the mechanism's
  size; on the slider-crank it reaches 9e-11 m, which no MuJoCo configuration does), found by timing MuJoCo in this
  process first (``peers.families``).

Each program is timed from start to exit in ``--rounds`` interleaved rounds (the order alternating), the ratio
ours / MuJoCo kept per round: its median and range. The error of either is the largest error of a body centre
coordinate on the output grid against the scene's reference, as in ``bench.py``.

    python benchmarks/processes.py [--rounds 7] [--scene double_pendulum ...] [--out results/processes.md]

Needs MuJoCo (extra ``[bench]``). Run it after ``mbd compile`` for the compiled engine's default, and with bytecode
written (PYTHONDONTWRITEBYTECODE unset: an installed package has its .pyc files); the table says which engine ran.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import bench, peers  # noqa: E402

SCENES = ("double_pendulum", "slider_crank", "spatial_double_pendulum")
TARGET = 1e-6
"""The error MuJoCo must reach where our default run is more accurate than this (m): what the default asks."""
PROGRAM = """\
import sys

import mujoco
import numpy as np
from mujoco import rollout

xml, state, out = sys.argv[1:4]
outputs, per_output, dimension = (int(a) for a in sys.argv[4:7])
m = mujoco.MjModel.from_xml_path(xml)
bodies = [m.body(name).id for name in sys.argv[7].split(",")]  # the model's bodies, in its order
d = mujoco.MjData(m)
qpos, qvel = np.split(np.load(state), [m.nq])
d.qpos[:], d.qvel[:] = qpos, qvel
mujoco.mj_forward(m, d)
spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
initial = np.empty(mujoco.mj_stateSize(m, spec))
mujoco.mj_getState(m, d, initial, spec)
states, _ = rollout.rollout(m, d, initial[None], nstep=outputs * per_output)
rows = []
for q in [qpos, *states[0, per_output - 1 :: per_output, 1 : 1 + m.nq]]:
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    rows.append(d.xipos[bodies, :dimension].copy().ravel())  # a copy: xipos is overwritten at the next state
np.savetxt(out, np.array(rows), delimiter=",")
"""
"""The MuJoCo user's program: MJCF file, initial state (qpos, qvel), CSV out, outputs, steps per output, dimension,
the bodies' names (comma-separated)."""


def our_positions(path: Path, scene) -> np.ndarray:
    """Body centres (outputs + 1, bodies, dim) from the CSV of ``mbd run``."""
    with path.open() as f:
        rows = list(csv.DictReader(f))
    axes = "xyz"[: scene.dimension]
    names = [body.name for body in scene.load().bodies]
    return np.array([[[float(row[f"{b}.{a}"]) for a in axes] for b in names] for row in rows])


def error(scene, positions: np.ndarray) -> float:
    """The largest error of a body centre coordinate on the output grid (``peers._position_error``)."""
    return float(np.max(np.abs(positions - scene.ref_positions)))


def cheapest_mujoco(scene, target: float):
    """(family, h, error, ms) of the cheapest MuJoCo configuration whose error is at most ``target``, or None: for
    each integrator (and solref of a loop) the first step of ``peers.families`` that reaches it, timed again."""
    found = []
    for family in peers.families(scene, quick=False):
        if not family.label.startswith("MuJoCo"):
            continue
        for h in family.settings:
            run = peers.execute(family, h, scene, 1)
            if run.ok and run.error <= target:
                run = peers.execute(family, h, scene, 3)
                found.append((run.ms, family, h, run.error))
                break
            if run.ms > 1e3 * peers.SECONDS:
                break
    if not found:
        return None
    ms, family, h, err = min(found, key=lambda item: item[0])
    return family, h, err, ms


def mujoco_files(scene, family, h: float, folder: Path) -> tuple[Path, Path, int]:
    """The MJCF file and initial state of the configuration, and its steps per output interval."""
    integrator = family.label.split(",")[0].split()[1]
    solref = family.label.split("solref ")[1] if "solref" in family.label else None
    xml, qpos, qvel = peers.mujoco_xml(scene, peers.MUJOCO_SCENES[scene.key], h, integrator, solref)
    model, state = folder / f"{scene.key}.xml", folder / f"{scene.key}.npy"
    model.write_text(xml)
    np.save(state, np.concatenate([qpos, qvel]))
    return model, state, round(scene.t_end / scene.outputs / h)


def seconds(command: list[str], env: dict) -> float:
    start = time.perf_counter()
    subprocess.run(command, cwd=ROOT, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def compare(scene, rounds: int, folder: Path, env: dict) -> dict:
    """The two programs of a scene, checked and timed (module docstring)."""
    source = (
        scene.source if isinstance(scene.source, dict) else yaml.safe_load((bench.MODELS / scene.source).read_text())
    )
    data = {"model": source["model"], "simulation": {"end_time": scene.t_end, "output_steps": scene.outputs}}
    model = folder / f"{scene.key}.yaml"
    model.write_text(yaml.safe_dump(data))
    ours_csv = folder / f"{scene.key}.csv"
    ours = [sys.executable, "-m", "solutions.cli", "run", str(model), "--out", str(ours_csv)]
    said = subprocess.run(ours, cwd=ROOT, env=env, check=True, capture_output=True, text=True).stdout
    engine = next((line[len("engine: ") :] for line in said.splitlines() if line.startswith("engine: ")), "-")
    ours_error = error(scene, our_positions(ours_csv, scene))
    chosen = cheapest_mujoco(scene, max(ours_error, TARGET))
    if chosen is None:
        return {"scene": scene.title, "ours_error": ours_error, "engine": engine, "mujoco": None}
    family, h, mujoco_error, in_process_ms = chosen
    xml, state, per_output = mujoco_files(scene, family, h, folder)
    program = folder / "mujoco_program.py"
    program.write_text(PROGRAM)
    theirs_csv = folder / f"{scene.key}_mujoco.csv"
    theirs = [sys.executable, str(program), str(xml), str(state), str(theirs_csv), str(scene.outputs),
              str(per_output), str(scene.dimension), ",".join(b.name for b in scene.load().bodies)]  # fmt: skip
    seconds(theirs, env)  # warm-up, and its output checked: the program computes what the in-process run did
    written = np.loadtxt(theirs_csv, delimiter=",").reshape(scene.ref_positions.shape)
    program_error = error(scene, written)
    times: dict[str, list[float]] = {"ours": [], "mujoco": []}
    for r in range(rounds):
        order = ("ours", "mujoco") if r % 2 == 0 else ("mujoco", "ours")
        for name in order:
            times[name].append(seconds(ours if name == "ours" else theirs, env))
    ratios = [a / b for a, b in zip(times["ours"], times["mujoco"], strict=True)]
    return {
        "scene": scene.title, "ours_error": ours_error, "engine": engine, "mujoco": family.label, "h": h,
        "mujoco_error": program_error, "mujoco_in_process_ms": in_process_ms, "times": times, "ratios": ratios,
    }  # fmt: skip


def table(results: list[dict], rounds: int) -> list[str]:
    lines = [
        f"\n## Whole processes: default `mbd run` against a MuJoCo program as accurate ({time.strftime('%Y-%m-%d')})\n",
        f"`python benchmarks/processes.py --rounds {rounds}`; {os.cpu_count()} cores; each program from start to "
        "exit, interleaved rounds; ratio: ours / MuJoCo's per round (below 1: ours faster).\n",
        "| scene | `mbd run` (error, engine) | median s | MuJoCo program (error) | median s | ratio median | min-max |",
        "|---|---|---:|---|---:|---:|---:|",
    ]
    for r in results:
        if r["mujoco"] is None:
            lines.append(f"| {r['scene']} | {r['ours_error']:.2g}, {r['engine']} | | no MuJoCo configuration "
                         f"reached {max(r['ours_error'], TARGET):.2g} m | | | |")  # fmt: skip
            continue
        ratios = r["ratios"]
        lines.append(
            f"| {r['scene']} | {r['ours_error']:.2g}, {r['engine']} | {statistics.median(r['times']['ours']):.3f} | "
            f"{r['mujoco']}, h = {r['h']:.3g} ({r['mujoco_error']:.2g}) | {statistics.median(r['times']['mujoco']):.3f}"
            f" | {statistics.median(ratios):.2f} | {min(ratios):.2f}-{max(ratios):.2f} |"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="mbd bench --processes", description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7, help="interleaved rounds (default 7)")
    parser.add_argument("--scene", action="append", choices=SCENES, help="only these scenes (repeatable)")
    parser.add_argument("--out", type=Path, help="append the table to this Markdown file")
    args = parser.parse_args(argv)
    if peers.mujoco is None:
        parser.error("the whole-process table needs MuJoCo: pip install -e '.[bench]' (or pip install mujoco)")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "MBD_ENGINE")}
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    chosen = [s for s in bench.scenes() if s.key in (args.scene or SCENES)]
    results = []
    with tempfile.TemporaryDirectory(prefix="mbd-processes-") as tmp:
        for scene in chosen:
            bench.prepare_reference(scene, quick=False)
            results.append(compare(scene, args.rounds, Path(tmp), env))
            print(f"{scene.key}: done", file=sys.stderr, flush=True)
    lines = table(results, args.rounds)
    print("\n".join(lines))
    if args.out:
        with args.out.open("a") as f:
            f.write("\n".join(lines) + "\n")
    return 0 if all(math.isfinite(r["ours_error"]) for r in results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
