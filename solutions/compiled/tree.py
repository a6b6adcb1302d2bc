"""Joint coordinates, compiled: the tree's data for the kernels, and the generated module of a tree scene.

``joint_coordinates.JointCoordinates`` integrates the joint state y = (joint positions, joint velocities) of a
spanning tree with (D^T M D) theta'' = D^T (Q - M xi) (eq. 5.44 with Z = D), q, q', D and xi made by
recursive kinematics from ground. The compiled engine takes open trees (no cut joint, no driver: nothing to
stabilize), planar (revolute, prismatic) and spatial (revolute, prismatic, spherical), with the forces the
kernels cover (``scene.py``). ``describe(scene, formulation)`` reads the tree the numpy formulation built
(``TreeJoint``, after its ``initial_state``, which fixes the sign of a prismatic joint's Euler parameters) into
the arrays of ``tree_kernels.py``; ``generate`` writes the module:

- ``scene_rhs(t, z, P, D, out)``: y' = (the rates of the joint positions, theta''[, P_dissipated, P_applied,
  0]) (``loops.RHS_SIGNATURE``: the integrator loops take it as they take the Baumgarte one);
- ``body_state(t, y, P, D, q, q', q'', lambda)``: the body coordinates at a joint state and lambda of the model's
  constraint rows from Psi_q^T lambda = Q - M q'' (normal equations; ``JointCoordinates.accelerations``),
  for the results and reactions (``loops.body_outputs``).

No numba here; the generated module is cached as ``codegen.py`` caches the scene's own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .codegen import CONSTRAINT_CALLS, FORCE_CALL, generated_name, is_generated_cached, load_generated
from .scene import SLOTS, Scene

SOURCES = ("tree_kernels.py", "projection_kernels.py")
KINDS = {"revolute": 0, "prismatic": 1, "spherical": 2}


@dataclass
class TreeScene:
    """A scene (``scene.Scene``: its forces and constraint rows) with the joints of its tree."""

    scene: Scene
    ints: np.ndarray
    floats: np.ndarray
    n_positions: int
    k: int
    unsupported: str | None = None

    @property
    def key(self) -> str:
        return "tree|" + self.scene.key

    def data(self) -> tuple:
        """D of the scene with the tree's joints in their slot."""
        ints, floats = self.scene.data()
        slot = SLOTS.index("tree")
        ints = (*ints[:slot], np.ascontiguousarray(self.ints), *ints[slot + 1 :])
        floats = (*floats[:slot], np.ascontiguousarray(self.floats), *floats[slot + 1 :])
        return ints, floats


def _row(joint) -> list[float]:
    pad = [0.0] * (3 - len(joint.s_parent))
    frame = [v for axis in joint.frame for v in axis] or [0.0] * 9
    return [
        *joint.s_parent, *pad, *joint.s_child, *pad, *joint.axis, *([0.0] * (3 - len(joint.axis))), joint.offset,
        *joint.a, *joint.c, *joint.u0, *joint.u1, *frame,
    ]  # fmt: skip


def describe(scene: Scene, formulation) -> TreeScene:
    """The tree of a ``JointCoordinates`` formulation over the scene (``unsupported`` says why not compiled)."""
    joints = formulation.joints
    k = formulation.tree.k
    rows = []
    for j in joints:  # the columns of D that move the child: its parent's and the joint's own
        moving = [*j.inherited, *range(j.velocity, j.velocity + j.n_velocities)]
        rows.append([KINDS[j.kind], j.parent, j.child, j.position, j.velocity, len(moving), *moving])
        rows[-1] += [-1] * (6 + k - len(rows[-1]))
    ints = np.array(rows, dtype=np.int64).reshape(-1, 6 + k)
    floats = np.array([_row(j) for j in joints], dtype=float).reshape(-1, 35)
    tree = TreeScene(scene, ints, floats, formulation.tree.n_positions, formulation.tree.k)
    if formulation.cut is not None:
        cut = ", ".join(dict.fromkeys(formulation.cut.row_owners))
        tree.unsupported = f"closed loops or drivers in joint coordinates (cut at {cut})"
    elif not joints:
        tree.unsupported = "a tree without joints"
    return tree


