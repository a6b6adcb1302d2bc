"""A model as another code's tree sees it: bodies in 3D at the assembled state, joints by their points and axes
in the two body frames, and a spanning tree of the joint graph with the joints it cuts (``mbd export``).

MJCF and URDF describe a mechanism as a tree of bodies, each placed in its parent's frame and moved by the joints
between them; a joint that closes a loop is not a joint of the tree but, in MJCF, an equality constraint (URDF
cannot hold it). Which joints to cut is a choice: the tree is a spanning tree of the joint graph (bodies as nodes,
ground one of them) grown by Kruskal's method over the joints in order of preference, so that the joints another
code can only hold as tree joints (a slide, a universal or cylindrical pair) are taken first and the joints it can
also close as a constraint (revolute, spherical, rigid) after them. ``joint_coordinates.tree_order`` grows its tree
breadth-first from ground and cuts whatever closes a loop first, which suits its own cut constraints (any element)
but not an exchange format's (the quick-return mechanism's slot would be cut there).

Planar models become 3D: a body's frame at (x, y, 0) turned by phi about z, joint axes in the xy-plane (a slide)
or along z (a hinge). Everything is taken at the configuration the project's assembly makes consistent
(``kinematics.assemble``) with the velocities of eq. 6.2 (``dynamics.consistent_initial_conditions``), so the
other code starts where ``mbd run`` starts.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from ..assembly import System, build_system
from ..rotation_matrices import euler_rotation, g_entries, planar_rotation
from .model import GROUND, Model, ModelError

TREE_ONLY = ("prismatic", "cylindrical", "universal", "revolute_prismatic")
"""Joints another code holds only as joints of the tree (no equality constraint of MJCF is one of them)."""
EITHER = ("revolute", "spherical", "rigid")
"""Joints held as tree joints or, when they close a loop, as equality constraints (MJCF connect, weld)."""
CUT_ONLY = ("revolute_revolute",)
"""Joints that are no joint of a tree (a distance between two points): always cut."""


class ExportError(ModelError):
    """A model element the target format cannot hold (one line: file, element, why, what to do)."""


@dataclass
class Frame:
    """A body's frame at the assembled state (its centre of mass, global): position r, rotation matrix A,
    Euler parameters p, velocity v of r and angular velocity omega (global)."""

    r: np.ndarray
    A: np.ndarray
    p: np.ndarray
    v: np.ndarray
    omega: np.ndarray


@dataclass
class JointGeometry:
    """A joint of the file by its points and axes, 3-vectors in the frames of body1 and body2 (-1 is ground):
    ``point1``, ``point2`` the joint's point; ``axis1`` its axis in body1 (a universal joint's body1 arm);
    ``axis2`` the axis in body2 (a universal joint's body2 arm)."""

    name: str
    kind: str
    body1: int
    body2: int
    point1: np.ndarray
    point2: np.ndarray
    axis1: np.ndarray
    axis2: np.ndarray


@dataclass
class TreeEdge:
    """A joint of the spanning tree from its parent to its child (``reverse``: the child is body1)."""

    joint: JointGeometry
    parent: int
    child: int

    @property
    def reverse(self) -> bool:
        return self.child == self.joint.body1


@dataclass
class Mechanism:
    """What an exporter needs: the model, its system, the bodies' frames (ground's at index -1 is the world), the
    joints' geometry, the spanning tree (``edges``, in topological order), the ``cut`` joints and the ``roots``
    (bodies that no tree joint reaches from ground: they float)."""

    model: Model
    system: System
    frames: list[Frame]
    joints: dict[str, JointGeometry]
    edges: list[TreeEdge] = field(default_factory=list)
    cut: list[JointGeometry] = field(default_factory=list)
    roots: list[int] = field(default_factory=list)

    def frame(self, body: int) -> Frame:
        """The frame of a body; ground (-1) is the world frame at rest."""
        if body < 0:
            zero = np.zeros(3)
            return Frame(zero, np.eye(3), np.array([1.0, 0.0, 0.0, 0.0]), zero, zero)
        return self.frames[body]

    def parent_edge(self, body: int) -> TreeEdge | None:
        return next((edge for edge in self.edges if edge.child == body), None)

    def name(self, body: int) -> str:
        return GROUND if body < 0 else self.model.bodies[body].name


def refuse(model: Model, where: str, why: str, todo: str) -> ExportError:
    """The one line of a refusal: the file, the element, why the format cannot hold it, what to do."""
    return ExportError(f"{model.source}: {where}: {why}; {todo}")


# -- the state ------------------------------------------------------------------------------------------------
def assembled_frames(model: Model, system: System, q0: np.ndarray, qd0: np.ndarray) -> list[Frame]:
    """Each body's frame at the assembled state with the consistent velocities of eq. 6.2."""
    from ..dynamics import consistent_initial_conditions
    from ..mass_matrix import mass_matrix

    q, qd, _ = consistent_initial_conditions(system, mass_matrix(model), q0, qd0)
    frames = []
    for k in range(len(model.bodies)):
        if model.dimension == 2:
            x, y, phi = q[3 * k : 3 * k + 3]
            vx, vy, w = qd[3 * k : 3 * k + 3]
            A = np.eye(3)
            A[:2, :2] = planar_rotation(phi)
            p = np.array([np.cos(phi / 2), 0.0, 0.0, np.sin(phi / 2)])
            frames.append(Frame(np.array([x, y, 0.0]), A, p, np.array([vx, vy, 0.0]), np.array([0.0, 0.0, w])))
        else:
            r, p = q[7 * k : 7 * k + 3], q[7 * k + 3 : 7 * k + 7]
            G = np.array(g_entries(*map(float, p))).reshape(3, 4)
            omega = 2.0 * G @ qd[7 * k + 3 : 7 * k + 7]  # eq. 8.16
            frames.append(Frame(r.copy(), euler_rotation(p), p / np.linalg.norm(p), qd[7 * k : 7 * k + 3], omega))
    return frames


# -- the joints' geometry ---------------------------------------------------------------------------------------
def _planar3(v) -> np.ndarray:
    return np.array([float(v[0]), float(v[1]), 0.0])


def joint_geometry(model: Model, system: System, frames: list[Frame]) -> dict[str, JointGeometry]:
    """Points and axes of every joint in its bodies' frames, read from the system's constraint elements (so the
    file's ``frame: body`` and defaults mean here what they mean to the solver)."""
    parts: dict[str, list] = {}
    for element in system.elements:
        parts.setdefault(element.name, []).append(element)
    z = np.array([0.0, 0.0, 1.0])
    out = {}
    for spec in model.joints:
        name, kind = spec["name"], spec["type"]
        i, j = model.body_index(spec["body1"]), model.body_index(spec["body2"])
        first = parts[name][0]
        if model.dimension == 3:
            fi, fj = first.frames
            out[name] = JointGeometry(name, kind, i, j, fi.origin, fj.origin, fi.h, fj.h)
            continue
        if kind in ("gear", "rack_pinion", "cam"):  # no points of a joint: the exporters refuse them by type
            out[name] = JointGeometry(name, kind, i, j, np.zeros(3), np.zeros(3), z, z)
            continue
        axis1 = _planar3(first.axis) if kind in ("prismatic", "revolute_prismatic") else z
        A1 = np.eye(3) if i < 0 else frames[i].A
        A2 = np.eye(3) if j < 0 else frames[j].A
        axis2 = A2.T @ A1 @ axis1
        out[name] = JointGeometry(name, kind, i, j, _planar3(first.si), _planar3(first.sj), axis1, axis2)
    return out


# -- the spanning tree ------------------------------------------------------------------------------------------
def preference(model: Model) -> list[dict]:
    """The joints in the order Kruskal's method takes them: those held only as tree joints, then driven joints
    (a motor drives a joint of the tree), then the others in the file's order; CUT_ONLY joints are left out."""
    driven = {m.get("joint") for m in model.motors}

    def rank(spec):
        return 0 if spec["type"] in TREE_ONLY else 1 if spec["name"] in driven else 2

    return sorted((s for s in model.joints if s["type"] not in CUT_ONLY), key=rank)


def spanning_tree(model: Model, joints: dict[str, JointGeometry]) -> tuple[list[TreeEdge], list, list[int]]:
    """(edges, cut, roots): Kruskal's method over ``preference(model)`` with a union-find of the bodies (a joint
    whose bodies are already connected closes a loop and is cut), then the tree oriented breadth-first from
    ground; bodies it does not reach are ``roots`` (they float), each with its own subtree."""
    parent = {k: k for k in range(-1, len(model.bodies))}

    def find(k):
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    tree, cut = [], []
    for spec in preference(model):
        joint = joints[spec["name"]]
        a, b = find(joint.body1), find(joint.body2)
        if a == b:
            cut.append(joint)
        else:
            parent[a] = b
            tree.append(joint)
    cut += [joints[s["name"]] for s in model.joints if s["type"] in CUT_ONLY]
    edges, reached, roots = [], set(), []
    for start in [-1, *range(len(model.bodies))]:
        if start in reached:
            continue
        if start >= 0:
            roots.append(start)
        reached.add(start)
        queue = deque([start])
        while queue:
            body = queue.popleft()
            for joint in tree:
                if body in (joint.body1, joint.body2):
                    other = joint.body2 if joint.body1 == body else joint.body1
                    if other not in reached:
                        reached.add(other)
                        edges.append(TreeEdge(joint, body, other))
                        queue.append(other)
    return edges, cut, roots


def mechanism(model: Model) -> Mechanism:
    """The model at its assembled state with its joints' geometry and spanning tree (``spanning_tree``)."""
    for k, body in enumerate(model.bodies):
        if not body.has_mass:
            raise refuse(
                model, f"model.bodies[{k}] ({body.name})", "no mass and inertia (a kinematic model)",
                "give every body mass and inertia: the other code integrates the equations of motion",
            )  # fmt: skip
    system, q0, qd0 = build_system(model)
    frames = assembled_frames(model, system, q0, qd0)
    joints = joint_geometry(model, system, frames)
    edges, cut, roots = spanning_tree(model, joints)
    return Mechanism(model, system, frames, joints, edges, cut, roots)


__all__ = ["ExportError", "Frame", "JointGeometry", "Mechanism", "TreeEdge", "mechanism", "refuse", "spanning_tree"]
