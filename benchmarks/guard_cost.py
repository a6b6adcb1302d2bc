"""The Guard's checks at the output times of a compiled run on the loop chain, part by part (issue 25, item 2).

``dynamics.Guard.check_outputs`` judges, at the 101 output times of a compiled run, the drift and the nearness to
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

from solutions import dynamics  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.compiled import singular  # noqa: E402
from solutions.io import load_model  # noqa: E402

PARTS = (
    (dynamics.Guard, "check_outputs", "checks at the output times (Guard)"),
    (singular, "row_norms", "  rows' norms: dense pass over the history"),
    (singular, "history_norms", "  rows' norms and pattern: the bodies' columns"),
    (singular, "_pattern", "  pattern: dense pass over the history"),
    (singular, "spectra", "  band spectra (singular.spectra)"),
    (singular, "band_order", "    band ordering (reverse Cuthill-McKee)"),
    (singular, "_band_structure", "    band ordering (kept per pattern)"),
    (dynamics, "null_space_bases", "    first basis: dense QR"),
    (singular, "_first_basis", "    first basis: banded LU of Psi_q^T"),
    (singular, "_spectra", "    time by time: ratio, basis, sign"),
    (dynamics.Guard, "_quiet", "  verdicts (_quiet)"),
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


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[16, 64], help="loops N of the chain")
    parser.add_argument("--calls", type=int, default=5, help="calls timed per size (default 5)")
    args = parser.parse_args(argv)
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
