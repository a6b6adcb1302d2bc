"""Model files of other codes in: URDF (ROS) and MJCF (MuJoCo) -> this project's model file (DESIGN section 4).

Both formats describe a *tree* of rigid bodies, each placed relative to its parent; this project's file gives every
body and joint globally, in one configuration. So an import walks the tree once from the root, composes the frames
(r_child = r_parent + A_parent s, A_child = A_parent A_rel, eq. 8.1) and writes, for each body:

- ``location`` and ``orientation`` (``rotation_matrix``: the columns are the body axes in global components): the
  origin and axes of the file's link (URDF) or body (MJCF) frame, so that the file's frame stays the body frame;
- ``com``: the centre of mass in that frame, and ``inertia``: the 3x3 inertia tensor about the centre of mass in
  that frame's axes, J' = R J_c R^T, where J_c is the file's tensor in its inertial frame, turned by R;
- joints with their global ``location`` (the joint's origin) and ``axis``; closed loops (MJCF only) as joints too.

The configuration written is the file's own: URDF's joint positions are zero there; MJCF's qpos0 is each joint's
``ref``, at which the file's body poses hold by definition; initial velocities are zero. An MJCF key named
``initial`` (what ``mbd export`` writes) gives the initial state instead, velocities included.

A model is always spatial (``dimension: 3``), also when every joint keeps the motion in one plane: the planar
motion then comes out of the spatial equations (redundant out-of-plane loop equations are allowed), which is
simpler, and exact, rather than guessing a plane. Fixed joints (URDF ``fixed``, an MJCF body without a joint) merge
the child into its parent as one rigid body (mass, centre of mass and inertia combined by the parallel axis
theorem), as MuJoCo's ``fusestatic`` does. What the model cannot hold (limits, transmissions and actuators, geometry
and contacts, ...) is listed in ``Imported.dropped``, one line per kind of element; what would change the model's
degrees of freedom or mass in a way this format cannot say (a planar joint, two joints of one body other than a
cylindrical or universal pair, the mass of a mesh, an equality on joint values) is refused with a ``ModelError``
naming the file, the element and what to do. An MJCF body without ``<inertial>`` takes the mass of its primitive
geoms as MuJoCo's compiler does (``_geom_inertia``).
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..rotation_matrices import euler_rotation
from ..rotations import euler_parameters, rodrigues
from .model import GROUND, ModelError

SUFFIXES = (".urdf", ".xml", ".mjcf")
"""The files ``import_file`` reads: URDF (root element ``<robot>``) or MJCF (``<mujoco>``), by their content."""

STANDARD_GRAVITY = (0.0, 0.0, -9.81)
"""URDF gives no gravity: ROS, Gazebo and MuJoCo take 9.81 m/s^2 along -z, and so does the import."""

NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_\-]*$")
"""A name this project's files accept (the schema's pattern)."""


@dataclass
class Imported:
    """A model file's content (``model`` and nothing else) and what the import left out, one line per kind."""

    data: dict
    dropped: list[str] = field(default_factory=list)


@dataclass
class Link:
    """A rigid link (URDF) or body (MJCF) of the file's tree, placed in the file's configuration.

    ``R`` has the frame's axes in global components as columns, ``r`` is its origin; ``com`` is the centre of mass
    in the frame, ``inertia`` the tensor about it in the frame's axes. ``joint`` connects it to ``parent`` (None: the
    ground): its type is one of revolute, prismatic, spherical, fixed or free, with global location and axis.
    """

    name: str
    R: np.ndarray
    r: np.ndarray
    parent: str | None = None
    joint: dict | None = None
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    has_inertial: bool = False
    springs: list[dict] = field(default_factory=list)
    sites: dict[str, tuple] = field(default_factory=dict)  # MJCF: named frames (point, axes) in the link frame
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))  # of the frame's origin, global
    angular_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))  # global


def import_file(path: str | Path) -> Imported:
    """Read a URDF or MJCF file (which one: the root element) into this project's model file content.

    Raises
    ------
    ModelError
        A file that cannot be read or parsed, or holds what the model cannot represent (file, element, what to do).
    """
    path = Path(path)
    label = path.name
    try:
        root = ET.parse(path).getroot()
    except OSError as err:
        raise ModelError(f"{path}: cannot read the file ({err.strerror})") from None
    except ET.ParseError as err:
        line, column = err.position
        raise ModelError(f"{label}: line {line}, column {column + 1}: malformed XML; check the tags") from None
    if root.tag == "robot":
        return urdf_model(root, label)
    if root.tag == "mujoco":
        return mjcf_model(root, label, path.parent)
    raise ModelError(
        f"{label}: <{root.tag}>: not a URDF (<robot>) or MJCF (<mujoco>) file; import reads those two formats"
    )


# -- numbers and frames ----------------------------------------------------------------------------------------
def _numbers(element: ET.Element, key: str, label: str, size: int, default=None, attrs: dict | None = None):
    """The attribute ``key`` as ``size`` floats (``default`` when absent; None: required)."""
    attrs = element.attrib if attrs is None else attrs
    text = attrs.get(key)
    what = f"<{element.tag}{_named(element)}> {key}"
    if text is None:
        if default is None:
            raise ModelError(f"{label}: {what}: missing; give {size} number(s)")
        return np.asarray(default, dtype=float)
    try:
        values = np.array([float(v) for v in text.split()])
    except ValueError:
        raise ModelError(f"{label}: {what}={text!r}: not numbers; give {size} number(s)") from None
    if values.size != size:
        raise ModelError(f"{label}: {what}={text!r}: expected {size} number(s)")
    return values


def _named(element: ET.Element) -> str:
    name = element.get("name") or element.get("link")
    return f' name="{name}"' if name else ""


def rpy_matrix(rpy) -> np.ndarray:
    """URDF's fixed-axis roll-pitch-yaw: roll about x, then pitch about the fixed y, then yaw about the fixed z,
    A = Rz(yaw) Ry(pitch) Rx(roll) (eq. 8.1 with Rodrigues' formula for each, eq. 8.8)."""
    roll, pitch, yaw = (float(a) for a in rpy)
    return rodrigues(np.eye(3)[2], yaw) @ rodrigues(np.eye(3)[1], pitch) @ rodrigues(np.eye(3)[0], roll)


def _unit(v: np.ndarray, label: str, what: str) -> np.ndarray:
    size = float(np.linalg.norm(v))
    if size < 1e-12:
        raise ModelError(f"{label}: {what}: the axis is zero; give a direction, e.g. 0 0 1")
    return np.asarray(v, dtype=float) / size


def _name(text: str | None, fallback: str, taken: set[str]) -> str:
    """A name the model file accepts: the file's with other characters as '_', unique, never 'ground'."""
    name = re.sub(r"[^A-Za-z0-9_\-]", "_", text or fallback)
    if not NAME.match(name):
        name = f"_{name}"
    if name == GROUND:
        name = "ground_"
    base, k = name, 1
    while name in taken:
        k += 1
        name = f"{base}_{k}"
    taken.add(name)
    return name


# -- URDF ------------------------------------------------------------------------------------------------------
URDF_JOINTS = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic", "fixed": "fixed",
               "floating": "free"}  # fmt: skip
