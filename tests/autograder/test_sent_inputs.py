"""What a child of hidden or per-student checks is sent (``mbdkit.probes.sent_inputs``, the one place the grader
and the reference take a probe's inputs from): times and states, never a value one of its expected outputs
follows from.

Every probe runs with the reference package on every hidden scene of the homeworks, with what such a child
would be sent; a child may hold what all its probes were sent (its code can keep it between calls), so no
array sent to any probe may equal, state by state, an output any probe is checked on there, nor give the
formulation's q'' and lambda in one solve of the augmented system (the attack that scored 84.5 of 100).
A new probe, or a new input, that sends the reference's results fails here.
"""

from __future__ import annotations

import numpy as np
import pytest

from autograder.reference import REFERENCE, hidden_reference, load_reference
from autograder.scenes import load_scene
from mbdkit.homework import available_homeworks, load_homework
from mbdkit.probes import INPUTS, MADE_UP, PERTURBED, PROBES, Job, sent_inputs
from mbdkit.scenes import HIDDEN, job_key

SCENES = sorted({c.scene for hw in ("hw1", "hw2", "hw3") for c in load_homework(hw).checks if c.kind == HIDDEN})
FUNCTION_PROBES = [p for p in PROBES if not p.endswith("_run") and p != "invariants"]


def pieces(array: np.ndarray) -> list[np.ndarray]:
    """The whole array and, for an array over states, each state's part."""
    array = np.asarray(array, dtype=float)
    return [array.ravel()] + ([a.ravel() for a in array] if array.ndim >= 2 else [])


def same(a: np.ndarray, b: np.ndarray) -> bool:
    scale = max(1.0, float(np.max(np.abs(b), initial=0.0)))
    return a.size == b.size and np.ptp(b) > 0 and np.allclose(a, b, rtol=1e-9, atol=1e-12 * scale)


@pytest.fixture(scope="module", params=SCENES)
def child(request):
    """(what a child of the scene's hidden checks is sent, per probe; what each probe gives on it)."""
    scene = load_scene(request.param)
    checks = [c for homework in available_homeworks() for c in load_homework(homework).checks]
    reference = hidden_reference(scene.name, checks)  # computed from the course secret (or the cache)
    dimension = reference.meta["dimension"]
    sent, expected = {}, {}
    for probe in FUNCTION_PROBES:
        try:
            inputs = sent_inputs(probe, reference.inputs, public=False, dimension=dimension)
        except KeyError:  # an input the scene has not (a dynamic probe on a kinematic scene)
            continue
        job = Job(job_key(scene), scene.data, inputs, {})
        try:
            outputs = {k: np.asarray(v, dtype=float) for k, v in PROBES[probe](REFERENCE, job).items()}
        except Exception:  # noqa: BLE001 - a probe that does not apply to this scene
            continue
        if not job.errors:
            sent[probe], expected[probe] = inputs, outputs
    return scene.name, sent, expected


def test_a_child_is_sent_only_times_states_and_made_up_arrays(child):
    _, sent, _ = child
    for probe, inputs in sent.items():
        assert set(inputs) <= set(INPUTS[probe])
        for name in inputs:
            assert name in PERTURBED or name in ("q", "qd") or name in MADE_UP, (probe, name)


def test_nothing_sent_to_a_child_is_an_output_it_is_checked_on(child):
    name, sent, expected = child
    assert "accelerations" in expected or "gamma" in expected, f"{name}: no probe ran"
    for probe, inputs in sent.items():
        for input_name, array in inputs.items():
            for other, outputs in expected.items():
                for output, value in outputs.items():
                    for a in pieces(array):
                        assert not any(same(a, e) for e in pieces(value)), (name, probe, input_name, other, output)


def test_no_solve_of_what_a_child_is_sent_gives_the_formulations_accelerations(child):
    name, sent, expected = child
    pool = {k: v for inputs in sent.values() for k, v in inputs.items()}
    if "accelerations" not in expected or not {"M_pert", "jacobian_pert", "Q_pert", "gamma_pert"} <= set(pool):
        return
    M, J, Q, g = (pool[k] for k in ("M_pert", "jacobian_pert", "Q_pert", "gamma_pert"))
    formulations = REFERENCE["formulations"]
    alpha, beta = formulations.DEFAULT_ALPHA, formulations.DEFAULT_BETA  # the formulation's, as checked here
    g_bar = g - 2 * alpha * pool.get("psi_dot_pert", 0 * g) - beta**2 * pool.get("psi_pert", 0 * g)
    n, m = M.shape[1], J.shape[1]
    for k in range(M.shape[0]):
        matrix = np.block([[M[k], J[k].T], [J[k], np.zeros((m, m))]])
        for rhs in (g[k], g_bar[k]):
            solution = np.linalg.solve(matrix, np.concatenate([Q[k], rhs]))
            assert not same(solution[:n], expected["accelerations"]["qdd"][k]), name
            assert not same(solution[n:], expected["accelerations"]["lam"][k]), name


def test_an_input_nobody_placed_is_never_sent(monkeypatch):
    monkeypatch.setitem(INPUTS, "a_new_probe", ("t", "lam_of_the_reference"))
    inputs = {"t": np.zeros(3), "lam_of_the_reference": np.ones((3, 2))}
    assert set(sent_inputs("a_new_probe", inputs, public=True)) == {"t", "lam_of_the_reference"}
    with pytest.raises(KeyError, match="lam_of_the_reference"):
        sent_inputs("a_new_probe", inputs, public=False)


def test_a_public_child_gets_the_reference_arrays_a_hidden_one_made_up_ones():
    inputs = load_reference("double_pendulum").inputs
    public = sent_inputs("augmented_accelerations", inputs, public=True)
    hidden = sent_inputs("augmented_accelerations", inputs, public=False)
    assert np.array_equal(public["M_pert"], inputs["M_pert"])
    for key in public:
        assert hidden[key].shape == public[key].shape and not np.allclose(hidden[key], public[key])
    M = hidden["M_pert"][0]
    assert np.allclose(M, M.T) and np.all(np.linalg.eigvalsh(M) > 0)
    velocity = sent_inputs("velocity", inputs, public=False)
    assert np.array_equal(velocity["q"], inputs["q_pert"])  # the run's own q is what newton returns
