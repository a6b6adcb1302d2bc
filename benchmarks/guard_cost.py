"""The Guard's checks at the output times of a compiled run on the loop chain, part by part (issue 25, item 2).

``guard.Guard.check_outputs`` judges, at the 101 output times of a compiled run, the drift and the nearness to
a singular position from Psi and the history of Psi_q (N, m, n) that the run wrote: the rows' norms (scaling and
drift), the pattern of Psi_q and its band ordering, the first output time's null-space basis, then, time by time
(``compiled.singular._spectra``), sigma_m / sigma_1 from the Gram matrix's extreme eigenvalues and the null space
and sign from the banded LU. Each part is timed inside real calls (``forward_dynamics`` on
``chains.loop_chain(N)``, joint coordinates, DOP853 at 1e-6, 1 s, 100 output intervals: as ``call_cost.py``) by
wrapping the functions that make it, those that exist in the checkout (a branch before this script had other
parts: the dense ``row_norms`` and ``_pattern`` passes, ``band_order`` at every call, a QR for the first basis).
Milliseconds per call, thread CPU, the mean of ``--calls`` calls after one warm-up call. Parts nest (``spectra``
holds ``_spectra``): the rows do not add up.

    .venv/bin/python benchmarks/guard_cost.py --sizes 16 64
    .venv/bin/python benchmarks/guard_cost.py --routes --sizes 2 4 8 16

``--routes``: each route of ``guard.square_spectra`` on the first history of Psi_q a run's Guard judges (numpy's
batched SVDs and QRs, the compiled one-pass ``singular.dense_spectra``, the compiled band ``singular.spectra``, its
ratios closed or settled by the Guard's tests), ms per history, thread CPU, the best of 3 rounds of 10 after one
warm-up; "-" where the band is wider than n / 2. How ``guard._compiled_spectra`` picks its route (issue 25, item 2).

``--small``: the compiled route of a small Psi_q (``singular.dense_spectra``, up to ``guard.DENSE_LARGEST`` rows)
on the first history of Psi_q the Guard judges in each course model's compiled run (Baumgarte's formulation and
joint coordinates), closed (Jacobi at every time) against settled (brackets, Jacobi where the Guard's tests need it:
what the Guard takes), ms per history, thread CPU, as ``--routes``; the times left to Jacobi after the brackets.

``--verdicts FILE``: what the Guard decided and reported on every course model (``course/models``) and loop chain
(N = 2, 4, 8, 16), compiled, 1 s and 100 output intervals, in Baumgarte's formulation and in joint coordinates where
the model has them: the closest ratio and its time, the singular positions passed with their figures and verdicts,
the error a run stopped with, and whether the band route (``singular.spectra``) judged it; one JSON line per run
into FILE, to compare two checkouts line by line (``diff``; the figures printed with every digit).

Nothing is asserted (timing depends on the machine): prints a Markdown table.
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT.parent))
sys.path.insert(0, str(ROOT))

import chains  # noqa: E402
import numpy as np  # noqa: E402

from solutions import dynamics, guard  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.compiled import singular  # noqa: E402
from solutions.compiled.history import BlockedJacobians  # noqa: E402
from solutions.io import load_model  # noqa: E402

PARTS = (
    (guard.Guard, "check_outputs", "checks at the output times (Guard)"),
    (singular, "row_norms", "  rows' norms: dense pass over the history"),
    (singular, "history_norms", "  rows' norms and pattern: the bodies' columns"),
    (singular, "_pattern", "  pattern: dense pass over the history"),
    (singular, "spectra", "  band spectra (singular.spectra)"),
    (singular, "band_order", "    band ordering (reverse Cuthill-McKee)"),
    (singular, "_band_structure", "    band ordering (kept per pattern)"),
    (guard, "null_space_bases", "    first basis: dense QR"),
    (singular, "_first_basis", "    first basis: banded LU of Psi_q^T"),
    (singular, "_band_start", "    first basis and the band's widths: one compiled call"),
    (singular, "_spectra", "    time by time: ratio, basis, sign"),
    (singular, "_settled_spectra", "    time by time, the ratios settled: one compiled call"),
    (guard.Guard, "_quiet", "  verdicts (_quiet)"),
)
"""(owner, attribute, label) of each part timed, where the checkout has it."""


def measure(n_loops: int, calls: int) -> dict[str, float]:
    """{label: milliseconds per call} of the Guard's parts in ``calls`` compiled runs of the chain of n_loops."""
    system, q0, qd0 = build_system(load_model(chains.loop_chain(n_loops)))
    options = dict(formulation="joint-coordinates", integrator="DOP853", rtol=1e-6, atol=1e-8, engine="compiled")
    dynamics.forward_dynamics(system, q0, qd0, 1.0, 100, divergence="skip", **options)  # compiles or loads
    seconds: dict[str, float] = {}
    saved = []
    for owner, name, label in PARTS:
        if not hasattr(owner, name):
            continue
        original = getattr(owner, name)

        def timed(*args, _original=original, _label=label, **kwargs):
            start = time.thread_time()
            try:
                return _original(*args, **kwargs)
            finally:
                seconds[_label] = seconds.get(_label, 0.0) + time.thread_time() - start

        saved.append((owner, name, original))
        setattr(owner, name, timed)
    try:
        for _ in range(calls):
            dynamics.forward_dynamics(system, q0, qd0, 1.0, 100, divergence="skip", **options)
    finally:
        for owner, name, original in saved:
            setattr(owner, name, original)
    return {label: value / calls * 1e3 for label, value in seconds.items()}


