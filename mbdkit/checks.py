"""Evaluate one check: compare what the student's package returned with the reference, and say why.

A failed check's message names the scene, the quantity, where it differs most (state, constraint row,
coordinate, time), expected against got, and the likely cause when it can tell (``diagnosis``). For a
hidden scene the numbers are left out: only the quantity, where, the relative error and the cause.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from . import diagnosis
from .homework import CheckSpec
from .probes import AXES, LOOP_TIMES, RK4_STEPS, SliderCrankLoop, reaction_labels
from .sandbox import Limits, Reply
from .scenes import HIDDEN
from .stored import Reference

Mistakes = Callable[[str], list[tuple[str, np.ndarray]]]
"""output -> [(cause, that output when the reference makes the mistake)]: the evidence of a likely cause."""
Measure = Callable[[dict], dict | str]
"""A run's outputs -> its invariants (drift, velocity_drift, energy), or why they cannot be measured."""

LAMBDA_SIGN_NOTE = "sign: M q'' + Psi_q^T lambda = Q"
"""Where lambda is checked, its sign convention (``diagnosis.LAMBDA_CONVENTION``): fixed by the course."""

DEFAULT_RTOL = 1e-6
DEFAULT_ATOL = 1e-8
"""Function and kinematic checks: |got - expected| <= rtol |expected| + atol * scale of the quantity."""

QUANTITIES = {
    "constraints.psi": "Psi (the constraint equations)",
    "jacobian.jacobian": "Psi_q (the Jacobian)",
    "psi_t.psi_t": "Psi_t",
    "gamma.gamma": "gamma (right side of the acceleration equation)",
    "newton.q": "the positions newton_raphson converges to",
    "velocity.qd": "the velocities of velocity_analysis",
    "acceleration.qdd": "the accelerations of acceleration_analysis",
    "loop_newton.q": "the positions newton_raphson converges to on the slider-crank given by its loop closure",
    "loop_velocity.qd": "the velocities of velocity_analysis on the slider-crank given by its loop closure",
    "loop_acceleration.qdd": "the accelerations of acceleration_analysis on the slider-crank given by its loop closure",
    "kinematic_run.q": "the positions of kinematic_analysis",
    "kinematic_run.qd": "the velocities of kinematic_analysis",
    "kinematic_run.qdd": "the accelerations of kinematic_analysis",
    "mass_matrix.M": "the mass matrix M",
    "generalized_forces.Q": "the generalized forces Q",
    "baumgarte_gamma.gamma_bar": "Baumgarte's gamma_bar",
    "augmented_accelerations.qdd": "q'' of augmented_accelerations",
    "augmented_accelerations.lam": f"lambda of augmented_accelerations ({LAMBDA_SIGN_NOTE})",
    "accelerations.qdd": "the accelerations q'' of the formulation",
    "accelerations.lam": f"the multipliers lambda of the formulation ({LAMBDA_SIGN_NOTE})",
    "rk4.y": "the result of rk4_step on y'' + y = sin 2t",
    "rotation_matrices.A": "the rotation matrix A(p)",
    "rotation_matrices.G": "G(p)",
    "rotation_matrices.L": "L(p)",
    "spatial_mass_matrix.M": "the spatial mass matrix M(q)",
    "quadratic_velocity.Qv": "the quadratic-velocity force Q_v",
    "reactions.reactions": "the joint reactions",
    "inverse_dynamics.lam": f"the multipliers lambda of inverse dynamics ({LAMBDA_SIGN_NOTE})",
    "dynamic_run.q": "the positions of forward_dynamics",
    "dynamic_run.qd": "the velocities of forward_dynamics",
    "dynamic_run.drift": "the constraint drift max |Psi| of forward_dynamics",
    "dynamic_run.velocity_drift": "the velocity constraint drift max |Psi_q q' + Psi_t| of forward_dynamics",
    "dynamic_run.energy": "the energy error max |E(t) - E(0)| of forward_dynamics",
}
INVARIANTS = ("drift", "velocity_drift", "energy")
"""Run outputs computed by the grader from the student's trajectory, compared with a bound."""
RUN_HINTS = {
    "q": "the positions differ: the function checks of Psi and newton_raphson tell which part is wrong",
    "qd": "the positions agree but the velocities do not: look at Psi_t and velocity_analysis",
    "qdd": "the positions and velocities agree but the accelerations do not: look at gamma and acceleration_analysis",
}


