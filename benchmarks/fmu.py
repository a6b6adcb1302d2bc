"""The FMU of every example, simulated by fmpy against ``mbd run`` (issue 28).

For each model of ``course/models/``: ``export_fmu`` builds its FMU (solutions/io/fmu.py), fmpy simulates it over
the file's span at the file's output interval (its default experiment), and ``mbd run --engine numpy --out
FILE.csv`` runs the file. Columns of the table:

- build: CPU seconds of ``export_fmu`` (the model started once to refuse what the FMU could not run, the FMU
  written); simulate: wall and CPU seconds of ``fmpy.simulate_fmu`` in this process (the solver is imported
  already; a fresh process adds the imports, about a second); mbd run: CPU seconds of the same run by ``mbd run``;
- rtol: the FMU's parameter rtol (the file's simulation.rtol, or mbd run's rule for it), or "kinematic" for a
  model whose drivers leave no degree of freedom (the FMU steps mbd run's kinematic analysis);
- positions: max |FMU - CSV| over the coordinate columns (m, rad, Euler parameters);
- all: max |FMU - CSV| over every column, and the column; relative: the same, each column's difference divided
  by max(1, its largest magnitude).

For forward dynamics the difference is the integrator's restart at every communication point (the FMU's) against
one continuous run with dense output at the output times (mbd run's): both within the tolerance, so it is of the
order of rtol times the size of the column; a kinematic analysis takes the same steps as mbd run's. Models the
exporter refuses are listed. This is a measurement, not a test. Run::

    .venv/bin/python benchmarks/fmu.py                       # every example, about a minute
    .venv/bin/python benchmarks/fmu.py double_pendulum andrews
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from solutions import cli  # noqa: E402
from solutions.io.fmu import FmuError, export_fmu, fmi_name  # noqa: E402
from solutions.io.results import read_csv  # noqa: E402

COORDINATES = ("x", "y", "z", "phi", "e0", "e1", "e2", "e3")


def measure(model: Path, folder: Path) -> dict | str:
    """One model's row, or the exporter's refusal."""
    from fmpy import read_model_description, simulate_fmu

    start = time.process_time()
    try:
        fmu = export_fmu(model, folder / f"{model.stem}.fmu")
    except FmuError as err:
        return str(err)
    build = time.process_time() - start
    simulation = yaml.safe_load(model.read_text())["simulation"]
    span, steps = simulation["end_time"], simulation["output_steps"]
    start = time.process_time()
    with contextlib.redirect_stdout(io.StringIO()):
        assert cli.main(["run", str(model), "--engine", "numpy", "--out", str(folder / f"{model.stem}.csv")]) == 0
    mbd = time.process_time() - start
    csv = read_csv(folder / f"{model.stem}.csv")
    wall, cpu = time.perf_counter(), time.process_time()
    result = simulate_fmu(str(fmu), stop_time=span, output_interval=span / steps)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    found = {k: float(np.max(np.abs(result[fmi_name(k)] - v))) for k, v in csv.items() if k != "t"}
    relative = {k: d / max(1.0, float(np.max(np.abs(csv[k])))) for k, d in found.items()}
    positions = max(d for k, d in found.items() if k.rsplit(".", 1)[-1] in COORDINATES)
    rtol = next((v.start for v in read_model_description(str(fmu)).modelVariables if v.name == "rtol"), None)
    worst, worst_relative = max(found, key=found.get), max(relative, key=relative.get)
    return {
        "build": build, "wall": wall, "cpu": cpu, "mbd": mbd, "positions": positions,
        "rtol": "kinematic" if rtol is None else f"{float(rtol):.0e}",
        "all": f"{found[worst]:.1e} ({worst})", "relative": f"{relative[worst_relative]:.1e} ({worst_relative})",
    }  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("models", nargs="*", help="model names in course/models (default: every one)")
    args = parser.parse_args(argv)
    names = args.models or sorted(p.stem for p in (ROOT / "course" / "models").glob("*.yaml"))
    print("| model | build (s CPU) | simulate (s wall / CPU) | mbd run (s CPU) | rtol | positions | all | relative |")
    print("|---|---|---|---|---|---|---|---|")
    refused = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            row = measure(ROOT / "course" / "models" / f"{name}.yaml", Path(tmp))
            if isinstance(row, str):
                refused.append(name)
                continue
            print(
                f"| {name} | {row['build']:.2f} | {row['wall']:.2f} / {row['cpu']:.2f} | {row['mbd']:.2f} | "
                f"{row['rtol']} | {row['positions']:.1e} | {row['all']} | {row['relative']} |",
                flush=True,
            )
    if refused:
        print(f"\nRefused by the exporter: {', '.join(refused)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
