"""The Guard's singularity test from the band of Psi_q (solutions/compiled/singular.py) against the dense one.

Independent of the code under test: numpy's SVD for sigma_m / sigma_1, numpy's determinant of [Psi_q; T^T] for the
sign, Psi_q T = 0 and T^T T = I for the basis; and the Guard's verdict on a chain of parallelogram loops driven
through its flat (singular) position, the same with the band as with the dense SVDs and QRs."""

from __future__ import annotations

import functools
import math
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("numba")

from solutions.assembly import build_system  # noqa: E402
from solutions.diagnostics import NEAR_SINGULAR, SingularConfigurationError  # noqa: E402
from solutions.guard import (  # noqa: E402
    ALIGNED,
    BAND_SMALLEST,
    DENSE_LARGEST,
    FALL,
    Guard,
    dips,
    null_space_bases,
    null_space_turns,
    scale_rows,
    smaller,
    square_spectra,
)
from solutions.io import load_model  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from benchmarks.chains import loop_chain  # noqa: E402

from ..conftest import LazyModule  # noqa: E402

singular = LazyModule("solutions.compiled.singular")  # compiled where a test first needs it (conftest.LazyModule)

LOOPS = 25  # 76 bodies, 152 rows, 153 coordinates: past BAND_SMALLEST. Flat, each loop loses a rank: an
# odd count flips the sign of det [Psi_q; T^T] (an even one cancels in pairs, and only the ratio's dip tells)


@functools.cache
def _chain_at(angles_deg: tuple[float, ...]):
    system, _, _ = build_system(load_model(loop_chain(LOOPS)))
    qs = [build_system(load_model(loop_chain(LOOPS, math.radians(a))))[1] for a in angles_deg]
    return system, np.array(qs)


def chain_at(angles_deg):
    """The chain's system, and its q at each crank angle from the vertical (90 degrees: flat, singular)."""
    return _chain_at(tuple(float(a) for a in angles_deg))


@pytest.fixture(scope="module")
def perturbed():
    """Scaled Jacobians of the chain at 60 degrees and at random states about it (the Guard's scaling)."""
    system, qs = chain_at([60.0])
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    rng = np.random.default_rng(7)
    states = [qs[0] + 0.02 * k * rng.standard_normal(qs[0].size) for k in range(12)]
    return np.array([guard._scaled(system.jacobian(q, 0.0)) for q in states])


@pytest.mark.parametrize("first", ["dense", "band"])
def test_band_gives_the_dense_ratio_basis_and_sign(perturbed, first):
    """With the first time's basis given (a QR's) or found from the band (the banded LU of Psi_q^T picks E)."""
    before = null_space_bases(perturbed[:1])[0] if first == "dense" else None
    ratios, bases, signs, certified = singular.spectra(perturbed, before)
    assert not np.any(certified)  # closed: every basis made
    s = np.linalg.svd(perturbed, compute_uv=False)
    m = perturbed.shape[1]
    np.testing.assert_allclose(ratios, s[:, m - 1] / s[:, 0], rtol=1e-11)
    assert np.max(np.abs(perturbed @ bases)) < 1e-13  # the null space
    d = bases.shape[2]
    np.testing.assert_allclose(np.swapaxes(bases, 1, 2) @ bases, np.broadcast_to(np.eye(d), (len(bases), d, d)),
                               atol=1e-13)  # fmt: skip
    determinants = [np.linalg.det(np.vstack([J, T.T])) for J, T in zip(perturbed, bases, strict=True)]
    np.testing.assert_array_equal(signs, np.sign(determinants))


def test_near_singular_ratio_to_its_relative_accuracy():
    """Within a hundredth of a degree of flat, sigma_m / sigma_1 ~ 1e-5: the band's bisection keeps its digits."""
    system, qs = chain_at([89.99, 90.01])
    guard = Guard(system, chain_at([60.0])[1][0], 1e-3, 1e-8)
    scaled = np.array([guard._scaled(system.jacobian(q, 0.0)) for q in qs])
    ratios = singular.spectra(scaled, null_space_bases(scaled[:1])[0])[0]
    s = np.linalg.svd(scaled, compute_uv=False)
    dense = s[:, -1] / s[:, 0]
    assert np.all(dense < 1e-3)
    np.testing.assert_allclose(ratios, dense, rtol=1e-8)


def test_not_a_band_is_left_to_the_dense_code():
    rng = np.random.default_rng(3)
    dense = rng.standard_normal((2, 60, 70))
    assert singular.spectra(dense, null_space_bases(dense[:1])[0]) is None


def test_a_first_psi_q_singular_to_the_last_bit_takes_householder_s_basis():
    """``singular.spectra`` with no basis known: where the banded LU of the first Psi_q^T meets an exact zero pivot
    (a zero row, ``_band_start``'s FIRST_FAILED), the pass starts from Householder's QR of it, and gives what it
    gives when handed that basis; a band that is wide takes neither (None)."""
    rng = np.random.default_rng(7)
    m, n = 6, 14
    jacobians = np.zeros((5, m, n))
    for r in range(m):
        jacobians[:, r, 2 * r : 2 * r + 3] = rng.uniform(0.5, 1.5, (5, 3))
    jacobians[0, 2] = 0.0  # Psi_q singular to the last bit at the first time
    first = np.linalg.qr(jacobians[0].T, mode="complete")[0][:, m:]
    found, given = singular.spectra(jacobians, None, widest=2), singular.spectra(jacobians, first, widest=2)
    for a, b in zip(found, given, strict=True):
        np.testing.assert_array_equal(a, b)
    assert singular.spectra(jacobians, None, widest=8) is None


def _through(band: bool, monkeypatch, through: bool = False):
    """The Guard's message on the chain driven from 80 to 100 degrees through flat (not at an output time: there the
    ratio is rounding, ~1e-18 both ways), at 20 output times, from the band or (``band=False``) from numpy's dense
    SVDs and QRs; with ``through``, the crossings it records."""
    if not band:
        monkeypatch.setattr("solutions.guard._compiled_spectra", lambda *args: None)
    banded, spectra = [], singular.spectra
    monkeypatch.setattr(singular, "spectra", lambda *args: banded.append(1) or spectra(*args))
    angles = np.linspace(80.0, 100.0, 20)
    system, qs = chain_at(angles)
    times = np.linspace(0.0, 1.0, angles.size)
    guard = Guard(system, qs[0], 1e-3, 1e-8, through=through)
    guard.banded = True  # as a compiled run's (dynamics.compiled_motion)
    psi = np.array([system.constraints(q, 0.0) for q in qs])
    jacobians = np.array([system.jacobian(q, 0.0) for q in qs])
    if through:
        guard.check_outputs(times, qs, psi, jacobians)
    else:
        with pytest.raises(SingularConfigurationError) as stop:
            guard.check_outputs(times, qs, psi, jacobians)
    assert bool(banded) == band  # the band taken, or the dense code
    return (guard.crossings, guard.closest) if through else str(stop.value)


