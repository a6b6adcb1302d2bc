"""The description of a joint-coordinates tree at a call's start (``compiled.tree.describe``, ``compiled.parameters``,
``joint_coordinates.tree_joints``): made with less work, the same arrays.

- each joint's 35 floats (``tree._row``) equal the reference row written out here (s_parent, s_child and the axis
  padded to 3, the offset, a, c, u0, u1, the frame or nine zeros), planar and spatial, every joint kind;
- P[8] is the sizes and then the tree's integer tables in order (``TreeScene.arrays``: cut rows, owners, cut rows'
  bodies, the row index, the cut solve's sparsity), concatenated;
- D's offsets: each slot's start, then where its cut elements stop (``TreeScene.data``);
- the joints a run never writes are handed out as built, a spatial prismatic joint (whose ``u0`` a run's
  ``joint_state`` sets) as a copy per formulation.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from chains import loop_chain, planar_chain, spatial_chain  # noqa: E402

from solutions.assembly import build_system  # noqa: E402
from solutions.compiled import parameters, plan  # noqa: E402
from solutions.compiled.scene import SLOTS  # noqa: E402
from solutions.compiled.tree import _row  # noqa: E402
from solutions.dynamics import mass_matrix  # noqa: E402
from solutions.formulations import make_formulation  # noqa: E402
from solutions.generalized_forces import build_forces  # noqa: E402
from solutions.io import load_model  # noqa: E402
from solutions.joint_coordinates import tree_joints  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
MODELS = [
    loop_chain(3),
    planar_chain(4),
    spatial_chain(3),
    ROOT / "course" / "models" / "slider_crank.yaml",
    ROOT / "course" / "models" / "spatial_slider_crank.yaml",
    ROOT / "course" / "models" / "heavy_top.yaml",
]


def _made(model):
    system = build_system(load_model(model))[0]
    M, forces = mass_matrix(system.model), build_forces(system.model)
    return system, M, forces, make_formulation("joint-coordinates", system, M, forces)


def _reference_row(joint) -> list[float]:
    """The joint's floats as written before session 26 (one list of unpackings and padding lists)."""
    pad = [0.0] * (3 - len(joint.s_parent))
    frame = [v for axis in joint.frame for v in axis] or [0.0] * 9
    return [
        *joint.s_parent, *pad, *joint.s_child, *pad, *joint.axis, *([0.0] * (3 - len(joint.axis))), joint.offset,
        *joint.a, *joint.c, *joint.u0, *joint.u1, *frame,
    ]  # fmt: skip


@pytest.mark.parametrize("model", MODELS, ids=lambda m: getattr(m, "stem", None) or m.get("name", "chain"))
def test_each_joint_row_equals_the_reference_row(model):
    made = _made(model)[3]
    kinds = {joint.kind for joint in made.joints}
    assert kinds
    for joint in made.joints:
        row = _row(joint)
        assert len(row) == 35 and row == _reference_row(joint)


@pytest.mark.parametrize("model", MODELS[:4], ids=["loops", "planar", "spatial", "slider_crank"])
def test_p8_is_the_sizes_then_the_trees_tables_and_d_s_offsets_the_starts_then_the_cut_stops(model):
    pytest.importorskip("numba")
    system, M, forces, made = _made(model)
    tree = plan(system, M, forces, "joint-coordinates", made).scene
    dims = parameters(tree, 1.0, 2.0).__getitem__(8)
    assert dims.dtype == np.int64 and dims.flags.c_contiguous
    scene = tree.scene
    drivers_power = int(scene.drivers and scene.energies)
    sizes = [scene.n, scene.m, 3 if scene.energies else 0, tree.n_positions, tree.k, drivers_power]
    tables = [tree.cut_rows, tree.owners, tree.cut_bodies, tree.row_index, tree.structure()]
    assert dims.tolist() == [*sizes, tree.cut_rows.size, *(v for table in tables for v in table.tolist())]
    offsets = tree.data()[2]
    starts, stops = offsets[: len(SLOTS) + 1], offsets[len(SLOTS) + 1 :]
    assert stops.tolist() == [starts[s] + scene.first_counts.get(name, 0) for s, name in enumerate(SLOTS)]


def test_the_joints_a_run_never_writes_are_shared_and_a_spatial_prismatic_joint_copied():
    planar = build_system(load_model(loop_chain(2)))[0]
    first, second = tree_joints(planar), tree_joints(planar)
    assert all(a is b for a, b in zip(first, second, strict=True))
    spatial = build_system(load_model(ROOT / "course" / "models" / "spatial_slider_crank.yaml"))[0]
    first, second = tree_joints(spatial), tree_joints(spatial)
    prismatic = [a.kind == "prismatic" for a in first]
    assert any(prismatic) and not all(prismatic)
    for a, b, copied in zip(first, second, prismatic, strict=True):
        assert (a is not b) if copied else (a is b)
        assert vars(a) == vars(b)


@pytest.mark.parametrize("model", MODELS, ids=lambda m: getattr(m, "stem", None) or m.get("name", "chain"))
def test_a_second_calls_description_reuses_the_systems_topology_with_the_same_arrays(model):
    """The tree's integers (``tree.topology``) are made once per system: a second call's plan (a new M, force model
    and formulation object, as ``forward_dynamics`` makes them) shares them, and its P, D and every table equal those
    of the same model built afresh, entry for entry (the cut solve's sparsity made by the first call's parameters,
    handed to the second)."""
    pytest.importorskip("numba")
    from solutions.compiled import tree as tree_module

    system = build_system(load_model(model))[0]
    first, P1, D1 = _described(system)
    second, P2, D2 = _described(system)
    fresh, P3, D3 = _described(build_system(load_model(model))[0])
    assert second is not first and second.topology is first.topology is tree_module.topology(system, [], 0)
    assert second.structure() is first.structure()  # made once, by the first call's parameters
    spatial_prismatic = system.model.dimension == 3 and any(j.kind == "prismatic" for j in tree_joints(system))
    assert (second.floats is first.floats) != spatial_prismatic  # a spatial prismatic joint's: each call's own
    for a, b in [*zip(P2, P3, strict=True), *zip(D2, D3, strict=True)]:
        assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)
    for name in ("ints", "floats", "cut_rows", "owners", "cut_bodies", "row_index"):
        assert np.array_equal(getattr(second, name), getattr(fresh, name)), name
    assert np.array_equal(second.structure(), fresh.structure())


def test_a_changed_elements_data_is_read_by_the_next_calls_description():
    """What an element holds besides the tree's structure (its points, a driver's function of time) is read at every
    call, not kept on the system: a driver's function changed between two calls changes the next call's data."""
    pytest.importorskip("numba")
    from solutions.functions import Polynomial

    system = build_system(load_model(ROOT / "course" / "models" / "slider_crank.yaml"))[0]
    before = _described(system)[0].scene.function_params.copy()
    motor = next(e for e in system.elements if getattr(e, "function", None) is not None and e.name == "drive")
    motor.function = Polynomial((0.5, 7.0))
    after = _described(system)[0].scene.function_params
    assert not np.array_equal(before, after) and 7.0 in after


def _described(system):
    """(the joint-coordinates plan's tree, its P, its D) of a call on ``system``: a new M, force model and
    formulation object, as ``forward_dynamics`` makes them."""
    M, forces = mass_matrix(system.model), build_forces(system.model)
    made = make_formulation("joint-coordinates", system, M, forces)
    tree = plan(system, M, forces, "joint-coordinates", made).scene
    return tree, parameters(tree, 1.0, 2.0), tree.data()
