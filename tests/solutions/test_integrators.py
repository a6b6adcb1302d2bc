"""The package's own DOP853 loop (``integrators.integrate``, method "dop853") against closed forms and itself."""

from __future__ import annotations

import numpy as np
import pytest

from solutions import integrators

TIMES = np.linspace(0.0, 6.0, 25)  # output times between the steps: every step past one makes a dense output


def oscillator(t: float, y: np.ndarray) -> np.ndarray:
    """y = (q, q') of two uncoupled oscillators q'' = -w^2 q (w = 1 and 2) and a clock z' = 1 after them."""
    return np.array([y[2], y[3], -y[0], -4.0 * y[1], 1.0])


def run(**options) -> tuple[np.ndarray, int, int]:
    """The recorded states, the evaluations the integrator counted (f also counted here) and the dense outputs."""
    calls, dense = [], []

    class Counted(integrators.DenseOutput):
        def __init__(self, *args):
            dense.append(1)
            super().__init__(*args)

    out = np.empty((TIMES.size, 5))

    def f(t, y):
        calls.append(t)
        return oscillator(t, y)

    def record(k, t, y):
        out[k] = y

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(integrators, "DenseOutput", Counted)
        stats = integrators.integrate(f, np.array([1.0, 0.5, 0.0, 0.0, 0.0]), TIMES, record, method="dop853",
                                      rtol=1e-8, atol=1e-10, **options)  # fmt: skip
    assert stats.rhs_evaluations == len(calls)  # the budget's count is every evaluation of f
    return out, stats.rhs_evaluations, len(dense)


@pytest.fixture(scope="module")
def runs():
    return run(), run(positions=2)


def test_dop853_follows_the_closed_form(runs):
    (out, _, _), _ = runs
    assert np.allclose(out[:, 0], np.cos(TIMES), rtol=0.0, atol=1e-7)
    assert np.allclose(out[:, 1], 0.5 * np.cos(2.0 * TIMES), rtol=0.0, atol=1e-7)
    assert np.allclose(out[:, 4], TIMES, rtol=0.0, atol=1e-12)


def test_a_dense_output_of_positions_alone_gives_the_same_positions_for_one_evaluation_less(runs):
    """``positions`` = n: q at the output times to the last bit, one evaluation of f fewer per step that passed an
    output time (the last extra stage of DOP853's interpolant), and the rest of the interpolated state NaN."""
    (full, full_evaluations, dense), (lean, lean_evaluations, lean_dense) = runs
    interpolated = ~np.isin(TIMES, [0.0, TIMES[-1]])  # the first and the last output are states, not interpolants
    assert np.array_equal(lean[:, :2], full[:, :2])
    assert np.isnan(lean[interpolated, 2:]).all() and np.array_equal(lean[~interpolated], full[~interpolated])
    assert lean_dense == dense > 10 and full_evaluations - lean_evaluations == dense
