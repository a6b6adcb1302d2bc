"""The compiled engine agrees with the numpy engine on every example model and every benchmark scene (issue 16).

Every model of ``course/models`` runs dynamically (the driven ones too: their drivers are constraints with
Lagrange multipliers, the motor forces) with the Baumgarte formulation and DOP853 at rtol = 1e-10 on both
engines; the compiled run must give the same trajectories q, q' and the same q'', lambda to 1e-8 of their
size, the same constraint residuals, energies and reactions, the same steps and warnings. The benchmark
scenes of ``benchmarks/bench.py`` are example models except the free slider-crank, which is run too.

The model is data: every scene of a dimension runs on one compiled module (every kernel of the dimension, each
called when the scene has its elements), so the 27 scenes share two modules, compiled once per machine. Short
runs (0.3 s, Andrews' mechanism its 0.03 s).
"""

import sys
from pathlib import Path

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.diagnostics import rank_at
from solutions.dynamics import forward_dynamics
from solutions.io import load_model

pytest.importorskip("numba")

ROOT = Path(__file__).resolve().parents[2]
MODELS = sorted(path.stem for path in (ROOT / "course" / "models").glob("*.yaml"))
T_END, STEPS = 0.3, 30
AT_REST = {"quarter-car"}
"""Scenes that start at rest in equilibrium: the first error estimates are rounding noise, so the two engines'
rounding picks different steps (51 and 48 for the quarter car) while the trajectories still agree to 1e-10."""
PLANET_IN_RING = {
    "model": {
        "name": "planet-in-ring",
        "dimension": 2,
        "gravity": [0.0, -9.81],
        "bodies": [
            {"name": "arm", "mass": 0.3, "inertia": 4e-4, "location": [0.03, 0.0], "angular_velocity": 30.0},
            {"name": "planet", "mass": 0.2, "inertia": 1.6e-4, "location": [0.06, 0.0]},
        ],
        "joints": [
            {"name": "pivot", "type": "revolute", "body1": "ground", "body2": "arm", "location": [0.0, 0.0]},
            {"name": "axle", "type": "revolute", "body1": "arm", "body2": "planet", "location": [0.06, 0.0]},
            {"name": "mesh", "type": "gear", "gear": "internal", "body1": "planet", "body2": "ground",
             "point1": [0.06, 0.0], "point2": [0.0, 0.0], "radius1": 0.04, "radius2": 0.1},
        ],
    }
}  # fmt: skip
"""An internal gear (sigma = -1, no example model has one): a planet on a swinging arm rolls inside a fixed ring;
its line of centres starts on atan2's branch cut (theta = pi), so Psi's modulo 2 pi k is crossed at once."""


def _close(reference: np.ndarray, value: np.ndarray, floor: float = 1e-10) -> bool:
    """Equal to 1e-8 of the reference's size; a quantity that is zero (q'' of a constant-speed gear train:
    rounding noise of 1e-12) to ``floor``."""
    scale = float(np.max(np.abs(reference))) if reference.size else 0.0
    return float(np.max(np.abs(reference - value), initial=0.0)) <= 1e-8 * scale + floor


def _agree(model) -> None:
    system, q0, qd0 = build_system(model)
    t_end = min(T_END, float(model.simulation.get("end_time", T_END)))
    kwargs = dict(formulation="baumgarte", integrator="DOP853", rtol=1e-10, atol=1e-12)
    reference = forward_dynamics(system, q0, qd0, t_end, STEPS, engine="numpy", **kwargs)
    compiled = forward_dynamics(system, q0, qd0, t_end, STEPS, engine="compiled", **kwargs)
    assert compiled.info["chosen"]["engine"] == "compiled", compiled.info["chosen"]
    for name in ("q", "qd", "qdd", "lam"):
        assert _close(getattr(reference, name), getattr(compiled, name)), name
    assert set(compiled.points) == set(reference.points)
    energy = max(float(np.max(np.abs(value))) for key, value in reference.points.items() if key.startswith("energy."))
    floors = {  # what 1e-8 of the state and of the energies allows: residuals at the integrator's noise are not equal
        "residual.position": 1e-8 * float(np.max(np.abs(reference.q))),
        "residual.velocity": 1e-8 * float(np.max(np.abs(reference.qd))),
    }
    for key, value in reference.points.items():  # residuals, energies (and the energy balance's error)
        assert key.startswith(("residual.", "energy.")), key
        assert _close(value, compiled.points[key], floor=floors.get(key, 1e-8 * energy)), key
    size = max(float(np.max(np.abs(value))) for value in reference.reactions.values())
    assert set(compiled.reactions) == set(reference.reactions)
    for key, value in reference.reactions.items():  # a zero moment is zero to rounding: measured against the largest
        assert np.max(np.abs(value - compiled.reactions[key])) <= 1e-8 * size, key
    steps, reference_steps = compiled.info["integrator_steps"], reference.info["integrator_steps"]
    if model.name in AT_REST:
        assert abs(steps - reference_steps) <= 0.1 * reference_steps, (steps, reference_steps)
    else:  # the same method: the same steps, but for an error estimate that rounding puts across the limit
        assert abs(steps - reference_steps) <= max(1, 0.02 * reference_steps), (steps, reference_steps)
    assert compiled.info["warnings"] == reference.info["warnings"]