"""URDF joint types and the model's: a floating joint is a free body (no joint), a fixed one merges the link."""


def _origin(element: ET.Element | None, label: str) -> tuple[np.ndarray, np.ndarray]:
    """(A, s) of an ``<origin xyz rpy>`` (both default 0): the child frame's axes and origin in the parent's."""
    if element is None:
        return np.eye(3), np.zeros(3)
    return rpy_matrix(_numbers(element, "rpy", label, 3, [0, 0, 0])), _numbers(element, "xyz", label, 3, [0, 0, 0])


def _urdf_inertial(link: ET.Element, label: str) -> tuple[float, np.ndarray, np.ndarray] | None:
    """(mass, com, inertia) of a link's ``<inertial>`` in the link frame, or None without one.

    ``<origin xyz rpy>`` places the inertial frame in the link frame; ``<inertia ixx .. izz>`` is the tensor about
    the centre of mass in the inertial frame's axes, so in the link frame's it is J' = A J_c A^T."""
    inertial = link.find("inertial")
    if inertial is None:
        return None
    where = f"link '{link.get('name')}' <inertial>"
    mass_element, tensor = inertial.find("mass"), inertial.find("inertia")
    if mass_element is None or tensor is None:
        raise ModelError(f"{label}: {where}: needs <mass value=.../> and <inertia ixx=... iyy=... izz=... .../>")
    mass = float(_numbers(mass_element, "value", label, 1)[0])
    entries = {key: float(_numbers(tensor, key, label, 1, [0.0])[0]) for key in
               ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}  # fmt: skip
    J = np.array([[entries["ixx"], entries["ixy"], entries["ixz"]],
                  [entries["ixy"], entries["iyy"], entries["iyz"]],
                  [entries["ixz"], entries["iyz"], entries["izz"]]])  # fmt: skip
    A, com = _origin(inertial.find("origin"), label)
    return mass, com, A @ J @ A.T


def urdf_model(robot: ET.Element, label: str) -> Imported:
    """A URDF ``<robot>``: links joined by joints into a tree whose root link is the ground.

    Conventions (ROS REP 103 and the URDF specification): a joint's ``<origin xyz rpy>`` places the child link's
    frame (= the joint frame) in the parent link's frame, xyz in m, rpy fixed-axis roll-pitch-yaw in rad
    (``rpy_matrix``); its ``<axis xyz>`` (default 1 0 0) is in the joint frame. The root link (never a child) is
    fixed, as MuJoCo and RViz take it: it is the ground, and its mass drops out.
    """
    dropped: list[str] = []
    links = {}
    for link in robot.findall("link"):
        if not link.get("name"):
            raise ModelError(f"{label}: <link>: a link without a name; give every link a name")
        if link.get("name") in links:
            raise ModelError(f"{label}: link '{link.get('name')}': the name is used twice; names must be unique")
        links[link.get("name")] = link
    if not links:
        raise ModelError(f"{label}: <robot>: no <link>; a URDF describes at least one link")
    joints = {}
    for joint in robot.findall("joint"):
        child = joint.find("child")
        parent = joint.find("parent")
        name = joint.get("name", "?")
        if child is None or parent is None:
            raise ModelError(f"{label}: joint '{name}': needs <parent link=.../> and <child link=.../>")
        for end in (parent, child):
            if end.get("link") not in links:
                raise ModelError(f"{label}: joint '{name}' <{end.tag}>: no link named '{end.get('link')}'")
        if child.get("link") in joints:
            raise ModelError(
                f"{label}: joint '{name}': link '{child.get('link')}' is the child of two joints; a URDF is a tree "
                "(a closed loop needs MJCF's <equality connect>)"
            )
        joints[child.get("link")] = joint
    roots = [name for name in links if name not in joints]
    if len(roots) != 1:
        what = "no root link (the joints form a loop)" if not roots else f"{len(roots)} root links ({', '.join(roots)})"
        raise ModelError(f"{label}: <robot>: {what}; a URDF is one tree with one root link")
    root = roots[0]
    if _urdf_inertial(links[root], label) is not None:
        dropped.append(f"<inertial> of the root link '{root}': the root is the ground (fixed, as MuJoCo takes it)")
    children: dict[str, list[str]] = {}
    for child, joint in joints.items():
        children.setdefault(joint.find("parent").get("link"), []).append(child)
    taken, joint_names = {GROUND}, set()
    placed = {root: Link(GROUND, np.eye(3), np.zeros(3))}
    order: list[Link] = []
    kinds: dict[str, list[str]] = {}
    stack = list(reversed(children.get(root, [])))
    while stack:
        child = stack.pop()
        joint = joints[child]
        parent = joint.find("parent").get("link")
        link = _urdf_link(links[child], joint, placed[parent], label, (taken, joint_names), kinds)
        placed[child] = link
        order.append(link)
        stack.extend(reversed(children.get(child, [])))
    if len(order) + 1 != len(links):
        raise ModelError(f"{label}: <robot>: some links are not connected to the root '{root}'; join them by joints")
    for kind, what in URDF_DROPPED.items():
        if kinds.get(kind):
            dropped.append(f"{kind} of {_list(kinds[kind])}: {what}")
    for tag, what in URDF_TOP.items():
        count = len(robot.findall(tag))
        if count:
            dropped.append(f"{count} <{tag}> element(s): {what}")
    model = _model_data(robot.get("name") or label, order, np.array(STANDARD_GRAVITY), [], label, dropped)
    dropped.insert(0, "gravity: URDF gives none; 9.81 m/s^2 along -z assumed (as ROS, Gazebo and MuJoCo take it)")
    return Imported(model, dropped)


URDF_DROPPED = {
    "<limit>": "dropped (the joints move without position, velocity or effort limits)",
    "<dynamics friction>": "dropped (no joint friction)",
    "<dynamics damping> of prismatic joints": "dropped (no translational joint damping)",
    "<mimic>": "dropped (the joints move independently)",
    "<safety_controller>": "dropped",
    "<calibration>": "dropped",
    "<visual>/<collision>": "dropped (no contacts; bodies are drawn as in any model file)",
}
"""Elements of links and joints that the model cannot hold, and what that means."""

URDF_TOP = {
    "transmission": "dropped (no actuators: the joints are unactuated)",
    "mujoco": "dropped (MuJoCo's settings for compiling the URDF)",
    "gazebo": "dropped (simulator settings)",
    "material": "dropped (appearance)",
}
"""Top-level elements of a robot that the model cannot hold."""


def _list(names: list[str]) -> str:
    return ", ".join(f"'{n}'" for n in names)


