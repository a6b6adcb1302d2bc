"""The Guard's screen of the steps next to a singular position for a branch switch, compiled (issue 25).

``guard.Guard.check_branches`` judges every step of a run whose ratio sigma_r / sigma_1 is below NEAR_SINGULAR
(``guard.branch_verdict``: did the velocities change by more than the accelerations explain?). A long chain of
loops is below NEAR_SINGULAR at every ordinary position, so every one of its steps is screened first by
``guard.possible_switches``: whole-array numpy over the steps (a dozen array operations on 100 steps, 0.12 ms of
a loop chain's 3 ms call). ``possible_switches`` here is the same screen in one pass over the steps, for the
compiled runs (which import numba anyway): per body, every velocity coordinate a speed (``gyration_weights``),

    mismatch = |q'_j - q'_i - h (q''_i + q''_j) / 2|,   allowance = h max(|q''_i|, |q''_j|),   speed V,

and a step is a possible switch where max over the bodies of (mismatch - allowance) exceeds BRANCH_JUMP / 2 times
the fastest body's speed (the screen's margin, far above rounding: ``branch_verdict`` judges each one it lets
through, and calls the others kept).

This module imports numba: it is imported only when the compiled engine runs. Its loop is compiled at import (or
loaded from disk), with the integrator loops by ``mbd compile``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types

_vector, _ivector, _matrix = types.float64[::1], types.int64[::1], types.float64[:, ::1]


@njit(cache=True, nogil=True)
def _sample_norms(weights, qd, qdd, steps):
    """(speeds, rates) (samples, bodies): each body's |weights q'| and |weights q''| at the ends of the steps in
    ``steps``, each sample once, summed coordinate by coordinate as the mismatch is (the other rows unset)."""
    bodies, per = weights.shape
    ends = np.zeros(qd.shape[0], dtype=np.bool_)
    for a in range(steps.size):
        ends[steps[a]] = ends[steps[a] + 1] = True
    speeds, rates = np.empty((qd.shape[0], bodies)), np.empty((qd.shape[0], bodies))
    for i in np.flatnonzero(ends):
        for b in range(bodies):
            speed, rate = 0.0, 0.0
            for s in range(per):
                c, w = b * per + s, weights[b, s]
                rate += (qdd[i, c] * w) ** 2
                speed += (qd[i, c] * w) ** 2
            speeds[i, b], rates[i, b] = math.sqrt(speed), math.sqrt(rate)
    return speeds, rates


@njit(types.boolean[::1](_matrix, _vector, _matrix, _matrix, _ivector, types.float64), cache=True, nogil=True)
def possible_switches(weights, t, qd, qdd, steps, margin):
    """Which steps from sample k to k + 1 (k in ``steps``) ``guard.branch_verdict`` could call 'switched': the
    largest mismatch of a body over the step beyond its allowance exceeds ``margin`` (BRANCH_JUMP / 2) times the
    fastest body's speed (module docstring); ``weights`` (bodies, per): ``gyration_weights``. Each sample's speeds
    and rates |q''| are made once (``_sample_norms``), where a step shares its ends with its neighbours."""
    bodies, per = weights.shape
    speeds, rates = _sample_norms(weights, qd, qdd, steps)
    possible = np.zeros(steps.size, dtype=np.bool_)
    for a in range(steps.size):
        i = steps[a]
        j = i + 1
        h = t[j] - t[i]
        worst, fastest, unknown = -np.inf, 0.0, False
        for b in range(bodies):
            mismatch = 0.0
            for s in range(per):
                c, w = b * per + s, weights[b, s]
                value = (qd[j, c] - qd[i, c] - 0.5 * h * (qdd[i, c] + qdd[j, c])) * w
                mismatch += value * value
            allowance = h * max(rates[i, b], rates[j, b])
            beyond, speed = math.sqrt(mismatch) - allowance, max(speeds[i, b], speeds[j, b])
            unknown = unknown or math.isnan(beyond) or math.isnan(speed)  # numpy's max keeps a NaN: no switch seen
            worst, fastest = max(worst, beyond), max(fastest, speed)
        possible[a] = not unknown and worst > margin * fastest
    return possible


@njit(types.UniTuple(_ivector, 4)(_vector, _vector, _vector, types.float64, types.float64, types.float64), cache=True,
      nogil=True)  # fmt: skip
def screen(ratios, signs, turns, near, fall, aligned):
    """``guard.branch_screen`` in one pass over the output times (a compiled run's): (the times k where the ratio
    dips, ``diagnostics.passes_zero``; the times k whose step from k - 1 flips the sign of det [Psi_q; T^T] against
    a turn above ``aligned``, none where ``signs`` is empty; the steps k (to k + 1) over which the ratio falls or
    rises by more than 1 / ``fall`` below ``near``; the steps k with a ratio below ``near`` at either end). The same
    tests as numpy's arrays make, a NaN failing each test as there (np.minimum and np.maximum keep a NaN)."""
    N = ratios.size
    size = max(N - 1, 0)
    dipped, flipped, fallen, close = (np.empty(size, dtype=np.int64), np.empty(size, dtype=np.int64),
                                      np.empty(size, dtype=np.int64), np.empty(size, dtype=np.int64))  # fmt: skip
    counts = np.zeros(4, dtype=np.int64)
    for k in range(1, N - 1):
        before, middle, after = ratios[k - 1], ratios[k], ratios[k + 1]
        lowest = not (math.isnan(before) or math.isnan(after)) and middle <= before and middle <= after
        up, down = before - middle, after - middle
        deep = not (math.isnan(up) or math.isnan(down)) and middle < max(up, down)
        if middle < near and lowest and deep:
            dipped[counts[0]] = k
            counts[0] += 1
    for k in range(1, N if signs.size else 0):
        turn = turns[k - 1]
        if abs(turn) > aligned and turn * signs[k] * signs[k - 1] < 0:
            flipped[counts[1]] = k
            counts[1] += 1
    for k in range(N - 1):
        a, b = ratios[k], ratios[k + 1]
        if not (math.isnan(a) or math.isnan(b)) and min(a, b) < near and min(a, b) < fall * max(a, b):
            fallen[counts[2]] = k
            counts[2] += 1
        if a < near or b < near:
            close[counts[3]] = k
            counts[3] += 1
    return dipped[: counts[0]], flipped[: counts[1]], fallen[: counts[2]], close[: counts[3]]


@njit(types.int64(_vector, types.float64), cache=True, nogil=True)
def first_dip(ratios, near):
    """The first output time k whose ratio dips (``diagnostics.passes_zero`` of ratios[k - 1], ratios[k], ratios[k +
    1], ``near``: NEAR_SINGULAR), or -1: ``guard.singular_dip`` in one pass. Python's min and max as passes_zero
    takes them (the first argument kept unless the second is smaller, larger), so a NaN next to the minimum decides
    as there: one after it leaves the other neighbour, one before it no dip."""
    for k in range(1, ratios.size - 1):
        before, middle, after = ratios[k - 1], ratios[k], ratios[k + 1]
        lowest = after if after < before else before  # min(before, after)
        up, down = before - middle, after - middle
        deepest = down if down > up else up  # max(before - middle, after - middle)
        if middle < near and middle <= lowest and middle < deepest:
            return k
    return -1
