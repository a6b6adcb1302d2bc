"""What a compiled run reports besides its motion (solutions/compiled/history.py, Guard.check_outputs), against
the numpy functions that the numpy engine uses: Psi, Psi_q, Psi_t from the generated module against the
System's, the residual and reaction columns against ``constraint_residuals`` and ``joint_reactions``, and the
batched checks of the Guard against its step-by-step checks (the same verdicts, the same messages).
"""

from pathlib import Path

import numpy as np
import pytest
import yaml

from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError, SingularConfigurationError
from solutions.dynamics import constraint_residuals, forward_dynamics
from solutions.guard import Guard
from solutions.io import load_model
from solutions.reactions import joint_reactions

pytest.importorskip("numba")

from solutions.compiled import codegen, describe, history  # noqa: E402
from solutions.generalized_forces import build_forces  # noqa: E402
from solutions.mass_matrix import mass_matrix  # noqa: E402

MODELS = [  # revolute, prismatic, drivers (Psi_t), loads; spatial joints with frames, to ground both ways
    "course/models/slider_crank_flywheel.yaml",
    "course/models/four_bar_spring.yaml",
    "course/models/spatial_double_pendulum.yaml",
    "course/models/heavy_top.yaml",
    "course/models/spatial_double_pendulum_driven.yaml",
    "course/models/gear_train.yaml",
    "course/models/carriage_pendulum.yaml",
    "course/models/revolute_revolute_skew.yaml",
]


def _numpy_history(path: str):
    """A short numpy run of the model (its motion is all these tests need) and its compiled module."""
    system, q0, qd0 = build_system(load_model(path))
    run = forward_dynamics(system, q0, qd0, 0.3, 12, formulation="baumgarte", integrator="DOP853", rtol=1e-8)
    scene = describe(system, mass_matrix(system.model), build_forces(system.model))
    assert scene.unsupported is None, scene.unsupported
    module, _ = codegen.load(scene)
    Y = np.hstack([run.q, run.qd])
    return system, run, scene, module, Y


@pytest.mark.parametrize("path", MODELS)
def test_history_matches_numpy_functions(path):
    system, run, scene, module, Y = _numpy_history(path)
    psi, jac, psit = history.constraint_arrays(module, scene, run.t, Y)
    for k, t in enumerate(run.t):
        assert np.allclose(psi[k], system.constraints(run.q[k], t), rtol=0, atol=1e-13)
        assert np.allclose(jac[k], system.jacobian(run.q[k], t), rtol=1e-13, atol=1e-13)
        assert np.allclose(psit[k], system.psi_t(run.q[k], t), rtol=1e-13, atol=1e-13)
    expected = constraint_residuals(system, run.t, run.q, run.qd)
    got = history.residuals(psi, jac, psit, run.qd)
    sparse = history.residuals(psi, jac, psit, run.qd, system)  # over each row's nonzero columns
    assert history.row_columns(system) is not None  # every element's rows: its bodies' columns
    for key in expected:
        assert np.allclose(got[key], expected[key], rtol=1e-10, atol=1e-14), key
        assert np.allclose(sparse[key], expected[key], rtol=1e-10, atol=1e-14), key
    expected = joint_reactions(system, run.q, run.lam, run.t)
    got = history.joint_reactions(system, run.q, run.lam, jac)
    assert list(got) == list(expected)  # the same columns in the same order (the CSV's)
    size = max(float(np.max(np.abs(v))) for v in expected.values())
    for key, value in expected.items():
        assert np.max(np.abs(got[key] - value)) <= 1e-12 * size, key
    _blocked_history_is_the_dense_one(system, run, scene, module, Y, (psi, jac, psit), sparse, got)


