"""Run a list of checks on a student's package: one sandbox, one probe call per scene and probe key.

Where the scenes and the expected values come from is a ``PublicData``, which reads the public
scenes and their stored expected values (a student kit, ``mbd selfcheck``, a notebook's ``check``); the
instructor's grader (``autograder.grading``) adds hidden and per-student scenes.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

import numpy as np

from . import withheld
from .checks import Measure, Mistakes, Outcome, evaluate, reconcile_causes
from .homework import CheckSpec
from .probes import REQUIRES, Job, sent_inputs
from .sandbox import Limits, Replies, Sandbox
from .scenes import HIDDEN, PUBLIC, STUDENT, Scene, job_key, load_public_scene, scene_kind
from .stored import Reference, load_reference
from .withheld import title

PACKAGE = "modules"
INVARIANTS_TIMEOUT = 30.0


class PublicData:
    """The scenes and expected values of the public checks, as stored (subclassed by the grader)."""

    def __init__(self) -> None:
        self._references: dict[str, Reference] = {}
        self._scenes: dict[str, Scene] = {}

    def scene(self, name: str) -> Scene:
        """A scene by name (read once)."""
        if name not in self._scenes:
            self._scenes[name] = load_public_scene(name)
        return self._scenes[name]

    def reference(self, scene: Scene, checks: list[CheckSpec]) -> Reference:
        """The expected values of a scene (read once)."""
        if scene.name not in self._references:
            self._references[scene.name] = load_reference(scene.name)
        return self._references[scene.name]

    def measure(self, scene: Scene, sandbox: Sandbox) -> Measure:
        """How a run's invariants are measured: here with the student's own package, in the sandbox
        (a kit has no reference package); the grader measures with the reference."""

        def measure(outputs: dict) -> dict | str:
            inputs = {name: np.asarray(outputs[name], dtype=float) for name in ("t", "q", "qd")}
            reply = sandbox.run("invariants", job_key(scene), scene.data, inputs, {}, INVARIANTS_TIMEOUT)
            if not reply.ok:
                error = reply.error or {}
                said = f": {error.get('message')}" if error.get("message") else ""
                return f"your package could not measure it ({error.get('type', reply.status)}{said})"
            return {name: float(value) for name, value in reply.outputs.items()}

        return measure

    def mistakes(self, check: CheckSpec, scene: Scene, job: Job) -> Mistakes | None:
        """The known mistakes of a check's outputs; None: those stored with the reference."""
        return None


def _order(checks: list[CheckSpec]) -> list[tuple[str, str]]:
    """Probe calls (scene, probe key): function checks first, then runs; public scenes first."""
    rank = {"public": 0, "student": 1, "hidden": 2}
    calls = dict.fromkeys((c.scene, c.probe_key) for c in checks)
    kinds = {(c.scene, c.probe_key): (c.probe.endswith("_run"), rank[c.kind]) for c in checks}
    return sorted(calls, key=lambda call: kinds[call])


def failed(
    check: CheckSpec,
    message: str,
    reason: str = "grader",
    done: dict[str, Outcome] | None = None,
    checks: list[CheckSpec] = (),
) -> Outcome:
    """A check that could not run, with the reason: ``message`` for a public check, the grader's ``reason``
    (``withheld.REASONS``) for a hidden or per-student one (its public twin among ``checks``, if in ``done``)."""
    if check.kind != PUBLIC:
        return withheld.outcome(check, withheld.NOT_RUN, reason, _twin_outcome(check, done or {}, list(checks)))
    return Outcome(
        check.name, check.group, check.scene, check.kind, 0.0, check.points, False, message, check.visibility
    )


def run_checks(
    checks: list[CheckSpec],
    folder: Path,
    data: PublicData | None = None,
    limits: Limits | None = None,
    forbidden: tuple[Path, ...] = (),
    hide: tuple[Path, ...] = (),
    isolation: str = "local",
    budget: float | None = None,
    replies: Replies | None = None,
) -> list[Outcome]:
    """Run ``checks`` on the package in ``folder`` (``folder/modules``); outcomes in order.

    The public checks run in one sandbox child, the per-student ones in a second and the hidden ones in a
    third, each started once the one before is gone, and sent nothing computed in another (only the
    functions that hung in the public child are not run again); under ``isolation="os"`` they are forked in
    one bubblewrap sandbox of the submission. A hidden or per-student check says only what ``withheld``
    lets it: its status, description and the grader's hint, nothing the student's code chose. ``budget``:
    wall-clock seconds for all the checks of the submission; the checks not started by then fail with a
    message saying so.

    ``forbidden`` are folders the sandbox may not read, ``hide`` folders removed from its import path;
    ``isolation`` the sandbox's backend: ``local`` (a student's own checks) or ``os`` (the grader's).
    ``replies``: earlier replies on this same package (``sandbox.Replies``), reused; the grader passes none.
    """
    data = data or PublicData()
    limits = limits or Limits()
    folder = Path(folder).resolve()
    if not (folder / PACKAGE / "__init__.py").is_file():
        message = f"no package {PACKAGE}/ (with __init__.py) in the folder {folder}"
        return [failed(c, message, "no package") for c in checks]
    host = None
    if isolation == "os":  # one bubblewrap sandbox per submission; a child for each set of checks
        from .isolation import IsolatedHost

        host = IsolatedHost(folder, PACKAGE, limits.tmp_size, limits, preload=preload_for(checks))
    try:
        outcomes = _run_all(checks, folder, data, limits, forbidden, hide, isolation, budget, host, replies)
        return reconcile_causes(checks, outcomes)  # a cause must agree with all the student's checks
    finally:
        if host is not None:
            host.close()


