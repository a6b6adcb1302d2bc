"""The articulated-body algorithm of the compiled joint coordinates (``solutions/compiled/articulated.py``).

An open tree's theta'' comes from two O(N) passes over the tree instead of the dense embedded equations
(D^T M D) theta'' = D^T (Q - M xi) (eq. 5.44 with Z = D). Checked against the numpy reference engine
(``joint_coordinates.JointCoordinates``, which forms D and solves the dense system) at random joint states of
random branching trees: revolute and prismatic joints in the plane; revolute, prismatic and spherical joints in
space, bodies with unequal principal inertias turned every way, a spring between two branches; and the
algorithm alone on a pendulum (its closed form) and on a massless one (NaN, as the dense solve gives).
"""

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.dynamics import EquationsOfMotion, mass_matrix
from solutions.formulations import make_formulation
from solutions.generalized_forces import build_forces
from solutions.io import load_model

pytest.importorskip("numba")


def _random_tree(dimension: int, n: int, seed: int) -> dict:
    """n bodies, body i joined to ground or to a random earlier body (a branching tree), joints of every kind."""
    rng = np.random.default_rng(seed)
    kinds = ("revolute", "prismatic") if dimension == 2 else ("revolute", "prismatic", "spherical")
    bodies, joints, centres = [], [], []
    for i in range(n):
        parent = int(rng.integers(-1, i))  # -1: ground
        base = np.zeros(dimension) if parent < 0 else centres[parent]
        pin = base + rng.uniform(-0.3, 0.3, dimension)
        centre = pin + rng.uniform(-0.4, 0.4, dimension)
        centres.append(centre)
        body = {"name": f"b{i}", "mass": float(rng.uniform(0.5, 3.0)), "location": centre.tolist()}
        if dimension == 2:
            body.update(inertia=float(rng.uniform(0.01, 0.2)), orientation=float(rng.uniform(-3, 3)),
                        velocity=rng.uniform(-1, 1, 2).tolist())  # fmt: skip
        else:
            p = rng.standard_normal(4)
            body.update(inertia=rng.uniform(0.01, 0.2, 3).tolist(), orientation=(p / np.linalg.norm(p)).tolist())
        bodies.append(body)
        kind = kinds[(i + seed) % len(kinds)]
        joint = {"name": f"j{i}", "type": kind, "body1": "ground" if parent < 0 else f"b{parent}",
                 "body2": f"b{i}", "location": pin.tolist()}  # fmt: skip
        if kind != "spherical" and (dimension == 3 or kind == "prismatic"):
            joint["axis"] = rng.standard_normal(dimension).tolist()
        joints.append(joint)
    gravity = [0.0, -9.81] if dimension == 2 else [0.0, 0.0, -9.81]
    spring = {"name": "spring", "type": "TSDA", "body1": f"b{n - 1}", "body2": f"b{n - 2}",
              "point1": centres[-1].tolist(), "point2": centres[-2].tolist(), "spring_coefficient": 40.0,
              "damping_coefficient": 0.5, "free_length": 0.2}  # fmt: skip
    return {"model": {"name": f"tree-{dimension}-{seed}", "dimension": dimension, "gravity": gravity,
                      "bodies": bodies, "joints": joints, "spring_dampers": [spring]}}  # fmt: skip


def compiled_sides(model: dict):
    """(numpy equations of motion, its formulation, the compiled plan, the compiled scene_rhs with its P and D, the
    joint state at the start) of a model in joint coordinates (also ``test_compiled_cut``)."""
    from solutions.compiled import load, parameters, plan

    system, q0, qd0 = build_system(load_model(model))
    forces = build_forces(system.model)
    made = make_formulation("joint-coordinates", system, mass_matrix(system.model), forces)
    equations = EquationsOfMotion(made, forces, False)
    job = plan(system, made.masses, forces, "joint-coordinates", made)
    assert job.scene.unsupported is None
    module, _, _ = load(job)
    P, D = parameters(job.scene, *job.numbers), job.scene.data()
    return equations, made, job, (module.scene_rhs, P, D), equations.initial_state(q0, qd0, 0.0)


