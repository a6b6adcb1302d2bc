"""What showing a motion costs: the viewer (``solutions/viewer.py``, a Plotly figure of data) against matplotlib's
``to_jshtml`` player of pictures (what the notebooks used before, issue 26), in the same run.

For each scene, both make an animation of the same result with the same number of frames; the table gives the
CPU seconds to build it (the median of ``--repeat`` builds) and its size in a notebook (the viewer's JSON; the
player's HTML), and their ratios.

    .venv/bin/python benchmarks/viewer_cost.py                 # 60 frames, as notebook_animation shows them
    .venv/bin/python benchmarks/viewer_cost.py --frames 120 --repeat 5

Nothing is asserted (timing depends on the machine): prints a Markdown table.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")

from solutions.animation import animate_result  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.dynamics import forward_dynamics  # noqa: E402
from solutions.io.model import load_model  # noqa: E402
from solutions.kinematics import kinematic_analysis  # noqa: E402
from solutions.viewer import result_view, size_of  # noqa: E402

MODELS = Path(__file__).resolve().parents[1] / "course" / "models"
SCENES = ("slider_crank", "four_bar_spring", "spatial_double_pendulum", "spatial_slider_crank")


def run(name: str):
    model = load_model(MODELS / f"{name}.yaml")
    system, q0, qd0 = build_system(model)
    if name in ("slider_crank", "spatial_slider_crank"):
        result = kinematic_analysis(system, q0, 2 * math.pi / 10, 200)
    else:
        result = forward_dynamics(system, q0, qd0, 1.0, 200)
    return model, system, result


def cpu(build, repeat: int) -> tuple[float, object]:
    times, made = [], None
    for _ in range(repeat):
        start = time.process_time()
        made = build()
        times.append(time.process_time() - start)
    return statistics.median(times), made


def measure(name: str, frames: int, repeat: int) -> str:
    """One table row: the player and the viewer of the same result."""
    model, system, result = run(name)
    player_s, html = cpu(lambda: animate_result(model, system, result, max_frames=frames).to_jshtml(), repeat)
    viewer_s, view = cpu(lambda: result_view(model, system, result, max_frames=frames), repeat)
    player_kb, viewer_kb = len(html.encode()) / 1e3, size_of(view) / 1e3
    return (
        f"| {name} | {player_s:.2f} | {viewer_s:.3f} | {player_s / viewer_s:.0f} | {player_kb:.0f} | "
        f"{viewer_kb:.0f} | {player_kb / viewer_kb:.0f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"{args.frames} frames, median of {args.repeat} builds (CPU seconds)\n")
    print("| scene | player s | viewer s | ratio | player kB | viewer kB | ratio |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name in SCENES:
        print(measure(name, args.frames, args.repeat))


if __name__ == "__main__":
    main()
