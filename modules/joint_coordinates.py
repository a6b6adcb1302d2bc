# Generated from solutions/joint_coordinates.py by `make modules` (every homework stubbed): do not edit by hand.
"""Joint coordinates of a spanning tree: the velocity-transformation (embedding) method; loops by cut joints.

When every body is reached from ground by exactly one chain of joints (an open tree, no closed loop),
the joint coordinates theta -- a revolute joint's angle, a prismatic joint's slide, a spherical joint's
relative orientation -- are minimal: every value of theta is an assembled configuration, so no
constraint has to be solved or stabilized (Nikravesh 1988, ch. 'joint coordinates'; Garcia de Jalon
and Bayo 1994, 'velocity transformations'). The body coordinates follow from theta by recursive
kinematics from ground, joint after joint in topological order:

    q = q(theta),      q' = D(theta) theta',      q'' = D theta'' + xi,   xi = D' theta'

D = dq/dtheta is an analytic basis of the null space of Psi_q (Psi_q D = 0: every theta' moves the
mechanism along its joints), so the null-space method (course notes, eq. 5.44) with Z = D removes the
multipliers and leaves k = dim(theta) equations (the embedding):

    (D^T M D) theta'' = D^T (Q - M xi)                                              (eq. 5.44)

A planar body's velocity is q' itself and M is constant. A spatial body's velocity is taken as
(v, omega'): the velocity of its centre of mass and its angular velocity omega' = A^T omega in its own
frame, with p' = 1/2 L(p)^T omega' (eq. 8.17). In these its mass matrix diag(m I, J') is constant, and
the rotational rows are Euler's equations J' omega'' + omega' x J' omega' = n': the gyroscopic term
takes the place of the quadratic-velocity term Q_v of the (r, p) form (``spatial.mass``, eq. 10.5) --
the same equations, since p' = 1/2 L^T omega'. Torques n' come from Q_p by n' = 1/2 L(p) Q_p.

The column of D for one joint coordinate is the velocity of every body when only that coordinate moves,
built recursively from the link vector l = rho_P + d - rho_C between the two centres of mass of a joint
(rho_P = A_P s_P', rho_C = A_C s_C' the joint point seen from the parent and the child, d the slide):

    omega_C = omega_P + omega_rel,     v_C = v_P + omega_P x l + h s' + rho_C x omega_rel
    alpha_C = alpha_P + omega_P x omega_rel                       (the part of the accelerations with theta'' = 0)
    a_C     = a_P + alpha_P x (rho_P + d) + omega_P x (omega_P x (rho_P + d)) + 2 s' omega_P x h
              - alpha_C x rho_C - omega_C x (omega_C x rho_C)

with omega_rel = h theta' (revolute, axis h), 0 (prismatic along h, slide s) or the spherical joint's
relative angular velocity (all vectors global). In the plane omega x r is omega R90 r and alpha_C = 0.

The state is y = (positions, velocities) of the joints in topological order:

- revolute: the angle theta (1), its rate theta' (1); prismatic: the slide s (1), s' (1);
- spherical (space only): the Euler parameters e (4) of the child's joint frame relative to the
  parent's, normalized whenever positions are made, and the relative angular velocity w' (3) in the
  child's joint frame; their rate is e' = 1/2 L(e)^T w' (eq. 8.17). The body-fixed w' varies slowly
  where the global one does not (a spinning top: about 100 times smaller errors at the same rtol).

No multiplier is computed on the way (``rhs``); ``accelerations`` also gives lambda of the model's
constraint rows, from Psi_q^T lambda = Q - M q'' (normal equations: independent rows),
with the same M and Q as the other formulations, so that reactions are the same.

Closed loops and drivers: cut joints (Nikravesh 1988, 'joint coordinates' of closed chains; Garcia de
Jalon and Bayo 1994). A spanning tree of the supported joints is chosen breadth-first from ground (each
body reached exactly once); every other joint (a loop's closing joint, a gear, a cam) and every driver
is kept as a cut constraint Psi_c(q(theta), t) = 0, evaluated by a ``System`` of those elements only.
With Psi_theta = Psi_c,q D, the velocity equation Psi_theta theta' = -Psi_c,t and the acceleration
equation Psi_theta theta'' = gamma_c - Psi_c,q xi join the embedded equations as an augmented system
(eq. 5.30 in joint coordinates), stabilized on the cut rows only (Baumgarte, eq. 5.29):

    [ D^T M D    Psi_theta^T ] [ theta'' ]   [ D^T (Q - M xi)                                  ]
    [ Psi_theta  0           ] [ mu      ] = [ gamma_c - Psi_c,q xi - 2 alpha Psi_c' - beta^2 Psi_c ]

An open tree has no cut rows, and this is (D^T M D) theta'' = D^T (Q - M xi) above.
"""

from __future__ import annotations

import functools
import math
from collections import deque
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .assembly import System
from .diagnostics import AnalysisError, rank_report
from .formulations import (
    DEFAULT_ALPHA,
    DEFAULT_BETA,
    FORMULATIONS,
    Formulation,
    augmented_accelerations,
    baumgarte_gamma,
)
from .generalized_forces import ForceModel
from .io.model import GROUND
from .linalg import cholesky_solve
from .rotation_matrices import (
    g_entries,
    l_entries,
    planar_rotation,
    planar_rotation_entries,
    quaternion_product_entries,
    unit_rotation_entries,
)

SUPPORTED_JOINTS = {2: ("revolute", "prismatic"), 3: ("revolute", "prismatic", "spherical")}
"""Joint types with joint coordinates, by dimension."""

R90 = np.array([[0.0, -1.0], [1.0, 0.0]])
"""Rotation by +90 degrees in the plane: omega x r = omega R90 r."""


# -- the tree and the cut --------------------------------------------------------------------------
def tree_order(system: System) -> tuple[list[tuple[dict, bool]], str | None]:
    """The joints of a spanning tree in topological order from ground, each with ``reversed`` (body2 is
    the parent), or a one-line reason why the bodies cannot all be reached by supported joints.

    Breadth-first from ground over the supported joints (``SUPPORTED_JOINTS``): a joint to a body not yet
    reached joins the tree; one between two reached bodies closes a loop and is cut (``cut_elements``). Found once
    per system (a run asks for it several times).
    """
    if "_tree_order" not in system.__dict__:
        system.__dict__["_tree_order"] = _tree_order(system)
    order, reason = system.__dict__["_tree_order"]
    return list(order), reason