def _blocked_history_is_the_dense_one(system, run, scene, module, Y, dense, residuals, reactions):
    """Psi_q kept by its rows' blocks (``history.BlockedJacobians``, a large Psi_q's history) stands for the dense
    one entry for entry, and the residuals and reactions read from its blocks are the dense history's to the last
    bit (the same products in the same order)."""
    psi, jac, psit = dense
    columns = history.row_columns(system)
    bpsi, blocked, bpsit = history.constraint_arrays(module, scene, run.t, Y, columns)
    assert isinstance(blocked, history.BlockedJacobians) and blocked.shape == jac.shape
    assert blocked.values.shape == (*jac.shape[:2], columns.shape[1])
    for got, want in ((bpsi, psi), (blocked.dense(), jac), (np.asarray(blocked), jac), (bpsit, psit)):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(blocked[3], jac[3])  # one time: its dense Psi_q
    np.testing.assert_array_equal(blocked[2:5].dense(), jac[2:5])  # a span of times: still blocks
    for key, value in history.residuals(bpsi, blocked, bpsit, run.qd, system).items():
        np.testing.assert_array_equal(value, residuals[key], err_msg=key)
    got = history.joint_reactions(system, run.q, run.lam, blocked)
    assert list(got) == list(reactions)
    for key, value in reactions.items():
        np.testing.assert_array_equal(got[key], value, err_msg=key)


def test_residuals_take_the_dense_product_where_a_row_reaches_other_bodies():
    """The nonzero columns of each row are those of its element's bodies (``history.row_columns``), checked once
    against Psi_q: where a row reaches another body's columns (here made so), the residuals come from the dense
    product, which counts that column."""
    from types import SimpleNamespace

    system, q0, qd0 = build_system(load_model("course/models/slider_crank.yaml"))
    reaching = system.jacobian(q0, 0.0)
    reaching[0, -1] = 1.0  # the first row (a joint of the crank) reaches the slider's angle column
    other = SimpleNamespace(**{
        name: getattr(system, name)
        for name in ("coordinates_per_body", "n_constraints", "n_coordinates", "elements", "rows")
    }, jacobian=lambda q, t: reaching)  # fmt: skip
    assert history.row_columns(other) is None
    jac = np.zeros((1, *reaching.shape))
    jac[0, 0, -1] = 1.0  # only that entry: Psi_q q' = 2 in row 0 with q' on that column
    qd, zeros = np.zeros((1, system.n_coordinates)), np.zeros((1, reaching.shape[0]))
    qd[0, -1] = 2.0
    assert history.residuals(zeros, jac, zeros, qd, other)["residual.velocity"][0] == 2.0  # the dense product
    assert history.residuals(zeros, jac, zeros, qd, system)["residual.velocity"][0] == 0.0  # the crank's columns


def test_residuals_keep_a_nan_as_numpy_does():
    """The compiled maxima (``history_kernels.residual_maxima``) give what numpy's max gives over each output time's
    rows: exact maxima, and NaN where any entry is NaN (a run that left the mechanism says so in its residuals)."""
    from solutions.output_history import residuals as numpy_residuals

    system, q0, qd0 = build_system(load_model("course/models/slider_crank.yaml"))
    rng = np.random.default_rng(7)
    m, n = system.n_constraints, system.n_coordinates
    psi, psit, qd = rng.standard_normal((4, m)), rng.standard_normal((4, m)), rng.standard_normal((4, n))
    jac = np.stack([system.jacobian(q0 + 0.1 * rng.standard_normal(n), 0.0) for _ in range(4)])
    psi[1, 2], psit[2, 0], qd[3, 1] = np.nan, np.nan, np.nan
    got, expected = history.residuals(psi, jac, psit, qd, system), numpy_residuals(psi, jac, psit, qd)
    for key, value in expected.items():
        position = key == "residual.position"
        assert np.isnan(value).tolist() == [False, position, not position, not position], key
        np.testing.assert_allclose(got[key], value, rtol=1e-15, atol=0.0, err_msg=key)


