# Generated from solutions/diagnostics.py by `make modules` (every homework stubbed): do not edit by hand.
"""Diagnostics by name: degrees of freedom, redundant constraints, singular configurations.

All of them read the singular value decomposition of the Jacobian, Psi_q = U S V^T (course notes,
eq. 4.20): the numerical rank r counts the independent constraints, n - r is the number of degrees
of freedom, and the left singular vectors of the zero (or tiny) singular values tell which constraint
rows depend on each other, hence which joints are redundant or locked.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.linalg import lapack

from .linalg import RANK_EPS, numerical_rank

if TYPE_CHECKING:
    from .assembly import System


class AnalysisError(RuntimeError):
    """An analysis that cannot go on, with a message that says why and what to do."""


def setting_words(name: str, value, option_value: str | None = None) -> str:
    """A setting as a message names it for both of its readers, the API's keyword and the command line's option:
    ``setting_words("singular_ratio", None, "0")`` is 'singular_ratio=None (mbd run --singular-ratio 0)', a flag
    ``setting_words("through_singular", True)`` 'through_singular=True (mbd run --through-singular)'.
    ``command_line_words`` keeps the option alone in what the command line prints."""
    option = "--" + name.replace("_", "-")
    given = option if value is True else f"{option} {value if option_value is None else option_value}"
    return f"{name}={value!r} (mbd run {given})"


SETTING_WORDS = re.compile(r"\b[a-z_]+=\S+ \(mbd run (--[^()]*)\)")
"""A setting in both spellings, as ``setting_words`` writes it; group 1 is the command line's."""


def command_line_words(message: str) -> str:
    """A message in the command line's words: each setting ``setting_words`` named in both spellings by its option
    alone ('--singular-ratio 0 runs on regardless', not 'singular_ratio=None (mbd run --singular-ratio 0) ...')."""
    return SETTING_WORDS.sub(r"\1", message)


class SingularConfigurationError(AnalysisError):
    """A run stopped at a singular configuration of Psi_q (``formulation="auto"`` then takes a formulation
    that passes it: the augmented Lagrangian one); ``t`` is the time it stopped at, when known."""

    def __init__(self, message: str, t: float | None = None):
        super().__init__(message)
        self.t = t


class BranchSwitchError(SingularConfigurationError):
    """A run left a singular position on another branch than the one it came along (``guard.branch_verdict``):
    its velocities jumped there, where the physical motion keeps them continuous."""


@dataclass
class RankReport:
    """What the SVD of Psi_q says about a configuration."""

    n_coordinates: int
    n_constraints: int
    rank: int
    singular_values: np.ndarray | None
    """In decreasing order; None where the rank was certified without them (``full_row_rank``)."""
    redundant_joints: list[str]

    @property
    def degrees_of_freedom(self) -> int:
        return self.n_coordinates - self.rank

    @property
    def n_redundant(self) -> int:
        return self.n_constraints - self.rank

    @property
    def condition_number(self) -> float:
        s = self.singular_values
        if s is None:
            return float("nan")  # not computed (``full_row_rank``)
        return float(s[0] / s[-1]) if s.size and s[-1] > 0 else float("inf")


def involved_joints(vectors: np.ndarray, row_owner: list[str], share: float = 1e-6) -> list[str]:
    """Joints whose rows carry a visible share of the given left singular vectors (columns)."""
    weight = np.sqrt(np.sum(vectors**2, axis=1)) if vectors.ndim == 2 else np.abs(vectors)
    names: list[str] = []
    for row in np.flatnonzero(weight > share * max(weight.max(initial=0.0), 1e-300)):
        if row_owner[row] not in names:
            names.append(row_owner[row])
    return names


def rank_report(jacobian: np.ndarray, row_owner: list[str], rtol: float | None = None) -> RankReport:
    """Numerical rank of Psi_q and the redundant joints.

    The rank is decided by the package's one rule (``linalg.rank_tolerance``: singular values above
    sigma_1 max(m, n) sqrt(eps)); ``rtol`` replaces the relative threshold max(m, n) sqrt(eps) when given.
    The singular values alone first (2-3x cheaper than the whole SVD); the left singular vectors of the
    redundant rows, which name the joints, only where rows are redundant.
    """
    m, n = jacobian.shape
    s = np.linalg.svd(jacobian, compute_uv=False)
    if rtol is None:
        rank = numerical_rank(s, jacobian.shape)
    else:
        rank = int(np.sum(s > rtol * s[0])) if s.size and s[0] > 0 else 0
    redundant = involved_joints(np.linalg.svd(jacobian)[0][:, rank:], row_owner) if m > rank else []
    padded = np.concatenate([s, np.zeros(max(0, min(m, n) - s.size))])
    return RankReport(n, m, rank, padded, redundant)