def test_guard_stops_at_the_crossing_with_the_dense_message(monkeypatch):
    banded = _through(True, monkeypatch)
    assert "singular configuration between t = 0.473684 s and t = 0.526316 s" in banded
    assert banded == _through(False, monkeypatch)


def test_a_run_through_records_the_dense_crossings(monkeypatch):
    """The chain swung from 80 to 100 degrees at 20 output times passes flat (90 degrees) at t = 0.5, midway between
    t_9 (89.47) and t_10 (90.53): mirror images, whose ratios are equal but for rounding (~1e-13 apart), so either
    is the dip's bottom and the crossing's time (which one depends on the last bits of the route: the band's LU or
    numpy's QR). The band records one crossing there, at one of the two, with the dense SVD's figure at that time."""
    crossings, closest = _through(True, monkeypatch, through=True)
    dense_crossings, dense_closest = _through(False, monkeypatch, through=True)
    times = np.linspace(0.0, 1.0, 20)
    system, qs = chain_at(np.linspace(80.0, 100.0, 20)[9:11])
    scaled = [Guard(system, qs[0], 1e-3, 1e-8)._scaled(system.jacobian(q, 0.0)) for q in qs]
    s = np.linalg.svd(np.array(scaled), compute_uv=False)
    tied = dict(zip(times[9:11], s[:, -1] / s[:, 0], strict=True))  # numpy's ratio at t_9 and t_10
    assert tied[times[9]] == pytest.approx(tied[times[10]], rel=1e-9) and max(tied.values()) < 1e-2
    for found in (crossings, dense_crossings):
        assert len(found) == 1 and found[0]["t"] in tied
        assert found[0]["ratio"] == pytest.approx(tied[found[0]["t"]], rel=1e-10)
    for found in (closest, dense_closest):
        assert found["t"] in tied and found["ratio"] == pytest.approx(tied[found["t"]], rel=1e-10)


@pytest.mark.parametrize("shape", [(9, 9), (4, 6), (8, 9), (20, 23)])
def test_small_dense_spectra_give_numpys_ratio_basis_and_sign(shape):
    """dense_spectra (QR of Psi_q^T, one-sided Jacobi on R) against numpy's SVD and determinant, on random Psi_q with
    columns weighted and rows of any length (scaled by the routine, as scale_rows), near singular ones
    among them (a row replaced by its neighbour plus 1e-6 of noise)."""
    m, n = shape
    rng = np.random.default_rng(m * n)
    jacobians = rng.standard_normal((12, m, n)) * rng.uniform(0.1, 10.0, (12, m, 1))
    jacobians[6:, 1] = jacobians[6:, 0] + 1e-6 * rng.standard_normal((6, n))
    columns = rng.uniform(0.5, 2.0, n)
    norms = np.linalg.norm(jacobians * columns, axis=-1)
    ratios, bases, signs = singular.dense_spectra(jacobians, columns, norms)
    scaled = scale_rows(jacobians, columns, norms)
    s = np.linalg.svd(scaled, compute_uv=False)
    assert np.all(s[6:, -1] / s[6:, 0] < 1e-5) and np.all(s[:6, -1] / s[:6, 0] > 1e-3)
    np.testing.assert_allclose(ratios[:6], s[:6, -1] / s[:6, 0], rtol=1e-10)
    np.testing.assert_allclose(ratios[6:], s[6:, -1] / s[6:, 0], rtol=1e-6)  # numpy's own error: eps / ratio
    assert bases.shape == (12, n, n - m) and np.max(np.abs(scaled @ bases), initial=0.0) < 1e-13
    np.testing.assert_allclose(np.swapaxes(bases, 1, 2) @ bases, np.broadcast_to(np.eye(n - m), (12, n - m, n - m)),
                               atol=1e-13)  # fmt: skip
    determinants = [np.linalg.det(np.vstack([J, T.T])) for J, T in zip(scaled, bases, strict=True)]
    np.testing.assert_array_equal(signs, np.sign(determinants))


def test_the_bands_iterated_ratio_is_numpys_without_the_bidiagonal_route():
    """The band's ratio from the Gram matrix's extreme eigenvalues (_iterated_ratio: Cholesky tests, shifted inverse
    iteration) itself, not its fallback, along the chain's swing from 30 to 85 degrees (sigma_m / sigma_1 from 2e-2
    to 1e-4): numpy's SVD to 1e-10, each time warm-started from the time before as in a run."""
    system, qs = chain_at(np.linspace(30.0, 85.0, 8))
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    scaled = np.array([guard._scaled(system.jacobian(q, 0.0)) for q in qs])
    pattern = np.any(scaled != 0.0, axis=0)
    _, keys = singular.band_order(pattern)
    starts = np.concatenate([[0], np.cumsum(pattern.sum(axis=1))]).astype(np.int64)
    indices = np.concatenate([np.flatnonzero(row) for row in pattern]).astype(np.int64)
    rows = np.argsort(keys, kind="mergesort")
    m, n = scaled.shape[1:]
    w = singular._gram_width(rows, starts, indices, n)
    G, L, low, high, y = np.empty((m, w + 1)), np.empty((m, w + 1)), np.ones(m), np.ones(m), np.empty(n)
    products = singular._gram_products(rows, starts, indices, w, n)
    envelope = singular._envelope(products, m, w)
    ratios = [
        singular._iterated_ratio(J, rows, starts, indices, products, envelope, G, L, low, high, y) for J in scaled
    ]
    s = np.linalg.svd(scaled, compute_uv=False)
    assert w < 16 and np.all(s[:, -1] / s[:, 0] < 0.1)  # a band, and near singular all along: the figure matters
    np.testing.assert_allclose(ratios, s[:, -1] / s[:, 0], rtol=1e-10)


def test_row_norms_from_the_bodies_columns_are_numpys_with_the_pattern():
    """The Guard's row norms of a history of Psi_q read on the columns of the bodies each row's element joins
    (history_norms with the system's reach) are the dense pass's over every column to the last bit (and numpy's to
    rounding), and its pattern is where numpy finds a nonzero entry; a reach that is not this history's (other
    rows) falls back to the dense pass, without pattern."""
    from solutions.compiled import history

    system, qs = chain_at([40.0, 60.0, 75.0])
    jacobians = np.array([system.jacobian(q, 0.0) for q in qs])
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    reach = history.row_columns(system)
    assert reach is not None and reach.shape[1] < jacobians.shape[2] // 8  # a few columns a row: the pass pays
    norms, pattern = singular.history_norms(jacobians, guard._columns, reach)
    np.testing.assert_array_equal(norms, singular.row_norms(jacobians, guard._columns))  # the dense pass's sums
    np.testing.assert_allclose(norms, np.linalg.norm(jacobians * guard._columns, axis=-1), rtol=1e-14)
    np.testing.assert_array_equal(pattern, np.any(jacobians != 0.0, axis=0))
    dense, none = singular.history_norms(jacobians[:, 1:], guard._columns, reach)
    assert none is None
    np.testing.assert_allclose(dense, np.linalg.norm(jacobians[:, 1:] * guard._columns, axis=-1), rtol=1e-15)