def _urdf_link(element, joint, parent: Link, label: str, taken: tuple[set, set], kinds: dict) -> Link:
    """A child link placed by its joint: A = A_p A_o, r = r_p + A_p s_o (``_origin``), the axis A (0 0 1 default
    1 0 0); the joint's location is the child frame's origin."""
    name, jname = element.get("name"), joint.get("name", "?")
    kind = joint.get("type")
    if kind == "planar":
        raise ModelError(
            f"{label}: joint '{jname}' type=\"planar\": the model has no planar (3-freedom) joint; "
            "replace it by two prismatic joints and a revolute one through light intermediate links"
        )
    if kind not in URDF_JOINTS:
        raise ModelError(
            f"{label}: joint '{jname}' type={kind!r}: unknown; URDF's types are {', '.join(URDF_JOINTS)}, planar"
        )
    A_o, s_o = _origin(joint.find("origin"), label)
    link = Link(_name(name, "link", taken[0]), parent.R @ A_o, parent.r + parent.R @ s_o, parent=parent.name)
    axis = _unit(_numbers(joint.find("axis"), "xyz", label, 3), label, f"joint '{jname}' <axis>") if (
        joint.find("axis") is not None) else np.array([1.0, 0.0, 0.0])  # fmt: skip
    link.joint = {"name": _name(jname, "joint", taken[1]), "type": URDF_JOINTS[kind], "location": link.r,
                  "axis": link.R @ axis}  # fmt: skip
    inertial = _urdf_inertial(element, label)
    if inertial is not None:
        link.mass, link.com, link.inertia = inertial
        link.has_inertial = True
    dynamics = joint.find("dynamics")
    if dynamics is not None:
        damping = float(_numbers(dynamics, "damping", label, 1, [0.0])[0])
        if damping and link.joint["type"] == "revolute":
            link.springs.append({"damping_coefficient": damping})
        elif damping:
            kinds.setdefault("<dynamics damping> of prismatic joints", []).append(jname)
        if float(_numbers(dynamics, "friction", label, 1, [0.0])[0]):
            kinds.setdefault("<dynamics friction>", []).append(jname)
    for tag in ("limit", "mimic", "safety_controller", "calibration"):
        if joint.find(tag) is not None:
            kinds.setdefault(f"<{tag}>", []).append(jname)
    if element.find("visual") is not None or element.find("collision") is not None:
        kinds.setdefault("<visual>/<collision>", []).append(name)
    return link


# -- MJCF ------------------------------------------------------------------------------------------------------
MJCF_REFUSED = {
    "include": "write the included file's content in place (or import the file that holds the bodies)",
    "frame": "write the frame's pose into its bodies",
    "replicate": "write the replicated bodies out",
    "composite": "composites (cables, cloth) are not rigid multibody models",
    "flexcomp": "flexible bodies are not rigid multibody models",
    "attach": "write the attached model's bodies in place",
}
"""MJCF elements an import refuses, and what to do instead."""

MJCF_TOP_DROPPED = {
    "sensor": "dropped (results report every coordinate)",
    "contact": "dropped (no contacts)",
    "asset": "dropped (meshes, textures, materials)",
    "visual": "dropped (appearance)",
    "statistic": "dropped",
    "size": "dropped",
    "custom": "dropped",
    "extension": "dropped (plugins)",
}
"""Top-level MJCF sections that the model cannot hold, and what that means."""

MJCF_JOINTS = {"hinge": "revolute", "slide": "prismatic", "ball": "spherical", "free": "free"}


@dataclass
class Mjcf:
    """What an MJCF file's ``<compiler>`` and ``<default>`` say about the rest of it."""

    label: str
    angle: float  # factor from the file's angles to rad: compiler angle="degree" (MuJoCo's default) or "radian"
    eulerseq: str
    classes: dict[str, dict[str, dict]]
    fromgeom: str = "auto"  # compiler inertiafromgeom: a body's mass from its geoms (true), its inertial, or either

    def attrs(self, element: ET.Element, childclass: str) -> dict:
        """The element's attributes over those of its default class (its ``class``, else the body's childclass)."""
        name = element.get("class") or childclass
        if name not in self.classes:
            raise ModelError(
                f"{self.label}: <{element.tag}{_named(element)}> class={name!r}: no <default class={name!r}>"
            )
        return {**self.classes[name].get(element.tag, {}), **element.attrib}

    def rotation(self, element: ET.Element, attrs: dict | None = None) -> np.ndarray:
        """A frame's axes in its parent's, from whichever of MuJoCo's forms it gives (identity if none):
        quat (w x y z, normalized), axisangle (x y z angle), euler (three angles about the axes of ``eulerseq``:
        lower case rotate with the frame, upper case stay fixed), xyaxes (x and y axes, y made normal to x), zaxis
        (the shortest rotation from 0 0 1 to it)."""
        attrs = element.attrib if attrs is None else attrs
        label = self.label
        if "quat" in attrs:
            p = _numbers(element, "quat", label, 4, attrs=attrs)
            return euler_rotation(p / np.linalg.norm(p))
        if "axisangle" in attrs:
            values = _numbers(element, "axisangle", label, 4, attrs=attrs)
            return rodrigues(_unit(values[:3], label, f"<{element.tag}> axisangle"), values[3] * self.angle)
        if "euler" in attrs:
            A = np.eye(3)
            for axis, angle in zip(self.eulerseq, _numbers(element, "euler", label, 3, attrs=attrs), strict=True):
                turn = rodrigues(np.eye(3)["xyz".index(axis.lower())], angle * self.angle)
                A = A @ turn if axis.islower() else turn @ A
            return A
        if "xyaxes" in attrs:
            values = _numbers(element, "xyaxes", label, 6, attrs=attrs)
            x = _unit(values[:3], label, f"<{element.tag}> xyaxes")
            y = _unit(values[3:] - (values[3:] @ x) * x, label, f"<{element.tag}> xyaxes")
            return np.column_stack([x, y, np.cross(x, y)])
        if "zaxis" in attrs:
            return z_rotation(_unit(_numbers(element, "zaxis", label, 3, attrs=attrs), label, f"<{element.tag}> zaxis"))
        return np.eye(3)


def z_rotation(z: np.ndarray) -> np.ndarray:
    """The shortest rotation that turns 0 0 1 into the unit vector z (MuJoCo's zaxis and fromto frames)."""
    turn = np.cross([0.0, 0.0, 1.0], z)
    if np.linalg.norm(turn) < 1e-12:
        return np.eye(3) if z[2] > 0 else np.diag([1.0, -1.0, -1.0])
    return rodrigues(turn, math.atan2(np.linalg.norm(turn), z[2]))


def _mjcf_classes(root: ET.Element) -> dict[str, dict[str, dict]]:
    """Default classes by name ('main': the top one), each {tag: attributes}, inheriting from the enclosing one."""
    classes: dict[str, dict[str, dict]] = {"main": {}}

    def walk(element: ET.Element, name: str, inherited: dict) -> None:
        own = {tag: dict(attrs) for tag, attrs in inherited.items()}
        for child in element:
            if child.tag != "default":
                own.setdefault(child.tag, {}).update(child.attrib)
        classes[name] = own
        for child in element:
            if child.tag == "default":
                walk(child, child.get("class", "main"), own)

    for top in root.findall("default"):
        walk(top, top.get("class", "main"), classes["main"])
    return classes


