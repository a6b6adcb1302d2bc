"""What a compiled ``forward_dynamics`` call costs besides its integration loop, stage by stage (issue 25, item 2).

Issue 25 asks that the fixed cost of a call (everything but the integration loop) be at most 1 ms at 2 bodies and
never more than the integration at any N. This script measures where that cost goes: each named stage of
``forward_dynamics`` (``solutions/dynamics.py``: initial conditions, the plan and its motion periods, the engine's
choice, the compiled loop, the outputs at the output times, the checks, the result with its residuals, energies
and reactions) is wrapped by a timer for the measured calls, and the table gives its milliseconds per call (the
mean of ``--calls`` calls after one warm-up call, the set-up's garbage collected before them: a full collection among
them, ~60 ms once, would swamp the mean), the integration loop (``loops.embedded``) beside the rest.
Stages nest (``integrate_motion`` holds the engine's choice, the compiled run and the checks), so the rows do
not add up; "outside the loop" is the whole call minus the loop.

    .venv/bin/python benchmarks/call_cost.py                                  # the three bench scenes
    .venv/bin/python benchmarks/call_cost.py --scene slider_crank --formulation joint-coordinates
    .venv/bin/python benchmarks/call_cost.py --chain loops --sizes 4 8 16     # chains of benchmarks/chains.py
    .venv/bin/python benchmarks/call_cost.py --engine cached --default-rtol   # the start rates of a cached run
    .venv/bin/python benchmarks/call_cost.py --engine auto --t-end 100 --default-rtol   # long enough for auto
    .venv/bin/python benchmarks/call_cost.py --prepared --cpu --formulation joint-coordinates   # prepared.run

``--prepared`` times ``prepared.run(q0, qd0)`` of one ``dynamics.prepare`` (the preparation, and its first run which
makes what the runs share, timed apart as MuJoCo's model compilation is left out of its rollouts), not the call.

Runs use the compiled engine from the machine's cache (the first call of a structure compiles it: warm-up), DOP853
at rtol = 1e-6 (``--default-rtol``: the rule's, eq. 6.60, from the start rates), atol = 1e-8, 1 s simulated
(``--t-end``), 100 output intervals; ``--engine cached`` or ``auto`` asks for that engine (the run must end up
compiled: an ``auto`` run needs a span whose numpy run is estimated above 0.5 s). Nothing is asserted (timing
depends on the machine): prints a Markdown table.
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import functools  # noqa: E402
import gc  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from solutions import dynamics, guard  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.compiled import dispatch, history, loops  # noqa: E402
from solutions.io import load_model  # noqa: E402

SCENES = ("double_pendulum", "slider_crank", "spatial_double_pendulum")
STAGES = (
    (dynamics, "consistent_start", "initial conditions (assembly)"),
    (dynamics, "plan_method", "plan: method and tolerance"),
    (dynamics, "motion_rate", "  motion rate (start rates: rho, q'')"),
    (dynamics, "integrate_motion", "engine: integrate_motion"),
    (dispatch, "choose", "  engine's choice"),
    (dispatch, "run", "  compiled run"),
    (loops, "embedded", "    integration loop"),
    (loops, "output_history", "    outputs at the output times"),
    (loops, "blocked_output_history", "    outputs at the output times"),  # a large Psi_q's (ONE_PASS_LARGEST)
    (loops, "outputs", "    outputs at the output times"),  # rows that reach other columns: two passes
    (history, "constraint_arrays", "    constraints at the output times"),
    (guard.Guard, "check_outputs", "  checks at the output times (Guard)"),
    (dynamics, "build_result", "result"),
    (history, "residuals", "  residuals"),
    (dynamics, "energy_history", "  energies"),
    (history, "joint_reactions", "  joint reactions"),
    (dynamics, "effort_columns", "  efforts"),
    (dynamics, "run_info", "info"),
)
"""(owner, attribute, label) of every stage timed, in the order of a call."""
COMPANION = (
    (dynamics, "companion_centres", "divergence check: the companion run"),
    (loops, "embedded", "  its integration loop"),
)
"""The stages of the divergence check's companion run at k x rtol (``dynamics.judge_divergence``), timed apart: the
loop's timer counts only inside the companion (``inside``)."""