def test_a_blocked_history_gives_the_dense_ones_norms_pattern_and_spectra():
    """Psi_q's history by its rows' blocks (``history.BlockedJacobians``: a large Psi_q's, from the compiled run):
    the Guard's row norms, pattern and band spectra from its blocks are those of the dense history to the last bit
    (the same entries, read in the same order), and its verdicts on it too (the closest approach to a singular
    position); near flat (89.99 degrees) as well as far from it."""
    from solutions.compiled import history

    system, qs = chain_at([40.0, 60.0, 75.0, 89.99])
    jacobians = np.array([system.jacobian(q, 0.0) for q in qs])
    blocked = history.BlockedJacobians.gather(jacobians, history.row_columns(system))
    np.testing.assert_array_equal(blocked.dense(), jacobians)  # the rows' blocks hold every nonzero
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    norms, pattern = singular.history_norms(jacobians, guard._columns, history.row_columns(system))
    got_norms, got_pattern = singular.history_norms(blocked, guard._columns)
    np.testing.assert_array_equal(got_norms, norms)
    np.testing.assert_array_equal(got_pattern, pattern)
    np.testing.assert_array_equal(blocked.pattern(), pattern)
    for given in (pattern, None):  # the pattern as history_norms gives it, or found from the blocks
        want = singular.spectra(jacobians, None, guard._columns, norms, pattern)
        got = singular.spectra(blocked, None, guard._columns, norms, given)
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a, b)
    verdicts = []
    for history_of_psi_q in (jacobians, blocked):
        judged = Guard(system, qs[0], 1e-3, 1e-8)
        judged.banded = True
        judged.check_outputs(np.arange(4.0), qs, np.zeros((4, jacobians.shape[1])), history_of_psi_q)
        verdicts.append(judged.closest)
    assert verdicts[0] == verdicts[1] and verdicts[0]["ratio"] < 1e-3  # near flat: the figure matters


def test_the_compiled_slots_and_first_entries_are_the_blocked_history_s():
    """``spectra``'s compiled reads of a blocked history (``_entry_slots``, ``_first_entries``) find each entry's
    slot as ``history.column_slots`` does (-1 where a row does not reach the column) and the first time's Psi_q on
    its pattern as the dense history holds it, to the last bit."""
    from solutions.compiled import history

    system, qs = chain_at([40.0, 60.0, 89.99])
    jacobians = np.array([system.jacobian(q, 0.0) for q in qs])
    reach = history.row_columns(system)
    blocked = history.BlockedJacobians.gather(jacobians, reach)
    m, n = jacobians.shape[1:]
    everywhere = np.ones((m, n), dtype=bool)  # every column of every row: most not reached
    for pattern in (history.BlockedJacobians.pattern(blocked), everywhere):
        starts = np.concatenate([[0], np.cumsum(pattern.sum(axis=1))]).astype(np.int64)
        rows, indices = (np.ascontiguousarray(a, dtype=np.int64) for a in np.nonzero(pattern))  # as _band_structure
        slots = singular._entry_slots(reach, starts, indices)
        np.testing.assert_array_equal(slots, history.column_slots(reach, rows, indices))
        if pattern is everywhere:
            assert np.any(slots < 0)
            continue
        first = singular._first_entries(blocked.values, starts, indices, slots, n)
        np.testing.assert_array_equal(first[pattern], jacobians[0][pattern])
        assert not np.any(first[~pattern])


def test_the_band_start_reads_the_first_time_from_the_stored_history():
    """``_band_start`` reads the first time's entries itself (``_first_entries``), from a dense history (slots =
    columns) or one by its rows' blocks: the same first null-space basis and verdict from both, to the last bit,
    and the basis of the first Psi_q's null space."""
    from solutions.compiled import history

    system, qs = chain_at([40.0, 60.0, 89.99])
    jacobians = np.array([system.jacobian(q, 0.0) for q in qs])
    reach = history.row_columns(system)
    blocked = history.BlockedJacobians.gather(jacobians, reach)
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    norms, pattern = singular.history_norms(jacobians, guard._columns, reach)
    position, keys, starts, indices = singular._band_structure(pattern)
    scale = (guard._columns, norms[0], position, keys, starts, indices, np.empty((0, 0)), float(singular.WIDEST_MID))
    slots = singular._entry_slots(reach, starts, indices)
    dense_first, dense_found = singular._band_start(jacobians, indices, *scale)
    first, found = singular._band_start(blocked.values, slots, *scale)
    assert found == dense_found == singular.BAND
    np.testing.assert_array_equal(first, dense_first)
    scaled = jacobians[0] * guard._columns / norms[0][:, None]
    assert np.max(np.abs(scaled @ first)) < 1e-13


@pytest.mark.parametrize("loops", [2, 5])
def test_mid_size_psi_q_takes_the_band_with_numpys_ratio_basis_and_sign(loops, monkeypatch):
    """A Psi_q of more than DENSE_LARGEST rows and fewer than BAND_SMALLEST coordinates (the loop chain of 2
    and 5 loops: 14 x 15, 32 x 33) goes to the band (up to half of n wide, ``singular.WIDEST_MID``) in a compiled
    run's square_spectra, and gives numpy's SVD ratio, an orthonormal null-space basis and numpy's sign of
    det [Psi_q; T^T], near-singular states (a hundredth of a degree off flat) among them."""
    taken, spectra = [], singular.spectra
    monkeypatch.setattr(singular, "spectra", lambda *args: taken.append(1) or spectra(*args))
    system = build_system(load_model(loop_chain(loops)))[0]
    qs = [build_system(load_model(loop_chain(loops, math.radians(a))))[1] for a in (40.0, 60.0, 75.0, 89.99, 90.01)]
    rng = np.random.default_rng(loops)
    qs += [qs[1] + 0.02 * rng.standard_normal(qs[1].size) for _ in range(3)]
    jacobians = np.array([system.jacobian(q, 0.0) for q in qs])
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    N, m, n = jacobians.shape
    assert DENSE_LARGEST < m < n < BAND_SMALLEST
    norms = np.linalg.norm(jacobians * guard._columns, axis=-1)
    ratios, bases, signs, _, _ = square_spectra(jacobians, guard._columns, norms, None)
    assert taken  # the band, not numpy's dense route
    scaled = np.array([guard._scaled(J) for J in jacobians])
    s = np.linalg.svd(scaled, compute_uv=False)
    dense = s[:, -1] / s[:, 0]
    assert np.all(dense[3:5] < 1e-3)  # near flat: near singular
    np.testing.assert_allclose(ratios, dense, rtol=1e-8)
    np.testing.assert_allclose(np.delete(ratios, [3, 4]), np.delete(dense, [3, 4]), rtol=1e-12)
    assert np.max(np.abs(scaled @ bases)) < 1e-13
    np.testing.assert_allclose(np.swapaxes(bases, 1, 2) @ bases, np.broadcast_to(np.eye(n - m), (N, n - m, n - m)),
                               atol=1e-13)  # fmt: skip
    determinants = [np.linalg.det(np.vstack([J, T.T])) for J, T in zip(scaled, bases, strict=True)]
    np.testing.assert_array_equal(signs, np.sign(determinants))


