"""The Unified Robot Description Format (URDF) from a model file: ``mbd export MODEL --to urdf``.

URDF (http://wiki.ros.org/urdf/XML) describes an open tree of ``<link>``s joined by ``<joint>``s, each joint
placing its child link's frame in its parent's (``<origin xyz rpy>``) and moving it about or along ``<axis>``
(in the child's frame, through its origin). What is written:

- ``<link name="ground">``, the root: the fixed world, the parent of every joint to ground;
- a link per body, its frame at the point of the joint that carries it (URDF's joint axis passes through the child
  link's origin) with the body's orientation, in the configuration the project's assembly makes consistent; its
  ``<inertial>`` at the centre of mass (``<origin>``, ``<mass>``, ``<inertia ixx .. izz>`` in the body frame; a
  planar body's polar moment J as (J, J, J));
- the joints of the spanning tree (``tree.spanning_tree``): revolute as ``continuous`` (a revolute joint of URDF
  needs limits; the course's have none), prismatic as ``prismatic`` (with ``<limit>`` far away: URDF requires it),
  rigid as ``fixed``; a body no joint reaches from ground as URDF's ``floating`` joint (planar: ``planar``,
  normal to z).

URDF holds no loops: a joint that closes one is refused by name (``ExportError``), as are joints URDF has no type
for (spherical, universal, cylindrical, pin-in-slot, distance, gear, rack, cam). It holds no gravity, initial
velocities, motors, spring-dampers or loads either: those are left out and named (``export_urdf``'s notes); the
other tool takes gravity along -z unless told (a planar model's gravity lies in its xy-plane).
"""

from __future__ import annotations

import math
from xml.sax.saxutils import quoteattr

import numpy as np

from .model import Model
from .tree import Mechanism, TreeEdge, mechanism, refuse

URDF_TYPES = {"revolute": "continuous", "prismatic": "prismatic", "rigid": "fixed"}
"""The course's joints URDF has a type for."""
FAR = 1e3
"""The limits of a prismatic joint (m): URDF requires them; the course's slides have none."""


def _v(x) -> str:
    return " ".join(f"{float(c):.17g}" for c in np.ravel(x))


def rpy(R: np.ndarray) -> np.ndarray:
    """URDF's roll, pitch, yaw of a rotation matrix: R = Rz(yaw) Ry(pitch) Rx(roll) (fixed axes x, y, z)."""
    roll = math.atan2(R[2, 1], R[2, 2])
    pitch = math.atan2(-R[2, 0], math.hypot(R[2, 1], R[2, 2]))
    yaw = math.atan2(R[1, 0], R[0, 0])
    return np.array([roll, pitch, yaw])


def link_origin(mech: Mechanism, body: int) -> np.ndarray:
    """Where a body's link frame is (global): the point of the joint that carries it, or its centre of mass."""
    if body < 0:
        return np.zeros(3)
    edge = mech.parent_edge(body)
    frame = mech.frame(body)
    if edge is None:
        return frame.r
    point = edge.joint.point1 if edge.reverse else edge.joint.point2
    return frame.r + frame.A @ point


def link(mech: Mechanism, body: int) -> str:
    """A ``<link>`` with its ``<inertial>`` at the centre of mass, in the link's frame."""
    b, frame = mech.model.bodies[body], mech.frame(body)
    com = frame.A.T @ (frame.r - link_origin(mech, body))
    J = np.diag([b.inertia] * 3) if mech.model.dimension == 2 else np.asarray(b.inertia, dtype=float)
    inertia = " ".join(
        f'{k}="{float(J[i, j]):.17g}"'
        for k, (i, j) in {
            "ixx": (0, 0),
            "ixy": (0, 1),
            "ixz": (0, 2),
            "iyy": (1, 1),
            "iyz": (1, 2),
            "izz": (2, 2),
        }.items()
    )
    return (
        f"<link name={quoteattr(b.name)}><inertial>"
        f'<origin xyz="{_v(com)}" rpy="0 0 0"/><mass value="{float(b.mass):.17g}"/><inertia {inertia}/>'
        "</inertial></link>"
    )