def mjcf_model(root: ET.Element, label: str, folder: Path) -> Imported:
    """An MJCF ``<mujoco>``: the bodies of ``<worldbody>`` with their joints, closed by ``<equality connect/weld>``.

    Conventions (MuJoCo's XML reference): a body's ``pos`` and orientation place its frame in its parent's; a joint's
    ``pos`` and ``axis`` (default 0 0 1) are in its body's frame; ``<inertial pos .. mass diaginertia|fullinertia>``
    places the inertial frame, whose axes the tensor is given in; angles are in degrees unless ``<compiler
    angle="radian">``. The file's pose is qpos0 (each hinge and slide at its ``ref``), where the model starts.
    """
    for tag, what in MJCF_REFUSED.items():
        element = root.find(f".//{tag}")
        if element is not None:
            raise ModelError(f"{label}: <{tag}>: import does not expand it; {what}")
    mjcf = _mjcf_compiler(root, label)
    gravity = np.array(STANDARD_GRAVITY)
    for option in root.findall("option"):
        gravity = _numbers(option, "gravity", label, 3, gravity)
    dropped: list[str] = []
    kinds: dict[str, list[str]] = {}
    placed, order = _mjcf_tree(root, mjcf, kinds)
    links = [placed["world"], *order]
    rest = _site_points(links)  # at qpos0, where MuJoCo measures a tendon's rest length
    _mjcf_keyframe(root, order, mjcf, dropped)
    loops = _mjcf_loops(root, placed, mjcf, dropped, {link.joint["name"] for link in order})
    tendons = _mjcf_tendons(root, links, rest, mjcf, dropped)
    loads = _mjcf_actuators(root, links, mjcf, dropped)
    _mjcf_dropped(root, kinds, dropped)
    model = _model_data(root.get("model") or label, order, gravity, loops, label, dropped, tendons, loads)
    return Imported(model, dropped)


def _mjcf_compiler(root: ET.Element, label: str) -> Mjcf:
    """What ``<compiler>`` and ``<default>`` say: the unit of angles, the Euler sequence, the default classes."""
    compiler = {k: v for c in root.findall("compiler") for k, v in c.attrib.items()}
    if compiler.get("coordinate", "local") != "local":
        raise ModelError(f"{label}: <compiler coordinate=...>: global coordinates are gone from MuJoCo; use local")
    fromgeom = compiler.get("inertiafromgeom", "auto")
    if fromgeom not in ("auto", "true", "false"):
        raise ModelError(f"{label}: <compiler inertiafromgeom={fromgeom!r}>: write auto, true or false")
    for key in ("settotalmass", "boundmass", "boundinertia", "balanceinertia"):
        if key in compiler:
            raise ModelError(f"{label}: <compiler {key}=...>: import keeps the file's masses as given; remove it")
    angle = {"degree": math.pi / 180.0, "radian": 1.0}.get(compiler.get("angle", "degree"))
    if angle is None:
        raise ModelError(f"{label}: <compiler angle={compiler['angle']!r}>: write degree or radian")
    eulerseq = compiler.get("eulerseq", "xyz")
    if len(eulerseq) != 3 or any(a not in "xyzXYZ" for a in eulerseq):
        raise ModelError(f"{label}: <compiler eulerseq={eulerseq!r}>: three letters of xyzXYZ, e.g. xyz")
    return Mjcf(label, angle, eulerseq, _mjcf_classes(root), fromgeom)


def _mjcf_tree(root: ET.Element, mjcf: Mjcf, kinds: dict) -> tuple[dict[str, Link], list[Link]]:
    """The bodies of ``<worldbody>`` placed in the file's pose, parents first (depth first, the file's order, which
    is MuJoCo's), by the file's names ('world': the ground, with the world's sites)."""
    world = root.find("worldbody")
    if world is None:
        raise ModelError(f"{mjcf.label}: <mujoco>: no <worldbody>; the bodies of an MJCF model are in it")
    taken = ({GROUND}, set())
    placed = {"world": Link(GROUND, np.eye(3), np.zeros(3))}
    if world.find("geom") is not None:
        kinds.setdefault("<geom>", []).append("world")
    for site in world.findall("site"):
        point = _numbers(site, "pos", mjcf.label, 3, [0, 0, 0])
        placed["world"].sites[site.get("name") or "site"] = (point, mjcf.rotation(site))
    order: list[Link] = []
    stack = [(body, placed["world"], "main") for body in reversed(world.findall("body"))]
    while stack:
        element, parent, childclass = stack.pop()
        link = _mjcf_body(element, parent, mjcf, childclass, taken, kinds)
        placed[element.get("name") or link.name] = link
        order.append(link)
        inner = element.get("childclass", childclass)
        stack.extend((body, link, inner) for body in reversed(element.findall("body")))
    return placed, order


def _mjcf_dropped(root: ET.Element, kinds: dict, dropped: list[str]) -> None:
    """One line per kind of element the model does not hold (joint attributes, geoms, whole sections)."""
    for kind, what in MJCF_DROPPED.items():
        if kinds.get(kind):
            dropped.append(f"{kind} of {_list(kinds[kind])}: {what}")
    for tag, what in MJCF_TOP_DROPPED.items():
        for section in root.findall(tag):
            if len(section) or tag in ("statistic", "size"):
                dropped.append(f"<{tag}> ({', '.join(sorted({e.tag for e in section})) or 'settings'}): {what}")
    if any(key in option.attrib for option in root.findall("option") for key in ("timestep", "integrator")):
        dropped.append("<option> timestep/integrator: dropped (mbd run chooses its own; see --integrator)")


MJCF_DROPPED = {
    "range/limited": "dropped (the joints move without limits)",
    "armature": "dropped (no rotor inertia added to the joints)",
    "frictionloss": "dropped (no joint friction)",
    "damping/stiffness of joints other than hinges": "dropped (springs about a hinge only)",
    "<geom>": "contacts dropped (a body without <inertial> keeps the mass of its geoms, as MuJoCo computes it)",
}
"""Joint attributes and body elements that the model cannot hold, and what that means."""


