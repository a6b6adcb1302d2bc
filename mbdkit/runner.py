"""Run a list of checks on a student's package: one sandbox, one probe call per scene and probe key.

Where the scenes and the expected values come from is a ``PublicData``, which reads the public
scenes and their stored expected values (a student kit, ``mbd selfcheck``, a notebook's ``check``); the
instructor's grader (``autograder.grading``) adds hidden and per-student scenes.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .checks import Measure, Mistakes, Outcome, evaluate, reconcile_causes
from .homework import CheckSpec
from .probes import Job
from .sandbox import Limits, Reply, Sandbox
from .scenes import HIDDEN, PUBLIC, STUDENT, Scene, job_key, load_public_scene, scene_kind
from .stored import Reference, load_reference

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


def title(scene: str) -> str:
    """How a scene is named in a message."""
    kind = scene_kind(scene)
    if kind == STUDENT:
        return f"{scene.split('/', 1)[1]} (your own variant)"
    if kind == HIDDEN:
        return f"{scene} (hidden scene)"
    return scene


def _order(checks: list[CheckSpec]) -> list[tuple[str, str]]:
    """Probe calls (scene, probe key): function checks first, then runs; public scenes first."""
    rank = {"public": 0, "student": 1, "hidden": 2}
    calls = dict.fromkeys((c.scene, c.probe_key) for c in checks)
    kinds = {(c.scene, c.probe_key): (c.probe.endswith("_run"), rank[c.kind]) for c in checks}
    return sorted(calls, key=lambda call: kinds[call])


def redact(reply: Reply) -> Reply:
    """A hidden scene's reply without the student's own text (an exception's message could echo hidden
    inputs); the grader's own messages (timeouts, crashes, skipped functions) stay."""
    if reply.error and reply.status == "error" and reply.error.get("type") != "HungEarlier":
        reply.error = {**reply.error, "message": ""}
    for error in reply.element_errors:
        error["message"] = ""
    reply.output_head = ""
    return reply


def failed(check: CheckSpec, message: str) -> Outcome:
    """A check that could not run, with the reason."""
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
) -> list[Outcome]:
    """Run ``checks`` on the package in ``folder`` (``folder/modules``); outcomes in order.

    The public checks run in one sandbox child, the hidden and per-student ones in a second, started once
    the first is gone (so nothing a hidden scene sent a child can surface in a public check's message);
    under ``isolation="os"`` both are forked in one bubblewrap sandbox of the submission. ``budget``:
    wall-clock seconds for all the checks of the submission; the checks not started by then fail with a
    message saying so.

    ``forbidden`` are folders the sandbox may not read, ``hide`` folders removed from its import path;
    ``isolation`` the sandbox's backend: ``local`` (a student's own checks) or ``os`` (the grader's).
    """
    data = data or PublicData()
    limits = limits or Limits()
    folder = Path(folder).resolve()
    if not (folder / PACKAGE / "__init__.py").is_file():
        message = f"no package {PACKAGE}/ (with __init__.py) in the folder {folder}"
        return [failed(c, message) for c in checks]
    host = None
    if isolation == "os":  # one bubblewrap sandbox per submission; a child for each set of checks
        from .isolation import IsolatedHost

        host = IsolatedHost(folder, PACKAGE, limits.tmp_size)
    try:
        outcomes = _run_all(checks, folder, data, limits, forbidden, hide, isolation, budget, host)
        return reconcile_causes(checks, outcomes)  # a cause must agree with all the student's checks
    finally:
        if host is not None:
            host.close()


def _run_all(checks, folder, data, limits, forbidden, hide, isolation, budget, host) -> list[Outcome]:
    outcomes: dict[str, Outcome] = {}
    start, hung = time.monotonic(), []
    for public in (True, False):  # hidden and per-student scenes never share a child with public checks
        calls = [call for call in _order(checks) if (scene_kind(call[0]) == PUBLIC) == public]
        if not calls:
            continue
        options = {"forbidden": forbidden, "hide": hide, "limits": limits, "isolation": isolation, "host": host}
        with Sandbox(folder, PACKAGE, **options) as sandbox:
            sandbox.hung = hung  # a function that hung costs one timeout per submission, in either child
            for scene_name, key in calls:
                group = [c for c in checks if c.scene == scene_name and c.probe_key == key]
                if budget is not None and time.monotonic() - start > budget:
                    message = (
                        f"not run: your submission used up its time budget ({budget:g} s for all its checks); "
                        "a function far slower than it should be? (the checks above say which ran)"
                    )
                    outcomes.update({c.name: failed(c, message) for c in group})
                    continue
                outcomes.update(_run_group(group, checks, data, sandbox, limits, scene_name, key))
    return [outcomes[c.name] for c in checks]


def _run_group(
    group: list[CheckSpec],
    checks: list[CheckSpec],
    data: PublicData,
    sandbox: Sandbox,
    limits: Limits,
    scene_name: str,
    key: str,
) -> dict[str, Outcome]:
    """The outcomes of the checks that share one probe call (a scene and a probe key)."""
    scene = data.scene(scene_name)
    reference = data.reference(scene, [c for c in checks if c.scene == scene_name])
    first = group[0]
    if not reference.has(key):
        message = f"grader configuration: no reference for {key} (run python -m autograder.reference)"
        return {c.name: failed(c, message) for c in group}
    job = Job(job_key(scene), scene.data, reference.inputs, dict(first.options))
    timeout = max(c.timeout for c in group)
    reply = sandbox.run(first.probe, job.key, scene.data, reference.inputs, first.options, timeout)
    if scene.kind == HIDDEN:
        reply = redact(reply)
    measure = data.measure(scene, sandbox)
    return {
        c.name: evaluate(c, reply, reference, measure, limits, title(scene_name), data.mistakes(c, scene, job))
        for c in group
    }
