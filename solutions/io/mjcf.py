"""MuJoCo's model format (MJCF) from a model file: ``mbd export MODEL --to mjcf``.

What is written, element by element of MJCF (https://mujoco.readthedocs.io/en/stable/XMLreference.html):

- ``<body>`` per body, its frame at the centre of mass (``pos``, ``quat`` in the parent's frame) in the
  configuration the project's assembly makes consistent, with ``<inertial pos="0 0 0" mass diaginertia|fullinertia>``
  (a planar body's polar moment J as ``diaginertia="J J J"``: only J about z matters in the plane);
- the joints of a spanning tree (``tree.spanning_tree``) as ``<joint type="hinge|slide|ball">``: revolute a hinge,
  prismatic a slide, spherical a ball, cylindrical a slide and a hinge, universal two hinges (the parent's arm
  first), a planar revolute-prismatic (pin in slot) a slide and a hinge, rigid none; a body no joint of the tree
  reaches from ground floats: a ``free`` joint (planar: slides along x and y and a hinge about z);
- the joints that close loops as ``<equality>``: revolute and spherical ``connect`` (a spatial revolute two
  connects one unit apart on its axis), rigid ``weld``, a planar revolute-revolute (distance) ``tendon`` of
  constant length; each with ``solref`` and ``solimp`` (``Stiffness``: by default a time constant of two steps and
  an impedance of 0.9999, the stiffest MuJoCo integrates stably);
- ``<option gravity timestep integrator="RK4">`` (planar gravity (gx, gy, 0));
- TSDA spring-dampers as ``<tendon><spatial stiffness damping springlength>`` between two ``<site>``s;
  RSDA springs about a joint of the tree as that joint's ``stiffness``, ``damping`` and ``springref``;
- constant loads as ``<actuator><general>`` on a ``site`` with ``biastype="affine"`` (a force that needs no
  control input), global loads measured in a world site (``refsite``);
- ``<keyframe><key name="initial" qpos qvel>``: the state ``mbd run`` starts from (load it with
  ``mujoco.mj_resetDataKeyframe``).

Motors. MJCF has no constraint that is a function of time, and a position servo (``<position kp>``) follows its
target only approximately. What is exact here: a motor whose function is a polynomial of degree 4 or less, or
harmonic, drives its joint by an ``<equality joint polycoef>``, a polynomial in a *clock* joint. The clock is a
slide joint of its own with an armature of ``CLOCK_INERTIA`` (no joint force moves it measurably) started at unit
speed, so its coordinate is t; a harmonic motor's clock is an undamped oscillator (``stiffness`` = inertia omega^2)
started on sin(omega t + phase). The driven joint then follows f(t) - f(0) as closely as any loop closure
follows its equality (the same solref and solimp). Angle and linear motors drive a joint of the tree; a planar
coordinate motor drives a floating body's slide or hinge; a distance motor is an ``<equality tendon>`` between a
spatial tendon through its two points and a ``<fixed>`` tendon of its clock. Refused by name (``ExportError``,
exit 2): gears, racks and cams (no MJCF element holds a rolling or cam contact), loops closed by a joint MJCF
has no equality for (prismatic, cylindrical, universal, pin-in-slot), motors of other functions or on cut joints,
actuator functions of spring-dampers, loads that vary in time, RSDAs about no joint of the tree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from xml.sax.saxutils import quoteattr

import numpy as np

from ..functions import Constant, Harmonic, Polynomial, function_from_spec
from ..rotation_matrices import quaternion_product_entries
from .model import Model
from .tree import CUT_ONLY, EITHER, Mechanism, TreeEdge, mechanism, refuse

CLOCK_INERTIA = 1e12
"""Armature of a clock joint (kg or kg m^2): a joint force of 1e3 N moves it by 1e-9 s^2 (a clock error of 1e-9 s
after a second)."""
REFUSED_JOINTS = {
    "gear": "MJCF has no rolling contact of two pitch circles",
    "rack_pinion": "MJCF has no rolling contact of a pinion on a rack",
    "cam": "MJCF has no cam-follower contact (only collisions of geometric primitives)",
}


@dataclass(frozen=True)
class Stiffness:
    """The integration step and the softness of every equality (MJCF ``solref`` = (time constant, damping ratio),
    ``solimp`` = (dmin, dmax, width)); ``time_constant`` None is two steps."""

    timestep: float = 1e-4
    time_constant: float | None = None
    damping_ratio: float = 1.0
    solimp: tuple = (0.9999, 0.9999, 0.001)

    @property
    def solref(self) -> str:
        return _v([self.time_constant or 2.0 * self.timestep, self.damping_ratio])


def _v(x) -> str:
    """Numbers as MJCF's space-separated text, exact to the last bit (17 significant digits)."""
    return " ".join(f"{float(c):.17g}" for c in np.ravel(x))


