"""Tolerances of the run checks, derived from the integrator's own accuracy, and the invariants.

A forward-dynamic run at the settings the homework prescribes (integrator, rtol, atol or step) is only
as accurate as those settings. The reference therefore runs twice: at the prescribed settings and at
tight ones (DOP853, rtol 1e-12). The difference is the integrator's own error e(t) on this scene. A
student's run is compared with the prescribed-settings reference and may differ by

    tol = SAFETY * max_t |e(t)|  +  rtol * scale + atol           (per coordinate)

so an equivalent implementation (other round-off, other step sequence) passes, while a wrong term or a
wrong stage weight, whose error is orders of magnitude larger, fails. The invariants get bounds the same
way: the constraint drift max |Psi(q(t), t)| and, for a conservative scene, the energy error
max |E(t) - E(0)|, each SAFETY times what the reference itself shows at the prescribed settings.
"""

from __future__ import annotations

import numpy as np

from mbdkit.probes import PROBES, Job, Package
from mbdkit.scenes import Scene, job_key

SAFETY = 10.0
TIGHT = {"integrator": "DOP853", "rtol": 1e-12, "atol": 1e-14}
REFERENCE = Package("solutions")
FIXED_STEP_RTOL = 1e-9
"""The relative floor of a fixed-step run's tolerance (it has no rtol of its own)."""


def invariants(scene_data: dict, t: np.ndarray, q: np.ndarray, qd: np.ndarray) -> dict[str, float]:
    """Constraint drift, velocity drift and (conservative scenes) energy error of a run, measured with
    the reference package (the ``invariants`` probe)."""
    key = job_key(Scene("run", scene_data, "any"))  # the probes cache the model per key: one per content
    job = Job(key, scene_data, {"t": np.asarray(t), "q": np.asarray(q), "qd": np.asarray(qd)})
    return {name: float(value) for name, value in PROBES["invariants"](REFERENCE, job).items()}


INTEGRATOR_OPTIONS = ("integrator", "rtol", "atol", "step", "engine")
"""Options that change only how the run is integrated (``engine``: not even that, only the code that runs it)."""


def dynamic_run(scene, job: Job, outputs: dict, tight: dict | None = None) -> dict[str, np.ndarray]:
    """tol:q, tol:qd (per coordinate) and bound:drift, bound:velocity_drift, bound:energy of a run.

    ``tight`` is the scene's own run at TIGHT settings; it is run again only when the check changes
    more than the integrator (e.g. the formulation)."""
    others = {k: v for k, v in job.options.items() if k not in INTEGRATOR_OPTIONS}
    if tight is None or others:
        tight = PROBES["dynamic_run"](REFERENCE, Job(job.key, job.model, job.inputs, {**others, **TIGHT}))
    fixed_step = job.setting("integrator", "integrator", "RK45") == "rk4"
    rtol = FIXED_STEP_RTOL if fixed_step else float(job.setting("rtol", "rtol", 1e-8))
    atol = FIXED_STEP_RTOL * 1e-3 if fixed_step else float(job.setting("atol", "atol", 1e-10))
    out = {}
    for name in ("q", "qd"):
        own = np.max(np.abs(outputs[name] - tight[name]), axis=0)
        scale = np.max(np.abs(tight[name]), axis=0)
        out[f"tol:{name}"] = SAFETY * own + rtol * scale + atol
    measured = invariants(job.model, outputs["t"], outputs["q"], outputs["qd"])
    out["bound:drift"] = np.array(SAFETY * measured["drift"] + 1e-10)
    out["bound:velocity_drift"] = np.array(SAFETY * measured["velocity_drift"] + 1e-9)
    if "energy" in measured:
        out["bound:energy"] = np.array(SAFETY * measured["energy"] + 1e-9 * measured["energy_scale"])
    return out


DERIVED = {"dynamic_run": dynamic_run}
"""Probe -> function making its stored tolerances and bounds."""
