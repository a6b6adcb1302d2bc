"""solutions/symbolic.py: the symbolic Psi, Psi_q, Psi_t and gamma of every example model agree with the
numeric arrays of the solver, at states off the constraints and with arbitrary velocities; `mbd derive`."""

from __future__ import annotations

import zlib
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from solutions.assembly import build_system
from solutions.cli import main
from solutions.io.model import load_model
from solutions.kinematics import assemble
from solutions.symbolic import derive_system, function_expression, planar_rotation

MODELS = sorted((Path(__file__).resolve().parents[2] / "course" / "models").glob("*.yaml"))


@cache
def derived(path: Path):
    system, q0, _ = build_system(load_model(path))
    derivation = derive_system(system)
    return system, assemble(system, q0)[0], derivation, derivation.functions()


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_symbolic_arrays_equal_the_solvers_on_every_example_model(path):
    system, q, derivation, f = derived(path)
    assert derivation.labels == system.labels and len(derivation.q) == system.n_coordinates
    rng = np.random.default_rng(zlib.crc32(path.stem.encode()))
    for t in (0.0, 0.137):
        x = q + 1e-3 * rng.standard_normal(q.size)  # off the constraints: the formulas, not just Psi = 0
        xd = rng.standard_normal(q.size)
        numeric = (system.constraints(x, t), system.jacobian(x, t), system.psi_t(x, t), system.gamma(x, xd, t))
        symbolic = (f["psi"](x, t), f["jacobian"](x, t), f["psi_t"](x, t), f["gamma"](x, xd, t))
        for name, a, b in zip(("Psi", "Psi_q", "Psi_t", "gamma"), numeric, symbolic, strict=True):
            assert a.shape == b.shape, name
            scale = 1.0 + np.abs(a).max()
            assert np.abs(a - b).max() <= 1e-9 * scale, (name, np.abs(a - b).max())


def test_gamma_of_a_revolute_joint_to_ground_is_eq_3_17():
    system, _, derivation, _ = derived(MODELS[[p.stem for p in MODELS].index("simple_pendulum")])
    joint = system.elements[0]
    phi, phid = derivation.q[2], derivation.qd[2]
    # eq. 3.17: gamma = A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2 with i = ground
    expected = -planar_rotation(phi) * sp.Matrix(joint.sj) * phid**2
    assert sp.simplify(derivation.gamma[:2, 0] - expected) == sp.zeros(2, 1)
    assert derivation.psi_t == sp.zeros(2, 1)


@pytest.mark.parametrize(
    "spec",
    [
        {"type": "polynomial", "coefficients": [0.1, 2.0, -0.5]},
        {"type": "harmonic", "amplitude": 0.3, "frequency": 4.0, "phase": 0.2, "offset": 1.0},
    ],
)
def test_function_expressions_match_the_numeric_functions_and_their_derivatives(spec):
    from solutions.functions import function_from_spec

    function, x = function_from_spec(spec), sp.Symbol("x")
    expr = function_expression(function, x)
    for value in (0.0, 0.7, 2.3):
        got = [float(expr.diff(x, k).subs(x, value)) for k in range(3)]
        assert got == pytest.approx([function.value(value), function.first(value), function.second(value)], abs=1e-12)


def test_mbd_derive_prints_the_equations_and_refuses_a_bad_file(capsys, tmp_path):
    model = str(MODELS[[p.stem for p in MODELS].index("slider_crank")])
    assert main(["derive", model]) == 0
    out = capsys.readouterr().out
    assert "[O.x]" in out and "dPsi/dphi_crank" in out and "gamma" in out and "Psi_t" in out  # the driver row
    assert main(["derive", model, "--latex"]) == 0
    assert "\\cos{\\left(" in capsys.readouterr().out
    bad = tmp_path / "bad.yaml"
    bad.write_text("model: {name: x, dimension: 2, bodies: []}\n")
    assert main(["derive", str(bad)]) == 2