@contextlib.contextmanager
def inside(outer, inner, seconds: dict):
    """Time ``outer`` (owner, name, label), and ``inner`` only while ``outer`` runs, into ``seconds``."""
    within = [False]
    owner, name, _ = inner
    saved = [(outer[0], outer[1], getattr(outer[0], outer[1])), (owner, name, getattr(owner, name))]

    def counted(*args, **kwargs):
        if not within[0]:
            return saved[1][2](*args, **kwargs)
        start = CLOCK[0]()
        try:
            return saved[1][2](*args, **kwargs)
        finally:
            seconds[inner[2]] = seconds.get(inner[2], 0.0) + CLOCK[0]() - start

    def flagged(*args, **kwargs):
        within[0] = True
        try:
            return saved[0][2](*args, **kwargs)
        finally:
            within[0] = False

    setattr(outer[0], outer[1], flagged)
    setattr(owner, name, counted)
    try:
        with timed([outer], seconds):
            yield seconds
    finally:
        for owner_, name_, original in saved:
            setattr(owner_, name_, original)


CLOCK = [time.perf_counter]
"""The clock of the timers: wall time, or with ``--cpu`` this thread's CPU time (``time.thread_time``), steadier on
a machine that other work shares (what it leaves out: waiting; a compiled call does not wait)."""


@contextlib.contextmanager
def timed(stages, seconds: dict):
    """Wrap each stage with a timer that adds its seconds to ``seconds[label]``; restore them afterwards."""
    saved = []
    for owner, name, label in stages:
        original = getattr(owner, name)

        def wrapper(*args, _original=original, _label=label, **kwargs):
            start = CLOCK[0]()
            try:
                return _original(*args, **kwargs)
            finally:
                seconds[_label] = seconds.get(_label, 0.0) + CLOCK[0]() - start

        saved.append((owner, name, original))
        setattr(owner, name, functools.wraps(original)(wrapper))
    try:
        yield seconds
    finally:
        for owner, name, original in saved:
            setattr(owner, name, original)