@dataclass
class Outcome:
    """The result of one check for one student."""

    name: str
    group: str
    scene: str
    kind: str
    points: float
    max_points: float
    passed: bool
    message: str
    visibility: str
    plot: dict | None = field(default=None, repr=False)
    causes: list[list[str]] = field(default_factory=list, repr=False)
    """Per likely cause in ``message``: every cause that explains those numbers, the named one first
    (``diagnosis.reconcile`` keeps one that agrees with the student's other checks)."""

    def to_test(self) -> dict:
        """The check as a Gradescope test result."""
        return {
            "name": self.name,
            "score": self.points,
            "max_score": self.max_points,
            "status": "passed" if self.passed else "failed",
            "output": self.message,
            "visibility": self.visibility,
            "extra_data": {"group": self.group, "scene": self.scene, "kind": self.kind},
        }


def _size(nbytes: int) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if nbytes < 1024 or unit == "GB":
            return f"{nbytes:.0f} {unit}" if unit == "B" else f"{nbytes:.1f} {unit}"
        nbytes /= 1024
    return ""


def failure_of_reply(reply: Reply, limits: Limits, hidden: bool) -> str | None:
    """What went wrong when the student's code did not return (or printed too much); None if fine."""
    if reply.status == "timeout":
        where = f"; it was stuck in {reply.stuck_in}" if reply.stuck_in else ""
        if reply.error and reply.error.get("message"):  # the grader's words: a reply begun and not finished
            return f"the sandbox child did not finish its reply within the time limit: {reply.error['message']}{where}"
        return f"your code did not finish within the time limit (an endless loop?){where}"
    if reply.status == "malformed":  # the grader's words (``sandbox.MALFORMED``), never the child's
        return (reply.error or {}).get("message") or "the sandbox child sent a malformed reply"
    if reply.status in ("cpu", "died"):
        error = reply.error or {}
        where = f" in {error['where']}" if error.get("where") else ""
        during = f", while the grader ran {error['during']}" if error.get("during") else ""
        return f"{error.get('message') or 'the process died'}{where}{during}"
    if reply.status == "error":
        error = reply.error or {}
        kind, message, where = error.get("type", "Error"), error.get("message", ""), error.get("where", "")
        at = f" ({where})" if where else ""
        said = f": {message}" if message else ""
        if kind == "NotImplementedError":
            return f"not implemented yet{said}{at}"
        if kind == "HungEarlier":
            return f"skipped{said}"
        if kind == "MemoryError":
            return f"ran out of memory (the limit is {_size(limits.memory)}){said}{at}"
        if kind == "Refused":
            return f"the grader refused an operation{said}{at}"
        if kind == "OSError" and error.get("code") == 27:
            return f"your code printed more than the grader keeps ({_size(limits.file_size)}); remove prints in loops"
        if kind == "SystemExit":
            return f"your code called sys.exit(){at}: a function must return, not end the program"
        return f"your code raised {kind}{said}{at}" + diagnosis.not_the_model(kind)
    if reply.printed > limits.output:
        head = "" if hidden else f" (it starts: {reply.output_head[:80]!r})"
        return (
            f"your code printed {_size(reply.printed)} here (the limit is {_size(limits.output)}){head}; "
            "remove print statements from functions called in loops"
        )
    return None


def _element_errors(reply: Reply, owners: set[str] | None) -> list[str]:
    lines = []
    for error in reply.element_errors:
        if owners is not None and error.get("element") not in owners:
            continue
        where = f" ({error['where']})" if error.get("where") else ""
        kind, said = error.get("type", "Error"), f": {error['message']}" if error.get("message") else ""
        text = f"not implemented yet{said}" if kind == "NotImplementedError" else f"raised {kind}{said}"
        lines.append(f"{error.get('element')}.{error.get('method')} {text}{where}")
    return lines


