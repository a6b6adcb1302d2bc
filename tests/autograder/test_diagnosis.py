"""Likely causes read from the numbers (the known mistakes replayed on the reference: test_replay)."""

from __future__ import annotations

import numpy as np

from mbdkit import diagnosis
from mbdkit.probes import RK4_SPAN, RK4_STEPS, rk4_test_exact, rk4_test_rhs

E = np.array([[1.5, -2.0, 0.0], [0.25, 3.0, -1.0]])
ALLOWED = 1e-6 * np.abs(E) + 1e-9
ALL = np.ones(E.shape, dtype=bool)


def test_causes_from_the_numbers():
    assert "sign" in diagnosis.structural(E, -E, ALL, ALLOWED)
    assert "missing term" in diagnosis.structural(E, 0 * E, ALL, ALLOWED)
    assert "degrees for radians" in diagnosis.structural(E, E * 180 / np.pi, ALL, ALLOWED)
    assert "factor 2" in diagnosis.structural(E, 2 * E, ALL, ALLOWED)
    assert "NaN" in diagnosis.structural(E, np.full_like(E, np.nan), ALL, ALLOWED)
    assert diagnosis.structural(E, E + 0.1, ALL, ALLOWED) is None
    assert diagnosis.transposed(E, E.T) and not diagnosis.transposed(np.eye(3), np.eye(3))


def _rk4(weights):
    finals = []
    for n in RK4_STEPS:
        h, y = RK4_SPAN / n, np.array([1.0, 0.0])
        for k in range(n):
            t = k * h
            k1 = rk4_test_rhs(t, y)
            k2 = rk4_test_rhs(t + h / 2, y + h / 2 * k1)
            k3 = rk4_test_rhs(t + h / 2, y + h / 2 * k2)
            k4 = rk4_test_rhs(t + h, y + h * k3)
            y = y + h * (weights[0] * k1 + weights[1] * k2 + weights[2] * k3 + weights[3] * k4)
        finals.append(y)
    return np.array(finals)


def test_rk4_order_is_measured_against_the_exact_solution():
    correct = _rk4((1 / 6, 2 / 6, 2 / 6, 1 / 6))
    assert np.allclose(correct[-1], rk4_test_exact(RK4_SPAN), atol=1e-6)
    assert diagnosis.rk4_order(correct) is None
    assert "order 1.0" in diagnosis.rk4_order(_rk4((1 / 6, 2 / 6, 1 / 6, 2 / 6)))
    assert "does not converge" in diagnosis.rk4_order(_rk4((1 / 6, 2 / 6, 2 / 6, 2 / 6)))