@pytest.mark.parametrize(
    "name",
    [
        *("four_bar", "quick_return", "six_bar", "rack_pinion", "slider_crank", "andrews"),
        *("spatial_slider_crank", "cylindrical_driven", "heavy_top_driven", "revolute_revolute_skew_driven"),
        "carriage_pendulum_driven",
    ],
)
def test_reactions_of_every_joint_kind_at_any_state(name):
    """The batched reactions (every joint at once) against the numpy engine's ``joint_reactions`` on planar models
    with motors (rows with Psi_t), revolute-prismatic, gear and prismatic pairs (two elements), and spatial ones
    with every joint kind and motors, joints to ground on either side: the reactions are algebraic in (q, lambda),
    so random states and multipliers test every term. Each column is a contiguous (N,) array: the compiled loops
    write a column a row of one (columns, N) array, each body's cos and sin (planar) or A(p) and G(p) (spatial)
    taken once an output time however many joints it carries (six_bar: bodies with two and three joint points)."""
    model = yaml.safe_load(Path(f"course/models/{name}.yaml").read_text())
    for joint in model["model"]["joints"][::2]:  # every other joint written the other way round: ground as body2
        joint["body1"], joint["body2"] = joint["body2"], joint["body1"]
    system, q0, _ = build_system(load_model(model))
    rng = np.random.default_rng(11)
    t = np.linspace(0.0, 0.5, 5)
    q = q0 + 0.3 * rng.normal(size=(t.size, q0.size))
    lam = rng.normal(size=(t.size, system.n_constraints))
    if system.model.dimension == 3:  # unit Euler parameters of every body
        bodies = q.reshape(t.size, -1, 7)
        bodies[..., 3:] /= np.linalg.norm(bodies[..., 3:], axis=2, keepdims=True)
    jac = np.stack([system.jacobian(q[k], t[k]) for k in range(t.size)])
    expected = joint_reactions(system, q, lam, t)
    got = history.joint_reactions(system, q, lam, jac)
    assert list(got) == list(expected)
    for key, value in expected.items():
        assert np.max(np.abs(got[key] - value)) <= 1e-12 * max(1.0, float(np.max(np.abs(value)))), key
        assert got[key].shape == (t.size,) and got[key].flags.c_contiguous, key


def _verdict(check):
    try:
        check()
    except AnalysisError as err:
        return type(err).__name__, str(err)
    return None


def test_batched_guard_gives_the_step_by_step_verdicts():
    """A slider-crank's motion judged with a singular ratio it passes below, and a history moved off its
    constraints: the Guard stops at the same output time with the same message, batched or step by step;
    with the defaults the history passes, and the closest approach to a singular position is the same."""
    system, run, scene, module, Y = _numpy_history("course/models/slider_crank_flywheel.yaml")
    psi, jac, _ = history.constraint_arrays(module, scene, run.t, Y)

    class Coordinates:  # what check_configuration asks of a formulation: q from the state y = (q, q')
        @staticmethod
        def coordinates(t, y):
            return y[: system.n_coordinates], y[system.n_coordinates :]

    def step_by_step(q_history, ratio=1e-6, drift=1e-3):
        guard = Guard(system, q_history[0], drift, ratio)
        for k, t in enumerate(run.t):
            guard.check_drift(q_history[k], t)
            guard.check_configuration(Coordinates, t, np.concatenate([q_history[k], run.qd[k]]))
        return guard

    def batched(q_history, ratio=1e-6, drift=1e-3):
        psi_k, jac_k, _ = history.constraint_arrays(module, scene, run.t, np.hstack([q_history, run.qd]))
        guard = Guard(system, q_history[0], drift, ratio)
        guard.check_outputs(run.t, q_history, psi_k, jac_k)
        return guard

    a, b = step_by_step(run.q), batched(run.q)
    assert a.closest == pytest.approx(b.closest, rel=1e-12)
    # a history with no verdict to give is judged at once (Guard._quiet): the state the time-ordered verdicts leave
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Guard, "_quiet", lambda *args: False)
        c = batched(run.q)
    assert (b.closest, b._t, b._sign) == (c.closest, c._t, c._sign) and np.array_equal(b._tangent, c._tangent)
    # a singular ratio the motion passes below: both stop at the first output time where sigma_r / sigma_1 dips
    limit = 1.01 * b.closest["ratio"]
    first = _verdict(lambda: step_by_step(run.q, ratio=limit))
    assert first is not None and first[0] == SingularConfigurationError.__name__
    assert _verdict(lambda: batched(run.q, ratio=limit)) == first
    # positions moved off the constraints from the sixth output time on
    off = run.q.copy()
    off[5:, 0] += 0.05
    first = _verdict(lambda: step_by_step(off))
    assert first is not None and "constraint drift at t" in first[1]
    assert _verdict(lambda: batched(off)) == first