class Labels:
    """Names of the entries of a probe's output, for messages."""

    def __init__(self, reference: Reference, expected: dict[str, np.ndarray]):
        self.meta = reference.meta
        self.inputs = reference.inputs
        self.expected = expected

    def axis(self, name: str, index: int, hidden: bool) -> str:
        meta = self.meta
        if name == "state":
            t = self.inputs.get("t")
            at = f" (t = {t[index]:.4g} s)" if t is not None and not hidden else ""
            return f"state {index + 1}{at}"
        if name == "row":
            label, owner, kind = meta["row_labels"][index], meta["row_owners"][index], meta["row_kinds"][index]
            return f"row {label} ({kind} {owner})"
        if name == "coordinate":
            return meta["coordinate_names"][index]
        if name == "time":
            t = self.expected.get("t")
            if t is None:
                return f"step {index}"
            return f"t = {t[index]:.4g} s" if not hidden else f"{100 * index / max(1, t.size - 1):.0f} % of the run"
        if name == "reaction":
            return reaction_labels(meta["row_owners"], meta["dimension"])[index]
        if name == "body":
            return meta["body_names"][index]
        if name in ("i", "j"):
            return f"{'row' if name == 'i' else 'column'} {index + 1}"
        if name == "steps":
            return f"{RK4_STEPS[index]} steps"
        if name == "crank":
            theta = SliderCrankLoop().driver(LOOP_TIMES[index])[0]
            return f"t = {LOOP_TIMES[index]:.4g} s (crank angle {theta:.4g} rad)"
        if name == "loop":
            return SliderCrankLoop.coordinate_names[index]
        if name == "component":
            return ("y", "y'")[index] if index < 2 else str(index)
        return f"{name} {index}"

    def where(self, axes: tuple[str, ...], index: tuple[int, ...], hidden: bool) -> str:
        parts = [self.axis(a, i, hidden) for a, i in zip(axes, index, strict=True)]
        if axes[-2:] == ("coordinate", "coordinate"):  # a matrix over the coordinates, e.g. M
            parts[-2:] = [f"row {parts[-2]}", f"column {parts[-1]}"]
        return ", ".join(parts)


def _row_mask(spec: CheckSpec, reference: Reference) -> np.ndarray | None:
    if not spec.rows:
        return None
    return np.array([kind in spec.rows for kind in reference.meta["row_kinds"]])


def _selector(axes: tuple[str, ...], mask: np.ndarray | None) -> Callable[[np.ndarray], np.ndarray]:
    if mask is None or "row" not in axes:
        return lambda x: x
    axis = axes.index("row")
    return lambda x: np.compress(mask, x, axis=axis)


def _allowed(spec: CheckSpec, probe_kind: str, expected: np.ndarray, stored: np.ndarray | None) -> np.ndarray:
    if stored is not None:
        return np.broadcast_to(stored, expected.shape)
    rtol = spec.rtol if spec.rtol is not None else DEFAULT_RTOL
    atol = spec.atol if spec.atol is not None else DEFAULT_ATOL
    scale = max(1e-3, float(np.max(np.abs(expected), initial=0.0)))
    if probe_kind == "run" and expected.ndim == 2:
        columns = np.maximum(np.max(np.abs(expected), axis=0, keepdims=True), 1e-3 * scale)
        return rtol * columns + atol * scale + 0 * expected
    return rtol * np.abs(expected) + atol * scale


def _fmt(x: float, other: float) -> str:
    """x with enough digits to tell it from ``other`` (at least 6 significant digits)."""
    difference = abs(x - other)
    digits = (
        6
        if difference == 0 or not np.isfinite(difference)
        else int(np.ceil(np.log10(max(abs(x), abs(other), 1e-300) / difference))) + 2
    )
    return f"{x:.{min(max(digits, 6), 15)}g}"


