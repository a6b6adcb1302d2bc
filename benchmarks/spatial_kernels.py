"""The compiled spatial mass kernel standalone: b0a1bd7's BLAS form against the loops of ``kernels.spatial_mass``.

numba's ``@`` and ``np.outer`` on 3 x 4 arrays are BLAS calls and allocations (150-300 ns each), dearer than the
arithmetic they do. ``kernels.spatial_mass`` (eq. 10.4-10.5) now writes every product out; ``blas_spatial_mass``
below is the form it replaced (issue 25, item 1), kept here to time the two in the same process, paired, and to
check that they agree to rounding. Thread CPU time per call (``time.thread_time``), the best of ``--rounds``.

    MBD_COMPILED_CACHE=build/bench-cache .venv/bin/python benchmarks/spatial_kernels.py --bodies 1 2 8
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from solutions.compiled import kernels  # noqa: E402


@kernels.jit
def blas_spatial_mass(q, qd, masses, inertias, weights, M, Q):
    """``kernels.spatial_mass`` as b0a1bd7 wrote it: seven matrix products and an outer product per body."""
    L, Ld = np.empty((3, 4)), np.empty((3, 4))
    for b in range(masses.size):
        o = 7 * b
        e0, e1, e2, e3 = q[o + 3], q[o + 4], q[o + 5], q[o + 6]
        kernels._l_matrix(e0, e1, e2, e3, L)
        kernels._l_matrix(qd[o + 3], qd[o + 4], qd[o + 5], qd[o + 6], Ld)
        J = inertias[b]
        for k in range(3):
            M[o + k, o + k] = masses[b]
        JL = J @ L
        Mp = 4.0 * (L.T @ JL)
        p = np.array([e0, e1, e2, e3])
        Mp += 4.0 * weights[b] * np.outer(p, p)
        M[o + 3 : o + 7, o + 3 : o + 7] = Mp
        Q[o + 3 : o + 7] += 8.0 * (Ld.T @ (J @ (Ld @ p)))


@kernels.jit
def _repeat(kernel, calls, q, qd, masses, inertias, weights, M, Q):
    for _ in range(calls):
        kernel(q, qd, masses, inertias, weights, M, Q)


def state(nb: int, seed: int = 0):
    """A random state of nb bodies (unit p, any p'), their masses, inertias (symmetric positive) and weights."""
    rng = np.random.default_rng(seed)
    q, qd = rng.normal(size=7 * nb), rng.normal(size=7 * nb)
    for b in range(nb):
        q[7 * b + 3 : 7 * b + 7] /= np.linalg.norm(q[7 * b + 3 : 7 * b + 7])
    A = rng.normal(size=(nb, 3, 3))
    inertias = A @ A.transpose(0, 2, 1) + np.eye(3)
    return q, qd, rng.uniform(1, 2, nb), inertias, rng.uniform(0.5, 1.5, nb)


def per_call(kernel, nb: int, calls: int, rounds: int) -> tuple[float, np.ndarray, np.ndarray]:
    """The best thread-CPU microseconds per call over ``rounds``, and M and Q of one call."""
    q, qd, masses, inertias, weights = state(nb)
    M, Q = np.zeros((7 * nb, 7 * nb)), np.zeros(7 * nb)
    kernel(q, qd, masses, inertias, weights, M, Q)
    once = (M.copy(), Q.copy())
    _repeat(kernel, 1, q, qd, masses, inertias, weights, M, Q)
    best = np.inf
    for _ in range(rounds):
        start = time.thread_time()
        _repeat(kernel, calls, q, qd, masses, inertias, weights, M, Q)
        best = min(best, (time.thread_time() - start) / calls * 1e6)
    return best, *once


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bodies", type=int, nargs="+", default=[1, 2, 8])
    parser.add_argument("--calls", type=int, default=100_000)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args(argv)
    print("| bodies | BLAS (b0a1bd7) us | loops us | ratio | largest difference (relative) |")
    print("|---:|---:|---:|---:|---:|")
    for nb in args.bodies:
        (before, M0, Q0), (after, M1, Q1) = (
            per_call(kernel, nb, args.calls, args.rounds) for kernel in (blas_spatial_mass, kernels.spatial_mass)
        )
        gap = max(abs(M1 - M0).max() / abs(M0).max(), abs(Q1 - Q0).max() / abs(Q0).max())
        print(f"| {nb} | {before:.3f} | {after:.3f} | {before / after:.1f} | {gap:.1e} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
