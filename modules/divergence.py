# Generated from solutions/divergence.py by `make modules` (every homework stubbed): do not edit by hand.
"""How far a run's positions are off, from a second run at a looser tolerance (eqs. 6.62-6.64).

The tolerance rule (eq. 6.60) and the estimate of eq. 6.61 assume that errors grow as the phase error of a regular
motion does, with the square of the number of periods. In a chaotic motion (a double pendulum released high) two
neighbouring motions part exponentially, d(t) ~ d(0) e^(lambda t), lambda the largest Lyapunov exponent, and the
local errors of the integrator grow the same way: neither the rule nor the energy balance sees it. What does see it
is Richardson's comparison: the error of an adaptive run grows as rtol^beta, so the same run at k times the
tolerance ("the companion") errs about k^beta times as much, and the two part by about (k^beta - 1) times the error
of the run,

    e(t) ~ D(t) / (k^beta - 1),     D(t) = max over bodies |r_companion(t) - r_run(t)|   (eq. 6.62)

as long as the companion's own error stays small (D below ``SATURATION`` L). Beyond that point t_s the error is
carried on at the rate measured over the last half of the window before it:

    e(t) ~ e(t_s) e^(lambda (t - t_s)),   lambda = ln(D(t_s) / D(t_s / 2)) / (t_s / 2)    (eq. 6.63)

(a growth by more than ``EXPONENTIAL`` over half the window is no power law of a regular motion: chaotic), or, for a
regular motion, as the power law that the same two points give. Errors follow rtol^beta, so the tolerance that
holds a bound b = accuracy x L over the span T is (with a margin of 2)

    rtol' = rtol (b / (2 e(T)))^(1 / beta)                                             (eq. 6.64)

and where rtol' is below what double precision holds, no tolerance can: the run says up to which time its results
meet the bound, and how often the errors double (ln 2 / lambda).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

COMPANION = 100.0
"""k: the companion run's tolerance is k times the run's (k^(1/8) fewer steps for DOP853: it costs about 0.6 of the
run)."""
BETA = 0.75
"""beta of eqs. 6.62 and 6.64, the least measured (DOP853, joint coordinates, against rtol 1e-12): a planar double
pendulum released level errs 60 to 200 times more at 100 x rtol (1e-10 against 1e-8, 1e-8 against 1e-6: beta 0.9 to
1.15), a spatial revolute-spherical one 30 times (beta 0.74). The least beta overstates the error of the others
(never understates it), and asks for a tighter rtol than they need."""
LOOSEST = 1e-4
"""The loosest tolerance a companion is run at (k is smaller for a run at a loose rtol, at least ``SMALLEST``)."""
SMALLEST = 10.0
"""The smallest k (a run at rtol 1e-3 is compared with one at 1e-2)."""
SATURATION = 3e-2
"""D / L beyond which the companion's error is no longer small against the motion: eq. 6.62 holds below it."""
EXPONENTIAL = 30.0
"""Growth of D over the last half of its window beyond which the growth is exponential (chaotic): a regular motion's
phase error grows as t^2 (a factor of 4 over the half) and no faster than t^4 (16)."""
MARGIN = 2.0
"""The factor by which eq. 6.64 aims below the bound."""
RESOLVED = 4
"""Output times a window needs before its growth is judged; fewer, and a regular t^2 growth is assumed."""


def companion_factor(rtol: float) -> float:
    """k of eq. 6.62: ``COMPANION``, smaller where k rtol would pass ``LOOSEST``, never below ``SMALLEST``."""
    return float(max(SMALLEST, min(COMPANION, LOOSEST / rtol)))


def departure(run: np.ndarray, companion: np.ndarray) -> np.ndarray:
    """D(t) of eq. 6.62: the largest distance between the same body centre in two runs, at each output time, from
    the centres' histories (N, bodies, dimension)."""
    return np.max(np.linalg.norm(companion - run, axis=2), axis=1)


@dataclass(frozen=True)
class Divergence:
    """The estimated position error e(t) of a run at its output times (eqs. 6.62-6.63) and how it grows."""

    t: np.ndarray
    errors: np.ndarray
    """e(t) in m: measured (eq. 6.62, the running maximum) up to ``measured_until``, carried on after it (eq. 6.63)."""
    measured_until: float
    growth: float
    """D(t_s) / D(t_s / 2): how much the departure grew over the last half of its window."""
    rate: float | None
    """lambda (1/s) of eq. 6.63 where the growth is exponential (chaotic); None for a regular motion."""

    @property
    def chaotic(self) -> bool:
        return self.rate is not None

    @property
    def doubling_time(self) -> float | None:
        """ln 2 / lambda: the time in which the errors of a chaotic motion double."""
        return None if self.rate is None else float(np.log(2.0) / self.rate)

    @property
    def final(self) -> float:
        """e(T): the estimated error at the end of the span, in m (the largest: e(t) is kept monotone)."""
        return float(self.errors[-1])

    def meets_until(self, bound: float, scale: float = 1.0) -> float:
        """The last output time up to which ``scale`` e(t) (the errors of a run at another tolerance: ``scaled``)
        stays within ``bound``; the run's start where it never does."""
        over = np.nonzero(scale * self.errors > bound)[0]
        return float(self.t[-1] if not over.size else self.t[max(over[0] - 1, 0)])


def estimate(t: np.ndarray, departures: np.ndarray, size: float, factor: float) -> Divergence:
    """e(t) from the departures D(t) of a companion run at ``factor`` (k) times the tolerance (eqs. 6.62-6.63)."""
    reached = np.maximum.accumulate(departures)  # errors oscillate with the motion; their envelope grows
    floor = 1e-13 * size  # below it, D is rounding
    over = np.nonzero(reached > SATURATION * size)[0]
    s = int(over[0]) if over.size else t.size - 1  # t_s: the last time eq. 6.62 holds
    half = int(np.searchsorted(t, t[s] / 2.0))
    if s >= RESOLVED and s > half:
        growth = float(max(reached[s], floor) / max(reached[half], floor))
        rate = float(np.log(growth) / (t[s] - t[half])) if growth > EXPONENTIAL else None
        power = float(np.log(max(growth, 1.0)) / np.log(t[s] / max(t[half], t[1])))
    else:  # saturated in the first few output times: too few to judge the growth; a regular motion's law
        growth, rate, power = 1.0, None, 2.0
    errors = reached / (factor**BETA - 1.0)
    later = t[s + 1 :]
    if later.size:
        grown = np.exp(np.minimum(rate * (later - t[s]), 700.0)) if rate is not None else (later / t[s]) ** power
        errors = np.concatenate([errors[: s + 1], errors[s] * grown])
    return Divergence(t, errors, float(t[s]), growth, rate)


def needed_rtol(found: Divergence, rtol: float, bound: float) -> float:
    """rtol' of eq. 6.64: the tolerance whose run stays within ``bound`` over the span, with a margin of 2."""
    return float(rtol * (bound / (MARGIN * max(found.final, 1e-300))) ** (1.0 / BETA))


def scaled(rtol: float, other: float) -> float:
    """How many times the error of a run at rtol ``other`` is that of a run at ``rtol`` (errors grow as rtol^beta)."""
    return float((other / rtol) ** BETA)