def compare(
    spec: CheckSpec,
    output: str,
    got: np.ndarray | None,
    reference: Reference,
    hidden: bool,
    mistakes: Mistakes | None = None,
    causes: list[list[str]] | None = None,
) -> tuple[bool, str, dict | None]:
    """Compare one output: (passed, message, plot data).

    ``mistakes`` gives the known mistakes of this output (default: those stored with the reference);
    ``causes``, when given, gets every cause that explains a failure (the named one first)."""
    key = spec.probe_key
    expected_all = reference.outputs(key)
    expected = expected_all[output]
    axes = AXES[f"{spec.probe}.{output}"]
    quantity = QUANTITIES.get(f"{spec.probe}.{output}", output)
    if got is None:
        return False, f"{quantity}: your code returned nothing for it", None
    got = np.asarray(got, dtype=float)
    if got.shape != expected.shape:
        if diagnosis.transposed(expected, got):
            return (
                False,
                f"{quantity}: you return the matrix transposed (shape {got.shape}, expected {expected.shape})",
                None,
            )
        return False, f"{quantity}: expected an array of shape {expected.shape}, got shape {got.shape}", None
    if diagnosis.transposed(expected, got):
        return False, f"{quantity}: you return the matrix transposed", None
    mask = _row_mask(spec, reference)
    select = _selector(axes, mask)
    e, g = select(expected), select(got)
    probe_kind = "run" if spec.probe.endswith("_run") else "function"
    allowed = _allowed(spec, probe_kind, e, reference.extra(key, f"tol:{output}"))
    error = np.abs(g - e)
    bad = ~(error <= allowed) & ~np.isnan(e)  # NaN counts as bad, unless the reference has none there
    if not np.any(bad):
        return True, "", None
    # the worst of the failing entries (a NaN or infinity counts as the worst; entries that pass, and NaNs
    # of the reference's own, never do)
    ratio = np.where(np.isfinite(error), error / np.maximum(np.nan_to_num(allowed, nan=np.inf), 1e-300), np.inf)
    worst = np.unravel_index(int(np.argmax(np.where(bad, ratio, -np.inf))), ratio.shape)
    # the index in the unfiltered array, for the labels
    full = list(worst)
    if mask is not None and "row" in axes:
        full[axes.index("row")] = int(np.flatnonzero(mask)[worst[axes.index("row")]])
    where = Labels(reference, expected_all).where(axes, tuple(full), hidden)
    ev, gv, tol = float(e[worst]), float(g[worst]), float(allowed[worst])
    if hidden:
        relative = abs(gv - ev) / max(abs(ev), tol)
        message = f"{quantity}: the largest difference is at {where} (relative error {relative:.2g})"
    else:
        message = (
            f"{quantity}: the largest difference is at {where}: expected {_fmt(ev, gv)}, got {_fmt(gv, ev)} "
            f"(tolerance {tol:.2g})"
        )
    count = int(np.sum(bad))
    if count > 1:
        message += f"; {count} of {bad.size} values are off"
    known = mistakes(output) if mistakes is not None else reference.replays(key, output)
    found = diagnosis.likely_causes(spec.probe, output, e, g, bad, allowed, known, select)
    if found:
        message += f". Likely cause: {found[0]}"
        if causes is not None:
            causes.append(found)
    plot = None
    if not hidden and axes and axes[0] == "time" and g.ndim == 2 and "t" in expected_all:
        column = int(full[1])
        plot = {
            "t": expected_all["t"],
            "expected": e[:, column],
            "got": g[:, column],
            "label": Labels(reference, expected_all).axis("coordinate", column, hidden)
            + {"qd": "_d", "qdd": "_dd"}.get(output, ""),
            "quantity": quantity,
        }
    return False, message, plot


FOLLOW = 0.1
"""A run's drift and energy count only while it follows the reference within this part of its motion."""


def _off_course(spec: CheckSpec, reply: Reply, reference: Reference, hidden: bool) -> str | None:
    """Why a run's invariants say nothing (it does not move like the reference), or None.

    A frozen or all-zero trajectory keeps its constraints and its energy perfectly: the drift and energy
    of a run only count when its positions stay within FOLLOW of the reference's range of motion.
    """
    expected, got = reference.outputs(spec.probe_key).get("q"), reply.outputs.get("q")
    if expected is None:
        return None
    if got is None or np.shape(got) != expected.shape:
        return "your run gave no trajectory of the reference's shape"
    motion = max(float(np.max(np.ptp(expected, axis=0))), 1e-12)
    difference = np.abs(np.asarray(got, dtype=float) - expected)
    off = float(np.max(difference)) if np.all(np.isfinite(difference)) else np.inf
    if off <= FOLLOW * motion:
        return None
    size = "" if hidden else f" (off by {off:.3g}, more than {FOLLOW:g} of its range of motion {motion:.3g})"
    return f"your trajectory does not follow the reference's{size}: the drift and energy of another motion earn nothing"


def _measured(measure: Measure, outputs: dict) -> dict | str:
    """The invariants of a student's run, or why they cannot be measured."""
    if "q" not in outputs or "qd" not in outputs or "t" not in outputs:
        return "your run returned no trajectory"
    try:
        return measure(outputs)
    except Exception as err:  # noqa: BLE001 - a trajectory of the wrong shape
        return f"cannot evaluate your trajectory ({type(err).__name__}: {err})"


