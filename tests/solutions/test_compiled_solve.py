"""The compiled solve of eq. 5.30 in its range-space form (eq. 5.31): planar (``kernels.range_space_solve``; a small
scene's dense form, ``dense_range_space_solve``) and spatial (``spatial_range_space_solve``: M block-diagonal,
eq. 10.4) against numpy's dense solve of the augmented system, on Jacobians shaped as mechanisms make them: a chain
(banded), a chain closed into a loop (a wide envelope), rows in shuffled order; and the cases it must hand back to
the LU of eq. 5.30 (dependent rows, a body without mass or inertia, a row with many nonzeros) without writing
anything.
"""

import numpy as np
import pytest

pytest.importorskip("numba")

from solutions.compiled.kernels import MAX_ROW_ENTRIES, dense_range_space_solve, range_space_solve  # noqa: E402

SOLVERS = {"envelope": range_space_solve, "dense": dense_range_space_solve}


def chain_jacobian(bodies: int, closed: bool, rng: np.random.Generator) -> np.ndarray:
    """Psi_q of planar revolute joints along a chain of ``bodies`` (3 columns each): ground to body 0, then body
    k - 1 to body k (two rows each, nonzeros in the columns of both bodies); ``closed``: body k - 1 to ground too."""
    pairs = [(-1, 0), *[(k - 1, k) for k in range(1, bodies)]] + ([(bodies - 1, -1)] if closed else [])
    jac = np.zeros((2 * len(pairs), 3 * bodies))
    for e, (i, j) in enumerate(pairs):
        for body, sign in ((i, 1.0), (j, -1.0)):
            if body >= 0:
                jac[2 * e : 2 * e + 2, 3 * body : 3 * body + 2] = sign * np.eye(2)
                jac[2 * e : 2 * e + 2, 3 * body + 2] = sign * rng.normal(size=2)
    return jac


def augmented(mass, jac, psi, psit, gam, Q, qd, ab):
    """q'' and lambda of eq. 5.30 with gamma_bar of eq. 5.29, by numpy's dense solve."""
    m, n = jac.shape
    K = np.block([[np.diag(mass), jac.T], [jac, np.zeros((m, m))]])
    gamma_bar = gam - 2.0 * ab[0] * (jac @ qd + psit) - ab[1] ** 2 * psi
    x = np.linalg.solve(K, np.concatenate([Q, gamma_bar]))
    return x[:n], x[n:]


def problem(jac: np.ndarray, rng: np.random.Generator) -> tuple:
    m, n = jac.shape
    mass = rng.uniform(0.5, 3.0, size=n)
    return mass, jac, rng.normal(size=m), rng.normal(size=m), rng.normal(size=m), rng.normal(size=n), rng.normal(size=n)


@pytest.mark.parametrize("bodies", [1, 2, 8, 64])
@pytest.mark.parametrize("closed", [False, True])
@pytest.mark.parametrize("shuffled", [False, True])
@pytest.mark.parametrize("ab", [(0.0, 0.0), (5.0, 7.0)])
@pytest.mark.parametrize("solver", SOLVERS)
def test_range_space_solve_equals_the_augmented_system(bodies, closed, shuffled, ab, solver):
    rng = np.random.default_rng(bodies + 10 * closed + 100 * shuffled)
    jac = chain_jacobian(bodies, closed, rng)
    if closed and bodies == 1:
        jac = jac[:2]  # one body between two grounds: six rows on three coordinates would be dependent
    if shuffled:
        jac = jac[rng.permutation(jac.shape[0])]
    mass, jac, psi, psit, gam, Q, qd = problem(jac, rng)
    ab = np.array(ab)
    qdd, lam = np.full(jac.shape[1], np.nan), np.full(jac.shape[0], np.nan)
    assert SOLVERS[solver](mass, jac, psi, psit, gam, Q, qd, ab, qdd, lam)
    expected_qdd, expected_lam = augmented(mass, jac, psi, psit, gam, Q, qd, ab)
    np.testing.assert_allclose(qdd, expected_qdd, rtol=1e-9, atol=1e-9 * np.max(np.abs(expected_qdd)))
    np.testing.assert_allclose(lam, expected_lam, rtol=1e-9, atol=1e-9 * np.max(np.abs(expected_lam)))


@pytest.mark.parametrize("solver", SOLVERS)
def test_no_constraints_is_newtons_law(solver):
    rng = np.random.default_rng(1)
    mass, jac, psi, psit, gam, Q, qd = problem(np.zeros((0, 6)), rng)
    qdd, lam = np.empty(6), np.empty(0)
    assert SOLVERS[solver](mass, jac, psi, psit, gam, Q, qd, np.zeros(2), qdd, lam)
    np.testing.assert_allclose(qdd, Q / mass, rtol=1e-15)