REDUNDANT = {"parallel_swing"}
"""Example models with redundant constraints: no compiled formulation takes them (baumgarte and projection refuse
them by name; svd and the augmented Lagrangian run on numpy), so there is no compiled run to compare."""


@pytest.mark.parametrize("name", sorted(set(MODELS) - REDUNDANT))
def test_example_model(name):
    _agree(load_model(ROOT / "course" / "models" / f"{name}.yaml"))


@pytest.mark.parametrize("name", sorted(REDUNDANT))
def test_redundant_example_model_runs_on_numpy_and_says_why(name):
    system, q0, qd0 = build_system(load_model(ROOT / "course" / "models" / f"{name}.yaml"))
    assert rank_at(system, q0).n_redundant > 0  # else it belongs with the others above
    run = forward_dynamics(system, q0, qd0, 0.02, 2, formulation="augmented-lagrangian", engine="compiled")
    assert run.info["chosen"]["engine"] == "numpy"
    assert "augmented-lagrangian formulation is not compiled" in run.info["chosen"]["engine_why"]


def test_internal_gear():
    _agree(load_model(PLANET_IN_RING))


def _bench_scenes():
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    from benchmarks import bench

    return bench.scenes()


def test_benchmark_scenes_are_example_models_or_run_here():
    """The benchmark scenes given by a file are example models (tested above); the others run below."""
    files = {scene.source for scene in _bench_scenes() if isinstance(scene.source, str)}
    assert files and files <= {f"{name}.yaml" for name in MODELS}


@pytest.mark.parametrize("name", [scene.key for scene in _bench_scenes() if not isinstance(scene.source, str)])
def test_benchmark_scene(name):
    scene = next(scene for scene in _bench_scenes() if scene.key == name)
    _agree(scene.load())


def test_the_function_of_time_and_the_jacobian_helper_are_compiled_once():
    """``kernels.function`` and ``_jac_add`` are called with constant orders and columns (0, 1, 2): under one
    explicit signature, compiled at import, numba converts the constants instead of compiling (and every generated
    module optimizing again) one version per constant."""
    from solutions.compiled import kernels

    for dispatcher in (kernels.function, kernels._jac_add):
        assert len(dispatcher.nopython_signatures) == 1 and not dispatcher._can_compile


def test_function_table_matches_functions():
    """Every compiled function kind against ``functions.py``: value, first and second derivative."""
    from solutions.compiled.kernels import function
    from solutions.compiled.scene import Functions
    from solutions.functions import Constant, EccentricCircle, Fourier, Harmonic, Polynomial, SmoothRamp

    examples = [
        Constant(2.5),
        Polynomial((0.1, -2.0, 0.5, 3.0)),
        Harmonic(0.3, 7.0, 0.2, -1.0),
        SmoothRamp(0.2, 0.5, 1.0, 3.0),
        Fourier(0.04, (0.01, -0.002, 0.003), (0.0, 0.004, -0.001), 2.0),
        EccentricCircle(0.05, 0.01),
    ]
    table = Functions()
    indices = [table.index(example) for example in examples]
    kinds, params = table.arrays()
    for example, f in zip(examples, indices, strict=True):
        for x in (-1.3, 0.0, 0.25, 0.35, 2.0):
            for order, method in enumerate((example.value, example.first, example.second)):
                expected, got = method(x), function(kinds, params, f, x, order)
                assert abs(got - expected) <= 1e-13 * max(1.0, abs(expected)), (example, x, order)
