"""The direct LAPACK solves (solutions/linalg.py) and the cheap diagnostics built on their factors.

Each is compared with an independent computation: numpy's and scipy's own solvers, the product of the
factors, and the sign of the determinant by numpy.linalg.det.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from solutions.kinematics import determinant_sign
from solutions.linalg import cholesky_solve, lu_factor, lu_solve, solve


@pytest.mark.parametrize("n", [1, 3, 9, 20])
def test_lu_factors_reproduce_the_matrix_and_solve_it(n):
    rng = np.random.default_rng(n)
    A = rng.standard_normal((n, n))
    b = rng.standard_normal(n)
    factors, pivots = lu_factor(A)
    L = np.tril(factors, -1) + np.eye(n)
    U = np.triu(factors)
    PA = A.copy()
    for k, p in enumerate(pivots):  # LAPACK's row interchanges, in order
        PA[[k, p]] = PA[[p, k]]
    np.testing.assert_allclose(L @ U, PA, atol=1e-12)
    np.testing.assert_allclose(lu_solve((factors, pivots), b), np.linalg.solve(A, b), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(A @ solve(A, b), b, atol=1e-10)
    B = rng.standard_normal((n, 3))
    np.testing.assert_allclose(solve(A, B), scipy.linalg.solve(A, B), rtol=1e-10, atol=1e-12)


def test_factors_of_scipy_and_of_lu_factor_are_interchangeable():
    rng = np.random.default_rng(1)
    A, b = rng.standard_normal((6, 6)), rng.standard_normal(6)
    np.testing.assert_allclose(lu_solve(scipy.linalg.lu_factor(A), b), np.linalg.solve(A, b), rtol=1e-10)


def test_a_singular_matrix_is_refused_as_numpy_does():
    A = np.array([[1.0, 2.0], [2.0, 4.0]])
    with pytest.raises(np.linalg.LinAlgError):
        solve(A, np.ones(2))
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.solve(A, np.ones(2))


def test_determinant_sign_from_the_factors_agrees_with_det():
    rng = np.random.default_rng(7)
    signs = set()
    for _ in range(200):
        A = rng.standard_normal((5, 5))
        expected = np.sign(np.linalg.det(A))
        assert determinant_sign(lu_factor(A)) == expected
        signs.add(expected)
    assert signs == {-1.0, 1.0}  # both signs were met


def test_cholesky_solve_agrees_with_numpy_and_refuses_an_indefinite_matrix():
    rng = np.random.default_rng(4)
    B = rng.standard_normal((5, 5))
    A, b = B @ B.T + 5 * np.eye(5), rng.standard_normal(5)
    np.testing.assert_allclose(cholesky_solve(A, b), np.linalg.solve(A, b), rtol=1e-10, atol=1e-12)
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        cholesky_solve(np.diag([1.0, -1.0]), np.ones(2))
