"""The Guard's screen of the steps next to a singular position for a branch switch, compiled (issue 25).

``dynamics.Guard.check_branches`` judges every step of a run whose ratio sigma_r / sigma_1 is below NEAR_SINGULAR
(``dynamics.branch_verdict``: did the velocities change by more than the accelerations explain?). A long chain of
loops is below NEAR_SINGULAR at every ordinary position, so every one of its steps is screened first by
``dynamics.possible_switches``: whole-array numpy over the steps (a dozen array operations on 100 steps, 0.12 ms of
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


@njit(types.boolean[::1](_matrix, _vector, _matrix, _matrix, _ivector, types.float64), cache=True, nogil=True)
def possible_switches(weights, t, qd, qdd, steps, margin):
    """Which steps from sample k to k + 1 (k in ``steps``) ``dynamics.branch_verdict`` could call 'switched': the
    largest mismatch of a body over the step beyond its allowance exceeds ``margin`` (BRANCH_JUMP / 2) times the
    fastest body's speed (module docstring); ``weights`` (bodies, per): ``gyration_weights``."""
    bodies, per = weights.shape
    possible = np.zeros(steps.size, dtype=np.bool_)
    for a in range(steps.size):
        i = steps[a]
        j = i + 1
        h = t[j] - t[i]
        worst, fastest, unknown = -np.inf, 0.0, False
        for b in range(bodies):
            mismatch, rate_i, rate_j, speed_i, speed_j = 0.0, 0.0, 0.0, 0.0, 0.0
            for s in range(per):
                c, w = b * per + s, weights[b, s]
                value = (qd[j, c] - qd[i, c] - 0.5 * h * (qdd[i, c] + qdd[j, c])) * w
                mismatch += value * value
                rate_i += (qdd[i, c] * w) ** 2
                rate_j += (qdd[j, c] * w) ** 2
                speed_i += (qd[i, c] * w) ** 2
                speed_j += (qd[j, c] * w) ** 2
            allowance = h * max(math.sqrt(rate_i), math.sqrt(rate_j))
            beyond, speed = math.sqrt(mismatch) - allowance, max(math.sqrt(speed_i), math.sqrt(speed_j))
            unknown = unknown or math.isnan(beyond) or math.isnan(speed)  # numpy's max keeps a NaN: no switch seen
            worst, fastest = max(worst, beyond), max(fastest, speed)
        possible[a] = not unknown and worst > margin * fastest
    return possible