def _attrs(**attributes) -> str:
    return " ".join(f"{k}={quoteattr(str(v))}" for k, v in attributes.items() if v is not None)


def _element(tag: str, **attributes) -> str:
    return f"<{tag} {_attrs(**attributes)}/>"


def spatial_tendon(site1: str, site2: str, **attributes) -> str:
    """A ``<spatial>`` tendon: the straight line between two sites (its length is their distance)."""
    return f"<spatial {_attrs(**attributes)}>{_element('site', site=site1)}{_element('site', site=site2)}</spatial>"


# -- bodies -----------------------------------------------------------------------------------------------------
def inertial(model: Model, body) -> str:
    """``<inertial>`` at the centre of mass: a planar polar moment J as (J, J, J); a spatial inertia as its principal
    moments (``diaginertia``) or, with products, ``fullinertia`` (Ixx Iyy Izz Ixy Ixz Iyz) in the body frame."""
    if model.dimension == 2:
        return _element("inertial", pos="0 0 0", mass=_v(body.mass), diaginertia=_v([body.inertia] * 3))
    J = np.asarray(body.inertia, dtype=float)
    if np.any(J - np.diag(np.diag(J))):
        full = [J[0, 0], J[1, 1], J[2, 2], J[0, 1], J[0, 2], J[1, 2]]
        return _element("inertial", pos="0 0 0", mass=_v(body.mass), fullinertia=_v(full))
    return _element("inertial", pos="0 0 0", mass=_v(body.mass), diaginertia=_v(np.diag(J)))


def relative_pose(mech: Mechanism, parent: int, child: int) -> tuple[np.ndarray, np.ndarray]:
    """The child's frame in the parent's: pos = A_P^T (r_C - r_P) and the Euler parameters of A_P^T A_C, the
    quaternion product quat = p_P^* p_C."""
    P, C = mech.frame(parent), mech.frame(child)
    conjugate = P.p * np.array([1.0, -1.0, -1.0, -1.0])
    return P.A.T @ (C.r - P.r), np.array(quaternion_product_entries(*conjugate, *C.p))


@dataclass
class MjcfJoint:
    """One ``<joint>`` of MJCF with where it starts in qpos (its reference value) and its motion at the assembled
    state (world frame): ``twist`` (nv columns of angular and linear velocity of the child's origin)."""

    name: str
    kind: str  # hinge, slide, ball, free
    pos: np.ndarray
    axis: np.ndarray
    twist: np.ndarray  # (6, nv)
    qpos0: tuple = (0.0,)
    extra: dict | None = None

    def xml(self) -> str:
        if self.kind == "free":
            return _element("freejoint", name=self.name)
        axis = None if self.kind == "ball" else _v(self.axis)
        return _element("joint", name=self.name, type=self.kind, pos=_v(self.pos), axis=axis, **(self.extra or {}))


def _hinge(name, mech, child, point_local, axis_local) -> MjcfJoint:
    """A hinge of the child about ``axis_local`` through ``point_local`` (child frame): omega = a, v = a x (r - x)."""
    C = mech.frame(child)
    a, x = C.A @ axis_local, C.r + C.A @ point_local
    return MjcfJoint(name, "hinge", point_local, axis_local, np.concatenate([a, np.cross(a, C.r - x)])[:, None])


def _slide(name, mech, child, point_local, axis_local) -> MjcfJoint:
    a = mech.frame(child).A @ axis_local
    return MjcfJoint(name, "slide", point_local, axis_local, np.concatenate([np.zeros(3), a])[:, None])


def _ball(name, mech, child, point_local) -> MjcfJoint:
    """A ball: its qvel is the child's angular velocity relative to the parent in the child's frame."""
    C = mech.frame(child)
    x = C.r + C.A @ point_local
    columns = [np.concatenate([C.A[:, k], np.cross(C.A[:, k], C.r - x)]) for k in range(3)]
    return MjcfJoint(name, "ball", point_local, np.zeros(3), np.column_stack(columns), qpos0=(1.0, 0.0, 0.0, 0.0))


