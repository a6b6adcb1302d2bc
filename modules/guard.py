# Generated from solutions/guard.py by `make modules` (every homework stubbed): do not edit by hand.
"""The Guard: the checks that keep a run of forward dynamics from returning a wrong answer silently.

An integrator controls the error of its own steps (course notes, sec. 6.3); it cannot see three ways in which a run
of the equations of motion goes wrong while every step is accurate. ``Guard`` checks for each during the run and
stops it with the time and the condition:

1. **Leaving the constraints.** The index-1 formulations integrate Psi_q q'' = gamma, the constraints'
   second derivative (sec. 5.4): Psi itself drifts. At every output time the distance of q from each constraint,
   |Psi_i| / |grad Psi_i| (angles measured as arc lengths), must stay below drift_limit times the mechanism's
   size (``check_drift``).
2. **Passing a singular configuration.** Where Psi_q loses rank (a change point, a toggle; sec. 4.3) the
   multipliers grow without bound and the motion is not decided by the equations. The Guard watches
   sigma_r / sigma_1 of the scaled Psi_q (its singular values, eq. 4.20; r the rank at the start) and the sign of
   det [Psi_q; T^T], T a basis of its null space: the test function of continuation methods, whose sign flips
   where a rank loss lies between two steps (``check_configuration``, ``check_outputs``, ``_judge``).
3. **Switching assembly branch.** At a singular position two branches meet (a parallelogram and its crossed
   form); the physical motion keeps its velocities continuous across it (sec. 5.5, "Leaving the branch"). At
   every singular position a run passes, the velocities must change by what the accelerations give
   (``check_branches``, ``branch_verdict``); a jump stops the run.

The numbers come from the history of Psi_q at the output times: dense SVDs and QR factorizations of the scaled
Psi_q (``square_spectra``, ``null_space_bases``), or in a compiled run the band of a large mechanism's Psi_q
(``compiled.singular``) and one compiled pass for each screen (``compiled.branches``): the same verdicts. The
index-3 integrators make the same checks at their accepted steps (sec. 6.5, ``implicit.GuardedSteps``). A run
makes its Guard in ``dynamics.make_guard`` (``dynamics.index3_guard``) and reports what it saw:
``info['closest_singularity']``, ``info['singular_positions']`` with each crossing's branch verdict.
A compiled run, which the Guard judges at the output times, is also judged at its pauses between steps
(``judge_pause``), where it stopped early (``judge_stop``) and where sigma_r / sigma_1 dips between output times
(``singular_dip``: the run is made again on the numpy engine, which judges every step).
"""

from __future__ import annotations

import math

import numpy as np

from .assembly import System, mechanism_size
from .diagnostics import (
    NEAR_SINGULAR,
    AnalysisError,
    BranchSwitchError,
    SingularConfigurationError,
    passes_zero,
    rank_at,
    setting_words,
)

DRIFT_REMEDY = "use baumgarte with alpha, beta > 0, or the projection formulation"
"""What the drift message advises for an index-1 formulation, whose acceleration-level equations let Psi drift."""
ALIGNED = 0.9
"""|det(T_prev^T T)| above which two steps' null spaces are close enough for the sign test of ``Guard``."""
BAND_SMALLEST = 64
"""Coordinates from which ``square_spectra`` takes the band of Psi_q when it is narrower than an eighth of them
(``compiled.singular.WIDEST``); below, with more than DENSE_LARGEST rows, a band up to half of them wide
(``compiled.singular.WIDEST_MID``: ``benchmarks/guard_cost.py --routes``), a square Psi_q at any width
(``WIDEST_SQUARE``)."""
DENSE_LARGEST = 10
"""Rows (constraints) up to which a compiled run's ``square_spectra`` takes ``compiled.singular.dense_spectra`` for a
Psi_q of fewer than BAND_SMALLEST coordinates: its one-sided Jacobi on R (m x m) costs O(m^3) a sweep, its QR O(m^2 n)
(at 101 random Psi_q, 0.55 of numpy's batched SVDs and QRs at 6 x 6, 0.87 at 9 x 9, 1.04 at 11 x 12, 1.7 at 17 x 18;
the spatial double pendulum's 8 x 14 history: 0.66 against numpy's 1.2 ms); else numpy's."""


def null_space_bases(jacobians: np.ndarray, signs: bool = False):
    """An orthonormal basis T (n, n - m) of the null space of each Psi_q (m, n) of full row rank in a stack
    (N, m, n): the last n - m columns of Q in the QR factorization Psi_q^T = Q R (the first m span the rows).
    With ``signs``, also the sign of det [Psi_q; T^T] of each (the Guard's test function), from the same QR:
    [Psi_q; T^T] = diag(R_1^T, I) Q^T with R_1 the top m x m of R, so det = det R_1 det Q, and each Householder
    reflector with tau != 0 has determinant -1.
    Any orthonormal basis serves the guard: replacing T by T R_k (R_k orthogonal) multiplies det [Psi_q; T^T] and
    det(T_prev^T T) by det R_k = +-1 each, and the product they are judged by by (det R_k)^2 = 1.

    Q = H_1 H_2 ... H_m is kept as LAPACK's Householder reflectors H_i = I - tau_i v_i v_i^T (``mode="raw"``);
    its last n - m columns are those reflectors applied to the last n - m columns of the identity, last reflector
    first (Golub and Van Loan, Matrix Computations, sec. 5.1.6, backward accumulation): O(m n (n - m)) work for
    each matrix, where forming all of Q costs O(n^3) (on a chain of 65 bodies, 101 output times: 66 ms, not 186)."""
    _, m, n = jacobians.shape
    h, tau = np.linalg.qr(np.swapaxes(jacobians, 1, 2), mode="raw")  # h[:, i, i + 1:]: v_i below its leading 1
    bases = np.zeros((jacobians.shape[0], n, n - m))
    bases[:, m:, :] = np.eye(n - m)
    for i in range(m - 1, -1, -1):  # T <- H_i T, rows i.. of T (v_i is zero above row i)
        v = h[:, i, i:].copy()
        v[:, 0] = 1.0
        products = np.einsum("kj,kjr->kr", v, bases[:, i:, :])  # v_i^T T
        bases[:, i:, :] -= (tau[:, i, None] * v)[:, :, None] * products[:, None, :]
    if not signs:
        return bases
    diagonal = np.diagonal(h, axis1=1, axis2=2)  # R's diagonal (``h`` holds R transposed, above its reflectors)
    return bases, np.sign(np.prod(diagonal, axis=1)) * (-1.0) ** np.count_nonzero(tau, axis=1)


