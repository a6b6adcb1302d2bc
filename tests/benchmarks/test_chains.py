"""The scaling study's references (benchmarks/chains.py): each chain family's ODE, written for the benchmark without
the package's code, against the package's runs of the same chain at tight tolerance. They agree to 1e-11 m or so,
so a configuration's error in the study is its own, not its reference's."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import chains  # noqa: E402
from benchmarks.bench import body_positions  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.dynamics import forward_dynamics  # noqa: E402
from solutions.io.model import load_model  # noqa: E402

TIMES = np.linspace(0.0, chains.T_END, chains.OUTPUTS + 1)


@pytest.mark.parametrize(
    ("family", "n", "formulation"),
    [("planar", 3, "joint-coordinates"), ("spatial", 3, "joint-coordinates"), ("spatial", 2, "baumgarte"),
     ("loops", 2, "baumgarte")],  # fmt: skip
)
def test_each_family_s_reference_is_the_package_s_motion(family, n, formulation):
    system, q0, qd0 = build_system(load_model(chains.FAMILIES[family](n)))
    run = forward_dynamics(system, q0, qd0, chains.T_END, chains.OUTPUTS, formulation, "dop853", rtol=1e-11,
                           atol=1e-11, engine="numpy")  # fmt: skip
    truth = chains.reference(family, n, system, q0, qd0, TIMES)
    ours = body_positions(run.q, system.model.dimension)
    assert truth.shape == ours.shape
    assert np.max(np.abs(truth - truth[0])) > 0.3  # the chain moves: a reference frozen at the start would fail
    assert np.max(np.abs(ours - truth)) < 1e-8

