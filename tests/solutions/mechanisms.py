"""Mechanisms written for the tests of singular positions and redundant constraints (issue 14), with the
one-degree-of-freedom equations of motion derived by hand from their geometry (not from the solver).

- ``parallelogram_chain(n)``: n parallelogram loops side by side (Gonzalez et al. 2006, problem A03 of the
  IFToMM benchmark library): n + 1 cranks of length L pinned to ground at x = 0, L, ..., n L, their tips
  joined by n couplers of length L. Every bar is a uniform rod (mass m, length L). Released with the cranks
  upright and the tips moving at ``speed`` to +x, it falls under gravity; every loop stays a parallelogram,
  so the cranks turn by one angle theta and the couplers translate. Twice a turn (theta = 0, pi) every bar
  lies on the ground line and Psi_q loses one rank per loop.
- ``sarrus(...)``: the Sarrus linkage, an over-constrained spatial 6R loop: a top plate joined to ground
  by two legs of two links, the three hinge axes of one leg parallel to x, those of the other to y. The
  Gruebler count gives 0 degrees of freedom (6 x 5 - 5 x 6); the geometry gives 1, the plate's height.
- ``bennett(...)``: the Bennett linkage, an over-constrained spatial 4R loop (Bennett 1903): links of alternating
  length and twist with a / sin(alpha) = b / sin(beta). The Gruebler count gives -2 degrees of freedom; the
  geometry gives 1, with a closed-form relation between the joint angles (``bennett_angles``).
"""

from __future__ import annotations

import math

import numpy as np

G = 9.81


# -- the chain of parallelogram loops ----------------------------------------------------------------
def parallelogram_chain(n: int, length: float = 1.0, mass: float = 1.0, speed: float = 1.0, end_time: float = 1.0):
    """The model (a mapping for ``load_model``) of n parallelogram loops, cranks upright, tips at ``speed``."""
    L, m = length, mass
    rod = m * L * L / 12.0
    omega = -speed / L  # theta' < 0: the upright cranks' tips move to +x
    bodies, joints = [], []
    for k in range(n + 1):
        bodies.append(
            {
                "name": f"crank{k}",
                "mass": m,
                "inertia": rod,
                "location": [k * L, L / 2],
                "orientation": math.pi / 2,
                "velocity": [-omega * L / 2, 0.0],
                "angular_velocity": omega,
            }
        )
        joints.append(
            {"name": f"O{k}", "type": "revolute", "body1": "ground", "body2": f"crank{k}", "location": [k * L, 0.0]}
        )
    for k in range(n):
        bodies.append(
            {
                "name": f"coupler{k}",
                "mass": m,
                "inertia": rod,
                "location": [k * L + L / 2, L],
                "orientation": 0.0,
                "velocity": [-omega * L, 0.0],
                "angular_velocity": 0.0,
            }
        )
        joints.append(
            {"name": f"A{k}", "type": "revolute", "body1": f"crank{k}", "body2": f"coupler{k}", "location": [k * L, L]}
        )
        joints.append(
            {
                "name": f"B{k}",
                "type": "revolute",
                "body1": f"crank{k + 1}",
                "body2": f"coupler{k}",
                "location": [(k + 1) * L, L],
            }
        )
    model = {
        "name": f"parallelogram-chain-{n}",
        "dimension": 2,
        "gravity": [0.0, -G],
        "bodies": bodies,
        "joints": joints,
    }
    return {"model": model, "simulation": {"analysis": "dynamic", "end_time": end_time, "output_steps": 100}}


def chain_theta(n: int, t: np.ndarray, length: float = 1.0, speed: float = 1.0, rtol: float = 1e-12) -> np.ndarray:
    """theta(t) of the chain from its own equation of motion, J theta'' = -dV/dtheta, integrated by scipy.

    With every loop a parallelogram: n + 1 cranks turning about their pivots (m L^2 / 3 each) and n
    couplers translating with their tips (m L^2 theta'^2 / 2 each), so with V = m g L sin(theta) ((n+1)/2 + n)

        ((n + 1) / 3 + n) L theta'' = -g cos(theta) ((n + 1) / 2 + n)
    """
    import scipy.integrate

    k = G * ((n + 1) / 2 + n) / (length * ((n + 1) / 3 + n))
    solution = scipy.integrate.solve_ivp(
        lambda _, y: [y[1], -k * math.cos(y[0])],
        (0.0, float(t[-1])),
        [math.pi / 2, -speed / length],
        method="DOP853",
        rtol=rtol,
        atol=1e-14,
        t_eval=t,
    )
    return solution.y[0]