def test_batched_guard_sees_a_rank_loss_between_output_times():
    """A parallelogram loop (tests/solutions/mechanisms.py) falling through theta = 0, where Psi_q loses a rank:
    its motion, from the augmented Lagrangian formulation that passes it, judged by the sign of det [Psi_q; T^T]
    alone (a singular ratio far below the one met): both checks stop between the same two output times."""
    from tests.solutions.mechanisms import parallelogram_chain

    system, q0, qd0 = build_system(load_model(parallelogram_chain(1, end_time=1.0)))
    run = forward_dynamics(system, q0, qd0, 1.0, 40, formulation="augmented-lagrangian", integrator="DOP853")
    scene = describe(system, mass_matrix(system.model), build_forces(system.model))
    module, _ = codegen.load(scene)
    psi, jac, _ = history.constraint_arrays(module, scene, run.t, np.hstack([run.q, run.qd]))

    class Coordinates:
        @staticmethod
        def coordinates(t, y):
            return y[: system.n_coordinates], y[system.n_coordinates :]

    def step_by_step():
        guard = Guard(system, run.q[0], None, 1e-14)
        for k, t in enumerate(run.t):
            guard.check_configuration(Coordinates, t, np.concatenate([run.q[k], run.qd[k]]))

    def batched():
        Guard(system, run.q[0], None, 1e-14).check_outputs(run.t, run.q, psi, jac)

    first = _verdict(step_by_step)
    assert first is not None and "lost rank there" in first[1], first
    assert _verdict(batched) == first


