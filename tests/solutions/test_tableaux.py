"""The Butcher tableaux of the embedded pairs (solutions/tableaux.py): scipy's coefficients to the last bit, the
order conditions they must meet, and runs on them that never import scipy.integrate."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.integrate

from solutions.tableaux import DOP853, RK45, TABLEAUX

REPO = Path(__file__).resolve().parents[2]
FIELDS = ("A", "B", "C", "E", "E5", "E3", "P", "A_EXTRA", "C_EXTRA", "D")


@pytest.mark.parametrize("name", ["RK45", "DOP853"])
def test_the_coefficients_are_scipys(name):
    ours, theirs = TABLEAUX[name], getattr(scipy.integrate, name)
    compared = 0
    for field in FIELDS:
        if getattr(ours, field) is None:  # a field of the other pair (scipy's DOP853 has E, P = NotImplemented)
            assert not isinstance(getattr(theirs, field, None), np.ndarray), field
            continue
        assert np.array_equal(getattr(ours, field), np.asarray(getattr(theirs, field))), field
        compared += 1
    assert compared == (5 if name == "RK45" else 8)
    assert (ours.order, ours.error_estimator_order, ours.n_stages) == (
        theirs.order, theirs.error_estimator_order, theirs.n_stages,
    )  # fmt: skip


@pytest.mark.parametrize("tableau", [RK45, DOP853], ids=["RK45", "DOP853"])
def test_the_stages_meet_the_order_conditions(tableau):
    """Independent of scipy: c_i = sum_j a_ij (each stage at its own time), and the quadrature conditions
    b^T c^(k-1) = 1/k for k = 1 .. order and b^T A c^(k-2) = 1/(k (k-1)) for k = 2 .. order (Hairer, Norsett and
    Wanner, sec. II.2): the method integrates y' = t^(k-1) and y' = y (through a linear stage chain) exactly."""
    B, C = tableau.B, tableau.C
    A = np.zeros((B.size, B.size))  # the stages' square matrix (RK45's A has no column for its last stage)
    A[:, : tableau.A.shape[1]] = tableau.A[: B.size]
    assert np.allclose(A.sum(axis=1), C, atol=1e-14)
    for k in range(1, tableau.order + 1):
        assert B @ C ** (k - 1) == pytest.approx(1.0 / k, abs=1e-14), k
    for k in range(2, tableau.order + 1):
        assert B @ (A @ C ** (k - 2)) == pytest.approx(1.0 / (k * (k - 1)), abs=1e-14), k
    chain = np.linalg.matrix_power(A, tableau.order - 1) @ np.ones_like(C)  # b^T A^(p-1) 1 = 1/p!
    assert B @ chain == pytest.approx(1.0 / math.factorial(tableau.order), abs=1e-14)


@pytest.mark.parametrize("tableau", [RK45, DOP853], ids=["RK45", "DOP853"])
def test_the_error_weights_vanish_on_a_constant(tableau):
    """The error estimate is the difference of two consistent methods: its weights sum to zero."""
    for weights in (tableau.E, tableau.E5, tableau.E3):
        if weights is not None:
            assert abs(weights.sum()) < 1e-14


def test_a_run_on_the_default_integrators_does_not_import_scipy_integrate():
    """Importing scipy.integrate costs longer than a short run: the package's loops (dop853, rk45), the rk4 loop
    and the estimate of the numpy run time (engine auto) step without it."""
    code = (
        "import sys\n"
        "from solutions.assembly import build_system\n"
        "from solutions.dynamics import forward_dynamics\n"
        "from solutions.io.model import load_model\n"
        "s, q, qd = build_system(load_model('course/models/heavy_top.yaml'))\n"
        "for integrator in ('dop853', 'rk45', 'rk4', 'auto'):\n"
        "    forward_dynamics(s, q, qd, 0.01, 2, integrator=integrator, engine='auto')\n"
        "print('scipy.integrate' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"