def tree_joints(mech: Mechanism, edge: TreeEdge) -> list[MjcfJoint]:
    """The MJCF joints of one joint of the tree, in the child's frame (see the module's list)."""
    joint, child = edge.joint, edge.child
    kind, name, C, P = joint.kind, joint.name, mech.frame(child), mech.frame(edge.parent)
    point = joint.point1 if edge.reverse else joint.point2
    axis = joint.axis1 if edge.reverse else joint.axis2  # the joint's axis (a universal joint: the child's arm)
    parent_arm = C.A.T @ P.A @ (joint.axis2 if edge.reverse else joint.axis1)
    if kind == "revolute":
        return [_hinge(name, mech, child, point, axis)]
    if kind == "prismatic":
        return [_slide(name, mech, child, point, axis)]
    if kind == "spherical":
        return [_ball(name, mech, child, point)]
    if kind == "cylindrical":
        return [_slide(f"{name}.slide", mech, child, point, axis), _hinge(f"{name}.hinge", mech, child, point, axis)]
    if kind == "universal":
        return [
            _hinge(f"{name}.hinge1", mech, child, point, parent_arm),
            _hinge(f"{name}.hinge2", mech, child, point, axis),
        ]
    if kind == "revolute_prismatic":  # the pin (body2's point2) slides along body1's slot and turns about z
        pin = mech.frame(joint.body2).r + mech.frame(joint.body2).A @ joint.point2
        pin_local = C.A.T @ (pin - C.r)
        z = np.array([0.0, 0.0, 1.0])
        slot = C.A.T @ P.A @ joint.axis1 if not edge.reverse else joint.axis1
        slide, hinge = (
            _slide(f"{name}.slide", mech, child, pin_local, slot),
            _hinge(f"{name}.hinge", mech, child, pin_local, z),
        )
        return [hinge, slide] if edge.reverse else [slide, hinge]  # the parent's freedom first
    return []  # rigid: the child is fixed in its parent


def floating_joints(mech: Mechanism, body: int) -> list[MjcfJoint]:
    """A body no tree joint reaches from ground: spatial, a free joint (qvel: world velocity of the origin, angular
    velocity in the body frame); planar, slides along the world's x and y and a hinge about z ('BODY.x', '.y',
    '.phi', the coordinates a coordinate motor drives)."""
    C, name = mech.frame(body), mech.name(body)
    if mech.model.dimension == 3:
        twist = np.zeros((6, 6))
        twist[3:, :3], twist[:3, 3:] = np.eye(3), C.A
        return [MjcfJoint(f"{name}.free", "free", np.zeros(3), np.zeros(3), twist, qpos0=(*C.r, *C.p))]
    zero = np.zeros(3)
    return [
        _slide(f"{name}.x", mech, body, zero, C.A.T @ [1.0, 0.0, 0.0]),
        _slide(f"{name}.y", mech, body, zero, C.A.T @ [0.0, 1.0, 0.0]),
        _hinge(f"{name}.phi", mech, body, zero, np.array([0.0, 0.0, 1.0])),
    ]


def joint_rates(mech: Mechanism, parent: int, child: int, joints: list[MjcfJoint]) -> np.ndarray:
    """The joints' qvel from the bodies' velocities: the child's twist relative to the parent,
    omega_C - omega_P and v_C - v_P - omega_P x (r_C - r_P), solved for in the joints' columns (least squares:
    exact when the velocities are consistent, as ``tree.assembled_frames`` makes them)."""
    if not joints:
        return np.zeros(0)
    P, C = mech.frame(parent), mech.frame(child)
    twist = np.concatenate([C.omega - P.omega, C.v - P.v - np.cross(P.omega, C.r - P.r)])
    return np.linalg.lstsq(np.hstack([j.twist for j in joints]), twist, rcond=None)[0]


