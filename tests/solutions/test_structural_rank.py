"""Psi_q's rank by structure: a planar open tree of revolute joints has full row rank with sigma_min >= 1 / nb
(``dynamics.revolute_tree_floor``), which decides the rank rule as the SVD does (``diagnostics.structural_rank``,
``dynamics.rank_at``: no SVD there); every other scene keeps the SVD."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import chains  # noqa: E402
from solutions import dynamics  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.diagnostics import rank_report, structural_rank  # noqa: E402
from solutions.dynamics import revolute_tree_floor  # noqa: E402
from solutions.io.model import load_model  # noqa: E402

MODELS = ROOT / "course" / "models"


@pytest.mark.parametrize("n", [1, 2, 5, 16])
def test_the_floor_bounds_sigma_min_of_a_revolute_tree_at_any_configuration(n):
    """The bound holds at every q, assembled or not (the +-I blocks do not depend on q): random q."""
    system, q0, _ = build_system(load_model(chains.planar_chain(n)))
    floor = revolute_tree_floor(system)
    assert floor == 1.0 / n
    rng = np.random.default_rng(n)
    for _ in range(20):
        q = q0 + rng.normal(scale=3.0, size=q0.size)
        s = np.linalg.svd(system.jacobian(q, 0.0), compute_uv=False)
        assert s[-1] >= floor * (1.0 - 1e-12)


@pytest.mark.parametrize(
    "model",
    [chains.planar_chain(4), chains.planar_chain(16), MODELS / "double_pendulum.yaml", MODELS / "simple_pendulum.yaml"],
)
def test_a_revolute_tree_s_rank_is_made_without_an_svd_and_agrees_with_it(monkeypatch, model):
    """rank_at gives rank_report's rank, redundancy and joints on a revolute tree, and calls no SVD for it."""
    system, q0, _ = build_system(load_model(model))
    reference = rank_report(system.jacobian(q0, 0.0), system.row_owners)
    called = []
    monkeypatch.setattr(dynamics, "rank_report", lambda *a, **k: called.append(1) or rank_report(*a, **k))
    found = dynamics.rank_at(system, q0)
    assert not called
    assert (found.rank, found.n_redundant, found.redundant_joints) == (reference.rank, 0, [])
    assert found.degrees_of_freedom == reference.degrees_of_freedom
    assert found.singular_values is None and np.isnan(found.condition_number)


@pytest.mark.parametrize(
    "model",
    [
        chains.loop_chain(2),
        chains.spatial_chain(2),
        MODELS / "slider_crank.yaml",
        MODELS / "parallel_swing.yaml",
        MODELS / "carriage_pendulum.yaml",
    ],
)
def test_other_scenes_keep_the_svd(model):
    """Closed loops, drivers, prismatic joints, spatial joints: no floor, rank_report's verdict itself."""
    system, q0, _ = build_system(load_model(model))
    assert revolute_tree_floor(system) is None
    found, reference = dynamics.rank_at(system, q0), rank_report(system.jacobian(q0, 0.0), system.row_owners)
    assert found.rank == reference.rank and found.redundant_joints == reference.redundant_joints
    assert np.array_equal(found.singular_values, reference.singular_values)


def test_a_floor_that_does_not_clear_the_tolerance_leaves_the_rank_to_the_svd():
    """Where the floor is not above twice the rule's tolerance bound, structural_rank says nothing."""
    jacobian = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    assert structural_rank(jacobian, 0.5).rank == 2
    assert structural_rank(jacobian, 1e-9) is None
    assert structural_rank(jacobian.T, 0.5) is None  # more rows than columns: never full row rank