def singular_ratios(s: np.ndarray, rank: int) -> np.ndarray:
    """sigma_r / sigma_1 of each row of singular values s (N, ...) sorted largest first; 0 where sigma_1 = 0."""
    return np.where(s[:, 0] > 0, s[:, rank - 1] / np.where(s[:, 0] > 0, s[:, 0], 1.0), 0.0)


def null_space_turns(tangents: np.ndarray, signs: np.ndarray, certified: np.ndarray | None = None) -> np.ndarray:
    """det(T_k-1^T T_k) of each two adjacent null-space bases (N, n, d) -> (N - 1,): how far the null space turned
    over each step (``Guard._judge``'s ALIGNED), with which the sign of det [Psi_q; T^T] is compared across it. At a
    step ``certified`` (``compiled.singular.certified``: by Weyl's inequality no flip of that sign, and no basis made
    at its end) the sign its proof gives, signs[k-1] signs[k], of size 1: the Guard's test reads no flip there."""
    if certified is None or not certified.any():  # (the array's own any: 2 us, not np.any's 4)
        return np.linalg.det(np.swapaxes(tangents[:-1], 1, 2) @ tangents[1:])
    turns = signs[:-1] * signs[1:]
    if certified.all():  # every step (a run far from singular positions): no basis to compare
        return turns
    steps = np.flatnonzero(~certified)  # the bases made at both ends
    if steps.size:
        turns[steps] = np.linalg.det(np.swapaxes(tangents[steps], 1, 2) @ tangents[steps + 1])
    return turns


def scale_rows(jacobians: np.ndarray, columns: np.ndarray, norms: np.ndarray) -> np.ndarray:
    """``Guard._scaled`` of Psi_q (N, m, n) whose weighted rows' norms (N, m) are known."""
    return jacobians * columns / np.where(norms > 0, norms, 1.0)[..., None]


