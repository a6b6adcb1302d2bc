"""Likely causes of a failed check: what a wrong result looks like when it comes from a known mistake.

Two kinds of evidence, tried in order on the entries that fail:

1. **The numbers themselves**: zero where the reference is not (a missing term, or a stub), minus the
   reference (a sign), the reference times 180/pi (degrees for radians), twice or half of it, the
   matrix transposed.
2. **Known mistakes**: what the reference package gives when one function is changed the way students
   get it wrong -- B(phi)^T for B(phi) (a transposed block), the quadratic-velocity terms of gamma
   dropped, Baumgarte's terms dropped or with the wrong sign, one joint's gamma negated -- and when that
   reproduces the student's numbers, that is the likely cause. Those outputs are stored with the expected
   values (``Reference.replays``; the instructor's ``autograder.replay`` makes them), so no reference code
   runs here.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .probes import RK4_SPAN, RK4_STEPS, rk4_test_exact


def structural(expected: np.ndarray, got: np.ndarray, failing: np.ndarray, allowed: np.ndarray) -> str | None:
    """What the numbers alone say about the failing entries."""
    e, g, a = expected[failing], got[failing], allowed[failing]
    if e.size == 0:
        return None
    if not np.all(np.isfinite(g)):
        return "NaN or infinity: a division by zero, or a function of a value outside its domain?"
    if np.all(np.abs(g) <= a) and np.any(np.abs(e) > a):
        return "you get zero where the reference does not: a missing term (or a function still to write)"
    if np.all(np.abs(g + e) <= a):
        return "a sign error: you get minus the expected value"
    big = np.abs(e) > 10 * a
    if np.any(big):
        ratio = g[big] / e[big]
        for factor, text in (
            (180 / np.pi, "degrees for radians: you get the expected value times 180/pi"),
            (np.pi / 180, "radians for degrees: you get the expected value times pi/180"),
            (2.0, "a factor 2: you get twice the expected value"),
            (0.5, "a factor 1/2: you get half the expected value"),
        ):
            if np.all(np.abs(ratio - factor) <= 1e-6 * factor + 1e-9):
                return text
    return None


def transposed(expected: np.ndarray, got: np.ndarray, rtol: float = 1e-6) -> bool:
    """Whether ``got`` is ``expected`` with its last two axes swapped (and that is not the same thing)."""
    if expected.ndim < 2:
        return False
    swapped = np.swapaxes(expected, -1, -2)
    atol = rtol * max(1.0, float(np.max(np.abs(expected), initial=0.0)))
    if got.shape != swapped.shape or (swapped.shape == expected.shape and np.allclose(swapped, expected, rtol, atol)):
        return False
    return bool(np.allclose(got, swapped, rtol=rtol, atol=atol))


def rk4_order(got: np.ndarray) -> str | None:
    """The order of convergence a student's rk4_step shows on the test ODE (it should be 4)."""
    exact = rk4_test_exact(RK4_SPAN)
    errors = np.linalg.norm(got - exact, axis=1)
    if not np.all(np.isfinite(errors)):
        return None
    if errors[-1] >= 0.5 * errors[-2]:
        return (
            "your rk4_step does not converge as the step shrinks: the stage weights should be "
            "1/6, 2/6, 2/6, 1/6 (they must sum to 1)"
        )
    order = float(np.log2(errors[-2] / errors[-1]))
    if order < 3.5:
        return (
            f"your rk4_step converges with order {order:.1f}, not 4 (errors {errors[-2]:.2g} and {errors[-1]:.2g} "
            f"for {RK4_STEPS[-2]} and {RK4_STEPS[-1]} steps): a stage weight (1/6, 2/6, 2/6, 1/6) or a stage "
            "time (t + h/2, t + h) is wrong"
        )
    return None


COVERAGE = 0.25
"""A mistake explains a failure when the student's numbers are the mistake's wherever they fail, and fail
in at least this part of the entries the mistake changes (B^T for B in one body's block of the revolute
joints: about half of what a global B^T changes; one flipped sign in L(p): one of the six entries in
which G(p) differs from L(p))."""


def explains(
    candidate: np.ndarray,
    expected: np.ndarray,
    got: np.ndarray,
    failing: np.ndarray,
    allowed: np.ndarray,
    valid: np.ndarray,
) -> bool:
    """Whether the output of a known mistake (``candidate``) explains the student's numbers ``got``.

    Matching only where the student fails is not enough: one flipped sign in L(p) fails in one entry,
    where G(p) happens to agree, but G differs from L in half of them; "G(p) used for L(p)" would be a
    wrong diagnosis. The student's numbers must be the mistake's wherever they fail, and the failures must
    cover a good part (COVERAGE) of what the mistake changes; a mistake made in one place of two (B^T for
    B in one body's block of a joint) still shows.
    """
    if not np.all(np.abs(candidate[failing] - got[failing]) <= allowed[failing]):
        return False
    changed = valid & (np.abs(candidate - expected) > allowed)
    return bool(changed.any()) and np.sum(failing & changed) >= COVERAGE * np.sum(changed)


def likely_cause(
    probe: str,
    output: str,
    expected: np.ndarray,
    got: np.ndarray,
    failing: np.ndarray,
    allowed: np.ndarray,
    mistakes: list[tuple[str, np.ndarray]] = (),
    select: Callable[[np.ndarray], np.ndarray] = lambda x: x,
) -> str | None:
    """The most likely cause of a failure, or None.

    ``mistakes`` are (cause, output of the reference making that mistake), ``select`` applies the
    check's row filter to them."""
    if probe == "rk4" and output == "y":
        found = rk4_order(got)
        if found:
            return found
    # a replayed mistake names the formula; "minus the expected value" may be only what it looks like
    # (B^T s' is -B s' in one component for a point on the body's x axis)
    if not np.all(np.isfinite(got[failing])):
        return structural(expected, got, failing, allowed)
    valid = ~np.isnan(expected)
    for cause, output_of_mistake in mistakes:
        candidate = select(np.asarray(output_of_mistake, dtype=float))
        if candidate.shape != got.shape:
            continue
        if explains(candidate, expected, got, failing, allowed, valid):
            return cause
    return structural(expected, got, failing, allowed)
