"""The open tree's compiled right-hand side in joint coordinates, part by part, beside its integration loop (issue 25).

The planar pendulum chain (revolute joints) and the spatial chain (spherical joints) of ``chains.py`` are open trees:
their compiled right-hand side (``compiled/tree.py``'s scene_rhs) makes the tree's recursion (``planar_motion`` /
``spatial_motion``: q, q', xi, each joint's columns S_e and link) and theta'' by the articulated-body algorithm
(``planar_articulated`` / ``spatial_articulated``, ``articulated.py``: a planar revolute or a spherical joint at its
joint point), no D and no constraint rows. Each part is timed
alone on the chain's starting state, its work arrays made once (scene_rhs makes them at every evaluation), thread CPU,
the least of ``--rounds`` rounds, microseconds per call, called from a compiled loop as the integration calls it,
beside the whole right-hand side with and without the outputs (q, q', q'', lambda of every row; with Psi, Psi_t and
Psi_q as ``loops.output_history`` asks; q alone, the divergence check's companion), and beside the
integration loop (``loops.embedded``, DOP853 at rtol = atol = 1e-6 over the chains' 1 s and 100 output intervals, as
``chains.py`` runs it) divided by its evaluations: what the loop costs per evaluation beyond the right-hand side is
DOP853's own stage arithmetic, error norm, step logic and dense output.

    .venv/bin/python benchmarks/tree_rhs.py --sizes 2 4 8 16

Nothing is asserted (timing depends on the machine): prints a Markdown table per family.
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
sys.path.insert(0, str(ROOT / "benchmarks"))

from chains import OUTPUTS, T_END, TOL, planar_chain, spatial_chain  # noqa: E402
from rhs_parts import per_call  # noqa: E402  (least thread CPU per call, in us)

from solutions.assembly import build_system  # noqa: E402
from solutions.dynamics import EquationsOfMotion, mass_matrix  # noqa: E402
from solutions.formulations import make_formulation  # noqa: E402
from solutions.generalized_forces import build_forces  # noqa: E402
from solutions.io import load_model  # noqa: E402

CHAINS = {"planar": planar_chain, "spatial": spatial_chain}


@functools.cache
def repeated():
    """Compiled loops that call each part ``calls`` times (a call from Python costs 0.3-1 us of unboxing P and D,
    more than the parts themselves: each part is timed as the integration loop calls it, from compiled code)."""
    from numba import njit

    from solutions.compiled import loops
    from solutions.compiled import tree_kernels as tk

    @njit(cache=False)
    def rhs(f, y, P, D, out, calls):
        for _ in range(calls):
            f(0.0, y, P, D, out)

    @njit(cache=False)
    def planar(theta, rate, joints, floats, nb, k, q, qd, xi, Dm, mass, Q0, thdd, body, joint, calls, which):
        for _ in range(calls):
            if which == 0:
                tk.planar_motion(theta, rate, joints, floats, nb, k, q, qd, xi, Dm, False, body, joint)
            else:
                tk.planar_articulated(mass, xi, Q0, joints, thdd, body, joint)

    @njit(cache=False)
    def spatial(theta, rate, joints, floats, nb, k, q, qd, xi, Dm, omega, rates, masses, inertias, Q0, thdd, body,
                joint, calls, which):  # fmt: skip
        for _ in range(calls):
            if which == 0:
                tk.spatial_motion(theta, rate, joints, floats, nb, k, q, qd, xi, Dm, omega, rates, False, body, joint)
            else:
                tk.spatial_articulated(masses, inertias, q, xi, omega, Q0, joints, thdd, body, joint)

    del loops
    return rhs, planar, spatial


def parts(family: str, n: int, rounds: int) -> dict[str, float | str]:
    """Microseconds per call of each part of the chain's right-hand side at N = n, and of its integration loop per
    evaluation."""
    from solutions.compiled import load, loops, parameters, plan, tableau
    from solutions.compiled.articulated import sizes
    from solutions.compiled.tree_kernels import PLANAR_MOTION_ROWS, SPATIAL_MOTION_ROWS

    system, q0, qd0 = build_system(load_model(CHAINS[family](n)))
    forces = build_forces(system.model)
    made = make_formulation("joint-coordinates", system, mass_matrix(system.model), forces)
    job = plan(system, made.masses, forces, "joint-coordinates", made)
    module, project, _ = load(job)
    tree, P, D = job.scene, parameters(job.scene, *job.numbers), job.scene.data()
    y = EquationsOfMotion(made, forces, False).initial_state(q0, qd0, 0.0)
    n_q, m, k, npos, joints, floats = tree.n, tree.m, tree.k, tree.n_positions, tree.ints, tree.floats
    nb, ne = n_q // (7 if family == "spatial" else 3), joints.shape[0]
    nv = 6 if family == "spatial" else 3
    calls = max(2000, 200000 // n)
    rhs_loop, planar_loop, spatial_loop = repeated()
    out, full = np.empty(y.size), np.empty(y.size + 3 * n_q + m)
    history, positions = np.empty(y.size + 3 * n_q + 3 * m + m * n_q), np.empty(y.size + n_q)  # output pass, companion
    q, qd, xi, Dm = np.empty(n_q), np.empty(n_q), np.empty(nv * nb), np.empty((nv * nb, k))
    omega, rates = np.empty((nb, 3)), np.empty(npos)
    thdd, (body_rows, joint_rows) = np.empty(k), sizes(nv)
    recursion = SPATIAL_MOTION_ROWS if family == "spatial" else PLANAR_MOTION_ROWS
    body = np.empty((nb + 1, body_rows + recursion, nv))  # the rows scene_rhs's have
    joint = np.empty((ne + 1, joint_rows, nv))
    Q0, mass, masses, inertias = P[0], P[1], P[2], P[3]
    theta, rate = y[:npos], y[npos : npos + k]
    if family == "planar":
        arguments = (theta, rate, joints, floats, nb, k, q, qd, xi, Dm, mass, Q0, thdd, body, joint, calls)
        part = lambda which: planar_loop(*arguments, which)  # noqa: E731
    else:
        arguments = (theta, rate, joints, floats, nb, k, q, qd, xi, Dm, omega, rates, masses, inertias, Q0, thdd, body)
        part = lambda which: spatial_loop(*arguments, joint, calls, which)  # noqa: E731
    rhs = loops.first_class(module.scene_rhs, loops.RHS_SIGNATURE)
    project = loops.first_class(project, loops.PROJECT_SIGNATURE)
    times = np.linspace(0.0, T_END, OUTPUTS + 1)
    budget = np.iinfo(np.int64).max

    def integrate():
        return loops.embedded(
            rhs, project, y, times, TOL, TOL, np.inf, budget, True, False, tableau(True), P, D, T_END, 0.0, 10**9
        )

    evaluations = integrate()[1]
    best = np.inf
    for _ in range(rounds):
        start = time.thread_time()
        for _ in range(3):
            integrate()
        best = min(best, (time.thread_time() - start) / 3)
    rhs_alone = per_call(lambda: rhs_loop(rhs, y, P, D, out, calls), 1, rounds) / calls
    loop = best / evaluations * 1e6
    return {
        "k, evaluations of the 1 s run": f"{k}, {evaluations}",
        "right-hand side (the integration's)": rhs_alone,
        "right-hand side with the outputs": per_call(lambda: rhs_loop(rhs, y, P, D, full, calls), 1, rounds) / calls,
        "with the outputs and Psi, Psi_t, Psi_q (loops.output_history's)": per_call(
            lambda: rhs_loop(rhs, y, P, D, history, calls), 1, rounds
        )
        / calls,
        "the positions alone (the companion run's, dispatch.positions)": per_call(
            lambda: rhs_loop(rhs, y, P, D, positions, calls), 1, rounds
        )
        / calls,
        "right-hand side called from Python": per_call(lambda: module.scene_rhs(0.0, y, P, D, out), calls, rounds),
        "tree recursion (q, q', xi, S_e, links)": per_call(lambda: part(0), 1, rounds) / calls,
        "articulated-body algorithm (theta'')": per_call(lambda: part(1), 1, rounds) / calls,
        "integration loop per evaluation (DOP853, 1e-6)": loop,
        "of which the loop's own (loop - rhs)": loop - rhs_alone,
        "integration loop, whole (ms)": best * 1e3,
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[2, 4, 8, 16], help="chain sizes N")
    parser.add_argument("--families", nargs="+", default=list(CHAINS), choices=list(CHAINS))
    parser.add_argument("--rounds", type=int, default=5, help="rounds; the least is kept (default 5)")
    args = parser.parse_args(argv)
    for family in args.families:
        columns = {n: parts(family, n, args.rounds) for n in args.sizes}
        print(f"\n## The {family} chain's right-hand side by part, us per call (thread CPU, least of rounds)\n")
        print("| part | " + " | ".join(f"N = {n}" for n in args.sizes) + " |")
        print("|---|" + "---:|" * len(args.sizes))
        for name in columns[args.sizes[0]]:
            cells = [columns[n][name] for n in args.sizes]
            print(f"| {name} | " + " | ".join(c if isinstance(c, str) else f"{c:.2f}" for c in cells) + " |")


if __name__ == "__main__":
    main()