def square_spectra(
    jacobians: np.ndarray,
    columns: np.ndarray,
    norms: np.ndarray,
    before: np.ndarray | None,
    banded: bool = True,
    pattern: np.ndarray | None = None,
    settle: tuple | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(sigma_m / sigma_1, null-space bases T, signs of det [Psi_q; T^T], turns det(T_k-1^T T_k) of each step,
    ``null_space_turns``) of each Psi_q (N, m, n) of full row rank m, scaled (``scale_rows`` with its column weights and
    row norms), for ``Guard.check_outputs``. Dense: SVDs and ``null_space_bases``, O(m^2 n) each. A large mechanism's
    Psi_q is a band once its rows and columns are ordered (``compiled.singular``, the compiled runs' code that calls
    this): extreme eigenvalues of Psi_q Psi_q^T by shifted inverse iteration and Cholesky tests for the ratio, banded LU
    for T and the sign, O(n b^2) each; scaled entry by entry, no scaled copy of the history. ``before``: a null-space
    basis just before the first time (which picks the band's independent coordinates), None if none is known.
    ``banded=False``: dense whatever the size (a numpy engine's run, which loads no compiled code). ``pattern`` (m, n):
    where any Psi_q is nonzero, if known (the band's structure; else found from the history). ``settle`` ((thresholds,
    fall, through): the Guard's tests of the ratios): the band's ratios closed only where those tests or the Guard's
    reported figures need it (``compiled.singular.spectra``, ``settled``), its bases made only where a step is not
    certified to hold no flip of the sign (``compiled.singular.certified``; NaN elsewhere, no test reads them); None:
    everywhere. A fifth item: the band's ``compiled.singular.Brackets`` that order two neighbours where their
    figures do not (None: the figures do, ``smaller``)."""
    _, m, n = jacobians.shape
    found = _compiled_spectra(jacobians, columns, norms, before, pattern, settle) if banded and m <= n else None
    if found is None:
        scaled = scale_rows(jacobians, columns, norms)
        tangents, signs = null_space_bases(scaled, signs=True)
        ratios = singular_ratios(np.linalg.svd(scaled, compute_uv=False), m)
        return ratios, tangents, signs, null_space_turns(tangents, signs), None
    ratios, tangents, signs, certified, *rest = found
    brackets = rest[0] if rest else None
    from .compiled.singular import unmade  # found by the compiled engine: it is there

    made, failed = unmade(ratios, signs, tangents, certified)  # no basis at times whose two steps are certified
    if failed.any():  # LAPACK met an exact zero pivot there: those times densely, and every basis not made
        failed |= ~made
        scaled = scale_rows(jacobians[failed], columns, norms[failed])
        tangents[failed], signs[failed] = null_space_bases(scaled, signs=True)
        ratios[failed] = singular_ratios(np.linalg.svd(scaled, compute_uv=False), m)
        certified = np.zeros_like(certified)
        if brackets is not None:  # closed there
            brackets.lower[failed] = ratios[failed]
    return ratios, tangents, signs, null_space_turns(tangents, signs, certified), brackets


def _compiled_spectra(
    jacobians: np.ndarray, columns: np.ndarray, norms: np.ndarray, before: np.ndarray | None, pattern=None, settle=None
):
    """The compiled engine's spectra of the scaled Psi_q: in one compiled pass over a small one (up to DENSE_LARGEST
    rows, ``compiled.singular.dense_spectra``; with ``settle``, Jacobi's figures only where the Guard's tests need
    them), else from its band (``compiled.singular.spectra``): from
    BAND_SMALLEST coordinates where the band is at most an eighth of them wide (``WIDEST``), below where it is at most
    half of them wide (``WIDEST_MID``: a mid-size Psi_q, the loop chain's of 2-8 loops, costs a quarter to two thirds
    of numpy's batched SVDs and QRs so; a wider band costs more than they), or at any width where it is square and its
    ratios are settled by the Guard's tests (``WIDEST_SQUARE``: no null space to solve for). (ratios, bases, signs,
    the steps certified to hold no flip of the sign, ``compiled.singular.certified``); None where there is no
    compiled engine (a student package) or not such a band: numpy's dense SVDs and QRs then."""
    try:
        from .compiled import singular
    except ImportError:  # a student package: dense
        return None
    N, m, n = jacobians.shape
    if m <= DENSE_LARGEST and n < BAND_SMALLEST:  # every basis made: no step certified
        return *singular.dense_spectra(jacobians, columns, norms, settle=settle), np.zeros(max(N - 1, 0), dtype=bool)
    if n >= BAND_SMALLEST:
        widest = singular.WIDEST
    else:
        widest = singular.WIDEST_SQUARE if m == n and settle is not None else singular.WIDEST_MID
    return singular.spectra(jacobians, before, columns, norms, pattern, widest, settle)


class Guard:
    """Keeps a run from returning a wrong answer silently (three checks, each with the time and the condition):

    - constraint drift: at every output time, how far q is off each constraint, |Psi_i| / |grad Psi_i| (with
      angles measured as arc lengths L phi, so every row gives metres), must stay below drift_limit L, with
      L the mechanism's size (the largest distance of a body centre or joint point from the origin, at least
      1 mm);
      a formulation that lets the positions leave the constraints (no stabilization, bad Baumgarte
      parameters) stops here instead of returning a mechanism that has come apart;
    - singular configurations: near a rank loss of Psi_q (a change point, a toggle) the multipliers grow
      without bound and the integrator can leave the assembly branch with no error it could see; the
      motion there is not decided by the equations. After every step the run stops when the sign of
      det [Psi_q; T^T] flips, T the null-space basis of Psi_q at the step before: a rank loss lies
      between the two steps (the test function of continuation methods for bifurcation points), or when
      sigma_r / sigma_1 of Psi_q falls below singular_ratio (r the rank at the start, so redundant
      constraints do not count; angle columns divided by the mechanism's size and rows to unit length,
      so the ratio does not depend on units).
    - branch switches (``check_branches``, on both engines at the output times; the index-3 integrators' at their
      accepted steps, ``implicit.GuardedSteps``): at every singular position a
      run passes (even rank losses too: one per loop of a chain of parallelograms, which keep the sign of det),
      the velocities must change by what the accelerations give (``branch_verdict``), as the physical motion's
      do; a jump means the run left the branch it came along and stops it; a crossing the output times are
      too coarse to judge is a warning.
    The smallest ratio met is reported (``info['closest_singularity']``), the crossings judged with their
    verdicts (``info['singular_positions']``, 'branch').
    """

    def __init__(
        self,
        system: System,
        q: np.ndarray,
        drift_limit: float | None,
        singular_ratio: float | None,
        through: bool = False,
        size: float | None = None,
        weights: np.ndarray | None = None,
        rank: int | None = None,
    ):
        self.system, self.singular_ratio, self.through = system, singular_ratio, through
        self.crossings: list[dict] = []  # singular positions passed (with ``through``: the formulation passes them)
        self.banded = False  # Psi_q's singular values from its band where it pays (a compiled run: compiled_motion)
        self.judged = 0.0  # the time of the last check
        self._last_ratios: tuple[float | None, float | None] = (None, None)
        self._last_q: tuple[np.ndarray, float] = (q, 0.0)
        if size is None:  # L, as the run's Plan has it
            size = mechanism_size(system, q)
        self.size = size
        self.drift_limit = None if drift_limit is None else drift_limit * size
        self.remedy = DRIFT_REMEDY  # what to do when the positions drift (index-3 runs: ``index3_guard``)
        if rank is None:  # a run's Guard is given it by the run's start (``Start.rank``)
            report = rank_at(system, q)
            rank = report.rank if report is not None else 0
        self.rank = rank
        self.closest: dict | None = None
        self._tangent, self._t, self._sign = None, 0.0, 1.0
        self._pending: list = []  # (t, q, Psi_q) after steps not judged yet (``queue``)
        per, dim = system.coordinates_per_body, system.model.dimension
        columns = np.ones((system.n_bodies, per))
        columns[:, dim:] = 1.0 / size  # derivatives by an angle (Euler parameter) times its arc length, in 1/m
        self._columns = columns.reshape(-1)
        self._weights = weights  # the speed weights (``speeds``): made where a branch is judged, read only

    @property
    def speeds(self) -> np.ndarray:
        """The weights that make each velocity coordinate a speed (``gyration_weights``), made at the first branch
        judged: a Guard that judges none (an open tree's) makes none."""
        if self._weights is None:
            self._weights = gyration_weights(self.system)
        return self._weights

    def _scaled(self, jacobian: np.ndarray) -> np.ndarray:
        """Psi_q made free of units and size: derivatives by angles per arc length (divided by the mechanism's
        size), rows to unit length, so that its singular values measure nearness to a rank loss alone."""
        scaled = jacobian * self._columns  # one Psi_q (m, n), or a stack of them (N, m, n)
        norms = np.linalg.norm(scaled, axis=-1, keepdims=True)
        return scaled / np.where(norms > 0, norms, 1.0)

    def _record(self, passed: bool, q: np.ndarray, t: float, ratio: float) -> None:
        """With ``through``: note a singular position passed, at a sign flip of det [Psi_q; T^T] (an odd
        rank loss between two steps) or where sigma_r / sigma_1 dips to zero (``diagnostics.passes_zero``: any
        rank loss, e.g. one per loop of a chain of parallelograms, whose signs cancel in pairs)."""
        from .diagnostics import singular_joints

        previous, before = self._last_ratios
        if previous is not None and before is not None and passes_zero(before, previous, ratio):
            if not self.crossings or self.crossings[-1]["t"] < self._last_q[1]:
                _, joints = singular_joints(self.system.jacobian(*self._last_q), self.system.row_owners)
                self.crossings.append({"t": self._last_q[1], "ratio": previous, "joints": joints})
        elif passed:
            _, joints = singular_joints(self.system.jacobian(q, t), self.system.row_owners)
            self.crossings.append({"t": float(t), "ratio": ratio, "joints": joints})
        self._last_ratios = (ratio, previous)
        self._last_q = (q, float(t))

    def check_drift(self, q: np.ndarray, t: float, psi: np.ndarray | None = None, jacobian=None) -> None:
        """The drift check at one state; ``psi`` and ``jacobian``: Psi and Psi_q there when the caller has them."""
        self.judged = float(t)
        if self.drift_limit is None:
            return
        psi = self.system.constraints(q, t) if psi is None else psi
        jacobian = self.system.jacobian(q, t) if jacobian is None else jacobian
        norms = np.linalg.norm(jacobian * self._columns, axis=1)
        distance = np.abs(psi) / np.where(norms > 0, norms, 1.0)  # |Psi_i| / |grad Psi_i|: how far q is off, in m
        worst = int(np.nanargmax(distance)) if np.any(np.isfinite(distance)) else 0
        if not float(np.max(distance, initial=0.0)) <= self.drift_limit:
            raise AnalysisError(
                f"constraint drift at t = {t:.6g} s: the positions are {distance[worst]:.3g} m off constraint "
                f"{self.system.labels[worst]} (|Psi| = {abs(psi[worst]):.3g}), more than {self.drift_limit:.3g} m, "
                f"{self.drift_limit / self.size:.3g} of the mechanism's size: the positions have left the "
                f"constraints; {self.remedy}"
            )

    def check_configuration(self, formulation, t: float, y: np.ndarray) -> None:
        """The check after a step, at once (``queue`` and ``flush``)."""
        self.queue(formulation, t, y)
        self.flush()

    def queue(self, formulation, t: float, y: np.ndarray) -> None:
        """Keep Psi_q after a step for ``flush``, which judges every state kept in time order, their SVDs and
        determinants in one stacked call each (numpy calls LAPACK on each matrix of a stack: the same numbers as
        one call per step, for a third of the cost on a small mechanism); at DEFERRED_STEPS states kept, now."""
        if not self.singular_ratio or self.rank == 0:
            return
        q, _ = formulation.coordinates(t, y)
        self._pending.append((t, q, self.system.jacobian(q, t)))
        if len(self._pending) >= DEFERRED_STEPS:
            self.flush()

    def flush(self) -> None:
        """``_judge`` each state ``queue`` kept, in time order: sigma_r / sigma_1 of the scaled Psi_q, its null-space
        basis T (the last rows of V^T) and the sign of det [Psi_q; T^T]; the first verdict against raises."""
        if not self._pending:
            return
        pending, self._pending = self._pending, []
        jacobians = self._scaled(np.array([jacobian for _, _, jacobian in pending]))
        _, s, vt = np.linalg.svd(jacobians)
        square = jacobians.shape[1] == self.rank
        if square:  # [Psi_q; T^T]: V^T with its first rows replaced by Psi_q's
            stacked = vt.copy()
            stacked[:, : self.rank] = jacobians
            signs = np.sign(np.linalg.det(stacked))
        for k, (t, q, _) in enumerate(pending):
            ratio = float(s[k, self.rank - 1] / s[k, 0]) if s[k, 0] > 0 else 0.0
            self._judge(q, t, ratio, vt[k, self.rank :].T, signs[k] if square else self._sign)

    def check_outputs(
        self, t: np.ndarray, q: np.ndarray, psi: np.ndarray, jacobians: np.ndarray, drift: bool = True
    ) -> None:
        """``check_drift`` and ``check_configuration`` at every output time t[k] of a finished run, given
        Psi (N, m) and Psi_q (N, m, n) there (the compiled engine's): the same tests, the arithmetic over all
        output times at once (batched norms, SVDs and determinants), the verdicts in time order. ``drift=False``:
        the configuration alone (a state between output times, where the numpy engine checks no drift)."""
        if self.drift_limit is None and not self.singular_ratio:  # nothing to check (an open tree's joint coordinates)
            return
        norms, pattern = self._row_norms(jacobians)  # |grad Psi_i| of every row at every time, angles as arc lengths
        if drift and self.drift_limit is not None:
            k = self._drifted(psi, norms)
            if k >= 0:
                self.check_drift(q[k], float(t[k]))  # raises, with the message of the step-by-step check
        if not self.singular_ratio or self.rank == 0:
            return
        ratios, tangents, signs, turns, _ = self._spectra(t, jacobians, norms, pattern)  # turns[k - 1]: to t_k
        if self._quiet(t, ratios, tangents, signs, turns):
            return
        for k in range(t.size):
            sign = self._sign if signs is None else signs[k]
            turn = None if k == 0 else turns[k - 1]
            self._judge(q[k], float(t[k]), float(ratios[k]), tangents[k], sign, turn)

    def _drifted(self, psi: np.ndarray, norms: np.ndarray) -> int:
        """The first output time whose drift |Psi_i| / |grad Psi_i| (Psi (N, m), the rows' norms (N, m)) is not
        within drift_limit, or -1: in one compiled pass in a compiled run (``compiled.singular.drifted``, the same
        verdict), else by numpy's arrays."""
        if self.banded:
            from .compiled import singular

            contiguous = np.ascontiguousarray(psi, dtype=float), np.ascontiguousarray(norms, dtype=float)
            return singular.drifted(*contiguous, float(self.drift_limit))
        distance = np.abs(psi) / np.where(norms > 0, norms, 1.0)
        bad = ~(np.max(distance, axis=1, initial=0.0) <= self.drift_limit)
        return int(np.argmax(bad)) if np.any(bad) else -1

    def _row_norms(self, jacobians: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """(|grad Psi_i| (N, m) of every row of Psi_q (N, m, n), angles as arc lengths; where any Psi_q is nonzero
        (m, n), or None): of a compiled run's history, one compiled pass over the columns of the bodies each row's
        element joins (``compiled.singular.history_norms``: the pattern, the band's structure, from the same
        entries), or over all where an element reaches further; numpy's norms otherwise."""
        if self.banded and jacobians.ndim == 3:
            from .compiled import history, singular

            try:
                reach = history.row_columns(self.system)
            except AttributeError:  # a system without elements' rows (no structure to read): every column
                reach = None
            return singular.history_norms(jacobians, self._columns, reach)
        return np.linalg.norm(jacobians * self._columns, axis=-1), None

    def _spectra(
        self, t: np.ndarray, jacobians: np.ndarray, norms: np.ndarray | None = None, pattern: np.ndarray | None = None
    ) -> tuple:
        """(sigma_r / sigma_1, null-space bases T, signs of det [Psi_q; T^T] or None, turns det(T_k-1^T T_k),
        ``null_space_turns``, the band's ``Brackets`` or None: ``square_spectra``) of the scaled Psi_q (``_scaled``)
        of Psi_q (N, m, n) at the times t (``norms``, ``pattern``: ``_row_norms``, if known), kept for ``spectra``:
        the run's later looks at the same output times (``singular_dip``, ``check_branches``) take them instead of a
        second and third batch of SVDs (on a chain of 32 loops each batch cost more than the integration). The ratios
        from the band are closed only where the Guard's tests of them (singular_ratio, NEAR_SINGULAR, FALL, the dips;
        the smallest and a crossing's figure reported) need it, elsewhere known in a bracket (about 1e-4 wide, or
        carried over a step by Weyl's inequality) that decides them the same way, the order of two neighbours worked
        out where ``check_branches`` reads it (``smaller``; ``compiled.singular.settled``); its bases made only at
        the ends of the steps not certified to hold no flip of the sign (``compiled.singular.certified``)."""
        if norms is None:
            norms, pattern = self._row_norms(jacobians)
        if jacobians.shape[1] == self.rank:  # independent rows: T and det [Psi_q; T^T], from the band where it pays
            settle = ((self.singular_ratio, NEAR_SINGULAR), FALL, self.through)  # what the ratios are judged by
            made = square_spectra(jacobians, self._columns, norms, self._tangent, self.banded, pattern, settle)
        else:  # redundant rows: the null space of rank r needs the SVD's V; det [Psi_q; T^T] is not defined
            _, s, vt = np.linalg.svd(scale_rows(jacobians, self._columns, norms))
            tangents = np.swapaxes(vt[:, self.rank :], 1, 2)
            made = singular_ratios(s, self.rank), tangents, None, null_space_turns(tangents, None), None
        self._made = (np.array(t, dtype=float), made)
        return made

    def spectra(self, t: np.ndarray, jacobians: np.ndarray) -> tuple:
        """``_spectra`` of Psi_q (N, m, n) at the output times t: those ``check_outputs`` made for the same times,
        else made here."""
        made = self.__dict__.get("_made")
        if made is not None and made[0].shape == np.shape(t) and (made[0] == t).all():
            return made[1]
        return self._spectra(t, jacobians)

    def check_branches(
        self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, jacobians: np.ndarray
    ) -> None:
        """The branch the motion took at every singular position it passed between output times t[k] of a run
        (``branch_verdict``), from q, q', q'' and Psi_q (N, m, n) there: the same check on both engines, on the
        same samples. A crossing is a dip of sigma_r / sigma_1 to zero around t[k] (``diagnostics.passes_zero``:
        any rank loss, even one per loop of a chain of parallelograms, which keeps the sign of det [Psi_q; T^T]),
        judged from t[k-1] to t[k+1]; a flip of that sign between t[k-1] and t[k] (an odd rank loss), or a fall
        of the ratio by more than 1 / FALL into a configuration that stays singular (no dip), judged there. Each is
        listed in ``crossings`` with its verdict ('branch'); a switch stops the run (``BranchSwitchError``), a
        crossing the velocities cannot decide is a warning (``warnings``). Every other step with a ratio below
        NEAR_SINGULAR is judged too, a switch alone counting. A run that never came near a singular position
        (``closest``, what the checks before saw) has nothing to judge."""
        if not self.judges_branches(t):
            return
        ratios, _, signs, turns, brackets = self.spectra(t, jacobians)
        dipped, flipped, fallen, near = self._screen(ratios, signs, turns)
        intervals = [(k - 1, k, k + 1) for k in dipped]
        for k in flipped:  # det [Psi_q; T^T] defined (independent rows): its sign flips
            if not any(a <= k - 1 and k <= b for a, _, b in intervals):  # not within a dip's interval
                intervals.append((k - 1, smaller(ratios, brackets, k - 1, k), k))
        for k in fallen:  # a fall into (or rise out of) a configuration that stays singular: no dip
            if not any(a <= k and k + 1 <= b for a, _, b in intervals):
                intervals.append((k, smaller(ratios, brackets, k, k + 1), k + 1))
        # a switch between two regular branches shows in the velocities of the step onto the other: every step next
        # to a singular position is judged too, but only a switch counts there
        near = near[self._possible_switches(t, qd, qdd, near)]  # the others are no switch: not judged
        steps = [(k, smaller(ratios, brackets, k, k + 1), k + 1) for k in near]
        for a, middle, b, crossing in sorted([(*i, True) for i in intervals] + [(*i, False) for i in steps]):
            self._judge_branch(t, q, qd, qdd, a, middle, b, float(ratios[middle]), crossing)
        # a singular position recorded step by step (``through``) between two output times at which no dip showed
        # (the output times too coarse for it): judged over the output interval that holds it
        for record in [c for c in self.crossings if "branch" not in c and t[0] < c["t"] < t[-1]]:
            k = int(np.searchsorted(t, record["t"]))  # t[k - 1] < t_c <= t[k]
            middle = smaller(ratios, brackets, k - 1, k)
            self._judge_branch(t, q, qd, qdd, k - 1, middle, k, float(ratios[middle]), True, record)

    def _screen(self, ratios: np.ndarray, signs: np.ndarray | None, turns: np.ndarray) -> tuple:
        """``branch_screen`` of the ratios, signs and turns: in one compiled pass in a compiled run (``banded``: numba
        is loaded; ``compiled.branches.screen``, the same tests without numpy's dozen array operations), else
        numpy's."""
        if not self.banded:
            return branch_screen(ratios, signs, turns)
        from .compiled import branches

        signs = np.empty(0) if signs is None else np.ascontiguousarray(signs, dtype=float)
        arrays = (np.ascontiguousarray(x, dtype=float) for x in (ratios, signs, turns))
        return branches.screen(*arrays, NEAR_SINGULAR, FALL, ALIGNED)

    def _possible_switches(self, t: np.ndarray, qd: np.ndarray, qdd: np.ndarray, steps: np.ndarray) -> np.ndarray:
        """``possible_switches`` of the steps (k to k + 1): in one compiled pass in a compiled run (``banded``: numba
        is loaded; ``compiled.branches``, the same screen without numpy's dozen array operations), else numpy's."""
        if not self.banded:
            return possible_switches(self.speeds, t, qd, qdd, steps)
        from .compiled import branches

        arrays = (np.ascontiguousarray(x, dtype=float) for x in (self.speeds, t, qd, qdd))
        return branches.possible_switches(*arrays, steps.astype(np.int64), 0.5 * BRANCH_JUMP)

    @property
    def warnings(self) -> list[str]:
        """One line naming the singular positions passed whose branch ``check_branches`` could not judge."""
        undecided = [f"{c['t']:.6g}" for c in self.crossings if c.get("branch") == "cannot tell"]
        if not undecided:
            return []
        return [
            f"branch: cannot tell whether the motion stayed on its assembly branch at the singular position(s) "
            f"near t = {', '.join(undecided)} s: the output times around them are too far apart for the motion "
            "(its velocities change there by as much as a switch would), or it comes to rest there (then its "
            "accelerations decide the branch); check the result past them, e.g. against --formulation "
            "augmented-lagrangian, or ask more output --steps"
        ]

    def jacobians(self, t: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Psi_q at every output time (N, m, n), for ``check_branches``."""
        return np.array([self.system.jacobian(q_k, t_k) for q_k, t_k in zip(q, t, strict=True)])

    def judges_branches(self, t) -> bool:
        """Whether ``check_branches`` has anything to judge at the output times t: a Guard that watches for
        singular positions, two times at least, and a run that came near one (``closest``, what the checks before
        saw; none seen yet counts as near). Asked before Psi_q is evaluated at every output time for it."""
        if not self.singular_ratio or self.rank == 0 or len(t) < 2:
            return False
        return self.closest is None or self.closest["ratio"] < NEAR_SINGULAR

    def check_branches_before(self, err: AnalysisError, t, q, qd, qdd) -> None:
        """``check_branches`` over the output times a run stored before it stopped with ``err``: a branch switch
        there is the first thing that went wrong (the motion on the wrong branch then meets what stopped it), so
        its ``BranchSwitchError`` is raised instead, from ``err``; otherwise nothing (the caller raises ``err``)."""
        if not self.judges_branches(t):
            return
        try:
            self.check_branches(t, q, qd, qdd, self.jacobians(t, q))
        except BranchSwitchError as switch:
            raise switch from err

    def _judge_branch(
        self, t, q, qd, qdd, a: int, middle: int, b: int, ratio: float, crossing: bool, record: dict | None = None
    ) -> None:
        """``check_branches``' verdict on the crossing (or, not ``crossing``, the step next to a singular
        position) near t[middle], between the samples a and b on either side: step by step (a dip's two steps
        each, the shorter the interval the surer the verdict), switched if one step is, kept if every one is. The
        verdict goes to ``record`` (a crossing recorded step by step) when given, else to the crossing recorded
        near t[middle], or to a new one."""
        from .diagnostics import singular_joints

        verdicts = [
            branch_verdict(self.speeds, float(t[j] - t[i]), (qd[i], qdd[i]), (qd[j], qdd[j]), self.system.model.bodies)
            for i, j in ((a, middle), (middle, b)) if i < j
        ]  # fmt: skip
        judged = {v[0]: v for v in verdicts}
        verdict, figure, body = judged.get("switched") or judged.get("cannot tell") or verdicts[0]
        if not crossing and verdict != "switched":
            return
        _, joints = singular_joints(self.system.jacobian(q[middle], t[middle]), self.system.row_owners)
        near = t[max(a - 1, 0)], t[min(b + 1, t.size - 1)]  # a crossing recorded step by step (``through``)
        known = [c for c in self.crossings if near[0] <= c["t"] <= near[1]]
        passed = record if record is not None else known[0] if known else {"t": float(t[middle]), "ratio": ratio,
                                                                           "joints": joints}  # fmt: skip
        passed["branch"] = verdict
        if record is None and not known:
            self.crossings.append(passed)
            self.crossings.sort(key=lambda c: c["t"])
        where = (
            f"the singular position near t = {passed['t']:.6g} s (joints {', '.join(passed['joints'])}; "
            f"judged from t = {t[a]:.6g} s to t = {t[b]:.6g} s)"
        )
        if verdict == "switched":
            undecided = [f"{c['t']:.6g}" for c in self.crossings if c.get("branch") == "cannot tell"]
            earlier = (
                f" (the crossings before it, at t = {', '.join(undecided)} s, could not be judged: it may have "
                "left there already)"
                if undecided
                else ""
            )
            raise BranchSwitchError(
                f"branch switch at {where}: the velocity of {body} changed by {figure:.3g} m/s more than its "
                "acceleration explains, where the physical motion keeps every velocity continuous: the run left "
                "the assembly branch it came along (e.g. a parallelogram folding or crossing over) and its result "
                f"past there is wrong{earlier}; --formulation augmented-lagrangian (or auto) carries the motion "
                "through on its branch; or try a tighter --rtol, more output --steps"
            )

    def _quiet(self, t, ratios, tangents, signs, turns) -> bool:
        """Whether no output time is near a singular position nor past one (``_judge``'s two verdicts, for all
        output times at once); if so, the state ``_judge`` would leave: the closest ratio, the last step's null
        space and sign. A run that passes singular positions (``through``) and redundant rows take ``_judge``."""
        if self.through or signs is None or self.rank != self.system.n_constraints:
            return False
        first = np.linalg.det(self._tangent.T @ tangents[0]) if self._tangent is not None else np.nan
        k = self._smallest_if_quiet(first, turns, signs, ratios)
        if k < 0:
            return False
        if self.closest is None or ratios[k] < self.closest["ratio"]:
            self.closest = {"t": float(t[k]), "ratio": float(ratios[k])}
        self._tangent, self._t, self._sign = tangents[-1], float(t[-1]), signs[-1]
        return True

    def _smallest_if_quiet(self, first: float, turns: np.ndarray, signs: np.ndarray, ratios: np.ndarray) -> int:
        """The first output time of the smallest ratio (as the time-ordered verdicts keep it) if none is near a
        singular position nor past one, else -1: where the null space's turn since the time before (``first``,
        since the Guard's last basis, then ``turns``) is above ALIGNED and the sign flips against it, or the ratio
        is below singular_ratio. In one compiled pass in a compiled run (``compiled.singular.quiet``), else by
        numpy's arrays: the same products and tests."""
        if self.banded:
            from .compiled import singular

            limit = float(self.singular_ratio)
            return int(singular.quiet(float(first), turns, signs, float(self._sign), ratios, limit, ALIGNED))
        turn = np.concatenate([[first], turns])  # the null space's turn since the step before, at every time
        before = np.concatenate([[self._sign], signs[:-1]])
        passed = (np.abs(turn) > ALIGNED) & (turn * signs * before < 0)
        if np.any(passed) or not np.all(ratios >= self.singular_ratio):
            return -1
        return int(np.argmin(ratios))

    def _judge(
        self, q: np.ndarray, t: float, ratio: float, tangent: np.ndarray, sign: float, turn: float | None = None
    ) -> None:
        """The verdict of ``check_configuration`` from sigma_r / sigma_1, the null-space basis T, the sign of
        det [Psi_q; T^T] and, if known, the turn det(T_prev^T T) of the null space since the last check."""
        self.judged = float(t)  # the time of the check, of a stop too (``check_branches_before``)
        if self.closest is None or ratio < self.closest["ratio"]:
            self.closest = {"t": float(t), "ratio": ratio}
        passed = False
        square = self.rank == self.system.n_constraints  # no redundant rows: det [Psi_q; T^T] is defined
        if self._tangent is not None and square:
            # the sign of det [Psi_q; T^T] with the previous step's null-space basis T flips when a rank loss
            # lies between the two steps (the test function of continuation methods for bifurcation points);
            # it says so only while the null space has turned little over the step (|det T^T T_new| near 1).
            # With C = T^T T_new, T^T = C T_new^T + Y Psi_q for some Y, so det [Psi_q; T^T] = det C det [Psi_q;
            # T_new^T]: the sign comes from C, already needed for the alignment, and this step's own sign.
            turn = np.linalg.det(self._tangent.T @ tangent) if turn is None else turn
            passed = abs(turn) > ALIGNED and turn * sign * self._sign < 0
        near = not ratio >= self.singular_ratio
        if self.through:  # record each singular position passed and go on
            self._record(passed, q, t, ratio)
        elif passed or near:
            from .diagnostics import singular_joints

            _, joints = singular_joints(self.system.jacobian(q, t), self.system.row_owners)
            where = f"between t = {self._t:.6g} s and t = {t:.6g} s" if passed else f"at t = {t:.6g} s"
            raise SingularConfigurationError(
                f"singular configuration {where}: Psi_q {'lost rank there' if passed else 'is about to lose rank'} "
                f"(smallest singular value {ratio:.2g} of the largest, condition number {1 / max(ratio, 1e-300):.3g}); "
                f"joints involved: {', '.join(joints)}. The mechanism can switch assembly branch there (a change "
                "point or a toggle); --formulation augmented-lagrangian (or auto) carries it through on the branch "
                f"its velocities point along; {setting_words('singular_ratio', None, '0')} runs on regardless",
                t=float(t),
            )
        self._tangent, self._t, self._sign = tangent, t, sign


DEFERRED_STEPS = 16
"""The numpy engine's Guard judges the states after its steps in batches of at most this many (``Guard.queue``), and
at every output time and every stop before anything else: the verdicts of a check after every step."""
BRANCH_JUMP = 0.1
"""Largest change of a body's velocity across a singular position beyond what its accelerations allow, as a
fraction of the fastest body's speed there, that ``branch_verdict`` takes for the branch the motion came along
(a switch stops or reverses a body: a change of the order of its speed)."""
FALL = 0.01
"""``Guard.check_branches`` takes a step over which sigma_r / sigma_1 changes by more than 1 / FALL below
NEAR_SINGULAR for a crossing (into or out of a configuration that stays singular: no dip to see)."""
BRANCH_BLIND = 0.25
"""``branch_verdict`` cannot tell when the accelerations at the two samples allow a change of velocity over the
interval of this fraction of the fastest body's speed (samples too far apart, or a body nearly at rest)."""


def shallow_copy(guard: Guard) -> Guard:
    """``copy.copy(guard)``: a new Guard with the same attributes (its lists and arrays shared), made directly (1 us,
    not ``copy``'s protocol's 4)."""
    copied = object.__new__(type(guard))
    copied.__dict__.update(guard.__dict__)
    return copied


def singular_dip(guard: Guard, times: np.ndarray, jacobians: np.ndarray) -> tuple[float, float] | None:
    """(t, sigma_r / sigma_1) where the ratio of the Guard's scaled Psi_q dips towards zero at an output time
    (``diagnostics.passes_zero``: a local minimum below NEAR_SINGULAR, deep against its neighbours), else None.
    There a run passed close to a rank loss between output times, where the numpy engine's Guard judges every
    step and the compiled engine's only the output times: an even rank loss (one per loop of a chain of
    parallelograms) keeps the sign of det [Psi_q; T^T], and the run may have left its branch unseen."""
    if guard.rank == 0 or times.size < 3:
        return None
    ratios = guard.spectra(times, jacobians)[0]  # those of the output times' checks
    if guard.banded:  # numba is loaded (a compiled run): passes_zero time by time in one compiled pass
        from .compiled import branches

        k = int(branches.first_dip(np.ascontiguousarray(ratios, dtype=float), NEAR_SINGULAR))
        return None if k < 0 else (float(times[k]), float(ratios[k]))
    # ``dips`` finds them all at once (a loop chain: 100 calls of passes_zero, 70 us); passes_zero decides the first
    # in time and those next to a NaN, on which the two disagree
    maybe = dips(ratios) | np.isnan(ratios[:-2]) | np.isnan(ratios[2:])
    for k in 1 + np.flatnonzero(maybe):
        if passes_zero(ratios[k - 1], ratios[k], ratios[k + 1]):
            return float(times[k]), float(ratios[k])
    return None


def judge_pause(guard: Guard, t: float, q: np.ndarray, psi: np.ndarray, jacobian: np.ndarray) -> None:
    """The numpy engine's check after a step, at a pause of the compiled loop between two steps (every
    ``compiled.PAUSE_STEPS``), by ``guard``, a copy of the run's Guard that sees the pauses in time order (the run's
    own judges the output times): SingularConfigurationError where Psi_q is about to lose rank or lost it since the
    pause before, so that a compiled run crawling at a singular position stops there as the numpy run does."""
    guard.check_outputs(np.array([t]), q[None, :], psi, jacobian, drift=False)


def judge_stop(guard: Guard, compiled, times: np.ndarray, n: int) -> None:
    """The Guard's checks over a compiled run that stopped early: the output times it reached and the state where
    it stopped. The numpy engine's Guard judges every step on the way, so a stop next to a singular position
    raises its SingularConfigurationError, or leaves ``guard.closest`` near zero, which makes ``auto`` run again
    with a formulation that passes it (``restartable``), on either engine. A state that is no longer finite
    (rk4's stop) is no configuration: the reached output times alone are judged."""
    k, q = compiled.reached, compiled.Y[:, :n]
    guard.check_outputs(times[:k], q[:k], compiled.psi[:k], compiled.jac[:k])
    if np.all(np.isfinite(compiled.Y[k])):
        guard.check_outputs(np.array([compiled.t]), q[k:], compiled.psi[k:], compiled.jac[k:], drift=False)


def gyration_weights(system: System) -> np.ndarray:
    """Weights that make every velocity coordinate of a body a speed in m/s: 1 for its centre's, its radius of
    gyration rho = sqrt(J / m) for phi' (planar), 2 rho for the Euler parameters' rates (|omega| = 2 |p'|;
    J the mean principal moment); so |weights * q'| of a body is sqrt(2 T / m), T its kinetic energy."""
    per, dim = system.coordinates_per_body, system.model.dimension
    weights = []  # body by body, as one list made an array once (a row written per body: 0.5 us each)
    for body in system.model.bodies:
        moment = _mean_moment(body.inertia)
        radius = math.sqrt(moment / body.mass) if body.mass and moment > 0 else 0.0
        weights += [1.0] * dim + [radius if dim == 2 else 2.0 * radius] * (per - dim)
    return np.array(weights, dtype=float).reshape(system.n_bodies, per)


def _mean_moment(inertia) -> float:
    """J of ``gyration_weights``: a planar moment itself (given as a number: no array made of it, 3 us a body at a
    loop chain's start), a 3 x 3 inertia's trace / 3, the mean of principal moments."""
    if inertia is None:
        return 0.0
    if isinstance(inertia, float | int):
        return float(inertia)
    inertia = np.asarray(inertia, dtype=float)
    return float(np.trace(inertia) / 3.0 if inertia.ndim == 2 else np.mean(inertia))


def branch_verdict(weights: np.ndarray, h: float, before: tuple, after: tuple, bodies) -> tuple:
    """Whether a motion through a singular position stayed on the branch it came along, from (q', q'') at two
    samples h apart on either side of it: ('kept' | 'switched' | 'cannot tell', a figure in m/s, a body's name).

    At a rank loss of Psi_q two branches of the constraint manifold meet (a parallelogram and its crossed or
    folded form) with different tangents. The physical motion keeps the generalized velocity continuous: it
    leaves along the tangent it came along, and each body's velocity changes by what its acceleration gives,

        q'_after - q'_before = h (q''_before + q''_after) / 2 + e,   |e| <= h max |q'' - (q''_before + q''_after) / 2|

    A branch switch turns the velocity onto the other tangent: it stops or reverses a body, a change of the order
    of its speed that the accelerations do not give. Per body, every coordinate a speed (``gyration_weights``):
    the mismatch J = |q'_a - q'_b - h (q''_b + q''_a) / 2|, the allowance R = h max(|q''_b|, |q''_a|) (the most
    the accelerations can change the velocity, if they do not peak in between) and the speed V:

    - 'switched' when max (J - R) > BRANCH_JUMP max V, the samples close enough that the accelerations change the
      velocities by less than their size (max R < max V: they cannot peak far above their values at the samples);
    - else 'cannot tell' when max R >= BRANCH_BLIND max V (samples too far apart for the motion, or a mechanism
      that comes to rest at the singular position: then its accelerations decide the branch, not its velocities);
    - else 'kept'."""

    def per_body(x: np.ndarray) -> np.ndarray:
        return np.linalg.norm(x.reshape(weights.shape) * weights, axis=1)

    (qd0, qdd0), (qd1, qdd1) = before, after
    mismatch = per_body(qd1 - qd0 - 0.5 * h * (qdd0 + qdd1))
    allowance = h * np.maximum(per_body(qdd0), per_body(qdd1))
    speed = np.maximum(per_body(qd0), per_body(qd1))
    fastest = float(np.max(speed, initial=0.0))
    k = int(np.argmax(mismatch - allowance))
    if mismatch[k] - allowance[k] > BRANCH_JUMP * fastest and np.max(allowance) < fastest:
        return "switched", float(mismatch[k]), bodies[k].name
    if not np.max(allowance, initial=0.0) < BRANCH_BLIND * fastest:
        return "cannot tell", fastest, bodies[int(np.argmax(speed))].name
    return "kept", float(mismatch[k]), bodies[k].name


def possible_switches(weights: np.ndarray, t: np.ndarray, qd: np.ndarray, qdd: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Which steps from sample k to k + 1 ``branch_verdict`` could call 'switched', for all of them at once by whole
    arrays: those whose largest mismatch exceeds its allowance by half the switch threshold (half: a margin far
    above rounding, so no step the verdict would call a switch is left out); ``branch_verdict`` judges each one
    kept. A long chain stays below NEAR_SINGULAR at every ordinary position, and judging each of its steps one
    call at a time cost more than the run's integration (a loop chain of 2 parallelograms: 100 steps, 3 ms)."""
    if k.size and k[-1] - k[0] == k.size - 1:  # consecutive steps (a chain near singular throughout): views, no copies
        i, j, samples = slice(k[0], k[-1] + 1), slice(k[0] + 1, k[-1] + 2), slice(k[0], k[-1] + 2)
    else:  # samples: the steps' ends, whose norms each step shares with its neighbours (made once: 4 norms -> 2)
        i, j, samples = k, k + 1, np.union1d(k, k + 1)
    h = (t[j] - t[i])[:, None]

    def per_body(x: np.ndarray) -> np.ndarray:
        return np.linalg.norm(x.reshape(-1, *weights.shape) * weights, axis=2)

    mismatch = per_body(qd[j] - qd[i] - 0.5 * h * (qdd[i] + qdd[j]))
    speeds, rates = np.empty((t.size, weights.shape[0])), np.empty((t.size, weights.shape[0]))
    speeds[samples], rates[samples] = per_body(qd[samples]), per_body(qdd[samples])
    allowance = h * np.maximum(rates[i], rates[j])
    fastest = np.max(np.maximum(speeds[i], speeds[j]), axis=1, initial=0.0)
    return np.max(mismatch - allowance, axis=1, initial=-np.inf) > 0.5 * BRANCH_JUMP * fastest


def branch_screen(ratios: np.ndarray, signs: np.ndarray | None, turns: np.ndarray) -> tuple:
    """What ``Guard.check_branches`` judges, from the ratios sigma_r / sigma_1 at the output times (N,), the signs of
    det [Psi_q; T^T] (N,) or None (redundant rows: not defined) and the turns of the null space over each step (N - 1,):
    (the times k where the ratio dips, ``dips``; the times k whose step from k - 1 flips the sign against a turn above
    ALIGNED, an odd rank loss; the steps k (to k + 1) over which the ratio changes a hundredfold (FALL) below
    NEAR_SINGULAR, a fall into or rise out of a configuration that stays singular, e.g. a parallelogram folded flat
    onto itself, which has no dip; the steps k with a ratio below NEAR_SINGULAR at either end), each ascending."""
    dipped = 1 + np.flatnonzero(dips(ratios))
    flipped = np.zeros(0, dtype=np.int64)
    if signs is not None:
        flipped = 1 + np.flatnonzero((np.abs(turns) > ALIGNED) & (turns * signs[1:] * signs[:-1] < 0))
    low, high = np.minimum(ratios[:-1], ratios[1:]), np.maximum(ratios[:-1], ratios[1:])
    fallen = np.flatnonzero((low < NEAR_SINGULAR) & (low < FALL * high))
    near = np.flatnonzero((ratios[:-1] < NEAR_SINGULAR) | (ratios[1:] < NEAR_SINGULAR))
    return dipped, flipped, fallen, near


def smaller(ratios: np.ndarray, brackets, a: int, b: int) -> int:
    """a if ratios[a] <= ratios[b], else b: the middle of a step ``check_branches`` judges (the time whose joints a
    switch there names). From the figures, or where the band left the two in overlapping brackets
    (``compiled.singular.Brackets``: a run that stops at singular positions), from the two closed there: the same
    order as closed figures give."""
    if brackets is not None:
        return brackets.smaller(a, b)
    return a if ratios[a] <= ratios[b] else b


def dips(ratios: np.ndarray) -> np.ndarray:
    """``diagnostics.passes_zero`` at every interior sample of a sequence of ratios at once (``check_branches``)."""
    before, middle, after = ratios[:-2], ratios[1:-1], ratios[2:]
    return (
        (middle < NEAR_SINGULAR)
        & (middle <= np.minimum(before, after))
        & (middle < np.maximum(before - middle, after - middle))
    )
