"""What a hidden or per-student check tells anyone: the grader's own words, from a fixed vocabulary.

A hidden scene (a variant the student never sees) and a student's own variant (made from the instructor's
secret) are data the student's code is given in its sandbox. Whatever that code returns, prints, raises,
names or takes time over could carry them out through a message: an exception's text or class name, a
function's name in a stack line, the row, the relative error or the count of wrong values of a comparison.
So the message of such a check is chosen by the grader alone from

- its **status**: passed, failed, timed out, crashed or could not run (``STATUSES``);
- its **description**: the check's ``description`` in the homework file, else the scene's title and the
  quantities compared (both the grader's);
- a **hint** from a fixed list: the reason of the status (``REASONS``) and what the check's public twin (the
  same probe and outputs on a public scene, run in the public child before) says (``TWIN``).

Nothing else of the reply reaches it: no text, name, number, row, position, count or timing of the student's
code. ``vocabulary`` lists every message a check can get (tests hold the grader's outputs to it).
"""

from __future__ import annotations

from .checks import QUANTITIES, Outcome
from .homework import CheckSpec
from .sandbox import Limits, Reply
from .scenes import HIDDEN, PUBLIC, STUDENT, scene_kind
from .stored import Reference

PASSED, FAILED, TIMED_OUT, CRASHED, NOT_RUN = "passed", "failed", "timed out", "crashed", "could not run"
STATUSES = (PASSED, FAILED, TIMED_OUT, CRASHED, NOT_RUN)

REASONS = {
    FAILED: "your code returned values that differ from the reference's",
    TIMED_OUT: "your code did not finish in time (an endless loop?), or was skipped after it did not finish in an "
    "earlier check",
    CRASHED: "your code raised an exception, or its process ended",
    "not implemented": "not implemented yet",
    "printed": "your code printed more than the grader keeps: remove prints from functions called in loops",
    "budget": "your submission used up its time budget before this check started",
    "no package": "no package modules/ (with __init__.py) in the submission",
    "grader": "the grader could not run this check (its configuration, not your code); ask the instructor",
}
"""The reason of each status (could not run has several), in the grader's words."""

TWIN = {
    PASSED: "it passes on the public scene ({twin}): does your code hold something true only of that scene "
    "(a number, a dimension, a mass, a direction, a joint or force it lacks)?",
    FAILED: "it does not pass on the public scene ({twin}) either: that check's message says more",
}
"""What the check's public twin says, by the twin's outcome."""


def title(scene: str) -> str:
    """How a scene is named in a message."""
    kind = scene_kind(scene)
    if kind == STUDENT:
        return f"{scene.split('/', 1)[1]} (your own variant)"
    if kind == HIDDEN:
        return f"{scene} (hidden scene)"
    return scene


def description(check: CheckSpec) -> str:
    """The check's public description: from the homework file, else the scene and the quantities compared."""
    if check.description:
        return f"{title(check.scene)}: {check.description}"
    quantities = ", ".join(QUANTITIES.get(f"{check.probe}.{output}", output) for output in check.outputs)
    rows = f" (rows of the {', '.join(check.rows)} elements)" if check.rows else ""
    return f"{title(check.scene)}: {quantities}{rows}"


def twin(check: CheckSpec, checks: list[CheckSpec]) -> CheckSpec | None:
    """The public check of the same probe, outputs and rows, on the scene the variant is made from if there
    is one (the public scene whose name starts the variant's), else on any public scene; None if none."""
    same = [
        c
        for c in checks
        if c.kind == PUBLIC and c.probe == check.probe and c.outputs == check.outputs and c.rows == check.rows
    ]
    base = check.scene.split("/", 1)[-1]
    related = [c for c in same if base == c.scene or base.startswith(c.scene + "_")]
    return max(related, key=lambda c: len(c.scene)) if related else (same[0] if same else None)


def status(check: CheckSpec, reply: Reply, reference: Reference, passed: bool, limits: Limits) -> tuple[str, str]:
    """(status, reason) of a check whose probe replied ``reply``: decided from the reply's kind alone."""
    if passed:
        return PASSED, PASSED
    if reply.status in ("timeout", "cpu"):
        return TIMED_OUT, TIMED_OUT
    if reply.status != "ok" and reply.status != "error":
        return CRASHED, CRASHED
    errors = [reply.error] if reply.status == "error" else _element_errors(check, reply, reference)
    errors = [error if isinstance(error, dict) else {} for error in errors]
    if any(error.get("type") == "OSError" and error.get("code") == 27 for error in errors):
        return FAILED, "printed"  # the capture file's size limit (RLIMIT_FSIZE) reached
    kinds = {error.get("type") for error in errors}
    if "HungEarlier" in kinds:
        return TIMED_OUT, TIMED_OUT
    if kinds and kinds <= {"NotImplementedError"}:
        return NOT_RUN, "not implemented"
    if errors:
        return CRASHED, CRASHED
    if isinstance(reply.printed, int) and reply.printed > limits.output:
        return FAILED, "printed"
    return FAILED, FAILED


def _element_errors(check: CheckSpec, reply: Reply, reference: Reference) -> list:
    """The errors of the elements whose rows the check compares."""
    meta = reference.meta
    owners = {
        owner
        for owner, kind in zip(meta.get("row_owners", []), meta.get("row_kinds", []), strict=False)
        if not check.rows or kind in check.rows
    }
    return [e for e in reply.element_errors if isinstance(e, dict) and e.get("element") in owners]


def message(check: CheckSpec, state: str, reason: str, twin_outcome: Outcome | None) -> str:
    """The whole message of a hidden or per-student check."""
    if state == PASSED:
        return PASSED
    text = f"{description(check)}: {state}: {REASONS[reason]}"
    if twin_outcome is not None:
        text += "; " + TWIN[PASSED if twin_outcome.passed else FAILED].format(twin=twin_outcome.name)
    return text


def outcome(check: CheckSpec, state: str, reason: str, twin_outcome: Outcome | None = None) -> Outcome:
    """The outcome of a hidden or per-student check: points for passing, the grader's words, no plot."""
    passed = state == PASSED
    return Outcome(
        check.name,
        check.group,
        check.scene,
        check.kind,
        check.points if passed else 0.0,
        check.points,
        passed,
        message(check, state, reason, twin_outcome),
        check.visibility,
    )


def vocabulary(check: CheckSpec, checks: list[CheckSpec]) -> set[str]:
    """Every message the check can get (its public twin among ``checks`` passing or not)."""
    public = twin(check, checks)
    names = [None] if public is None else [None, public.name]
    said = {PASSED}
    for name in names:
        for passed in (True, False):
            other = None if name is None else Outcome(name, "", "", PUBLIC, 0.0, 0.0, passed, "", "visible")
            for reason in REASONS:
                state = {TIMED_OUT: TIMED_OUT, CRASHED: CRASHED, FAILED: FAILED, "printed": FAILED}.get(reason, NOT_RUN)
                said.add(message(check, state, reason, other))
    return said