def _both_sides(model: dict):
    """(numpy equations of motion, compiled scene_rhs with its data, the joint state at the start) of an open tree."""
    equations, made, job, compiled, y0 = compiled_sides(model)
    assert job.scene.cut_rows.size == 0  # an open tree: the articulated-body algorithm runs
    return equations, made, compiled, y0


def output_pass(rhs, P, D, y: np.ndarray) -> tuple[np.ndarray, ...]:
    """(q, q', q'', lambda, the whole ``out``) of the compiled right-hand side's output pass at the joint state y,
    with Psi, Psi_t and Psi_q after the outputs (``loops.output_history``'s ``out``; also ``test_compiled_cut``)."""
    n, m = int(P[8][0]), int(P[8][1])
    out = np.zeros(y.size + 3 * n + 3 * m + m * n)
    rhs(0.0, y.copy(), P, D, out)
    q, qd, qdd = (out[y.size + a * n : y.size + (a + 1) * n] for a in range(3))
    return q, qd, qdd, out[y.size + 3 * n : y.size + 3 * n + m], out


def _random_state(made, y0: np.ndarray, rng) -> np.ndarray:
    """The joint state moved by a random amount: every angle, slide and rate; spherical joints' Euler parameters
    turned and normalized."""
    y = y0 + rng.uniform(-0.5, 0.5, y0.size)
    for joint in made.joints:
        if joint.kind == "spherical":
            e = y[joint.position : joint.position + 4]
            e /= np.linalg.norm(e)
    return y


@pytest.mark.parametrize(("dimension", "n", "seed"), [(2, 6, 1), (2, 12, 2), (3, 6, 3), (3, 12, 4), (3, 9, 5)])
def test_articulated_accelerations_equal_the_dense_embedded_equations(dimension, n, seed):
    equations, made, (rhs, P, D), y0 = _both_sides(_random_tree(dimension, n, seed))
    rng = np.random.default_rng(seed)
    kinds = {joint.kind for joint in made.joints}
    assert kinds == ({"revolute", "prismatic"} if dimension == 2 else {"revolute", "prismatic", "spherical"})
    positions, k = made.tree.n_positions, made.tree.k
    for _ in range(5):
        y = _random_state(made, y0, rng)
        expected = equations.rhs(0.0, y)[: positions + k]
        out = np.empty(y.size)
        rhs(0.0, y, P, D, out)
        thdd, reference = out[positions : positions + k], expected[positions:]
        assert np.max(np.abs(thdd - reference)) <= 1e-10 * max(1.0, np.max(np.abs(reference)))
        assert np.allclose(out[:positions], expected[:positions], rtol=1e-12, atol=1e-12)  # the position rates


def _pendulum(mass: float, inertia: float, r: float, theta: float):
    """The arrays of ``articulated_accelerations`` for one bar on a revolute joint at the origin, its centre r from
    the pin at angle theta from the downward vertical, at rest under gravity (planar: v_x, v_y, omega)."""
    IA = np.zeros((2, 3, 3))  # the bar, then ground
    IA[0] = np.diag([mass, mass, inertia])
    pA = np.zeros((2, 3))
    pA[0] = -np.array([0.0, -9.81 * mass, 0.0])  # p_b = M xi - Q, xi = 0 at rest
    rho = np.array([-r * np.sin(theta), r * np.cos(theta)])  # from the centre to the pin
    S = np.zeros((1, 3, 3))
    S[0, :, 0] = [rho[1], -rho[0], 1.0]
    links = np.array([[-rho[0], -rho[1], 0.0]])  # from ground's origin to the centre
    ints = np.array([[0, -1, 0, 0]])
    return IA, pA, ints, S, links