MID = 4  # 26 x 27: a mid-size Psi_q (DENSE_LARGEST < m < BAND_SMALLEST), the band's WIDEST_MID route


@pytest.fixture(scope="module")
def swing():
    """The chain of MID loops swung from 60 to 119 degrees through flat (90, between two of the 31 output times):
    its system, the times, q and Psi_q there."""
    angles = np.linspace(60.0, 119.0, 31)
    system = build_system(load_model(loop_chain(MID)))[0]
    qs = np.array([build_system(load_model(loop_chain(MID, math.radians(a))))[1] for a in angles])
    return system, np.linspace(0.0, 1.0, angles.size), qs, np.array([system.jacobian(q, 0.0) for q in qs])


@pytest.mark.parametrize("square", [False, True])
def test_settled_ratios_decide_as_numpys_svd_through_a_singular_position(swing, square, monkeypatch):
    """The Guard's ratios in brackets, closed only where its tests need them (``settle``, singular.settled), give
    every decision that numpy's SVD ratios give: the order of each two adjacent times, the falls, the dips
    (diagnostics.passes_zero), the thresholds; the smallest ratio and the dip's to 1e-10; the others within the
    brackets' width (the loose figures are taken: not all to 1e-12); the basis and sign as numpy's. ``square``:
    Psi_q with a driver's row (a unit row on the coordinate the chain moves most in: 27 x 27, as a driven
    mechanism's; no null space, the sign of det Psi_q), which takes the band too (singular.WIDEST_SQUARE)."""
    system, t, qs, jacobians = swing
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    if square:
        driven = np.argmax(np.abs(null_space_bases(guard._scaled(jacobians[:1]))[0, :, 0]))
        jacobians = np.concatenate([jacobians, np.zeros((len(t), 1, jacobians.shape[2]))], axis=1)
        jacobians[:, -1, driven] = 1.0
    taken, spectra = [], singular.spectra
    monkeypatch.setattr(singular, "spectra", lambda *args: taken.append(1) or spectra(*args))
    norms = np.linalg.norm(jacobians * guard._columns, axis=-1)
    settle = ((1e-8, NEAR_SINGULAR), FALL)
    ratios, bases, signs, turns, brackets = square_spectra(jacobians, guard._columns, norms, None, True, None,
                                                                     settle)  # fmt: skip
    assert taken  # the band
    scaled = np.array([guard._scaled(J) for J in jacobians])
    s = np.linalg.svd(scaled, compute_uv=False)
    exact = s[:, -1] / s[:, 0]
    dip = int(np.argmin(exact))
    assert exact[dip] < 1e-2 and np.all(exact < NEAR_SINGULAR)  # every time judged by check_branches
    np.testing.assert_allclose(ratios, exact, rtol=1e-3)
    assert not np.allclose(ratios, exact, rtol=1e-12, atol=0.0)  # brackets, not closed figures, at most times
    np.testing.assert_allclose(ratios[dip - 1 : dip + 2], exact[dip - 1 : dip + 2], rtol=1e-10)
    np.testing.assert_array_equal(dips(ratios), dips(exact))
    assert dips(exact)[dip - 1]  # the crossing is seen
    ordered = [smaller(ratios, brackets, k, k + 1) == k for k in range(len(t) - 1)]  # as check_branches
    np.testing.assert_array_equal(ordered, exact[:-1] <= exact[1:])
    falls = [np.minimum(r[:-1], r[1:]) < FALL * np.maximum(r[:-1], r[1:]) for r in (ratios, exact)]
    np.testing.assert_array_equal(*falls)
    made = np.all(np.isfinite(bases), axis=(1, 2))  # the bases made: at the ends of the steps not certified
    assert made[0] and made[-1] and made[dip - 1 : dip + 2].all() and (square or not made.all())  # square: no T
    assert np.max(np.abs(scaled[made] @ bases[made]), initial=0.0) < 1e-13
    determinants = [np.linalg.det(np.vstack([J, T.T])) for J, T in zip(scaled[made], bases[made], strict=True)]
    np.testing.assert_array_equal(signs[made], np.sign(determinants))
    tangents, dense_signs = null_space_bases(scaled, signs=True)  # numpy's: every step's flip test as the Guard's
    flips = [(np.abs(u) > ALIGNED) & (u * g[1:] * g[:-1] < 0)
             for u, g in ((turns, signs), (null_space_turns(tangents, dense_signs), dense_signs))]  # fmt: skip
    np.testing.assert_array_equal(*flips)


def test_a_mid_size_run_through_records_the_dense_crossings_and_figures(swing, monkeypatch):
    """The Guard of a run that passes the singular position (``through``) records, from the settled band, the
    crossing and the closest ratio (time and figure) that numpy's dense SVDs and QRs give it."""
    system, t, qs, jacobians = swing
    psi = np.array([system.constraints(q, 0.0) for q in qs])
    found = []
    for band in (True, False):
        if not band:
            monkeypatch.setattr("solutions.guard._compiled_spectra", lambda *args: None)
        guard = Guard(system, qs[0], 1e-3, 1e-8, through=True)
        guard.banded = True
        guard.check_outputs(t, qs, psi, jacobians)
        found.append((guard.crossings, guard.closest))
    (crossings, closest), (dense_crossings, dense_closest) = found
    assert len(crossings) == 1 and [c["t"] for c in crossings] == [c["t"] for c in dense_crossings]
    assert crossings[0]["ratio"] == pytest.approx(dense_crossings[0]["ratio"], rel=1e-10)
    assert closest["t"] == dense_closest["t"] and closest["ratio"] == pytest.approx(dense_closest["ratio"], rel=1e-10)


