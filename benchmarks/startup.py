"""What a one-step run costs as a whole process, against importing what any numerical Python script imports.

Issue 25 asks that a one-step `mbd run` (default settings: engine auto) start within 1.5x of
``python -c "import numpy, scipy.linalg, yaml"``. Each round runs the baseline and every model's one-step run once,
in turn (interleaved: a slow moment of the machine falls on both), and the ratio of each run to the baseline of
its round is kept; the table gives the median ratio and its spread over the rounds, and the median seconds.

    python benchmarks/startup.py [--rounds 15] [--models heavy_top four_bar ...] [--out results/startup.md]

Run it with bytecode written (PYTHONDONTWRITEBYTECODE unset: a user's installed package has its .pyc files) and
after `mbd compile` or not: a one-step run does not load the compiled engine either way.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODELS = ("heavy_top", "spatial_double_pendulum", "four_bar", "slider_crank_flywheel", "double_pendulum")
BASELINE = [sys.executable, "-c", "import numpy, scipy.linalg, yaml"]


def one_step(model: str, out: Path) -> list[str]:
    """``mbd run MODEL`` over one output step of 1 ms, writing its CSV: the whole process a user starts."""
    path = ROOT / "course" / "models" / f"{model}.yaml"
    return [sys.executable, "-m", "solutions.cli", "run", str(path), "--t-end", "0.001", "--steps", "1"] + [
        "--out", str(out / f"{model}.csv"),
    ]  # fmt: skip


def seconds(command: list[str], env: dict) -> float:
    start = time.perf_counter()
    subprocess.run(command, cwd=ROOT, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--models", nargs="+", default=list(MODELS))
    parser.add_argument("--out", type=Path, help="append the table to this Markdown file")
    args = parser.parse_args(argv)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "MBD_ENGINE")}
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    ratios: dict[str, list[float]] = {m: [] for m in args.models}
    times: dict[str, list[float]] = {m: [] for m in ["baseline", *args.models]}
    with tempfile.TemporaryDirectory() as tmp:
        for model in args.models:  # one warm-up each: bytecode written, files in the page cache
            seconds(one_step(model, Path(tmp)), env)
        for _ in range(args.rounds):
            base = seconds(BASELINE, env)
            times["baseline"].append(base)
            for model in args.models:
                t = seconds(one_step(model, Path(tmp)), env)
                times[model].append(t)
                ratios[model].append(t / base)
    lines = [
        f'\n## One-step `mbd run` against `python -c "import numpy, scipy.linalg, yaml"` '
        f"({time.strftime('%Y-%m-%d')})\n",
        f"`python benchmarks/startup.py --rounds {args.rounds}`; {os.cpu_count()} cores; ratios paired by round.\n",
        "| run | median s | median ratio | ratio min-max |",
        "|---|---:|---:|---:|",
        f"| baseline | {statistics.median(times['baseline']):.3f} | 1 | |",
    ]
    for model in args.models:
        r = ratios[model]
        lines.append(
            f"| {model} | {statistics.median(times[model]):.3f} | {statistics.median(r):.2f} | "
            f"{min(r):.2f}-{max(r):.2f} |"
        )
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        with open(args.out, "a") as f:
            f.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
