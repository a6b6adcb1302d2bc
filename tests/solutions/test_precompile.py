"""``mbd compile`` (solutions/compiled/precompile.py): the engine compiled once per machine from two pendulums, after
which every course model of either dimension runs on machine code from disk, in any compiled formulation and in
kinematic analysis, with nothing compiled.

Both steps run as new processes, as a user meets them: ``mbd compile``, then the course's models with
``engine="cached"`` (the compiled engine only where its code is on disk, else numpy, saying why). The run's compiled
cache (``tests/conftest.py``) may hold some modules already; the command says which it found.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from solutions.compiled.precompile import FORMULATIONS, PENDULUMS

pytest.importorskip("numba")

REPO = Path(__file__).resolve().parents[2]

RUNS = """
import glob, json, sys
from solutions.analysis import choose_analysis
from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.io import load_model
from solutions.kinematics import kinematic_analysis
seen = {}
for path in sorted(glob.glob("course/models/*.yaml")):
    name = path.split("/")[-1][:-5]
    model = load_model(path)
    system, q0, qd0 = build_system(model)
    if choose_analysis(system, q0) == "kinematic":  # by rank, as mbd run (redundant joints miscount n - m)
        run = kinematic_analysis(system, q0, 0.1, 4, engine="cached")
        seen[name + ":kinematic"] = [model.dimension, run.info["chosen"], True]
        continue
    for formulation in sys.argv[1:]:
        try:
            run = forward_dynamics(system, q0, qd0, 0.02, 2, formulation=formulation, integrator="DOP853",
                                   rtol=1e-6, atol=1e-8, engine="cached")
        except Exception as err:  # a formulation the model does not take (numpy says so as well)
            seen[f"{name}:{formulation}"] = [model.dimension, {"engine": "none", "engine_why": repr(err)}, None]
            continue
        cached = run.info.get("compiled", {}).get("cached")
        seen[f"{name}:{formulation}"] = [model.dimension, run.info["chosen"], cached]
from numba.core.registry import CPUDispatcher
kernels = ("element_history_kernels", "spatial_element_history_kernels")
histories = [sys.modules.get(f"solutions.compiled.{m}") for m in kernels]
compiled_here = sorted(  # what the output times' element loops compiled in this process (nothing: all on disk)
    name for module in histories if module is not None for name, f in vars(module).items()
    if isinstance(f, CPUDispatcher) and sum(f.stats.cache_misses.values())
)
print(json.dumps({"runs": seen, "imported": [m is not None for m in histories], "compiled": compiled_here}))
"""


def _run(*args: str) -> subprocess.CompletedProcess:
    environment = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run(
        [sys.executable, *args], cwd=REPO, env=environment, capture_output=True, text=True, timeout=900
    )


@pytest.fixture(scope="module")
def compiled_then_run():
    done = _run("-m", "solutions.cli", "compile", "--quiet")
    assert done.returncode == 0, done.stderr
    runs = _run("-c", RUNS, *FORMULATIONS)
    assert runs.returncode == 0, runs.stderr
    found = json.loads(runs.stdout.strip().splitlines()[-1])
    return done.stdout, found["runs"], found


def test_mbd_compile_names_every_part_and_where_it_is(compiled_then_run):
    out, _, _ = compiled_then_run
    lines = out.strip().splitlines()
    parts = ["integrator and kinematic loops"] + [
        f"{dimension} {what}" for dimension in PENDULUMS for what in (*FORMULATIONS, "kinematic")
    ]
    assert [line[:32].strip() for line in lines[:-1]] == parts
    assert all(line.rstrip().endswith(("compiled", "on disk already")) for line in lines[:-1])
    assert lines[-1].startswith("the engine is compiled (") and lines[-1].endswith(os.environ["MBD_COMPILED_CACHE"])


def test_after_it_every_course_model_runs_on_the_cached_engine(compiled_then_run):
    """Every model of course/models in every compiled formulation it takes, and every kinematic one: the compiled
    engine, its code loaded from disk (the kernels cover every element the course's models use)."""
    _, seen, _ = compiled_then_run
    refused = sorted(key for key, (_, chosen, _) in seen.items() if chosen["engine"] == "none")
    redundant = [f"parallel_swing:{formulation}" for formulation in sorted(FORMULATIONS)]  # none takes its extra arm
    assert refused == sorted(["cylindrical:joint-coordinates", "quarter_car:joint-coordinates", *redundant])
    assert all("redundant constraint equation(s)" in seen[key][1]["engine_why"] for key in redundant)
    assert all("cannot take this scene" in seen[key][1]["engine_why"] for key in refused if key not in redundant)
    for key, (_, chosen, cached) in seen.items():
        if key not in refused:
            assert chosen == {"engine": "compiled", "engine_why": "compiled code for this scene's dimension is cached"}
            assert cached is True, key  # loaded from disk: nothing compiled in that process
    dimensions = {dimension for key, (dimension, _, _) in seen.items() if key not in refused}
    kinematic = {seen[key][0] for key in seen if key.endswith(":kinematic")}
    assert dimensions == kinematic == {2, 3} and len(seen) >= 40


def test_the_element_loops_of_the_output_times_come_from_disk_too(compiled_then_run):
    """The course's models with springs and loads (both dimensions) report their force elements' columns from the
    compiled element loops (``compiled.element_history``), which ``mbd compile`` made: none compiled by a run."""
    _, _, found = compiled_then_run
    assert found["imported"] == [True, True]
    assert found["compiled"] == []
