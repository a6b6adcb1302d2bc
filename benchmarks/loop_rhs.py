"""The loop chain's compiled right-hand side in joint coordinates, part by part (issue 25, item 1).

The chain of N parallelogram four-bars (``chains.loop_chain``: 2N + 1 bodies, N loops, one degree of freedom) in
joint coordinates is a shallow tree (the cranks from ground, each coupler on its crank) with 2N cut rows (the joints
from each coupler to the next crank). One right-hand side makes, in this order (``compiled/tree.py``'s scene_rhs):
the tree's recursion with the columns of D (``planar_motion``), the constraint rows (every kernel, into an m x n
Psi_q), the embedded equations D^T M D and D^T (Q - M xi) (``planar_equations``), and the cut rows' solve
(``cut_accelerations``: the Schur complement on the tree's factorization, notes eq. 7.11-7.12). Each part is timed
alone on the chain's starting state (thread CPU, the least of ``--rounds`` rounds, microseconds per call), beside
the whole right-hand side, with and without the outputs (q, q', q'', lambda of every row), and beside the dense
augmented LU of eq. 7.6 that the engine solved before (1f2d7c9: assembled (k + m_c)^2, LAPACK's gesv).

    .venv/bin/python benchmarks/loop_rhs.py --sizes 4 16 64
    .venv/bin/python benchmarks/loop_rhs.py --model course/models/slider_crank.yaml   # any model's whole rhs

Nothing is asserted (timing depends on the machine): prints a Markdown table.
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from chains import loop_chain  # noqa: E402
from rhs_parts import per_call  # noqa: E402  (least thread CPU per call, in us)

from solutions.assembly import build_system  # noqa: E402
from solutions.compiled.kernels import lu_solve  # noqa: E402  (imports numba)
from solutions.dynamics import EquationsOfMotion, mass_matrix  # noqa: E402
from solutions.formulations import make_formulation  # noqa: E402
from solutions.generalized_forces import build_forces  # noqa: E402
from solutions.io import load_model  # noqa: E402


def dense_augmented(matrix, rhs, Dq, xiq, jac, psi, psit, gam, qd, rows, alpha, beta, mu):
    """The solve of eq. 7.6 before this session (1f2d7c9): Psi_theta = Psi_c,q D by BLAS, the augmented matrix
    assembled whole and solved by LU (``kernels.lu_solve``: LAPACK's gesv above 32 unknowns)."""
    k, mc = rhs.size, rows.size
    cut = np.empty((mc, jac.shape[1]))
    for a in range(mc):
        cut[a] = jac[rows[a]]
    K = np.zeros((k + mc, k + mc))
    b = np.empty(k + mc)
    for i in range(k):
        b[i] = rhs[i]
        for j in range(i + 1):
            K[i, j] = K[j, i] = matrix[i, j]
    theta = cut @ Dq
    K[k:, :k] = theta
    K[:k, k:] = theta.T
    psi_dot, convective = cut @ qd, cut @ xiq
    for a in range(mc):
        r = rows[a]
        b[k + a] = gam[r] - 2.0 * alpha * (psit[r] + psi_dot[a]) - beta * beta * psi[r] - convective[a]
    x = lu_solve(K, b)
    mu[:] = x[k:]
    return x[:k]


def _scene(model):
    """(module, tree scene, P, D, joint state at the start) of a model in compiled joint coordinates; the energy
    states appended where the run integrates them (a driven model: its drivers' power)."""
    from solutions.compiled import load, parameters, plan

    system, q0, qd0 = build_system(load_model(model))
    forces = build_forces(system.model)
    made = make_formulation("joint-coordinates", system, mass_matrix(system.model), forces)
    job = plan(system, made.masses, forces, "joint-coordinates", made)
    module, _, _ = load(job)
    P, D = parameters(job.scene, *job.numbers), job.scene.data()
    y = EquationsOfMotion(made, forces, bool(job.scene.scene.drivers)).initial_state(q0, qd0, 0.0)
    return module, job.scene, P, D, y


def in_loop(rhs, y, P, D, out, calls: int, rounds: int) -> float:
    """Microseconds per call of rhs(0, y, P, D, out) called from a compiled loop, as the integration loops call it
    (from Python each call also pays numba's unboxing of P and D, ~1 us)."""
    from numba import njit

    @njit
    def repeat(y, P, D, out, count):
        for _ in range(count):
            rhs(0.0, y, P, D, out)

    inner = 100
    return per_call(lambda: repeat(y, P, D, out, inner), max(1, calls // inner), rounds) / inner


def whole(model, rounds: int) -> dict[str, float]:
    """Microseconds per call of a model's whole right-hand side, without and with the outputs (``--model``)."""
    module, tree, P, D, y = _scene(model)
    out, full = np.empty(y.size), np.empty(y.size + 3 * tree.n + tree.m)
    return {
        "k, cut rows": f"{tree.k}, {tree.cut_rows.size}",
        "right-hand side, from a compiled loop": in_loop(module.scene_rhs, y, P, D, out, 20000, rounds),
        "right-hand side with the outputs, from a compiled loop": in_loop(
            module.scene_rhs, y, P, D, full, 20000, rounds
        ),
        "right-hand side, from Python": per_call(lambda: module.scene_rhs(0.0, y, P, D, out), 2000, rounds),
    }


def parts(n: int, rounds: int) -> dict[str, float]:
    """Microseconds per call of each part of the loop chain's right-hand side at N = n."""
    from numba import njit

    from solutions.compiled.articulated import sizes
    from solutions.compiled.tree_kernels import cut_accelerations, planar_equations, planar_motion

    module, tree, P, D, y = _scene(loop_chain(n))
    n_q, m, k, joints = tree.n, tree.m, tree.k, tree.ints
    calls = max(20, 20000 // (n * n))
    out, full = np.empty(y.size), np.empty(y.size + 3 * n_q + m)
    q, qd, xi, Dm = np.empty(n_q), np.empty(n_q), np.empty(n_q), np.zeros((n_q, k))
    (body_rows, joint_rows), nb = sizes(3), n_q // 3
    body, joint = np.empty((nb + 1, body_rows + 3, 3)), np.empty((joints.shape[0] + 1, joint_rows, 3))  # as scene_rhs's

    def motion():  # as the integration's right-hand side: the columns that move each body
        planar_motion(y[:k], y[k : 2 * k], joints, tree.floats, nb, k, q, qd, xi, Dm, True, body, joint)

    motion()  # D once, its zeros left (Dm made by np.zeros: the dense solve below reads them)
    times, states = np.zeros(1), np.ascontiguousarray(np.hstack([q, qd])[None, :])

    from solutions.compiled import codegen

    evaluate = codegen.load(tree.scene)[0].constraint_arrays  # the scene's module: a tree's has no second pass

    def constraints():
        arrays = np.zeros((1, m)), np.zeros((1, m, n_q)), np.zeros((1, m))
        evaluate(times, states, P, D, *arrays)
        return arrays

    psi, jac, psit = (a[0] for a in constraints())
    matrix, rhs = planar_equations(P[1], Dm, xi, P[0].copy(), joints)
    rows, mu, dense = tree.cut_rows, np.empty(tree.cut_rows.size), njit(dense_augmented)
    gam = np.zeros(m)
    cut = (rows, tree.cut_bodies, 5.0, 5.0, mu, joints, 3, tree.structure())  # its sparsity made once per scene
    return {
        "k, cut rows": f"{k}, {rows.size}",
        "right-hand side (the integration's)": per_call(lambda: module.scene_rhs(0.0, y, P, D, out), calls, rounds),
        "right-hand side, from a compiled loop": in_loop(module.scene_rhs, y, P, D, out, 100 * calls, rounds),
        "right-hand side with the outputs": per_call(lambda: module.scene_rhs(0.0, y, P, D, full), calls, rounds),
        "tree recursion with D's columns": per_call(motion, calls, rounds),
        "constraint rows, all kernels, m x n Psi_q zeroed": per_call(constraints, calls, rounds),
        "D^T M D and D^T (Q - M xi)": per_call(lambda: planar_equations(P[1], Dm, xi, P[0], joints), calls, rounds),
        "cut solve: Schur complement on the tree's factorization": per_call(
            lambda: cut_accelerations(matrix.copy(), rhs, Dm, xi, jac, psi, psit, gam, qd, *cut), calls, rounds
        ),
        "cut solve: dense augmented LU (1f2d7c9)": per_call(
            lambda: dense(matrix.copy(), rhs, Dm, xi, jac, psi, psit, gam, qd, rows, 5.0, 5.0, mu), calls, rounds
        ),
    }


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[4, 16, 64], help="chain sizes N")
    parser.add_argument("--rounds", type=int, default=3, help="rounds; the least is kept (default 3)")
    parser.add_argument("--model", action="append", help="a model file instead (repeatable): its whole rhs alone")
    args = parser.parse_args(argv)
    if args.model:
        columns = {Path(path).stem: whole(path, args.rounds) for path in args.model}
        print("## Compiled joint-coordinate right-hand side, us per call (thread CPU, least of rounds)\n")
    else:
        columns = {f"N = {n}": parts(n, args.rounds) for n in args.sizes}
        print("## The loop chain's right-hand side by part, us per call (thread CPU, least of rounds)\n")
    print("| part | " + " | ".join(columns) + " |")
    print("|---|" + "---:|" * len(columns))
    for name in next(iter(columns.values())):
        cells = [column[name] for column in columns.values()]
        print(f"| {name} | " + " | ".join(c if isinstance(c, str) else f"{c:.1f}" for c in cells) + " |")


if __name__ == "__main__":
    main()
