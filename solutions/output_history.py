"""What a run reports at its output times besides its motion, over all of them at once: constraint residuals and
joint reactions from Psi, Psi_q and Psi_t stacked over the output grid (either engine's).

``reactions.py`` and ``spatial/reactions.py`` give the reactions at one state, joint by joint (what students
write). A run has Psi, Psi_q and Psi_t at every output time already (the numpy engine evaluates them there for the
Guard's drift check, the compiled engine's module gives them in one call), and here they become the result columns
with array operations over all output times, in the same words:

- residuals: max |Psi| and max |Psi_q q' + Psi_t| per output time (``dynamics.constraint_residuals``);
- reactions: for joint k and each of its moving bodies i, Q_i^k = -(Psi_qi^k)^T lambda_k (eq. 5.70, 10.20),
  split into the force F and the moment about the joint point P: planar M = n - (r_P - r_i) x F (eq. 5.71),
  spatial n = 1/2 G(p_i) Q_p, M = n - (r_P - r_i) x F (eq. 10.21); ground takes minus what the joint exerts
  on the moving body. The columns are those of ``reactions.joint_reactions`` (the second body's force and
  moment; spatial joints also in the joint frame fixed in that body).

Tests (``tests/solutions/test_compiled_history.py``) compare every column with the functions at one state.
"""

from __future__ import annotations

import numpy as np

from .rotation_matrices import g_entries, rotation_entries


def residuals(psi: np.ndarray, jac: np.ndarray, psit: np.ndarray, qd: np.ndarray) -> dict[str, np.ndarray]:
    """'residual.position' max |Psi| and 'residual.velocity' max |Psi_q q' + Psi_t| at every output time."""
    velocity = (jac @ qd[:, :, None])[:, :, 0] + psit  # Psi_q q' at every time, by BLAS
    return {
        "residual.position": np.max(np.abs(psi), axis=1, initial=0.0),
        "residual.velocity": np.max(np.abs(velocity), axis=1, initial=0.0),
    }


def planar_joints(system) -> tuple[list, list, list, list, list]:
    """The planar joints as the reaction columns group them (``reactions.joint_groups``): their names, each one's
    rows of Psi, its two bodies (i, j), the body carrying its point and that point in the body (its first element's
    s_j, else the body's origin)."""
    from .reactions import joint_groups

    names, rows, sides, carriers, points, every_row = [], [], [], [], [], np.arange(system.n_constraints)
    for name, indices in joint_groups(system).items():
        first = next((system.elements[k] for k in indices if getattr(system.elements[k], "sj", None) is not None), None)
        owner = system.elements[indices[0]]
        names.append(name)
        rows.append(np.concatenate([every_row[system.rows[k]] for k in indices]))
        sides.append((owner.i, owner.j))
        carriers.append((owner if first is None else first).j)
        points.append((0.0, 0.0) if first is None else first.sj)
    return names, rows, sides, carriers, points


def planar_reactions(system, q: np.ndarray, lam: np.ndarray, jac: np.ndarray) -> dict[str, np.ndarray]:
    """``reactions.joint_reactions(system, q, lam, t)`` over the histories q (N, n), lambda (N, m), every joint at
    once: each row's part -(Psi_q)_r^T lambda_r of the generalized force on the three columns of either body (eq.
    5.70), summed over the rows of its joint, the moment taken about the joint point; a ground side gets the
    opposite of the other side's."""
    N = q.shape[0]
    X = np.concatenate([q.reshape(N, -1, 3), np.zeros((N, 1, 3))], axis=1)  # ground last: body -1
    names, rows, sides, carriers, points = planar_joints(system)
    if not names:  # no joint: no reaction
        return {}
    lengths = [len(r) for r in rows]
    starts = np.cumsum([0, *lengths[:-1]])  # each joint's first row in rows_all
    rows_all, (i, j) = np.concatenate(rows), np.array(sides).T
    carrier, s = np.array(carriers), np.asarray(points, dtype=float)
    c, sn = np.cos(X[:, carrier, 2]), np.sin(X[:, carrier, 2])  # the joint point r_j + A(phi_j) s_j (eq. 2.2)
    point = X[:, carrier, :2] + np.stack([c * s[:, 0] - sn * s[:, 1], sn * s[:, 0] + c * s[:, 1]], axis=-1)
    force, moment = {}, {}
    for side, body in (("i", i), ("j", j)):
        per_row = np.repeat(body, lengths)
        columns = 3 * np.maximum(per_row, 0)[:, None] + np.arange(3)  # ground's rows read column 0, then zeroed
        parts = -jac[:, rows_all[:, None], columns] * (lam[:, rows_all] * (per_row >= 0))[:, :, None]
        g = np.add.reduceat(parts, starts, axis=1)  # (N, joints, 3): x, y and the angle's column
        arm = point - X[:, body, :2]
        force[side], moment[side] = g[..., :2], g[..., 2] - (arm[..., 0] * g[..., 1] - arm[..., 1] * g[..., 0])
    ground = j < 0
    Fj = np.where(ground[:, None], -force["i"], force["j"])
    Mj = np.where(ground, -moment["i"], moment["j"])
    columns = {}
    for k, name in enumerate(names):
        columns[f"{name}.Fx"], columns[f"{name}.Fy"], columns[f"{name}.Mz"] = Fj[:, k, 0], Fj[:, k, 1], Mj[:, k]
    return columns