@pytest.fixture(scope="module")
def small_swing():
    """One parallelogram loop (8 x 9: a small Psi_q, compiled.singular.dense_spectra's) swung from 30 to 149 degrees
    through flat (90, between two of the 61 output times): its Guard, Psi_q there, and numpy's SVD ratios of the
    scaled Psi_q."""
    angles = np.linspace(30.0, 149.0, 61)
    system = build_system(load_model(loop_chain(1)))[0]
    qs = np.array([build_system(load_model(loop_chain(1, math.radians(a))))[1] for a in angles])
    jacobians = np.array([system.jacobian(q, 0.0) for q in qs])
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    s = np.linalg.svd(np.array([guard._scaled(J) for J in jacobians]), compute_uv=False)
    return guard, jacobians, s[:, -1] / s[:, 0]


def test_small_settled_ratios_decide_as_numpys_svd_through_a_singular_position(small_swing):
    """A small Psi_q's ratios in brackets (dense_spectra with the Guard's ``settle``: Jacobi only where its tests need
    the figure) give every decision numpy's SVD ratios give: the order of adjacent times, the falls, the dips, the
    thresholds; the smallest and the dip's three to 1e-10; every other within the brackets' width, and each
    bracket holds numpy's figure; the basis and sign those of the closed route, bit for bit."""
    guard, jacobians, exact = small_swing
    assert jacobians.shape[1:] == (8, 9) and jacobians.shape[1] <= DENSE_LARGEST
    norms = np.linalg.norm(jacobians * guard._columns, axis=-1)
    settle = ((1e-8, NEAR_SINGULAR), FALL)
    ratios, bases, signs, _, _ = square_spectra(jacobians, guard._columns, norms, None, True, None, settle)
    closed = singular.dense_spectra(jacobians, guard._columns, norms)
    dip = int(np.argmin(exact))
    assert exact[dip] < 1e-2 < exact[0]
    np.testing.assert_allclose(ratios, exact, rtol=3e-4)
    assert not np.allclose(ratios, exact, rtol=1e-12, atol=0.0)  # brackets, not closed figures, at most times
    np.testing.assert_allclose(ratios[dip - 1 : dip + 2], exact[dip - 1 : dip + 2], rtol=1e-10)
    np.testing.assert_array_equal(ratios[dip - 1 : dip + 2], closed[0][dip - 1 : dip + 2])  # Jacobi's own figures
    np.testing.assert_array_equal(dips(ratios), dips(exact))
    assert dips(exact)[dip - 1]  # the crossing is seen
    np.testing.assert_array_equal(ratios[:-1] <= ratios[1:], exact[:-1] <= exact[1:])
    falls = [np.minimum(r[:-1], r[1:]) < FALL * np.maximum(r[:-1], r[1:]) for r in (ratios, exact)]
    np.testing.assert_array_equal(*falls)
    for value in settle[0]:
        np.testing.assert_array_equal(ratios < value, exact < value)
    np.testing.assert_array_equal(bases, closed[1])
    np.testing.assert_array_equal(signs, closed[2])
    scale = (np.ascontiguousarray(guard._columns), np.ascontiguousarray(norms))
    figures, _, _, lower = singular._dense_bracketed(np.ascontiguousarray(jacobians), *scale, True, singular.LOOSE)
    assert np.all(lower <= exact * (1 + 1e-13)) and np.all(exact <= figures * (1 + 1e-13))


def test_a_constant_small_ratio_is_closed_as_before(small_swing):
    """A Psi_q that does not change (a driven mechanism held still): no bracket can settle its ratios, each equal to
    its neighbours' (Weyl's bound: the pass closes them at once), so the settled route gives Jacobi's figures of
    the closed route, bit for bit."""
    guard, jacobians, _ = small_swing
    still = np.repeat(jacobians[:1], 20, axis=0)
    norms = np.linalg.norm(still * guard._columns, axis=-1)
    settle = ((1e-8, NEAR_SINGULAR), FALL)
    made = singular.dense_spectra(still, guard._columns, norms, settle=settle)
    closed = singular.dense_spectra(still, guard._columns, norms)
    for a, b in zip(made, closed, strict=True):
        np.testing.assert_array_equal(a, b)


def test_a_moving_psi_q_of_constant_ratio_is_not_bracketed(small_swing):
    """Psi_q turned by rotations of its columns (it moves far more than a bracket's width; its singular values stay,
    the ratio constant to rounding, as a cylindrical joint's rotation): the brackets of neighbouring times would
    overlap, so none is tried (the figures do not move: singular.MOVING) and every ratio is Jacobi's, the settled
    route the closed one bit for bit."""
    _, jacobians, _ = small_swing
    J = jacobians[10] / np.linalg.norm(jacobians[10], axis=-1, keepdims=True)
    n = J.shape[1]
    turns = []
    for angle in np.linspace(0.0, 1.0, 20):
        R = np.eye(n)
        R[[0, 0, 3, 3], [0, 3, 0, 3]] = np.cos(angle), -np.sin(angle), np.sin(angle), np.cos(angle)
        turns.append(J @ R)
    turning = np.array(turns)
    columns, norms = np.ones(n), np.linalg.norm(turning, axis=-1)
    assert np.min(np.linalg.norm(np.diff(turning, axis=0), axis=(1, 2))) > 1e-2  # Psi_q moves
    figures, _, _, lower = singular._dense_bracketed(turning, columns, norms, True, singular.LOOSE)
    np.testing.assert_array_equal(lower, figures)  # every ratio closed by Jacobi, no bracket tried
    s = np.linalg.svd(turning, compute_uv=False)
    np.testing.assert_allclose(figures, s[:, -1] / s[:, 0], rtol=1e-12)
    settle = ((1e-8, NEAR_SINGULAR), FALL)
    for a, b in zip(singular.dense_spectra(turning, columns, norms, settle=settle),
                    singular.dense_spectra(turning, columns, norms), strict=True):  # fmt: skip
        np.testing.assert_array_equal(a, b)


def test_the_band_lu_solves_and_signs_as_numpy():
    """singular._band_lu / _band_solve (the banded LU with partial pivoting written out) on a random band 17 x 17
    (kl = 2, ku = 3) whose small diagonal forces row swaps: A^-1 b as numpy's solve, the sign of det A from U's
    diagonal and the swaps as numpy's determinant's; an exact zero column stops it (False)."""
    rng = np.random.default_rng(5)
    n, kl, ku = 17, 2, 3
    A = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - kl), min(n, i + ku + 1)):
            A[i, j] = rng.standard_normal()
        A[i, i] *= 1e-3
    ab = np.zeros((n, 2 * kl + ku + 1))
    for i in range(n):
        for j in range(max(0, i - kl), min(n, i + ku + 1)):
            ab[j, kl + ku + i - j] = A[i, j]
    pivots = np.empty(n, dtype=np.int64)
    assert singular._band_lu(ab, kl, ku, pivots)
    assert np.any(pivots != np.arange(n))  # rows were swapped
    b = rng.standard_normal(n)
    x = b.copy()
    singular._band_solve(ab, kl, ku, pivots, x)
    np.testing.assert_allclose(A @ x, b, atol=1e-12)
    np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-9)
    sign = np.prod(np.sign(ab[:, kl + ku])) * (-1.0) ** np.count_nonzero(pivots != np.arange(n))
    assert sign == np.sign(np.linalg.det(A))
    A[:, 4] = 0.0
    ab[:, :] = 0.0
    for i in range(n):
        for j in range(max(0, i - kl), min(n, i + ku + 1)):
            ab[j, kl + ku + i - j] = A[i, j]
    assert not singular._band_lu(ab, kl, ku, pivots)


