"""What the engine compiles, and where (``mbd compile``, a first run): no function that no run calls, and no function
compiled in two processes.

- A tree's generated module (``compiled/tree.py``) is ``scene_rhs`` alone: Psi, Psi_q and Psi_t at the output times
  come from its output pass (``loops.output_history``), also where a large Psi_q's rows reach other columns than
  their bodies' (no blocks to keep), where the module's ``constraint_arrays`` made a second pass before.
- The kernels called with constants: one version each (``kernels.typed``).
- ``mbd compile`` (``precompile.GROUPS``): both tree modules in one process, where their kernels (``tree_kernels``,
  ``articulated``: not cached on disk) are compiled once, each group after the halves of the loops it imports.
- No compiled function assigns an array into a slice (``loops._copy``): numba compiles the shape check's formatted
  error message (strings) into every function that does.
"""

from __future__ import annotations

import ast
from pathlib import Path

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


_COMPILED = ("jit", "njit", "inlined", "_inline", "typed", "eager", "at_first_call")
"""The decorators of the package's compiled functions (numba's and the modules' own names for them)."""


def _array_slice_assignments(source: str, name: str, compiled_only: bool = True) -> list[str]:
    """``name:line`` of every assignment in ``source``'s compiled functions (all of its functions if not
    ``compiled_only``) whose target slices an array (``a[:]``, ``a[i:j]``, ``a[:, r]``) and whose value is not a
    number: the assignments numba compiles with its formatted shape-mismatch message."""
    found = []
    for function in ast.walk(ast.parse(source)):
        if not isinstance(function, ast.FunctionDef):
            continue
        decorators = {ast.unparse(d).split("(")[0] for d in function.decorator_list}
        if compiled_only and not decorators & set(_COMPILED):
            continue
        for node in ast.walk(function):
            if not isinstance(node, ast.Assign):
                continue
            targets = [
                t for target in node.targets for t in (target.elts if isinstance(target, ast.Tuple) else [target])
            ]
            sliced = any(isinstance(t, ast.Subscript) and any(isinstance(i, ast.Slice) for i in ast.walk(t.slice))
                         for t in targets)  # fmt: skip
            values = node.value.elts if isinstance(node.value, ast.Tuple) else [node.value]
            numbers = all(isinstance(v, ast.Constant) or ast.unparse(v) in ("np.nan", "np.inf") for v in values)
            if sliced and not numbers:
                found.append(f"{name}:{node.lineno}")
    return found


def test_no_compiled_function_assigns_an_array_into_a_slice():
    """The compiled modules' functions and the generated modules copy arrays by loops (``loops._copy``), not by
    slice assignments: numba compiles a slice assignment's shape check with a formatted error message (strings,
    integers' text, a join), ~3 s of each process's first compilation and more LLVM work in every function with one
    (``mbd compile`` 160 -> 148 s of CPU: call_cost.md, thirtieth session). Assigning a number (``x[:] = 0.0``) is
    not one of them."""
    from solutions import compiled
    from solutions.compiled import codegen, projection, tree
    from solutions.formulations import make_formulation
    from solutions.generalized_forces import build_forces
    from solutions.mass_matrix import mass_matrix

    package = Path(compiled.__file__).parent
    found = [
        hit for path in sorted(package.glob("*.py")) for hit in _array_slice_assignments(path.read_text(), path.name)
    ]
    for model in ("course/models/slider_crank.yaml", "course/models/spatial_double_pendulum.yaml"):
        system, _, _ = build_system(load_model(model))
        M, forces = mass_matrix(system.model), build_forces(system.model)
        for formulation, generate in (("baumgarte", codegen.generate), ("projection", projection.generate),
                                      ("joint-coordinates", tree.generate)):  # fmt: skip
            made = make_formulation(formulation, system, M, forces)
            text = generate(compiled.plan(system, M, forces, formulation, made).scene)
            found += _array_slice_assignments(text, f"{model} {formulation}", compiled_only=False)
    assert not found