def _mjcf_body(element, parent: Link, mjcf: Mjcf, childclass: str, taken: tuple[set, set], kinds: dict) -> Link:
    """A body placed in its parent (r = r_p + A_p pos, A = A_p A_rel), its inertial, its sites and its joints
    (``_combined``; none: welded to the parent; a free joint: no joint of the model)."""
    label = mjcf.label
    childclass = element.get("childclass", childclass)
    name = _name(element.get("name"), f"body{len(taken[0])}", taken[0])
    where = f"body '{name}'"
    for tag in ("composite", "flexcomp", "plugin"):
        if element.find(tag) is not None:
            raise ModelError(f"{label}: {where} <{tag}>: not a rigid body; import reads rigid bodies only")
    if element.get("mocap") == "true":
        raise ModelError(f'{label}: {where} mocap="true": a body moved by the user; remove mocap to import it')
    s = _numbers(element, "pos", label, 3, [0, 0, 0])
    link = Link(name, parent.R @ mjcf.rotation(element), parent.r + parent.R @ s, parent=parent.name)
    inertial, geoms = element.find("inertial"), element.findall("geom")
    if mjcf.fromgeom == "true" or (mjcf.fromgeom == "auto" and inertial is None):
        if geoms:
            link.mass, link.com, link.inertia = _geom_inertia(geoms, mjcf, childclass, where)
            link.has_inertial = True
    elif inertial is not None:
        link.mass = float(_numbers(inertial, "mass", label, 1)[0])
        if "fullinertia" in inertial.attrib:
            xx, yy, zz, xy, xz, yz = _numbers(inertial, "fullinertia", label, 6)
            J = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        else:
            J = np.diag(_numbers(inertial, "diaginertia", label, 3))
        A = mjcf.rotation(inertial)
        link.com, link.inertia, link.has_inertial = _numbers(inertial, "pos", label, 3), A @ J @ A.T, True
    if geoms:
        kinds.setdefault("<geom>", []).append(name)
    for site in element.findall("site"):
        point = _numbers(site, "pos", label, 3, [0, 0, 0])
        link.sites[site.get("name") or f"site{len(link.sites)}"] = (point, mjcf.rotation(site))
    joints = [(j, mjcf.attrs(j, childclass)) for j in element.findall("joint")]
    joints += [(j, {"type": "free", **j.attrib}) for j in element.findall("freejoint")]
    if not joints:
        link.joint = {"name": f"{name}_weld", "type": "fixed", "parts": []}
        return link
    parts = []
    for joint, attrs in joints:
        kind = attrs.get("type", "hinge")
        if kind not in MJCF_JOINTS:
            raise ModelError(f"{label}: {where} <joint type={kind!r}>: unknown; MuJoCo's are {', '.join(MJCF_JOINTS)}")
        jname = _name(attrs.get("name"), f"{name}_joint", taken[1])
        axis = _unit(_numbers(joint, "axis", label, 3, [0, 0, 1], attrs=attrs), label, f"joint '{jname}' axis")
        ref = float(_numbers(joint, "ref", label, 1, [0.0], attrs=attrs)[0]) * (mjcf.angle if kind == "hinge" else 1.0)
        anchor = _numbers(joint, "pos", label, 3, [0, 0, 0], attrs=attrs)
        parts.append({"kind": MJCF_JOINTS[kind], "name": jname, "anchor": anchor, "axis": axis, "ref": ref})
        _mjcf_joint_extras(joint, attrs, link, mjcf, kinds, parts[-1])
    link.joint = _combined(parts, link, label, where, taken[1])
    if link.springs and link.joint["type"] not in ("revolute", "cylindrical"):
        kinds.setdefault("damping/stiffness of joints other than hinges", []).append(link.joint["name"])
        link.springs = []
    return link


GEOM_SHAPES = ("sphere", "capsule", "cylinder", "box", "ellipsoid")
"""The geoms whose mass and inertia import computes (MuJoCo's primitive solids)."""


def _geom_inertia(geoms: list, mjcf: Mjcf, childclass: str, where: str) -> tuple[float, np.ndarray, np.ndarray]:
    """A body's mass, centre of mass and inertia tensor (body frame) from its geoms, as MuJoCo's compiler takes them
    when the body has no <inertial>: each a solid of density 1000 kg/m^3 (or its ``density``, or its ``mass``),
    combined by the parallel axis theorem (``_merge``). Planes and height fields have none; meshes are refused."""
    total = Link("geoms", np.eye(3), np.zeros(3))
    for geom in geoms:
        attrs = mjcf.attrs(geom, childclass)
        kind = attrs.get("type", "sphere")
        if kind in ("plane", "hfield"):
            continue
        if kind not in GEOM_SHAPES:
            raise ModelError(
                f"{mjcf.label}: {where} <geom type={kind!r}>: import computes the mass of {', '.join(GEOM_SHAPES)} "
                "only; give the body an <inertial>"
            )
        solid = _solid(geom, attrs, kind, mjcf, where)
        _merge(total, solid)
    return total.mass, total.com, total.inertia


def _solid(geom, attrs: dict, kind: str, mjcf: Mjcf, where: str) -> Link:
    """One geom as a solid in the body frame: its pose (pos and orientation, or ``fromto``: the midpoint, z along
    the segment, half length |to - from| / 2), volume V and principal moments per unit mass, e.g. a capsule's
    cylinder and two hemispheres: J_z = m_c r^2/2 + 2 m_s r^2/5, J_x = m_c (3 r^2 + 4 h^2)/12 + m_s (2 r^2/5 + h^2 +
    3 h r/4)."""
    label = mjcf.label
    size = [float(v) for v in attrs.get("size", "").split()]
    if "fromto" in attrs:
        ends = _numbers(geom, "fromto", label, 6, attrs=attrs)
        axis = ends[3:] - ends[:3]
        R = z_rotation(_unit(axis, label, f"{where} <geom> fromto"))
        pos, half = 0.5 * (ends[:3] + ends[3:]), 0.5 * float(np.linalg.norm(axis))
        size = size[:2] + [half] if kind in ("box", "ellipsoid") else size[:1] + [half]
    else:
        pos, R = _numbers(geom, "pos", label, 3, [0, 0, 0], attrs=attrs), mjcf.rotation(geom, attrs)
    needed = {"sphere": 1, "capsule": 2, "cylinder": 2, "box": 3, "ellipsoid": 3}[kind]
    if len(size) < needed:
        raise ModelError(f"{label}: {where} <geom type={kind!r}> size: give {needed} number(s) (or fromto)")
    r = size[0]
    if kind == "sphere":
        volume, moments = 4.0 / 3.0 * math.pi * r**3, np.full(3, 0.4 * r**2)
    elif kind == "ellipsoid" or kind == "box":
        a, b, c = size[:3]
        volume = (4.0 / 3.0 * math.pi if kind == "ellipsoid" else 8.0) * a * b * c
        moments = np.array([b * b + c * c, a * a + c * c, a * a + b * b]) / (5.0 if kind == "ellipsoid" else 3.0)
    elif kind == "cylinder":
        h = size[1]
        volume, moments = 2.0 * math.pi * r * r * h, np.array([(3 * r * r + 4 * h * h) / 12] * 2 + [r * r / 2])
    else:
        h = size[1]
        cylinder, sphere = 2.0 * math.pi * r * r * h, 4.0 / 3.0 * math.pi * r**3
        volume = cylinder + sphere
        c, s = cylinder / volume, sphere / volume  # the mass fractions
        transverse = c * (3 * r * r + 4 * h * h) / 12 + s * (0.4 * r * r + h * h + 0.75 * h * r)
        moments = np.array([transverse, transverse, c * r * r / 2 + s * 0.4 * r * r])
    if "mass" in attrs:
        mass = float(_numbers(geom, "mass", label, 1, attrs=attrs)[0])
    else:
        mass = float(_numbers(geom, "density", label, 1, [1000.0], attrs=attrs)[0]) * volume
    solid = Link("geom", np.eye(3), np.zeros(3), mass=mass, com=pos, has_inertial=True)
    solid.inertia = R @ np.diag(mass * moments) @ R.T
    return solid


