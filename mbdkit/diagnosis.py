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

A cause is a claim about one function of the student's code, and it must agree with the student's other
checks: ``reconcile`` takes back every cause that blames a function whose own checks all pass (the next
cause that explains the numbers, if any, is named instead). A consistent opposite sign of lambda is the
sign convention, said as such (``LAMBDA_SIGN``).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from .probes import RK4_SPAN, RK4_STEPS, rk4_test_exact

LAMBDA_CONVENTION = "the course writes M q'' + Psi_q^T lambda = Q (eq. 5.25)"
"""lambda's sign convention, fixed by the course (DESIGN section 3): the reactions follow from it."""
LAMBDA_SIGN = (
    f"your lambda has the opposite sign: {LAMBDA_CONVENTION}, so Psi_q^T lambda is minus the constraint "
    "forces; with your sign every lambda check fails (the convention is the course's, the reactions follow "
    "from it): flip the sign of lambda (or of Psi_q^T in your system matrix)"
)


def structural(
    expected: np.ndarray, got: np.ndarray, failing: np.ndarray, allowed: np.ndarray, output: str = ""
) -> str | None:
    """What the numbers alone say about the failing entries (``output`` ``lam``: lambda's sign convention)."""
    e, g, a = expected[failing], got[failing], allowed[failing]
    if e.size == 0:
        return None
    if not np.all(np.isfinite(g)):
        return "NaN or infinity: a division by zero, or a function of a value outside its domain?"
    if np.all(np.abs(g) <= a) and np.any(np.abs(e) > a):
        return "you get zero where the reference does not: a missing term (or a function still to write)"
    valid = ~np.isnan(expected)
    if output == "lam" and np.all(np.abs(got + expected)[valid] <= allowed[valid]):  # every entry, not the failing
        return LAMBDA_SIGN
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


def likely_causes(
    probe: str,
    output: str,
    expected: np.ndarray,
    got: np.ndarray,
    failing: np.ndarray,
    allowed: np.ndarray,
    mistakes: list[tuple[str, np.ndarray]] = (),
    select: Callable[[np.ndarray], np.ndarray] = lambda x: x,
) -> list[str]:
    """Every cause that explains a failure, the most likely first (``reconcile`` keeps the first that
    agrees with the student's other checks).

    ``mistakes`` are (cause, output of the reference making that mistake), ``select`` applies the
    check's row filter to them."""
    found = []
    if probe == "rk4" and output == "y":
        found += [c for c in [rk4_order(got)] if c]
    # a replayed mistake names the formula; "minus the expected value" may be only what it looks like
    # (B^T s' is -B s' in one component for a point on the body's x axis)
    if np.all(np.isfinite(got[failing])):
        valid = ~np.isnan(expected)
        for cause, output_of_mistake in mistakes:
            candidate = select(np.asarray(output_of_mistake, dtype=float))
            if candidate.shape != got.shape:
                continue
            if explains(candidate, expected, got, failing, allowed, valid):
                found.append(cause)
    found += [c for c in [structural(expected, got, failing, allowed, output)] if c]
    return list(dict.fromkeys(found))


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
    """The most likely cause of a failure, or None (the first of ``likely_causes``)."""
    found = likely_causes(probe, output, expected, got, failing, allowed, mistakes, select)
    return found[0] if found else None


MODEL_ERRORS = ("AnalysisError", "SingularConfigurationError", "ModelError", "StiffnessError", "BudgetError")
"""The solver's own refusals: their texts give advice on the model file (remove a joint, add a motor), which
on a grading scene (the course's, solved by the reference as it is) points the wrong way."""


def not_the_model(kind: str) -> str:
    """What to add to a refusal of the student's solver (``MODEL_ERRORS``): the cause is in their code."""
    if kind not in MODEL_ERRORS:
        return ""
    return (
        ". This scene is the course's and the reference solves it as it is: the model is not the problem, "
        "your functions are (a wrong Psi_q or gamma makes a sound model look redundant, locked or stiff; "
        "their own checks say which)"
    )


# -- causes that agree with the student's other checks ----------------------------------------------------
BLAMES: list[tuple[str, tuple[str, ...], str | None]] = [
    (r"B\(phi\)\^T in d_ij'", ("gamma",), None),
    (r"B\(phi\)\^T used where B\(phi\)", ("jacobian",), None),
    (r"A\(phi\)\^T used where A\(phi\)", ("constraints",), None),
    (r"the angle converted as if it were in degrees", ("constraints",), None),
    (r"quadratic-velocity term|phi' where phi'\^2", ("gamma",), None),
    (r"Baumgarte's term|Baumgarte term", ("baumgarte_gamma",), None),
    (r"gamma with the wrong sign in (\w+)\.gamma", ("gamma",), "element"),
    (r"Psi_t with the wrong sign in (\w+)\.psi_t", ("psi_t",), "element"),
    (r"A\(p\)\^T used where A\(p\)", ("rotation_matrices",), None),
    (r"G\(p\) used where L\(p\)|L\(p\) used where G\(p\)", ("rotation_matrices",), None),
    (r"Q_v = 8 L\(p'\)\^T J' L\(p'\) p is missing", ("quadratic_velocity",), None),
]
"""A known mistake's cause -> the probes whose checks test the function it blames (and, for one joint
class's method, that the checks' rows are narrowed to the class named in the cause)."""


@dataclass(frozen=True)
class Tested:
    """One check of a student as ``reconcile`` sees it: what it tests and whether it passed."""

    probe: str
    rows: tuple[str, ...]
    passed: bool


def blamed(cause: str) -> tuple[tuple[str, ...], str | None] | None:
    """(probes that test the function a cause blames, the element class it names or None), or None when
    the cause blames no function of its own (the numbers themselves: zero, minus, a factor)."""
    for pattern, probes, element in BLAMES:
        match = re.search(pattern, cause)
        if match:
            return probes, (match.group(1) if element else None)
    return None


def _covers(rows: tuple[str, ...], element: str) -> bool:
    """Whether a check narrowed to ``rows`` (joint types, e.g. revolute) tests the element class ``element``
    (e.g. Revolute) by name; a check of every row, or of rows named otherwise, is not known to."""
    return any(row.replace("_", "") == element.lower() for row in rows)


def consistent(cause: str, checks: Iterable[Tested]) -> bool:
    """A cause agrees with the student's checks unless every check of the function it blames passes."""
    found = blamed(cause)
    if found is None:
        return True
    probes, element = found
    own = [c for c in checks if c.probe in probes]
    named = [c for c in own if element is not None and _covers(c.rows, element)]
    own = named or own  # a class the rows do not name (Distance for revolute_revolute): every check of the probe
    return not own or not all(c.passed for c in own)


def reconcile(message: str, candidates: list[list[str]], checks: Iterable[Tested]) -> str:
    """``message`` with each of its likely causes (``candidates``: per cause in the message, the causes that
    explain those numbers, the named one first) replaced by the first that agrees with the student's other
    checks, or taken out when none does."""
    checks = list(checks)
    for causes in candidates:
        if not causes or consistent(causes[0], checks):
            continue
        fitting = [c for c in causes[1:] if consistent(c, checks)]
        replacement = f". Likely cause: {fitting[0]}" if fitting else ""
        message = message.replace(f". Likely cause: {causes[0]}", replacement, 1)
    return message
