"""The default engine's two estimates of a numpy run against the run itself, on every course model (issue 25).

    MBD_COMPILED_CACHE=$(mktemp -d) .venv/bin/python benchmarks/auto_estimate.py [--t-end 1] [--skip andrews]
    MBD_COMPILED_CACHE=$(mktemp -d) .venv/bin/python benchmarks/auto_estimate.py --calibrate [--divergence skip]

(an empty compiled cache: nothing is compiled; the runs are integrated by the numpy loop here, Andrews' squeezer
alone takes ~2 minutes at the three tolerances.)

``compiled.dispatch.estimated_numpy_seconds`` first estimates the numpy run from the starting step h0 (the
"quick" estimate: stages x t_end / h0 evaluations) and, where that comes within a tenth of the bound, from a
trial of TRIAL_STEPS accepted steps (``dispatch.trial_rate``: its evaluations x t_end / the time it reached).
Both are compared here with the evaluations the whole numpy integration takes (the same right-hand side, method,
tolerances and span; evaluations, not seconds: no timing noise), for each course model at the rule's rtol, 1e-6
and 1e-9. ``--calibrate``: the whole numpy run's wall time (``forward_dynamics`` on engine numpy, 2 s, 100
outputs, the rule's rtol and 1e-6) over the trial's estimate of its integration, the ratio behind
``dispatch.RUN_FACTOR``. Never asserted anywhere (a test checks the trial on two models: tests/solutions/compiled/
test_dispatch_estimate.py).
"""

from __future__ import annotations

import argparse
import glob
import math
import os
import sys
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


class Measured(Exception):
    """Raised by the hook once the figures of a run are taken: the run itself is not needed."""

    def __init__(self, figures: tuple[str, float, float, float, float]) -> None:
        super().__init__()
        self.figures = figures


def measure(equations, z0, settings, threshold=math.inf):
    """(method, rtol, run's evaluations, quick / run, trial / run) of the numpy run the engine's choice estimates."""
    f, integrator, t_end = equations.rhs, settings.integrator, settings.t_end
    if integrator not in dispatch.STAGES or integrator == "rk4":
        raise Measured((integrator, settings.rtol, math.nan, math.nan, math.nan))
    method = "dop853" if integrator in ("DOP853", "dop853") else "rk45"
    order = 7 if method == "dop853" else 4
    h0 = initial_step(f, 0.0, z0, f(0.0, z0), order, settings.rtol, settings.atol, t_end)
    quick = dispatch.STAGES[integrator] * t_end / max(h0, 1e-300)
    trial, _ = dispatch.trial_rate(f, z0, t_end, integrator, settings.rtol, settings.atol, settings.step)
    run = integrate(
        f, z0, np.array([0.0, t_end]), lambda k, t, y: None, method, settings.rtol, settings.atol, settings.step,
        max_evaluations=None, stiffness="off",
    )  # fmt: skip
    evaluations = run.rhs_evaluations
    raise Measured((method, settings.rtol, evaluations, quick / evaluations, trial / evaluations))


def calibrate(t_end: float, divergence: str, skip: list[str]) -> None:
    """The whole numpy run's wall time over the trial's estimate of its integration, on every course model."""
    import time

    found: list[float] = []

    def trial_only(equations, z0, settings, threshold=math.inf):
        f, s = equations.rhs, settings
        found.append(dispatch.trial_seconds(f, z0, s.t_end, s.integrator, s.rtol, s.atol, s.step))
        return 0.0  # the run stays on numpy

    dispatch.estimated_numpy_seconds = trial_only
    print(f"divergence = {divergence}, t_end = {t_end:g} s, 100 outputs\n")
    print("| model | rtol | trial's estimate (s) | whole run (s) | run / estimate |\n|---|---:|---:|---:|---:|")
    ratios = []
    for path in sorted(glob.glob(str(ROOT / "course/models/*.yaml"))):
        if Path(path).stem in skip:
            continue
        system, q0, qd0 = build_system(load_model(path))
        for rtol in (None, 1e-6):
            options = {} if rtol is None else {"rtol": rtol}
            found.clear()
            try:
                forward_dynamics(system, q0, qd0, t_end, 100, engine="auto", divergence=divergence, **options)
                start = time.perf_counter()
                forward_dynamics(system, q0, qd0, t_end, 100, engine="numpy", divergence=divergence, **options)
                whole = time.perf_counter() - start
            except Exception as err:  # noqa: BLE001 -- a model that fails at this rtol: said, and the next
                print(f"| {Path(path).stem} | {rtol or 'rule'} | {type(err).__name__} | | |")
                continue
            if found:
                ratios.append(whole / found[0])
                print(f"| {Path(path).stem} | {rtol or 'rule'} | {found[0]:.3g} | {whole:.3g} | {ratios[-1]:.2f} |")
    if ratios:
        print(f"\nrun / estimate: {min(ratios):.2f} to {max(ratios):.2f}, median {np.median(ratios):.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=1.0)
    parser.add_argument("--skip", nargs="*", default=[], help="model names left out (andrews: ~2 minutes)")
    parser.add_argument("--calibrate", action="store_true", help="the whole run over the trial's estimate")
    parser.add_argument("--divergence", default="check", help="with --calibrate: check or skip")
    args = parser.parse_args()
    if args.calibrate:
        calibrate(2.0 if args.t_end == 1.0 else args.t_end, args.divergence, args.skip or ["andrews"])
        return
    dispatch.estimated_numpy_seconds = measure
    print(
        f"TRIAL_STEPS = {dispatch.TRIAL_STEPS}, t_end = {args.t_end:g} s\n\n"
        "| model | rtol | method | run's evaluations | quick / run | trial / run |\n|---|---:|---|---:|---:|---:|"
    )
    quick_all, trial_all = [], []
    for path in sorted(glob.glob(str(ROOT / "course/models/*.yaml"))):
        if Path(path).stem in args.skip:
            continue
        system, q0, qd0 = build_system(load_model(path))
        for rtol in (None, 1e-6, 1e-9):
            options = {} if rtol is None else {"rtol": rtol}
            try:
                forward_dynamics(system, q0, qd0, args.t_end, 5, engine="auto", divergence="skip", **options)
            except Measured as measured:
                method, used, evaluations, quick, trial = measured.figures
            except Exception as err:  # noqa: BLE001 -- a model that fails at this rtol: said, and the next
                print(f"| {Path(path).stem} | {rtol or 'rule'} | {type(err).__name__} | | | |")
                continue
            else:
                continue  # the estimate was not asked for (a fixed-step run, an engine asked for by name)
            quick_all.append(quick)
            trial_all.append(trial)
            print(f"| {Path(path).stem} | {used:.0e} | {method} | {evaluations:g} | {quick:.3g} | {trial:.3g} |")
    for name, found in (("quick", quick_all), ("trial", trial_all)):
        found = np.array(found)
        found = found[np.isfinite(found)]
        if found.size:
            print(f"\n{name} / run: {found.min():.3g} to {found.max():.3g}, median {np.median(found):.3g}", end="")
    print()


if __name__ == "__main__":
    main()
