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


def run_in_a_new_process(*args: str, then: str = "") -> tuple[int, set[str], str, str]:
    """``mbd run ARGS`` in a fresh process: its exit code, the top-level packages (and scipy's subpackages) in
    sys.modules after it, its standard error, and what the statement ``then`` run after it printed."""
    script = (
        "import contextlib, io, json, sys\n"
        "from solutions.cli import main\n"
        f"code = main({['run', *args]!r})\n"
        "names = {m.split('.')[0] for m in sys.modules} | {'.'.join(m.split('.')[:2]) for m in sys.modules}\n"
        "after = io.StringIO()\n"
        "with contextlib.redirect_stdout(after):\n"
        f"    exec({then!r})\n"
        "print(json.dumps({'code': code, 'modules': sorted(names), 'then': after.getvalue()}))\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=ROOT, env=env)
    report = json.loads(out.stdout.strip().splitlines()[-1])
    return report["code"], set(report["modules"]), out.stderr, report["then"]


def modules_after_run(*args: str) -> set[str]:
    """The top-level packages (and scipy's subpackages) in sys.modules after a successful ``mbd run ARGS``."""
    code, modules, err, _ = run_in_a_new_process(*args)
    assert code == 0, err
    return modules


@pytest.mark.parametrize(
    ("args", "integrate"),
    [
        (("slider_crank.yaml",), False),  # kinematic
        (("double_pendulum.yaml", "--integrator", "rk4"), False),  # this package's RK4
        (("double_pendulum.yaml", "--engine", "numpy"), True),  # the file's DOP853: scipy's solve_ivp
        (("double_pendulum.yaml",), True),  # engine auto: numpy for a run this short
        (("spatial_double_pendulum.yaml", "--integrator", "dop853"), False),  # this package's loop and tableau
    ],
)
def test_a_numpy_run_imports_only_what_it_uses(args, integrate):
    model, *options = args
    modules = modules_after_run(str(MODELS / model), "--steps", "1", "--t-end", "0.01", *options)
    assert "solutions.cli" in modules and "numpy" in modules  # the report holds what the run imported
    assert sorted(set(NEVER) & modules) == []
    assert ("scipy.integrate" in modules) == integrate


def test_an_invalid_file_is_explained_without_the_slow_format_backends(tmp_path):
    """jsonschema explains an invalid file, imported without rfc3987_syntax (it builds a grammar for a second;
    the schema checks no formats): one clear message and exit code 2 as before, and the package can still
    be imported afterwards by whoever needs it."""
    text = (MODELS / "double_pendulum.yaml").read_text().replace("{name: upper, mass:", "{name: upper, mas:")
    path = tmp_path / "misspelt.yaml"
    path.write_text(text)
    then = "import importlib.util; print(importlib.util.find_spec('rfc3987_syntax') is not None)"
    code, modules, err, installed = run_in_a_new_process(str(path), "--steps", "1", then=then)
    assert code == 2
    assert err == "mbd: error: misspelt.yaml: model.bodies[0].mas: unknown key 'mas' (did you mean 'mass'?)\n"
    assert "jsonschema" in modules and "rfc3987_syntax" not in modules
    if installed.strip() == "True":  # held back only while jsonschema is imported
        _, _, _, imported = run_in_a_new_process(str(path), then="import rfc3987_syntax; print('ok')")
        assert imported.strip() == "ok"
