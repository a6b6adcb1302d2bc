"""What the engine compiles, and where (``mbd compile``, a first run): no function that no run calls, and no function
compiled in two processes.

- A tree's generated module (``compiled/tree.py``) is ``scene_rhs`` alone: Psi, Psi_q and Psi_t at the output times
  come from its output pass (``loops.output_history``), also where a large Psi_q's rows reach other columns than
  their bodies' (no blocks to keep), where the module's ``constraint_arrays`` made a second pass before.
- The kernels called with constants: one version each (``kernels.typed``).
- ``mbd compile`` (``precompile.GROUPS``): both tree modules in one process, where their kernels (``tree_kernels``,
  ``articulated``: not cached on disk) are compiled once, each group after the halves of the loops it imports.
"""

from __future__ import annotations

import numpy as np
import pytest

from solutions.assembly import build_system
from solutions.compiled.precompile import FORMULATIONS, GROUPS, PENDULUMS, SHARED, parts
from solutions.dynamics import forward_dynamics
from solutions.io import load_model

pytest.importorskip("numba")


def test_a_tree_module_is_its_right_hand_side_alone():
    """The generated text of a tree's module defines ``scene_rhs`` and no ``constraint_arrays`` (every constraint
    kernel linked and optimized a second time, for a pass no run makes)."""
    from solutions import compiled
    from solutions.compiled import tree
    from solutions.formulations import make_formulation
    from solutions.generalized_forces import build_forces
    from solutions.mass_matrix import mass_matrix

    system, _, _ = build_system(load_model("course/models/slider_crank.yaml"))
    M, forces = mass_matrix(system.model), build_forces(system.model)
    made = make_formulation("joint-coordinates", system, M, forces)
    text = tree.generate(compiled.plan(system, M, forces, "joint-coordinates", made).scene)
    assert "def scene_rhs(" in text and "def constraint_arrays(" not in text


def test_a_tree_whose_rows_reach_other_columns_keeps_one_output_pass(monkeypatch):
    """Above ``ONE_PASS_LARGEST``, a tree whose rows reach other columns than their bodies' (``row_columns`` None:
    no blocks) takes Psi, Psi_q and Psi_t from its one output pass, dense, the same to the last bit as the run below
    the limit, as are its results (the module's ``constraint_arrays``, which it no longer has, never asked for)."""
    import solutions.compiled as compiled
    from solutions.compiled import history, loops, scene

    passes = []
    output_history = loops.output_history

    def recorded(*arguments):
        passes.append(output_history(*arguments))
        return passes[-1]

    def second_pass(*arguments):
        raise AssertionError("the constraints evaluated again after the output pass")

    monkeypatch.setattr(loops, "output_history", recorded)
    options = dict(formulation="joint-coordinates", integrator="DOP853", rtol=1e-8, engine="compiled")
    runs = []
    for largest in (compiled.ONE_PASS_LARGEST, 0):
        monkeypatch.setattr(compiled, "ONE_PASS_LARGEST", largest)
        monkeypatch.setattr(scene, "_row_columns", lambda system: None)  # no blocks: rows reaching further
        monkeypatch.setattr(history, "constraint_arrays", second_pass)
        system, q0, qd0 = build_system(load_model("course/models/slider_crank.yaml"))  # described anew
        runs.append(forward_dynamics(system, q0, qd0, 0.3, 12, divergence="skip", **options))
    assert len(passes) == 2 and passes[1][2].shape == (13, system.n_constraints, system.n_coordinates)
    for below, above in zip(*passes, strict=True):  # y' and the outputs, Psi, Psi_q, Psi_t
        np.testing.assert_array_equal(below, above)
    for name in ("q", "qd", "qdd", "lam"):
        np.testing.assert_array_equal(getattr(runs[0], name), getattr(runs[1], name), err_msg=name)
    for kind in ("points", "reactions", "forces"):
        for key, value in getattr(runs[0], kind).items():
            np.testing.assert_array_equal(getattr(runs[1], kind)[key], value, err_msg=key)


def test_mbd_compile_takes_every_module_once_both_trees_in_one_process():
    """``GROUPS``: every generated module in exactly one group, both dimensions' tree modules (joint coordinates) in
    the same one, and each group after the halves of the loops it imports: the kinematic modules after the
    kinematic step loop, every other after the integrator loops."""
    modules = [name for dimension in PENDULUMS for name, _ in parts(dimension)]
    grouped = [name for _, names in GROUPS for name in names]
    assert sorted(grouped) == sorted(modules) and len(grouped) == len(set(grouped))
    trees = [f"{dimension} joint-coordinates" for dimension in PENDULUMS]
    assert any(set(trees) <= set(names) for _, names in GROUPS)
    for needs, names in GROUPS:
        assert set(needs) <= set(SHARED)
        assert all(("kinematic loops" if name.endswith("kinematic") else "integrator loops") in needs for name in names)
    assert {name.split(" ", 1)[1] for name in grouped} == {*FORMULATIONS, "kinematic"}


def test_the_kernels_called_with_a_constant_flag_or_body_are_compiled_once():
    """``augmented_solve`` (spatial True or False), ``_mass_solve`` (first body 0) and ``_spatial_torque`` (body frame
    False) under one explicit signature each (``kernels.typed``): numba converts the constant instead of compiling
    one version per value (two, three and two versions before, each optimized again in every caller)."""
    from solutions.compiled import kernels

    for dispatcher in (kernels.augmented_solve, kernels._mass_solve, kernels._spatial_torque):
        assert len(dispatcher.nopython_signatures) == 1 and not dispatcher._can_compile