def compare_invariant(
    spec: CheckSpec, output: str, measured: dict | str, reference: Reference, hidden: bool
) -> tuple[bool, str]:
    """A run's constraint drift or energy error against its bound."""
    bound = reference.extra(spec.probe_key, f"bound:{output}")
    quantity = QUANTITIES.get(f"{spec.probe}.{output}", output)
    if bound is None:
        return False, f"{quantity}: no bound stored for this scene (grader configuration)"
    if isinstance(measured, str):
        return False, f"{quantity}: {measured}"
    value, limit = measured.get(output, np.nan), float(bound)
    if value <= limit:
        return True, ""
    if hidden:
        message = f"{quantity} is {value / limit:.2g} times its bound (ten times what the reference shows)"
    else:
        message = f"{quantity} reaches {value:.3g}, more than {limit:.2g} (ten times what the reference shows)"
    if output in ("drift", "velocity_drift"):
        message += (
            ". Likely cause: a constraint error that grows instead of decaying: Baumgarte's terms with the wrong "
            "sign or missing (gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi), or a wrong gamma"
        )
    elif output == "energy":
        message += ". Likely cause: a wrong force or mass term, or an integrator of lower order than prescribed"
    return False, message


def evaluate(
    spec: CheckSpec,
    reply: Reply,
    reference: Reference,
    measure: Measure,
    limits: Limits,
    title: str,
    mistakes: Mistakes | None = None,
) -> Outcome:
    """The outcome of one check from the reply of its probe.

    ``measure`` gives the invariants of a run, ``mistakes`` the known mistakes (default: stored)."""
    hidden = spec.kind == HIDDEN
    messages, plot, causes = [], None, []
    failure = failure_of_reply(reply, limits, hidden)
    owners = None
    mask = _row_mask(spec, reference)
    if mask is not None:
        owners = {o for o, keep in zip(reference.meta["row_owners"], mask, strict=True) if keep}
    errors = _element_errors(reply, owners)
    if failure:
        messages.append(failure)
    elif errors:
        messages.append("; ".join(errors[:3]) + (f"; and {len(errors) - 3} more" if len(errors) > 3 else ""))
    else:
        results = {}
        measured = None
        for output in spec.outputs:
            if output in INVARIANTS:
                if measured is None:
                    measured = _off_course(spec, reply, reference, hidden) or _measured(measure, reply.outputs)
                ok, text = compare_invariant(spec, output, measured, reference, hidden)
                results[output] = ok
                if not ok:
                    messages.append(text)
                continue
            ok, text, data = compare(spec, output, reply.outputs.get(output), reference, hidden, mistakes, causes)
            results[output] = ok
            if not ok:
                messages.append(text)
                plot = plot or data
        if spec.probe.endswith("_run") and messages and "Likely cause" not in " ".join(messages):
            hint = _run_hint(spec, reply, reference, hidden)
            if hint:
                messages.append(hint)
    passed = not messages
    text = "passed" if passed else f"{title}: " + "; ".join(messages)
    return Outcome(
        name=spec.name,
        group=spec.group,
        scene=spec.scene,
        kind=spec.kind,
        points=spec.points if passed else 0.0,
        max_points=spec.points,
        passed=passed,
        message=text,
        visibility=spec.visibility,
        plot=plot,
        causes=causes,
    )


def reconcile_causes(checks: list[CheckSpec], outcomes: list[Outcome]) -> list[Outcome]:
    """One student's outcomes with every likely cause checked against all their checks: a cause that blames
    a function whose own checks pass is replaced by the next that fits, or taken out (``diagnosis.reconcile``)."""
    specs = {c.name: c for c in checks}
    tested = [
        diagnosis.Tested(specs[o.name].probe, tuple(specs[o.name].rows or ()), o.passed)
        for o in outcomes
        if o.name in specs
    ]
    for outcome in outcomes:
        if outcome.causes:
            outcome.message = diagnosis.reconcile(outcome.message, outcome.causes, tested)
    return outcomes


def _run_hint(spec: CheckSpec, reply: Reply, reference: Reference, hidden: bool) -> str | None:
    """For a run: which of q, q', q'' agree with the reference tells where the error is."""
    agree = {}
    for output in ("q", "qd", "qdd"):
        if output in reference.outputs(spec.probe_key) and output in reply.outputs:
            ok, _, _ = compare(spec, output, reply.outputs[output], reference, hidden, lambda _: [])
            agree[output] = ok
    if not agree:
        return None
    for output in ("q", "qd", "qdd"):
        if output in agree and not agree[output]:
            if output == "q" and spec.probe == "dynamic_run":
                return (
                    "the trajectory leaves the reference: the function checks (mass matrix, forces, "
                    "accelerations, rk4) tell which part is wrong; if they all pass, your forward_dynamics "
                    "does not integrate as asked (are the rtol, atol and step it is given passed to the integrator?)"
                )
            return RUN_HINTS[output]
    return None
