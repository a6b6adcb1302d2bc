"""The Guard's singularity test at the output times of a large mechanism, from the band of Psi_q (issue 25).

``guard.Guard.check_outputs`` needs, at every output time of a compiled run, three things of the scaled
Jacobian Psi_q (m x n, full row rank m at the start):

- the ratio sigma_m / sigma_1 of its smallest and largest singular values (how near a rank loss it is);
- an orthonormal basis T (n x d, d = n - m) of its null space (the directions the mechanism can move in);
- the sign of det [Psi_q; T^T] (the test function whose flip between two times says that a rank loss lies
  between them).

Dense, they cost an SVD and a QR of Psi_q at every output time: O(m^2 n) each, on a chain of 32 parallelogram
loops (194 x 195) 326 ms for 101 times against the integration's 35 ms. But Psi_q is sparse: each row holds the
columns of one or two bodies. Ordered by reverse Cuthill-McKee (``band_order``: George and Liu, Computer
Solution of Large Sparse Positive Definite Systems, 1981, ch. 4), the columns of bodies that share a joint lie
close together, and so do the rows; with d empty rows slotted in where the rows do not reach, the square
matrix [Psi_q; 0] is a band whose half-widths kl, ku do not grow with the number of bodies on a chain. Then:

- sigma_1 and sigma_m, as the extreme eigenvalues of G = Psi_q Psi_q^T, itself a band (half-width w) with the
  rows in the same order: each is bracketed, from above or below by a Cholesky test (a Sturm count: G - s I or
  s I - G positive definite, O(m w^2)), from the other side by the Rayleigh quotient of inverse iteration shifted
  to the bracket's end (O(m w) a step; from the eigenvector of the output time before, the figures closed to
  1e-13 in a few tests: ``_largest``, ``_smallest``). sigma_m's figure is |Psi_q^T x| of the converged x, not
  x^T G x: no squaring of the condition number, the dense SVD's accuracy (Parlett, The Symmetric Eigenvalue
  Problem, 1998, ch. 4 and 11). G's rounding, eps sigma_1^2, bounds what a Cholesky test can certify of sigma_m^2:
  within about 1e-5 of a rank loss the exact route takes over. There LAPACK's dgbbrd reduces the band to
  bidiagonal form B by Givens rotations, O(n^2 (kl + ku)) (Kaufman, "Band reduction algorithms revisited", ACM
  TOMS 26, 2000); the singular values of B are the positive eigenvalues of its Golub-Kahan form, the 2n x 2n
  tridiagonal with zero diagonal and off-diagonal (b_11, b_12, b_22, b_23, ...), of which bisection on Sturm
  counts (dstebz) finds the two wanted ones to high relative accuracy (Demmel and Kahan, SIAM J. Sci. Stat.
  Comput. 11, 1990). [Psi_q; 0] has Psi_q's singular values and d zeros. On a chain of 16 loops (98 x 99) the
  iterated figures cost 0.1 ms an output time, the reduction 0.36 ms; on 64 loops 0.3-0.4 ms against 2.9 ms.
- most of those figures need not be closed (``settled``, issue 25): the Guard compares each ratio with thresholds
  (NEAR_SINGULAR, singular_ratio) and with its neighbours' (dips, falls, which of two is smaller) and reports the
  smallest and a crossing's. Given its tests (``settle``), ``spectra`` first puts every ratio in a bracket about
  LOOSE = 1e-4 wide with one or two Cholesky tests per eigenvalue, from eigenvectors extrapolated from the two times
  before (``_bracketed_ratio``), and closes it only at the times where a test could go the other way within the
  bracket or whose figure is reported: on the loop chain 0-3 of 101 times; 2-3 tests a time where closing took 8-9
  tests and 14 solves. The verdicts are those of the closed figures, the figures reported the same to ~1e-14.
  Many times need no test at all (a run that stops at singular positions): by Weyl's inequality each singular value
  moves by at most |J_k - J_k-1|_2 over a step, a bound ``_scale`` makes anyway, so the time before's bracket,
  widened by it (``_carried``: 1.5-2.2 times wide on the loop chain of 2-8 loops), holds the ratio; it is kept
  where it still decides the tests (``_carries``: above the smallest so far, off the thresholds, no dip), on the
  loop chain at 37-43 of 101 times from N = 2 to 4. Such a bracket overlaps its neighbours': their order, which
  ``check_branches`` reads at the few steps it judges, is worked out there (``Brackets``).
- null space and sign: with d unit rows E^T in the empty slots (``e_c`` for the d coordinates in which the null
  space of the time before is largest, the independent coordinates of coordinate partitioning, eq. 5.40), the
  square band A = [Psi_q; E^T] is factored by the banded LU with partial pivoting (LAPACK's dgbtf2 steps written
  out, ``_band_lu``: O(n kl (kl + ku))); then T_0 = A^-1 [0; I_d] (``_band_solve``) spans the null space
  (Psi_q T_0 = 0, E^T T_0 = I), T = T_0 S^-1 by Gram-Schmidt with S's diagonal positive, and det [Psi_q; T^T] =
  det S det A, so its sign is that of det A: the product of U's diagonal, the pivots' swaps and the two orderings'
  parities. (Proof: with W = A^-1 [I_m; 0], [Psi_q; T^T] [W T_0] = [[I, 0], [T^T W, S]] and det [W T_0] =
  1 / det A.)
- most steps need neither (``certified``, issue 25): the Guard reads T and the sign only to see a flip between two
  times, and by Weyl's inequality none can lie on a step over which Psi_q moves by less than sigma_m (its bracket
  gives that bound). Given the Guard's tests, ``spectra`` makes T only at the first and last times and at both ends
  of a step it cannot certify so: on the loop chain of 2-16 loops at no other time (the pass over the output
  times 0.3 shorter).

Any orthonormal basis serves the Guard (``guard.null_space_bases``): a different E gives T R with R
orthogonal, which multiplies det [Psi_q; T^T] and the turn det(T_prev^T T) by the same det R = +-1.

``spectra`` returns, for a stack of scaled Jacobians (N, m, n), the ratios (N,), the bases (N, n, d) and the
signs (N,) (given Psi_q and the column weights and row norms instead, it scales each output time's Psi_q on its
pattern as it goes, no scaled copy of the history, and given the pattern too, ``history_norms``, it reads the
history only there: the band's ordering is kept per pattern, ``_band_structure``); ``dense_spectra`` the same for
a small Psi_q that is no band, from a QR and one-sided Jacobi. A time where a factorization fails (a zero
pivot: Psi_q singular to the last bit at an output time) gets NaN there, and the Guard computes that time densely.
No numba in the numpy engine: this module is imported by compiled runs only (``guard.square_spectra``, from
``Guard.check_outputs``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, types

from .history import BlockedJacobians, block_slots
from .lapack import PIVOT_TYPE, lapack

_GBBRD, _STEBZ = lapack("dgbbrd", 18), lapack("dstebz", 18)
_GBTRF = lapack("dgbtrf", 8)
"""LAPACK's dgbbrd(vect, m, n, ncc, kl, ku, ab, ldab, d, e, q, ldq, pt, ldpt, c, ldc, work, info), dstebz(range,
order, n, vl, vu, il, iu, abstol, d, e, m, nsplit, w, iblock, isplit, work, iwork, info), dgbtrf(m, n, kl, ku, ab,
ldab, ipiv, info) (``_first_basis``'s n x m band, once a history): Fortran calls, every argument
by address (``lapack.lapack``)."""

WIDEST = 8
"""The band pays where its width kl + ku + 1 is at most an eighth of the coordinates (``spectra``: None otherwise)."""
WIDEST_MID = 2
"""``widest`` for a Psi_q of fewer than ``guard.BAND_SMALLEST`` coordinates: there a band up to half the
coordinates wide pays, for the compiled pass has none of numpy's per-matrix overhead (101 Psi_q, thread CPU, band /
numpy's batched SVDs and QRs: the loop chain's, 6-7 wide, 1.2 / 1.7 ms at 14 x 15, 2.1 / 4.2 at 26 x 27, 4.1 / 14.1
at 50 x 51; the carriage pendulum's 12 x 14, 5 wide, 0.67 / 1.30), where a wider one does not (random sparse Psi_q
of bands 0.7-1.0 n wide: 4.3 / 3.5 at 20 x 24, 19 / 13 at 40 x 45, 48 / 25 at 55 x 60; ``benchmarks/guard_cost.py
--routes``)."""

WIDEST_SQUARE = 0.5
"""``widest`` for a square Psi_q (m = n, d = 0: the sign of det Psi_q and the ratio alone) of more than
``guard.DENSE_LARGEST`` rows and fewer than ``guard.BAND_SMALLEST`` coordinates whose ratios are settled by
the Guard's tests (``settled``): any width, even a full matrix (101 Psi_q of the course's driven mechanisms, thread
CPU, bracketed Gram route / numpy's batched SVDs and QRs: the quick-return 12 x 12 0.43 / 1.26 ms, the six-bar
15 x 15 0.61 / 1.85, the spatial slider-crank 21 x 21, no band, 1.21 / 3.27)."""

BRACKETED_SMALLEST = 6
"""Rows from which ``dense_spectra`` brackets the ratios the Guard's tests settle (``_dense_bracketed``): below,
Jacobi's few sweeps of an m x m R cost less than a bracket's Gram matrix and Cholesky tests (101 Psi_q of the
course models, thread CPU, bracketed / Jacobi: 2 x 3 to 5 x 7 1.3-3.7 times the time; 6 x 6 to 9 x 9 0.5-1.4,
``benchmarks/guard_cost.py --small``)."""

_vector, _ivector, _matrix = types.float64[::1], types.int64[::1], types.float64[:, ::1]
_stack = types.float64[:, :, ::1]
_PATTERN = (_ivector, _vector, _ivector, _ivector, _ivector)  # position, keys, starts, indices, slots
_SPECTRA = types.Tuple((_vector, _stack, _vector, _vector, _stack, types.boolean[::1]))(
    _stack, _vector, _matrix, *_PATTERN, _matrix, types.float64, types.boolean, _vector
)
_AT = _vector(_stack, _vector, _matrix, _ivector, _vector, _ivector, _ivector, _ivector, _stack, _stack, _ivector)
_SETTLED_SPECTRA = types.Tuple((_vector, _stack, _vector, types.boolean[::1], _vector, _stack))(
    _stack, _vector, _matrix, *_PATTERN, _matrix, _vector, types.float64, types.boolean
)
_SETTLED = types.boolean[::1](_vector, _vector, _vector, _vector, types.float64, types.boolean)
_DENSE = types.Tuple((_vector, _stack, _vector))(_stack, _vector, _matrix, types.boolean)
_BRACKETED = types.Tuple((_vector, _stack, _vector, _vector))(_stack, _vector, _matrix, types.boolean, types.float64)
_CLOSED = _vector(_stack, _vector, _matrix, _ivector)
"""Signatures compiled at import (and cached on disk, ``precompile``), but ``AT_FIRST_CALL``'s: after ``mbd compile``
a run never waits for them."""
_imatrix = types.int64[:, ::1]
AT_FIRST_CALL = {
    "_spectra": _SPECTRA.args,
    "_ratios_at": _AT.args,
    "_settled_spectra": _SETTLED_SPECTRA.args,
    "_band_start": (_stack, _ivector, _vector, _vector, _ivector, _vector, _ivector, _ivector, _matrix, types.float64),
    "_entry_slots": (_imatrix, _ivector, _ivector),
    "_reached_norms": (_stack, _vector, _imatrix, _imatrix),
    "unmade": (_vector, _vector, _stack, types.boolean[::1]),
    "quiet": (types.float64, _vector, _vector, types.float64, _vector, types.float64, types.float64),
}
"""The band route's functions (its two passes, ``_settled_spectra``, which calls them under the Guard's tests, and
those the Guard calls from Python on a band), compiled (or loaded from disk) where first called, not at import: only a
Psi_q of at least ``guard.BAND_SMALLEST`` coordinates, or a mid-size one narrow enough (``WIDEST_MID``), takes them,
and a small closed loop's Guard, which takes the dense route (``dense_spectra``), paid for them at its first run on a
new machine (the slider-crank's first run in joint
coordinates: ``singular`` 34.5 -> 17.5 s, the run 89.5 -> 75.2 s of thread CPU; i29-compile's section of
``benchmarks/results/call_cost.md``). ``mbd compile`` compiles them for these argument types (``precompile``); a run's
calls have exactly these types, so no run compiles another version of them. Argument types alone, no return type:
numba's disk cache files a version under the signature it was compiled for, and a call looks it up by its arguments'
types (with ``_spectra``'s full signature, ``mbd compile``'s version was never found: each machine's first band run
compiled it again, ~15 s)."""

MOVING = 3.0
"""Until a first bracket settles apart from its neighbour's, ``_dense_bracketed`` brackets a ratio only where the
two figures before it differ by more than this many brackets' relative widths (LOOSE): nearer, the brackets of
neighbouring times overlap and ``settled`` closes both (models that start from rest or keep a constant ratio paid
brackets and Jacobi, 1.1-1.4 times Jacobi alone, session 22)."""


def band_order(pattern: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(columns, keys) of a band ordering of a sparsity pattern (m, n), m <= n: the columns in reverse
    Cuthill-McKee order of the graph where two columns are adjacent when a row holds both, and each row's key,
    the mean position of its columns in that order, which places it along the diagonal of the square n x n band
    (``_layout``: with the unit rows of E at their column's position)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import reverse_cuthill_mckee

    boolean = np.asarray(pattern, dtype=bool)
    adjacency = csr_matrix(boolean.T.astype(float) @ boolean.astype(float))
    columns = np.asarray(reverse_cuthill_mckee(adjacency, symmetric_mode=True), dtype=np.int64)
    position = np.empty(columns.size, dtype=np.int64)
    position[columns] = np.arange(columns.size)
    keys = np.array([position[np.flatnonzero(row)].mean() if row.any() else 0.0 for row in boolean])
    return columns, keys


def spectra(
    scaled: np.ndarray, first: np.ndarray | None, columns=None, norms=None, pattern=None, widest=WIDEST, settle=None
):
    """(sigma_m / sigma_1 (N,), null-space bases (N, n, d), signs of det [Psi_q; T^T] (N,), the steps certified
    to hold no flip of that sign (N - 1,), ``certified``) of each scaled Psi_q (N, m, n) of full row rank, from the
    band (module docstring); None where the ordered Psi_q is not a band
    at most n / ``widest`` wide (an eighth of n, ``WIDEST``; half of n at mid sizes, ``WIDEST_MID``). ``first``
    (n, d): a null-space basis at (or just before) the first time, which picks its independent coordinates (None:
    from the band, ``_first_basis``). NaN at a time where LAPACK failed.
    With ``columns`` (n,) and ``norms`` (N, m) (``row_norms``), ``scaled`` is Psi_q itself, scaled here entry by
    entry of its pattern (no scaled copy of the whole history: on a chain of 64 loops it is 121 MB); ``pattern``
    (m, n): where any of them is nonzero, if known (``history_norms``), else found here by a pass over the history.
    ``settle`` (thresholds, fall[, ends]), the Guard's tests of the ratios (``settled``; ``ends``: the first two and
    last two times closed too, which a run ``through`` singular positions compares with the batches of output times
    before and after, ``Guard._record``): each ratio first in a bracket of
    relative width about LOOSE (one Cholesky test a bound, ``_bracketed_ratio``), then closed to EXTREME_TOLERANCE
    only at the times where a test of the Guard could go the other way within it or whose figure it reports (the
    smallest, a dip), and the bases and signs made only at the first and last times and at both ends of each step
    that ``certified`` leaves open (elsewhere NaN, and the signs carried over from the time before: ``_spectra``),
    and a fifth item, the ``Brackets`` whose order ``check_branches`` reads (None with ``ends``: every two
    neighbours ordered in the pass); None: every ratio closed, every basis made, no step certified."""
    if columns is None:
        columns, norms = np.ones(scaled.shape[2]), np.ones(scaled.shape[:2])
        pattern = np.any(scaled != 0.0, axis=0)
    elif pattern is None and isinstance(scaled, BlockedJacobians):
        pattern = scaled.pattern()
    elif pattern is None:
        pattern = _pattern(np.ascontiguousarray(scaled, dtype=float))
    structure = _band_structure(pattern)  # position, keys, starts, indices
    scale = (np.ascontiguousarray(columns, dtype=float), np.ascontiguousarray(norms, dtype=float))
    given = np.empty((0, 0)) if first is None else np.ascontiguousarray(first, dtype=float)
    position, keys, starts, indices = structure
    stored, slots = scaled, indices
    if isinstance(scaled, BlockedJacobians):  # its blocks: each pattern entry's slot in its row
        stored, slots = scaled.values, _entry_slots(scaled.columns, starts, indices)
    stored = np.ascontiguousarray(stored)
    at_first = (stored, slots, scale[0], scale[1][0], *structure)
    first, found = _band_start(*at_first, given, float(widest))
    if found == NOT_A_BAND:  # dense costs less
        return None
    if found == FIRST_FAILED:  # U singular to the last bit: Householder's QR of the scaled Psi_q
        J = scaled[0] * scale[0] / np.where(scale[1][0] > 0.0, scale[1][0], 1.0)[:, None]
        first = np.ascontiguousarray(np.linalg.qr(J.T, mode="complete")[0][:, structure[1].size :])
        if _band_start(*at_first, first, float(widest))[1] == NOT_A_BAND:
            return None
    arguments = (stored, *scale, position, keys, starts, indices, slots)
    if settle is None:
        ratios, bases, signs, _, _, certified = _spectra(*arguments, first, 0.0, False, np.empty(0))
        return ratios, bases, signs, certified
    tests = _tests(settle)
    ratios, bases, signs, certified, lower, vectors = _settled_spectra(*arguments, first, *tests)
    brackets = None if tests[2] else Brackets(ratios, lower, arguments, bases, vectors)
    return ratios, bases, signs, certified, brackets


@njit(cache=True, nogil=True)  # AT_FIRST_CALL
def _settled_spectra(jacobians, columns, norms, position, keys, starts, indices, slots, first, thresholds, fall, ends):
    """``_spectra`` with each ratio in a bracket LOOSE wide or (without ``ends``) one carried over a step where that
    decides the Guard's tests (``_carried``), then closed at the times those tests (thresholds, fall, ends:
    ``_tests``) need (``_unsettled``), each from its own eigenvectors (``_ratios_at``): (ratios, bases, signs,
    certified steps, the ratios' lower ends, each time's eigenvectors: ``Brackets``), in one compiled call (from
    Python, the three calls and the tests' arrays between them cost ~0.03 ms a history)."""
    arguments = (jacobians, columns, norms, position, keys, starts, indices, slots)
    carry = thresholds if not ends else np.empty(0)
    ratios, bases, signs, lower, vectors, certified = _spectra(*arguments, first, LOOSE, not ends, carry)
    times = _unsettled(lower, ratios, signs, thresholds, fall, ends, ends)
    if times.size:  # closed there, each from its own vectors
        closed = _ratios_at(*arguments, bases, vectors, times)
        for a in range(times.size):  # loops, not slice assignments (``_leading``)
            ratios[times[a]] = lower[times[a]] = closed[a]
    return ratios, bases, signs, certified, lower, vectors


class Brackets:
    """The band's ratios as ``spectra`` leaves them under the Guard's tests of a run that stops at singular
    positions (``settle`` without ``ends``): each closed or in a bracket [lower, upper] (LOOSE wide, or carried over
    a step up to CARRIED wide: ``_carried``) that decides every test of ``settled`` but one (``adjacent`` False):
    which of two neighbours is the smaller, which ``guard.Guard.check_branches`` reads at the steps it judges
    alone (the middle of a step next to a singular position, whose joints a switch found there names; ``smaller``).
    Where their brackets overlap, ``smaller`` closes both as ``_settled_spectra`` closes a ratio (``_ratios_at``,
    from the eigenvectors their brackets left) and writes the figures into ``upper``, the ratios' array the Guard
    holds: the order of the closed figures, as when every overlapping pair was closed in the pass (i25-guard9), at
    the few steps a run reads it, not at every carried bracket (each overlaps its neighbours)."""

    def __init__(self, upper, lower, arguments, bases, vectors):
        self.upper, self.lower = upper, lower
        self._arguments, self._bases, self._vectors = arguments, bases, vectors

    def smaller(self, a: int, b: int) -> int:
        """a if the ratio at time a is at most that at b, else b, as their closed figures compare. Where the
        brackets are apart, their figures (upper ends) compare so: each bracket holds its closed figure
        (``_widened``), so upper[a] < lower[b] gives closed_a <= upper[a] < lower[b] <= closed_b and upper[a] <=
        upper[b]."""
        upper, lower = self.upper, self.lower
        if not (upper[a] < lower[b] or upper[b] < lower[a]):  # overlapping: both closed
            times = np.array([k for k in (a, b) if lower[k] < upper[k]], dtype=np.int64)
            if times.size:
                upper[times] = _ratios_at(*self._arguments, self._bases, self._vectors, times)
                lower[times] = upper[times]
        return a if upper[a] <= upper[b] else b


def _tests(settle: tuple) -> tuple[np.ndarray, float, bool]:
    """(thresholds (the nonzero ones), fall, ends) of the Guard's tests ``settle`` (thresholds, fall[, ends]) of the
    ratios, as ``_unsettled`` takes them."""
    thresholds = np.array([value for value in settle[0] if value], dtype=float)
    return thresholds, float(settle[1]), bool(len(settle) > 2 and settle[2])


@njit(cache=True, nogil=True)
def _unsettled(lower, ratios, signs, thresholds, fall, ends, adjacent):
    """The output times (int64) whose ratios, known in brackets [lower, ratios], the Guard's tests (``thresholds``,
    ``fall``: ``_tests``; ``adjacent``: every two neighbours ordered) need closed (``settled``); with ``ends``, the
    first two and last two times too, which a run ``through`` singular positions compares with the batches before
    and after (``Guard._record``)."""
    unsettled = ~settled(lower, ratios, signs, thresholds, fall, adjacent)
    N = lower.size
    for k in range(N):
        if ends and (k < 2 or k >= N - 2) and lower[k] < ratios[k]:
            unsettled[k] = True
    return np.nonzero(unsettled)[0].astype(np.int64)


@njit(_SETTLED, cache=True, nogil=True)
def settled(lower, upper, signs, thresholds, fall, adjacent):
    """Where a ratio known only in its bracket [lower, upper] (N,) (``upper`` the figure) gives every test of the
    Guard the verdict its exact value gives, and is no figure the Guard reports (``guard.Guard``: ``_quiet``,
    ``_judge``, ``check_branches``, ``diagnostics.passes_zero``): True where the bracket
    - lies on one side of each of the ``thresholds`` (NEAR_SINGULAR, the run's singular_ratio), and above the
      smallest (the Guard stops below singular_ratio and reports that figure);
    - holds no candidate for the smallest ratio of the run (``closest``, reported): its lower end above every upper;
    - does not overlap its neighbours' ``fall`` times (the falls of ``check_branches`` decided) nor, if
      ``adjacent``, its neighbours' own (each comparison of two ratios of adjacent times decided: a run ``through``
      singular positions reads any of them; else ``Brackets.smaller`` decides the few ``check_branches`` reads);
    - is no possible dip (``passes_zero`` of it and its neighbours decided false; a dip's three are closed: its
      figure is reported), no possible fall's low end (below NEAR_SINGULAR, ``fall`` times its neighbour's upper
      end or less: ``check_branches`` reports it as the crossing's figure) nor next to a flip of the sign of
      det [Psi_q; T^T] (the crossing's figure).
    A closed ratio (lower = upper) is settled. One compiled pass: numpy's forty array operations on 101 times
    cost 90 us, a tenth of the ratios' own time on a small chain."""
    N = lower.size
    loose = lower < upper
    unsettled = np.zeros(N, dtype=np.bool_)
    smallest = np.min(upper) if N else 0.0
    near = np.max(thresholds) if thresholds.size else np.inf
    floor = np.min(thresholds) if thresholds.size else 0.0
    for k in range(N):
        if not loose[k]:
            continue
        if lower[k] <= smallest or lower[k] < floor:
            unsettled[k] = True
        for value in thresholds:
            if lower[k] < value <= upper[k]:
                unsettled[k] = True
    for k in range(N - 1):
        if not (loose[k] or loose[k + 1]):
            continue
        for a, b in ((k, k + 1), (k + 1, k)):
            for factor in (1.0, fall):  # ratios[a] <= factor ratios[b]: decided unless the brackets overlap
                if (adjacent or factor != 1.0) and lower[a] <= factor * upper[b] and factor * lower[b] <= upper[a]:
                    unsettled[k] = unsettled[k + 1] = True
            if lower[a] < near and lower[a] <= fall * upper[b]:  # a possible fall: its low end's figure is reported
                unsettled[a] = True
        if signs[k] * signs[k + 1] < 0.0:
            unsettled[k] = unsettled[k + 1] = True
    for k in range(1, N - 1):  # passes_zero(before, middle, after) unless decided false
        below = lower[k] <= min(upper[k - 1], upper[k + 1]) and 2.0 * lower[k] < max(upper[k - 1], upper[k + 1])
        if lower[k] < near and below:
            unsettled[k - 1] = unsettled[k] = unsettled[k + 1] = True
    return ~(unsettled & loose)


@njit(cache=True, nogil=True)
def _first_basis(jacobian, columns, norms, position, keys, starts, indices):
    """A null-space basis (n, d) of one scaled Psi_q (m, n) with no basis of a time before to pick E's coordinates
    (the first output time of a run): those coordinate partitioning (eq. 5.40) leaves independent, by the banded LU
    with partial pivoting of Psi_q^T (n x m, its rows the coordinates in band order; LAPACK's dgbtrf,
    O(n kl (kl + ku))): the coordinates not taken as pivots, whose m columns of Psi_q are then nonsingular, so that
    A = [Psi_q; E^T] is. T then as at every time (``_null_space``): on a chain of 64 loops 0.1 ms, where the dense
    QR of Psi_q cost 5.5. NaN where U has an exact zero pivot (Psi_q singular to the last bit)."""
    m, n = keys.size, position.size
    d = n - m
    J = np.zeros((m, n))
    for r in range(m):
        norm = norms[r] if norms[r] > 0.0 else 1.0
        for p in range(starts[r], starts[r + 1]):
            J[r, indices[p]] = jacobian[r, indices[p]] * columns[indices[p]] / norm
    rows = np.argsort(keys, kind="mergesort")  # Psi_q's rows in band order: B = Psi_q^T's columns
    kl, ku = 0, 0
    for j in range(m):
        r = rows[j]
        for p in range(starts[r], starts[r + 1]):
            i = position[indices[p]]
            kl, ku = max(kl, i - j), max(ku, j - i)
    ldab = 2 * kl + ku + 1
    ab = np.zeros((m, ldab))  # dgbtrf's AB of B (n x m): ab[j, kl + ku + i - j] = B[i, j], kl rows for the fill
    for j in range(m):
        r = rows[j]
        for p in range(starts[r], starts[r + 1]):
            i = position[indices[p]]
            ab[j, kl + ku + i - j] = J[r, indices[p]]
    pivots = np.empty(m, dtype=PIVOT_TYPE)
    sizes = np.array([n, m, kl, ku, ldab, 0], dtype=PIVOT_TYPE)  # m, n, kl, ku, ldab, info
    _GBTRF(sizes[0:].ctypes, sizes[1:].ctypes, sizes[2:].ctypes, sizes[3:].ctypes, ab.ctypes, sizes[4:].ctypes,
           pivots.ctypes, sizes[5:].ctypes)  # fmt: skip
    if sizes[5] != 0:
        return np.full((n, d), np.nan)
    taken = np.arange(n)  # the row interchanges, in order: rows 0..m-1 of the result are the pivots' coordinates
    for j in range(m):
        p = pivots[j] - 1
        taken[j], taken[p] = taken[p], taken[j]
    order = np.empty(n, dtype=np.int64)  # the coordinate at each place of the band order
    for i in range(n):  # loops, not slice assignments (``_leading``)
        order[position[i]] = i
    chosen = np.sort(order[taken[m:]])
    slot = _layout(keys, position, chosen)
    kl, ku = _widths(slot, m, starts, indices, position, chosen, True)
    basis = np.empty((n, d))
    work = np.empty((n, 2 * kl + ku + 1)), np.empty(n, dtype=np.int64), np.empty(n)
    _null_space(J, slot, m, starts, indices, position, chosen, 1.0, kl, ku, *work, basis)
    return basis


NOT_A_BAND, BAND, FIRST_FAILED = 0, 1, 2
"""``_band_start``'s verdicts: the ordered Psi_q is wider than ``spectra``'s ``widest`` allows; a band, with a first
basis; a band whose first Psi_q's banded LU met an exact zero pivot (no first basis from it)."""


@njit(cache=True, nogil=True)
def _band_start(stored, slots, columns, norms, position, keys, starts, indices, first, widest):
    """(the null-space basis at the first time, ``NOT_A_BAND`` | ``BAND`` | ``FIRST_FAILED``) of a history whose
    first Psi_q (m, n) is read from ``stored`` (``_first_entries``: entry p of the pattern at slots[p]) and scaled
    by ``columns`` and ``norms`` as ``_first_basis`` scales it, in one compiled call (each call from Python costs
    some microseconds a dozen times a history; once per history here, its first entries read inside). ``first``
    (n, d): a basis known at (or just before) the first time, or (0, 0) for none: then from the band
    (``_first_basis``), if the rows' widths with E's rows at the band's end leave one. The band is one where its
    width kl + ku + 1 with E's rows where the basis puts them (``_independent``) is at most n / ``widest``."""
    m, n = keys.size, position.size
    if first.shape[0] == 0:
        last = np.sort(np.argsort(position)[m:])  # E's rows at the band's end: the widths of Psi_q's rows
        kl, ku = _widths(_layout(keys, position, last), m, starts, indices, position, last, False)
        if widest * (kl + ku + 1) > n:
            return first, NOT_A_BAND
        jacobian = _first_entries(stored, starts, indices, slots, n)
        first = _first_basis(jacobian, columns, norms, position, keys, starts, indices)
        if not np.all(np.isfinite(first)):
            return first, FIRST_FAILED
    chosen = _independent(first, n - m)
    kl, ku = _widths(_layout(keys, position, chosen), m, starts, indices, position, chosen, True)
    return first, NOT_A_BAND if widest * (kl + ku + 1) > n else BAND


@njit(cache=True, nogil=True)
def _entry_slots(reach, starts, indices):
    """Each pattern entry's slot among its row's blocks (``history.BlockedJacobians``: entry s of row r in column
    reach[r, s], -1 after the last): slots[p] = s where reach[r, indices[p]] holds column indices[p] (-1 where the
    row does not reach it), as ``history.column_slots`` finds them, in one compiled pass (numpy's comparison of
    every entry's row with its column, ``any`` and ``argmax`` cost ~70 us in a call at N = 8 loops)."""
    slots = np.full(indices.size, -1, dtype=np.int64)
    for r in range(starts.size - 1):
        for p in range(starts[r], starts[r + 1]):
            for s in range(reach.shape[1]):
                if reach[r, s] == indices[p]:
                    slots[p] = s
                    break
    return slots


@njit(cache=True, nogil=True)
def _first_entries(stored, starts, indices, slots, n):
    """The first output time's Psi_q (m, n) on its pattern (entry p of row r, column indices[p], is
    stored[0, r, slots[p]]; zero elsewhere): all that ``_band_start`` reads of it (``_first_basis`` reads the
    pattern's entries alone), without a dense copy of a blocked history's time (~40 us in a call at N = 8 loops)."""
    m = starts.size - 1
    jacobian = np.zeros((m, n))
    for r in range(m):
        for p in range(starts[r], starts[r + 1]):
            jacobian[r, indices[p]] = stored[0, r, slots[p]]
    return jacobian


_STRUCTURES: dict = {}
"""``_band_structure`` of the patterns met (a mechanism's Psi_q has the same pattern at every output time and in
every run: its band ordering is found once)."""


def _band_structure(pattern: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(position (n,): each column's place in the band order, keys (m,): each row's place along the diagonal
    (``band_order``), starts (m + 1,) and indices: each row's nonzero columns, CSR) of a pattern (m, n), kept in
    ``_STRUCTURES`` (the reverse Cuthill-McKee ordering and the rows' keys cost 5 ms on a chain of 64 loops)."""
    key = (pattern.shape, np.asarray(pattern, dtype=bool).tobytes())  # one byte an entry: no packing needed
    if key not in _STRUCTURES:
        columns_order, keys = band_order(pattern)
        position = np.empty(columns_order.size, dtype=np.int64)
        position[columns_order] = np.arange(columns_order.size)
        starts = np.concatenate([[0], np.cumsum(pattern.sum(axis=1))]).astype(np.int64)
        indices = np.nonzero(pattern)[1].astype(np.int64)  # row by row, columns ascending
        if len(_STRUCTURES) >= 16:
            _STRUCTURES.clear()
        _STRUCTURES[key] = (position, keys, starts, indices)
    return _STRUCTURES[key]


def history_norms(jacobians: np.ndarray, columns: np.ndarray, reach: np.ndarray | None = None):
    """(``row_norms`` (N, m), pattern (m, n) or None) of a history of Psi_q (N, m, n). With ``reach`` (m, w): the
    columns where each row can be nonzero, those of the bodies its element joins (-1 after the last,
    ``history.row_columns``), both in one pass over those entries alone (``_reached_norms``: on a chain of 64
    loops 6 of 387 columns a row, where the dense pass reads all 121 MB of the history); the same norms to the
    last bit (the dense sum adds zeros between them). Without, the dense pass and no pattern."""
    columns = np.ascontiguousarray(columns, dtype=float)
    if isinstance(jacobians, BlockedJacobians):  # its blocks are the reach: the same entries in the same order
        reach = jacobians.columns
        return _reached_norms(np.ascontiguousarray(jacobians.values), columns, reach, block_slots(reach))
    jacobians = np.ascontiguousarray(jacobians, dtype=float)
    if reach is not None and (reach.shape[0] != jacobians.shape[1] or reach.max(initial=-1) >= jacobians.shape[2]):
        reach = None  # not this history's rows and columns: the dense pass
        return row_norms(jacobians, columns), None
    reach = np.ascontiguousarray(reach, dtype=np.int64)
    return _reached_norms(jacobians, columns, reach, reach)


@njit(cache=True, nogil=True)
def _reached_norms(stored, columns, reach, slots):
    """``row_norms`` and ``_pattern`` of a history of Psi_q from the entries of each row alone: the s-th of row r
    lies in column reach[r, s] (ascending, -1 after the last) and is stored[k, r, slots[r, s]]: in that column of
    a dense history (N, m, n), slots = reach, or in slot s of a history by its rows' blocks (N, m, w),
    ``history.BlockedJacobians``."""
    N, m = stored.shape[:2]
    n = columns.size
    norms = np.empty((N, m))
    pattern = np.zeros((m, n), dtype=np.bool_)
    for k in range(N):
        for r in range(m):
            total = 0.0
            for s in range(reach.shape[1]):
                c = reach[r, s]
                if c < 0:
                    break
                entry = stored[k, r, slots[r, s]]
                if entry != 0.0:
                    pattern[r, c] = True
                value = entry * columns[c]
                total += value * value
            norms[k, r] = np.sqrt(total)
    return norms, pattern


@njit(_matrix(_stack, _vector), cache=True, nogil=True)
def row_norms(jacobians, columns):
    """|grad Psi_i| of every row of every Psi_q (N, m, n) with its columns weighted by ``columns`` (angles as arc
    lengths): the Guard's drift and scaling, in one pass over the history (numpy's product, norm and quotient
    make three, and a copy)."""
    N, m, n = jacobians.shape
    norms = np.empty((N, m))
    for k in range(N):
        for r in range(m):
            total = 0.0
            for c in range(n):
                value = jacobians[k, r, c] * columns[c]
                total += value * value
            norms[k, r] = np.sqrt(total)
    return norms


@njit(types.int64(_matrix, _matrix, types.float64), cache=True, nogil=True)
def drifted(psi, norms, limit):
    """The first output time at which a row's drift |Psi_i| / |grad Psi_i| (``psi`` (N, m), ``norms`` (N, m):
    ``row_norms``, 1 where a row's is 0) is not within ``limit``, a NaN counting, or -1: ``guard.Guard.
    check_outputs``' drift test in one pass, where numpy's quotient, maximum over the rows and test make five
    arrays (70 us on the loop chain of 4 loops). The same verdict: numpy's max(0, d_1, ..., d_m) <= limit (the
    maximum propagates a NaN) holds exactly when 0 <= limit and d_r <= limit for every r, each d_r the same
    quotient."""
    for k in range(psi.shape[0]):
        if not 0.0 <= limit:
            return k
        for r in range(psi.shape[1]):
            norm = norms[k, r] if norms[k, r] > 0.0 else 1.0
            if not abs(psi[k, r]) / norm <= limit:
                return k
    return -1


@njit(cache=True, nogil=True)
def unmade(ratios, signs, bases, certified):
    """(made, failed) (N,) of the band's pass (``spectra`` with ``settle``: ratios, bases, signs, certified steps):
    made where a basis was made (the first and last times and both ends of each step not certified), failed where
    LAPACK met an exact zero pivot (a ratio or sign NaN, or a made basis with a NaN), which
    ``guard.square_spectra`` makes densely: its test in one pass, where numpy's made nine arrays (~20 us a
    history on the loop chain of 4 loops)."""
    N = ratios.size
    made = np.ones(N, dtype=np.bool_)
    failed = np.zeros(N, dtype=np.bool_)
    for k in range(N):
        if 0 < k < N - 1:
            made[k] = not (certified[k - 1] and certified[k])
        failed[k] = not (np.isfinite(ratios[k]) and np.isfinite(signs[k]))
        if made[k] and not failed[k]:
            failed[k] = not _finite(bases[k])
    return made, failed


@njit(cache=True, nogil=True)
def _finite(basis):
    """Whether every entry of a basis (n, d) is finite (no array made, as np.all(np.isfinite) makes one)."""
    for value in basis.ravel():
        if not np.isfinite(value):
            return False
    return True


@njit(cache=True, nogil=True)
def quiet(first, turns, signs, sign, ratios, singular_ratio, aligned):
    """The first output time of the smallest ratio if no output time is near a singular position nor past one,
    else -1: ``guard.Guard._quiet``'s test in one pass (numpy's made fifteen arrays, ~25 us a history). Time k
    is past one where the null space's turn since the time before (``first`` at k = 0, since the Guard's last
    basis; turns[k - 1] after) is above ``aligned`` and the sign of det [Psi_q; T^T] flips against it, turn
    signs[k] signs[k - 1] < 0 (``sign`` before k = 0), each product as numpy's in that order; near one where the
    ratio is not at least ``singular_ratio`` (a NaN is)."""
    for k in range(ratios.size):
        turn = first if k == 0 else turns[k - 1]
        before = sign if k == 0 else signs[k - 1]
        if abs(turn) > aligned and turn * signs[k] * before < 0.0:
            return -1
        if not ratios[k] >= singular_ratio:
            return -1
    return np.argmin(ratios)


@njit(types.boolean[:, ::1](_stack), cache=True, nogil=True)
def _pattern(jacobians):
    """Where any Psi_q of the history (N, m, n) has a nonzero entry (m, n)."""
    N, m, n = jacobians.shape
    pattern = np.zeros((m, n), dtype=np.bool_)
    for k in range(N):
        for r in range(m):
            for c in range(n):
                if jacobians[k, r, c] != 0.0:
                    pattern[r, c] = True
    return pattern


@njit(cache=True, nogil=True)
def _leading(A, B):
    """B = A's leading block of B's shape, entry by entry: loops, not slice assignments (``B[:, :] = A[:, :m]``), whose
    shape check numba compiles with a formatted error message into every function that has one (``loops._copy``)."""
    for r in range(B.shape[0]):
        for c in range(B.shape[1]):
            B[r, c] = A[r, c]


@njit(cache=True, nogil=True)
def _parity(permutation):
    """+1 or -1: the sign of a permutation (its number of even-length cycles)."""
    seen = np.zeros(permutation.size, dtype=np.bool_)
    sign = 1.0
    for start in range(permutation.size):
        if seen[start]:
            continue
        length, at = 0, start
        while not seen[at]:
            seen[at] = True
            at = permutation[at]
            length += 1
        if length % 2 == 0:
            sign = -sign
    return sign


@njit(cache=True, nogil=True)
def _independent(basis, d):
    """The d coordinates in which the null-space basis (n, d) is largest: greedy pivoting of its rows (the
    columns of T^T), each chosen row's direction removed from the rest (Gram-Schmidt), so that [Psi_q; E^T] is
    as far from singular as a choice of d unit rows makes it."""
    chosen = np.empty(d, dtype=np.int64)
    _choose(basis, basis.copy(), np.empty(d), chosen)
    return chosen


@njit(cache=True, nogil=True)
def _choose(basis, rest, direction, chosen):
    """``_independent`` into ``chosen`` (d,), sorted, with work arrays ``rest`` (n, d) and ``direction`` (d,) (made
    once per history by ``_spectra``, which asks at every output time)."""
    d = chosen.size
    _leading(basis, rest)
    for a in range(d):
        best, size = 0, -1.0
        for r in range(rest.shape[0]):
            norm = 0.0
            for c in range(d):
                norm += rest[r, c] * rest[r, c]
            if norm > size:
                best, size = r, norm
        chosen[a] = best
        for c in range(d):
            direction[c] = rest[best, c] / np.sqrt(size) if size > 0.0 else rest[best, c] * 0.0
        for r in range(rest.shape[0]):
            along = 0.0
            for c in range(d):
                along += rest[r, c] * direction[c]
            for c in range(d):
                rest[r, c] -= along * direction[c]
    chosen.sort()


@njit(cache=True, nogil=True)
def _layout(keys, position, chosen):
    """The rows of the square band: slot[i] the row of A = [Psi_q; E^T] at band row i (E's rows m, m + 1, ...),
    by their places along the diagonal (Psi_q's rows at the mean position of their columns, ``band_order``; E's
    unit rows at their column's position)."""
    m = keys.size
    places = np.empty(m + chosen.size)
    for r in range(m):  # loops, not slice assignments (``_leading``)
        places[r] = keys[r]
    for a in range(chosen.size):
        places[m + a] = position[chosen[a]]
    return np.argsort(places, kind="mergesort")


@njit(cache=True, nogil=True)
def _widths(slot, m, starts, indices, position, chosen, with_e):
    """(kl, ku) of the square band: the largest distance below and above the diagonal of a structural nonzero."""
    kl, ku = 0, 0
    for i in range(slot.size):
        r = slot[i]
        if r < m:
            for p in range(starts[r], starts[r + 1]):
                j = position[indices[p]]
                kl, ku = max(kl, i - j), max(ku, j - i)
        elif with_e:
            j = position[chosen[r - m]]
            kl, ku = max(kl, i - j), max(ku, j - i)
    return kl, ku


@njit(cache=True, nogil=True)
def _ratio(J, slot, m, starts, indices, position, chosen):
    """sigma_m / sigma_1 of Psi_q from the band [Psi_q; 0] (dgbbrd, then dstebz on the Golub-Kahan form: module
    docstring); 0 where sigma_1 = 0 (as the dense ratio), NaN where LAPACK failed."""
    n = slot.size
    kl, ku = _widths(slot, m, starts, indices, position, chosen, False)
    ldab = kl + ku + 1
    ab = np.zeros((n, ldab))  # Fortran's AB(ldab, n): ab[j, ku + i - j] = A[i, j]
    for i in range(n):
        r = slot[i]
        if r < m:
            for p in range(starts[r], starts[r + 1]):
                c = indices[p]
                ab[position[c], ku + i - position[c]] = J[r, c]
    d, e = np.empty(n), np.zeros(n)
    dummy, work = np.zeros(1), np.empty(8 * n)
    letter = np.full(3, ord("N"), dtype=np.uint8)  # vect 'N'; then range 'I' and order 'E' for dstebz
    sizes = np.array([n, n, 0, kl, ku, ldab, 1, 0], dtype=PIVOT_TYPE)  # m, n, ncc, kl, ku, ldab, ldq/ldpt/ldc, info
    _GBBRD(letter[0:].ctypes, sizes[0:].ctypes, sizes[1:].ctypes, sizes[2:].ctypes, sizes[3:].ctypes, sizes[4:].ctypes,
           ab.ctypes, sizes[5:].ctypes, d.ctypes, e.ctypes, dummy.ctypes, sizes[6:].ctypes, dummy.ctypes,
           sizes[6:].ctypes, dummy.ctypes, sizes[6:].ctypes, work.ctypes, sizes[7:].ctypes)  # fmt: skip
    if sizes[7] != 0:
        return np.nan
    diagonal, off = np.zeros(2 * n), np.empty(2 * n)  # the Golub-Kahan tridiagonal of B
    for i in range(n):
        off[2 * i] = d[i]
        off[2 * i + 1] = e[i] if i < n - 1 else 0.0
    letter[1], letter[2] = ord("I"), ord("E")
    found = np.empty(2)
    for a, index in enumerate((2 * n - m + 1, 2 * n)):  # ascending: sigma_m, then sigma_1 (1-based indices)
        numbers = np.array([2 * n, index, index, 0, 0, 0], dtype=PIVOT_TYPE)  # n, il, iu, m, nsplit, info
        bounds = np.array([0.0, 0.0, 2.0 * np.finfo(np.float64).tiny])  # vl, vu (unused), abstol
        w = np.empty(2 * n)
        block, split = np.empty(2 * n, dtype=PIVOT_TYPE), np.empty(2 * n, dtype=PIVOT_TYPE)
        iwork = np.empty(6 * n, dtype=PIVOT_TYPE)
        _STEBZ(letter[1:].ctypes, letter[2:].ctypes, numbers[0:].ctypes, bounds[0:].ctypes, bounds[1:].ctypes,
               numbers[1:].ctypes, numbers[2:].ctypes, bounds[2:].ctypes, diagonal.ctypes, off.ctypes,
               numbers[3:].ctypes, numbers[4:].ctypes, w.ctypes, block.ctypes, split.ctypes, work.ctypes,
               iwork.ctypes, numbers[5:].ctypes)  # fmt: skip
        if numbers[5] != 0 or numbers[3] != 1:
            return np.nan
        found[a] = abs(w[0])
    return found[0] / found[1] if found[1] > 0.0 else 0.0


@njit(cache=True, nogil=True)
def _band_lu(ab, kl, ku, pivots):
    """LU with partial pivoting of the square band A (n x n, half-widths kl, ku) in place, as LAPACK's unblocked
    dgbtf2 (which dgbtrf calls at these widths): ab[j, kl + ku + i - j] = A[i, j], kl rows above for the fill;
    pivots[j] the row swapped with row j (0-based). False at an exact zero pivot. Written out: LAPACK's column step
    makes four BLAS calls (idamax, dswap, dscal, dger), whose call costs more than the arithmetic of a band a few
    entries wide (101 LUs of the loop chain's 15 x 15 to 51 x 51: 0.12 -> 0.08 ms and 0.39 -> 0.25, session 22)."""
    n = ab.shape[0]
    kv = kl + ku  # the diagonal's column in ab
    ju = 0  # the last column U reaches so far
    for j in range(n):
        below = min(kl, n - 1 - j)
        p, size = 0, abs(ab[j, kv])
        for i in range(1, below + 1):
            if abs(ab[j, kv + i]) > size:
                p, size = i, abs(ab[j, kv + i])
        pivots[j] = j + p
        if ab[j, kv + p] == 0.0:
            return False
        ju = max(ju, min(j + ku + p, n - 1))
        if p != 0:  # rows j and j + p, columns j..ju
            for c in range(j, ju + 1):
                a, b = kv + j - c, kv + j + p - c
                ab[c, a], ab[c, b] = ab[c, b], ab[c, a]
        reciprocal = 1.0 / ab[j, kv]
        for i in range(1, below + 1):
            ab[j, kv + i] *= reciprocal
        for c in range(j + 1, ju + 1):  # the rank-one update of the rows below
            u = ab[c, kv + j - c]
            if u != 0.0:
                for i in range(1, below + 1):
                    ab[c, kv + j + i - c] -= ab[j, kv + i] * u
    return True


@njit(cache=True, nogil=True)
def _band_solve(ab, kl, ku, pivots, b):
    """b <- A^-1 b (b (n,)) with ``_band_lu``'s factors, as LAPACK's dgbtrs: L's swaps and columns forward, then U
    (upper band kl + ku wide) back."""
    n = ab.shape[0]
    kv = kl + ku
    for j in range(n - 1):
        p = pivots[j]
        if p != j:
            b[j], b[p] = b[p], b[j]
        for i in range(1, min(kl, n - 1 - j) + 1):
            b[j + i] -= ab[j, kv + i] * b[j]
    for j in range(n - 1, -1, -1):
        b[j] /= ab[j, kv]
        for i in range(max(0, j - kv), j):
            b[i] -= b[j] * ab[j, kv + i - j]


@njit(cache=True, nogil=True)
def _null_space(J, slot, m, starts, indices, position, chosen, ordered, kl, ku, ab, pivots, rhs, basis):
    """The sign of det [Psi_q; T^T] and T into ``basis`` (n, d), from the banded LU of A = [Psi_q; E^T] (module
    docstring; ``_band_lu``); NaN on failure. ordered: the parities of the rows' order ``slot`` and the columns'
    ``position`` (``_parity``), multiplied; kl, ku: the band's widths (``_widths``): all three found once for each
    choice of E's coordinates, ``chosen``. Work arrays, made once per choice of E: ab (n, 2 kl + ku + 1), pivots
    (n,), rhs (n,)."""
    n, d = slot.size, chosen.size
    kv = kl + ku
    ab[:, :] = 0.0
    for i in range(n):
        r = slot[i]
        if r < m:
            for p in range(starts[r], starts[r + 1]):
                j = position[indices[p]]
                ab[j, kv + i - j] = J[r, indices[p]]
        else:
            j = position[chosen[r - m]]
            ab[j, kv + i - j] = 1.0
    if not _band_lu(ab, kl, ku, pivots):
        basis[:, :] = np.nan
        return np.nan
    sign = ordered  # B[i, j] = A[slot[i], columns[j]] (A's rows: Psi_q's, then E's): sign(slot) det A sign(columns)
    for i in range(n):
        if ab[i, kv] < 0.0:
            sign = -sign
        if pivots[i] != i:
            sign = -sign
    for a in range(d):  # T_0 = A^-1 [0; I_d]: E's unit vectors in the band layout
        rhs[:] = 0.0
        for i in range(n):
            if slot[i] == m + a:
                rhs[i] = 1.0
        _band_solve(ab, kl, ku, pivots, rhs)
        for c in range(n):
            basis[c, a] = rhs[position[c]]
    for a in range(d):  # Gram-Schmidt: T = T_0 S^-1, S upper triangular with a positive diagonal
        for b in range(a):
            along = 0.0
            for c in range(n):
                along += basis[c, b] * basis[c, a]
            for c in range(n):
                basis[c, a] -= along * basis[c, b]
        norm = 0.0
        for c in range(n):
            norm += basis[c, a] * basis[c, a]
        norm = np.sqrt(norm)
        for c in range(n):
            basis[c, a] /= norm
    return sign


EXTREME_TOLERANCE = 1e-13
"""Relative width to which ``_largest`` and ``_smallest`` close their brackets of an eigenvalue of Psi_q Psi_q^T."""
CERTIFIED = 1e-5
"""Largest relative width of the bracket of sigma_m^2 that the Cholesky test can certify (its rounding, about
16 eps sigma_1^2, against sigma_m^2) for ``_smallest`` to give the figure; past it (sigma_m / sigma_1 below about
1e-5) the exact band route (``_ratio``) or the dense SVD gives it."""
LOOSE = 1e-4
"""Relative width of the bracket of each extreme eigenvalue of Psi_q Psi_q^T that ``_bracketed_ratio`` first tries
(one Cholesky test each): the ratios of adjacent output times differ by more (loop chain: the two times' brackets
overlap at fewer than one time in 20, ``benchmarks/guard_cost.py``), so most verdicts are decided there."""
WIDE = 1e-2
"""Relative width of a tested bracket where neighbours need not be ordered (``_spectra`` with ``carry``) next after
a carried one (whose eigenvectors, two steps old, would take a sharpening test) away from the smallest ratio so far
(``_away``): wide enough for every test of ``settled`` but the smallest (thresholds, dips
2x, falls 100x), and no sharpening test (``_top_sharpen``) after the first; nearer the smallest, LOOSE (a bracket
WIDE wide there makes a candidate for the smallest, closed: on the loop chain, which starts from rest at its
smallest ratio, the first 8 times)."""
CARRIED = 2.2
"""Widest a bracket carried over a step by Weyl's inequality may be (upper / lower end, ``_carried``) for ``_spectra``
to keep it instead of a bracket of its own; and it must decide the Guard's tests as far as the times so far tell
(``_carries``)."""
_ROUNDS = 60
STEP = 1e-5
GUESS = 1e-3
"""``_largest`` first tries an upper bound this fraction above the Rayleigh quotient of the time before's vector."""
"""Each trial of a bracket's Cholesky test lies this fraction of the bracket beyond its Rayleigh quotient."""


@njit(cache=True, nogil=True)
def _gram_width(rows, starts, indices, n):
    """Half-bandwidth of G = Psi_q Psi_q^T with its rows and columns in the order ``rows``: the farthest earlier
    row that shares a coordinate with a row."""
    first = np.full(n, -1, dtype=np.int64)
    width = 0
    for i in range(rows.size):
        r = rows[i]
        for p in range(starts[r], starts[r + 1]):
            c = indices[p]
            if first[c] < 0:
                first[c] = i
            width = max(width, i - first[c])
    return width


@njit(cache=True, nogil=True)
def _gram_products(rows, starts, indices, w, n):
    """The products that make G = Psi_q Psi_q^T (m x n) in lower band storage (``_gram``), found once from the
    pattern: (P, 3) rows (g, x, y) of places in the flat arrays, G.flat[g] += Psi_q.flat[x] Psi_q.flat[y] with
    g = i (w + 1) + t (G[i, t]), x = a n + c, y = b n + c (Psi_q[a, c], Psi_q[b, c]), a = rows[i], b = rows[i - t],
    for each column c the two rows share, in the order of G's entries and of their common columns (on a chain of
    64 loops 2,000 products, where merging every pair of rows within the band's width costs 8 times their time;
    three places a product, where (i, t, a, b, c) took five reads and three index products: 0.51 -> 0.43 us for
    the loop chain's 26 x 6 G)."""
    m = rows.size
    products = np.empty((0, 3), dtype=np.int64)
    for counting in (True, False):
        count = 0
        for i in range(m):
            a = rows[i]
            for t in range(min(w, i) + 1):
                b = rows[i - t]
                p, q = starts[a], starts[b]
                while p < starts[a + 1] and q < starts[b + 1]:
                    if indices[p] == indices[q]:
                        if not counting:
                            products[count, 0] = i * (w + 1) + t
                            products[count, 1], products[count, 2] = a * n + indices[p], b * n + indices[p]
                        count += 1
                        p += 1
                        q += 1
                    elif indices[p] < indices[q]:
                        p += 1
                    else:
                        q += 1
        if counting:
            products = np.empty((count, 3), dtype=np.int64)
    return products


@njit(cache=True, nogil=True)
def _envelope(products, m, w):
    """(first, last) (2, m) of G = Psi_q Psi_q^T's envelope from its products (``_gram_products``), found once
    from the pattern: first[i] the first column of row i that holds a product (left of it G and its Cholesky factor
    hold exact zeros: ``_cholesky``), last[j] the last row whose envelope reaches column j (at least j). The loop
    chain's G, 5 wide, holds 2-5 entries left of the diagonal (3 on average): the solves and the Rayleigh quotient
    sum over the envelope alone (``_solve_pair``, ``_quotients``), skipping products with exact zeros of the band
    (George and Liu, ch. 4: the envelope of a matrix is its Cholesky factor's), the same sums to the last bit."""
    envelope = np.empty((2, m), dtype=np.int64)
    first, last = envelope[0], envelope[1]
    for r in range(m):  # loops, not slice assignments (``_leading``)
        first[r] = last[r] = r
    for p in range(products.shape[0]):
        i, t = products[p, 0] // (w + 1), products[p, 0] % (w + 1)
        first[i] = min(first[i], i - t)
    for i in range(m):
        for j in range(first[i], i):
            last[j] = max(last[j], i)
    return envelope


@njit(cache=True, nogil=True)
def _whole_band(m, w):
    """The ``_envelope`` (2, m) of a band of half-width w with no zeros in it: first[i] = max(i - w, 0), last[j] =
    min(j + w, m - 1) (a full G: w = m - 1)."""
    envelope = np.empty((2, m), dtype=np.int64)
    for i in range(m):
        envelope[0, i], envelope[1, i] = max(i - w, 0), min(i + w, m - 1)
    return envelope


@njit(cache=True, nogil=True, inline="always")
def _gram(J, products, G):
    """G = Psi_q Psi_q^T in lower band storage, G[i, t] = (Psi_q Psi_q^T)[i, i - t], rows in the order of
    ``_gram_products``: each entry the sum of its products in their order (the merge of two rows' columns gave
    the same sums, to the last bit). J and G C-contiguous (``reshape`` refuses others): their flat places."""
    flat, gram = J.reshape(J.size), G.reshape(G.size)
    gram[:] = 0.0
    for p in range(products.shape[0]):
        gram[products[p, 0]] += flat[products[p, 1]] * flat[products[p, 2]]


@njit(cache=True, nogil=True)
def _cholesky(G, a, b, L):
    """L L^T = a G + b I (band storage as G's, L[i, 0] holding 1 / L_ii: a product where the pivot's division
    cost most of the factorization on a narrow band), True if it is positive definite (every pivot > 0): the Sturm
    test of continuation, here of an eigenvalue bound (a = 1, b = -s: all eigenvalues of G above s; a = -1, b = s:
    all below s), O(m w^2) (Golub and Van Loan, Matrix Computations, sec. 4.3.5, band Cholesky; sec. 8.4.1).
    Each row from its first nonzero entry of G on (its envelope: no fill before it, George and Liu, ch. 4; the loop
    chain's G, 5 wide, holds 2-5 entries left of the diagonal): L is zero before it, so the sums skip products that
    are exact zeros, the same figures to the last bit."""
    m, w = G.shape[0], G.shape[1] - 1
    for i in range(m):
        top = min(w, i)
        while top > 0 and G[i, top] == 0.0:
            L[i, top] = 0.0
            top -= 1
        first = i - top  # the row's first nonzero column
        for t in range(top, 0, -1):
            j = i - t
            total = a * G[i, t]
            for k in range(first, j):
                total -= L[i, i - k] * L[j, j - k]
            L[i, t] = total * L[j, 0]
        total = a * G[i, 0] + b
        for k in range(first, i):
            total -= L[i, i - k] * L[i, i - k]
        if not total > 0.0:
            return False
        L[i, 0] = 1.0 / np.sqrt(total)
    return True


@njit(cache=True, nogil=True, inline="always")
def _cholesky_pair(G, above, below, upper, lower):
    """``_cholesky`` of above I - G into ``upper`` and of G - below I into ``lower`` (the first tests of lambda_1's
    and lambda_m's brackets, ``_bracketed_ratio``), side by side: True if both are positive definite. Each factor's
    sums wait on the product before and each row on the rows before (a square root and a division), the two
    factors not on each other: with each sum of the one beside the same sum of the other, the processor overlaps
    them (on the loop chain's G, 26 x 6: 0.6 of the two apart). Each sum in ``_cholesky``'s order: the same
    factors to the last bit."""
    w = G.shape[1] - 1
    for i in range(G.shape[0]):
        top = min(w, i)
        while top > 0 and G[i, top] == 0.0:
            upper[i, top], lower[i, top] = 0.0, 0.0
            top -= 1
        first = i - top
        for t in range(top, 0, -1):
            j = i - t
            one, other = -1.0 * G[i, t], 1.0 * G[i, t]
            for k in range(first, j):
                one -= upper[i, i - k] * upper[j, j - k]
                other -= lower[i, i - k] * lower[j, j - k]
            upper[i, t], lower[i, t] = one * upper[j, 0], other * lower[j, 0]
        one, other = -1.0 * G[i, 0] + above, 1.0 * G[i, 0] + -below
        for k in range(first, i):
            one -= upper[i, i - k] * upper[i, i - k]
            other -= lower[i, i - k] * lower[i, i - k]
        if not (one > 0.0 and other > 0.0):
            return False
        upper[i, 0], lower[i, 0] = 1.0 / np.sqrt(one), 1.0 / np.sqrt(other)
    return True


@njit(cache=True, nogil=True)
def _solve_normalized(L, x, envelope):
    """x <- (L L^T)^-1 x / |(L L^T)^-1 x|: one step of inverse iteration with the factor of ``_cholesky``, over
    G's ``envelope`` (``_envelope``: the products left out are of the factor's exact zeros; ``_whole_band``)."""
    m = L.shape[0]
    first, last = envelope[0], envelope[1]
    for i in range(m):
        total = x[i]
        for k in range(first[i], i):
            total -= L[i, i - k] * x[k]
        x[i] = total * L[i, 0]
    size = 0.0
    for i in range(m - 1, -1, -1):
        total = x[i]
        for k in range(i + 1, last[i] + 1):
            total -= L[k, k - i] * x[k]
        x[i] = total * L[i, 0]
        size += x[i] * x[i]
    x *= 1.0 / np.sqrt(size)


@njit(cache=True, nogil=True, inline="always")
def _solve_pair(upper, high, lower, low, envelope):
    """``_solve_normalized`` of ``high`` with ``upper`` and of ``low`` with ``lower``, side by side (as
    ``_cholesky_pair``: two chains of dependent sums the processor overlaps), each sum in its order: the same
    vectors to the last bit as two calls. Over G's ``envelope`` (``_envelope``) alone: the products left out are of
    the factors' exact zeros."""
    m = upper.shape[0]
    first, last = envelope[0], envelope[1]
    for i in range(m):
        one, other = high[i], low[i]
        for k in range(first[i], i):
            one -= upper[i, i - k] * high[k]
            other -= lower[i, i - k] * low[k]
        high[i], low[i] = one * upper[i, 0], other * lower[i, 0]
    above, below = 0.0, 0.0
    for i in range(m - 1, -1, -1):
        one, other = high[i], low[i]
        for k in range(i + 1, last[i] + 1):
            one -= upper[k, k - i] * high[k]
            other -= lower[k, k - i] * low[k]
        high[i], low[i] = one * upper[i, 0], other * lower[i, 0]
        above += high[i] * high[i]
        below += low[i] * low[i]
    high *= 1.0 / np.sqrt(above)
    low *= 1.0 / np.sqrt(below)


@njit(cache=True, nogil=True)
def _rayleigh(G, x, envelope):
    """x^T G x of a unit x, G in lower band storage, over its ``envelope`` (``_envelope``: past it, exact zeros)."""
    m, first = G.shape[0], envelope[0]
    total = 0.0
    for i in range(m):
        total += G[i, 0] * x[i] * x[i]
        for t in range(1, i - first[i] + 1):
            total += 2.0 * G[i, t] * x[i] * x[i - t]
    return total


@njit(cache=True, nogil=True)
def _warm(x):
    """The vector of the time before, nudged along every eigenvector (a fixed pseudo-random vector), unit: inverse
    iteration from it reaches the extreme eigenvalue even where two eigenvalues crossed since."""
    for i in range(x.size):
        x[i] += 1e-3 * np.sin(0.7 * i + 0.3)
    x /= np.sqrt(np.dot(x, x))


@njit(cache=True, nogil=True)
def _largest(G, L, x, envelope):
    """sigma_1^2, the largest eigenvalue of G = Psi_q Psi_q^T, in a bracket [lo, hi] closed to EXTREME_TOLERANCE: lo
    from Rayleigh quotients of inverse iteration shifted to hi (x, the vector of the time before, converges to
    its eigenvector), hi from a Cholesky test of hi' I - G at a trial just above lo; NaN if it does not close.
    G's rounding is eps sigma_1^2, so the figure has full relative accuracy. x: updated to the eigenvector."""
    m = G.shape[0]
    hi, lo = 0.0, 0.0
    for i in range(m):  # Gershgorin's bound, and the largest diagonal entry
        total = 0.0
        for t in range(G.shape[1]):
            if t <= i:
                total += abs(G[i, t])
            if t > 0 and i + t < m:
                total += abs(G[i + t, t])
        hi, lo = max(hi, total), max(lo, G[i, 0])
    hi *= 1.0 + 1e-12
    _warm(x)
    lo = max(lo, _rayleigh(G, x, envelope))
    factored = False
    guess = lo * (1.0 + GUESS)  # the Rayleigh quotient of the time before's eigenvector: sigma_1^2 is rarely far above
    if guess < hi and _cholesky(G, -1.0, guess, L):
        hi, factored = guess, True
    step = STEP
    for _ in range(_ROUNDS):
        if hi - lo <= EXTREME_TOLERANCE * hi:
            return lo
        if not factored and not _cholesky(G, -1.0, hi, L):
            return np.nan
        for _ in range(2):
            _solve_normalized(L, x, envelope)
        lo = max(lo, _rayleigh(G, x, envelope))
        if hi - lo <= EXTREME_TOLERANCE * hi:
            return lo
        trial = lo + max(step * (hi - lo), 0.5 * EXTREME_TOLERANCE * lo)
        factored = _cholesky(G, -1.0, trial, L)
        if factored:
            hi, step = trial, STEP
        else:  # sigma_1^2 lies further up (the vector is still in a cluster below it): longer steps, up to bisection
            lo, step = trial, min(0.5, 100.0 * step)
    return np.nan


@njit(cache=True, nogil=True)
def _smallest(J, rows, starts, indices, G, L, x, largest, y, envelope):
    """sigma_m^2, the smallest eigenvalue of G = Psi_q Psi_q^T: the Rayleigh quotient |Psi_q^T x|^2 of inverse
    iteration (from Psi_q itself, not G: no squaring of the condition, the figure to the dense SVD's accuracy),
    certified the smallest by a Cholesky test of G - s I at s just below it, the shift then taken for two more
    iterations (their rate (sigma_m^2 - s) / (sigma_(m-1)^2 - s) ~ 0); NaN where G's rounding (16 eps sigma_1^2)
    is more than CERTIFIED of sigma_m^2, or the bracket does not close. x: updated to the eigenvector."""
    floor = 16.0 * np.finfo(np.float64).eps * largest
    if not _cholesky(G, 1.0, 0.0, L):
        return np.nan
    _warm(x)
    lo, hi, step = 0.0, np.inf, STEP
    for _ in range(_ROUNDS):
        for _ in range(2):
            _solve_normalized(L, x, envelope)
        y[:] = 0.0
        for i in range(rows.size):
            r = rows[i]
            for p in range(starts[r], starts[r + 1]):
                y[indices[p]] += J[r, indices[p]] * x[i]
        hi = min(hi, np.dot(y, y))
        width = max(EXTREME_TOLERANCE, floor / hi)
        if width > CERTIFIED:
            return np.nan
        if hi - lo <= width * hi:
            return hi
        trial = hi - max(step * (hi - lo), 0.5 * width * hi)
        if _cholesky(G, 1.0, -trial, L):
            lo, step = trial, STEP
        elif not _cholesky(G, 1.0, -lo, L):
            return np.nan
        else:  # sigma_m^2 lies further down: longer steps, up to bisection
            step = min(0.5, 100.0 * step)
    return np.nan


@njit(cache=True, nogil=True)
def _iterated_ratio(J, rows, starts, indices, products, envelope, G, L, low, high, y):
    """sigma_m / sigma_1 of Psi_q from its Gram matrix's extreme eigenvalues (``_largest``, ``_smallest``): O(m w^2)
    per Cholesky test and a few of them, against the band's bidiagonal reduction's O(n^2 (kl + ku)); NaN where
    they cannot give it (the caller takes the exact route). low, high: the eigenvectors of the time before;
    products: ``_gram_products`` of the pattern; envelope: G's (``_envelope``)."""
    _gram(J, products, G)
    largest = _largest(G, L, high, envelope)
    if not np.isfinite(largest) or largest <= 0.0:
        return np.nan
    smallest = _smallest(J, rows, starts, indices, G, L, low, largest, y, envelope)
    return np.sqrt(smallest / largest)


@njit(cache=True, nogil=True, inline="always")
def _bracketed_ratio(J, rows, starts, indices, products, envelope, G, factors, low, high, y, loose, spread):
    """(figure, lower bound) of sigma_m / sigma_1 with each extreme eigenvalue of G = Psi_q Psi_q^T in a bracket
    about ``loose`` wide, by one or two Cholesky tests each (``_top``, ``_bottom``), from the eigenvectors ``high``,
    ``low`` of the times before (``_extrapolate``), where ``_iterated_ratio`` takes 8-9 tests and 14 solves to
    close it. The figure sqrt(lambda_m's upper / lambda_1's lower) is the ratio's upper end. (NaN, NaN) where a
    bound's tests fail (its vector too far off: the first time) or G's rounding (``_smallest``'s floor) is not well
    below lambda_m's bracket: ``_iterated_ratio`` then. ``products`` with no rows: G already made (``_dense_gram``).
    ``envelope`` (2, m): G's (``_envelope``). ``factors`` (2, m, w + 1): the two brackets' Cholesky factors.
    The two brackets are independent but for lambda_m's rounding test, which reads lambda_1's upper end: their
    first tests and inverse-iteration steps run side by side (``_cholesky_pair``, ``_solve_pair``) where both
    first tests pass and that rounding test passes whatever lambda_1's bracket becomes (it only narrows), else one
    after the other; either way the arithmetic of ``_top`` then ``_bottom``: the same figures to the last bit."""
    if products.shape[0]:
        _gram(J, products, G)
    quotient, hi = _quotients(G, high, J, rows, starts, indices, low, y, envelope)
    lo, width = _top_start(G, quotient, loose, spread)
    above, below = lo * (1.0 + width), hi * (1.0 - _bottom_width(loose, spread))
    if _rounding_ok(2.0 * above, below, loose) and _cholesky_pair(G, above, below, factors[0], factors[1]):
        _solve_pair(factors[0], high, factors[1], low, envelope)
        quotient, residual = _quotients(G, high, J, rows, starts, indices, low, y, envelope)
        top, ceiling = _top_sharpen(G, factors[0], quotient, lo, above, loose, spread)
        bottom, floor = _bottom_sharpen(G, factors[1], residual, hi, below, loose, spread)
        return np.sqrt(bottom / top), np.sqrt(floor / ceiling)
    top, ceiling = _top(G, factors[0], high, loose, spread, envelope)
    if not np.isfinite(ceiling):
        return np.nan, np.nan
    bottom, floor = _bottom(J, rows, starts, indices, G, factors[0], low, y, loose, spread, ceiling, envelope)
    if not np.isfinite(floor):
        return np.nan, np.nan
    return np.sqrt(bottom / top), np.sqrt(floor / ceiling)


@njit(cache=True, nogil=True)
def _top(G, L, x, loose, spread, envelope):
    """(lo, hi) about lambda_1 of G: lo the Rayleigh quotient of x (or G's largest diagonal entry), hi = lo (1 + s)
    if hi I - G is positive definite (Cholesky), s = four times how far the time before's quotient was off
    (``spread[0]``, updated), at least ``loose``; a hundred times wider if that fails. The factor then takes one step
    of inverse iteration shifted to hi (Parlett, ch. 4; its rate (hi - lambda_1) / (hi - lambda_2) is small), whose
    quotient is the sharper lo and x the next time's; where hi - lo is still above ``loose`` lo, one more test at
    lo (1 + loose) (``_top_sharpen``). (lo, NaN) where both first tests fail."""
    lo, width = _top_start(G, _rayleigh(G, x, envelope), loose, spread)
    hi = lo * (1.0 + width)
    if not _cholesky(G, -1.0, hi, L):
        width = min(0.5, 100.0 * width)
        hi = lo * (1.0 + width)
        if not _cholesky(G, -1.0, hi, L):
            spread[0] = width
            return lo, np.nan
    _solve_normalized(L, x, envelope)
    return _top_sharpen(G, L, _rayleigh(G, x, envelope), lo, hi, loose, spread)


@njit(cache=True, nogil=True, inline="always")
def _top_start(G, quotient, loose, spread):
    """(lo, s) of ``_top``: the Rayleigh ``quotient`` of its vector or G's largest diagonal entry, and the first
    test's width."""
    lo = 0.0
    for i in range(G.shape[0]):
        lo = max(lo, G[i, 0])
    return max(lo, quotient), max(loose, spread[0])


@njit(cache=True, nogil=True, inline="always")
def _top_sharpen(G, L, quotient, lo, hi, loose, spread):
    """``_top``'s (lo, hi) after its step of inverse iteration, given its vector's new Rayleigh ``quotient``: the
    sharper lo, ``spread[0]``, and where hi - lo is still above ``loose`` lo, one more test at lo (1 + loose)."""
    sharper = max(lo, quotient)
    spread[0] = 4.0 * (sharper - lo) / sharper
    lo = sharper
    if hi - lo > loose * lo and _cholesky(G, -1.0, lo * (1.0 + loose), L):
        hi = lo * (1.0 + loose)
    return lo, hi


@njit(cache=True, nogil=True)
def _bottom(J, rows, starts, indices, G, L, x, y, loose, spread, ceiling, envelope):
    """(hi, lo) about lambda_m of G, as ``_top`` from below: hi = |Psi_q^T x|^2 (``_residual``: from Psi_q, the dense
    SVD's accuracy), lo = hi (1 - s) if G - lo I is positive definite (``spread[1]``); (hi, NaN) where both first
    tests fail or G's rounding, 16 eps ``ceiling`` (lambda_1's upper bound), is above a tenth of ``loose`` lo
    (``_rounding_ok``)."""
    hi, width = _residual(J, rows, starts, indices, x, y), _bottom_width(loose, spread)
    lo = hi * (1.0 - width)
    if not _rounding_ok(ceiling, lo, loose):
        return hi, np.nan
    if not _cholesky(G, 1.0, -lo, L):
        width = min(0.5, 100.0 * width)
        lo = hi * (1.0 - width)
        if not _cholesky(G, 1.0, -lo, L):
            spread[1] = width
            return hi, np.nan
    _solve_normalized(L, x, envelope)
    return _bottom_sharpen(G, L, _residual(J, rows, starts, indices, x, y), hi, lo, loose, spread)


@njit(cache=True, nogil=True, inline="always")
def _bottom_width(loose, spread):
    """The relative width of ``_bottom``'s first test."""
    return min(0.5, max(loose, spread[1]))


@njit(cache=True, nogil=True, inline="always")
def _rounding_ok(ceiling, lo, loose):
    """Whether G's rounding, 16 eps ``ceiling`` (an upper bound of lambda_1), is at most a tenth of ``loose`` lo: a
    Cholesky test of G - lo I can then certify lambda_m's bracket (``_bottom``)."""
    return not 16.0 * np.finfo(np.float64).eps * ceiling > 0.1 * loose * lo


@njit(cache=True, nogil=True, inline="always")
def _bottom_sharpen(G, L, residual, hi, lo, loose, spread):
    """``_bottom``'s (hi, lo) after its step of inverse iteration, given its vector's new ``residual`` |Psi_q^T x|^2,
    as ``_top_sharpen``."""
    sharper = min(hi, residual)
    spread[1] = 4.0 * (hi - sharper) / sharper
    hi = sharper
    if hi - lo > loose * hi and _cholesky(G, 1.0, -hi * (1.0 - loose), L):
        lo = hi * (1.0 - loose)
    return hi, lo


@njit(cache=True, nogil=True, inline="always")
def _widened(figure, bound):
    """(upper, lower) of a ratio's bracket [bound, figure] from ``_bracketed_ratio`` widened by G's rounding (16 eps
    lambda_1 on each eigenvalue's test, relative to lambda_m: 16 eps / ratio^2) and 1e-12: its ends are Rayleigh
    quotients and Cholesky tests, bounds of the exact ratio only up to that rounding (on a constant ratio the bare
    quotient falls an ulp below the exact figure), so widened it holds the closed figure too (``_iterated_ratio``'s
    to EXTREME_TOLERANCE, Jacobi's), and a comparison with a closed neighbour goes the way theirs does."""
    margin = 1e-12 + 16.0 * np.finfo(np.float64).eps / (bound * bound)
    return figure * (1.0 + margin), bound * (1.0 - margin)


@njit(cache=True, nogil=True, inline="always")
def _carried(upper, lower, moved):
    """(upper, lower) ends of the ratio sigma_m / sigma_1 of the scaled J_k from those of J_k-1 and ``moved``, a bound
    of |J_k - J_k-1|_2 (``_scale``). Weyl's inequality: each singular value moves by at most delta = |J_k - J_k-1|_2,
    so with x = delta / sigma_1(J_k-1) <= delta (sigma_1 >= 1: rows of unit length),
    r_k >= (sigma_m - delta) / (sigma_1 + delta) = (r - x) / (1 + x) >= (lower - delta) / (1 + delta) and r_k <=
    (r + x) / (1 - x) <= (upper + delta) / (1 - delta) (the first decreasing, the second increasing in x); delta
    and the ends widened by 1e-12 relative for the rounding of ``moved`` (~m eps) and of these operations, as
    ``_widened``: the carried bracket holds the exact ratio and the closed figure (to 1e-13). (inf, 0) where delta
    >= 1 or the lower end is not positive: no bound."""
    delta = moved * (1.0 + 1e-12)
    if not (delta < 1.0 and lower > delta):
        return np.inf, 0.0
    return (upper + delta) / (1.0 - delta) * (1.0 + 1e-12), (lower - delta) / (1.0 + delta) * (1.0 - 1e-12)


@njit(cache=True, nogil=True, inline="always")
def _away(before, last, smallest, thresholds):
    """Whether the ratio at the next time is likely more than 5 % above the smallest so far and 5 % off each
    threshold: the last figure plus or minus twice its last step's change is (``WIDE``'s choice, of cost alone: a
    WIDE bracket that reaches the smallest or a threshold is closed by ``settled``)."""
    change = 2.0 * abs(last - before)
    for value in thresholds:
        if last - change < 1.05 * value and last + change > 0.95 * value:
            return False
    return last - change > 1.05 * smallest


@njit(cache=True, nogil=True, inline="always")
def _carries(upper, lower, before_upper, before_lower, smallest, thresholds):
    """Whether a carried bracket [lower, upper] (``_carried``) is kept: at most CARRIED wide, above the least upper
    end so far (no candidate for the smallest: ``settled`` would close it), on one side of each threshold and no
    dip of its own nor of the time before (a dip's middle is under half its neighbours: 2 lower above the time
    before's upper end, upper under the time before's lower end times 1.6). A choice of cost alone: any bracket
    that holds the ratio gives the verdicts, ``settled`` closes the times whose tests it leaves open."""
    if not (upper <= CARRIED * lower and lower > smallest):
        return False
    for value in thresholds:
        if lower < value <= upper:
            return False
    return 2.0 * lower > 1.25 * before_upper and upper < 1.6 * before_lower


@njit(cache=True, nogil=True, inline="always")
def _extrapolate(x, before, scratch):
    """x <- 2 x - x_before, unit, and x_before <- x (the eigenvector of the last time; ``before`` of the time before
    it): a linear extrapolation in time of the vectors ``_bracketed_ratio`` starts from, whose error is then
    second order in the output interval where the vector of the time before has a first-order one (their signs
    follow each other: inverse iteration with a definite factor keeps them). ``scratch``: at least x's size."""
    size = 0.0
    for i in range(x.size):
        scratch[i] = x[i]
        x[i] = 2.0 * x[i] - before[i]
        size += x[i] * x[i]
    size = 1.0 / np.sqrt(size)
    for i in range(x.size):
        x[i] *= size
        before[i] = scratch[i]


@njit(cache=True, nogil=True)
def _residual(J, rows, starts, indices, x, y):
    """|Psi_q^T x|^2 (x along G's rows, ``rows``): the Rayleigh quotient of G at a unit x without forming G."""
    y[:] = 0.0
    for i in range(rows.size):
        _add_row(J, rows[i], starts, indices, x[i], y)
    return _squares(y)


@njit(cache=True, nogil=True, inline="always")
def _add_row(J, r, starts, indices, weight, y):
    """y += weight times row r of Psi_q (on its pattern: ``starts``, ``indices``)."""
    for p in range(starts[r], starts[r + 1]):
        y[indices[p]] += J[r, indices[p]] * weight


@njit(cache=True, nogil=True, inline="always")
def _squares(y):
    """|y|^2, summed from the first entry."""
    total = 0.0
    for c in range(y.size):
        total += y[c] * y[c]
    return total


@njit(cache=True, nogil=True, inline="always")
def _quotients(G, high, J, rows, starts, indices, low, y, envelope):
    """(``_rayleigh`` of ``high``, ``_residual`` of ``low``) in one pass over the rows: two serial sums side by side,
    which the processor overlaps (``_bracketed_ratio``); each in its own order, the same figures to the last bit
    (the Rayleigh quotient over G's ``envelope``, as ``_rayleigh``)."""
    m, first = G.shape[0], envelope[0]
    y[:] = 0.0
    quotient = 0.0
    for i in range(m):
        quotient += G[i, 0] * high[i] * high[i]
        for t in range(1, i - first[i] + 1):
            quotient += 2.0 * G[i, t] * high[i] * high[i - t]
        _add_row(J, rows[i], starts, indices, low[i], y)
    return quotient, _squares(y)


CERTAIN = 0.9
"""``certified``'s margin: a step is certified where the bound of |J_k - J_k-1|_2 is below this fraction of the
lower bound of sigma_m (J_k-1) (far above the bounds' rounding, ~1e-15 of them)."""


@njit(cache=True, nogil=True, inline="always")
def certified(moved, lower):
    """Whether the step from t_k-1 to t_k certainly holds no flip of the sign of det [Psi_q; T^T] the Guard tests
    (``guard.Guard._judge``: a rank loss between the two times), from ``moved``, a bound of |J_k - J_k-1|_2 of
    the scaled Psi_q (``_scale``), and ``lower``, the lower end of sigma_m / sigma_1 at t_k-1.
    With T the null-space basis at t_k-1, [J_k-1; T^T] has the singular values of J_k-1 and d ones (J T = 0, T^T T
    = I), so its smallest is min(sigma_m, 1) >= the ratio (sigma_1 >= 1: rows of unit length). By Weyl's
    inequality [J_k-1 + s (J_k - J_k-1); T^T] stays nonsingular for s in [0, 1] where |J_k - J_k-1|_2 is below
    that: det [J_k; T^T] keeps the sign of det [J_k-1; T^T]. It is det(T^T T_k) det [J_k; T_k^T] for any basis T_k
    at t_k (``guard.Guard._judge``), so turn * sign_k * sign_k-1 > 0: no flip, whatever bases are taken
    (Golub and Van Loan, Matrix Computations, sec. 8.6.2). The Guard then needs no basis at t_k for that step."""
    return moved < CERTAIN * lower


@njit(cache=True, nogil=True, inline="always")
def _scale(jacobians, k, columns, norms, starts, indices, slots, J, previous, sums):
    """J <- the scaled Psi_q at time k (as ``guard.scale_rows``, to the last bit, on its pattern alone), previous
    <- the J it held; returns a bound of |J - previous|_2: the least of its Frobenius norm and sqrt(|.|_1 |.|_inf)
    (Golub and Van Loan, sec. 2.3.3; the latter does not grow with the chain's length). ``sums``: work (n,)."""
    m = starts.size - 1
    frobenius, rows = 0.0, 0.0
    sums[:] = 0.0
    for r in range(m):
        norm = norms[k, r] if norms[k, r] > 0.0 else 1.0
        row = 0.0
        for p in range(starts[r], starts[r + 1]):
            c = indices[p]
            previous[r, c] = J[r, c]
            J[r, c] = jacobians[k, r, slots[p]] * columns[c] / norm
            change = abs(J[r, c] - previous[r, c])
            frobenius += change * change
            row += change
            sums[c] += change
        rows = max(rows, row)
    return min(np.sqrt(frobenius), np.sqrt(rows * np.max(sums)))


@njit(cache=True, nogil=True)  # AT_FIRST_CALL
def _spectra(jacobians, columns, norms, position, keys, starts, indices, slots, first, loose, carry, thresholds):
    """(ratios, bases, signs, the ratios' lower bounds, eigenvectors, certified steps) at every time; ``loose`` > 0:
    the ratios in brackets of that relative width where one test a bound gives them (``_bracketed_ratio``), else
    closed; with ``carry``, a time's bracket carried over its step from the time before's where that decides the
    Guard's tests (``thresholds``: ``_carries``), no eigenvalue test there (its eigenvectors the time before's);
    and the basis and sign made only where a step needs them (not ``certified``: both its ends), at the first and
    last times (the Guard compares them with the batches before and after), elsewhere bases NaN and the sign the
    time before's (the sign of a basis carried along continuously, by ``certified``'s proof). ``loose`` = 0: every
    basis made (as closed, no step certified). Entry p of the CSR pattern (row r, column indices[p]) is
    jacobians[k, r, slots[p]]: its column (slots = indices), or its slot among a blocked history's blocks
    (``history.BlockedJacobians``)."""
    N, m = jacobians.shape[:2]
    n = position.size
    d = n - m
    ratios, bases, signs, lower = np.empty(N), np.full((N, n, d), np.nan), np.empty(N), np.empty(N)
    steps = np.zeros(max(N - 1, 0), dtype=np.bool_)  # certified: no flip, no basis needed
    made = np.zeros(N, dtype=np.bool_)
    vectors = np.empty((N, 2, m))  # each time's eigenvectors (``_ratios_at`` starts from them)
    rows = np.argsort(keys, kind="mergesort")  # Psi_q's rows along the band: G = Psi_q Psi_q^T a band too
    w = _gram_width(rows, starts, indices, n)
    products = _gram_products(rows, starts, indices, w, n)
    envelope = _envelope(products, m, w)
    G, factors, low, high, y = np.empty((m, w + 1)), np.empty((2, m, w + 1)), np.ones(m), np.ones(m), np.empty(n)
    L = factors[0]  # ``_bracketed_ratio``'s two factors, ``_iterated_ratio``'s one
    before, ordered, last = first, _parity(position), -1  # the basis E's coordinates come from, and its time
    kept, slot, kl, ku, parity = np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64), 0, 0, 1.0
    ab, pivots = np.empty((0, 0)), np.empty(0, dtype=np.int64)  # the banded LU's work arrays (``_null_space``)
    rest, direction, chosen = np.empty((n, d)), np.empty(d), np.empty(d, dtype=np.int64)  # ``_choose``'s
    spread = np.full(2, 0.5)  # how far the time before's Rayleigh quotients were off (``_bracketed_ratio``)
    earlier = np.empty((2, m))  # the eigenvectors of the time before the last (``_extrapolate``)
    J, previous = np.zeros((m, n)), np.zeros((m, n))  # this time's scaled Psi_q and the time before's
    tested = np.full(2, -1)  # the times of the last two brackets of their own (``_extrapolate``'s spacing)
    smallest = np.inf  # the least upper end so far
    for k in range(N):
        moved = _scale(jacobians, k, columns, norms, starts, indices, slots, J, previous, y)
        ratios[k], lower[k] = np.nan, np.nan
        carried = k >= 2 and np.isfinite(lower[k - 1]) and not tested[1] == k - 1  # the time before's carried
        if carry and k >= 1 and np.isfinite(lower[k - 1]):
            upper, bound = _carried(ratios[k - 1], lower[k - 1], moved)
            if _carries(upper, bound, ratios[k - 1], lower[k - 1], smallest, thresholds):
                ratios[k], lower[k] = upper, bound
        if loose > 0.0 and not np.isfinite(lower[k]):
            spaced = tested[0] >= 0 and k - tested[1] == tested[1] - tested[0]  # evenly: a linear extrapolation
            if spaced and lower[tested[1]] < ratios[tested[1]] and lower[tested[0]] < ratios[tested[0]]:
                _extrapolate(low, earlier[0], y)
                _extrapolate(high, earlier[1], y)
            else:
                for i in range(m):
                    earlier[0, i], earlier[1, i] = low[i], high[i]
            after = carried and _away(ratios[k - 2], ratios[k - 1], smallest, thresholds)  # after a carried one
            width = WIDE if after else loose
            figure, bound = _bracketed_ratio(
                J, rows, starts, indices, products, envelope, G, factors, low, high, y, width, spread
            )
            if np.isfinite(bound):  # widened by G's rounding: it holds the closed figure too
                ratios[k], lower[k] = _widened(figure, bound)
            tested[0], tested[1] = tested[1], k
        if not np.isfinite(lower[k]):
            ratios[k] = _iterated_ratio(J, rows, starts, indices, products, envelope, G, L, low, high, y)
            lower[k] = ratios[k]
        if not np.isfinite(ratios[k]):  # near a rank loss: the bidiagonal reduction's figure
            low[:], high[:] = 1.0, 1.0
            chosen = _independent(before, d)  # E's rows' places along the band (their values do not matter)
            ratios[k] = _ratio(J, _layout(keys, position, chosen), m, starts, indices, position, chosen)
            lower[k] = ratios[k]
        for i in range(m):
            vectors[k, 0, i], vectors[k, 1, i] = low[i], high[i]
        smallest = min(smallest, ratios[k])
        if k >= 1:
            steps[k - 1] = loose > 0.0 and certified(moved, lower[k - 1])
        open_step = k == 0 or not steps[k - 1]  # the step to t_k needs its ends' bases
        for at in range(max(k - 1, 0), k + 1):
            if made[at] or not (open_step or at == N - 1):
                continue
            source = previous if at < k else J
            for _ in range(2):  # E from the nearest basis made; after a gap, again from this one if it picks others
                _choose(before, rest, direction, chosen)
                changed = last < 0
                for a in range(d):
                    changed = changed or chosen[a] != kept[a]
                if changed:  # E's coordinates changed: the band's rows, widths and parity
                    kept, slot = chosen.copy(), _layout(keys, position, chosen)
                    kl, ku = _widths(slot, m, starts, indices, position, chosen, True)
                    parity = _parity(slot) * ordered
                    ab, pivots = np.empty((n, 2 * kl + ku + 1)), np.empty(n, dtype=np.int64)
                signs[at] = _null_space(source, slot, m, starts, indices, position, chosen, parity, kl, ku, ab, pivots,
                                        y, bases[at])  # fmt: skip
                gap = last >= 0 and at - last > 1
                if np.all(np.isfinite(bases[at])):
                    before, last = bases[at], at
                if not gap:
                    break
                _choose(before, rest, direction, chosen)
                if np.all(chosen == kept):
                    break
            made[at] = True
        if not made[k]:  # the sign of the basis carried along from the time before (``certified``)
            signs[k] = signs[k - 1]
    return ratios, bases, signs, lower, vectors, steps


@njit(cache=True, nogil=True)  # AT_FIRST_CALL
def _ratios_at(jacobians, columns, norms, position, keys, starts, indices, slots, bases, vectors, times):
    """The ratios closed to EXTREME_TOLERANCE (``_spectra``'s) at the output times ``times`` alone, each from the
    eigenvectors its bracket left (``vectors`` (N, 2, m): lambda_m's, lambda_1's); ``bases``: the null-space bases
    (E's rows, for the bidiagonal route: the nearest made at or before the time); ``slots``: as ``_spectra``'s."""
    N, m = jacobians.shape[:2]
    n = position.size
    rows = np.argsort(keys, kind="mergesort")
    w = _gram_width(rows, starts, indices, n)
    products = _gram_products(rows, starts, indices, w, n)
    envelope = _envelope(products, m, w)
    G, L, y, J = np.empty((m, w + 1)), np.empty((m, w + 1)), np.empty(n), np.zeros((m, n))
    ratios = np.empty(times.size)
    for a in range(times.size):
        k = times[a]
        for r in range(m):
            norm = norms[k, r] if norms[k, r] > 0.0 else 1.0
            for p in range(starts[r], starts[r + 1]):
                J[r, indices[p]] = jacobians[k, r, slots[p]] * columns[indices[p]] / norm
        low, high = vectors[k, 0].copy(), vectors[k, 1].copy()
        ratios[a] = _iterated_ratio(J, rows, starts, indices, products, envelope, G, L, low, high, y)
        if not np.isfinite(ratios[a]):
            made = k
            while made > 0 and not np.all(np.isfinite(bases[made])):  # the nearest basis made (``_spectra``)
                made -= 1
            chosen = _independent(bases[made], n - m)
            ratios[a] = _ratio(J, _layout(keys, position, chosen), m, starts, indices, position, chosen)
    return ratios


def dense_spectra(
    jacobians: np.ndarray, columns: np.ndarray, norms: np.ndarray, bases: bool = True, settle: tuple | None = None
):
    """``spectra`` of a small Psi_q (N, m, n), m <= n, full row rank, not a band: in one compiled pass over the output
    times, without numpy's per-matrix overhead (on the slider-crank's 101 Psi_q of 9 x 9, batched SVDs and QRs
    cost 1 ms): Householder's QR of Psi_q^T (``_householder``, as ``guard.null_space_bases``) gives T and the
    sign of det [Psi_q; T^T], and R, whose singular values are Psi_q's: sigma_m / sigma_1 by one-sided Jacobi
    (``_jacobi_ratio``). ``bases=False``: T left out (n x 0). NaN where Jacobi did not settle (the dense SVD's).
    ``settle`` (the Guard's tests, as ``spectra``'s): each ratio first in a bracket about LOOSE wide from the Gram
    matrix's extreme eigenvalues (``_bracketed_ratio``, one or two Cholesky tests a bound, m^3 / 6 each, where
    Jacobi's sweeps cost ~10 m^3), Jacobi only at the times ``settled`` leaves open: there the same figure to the
    last bit (the same R, the same sweeps), elsewhere a bracket that decides every test of the Guard as the figure
    does (``_dense_bracketed``)."""
    scale = (np.ascontiguousarray(columns, dtype=float), np.ascontiguousarray(norms, dtype=float))
    jacobians = np.ascontiguousarray(jacobians, dtype=float)
    if settle is None or jacobians.shape[1] < BRACKETED_SMALLEST:
        return _dense_spectra(jacobians, *scale, bool(bases))
    ratios, tangents, signs, lower = _dense_bracketed(jacobians, *scale, bool(bases), LOOSE)
    if np.array_equal(lower, ratios):  # every ratio closed in the pass
        return ratios, tangents, signs
    times = _unsettled(lower, ratios, signs, *_tests(settle), True)
    if times.size:
        ratios[times] = _closed_ratios(jacobians, *scale, times)
    return ratios, tangents, signs


@njit(cache=True, nogil=True)
def _householder(J, V, beta, T):
    """Householder's QR of Psi_q^T (n x m) = Q R: the sign of det [Psi_q; T^T] = det R_1 det Q (each reflector
    det -1), and, if T has columns, the null-space basis T (n x d) = Q's last d columns, the reflectors applied to
    the identity's last columns last first (Golub and Van Loan, sec. 5.1.6). J (m x n, Psi_q's rows: Psi_q^T's
    columns) is overwritten, R^T in its first m columns; 0 where a column of R vanishes."""
    m, n = J.shape
    sign = 1.0
    for j in range(m):
        norm = 0.0
        for i in range(j, n):
            norm += J[j, i] * J[j, i]
        norm = np.sqrt(norm)
        if norm == 0.0:
            beta[j] = 0.0
            sign = 0.0
            continue
        alpha = -norm if J[j, j] >= 0.0 else norm  # R's diagonal entry, away from J[j, j] (no cancellation)
        size = 0.0
        for i in range(j, n):
            V[j, i] = J[j, i] - (alpha if i == j else 0.0)
            size += V[j, i] * V[j, i]
        beta[j] = 2.0 / size
        for c in range(j + 1, m):
            along = 0.0
            for i in range(j, n):
                along += V[j, i] * J[c, i]
            along *= beta[j]
            for i in range(j, n):
                J[c, i] -= along * V[j, i]
        J[j, j] = alpha
        for i in range(j + 1, n):
            J[j, i] = 0.0
        sign = -sign if alpha > 0.0 else sign  # sign(alpha) times the reflector's -1
    d = T.shape[1]
    for a in range(d):
        for i in range(n):
            T[i, a] = 1.0 if i == m + a else 0.0
    for j in range(m - 1, -1, -1):
        if beta[j] == 0.0:
            continue
        for a in range(d):
            along = 0.0
            for i in range(j, n):
                along += V[j, i] * T[i, a]
            along *= beta[j]
            for i in range(j, n):
                T[i, a] -= along * V[j, i]
    return sign


@njit(cache=True, nogil=True)
def _squared_norms(B, sizes):
    """sizes[p] = |B_p|^2 of every row p of B."""
    for p in range(B.shape[0]):
        sizes[p] = 0.0
        for i in range(B.shape[1]):
            sizes[p] += B[p, i] * B[p, i]


@njit(cache=True, nogil=True)
def _jacobi_ratio(B):
    """sigma_m / sigma_1 of the square B (m x m; here R^T of ``_householder``: Psi_q's singular values) by
    one-sided Jacobi (Hestenes): plane rotations of pairs of rows until every pair is orthogonal to rounding,
    the row norms then the singular values, to high relative accuracy (Demmel and Veselic, SIAM J. Matrix Anal.
    Appl. 13, 1992); after a QR, few sweeps. O(m^3) a sweep, no LAPACK call: on the matrices of a small
    mechanism it costs less than the call. NaN if the sweeps do not settle. (Every product by loops: numba's np.dot
    of two rows calls BLAS, whose call costs more than a row of 9; the test |c| <= tol sqrt(s_p s_q) squared.)"""
    m = B.shape[0]
    sizes = np.empty(m)  # the rows' squared norms, updated by each rotation (de Rijk's bookkeeping)
    tolerance = np.sqrt(m) * np.finfo(np.float64).eps  # orthogonal to rounding (LAPACK's dgesvj)
    _squared_norms(B, sizes)
    for _ in range(30):
        rotated = False
        for p in range(m - 1):
            for q in range(p + 1, m):
                c = 0.0
                for i in range(m):
                    c += B[p, i] * B[q, i]
                if c * c <= tolerance * tolerance * (sizes[p] * sizes[q]):
                    continue
                rotated = True
                zeta = (sizes[q] - sizes[p]) / (2.0 * c)
                t = (1.0 if zeta >= 0.0 else -1.0) / (abs(zeta) + np.sqrt(1.0 + zeta * zeta))
                cs = 1.0 / np.sqrt(1.0 + t * t)
                sn = cs * t
                for i in range(m):
                    x, y = B[p, i], B[q, i]
                    B[p, i], B[q, i] = cs * x - sn * y, sn * x + cs * y
                sizes[p] -= t * c
                sizes[q] += t * c
        if not rotated:
            _squared_norms(B, sizes)
            largest = np.max(sizes)
            return np.sqrt(np.min(sizes) / largest) if largest > 0.0 else 0.0
    return np.nan


@njit(_DENSE, cache=True, nogil=True)
def _dense_spectra(jacobians, columns, norms, bases):
    N, m, n = jacobians.shape
    d = n - m
    ratios, signs = np.empty(N), np.empty(N)
    tangents = np.zeros((N, n, d if bases else 0))
    J, V, beta, B = np.empty((m, n)), np.zeros((m, n)), np.empty(m), np.empty((m, m))
    for k in range(N):
        for r in range(m):
            norm = norms[k, r] if norms[k, r] > 0.0 else 1.0
            for c in range(n):  # as ``guard.scale_rows``, to the last bit
                J[r, c] = jacobians[k, r, c] * columns[c] / norm
        signs[k] = _householder(J, V, beta, tangents[k])
        _leading(J, B)  # R^T
        ratios[k] = _jacobi_ratio(B)
    return ratios, tangents, signs


@njit(cache=True, nogil=True)
def _dense_gram(J, G):
    """``_gram`` of a dense Psi_q (m x n; G (m, m) in lower band storage, w = m - 1): each entry's products in the
    order of the columns, as ``_gram_products`` lists them for a full pattern (the same sums), without reading
    their indices."""
    m, n = J.shape
    for i in range(m):
        for t in range(i + 1):
            total = 0.0
            for c in range(n):
                total += J[i, c] * J[i - t, c]
            G[i, t] = total


@njit(_BRACKETED, cache=True, nogil=True)
def _dense_bracketed(jacobians, columns, norms, bases, loose):
    """``_dense_spectra`` with each ratio in a bracket where one pays: (figures, bases, signs, lower bounds). The
    bracket is the band route's (``_bracketed_ratio`` on the dense pattern, from the eigenvectors of the times
    before, extrapolated), widened by G's rounding (16 eps lambda_1, relative to lambda_m: 16 eps / ratio^2) and
    1e-12, so that it holds Jacobi's figure too (a constant ratio's bracket then overlaps Jacobi's figure at the
    time before, as its exact value does, where the bare Rayleigh quotients can fall an ulp below it and decide a
    tie).
    Jacobi at once (closed: lower = figure) at the first time, where a bracket fails (its eigenvectors then iterated
    to convergence for the next time's, ``_iterated_ratio``), and where the ratio cannot have moved by a bracket's
    width since the time before, so that ``settled`` would close both anyway: by Weyl's inequality each singular
    value moves by at most delta = |J_k - J_k-1|_F, so sigma_m / sigma_1 by a relative (1 + 1 / ratio) delta at
    most (sigma_1 >= 1: rows of unit length), to first order (a driven mechanism's constant Psi_q); until a first
    bracket settled apart from the time before's, where the two figures before differ by less than MOVING
    brackets' widths (a start from rest, whose ratio moves less than a bracket's width over the first output times
    while Psi_q moves more; a constant ratio of a moving Psi_q, a cylindrical joint's rotation: their brackets would
    overlap, and ``settled`` close both); and every time once more than half of four or more brackets overlapped
    the time before's or failed (a fast flywheel's ratio: brackets that stay wide). The choices cost m n operations
    a time and decide cost alone, never a figure."""
    N, m, n = jacobians.shape
    d = n - m
    ratios, signs, lower = np.empty(N), np.empty(N), np.empty(N)
    tangents = np.zeros((N, n, d if bases else 0))
    J, previous = np.empty((m, n)), np.empty((m, n))
    S, V, beta, B = np.empty((m, n)), np.zeros((m, n)), np.empty(m), np.empty((m, m))
    rows = np.arange(m)
    starts = np.arange(0, m * n + 1, n)
    indices = np.empty(m * n, dtype=np.int64)
    for r in range(m):
        for c in range(n):
            indices[r * n + c] = c
    products = np.empty((0, 3), dtype=np.int64)  # for ``_iterated_ratio``, made at its first call
    made = np.empty((0, 3), dtype=np.int64)  # ``_bracketed_ratio``: G made by ``_dense_gram``
    full = _whole_band(m, m - 1)  # a full G's envelope
    G, factors, low, high, y = np.empty((m, m)), np.empty((2, m, m)), np.ones(m), np.ones(m), np.empty(n)
    L = factors[0]  # ``_bracketed_ratio``'s two factors, ``_iterated_ratio``'s one
    spread, earlier = np.full(2, 0.5), np.empty((2, m))
    tried, tries, overlaps, apart = True, 0, 0, False  # brackets made, how many overlapped, one apart yet
    for k in range(N):
        moved = 0.0
        for r in range(m):
            norm = norms[k, r] if norms[k, r] > 0.0 else 1.0
            for c in range(n):  # as ``guard.scale_rows``, to the last bit
                previous[r, c] = J[r, c]
                J[r, c] = jacobians[k, r, c] * columns[c] / norm
                moved += (J[r, c] - previous[r, c]) ** 2
        _leading(J, S)
        signs[k] = _householder(S, V, beta, tangents[k])
        ratios[k], lower[k] = np.nan, np.nan
        moving = apart or (k >= 2 and abs(ratios[k - 1] - ratios[k - 2]) > MOVING * loose * ratios[k - 1])
        tried = tried and (tries < 4 or 2 * overlaps <= tries)  # once stopped, for the rest
        if tried and moving and np.sqrt(moved) * (1.0 + 1.0 / lower[k - 1]) >= loose:
            tries += 1
            if k >= 2 and lower[k - 1] < ratios[k - 1] and lower[k - 2] < ratios[k - 2]:  # both bracketed
                _extrapolate(low, earlier[0], y)
                _extrapolate(high, earlier[1], y)
            else:
                for i in range(m):
                    earlier[0, i], earlier[1, i] = low[i], high[i]
            _dense_gram(J, G)
            figure, bound = _bracketed_ratio(
                J, rows, starts, indices, made, full, G, factors, low, high, y, loose, spread
            )
            if np.isfinite(bound):
                ratios[k], lower[k] = _widened(figure, bound)
                if lower[k] <= ratios[k - 1] and lower[k - 1] <= ratios[k]:  # overlaps the time before's
                    overlaps += 1
                else:
                    apart = True
            else:  # the eigenvectors too far off: iterated to convergence for the next time (a failure counts as
                overlaps += 1  # an overlap: as useless)
                if products.shape[0] == 0:
                    products = _gram_products(rows, starts, indices, m - 1, n)
                _iterated_ratio(J, rows, starts, indices, products, full, G, L, low, high, y)
        if not np.isfinite(lower[k]):
            _leading(S, B)  # R^T
            ratios[k] = _jacobi_ratio(B)
            lower[k] = ratios[k]
    return ratios, tangents, signs, lower


@njit(_CLOSED, cache=True, nogil=True)
def _closed_ratios(jacobians, columns, norms, times):
    """Jacobi's sigma_m / sigma_1 at the output times ``times`` alone, as ``_dense_spectra`` makes it there (the same
    scaling, Householder's R and sweeps: the same figure to the last bit)."""
    N, m, n = jacobians.shape
    ratios = np.empty(times.size)
    J, V, beta, B, T = np.empty((m, n)), np.zeros((m, n)), np.empty(m), np.empty((m, m)), np.empty((n, 0))
    for a in range(times.size):
        k = times[a]
        for r in range(m):
            norm = norms[k, r] if norms[k, r] > 0.0 else 1.0
            for c in range(n):
                J[r, c] = jacobians[k, r, c] * columns[c] / norm
        _householder(J, V, beta, T)
        _leading(J, B)
        ratios[a] = _jacobi_ratio(B)
    return ratios


__all__ = [
    "WIDEST",
    "Brackets",
    "WIDEST_MID",
    "WIDEST_SQUARE",
    "band_order",
    "dense_spectra",
    "drifted",
    "history_norms",
    "row_norms",
    "settled",
    "spectra",
]