def _combined(parts: list[dict], link: Link, label: str, where: str, taken: set) -> dict:
    """The model's joint of a body's MuJoCo joints: one joint as it is; a hinge and a slide along one line, a
    cylindrical joint; two hinges through one point with normal axes (the first fixed in the parent, the second
    in the body, as MuJoCo turns a body by its joints in turn), a universal joint. Global location and axes."""
    first = parts[0]
    joint = {"name": first["name"], "type": first["kind"], "parts": parts,
             "location": link.r + link.R @ first["anchor"], "axis": link.R @ first["axis"]}  # fmt: skip
    if len(parts) == 1:
        return joint
    kinds = sorted(p["kind"] for p in parts)
    second = parts[1]
    along = np.cross(second["anchor"] - first["anchor"], first["axis"])
    if (
        kinds == ["prismatic", "revolute"]
        and np.linalg.norm(np.cross(first["axis"], second["axis"])) < 1e-9
        and (np.linalg.norm(along) < 1e-9)
    ):
        joint["type"] = "cylindrical"
    elif (
        kinds == ["revolute", "revolute"]
        and abs(first["axis"] @ second["axis"]) < 1e-9
        and (np.linalg.norm(second["anchor"] - first["anchor"]) < 1e-12)
    ):
        joint["type"], joint["axis2"] = "universal", link.R @ second["axis"]
    else:
        raise ModelError(
            f"{label}: {where}: joints {_list([p['name'] for p in parts])} in one body; one body takes one joint here, "
            "or a hinge and a slide along one line (cylindrical), or two hinges with normal axes through one point "
            "(universal): nest a light body per joint"
        )
    common = re.sub(r"[._\-]+$", "", _common_prefix([p["name"] for p in parts]))
    if common:  # the exporter's 'B.hinge1', 'B.hinge2' are the model's joint 'B'
        joint["name"] = _name(common, "joint", taken)
    return joint


def _common_prefix(names: list[str]) -> str:
    prefix = names[0]
    for name in names[1:]:
        while not name.startswith(prefix):
            prefix = prefix[:-1]
    return prefix


def _mjcf_joint_extras(joint, attrs: dict, link: Link, mjcf: Mjcf, kinds: dict, part: dict) -> None:
    """A hinge's damping and stiffness as a rotational spring-damper (RSDA, eq. 10.13) about it: MuJoCo's torque
    -k (q - springref) - c q', with q = ref in the file's pose, is the RSDA's with free angle springref - ref."""
    label, name, kind = mjcf.label, part["name"], part["kind"]
    value = {key: float(_numbers(joint, key, label, 1, [0.0], attrs=attrs)[0])
             for key in ("damping", "stiffness", "springref", "armature", "frictionloss")}  # fmt: skip
    if kind == "revolute" and (value["damping"] or value["stiffness"]):
        spring = {"damping_coefficient": value["damping"], "spring_coefficient": value["stiffness"]}
        free = value["springref"] * mjcf.angle - part["ref"]
        if value["stiffness"] and free:
            spring["free_angle"] = free
        link.springs.append(spring)
    elif value["damping"] or value["stiffness"]:
        kinds.setdefault("damping/stiffness of joints other than hinges", []).append(name)
    for key in ("armature", "frictionloss"):
        if value[key]:
            kinds.setdefault(key, []).append(name)
    if "range" in attrs and attrs.get("limited", "auto") != "false":
        kinds.setdefault("range/limited", []).append(name)


QPOS = {"revolute": (1, 1), "prismatic": (1, 1), "spherical": (4, 3), "free": (7, 6)}
"""The numbers each of MuJoCo's joints takes in qpos and qvel."""


def _mjcf_keyframe(root: ET.Element, order: list[Link], mjcf: Mjcf, dropped: list[str]) -> None:
    """Start from the ``<key name="initial">`` (what ``mbd export`` writes) when the file has one; MuJoCo itself
    starts from qpos0 and takes a key only when asked, so other keys are dropped, said by name.

    qpos and qvel list the joints in the order of the bodies in the file (depth first, as ``order``): a hinge's
    angle and a slide's position (their file pose at ``ref``), a ball's quaternion and its angular velocity in the
    body's frame, a free joint's position and quaternion of the body frame and its linear (global) and angular
    (body frame) velocity. Each body is placed by its joints from its parent (``_move``).
    """
    keys = [key for section in root.findall("keyframe") for key in section.findall("key")]
    chosen = next((key for key in keys if key.get("name") == "initial"), None)
    others = [key.get("name") or f"#{k + 1}" for k, key in enumerate(keys) if key is not chosen]
    if others:
        dropped.append(f"<keyframe> key(s) {_list(others)}: dropped (the model starts at qpos0, or at key 'initial')")
    if chosen is None:
        return
    parts = [part for link in order for part in link.joint["parts"]]
    n_pos, n_vel = (sum(QPOS[p["kind"]][k] for p in parts) for k in (0, 1))
    qpos = _numbers(chosen, "qpos", mjcf.label, n_pos, _qpos0(order))
    qvel = _numbers(chosen, "qvel", mjcf.label, n_vel, np.zeros(n_vel))
    moved = {GROUND: Link(GROUND, np.eye(3), np.zeros(3))}
    before = {GROUND: moved[GROUND]}
    i = j = 0
    for link in order:
        before[link.name] = Link(link.name, link.R.copy(), link.r.copy())
        sizes = [QPOS[p["kind"]] for p in link.joint["parts"]]
        di, dj = sum(n for n, _ in sizes), sum(n for _, n in sizes)
        _move(link, before[link.parent], moved[link.parent], qpos[i : i + di], qvel[j : j + dj])
        moved[link.name] = link
        i, j = i + di, j + dj


def _qpos0(order: list[Link]) -> list[float]:
    """MuJoCo's qpos0: hinges and slides at ref, balls at the unit quaternion, free bodies where the file puts them."""
    out: list[float] = []
    for link in order:
        for part in link.joint["parts"]:
            if part["kind"] in ("revolute", "prismatic"):
                out.append(part["ref"])
            elif part["kind"] == "spherical":
                out += [1.0, 0.0, 0.0, 0.0]
            else:
                out += [*link.r, *euler_parameters(link.R)]
    return out


def _move(link: Link, parent0: Link, parent: Link, qpos: np.ndarray, qvel: np.ndarray) -> None:
    """Place ``link`` by its joint values from its parent (``parent0``: the parent in the file's pose), as MuJoCo's
    kinematics does, joint after joint: from the file's relative pose, a slide shifts the frame by u (q - ref), a
    hinge turns it by q - ref about u through the joint's anchor, a ball by its quaternion, each axis and anchor
    taken in the frame as the joints before left it; a free joint gives the pose itself. The velocity composes
    the parent's, v = v_p + w_p x (r - r_p), w = w_p, with each joint's own: a slide's u q', a hinge's or ball's
    w_j x (r - anchor) and w_j. The model's joint location and axes move with the body."""
    A0, s0 = parent0.R.T @ link.R, parent0.R.T @ (link.r - parent0.r)  # the file's pose in the parent's frame
    R, r = parent.R @ A0, parent.r + parent.R @ s0
    twists = []  # (w_j, v_j, point of w_j's axis) of each joint, global
    i = j = 0
    for part in link.joint["parts"]:
        kind, a, u = part["kind"], part["anchor"], part["axis"]
        n_pos, n_vel = QPOS[kind]
        q, qd = qpos[i : i + n_pos], qvel[j : j + n_vel]
        anchor, axis = r + R @ a, R @ u
        if kind == "prismatic":
            r = r + axis * (q[0] - part["ref"])
            twists.append((np.zeros(3), axis * qd[0], anchor))
        elif kind == "free":
            R, r = euler_rotation(q[3:] / np.linalg.norm(q[3:])), q[:3].copy()
            twists.append((R @ qd[3:], qd[:3] - np.cross(R @ qd[3:], r), np.zeros(3)))
        else:
            turn = rodrigues(u, q[0] - part["ref"]) if kind == "revolute" else euler_rotation(q / np.linalg.norm(q))
            R = R @ turn
            r = anchor - R @ a
            twists.append((axis * qd[0] if kind == "revolute" else R @ qd, np.zeros(3), anchor))
        part["global"] = (anchor, axis)
        i, j = i + n_pos, j + n_vel
    link.R, link.r = R, r
    link.angular_velocity = parent.angular_velocity.copy()
    link.velocity = parent.velocity + np.cross(parent.angular_velocity, r - parent.r)
    for w, v, point in twists:
        link.angular_velocity = link.angular_velocity + w
        link.velocity = link.velocity + v + np.cross(w, r - point)
    if link.joint["parts"]:
        first = link.joint["parts"][0]["global"]
        link.joint["location"], link.joint["axis"] = first
        if "axis2" in link.joint:
            link.joint["axis2"] = link.joint["parts"][1]["global"][1]