@pytest.mark.parametrize("dimension", [2, 3])
def test_a_free_body_runs_compiled_with_no_reaction_columns(dimension):
    """A body with no joint (no constraint but a spatial body's Euler-parameter normalization) moves at constant
    velocity without gravity: x = v t on both engines; no joint, so no reaction column (the compiled output stage
    took the rows of no joint and failed)."""
    body = {"name": "b", "mass": 1.0, "location": [0.0] * dimension, "velocity": [1.0, 2.0, 0.0][:dimension]}
    if dimension == 2:
        body.update(inertia=0.1, orientation=0.0, angular_velocity=1.0)
    else:
        body.update(inertia=[0.1, 0.2, 0.3], angular_velocity=[1.0, 0.5, 0.2])
    model = load_model({"model": {"dimension": dimension, "gravity": [0.0] * dimension, "bodies": [body]}})
    for engine in ("numpy", "compiled"):
        run = forward_dynamics(*build_system(model), 1.0, 4, engine=engine, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(run.q[:, :2], np.outer(run.t, [1.0, 2.0]), atol=1e-9)
        assert not run.reactions
    assert run.info["chosen"]["engine"] == "compiled"


@pytest.mark.parametrize(
    ("path", "formulation"),
    [("course/models/slider_crank_flywheel.yaml", "baumgarte"), ("course/models/spatial_double_pendulum.yaml",
     "joint-coordinates"), ("course/models/slider_crank.yaml", "joint-coordinates")],
)  # fmt: skip
def test_one_output_pass_gives_the_systems_constraints_and_the_blocked_pass_numbers(path, formulation, monkeypatch):
    """A compiled run's Psi, Psi_q, Psi_t at the output times from its one output pass (``loops.output_history``: the
    right-hand side writes them beside q'' and lambda) are the System's at the run's q, and to the last bit those of
    the pass that keeps a large Psi_q by its rows' blocks (``loops.blocked_output_history``, above ONE_PASS_LARGEST),
    which evaluates no constraint kernel a second time (the module's ``constraint_arrays`` is not called); with a tree's
    cut rows too (the slider-crank in joint coordinates)."""
    import solutions.compiled as compiled

    system, q0, qd0 = build_system(load_model(path))
    made = {}
    run = compiled.run

    def keep(*args, **kwargs):
        made["run"] = run(*args, **kwargs)
        return made["run"]

    monkeypatch.setattr(compiled, "run", keep)
    options = dict(formulation=formulation, integrator="DOP853", rtol=1e-8, engine="compiled", divergence="skip")
    result = forward_dynamics(system, q0, qd0, 0.3, 12, **options)
    one = made.pop("run")
    assert one.jac.shape == (13, system.n_constraints, system.n_coordinates)
    for k, t in enumerate(result.t):
        assert np.allclose(one.psi[k], system.constraints(result.q[k], t), rtol=0, atol=1e-13)
        assert np.allclose(one.jac[k], system.jacobian(result.q[k], t), rtol=1e-13, atol=1e-13)
        assert np.allclose(one.psit[k], system.psi_t(result.q[k], t), rtol=1e-13, atol=1e-13)
    monkeypatch.setattr(compiled, "ONE_PASS_LARGEST", 0)

    def second_pass(*args, **kwargs):
        raise AssertionError("the constraints evaluated again after the output pass")

    monkeypatch.setattr(history, "constraint_arrays", second_pass)
    blocked = forward_dynamics(system, q0, qd0, 0.3, 12, **options)
    two = made.pop("run")
    assert isinstance(two.jac, history.BlockedJacobians)  # above ONE_PASS_LARGEST: Psi_q by its rows' blocks
    for name in ("Y", "qdd", "lam", "psi", "jac", "psit"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name), err_msg=name)
    for kind in ("points", "reactions", "forces"):  # the result's columns (its CSV) from the blocks: the same
        got, want = getattr(blocked, kind), getattr(result, kind)
        assert list(got) == list(want)
        for key, value in want.items():
            np.testing.assert_array_equal(got[key], value, err_msg=key)
    for key in ("closest_singularity", "max_constraint_residual", "max_velocity_residual"):  # Guard, residuals
        assert blocked.info[key] == result.info[key], key


def test_the_compiled_kinetic_energy_of_a_spatial_model_is_each_states_t():
    """``history.kinetic_energy``: T at every output time in one compiled pass (eq. 10.3), against the state-by-state
    sum ``spatial.mass.kinetic_energy`` (1/2 m r'^T r' + 1/2 omega'^T J' omega', omega' = 2 L p') at random states of
    a model with a full inertia matrix, within rounding."""
    from solutions.spatial.mass import SpatialMassMatrix, kinetic_energy

    system, _, _ = build_system(load_model("course/models/spatial_double_pendulum.yaml"))
    model = system.model
    model.bodies[0].inertia = np.array([[0.3, 0.05, -0.02], [0.05, 0.2, 0.01], [-0.02, 0.01, 0.1]])  # off-diagonal
    rng = np.random.default_rng(7)
    q, qd = rng.standard_normal((9, system.n_coordinates)), rng.standard_normal((9, system.n_coordinates))
    for b in range(len(model.bodies)):
        q[:, 7 * b + 3 : 7 * b + 7] /= np.linalg.norm(q[:, 7 * b + 3 : 7 * b + 7], axis=1)[:, None]
    kinetic = history.kinetic_energy(SpatialMassMatrix(model), q, qd)
    expected = [kinetic_energy(model, q[k], qd[k]) for k in range(len(q))]
    np.testing.assert_allclose(kinetic, expected, rtol=1e-14, atol=0)


