"""Dense linear solves of the small systems a time step needs, without per-call overhead; and the one rule
that decides the numerical rank of a constraint Jacobian (``numerical_rank``).

A multibody time step solves a few small dense systems (Psi_q of a planar mechanism is 10 x 10; the
augmented matrix of eq. 5.30 20 x 20) thousands of times. LAPACK factors such a matrix in one or two
microseconds, while ``numpy.linalg.solve`` and ``scipy.linalg.lu_factor``/``lu_solve`` spend several
more on checking and converting their arguments. The functions here call the same LAPACK routines
directly (``getrf``, ``getrs``, ``gesv``: LU with partial pivoting, P A = L U) and give the same results.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

_GETRF, _GETRS, _GESV, _POSV, _POTRS = lapack.get_lapack_funcs(
    ("getrf", "getrs", "gesv", "posv", "potrs"), (np.zeros((1, 1)),)
)


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


def cho_solve(factor: tuple[np.ndarray, bool], rhs: np.ndarray) -> np.ndarray:
    """x from A x = rhs with the Cholesky factor of ``scipy.linalg.cho_factor(A)`` (as ``scipy.linalg.cho_solve``
    without its argument checks: the augmented Lagrangian's iterations call it a few times per evaluation)."""
    c, lower = factor
    x, _ = _POTRS(c, rhs, lower=lower)
    return x


RANK_EPS = float(np.sqrt(np.finfo(float).eps))
"""sqrt(machine epsilon), about 1.5e-8: the relative size below which a singular value counts as zero (per row
or column of the matrix, ``rank_tolerance``)."""


def rank_tolerance(largest: float, shape: tuple[int, ...]) -> float:
    """The rank decision of the whole package, stated once (course notes, eq. 4.22):

        sigma_i counts (is nonzero)  when  sigma_i > sigma_1 max(m, n) sqrt(eps)

    for an m x n matrix with largest singular value sigma_1. Relative to sigma_1, the rule does not depend
    on the units or the overall size of the mechanism; the factor max(m, n) follows the rounding error of
    the SVD, which grows with the size of the model (Golub and Van Loan, sec. 5.5.8, use max(m, n) eps); and
    sqrt(eps) instead of eps leaves room for the constraint residual a run carries: a redundant constraint
    gives a singular value of exactly zero on the constraints only, and of the order of |Psi| beside them
    (1e-10 of the mechanism's size and below in a run at the default tolerances). The assembly check,
    ``mbd check``, the svd formulation, the minimum-norm multipliers of the reactions and the implicit
    integrators all decide with it; a configuration closer than this to a rank loss is a singular position
    (``guard.Guard`` and the kinematic analysis report those by name).
    """
    return float(largest) * max(shape, default=1) * RANK_EPS


def numerical_rank(singular_values: np.ndarray, shape: tuple[int, ...]) -> int:
    """The number of singular values (in decreasing order, as numpy gives them) that count (``rank_tolerance``)."""
    s = np.asarray(singular_values)
    if s.size == 0 or not s[0] > 0.0:
        return 0
    return int(np.count_nonzero(s > rank_tolerance(s[0], shape)))


def independent_rows(matrix: np.ndarray) -> np.ndarray:
    """Indices (sorted) of a largest set of linearly independent rows, by the rank rule (``numerical_rank``):
    the pivots of a column-pivoted QR of the transpose, A^T P = Q R (LAPACK geqp3 through scipy)."""
    import scipy.linalg

    if matrix.shape[0] == 0:
        return np.arange(0)
    _, _, pivots = scipy.linalg.qr(matrix.T, mode="economic", pivoting=True)
    rank = numerical_rank(np.linalg.svd(matrix, compute_uv=False), matrix.shape)
    return np.sort(pivots[:rank])


def minimum_norm_solution(matrix: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """x of least norm that minimizes |A x - rhs| with A's rank by the rule (``numerical_rank``): the
    truncated-SVD pseudo-inverse, x = V_1 S_1^-1 U_1^T rhs. Never raises for a rank-deficient A."""
    u, s, vt = np.linalg.svd(matrix, full_matrices=False)
    r = numerical_rank(s, matrix.shape)
    return vt[:r].T @ ((u[:, :r].T @ rhs) / s[:r])


__all__ = [
    "RANK_EPS",
    "cho_solve",
    "cholesky_solve",
    "independent_rows",
    "lu_factor",
    "lu_solve",
    "minimum_norm_solution",
    "numerical_rank",
    "rank_tolerance",
    "solve",
]


def largest(x: np.ndarray) -> float:
    """max |x|, 0 for an empty array (``np.max(np.abs(x), initial=0.0)``, without its dispatch: 1 us, not 4)."""
    return float(np.abs(x).max()) if x.size else 0.0
