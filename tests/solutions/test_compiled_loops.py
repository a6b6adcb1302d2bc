"""The compiled integration loops (solutions/compiled/loops.py) against the numpy loops and a closed form.

A system of damped oscillators, q_i'' = -w_i^2 q_i - c_i q_i', whose right-hand side is the same elementwise
arithmetic in numpy and in numba (no sums: the two engines' evaluations agree to the last bit), so that what differs
between the runs is the loops alone. Its exact solution is exp(M t) y0 (scipy's expm). With 2 oscillators the state
has 4 components and with 5 it has 10: the loops' sums over the stages take their small-state and their large-state
branch (``loops._weighted_sum``).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from solutions.integrators import integrate

pytest.importorskip("numba")

from solutions.compiled import tableau  # noqa: E402

from ..conftest import LazyModule  # noqa: E402

loops = LazyModule("solutions.compiled.loops")  # compiled where a test first needs it (conftest.LazyModule)

T_OUT = np.linspace(0.0, 2.0, 41)
TOL = 1e-8


def oscillators(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """w^2, c and the initial state (q, q') of n oscillators."""
    w2 = (2.0 + np.arange(n)) ** 2
    c = 0.1 * (1.0 + np.arange(n))
    return w2, c, np.concatenate([np.linspace(1.0, 0.2, n), np.linspace(-0.5, 0.5, n)])


@pytest.fixture(scope="module")
def compiled_rhs():
    """The oscillators' right-hand side with the loops' signature: w^2 in P[4], c in P[7]."""
    from numba import njit

    @njit(loops.RHS_SIGNATURE, cache=False)
    def rhs(t, z, P, D, out):
        n = z.size // 2
        w2, c = P[4], P[7]
        for i in range(n):
            out[i] = z[n + i]
            out[n + i] = -w2[i] * z[i] - c[i] * z[n + i]

    return loops.first_class(rhs, loops.RHS_SIGNATURE), loops.first_class(loops.no_projection, loops.PROJECT_SIGNATURE)


def packed(w2: np.ndarray, c: np.ndarray) -> tuple[tuple, tuple]:
    """P and D of the loops' types, holding only what the oscillators' right-hand side reads."""
    e1, e2 = np.zeros(1), np.zeros((1, 1))
    P = (e1, e1, e1, np.zeros((1, 1, 1)), w2, np.zeros(1, np.int64), e2, c, np.zeros(1, np.int64))
    return P, (np.zeros((1, 1), np.int64), e2, np.zeros(1, np.int64))


def numpy_run(w2, c, y0, method: str, **options):
    """The numpy loop's states at T_OUT and its statistics, on the same arithmetic of the right-hand side."""
    n = w2.size
    Y = np.empty((T_OUT.size, y0.size))

    def f(t, y):
        return np.concatenate([y[n:], -w2 * y[:n] - c * y[n:]])

    def record(k, t, y):
        Y[k] = y

    stats = integrate(f, y0, T_OUT, record, method, stiffness="off", **options)
    return Y, stats


def exact(w2, c, y0) -> np.ndarray:
    """exp(M t) y0 at T_OUT, M = [[0, I], [-diag(w^2), -diag(c)]]."""
    n = w2.size
    M = np.block([[np.zeros((n, n)), np.eye(n)], [-np.diag(w2), -np.diag(c)]])
    return np.array([expm(M * t) @ y0 for t in T_OUT])


@pytest.mark.parametrize("n", [2, 5])
@pytest.mark.parametrize("method", ["dop853", "rk45", "DOP853", "RK45"])
def test_the_embedded_loop_takes_the_numpy_loops_steps(compiled_rhs, n, method):
    """The same steps, rejected steps (where the numpy loop counts them) and evaluations as the numpy loop (this
    package's own, or scipy's solvers as ``integrators`` drives them), states at the output times within rounding
    of it (the sums over the stages are added in another order), and both within the tolerance's reach of the exact
    solution."""
    rhs, project = compiled_rhs
    w2, c, y0 = oscillators(n)
    P, D = packed(w2, c)
    dop = method.lower() == "dop853"
    Y, evaluations, steps, rejected, status, t, _, reached = loops.embedded(
        rhs, project, y0, T_OUT, TOL, TOL, np.inf, 10**9, dop, method.isupper(), tableau(dop), P, D, T_OUT[-1], 0.0,
        10**9,
    )  # fmt: skip
    expected, stats = numpy_run(w2, c, y0, method, rtol=TOL, atol=TOL)
    assert (status, reached, t) == (0, T_OUT.size, T_OUT[-1])
    assert (steps, evaluations) == (stats.steps, stats.rhs_evaluations)
    if method.islower():  # scipy's solvers do not tell ``integrators`` of the steps they rejected
        assert rejected == stats.rejected
    assert np.allclose(Y, expected, rtol=0.0, atol=1e-13)
    assert np.allclose(Y, exact(w2, c, y0), rtol=0.0, atol=1e-6)


@pytest.mark.parametrize("n", [2, 5])
def test_rk4_gives_the_numpy_loops_numbers(compiled_rhs, n):
    """RK4 (eq. 6.12) computes numpy's elementwise expressions in numpy's order: the states to the last bit; and
    its error at a step of 1e-3 is the method's (4th order: C h^4, here below 1e-9)."""
    rhs, project = compiled_rhs
    w2, c, y0 = oscillators(n)
    P, D = packed(w2, c)
    Y, evaluations, steps, _, status, _, _, reached = loops.rk4(rhs, project, y0, T_OUT, 1e-3, P, D)
    expected, stats = numpy_run(w2, c, y0, "rk4", step=1e-3)
    assert (status, reached, steps, evaluations) == (0, T_OUT.size, stats.steps, stats.rhs_evaluations)
    assert np.array_equal(Y, expected)
    assert np.allclose(Y, exact(w2, c, y0), rtol=0.0, atol=1e-9)