def test_the_envelope_cholesky_is_numpys_and_tests_the_eigenvalues():
    """singular._cholesky on a band (w = 4) whose rows start at different columns (zeros left of each row's first
    entry, as the loop chain's Gram matrix): the factor numpy's Cholesky's, and a + b shift definite exactly where
    numpy's eigenvalues say (the Sturm test of the brackets), on both sides of the smallest and largest."""
    rng = np.random.default_rng(11)
    m, w = 12, 4
    starts = [max(0, i - rng.integers(0, w + 1)) for i in range(m)]
    B = np.zeros((m, m))
    for i in range(m):
        B[i, starts[i] : i + 1] = rng.standard_normal(i + 1 - starts[i])
    A = B @ B.T + 0.1 * np.eye(m)
    A[np.abs(np.subtract.outer(np.arange(m), np.arange(m))) > w] = 0.0
    A = A + m * np.eye(m)  # definite after the band's cut
    G = np.zeros((m, w + 1))
    for i in range(m):
        for t in range(min(w, i) + 1):
            G[i, t] = A[i, i - t]
    L = np.empty_like(G)
    assert singular._cholesky(G, 1.0, 0.0, L)
    dense = np.zeros((m, m))
    for i in range(m):
        dense[i, i] = 1.0 / L[i, 0]
        for t in range(1, min(w, i) + 1):
            dense[i, i - t] = L[i, t]
    np.testing.assert_allclose(dense, np.linalg.cholesky(A), atol=1e-13)
    eigenvalues = np.linalg.eigvalsh(A)
    for s in (eigenvalues[0] * (1 - 1e-6), eigenvalues[0] * (1 + 1e-6)):
        assert singular._cholesky(G, 1.0, -s, L) == (eigenvalues[0] > s)
    for s in (eigenvalues[-1] * (1 - 1e-6), eigenvalues[-1] * (1 + 1e-6)):
        assert singular._cholesky(G, -1.0, s, L) == (eigenvalues[-1] < s)


def test_a_fall_s_figure_is_closed():
    """A fall of the ratio (a hundredfold over a step, below NEAR_SINGULAR: ``Guard.check_branches`` records a
    crossing there with the low end's ratio as its figure) is closed at its low end, though its bracket decides
    every comparison and is not the run's smallest: a reported figure is never a bracket's end (i25-guard6 found
    the bracket's upper end, up to LOOSE off, reported)."""
    upper = np.array([0.05, 2e-4, 1e-4, 1.5e-4])
    lower = upper * (1.0 - singular.LOOSE)
    lower[2] = upper[2]  # the smallest, closed
    thresholds = np.array([1e-8, NEAR_SINGULAR])
    done = singular.settled(lower, upper, np.ones(4), thresholds, FALL, True)
    assert not done[1]  # the fall's low end: its figure is reported
    assert done[0] and done[3]  # the fall's high end and a time that neither falls nor dips: brackets
    assert upper[1] < FALL * upper[0] and not dips(upper)[0]  # a fall, no dip, not the smallest


def test_a_certified_step_moves_psi_q_by_less_than_sigma_m(swing):
    """``singular._scale``'s bound of |J_k - J_k-1|_2 holds (numpy's 2-norm of the scaled difference is below it), and
    a step ``certified`` from it is one over which [J; T^T] (T the basis at t_k-1) cannot turn singular: its
    smallest singular value at t_k-1, min(sigma_m, 1), is above the move (Weyl's inequality), and numpy's
    det [J_k; T^T] keeps the sign of det [J_k-1; T^T]."""
    system, t, qs, jacobians = swing
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    norms = np.linalg.norm(jacobians * guard._columns, axis=-1)
    scaled = scale_rows(jacobians, guard._columns, norms)
    position, keys, starts, indices = singular._band_structure(np.any(jacobians != 0.0, axis=0))
    J, previous, sums = np.zeros(scaled.shape[1:]), np.zeros(scaled.shape[1:]), np.empty(scaled.shape[2])
    columns, norms = np.ascontiguousarray(guard._columns), np.ascontiguousarray(norms)
    moved = [singular._scale(jacobians, k, columns, norms, starts, indices, indices, J, previous, sums)
             for k in range(len(t))][1:]  # fmt: skip
    np.testing.assert_array_equal(J, scaled[-1])  # the last time's scaled Psi_q, as scale_rows makes it
    exact = np.linalg.norm(np.diff(scaled, axis=0), ord=2, axis=(1, 2))
    assert np.all(exact <= np.array(moved) * (1.0 + 1e-12))
    s = np.linalg.svd(scaled, compute_uv=False)
    ratios = s[:, -1] / s[:, 0]
    tangents, signs = null_space_bases(scaled, signs=True)
    steps = [k for k in range(len(moved)) if singular.certified(moved[k], ratios[k])]
    assert 0 < len(steps) < len(moved)  # the steps next to the flat position are not certified
    for k in steps:
        assert moved[k] < min(s[k, -1], 1.0)
        assert np.sign(np.linalg.det(np.vstack([scaled[k + 1], tangents[k].T]))) == signs[k]


def _bracket_reference(J, rows, starts, indices, G, low, high, loose, spread):
    """``singular._bracketed_ratio`` as it was before its brackets ran side by side: ``_top``, then ``_bottom``, over
    the whole band (``_whole_band``: no envelope)."""
    y, L = np.empty(J.shape[1]), np.empty_like(G)
    whole = singular._whole_band(G.shape[0], G.shape[1] - 1)
    top, ceiling = singular._top(G, L, high, loose, spread, whole)
    if not np.isfinite(ceiling):
        return np.nan, np.nan
    bottom, floor = singular._bottom(J, rows, starts, indices, G, L, low, y, loose, spread, ceiling, whole)
    if not np.isfinite(floor):
        return np.nan, np.nan
    return np.sqrt(bottom / top), np.sqrt(floor / ceiling)


