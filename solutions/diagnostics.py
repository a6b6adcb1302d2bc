"""Diagnostics by name: degrees of freedom, redundant constraints, singular configurations.

All of them read the singular value decomposition of the Jacobian, Psi_q = U S V^T (course notes,
eq. 4.20): the numerical rank r counts the independent constraints, n - r is the number of degrees
of freedom, and the left singular vectors of the zero (or tiny) singular values tell which constraint
rows depend on each other, hence which joints are redundant or locked.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from .linalg import RANK_EPS, numerical_rank


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
    """A run left a singular position on another branch than the one it came along (``dynamics.branch_verdict``):
    its velocities jumped there, where the physical motion keeps them continuous."""


@dataclass
class RankReport:
    """What the SVD of Psi_q says about a configuration."""

    n_coordinates: int
    n_constraints: int
    rank: int
    singular_values: np.ndarray | None
    """In decreasing order; None where the rank was decided by structure (``structural_rank``)."""
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
            return float("nan")  # not computed (``structural_rank``)
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


def structural_rank(jacobian: np.ndarray, floor: float) -> RankReport | None:
    """The rank report of a Psi_q of full row rank by structure, whose sigma_min is at least ``floor`` in exact
    arithmetic (``dynamics.revolute_tree_floor``), where that floor decides the rank rule's verdict too
    (``rank_report``: rank m, no redundant joint), else None (the SVD decides).

    The rule counts the singular values above tol = sigma_1 max(m, n) sqrt(eps) (``linalg.rank_tolerance``), and
    sigma_1 <= ||Psi_q||_F. So where floor > 2 ||Psi_q||_F max(m, n) sqrt(eps), every singular value lies above
    twice the tolerance, and the SVD's own rounding (at most a small multiple of max(m, n) eps sigma_1, eps = 2.2e-16:
    ten million times below the tolerance) and the norm's cannot bring one under it: both rules give rank m.
    Where the floor does not clear it (a tree of more than ~500 bodies with 1 m links, or links of ~2 x 10^4 m at 16
    bodies: never in the course's scenes), the SVD decides, as for every other scene. No singular value computed."""
    m, n = jacobian.shape
    if m > n or not floor > 2.0 * np.linalg.norm(jacobian) * max(m, n) * RANK_EPS:
        return None
    return RankReport(n, m, m, None, [])


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