def _refused(mass, jac, psi, psit, gam, Q, qd, solver=range_space_solve) -> bool:
    qdd, lam = np.full(jac.shape[1], 7.0), np.full(jac.shape[0], 7.0)
    done = solver(mass, jac, psi, psit, gam, Q, qd, np.zeros(2), qdd, lam)
    return not done and np.all(qdd == 7.0) and np.all(lam == 7.0)


@pytest.mark.parametrize("solver", SOLVERS)
def test_dependent_rows_are_handed_to_the_augmented_lu(solver):
    rng = np.random.default_rng(2)
    jac = chain_jacobian(4, False, rng)
    jac = np.vstack([jac, jac[3] + jac[5]])  # a redundant row: Psi_q M^-1 Psi_q^T is singular
    assert _refused(*problem(jac, rng), SOLVERS[solver])


@pytest.mark.parametrize("solver", SOLVERS)
def test_a_body_without_mass_is_handed_to_the_augmented_lu(solver):
    rng = np.random.default_rng(3)
    mass, *rest = problem(chain_jacobian(3, False, rng), rng)
    mass[4] = 0.0
    assert _refused(mass, *rest, SOLVERS[solver])


def test_a_row_with_many_nonzeros_is_handed_to_the_augmented_lu():
    rng = np.random.default_rng(4)
    jac = chain_jacobian(6, False, rng)
    jac[0, : MAX_ROW_ENTRIES + 1] = 1.0  # a row coupling five bodies
    assert _refused(*problem(jac, rng))


# -- the compiled engine on scenes large enough for eq. 5.31, against the numpy engine ----------------------------
@pytest.mark.parametrize("family, size", [("planar", 16), ("loops", 6)])
def test_a_large_planar_scene_agrees_with_the_numpy_engine(family, size):
    """A chain of 16 bars (n + m = 80) and a chain of six four-bar loops (n + m = 75) of ``benchmarks/chains.py``,
    past ``RANGE_SPACE_SIZE``: the compiled run (eq. 5.31) and the numpy run (eq. 5.30 by LU) at rtol = 1e-10 give
    the same q, q', q'' and lambda to 1e-8 of their size; the step counts within 2 % (the two solves round
    differently, and the step-size control sees it)."""
    import sys
    from pathlib import Path

    from solutions.assembly import build_system
    from solutions.compiled.kernels import RANGE_SPACE_SIZE
    from solutions.dynamics import forward_dynamics
    from solutions.io import load_model

    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    from benchmarks.chains import loop_chain, planar_chain

    model = load_model((planar_chain if family == "planar" else loop_chain)(size))
    system, q0, qd0 = build_system(model)
    assert system.n_coordinates + system.n_constraints >= RANGE_SPACE_SIZE
    runs = {
        engine: forward_dynamics(
            system,
            q0,
            qd0,
            0.5,
            50,
            formulation="baumgarte",
            integrator="DOP853",
            engine=engine,
            rtol=1e-10,
            atol=1e-10,
        )  # fmt: skip
        for engine in ("numpy", "compiled")
    }
    assert runs["compiled"].info["chosen"]["engine"] == "compiled"
    for name in ("q", "qd", "qdd", "lam"):
        reference, value = getattr(runs["numpy"], name), getattr(runs["compiled"], name)
        assert np.max(np.abs(reference - value)) <= 1e-8 * np.max(np.abs(reference)), name
    steps = [run.info["integrator_steps"] for run in runs.values()]
    assert abs(steps[0] - steps[1]) <= 0.02 * steps[0], steps


def test_a_wide_envelope_is_narrowed_by_reordering_the_rows():
    """Rows of a chain in random order: Psi_q M^-1 Psi_q^T has an envelope as wide as the matrix; in reverse
    Cuthill-McKee order it is a band again (the order ``range_space_solve`` factors in)."""
    from solutions.compiled.kernels import PROFILE_WIDTH, _profile_order, _range_space_matrix, _reordered, _row_pattern

    rng = np.random.default_rng(5)
    jac = chain_jacobian(64, True, rng)[rng.permutation(130)]
    m, n = jac.shape
    mass = rng.uniform(0.5, 3.0, size=n)
    rows, counts = np.empty((m, MAX_ROW_ENTRIES), np.int64), np.empty(m, np.int64)
    assert _row_pattern(jac, rows, counts)
    S, first = np.zeros((m, m)), np.empty(m, np.int64)
    _range_space_matrix(mass, jac, rows, counts, S, first)
    assert np.sum(np.arange(m) - first) > PROFILE_WIDTH * m
    order = _profile_order(S, first)
    assert sorted(order) == list(range(m))
    P = _reordered(S, order, first)
    assert np.max(np.arange(m) - first) <= 8  # a band: a joint's rows couple with its neighbours' only
    full = np.tril(S) + np.tril(S, -1).T
    np.testing.assert_array_equal(np.tril(full[np.ix_(order, order)]), np.tril(P))