def test_the_brackets_side_by_side_are_the_brackets_one_after_the_other():
    """The two extreme eigenvalues' brackets side by side (``singular._cholesky_pair``, ``_solve_pair``,
    ``_quotients``: the processor overlaps the two chains; the solves and quotients over G's envelope alone,
    ``_envelope``) give the factors, vectors and quotients of ``_cholesky``, ``_solve_normalized``, ``_rayleigh`` and
    ``_residual`` (over the whole band) one after the other, to the last bit, with shifts on both
    sides of the extreme eigenvalues of a loop chain's Gram matrix; and ``_bracketed_ratio`` the figures, vectors and
    spreads of ``_top`` then ``_bottom``, from vectors near the eigenvectors (the side-by-side route) and far off."""
    system, q, _ = build_system(load_model(loop_chain(4)))
    J = Guard(system, q, 1e-3, 1e-8)._scaled(system.jacobian(q, 0.0))
    position, keys, starts, indices = singular._band_structure(J != 0.0)
    rows = np.argsort(keys, kind="mergesort")
    w = singular._gram_width(rows, starts, indices, J.shape[1])
    G = np.empty((J.shape[0], w + 1))
    products = singular._gram_products(rows, starts, indices, w, J.shape[1])
    singular._gram(J, products, G)
    envelope = singular._envelope(products, J.shape[0], w)  # the pair's solves and quotients: over it alone
    assert np.sum(envelope[0] > np.arange(J.shape[0]) - w) > J.shape[0] // 2  # most rows shorter than the band
    values, vectors = np.linalg.eigh((J @ J.T)[np.ix_(rows, rows)])
    band = np.array([[t <= i for t in range(w + 1)] for i in range(J.shape[0])])  # the factors' stored entries
    for above in values[-1] * np.array([1 + 1e-3, 1 - 1e-3]):
        for below in values[0] * np.array([1 - 1e-3, 1 + 1e-3]):
            pair, apart = np.empty((2, *G.shape)), np.empty((2, *G.shape))
            both = singular._cholesky(G, -1.0, above, apart[0]) & singular._cholesky(G, 1.0, -below, apart[1])
            assert singular._cholesky_pair(G, above, below, pair[0], pair[1]) == both
            if both:
                assert np.array_equal(pair[:, band], apart[:, band])
    rng = np.random.default_rng(5)
    high, low = vectors[:, -1] + 1e-3 * rng.standard_normal(G.shape[0]), vectors[:, 0].copy()
    factors = np.empty((2, *G.shape))
    assert singular._cholesky_pair(G, values[-1] * 1.01, values[0] * 0.99, factors[0], factors[1])
    side = high.copy(), low.copy()
    singular._solve_pair(factors[0], side[0], factors[1], side[1], envelope)
    apart = high.copy(), low.copy()
    whole = singular._whole_band(J.shape[0], w)
    singular._solve_normalized(factors[0], apart[0], whole)
    singular._solve_normalized(factors[1], apart[1], whole)
    assert np.array_equal(side[0], apart[0]) and np.array_equal(side[1], apart[1])
    y = np.empty(J.shape[1])
    assert singular._quotients(G, high, J, rows, starts, indices, low, y, envelope) == (
        singular._rayleigh(G, high, whole),
        singular._residual(J, rows, starts, indices, low, y),
    )
    for start in (0.0, 1e-6, 1e-2, 1.0):  # from near the eigenvectors (side by side) to far off (one after the other)
        low = vectors[:, 0] + start * rng.standard_normal(G.shape[0])
        high = vectors[:, -1] + start * rng.standard_normal(G.shape[0])
        low, high = low / np.linalg.norm(low), high / np.linalg.norm(high)
        given = [low.copy(), high.copy(), np.array([0.5, 0.5])]
        expected = _bracket_reference(J, rows, starts, indices, G, given[0], given[1], singular.LOOSE, given[2])
        found = [low.copy(), high.copy(), np.array([0.5, 0.5])]
        products = np.empty((0, 3), dtype=np.int64)  # G made above
        figures = singular._bracketed_ratio(J, rows, starts, indices, products, envelope, G, factors, found[0],
                                            found[1], y, singular.LOOSE, found[2])  # fmt: skip
        assert np.array_equal(figures, expected, equal_nan=True)
        for a, b in zip(found, given, strict=True):
            assert np.array_equal(a, b)


def test_a_carried_bracket_holds_the_ratio_and_smaller_orders_neighbours_as_numpy():
    """Over small steps (the chain of MID loops swung by 0.3 degrees a time) the band carries most times' brackets
    over their step by Weyl's inequality (``singular._carried``: no eigenvalue test there), each holding numpy's SVD
    ratio; the Guard's tests decide as numpy's figures (thresholds, dips), the smallest is closed, and the order of
    two neighbours, which the carried brackets leave open, is numpy's where ``check_branches`` asks it
    (``smaller``, ``singular.Brackets``: the two closed there). Fails on the code before: no carried
    bracket, no ``Brackets``."""
    angles = np.linspace(60.0, 30.0, 101)  # away from flat: the ratio grows, each time above the smallest before
    system = build_system(load_model(loop_chain(MID)))[0]
    qs = np.array([build_system(load_model(loop_chain(MID, math.radians(a))))[1] for a in angles])
    jacobians = np.array([system.jacobian(q, 0.0) for q in qs])
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    norms = np.linalg.norm(jacobians * guard._columns, axis=-1)
    settle = ((1e-8, NEAR_SINGULAR), FALL)
    ratios, _, _, _, brackets = square_spectra(jacobians, guard._columns, norms, None, True, None, settle)
    s = np.linalg.svd(np.array([guard._scaled(J) for J in jacobians]), compute_uv=False)
    exact = s[:, -1] / s[:, 0]
    lower = brackets.lower.copy()
    carried = ratios > 1.01 * lower  # wider than any bracket of its own (LOOSE, a sharpened one)
    assert carried.sum() >= 20
    assert np.all(lower * (1.0 - 1e-12) <= exact) and np.all(exact <= ratios * (1.0 + 1e-12))
    k = int(np.argmin(exact))
    assert ratios[k] == lower[k] and ratios[k] == pytest.approx(exact[k], rel=1e-12)  # the smallest: closed
    np.testing.assert_array_equal(dips(ratios), dips(exact))
    assert np.all(ratios < NEAR_SINGULAR) and np.all(exact < NEAR_SINGULAR)
    apart = np.abs(exact[1:] - exact[:-1]) > 1e-10 * exact[1:]  # numpy's order is the exact one there
    for a in np.flatnonzero(apart):
        assert smaller(ratios, brackets, a, a + 1) == (a if exact[a] <= exact[a + 1] else a + 1)
    asked = brackets.lower == ratios  # closed where their order was asked (every pair here): numpy's figures
    assert asked[carried].all()
    np.testing.assert_allclose(ratios[asked], exact[asked], rtol=1e-12)