def axes(frame) -> np.ndarray:
    """[f g h] of a joint frame, its axes in the body as columns."""
    return np.column_stack([frame.f, frame.g, frame.h])


def spatial_reactions(system, q: np.ndarray, lam: np.ndarray, jac: np.ndarray) -> dict[str, np.ndarray]:
    """``spatial.reactions.joint_reactions(system, q, lam, t)`` over the histories q (N, n), lambda (N, m), every
    element at once: each row's part -(Psi_q)_r^T lambda_r of the generalized force on the seven columns of either
    body (eq. 10.20), summed over the element's rows; the force F and the torque n = 1/2 G(p) Q_p (eq. 8.14), its
    moment taken about the joint point; a ground side gets the opposite of the other side's."""
    from .spatial.joints import EulerNormalization, Joint

    N = q.shape[0]
    X = np.concatenate([q.reshape(N, -1, 7), np.tile([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], (N, 1, 1))], axis=1)
    p = X[..., 3:] / np.linalg.norm(X[..., 3:], axis=2, keepdims=True)  # every body's unit Euler parameters
    A = np.stack(rotation_entries(*np.moveaxis(p, 2, 0)), -1).reshape(N, -1, 3, 3)  # (eq. 8.12)
    G = np.stack(g_entries(*np.moveaxis(p, 2, 0)), -1).reshape(N, -1, 3, 4)  # (eq. 8.14)
    every_row = np.arange(system.n_constraints)
    elements = [(k, e) for k, e in enumerate(system.elements) if not isinstance(e, EulerNormalization)]
    if not elements:  # free bodies: no reaction
        return {}
    rows = [every_row[system.rows[k]] for k, _ in elements]
    lengths = [len(r) for r in rows]
    starts, rows_all = np.cumsum([0, *lengths[:-1]]), np.concatenate(rows)
    i, j = np.array([e.i for _, e in elements]), np.array([e.j for _, e in elements])
    framed = [isinstance(e, Joint) and bool(e.frames) for _, e in elements]
    offsets = np.zeros((len(elements), 3))  # the joint point in body j (its centre where none is given)
    for row, ((_, e), has_frames) in enumerate(zip(elements, framed, strict=True)):
        given = e.frames[1].origin if has_frames else getattr(e, "sj", None)
        offsets[row] = 0.0 if given is None else given
    point = X[:, j, :3] + (A[:, j] @ offsets[:, :, None])[..., 0]
    force, moment = {}, {}
    for side, body in (("i", i), ("j", j)):
        per_row = np.repeat(body, lengths)
        columns = 7 * np.maximum(per_row, 0)[:, None] + np.arange(7)  # ground's rows read column 0, then zeroed
        parts = -jac[:, rows_all[:, None], columns] * (lam[:, rows_all] * (per_row >= 0))[:, :, None]
        g = np.add.reduceat(parts, starts, axis=1)  # (N, elements, 7): Q_r, Q_p of the body
        n = 0.5 * (G[:, body] @ g[..., 3:, None])[..., 0]
        force[side], moment[side] = g[..., :3], n - np.cross(point - X[:, body, :3], g[..., :3])
    ground = (j < 0)[:, None]
    F, M = np.where(ground, -force["i"], force["j"]), np.where(ground, -moment["i"], moment["j"])
    joints = np.flatnonzero(framed)  # F and M in the joint frame too: its f, g, h in body j, turned to global axes
    frames = np.array([axes(elements[e][1].frames[1]) for e in joints]).reshape(-1, 3, 3)
    axes_t = np.swapaxes(A[:, j[joints]] @ frames, 2, 3)  # rows f, g, h (global)
    F_joint, M_joint = (axes_t @ F[:, joints, :, None])[..., 0], (axes_t @ M[:, joints, :, None])[..., 0]
    place = np.full(len(elements), -1)
    place[joints] = np.arange(joints.size)
    return spatial_columns([e.name for _, e in elements], F, M, F_joint, M_joint, place)


def spatial_columns(names, F, M, F_joint, M_joint, place) -> dict[str, np.ndarray]:
    """The spatial reaction columns of ``spatial.reactions.joint_reactions``, in its order: each element's force F
    and moment M (N, elements, 3), and where it has joint frames (``place``: its row in F_joint, M_joint, else -1)
    the same in the joint frame fixed in body j."""
    columns = {}
    for row, name in enumerate(names):
        for axis, c in zip("xyz", range(3), strict=True):
            columns[f"{name}.F{axis}"] = F[:, row, c]
        for axis, c in zip("xyz", range(3), strict=True):
            columns[f"{name}.M{axis}"] = M[:, row, c]
        if place[row] >= 0:
            for axis, c in zip("xyz", range(3), strict=True):
                columns[f"{name}.F{axis}_joint"] = F_joint[:, place[row], c]
                columns[f"{name}.M{axis}_joint"] = M_joint[:, place[row], c]
    return columns


def joint_reactions(system, q: np.ndarray, lam: np.ndarray, jac: np.ndarray) -> dict[str, np.ndarray]:
    """The reaction columns of every joint and driver over a run (module docstring), planar or spatial."""
    if system.model.dimension == 3:
        return spatial_reactions(system, q, lam, jac)
    return planar_reactions(system, q, lam, jac)


__all__ = ["joint_reactions", "planar_reactions", "residuals", "spatial_reactions"]
