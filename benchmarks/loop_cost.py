"""What the compiled integration loops cost per evaluation beyond the right-hand side (issue 25, session 22).

``tree_rhs.py``'s row "of which the loop's own" subtracts the right-hand side timed alone at the starting state from
the loop's time per evaluation: the right-hand side costs more at the run's states and inside the loop (its code and
the loop's share the caches) than in a tight loop at one state, so that row counts some of the right-hand side as the
loop's (up to 0.2 us on the spatial chain). Here the right-hand side is nearly free: n/2 damped oscillators,
q_i'' = -400 (1 + i) q_i - c_i q_i' (a few ns an evaluation), handed to ``loops.embedded`` and ``loops.rk4`` as a
scene's is (a first-class function with the loops' signature), so the time per evaluation is the loop's own: stage
sums, error norm, step-size control, dense output at 100 output times over 1 s, the call from Python included
(~10 us a call). DOP853 and RK45 at rtol = atol = 1e-6 (this package's own step rule), RK4 at a step of 1e-3.

    .venv/bin/python benchmarks/loop_cost.py --sizes 4 14 48

Nothing is asserted (timing depends on the machine): prints a Markdown table of us per evaluation (thread CPU, the
least of ``--rounds`` rounds of 20 calls) with each run's evaluations.
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import functools  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from solutions.compiled import loops, tableau  # noqa: E402

TIMES = np.linspace(0.0, 1.0, 101)
TOL, STEP, CALLS = 1e-6, 1e-3, 20


def oscillators():
    """The oscillators' right-hand side with the loops' signature (damping c in P[7]) and the loops' no-projection."""
    from numba import njit

    @njit(loops.RHS_SIGNATURE, cache=False)
    def rhs(t, z, P, D, out):
        n, c = z.size // 2, P[7]
        for i in range(n):
            out[i] = z[n + i]
            out[n + i] = -400.0 * (1.0 + i) * z[i] - c[i] * z[n + i]

    return loops.first_class(rhs, loops.RHS_SIGNATURE), loops.first_class(loops.no_projection, loops.PROJECT_SIGNATURE)


def packed(n: int) -> tuple[tuple, tuple]:
    """P and D of the loops' types, holding only the damping the right-hand side reads."""
    e1, e2 = np.zeros(1), np.zeros((1, 1))
    c = np.linspace(0.1, 0.5, n)
    P = (e1, e1, e1, np.zeros((1, 1, 1)), e1, np.zeros(1, np.int64), e2, c, np.zeros(1, np.int64))
    return P, (np.zeros((1, 1), np.int64), e2, np.zeros(1, np.int64))


def per_evaluation(run, rounds: int) -> tuple[float, int]:
    """us per evaluation of ``run`` (the least of rounds of CALLS calls, thread CPU) and its evaluations."""
    evaluations = run()[1]
    best = np.inf
    for _ in range(rounds):
        start = time.thread_time()
        for _ in range(CALLS):
            run()
        best = min(best, (time.thread_time() - start) / CALLS)
    return best / evaluations * 1e6, evaluations


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[4, 14, 48], help="state sizes (even)")
    parser.add_argument("--rounds", type=int, default=7, help="rounds; the least is kept (default 7)")
    args = parser.parse_args(argv)
    rhs, project = oscillators()
    rows = {}
    for size in args.sizes:
        y0 = np.linspace(0.1, 1.0, size)
        P, D = packed(size // 2)
        for name, dop in (("DOP853", True), ("RK45", False)):
            arguments = (rhs, project, y0, TIMES, TOL, TOL, np.inf, 10**12, dop, False, tableau(dop), P, D, 1.0)
            run = functools.partial(loops.embedded, *arguments, 0.0, 10**9)
            rows.setdefault(name, []).append(per_evaluation(run, args.rounds))
        run = functools.partial(loops.rk4, rhs, project, y0, TIMES, STEP, P, D)
        rows.setdefault("RK4", []).append(per_evaluation(run, args.rounds))
    print("## The loops' own cost, us per evaluation (a nearly free right-hand side; evaluations in brackets)\n")
    print("| loop | " + " | ".join(f"n = {n}" for n in args.sizes) + " |")
    print("|---|" + "---:|" * len(args.sizes))
    for name, cells in rows.items():
        print(f"| {name} | " + " | ".join(f"{us:.3f} ({evaluations})" for us, evaluations in cells) + " |")


if __name__ == "__main__":
    main()