def test_a_pendulum_gets_its_closed_form_and_a_massless_one_nan():
    from solutions.compiled.articulated import articulated_accelerations
    from solutions.compiled.tree_kernels import WIDTHS

    mass, inertia, r, theta = 2.0, 0.05, 0.3, 0.7
    thdd, acc = np.zeros(1), np.full((2, 3), np.nan)
    IA, pA, ints, S, links = _pendulum(mass, inertia, r, theta)
    articulated_accelerations(IA, pA, ints, S, links, WIDTHS, 3, thdd, acc)
    assert thdd[0] == pytest.approx(-mass * 9.81 * r * np.sin(theta) / (inertia + mass * r**2), rel=1e-14)
    # at rest the centre (r sin theta, -r cos theta) accelerates by theta'' (r cos theta, r sin theta); ground not
    np.testing.assert_allclose(acc, [[r * np.cos(theta) * thdd[0], r * np.sin(theta) * thdd[0], thdd[0]], [0, 0, 0]],
                               rtol=1e-14, atol=1e-15)  # fmt: skip
    IA, pA, ints, S, links = _pendulum(0.0, 0.0, r, theta)  # no inertia at the end of the tree: D_e = 0
    articulated_accelerations(IA, pA, ints, S, links, WIDTHS, 3, thdd, acc)
    assert np.isnan(thdd).all()  # the adaptive integrators reject such a step, as with the dense solve