INTEGRATING = {"dynamics", "integrators"}
"""What a probe that integrates requires (``probes.REQUIRES``): its child needs scipy.integrate."""


def preload_for(checks: list[CheckSpec]) -> str:
    """What the sandbox's zygote imports for ``checks`` (``_zygote.LEVELS``): scipy's integrators only when
    one of them integrates (a kinematic homework's sandbox starts 0.4 s of CPU sooner without them)."""
    return "all" if any(INTEGRATING & set(REQUIRES.get(c.probe, ())) for c in checks) else "kinematic"


KINDS = (PUBLIC, STUDENT, HIDDEN)
"""The sets of checks, each run in a child of its own, in this order (public first: a variant's hint names
how its public twin did)."""


def _run_all(checks, folder, data, limits, forbidden, hide, isolation, budget, host, replies=None) -> list[Outcome]:
    outcomes: dict[str, Outcome] = {}
    start, hung = time.monotonic(), []
    for kind in KINDS:
        calls = [call for call in _order(checks) if scene_kind(call[0]) == kind]
        if not calls:
            continue
        options = {"forbidden": forbidden, "hide": hide, "limits": limits, "isolation": isolation, "host": host}
        with _sandbox(kind, folder, options, replies) as sandbox:
            # a function that hung in the public child is not run again in the others (one timeout per
            # submission); what hung in a hidden or per-student child is told to no other child
            hung = sandbox.hung if kind == PUBLIC and sandbox.hung else hung  # a kept child's, from before
            sandbox.hung = hung if kind == PUBLIC else list(hung)
            for scene_name, key in calls:
                group = [c for c in checks if c.scene == scene_name and c.probe_key == key]
                if budget is not None and time.monotonic() - start > budget:
                    message = (
                        f"not run: your submission used up its time budget ({budget:g} s for all its checks); "
                        "a function far slower than it should be? (the checks above say which ran)"
                    )
                    outcomes.update({c.name: failed(c, message, "budget", outcomes, checks) for c in group})
                    continue
                outcomes.update(_run_group(group, checks, data, sandbox, limits, scene_name, key, outcomes))
    return [outcomes[c.name] for c in checks]


def _sandbox(kind: str, folder: Path, options: dict, replies: Replies | None):
    """The sandbox of one set of checks: a new one, closed after the set; or, for a student's public checks run
    again on the same package (``replies``, local backend), the one kept with those replies, left running for
    the next call (a notebook's next graded cell starts no child)."""
    if replies is None or kind != PUBLIC or options["isolation"] != "local":
        return Sandbox(folder, PACKAGE, replies=replies, **options)
    if replies.sandbox is None:
        replies.sandbox = Sandbox(folder, PACKAGE, replies=replies, **options)
    return contextlib.nullcontext(replies.sandbox)


def _twin_outcome(check: CheckSpec, done: dict[str, Outcome], checks: list[CheckSpec]) -> Outcome | None:
    """The outcome of the check's public twin among ``checks`` (``withheld.twin``), if it ran."""
    public = withheld.twin(check, checks)
    return None if public is None else done.get(public.name)


def _run_group(
    group: list[CheckSpec],
    checks: list[CheckSpec],
    data: PublicData,
    sandbox: Sandbox,
    limits: Limits,
    scene_name: str,
    key: str,
    done: dict[str, Outcome],
) -> dict[str, Outcome]:
    """The outcomes of the checks that share one probe call (a scene and a probe key); ``done``: the
    outcomes so far (a hidden or per-student check's hint names how its public twin did)."""
    scene = data.scene(scene_name)
    reference = data.reference(scene, [c for c in checks if c.scene == scene_name])
    first = group[0]
    if not reference.has(key):
        message = f"grader configuration: no reference for {key} (run python -m autograder.reference)"
        return {c.name: failed(c, message, "grader", done, checks) for c in group}
    public = scene.kind == PUBLIC
    inputs = sent_inputs(first.probe, reference.inputs, public, reference.meta.get("dimension", 2))
    job = Job(job_key(scene), scene.data, inputs, dict(first.options))
    timeout = max(c.timeout for c in group)
    reply = sandbox.run(first.probe, job.key, scene.data, inputs, first.options, timeout)
    measure = data.measure(scene, sandbox)
    outcomes = {}
    for c in group:
        graded = evaluate(c, reply, reference, measure, limits, title(scene_name), data.mistakes(c, scene, job))
        if not public:  # the grader's words only
            state, reason = withheld.status(c, reply, reference, graded.passed, limits)
            graded = withheld.outcome(c, state, reason, _twin_outcome(c, done, checks))
        outcomes[c.name] = graded
    return outcomes
