"""The start of a ``forward_dynamics`` call, made cheaper without changing what it makes (issue 25).

A call builds M, the force model, the joint-coordinates object and the compiled engine's description of the scene
anew (nothing kept across calls: ``dynamics.prepare`` is the way to keep them). These tests hold the faster
constructions to what they replace: the output grid is ``np.linspace``'s, the tree's cut rows are those of the cut
elements, the singular inertias are the eigensolver's verdicts, and what only some runs read is made where read.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import chains  # noqa: E402
from solutions import diagnostics, dynamics  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.compiled import plan  # noqa: E402
from solutions.io.model import load_model  # noqa: E402
from solutions.joint_coordinates import cut_elements, tree_order  # noqa: E402
from solutions.mass_matrix import singular_inertia  # noqa: E402
from solutions.planar import build  # noqa: E402

MODELS = ROOT / "course" / "models"


@pytest.mark.parametrize("t_end, steps", [(1.0, 100), (2.5, 7), (10.0, 1000), (0.3, 3), (1e-3, 17), (7, 1), (3.7, 251)])
def test_the_output_grid_is_linspace_bit_for_bit(t_end, steps):
    expected = np.linspace(0.0, t_end, steps + 1)
    grid = dynamics.output_grid(t_end, steps)
    assert grid.dtype == expected.dtype and grid.tobytes() == expected.tobytes()


def _tree(model):
    system, q0, qd0 = build_system(model)
    M, forces = dynamics.dynamic_model(system, None, None)
    formulation = dynamics.make_formulation("joint-coordinates", system, M, forces)
    formulation.initial_state(q0, qd0, 0.0)
    return system, plan(system, M, forces, "joint-coordinates", formulation).scene


@pytest.mark.parametrize("name", ["slider_crank", "four_bar", "double_pendulum", "spatial_slider_crank", "loops3"])
def test_the_tree_cut_rows_are_the_cut_elements_rows(name):
    model = load_model(chains.loop_chain(3)) if name == "loops3" else load_model(MODELS / f"{name}.yaml")
    system, tree = _tree(model)
    cut = {id(element) for element in cut_elements(system, tree_order(system)[0])}
    rows, bodies = [], []
    for element, where in zip(system.elements, system.rows, strict=True):
        if id(element) in cut:
            rows += range(where.start, where.stop)
            bodies += [element.i, element.j] * (where.stop - where.start)
    assert tree.cut_rows.tolist() == rows and tree.cut_bodies.tolist() == bodies
    assert np.flatnonzero(tree.owners < 0).tolist() == rows  # a row is cut exactly where it has no owner
    for array in (tree.cut_rows, tree.cut_bodies, tree.owners, tree.row_index):
        assert array.dtype == np.int64
    start, owned = tree.row_index[: len(system.model.bodies) + 1], tree.row_index[len(system.model.bodies) + 1 :]
    for b in range(len(system.model.bodies)):  # each body's rows, in row order
        assert owned[start[b] : start[b + 1]].tolist() == np.flatnonzero(tree.owners == b).tolist()


def _spatial_model(inertias):
    model = load_model(MODELS / "spatial_double_pendulum.yaml")
    for body, inertia in zip(model.bodies, inertias, strict=True):
        body.inertia = np.asarray(inertia, dtype=float)
    return model


def _eigensolver_verdict(model) -> list[int]:
    stacked = np.array([np.asarray(body.inertia, dtype=float) for body in model.bodies])
    smallest = np.linalg.eigvalsh(0.5 * (stacked + np.swapaxes(stacked, 1, 2)))[:, 0]
    return [k for k, body in enumerate(model.bodies) if not smallest[k] > 1e-12 * np.max(np.abs(stacked[k]))]


@pytest.mark.parametrize(
    "inertias",
    [
        [np.diag([0.1, 0.2, 0.3]), np.diag([0.0, 0.0, 0.0])],  # principal axes, a point mass
        [np.diag([0.1, 0.2, 0.3]), np.diag([1.0, 1.0, 1e-14])],  # a slender rod about its axis
        [np.diag([0.1, 0.2, 0.3]), np.diag([0.5, 0.5, 0.5])],  # none singular
        [[[0.2, 0.1, 0.0], [0.1, 0.2, 0.0], [0.0, 0.0, 0.3]], np.diag([0.0, 0.0, 0.0])],  # not principal: eigvalsh
        [[[0.5, 0.5, 0.0], [0.5, 0.5, 0.0], [0.0, 0.0, 0.3]], np.diag([0.1, 0.1, 0.1])],  # singular off its axes
    ],
)
def test_singular_inertias_are_the_eigensolvers_verdicts(inertias):
    model = _spatial_model(inertias)
    assert singular_inertia(model) == _eigensolver_verdict(model)


def test_planar_moments_as_numbers_or_arrays_give_one_verdict():
    model = load_model(MODELS / "double_pendulum.yaml")
    model.bodies[1].inertia = 0.0
    as_numbers = singular_inertia(model)
    for body in model.bodies:
        body.inertia = np.array([[body.inertia]])
    assert as_numbers == singular_inertia(model) == [1]


@pytest.mark.parametrize("name", ["spatial_double_pendulum", "double_pendulum"])
def test_singular_mass_is_decided_where_first_asked(name):
    system, _, _ = build_system(load_model(MODELS / f"{name}.yaml"))
    M, forces = dynamics.dynamic_model(system, None, None)
    formulation = dynamics.make_formulation("joint-coordinates", system, M, forces)
    assert "singular_mass" not in formulation.__dict__  # made by no run that does not project
    expected = bool(singular_inertia(system.model)) if callable(M) else not np.linalg.eigvalsh(M)[0] > 0.0
    assert formulation.singular_mass is expected


def test_body_frames_read_the_file_configuration_only_for_a_global_point():
    model = load_model(MODELS / "double_pendulum.yaml")
    frames = build._Frames(model)
    assert np.array_equal(frames.local_point(0, [0.1, 0.2], "body"), [0.1, 0.2])
    assert "q0" not in frames.__dict__  # a body-frame point needs no configuration (a pendulum's forces: none)
    q0, _ = build.initial_coordinates(model)
    x, y, phi = q0[:3]
    expected = np.array([[np.cos(phi), np.sin(phi)], [-np.sin(phi), np.cos(phi)]]) @ (np.array([1.0, 0.5]) - [x, y])
    assert np.allclose(frames.local_point(0, [1.0, 0.5], "global"), expected, rtol=0, atol=1e-15)
    assert np.array_equal(frames.q0, q0) and q0.dtype == np.float64


def _turned_top(p: np.ndarray):
    """The heavy top turned to the unit Euler parameters p about its tip O (the origin): q on its constraints."""
    from solutions.rotations import rotation_matrix

    system, q0, _ = build_system(load_model(MODELS / "heavy_top.yaml"))
    return system, np.concatenate([rotation_matrix(p) @ np.array([0.0, 0.0, 0.05]), p])


def test_a_spatial_q0_on_the_constraints_moves_no_body_exactly():
    """No Newton iteration: q is q0 and every body's move is reported exactly 0, spatial as planar (the angle of
    conj(p0) p0 was the rounding of the quaternion product, a few 1e-17 rad for some p0: this test picks one)."""
    from solutions.kinematics import assemble
    from solutions.rotations import conjugate, normalized, quaternion_product, to_axis_angle

    rng = np.random.default_rng(7)
    for _ in range(200):
        p = normalized(rng.normal(size=4))
        if to_axis_angle(quaternion_product(conjugate(normalized(p)), normalized(p)))[1] != 0.0:
            break  # the old report's rounding: not a motion
    else:
        pytest.fail("no Euler parameters with a rounding-level conj(p) p among 200")
    system, q = _turned_top(p)
    assembled, report = assemble(system, q)
    assert report["iterations"] == 0 and assembled.tobytes() == q.tobytes()
    assert report["moved"] == {"top": {"translation": 0.0, "rotation": 0.0}}


def test_consistent_initial_conditions_at_rest_take_psi_t_as_the_residual():
    """q0' = 0: Psi_q q0' + Psi_t is Psi_t (Psi_q made only where q0' needs a correction): a driven mechanism at rest
    is corrected as before, bit for bit against Psi_q q0' + Psi_t."""
    system, q0, _ = build_system(load_model(MODELS / "slider_crank.yaml"))
    M = dynamics.dynamic_model(system, None, None)[0]
    rest = np.zeros_like(q0)
    q, qd, report = dynamics.consistent_initial_conditions(system, M, q0, rest)
    jacobian, psi_t = system.jacobian(q, 0.0), system.psi_t(q, 0.0)
    assert report["velocity_residual_before"] == float(np.abs(jacobian @ rest + psi_t).max())
    assert report["velocity_residual"] <= 1e-10 * max(1.0, report["velocity_residual_before"])
    if not report["velocity_residual_before"]:
        assert qd.tobytes() == rest.tobytes()


def test_the_spatial_tree_mass_is_made_at_its_first_numpy_evaluation():
    """diag(m I, J') of every body (``JointCoordinates._body_mass``): not made by the object (a compiled run never
    reads it), made by the first numpy evaluation, the blocks of each body's mass and inertia."""
    system, q0, qd0 = build_system(load_model(MODELS / "spatial_double_pendulum.yaml"))
    M, forces = dynamics.dynamic_model(system, None, None)
    formulation = dynamics.make_formulation("joint-coordinates", system, M, forces)
    assert "_body_mass" not in formulation.__dict__
    formulation.accelerations(*formulation.coordinates(0.0, formulation.initial_state(q0, qd0, 0.0)), 0.0)
    body_mass = formulation.__dict__["_body_mass"]
    for b, body in enumerate(system.model.bodies):
        block = body_mass[6 * b : 6 * b + 6, 6 * b : 6 * b + 6]
        assert np.array_equal(block[:3, :3], body.mass * np.eye(3)) and np.array_equal(block[3:, 3:], body.inertia)
    assert np.count_nonzero(body_mass) == sum(
        np.count_nonzero(body_mass[6 * b : 6 * b + 6, 6 * b : 6 * b + 6]) for b in range(2)
    )


def test_the_divergence_companion_starts_from_the_runs_start_state(monkeypatch):
    """A compiled call whose divergence check runs a companion (the spatial double pendulum: two degrees of freedom
    and more) makes the joint state of its start once, for its start rates, and hands it to the run and to the
    companion (``dynamics.start_state``): the same numbers as a joint state made again (the result is the call's)."""
    from solutions.joint_coordinates import JointCoordinates

    system, q0, qd0 = build_system(load_model(MODELS / "spatial_double_pendulum.yaml"))
    options = dict(formulation="joint-coordinates", integrator="DOP853", rtol=1e-6, atol=1e-8, engine="compiled")
    reference = dynamics.forward_dynamics(system, q0, qd0, 1.0, 20, **options)
    assert "doubling_time" in reference.info["divergence"]  # the companion ran
    made = []
    original = JointCoordinates.initial_state
    monkeypatch.setattr(JointCoordinates, "initial_state", lambda self, *a: made.append(1) or original(self, *a))
    result = dynamics.forward_dynamics(system, q0, qd0, 1.0, 20, **options)
    assert len(made) == 1
    for name in ("q", "qd", "qdd", "lam"):
        assert np.array_equal(getattr(result, name), getattr(reference, name))
    assert result.info["divergence"] == reference.info["divergence"]


@pytest.mark.parametrize("engine", ["numpy", "compiled"])
def test_each_call_makes_psi_q_s_rank_once_and_keeps_nothing_for_the_next(monkeypatch, engine):
    """Psi_q's rank at the start (``diagnostics.rank_at``: a certificate or an SVD, 0.1-1 ms on the loop chains) is made
    once per call, at its start (``Start.rank``), and handed to the method's choice, the redundancy checks, the Guard
    and the divergence check: a second identical call makes it again (no result kept on the system across calls), and a
    call from another q0 gets its own. The results are the same as without counting."""
    system, q0, qd0 = build_system(load_model(chains.loop_chain(2)))
    options = dict(formulation="auto", rtol=1e-6, atol=1e-8, engine=engine)
    reference = dynamics.forward_dynamics(system, q0, qd0, 0.2, 10, **options)
    made = []  # each decision of the rank: the certificate (``full_row_rank``), the SVD where it fails
    for name in ("full_row_rank", "rank_report"):
        original = getattr(diagnostics, name)
        monkeypatch.setattr(diagnostics, name, lambda *a, _f=original, **k: made.append(1) or _f(*a, **k))
    first = dynamics.forward_dynamics(system, q0, qd0, 0.2, 10, **options)
    second = dynamics.forward_dynamics(system, q0, qd0, 0.2, 10, **options)
    assert len(made) == 2
    for name in ("q", "qd", "qdd", "lam"):
        assert np.array_equal(getattr(first, name), getattr(reference, name))
        assert np.array_equal(getattr(second, name), getattr(reference, name))


def test_a_driven_start_makes_psi_q_once_for_its_velocities_and_its_rank(monkeypatch):
    """A driven mechanism released at rest (Psi_t != 0: the slider-crank) corrects q0' with Psi_q at the consistent q
    (eq. 6.2), and its rank at the start is of the same matrix (``dynamics.consistent_start`` hands it to
    ``start_rank``): Psi_q is made once at the start, not again by ``rank_at``; the start's q, q' and rank are those of
    ``consistent_initial_conditions`` and ``rank_at``, bit for bit."""
    system, q0, qd0 = build_system(load_model(MODELS / "slider_crank.yaml"))
    M = dynamics.dynamic_model(system, None, None)[0]
    q, qd, report = dynamics.consistent_initial_conditions(system, M, q0, qd0)
    assert report["velocity_residual_before"] > 0.0  # Psi_t corrected: Psi_q made for it
    expected = diagnostics.rank_at(system, q)
    made, inside = [], [False]
    jacobian = type(system).jacobian
    monkeypatch.setattr(type(system), "jacobian", lambda self, *a: made.append(inside[0]) or jacobian(self, *a))
    start_motion = dynamics.start_motion

    def counted(*args):
        inside[0] = True
        try:
            return start_motion(*args)
        finally:
            inside[0] = False

    class Planned(Exception):
        """Raised by the plan with what the start handed it (q, q', Psi_q's rank): the call stops there."""

    def planned(run, M, forces, q, qd, formulation, integrator, rates, rank):
        raise Planned(q, qd, rank)

    monkeypatch.setattr(dynamics, "start_motion", counted)
    monkeypatch.setattr(dynamics, "plan_method", planned)
    with pytest.raises(Planned) as stopped:
        dynamics.forward_dynamics(system, q0, qd0, 0.1, 2, formulation="joint-coordinates", engine="numpy")
    assert made.count(True) == 1
    q_start, qd_start, rank = stopped.value.args
    assert q_start.tobytes() == q.tobytes() and qd_start.tobytes() == qd.tobytes()
    assert (rank.rank, rank.n_redundant, rank.redundant_joints) == (
        expected.rank,
        expected.n_redundant,
        expected.redundant_joints,
    )