def full_row_rank(jacobian: np.ndarray) -> RankReport | None:
    """The rank report of a Psi_q (m x n) whose rank the rule of ``rank_report`` puts at m, certified without its
    SVD, or None where the certificate does not hold (the SVD decides: redundant rows, a configuration near a
    singular one, m > n).

    The certificate: sigma_min(Psi_q)^2 = lambda_min(Psi_q Psi_q^T), and a symmetric matrix is positive definite
    exactly where its Cholesky factorization exists, so Cholesky of G - tau^2 I, G = Psi_q Psi_q^T, succeeds only
    where sigma_min > tau -- up to rounding: forming G errs by at most n eps ||Psi_q||_F^2 (in the 2-norm), and a
    Cholesky that succeeds is exact for a matrix within (m + 1) m eps ||G|| (Higham, Accuracy and Stability of
    Numerical Algorithms, thm. 10.3); together at most 2 (n + m^2 + m) eps ||Psi_q||_F^2, eps = 2.2e-16. The rule
    counts the singular values above tol = sigma_1 max(m, n) sqrt(eps) (``linalg.rank_tolerance``), and sigma_1 <=
    ||Psi_q||_F. With tau^2 = 10 max(m, n)^2 eps ||Psi_q||_F^2 a Cholesky that succeeds proves sigma_min^2 >=
    tau^2 - 2 (n + m^2 + m) eps ||Psi_q||_F^2 >= 4 max(m, n)^2 eps ||Psi_q||_F^2 >= (2 tol)^2 (m <= n): every
    singular value lies above twice the tolerance, and the SVD's own rounding (a small multiple of max(m, n) eps
    sigma_1, ten million times below tol) cannot bring one under it. Both rules give rank m: the verdict is the
    SVD's, on the same matrix. A Cholesky of m x m costs a fifth of the singular values of m x n (loop chain
    N = 4: 12 against 36 us; N = 16: 75 against 400); LAPACK's own (``dpotrf``), whose info says whether it
    succeeded, without numpy's checks around it (a few us, each numpy call dearer at a call's start). No singular
    value is computed."""
    m, n = jacobian.shape
    if m > n:
        return None
    shifted = jacobian @ jacobian.T  # G; its trace is ||Psi_q||_F^2
    frobenius2 = float(shifted.trace())
    if not math.isfinite(frobenius2) or frobenius2 == 0.0:
        return None
    shifted.flat[:: m + 1] -= 10.0 * max(m, n) ** 2 * RANK_EPS**2 * frobenius2  # G - tau^2 I
    if lapack.dpotrf(shifted, overwrite_a=True)[1] != 0:  # LAPACK's Cholesky: not positive definite, sigma_min <= tau
        return None
    return RankReport(n, m, m, None, [])


def rank_at(system: System, q: np.ndarray, jacobian: np.ndarray | None = None) -> RankReport | None:
    """``rank_report`` of Psi_q at q (the singular values of the whole Jacobian), or None without constraints:
    made once per run at its start (``Start.rank``) and handed to the method's choice, the redundancy checks, the
    Guard and the divergence check. Where Psi_q has full row rank with a margin, a shifted Cholesky factorization
    certifies the rule's verdict without the SVD (``full_row_rank``: a fifth of its cost). ``jacobian``: Psi_q at q
    where the caller made it already (the run's start, ``dynamics.consistent_start``)."""
    if not system.n_constraints:
        return None
    if jacobian is None:
        jacobian = system.jacobian(q, 0.0)
    return full_row_rank(jacobian) or rank_report(jacobian, system.row_owners)


def singular_joints(jacobian: np.ndarray, row_owner: list[str]) -> tuple[float, list[str]]:
    """Condition number of Psi_q and the joints in its weakest direction (for lock-up reports)."""
    u, s, _ = np.linalg.svd(jacobian)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else float("inf")
    if jacobian.shape[0] > s.size:  # more rows than columns: include the whole left null space
        return cond, involved_joints(u[:, s.size - 1 :], row_owner, share=0.1)
    return cond, involved_joints(u[:, -1], row_owner, share=0.1)


NEAR_SINGULAR = 0.1
"""Largest sigma_min / sigma_max (or min / max |pivot|) that ``passes_zero`` takes for a singular position."""


def passes_zero(before: float, middle: float, after: float) -> bool:
    """Whether three samples of a measure of rank, r = sigma_min / sigma_max at three steps, show that it went
    through zero near the middle step: a local minimum below NEAR_SINGULAR whose value is less than the change
    to a neighbour (r falls to zero along a V, |t - t*|, at a transversal crossing; a smooth minimum away from
    zero changes by much less than its value over a step)."""
    return middle < NEAR_SINGULAR and middle <= min(before, after) and middle < max(before - middle, after - middle)