@pytest.mark.parametrize("name", ["double_pendulum", "slider_crank", "six_bar"])
def test_the_compiled_kinetic_energy_of_a_planar_model_is_numpys_bit_for_bit(name):
    """``history.kinetic_energy`` of a planar model, M = diag(m, m, J) (every planar M the compiled engine runs):
    1/2 sum_i m_i q_i'^2 by the diagonal, the same numbers as ``energy.kinetic_energy``'s q' M by BLAS (each entry's
    other terms are exact zeros), random velocities of every sign and scale; a non-diagonal M is left to numpy."""
    from solutions.energy import kinetic_energy

    system, _, _ = build_system(load_model(f"course/models/{name}.yaml"))
    M = mass_matrix(system.model)
    rng = np.random.default_rng(5)
    qd = rng.standard_normal((40, system.n_coordinates)) * 10.0 ** rng.integers(-8, 8, (40, system.n_coordinates))
    kinetic = history.kinetic_energy(M, qd, qd)
    assert kinetic.tobytes() == kinetic_energy(M, qd).tobytes()
    coupled = M.copy()
    coupled[0, 1] = coupled[1, 0] = 0.01
    assert history.kinetic_energy(coupled, qd, qd) is None


def test_the_planar_kinetic_energy_sums_in_numpys_order_at_every_size():
    """``history_kernels.planar_kinetic_energy``: 1/2 sum_i (q_i' m_i) q_i' summed in np.sum's pairwise order
    (``_pairwise_sum``: one by one below 8 terms, eight running sums up to 128), bit for bit against
    ``0.5 * np.sum((qd * m) * qd, axis=-1)`` at every row length from 0 to 128 (a chain of 42 bodies), velocities of
    every sign and scale; ``history.kinetic_energy`` keeps longer rows (numpy splits them in halves) to numpy."""
    from solutions.compiled import history_kernels

    rng = np.random.default_rng(11)
    for n in range(history_kernels.PAIRWISE_BLOCK + 1):
        qd = rng.standard_normal((9, n)) * 10.0 ** rng.integers(-8, 8, (9, n))
        diagonal = rng.uniform(0.1, 3.0, n)
        out = np.empty(9)
        history_kernels.planar_kinetic_energy(qd, diagonal, out)
        assert out.tobytes() == (0.5 * np.sum((qd * diagonal) * qd, axis=-1)).tobytes(), n
    n = 3 * 50  # longer than a block: numpy's own expression
    qd, M = rng.standard_normal((9, n)), np.diag(rng.uniform(0.1, 3.0, n))
    expected = 0.5 * np.sum((qd * np.diagonal(M)) * qd, axis=-1)
    assert history.kinetic_energy(M, qd, qd).tobytes() == expected.tobytes()


def test_a_planar_compiled_run_never_compiles_the_spatial_output_kernels():
    """The spatial reactions and kinetic energy live in ``spatial_history_kernels`` (compiled at its import, ~2.5 s
    on a new machine): a planar compiled run, in a process of its own, imports no module that holds them."""
    import os
    import subprocess
    import sys

    script = (
        "import sys\n"
        "from solutions.assembly import build_system\n"
        "from solutions.dynamics import forward_dynamics\n"
        "from solutions.io import load_model\n"
        "system, q0, qd0 = build_system(load_model('course/models/slider_crank_flywheel.yaml'))\n"
        "run = forward_dynamics(system, q0, qd0, 0.1, 5, formulation='baumgarte', integrator='DOP853',"
        " engine='compiled')\n"
        "assert run.reactions and run.info['chosen']['engine'] == 'compiled'\n"
        "kernels = sys.modules['solutions.compiled.history_kernels']\n"
        "print('solutions.compiled.spatial_history_kernels' in sys.modules, hasattr(kernels, 'spatial_reactions'))\n"
    )
    root = Path(__file__).resolve().parents[2]
    environment = dict(os.environ, PYTHONPATH=str(root))
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=root, env=environment, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "False False"
