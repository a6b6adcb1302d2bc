"""Dense linear solves of the small systems a time step needs, without per-call overhead.

A multibody time step solves a few small dense systems (Psi_q of a planar mechanism is 10 x 10; the
augmented matrix of eq. 5.30 20 x 20) thousands of times. LAPACK factors such a matrix in one or two
microseconds, while ``numpy.linalg.solve`` and ``scipy.linalg.lu_factor``/``lu_solve`` spend several
more on checking and converting their arguments. The functions here call the same LAPACK routines
directly (``getrf``, ``getrs``, ``gesv``: LU with partial pivoting, P A = L U) and give the same results.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

_GETRF, _GETRS, _GESV, _POSV = lapack.get_lapack_funcs(("getrf", "getrs", "gesv", "posv"), (np.zeros((1, 1)),))


def lu_factor(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """P A = L U with partial pivoting: (factors, pivots), as ``scipy.linalg.lu_factor`` returns them.

    A singular matrix gives a zero on U's diagonal and no warning: the caller tests the diagonal.
    """
    factors, pivots, _ = _GETRF(matrix)
    return factors, pivots


def lu_solve(lu: tuple[np.ndarray, np.ndarray], rhs: np.ndarray) -> np.ndarray:
    """x from A x = rhs with the factors of ``lu_factor`` (as ``scipy.linalg.lu_solve``)."""
    x, _ = _GETRS(*lu, rhs)
    return x


def solve(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """x from A x = rhs (a vector or the columns of a matrix), as ``numpy.linalg.solve``.

    Raises
    ------
    numpy.linalg.LinAlgError
        If A is singular (an exact zero pivot), as numpy.linalg.solve does.
    """
    _, _, x, info = _GESV(matrix, rhs)
    if info > 0:
        raise np.linalg.LinAlgError("Singular matrix")
    return x


def cholesky_solve(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """x from A x = rhs for a symmetric positive definite A (Cholesky factor and solve, ``posv``).

    Raises
    ------
    numpy.linalg.LinAlgError
        If A is not positive definite.
    """
    _, x, info = _POSV(matrix, rhs)
    if info != 0:
        raise np.linalg.LinAlgError(f"not positive definite (LAPACK posv info {info})")
    return x


__all__ = ["cholesky_solve", "lu_factor", "lu_solve", "solve"]