def test_the_compiled_drift_test_finds_numpys_first_drifted_time():
    """``singular.drifted`` (the compiled runs' drift test) names the first time numpy's test names: over the limit,
    a NaN, a zero row norm (taken as 1), exactly at the limit (within it), none at all (-1)."""
    rng = np.random.default_rng(5)
    psi, norms = rng.uniform(-1e-4, 1e-4, (12, 5)), rng.uniform(0.5, 2.0, (12, 5))
    norms[2, 1] = 0.0

    def numpy_test(psi, norms, limit):
        bad = ~(np.max(np.abs(psi) / np.where(norms > 0, norms, 1.0), axis=1, initial=0.0) <= limit)
        return int(np.argmax(bad)) if np.any(bad) else -1

    cases = [(psi, 1e-3)]
    for k, r, value in ((7, 3, 5e-3), (4, 0, np.nan), (2, 1, 2e-3), (9, 4, 1e-3 * norms[9, 4])):
        changed = psi.copy()
        changed[k, r] = value
        cases.append((changed, 1e-3))
    for case, limit in cases:
        assert singular.drifted(case, norms, limit) == numpy_test(case, norms, limit)
    assert singular.drifted(psi, norms, 1e-3) == -1 and singular.drifted(cases[1][0], norms, 1e-3) == 7


def test_the_compiled_failure_test_finds_numpys_made_and_failed_times():
    """``singular.unmade`` (``square_spectra``'s failure test of the band's pass) gives numpy's made times (the ends
    and both ends of each step not certified) and failed ones (a NaN ratio or sign anywhere, a NaN in a basis made;
    one in a basis not made is no failure)."""
    rng = np.random.default_rng(11)
    N = 9
    ratios, signs, bases = rng.uniform(0.1, 1.0, N), np.sign(rng.uniform(-1, 1, N)), rng.standard_normal((N, 5, 2))
    certified = np.array([True, True, False, True, True, True, False, True])
    ratios[3], signs[6], bases[2, 4, 1], bases[5, 0, 0] = np.nan, np.nan, np.inf, np.nan

    made = np.ones(N, dtype=bool)
    made[1:-1] = ~(certified[:-1] & certified[1:])
    failed = ~(np.isfinite(ratios) & np.isfinite(signs)) | (made & ~np.all(np.isfinite(bases), axis=(1, 2)))
    found = singular.unmade(ratios, signs, bases, certified)
    np.testing.assert_array_equal(found[0], made)
    np.testing.assert_array_equal(found[1], failed)
    assert not made[5] and failed.tolist() == [k in (2, 3, 6) for k in range(N)]


@pytest.mark.parametrize("banded", [False, True])
def test_the_quiet_test_finds_numpys_smallest_or_a_crossing(banded):
    """``Guard._smallest_if_quiet`` in one compiled pass (``singular.quiet``, a compiled run's Guard) and by numpy's
    arrays: the first time of the smallest ratio, or -1 at a flip of the sign against a turn above ALIGNED (at the
    first time against the Guard's sign too), a ratio below singular_ratio or NaN; a flip with the null space
    turned too far, or a NaN first turn, is none."""
    system, qs = chain_at([60.0])
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    guard.banded = banded
    ratios = np.array([0.3, 0.2, 0.25, 0.2, 0.4])
    signs, turns = np.ones(5), np.array([0.99, -0.98, 0.97, 0.5])
    signs[2:] = -1.0  # the turn to t_2 is negative: no flip
    assert guard._smallest_if_quiet(0.99, turns, signs, ratios) == 1
    assert guard._smallest_if_quiet(np.nan, turns, signs, ratios) == 1
    assert guard._smallest_if_quiet(-0.99, turns, signs, ratios) == -1  # flipped since the Guard's last time
    flipped = signs.copy()
    flipped[4] = 1.0
    assert guard._smallest_if_quiet(0.99, turns, flipped, ratios) == 1  # turned by 0.5: too far to tell
    assert guard._smallest_if_quiet(0.99, np.array([0.99, -0.98, 0.97, 0.99]), flipped, ratios) == -1
    for value in (1e-9, np.nan):
        low = ratios.copy()
        low[3] = value
        assert guard._smallest_if_quiet(0.99, turns, signs, low) == -1


def test_null_space_turns_reads_the_signs_at_certified_steps_and_the_bases_elsewhere():
    """``null_space_turns``: det(T_k-1^T T_k) of each step without certified steps; the signs' product
    signs[k-1] signs[k] at a certified step (every step certified: no basis read, NaN bases allowed), the
    determinant at the others."""
    rng = np.random.default_rng(5)
    tangents = np.linalg.qr(rng.standard_normal((6, 5, 2)))[0]
    signs = np.array([1.0, -1.0, -1.0, 1.0, 1.0, -1.0])
    turns = np.linalg.det(np.swapaxes(tangents[:-1], 1, 2) @ tangents[1:])
    np.testing.assert_array_equal(null_space_turns(tangents, signs), turns)
    np.testing.assert_array_equal(null_space_turns(tangents, signs, np.zeros(5, dtype=bool)), turns)
    unmade = np.full_like(tangents, np.nan)
    every = null_space_turns(unmade, signs, np.ones(5, dtype=bool))
    np.testing.assert_array_equal(every, signs[:-1] * signs[1:])
    some = np.array([True, False, True, True, False])
    mixed = null_space_turns(tangents, signs, some)
    np.testing.assert_array_equal(mixed[some], (signs[:-1] * signs[1:])[some])
    np.testing.assert_array_equal(mixed[~some], turns[~some])


def test_the_band_passes_are_compiled_at_their_first_call_under_their_signatures_alone(swing):
    """``singular``'s band route (``AT_FIRST_CALL``: its passes ``_spectra``, ``_ratios_at``, ``_settled_spectra`` and
    the functions the Guard calls from Python on a band) is not compiled at import: a small closed loop's Guard takes
    the dense route and paid for them at its first run on a new machine. Compiled under their signatures (``mbd
    compile``), a band run's calls (closed figures, and the settled tests) find that version: no other is compiled.
    (Until the twenty-ninth session ``_settled_spectra``, ``_band_start``, ``_entry_slots``, ``_reached_norms``,
    ``unmade`` and ``quiet`` had no signature ``mbd compile`` compiled: the loop chain of 8 loops compiled them at its
    first run after it.)"""
    import subprocess

    code = "from solutions.compiled import singular as s; print(*(len(vars(s)[f].signatures) for f in s.AT_FIRST_CALL))"
    imported = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert imported.stdout.split() == ["0"] * len(singular.AT_FIRST_CALL)
    for name, signature in singular.AT_FIRST_CALL.items():
        getattr(singular, name).compile(signature)
    system, t, qs, jacobians = swing
    guard = Guard(system, qs[0], 1e-3, 1e-8)
    norms = np.linalg.norm(jacobians * guard._columns, axis=-1)
    square_spectra(jacobians, guard._columns, norms, None)  # closed figures: _spectra from Python
    square_spectra(jacobians, guard._columns, norms, None, True, None, ((1e-8, NEAR_SINGULAR), FALL))  # settled
    for name in singular.AT_FIRST_CALL:
        assert len(getattr(singular, name).signatures) == 1