# -- motors -----------------------------------------------------------------------------------------------------
def motor_polynomial(model: Model, where: str, spec: dict) -> tuple[list[float], str, float]:
    """(coefficients a of f(t) - f(0) in the clock's coordinate x, clock kind, omega): a polynomial of degree <= 4
    in x = t ('time'); a harmonic a0 + a1 x in x = sin(omega t + phase) ('sine')."""
    function = function_from_spec(spec["function"])
    if isinstance(function, Constant):
        return [0.0] * 5, "time", 0.0
    if isinstance(function, Polynomial):
        c = list(function.coefficients)
        if len(c) > 5:
            raise refuse(
                model, f"{where}.function", f"a polynomial of degree {len(c) - 1} (MJCF's polycoef holds degree 4)",
                "give the motor a polynomial of degree 4 or less",
            )  # fmt: skip
        return [0.0, *c[1:], *[0.0] * (5 - len(c))], "time", 0.0
    if isinstance(function, Harmonic):
        a = function.amplitude
        return [-a * math.sin(function.phase), a, 0.0, 0.0, 0.0], "sine", function.frequency
    kind = spec["function"].get("type", "function") if isinstance(spec["function"], dict) else "function"
    raise refuse(
        model, f"{where}.function", f"a {kind} motor (MJCF drives a joint exactly by a polynomial in a clock only)",
        "give it a polynomial (degree <= 4) or harmonic function, or export the model without the motor",
    )  # fmt: skip


def driven_joint(mech: Mechanism, where: str, spec: dict, names: dict[str, TreeEdge]) -> tuple[str, float]:
    """The MJCF joint a motor drives and the sign of its coordinate against the motor's (-1 when the tree's child
    is the joint's body1: the child then turns or slides the other way)."""
    model = mech.model
    if spec["type"] == "coordinate":
        body = model.body_index(spec["body"])
        if body not in mech.roots or model.dimension == 3:
            raise refuse(
                model, where, f"a coordinate motor of '{spec['body']}', a body joined to others by the tree",
                "drive a joint (angle or linear motor) instead: MJCF drives a joint's coordinate, a planar floating "
                "body's x, y or phi",
            )  # fmt: skip
        return f"{spec['body']}.{spec['coordinate']}", 1.0
    edge = names.get(spec["joint"])
    if edge is None:
        raise refuse(
            model, f"{where}.joint", f"drives '{spec['joint']}', a joint the export closes as an equality (a loop)",
            "drive a joint of the tree",
        )  # fmt: skip
    sign = -1.0 if edge.reverse else 1.0
    if edge.joint.kind == "cylindrical":
        return f"{spec['joint']}.{'hinge' if spec['type'] == 'angle' else 'slide'}", sign
    return spec["joint"], sign


# -- the document -----------------------------------------------------------------------------------------------
@dataclass
class Document:
    """The parts of an MJCF file as they are gathered: bodies' XML by body, equalities, tendons, actuators, and the
    MJCF joints in qpos order with their initial qpos and qvel."""

    mech: Mechanism
    stiffness: Stiffness
    sites: dict
    equalities: list
    tendons: list
    actuators: list
    clocks: list
    joints: list  # (MjcfJoint, qpos, qvel) in MuJoCo's order

    def equality(self, tag: str, **attributes) -> None:
        s = self.stiffness
        self.equalities.append(_element(tag, **attributes, solref=s.solref, solimp=_v(s.solimp)))

    def site(self, body: int, point, name: str) -> str:
        """A site at ``point`` (body frame) of ``body`` (world: -1), named ``name``."""
        self.sites.setdefault(body, []).append(_element("site", name=name, pos=_v(point)))
        return name


def _check_joints(mech: Mechanism) -> None:
    model = mech.model
    for k, spec in enumerate(model.joints):
        if spec["type"] in REFUSED_JOINTS:
            raise refuse(
                model, f"model.joints[{k}] ({spec['name']})", f"a {spec['type']} joint: {REFUSED_JOINTS[spec['type']]}",
                "export a model without it (or drive the bodies it couples by their own motors)",
            )  # fmt: skip
    for joint in mech.cut:
        if joint.kind not in EITHER + CUT_ONLY:
            k = next(k for k, s in enumerate(model.joints) if s["name"] == joint.name)
            raise refuse(
                model, f"model.joints[{k}] ({joint.name})",
                f"a {joint.kind} joint that closes a loop (MJCF has no equality constraint for it)",
                "close the loop at a revolute, spherical or rigid joint (make this one a joint of an open chain)",
            )  # fmt: skip