def _tree_order(system: System) -> tuple[list[tuple[dict, bool]], str | None]:
    model = system.model
    supported = SUPPORTED_JOINTS[model.dimension]
    touching: dict[str, list[int]] = {}  # body -> the supported joints at it, in the file's order
    for k, spec in enumerate(model.joints):
        if spec["type"] in supported:
            for name in dict.fromkeys((spec["body1"], spec["body2"])):
                touching.setdefault(name, []).append(k)
    reached, order, queue, taken = {GROUND}, [], deque([GROUND]), set()
    while queue:
        body = queue.popleft()
        for k in touching.get(body, []):
            if k in taken:
                continue
            taken.add(k)
            spec = model.joints[k]
            other = spec["body2"] if spec["body1"] == body else spec["body1"]
            if other not in reached:
                order.append((spec, spec["body1"] != body))
                reached.add(other)
                queue.append(other)
    for body in model.bodies:
        if body.name not in reached:
            return [], (
                f"body '{body.name}' is not reached from ground by {'/'.join(supported)} joints "
                "(the joint coordinates of a spanning tree)"
            )
    return order, None


def cut_elements(system: System, order: list[tuple[dict, bool]]) -> list:
    """The system's elements that are not joints of the tree: loop-closing joints, gears, cams and
    drivers, kept as constraints. (A spatial body's Euler-parameter normalization holds by construction.)"""
    tree = {spec["name"] for spec, _ in order} | {f"{b.name}.p" for b in system.model.bodies}
    return [element for element in system.elements if element.name not in tree]


def cut_system(system: System) -> System | None:
    """The ``System`` of the cut elements (``cut_elements``), or None for an open tree: made once per system, as
    ``tree_order`` and ``tree_joints``, and shared by its runs' formulations (it keeps nothing of a run but the
    one-entry cache of its last configuration, keyed by q). Making it checks its batched groups against the
    element methods (``System._make_groups``): 0.4-0.5 ms of a loop chain's run at N = 4, every run."""
    kept = system.__dict__.setdefault("_cut_systems", {})  # by ``vectorized``: the element loop, or the groups
    if system.vectorized not in kept:
        cut = cut_elements(system, tree_order(system)[0])
        kept[system.vectorized] = System(system.model, cut, vectorized=system.vectorized) if cut else None
    return kept[system.vectorized]


def open_tree(system: System) -> str | None:
    """None when the scene is an open tree of supported joints (no cut constraint: nothing to stabilize),
    else a one-line reason. ``auto`` picks joint coordinates only then: with cut joints it measured slower
    than baumgarte (benchmarks: the free slider-crank, the four-bar with spring, Andrews' mechanism)."""
    order, reason = tree_order(system)
    cut = dict.fromkeys(element.name for element in cut_elements(system, order))
    return reason or (f"closed loops or drivers, cut at {', '.join(cut)} (then slower than baumgarte)" if cut else None)


def supports(system: System) -> str | None:
    """None when joint coordinates can take the scene, else a one-line reason: a body not reached from
    ground by supported joints, or redundant constraints (the cut rows' augmented system needs
    independent rows; the model's q0 from its file is where they are counted). Decided once per system (an
    SVD of the whole Psi_q: on a chain of 32 loops more than the integration, and every run makes the
    formulation twice: for its start rates and to integrate)."""
    if "_supports" not in system.__dict__:
        system.__dict__["_supports"] = _supports(system)
    return system.__dict__["_supports"]


def _supports(system: System) -> str | None:
    order, reason = tree_order(system)
    if reason is not None or not cut_elements(system, order):
        return reason
    model = system.model
    if model.dimension == 3:
        from .spatial.build import initial_coordinates
    else:
        from .planar.build import initial_coordinates
    report = rank_report(system.jacobian(initial_coordinates(model)[0], 0.0), system.row_owners)
    if report.n_redundant:
        return (
            f"{report.n_redundant} redundant constraint equation(s) among joints {', '.join(report.redundant_joints)}: "
            "the cut joints' augmented system needs independent constraints; use --formulation svd"
        )
    return None


@dataclass
class TreeJoint:
    """One joint of the tree, seen from its parent body P to its child body C (-1 is ground).

    Constant data, found once, as tuples of floats: ``s_parent``, ``s_child`` the joint point in the two
    body frames; ``axis`` the joint axis (rotation or slide) in the parent's frame; planar ``offset`` the
    angle phi_C - phi_P of a prismatic joint; spatial ``a``, ``c`` the Euler parameters of the parent's
    joint frame and the inverse of the child's, so that p_C = p_P a e_J c (e_J the joint's own rotation),
    ``u0``, ``u1`` = a (1, 0, 0, 0) c and a (0, 0, 0, 1) c (a revolute joint's p_P^-1 p_C is
    cos(theta/2) u0 + sin(theta/2) u1), ``frame`` the child's joint frame axes (f, g, h) in its body
    frame. ``position``, ``velocity``: where its coordinates start in the state; ``inherited``: the
    velocity columns that move the parent (its ancestors' columns).
    """

    name: str
    kind: str
    parent: int
    child: int
    s_parent: tuple
    s_child: tuple
    axis: tuple
    offset: float = 0.0
    a: tuple = (1.0, 0.0, 0.0, 0.0)
    c: tuple = (1.0, 0.0, 0.0, 0.0)
    u0: tuple = (1.0, 0.0, 0.0, 0.0)
    u1: tuple = (0.0, 0.0, 0.0, 1.0)
    frame: tuple = ()
    position: int = 0
    velocity: int = 0
    inherited: tuple = ()

    @property
    def n_positions(self) -> int:
        return 4 if self.kind == "spherical" else 1

    @property
    def n_velocities(self) -> int:
        return 3 if self.kind == "spherical" else 1


# -- the tree's joints from the system's elements --------------------------------------------------
def tree_joints(system: System) -> list[TreeJoint]:
    """``build_tree(system)``, built once per system (a spatial chain of 64 joints: 4 ms of Python, every run) and
    handed out: a copy of each joint a run changes (a spatial prismatic joint, whose ``u0`` its ``joint_state``
    sets), the others as built (nothing writes them: a copy of each, ~1 us, was ~9 us of a loop chain of four's
    start in a call, ~16 us of a planar chain of sixteen's)."""
    if "_tree_joints" not in system.__dict__:
        system.__dict__["_tree_joints"] = build_tree(system)
    spatial = system.model.dimension == 3
    return [_copied(j) if spatial and j.kind == "prismatic" else j for j in system.__dict__["_tree_joints"]]


