"""Joint coordinates, compiled: the tree's data for the kernels, and the generated module of a tree scene.

``joint_coordinates.JointCoordinates`` integrates the joint state y = (joint positions, joint velocities) of a
spanning tree with (D^T M D) theta'' = D^T (Q - M xi) (eq. 5.44 with Z = D), q, q', D and xi made by
recursive kinematics from ground, planar (revolute, prismatic) and spatial (revolute, prismatic, spherical);
closed loops and drivers are cut constraints, whose rows join as an augmented system stabilized on the cut
rows (eq. 5.29, 5.30 in joint coordinates). The compiled engine takes what the numpy formulation takes with the
forces and constraints the kernels cover (``scene.py``). ``describe(scene, formulation)`` reads the tree the
numpy formulation built (``TreeJoint``, after its ``initial_state``, which fixes the sign of a prismatic
joint's Euler parameters) into the arrays of ``tree_kernels.py``, and the cut rows among the scene's rows;
``generate`` writes the module:

- ``scene_rhs(t, z, P, D, out)``: y' = (the rates of the joint positions, theta''[, P_dissipated, P_applied,
  P_drivers]) (``loops.RHS_SIGNATURE``: the integrator loops take it as they take the Baumgarte one); an open
  tree's theta'' by the articulated-body algorithm in O(N) (``articulated.py``); with cut
  rows it evaluates every constraint kernel and keeps the cut rows (P[8][7:]); with drivers and the energy
  balance, the drivers' power (eq. 5.61, as ``dynamics.EquationsOfMotion``) lambda^T Psi_t from the cut rows'
  multipliers mu alone (a driver is a cut row, and the tree's joints have Psi_t = 0). Given an ``out``
  longer than y, it writes after y' the body coordinates q, q' at the joint state, q'' and lambda of the model's
  constraint rows from Psi_q^T lambda = Q - M q'' (an open planar tree's from its articulated pass's joint forces;
  ``JointCoordinates.accelerations``), for the results and reactions, and after those Psi, Psi_t and Psi_q (row by
  row; its part of ``out`` zero on entry but in the rows' blocks, which it zeroes before the kernels add into them)
  when ``out`` is longer still (``loops.output_history``, ``blocked_output_history``, which gathers the rows'
  blocks and zeroes them again): one function for both, since numba optimizes the kernels again
  in every function that calls them. Given an ``out`` of y.size + n, only q after y (the tree's forward
  kinematics: the body coordinates of a divergence check's companion run, ``dispatch.positions``; y' not
  written). A state of another size than the tree's, or an ``out`` longer than y' + n but too short for the
  outputs, gets ``out`` filled with NaN (numba checks no bounds: it wrote past ``out``'s end).

That one function is the whole module: Psi, Psi_q and Psi_t at the output times come from it (``loops.
output_history``), so a tree has no ``constraint_arrays`` of its own (the scene's module has, ``codegen.py``): a
second function calling every constraint kernel would have numba link and optimize them all a second time, the
module's first compilation ~7 % longer (1.2 s of CPU of 16-19 s a dimension, ``mbd compile``'s compile events) for a
function no run needs.

No numba here; the generated module is cached as ``codegen.py`` caches the scene's own.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .codegen import (
    CONSTRAINT_CALLS,
    constraint_calls,
    force_calls,
    is_generated_cached,
    kernel_names,
    load_generated,
    named_module,
    slot_rows,
)
from .scene import SLOTS, Scene, packed

SOURCES = ("tree_kernels.py", "articulated.py", "projection_kernels.py", "../joint_coordinates.py")
KINDS = {"revolute": 0, "prismatic": 1, "spherical": 2}
_REVOLUTE = SLOTS.index("planar_revolute")
TREE_CALLS = {
    "planar_revolute": "tree_revolute(q, qd, {ints}, {floats}, psi, jac, gam, body, "
    f"D[2][{_REVOLUTE + 1 + len(SLOTS)}] - D[2][{_REVOLUTE}] if ncut > 0 else 0)"
}
"""The constraint kernels a tree's module calls by another form (``codegen.CONSTRAINT_CALLS``): a planar revolute
joint's rows with the recursion's cos and sin (``tree_kernels.tree_revolute``), gamma only of the cut joints (the
slot's first, ``TreeScene.data``: its stop among the offsets after the starts), all the cut solve reads."""


@dataclass
class TreeScene:
    """A scene (``scene.Scene``: its forces and constraint rows) with the joints of its tree."""

    scene: Scene
    ints: np.ndarray
    floats: np.ndarray
    n_positions: int
    k: int
    cut_rows: np.ndarray
    owners: np.ndarray = None
    """The constraint rows' owners: the child body of the tree joint a row belongs to, or the body whose Euler
    parameters it normalizes (``tree_kernels.tree_multipliers``); -1 for a cut row."""
    cut_bodies: np.ndarray = None
    """The two bodies of each cut row's element, row after row (-1 ground): the bodies its row of Psi_q meets
    (``tree_kernels.cut_accelerations``)."""
    row_index: np.ndarray = None
    """The tree's rows body by body (``row_index``: start (nb + 1), then the rows), made once per system
    (``Topology``): what ``tree_multipliers`` and ``zero_tree_blocks`` read (P[8] after the cut rows' bodies)."""
    cut_index: np.ndarray = None
    """The sparsity of the cut solve (``structure``), made once per system (``Topology``): what ``cut_accelerations``
    reads (P[8] after the row index)."""
    unsupported: str | None = None
    topology: Topology | None = field(default=None, repr=False, compare=False)
    """The integers above as the system's tree fixes them, made once per system (``topology``)."""
    packed_data: tuple | None = field(default=None, repr=False, compare=False)  # ``data()``, made once

    @property
    def n(self) -> int:
        return self.scene.n

    @property
    def m(self) -> int:
        return self.scene.m

    @property
    def key(self) -> str:
        """What the tree's module depends on: the dimension (cut rows, the energy terms and the drivers' power
        are data, chosen at run time: P[8], ``compiled.parameters``)."""
        return f"tree|{self.scene.key}"

    def data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """D of the scene with the tree's joints in their slot (``scene.packed``), made at the first call; in each
        constraint kernel's slot the elements of cut rows first, as the scene describes them (``compiled.plan``
        gives ``scene.describe`` the tree's ``cut_names``: ``Scene.first_counts``), and after the offsets of every
        slot (len(SLOTS) + 1) where each slot's cut elements stop: the integration evaluates those alone. The tree's
        joints satisfy their rows by construction (eq. 5.44: the joint coordinates parametrize them), so the
        integration's right-hand side, which reads the cut rows alone, calls each kernel on its cut elements only.
        Every element writes Psi, Psi_q and gamma of its own rows alone, so the order of a kernel's elements
        changes no number."""
        if self.packed_data is None:
            kernels = [*self.scene.constraint_kernels, *self.scene.force_kernels, ("tree", self.ints, self.floats)]
            ints, floats, offsets = packed(kernels, SLOTS)
            counts = self.scene.first_counts
            starts = offsets.tolist()  # Python ints: the stops made in a list, one array (no numpy call per slot)
            stops = [start + counts.get(name, 0) for name, start in zip(SLOTS, starts, strict=False)]
            self.packed_data = ints, floats, np.array(starts + stops, dtype=np.int64)
        return self.packed_data

    def arrays(self) -> tuple[np.ndarray, ...]:
        """The tree's integer tables in P[8] after the sizes (``compiled.parameters``), in order: the cut rows, the
        rows' owners, the cut rows' bodies, the tree's rows body by body (``row_index``) and the cut solve's
        sparsity (``structure``): concatenated as they are (each made into a list and the whole into one array
        again cost ~5-15 us of a call's start)."""
        return self.cut_rows, self.owners, self.cut_bodies, self.row_index, self.structure()

    def structure(self) -> np.ndarray:
        """The sparsity of the cut solve (``structure.cut_structure``, compiled), made at the first call: by the
        run's parameters (``compiled.parameters``), where numba is loaded already (the engine's choice, which
        describes the tree too, loads none). An open tree has none."""
        if self.cut_index is None:
            made = None if self.topology is None else self.topology.cut_index  # an earlier run's, of the same system
            if made is None and self.cut_bodies.size == 0:  # no cut rows: no cut solve
                made = np.zeros(0, dtype=np.int64)
            elif made is None:
                from .structure import cut_structure  # imports numba

                nb = self.n // (7 if self.scene.dimension == 3 else 3)
                made = cut_structure(self.ints, self.cut_bodies, self.k, nb)
            self.cut_index = made
            if self.topology is not None:
                self.topology.cut_index = made
        return self.cut_index


ONE_BODY = ("planar_coordinate", "spatial_coordinate", "spatial_normalization")
"""The constraint kernels whose ints begin (body, row, ...) (``scene.py``); every other's begin (i, j, row, ...)."""


NO_FRAME = (0.0,) * 9
"""The frame entries of a joint without a child frame (a planar joint's)."""


def _row(joint) -> list[float]:
    """A joint's 35 floats (``tree_kernels``' joint_floats): s_parent, s_child and the axis, each padded to 3, the
    offset, a, c, u0, u1 and the child's frame axes (zeros without one), extended in place (a list made of seven
    unpackings and three padding lists cost twice as much: ~1 us a planar joint at a call's start)."""
    row = list(joint.s_parent)
    row += (0.0,) * (3 - len(row))
    row += joint.s_child
    row += (0.0,) * (6 - len(row))
    row += joint.axis
    row += (0.0,) * (9 - len(row))
    row.append(joint.offset)
    row += joint.a
    row += joint.c
    row += joint.u0
    row += joint.u1
    for axis in joint.frame or (NO_FRAME,):
        row += axis
    return row


def describe(scene: Scene, formulation) -> TreeScene:
    """The tree of a ``JointCoordinates`` formulation over the scene (``unsupported`` says why not compiled), a scene
    described with the tree's cut elements first (``compiled.plan``; ``scene.describe``'s ``first``: ValueError
    otherwise, whose integration would read the wrong rows): the joints' integers and rows as the system's tree fixes
    them (``topology``, made once per system), and the joints' floats with them where every joint is the system's own
    (``Topology.floats``), else made here (``joint_floats``)."""
    if scene.first != cut_names(formulation):
        raise ValueError("a tree's scene is described with its cut elements first: compiled.plan describes it")
    joints, k = formulation.joints, formulation.tree.k
    shape = topology(formulation.system, joints, k)
    floats = joint_floats(joints) if shape.floats is None else shape.floats
    tree = TreeScene(
        scene, shape.ints, floats, formulation.tree.n_positions, k,
        shape.cut_rows, owners=shape.owners, cut_bodies=shape.cut_bodies, row_index=shape.row_index,
        cut_index=shape.cut_index, topology=shape,
    )  # fmt: skip
    if not joints:
        tree.unsupported = "a tree without joints"
    return tree


@dataclass
class Topology:
    """What of a tree scene the system's tree fixes (``TreeScene``'s): each joint's kind, parent, child,
    place in the state and the velocity columns that move its child (``ints``, ``tree_kernels``' joint_ints); the cut
    rows, the rows' owners, the cut rows' bodies, the rows body by body (``_owners``, ``row_index``); the cut solve's
    sparsity (``cut_index``, made by the first run's parameters: ``TreeScene.structure``). None of them depends on a
    run: made once per system (``topology``), as the tree's joints (``joint_coordinates.tree_joints``) and the cut
    system (``cut_system``) they come from, where every call described them anew (a loop chain of four's start rates
    -55..-61 us a call with the floats); the joints' floats too where no run changes a joint (``floats``)."""

    ints: np.ndarray
    cut_rows: np.ndarray
    owners: np.ndarray
    cut_bodies: np.ndarray
    row_index: np.ndarray
    floats: np.ndarray | None
    """The joints' floats (``joint_floats``) where no run changes a joint: every joint is then the system's own object,
    as ``tree_joints`` hands it out, and these are its numbers; None where a spatial prismatic joint's rotation
    follows each run's initial state (its floats made by each call)."""
    cut_index: np.ndarray | None = None


def topology(system, joints, k: int) -> Topology:
    """The ``Topology`` of ``system``'s tree (``joints``: ``joint_coordinates.tree_joints(system)``, k velocity
    columns), made at the first call for the system and kept on it (``tree_joints``' way: the system's elements and
    tree do not change once built)."""
    kept = system.__dict__.get("_tree_topology")
    if kept is None:
        kept = system.__dict__["_tree_topology"] = _topology(system, joints, k)
    return kept


def _topology(system, joints, k: int) -> Topology:
    """``topology``'s arrays: the joints' integer rows (the columns of D that move the child: its parent's, inherited,
    then its own) and the rows' owners (``_owners``)."""
    heads = []
    for j in joints:
        own = j.n_velocities
        count = len(j.inherited) + own
        heads += (KINDS[j.kind], j.parent, j.child, j.position, j.velocity, count)
        heads += j.inherited
        heads += range(j.velocity, j.velocity + own)
        heads += (-1,) * (k - count)
    owners, cut, bodies, owned = _owners(system, joints)
    changed = system.model.dimension == 3 and any(j.kind == "prismatic" for j in joints)  # ``tree_joints``' copies
    return Topology(
        np.array(heads, dtype=np.int64).reshape(-1, 6 + k), np.array(cut, dtype=np.int64),
        np.array(owners, dtype=np.int64), np.array(bodies, dtype=np.int64), row_index(owned),
        None if changed else joint_floats(joints),
    )  # fmt: skip


def joint_floats(joints) -> np.ndarray:
    """The joints' 35 floats a row (``_row``), built as one flat list of Python numbers made an array once (an array
    of nested lists, or of numpy scalars, costs several times as much)."""
    floats = []
    for j in joints:
        floats += _row(j)
    return np.array(floats, dtype=float).reshape(-1, 35)


def cut_names(formulation) -> frozenset:
    """The names of a ``JointCoordinates`` formulation's cut elements (``joint_coordinates.cut_elements``: loop
    closures, gears, cams and drivers, the rows the tree does not satisfy by construction)."""
    cut = formulation.cut
    return frozenset() if cut is None else frozenset(element.name for element in cut.elements)


def _owners(system, joints) -> tuple[list[int], list[int], list[int], list[list[int]]]:
    """(the owner of every constraint row of the tree (``TreeScene.owners``): the child of its tree joint, or the
    body of its Euler-parameter normalization (element ``<body>.p``); -1 for a cut row (a cut joint's or a
    driver's: ``joint_coordinates.cut_elements``), whose multiplier comes from the augmented system
    (``cut_accelerations``); the cut rows; their elements' two bodies, row after row (``TreeScene.cut_bodies``);
    each body's rows in row order (``row_index``)), in one pass over the elements (a loop: faster than numpy's
    repeat up to a loop chain of 16 at least), as lists. Each body's rows checked as ``tree_kernels.tree_multipliers``
    reads them: its joint's, then its normalization (``check_row_order``)."""
    child = {joint.name: joint.child for joint in joints}
    normalizations = {}  # the Euler-parameter normalizations (a planar scene has none)
    if system.model.dimension == 3:
        normalizations = {f"{body.name}.p": b for b, body in enumerate(system.model.bodies)}
    child |= normalizations
    owners, cut, bodies, owned, closed = [], [], [], [[] for _ in system.model.bodies], set()
    for element, where in zip(system.elements, system.rows, strict=True):
        owner, size = child.get(element.name, -1), where.stop - where.start
        owners += [owner] * size
        if owner < 0:
            cut += range(where.start, where.stop)
            bodies += [element.i, element.j] * size
        else:
            normalization = element.name in normalizations
            check_row_order(system, owner, owned[owner], normalization, closed)
            owned[owner] += range(where.start, where.stop)
            if normalization:
                closed.add(owner)
    return owners, cut, bodies, owned


def check_row_order(system, body: int, rows: list[int], normalization: bool, closed: set) -> None:
    """ValueError unless a body's rows come as ``tree_kernels.tree_multipliers`` reads them: its tree joint's rows
    first (``translational_rows``: where each kind's translational rows are among them), its Euler-parameter
    normalization last (``spatial.build.build_elements`` puts the normalizations after every joint). Called for
    each element the body owns before its rows join ``rows`` (the body's so far; ``normalization``: the element is
    the body's normalization; ``closed``: the bodies whose normalization came): another order would give lambda to
    the wrong rows, silently. Where the plan is made, a set lookup an element: never at an output time."""
    if body in closed:
        raise ValueError(f"body {system.model.bodies[body].name}: a row after its Euler-parameter normalization")
    if normalization and not rows:
        raise ValueError(f"body {system.model.bodies[body].name}: its Euler-parameter normalization before its joint")


def row_index(rows: list[list[int]]) -> np.ndarray:
    """The rows each body owns (``_owners``' lists, in row order; cut rows, owner -1, in none) as one array: start
    (nb + 1), then the rows body by body, body b's at [nb + 1 + start[b], nb + 1 + start[b + 1]). Made once per system
    (``topology``), where ``tree_multipliers`` sorted them at every output time (two allocations and three passes over
    the rows: ~0.25 us of an evaluation at two bodies); from Python lists, one array at the end (numpy's bincount,
    cumsum, argsort and concatenate cost ~20 us at a call's start against a loop chain's few dozen rows)."""
    flat, at = [0], 0
    for body in rows:
        at += len(body)
        flat.append(at)
    for body in rows:
        flat += body
    return np.array(flat, dtype=np.int64)


VECTORS = (("xi", "a"), ("Q", "n"), ("power", "3"), ("q", "n"), ("qd", "n"), ("thdd", "k"), ("mu", "ncut"))
"""The vectors of every evaluation (name, size), slices of one allocation: xi (eq. 5.44), Q, the powers, q and q',
theta'', the cut rows' multipliers mu. (Psi, Psi_q, Psi_t, gamma, q'' and lambda are made where they are needed: a
tree without cut rows needs none of them on the way to theta''.)"""


def _arrays(spatial: bool) -> list[str]:
    """The lines that make the work arrays of an evaluation, two allocations (three spatial: omega'): the vectors
    cut from one (a slice of a vector costs nothing), and two arrays indexed by body or joint and a named row
    (``articulated.body_rows``, ``joint_rows``; the recursion's rows after the body's, ``tree_kernels.MOTION``
    and ``SPATIAL_MOTION``), the leading slices of one array of entries with the rows of the longer (a leading
    slice stays C-contiguous for numba), never cut further into views: a reshape costs ~20 ns, an allocation ~30
    ns, a view handed on ~10 ns, more than a planar joint's arithmetic. D (eq. 5.44) only for cut rows: an open
    tree's articulated pass never forms it."""
    from .articulated import sizes  # numba: imported only where a module is written (this module imports none)
    from .tree_kernels import PLANAR_MOTION_ROWS, SPATIAL_MOTION_ROWS

    nv = 6 if spatial else 3
    body, joint = sizes(nv)
    body += SPATIAL_MOTION_ROWS if spatial else PLANAR_MOTION_ROWS  # the recursion's rows
    lines = [
        f"    nb = n // {7 if spatial else 3}",
        f"    nv = {nv}  # a body's velocity: (v, omega) spatial, (v_x, v_y, omega) planar",
        "    a = nv * nb  # the rows of xi and D",
        f"    vectors = np.empty({' + '.join(size for _, size in VECTORS)})",
        "    at = 0",
    ]
    for name, size in VECTORS:
        lines += [f"    {name} = vectors[at : at + {size}]", f"    at += {size}"]
    lines += [
        f"    entries = np.empty((nb + 1 + ne + 1, {max(body, joint)}, nv))  # one allocation: a body's, a joint's",
        "    body = entries[: nb + 1]  # I^A, p^A, A, the recursion's: ground last (a leading slice stays contiguous)",
        "    joint = entries[nb + 1 :]  # S_e, U, D_e's factor, u, l; the passes' scratch last",
        "    Dm = np.empty((a, k)) if columns else body[0]  # D (a x k) for the cut rows only; else not read",
    ]
    if spatial:
        lines.append("    omega = np.empty((nb, 3))  # the bodies' omega'")
    return lines


def _multipliers(scene: Scene) -> list[str]:
    """The lines that make q'' (``qdd``) from theta'' and lambda of every row from Psi_q^T lambda = Q - M q'' (an open
    tree's q'' from the articulated pass's body accelerations; lambda of an open planar tree from the pass's joint
    forces (``tree_kernels.planar_joint_multipliers``: no solve), of a spatial tree, and of a tree with cut rows
    (q'' = D theta'' + xi, the cut rows' lambda mu from the augmented system, their forces applied), from the
    backward pass of inverse dynamics (``tree_kernels.tree_multipliers``: each body's rows from its own columns,
    O(N), the translational rows without a solve))."""
    solve = [
        "for a in range(ncut):  # the cut rows' lambda: mu of the augmented system; the tree's from what is left",
        "    lam[dims[7 + a]] = mu[a]",
        "if ncut > 0:  # (an open tree: no call, whose arrays cost ~10 ns each to hand on)",
        "    cut_row_forces(jac, mu, dims[7 : 7 + ncut], dims[7 + ncut + m : 7 + 3 * ncut + m], "
        f"{7 if scene.dimension == 3 else 3}, residual)",
        "# the tree's rows body by body from the leaves, O(N)",
        f"tree_multipliers(jac, residual, tree_rows, {7 if scene.dimension == 3 else 3}, joints, lam)",
    ]
    if scene.dimension == 3:
        lines = [
            "if ncut > 0:",
            "    spatial_coordinate_accelerations(q, qd, Dm, xi, omega, thdd, joints, qdd)",
            "else:  # the articulated pass's body accelerations: no D",
            "    spatial_body_accelerations(q, qd, body, xi, omega, qdd)",
            "spatial_mass_residual(q, qd, qdd, masses, inertias, weights, Q, residual)  # Q += Q_v; Q - M q''",
            *solve,
        ]
    else:
        cut = [
            "tree_accelerations(Dm, thdd, xi, joints, 3, qdd)  # D theta'' + xi over each body's columns",
            "for coordinate in range(n):  # Q - M q'' (the tree's multipliers work in it)",
            "    residual[coordinate] = Q[coordinate] - mass[coordinate] * qdd[coordinate]",
            *solve,
        ]
        lines = [
            "if ncut == 0:  # the articulated pass's body accelerations (no D) and joint forces (no solve)",
            "    planar_body_accelerations(body, xi, qdd)",
            "    planar_joint_multipliers(jac, body, tree_rows, joints, lam)",
            "else:",
            *("    " + line for line in cut),
        ]
    both = "outputs = np.empty(2 * n + m)  # q'', lambda and Q - M q'' in one allocation"
    split = "qdd, lam, residual = outputs[:n], outputs[n : n + m], outputs[n + m :]"
    return ["        " + line for line in [both, split, *lines]]


def _body(tree: TreeScene) -> list[str]:
    """The lines of ``scene_rhs``: q and q', xi, D, omega', Q and the powers at the joint state y; Psi, Psi_q, Psi_t
    and gamma when they are needed; theta'' (``thdd``): a tree with cut rows (P[8][7:], chosen at run time: one
    module per dimension) solves the augmented system (``cut_accelerations``), one without the embedded equations
    (D^T M D) theta'' = D^T (Q - M xi) by the articulated-body algorithm (``articulated``, O(N), D never formed);
    q'' and lambda of every row for the outputs; in the integration the drivers' power (eq. 5.61) from the cut rows'
    mu alone."""
    scene = tree.scene
    spatial = scene.dimension == 3
    rows = slot_rows(SLOTS.index("tree"))
    equations = "spatial" if spatial else "planar"
    width = 7 if spatial else 3
    arguments = "masses, inertias, q, Dm, xi, omega, Q" if spatial else "mass, Dm, xi, Q"
    articulated = "masses, inertias, q, xi, omega, Q" if spatial else "mass, xi, Q"
    lines = [
        "    Q0, mass, masses, inertias, weights, fk, fp, numbers, dims = P",
        "    n, m, npos, k = dims[0], dims[1], dims[3], dims[4]",
        f"    joints, joint_floats = D[0][{rows}], D[1][{rows}]",
        "    ne = joints.shape[0]",
        "    ny = npos + k + dims[2]  # the joint state and the energy balance's three states (P[8][2] = 3 or 0)",
        "    if y.size != ny or (out.size != ny and out.size != ny + n and out.size < ny + 3 * n + m):",
        "        out[:] = np.nan  # a size it does not know: NaN, not a write past out's end (no bounds checks)",
        "        return  # (y', [q alone | q, q', q'', lambda [, Psi, Psi_t, Psi_q when out is exactly that long]])",
        "    positions = out.size == y.size + n  # q alone after y (the companion run's: dispatch.positions)",
        "    full = out.size > y.size + n  # the outputs asked for too (loops.outputs): q, q', q'', lambda after y'",
        "    ncut = dims[6]  # cut rows (P[8][7 : 7 + ncut]); the rows' owners after them",
        "    columns = ncut > 0  # D itself: for the cut rows only (an open tree's outputs: the body accelerations)",
        *_arrays(spatial),
        "    tree_rows = dims[7 + 3 * ncut + m : 8 + 2 * ncut + 2 * m + nb]  # body by body (tree.row_index)",
        "    structure = dims[8 + 2 * ncut + 2 * m + nb :]  # the cut solve's sparsity (structure.cut_structure)",
        "    for i in range(n):  # loops, not slice assignments (numba's broadcasting: ~20 ns each)",
        "        Q[i] = Q0[i]",
        "    power[0] = power[1] = power[2] = 0.0",
    ]
    if spatial:
        rates = "out[:npos]"  # the rates of the joint positions (Euler parameters: not theta')
        lines.append(
            "    spatial_motion(y[:npos], y[npos : npos + k], joints, joint_floats, nb, k, q, qd, xi, Dm, omega, "
            f"{rates}, columns, body, joint)"
        )
    else:
        lines.append(
            "    planar_motion(y[:npos], y[npos : npos + k], joints, joint_floats, nb, k, q, qd, xi, Dm, columns, "
            "body, joint)"
        )
    lines += [
        "    if positions:  # the tree's forward kinematics alone: q after y (y' not written)",
        "        for i in range(n):",
        "            out[y.size + i] = q[i]",
        "        return",
    ]
    lines += force_calls(scene, "    ")
    lines += [
        "    if full or ncut > 0:  # the constraint rows: lambda of every row, or the cut rows",
        "        history = out.size == y.size + 3 * n + 3 * m + m * n  # Psi, Psi_t, Psi_q too (loops.output_history)",
        "        rows_work = np.empty(3 * m + (0 if history else m * n))  # Psi, Psi_t, gamma[, Psi_q]: one allocation",
        "        rows_work[: 3 * m] = 0.0",
        "        psi, psit, gam = rows_work[:m], rows_work[m : 2 * m], rows_work[2 * m : 3 * m]",
        "        if history:  # Psi_q whole, in its place in out (zero but in the rows' blocks: loops.output_history)",
        "            jac = out[y.size + 3 * n + 3 * m :].reshape((m, n))",
        "        else:",
        "            jac = rows_work[3 * m :].reshape((m, n))",
        "        if ncut > 0:  # the kernels add into each row's blocks at its bodies, all that is read: zeroed alone",
        f"            zero_cut_blocks(jac, dims[7 : 7 + ncut], dims[7 + ncut + m : 7 + 3 * ncut + m], {width})",
        "        if full:  # every row: the tree rows at their body and its parent",
        f"            zero_tree_blocks(jac, tree_rows, joints, {width})",
        f"        cut = 0 if full else {len(SLOTS)}  # each slot's stop: every row's or its cut rows' (TreeScene.data)",
        *constraint_calls(scene, "        ", " + cut", {**CONSTRAINT_CALLS, **TREE_CALLS}),
        "        if history:  # Psi and Psi_t after the outputs, before Psi_q",
        "            o = y.size + 3 * n + m",
        "            for i in range(m):",
        "                out[o + i], out[o + m + i] = psi[i], psit[i]",
        "    if ncut > 0:  # cut rows: the augmented system (eq. 5.29, 5.30 in joint coordinates)",
        f"        matrix, rhs = {equations}_equations({arguments}, joints)",
    ]
    if spatial:
        lines += [
            "        Dq, xiq = np.empty((n, k)), np.empty(n)",
            "        spatial_joint_matrix(q, Dm, Dq)",
            "        spatial_coordinate_accelerations(q, qd, Dm, xi, omega, np.zeros(k), joints, xiq)",
        ]
    else:
        lines.append("        Dq, xiq = Dm, xi")
    return lines + [
        "        solved = cut_accelerations("
        "matrix, rhs, Dq, xiq, jac, psi, psit, gam, qd, dims[7 : 7 + ncut], dims[7 + ncut + m : 7 + 3 * ncut + m], "
        f"numbers[0], numbers[1], mu, joints, {7 if spatial else 3}, structure)",
        "        for i in range(k):  # loops, not slice assignments (``loops._copy``)",
        "            thdd[i] = solved[i]",
        "    else:  # an open tree: the articulated-body algorithm, O(N)",
        f"        {equations}_articulated({articulated}, joints, thdd, body, joint)",
        "    if full:  # lambda of every row: the outputs",
        *_multipliers(scene),
        "        if dims[5]:  # the drivers' power (eq. 5.61)",
        "            power[2] = lam @ psit",
        "    elif ncut > 0 and dims[5]:  # the drivers' power in the integration: lambda^T Psi_t over the cut rows",
        "        for a in range(ncut):  # (a driver is a cut row; the tree's joints are scleronomic: Psi_t = 0 there)",
        "            power[2] += mu[a] * psit[dims[7 + a]]",
    ]


def generate(tree: TreeScene) -> str:
    """The source text of the tree scene's module (module docstring): the joint accelerations written out in
    the right-hand side (P and D stay in the function that receives them: passing them on costs more than the
    arithmetic of a small tree). One module per dimension: whether the tree has cut rows is data (P[8])."""
    scene = tree.scene
    spatial = scene.dimension == 3
    forces = [name for name, _, _ in scene.force_kernels]
    constraints = [name for name, _, _ in scene.constraint_kernels]
    kernels = sorted({*forces, *constraints})
    dimension = "spatial" if spatial else "planar"
    tree_imports = {f"{dimension}_motion", f"{dimension}_equations", f"{dimension}_articulated", "cut_accelerations"}
    tree_imports |= {"zero_cut_blocks", "zero_tree_blocks", "cut_row_forces", "tree_accelerations"}
    spatial_kernels = {"spatial_coordinate_accelerations", "spatial_joint_matrix", "spatial_body_accelerations"}
    tree_imports |= {"tree_multipliers"}  # the backward pass; an open planar tree's lambda: its joint forces
    planar_kernels = {"planar_body_accelerations", "planar_joint_multipliers"}
    planar_kernels |= {"tree_revolute"}
    tree_imports |= spatial_kernels | {"spatial_mass_residual"} if spatial else planar_kernels
    lines = [
        f'"""Generated by solutions.compiled.tree for the tree {tree.key!r}: do not edit."""',
        "import numpy as np",
        "from numba import njit",
        "",
        f"from solutions.compiled.kernels import {', '.join(kernels)}",
        "from solutions.compiled.loops import RHS_SIGNATURE",
        f"from solutions.compiled.tree_kernels import {', '.join(sorted(tree_imports))}",
        "",
        "",
        "@njit(RHS_SIGNATURE, cache=True, nogil=True)",
        "def scene_rhs(t, y, P, D, out):",
        "    \"\"\"y' = (the rates of the joint positions, theta''[, P_dissipated, P_applied, P_drivers]); when",
        "    ``out`` is longer than y, after y' q, q', q'' and lambda (Psi_q^T lambda = Q - M q'', normal eq.).\"\"\"",
        *_body(tree),
        *(
            []
            if spatial
            else ["    for i in range(k):  # planar: the rates are theta'", "        out[i] = y[npos + i]"]
        ),
        "    for i in range(k):",
        "        out[npos + i] = thdd[i]",
        "    if dims[2]:  # the energy balance's three powers",
        "        out[npos + k], out[npos + k + 1], out[npos + k + 2] = power[0], power[1], power[2]",
        "    if full:  # the outputs at this state",
        "        o = y.size",
        "        for i in range(n):",
        "            out[o + i], out[o + n + i], out[o + 2 * n + i] = q[i], qd[i], qdd[i]",
        "        for i in range(m):",
        "            out[o + 3 * n + i] = lam[i]",
    ]
    return "\n".join(lines) + "\n"


def _named(tree: TreeScene) -> tuple[str, str]:
    return named_module(tree.key, kernel_names(tree.scene), lambda: generate(tree), "mbd_tree_", SOURCES)


def module_name(tree: TreeScene) -> str:
    return _named(tree)[0]


def is_cached(tree: TreeScene) -> bool:
    """Whether numba's machine code of the tree scene's right-hand side is on disk."""
    return is_generated_cached(module_name(tree), "scene_rhs")


def load(tree: TreeScene) -> tuple[object, bool]:
    """The tree scene's compiled module, and whether its machine code was on disk already."""
    return load_generated(*_named(tree), "scene_rhs")


__all__ = ["TreeScene", "describe", "generate", "is_cached", "load"]
