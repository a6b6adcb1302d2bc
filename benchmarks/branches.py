"""Branch switches at singular positions (issue 29): the chain of N parallelogram loops (benchmarks/chains.py
``loop_chain``, cranks thrown at 8 rad/s from 60 degrees) through its flat positions, judged against its one-degree-
of-freedom equation (``loop_reference``, scipy at 1e-12, the parallelogram branch throughout).

Per N, engine and writing of the bodies (frames at the centres of mass, or at the joints with ``com:``): what the run
returns (exit 0 with its largest error and the first time it exceeds 1e-6 m, and its warnings; or the stop and its
message). ``--without-check`` runs with the Guard's branch check switched off: what the run returned before it.

    .venv/bin/python benchmarks/branches.py --sizes 2 40 --t-end 10 --engines numpy compiled
    .venv/bin/python benchmarks/branches.py --sizes 2 --t-end 1.35 --rtol 7e-10 --steps 135 --without-check
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import chains  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.diagnostics import AnalysisError  # noqa: E402
from solutions.dynamics import forward_dynamics  # noqa: E402
from solutions.guard import Guard  # noqa: E402
from solutions.io.model import load_model  # noqa: E402

ANGLE, RATE = math.radians(60.0), 8.0


def outcome(n: int, engine: str, frames: str, t_end: float, steps: int, formulation: str, rtol) -> str:
    """One line: the run's outcome against the reference."""
    times = np.linspace(0.0, t_end, steps + 1)
    truth = chains.loop_reference(n, times, ANGLE, RATE)
    system, q0, qd0 = build_system(load_model(chains.loop_chain(n, ANGLE, RATE, frames)))
    options = {} if rtol is None else {"rtol": rtol, "atol": rtol}
    start = time.process_time()
    try:
        result = forward_dynamics(system, q0, qd0, t_end, steps, formulation, engine=engine, **options)
    except AnalysisError as err:
        return f"stopped: {err} [{time.process_time() - start:.1f} s CPU]"
    error = np.linalg.norm(result.q.reshape(times.size, -1, 3)[:, :, :2] - truth, axis=-1).max(axis=1)
    off = np.flatnonzero(error > 1e-6)
    first = f", > 1e-6 m from t = {times[off[0]]:.3g} s" if off.size else ""
    said = "; ".join(result.info["warnings"]) or "no warning"
    return (
        f"exit 0, error {error.max():.2g} m{first}, rtol {result.info['rtol']:.2g}; {said} "
        f"[{time.process_time() - start:.1f} s CPU]"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="*", type=int, default=[1, 2, 10, 40])
    parser.add_argument("--engines", nargs="*", default=["numpy", "compiled"], choices=["numpy", "compiled"])
    parser.add_argument("--frames", nargs="*", default=["centre", "joint"], choices=["centre", "joint"])
    parser.add_argument("--t-end", type=float, default=10.0)
    parser.add_argument("--steps", type=int, default=100, help="output intervals (default 100, as mbd run's)")
    parser.add_argument("--formulation", default="joint-coordinates")
    parser.add_argument("--rtol", type=float, default=None, help="rtol = atol (default: the package's rule)")
    parser.add_argument("--without-check", action="store_true", help="the Guard's branch check switched off")
    args = parser.parse_args(argv)
    if args.without_check:
        Guard.check_branches = lambda *a, **k: None
        Guard.check_branches_before = lambda *a, **k: None
    for n in args.sizes:
        for frames in args.frames:
            for engine in args.engines:
                said = outcome(n, engine, frames, args.t_end, args.steps, args.formulation, args.rtol)
                print(f"N = {n}, {engine}, frames at the {frames}s: {said}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