def _site_points(links: list[Link]) -> dict[str, tuple[str, np.ndarray, np.ndarray]]:
    """{site: (its body, its global position, its global axes)} in the links' present pose."""
    return {site: (link.name, link.r + link.R @ point, link.R @ axes)
            for link in links for site, (point, axes) in link.sites.items()}  # fmt: skip


def _mjcf_tendons(root, links: list[Link], rest: dict, mjcf: Mjcf, dropped: list[str]) -> list[dict]:
    """A spatial tendon through two sites, with stiffness or damping, is a TSDA (eq. 10.12) between their bodies:
    MuJoCo's force -k (l - l0) - c l' along it, l0 its ``springlength`` or, when not given, its length at qpos0.
    Other tendons (more sites, wrapping, fixed tendons, none with a spring) are dropped by name."""
    points = _site_points(links)
    out, other = [], []
    for section in root.findall("tendon"):
        for k, tendon in enumerate(section):
            name = tendon.get("name") or f"tendon{k + 1}"
            sites = [s.get("site") for s in tendon]
            stiffness = float(_numbers(tendon, "stiffness", mjcf.label, 1, [0.0])[0])
            damping = float(_numbers(tendon, "damping", mjcf.label, 1, [0.0])[0])
            if tendon.tag != "spatial" or len(sites) != 2 or None in sites or not (stiffness or damping):
                other.append(name)
                continue
            for site in sites:
                if site not in points:
                    raise ModelError(f"{mjcf.label}: <tendon><spatial name={name!r}>: no site named {site!r}")
            lengths = [float(v) for v in tendon.get("springlength", "-1").split()]
            if len(lengths) == 2 and lengths[0] != lengths[1]:
                other.append(name)  # a dead band: no counterpart
                continue
            (body1, p1, _), (body2, p2, _) = (points[site] for site in sites)
            free = lengths[0] if lengths[0] >= 0 else float(np.linalg.norm(rest[sites[1]][1] - rest[sites[0]][1]))
            ends = {"body1": body1, "body2": body2, "point1": p1, "point2": p2}
            coefficients = {"spring_coefficient": stiffness, "damping_coefficient": damping, "free_length": free}
            out.append({"name": name, "type": "TSDA", **ends, **coefficients})
    if other:
        dropped.append(f"<tendon> {_list(other)}: dropped (a spring-damper is a spatial tendon through two sites)")
    return out


def _mjcf_actuators(root, links: list[Link], mjcf: Mjcf, dropped: list[str]) -> list[dict]:
    """Actuators with their control at 0, as MuJoCo leaves it without a controller: force = gain 0 + bias. A
    ``<general>`` on a site with an affine bias (b0, 0, 0) is a constant wrench b0 gear (force, torque in the site's
    frame), so a force and a torque fixed in its body; an actuator without bias exerts nothing and is dropped as
    such; any other (position and velocity servos, muscles, ...) is dropped by name: it would pull."""
    points = _site_points(links)
    loads, idle, other = [], [], []
    for section in root.findall("actuator"):
        for k, actuator in enumerate(section):
            name = actuator.get("name") or f"actuator{k + 1}"
            bias = actuator.get("biastype", "none")
            if actuator.tag == "motor" or (actuator.tag == "general" and bias == "none"):
                idle.append(name)
                continue
            prm = [float(v) for v in actuator.get("biasprm", "0 0 0").split()] + [0.0] * 3
            site = actuator.get("site")
            if actuator.tag != "general" or bias != "affine" or any(prm[1:3]) or site not in points:
                other.append(name)
                continue
            gear = np.zeros(6)
            values = [float(v) for v in actuator.get("gear", "1").split()]
            gear[: len(values)] = values
            body, point, axes = points[site]
            force, torque = axes @ gear[:3] * prm[0], axes @ gear[3:] * prm[0]
            loads.append({"name": name, "body": body, "point": point, "force": force, "torque": torque})
    if idle:
        dropped.append(f"<actuator> {_list(idle)}: dropped (no force while the control stays 0, as here)")
    if other:
        dropped.append(f"<actuator> {_list(other)}: dropped (no inputs here; a servo's pull towards 0 is gone too)")
    return loads


def _mjcf_loops(root: ET.Element, placed: dict[str, Link], mjcf: Mjcf, dropped: list[str], taken: set) -> list[dict]:
    """``<equality connect>`` as a spherical joint at the anchor (body1's frame; MuJoCo finds body2's point at qpos0,
    so the two coincide in the file's pose) and ``<equality weld>`` as a rigid joint (the qpos0 relative pose)."""
    label, loops, soft = mjcf.label, [], False
    for section in root.findall("equality"):
        for k, element in enumerate(section):
            where = f"<equality><{element.tag}{_named(element)}>"
            if element.get("active", "true") == "false":
                dropped.append(f"{where}: inactive, dropped")
                continue
            if element.tag not in ("connect", "weld"):
                raise ModelError(
                    f"{label}: {where}: an equality between joint or tendon values has no counterpart here; "
                    "import holds connect (a spherical joint) and weld (a rigid joint)"
                )
            soft = soft or "solref" in element.attrib or "solimp" in element.attrib
            if "site1" in element.attrib:
                raise ModelError(f"{label}: {where} site1: write the constraint with body1, body2 and anchor")
            bodies = []
            for key in ("body1", "body2"):
                body = element.get(key, "world")
                if body not in placed:
                    raise ModelError(f"{label}: {where} {key}={body!r}: no body of that name")
                bodies.append(placed[body])
            if element.tag == "weld" and ("relpose" in element.attrib or "anchor" in element.attrib):
                raise ModelError(f"{label}: {where}: a weld with relpose or anchor; remove it (the file's pose holds)")
            anchor = _numbers(element, "anchor", label, 3, [0, 0, 0])
            first = bodies[0]
            loops.append({
                "name": _name(element.get("name"), f"{element.tag}{k + 1}", taken),
                "type": "spherical" if element.tag == "connect" else "fixed",
                "bodies": (first.name, bodies[1].name),
                "location": first.r + first.R @ anchor,
            })  # fmt: skip
    if soft:
        dropped.append("<equality> solref/solimp: dropped (the loop constraints hold exactly here)")
    return loops


