"""What a compiled run reports besides its motion: constraint residuals and joint reactions over the output grid.

The numpy engine evaluates Psi, Psi_q and Psi_t once per output time through the ``System`` and builds the
reactions joint by joint (``reactions.py``, ``spatial/reactions.py``: what students write). A compiled run
has the same arrays from its generated module at every output time in one call (``constraint_arrays``), and
here they are turned into the same result columns over all output times at once: the residuals by array
operations, the reactions by compiled loops (``history_kernels.py``) over an index layout made once per system:

- Psi_q's history: dense (N, m, n) for a small Psi_q, by its rows' blocks for a large one (``BlockedJacobians``:
  each row's entries in the columns of the bodies its element joins, (N, m, w) with w = 2 x 3 planar, 2 x 7
  spatial; on a chain of 64 loops 1.9 MB where the dense array is 121 MB, whose first touch alone costs 20 ms);
- residuals: max |Psi| and max |Psi_q q' + Psi_t| per output time (``dynamics.constraint_residuals``);
- reactions: for joint k and each of its moving bodies i, Q_i^k = -(Psi_qi^k)^T lambda_k (eq. 5.70, 10.20),
  split into the force F and the moment about the joint point P: planar M = n - (r_P - r_i) x F (eq. 5.71),
  spatial n = 1/2 G(p_i) Q_p, M = n - (r_P - r_i) x F (eq. 10.21); ground takes minus what the joint exerts
  on the moving body. The columns are those of ``reactions.joint_reactions`` (the second body's force and
  moment; spatial joints also in the joint frame fixed in that body).

Tests (``tests/solutions/test_compiled.py``) compare every column with the numpy functions.
"""

from __future__ import annotations

import numpy as np

from ..output_history import axes, planar_joints


def constraint_arrays(module, scene, times: np.ndarray, Y: np.ndarray, columns: np.ndarray | None = None) -> tuple:
    """(Psi, Psi_q, Psi_t) at every output time, shapes (N, m), (N, m, n), (N, m), from the compiled module; with the
    rows' ``columns`` (m, w) (``row_columns``), Psi_q by its rows' blocks (``BlockedJacobians``): the module writes
    each time into one reused (m, n) and its blocks are gathered (``history_kernels.blocked_constraint_arrays``)."""
    from . import parameters

    N, n, m = times.size, scene.n, scene.m
    psi, psit = np.zeros((N, m)), np.zeros((N, m))
    arguments = (times, np.ascontiguousarray(Y), parameters(scene, 0.0, 0.0), scene.data())
    if columns is None:
        jac = np.zeros((N, m, n))
        module.constraint_arrays(*arguments, psi, jac, psit)
        return psi, jac, psit
    from . import history_kernels, loops

    function = loops.first_class(module.constraint_arrays, loops.CONSTRAINT_ARRAYS_SIGNATURE)
    values = np.zeros((N, m, columns.shape[1]))  # slots after a row's last stay 0
    history_kernels.blocked_constraint_arrays(function, *arguments, psi, values, psit, columns, n)
    return psi, BlockedJacobians(values, columns, n), psit


def block_slots(columns: np.ndarray) -> np.ndarray:
    """(m, w) slots of a history by its rows' blocks (``BlockedJacobians``, ``columns`` (m, w)): entry s of row r
    is in slot s. Kernels that read a dense history at columns[r, s] read the blocks at slots[r, s] instead."""
    m, w = columns.shape
    return np.ascontiguousarray(np.broadcast_to(np.arange(w, dtype=np.int64), (m, w)))