def _cross_matrix(a: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _shift(link: np.ndarray) -> np.ndarray:
    """X (eq. 7.7): motion at a point carried to a point ``link`` away from it, (v - l x omega, omega)."""
    X = np.eye(6)
    X[:3, 3:] = -_cross_matrix(link)
    return X


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_spherical_joint_passes_on_a_translational_block_at_its_point(seed):
    """A spherical joint transmits no moment: the spatial passes carry a spherical joint's child to its parent as
    [[I_vv - G K^-1 G^T, 0], [0, 0]] at the joint point (``articulated.spherical_passed_on``), not by the 6 x 6
    route I - U D_e^-1 U^T with U = I S_e. One body on a spherical joint to ground, a random inertia and bias force
    at its centre, joint axes turned every way: theta'' and what ground receives equal the dense formulas of eq.
    7.8-7.10, and ground's articulated inertia seen at the joint point has no angular rows or columns."""
    from solutions.compiled.articulated import articulated_accelerations
    from solutions.compiled.tree_kernels import WIDTHS

    rng = np.random.default_rng(seed)
    root = rng.standard_normal((6, 6))
    inertia = root @ root.T + 6.0 * np.eye(6)  # symmetric positive definite, coupled v and omega
    bias = rng.standard_normal(6)
    axes = np.linalg.qr(rng.standard_normal((3, 3)))[0]  # the child's joint axes x_n (columns), orthonormal
    rho, e_p = rng.uniform(-0.5, 0.5, 3), rng.uniform(-0.5, 0.5, 3)  # the joint point from the child's, parent's centre
    S = np.vstack([np.cross(rho, axes.T).T, axes])  # (rho_C x x_n, x_n)
    IA, pA = np.zeros((2, 6, 6)), np.zeros((2, 6))
    IA[0], pA[0] = inertia, bias
    thdd, acc = np.zeros(3), np.zeros((2, 6))
    articulated_accelerations(IA, pA, np.array([[2, -1, 0, 0]]), S[None], (e_p - rho)[None], WIDTHS, 3, thdd, acc)
    U = inertia @ S
    D_inverse = np.linalg.inv(S.T @ U)
    expected = -D_inverse @ (S.T @ bias)  # ground at rest: theta'' = D_e^-1 (u - U^T 0), u = -S^T p
    np.testing.assert_allclose(thdd, expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(acc[0], S @ expected, rtol=1e-12, atol=1e-12)
    X = _shift(e_p - rho)  # ground's origin to the child's centre
    passed = X.T @ (inertia - U @ D_inverse @ U.T) @ X
    np.testing.assert_allclose(IA[1], passed, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(pA[1], X.T @ (bias + U @ D_inverse @ (-S.T @ bias)), rtol=1e-12, atol=1e-12)
    at_point = np.linalg.inv(_shift(e_p)).T @ IA[1] @ np.linalg.inv(_shift(e_p))  # from ground's origin to the point
    np.testing.assert_allclose(at_point[3:], 0.0, atol=1e-12)
    np.testing.assert_allclose(at_point[:, 3:], 0.0, atol=1e-12)


@pytest.mark.parametrize(("dimension", "n", "seed"), [(2, 6, 1), (3, 6, 3)])
def test_the_positions_pass_gives_the_body_coordinates_of_the_joint_state(dimension, n, seed):
    """An ``out`` of y.size + n asks scene_rhs for q alone after y (the divergence check's companion run,
    ``dispatch.positions``): the numpy tree's recursive kinematics at the same joint state (spatial: the same
    orientations), and the q the whole outputs write, bit for bit (the same recursion)."""
    equations, made, (rhs, P, D), y0 = _both_sides(_random_tree(dimension, n, seed))
    rng = np.random.default_rng(seed)
    nq, m = made.system.n_coordinates, made.system.n_constraints
    for _ in range(3):
        y = _random_state(made, y0, rng)
        positions, full = np.full(y.size + nq, np.nan), np.empty(y.size + 3 * nq + m)
        rhs(0.0, y, P, D, positions)
        rhs(0.0, y, P, D, full)
        q, expected = positions[y.size :].copy(), made.motion(y).q
        if dimension == 3:  # Euler parameters p and -p are one orientation: the numpy tree's sign taken
            for p, reference in zip(q.reshape(-1, 7)[:, 3:], expected.reshape(-1, 7)[:, 3:], strict=True):
                p *= np.sign(p @ reference)
        np.testing.assert_allclose(q, expected, rtol=1e-13, atol=1e-13)
        np.testing.assert_array_equal(positions[y.size :], full[y.size : y.size + nq])


def test_a_state_or_out_of_a_size_scene_rhs_does_not_know_gets_nan_not_a_write_past_its_end():
    """numba checks no bounds: an ``out`` longer than y' and q alone but too short for the outputs (q, q', q'',
    lambda) wrote past its end. Now such an ``out``, or a joint state of another size, is filled with NaN; the
    sizes it knows (y', q alone, the outputs, with Psi, Psi_t and Psi_q after them) are still filled with finite
    numbers (Psi_q's part of the last handed over zero, as ``loops.output_history`` hands it)."""
    _, made, (rhs, P, D), y = _both_sides(_random_tree(2, 6, 1))
    n, m = made.system.n_coordinates, made.system.n_constraints
    full = y.size + 3 * n + m
    for size in (y.size, y.size + n, full, full + 2 * m + m * n):
        out = np.full(size, np.nan)
        out[full + 2 * m :] = 0.0  # (only the last size has a Psi_q part)
        rhs(0.0, y, P, D, out)
        assert np.isfinite(out[y.size :] if size == y.size + n else out).all(), size  # q alone: y' not written
    for size in (y.size - 1, y.size + 1, y.size + n - 1, y.size + n + 1, full - 1):
        out = np.zeros(size + 8)[:size]  # the 8 after its end must stay untouched
        rhs(0.0, y, P, D, out)
        assert np.isnan(out).all(), size
        assert not np.any(out.base[size:]), size
    out = np.zeros(y.size)
    rhs(0.0, y[:-1].copy(), P, D, out)  # a state one short
    assert np.isnan(out).all()


def test_the_row_index_lists_each_bodys_rows_in_row_order_without_cut_rows():
    """``tree.row_index``: start (nb + 1), then the rows of body 0, body 1, ... from ``_owners``' lists of each
    body's rows (``tree_multipliers``' and the joint forces' index, made once per scene); a cut row (owner -1)
    belongs to no body (``test_call_start`` checks ``describe``'s against the owners of real scenes)."""
    from solutions.compiled.tree import row_index

    assert row_index([[1, 4], [0, 3], [5]]).tolist() == [0, 2, 4, 5, 1, 4, 0, 3, 5]
    assert row_index([[], []]).tolist() == [0, 0, 0]
    assert row_index([[2, 3], []]).dtype == np.int64


def _planar_shift(link: np.ndarray) -> np.ndarray:
    """X (eq. 7.7) in the plane: motion at a point carried to a point ``link`` away, (v + omega (-l_y, l_x), omega)."""
    X = np.eye(3)
    X[:2, 2] = -link[1], link[0]
    return X


def _spd(rng, size: int) -> np.ndarray:
    root = rng.standard_normal((size, size))
    return root @ root.T + size * np.eye(size)  # symmetric positive definite, v and omega coupled


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_planar_joint_point_passes_equal_the_dense_embedded_equations(seed):
    """The planar passes take a revolute joint at its joint point (``articulated.revolute_passed_on``: S_e = (0, 0, 1)
    there, the child passes on a 2 x 2 translational block) and a prismatic one by the 3 x 3 route at the child's
    centre. On a random branching tree of both kinds, every body a coupled symmetric positive definite inertia and a
    bias force p_b at its centre: theta'' equals the dense solve of eq. 7.4, (D^T M D) theta'' = -D^T p, with D's
    columns made from S_e and the links (D_C = X D_P, then S_e: eq. 7.5, 7.7), and each body's acceleration D_b
    theta''."""
    from solutions.compiled.articulated import articulated_accelerations
    from solutions.compiled.tree_kernels import WIDTHS

    rng = np.random.default_rng(seed)
    nb = 7
    IA, pA = np.zeros((nb + 1, 3, 3)), np.zeros((nb + 1, 3))
    ints, S, links = np.zeros((nb, 4), dtype=np.int64), np.zeros((nb, 3, 3)), np.zeros((nb, 3))
    D = np.zeros((nb, 3, nb))  # D_b (3 x k) body by body
    for e in range(nb):  # joint e moves body e, its parent an earlier body or ground (-1)
        parent, kind = int(rng.integers(-1, e)), (0 if e % 3 else 1)
        IA[e], pA[e] = _spd(rng, 3), rng.standard_normal(3)
        if kind == 0:  # revolute: the joint point rho_C from the child's centre, e_P from the parent's
            rho, e_p = rng.uniform(-0.5, 0.5, 2), rng.uniform(-0.5, 0.5, 2)
            S[e, :, 0], links[e, :2] = (rho[1], -rho[0], 1.0), e_p - rho
        else:  # prismatic: its axis u
            u = rng.standard_normal(2)
            S[e, :2, 0], links[e, :2] = u / np.linalg.norm(u), rng.uniform(-0.5, 0.5, 2)
        ints[e] = kind, parent, e, e
        if parent >= 0:
            D[e] = _planar_shift(links[e]) @ D[parent]
        D[e, :, e] = S[e, :, 0]
    assert set(ints[:, 0]) == {0, 1}
    H = sum(D[b].T @ IA[b] @ D[b] for b in range(nb))
    expected = np.linalg.solve(H, -sum(D[b].T @ pA[b] for b in range(nb)))
    thdd, acc = np.zeros(nb), np.zeros((nb + 1, 3))
    articulated_accelerations(IA.copy(), pA.copy(), ints, S, links, WIDTHS, 3, thdd, acc)
    np.testing.assert_allclose(thdd, expected, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(acc[:nb], np.einsum("bik,k->bi", D, expected), rtol=1e-11, atol=1e-11)
    np.testing.assert_array_equal(acc[nb], 0.0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_planar_revolute_joint_passes_on_a_translational_block_at_its_point(seed):
    """What a child passes on at a revolute joint's point (``revolute_passed_on``, eq. 7.9 at J): with I' = X_c^T I
    X_c and p' = X_c^T p (X_c from the point to the child's centre), U = I' (0, 0, 1) and D_e = K, I' - U D_e^-1 U^T
    has no angular row or column and its 2 x 2 block is the M returned; p' + U D_e^-1 u (u = -p'_w) has no angular
    entry and its linear part is pa_v. Ground then receives X_p^T of them at its centre
    (``articulated_accelerations``)."""
    from solutions.compiled.articulated import articulated_accelerations, joint_rows, revolute_passed_on, sizes
    from solutions.compiled.tree_kernels import WIDTHS

    rng = np.random.default_rng(seed)
    inertia, bias = _spd(rng, 3), rng.standard_normal(3)
    rho, e_p = rng.uniform(-0.5, 0.5, 2), rng.uniform(-0.5, 0.5, 2)
    X_c = _planar_shift(-rho)  # the point to the child's centre: v_C = v_J + omega (rho_y, -rho_x)
    I_point, p_point = X_c.T @ inertia @ X_c, X_c.T @ bias
    U = I_point[:, 2]
    Ia = I_point - np.outer(U, U) / I_point[2, 2]
    pa = p_point - U * p_point[2] / I_point[2, 2]
    np.testing.assert_allclose(Ia[2], 0.0, atol=1e-12)
    np.testing.assert_allclose(pa[2], 0.0, atol=1e-12)
    body, joint = np.zeros((2, sizes(3)[0], 3)), np.zeros((2, sizes(3)[1], 3))
    body[0, :3], body[0, 3] = inertia, bias
    joint[0, joint_rows(3)[0], 0], joint[0, joint_rows(3)[0] + 1, 0] = rho[1], -rho[0]
    positive, m00, m01, m11, pa0, pa1 = revolute_passed_on(body, joint, 0, 0)
    assert positive
    np.testing.assert_allclose([[m00, m01], [m01, m11]], Ia[:2, :2], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose([pa0, pa1], pa[:2], rtol=1e-12, atol=1e-12)
    IA, pA, thdd, acc = np.zeros((2, 3, 3)), np.zeros((2, 3)), np.zeros(1), np.zeros((2, 3))
    IA[0], pA[0] = inertia, bias
    S = np.array([[[rho[1], 0, 0], [-rho[0], 0, 0], [1.0, 0, 0]]])
    link = np.array([[*(e_p - rho), 0.0]])
    articulated_accelerations(IA, pA, np.array([[0, -1, 0, 0]]), S, link, WIDTHS, 3, thdd, acc)
    X_p = _planar_shift(e_p)  # ground's centre to the point
    np.testing.assert_allclose(IA[1], X_p.T @ Ia @ X_p, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(pA[1], X_p.T @ pa, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(thdd, -p_point[2] / I_point[2, 2], rtol=1e-12)  # ground at rest: K theta'' = -p'_w


@pytest.mark.parametrize(("n", "seed"), [(6, 1), (12, 2), (8, 6)])
def test_an_open_planar_trees_lambda_from_its_joint_forces_equals_the_normal_equations(n, seed):
    """The outputs' lambda of an open planar tree (revolute and prismatic joints, branching) from the articulated
    pass's joint forces f_e = I^A_C A_C + p^A_C (``tree_kernels.planar_joint_multipliers``, no solve) against the
    numpy engine's (the normal equations of the whole Psi_q, ``JointCoordinates.accelerations``) at states off
    the start (rounding: the sums in another order), and the outputs alone (Psi_q's blocks in the work array) equal
    the output pass's (Psi_q whole in ``out``) bit for bit."""
    equations, made, (rhs, P, D), y0 = _both_sides(_random_tree(2, n, seed))
    n3, m = int(P[8][0]), int(P[8][1])
    rng = np.random.default_rng(seed)
    for _ in range(4):
        y = _random_state(made, y0, rng)
        q, qd, _, lam, out = output_pass(rhs, P, D, y)
        _, expected = equations.formulation.accelerations(q, qd, 0.0)
        np.testing.assert_allclose(lam, expected, rtol=0, atol=1e-10 * np.abs(expected).max())
        blocks = np.full(y.size + 3 * n3 + m, np.nan)  # the outputs alone: Psi_q's blocks zeroed in the work array
        rhs(0.0, y.copy(), P, D, blocks)
        np.testing.assert_array_equal(blocks, out[: blocks.size])
