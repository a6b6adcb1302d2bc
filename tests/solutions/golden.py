"""Golden summaries of the example models: every ``course/models`` file run as ``mbd run MODEL --engine numpy``
runs it (its own ``simulation`` block), summarised by ``Result.summary`` (final state, max |lambda| and reaction,
largest constraint residual, energy drift) and kept in ``golden_summaries.json``.

``tests/solutions/test_golden.py`` runs each model again and compares; after a change that is meant to change a
result, regenerate the file with one command and review its diff:

    make golden        # = python tests/solutions/golden.py

Each summary is checked against the physics when it is written (``check``): the constraint residual is at the
solver's tolerance and a dynamic run keeps its energy balance (kinetic + potential energy against the work of
dampers, actuators, loads and drivers).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MODELS = sorted((ROOT / "course" / "models").glob("*.yaml"))
GOLDEN = Path(__file__).with_name("golden_summaries.json")
if str(ROOT) not in sys.path:  # run as a script (make golden)
    sys.path.insert(0, str(ROOT))

RESIDUAL_LIMIT = 1e-6
"""The largest constraint residual |Psi| a summary may record (the example models hold theirs to about 1e-8)."""
ENERGY_LIMIT = 1e-4
"""The largest energy error |E(t) - E(0)| in J a summary may record, E the balance of kinetic and potential energy
with the work of dampers, actuators, loads and drivers (``energy.py``): the example models keep it under 1e-5 J."""


def summarize(path: Path) -> dict[str, float]:
    """The summary of ``mbd run PATH --engine numpy``."""
    from solutions.analysis import run_analysis
    from solutions.assembly import build_system
    from solutions.io.model import load_model
    from solutions.settings import read_settings

    model = load_model(path)
    system, q0, qd0 = build_system(model)
    return run_analysis(system, q0, qd0, read_settings(model.simulation, engine="numpy")).summary()


def check(name: str, summary: dict[str, float]) -> list[str]:
    """What is physically wrong with a summary (empty when nothing): a residual over RESIDUAL_LIMIT, an energy
    error over ENERGY_LIMIT."""
    residual, drift = summary.get("max_constraint_residual", 0.0), summary.get("energy_drift", 0.0)
    problems = [f"{name}: constraint residual {residual:.3g} > {RESIDUAL_LIMIT:g}"] if residual > RESIDUAL_LIMIT else []
    return problems + ([f"{name}: energy error {drift:.3g} J > {ENERGY_LIMIT:g} J"] if drift > ENERGY_LIMIT else [])


def main() -> int:
    summaries, problems = {}, []
    for path in MODELS:
        summaries[path.stem] = summary = summarize(path)
        problems += check(path.stem, summary)
        print(f"{path.stem}: {len(summary)} numbers", flush=True)
    if problems:
        print("\n".join(["not written:", *problems]), file=sys.stderr)
        return 1
    GOLDEN.write_text(json.dumps(summaries, indent=1, sort_keys=True) + "\n")
    print(f"written {GOLDEN.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