def close_loops(doc: Document) -> None:
    """Each cut joint as an equality (see the module's list); anchors in body1's frame at the assembled state."""
    mech = doc.mech
    for joint in mech.cut:
        b1, b2 = mech.name(joint.body1), mech.name(joint.body2)
        b1 = "world" if joint.body1 < 0 else b1
        b2 = "world" if joint.body2 < 0 else b2
        if joint.kind == "rigid":
            doc.equality("weld", name=joint.name, body1=b1, body2=b2)
        elif joint.kind == "revolute_revolute":
            s1 = doc.site(joint.body1, joint.point1, f"{joint.name}.1")
            s2 = doc.site(joint.body2, joint.point2, f"{joint.name}.2")
            doc.tendons.append(spatial_tendon(s1, s2, name=joint.name))
            doc.equality("tendon", name=joint.name, tendon1=joint.name, polycoef="0 0 0 0 0")
        else:
            doc.equality("connect", name=joint.name, body1=b1, body2=b2, anchor=_v(joint.point1))
            if joint.kind == "revolute" and mech.model.dimension == 3:  # a second point on the axis: 5 conditions
                other = joint.point1 + joint.axis1 / np.linalg.norm(joint.axis1)
                doc.equality("connect", name=f"{joint.name}.axis", body1=b1, body2=b2, anchor=_v(other))


def drive(doc: Document, names: dict[str, TreeEdge]) -> None:
    """Each motor as an equality between its joint and a clock joint (see the module's docstring)."""
    mech, model = doc.mech, doc.mech.model
    g = np.zeros(3)
    g[: model.dimension] = model.gravity
    elements = {e.name: e for e in mech.system.elements}
    for k, spec in enumerate(model.motors):
        where = f"model.motors[{k}] ({spec['name']})"
        coefficients, kind, omega = motor_polynomial(model, where, spec)
        clock = f"{spec['name']}.clock"
        phase = function_from_spec(spec["function"]).phase if kind == "sine" else 0.0
        doc.clocks.append((clock, kind, omega, phase, _normal_to(g)))
        if spec["type"] == "distance":  # a spatial tendon's length against a fixed tendon of the clock
            e, name = elements[spec["name"]], spec["name"]
            s1, s2 = doc.site(e.i, _3(e.si), f"{name}.1"), doc.site(e.j, _3(e.sj), f"{name}.2")
            doc.tendons.append(spatial_tendon(s1, s2, name=name))
            doc.tendons.append(f"<fixed {_attrs(name=clock)}>{_element('joint', joint=clock, coef='1')}</fixed>")
            doc.equality("tendon", name=name, tendon1=name, tendon2=clock, polycoef=_v(coefficients))
            continue
        joint, sign = driven_joint(mech, where, spec, names)
        doc.equality(
            "joint", name=spec["name"], joint1=joint, joint2=clock, polycoef=_v(np.multiply(sign, coefficients))
        )


def _normal_to(g: np.ndarray) -> np.ndarray:
    """A unit vector normal to gravity: a clock's slide, on which gravity does no work."""
    if not np.any(g):
        return np.array([1.0, 0.0, 0.0])
    n = np.cross(g, np.eye(3)[int(np.argmin(np.abs(g)))])
    return n / np.linalg.norm(n)


def clock_body(
    name: str, kind: str, omega: float, phase: float, axis: np.ndarray
) -> tuple[str, MjcfJoint, tuple, tuple]:
    """A clock's body and joint, with its initial qpos and qvel: x = t (x(0) = 0, x'(0) = 1), or
    x = sin(omega t + phase) (x(0) = sin(phase), x'(0) = omega cos(phase); stiffness (m + armature) omega^2 about
    the reference x = 0)."""
    stiffness = (1.0 + CLOCK_INERTIA) * omega**2 if kind == "sine" else None
    extra = {"armature": _v(CLOCK_INERTIA), "stiffness": None if stiffness is None else _v(stiffness)}
    joint = MjcfJoint(name, "slide", np.zeros(3), axis, np.zeros((6, 1)), extra=extra)
    xml = f'<body name="{name}">{_element("inertial", pos="0 0 0", mass="1", diaginertia="1 1 1")}{joint.xml()}</body>'
    if kind == "time":
        return xml, joint, (0.0,), (1.0,)
    return xml, joint, (math.sin(phase),), (omega * math.cos(phase),)