def _copied(joint: TreeJoint) -> TreeJoint:
    """A shallow copy of a joint (``copy.copy`` without its protocol: 1 us, not 4)."""
    made = object.__new__(type(joint))
    made.__dict__.update(joint.__dict__)
    return made


def build_tree(system: System) -> list[TreeJoint]:
    """The tree's joints in topological order, with their constant data."""
    order, reason = tree_order(system)
    if reason is not None:
        raise AnalysisError(f"the joint-coordinates formulation cannot take this scene: {reason}")
    model = system.model
    elements: dict[str, list] = {}
    for element in system.elements:
        elements.setdefault(element.name, []).append(element)
    joints, position, velocity = [], 0, 0
    moving: dict[int, tuple] = {-1: ()}  # body -> the velocity columns that move it
    index = {GROUND: -1} | {body.name: k for k, body in enumerate(model.bodies)}
    for spec, reverse in order:
        i, j = index[spec["body1"]], index[spec["body2"]]
        parent, child = (j, i) if reverse else (i, j)
        joint = (planar_joint if model.dimension == 2 else spatial_joint)(spec, elements[spec["name"]], reverse)
        joint.parent, joint.child = parent, child
        joint.position, joint.velocity, joint.inherited = position, velocity, moving[parent]
        moving[child] = moving[parent] + tuple(range(velocity, velocity + joint.n_velocities))
        position, velocity = position + joint.n_positions, velocity + joint.n_velocities
        joints.append(joint)
    return joints


def _floats(x) -> tuple:
    """The entries of a vector as a tuple of Python floats (the scalar arithmetic of the tree's recursions); an
    array's by ``tolist`` (the same values, 5x faster than float() one by one: 26 calls a spatial run's start)."""
    if isinstance(x, np.ndarray) and x.dtype == np.float64 and x.ndim == 1:
        return tuple(x.tolist())
    return tuple(float(v) for v in x)


def planar_joint(spec: dict, parts: list, reverse: bool) -> TreeJoint:
    """A planar revolute (``Revolute``) or prismatic (``PinInSlot`` + ``RelativeAngle``) joint."""
    slot = parts[0]  # Revolute or PinInSlot: the joint points
    si, sj = _floats(slot.si), _floats(slot.sj)
    s_parent, s_child = (sj, si) if reverse else (si, sj)
    if spec["type"] == "revolute":
        return TreeJoint(spec["name"], "revolute", -1, -1, s_parent, s_child, (0.0, 0.0))
    phi0 = next(p.phi0 for p in parts if hasattr(p, "phi0"))  # phi_j - phi_i
    ux, uy = _floats(slot.axis)  # the slot direction in body i
    if reverse:  # in body j: A_j^T A_i u_i' = A(-phi0) u_i'
        cos, _, sin, _ = planar_rotation_entries(phi0)
        ux, uy = cos * ux + sin * uy, -sin * ux + cos * uy
    return TreeJoint(spec["name"], "prismatic", -1, -1, s_parent, s_child, (ux, uy), offset=-phi0 if reverse else phi0)


def spatial_joint(spec: dict, parts: list, reverse: bool) -> TreeJoint:
    """A spatial revolute, prismatic or spherical joint from its definition frames (``Joint.frames``).

    A_C = A_P F_P R_J F_C^T with F = [f g h] the joint frame in each body and R_J the joint's rotation
    (about h by theta; none; any), so p_C = p_P a e_J c with a = p(F_P), c = p(F_C)^-1.
    """
    from .rotations import euler_parameters  # here: a planar scene never imports spatial code

    frame_i, frame_j = parts[0].frames
    frame_p, frame_c = (frame_j, frame_i) if reverse else (frame_i, frame_j)
    a = _floats(euler_parameters(np.column_stack([frame_p.f, frame_p.g, frame_p.h])))
    c = _floats(euler_parameters(np.column_stack([frame_c.f, frame_c.g, frame_c.h])) * CONJUGATE)
    return TreeJoint(
        spec["name"], spec["type"], -1, -1, _floats(frame_p.origin), _floats(frame_c.origin), _floats(frame_p.h),
        a=a, c=c, u0=qmul(a, c), u1=qmul(qmul(a, (0.0, 0.0, 0.0, 1.0)), c),
        frame=(_floats(frame_c.f), _floats(frame_c.g), _floats(frame_c.h)),
    )  # fmt: skip


# -- 3-vectors, rotations and quaternions as tuples of floats ----------------------------------------
# One numpy call costs about a microsecond, far more than the arithmetic of a 3-vector, so the
# recursion works on plain floats; the results are gathered into arrays once per evaluation.
ZERO3 = (0.0, 0.0, 0.0)
ZERO6 = (0.0,) * 6
IDENTITY9 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
CONJUGATE = np.array([1.0, -1.0, -1.0, -1.0])


def add(a: tuple, b: tuple) -> tuple:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a: tuple, b: tuple) -> tuple:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def scale(s: float, a: tuple) -> tuple:
    return (s * a[0], s * a[1], s * a[2])