# -- the Sarrus linkage --------------------------------------------------------------------------------
SARRUS = {"L": 0.5, "c": 0.3, "m": 1.0, "m_top": 2.0, "theta0": 0.6}
"""Link length L, half-width c of the plate, link mass m, plate mass m_top, initial link angle from the vertical."""


def sarrus(end_time: float = 1.0, theta0: float = SARRUS["theta0"]):
    """The Sarrus linkage (a mapping for ``load_model``), released at rest with its links theta0 off vertical.

    Leg a lies in the plane x = 0 beside the hinge line y = -c (hinges along x), leg b in the plane
    y = 0 beside x = c (hinges along y); each knee points outwards. The plate (a 2c x 2c square, at
    height z = 2 L cos(theta)) only translates vertically.
    """
    L, c, m, mt = SARRUS["L"], SARRUS["c"], SARRUS["m"], SARRUS["m_top"]
    s, h = L * math.sin(theta0), L * math.cos(theta0)
    rod = [m * L * L / 12.0] * 3  # the same about every axis: m L^2 / 12 about its hinge, whatever its tilt
    plate = [mt * (2 * c) ** 2 / 12.0, mt * (2 * c) ** 2 / 12.0, mt * (2 * c) ** 2 / 6.0]
    bodies = [
        {"name": "a1", "mass": m, "inertia": rod, "location": [0.0, -c - s / 2, h / 2]},
        {"name": "a2", "mass": m, "inertia": rod, "location": [0.0, -c - s / 2, 3 * h / 2]},
        {"name": "top", "mass": mt, "inertia": plate, "location": [0.0, 0.0, 2 * h]},
        {"name": "b2", "mass": m, "inertia": rod, "location": [c + s / 2, 0.0, 3 * h / 2]},
        {"name": "b1", "mass": m, "inertia": rod, "location": [c + s / 2, 0.0, h / 2]},
    ]
    x, y = [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]
    joints = [
        {"name": "A0", "type": "revolute", "body1": "ground", "body2": "a1", "location": [0.0, -c, 0.0], "axis": x},
        {"name": "A1", "type": "revolute", "body1": "a1", "body2": "a2", "location": [0.0, -c - s, h], "axis": x},
        {"name": "A2", "type": "revolute", "body1": "a2", "body2": "top", "location": [0.0, -c, 2 * h], "axis": x},
        {"name": "B2", "type": "revolute", "body1": "top", "body2": "b2", "location": [c, 0.0, 2 * h], "axis": y},
        {"name": "B1", "type": "revolute", "body1": "b2", "body2": "b1", "location": [c + s, 0.0, h], "axis": y},
        {"name": "B0", "type": "revolute", "body1": "b1", "body2": "ground", "location": [c, 0.0, 0.0], "axis": y},
    ]
    model = {"name": "sarrus", "dimension": 3, "gravity": [0.0, 0.0, -G], "bodies": bodies, "joints": joints}
    return {"model": model, "simulation": {"analysis": "dynamic", "end_time": end_time, "output_steps": 100}}


def sarrus_theta(t: np.ndarray, theta0: float = SARRUS["theta0"], rtol: float = 1e-12) -> np.ndarray:
    """The links' angle theta(t) from the vertical, from Lagrange's equation in theta alone, by scipy.

    Per leg: the lower link turns about its ground hinge (J = I + m L^2 / 4); the upper link's centre is at
    (L sin / 2, 3 L cos / 2) in the leg's plane, it turns at -theta'; the plate rises at z' = -2 L sin theta'.
    T = J(theta) theta'^2 / 2, V(theta) = g cos(theta) L (4 m + 2 m_top) (both legs: m L/2 + 3 m L/2 each),
    J(theta) = 2 [2 I + m L^2 / 4 + m L^2 (cos^2 / 4 + 9 sin^2 / 4)] + 4 m_top L^2 sin^2,
    and J theta'' + J'(theta) theta'^2 / 2 + V'(theta) = 0.
    """
    import scipy.integrate

    L, m, mt = SARRUS["L"], SARRUS["m"], SARRUS["m_top"]
    inertia = m * L * L / 12.0

    def J(th):
        return 2 * (2 * inertia + m * L * L / 4 + m * L * L * (math.cos(th) ** 2 / 4 + 9 * math.sin(th) ** 2 / 4)) + (
            4 * mt * L * L * math.sin(th) ** 2
        )

    def dJ(th):
        return 8 * (m + mt) * L * L * math.sin(th) * math.cos(th)

    def dV(th):
        return -G * math.sin(th) * L * (4 * m + 2 * mt)

    def rhs(_, y):
        th, w = y
        return [w, -(0.5 * dJ(th) * w * w + dV(th)) / J(th)]

    solution = scipy.integrate.solve_ivp(
        rhs, (0.0, float(t[-1])), [theta0, 0.0], method="DOP853", rtol=rtol, atol=1e-14, t_eval=t
    )
    return solution.y[0]


