# Generated from solutions/spatial/reactions.py by `make modules` (every homework stubbed): do not edit by hand.
"""Spatial joint reactions: the forces and torques the joints and drivers exert, from the multipliers.

As in the plane (``reactions.py``), joint k with rows Psi^k and multipliers lambda_k acts on body i
with the generalized force Q_i^k = -(Psi_qi^k)^T lambda_k = [F_i ; Q_p]  (course notes, eq. 10.20).
Q_p is a 4-vector in p coordinates: any such vector is 2 G^T n + c p, with n the torque (global) about
the centre of mass, since the 4 x 4 matrix [p, G^T] is orthogonal (G G^T = I, G p = 0). The part
c p only stretches p, which the normalization constraint takes up; so (eq. 10.21)

    n_i = 1/2 G(p_i) Q_p   (global),        n_i' = 1/2 L(p_i) Q_p = A_i^T n_i   (body frame)

and about the joint point P the moment is M_i = n_i - (r_P - r_i) x F_i. The pair is action and
reaction, F_j = -F_i, M_j = -M_i about P; a joint to ground exerts on ground minus what it exerts on
the moving body.

Result columns (DESIGN section 5): ``JOINT.Fx JOINT.Fy JOINT.Fz JOINT.Mx JOINT.My JOINT.Mz``, the
reaction on the joint's second body (``body2`` in the file) in the global frame, the moment about the
joint point P (its definition frame's origin on body2; a driver without a point uses the centre of
body2); and for joints ``JOINT.Fx_joint`` ... ``JOINT.Mz_joint``, the same force and moment in the
joint's definition frame as fixed in body2 (x, y, z = its f, g, h axes: for a revolute joint
``Mz_joint`` is the torque about the pin, zero, and ``Fz_joint`` the axial thrust). The Euler-parameter
normalization rows carry no reaction and are left out.
"""

from __future__ import annotations

import numpy as np

from ..rotations import g_matrix, normalized, rotation_matrix
from .joints import EulerNormalization, Joint

GROUND = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])


def body_reaction(jacobian_rows: np.ndarray, lam: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, n): force and global torque about the centre from Q = -(Psi_qi^k)^T lambda_k (eq. 10.20, 8.21)."""
    raise NotImplementedError('body_reaction: (F, n): force and global torque about the centre from Q = -(Psi_qi^k)^T lambda_k, see eq. 10.20, 8.21')


def _body_q(system, q: np.ndarray, body: int) -> np.ndarray:
    return GROUND if body < 0 else q[7 * body : 7 * body + 7]


def joint_point(system, element, q: np.ndarray) -> np.ndarray:
    """The joint point P on body j: the joint frame's origin, a driver's point s_j', else the centre of j."""
    qj = _body_q(system, q, element.j)
    if isinstance(element, Joint) and element.frames:
        s = element.frames[1].origin
    else:
        s = getattr(element, "sj", None)
    return qj[:3].copy() if s is None else qj[:3] + rotation_matrix(normalized(qj[3:])) @ s


def reactions_at(system, q: np.ndarray, lam: np.ndarray, t: float = 0.0) -> dict[str, dict]:
    """{joint: {'bodies', 'point', 'force': (F_i, F_j), 'moment': (M_i, M_j), 'joint_frame': 3x3 or None}}."""
    jacobian = system.jacobian(q, t)
    out = {}
    for k, element in enumerate(system.elements):
        if isinstance(element, EulerNormalization):
            continue
        rows = system.rows[k]
        point = joint_point(system, element, q)
        force, moment = {}, {}
        for body in (element.i, element.j):
            if body >= 0:
                qb = _body_q(system, q, body)
                F, n = body_reaction(jacobian[rows, 7 * body : 7 * body + 7], lam[rows], qb[3:])
                force[body], moment[body] = F, n - np.cross(point - qb[:3], F)
        for body, other in ((element.i, element.j), (element.j, element.i)):
            if body < 0:
                force[body], moment[body] = -force[other], -moment[other]
        axes = None
        if isinstance(element, Joint) and element.frames:
            frame = element.frames[1]
            A = rotation_matrix(normalized(_body_q(system, q, element.j)[3:]))
            axes = A @ np.column_stack([frame.f, frame.g, frame.h])  # global f, g, h of the joint frame
        out[element.name] = {
            "bodies": (element.i, element.j),
            "point": point,
            "force": (force[element.i], force[element.j]),
            "moment": (moment[element.i], moment[element.j]),
            "joint_frame": axes,
        }
    return out


def joint_reactions(
    system, q: np.ndarray, lam: np.ndarray, t: float | np.ndarray = 0.0, both_bodies: bool = False
) -> dict[str, np.ndarray]:
    """Reaction forces and moments of every joint and driver as result columns (module docstring).

    q, lam: one state ((n,), (m,)) or histories ((N, n), (N, m)); t the time or the N times.
    ``both_bodies`` adds ``JOINT.BODY.Fx`` ... ``JOINT.BODY.Mz`` for each of the two bodies (global).
    """
    q, lam = np.asarray(q, dtype=float), np.asarray(lam, dtype=float)
    single = q.ndim == 1
    Q, L = np.atleast_2d(q), np.atleast_2d(lam)
    times = np.broadcast_to(np.asarray(t, dtype=float), (Q.shape[0],))
    names = ["ground"] + [b.name for b in system.model.bodies]
    columns: dict[str, list[float]] = {}
    for qk, lk, tk in zip(Q, L, times, strict=True):
        for joint, r in reactions_at(system, qk, lk, float(tk)).items():
            values = {}
            F, M = r["force"][1], r["moment"][1]
            for axis, k in zip("xyz", range(3), strict=True):
                values[f"{joint}.F{axis}"] = F[k]
            for axis, k in zip("xyz", range(3), strict=True):
                values[f"{joint}.M{axis}"] = M[k]
            if r["joint_frame"] is not None:
                F_joint, M_joint = r["joint_frame"].T @ F, r["joint_frame"].T @ M
                for axis, k in zip("xyz", range(3), strict=True):
                    values[f"{joint}.F{axis}_joint"] = F_joint[k]
                    values[f"{joint}.M{axis}_joint"] = M_joint[k]
            if both_bodies:
                for b, body in enumerate(r["bodies"]):
                    for axis, k in zip("xyz", range(3), strict=True):
                        values[f"{joint}.{names[body + 1]}.F{axis}"] = r["force"][b][k]
                        values[f"{joint}.{names[body + 1]}.M{axis}"] = r["moment"][b][k]
            for key, value in values.items():
                columns.setdefault(key, []).append(float(value))
    return {key: (values[0] if single else np.array(values)) for key, values in columns.items()}


__all__ = ["body_reaction", "joint_point", "joint_reactions", "reactions_at"]