def springs(doc: Document, names: dict[str, TreeEdge], joint_extra: dict[str, dict]) -> None:
    """TSDAs as spatial tendons with stiffness, damping and springlength; RSDAs as their joint's spring."""
    from ..generalized_forces import build_forces
    from ..planar.forces import RSDA as PlanarRSDA
    from ..spatial.forces import RSDA as SpatialRSDA

    mech, model = doc.mech, doc.mech.model
    elements = {e.name: e for e in build_forces(model).elements}
    for k, spec in enumerate(model.spring_dampers):
        where, e = f"model.spring_dampers[{k}] ({spec['name']})", elements[spec["name"]]
        if "actuator" in spec:
            raise refuse(
                model, f"{where}.actuator", "an actuator force in time (MJCF's tendon spring has none)",
                "export the model without the actuator",
            )  # fmt: skip
        if isinstance(e, PlanarRSDA | SpatialRSDA):
            rotational_spring(mech, where, spec, e, names, joint_extra)
            continue
        s1 = doc.site(e.i, _3(e.si), f"{spec['name']}.1")
        s2 = doc.site(e.j, _3(e.sj), f"{spec['name']}.2")
        spring = {"stiffness": _v(e.stiffness), "damping": _v(e.damping), "springlength": _v(e.free_length)}
        doc.tendons.append(spatial_tendon(s1, s2, name=spec["name"], **spring))