def cross(a: tuple, b: tuple) -> tuple:
    """a x b."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    return (a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0)


def rotate(A: tuple, v: tuple) -> tuple:
    """A v, with A a 3 x 3 matrix given row by row (9 floats)."""
    v0, v1, v2 = v
    return (A[0] * v0 + A[1] * v1 + A[2] * v2, A[3] * v0 + A[4] * v1 + A[5] * v2, A[6] * v0 + A[7] * v1 + A[8] * v2)


def rotate_back(A: tuple, v: tuple) -> tuple:
    """A^T v: a global vector in the body frame."""
    v0, v1, v2 = v
    return (A[0] * v0 + A[3] * v1 + A[6] * v2, A[1] * v0 + A[4] * v1 + A[7] * v2, A[2] * v0 + A[5] * v1 + A[8] * v2)


def _conjugate(p: tuple) -> tuple:
    """(e0, -e): the inverse rotation, as Python floats (``CONJUGATE * p`` entry by entry, without an array)."""
    return (float(p[0]), -float(p[1]), -float(p[2]), -float(p[3]))


def qmul(a: tuple, b: tuple) -> tuple:
    """The quaternion product a b: A(a b) = A(a) A(b) (``rotation_matrices.quaternion_product_entries``)."""
    return quaternion_product_entries(*a, *b)


def rotation9(p: tuple) -> tuple:
    """A(p) of unit Euler parameters, row by row (eq. 8.12)."""
    return unit_rotation_entries(*p)


def half_transpose_product(m: tuple, w: tuple) -> tuple:
    """1/2 M^T w of a 3 x 4 matrix M given row by row (G or L) and a 3-vector w."""
    w0, w1, w2 = w
    return (
        0.5 * (m[0] * w0 + m[4] * w1 + m[8] * w2),
        0.5 * (m[1] * w0 + m[5] * w1 + m[9] * w2),
        0.5 * (m[2] * w0 + m[6] * w1 + m[10] * w2),
        0.5 * (m[3] * w0 + m[7] * w1 + m[11] * w2),
    )


def half_g_transpose(p: tuple, w: tuple) -> tuple:
    """p' = 1/2 G(p)^T omega (eq. 8.17), G(p) = [-e, e~ + e0 I]."""
    return half_transpose_product(g_entries(*p), w)


def half_l_transpose(p: tuple, w: tuple) -> tuple:
    """p' = 1/2 L(p)^T omega' (eq. 8.17), L(p) = [-e, -e~ + e0 I], omega' in the body frame."""
    return half_transpose_product(l_entries(*p), w)


def scaled_product(scale: float, m: tuple, x: tuple) -> tuple:
    """scale M x of a 3 x 4 matrix M given row by row (G or L) and a 4-vector x."""
    x0, x1, x2, x3 = x
    return (
        scale * (m[0] * x0 + m[1] * x1 + m[2] * x2 + m[3] * x3),
        scale * (m[4] * x0 + m[5] * x1 + m[6] * x2 + m[7] * x3),
        scale * (m[8] * x0 + m[9] * x1 + m[10] * x2 + m[11] * x3),
    )


def half_l(p: tuple, x: tuple) -> tuple:
    """1/2 L(p) x of a 4-vector x: the body-frame torque n' of Q_p = 2 L^T n'."""
    return scaled_product(0.5, l_entries(*p), x)


def twice_g(p: tuple, pd: tuple) -> tuple:
    """omega = 2 G(p) p' = 2 (-p0' e + e x e' + e0 e') (eq. 8.16)."""
    return scaled_product(2.0, g_entries(*p), pd)


# -- recursive kinematics ---------------------------------------------------------------------------
@dataclass
class TreeMotion:
    """The bodies' motion made from the joint state by recursive kinematics.

    ``q``, ``qd``: body coordinates and their rates; ``D`` (c nb x k): the body velocities per unit
    joint velocity (planar: q'; spatial: v and the body-frame omega' per body); ``xi``: the body
    accelerations with theta'' = 0 in the same form; ``rates``: the rates of the joints' position
    coordinates; spatial ``A`` (rotation matrices, 9 floats each) and ``omega`` (omega' per body).
    """

    q: np.ndarray
    qd: np.ndarray
    D: np.ndarray
    xi: np.ndarray
    rates: np.ndarray
    A: list | None = None
    omega: list | None = None


