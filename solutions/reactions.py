"""Joint reactions: the forces and torques that the joints and drivers exert, from the multipliers.

The equations of motion M q'' + Psi_q^T lambda = Q (course notes, eq. 5.25) move the constraint term to
the left: the joints act on the bodies with the generalized forces -Psi_q^T lambda. Joint k, with rows
Psi^k and multipliers lambda_k, acts on body i of the joint with (eq. 5.70)

    Q_i^k = -(Psi_qi^k)^T lambda_k = [F_i ; n_i]        F_i the force, n_i its moment about the centre of body i

and on body j with Q_j^k likewise. Engineers report the moment about the joint point P instead of the
centre of mass (eq. 5.71):

    M_i = n_i - (r_P - r_i) x F_i,         a x b = a_x b_y - a_y b_x,

which is zero for a revolute joint and the locking torque for a prismatic one. In the body frame of i
the force is F_i' = A_i^T F_i (eq. 5.72). A joint's equations do not change when its two bodies move
together as one rigid body, so the pair is action and reaction: F_j = -F_i and M_j = -M_i about the same
point P. A joint to ground exerts on ground minus what it exerts on the moving body.

The point P is the joint's point on its second body, r_j + A_j s_j' (for a revolute joint also the point
of the first body); a driver without a point (an angle or a coordinate driver) uses the centre of body j.
Result columns follow DESIGN section 5: ``JOINT.Fx JOINT.Fy JOINT.Mz`` are the reaction on the joint's
second body (``body2`` in the file) in the global frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .assembly import System
from .linalg import minimum_norm_solution
from .planar.bodies import rotation


@dataclass
class JointReaction:
    """What one joint (all its constraint rows) exerts on its two bodies at one instant.

    ``force[b]`` is the global force on body b (0: the joint's first body, 1: its second), ``moment[b]``
    its moment about the joint point ``point``, ``force_local[b]`` the force in the frame of body b.
    """

    joint: str
    bodies: tuple[str, str]
    point: np.ndarray
    force: tuple[np.ndarray, np.ndarray]
    moment: tuple[float, float]
    force_local: tuple[np.ndarray, np.ndarray]


def cross(a: np.ndarray, b: np.ndarray) -> float:
    """Planar cross product a x b = a_x b_y - a_y b_x (the z component)."""
    return float(a[0] * b[1] - a[1] * b[0])


def body_reaction(jacobian_rows: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """Q_i^k = -(Psi_qi^k)^T lambda_k: the (3,) generalized reaction [F_x, F_y, n] on one body (eq. 5.70).

    ``jacobian_rows`` is the block Psi_qi^k of the joint's rows and the body's three columns.
    """
    ### BEGIN SOLUTION hw2
    return -jacobian_rows.T @ lam
    ### END SOLUTION


def moment_about_point(generalized: np.ndarray, arm: np.ndarray) -> float:
    """M = n - s x F: moment about P of a force F with moment n about the centre, s = r_P - r (eq. 5.71)."""
    ### BEGIN SOLUTION hw2
    return float(generalized[2]) - cross(arm, generalized[:2])
    ### END SOLUTION


def joint_groups(system: System) -> dict[str, list[int]]:
    """Element indices per joint or driver name (a prismatic or rigid joint has two elements)."""
    groups: dict[str, list[int]] = {}
    for k, element in enumerate(system.elements):
        groups.setdefault(element.name, []).append(k)
    return groups


def _body_state(q: np.ndarray, body: int) -> tuple[np.ndarray, float]:
    """Position of the centre and angle of a body; ground is at the origin with angle 0."""
    if body < 0:
        return np.zeros(2), 0.0
    return q[3 * body : 3 * body + 2], float(q[3 * body + 2])


def joint_point(system: System, indices: list[int], q: np.ndarray) -> np.ndarray:
    """Global position of the joint point P: the first element's point on body j, else the centre of j."""
    element = system.elements[indices[0]]
    for k in indices:
        if getattr(system.elements[k], "sj", None) is not None:
            element = system.elements[k]
            break
    r_j, phi_j = _body_state(q, element.j)
    s_j = getattr(element, "sj", None)
    return r_j if s_j is None else r_j + rotation(phi_j) @ s_j


def reactions_at(system: System, q: np.ndarray, lam: np.ndarray, t: float = 0.0) -> list[JointReaction]:
    """The reactions of every joint and driver at one state (q, lambda) at time t."""
    jacobian = system.jacobian(q, t)
    names = [b.name for b in system.model.bodies]
    out = []
    for joint, indices in joint_groups(system).items():
        first = system.elements[indices[0]]
        i, j = first.i, first.j
        point = joint_point(system, indices, q)
        rows = np.concatenate([np.arange(system.n_constraints)[system.rows[k]] for k in indices])
        force, moment = {}, {}
        for body in (i, j):  # the moving bodies: from their columns of Psi_q
            if body >= 0:
                g = body_reaction(jacobian[rows, 3 * body : 3 * body + 3], lam[rows])
                force[body] = g[:2]
                moment[body] = moment_about_point(g, point - _body_state(q, body)[0])
        for body, other in ((i, j), (j, i)):  # ground: action and reaction
            if body < 0:
                force[body], moment[body] = -force[other], -moment[other]
        local = tuple(rotation(_body_state(q, b)[1]).T @ force[b] for b in (i, j))
        bodies = tuple("ground" if b < 0 else names[b] for b in (i, j))
        out.append(JointReaction(joint, bodies, point, (force[i], force[j]), (moment[i], moment[j]), local))
    return out


def joint_reactions(
    system: System, q: np.ndarray, lam: np.ndarray, t: float | np.ndarray = 0.0, both_bodies: bool = False
) -> dict[str, np.ndarray]:
    """Reaction forces and torques of every joint and driver as result columns.

    Parameters
    ----------
    system : the assembled system
    q, lam : one state, shapes (n,) and (m,), or histories, shapes (N, n) and (N, m)
    t : time (or the N times) of the states; only drivers' Jacobians can depend on it
    both_bodies : also give, for each body b of the joint, ``JOINT.b.Fx``, ``JOINT.b.Fy``, ``JOINT.b.Mz``
        (global frame) and ``JOINT.b.Fx_local``, ``JOINT.b.Fy_local`` (frame of body b)

    Returns
    -------
    dict
        ``JOINT.Fx``, ``JOINT.Fy``, ``JOINT.Mz``: what the joint exerts on its second body, global frame,
        moment about the joint point (DESIGN section 5); values are floats for one state, (N,) arrays
        for histories.
    """
    if system.model.dimension == 3:  # forces and moments in 3D: spatial/reactions.py
        from .spatial.reactions import joint_reactions as spatial_joint_reactions

        return spatial_joint_reactions(system, q, lam, t, both_bodies)
    q, lam = np.asarray(q, dtype=float), np.asarray(lam, dtype=float)
    single = q.ndim == 1
    Q, L = np.atleast_2d(q), np.atleast_2d(lam)
    times = np.broadcast_to(np.asarray(t, dtype=float), (Q.shape[0],))
    columns: dict[str, list[float]] = {}
    for qk, lk, tk in zip(Q, L, times, strict=True):
        for reaction in reactions_at(system, qk, lk, float(tk)):
            name = reaction.joint
            values = {
                f"{name}.Fx": reaction.force[1][0],
                f"{name}.Fy": reaction.force[1][1],
                f"{name}.Mz": reaction.moment[1],
            }
            if both_bodies:
                for b, body in enumerate(reaction.bodies):
                    values[f"{name}.{body}.Fx"] = reaction.force[b][0]
                    values[f"{name}.{body}.Fy"] = reaction.force[b][1]
                    values[f"{name}.{body}.Mz"] = reaction.moment[b]
                    values[f"{name}.{body}.Fx_local"] = reaction.force_local[b][0]
                    values[f"{name}.{body}.Fy_local"] = reaction.force_local[b][1]
            for key, value in values.items():
                columns.setdefault(key, []).append(float(value))
    return {key: (values[0] if single else np.array(values)) for key, values in columns.items()}


REDUNDANT_NOTE = (
    "redundant constraints: the multipliers, and so the reactions of the joints that share a redundant "
    "constraint, are not unique (any lambda + u with Psi_q^T u = 0 gives the same motion); the reported set "
    "is the minimum-norm one, lambda in the range of Psi_q (eq. 5.73)"
)
"""What a result of a model with redundant constraints says about its reactions (``info['notes']``)."""


def minimum_norm_multipliers(system: System, q: np.ndarray, lam: np.ndarray, t: float | np.ndarray = 0.0) -> np.ndarray:
    """The minimum-norm multipliers with the same constraint forces as ``lam`` (eq. 5.73):

        lambda_min = argmin |lambda'|  subject to  Psi_q^T lambda' = Psi_q^T lambda

    that is, lam projected onto the range of Psi_q (rank by ``linalg.numerical_rank``). With independent
    constraints lambda is unique and comes back unchanged (to rounding); with redundant ones, the joints
    that share a redundant constraint share its reaction in the least-squares sense: a choice, since
    statics alone does not divide it (the reactions of an over-constrained loop depend on the compliance
    of its joints, which a rigid model does not have). ``q``, ``lam``: one state or histories (N, n), (N, m).
    """
    q, lam = np.asarray(q, dtype=float), np.asarray(lam, dtype=float)
    single = q.ndim == 1
    Q, L = np.atleast_2d(q), np.atleast_2d(lam)
    times = np.broadcast_to(np.asarray(t, dtype=float), (Q.shape[0],))
    out = np.empty_like(L)
    for k, (qk, lk, tk) in enumerate(zip(Q, L, times, strict=True)):
        jacobian = system.jacobian(qk, float(tk))
        out[k] = minimum_norm_solution(jacobian.T, jacobian.T @ lk)
    return out[0] if single else out


def driver_efforts(system: System, q: np.ndarray, lam: np.ndarray, t: float = 0.0) -> dict[str, float]:
    """The force or torque each driver applies along the quantity it drives: effort = -lambda dPsi/ds.

    For an angle, coordinate or linear driver Psi = s - f(t), so the effort is -lambda (a torque in N m
    on body j for an angle driver, a force in N along the axis for a linear one). For a distance driver
    Psi = (d^T d - L^2) / 2 has dPsi/dL = L, so the effort (the force pushing the two points apart) is
    -lambda L. The effort times the driven rate f'(t) is the driver's power.
    """
    motors = {m["name"] for m in system.model.motors}
    efforts: dict[str, float] = {}
    for k, element in enumerate(system.elements):
        if element.name not in motors:
            continue
        lam_k = float(np.asarray(lam)[system.rows[k]][0])
        length = getattr(element, "length", None)
        scale = length.value(t) if length is not None else 1.0
        efforts[element.name] = -lam_k * scale
    return efforts


__all__ = [
    "REDUNDANT_NOTE",
    "JointReaction",
    "body_reaction",
    "cross",
    "driver_efforts",
    "joint_point",
    "joint_reactions",
    "minimum_norm_multipliers",
    "moment_about_point",
    "reactions_at",
]