def _3(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return np.array([*v, 0.0]) if v.size == 2 else v


def rotational_spring(mech, where, spec, e, names, joint_extra) -> None:
    """An RSDA about a hinge of the tree: theta = theta_assembled + sign q, so the joint's spring
    -k (q - springref) with springref = sign (theta0 - theta_assembled) is the RSDA's torque (eq. 5.15, 10.13)."""
    model = mech.model
    pair = {e.i, e.j}
    if model.dimension == 2:
        edge = next(
            (
                g
                for g in names.values()
                if {g.parent, g.child} == pair and g.joint.kind in ("revolute", "revolute_prismatic")
            ),
            None,
        )
        Ai, Aj = mech.frame(e.i).A, mech.frame(e.j).A
        theta = math.atan2(Aj[1, 0], Aj[0, 0]) - math.atan2(Ai[1, 0], Ai[0, 0])
        theta += 2 * math.pi * round((e.free_angle - theta) / (2 * math.pi))
    else:
        edge = names.get(spec.get("joint", ""))
        Ai, Aj = mech.frame(e.i).A, mech.frame(e.j).A
        fj = Aj @ e.fj
        theta = math.atan2((Ai @ e.gi) @ fj, (Ai @ e.fi) @ fj)
    if edge is None or edge.joint.kind not in ("revolute", "cylindrical", "revolute_prismatic"):
        raise refuse(
            model, where, "an RSDA about no hinge of the exported tree (MJCF springs a joint's own coordinate)",
            "put the RSDA on two bodies joined by a revolute joint that is not cut",
        )  # fmt: skip
    sign = 1.0 if edge.child == e.j else -1.0
    hinge = edge.joint.name if edge.joint.kind == "revolute" else f"{edge.joint.name}.hinge"
    joint_extra[hinge] = {
        "stiffness": _v(e.stiffness),
        "damping": _v(e.damping),
        "springref": _v(sign * (e.free_angle - theta)),
    }


def loads(doc: Document) -> None:
    """Constant loads as ``general`` actuators with a constant bias (force = biasprm[0] times gear), through a site
    at the load's point; global loads measured in the world site ``origin``."""
    from ..generalized_forces import build_forces

    model = doc.mech.model
    elements = {e.name: e for e in build_forces(model).elements}
    for k, spec in enumerate(model.forces):
        where, e = f"model.forces[{k}] ({spec['name']})", elements[spec["name"]]
        functions = getattr(e, "components", None) or (e.function,)
        if not all(
            isinstance(f, Constant) or (isinstance(f, Polynomial) and len(f.coefficients) == 1) for f in functions
        ):
            raise refuse(
                model, f"{where}.value", "a load that varies in time (MJCF applies constant or controlled forces)",
                "export the model with constant loads",
            )  # fmt: skip
        value = np.array([f.value(0.0) for f in functions])
        if spec["type"] == "torque":
            gear = np.concatenate([np.zeros(3), _3(value) if value.size > 1 else [0.0, 0.0, value[0]]])
            point = np.zeros(3)
        else:
            gear = np.concatenate([_3(value), np.zeros(3)])
            point = _3(e.point)
        site = doc.site(e.i, point, f"{spec['name']}.site")
        fixed = getattr(e, "body_fixed", False) or (model.dimension == 2 and spec["type"] == "torque")
        doc.actuators.append(
            _element("general", name=spec["name"], site=site, refsite=None if fixed else "origin", gear=_v(gear),
                     gainprm="0", biastype="affine", biasprm="1 0 0")
        )  # fmt: skip


def body_xml(doc: Document, body: int, children: dict, joint_extra: dict, parent: int) -> str:
    """One ``<body>`` with its inertial, joints, sites and children (depth first: MuJoCo's qpos order)."""
    mech = doc.mech
    edge = mech.parent_edge(body)
    joints = floating_joints(mech, body) if edge is None else tree_joints(mech, edge)
    rates = joint_rates(mech, parent, body, joints)
    v = 0
    for joint in joints:
        nv = joint.twist.shape[1]
        doc.joints.append((joint, joint.qpos0, tuple(rates[v : v + nv])))
        v += nv
        joint.extra = joint_extra.get(joint.name, joint.extra)
    pos, quat = relative_pose(mech, parent, body)
    inner = [inertial(mech.model, mech.model.bodies[body]), *(j.xml() for j in joints)]
    inner += doc.sites.get(body, [])
    inner += [body_xml(doc, child, children, joint_extra, body) for child in children.get(body, [])]
    return f"<body {_attrs(name=mech.name(body), pos=_v(pos), quat=_v(quat))}>\n" + "\n".join(inner) + "\n</body>"


def export_mjcf(model: Model, stiffness: Stiffness | None = None) -> str:
    """The MJCF text of a model (see the module's docstring), or ExportError naming what MJCF cannot hold."""
    stiffness = stiffness or Stiffness()
    for k, body in enumerate(model.bodies):
        if body.name == "world":
            raise refuse(model, f"model.bodies[{k}].name", "'world' is MJCF's fixed frame", "rename the body")
    mech = mechanism(model)
    _check_joints(mech)
    doc = Document(mech, stiffness, {}, [], [], [], [], [])
    names = {edge.joint.name: edge for edge in mech.edges}
    joint_extra: dict[str, dict] = {}
    close_loops(doc)
    drive(doc, names)
    springs(doc, names, joint_extra)
    loads(doc)
    doc.site(-1, np.zeros(3), "origin")
    children: dict[int, list[int]] = {}
    for edge in mech.edges:
        children.setdefault(edge.parent, []).append(edge.child)
    tops = children.get(-1, []) + mech.roots
    bodies = [body_xml(doc, body, children, joint_extra, -1) for body in tops]
    for clock in doc.clocks:
        xml, joint, qpos, qvel = clock_body(*clock)
        bodies.append(xml)
        doc.joints.append((joint, qpos, qvel))
    gravity = np.zeros(3)
    gravity[: model.dimension] = model.gravity
    qpos = [x for _, q, _ in doc.joints for x in q]
    qvel = [x for _, _, v in doc.joints for x in v]
    option = _element("option", timestep=_v(stiffness.timestep), integrator="RK4", gravity=_v(gravity))
    parts = [
        f"<mujoco model={quoteattr(model.name)}>",
        f"<!-- {model.source} exported by mbd export: bodies at their centres of mass in the assembled configuration"
        " (mbd check); keyframe 'initial' holds the state mbd run starts from -->",
        '<compiler angle="radian" autolimits="true"/>',
        option,
        "<worldbody>",
        *doc.sites.get(-1, []),
        *bodies,
        "</worldbody>",
    ]
    for tag, items in (("equality", doc.equalities), ("tendon", doc.tendons), ("actuator", doc.actuators)):
        if items:
            parts += [f"<{tag}>", *items, f"</{tag}>"]
    parts += [
        "<keyframe>",
        _element("key", name="initial", qpos=_v(qpos) if qpos else None, qvel=_v(qvel) if qvel else None),
        "</keyframe>",
        "</mujoco>",
    ]
    return "\n".join(parts) + "\n"


__all__ = ["CLOCK_INERTIA", "Stiffness", "export_mjcf"]
