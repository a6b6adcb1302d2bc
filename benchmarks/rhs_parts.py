"""Per-evaluation cost of each part of the right-hand side: the numpy engine against the textbook code (issue 25).

For one bench scene (``--scene``, default the free slider-crank), at one state of its run, this thread's CPU time per
call (the least of ``--repeats`` rounds of ``--calls`` calls, ``time.thread_time``) of

- the engine (``forward_dynamics(..., "baumgarte", engine="numpy")``'s formulation): the shared pass over the rotated
  body vectors (``System._configuration``), Psi, Psi_q, gamma (``System._constraints``, ``_jacobian``, ``_gamma``),
  the whole ``System.evaluate``, the stabilized gamma (Psi' = Psi_q q', eq. 5.29), the augmented solve (eq. 5.30,
  ``augmented_accelerations``: one LAPACK gesv), the whole right-hand side (``Formulation.rhs``);
- the textbook code of ``benchmarks/textbook.py``: its ``constraints``, ``jacobian``, ``gamma``, the block matrix
  and ``numpy.linalg.solve``, the whole right-hand side.

    .venv/bin/python benchmarks/rhs_parts.py [--scene slider_crank]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def per_call(f, calls: int, repeats: int) -> float:
    """Microseconds of this thread's CPU per call of f(): the least of ``repeats`` rounds."""
    f()
    best = np.inf
    for _ in range(repeats):
        start = time.thread_time()
        for _ in range(calls):
            f()
        best = min(best, time.thread_time() - start)
    return best / calls * 1e6


def engine_parts(scene, calls: int, repeats: int) -> list[tuple[str, float]]:
    from solutions.assembly import build_system
    from solutions.formulations import augmented_accelerations, make_formulation
    from solutions.generalized_forces import build_forces
    from solutions.mass_matrix import mass_matrix

    model = scene.load()
    system, q0, qd0 = build_system(model)
    formulation = make_formulation("baumgarte", system, mass_matrix(model), build_forces(model), alpha=5.0, beta=5.0)
    rng = np.random.default_rng(1)
    q, qd, t = q0 + 1e-3 * rng.standard_normal(q0.size), qd0 + 1e-3 * rng.standard_normal(q0.size), 0.1
    y = np.concatenate([q, qd])

    def fresh(f):  # the System keeps its last configuration: every call here is at a new state, as in a run
        def call():
            system._last = None
            return f()

        return call

    state = system._configuration(q)
    jacobian, gamma = formulation.constraint_terms(q, qd, t)
    M, Q = formulation.mass(q), formulation.applied_forces(q, qd, t)
    return [
        ("shared pass (X, rotated vectors, terms)", per_call(fresh(lambda: system._configuration(q)), calls, repeats)),
        ("Psi", per_call(lambda: system._constraints(q, t, state), calls, repeats)),
        ("Psi_q", per_call(lambda: system._jacobian(q, t, state), calls, repeats)),
        ("gamma", per_call(lambda: system._gamma(q, qd, t, state), calls, repeats)),
        (
            "System.evaluate (all four)",
            per_call(fresh(lambda: system.evaluate(q, qd, t, True, system.rheonomic)), calls, repeats),
        ),
        (
            "stabilized gamma (evaluate + eq. 5.29)",
            per_call(fresh(lambda: formulation.constraint_terms(q, qd, t)), calls, repeats),
        ),
        (
            "augmented solve (eq. 5.30)",
            per_call(lambda: augmented_accelerations(M, jacobian, Q, gamma), calls, repeats),
        ),
        ("right-hand side", per_call(fresh(lambda: formulation.rhs(t, y)), calls, repeats)),
    ]


def textbook_parts(key: str, calls: int, repeats: int) -> list[tuple[str, float]]:
    import textbook as book

    rhs, y0, *_ = book.TEXTBOOK[key]
    out = [("right-hand side", per_call(lambda: rhs(0.1, y0), calls, repeats))]
    if key == "slider_crank":
        q, qd = y0[:9], y0[9:]
        J = book.jacobian(q)
        M = np.diag(book.MASSES)
        out = [
            ("Psi", per_call(lambda: book.constraints(q), calls, repeats)),
            ("Psi_q", per_call(lambda: book.jacobian(q), calls, repeats)),
            ("gamma", per_call(lambda: book.gamma(q, qd), calls, repeats)),
            (
                "block matrix + numpy.linalg.solve",
                per_call(
                    lambda: np.linalg.solve(np.block([[M, J.T], [J, np.zeros((8, 8))]]), np.zeros(17)), calls, repeats
                ),
            ),
            *out,
        ]
    return out


def main() -> int:
    import bench

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--scene", default="slider_crank", choices=("double_pendulum", "slider_crank", "spatial_double_pendulum")
    )
    parser.add_argument("--calls", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    scene = next(s for s in bench.scenes() if s.key == args.scene)
    print(f"{args.scene}: microseconds of thread CPU per call (least of {args.repeats} rounds of {args.calls})")
    for who, parts in (
        ("engine", engine_parts(scene, args.calls, args.repeats)),
        ("textbook", textbook_parts(args.scene, args.calls, args.repeats)),
    ):
        for name, us in parts:
            print(f"| {who} | {name} | {us:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