# -- the Bennett linkage -------------------------------------------------------------------------------
BENNETT = {"a": 0.3, "alpha": math.pi / 4, "beta": math.pi / 2, "m": 1.0, "theta0": 1.2}
"""Link length a and twist alpha of links 1 and 3, twist beta of links 2 and 4 (their length b from Bennett's
condition, a / sin(alpha) = b / sin(beta)), link mass m, initial angle theta0 of joint J1."""


def _rz(t):
    """Rotation about z by t (real or complex), as a 4 x 4 pose."""
    c, s = np.cos(t), np.sin(t)
    pose = np.eye(4, dtype=np.result_type(c, float))
    pose[:2, :2] = [[c, -s], [s, c]]
    return pose


def _tx_rx(length, twist):
    """Along the link's common normal by ``length``, then about it by the twist (Denavit-Hartenberg)."""
    c, s = math.cos(twist), math.sin(twist)
    return np.array([[1.0, 0.0, 0.0, length], [0.0, c, -s, 0.0], [0.0, s, c, 0.0], [0.0, 0.0, 0.0, 1.0]])


def bennett_angles(theta1):
    """Joint angles (theta1, theta2, theta3, theta4) of the Bennett linkage from the input theta1 (Bennett 1903;
    Baker 1979, Mech. Mach. Theory 14: 'An analysis of the Bennett and Goldberg linkages'), in the
    Denavit-Hartenberg form used here (frame i+1 = frame i Rz(theta_i) Tx(a_i) Rx(alpha_i)):

        tan(theta1 / 2) tan(theta2 / 2) = sin((beta + alpha) / 2) / sin((beta - alpha) / 2),
        theta3 = -theta1,  theta4 = -theta2.

    Works on complex theta1 too (the reference takes derivatives by complex step)."""
    alpha, beta = BENNETT["alpha"], BENNETT["beta"]
    k = math.sin((beta + alpha) / 2) / math.sin((beta - alpha) / 2)
    theta2 = 2 * np.arctan(k / np.tan(theta1 / 2))
    return theta1, theta2, -theta1, -theta2


def bennett_frames(theta1):
    """4 x 4 poses of link 1, 2, 3 (ground is link 4; link i turns about joint J_i, its x axis along the
    common normal to joint J_i+1, a rod of length a_i from J_i) and the frame of joint J4 (fixed in ground)."""
    a, alpha, beta = BENNETT["a"], BENNETT["alpha"], BENNETT["beta"]
    b = a * math.sin(beta) / math.sin(alpha)
    links = [(a, alpha), (b, beta), (a, alpha)]
    frame, poses = np.eye(4), []
    for theta, (length, twist) in zip(bennett_angles(theta1)[:3], links, strict=True):
        pose = frame @ _rz(theta)
        poses.append(pose)
        frame = pose @ _tx_rx(length, twist)
    return poses, frame