def _per_history(run, repeats: int = 10) -> float:
    """Milliseconds of thread CPU per call of ``run``: the best of 3 rounds of ``repeats`` after one warm-up."""
    run()
    rounds = []
    for _ in range(3):
        start = time.thread_time()
        for _ in range(repeats):
            run()
        rounds.append((time.thread_time() - start) / repeats * 1e3)
    return min(rounds)


def routes(n_loops: int) -> tuple[tuple[int, int], dict[str, float | None]]:
    """((m, n), {route: ms per history}) of ``square_spectra``'s routes on the first history of Psi_q (101 output
    times) that a compiled run's Guard judges on the chain of n_loops."""
    system, q0, qd0 = build_system(load_model(chains.loop_chain(n_loops)))
    histories, square_spectra = [], guard.square_spectra

    def kept(jacobians, columns, norms, before, *args):
        held = jacobians  # a dense history, or one by its rows' blocks (``history.BlockedJacobians``, from N = 8)
        held = BlockedJacobians(held.values.copy(), held.columns, held.n) if hasattr(held, "values") else held.copy()
        histories.append((held, columns.copy(), norms.copy(), before))
        return square_spectra(jacobians, columns, norms, before, *args)

    guard.square_spectra = kept
    try:
        options = dict(formulation="joint-coordinates", integrator="DOP853", rtol=1e-6, atol=1e-8, engine="compiled")
        dynamics.forward_dynamics(system, q0, qd0, 1.0, 100, divergence="skip", **options)
    finally:
        guard.square_spectra = square_spectra
    jacobians, columns, norms, before = histories[0]
    dense = np.asarray(jacobians)  # numpy's and the dense route's input; the band reads the history as the run wrote it

    def numpy_route():
        scaled = guard.scale_rows(dense, columns, norms)
        guard.null_space_bases(scaled, signs=True)
        np.linalg.svd(scaled, compute_uv=False)

    band = lambda: singular.spectra(jacobians, before, columns, norms, None, singular.WIDEST_MID)  # noqa: E731
    settle = ((1e-8, guard.NEAR_SINGULAR), guard.FALL)  # the Guard's tests (Guard._spectra)
    settled = lambda: singular.spectra(jacobians, before, columns, norms, None, singular.WIDEST_MID, settle)  # noqa: E731
    return jacobians.shape[1:], {
        "numpy batched": _per_history(numpy_route),
        "compiled dense": _per_history(lambda: singular.dense_spectra(dense, columns, norms)),
        "compiled band": None if band() is None else _per_history(band),
        "compiled band, settled": None if band() is None or not hasattr(singular, "settled") else _per_history(settled),
    }


def print_routes(sizes: list[int]) -> None:
    """A Markdown table of ``routes`` at each size."""
    results = [routes(n) for n in sizes]
    print("## square_spectra's routes on a run's history of Psi_q, ms per 101 Psi_q (loop chain, thread CPU)\n")
    print(
        "| route | " + " | ".join(f"N = {n} ({m} x {c})" for n, ((m, c), _) in zip(sizes, results, strict=True)) + " |"
    )
    print("|---|" + "---:|" * len(sizes))
    for route in results[0][1]:
        cells = ["-" if r[route] is None else f"{r[route]:.2f}" for _, r in results]
        print(f"| {route} | " + " | ".join(cells) + " |")


