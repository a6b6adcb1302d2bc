"""The default engine's two estimates of a numpy run side by side on every course model (issue 25, item 3).

    MBD_COMPILED_CACHE=$(mktemp -d) .venv/bin/python benchmarks/auto_estimate.py [--t-end 1]   # ~40 s

(an empty compiled cache: the runs stay on numpy but for the few that ``auto`` compiles; with the course's cache
the estimates are the same, the runs much longer).

``compiled.dispatch.estimated_numpy_seconds`` first estimates the numpy run from the starting step h0 (the
"quick" estimate) and, where that comes within a tenth of the bound, from a trial of TRIAL_STEPS steps. Whether
the quick estimate alone could decide a run far above the bound (no trial: 6-19 ms saved on a run ``auto``
compiles) depends on how far it can be off the trial's: this prints quick / trial for each course model at the
rule's rtol, 1e-6 and 1e-9 (both from one per-evaluation time, the thread CPU of 20 evaluations, so the ratio is
that of the steps alone). Never asserted anywhere.
"""

from __future__ import annotations

import argparse
import glob
import math
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from solutions.assembly import build_system  # noqa: E402
from solutions.compiled import dispatch  # noqa: E402
from solutions.dynamics import forward_dynamics  # noqa: E402
from solutions.integrators import initial_step, integrate  # noqa: E402
from solutions.io import load_model  # noqa: E402

FOUND: list[tuple[float, float]] = []


def both_estimates(equations, z0, settings, threshold=math.inf, _original=dispatch.estimated_numpy_seconds):
    """Records (quick, trial) for the run, then makes the engine's own estimate."""
    f, integrator = equations.rhs, settings.integrator
    if integrator in dispatch.STAGES and integrator != "rk4":
        fy = f(0.0, z0)
        start = time.thread_time()
        for _ in range(20):
            f(0.0, z0)
        per_call = (time.thread_time() - start) / 20
        order = 7 if integrator in ("DOP853", "dop853") else 4
        h0 = initial_step(f, 0.0, z0, fy, order, settings.rtol, settings.atol, settings.t_end)
        method = "dop853" if integrator in ("DOP853", "dop853") else "rk45"
        stats = integrate(
            f, z0, np.array([0.0, settings.t_end]), lambda k, t, y: None, method, settings.rtol, settings.atol,
            settings.step, max_evaluations=None, stiffness="off", max_steps=dispatch.TRIAL_STEPS,
        )  # fmt: skip
        h = stats.step_size if np.isfinite(stats.step_size) else settings.t_end
        scale = per_call * dispatch.STAGES[integrator] * settings.t_end
        FOUND.append((scale / max(h0, 1e-300), scale / max(h, 1e-300)))
    return _original(equations, z0, settings, threshold)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=1.0)
    args = parser.parse_args()
    dispatch.estimated_numpy_seconds = both_estimates
    print("| model | rtol | quick (s) | trial (s) | quick / trial | engine |\n|---|---|---:|---:|---:|---|")
    for path in sorted(glob.glob(str(ROOT / "course/models/*.yaml"))):
        system, q0, qd0 = build_system(load_model(path))
        for rtol in (None, 1e-6, 1e-9):
            FOUND.clear()
            options = {} if rtol is None else {"rtol": rtol}
            try:
                run = forward_dynamics(system, q0, qd0, args.t_end, 5, engine="auto", divergence="skip", **options)
            except Exception as err:  # noqa: BLE001 -- a model that fails at this rtol: said, and the next
                print(f"| {Path(path).stem} | {rtol or 'rule'} | {type(err).__name__} | | | |")
                continue
            for quick, trial in FOUND:
                print(
                    f"| {Path(path).stem} | {rtol or 'rule'} | {quick:.3g} | {trial:.3g} | {quick / trial:.3g} "
                    f"| {'compiled' if 'compiled' in run.info else 'numpy'} |"
                )


if __name__ == "__main__":
    main()