def bennett(end_time: float = 1.0, theta0: float = BENNETT["theta0"]):
    """The Bennett linkage (a mapping for ``load_model``): four revolute joints in one spatial loop, links of
    alternating length and twist (a, alpha), (b, beta), (a, alpha), (b, beta) with a / sin(alpha) =
    b / sin(beta); link 4 is ground, J1 the vertical z axis, gravity along -y. Released at rest at
    theta1 = theta0. The Gruebler count gives 6 x 3 - 5 x 4 = -2 degrees of freedom; the geometry gives 1:
    Psi_q (21 coordinates, 23 equations with the three Euler-parameter norms) has rank 20.

    Every link is a rod with the same moment of inertia m a^2 / 12 about every axis (as in ``sarrus``: the
    reference then needs no orientation of the inertia)."""
    a, m = BENNETT["a"], BENNETT["m"]
    b = a * math.sin(BENNETT["beta"]) / math.sin(BENNETT["alpha"])
    poses, j4 = bennett_frames(theta0)
    bodies = []
    for k, (pose, length) in enumerate(zip(poses, (a, b, a), strict=True)):
        centre = pose @ [length / 2, 0.0, 0.0, 1.0]
        bodies.append({"name": f"link{k + 1}", "mass": m, "inertia": [m * a * a / 12.0] * 3,
                       "location": centre[:3].tolist()})  # fmt: skip
    pins = [np.eye(4), poses[0] @ _tx_rx(a, BENNETT["alpha"]), poses[1] @ _tx_rx(b, BENNETT["beta"]), j4]
    pairs = [("ground", "link1"), ("link1", "link2"), ("link2", "link3"), ("link3", "ground")]
    joints = [
        {"name": f"J{k + 1}", "type": "revolute", "body1": one, "body2": two,
         "location": pin[:3, 3].tolist(), "axis": pin[:3, 2].tolist()}
        for k, (pin, (one, two)) in enumerate(zip(pins, pairs, strict=True))
    ]  # fmt: skip
    model = {"name": "bennett", "dimension": 3, "gravity": [0.0, -G, 0.0], "bodies": bodies, "joints": joints}
    return {"model": model, "simulation": {"analysis": "dynamic", "end_time": end_time, "output_steps": 100}}


def bennett_centres(theta1):
    """Centres of mass of links 1, 2, 3 (3 x 3, a row each) at input angle theta1, from the closed form."""
    a = BENNETT["a"]
    b = a * math.sin(BENNETT["beta"]) / math.sin(BENNETT["alpha"])
    poses, _ = bennett_frames(theta1)
    return np.array([(pose @ [length / 2, 0.0, 0.0, 1.0])[:3] for pose, length in zip(poses, (a, b, a), strict=True)])


def bennett_theta(t: np.ndarray, theta0: float = BENNETT["theta0"], rtol: float = 1e-12) -> np.ndarray:
    """theta1(t) from Lagrange's equation in theta1 alone, J(theta) theta'' + J'(theta) theta'^2 / 2 + V'(theta) = 0,
    integrated by scipy. From the closed form (``bennett_angles``, ``bennett_frames``):

        J(theta) = sum over links of m |dc_i/dtheta|^2 + I |w_i|^2,  [w_i]x = (dR_i/dtheta) R_i^T,
        V(theta) = sum over links of m g y_i (c_i the centre, R_i the rotation of link i, I = m a^2 / 12).

    dc_i/dtheta, dR_i/dtheta and V' are taken by complex step (exact to rounding), J' by a five-point
    difference of J (error about 1e-12)."""
    import scipy.integrate

    m, a = BENNETT["m"], BENNETT["a"]
    inertia, h = m * a * a / 12.0, 1e-30

    def J(th):
        poses, _ = bennett_frames(th + 1j * h)
        total = 0.0
        a_, b_ = a, a * math.sin(BENNETT["beta"]) / math.sin(BENNETT["alpha"])
        for pose, length in zip(poses, (a_, b_, a_), strict=True):
            dc = (pose @ [length / 2, 0.0, 0.0, 1.0])[:3].imag / h
            spin = (pose[:3, :3].imag / h) @ pose[:3, :3].real.T
            w = np.array([spin[2, 1], spin[0, 2], spin[1, 0]])
            total += m * dc @ dc + inertia * w @ w
        return total

    def dV(th):
        return m * G * float(np.sum(bennett_centres(th + 1j * h)[:, 1].imag)) / h

    def dJ(th, d=1e-3):
        return (J(th - 2 * d) - 8 * J(th - d) + 8 * J(th + d) - J(th + 2 * d)) / (12 * d)

    def rhs(_, y):
        th, w = y
        return [w, -(0.5 * dJ(th) * w * w + dV(th)) / J(th)]

    solution = scipy.integrate.solve_ivp(
        rhs, (0.0, float(t[-1])), [theta0, 0.0], method="DOP853", rtol=rtol, atol=1e-14, t_eval=t
    )
    return solution.y[0]
