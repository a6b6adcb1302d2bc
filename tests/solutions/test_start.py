"""The start of ``mbd run``: a run imports what it uses and nothing more (issue 16, item 3).

Start-up time itself is measured by benchmarks/start.py, never asserted here; what is checked is which
modules a run leaves in ``sys.modules``: numba (the compiled engine), matplotlib (plots, animations), dask
and tqdm (sweeps, grading) and jsonschema (explains an invalid file) must not be imported by a numpy run of
a valid file, and scipy.integrate only by a run whose integrator is one of scipy's.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "course" / "models"
NEVER = ("numba", "llvmlite", "matplotlib", "dask", "distributed", "tqdm", "jsonschema", "sympy")
"""Packages a numpy run of a valid model file does not use."""


def modules_after_run(*args: str) -> set[str]:
    """The top-level packages (and scipy's subpackages) in sys.modules after ``mbd run ARGS`` in a fresh process."""
    script = (
        "import json, sys\n"
        "from solutions.cli import main\n"
        f"code = main({['run', *args]!r})\n"
        "names = {m.split('.')[0] for m in sys.modules} | {'.'.join(m.split('.')[:2]) for m in sys.modules}\n"
        "print(json.dumps({'code': code, 'modules': sorted(names)}))\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=ROOT, env=env)
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert report["code"] == 0, out.stderr
    return set(report["modules"])


@pytest.mark.parametrize(
    ("args", "integrate"),
    [
        (("slider_crank.yaml",), False),  # kinematic
        (("double_pendulum.yaml", "--integrator", "rk4"), False),  # this package's RK4
        (("double_pendulum.yaml", "--engine", "numpy"), True),  # the file's DOP853: scipy's solve_ivp
        (("double_pendulum.yaml",), True),  # engine auto: numpy for a run this short
        (("spatial_double_pendulum.yaml", "--integrator", "dop853"), True),  # this package's loop, scipy's tableau
    ],
)
def test_a_numpy_run_imports_only_what_it_uses(args, integrate):
    model, *options = args
    modules = modules_after_run(str(MODELS / model), "--steps", "1", "--t-end", "0.01", *options)
    assert "solutions.cli" in modules and "numpy" in modules  # the report holds what the run imported
    assert sorted(set(NEVER) & modules) == []
    assert ("scipy.integrate" in modules) == integrate