# -- the spatial form: M block-diagonal (eq. 10.4), M^-1 applied body by body -------------------------------------
def spatial_problem(bodies: int, rng: np.random.Generator) -> tuple:
    """A spatial chain's eq. 5.30: M of eq. 10.4's shape (m I and a positive definite 4 x 4 Euler-parameter block per
    body of 7 coordinates), Psi_q with a joint's 5 rows between neighbours (ground to body 0) on both bodies' 14
    columns and each body's normalization row 2 p^T on its own 4; psi, Psi_t, gamma, Q, q' random."""
    n = 7 * bodies
    M = np.zeros((n, n))
    rows = []
    for b in range(bodies):
        o = 7 * b
        M[o : o + 3, o : o + 3] = rng.uniform(0.5, 3.0) * np.eye(3)
        A = rng.normal(size=(4, 4))
        M[o + 3 : o + 7, o + 3 : o + 7] = A @ A.T + 0.1 * np.eye(4)
        joint = np.zeros((5, n))
        joint[:, max(0, o - 7) : o + 7] = rng.normal(size=(5, min(14, o + 7)))
        normalization = np.zeros((1, n))
        normalization[0, o + 3 : o + 7] = 2.0 * rng.normal(size=4)
        rows += [joint, normalization]
    jac = np.vstack(rows)
    m = jac.shape[0]
    return M, jac, rng.normal(size=m), rng.normal(size=m), rng.normal(size=m), rng.normal(size=n), rng.normal(size=n)


def spatial_augmented(M, jac, psi, psit, gam, Q, qd, ab):
    """q'' and lambda of eq. 5.30 with gamma_bar of eq. 5.29 and a full M, by numpy's dense solve."""
    m, n = jac.shape
    K = np.block([[M, jac.T], [jac, np.zeros((m, m))]])
    gamma_bar = gam - 2.0 * ab[0] * (jac @ qd + psit) - ab[1] ** 2 * psi
    x = np.linalg.solve(K, np.concatenate([Q, gamma_bar]))
    return x[:n], x[n:]


@pytest.mark.parametrize("bodies", [1, 2, 8])
@pytest.mark.parametrize("ab", [(0.0, 0.0), (5.0, 7.0)])
def test_spatial_range_space_solve_equals_the_augmented_system(bodies, ab):
    from solutions.compiled.kernels import spatial_range_space_solve

    rng = np.random.default_rng(20 + bodies)
    M, jac, psi, psit, gam, Q, qd = spatial_problem(bodies, rng)
    ab = np.array(ab)
    qdd, lam = np.full(jac.shape[1], np.nan), np.full(jac.shape[0], np.nan)
    assert spatial_range_space_solve(M, jac, psi, psit, gam, Q, qd, ab, qdd, lam)
    expected_qdd, expected_lam = spatial_augmented(M, jac, psi, psit, gam, Q, qd, ab)
    np.testing.assert_allclose(qdd, expected_qdd, rtol=1e-9, atol=1e-9 * np.max(np.abs(expected_qdd)))
    np.testing.assert_allclose(lam, expected_lam, rtol=1e-9, atol=1e-9 * np.max(np.abs(expected_lam)))


@pytest.mark.parametrize("fault", ["dependent rows", "a block without inertia", "a body without mass"])
def test_the_spatial_solve_hands_what_it_cannot_take_to_the_augmented_lu(fault):
    from solutions.compiled.kernels import spatial_range_space_solve

    rng = np.random.default_rng(30)
    M, jac, psi, psit, gam, Q, qd = spatial_problem(3, rng)
    if fault == "dependent rows":  # S = Psi_q M^-1 Psi_q^T singular
        jac = np.vstack([jac, jac[2] - jac[7]])
        psi, psit, gam = (np.append(v, 0.0) for v in (psi, psit, gam))
    elif fault == "a block without inertia":
        M[10:14, 10:14] = 0.0
    else:
        M[7, 7] = 0.0
    qdd, lam = np.full(jac.shape[1], 7.0), np.full(jac.shape[0], 7.0)
    assert not spatial_range_space_solve(M, jac, psi, psit, gam, Q, qd, np.zeros(2), qdd, lam)
    assert np.all(qdd == 7.0) and np.all(lam == 7.0)