class PlanarTree:
    """Recursive kinematics of a planar tree; one coordinate per joint, the body velocities are q'."""

    def __init__(self, joints: list[TreeJoint], n_bodies: int):
        self.joints, self.nb, self.k = joints, n_bodies, len(joints)
        self.n_positions = self.k

    def motion(self, positions: np.ndarray, velocities: np.ndarray) -> TreeMotion:
        """q, q', D and xi from (theta, theta'), joint after joint from ground (module docstring).

        Component by component: x and y of the plane's vectors, R90 (x, y) = (-y, x); alpha = 0 here.
        """
        nb, k = self.nb, self.k
        theta, rate = positions.tolist(), velocities.tolist()
        x, y, phi, vx, vy, w, ax, ay = ([0.0] * (nb + 1) for _ in range(8))  # the last entry (-1) is ground
        Dx, Dy, Dphi = ([[0.0] * k for _ in range(nb + 1)] for _ in range(3))  # rows of D, body by body
        for joint in self.joints:
            P, C, c = joint.parent, joint.child, joint.position
            revolute = joint.kind == "revolute"
            phi[C] = phi[P] + (theta[c] if revolute else joint.offset)
            (cp, _, sp, _), (cc, _, sc, _) = planar_rotation_entries(phi[P]), planar_rotation_entries(phi[C])
            (spx, spy), (scx, scy) = joint.s_parent, joint.s_child
            rcx, rcy = cc * scx - sc * scy, sc * scx + cc * scy  # rho_C = A_C s_C'
            ux = uy = s = sd = w_rel = 0.0
            if revolute:
                w_rel = rate[c]
            else:
                ux, uy = cp * joint.axis[0] - sp * joint.axis[1], sp * joint.axis[0] + cp * joint.axis[1]
                s, sd = theta[c], rate[c]
            ex, ey = cp * spx - sp * spy + s * ux, sp * spx + cp * spy + s * uy  # rho_P + d
            lx, ly = ex - rcx, ey - rcy  # the link l = rho_P + d - rho_C
            x[C], y[C] = x[P] + lx, y[P] + ly
            wp = w[P]
            w[C] = wc = wp + w_rel
            vx[C] = vx[P] - wp * ly + ux * sd + w_rel * rcy  # v_P + omega_P R90 l + u s' - omega_rel R90 rho_C
            vy[C] = vy[P] + wp * lx + uy * sd - w_rel * rcx
            ax[C] = ax[P] - wp * wp * ex + wc * wc * rcx - 2.0 * wp * sd * uy  # ... + 2 omega_P s' R90 u
            ay[C] = ay[P] - wp * wp * ey + wc * wc * rcy + 2.0 * wp * sd * ux
            # D_C = D_P + R90 l (angle row of D_P), and the joint's own column
            rows = Dx[P][:], Dy[P][:], Dphi[P][:]
            for col in joint.inherited:
                rows[0][col] -= ly * Dphi[P][col]
                rows[1][col] += lx * Dphi[P][col]
            rows[0][c], rows[1][c], rows[2][c] = (rcy, -rcx, 1.0) if revolute else (ux, uy, 0.0)
            Dx[C], Dy[C], Dphi[C] = rows
        flat = []  # q, q', xi and D in one array (one conversion from floats)
        for b in range(nb):
            flat += (x[b], y[b], phi[b])
        for b in range(nb):
            flat += (vx[b], vy[b], w[b])
        for b in range(nb):
            flat += (ax[b], ay[b], 0.0)
        for b in range(nb):
            flat += Dx[b] + Dy[b] + Dphi[b]
        out, n = np.array(flat), 3 * nb
        return TreeMotion(out[:n], out[n : 2 * n], out[3 * n :].reshape(n, k), out[2 * n : 3 * n], velocities)

    def joint_state(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(theta, theta') of body coordinates on the constraints, in closed form: a revolute joint's
        phi_C - phi_P (the angles as Python floats, as ``motion`` reads them: a numpy scalar per joint cost more
        than the subtraction), a prismatic joint's u^T d with d between the two joint points (``slide``)."""
        angles, spins = q[2::3].tolist() + [0.0], qd[2::3].tolist() + [0.0]  # ground's entry last (-1)
        theta, rate = [0.0] * self.k, [0.0] * self.k
        for joint in self.joints:
            P, C, c = joint.parent, joint.child, joint.position
            if joint.kind == "revolute":
                theta[c], rate[c] = angles[C] - angles[P], spins[C] - spins[P]
            else:
                theta[c], rate[c] = slide(joint, q, qd)
        return np.array(theta), np.array(rate)

    def joint_matrix(self, motion: TreeMotion) -> np.ndarray:
        """dq/dtheta (n x k): D itself."""
        return motion.D

    def coordinate_accelerations(self, motion: TreeMotion, accelerations: np.ndarray) -> np.ndarray:
        """q'' = D theta'' + xi."""
        return motion.D @ accelerations + motion.xi


def slide(joint: TreeJoint, q: np.ndarray, qd: np.ndarray) -> tuple[float, float]:
    """(s, s') of a planar prismatic joint from its bodies' coordinates: u^T d and u^T d' with d = r_C + rho_C - r_P
    - rho_P between the two joint points and u the axis in the parent's frame turned to the plane's."""
    X, V = np.zeros((q.size // 3 + 1, 3)), np.zeros((q.size // 3 + 1, 3))  # ground's row last (zeros)
    X[:-1], V[:-1] = q.reshape(-1, 3), qd.reshape(-1, 3)
    P, C = joint.parent, joint.child
    AP, AC = planar_rotation(X[P, 2]), planar_rotation(X[C, 2])
    rho_p, rho_c, u = AP @ joint.s_parent, AC @ joint.s_child, AP @ joint.axis
    d = X[C, :2] + rho_c - X[P, :2] - rho_p
    d_dot = V[C, :2] + V[C, 2] * (R90 @ rho_c) - V[P, :2] - V[P, 2] * (R90 @ rho_p)
    return u @ d, u @ d_dot


def joint_rotation(joint: TreeJoint, AP: tuple, theta: list, rate: list, rates: list) -> tuple:
    """What a spatial joint adds to its parent (A_P the parent's rotation): its own rotation p_joint, its axis h
    (global), the relative angular velocity (None for a prismatic joint; a spherical joint's comes after the
    child's rotation), the sliding rate s' and e_P, the vector from the parent's centre to the child's joint
    point: rho_P, plus s h for a prismatic joint. A spherical joint's Euler parameter rates e' = 1/2 L(e)^T w'
    go to ``rates`` (eq. 8.17)."""
    at, c = joint.position, joint.velocity
    if joint.kind == "revolute":
        h = rotate(AP, joint.axis)
        co, si = math.cos(0.5 * theta[at]), math.sin(0.5 * theta[at])
        (a0, a1, a2, a3), (b0, b1, b2, b3) = joint.u0, joint.u1
        p_joint = (co * a0 + si * b0, co * a1 + si * b1, co * a2 + si * b2, co * a3 + si * b3)
        rho_p = rotate(AP, joint.s_parent)
        return p_joint, h, scale(rate[c], h), 0.0, rho_p
    if joint.kind == "prismatic":
        h = rotate(AP, joint.axis)
        rho_p = rotate(AP, joint.s_parent)
        return joint.u0, h, None, rate[c], add(rho_p, scale(theta[at], h))  # rho_P + d
    e0, e1, e2, e3 = theta[at : at + 4]
    norm = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
    e = (e0 / norm, e1 / norm, e2 / norm, e3 / norm)
    rates[at : at + 4] = half_l_transpose(e, rate[c : c + 3])  # e' = 1/2 L(e)^T w'
    return qmul(qmul(joint.a, e), joint.c), None, None, 0.0, rotate(AP, joint.s_parent)


class SpatialTree:
    """Recursive kinematics of a spatial tree. A body's velocity is taken as (v, omega'): the velocity of
    its centre of mass (global) and its angular velocity in its own frame, in which its mass matrix
    diag(m I, J') is constant; omega = A omega', p' = 1/2 L(p)^T omega' (eq. 8.16, 8.17)."""

    def __init__(self, joints: list[TreeJoint], n_bodies: int):
        self.joints, self.nb = joints, n_bodies
        self.k = sum(joint.n_velocities for joint in joints)
        self.n_positions = sum(joint.n_positions for joint in joints)
        self.spherical = any(joint.kind == "spherical" for joint in joints)
        self.moving = [()] * n_bodies  # the velocity columns that move each body
        for joint in joints:
            self.moving[joint.child] = joint.inherited + tuple(
                range(joint.velocity, joint.velocity + joint.n_velocities)
            )

    def motion(self, positions: np.ndarray, velocities: np.ndarray) -> TreeMotion:
        """q, q', D and xi from the joint state, joint after joint from ground (module docstring)."""
        nb, k = self.nb, self.k
        theta, rate = positions.tolist(), velocities.tolist()
        r, v, w, acc, alpha = ([ZERO3] * (nb + 1) for _ in range(5))  # global; the last entry (-1) is ground
        p, A = [(1.0, 0.0, 0.0, 0.0)] * (nb + 1), [IDENTITY9] * (nb + 1)
        Dv, Dw = [[ZERO3] * k for _ in range(nb + 1)], [[ZERO3] * k for _ in range(nb + 1)]  # columns of D
        rates = [0.0] * self.n_positions if self.spherical else rate
        for joint in self.joints:
            P, C, c = joint.parent, joint.child, joint.velocity
            AP, wp, alp = A[P], w[P], alpha[P]
            if self.spherical and joint.kind != "spherical":
                rates[joint.position] = rate[c]
            p_joint, h, w_rel, sd, e_p = joint_rotation(joint, AP, theta, rate, rates)
            p[C] = qmul(p[P], p_joint)
            A[C] = AC = rotation9(p[C])
            if joint.kind == "spherical":
                axes = [rotate(AC, f) for f in joint.frame]  # the child's joint frame, global
                rel = rate[c : c + 3]
                w_rel = add(add(scale(rel[0], axes[0]), scale(rel[1], axes[1])), scale(rel[2], axes[2]))
            rho_c = rotate(AC, joint.s_child)
            link = sub(e_p, rho_c)
            r[C] = add(r[P], link)
            # velocities and the accelerations with theta'' = 0 (module docstring)
            vc = add(v[P], cross(wp, link))
            ac = add(add(acc[P], cross(alp, e_p)), cross(wp, cross(wp, e_p)))
            if w_rel is None:
                wc, alc = wp, alp
                vc = add(vc, scale(sd, h))
                ac = add(ac, scale(2.0 * sd, cross(wp, h)))
            else:
                wc, alc = add(wp, w_rel), add(alp, cross(wp, w_rel))
                vc = add(vc, cross(rho_c, w_rel))
            w[C], alpha[C], v[C] = wc, alc, vc
            acc[C] = sub(ac, add(cross(alc, rho_c), cross(wc, cross(wc, rho_c))))
            # columns of D: the parent's moved by omega x l, then the joint's own
            dv, dw = Dv[P][:], Dw[P][:]
            for col in joint.inherited:
                dv[col] = sub(dv[col], cross(link, dw[col]))
            if joint.kind == "revolute":
                dv[c], dw[c] = cross(rho_c, h), h
            elif joint.kind == "prismatic":
                dv[c] = h
            else:
                for n in range(3):
                    dv[c + n], dw[c + n] = cross(rho_c, axes[n]), axes[n]
            Dv[C], Dw[C] = dv, dw
        omega = [rotate_back(A[b], w[b]) for b in range(nb)]  # omega' = A^T omega
        q, qd, D, xi = self.pack(r, v, acc, alpha, p, A, omega, Dv, Dw)
        return TreeMotion(q, qd, D, xi, np.asarray(rates) if self.spherical else velocities, A[:nb], omega)

    def pack(self, r, v, acc, alpha, p, A, omega, Dv, Dw) -> tuple[np.ndarray, ...]:
        """q, q', D and xi as arrays from the bodies' tuples: q' = (r', 1/2 L(p)^T omega') (eq. 8.17), xi of
        omega'' = A^T alpha, each column of D as (v, A^T omega) of every body it moves."""
        nb, k = self.nb, self.k
        columns = [[ZERO6] * k for _ in range(nb)]  # (v, omega') of each body per joint velocity, where not zero
        for b, cols in enumerate(self.moving):
            for col in cols:
                columns[b][col] = Dv[b][col] + rotate_back(A[b], Dw[b][col])
        flat = []  # q, q', xi and the columns of D in one array (one conversion from floats)
        for b in range(nb):
            flat += r[b] + p[b]
        for b in range(nb):
            flat += v[b] + half_l_transpose(p[b], omega[b])
        for b in range(nb):
            flat += acc[b] + rotate_back(A[b], alpha[b])
        for b in range(nb):
            for column in columns[b]:
                flat += column
        out = np.array(flat)
        q, qd, xi = out[: 7 * nb], out[7 * nb : 14 * nb], out[14 * nb : 20 * nb]
        D = out[20 * nb :].reshape(nb, k, 6).transpose(0, 2, 1).reshape(6 * nb, k)
        return q, qd, D, xi

    def joint_state(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The joint state of body coordinates on the constraints, in closed form.

        Revolute: the joint's own rotation a^-1 p_P^-1 p_C c^-1 = (cos theta/2, 0, 0, sin theta/2), so
        theta = 2 atan2(e_3, e_0) (which keeps the sign of p_C); prismatic: s = h^T d with d between the
        two joint points; spherical: e = a^-1 p_P^-1 p_C c^-1 itself. Velocities: h^T (omega_C - omega_P),
        h^T d', and (A_C F_C)^T (omega_C - omega_P).
        """
        nb = self.nb
        X, V = np.zeros((nb + 1, 7)), np.zeros((nb + 1, 7))  # ground's row last: at the origin, not turned
        X[:nb], V[:nb], X[nb, 3] = q.reshape(nb, 7), qd.reshape(nb, 7), 1.0
        p, pd = [tuple(row[3:]) for row in X.tolist()], [tuple(row[3:]) for row in V.tolist()]  # floats, at once
        omega = [np.array(twice_g(p[b], pd[b])) for b in range(nb + 1)]  # eq. 8.16
        positions, velocities = np.empty(self.n_positions), np.empty(self.k)
        for joint in self.joints:
            P, C, at, c = joint.parent, joint.child, joint.position, joint.velocity
            pP, pC = p[P], p[C]
            AC = np.array(rotation9(pC)).reshape(3, 3)
            relative = qmul(qmul(_conjugate(joint.a), qmul(_conjugate(pP), pC)), _conjugate(joint.c))
            w_rel = omega[C] - omega[P]
            if joint.kind == "spherical":
                positions[at : at + 4] = relative
                frame = np.array(joint.frame).T.copy()  # the child's joint axes as columns (np.column_stack's)
                velocities[c : c + 3] = (AC @ frame).T @ w_rel
                continue
            AP = np.array(rotation9(pP)).reshape(3, 3)
            h = AP @ joint.axis
            if joint.kind == "revolute":
                positions[at], velocities[c] = 2.0 * math.atan2(relative[3], relative[0]), h @ w_rel
                continue
            sign = 1.0 if relative[0] >= 0.0 else -1.0  # p and -p are one orientation: keep the given p_C's sign
            joint.u0 = tuple(sign * u for u in qmul(joint.a, joint.c))
            rho_p, rho_c = AP @ joint.s_parent, AC @ joint.s_child
            d = X[C, :3] + rho_c - X[P, :3] - rho_p
            d_dot = V[C, :3] + np.cross(omega[C], rho_c) - V[P, :3] - np.cross(omega[P], rho_p)
            positions[at], velocities[c] = h @ d, h @ d_dot
        return positions, velocities

    def joint_matrix(self, motion: TreeMotion) -> np.ndarray:
        """dq/dtheta (n x k): the v rows of D for r, 1/2 L(p)^T times its omega' rows for p (eq. 8.17)."""
        D = motion.D.reshape(self.nb, 6, self.k)
        out = np.empty((self.nb, 7, self.k))
        for b in range(self.nb):
            out[b, :3] = D[b, :3]
            p = _floats(motion.q[7 * b + 3 : 7 * b + 7])
            out[b, 3:] = np.transpose([half_l_transpose(p, _floats(column)) for column in D[b, 3:].T])
        return out.reshape(7 * self.nb, self.k)

    def coordinate_accelerations(self, motion: TreeMotion, accelerations: np.ndarray) -> np.ndarray:
        """q'' = (r'', p'') from (a, omega'') = D theta'' + xi: p'' = 1/2 L(p)^T omega'' + 1/2 L(p')^T omega'."""
        acc = (motion.D @ accelerations + motion.xi).reshape(self.nb, 6)
        out = np.empty((self.nb, 7))
        for b in range(self.nb):
            p, pd = motion.q[7 * b + 3 : 7 * b + 7], motion.qd[7 * b + 3 : 7 * b + 7]
            out[b, :3] = acc[b, :3]
            out[b, 3:] = np.add(
                half_l_transpose(_floats(p), _floats(acc[b, 3:])), half_l_transpose(_floats(pd), motion.omega[b])
            )
        return out.ravel()


# -- the formulation --------------------------------------------------------------------------------
class JointCoordinates(Formulation):
    """The embedding (velocity-transformation) method in the joint coordinates of a spanning tree (module
    docstring).

    State y = (joint positions, joint velocities); ``rhs`` solves (D^T M D) theta'' = D^T (Q - M xi)
    (k x k) without multipliers for an open tree, and with the cut constraints' rows (``cut``: a System of
    the cut joints and drivers, None for an open tree; stabilized with alpha, beta) for closed loops;
    ``accelerations`` adds lambda of every row, for the reactions.
    """

    name = "joint-coordinates"

    def __init__(self, system: System, M, forces: ForceModel, alpha: float = DEFAULT_ALPHA, beta: float = DEFAULT_BETA):
        reason = supports(system)
        if reason is not None:
            raise AnalysisError(
                f"the joint-coordinates formulation cannot take this scene: {reason}; "
                "choose another formulation (or auto, which picks one that can)"
            )
        super().__init__(system, M, forces, alpha, beta)
        self.joints = tree_joints(system)
        model = system.model
        self.cut = cut_system(system)
        if self.cut is None:
            self.alpha = self.beta = 0.0  # an open tree: no constraint to stabilize
        nb = len(model.bodies)
        self.tree = (PlanarTree if model.dimension == 2 else SpatialTree)(self.joints, nb)
        self.n_positions = self.tree.n_positions
        self._y = self._motion = self._qdd = self._theta_dd = None
        self._forced = bool(getattr(forces, "elements", None) or getattr(forces, "user_forces", None))
        if model.dimension == 3:  # constant: diag(m I, J') per body, and the weights
            self._masses = [float(b.mass) for b in model.bodies]
            inertias = np.array([b.inertia for b in model.bodies], dtype=float).reshape(nb, 9)
            self._inertias = [tuple(inertia) for inertia in inertias.tolist()]
            self._weights = [scale(b.mass, _floats(model.gravity)) for b in model.bodies]

    @functools.cached_property
    def _m(self) -> np.ndarray | None:
        """A planar M's diagonal m where M is diagonal (no nonzero off it: D^T M = D^T * m), else None; made at the
        first numpy evaluation that needs it (``embedded_equations``): a compiled run never does."""
        diagonal = np.diag(self.M)
        return diagonal if np.count_nonzero(self.M) == np.count_nonzero(diagonal) else None

    @functools.cached_property
    def _body_mass(self) -> np.ndarray:
        """diag(m I, J') of every body (6 nb x 6 nb, constant), made at the first numpy evaluation that needs it
        (``embedded_equations``): a compiled run never does (7.5 us of a spatial call's start)."""
        nb = len(self._masses)
        blocks = np.zeros((nb, 6, 6))  # each body's diag(m I, J')
        blocks[:, :3, :3] = np.multiply.outer(self._masses, np.eye(3))
        blocks[:, 3:, 3:] = np.array(self._inertias, dtype=float).reshape(nb, 3, 3)
        return scipy.linalg.block_diag(*blocks)

    def start_over(self) -> None:
        """Forget the last evaluation (joint state, motion, accelerations) and the compiled plan made for it: the
        object then evaluates as a new one made for the same system (a prepared run hands it to its next run,
        ``dynamics.Prepared``; the joints' ``u0`` are set anew by that run's initial state, ``joint_state``)."""
        self._y = self._motion = self._qdd = self._theta_dd = None
        self.__dict__.pop("_compiled_plan", None)
        if self._mass is not None:  # a spatial M(q): the last one evaluated
            self.M = self.masses

    # -- from joint state to bodies, and back
    def motion(self, y: np.ndarray) -> TreeMotion:
        """The bodies' motion at joint state y; the last one is kept (``coordinates``, then ``accelerations``)."""
        if self._y is not None and np.array_equal(y, self._y):
            return self._motion
        k = self.n_positions
        self._motion = self.tree.motion(y[:k], y[k:])
        self._y, self._qdd = y.copy(), None
        return self._motion

    def initial_state(self, q, qd, t):
        positions, velocities = self.tree.joint_state(q, qd)
        return np.concatenate([positions, velocities])

    def coordinates(self, t, y):
        motion = self.motion(y)
        return motion.q, motion.qd

    def joint_matrix(self, y: np.ndarray) -> np.ndarray:
        """D = dq/dtheta (n x k) at joint state y: q' = D theta' (spatial: per joint velocity)."""
        return self.tree.joint_matrix(self.motion(y))

    def convective(self, y: np.ndarray) -> np.ndarray:
        """xi = D' theta' (n,): q'' = D theta'' + xi."""
        motion = self.motion(y)
        return self.tree.coordinate_accelerations(motion, np.zeros(self.tree.k))

    @property
    def cut_rows(self) -> int:
        """The number of cut constraint rows (0 for an open tree: then nothing can drift or turn singular)."""
        return 0 if self.cut is None else self.cut.n_constraints

    # -- the equations of motion in joint coordinates
    def joint_accelerations(self, motion: TreeMotion, t: float) -> np.ndarray:
        """theta'' of the tree (eq. 5.44 with Z = D), or of the augmented system with the cut rows."""
        matrix, rhs = self.embedded_equations(motion, t)
        if self.cut is None:
            try:
                return cholesky_solve(matrix, rhs)
            except np.linalg.LinAlgError as err:
                raise AnalysisError(
                    f"joint coordinates: the mass matrix D^T M D is not positive definite ({err}): "
                    "a body without mass or inertia along a joint's motion"
                ) from None
        psi_theta, gamma = self.cut_equations(motion, t)
        try:
            return augmented_accelerations(matrix, psi_theta, rhs, gamma)[0]
        except np.linalg.LinAlgError:
            raise AnalysisError(
                f"joint coordinates at t = {t:.6g} s: the cut constraints' augmented matrix is singular "
                f"(cut rows of {', '.join(dict.fromkeys(self.cut.row_owners))}): a singular configuration"
            ) from None

    def embedded_equations(self, motion: TreeMotion, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(D^T M D, D^T (Q - M xi)): the tree's equations of motion (eq. 5.44 with Z = D)."""
        D = motion.D
        if self.system.model.dimension == 2:
            Q = self.applied_forces(motion.q, motion.qd, t)
            DtM = D.T * self._m if self._m is not None else D.T @ self.M
            return DtM @ D, D.T @ Q - DtM @ motion.xi
        return D.T @ (self._body_mass @ D), D.T @ self.spatial_forces(motion, t)

    def cut_equations(self, motion: TreeMotion, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(Psi_theta, gamma_theta): the cut rows' acceleration equation Psi_theta theta'' = gamma_theta with
        Psi_theta = Psi_c,q D and gamma_theta = gamma_c - Psi_c,q xi - 2 alpha Psi_c' - beta^2 Psi_c
        (q'' = D theta'' + xi, eq. 5.29), D and xi here as dq/dtheta and q'' at theta'' = 0."""
        q, qd = motion.q, motion.qd
        psi, jacobian, psi_t, gamma = self.cut.evaluate(q, qd, t)
        gamma = baumgarte_gamma(gamma, psi, jacobian @ qd + psi_t, self.alpha, self.beta)
        if self.system.model.dimension == 2:
            return jacobian @ motion.D, gamma - jacobian @ motion.xi
        xi = self.tree.coordinate_accelerations(motion, np.zeros(self.tree.k))
        return jacobian @ self.tree.joint_matrix(motion), gamma - jacobian @ xi

    def spatial_forces(self, motion: TreeMotion, t: float) -> np.ndarray:
        """Q - M xi per body in (v, omega') form: (F - m a, n' - J' omega'' - omega' x J' omega') (Euler's
        equations), with (F, n') from the force model's Q = (Q_r, Q_p): F = Q_r, n' = 1/2 L(p) Q_p (the
        inverse of Q_p = 2 L^T n', eq. 10.10); gravity alone is (m g, 0)."""
        nb = self.tree.nb
        if self._forced:
            Q, q = self.forces.applied_forces(motion.q, motion.qd, t).tolist(), motion.q.tolist()
            loads = [
                (Q[7 * b : 7 * b + 3], half_l(q[7 * b + 3 : 7 * b + 7], Q[7 * b + 3 : 7 * b + 7])) for b in range(nb)
            ]
        else:
            loads = [(weight, ZERO3) for weight in self._weights]
        xi = motion.xi.tolist()
        out = []
        for b in range(nb):
            (force, torque), m, J = loads[b], self._masses[b], self._inertias[b]
            w, a, dw = motion.omega[b], xi[6 * b : 6 * b + 3], xi[6 * b + 3 : 6 * b + 6]
            out += sub(force, scale(m, a))
            out += sub(torque, add(rotate(J, dw), cross(w, rotate(J, w))))
        return np.array(out)

    # -- the integrator's view
    def derivative(self, t, y):
        """(theta', theta'') without lambda, and the bodies' q, q' (kept for ``coordinates`` at the same y)."""
        k = self.n_positions
        self._motion = motion = self.tree.motion(y[:k], y[k:])
        self._y, self._qdd = y.copy(), None
        return np.concatenate([motion.rates, self.joint_accelerations(motion, t)]), motion.q, motion.qd

    def accelerations(self, q, qd, t):
        """q'' = D theta'' + xi, and lambda from Psi_q^T lambda = Q - M q'' (normal equations)."""
        motion = self._motion
        if motion is None or q is not motion.q:  # not the q just made by ``coordinates``
            motion = self.motion(self.initial_state(q, qd, t))
        self._theta_dd = self.joint_accelerations(motion, t)
        self._qdd = qdd = self.tree.coordinate_accelerations(motion, self._theta_dd)
        jacobian = self.system.jacobian(motion.q, t)
        residual = self.applied_forces(motion.q, motion.qd, t) - self.mass(motion.q) @ qdd
        lam = np.linalg.solve(jacobian @ jacobian.T, jacobian @ residual)
        return qdd, lam

    def state_derivative(self, q, qd, qdd):
        motion = self._motion
        if motion is not None and q is motion.q and qdd is self._qdd:
            return np.concatenate([motion.rates, self._theta_dd])
        motion = self.motion(self.initial_state(q, qd, 0.0))
        D = self.tree.joint_matrix(motion)
        xi = self.tree.coordinate_accelerations(motion, np.zeros(self.tree.k))
        theta_dd = np.linalg.lstsq(D, qdd - xi, rcond=None)[0]
        return np.concatenate([motion.rates, theta_dd])


__all__ = [
    "SUPPORTED_JOINTS",
    "JointCoordinates",
    "TreeJoint",
    "build_tree",
    "cut_elements",
    "open_tree",
    "supports",
    "tree_order",
]

FORMULATIONS[JointCoordinates.name] = JointCoordinates  # open trees: joint coordinates, no constraints to keep