# -- the model file ----------------------------------------------------------------------------------------------
def _merge(target: Link, link: Link) -> None:
    """Merge ``link`` into ``target`` as one rigid body: m = m1 + m2, c = (m1 c1 + m2 c2) / m, and each tensor
    moved to c by the parallel axis theorem, J = sum (A_k J_k A_k^T + m_k (|d_k|^2 I - d_k d_k^T)), in the
    target frame's axes."""
    mass = target.mass + link.mass
    if mass <= 0.0:
        target.has_inertial = target.has_inertial or link.has_inertial
        return
    c1, c2 = target.r + target.R @ target.com, link.r + link.R @ link.com
    c = (target.mass * c1 + link.mass * c2) / mass
    J = np.zeros((3, 3))
    for m, centre, R, J_k in ((target.mass, c1, target.R, target.inertia), (link.mass, c2, link.R, link.inertia)):
        d = centre - c
        J += R @ J_k @ R.T + m * (d @ d * np.eye(3) - np.outer(d, d))
    target.mass, target.com, target.inertia = mass, target.R.T @ (c - target.r), target.R.T @ J @ target.R
    target.has_inertial = True


def _clean(values) -> list:
    """Numbers for the file: rounding noise of the frame products (below 1e-14) written as 0."""
    array = np.asarray(values, dtype=float)
    array = np.where(np.abs(array) < 1e-14, 0.0, array)
    return array.tolist()


def _model_data(
    name: str, links: list[Link], gravity, loops: list[dict], label: str, dropped: list[str], tsdas=(), loads=()
) -> dict:
    """The model file's content: fixed joints merged, a body per remaining link, its joint, the loops' joints."""
    owner = {GROUND: GROUND}
    bodies: dict[str, Link] = {}
    merged = []
    for link in links:  # parents come before their children
        if link.joint["type"] == "fixed":
            owner[link.name] = owner[link.parent]
            if owner[link.name] != GROUND:
                _merge(bodies[owner[link.name]], link)
            elif link.mass:
                dropped.append(f"mass of '{link.name}': it is fixed to the ground, so it is part of the ground")
            merged.append(f"'{link.name}' into '{owner[link.name]}'")
        else:
            owner[link.name] = link.name
            bodies[link.name] = link
    if merged:
        dropped.append(f"fixed joints: {', '.join(merged)} merged (one rigid body each; their names are gone)")
    if not bodies:
        raise ModelError(f"{label}: no body moves (every joint is fixed); import needs a moving body")
    with_mass = [b.name for b in bodies.values() if b.mass > 0.0]
    if with_mass and len(with_mass) != len(bodies):
        missing = next(b.name for b in bodies.values() if b.mass <= 0.0)
        raise ModelError(
            f"{label}: body '{missing}': no mass (no inertial, or mass 0), yet it moves; give it an inertial with a "
            "mass > 0 (every moving body needs one for a dynamic analysis)"
        )
    if not with_mass:
        dropped.append("mass: no body has any, so the model is kinematic only (mbd run --analysis kinematic)")
    model = {"name": _name(name, "imported", set()), "dimension": 3, "gravity": _clean(gravity), "bodies": []}
    joints, springs = [], []
    for body in bodies.values():
        model["bodies"].append(_body_data(body, bool(with_mass)))
        joint = body.joint
        if joint["type"] == "free":
            continue
        item = {"name": joint["name"], "type": joint["type"], "body1": owner[body.parent], "body2": body.name,
                "location": _clean(joint["location"])}  # fmt: skip
        if joint["type"] in ("revolute", "prismatic", "cylindrical", "universal"):
            item["axis"] = _clean(joint["axis"])
        if joint["type"] == "universal":
            item["axis2"] = _clean(joint["axis2"])
        joints.append(item)
        for k, spring in enumerate(body.springs):
            springs.append({"name": f"{joint['name']}_spring{k + 1 if k else ''}", "type": "RSDA",
                            "body1": item["body1"], "body2": body.name, "joint": joint["name"], **spring})  # fmt: skip
    for loop in loops:
        body1, body2 = (owner[b] for b in loop["bodies"])
        if body1 == body2:
            raise ModelError(f"{label}: <equality> '{loop['name']}': joins one rigid body to itself; remove it")
        joints.append({"name": loop["name"], "type": "rigid" if loop["type"] == "fixed" else loop["type"],
                       "body1": body1, "body2": body2, "location": _clean(loop["location"])})  # fmt: skip
    for tsda in tsdas:
        body1, body2 = owner[tsda["body1"]], owner[tsda["body2"]]
        if body1 == body2:
            dropped.append(f"<tendon> '{tsda['name']}': both ends on one rigid body, dropped")
            continue
        point1, point2 = _clean(tsda["point1"]), _clean(tsda["point2"])
        springs.append({**tsda, "body1": body1, "body2": body2, "point1": point1, "point2": point2})
    forces = []
    for load in loads:
        body = bodies.get(owner[load["body"]])
        if body is None:
            continue  # on the ground
        for kind in ("force", "torque"):
            if np.any(load[kind]):
                item = {"name": f"{load['name']}_{kind}" if np.any(load["force"]) and np.any(load["torque"])
                        else load["name"], "type": kind, "body": body.name, "frame": "body",
                        "value": _clean(body.R.T @ load[kind])}  # fmt: skip
                if kind == "force":
                    item["point"] = _clean(body.R.T @ (load["point"] - body.r))
                forces.append(item)
    if joints:
        model["joints"] = joints
    if springs:
        model["spring_dampers"] = springs
    if forces:
        model["forces"] = forces
    return {"model": model}


def _body_data(link: Link, with_mass: bool) -> dict:
    """A body of the file: the link frame as location and orientation, the centre of mass as com (left out when it
    is the frame's origin), the tensor about it in the frame's axes (three moments when they are principal)."""
    body: dict = {"name": link.name}
    if with_mass:
        J = 0.5 * (link.inertia + link.inertia.T)  # symmetric also after the products of rotations
        J = np.where(np.abs(J) < 1e-14 * max(1.0, float(np.max(np.abs(J)))), 0.0, J)
        body["mass"] = float(link.mass)
        body["inertia"] = _clean(np.diag(J)) if not np.any(J - np.diag(np.diag(J))) else _clean(J)
    body["location"] = _clean(link.r)
    if np.max(np.abs(link.R - np.eye(3))) > 1e-15:
        body["orientation"] = {"rotation_matrix": _clean(link.R)}
    if with_mass and np.any(np.abs(link.com) > 1e-15):
        body["com"] = _clean(link.com)
    if np.any(link.velocity):
        body["velocity"] = _clean(link.velocity)
    if np.any(link.angular_velocity):
        body["angular_velocity"] = _clean(link.angular_velocity)
    return body


def model_text(imported: Imported, source: str) -> str:
    """The model file as YAML: a header naming the source and what was dropped, then the content."""
    import yaml

    lines = [f"# Imported from {source} by mbd import (solutions/io/importers.py); what it left out:"]
    lines += [f"#   {line}" for line in imported.dropped]
    body = yaml.safe_dump(imported.data, sort_keys=False, default_flow_style=None, width=120)
    return "\n".join(lines) + "\n" + body
