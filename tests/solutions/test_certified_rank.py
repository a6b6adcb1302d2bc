"""Psi_q's rank certified without its SVD where it is full (``diagnostics.full_row_rank``: a shifted Cholesky of
Psi_q Psi_q^T), the same verdict as the SVD's rule (``rank_report``), and the SVD wherever the certificate fails
(redundant rows, a configuration near a singular one)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import chains  # noqa: E402
from solutions import diagnostics  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.diagnostics import full_row_rank, rank_at, rank_report  # noqa: E402
from solutions.io.model import load_model  # noqa: E402
from solutions.linalg import RANK_EPS  # noqa: E402

MODELS = ROOT / "course" / "models"


@pytest.mark.parametrize(
    "model",
    [
        chains.loop_chain(4),
        chains.loop_chain(16),
        chains.planar_chain(16),
        chains.spatial_chain(4),
        MODELS / "double_pendulum.yaml",
        MODELS / "slider_crank.yaml",
        MODELS / "spatial_double_pendulum.yaml",
    ],
)
def test_a_full_rank_psi_q_is_certified_without_an_svd_and_agrees_with_it(monkeypatch, model):
    """rank_at gives rank_report's rank, redundancy and joints where Psi_q has full row rank, and calls no SVD."""
    system, q0, _ = build_system(load_model(model))
    reference = rank_report(system.jacobian(q0, 0.0), system.row_owners)
    called = []
    monkeypatch.setattr(diagnostics, "rank_report", lambda *a, **k: called.append(1) or rank_report(*a, **k))
    found = rank_at(system, q0)
    assert not called
    assert (found.rank, found.n_redundant, found.redundant_joints) == (reference.rank, 0, [])
    assert found.degrees_of_freedom == reference.degrees_of_freedom
    assert found.singular_values is None and np.isnan(found.condition_number)


def test_redundant_rows_are_left_to_the_svd_which_names_the_joints():
    """A redundant joint (the parallel swing): the certificate fails, the SVD's report itself."""
    system, q0, _ = build_system(load_model(MODELS / "parallel_swing.yaml"))
    jacobian = system.jacobian(q0, 0.0)
    assert full_row_rank(jacobian) is None
    found, reference = rank_at(system, q0), rank_report(jacobian, system.row_owners)
    assert found.n_redundant == reference.n_redundant > 0 and found.redundant_joints == reference.redundant_joints
    assert np.array_equal(found.singular_values, reference.singular_values)


@pytest.mark.parametrize("m", [2, 10, 40])
def test_the_certificate_fails_before_sigma_min_reaches_twice_the_rule_s_tolerance(m):
    """Psi_q = U diag(s) V^T with sigma_min swept down through the rule's tolerance: where the certificate holds,
    sigma_min is above twice the tolerance bound max(m, n) sqrt(eps) ||Psi_q||_F (so the SVD counts m); below it,
    at the tolerance and at zero, it says nothing. Where it holds the rule says m as well."""
    n = m + 3
    rng = np.random.default_rng(m)
    U, _ = np.linalg.qr(rng.normal(size=(m, m)))
    V, _ = np.linalg.qr(rng.normal(size=(n, n)))
    held = []
    for smallest in np.geomspace(1.0, 1e-12, 60):
        s = np.linspace(1.0, smallest, m)
        jacobian = U @ np.diag(s) @ V[:m]
        found = full_row_rank(jacobian)
        bound = 2.0 * max(m, n) * RANK_EPS * np.linalg.norm(jacobian)
        if found is not None:
            held.append(smallest)
            assert smallest > bound and found.rank == m
            assert rank_report(jacobian, ["j"] * m).rank == m
    assert held and min(held) > 1e-7  # it held at the well-conditioned end, never down at the tolerance
    assert full_row_rank(np.zeros((2, 3))) is None
    assert full_row_rank(np.eye(3)[:, :2]) is None  # more rows than columns: never full row rank
    assert full_row_rank(np.array([[np.nan, 1.0, 0.0]])) is None