class BlockedJacobians:
    """Psi_q at N output times by its rows' blocks: ``values`` (N, m, w), entry s of row r in column
    ``columns[r, s]`` (-1 after the row's last: ``row_columns``, the columns of the bodies the row's element
    joins), every other entry zero. Read as the dense (N, m, n) it stands for where a reader needs that (``dense``,
    ``np.asarray``, a time ``[k]``: one (m, n)); the compiled readers (residuals, reactions, the Guard's norms and
    spectra) read the blocks. Indexing by a slice or a mask of times keeps the blocks."""

    ndim = 3

    def __init__(self, values: np.ndarray, columns: np.ndarray, n: int):
        self.values, self.columns, self.n = values, columns, int(n)

    @classmethod
    def gather(cls, jac: np.ndarray, columns: np.ndarray) -> BlockedJacobians:
        """The blocks of a dense history (N, m, n) in the rows' ``columns`` (m, w) (its entries elsewhere dropped)."""
        rows, slots = np.nonzero(columns >= 0)
        values = np.zeros((jac.shape[0], *columns.shape))
        values[:, rows, slots] = jac[:, rows, columns[rows, slots]]
        return cls(values, columns, jac.shape[2])

    @property
    def shape(self) -> tuple[int, int, int]:
        return (*self.values.shape[:2], self.n)

    def __len__(self) -> int:
        return self.values.shape[0]

    def __getitem__(self, index):
        if isinstance(index, (int, np.integer)):
            return self.dense(self.values[index][None])[0]
        return BlockedJacobians(self.values[index], self.columns, self.n)

    def dense(self, values: np.ndarray | None = None) -> np.ndarray:
        """The dense (N, m, n) history (of ``values``, blocks of some times, if given)."""
        values = self.values if values is None else values
        jac = np.zeros((values.shape[0], values.shape[1], self.n))
        rows, slots = np.nonzero(self.columns >= 0)
        jac[:, rows, self.columns[rows, slots]] = values[:, rows, slots]
        return jac

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        return self.dense() if dtype is None else self.dense().astype(dtype)

    def pattern(self) -> np.ndarray:
        """Where any Psi_q of the history is nonzero (m, n)."""
        pattern = np.zeros((self.values.shape[1], self.n), dtype=bool)
        rows, slots = np.nonzero((self.columns >= 0) & np.any(self.values != 0.0, axis=0))
        pattern[rows, self.columns[rows, slots]] = True
        return pattern

    def slots(self, rows: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """Where column ``targets[a]`` of row ``rows[a]`` sits among the row's blocks (its slot s); -1 where the row
        does not reach it."""
        return column_slots(self.columns, rows, targets)


def column_slots(columns: np.ndarray, rows: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Where column ``targets[a]`` of row ``rows[a]`` sits among the row's blocks (``columns`` (m, w): a blocked
    history's, ``BlockedJacobians``); -1 where the row does not reach it."""
    found = columns[rows] == np.asarray(targets)[:, None]
    return np.where(found.any(axis=1), np.argmax(found, axis=1), -1).astype(np.int64)


def residuals(psi: np.ndarray, jac, psit: np.ndarray, qd: np.ndarray, system=None) -> dict[str, np.ndarray]:
    """'residual.position' max |Psi| and 'residual.velocity' max |Psi_q q' + Psi_t| at every output time. With the
    ``system``, both maxima in one compiled pass, Psi_q q' over each row's nonzero columns
    (``history_kernels.residual_maxima``; of a blocked history, over its blocks: the same products in the same
    order), else Psi_q q' by BLAS."""
    from . import history_kernels

    qd, psit = (np.ascontiguousarray(a, dtype=float) for a in (qd, psit))
    if isinstance(jac, BlockedJacobians):
        stored, columns, slots = jac.values, jac.columns, block_slots(jac.columns)
    elif system is None or row_columns(system) is None:
        velocity = (jac @ qd[:, :, None])[:, :, 0] + psit  # Psi_q q' at every time, by BLAS
        return {
            "residual.position": np.max(np.abs(psi), axis=1, initial=0.0),
            "residual.velocity": np.max(np.abs(velocity), axis=1, initial=0.0),
        }
    else:
        stored, columns = jac, row_columns(system)
        slots = columns
    position, velocity = np.empty(psit.shape[0]), np.empty(psit.shape[0])
    stored, psi = (np.ascontiguousarray(a, dtype=float) for a in (stored, psi))  # a slice of times may not be
    history_kernels.residual_maxima(stored, qd, psi, psit, columns, slots, position, velocity)
    return {"residual.position": position, "residual.velocity": velocity}


def kinetic_energy(masses, q: np.ndarray, qd: np.ndarray) -> np.ndarray | None:
    """T at every output time: of a spatial model (``masses``: its ``spatial.mass.SpatialMassMatrix``) in one compiled
    pass (``spatial_history_kernels``, eq. 10.3); of a planar model with a diagonal M = diag(m, m, J)
    (every planar model the compiled engine runs: ``scene.describe``) as T = 1/2 sum_i m_i q_i'^2 (eq. 5.2), where
    ``energy.kinetic_energy``'s q' M multiplies every zero of M too (BLAS over n x n: ~20-30 us of a loop chain's
    result at n = 27), in one compiled pass (``history_kernels.planar_kinetic_energy``). The same numbers: each entry
    of q' M is its one product q_i' m_i (the others add exact zeros), summed in np.sum's order. None otherwise
    (numpy's product)."""
    from ..spatial.mass import SpatialMassMatrix
    from . import history_kernels

    if isinstance(masses, np.ndarray):
        diagonal = np.diagonal(masses)
        if np.count_nonzero(masses) != np.count_nonzero(diagonal):  # not diagonal: numpy's product
            return None
        if qd.shape[-1] > history_kernels.PAIRWISE_BLOCK:  # numpy's order splits the sum: numpy's expression
            return 0.5 * np.sum((qd * diagonal) * qd, axis=-1)
        out = np.empty(len(qd))
        qd, diagonal = (np.ascontiguousarray(a, dtype=float) for a in (qd, diagonal))
        history_kernels.planar_kinetic_energy(qd, diagonal, out)
        return out
    if not isinstance(masses, SpatialMassMatrix):
        return None
    from . import spatial_history_kernels  # compiled at its import: a planar run never imports it

    constants = layout(masses, _body_constants)  # kept on the mass matrix: every run of a formulation
    out = np.empty(len(q))
    q, qd = (np.ascontiguousarray(a, dtype=float) for a in (q, qd))
    spatial_history_kernels.spatial_kinetic_energy(q, qd, *constants, out)
    return out


def _body_constants(mass_matrix) -> tuple[np.ndarray, np.ndarray]:
    """(the bodies' masses, their body-frame inertia matrices (nb, 3, 3)) of a ``SpatialMassMatrix``, made once
    (``layout``)."""
    bodies = mass_matrix.model.bodies
    masses = np.array([body.mass for body in bodies], dtype=float)
    inertias = np.ascontiguousarray([body.inertia for body in bodies], dtype=float).reshape(-1, 3, 3)
    return masses, inertias


def layout(system, make):
    """``make(system)``, the index arrays of the reaction columns that depend only on the system's structure, made
    once per system (every run of a system asks for the same columns)."""
    kept = system.__dict__.setdefault("_reaction_layouts", {})
    if make not in kept:
        kept[make] = make(system)
    return kept[make]


def row_columns(system) -> np.ndarray | None:
    """(m, w): the columns of Psi_q where each row can be nonzero (``_element_columns``), made once per system."""
    return layout(system, _element_columns)


def _element_columns(system) -> np.ndarray | None:
    """(m, w): the columns of Psi_q where each row can be nonzero, those of the bodies its element joins (-1 after
    the last), or None where an element's rows reach other columns (checked once, at a configuration off the
    model's: then the dense product)."""
    per, m = system.coordinates_per_body, system.n_constraints
    columns = np.full((m, 2 * per), -1, dtype=np.int64)
    every_row = np.arange(m)
    for k, element in enumerate(system.elements):
        bodies = sorted(b for b in (getattr(element, "i", -1), getattr(element, "j", -1)) if b is not None and b >= 0)
        reach = np.concatenate([per * b + np.arange(per) for b in bodies]) if bodies else np.zeros(0, np.int64)
        columns[every_row[system.rows[k]], : reach.size] = reach
    q = np.random.default_rng(3).uniform(0.5, 1.5, system.n_coordinates)  # no zero an element's rows could hide
    pattern = np.zeros((m, system.n_coordinates), dtype=bool)
    rows, slots = np.nonzero(columns >= 0)
    pattern[rows, columns[rows, slots]] = True
    try:
        outside = np.any((system.jacobian(q, 0.5) != 0.0) & ~pattern)
    except (ArithmeticError, ValueError, np.linalg.LinAlgError):  # not evaluable there: the dense product
        return None
    return None if outside else columns


def _planar_layout(system) -> tuple:
    """(joint names, the rows of all joints in joint order, each joint's first row among them, its two bodies (i, j),
    the body carrying its point and the point in that body, the bodies that carry one), as
    ``history_kernels.planar_reactions`` takes them."""
    names, rows, sides, carriers, points = planar_joints(system)
    starts = np.cumsum([0, *[len(r) for r in rows[:-1]]])  # each joint's first row in the rows of all
    i, j = (np.ascontiguousarray(side, dtype=np.int64) for side in np.array(sides, dtype=np.int64).reshape(-1, 2).T)
    carrier = np.array(carriers, np.int64)
    layout = (np.concatenate(rows).astype(np.int64), starts.astype(np.int64), i, j, carrier)
    return names, (*layout, np.asarray(points, dtype=float).reshape(-1, 2), np.unique(carrier[carrier >= 0]))


def _histories(system, q: np.ndarray, lam: np.ndarray, jac, rows: np.ndarray, reported, reported_slots) -> tuple:
    """q, lambda, Psi_q as the compiled loops take them (C-contiguous float arrays: one machine code for all), and
    for each of the ``rows`` (of all joints in joint order) where the columns of the body whose reaction it reports
    begin (``reported(system)``: those columns) in Psi_q's row: that column, or in a blocked history its slot among
    the row's blocks (``reported_slots(system)`` where the blocks are the system's ``row_columns``, as a compiled
    run's are, ``compiled.run``); both made once per system (``layout``)."""
    columns = layout(system, reported)
    if isinstance(jac, BlockedJacobians):
        own = jac.columns is row_columns(system)
        slots = layout(system, reported_slots) if own else _slots(jac.columns, rows, columns)
        jac = jac.values
    else:
        slots = columns
    return (*(np.ascontiguousarray(a, dtype=float) for a in (q, lam, jac)), np.ascontiguousarray(slots, np.int64))


def _slots(blocks: np.ndarray, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Where column ``columns[a]`` of row ``rows[a]`` sits among the row's blocks (``blocks``: a history's
    ``BlockedJacobians.columns``); every joint's row reaches its own bodies' columns."""
    slots = column_slots(blocks, rows, columns)
    if np.any(slots < 0):  # row_columns gives every row its element's bodies: a joint's own body is there
        raise ValueError("a joint's row of Psi_q does not reach its own body's columns")
    return slots


def _planar_slots(system) -> np.ndarray:
    """``_slots`` of the planar layout in the system's ``row_columns``, made once per system (``layout``)."""
    return _slots(row_columns(system), layout(system, _planar_layout)[1][0], layout(system, _planar_reported))


def _spatial_slots(system) -> np.ndarray:
    """``_slots`` of the spatial layout in the system's ``row_columns``, made once per system (``layout``)."""
    return _slots(row_columns(system), layout(system, _spatial_layout)[2][0], layout(system, _spatial_reported))


def _reported_columns(arrays: tuple, per: int) -> np.ndarray:
    """For each row of all joints (``arrays``: a reaction layout), the first column of the body whose reaction the
    joint reports (its second, or its first where the second is ground)."""
    rows, starts, i, j = arrays[:4]
    body = np.where(j >= 0, j, i)
    return per * np.repeat(body, np.diff(np.append(starts, rows.size)))


def _planar_reported(system) -> np.ndarray:
    """``_reported_columns`` of the planar layout, made once per system (``layout``)."""
    return _reported_columns(layout(system, _planar_layout)[1], 3)


def _spatial_reported(system) -> np.ndarray:
    """``_reported_columns`` of the spatial layout, made once per system (``layout``)."""
    return _reported_columns(layout(system, _spatial_layout)[2], 7)


def planar_reactions(system, q: np.ndarray, lam: np.ndarray, jac) -> dict[str, np.ndarray]:
    """``reactions.joint_reactions(system, q, lam, t)`` over the histories q (N, n), lambda (N, m), every joint at
    once (``history_kernels.planar_reactions``): each row's part -(Psi_q)_r^T lambda_r of the generalized force on
    the three columns of either body (eq. 5.70), summed over the rows of its joint, the moment taken about the joint
    point (eq. 5.71); a ground side gets the opposite of the other side's."""
    from . import history_kernels

    if not system.elements:  # free bodies: no joint, no reaction
        return {}
    names, arrays = layout(system, _planar_layout)
    out = np.empty((3 * len(names), q.shape[0]))  # a column a row: Fx, Fy, Mz joint after joint
    histories = _histories(system, q, lam, jac, arrays[0], _planar_reported, _planar_slots)
    history_kernels.planar_reactions(*histories, *arrays, out)
    return dict(zip(layout(system, _planar_labels), out, strict=True))


def _planar_labels(system) -> list[str]:
    """The planar reaction columns' names, joint after joint (``name.Fx``, ``name.Fy``, ``name.Mz``), made once per
    system (``layout``)."""
    names = layout(system, _planar_layout)[0]
    return [f"{name}.{part}" for name in names for part in ("Fx", "Fy", "Mz")]


def _spatial_layout(system) -> tuple:
    """(element names, each element's place among those with joint frames or -1, and the arrays
    ``spatial_history_kernels.spatial_reactions`` takes: the rows of all elements (the Euler parameters' normalization
    left out), each element's first row among them, its bodies (i, j), the joint point in body j, the frames' axes
    as columns, each element's place among the framed ones, the bodies whose A(p) or G(p) it reads, each element's
    first result column)."""
    from ..spatial.joints import EulerNormalization, Joint

    every_row = np.arange(system.n_constraints)
    elements = [(k, e) for k, e in enumerate(system.elements) if not isinstance(e, EulerNormalization)]
    rows = [every_row[system.rows[k]] for k, _ in elements]
    starts = np.cumsum([0, *[len(r) for r in rows[:-1]]]).astype(np.int64)
    i = np.array([e.i for _, e in elements], dtype=np.int64)
    j = np.array([e.j for _, e in elements], dtype=np.int64)
    framed = [isinstance(e, Joint) and bool(e.frames) for _, e in elements]
    offsets = np.zeros((len(elements), 3))  # the joint point in body j (its centre where none is given)
    for row, ((_, e), has_frames) in enumerate(zip(elements, framed, strict=True)):
        given = e.frames[1].origin if has_frames else getattr(e, "sj", None)
        offsets[row] = 0.0 if given is None else given
    joints = np.flatnonzero(framed)  # F and M in the joint frame too: its f, g, h in body j
    frames = np.array([axes(elements[e][1].frames[1]) for e in joints], dtype=float).reshape(-1, 3, 3)
    place = np.full(len(elements), -1, dtype=np.int64)
    place[joints] = np.arange(joints.size)
    names = [e.name for _, e in elements]
    turned = np.unique(np.concatenate([j[j >= 0], np.where(j >= 0, j, i)]))  # A(p_j) and G(p) of the reported body
    columns = np.cumsum([0, *[12 if f else 6 for f in framed[:-1]]]).astype(np.int64)  # each element's first column
    arrays = (np.concatenate(rows).astype(np.int64), starts, i, j, offsets, frames, place, turned, columns)
    return names, place, arrays


def spatial_reactions(system, q: np.ndarray, lam: np.ndarray, jac) -> dict[str, np.ndarray]:
    """``spatial.reactions.joint_reactions(system, q, lam, t)`` over the histories q (N, n), lambda (N, m), every
    element at once (``spatial_history_kernels``): each row's part -(Psi_q)_r^T lambda_r of the
    generalized force on the seven columns of either body (eq. 10.20), summed over the element's rows; the force F
    and the torque n = 1/2 G(p) Q_p (eq. 8.14), its moment taken about the joint point (eq. 10.21); a ground side
    gets the opposite of the other side's."""
    from ..spatial.joints import EulerNormalization
    from . import spatial_history_kernels

    if all(isinstance(e, EulerNormalization) for e in system.elements):  # free bodies: no joint, no reaction
        return {}
    _, _, arrays = layout(system, _spatial_layout)
    labels = layout(system, _spatial_labels)
    out = np.empty((len(labels), q.shape[0]))  # a column a row, in ``output_history.spatial_columns``' order
    histories = _histories(system, q, lam, jac, arrays[0], _spatial_reported, _spatial_slots)
    spatial_history_kernels.spatial_reactions(*histories, *arrays, out)
    return dict(zip(labels, out, strict=True))


def _spatial_labels(system) -> list[str]:
    """The spatial reaction columns' names in ``output_history.spatial_columns``' order (each element's F and M,
    then where it has joint frames F and M in the joint frame, axis by axis), made once per system (``layout``)."""
    names, place, _ = layout(system, _spatial_layout)
    labels = []
    for name, framed in zip(names, place, strict=True):
        labels += [f"{name}.{part}{axis}" for part in "FM" for axis in "xyz"]
        if framed >= 0:
            labels += [f"{name}.{part}{axis}_joint" for axis in "xyz" for part in "FM"]
    return labels


def joint_reactions(system, q: np.ndarray, lam: np.ndarray, jac) -> dict[str, np.ndarray]:
    """The reaction columns of every joint and driver over a run (module docstring), planar or spatial."""
    if system.model.dimension == 3:
        return spatial_reactions(system, q, lam, jac)
    return planar_reactions(system, q, lam, jac)


__all__ = ["BlockedJacobians", "block_slots", "constraint_arrays", "joint_reactions", "kinetic_energy", "residuals"]
