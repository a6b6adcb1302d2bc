"""Issue 29 study: the augmented Lagrangian's iterations (eq. 5.52) -- how many, how long, how accurate.

    PYTHONPATH=. OPENBLAS_NUM_THREADS=1 python benchmarks/augmented.py            # every case but Radau, ~1 min
    PYTHONPATH=. OPENBLAS_NUM_THREADS=1 python benchmarks/augmented.py --radau    # adds Sarrus by Radau over 1 s

Per case: right-hand-side evaluations, the iterations of eq. 5.52 (all of them, and the evaluations that ended at
``max_iterations``), wall time, and the error against an independent reference: the Sarrus linkage's plate height
and the Bennett linkage's link centres against their one-dof equations (``tests/solutions/mechanisms.py``, scipy
DOP853 at rtol 1e-12), the parallelogram chain's crank angles likewise, the spatial hexagon against the planar
hexagon by baumgarte at rtol 1e-12, the double pendulum against baumgarte at rtol 1e-12. Energy: the run's own
balance (``energy_drift_relative``). The table is in benchmarks/results/stress.md ("augmented Lagrangian").

The iterations are the run's ``info['augmented_iterations']``; for a tree that predates that count (a worktree of
an older commit, run with PYTHONPATH pointing at it, gives the 'before' rows) they are counted by wrapping
``AugmentedLagrangian.accelerations``: each call solved with the factor 1 + (iterations) + 1 times (the first
penalty solution, one per iteration, the multipliers' least-squares correction). Per evaluation: per call of
``accelerations`` (a few more than the integrator's evaluations: the start, the outputs).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests" / "solutions"))

from mechanisms import (  # noqa: E402
    SARRUS,
    bennett,
    bennett_centres,
    bennett_theta,
    chain_theta,
    parallelogram_chain,
    sarrus,
    sarrus_theta,
)

from solutions import formulations  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.dynamics import forward_dynamics  # noqa: E402
from solutions.io.model import load_model  # noqa: E402

COUNT = {"calls": 0, "solves": 0, "empty": 0}


def _counting() -> None:
    """Count the factor's solves inside ``AugmentedLagrangian.accelerations`` (see the module's docstring)."""
    accelerations, cho_solve = formulations.AugmentedLagrangian.accelerations, scipy.linalg.cho_solve
    inside = [False]

    def counted_solve(*args, **kwargs):
        if inside[0]:
            COUNT["solves"] += 1
        return cho_solve(*args, **kwargs)

    def counted(self, q, qd, t):
        COUNT["calls"] += 1
        inside[0] = True
        try:
            return accelerations(self, q, qd, t)
        finally:
            inside[0] = False

    scipy.linalg.cho_solve = counted_solve
    formulations.AugmentedLagrangian.accelerations = counted


def iterations(info: dict) -> int:
    """Iterations of eq. 5.52 of the run: its own count (``info['augmented_iterations']``) where the tree has one,
    else the solves less the first and the correction, per call (a tree from before the count)."""
    if "augmented_iterations" in info:
        return info["augmented_iterations"]
    return COUNT["solves"] - 2 * COUNT["calls"]


def sarrus_case(integrator: str, t_end: float):
    system, q0, qd0 = build_system(load_model(sarrus()))
    result = forward_dynamics(system, q0, qd0, t_end, int(round(50 * t_end)), integrator=integrator, engine="numpy")
    z = result.q[:, system.coordinate_names.index("top.z")]
    return result, float(np.max(np.abs(z - 2 * SARRUS["L"] * np.cos(sarrus_theta(result.t))))), "m"


def bennett_case():
    system, q0, qd0 = build_system(load_model(bennett()))
    result = forward_dynamics(system, q0, qd0, 1.0, 50, engine="numpy")
    names = system.coordinate_names
    columns = [[names.index(f"link{i}.{axis}") for axis in "xyz"] for i in (1, 2, 3)]
    expected = np.array([bennett_centres(th) for th in bennett_theta(result.t)])
    got = np.stack([result.q[:, c] for c in columns], axis=1)
    return result, float(np.max(np.abs(got - expected))), "m"


def chain_case(n: int):
    system, q0, qd0 = build_system(load_model(parallelogram_chain(n)))
    result = forward_dynamics(system, q0, qd0, 3.0, 150, formulation="augmented-lagrangian", engine="numpy")
    theta = chain_theta(n, result.t)
    names = system.coordinate_names
    error = max(float(np.max(np.abs(result.q[:, names.index(f"crank{k}.phi")] - theta))) for k in range(n + 1))
    return result, error, "rad"


def hexagon_case():
    from tests.solutions.test_accuracy import centres, hexagon

    planar, spatial = (build_system(load_model(hexagon(d))) for d in (2, 3))
    reference = forward_dynamics(*planar, 0.5, 25, "baumgarte", "DOP853", rtol=1e-12, atol=1e-14, engine="numpy")
    COUNT.update(calls=0, solves=0)
    result = forward_dynamics(*spatial, 0.5, 25, engine="numpy")
    error = float(np.max(np.abs(centres(spatial[0], result.q)[:, :, :2] - centres(planar[0], reference.q)[:, :, :2])))
    return result, error, "m"


def double_pendulum_case():
    path = REPO / "course" / "models" / "double_pendulum.yaml"
    system, q0, qd0 = build_system(load_model(path))
    reference = forward_dynamics(system, q0, qd0, 2.0, 100, "baumgarte", "DOP853", rtol=1e-12, atol=1e-14)
    COUNT.update(calls=0, solves=0)
    result = forward_dynamics(system, q0, qd0, 2.0, 100, "augmented-lagrangian", "DOP853", engine="numpy")
    return result, float(np.max(np.abs(result.q - reference.q))), "m or rad"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radau", action="store_true", help="add the Sarrus linkage by Radau over 1 s (minutes)")
    parser.add_argument("--only", help="run only the cases whose name contains this")
    args = parser.parse_args()
    _counting()
    cases = {
        "Sarrus 1 s, auto (dop853)": lambda: sarrus_case("auto", 1.0),
        "Sarrus 0.3 s, Radau": lambda: sarrus_case("Radau", 0.3),
        "Sarrus 0.5 s, Radau (one singular position)": lambda: sarrus_case("Radau", 0.5),
        "Bennett 1 s, auto": bennett_case,
        "hexagon 0.5 s, auto": hexagon_case,
        "chain N=1, 3 s": lambda: chain_case(1),
        "chain N=2, 3 s": lambda: chain_case(2),
        "chain N=10, 3 s": lambda: chain_case(10),
        "double pendulum 2 s, DOP853": double_pendulum_case,
    }
    if args.radau:
        cases["Sarrus 1 s, Radau"] = lambda: sarrus_case("Radau", 1.0)
    print("| case | evaluations | iterations (per evaluation) | unconverged | wall s | error | energy | warns |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, case in cases.items():
        if args.only and args.only not in name:
            continue
        COUNT.update(calls=0, solves=0)
        start = time.perf_counter()
        result, error, unit = case()
        wall = time.perf_counter() - start
        info, calls = result.info, max(COUNT["calls"], 1)
        print(
            f"| {name} | {info['rhs_evaluations']} | {iterations(info)} ({iterations(info) / calls:.2f}) | "
            f"{info.get('unconverged_iterations', '-')} | {wall:.1f} | {error:.2g} {unit} | "
            f"{info['energy_drift_relative']:.2g} | {'yes' if info['warnings'] else 'no'} |",
            flush=True,
        )
        if info["warnings"]:
            print("  warnings:", "; ".join(w[:160] for w in info["warnings"]), flush=True)


if __name__ == "__main__":
    main()