def _accelerations(scene: Scene, rates: str, coordinates: bool) -> list[str]:
    """The lines that make (``coordinates``: q and q'), xi, D, omega', Q and the powers, and theta'' (``thdd``),
    at the joint state y; the arrays cut from one allocation."""
    spatial = scene.dimension == 3
    per = 6 if spatial else 3
    slot = SLOTS.index("tree")
    data = f"D[0][{slot}], D[1][{slot}]"
    lines = [
        "    Q0, mass, masses, inertias, weights, fk, fp, numbers, dims = P",
        "    n, m, npos, k = dims[0], dims[1], dims[3], dims[4]",
        f"    nb = n // {7 if spatial else 3}",
        f"    a, b = {per} * nb, {per} * nb * (k + 1)  # xi, D",
        f"    work = np.empty(b + 3 * nb + n + 3{' + 2 * n' if coordinates else ''})",
        "    xi, Dm, omega = work[:a], work[a:b].reshape((a, k)), work[b : b + 3 * nb].reshape((nb, 3))",
        "    Q, power = work[b + 3 * nb : b + 3 * nb + n], work[b + 3 * nb + n : b + 3 * nb + n + 3]",
        "    Q[:] = Q0",
        "    power[:] = 0.0",
    ]
    if coordinates:
        lines.append("    q, qd = work[b + 3 * nb + n + 3 : b + 3 * nb + 2 * n + 3], work[b + 3 * nb + 2 * n + 3 :]")
    if spatial:
        lines.append(f"    spatial_motion(y[:npos], y[npos : npos + k], {data}, nb, k, q, qd, xi, Dm, omega, {rates})")
    else:
        lines.append(f"    planar_motion(y[:npos], y[npos : npos + k], {data}, nb, k, q, qd, xi, Dm)")
    for name, _, _ in scene.force_kernels:
        s = SLOTS.index(name)
        lines.append("    " + FORCE_CALL.format(name=name, ints=f"D[0][{s}]", floats=f"D[1][{s}]"))
    if spatial:
        lines.append(f"    thdd = spatial_accelerations(masses, inertias, q, Dm, xi, omega, Q, D[0][{slot}])")
    else:
        lines.append(f"    thdd = planar_accelerations(mass, Dm, xi, Q, D[0][{slot}])")
    return lines


def generate(tree: TreeScene) -> str:
    """The source text of the tree scene's module (module docstring): the joint accelerations written out in
    both functions (P and D stay in the function that receives them: passing them on costs more than the
    arithmetic of a small tree)."""
    scene = tree.scene
    spatial = scene.dimension == 3
    forces = [name for name, _, _ in scene.force_kernels]
    constraints = [name for name, _, _ in scene.constraint_kernels]
    kernels = sorted({*forces, *constraints, "lu_solve"} | ({"spatial_mass"} if spatial else set()))
    if spatial:
        tree_imports = ["spatial_accelerations", "spatial_coordinate_accelerations", "spatial_motion"]
    else:
        tree_imports = ["planar_accelerations", "planar_motion"]
    lines = [
        f'"""Generated by solutions.compiled.tree for the structure {tree.key!r}: do not edit."""',
        "import numpy as np",
        "from numba import njit",
        "",
        f"from solutions.compiled.kernels import {', '.join(kernels)}",
        "from solutions.compiled.loops import BODY_STATE_SIGNATURE, RHS_SIGNATURE",
        f"from solutions.compiled.tree_kernels import {', '.join(tree_imports)}",
        "",
        "",
        "@njit(RHS_SIGNATURE, cache=True, nogil=True)",
        "def scene_rhs(t, y, P, D, out):",
        '    """y\' = (the rates of the joint positions, theta\'\'[, P_dissipated, P_applied, 0])."""',
        *_accelerations(scene, "out[:npos]", True),
        *([] if spatial else ["    out[:npos] = y[npos : npos + k]  # planar: the rates are theta'"]),
        "    out[npos : npos + k] = thdd",
    ]
    if scene.energies:
        lines.append("    out[npos + k], out[npos + k + 1], out[npos + k + 2] = power[0], power[1], 0.0")
    lines += [
        "",
        "",
        "@njit(BODY_STATE_SIGNATURE, cache=True, nogil=True)",
        "def body_state(t, y, P, D, q, qd, qdd, lam):",
        '    """q, q\', q\'\' and lambda (Psi_q^T lambda = Q - M q\'\', normal equations) at the joint state y."""',
        *_accelerations(scene, "np.empty(npos)", False),
    ]
    if spatial:
        lines += [
            "    spatial_coordinate_accelerations(q, qd, Dm, xi, omega, thdd, qdd)",
            "    M = np.zeros((n, n))",
            "    spatial_mass(q, qd, masses, inertias, weights, M, Q)  # M(q) and Q += Q_v (eq. 10.4, 10.5)",
            "    residual = Q - M @ qdd",
        ]
    else:
        lines += ["    qdd[:] = Dm @ thdd + xi", "    residual = Q - mass * qdd"]
    lines += [
        "    psi, psit, gam = np.zeros(m), np.zeros(m), np.zeros(m)",
        "    jac = np.zeros((m, n))",
    ]
    for name in constraints:
        s = SLOTS.index(name)
        lines.append("    " + CONSTRAINT_CALLS[name].format(name=name, ints=f"D[0][{s}]", floats=f"D[1][{s}]"))
    lines.append("    lam[:] = lu_solve(jac @ jac.T, jac @ residual)")
    return "\n".join(lines) + "\n"


def module_name(tree: TreeScene) -> str:
    return generated_name("mbd_tree_", generate(tree), SOURCES)


def is_cached(tree: TreeScene) -> bool:
    """Whether numba's machine code of the tree scene's right-hand side is on disk."""
    return is_generated_cached(module_name(tree), "scene_rhs")


def load(tree: TreeScene) -> tuple[object, bool]:
    """The tree scene's compiled module, and whether its machine code was on disk already."""
    text = generate(tree)
    return load_generated(generated_name("mbd_tree_", text, SOURCES), text, "scene_rhs")


__all__ = ["TreeScene", "describe", "generate", "is_cached", "load"]