def joint(mech: Mechanism, edge: TreeEdge | None, body: int) -> str:
    """The ``<joint>`` that carries a body: its origin in the parent link's frame, its axis in the child's."""
    parent = -1 if edge is None else edge.parent
    P, C = mech.frame(parent), mech.frame(body)
    xyz = P.A.T @ (link_origin(mech, body) - link_origin(mech, parent))
    R = P.A.T @ C.A
    if edge is None:
        kind, name, axis = ("floating" if mech.model.dimension == 3 else "planar"), f"{mech.name(body)}.free", None
        axis = None if kind == "floating" else np.array([0.0, 0.0, 1.0])
    else:
        kind, name = URDF_TYPES[edge.joint.kind], edge.joint.name
        axis = edge.joint.axis1 if edge.reverse else edge.joint.axis2
    text = (
        f"<joint name={quoteattr(name)} type={quoteattr(kind)}><parent link={quoteattr(mech.name(parent))}/>"
        f'<child link={quoteattr(mech.name(body))}/><origin xyz="{_v(xyz)}" rpy="{_v(rpy(R))}"/>'
    )
    if axis is not None and kind != "fixed":
        text += f'<axis xyz="{_v(axis / np.linalg.norm(axis))}"/>'
    if kind == "prismatic":
        text += f'<limit lower="{-FAR:g}" upper="{FAR:g}" effort="{FAR:g}" velocity="{FAR:g}"/>'
    return text + "</joint>"


def _check(mech: Mechanism) -> None:
    model = mech.model
    index = {spec["name"]: k for k, spec in enumerate(model.joints)}
    for spec in model.joints:
        if spec["type"] not in URDF_TYPES:
            raise refuse(
                model, f"model.joints[{index[spec['name']]}] ({spec['name']})",
                f"a {spec['type']} joint (URDF's joints are revolute, continuous, prismatic, fixed, floating, planar)",
                "export to MJCF (mbd export MODEL --to mjcf), or model it with revolute and prismatic joints",
            )  # fmt: skip
    for cut in mech.cut:
        raise refuse(
            model, f"model.joints[{index[cut.name]}] ({cut.name})",
            f"closes a loop ({cut.body1 < 0 and 'ground' or mech.name(cut.body1)} - {mech.name(cut.body2)} are joined "
            "by the tree already); URDF holds open trees only",
            "export to MJCF, which closes loops with equality constraints (mbd export MODEL --to mjcf)",
        )  # fmt: skip


def left_out(model: Model) -> list[str]:
    """What URDF cannot hold and the export leaves out, named (one line each)."""
    notes = []
    for section, what in (("motors", "motors"), ("spring_dampers", "spring-dampers"), ("forces", "loads")):
        items = getattr(model, section)
        if items:
            notes.append(f"URDF holds no {what}: left out {', '.join(item['name'] for item in items)}")
    if np.any(model.gravity):
        notes.append(f"URDF holds no gravity: the model's is {list(map(float, model.gravity))} m/s^2")
    return notes


def export_urdf(model: Model) -> tuple[str, list[str]]:
    """The URDF text of an open-tree model and the notes naming what it leaves out; ExportError for a loop or a
    joint URDF has no type for (see the module's docstring)."""
    mech = mechanism(model)
    _check(mech)
    moving = [k for k, b in enumerate(model.bodies) if np.any(mech.frame(k).v) or np.any(mech.frame(k).omega)]
    notes = left_out(model)
    if moving:
        notes.append(
            "URDF holds no initial velocities: left out those of " + ", ".join(model.bodies[k].name for k in moving)
        )
    lines = [
        '<?xml version="1.0"?>',
        f"<robot name={quoteattr(model.name)}>",
        f"<!-- {model.source} exported by mbd export: links as assembled (mbd check); joint values 0 there -->",
        '<link name="ground"/>',
    ]
    for edge in mech.edges:
        lines += [link(mech, edge.child), joint(mech, edge, edge.child)]
    for body in mech.roots:
        lines += [link(mech, body), joint(mech, None, body)]
    lines.append("</robot>")
    return "\n".join(lines) + "\n", notes


__all__ = ["export_urdf", "rpy"]