def measure(
    model, formulation: str, calls: int, engine: str = "compiled", t_end: float = 1.0, rtol=1e-6, prepared=False
):
    """(seconds per call, {stage label: seconds per call}, seconds per call with the divergence check, seconds of the
    preparation or None) of the compiled run of ``model``: the stages of one run (``divergence="skip"``), then the
    whole call as a user makes it, whose divergence check (``dynamics.judge_divergence``) may add a second run at
    100 x rtol (its own stages in ``COMPANION``: the companion, and its loop). ``prepared``: each call is ``run`` of
    one ``dynamics.prepare`` (made, with its first run, before the timed calls, and timed apart)."""
    system, q0, qd0 = build_system(load_model(model))
    options = dict(formulation=formulation, integrator="DOP853", rtol=rtol, atol=1e-8, engine=engine)
    first = dynamics.forward_dynamics(system, q0, qd0, t_end, 100, **options)  # compiles or loads the module
    if first.info["chosen"]["engine"] != "compiled":
        raise SystemExit(f"not compiled: {first.info['chosen']['engine_why']}")
    preparation = None
    if prepared:
        start = CLOCK[0]()
        skipping = dynamics.prepare(system, t_end, 100, divergence="skip", **options)
        skipping.run(q0, qd0)  # makes what its runs share (M, forces, the compiled plan and module)
        preparation = CLOCK[0]() - start
        checking = dynamics.prepare(system, t_end, 100, **options)
        checking.run(q0, qd0)
        skipped, checked_call = (lambda: skipping.run(q0, qd0)), (lambda: checking.run(q0, qd0))
    else:
        skipped = lambda: dynamics.forward_dynamics(system, q0, qd0, t_end, 100, divergence="skip", **options)  # noqa: E731
        checked_call = lambda: dynamics.forward_dynamics(system, q0, qd0, t_end, 100, **options)  # noqa: E731
    seconds: dict[str, float] = {}
    gc.collect()  # the garbage of the set-up collected before the timed calls, not by a full collection among them
    with timed(STAGES, seconds):
        start = CLOCK[0]()
        for _ in range(calls):
            skipped()
        total = (CLOCK[0]() - start) / calls
    companion: dict[str, float] = {}
    gc.collect()
    with inside(*COMPANION, companion):
        start = CLOCK[0]()
        for _ in range(calls):
            checked_call()
        checked = (CLOCK[0]() - start) / calls
    seconds.update(companion)
    return total, {label: value / calls for label, value in seconds.items()}, checked, preparation


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", action="append", choices=SCENES, help="only these scenes (repeatable)")
    parser.add_argument("--formulation", default="baumgarte", choices=("baumgarte", "projection", "joint-coordinates"))
    parser.add_argument("--chain", choices=("planar", "spatial", "loops"), help="chains of benchmarks/chains.py")
    parser.add_argument("--sizes", type=int, nargs="+", default=[4, 8, 16], help="chain sizes N (with --chain)")
    parser.add_argument("--calls", type=int, default=20, help="calls timed per case (default 20)")
    parser.add_argument(
        "--engine",
        default="compiled",
        choices=("compiled", "cached", "auto"),
        help="the engine asked for (cached, auto: the start rates before the engine's choice)",
    )
    parser.add_argument(
        "--t-end", type=float, default=1.0, help="simulated seconds (default 1; auto compiles long runs)"
    )
    parser.add_argument("--default-rtol", action="store_true", help="rtol by the rule (eq. 6.60), not 1e-6")
    parser.add_argument("--cpu", action="store_true", help="time this thread's CPU, not the wall (a shared machine)")
    parser.add_argument(
        "--prepared", action="store_true", help="time prepared.run of one dynamics.prepare (its preparation apart)"
    )
    args = parser.parse_args(argv)
    CLOCK[0] = time.thread_time if args.cpu else time.perf_counter
    if args.chain:
        import chains

        make = {"planar": chains.planar_chain, "spatial": chains.spatial_chain, "loops": chains.loop_chain}
        cases = [(f"{args.chain} chain N = {n}", make[args.chain](n)) for n in args.sizes]
    else:
        cases = [(scene, ROOT / "course" / "models" / f"{scene}.yaml") for scene in args.scene or SCENES]
    rtol = None if args.default_rtol else 1e-6
    results = [
        (name, *measure(model, args.formulation, args.calls, args.engine, args.t_end, rtol, args.prepared))
        for name, model in cases
    ]
    setting = (
        f"{args.formulation}, DOP853, {'rtol by the rule' if rtol is None else '1e-6'}, {args.t_end:g} s, 100 outputs, "
        f"engine {args.engine}, {'thread CPU' if args.cpu else 'wall'}"
    )
    call = "prepared.run" if args.prepared else "compiled call"
    print(f"## Cost of a {call} by stage, ms per call ({setting})\n")
    print("| stage | " + " | ".join(name for name, *_ in results) + " |")
    print("|---|" + "---:|" * len(results))
    print("| **whole call** | " + " | ".join(f"**{total * 1e3:.2f}**" for _, total, *_ in results) + " |")
    loop = "    integration loop"
    outside = [total - stages.get(loop, 0.0) for _, total, stages, *_ in results]
    print("| **outside the loop** | " + " | ".join(f"**{value * 1e3:.2f}**" for value in outside) + " |")
    print("| whole call with the divergence check | " + " | ".join(f"{c * 1e3:.2f}" for *_, c, _ in results) + " |")
    if args.prepared:  # prepare() and the first run, which makes what the runs share
        print("| preparation (prepare + first run) | " + " | ".join(f"{p * 1e3:.2f}" for *_, p in results) + " |")
    for label in dict.fromkeys(label for _, _, label in STAGES + COMPANION):  # each once (two stages may share one)
        cells = [_milliseconds(stages[label]) if label in stages else "-" for _, _, stages, *_ in results]
        print(f"| {label.replace('  ', '&nbsp;&nbsp;')} | " + " | ".join(cells) + " |")


def _milliseconds(seconds: float) -> str:
    """A stage's time in ms to the microsecond, and a stage under half a microsecond (the efforts of a scene without
    drivers) to two significant figures: a stage that ran never reads 0.000."""
    value = seconds * 1e3
    return f"{value:.3f}" if value >= 0.01 or value == 0.0 else f"{value:.2g}"


if __name__ == "__main__":
    main()