def print_small() -> None:
    """``--small``: a Markdown table (module docstring)."""
    import glob

    histories, dense = [], singular.dense_spectra

    def kept(jacobians, columns, norms, *args, **kwargs):
        histories.append((np.array(jacobians), np.array(columns), np.array(norms)))
        return dense(jacobians, columns, norms, *args, **kwargs)

    singular.dense_spectra = kept
    rows = []
    try:
        for source in sorted(glob.glob(str(ROOT.parent / "course/models/*.yaml"))):
            system, q0, qd0 = build_system(load_model(source))
            for formulation in ("baumgarte", "joint-coordinates"):
                histories.clear()
                options = dict(formulation=formulation, rtol=1e-6, atol=1e-8, engine="compiled", divergence="skip")
                try:
                    dynamics.forward_dynamics(system, q0, qd0, 1.0, 100, **options)
                except Exception:  # noqa: BLE001, S112 -- a formulation the model cannot take, or a stop: no row
                    continue
                if histories:
                    rows.append((Path(source).stem, formulation, histories[0]))
    finally:
        singular.dense_spectra = dense
    settle = ((1e-8, guard.NEAR_SINGULAR), guard.FALL)  # the Guard's tests (Guard._spectra, default ratio)
    print("## dense_spectra on each course model's history of Psi_q, ms per 101 Psi_q (thread CPU)\n")
    print("| model | formulation | m x n | closed | settled | settled / closed | Jacobi after brackets |")
    print("|---|---|---|---:|---:|---:|---:|")
    for name, formulation, (jacobians, columns, norms) in rows:
        closed = _per_history(lambda: dense(jacobians, columns, norms))  # noqa: B023
        settled = _per_history(lambda: dense(jacobians, columns, norms, settle=settle))  # noqa: B023
        figures, _, signs, lower = singular._dense_bracketed(jacobians, columns, norms, True, singular.LOOSE)
        tests = (*singular._tests(settle), True)  # every two neighbours ordered, as dense_spectra does
        left = (lower == figures).sum() + singular._unsettled(lower, figures, signs, *tests).size
        left = "all" if jacobians.shape[1] < singular.BRACKETED_SMALLEST else left
        size = "x".join(map(str, jacobians.shape[1:]))
        print(f"| {name} | {formulation} | {size} | {closed:.3f} | {settled:.3f} | {settled / closed:.2f} | {left} |")


def verdicts(path: str, sizes: list[int]) -> None:
    """``--verdicts``: one JSON line per run (module docstring) into ``path``."""
    import glob
    import json

    band, spectra = [], singular.spectra

    def counted(*args, **kwargs):
        made = spectra(*args, **kwargs)
        band.append(made is not None)
        return made

    singular.spectra = counted
    models = [(Path(p).stem, p) for p in sorted(glob.glob(str(ROOT.parent / "course/models/*.yaml")))]
    models += [(f"loops{n}", chains.loop_chain(n)) for n in sizes]
    with open(path, "w") as out:
        for name, source in models:
            system, q0, qd0 = build_system(load_model(source))
            for formulation in ("baumgarte", "joint-coordinates"):
                band.clear()
                options = dict(formulation=formulation, rtol=1e-6, atol=1e-8, engine="compiled", divergence="skip")
                line = {"model": name, "formulation": formulation}
                try:
                    info = dynamics.forward_dynamics(system, q0, qd0, 1.0, 100, **options).info
                    line["closest"] = info.get("closest_singularity")
                    line["crossings"] = info.get("singular_positions")
                except Exception as err:  # noqa: BLE001 -- the stop is the verdict compared
                    line["error"] = f"{type(err).__name__}: {err}"
                line["band"] = any(band)
                out.write(json.dumps(line, default=repr) + "\n")
                print(name, formulation, line.get("error", "")[:80], "band" if line["band"] else "", flush=True)
    singular.spectra = spectra


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[16, 64], help="loops N of the chain")
    parser.add_argument("--calls", type=int, default=5, help="calls timed per size (default 5)")
    parser.add_argument("--routes", action="store_true", help="time square_spectra's routes instead")
    parser.add_argument("--small", action="store_true", help="time dense_spectra closed and settled per model")
    parser.add_argument("--verdicts", metavar="FILE", help="the Guard's verdicts and figures on every run into FILE")
    args = parser.parse_args(argv)
    if args.verdicts:
        return verdicts(args.verdicts, args.sizes)
    if args.small:
        return print_small()
    if args.routes:
        return print_routes(args.sizes)
    results = [measure(n, args.calls) for n in args.sizes]
    print("## The Guard's checks at the output times by part, ms per call (loop chain, joint coordinates, CPU)\n")
    print("| part | " + " | ".join(f"N = {n}" for n in args.sizes) + " |")
    print("|---|" + "---:|" * len(args.sizes))
    for _, _, label in PARTS:
        if any(label in result for result in results):
            name = label.replace("  ", "&nbsp;&nbsp;")
            print(f"| {name} | " + " | ".join(f"{r[label]:.3f}" if label in r else "-" for r in results) + " |")


if __name__ == "__main__":
    main()
