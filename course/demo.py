"""``make demo``: the course's main job on its own data.

Runs every example model in course/models/ with the analysis it needs (kinematic when its drivers leave
no degree of freedom, dynamic otherwise), writes each result as CSV and a plot of its coordinates, and
prints a table saying where every output is.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from solutions.assembly import build_system
from solutions.cli import analysis_settings, choose_analysis, run_analysis
from solutions.diagnostics import AnalysisError
from solutions.io.model import ModelError, load_model
from solutions.io.results import write_csv
from solutions.kinematics import assemble
from solutions.plotting import plot_result

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "course" / "models"


def run_examples(out: Path) -> list[dict]:
    """Run every example model; return one row per model for the summary table."""
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for path in sorted(MODELS.glob("*.yaml")):
        row = {"model": path.name}
        start = time.perf_counter()
        try:
            model = load_model(path)
            system, q0, qd0 = build_system(model)
            settings = analysis_settings(model)
            if settings["analysis"] == "auto":
                settings["analysis"] = choose_analysis(system, assemble(system, q0)[0])
            analysis = settings["analysis"]
            result = run_analysis(system, q0, qd0, settings)
            csv = write_csv(result, out / f"{path.stem}.csv")
            png = plot_result(result, out / f"{path.stem}.png")
            row.update(analysis=analysis, status="ok", outputs=f"{csv.name}, {png.name}")
        except (ModelError, AnalysisError, ImportError) as err:
            row.update(analysis="-", status=f"failed: {err}", outputs="-")
        row["seconds"] = time.perf_counter() - start
        rows.append(row)
    return rows


def main() -> int:
    out = ROOT / "out" / "demo"
    print(f"Running the example mechanisms of {MODELS.relative_to(ROOT)}/ ...")
    rows = run_examples(out)
    width = max(len(r["model"]) for r in rows)
    print(f"\n{'model':<{width}}  {'analysis':<9}  {'time':>7}  outputs")
    for r in rows:
        print(f"{r['model']:<{width}}  {r['analysis']:<9}  {r['seconds']:6.2f}s  {r['outputs']}  {r['status']}")
    print(f"\nResults (CSV) and plots (PNG) are in {out}")
    failed = [r for r in rows if r["status"] != "ok"]
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
