"""The cut constraints' solve of the compiled joint coordinates (``tree_kernels.cut_accelerations``).

A tree with cut joints or drivers gets theta'' and the cut rows' multipliers from the augmented system of eq. 7.6.
The compiled engine solves it by the Schur complement of the cut rows on the tree's factorization H = L^T D L
(Featherstone's LTDL), a band solve where the complement is a band; the numpy reference engine
(``JointCoordinates.joint_accelerations``) assembles the whole augmented matrix and solves it densely by LAPACK.
Both are compared at random joint states (off the constraint manifold, so every term of the right side counts) on:
the chain of parallelogram loops (a shallow tree: cranks from ground, couplers on them; the complement a band of
half-width 3), a hanging serial chain held by distance drivers from ground to every bar (a deep tree: the
complement is full and goes to the dense branch), and a spatial loop (a cut spherical joint: Euler parameters'
rows of dq/dtheta; its compiled module is test_compiled_formulations'). A driven tree's energy balance (the
drivers' power from the cut rows' multipliers alone) against the numpy engine's lambda^T Psi_t of every row.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("numba")

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mechanisms import parallelogram_chain  # noqa: E402
from test_compiled_articulated import _random_state, _random_tree, compiled_sides, output_pass  # noqa: E402
from test_compiled_formulations import _spatial_loop  # noqa: E402

from solutions.assembly import build_system  # noqa: E402
from solutions.compiled import describe, load, parameters, plan  # noqa: E402
from solutions.dynamics import EquationsOfMotion, mass_matrix  # noqa: E402
from solutions.formulations import make_formulation  # noqa: E402
from solutions.generalized_forces import build_forces  # noqa: E402
from solutions.io import load_model  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def _held_chain(n: int) -> dict:
    """n bars hanging in a row from a pin at the origin, bars 1 .. n-1 each held by a distance driver from a ground
    point beside the chain: one degree of freedom, n - 1 cut rows meeting every column above their bar."""
    bodies, joints, drivers = [], [], []
    for i in range(n):
        angle = -1.2 + 0.15 * i
        start = np.sum([[np.cos(-1.2 + 0.15 * j), np.sin(-1.2 + 0.15 * j)] for j in range(i)], axis=0) if i else [0, 0]
        start = np.asarray(start, dtype=float)
        direction = np.array([np.cos(angle), np.sin(angle)])
        bodies.append({"name": f"b{i}", "mass": 1.0 + 0.1 * i, "inertia": 0.08, "orientation": angle,
                       "location": (start + 0.5 * direction).tolist()})  # fmt: skip
        joints.append({"name": f"j{i}", "type": "revolute", "body1": "ground" if i == 0 else f"b{i - 1}",
                       "body2": f"b{i}", "location": start.tolist()})  # fmt: skip
        if i:
            anchor, tip = np.array([2.0 + 0.3 * i, 1.0 - 0.2 * i]), start + direction
            drivers.append({"name": f"d{i}", "type": "distance", "body1": "ground", "body2": f"b{i}",
                            "point1": anchor.tolist(), "point2": tip.tolist(),
                            "function": float(np.linalg.norm(tip - anchor))})  # fmt: skip
    return {"model": {"name": f"held-chain-{n}", "dimension": 2, "gravity": [0.0, -9.81], "bodies": bodies,
                      "joints": joints, "motors": drivers}}  # fmt: skip


def _both_sides(model):
    """(numpy equations of motion, the compiled scene_rhs with its P and D, the tree scene, the start's joint state)."""
    equations, _, job, (rhs, P, D), y0 = compiled_sides(model)
    dims = P[8].copy()  # the energy states as ``equations`` has them, no drivers' power (``dispatch.start_rates``)
    dims[2], dims[5] = equations.extra, 0
    return equations, (rhs, (*P[:8], dims), D), job.scene, y0


@pytest.mark.parametrize(
    ("model", "cut"),
    [(parallelogram_chain(6), 12), (_held_chain(12), 11), (_spatial_loop(), 3)],
    ids=["loop-chain-band", "held-chain-dense", "spatial-loop"],
)
def test_cut_solve_equals_the_dense_augmented_solve(model, cut):
    equations, (rhs, P, D), tree, y0 = _both_sides(model)
    assert tree.cut_rows.size == cut
    rng = np.random.default_rng(7)
    out = np.empty(y0.size)
    for _ in range(3):
        y = y0 + rng.uniform(-0.2, 0.2, y0.size)
        if equations.formulation.tree.n_positions != equations.formulation.tree.k:  # Euler parameters: unit
            for joint in equations.formulation.joints:
                if joint.kind == "spherical":
                    e = y[joint.position : joint.position + 4]
                    e /= np.linalg.norm(e)
        expected = equations.rhs(0.0, y)
        rhs(0.0, y, P, D, out)
        np.testing.assert_allclose(out, expected, rtol=0, atol=1e-11 * np.abs(expected).max())


def test_outputs_lambda_from_the_rows_blocks_equals_the_whole_psi_q():
    """The outputs' right-hand side (``loops.outputs``) zeroes only the blocks of Psi_q the solves read (each row at
    its bodies: ``zero_cut_blocks``, ``zero_tree_blocks``); the output stage's one pass (``loops.output_history``)
    hands it over zero whole, in the outputs. The same q'' and lambda, bit for bit, at states off the constraint
    manifold; and the numpy engine's lambda (normal equations of the whole Psi_q, ``JointCoordinates.accelerations``)
    within rounding."""
    equations, (rhs, P, D), _, y0 = _both_sides(parallelogram_chain(6))
    n, m = int(P[8][0]), int(P[8][1])
    width = 3 * n + m  # q, q', q'', lambda after y'
    rng = np.random.default_rng(11)
    for _ in range(2):
        y = y0 + rng.uniform(-0.2, 0.2, y0.size)
        blocks, whole = np.full(y.size + width, np.nan), np.zeros(y.size + width + 2 * m + m * n)
        rhs(0.0, y.copy(), P, D, blocks)
        rhs(0.0, y.copy(), P, D, whole)
        np.testing.assert_array_equal(blocks, whole[: y.size + width])
        q, qd, lam = blocks[y.size : y.size + n], blocks[y.size + n : y.size + 2 * n], blocks[y.size + 3 * n :]
        _, expected = equations.formulation.accelerations(q, qd, 0.0)
        np.testing.assert_allclose(lam, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


def _child_first(joints: list[dict]) -> None:
    """Every other tree joint written child first: its child the element's body i (the sign of its Psi_q block +1,
    else -1)."""
    for joint in joints[1::2]:
        joint["body1"], joint["body2"] = joint["body2"], joint["body1"]


def _random_loops(dimension: int, n: int, seed: int) -> dict:
    """A random branching tree (``_random_tree``: revolute and prismatic joints, spherical in space), every other
    tree joint written child first (its child the element's body i: the sign of its Psi_q block +1, else -1), closed
    by cut joints (revolute in the plane, spherical in space) at a point between two bodies whose loop is mobile
    (in the plane at least three tree joints on the path between them, so a loop of four joints or more; in space
    freedoms enough that the cut's three and the path's exceed six), each assembled at the start (the joint's point
    is where both bodies are)."""
    rng = np.random.default_rng(100 + seed)
    model = _random_tree(dimension, n, seed)
    joints, bodies = model["model"]["joints"], model["model"]["bodies"]
    parent = [-1 if j["body1"] == "ground" else int(j["body1"][1:]) for j in joints]
    freedom = [{"revolute": 1, "prismatic": 1, "spherical": 3}[j["type"]] for j in joints]
    _child_first(joints)

    def path(b):  # the tree joints from body b to ground (joint i moves body i)
        return [b] + path(parent[b]) if b >= 0 else []

    cuts = 0
    for a in range(n):
        for b in range(a + 1, n):
            loop = set(path(a)) ^ set(path(b))  # the joints of the loop's tree path
            mobile = len(loop) >= 3 if dimension == 2 else 3 + sum(freedom[j] for j in loop) >= 8
            if mobile and cuts < 2 and rng.uniform() < 0.5:
                point = 0.5 * (np.array(bodies[a]["location"]) + np.array(bodies[b]["location"]))
                joints.append({"name": f"cut{cuts}", "type": "revolute" if dimension == 2 else "spherical",
                               "body1": f"b{a}", "body2": f"b{b}", "location": point.tolist()})  # fmt: skip
                cuts += 1
    assert cuts > 0
    return model


def _assert_outputs_equal_numpys(sides, seed: int) -> None:
    """The output pass's q'' and lambda (``compiled_sides``' scene_rhs) against the numpy engine's
    (``JointCoordinates.accelerations``: the normal equations of the whole Psi_q) at three random joint states."""
    equations, made, _, (rhs, P, D), y0 = sides
    rng = np.random.default_rng(seed)
    for _ in range(3):
        q, qd, qdd, lam, _ = output_pass(rhs, P, D, _random_state(made, y0, rng))
        expected_qdd, expected = equations.formulation.accelerations(q, qd, 0.0)
        np.testing.assert_allclose(qdd, expected_qdd, rtol=0, atol=1e-9 * np.abs(expected_qdd).max())
        np.testing.assert_allclose(lam, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize(("dimension", "n", "seed"), [(2, 6, 1), (2, 9, 2), (2, 12, 3), (3, 6, 4), (3, 8, 5)])
def test_a_closed_loops_lambda_equals_the_numpy_engines_on_random_loops(dimension, n, seed):
    """The outputs' lambda of random closed loops in joint coordinates (the cut route: the cut rows' mu of the
    augmented system, the tree's rows from r = Q - M q'' - Psi_c,q^T mu body by body from the leaves; a planar
    tree's revolute rows without a solve, ``tree_kernels.tree_multipliers``) against the numpy engine's (the
    dense augmented solve for q'', then the normal equations of the whole Psi_q, ``JointCoordinates.accelerations``)
    at random joint states off the constraint manifold: every row's multiplier, tree and cut, and q''. Revolute
    joints with their child as body i or j (Psi_q's sign), prismatic and spherical joints, two loops."""
    sides = compiled_sides(_random_loops(dimension, n, seed))
    assert sides[2].scene.cut_rows.size > 0  # closed loops: the cut route
    _assert_outputs_equal_numpys(sides, seed)


@pytest.mark.parametrize("name", ["slider_crank"])
def test_the_drivers_power_from_the_cut_rows_is_lambda_psi_t_of_every_row(name):
    """A driven tree's energy balance integrates the drivers' power lambda^T Psi_t (eq. 5.61) at every evaluation;
    the compiled right-hand side sums it over the cut rows' multipliers mu alone (a driver is a cut row; the tree's
    joints have Psi_t = 0), without lambda of every row. The whole y' (theta'', the three powers) against the numpy
    engine's, whose drivers' power takes lambda of every row from the normal equations of the whole Psi_q, at
    random joint states off the constraint manifold and a time where the crank's driver moves."""
    system, q0, qd0 = build_system(load_model(ROOT / "course" / "models" / f"{name}.yaml"))
    forces = build_forces(system.model)
    made = make_formulation("joint-coordinates", system, mass_matrix(system.model), forces)
    equations = EquationsOfMotion(made, forces, True)
    job = plan(system, made.masses, forces, "joint-coordinates", made)
    module, _, _ = load(job)
    P, D = parameters(job.scene, *job.numbers), job.scene.data()
    assert P[8][2] == 3 and P[8][5] == 1  # the energy states, the drivers' power: what a run integrates
    y0 = equations.initial_state(q0, qd0, 0.0)
    rng = np.random.default_rng(5)
    out = np.empty(y0.size)
    for _ in range(3):
        y = y0 + np.concatenate([rng.uniform(-0.2, 0.2, y0.size - 3), np.zeros(3)])
        expected = equations.rhs(0.3, y)
        module.scene_rhs(0.3, y, P, D, out)
        assert abs(expected[-1]) > 1e-3  # the driver does work here
        np.testing.assert_allclose(out, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize(
    ("model", "band"),
    [(parallelogram_chain(6), 3), (_held_chain(12), 10), (_spatial_loop(), 2)],
    ids=["loop-chain-band", "held-chain-dense", "spatial-loop"],
)
def test_the_cut_solves_sparsity_is_made_once_per_scene_from_the_tree(model, band):
    """The cut solve's integer work is the tree's structure (``structure.cut_structure``, in P[8] after the row index):
    lambda(i) of every joint velocity (an ancestor: smaller), each cut row's support (the columns that move its two
    bodies, walked up lambda from each body's own last column: every ancestor, descending), each entry's slot in W
    stored column by column (that column's range, its row recorded there, rows increasing), and S's half-band (the
    widest distance of two rows sharing a column: the band solve up to ``BAND``, LAPACK beyond)."""
    from solutions.compiled.tree_kernels import cut_parts

    _, _, job, (_, P, _), _ = compiled_sides(model)
    tree = job.scene
    k, mc, width = tree.k, tree.cut_rows.size, 7 if tree.scene.dimension == 3 else 3
    nb = tree.n // width
    structure = P[8][8 + 2 * mc + 2 * tree.m + nb :]
    np.testing.assert_array_equal(structure, tree.cut_index)
    p, parent, joint, row_start, column_start, support, slot, at = cut_parts(structure, k, mc, nb)
    assert p == band
    assert all(parent[i] < i for i in range(k))
    for a in range(mc):
        expected = set()
        for b in tree.cut_bodies[2 * a : 2 * a + 2]:
            i = tree.ints[joint[b], 6 + tree.ints[joint[b], 5] - 1] if b >= 0 else -1
            while i >= 0:
                expected.add(i)
                i = parent[i]
        entries = range(row_start[a], row_start[a + 1])
        assert [support[u] for u in entries] == sorted(expected, reverse=True)
        for u in entries:
            assert column_start[support[u]] <= slot[u] < column_start[support[u] + 1] and at[slot[u]] == a
    for i in range(k):
        rows = list(at[column_start[i] : column_start[i + 1]])
        assert rows == sorted(rows)
    widest = max(
        (at[column_start[i + 1] - 1] - at[column_start[i]] for i in range(k) if column_start[i + 1] > column_start[i]),
        default=0,
    )
    assert p == widest


def _python_structure(tree) -> list[int]:
    """``structure.cut_structure`` written with Python lists and sets (the structure as the twenty-fourth session
    made it in ``tree.py``, at every call's start): the reference of the compiled one."""
    from itertools import accumulate

    k, width = tree.k, 7 if tree.scene.dimension == 3 else 3
    nb, heads, bodies = tree.n // width, tree.ints[:, :6].tolist(), tree.cut_bodies.tolist()
    moving = [tree.ints[e, 6 : 6 + head[5]].tolist() for e, head in enumerate(heads)]
    joint, parent = [-1] * nb, [-1] * k
    for e, (kind, _, child, _, _, count) in enumerate(heads):
        joint[child] = e
        for a in range(max(count - (3 if kind == 2 else 1), 1), count):
            parent[moving[e][a]] = moving[e][a - 1]
    supports = [
        sorted({i for b in bodies[2 * a : 2 * a + 2] if b >= 0 for i in moving[joint[b]]}, reverse=True)
        for a in range(len(bodies) // 2)
    ]
    column_rows = [[a for a, support in enumerate(supports) if i in support] for i in range(k)]
    column_start = list(accumulate(map(len, column_rows), initial=0))
    filled, slots = column_start[:k], []
    for support in supports:
        for i in support:
            slots.append(filled[i])
            filled[i] += 1
    band = max([rows[-1] - rows[0] for rows in column_rows if rows], default=0)
    row_start = list(accumulate(map(len, supports), initial=0))
    every = [band, *parent, *joint, *row_start, *column_start, *(i for s in supports for i in s), *slots]
    return every + [a for rows in column_rows for a in rows]


@pytest.mark.parametrize(
    "model",
    [parallelogram_chain(1), parallelogram_chain(6), _held_chain(12), _spatial_loop()],
    ids=["loop-chain-1", "loop-chain-6", "held-chain", "spatial-loop"],
)
def test_the_compiled_cut_structure_equals_the_python_lists_one_and_is_made_only_for_the_run(model):
    """``TreeScene.structure`` (numba, ``compiled/structure.py``) gives the Python reference's array entry for entry;
    ``tree.describe`` (which the engine's choice calls before numba is loaded) leaves it to the run's parameters."""

    system, _, _ = build_system(load_model(model))
    M, forces = mass_matrix(system.model), build_forces(system.model)
    made = make_formulation("joint-coordinates", system, M, forces)
    EquationsOfMotion(made, forces, False).initial_state(*build_system(load_model(model))[1:], 0.0)
    tree = plan(system, M, forces, "joint-coordinates", made).scene
    assert tree.cut_index is None  # not made by the description
    assert tree.structure().tolist() == _python_structure(tree)
    assert tree.structure() is tree.cut_index  # made once per scene


@pytest.mark.parametrize(
    "model", [parallelogram_chain(6), _held_chain(12), _spatial_loop()], ids=["loop-chain", "held-chain", "spatial"]
)
def test_the_integration_evaluates_the_cut_elements_kernels_alone(model):
    """The tree's joints satisfy their rows by construction, so the integration's right-hand side reads the cut rows
    alone and calls each constraint kernel on its cut elements only: ``TreeScene.data`` puts each slot's elements of
    cut rows first (each group in its order) and appends, after the offsets of every slot, where each slot's cut
    elements stop. The same y', bit for bit, as with every element evaluated (the stops moved to the slots' ends),
    at states off the constraint manifold; the outputs evaluate every element (lambda and Psi_q of every row)."""
    from solutions.compiled.scene import SLOTS
    from solutions.compiled.tree import ONE_BODY

    _, (rhs, P, D), tree, y0 = _both_sides(model)
    ints, floats, offsets = D
    slots = len(SLOTS)
    assert offsets.shape == (2 * slots + 1,)
    evaluated = 0
    for s, name in enumerate(SLOTS):
        first, stop, cut_stop = offsets[s], offsets[s + 1], offsets[slots + 1 + s]
        assert first <= cut_stop <= stop
        if name not in {kernel for kernel, _, _ in tree.scene.constraint_kernels}:
            assert cut_stop == first, name  # forces and the tree's joints: no cut elements
            continue
        column = 1 if name in ONE_BODY else 2
        owners = tree.owners[ints[first:stop, column]]
        assert np.all(owners[: cut_stop - first] < 0) and np.all(owners[cut_stop - first :] >= 0), name
        evaluated += cut_stop - first
    assert 0 < evaluated < ints.shape[0]
    every = (ints, floats, np.concatenate([offsets[: slots + 1], offsets[1 : slots + 1]]))  # every element's stop
    rng = np.random.default_rng(3)
    out, expected = np.empty(y0.size), np.empty(y0.size)
    for _ in range(3):
        y = y0 + rng.uniform(-0.2, 0.2, y0.size)
        rhs(0.0, y.copy(), P, D, out)
        rhs(0.0, y.copy(), P, every, expected)
        assert np.all(np.isfinite(out))
        np.testing.assert_array_equal(out, expected)


@pytest.mark.parametrize(
    "model", [parallelogram_chain(6), _held_chain(12), _spatial_loop()], ids=["loop-chain", "held-chain", "spatial"]
)
def test_the_scene_describes_the_cut_elements_first_as_the_tree_orders_them(model):
    """The cut-first order is made where the scene is described, by ``compiled.plan`` alone (it gives
    ``scene.describe`` the tree's cut elements, ``tree.cut_names``): each constraint kernel's cut elements lead its own
    data, their count in ``first_counts``; the tree's D equals, array for array, the one of a scene described
    without them with each kernel's cut elements moved first (``_cut_first``, the reorder ``TreeScene.data`` made
    before session 26); a scene described for any other formulation keeps the elements' order, and the tree refuses
    a scene described without its cut elements first (its integration would read the wrong rows)."""
    from solutions.compiled import tree as tree_module
    from solutions.compiled.scene import SLOTS, packed
    from solutions.compiled.tree import ONE_BODY, cut_names

    system = build_system(load_model(model))[0]
    M, forces = mass_matrix(system.model), build_forces(system.model)
    made = make_formulation("joint-coordinates", system, M, forces)
    first = cut_names(made)
    told = plan(system, M, forces, "joint-coordinates", made).scene
    untold = describe(system, M, forces)
    assert told.scene.first == first and untold.first == frozenset()
    assert sum(told.scene.first_counts.values()) == len(first) > 0
    owners = told.owners
    for name, ints, _ in told.scene.constraint_kernels:
        if ints.shape[0]:
            cut = told.scene.first_counts.get(name, 0)
            column_owners = owners[ints[:, 1 if name in ONE_BODY else 2]]
            assert np.all(column_owners[:cut] < 0) and np.all(column_owners[cut:] >= 0), name
    cut = {}
    constraints = [_cut_first(*kernel, owners.tolist(), cut) for kernel in untold.constraint_kernels]
    ints, floats, offsets = packed([*constraints, *untold.force_kernels, ("tree", told.ints, told.floats)], SLOTS)
    stops = offsets[:-1].copy()
    for name, count in cut.items():
        stops[SLOTS.index(name)] += count
    for ours, theirs in zip(told.data(), (ints, floats, np.concatenate([offsets, stops])), strict=True):
        assert ours.dtype == theirs.dtype and ours.tobytes() == theirs.tobytes()
    kernels = [(name, ints) for name, ints, _ in untold.constraint_kernels if ints.shape[0]]
    rows = [ints[:, 1 if name in ONE_BODY else 2].tolist() for name, ints in kernels]
    assert all(r == sorted(r) for r in rows)  # the elements' order: each element's first row increasing
    with pytest.raises(ValueError, match="cut elements first"):
        tree_module.describe(untold, made)


def _cut_first(name: str, ints: np.ndarray, floats: np.ndarray, owners: list, cut: dict) -> tuple:
    """A constraint kernel's data with the elements of cut rows (owner -1) first, each group in its order; their count
    in ``cut[name]``: the reference of the cut-first order (``TreeScene.data``'s own reorder before session 26)."""
    from solutions.compiled.tree import ONE_BODY

    if ints.shape[0] == 0:
        return name, ints, floats
    rows = ints[:, 1 if name in ONE_BODY else 2].tolist()
    order = [e for e, row in enumerate(rows) if owners[row] < 0]
    cut[name] = len(order)
    order += [e for e, row in enumerate(rows) if owners[row] >= 0]
    return name, ints[order], floats[order]


@pytest.mark.parametrize(("n", "seed"), [(6, 4), (9, 5), (12, 6)])
def test_an_open_spatial_trees_lambda_equals_the_numpy_engines_on_random_trees(n, seed):
    """The outputs' lambda of an open spatial tree (revolute, prismatic and spherical joints, branching, every other
    joint child first: Psi_q's sign) from r = Q - M q'' body by body from the leaves (``tree_kernels.tree_multipliers``:
    a joint's translational rows read from the residual's translational part, s r_C,v, no solve)
    against the numpy engine's (the normal equations of the whole Psi_q, ``JointCoordinates.accelerations``) at
    random joint states off the constraint manifold: every row's multiplier, and q''."""
    model = _random_tree(3, n, seed)
    _child_first(model["model"]["joints"])
    sides = compiled_sides(model)
    assert sides[2].scene.cut_rows.size == 0  # an open tree: the articulated pass, no cut solve
    _assert_outputs_equal_numpys(sides, seed)


def _prismatic(model: dict, n: int) -> dict:
    """The tree's revolute joints (the first n joints) made prismatic along their axes: one freedom either way, so a
    random loop stays mobile."""
    for joint in model["model"]["joints"][:n]:
        if joint["type"] == "revolute":
            joint["type"] = "prismatic"
    return model


@pytest.mark.parametrize(("n", "seed", "closed"), [(7, 7, False), (10, 8, False), (6, 4, True), (8, 5, True)])
def test_a_spatial_prismatic_joints_lambda_equals_the_numpy_engines(n, seed, closed):
    """A spatial prismatic joint's rows (eq. 9.18) from the force its joint passes the child (``tree_kernels.
    tree_multipliers``): the two dot-2 rows meet the child's position columns along s f_i and s g_i, read as their
    components of r_C,v; the three dot-1 rows and the normalization by least squares on the Euler-parameter columns.
    Random trees whose revolute joints are all prismatic (two of three joints, the rest spherical; every other child
    first: the sign s), open (the articulated pass) and closed (the cut route), against the numpy engine's normal
    equations of the whole Psi_q at random states: every row's lambda, and q''."""
    if closed:
        model = _prismatic(_random_loops(3, n, seed), n)
    else:
        model = _prismatic(_random_tree(3, n, seed), n)
        _child_first(model["model"]["joints"])
    sides = compiled_sides(model)
    assert sum(joint.kind == "prismatic" for joint in sides[1].joints) >= n // 2
    assert (sides[2].scene.cut_rows.size > 0) == closed
    _assert_outputs_equal_numpys(sides, seed)


TRANSLATIONAL = {(2, "revolute"): ("x", "y"), (2, "prismatic"): ("n",), (3, "revolute"): ("x", "y", "z"),
                 (3, "spherical"): ("x", "y", "z"), (3, "prismatic"): ("fi.d", "gi.d")}  # fmt: skip
"""The rows of each tree joint that meet its child's position columns, by their labels: a revolute joint's (eq. 3.17),
a planar prismatic joint's pin-in-slot row (eq. 3.24), a spherical part's (eq. 9.12), a spatial prismatic joint's
dot-2 rows (eq. 9.18)."""


@pytest.mark.parametrize(("dimension", "seed"), [(2, 3), (3, 3), (3, 4)])
def test_each_joints_translational_rows_are_where_the_backward_pass_reads_them(dimension, seed):
    """``tree_kernels.translational_rows`` (where among a body's rows its joint's translational rows are) against the
    rows' labels of every joint kind, and a spatial body's normalization last of its rows (``tree.row_index``)."""
    from solutions.compiled.tree_kernels import translational_rows

    model = _random_tree(dimension, 9, seed)
    system, _, _ = build_system(load_model(model))
    forces = build_forces(system.model)
    made = make_formulation("joint-coordinates", system, mass_matrix(system.model), forces)
    tree = plan(system, made.masses, forces, "joint-coordinates", made).scene
    labels, nb = system.labels, len(system.model.bodies)
    start, rows = tree.row_index[: nb + 1], tree.row_index[nb + 1 :]
    for e, joint in enumerate(made.joints):  # the tree's joints in its order (tree.ints)
        mine = rows[start[joint.child] : start[joint.child + 1]]
        at, count = translational_rows.py_func(tree.ints[e, 0], 3 if dimension == 2 else 7)
        read = [labels[row].removeprefix(f"{joint.name}.") for row in mine[at : at + count]]
        assert tuple(read) == TRANSLATIONAL[(dimension, joint.kind)], joint.name
        if dimension == 3:
            assert labels[mine[-1]] == f"{system.model.bodies[joint.child].name}.p"


def test_the_plan_fails_loudly_where_a_bodys_normalization_comes_before_its_joint(monkeypatch):
    """The backward pass reads a spatial body's rows as its joint's, then its normalization (``spatial.build.
    build_elements`` puts the normalizations last): with the normalizations first the plan raises (``tree.
    check_row_order``), where it would give lambda to the wrong rows."""
    from solutions.spatial import build

    made_elements = build.build_elements

    def normalizations_first(model):
        elements = made_elements(model)
        return elements[-len(model.bodies) :] + elements[: -len(model.bodies)]

    monkeypatch.setattr(build, "build_elements", normalizations_first)
    system, _, _ = build_system(load_model(_random_tree(3, 4, 1)))
    forces = build_forces(system.model)
    made = make_formulation("joint-coordinates", system, mass_matrix(system.model), forces)
    with pytest.raises(ValueError, match="normalization before its joint"):
        plan(system, made.masses, forces, "joint-coordinates", made)
