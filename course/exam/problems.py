"""The problem bank of the written test: each problem with its numbers drawn per student, a worked solution
by the hand method of the course notes, and the same answers recomputed with the reference solver.

A problem is four functions: ``draw(rng)`` the numbers of a variant, ``statement(v)`` the text the student
gets, ``solution(v)`` the worked solution (text and answers, computed by the closed forms and hand steps
the notes teach) and ``solver(v)`` the same answers from ``solutions/`` (a model built from the numbers, an
analysis, or the solver's element functions). ``tests/course/test_exam.py`` checks that the two agree for
many variants: a worked solution whose numbers the solver does not confirm is a defect of the bank.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from solutions.assembly import build_system
from solutions.diagnostics import rank_report
from solutions.io.model import load_model
from solutions.kinematics import assemble

Answers = dict[str, float]


@dataclass(frozen=True)
class Problem:
    """One problem of the bank (see the module's docstring)."""

    key: str
    chapter: int
    title: str
    draw: Callable[[np.random.Generator], dict]
    statement: Callable[[dict], str]
    solution: Callable[[dict], tuple[str, Answers]]
    solver: Callable[[dict], Answers]
    tolerance: float = 1e-8
    """Relative tolerance of the comparison (a measured period is less exact than a formula)."""


PROBLEMS: list[Problem] = []


def problem(
    key: str, chapter: int, title: str, draw: Callable, statement: Callable, tolerance: float = 1e-8
) -> Callable:
    """Register a problem: decorates its ``solution``; the ``solver`` is attached with ``.solver``."""

    def register(solution):
        def attach(solver):
            PROBLEMS.append(Problem(key, chapter, title, draw, statement, solution, solver, tolerance))
            return solver

        solution.solver = attach
        return solution

    return register


def pick(rng: np.random.Generator, low: float, high: float, digits: int = 2) -> float:
    """A round number in [low, high]."""
    return round(float(rng.uniform(low, high)), digits)


def fmt(x: float) -> str:
    return f"{x:.6g}"


def planar_model(bodies, joints, motors=(), forces=(), springs=(), gravity=(0.0, -9.81)) -> dict:
    return {
        "model": {
            "name": "exam",
            "dimension": 2,
            "gravity": list(gravity),
            "bodies": list(bodies),
            "joints": list(joints),
            "motors": list(motors),
            "forces": list(forces),
            "spring_dampers": list(springs),
        }
    }


def rod_body(name: str, mass: float, length: float, start, angle: float) -> dict:
    """A uniform rod from ``start`` at ``angle``: its centre of mass and J = m l^2 / 12."""
    centre = np.asarray(start, float) + 0.5 * length * np.array([math.cos(angle), math.sin(angle)])
    return {
        "name": name,
        "mass": mass,
        "inertia": mass * length**2 / 12,
        "location": list(centre),
        "orientation": angle,
    }


# == chapters 1-4: planar kinematics =================================================================================
@problem(
    "point-kinematics",
    2,
    "Velocity and acceleration of a body point",
    draw=lambda rng: {
        "phi": pick(rng, 0.2, 1.4),
        "phid": pick(rng, 1.0, 6.0),
        "phidd": pick(rng, -5.0, 5.0),
        "sx": pick(rng, 0.05, 0.3),
        "sy": pick(rng, -0.1, 0.1),
        "vx": pick(rng, -1.0, 1.0),
        "vy": pick(rng, -1.0, 1.0),
    },
    statement=lambda v: (
        f"A body's centre of mass moves with velocity ({fmt(v['vx'])}, {fmt(v['vy'])}) m/s and no acceleration; the "
        f"body is at angle phi = {fmt(v['phi'])} rad, turning at phi' = {fmt(v['phid'])} rad/s with phi'' = "
        f"{fmt(v['phidd'])} rad/s^2. Point P is at s' = ({fmt(v['sx'])}, {fmt(v['sy'])}) m in the body frame. "
        "Find the velocity and the acceleration of P (eq. 2.11, 2.12)."
    ),
)
def point_kinematics_solution(v: dict) -> tuple[str, Answers]:
    c, s = math.cos(v["phi"]), math.sin(v["phi"])
    As = np.array([c * v["sx"] - s * v["sy"], s * v["sx"] + c * v["sy"]])
    Bs = np.array([-As[1], As[0]])  # B s' = A R s' = (A s') turned by 90 degrees
    vel = np.array([v["vx"], v["vy"]]) + Bs * v["phid"]
    acc = Bs * v["phidd"] - As * v["phid"] ** 2
    text = (
        f"A s' = ({fmt(As[0])}, {fmt(As[1])}); B s' = A R s' = ({fmt(Bs[0])}, {fmt(Bs[1])}).\n"
        f"r^P' = r' + B s' phi' = ({fmt(vel[0])}, {fmt(vel[1])}) m/s.\n"
        f"r^P'' = B s' phi'' - A s' phi'^2 = ({fmt(acc[0])}, {fmt(acc[1])}) m/s^2."
    )
    return text, {"vx": vel[0], "vy": vel[1], "ax": acc[0], "ay": acc[1]}


@point_kinematics_solution.solver
def _(v):
    from solutions.kinematics import point_kinematics

    q, qd = np.array([[0.0, 0.0, v["phi"]]]), np.array([[v["vx"], v["vy"], v["phid"]]])
    qdd = np.array([[0.0, 0.0, v["phidd"]]])
    _, vel, acc = point_kinematics(q, qd, qdd, 0, np.array([v["sx"], v["sy"]]))
    return {"vx": vel[0, 0], "vy": vel[0, 1], "ax": acc[0, 0], "ay": acc[0, 1]}


@problem(
    "revolute-gamma",
    3,
    "The acceleration right-hand side of a revolute joint",
    draw=lambda rng: {
        "phi_i": pick(rng, -1.0, 1.0),
        "phi_j": pick(rng, 0.5, 2.5),
        "w_i": pick(rng, -5.0, 5.0),
        "w_j": pick(rng, -5.0, 5.0),
        "si": (pick(rng, 0.1, 0.4), 0.0),
        "sj": (pick(rng, -0.4, -0.1), pick(rng, -0.05, 0.05)),
    },
    statement=lambda v: (
        f"A revolute joint connects point s_i' = ({fmt(v['si'][0])}, {fmt(v['si'][1])}) m of body i with point "
        f"s_j' = ({fmt(v['sj'][0])}, {fmt(v['sj'][1])}) m of body j. The bodies are at phi_i = {fmt(v['phi_i'])}, "
        f"phi_j = {fmt(v['phi_j'])} rad and turn at phi_i' = {fmt(v['w_i'])}, phi_j' = {fmt(v['w_j'])} rad/s. "
        "Write Psi, Psi_q and compute gamma (eq. 3.17)."
    ),
)
def revolute_gamma_solution(v: dict) -> tuple[str, Answers]:
    def rotate(phi, s):
        return np.array([math.cos(phi) * s[0] - math.sin(phi) * s[1], math.sin(phi) * s[0] + math.cos(phi) * s[1]])

    ai, aj = rotate(v["phi_i"], v["si"]), rotate(v["phi_j"], v["sj"])
    gamma = ai * v["w_i"] ** 2 - aj * v["w_j"] ** 2
    text = (
        "Psi = r_i + A_i s_i' - r_j - A_j s_j', Psi_q = [I, B_i s_i', -I, -B_j s_j'].\n"
        f"A_i s_i' = ({fmt(ai[0])}, {fmt(ai[1])}), A_j s_j' = ({fmt(aj[0])}, {fmt(aj[1])});\n"
        f"gamma = A_i s_i' phi_i'^2 - A_j s_j' phi_j'^2 = ({fmt(gamma[0])}, {fmt(gamma[1])}) m/s^2."
    )
    return text, {"gamma_x": gamma[0], "gamma_y": gamma[1]}


@revolute_gamma_solution.solver
def _(v):
    from solutions.planar.joints import Revolute

    joint = Revolute("R", 0, 1, si=np.array(v["si"], float), sj=np.array(v["sj"], float))
    qi, qj = np.array([0.3, -0.2, v["phi_i"]]), np.array([1.0, 0.5, v["phi_j"]])
    qdi, qdj = np.array([0.7, 0.1, v["w_i"]]), np.array([-0.4, 0.2, v["w_j"]])
    gamma = joint.gamma(qi, qj, qdi, qdj, 0.0)
    return {"gamma_x": gamma[0], "gamma_y": gamma[1]}


@problem(
    "distance-constraint",
    3,
    "A revolute-revolute link: Psi and gamma of the distance constraint",
    draw=lambda rng: _draw_distance(rng),
    statement=lambda v: (
        f"Two particles (points at the centres of mass, s' = 0), not yet assembled, are at relative position d = "
        f"({fmt(v['d'][0])}, {fmt(v['d'][1])}) m, {_apart_or_closing(v)} with d' = ({fmt(v['dd'][0])}, "
        f"{fmt(v['dd'][1])}) m/s. A distance constraint (a link of length L = {fmt(v['L'])} m) is to join them. "
        "Evaluate Psi and gamma of eq. 3.27 at this state: how far is it from assembled?"
    ),
)
def distance_solution(v: dict) -> tuple[str, Answers]:
    d, dd = np.array(v["d"]), np.array(v["dd"])
    psi = 0.5 * (d @ d - v["L"] ** 2)
    gamma = -dd @ dd
    text = (
        f"Psi = (d^T d - L^2) / 2 = ({fmt(d @ d)} - {fmt(v['L'] ** 2)}) / 2 = {fmt(psi)} m^2 (the positions do not "
        f"satisfy the link yet).\nWith s' = 0 and L constant, gamma = -d'^T d' = {fmt(gamma)} m^2/s^2."
    )
    return text, {"psi": psi, "gamma": gamma}


def _draw_distance(rng: np.random.Generator) -> dict:
    """d, d' and a link length L at least 1 cm away from |d| (a state that is not assembled, as the statement says)."""
    d, dd = (pick(rng, 0.2, 0.5), pick(rng, -0.3, 0.3)), (pick(rng, -1.0, 1.0), pick(rng, -1.0, 1.0))
    length = pick(rng, 0.3, 0.5)
    while abs(length - math.hypot(*d)) < 0.01:
        length = pick(rng, 0.3, 0.5)
    return {"d": d, "dd": dd, "L": length}


def _apart_or_closing(v: dict) -> str:
    """What d' does to the distance: d^T d' > 0 moves the particles apart, < 0 closes them in."""
    rate = float(np.dot(v["d"], v["dd"]))
    return "moving apart" if rate > 0 else "closing in" if rate < 0 else "turning about each other"


@distance_solution.solver
def _(v):
    from solutions.functions import Constant
    from solutions.planar.joints import Distance

    link = Distance("link", 0, 1, si=np.zeros(2), sj=np.zeros(2), length=Constant(v["L"]))
    qi, qj = np.array([0.1, 0.2, 0.4]), np.array([0.1 + v["d"][0], 0.2 + v["d"][1], -0.3])
    qdi, qdj = np.array([0.0, 0.0, 3.0]), np.array([v["dd"][0], v["dd"][1], -2.0])
    return {"psi": link.constraints(qi, qj, 0.0)[0], "gamma": link.gamma(qi, qj, qdi, qdj, 0.0)[0]}


EQUATIONS_PER_JOINT = {"revolute": 2, "prismatic": 2, "revolute_prismatic": 1, "gear": 1, "rack_pinion": 1, "cam": 1}
PLANAR_MECHANISMS = ("slider_crank", "four_bar", "six_bar", "quick_return", "gear_train", "rack_pinion", "cam_follower")


def _joints_of(name: str):
    """The example model ``course/models/NAME.yaml``."""
    from course.release.generator import REPO

    return load_model(REPO / "course" / "models" / f"{name}.yaml")


def _describe(name: str) -> str:
    """'the moving bodies a, b and the joints O (revolute), ...' of an example model."""
    model = _joints_of(name)
    joints = ", ".join("{} ({})".format(j["name"], j["type"]) for j in model.joints)
    return f"the bodies {', '.join(b.name for b in model.bodies)} and the joints {joints}"


@problem(
    "degrees-of-freedom",
    1,
    "Counting degrees of freedom",
    draw=lambda rng: {"mechanism": str(rng.choice(PLANAR_MECHANISMS))},
    statement=lambda v: (
        f"The planar mechanism `{v['mechanism']}` has {_describe(v['mechanism'])}. Without its motor, how many "
        "degrees of freedom does it have (eq. 1.2)?"
    ),
)
def dof_solution(v: dict) -> tuple[str, Answers]:
    model = _joints_of(v["mechanism"])
    removed = sum(EQUATIONS_PER_JOINT[j["type"]] for j in model.joints)
    n = 3 * len(model.bodies)
    text = f"n = 3 x {len(model.bodies)} = {n}; the joints remove {removed}; f = {n - removed}."
    return text, {"dof": float(n - removed)}


@dof_solution.solver
def _(v):
    model = _joints_of(v["mechanism"])
    model.motors.clear()
    system, q0, _ = build_system(model)
    return {"dof": float(rank_report(system.jacobian(q0, 0.0), system.row_owners).degrees_of_freedom)}


def slider_crank(r: float, l: float, omega: float) -> dict:
    return planar_model(
        [
            rod_body("crank", 1.0, r, (0, 0), 0.0),
            rod_body("rod", 1.0, l, (r, 0), 0.0),
            {"name": "slider", "mass": 1.0, "inertia": 1e-3, "location": [r + l, 0.0], "orientation": 0.0},
        ],
        [
            {"name": "O", "type": "revolute", "body1": "ground", "body2": "crank", "location": [0.0, 0.0]},
            {"name": "A", "type": "revolute", "body1": "crank", "body2": "rod", "location": [r, 0.0]},
            {"name": "B", "type": "revolute", "body1": "rod", "body2": "slider", "location": [r + l, 0.0]},
            {
                "name": "S",
                "type": "prismatic",
                "body1": "ground",
                "body2": "slider",
                "location": [r + l, 0.0],
                "axis": [1.0, 0.0],
            },
        ],  # fmt: skip
        motors=[
            {
                "name": "drive",
                "type": "angle",
                "joint": "O",
                "function": {"type": "polynomial", "coefficients": [0, omega]},
            }
        ],
    )


def _run_to(spec: dict, t: float, steps: int = 40):
    from solutions.kinematics import kinematic_analysis

    system, q0, _ = build_system(load_model(spec))
    return kinematic_analysis(system, q0, t_end=t, steps=steps, engine="numpy")  # the same figures on every machine


@problem(
    "slider-crank",
    4,
    "Position and velocity analysis of a slider-crank",
    draw=lambda rng: {
        "r": pick(rng, 0.05, 0.12),
        "l": pick(rng, 0.25, 0.4),
        "omega": pick(rng, 5.0, 20.0, 1),
        "theta": pick(rng, 0.3, 2.8),
    },
    statement=lambda v: (
        f"A slider-crank has crank r = {fmt(v['r'])} m and rod l = {fmt(v['l'])} m; the slider moves on the line "
        f"through the crank pivot. The crank turns at {fmt(v['omega'])} rad/s. At the crank angle theta = "
        f"{fmt(v['theta'])} rad, find the slider's position and velocity (eq. 4.5)."
    ),
)
def slider_crank_solution(v: dict) -> tuple[str, Answers]:
    r, l, w, th = v["r"], v["l"], v["omega"], v["theta"]
    root = math.sqrt(l**2 - (r * math.sin(th)) ** 2)
    x = r * math.cos(th) + root
    xd = -r * w * math.sin(th) - r**2 * w * math.sin(th) * math.cos(th) / root
    text = (
        f"x = r cos(theta) + sqrt(l^2 - r^2 sin^2(theta)) = {fmt(x)} m.\n"
        f"x' = -r w sin(theta) - r^2 w sin(theta) cos(theta) / sqrt(l^2 - r^2 sin^2(theta)) = {fmt(xd)} m/s."
    )
    return text, {"x": x, "xd": xd}


@slider_crank_solution.solver
def _(v):
    run = _run_to(slider_crank(v["r"], v["l"], v["omega"]), v["theta"] / v["omega"])
    return {"x": run.coordinate("slider.x")[-1], "xd": run.coordinate("slider.x", 1)[-1]}


def _four_bar_point(a, b, c, d, theta):
    """Coupler-rocker pin B of a four-bar (ground a, crank b, coupler c, rocker d), upper branch."""
    A = b * np.array([math.cos(theta), math.sin(theta)])
    O4 = np.array([a, 0.0])
    e = O4 - A
    dist = np.linalg.norm(e)
    along = (c**2 - d**2 + dist**2) / (2 * dist)
    height = math.sqrt(c**2 - along**2)
    normal = np.array([-e[1], e[0]]) / dist
    return A, A + along * e / dist + height * normal


def four_bar(a, b, c, d, omega) -> dict:
    A, B = _four_bar_point(a, b, c, d, 0.0)
    coupler, rocker = math.atan2(*(B - A)[::-1]), math.atan2(B[1], B[0] - a)
    return planar_model(
        [rod_body("crank", 0.2, b, (0, 0), 0.0), rod_body("coupler", 0.4, c, A, coupler),
         rod_body("rocker", 0.4, d, (a, 0), rocker)],
        [{"name": "O2", "type": "revolute", "body1": "ground", "body2": "crank", "location": [0.0, 0.0]},
         {"name": "A", "type": "revolute", "body1": "crank", "body2": "coupler", "location": list(A)},
         {"name": "B", "type": "revolute", "body1": "coupler", "body2": "rocker", "location": list(B)},
         {"name": "O4", "type": "revolute", "body1": "ground", "body2": "rocker", "location": [a, 0.0]}],
        motors=[{"name": "drive", "type": "angle", "joint": "O2",
                 "function": {"type": "polynomial", "coefficients": [0, omega]}}],
    )  # fmt: skip


@problem(
    "four-bar",
    4,
    "The rocker angle of a crank-rocker four-bar",
    draw=lambda rng: {
        "a": 0.3,
        "b": pick(rng, 0.06, 0.1),
        "c": pick(rng, 0.24, 0.3),
        "d": pick(rng, 0.24, 0.3),
        "theta": pick(rng, 0.5, 5.5),
    },
    statement=lambda v: (
        f"A four-bar has ground link a = {fmt(v['a'])} m (pivots O2 = (0, 0), O4 = (a, 0)), crank b = {fmt(v['b'])} m, "
        f"coupler c = {fmt(v['c'])} m and rocker d = {fmt(v['d'])} m, assembled with the coupler-rocker pin above the "
        f"ground line. Find the rocker's angle (from the x axis, O4 to B) at crank angle theta = {fmt(v['theta'])} rad."
    ),
)
def four_bar_solution(v: dict) -> tuple[str, Answers]:
    A, B = _four_bar_point(v["a"], v["b"], v["c"], v["d"], v["theta"])
    angle = math.atan2(B[1], B[0] - v["a"])
    text = (
        f"A = b (cos theta, sin theta) = ({fmt(A[0])}, {fmt(A[1])}). B lies on the circles |B - A| = c and "
        f"|B - O4| = d: with e = O4 - A, |e| = {fmt(np.linalg.norm(A - [v['a'], 0]))}, B = A + p e/|e| + h n, "
        f"p = (c^2 - d^2 + |e|^2) / (2|e|), h = sqrt(c^2 - p^2), so B = ({fmt(B[0])}, {fmt(B[1])}).\n"
        f"Rocker angle = atan2(B_y, B_x - a) = {fmt(angle)} rad."
    )
    return text, {"rocker": angle}


@four_bar_solution.solver
def _(v):
    run = _run_to(four_bar(v["a"], v["b"], v["c"], v["d"], 10.0), v["theta"] / 10.0, steps=80)
    angle = run.coordinate("rocker.phi")[-1]
    return {"rocker": math.atan2(math.sin(angle), math.cos(angle))}


def pendulum(length: float, mass: float, angle: float = 0.0, driven=None) -> dict:
    motors = []
    if driven is not None:
        motors = [{"name": "drive", "type": "angle", "joint": "O", "function": {"type": "polynomial",
                   "coefficients": list(driven)}}]  # fmt: skip
    return planar_model(
        [rod_body("rod", mass, length, (0, 0), angle)],
        [{"name": "O", "type": "revolute", "body1": "ground", "body2": "rod", "location": [0.0, 0.0]}],
        motors=motors,
    )


@problem(
    "newton-step",
    4,
    "One Newton-Raphson step",
    draw=lambda rng: {
        "c": pick(rng, 0.2, 0.5),
        "theta": pick(rng, 0.3, 1.2),
        "x0": pick(rng, 0.1, 0.3),
        "y0": pick(rng, 0.05, 0.3),
        "phi0": pick(rng, 0.1, 1.0),
    },
    statement=lambda v: (
        f"A rod is pinned at the origin; its centre of mass lies c = {fmt(v['c'])} m from the pin, so that "
        "Psi = [-x + c cos(phi), -y + c sin(phi), phi - theta] = 0 with the driven angle theta = "
        f"{fmt(v['theta'])} rad. From the estimate (x, y, phi) = ({fmt(v['x0'])}, {fmt(v['y0'])}, {fmt(v['phi0'])}), "
        "carry out one Newton-Raphson step (eq. 4.8)."
    ),
)
def newton_solution(v: dict) -> tuple[str, Answers]:
    c, th, x0, y0, p0 = v["c"], v["theta"], v["x0"], v["y0"], v["phi0"]
    dphi = th - p0
    x1 = c * math.cos(p0) - c * math.sin(p0) * dphi
    y1 = c * math.sin(p0) + c * math.cos(p0) * dphi
    residual = (-x0 + c * math.cos(p0), -y0 + c * math.sin(p0), p0 - th)
    text = (
        f"Psi(q0) = ({', '.join(fmt(r) for r in residual)}). "
        "Psi_q = [[-1, 0, -c sin(phi)], [0, -1, c cos(phi)], [0, 0, 1]]. The last row gives dphi = theta - phi0 = "
        f"{fmt(dphi)}; the first two, -dx - c sin(phi0) dphi = x0 - c cos(phi0) and -dy + c cos(phi0) dphi = "
        f"y0 - c sin(phi0).\nq1 = ({fmt(x1)}, {fmt(y1)}, {fmt(th)}) (the error is now of the order of dphi^2)."
    )
    return text, {"x1": x1, "y1": y1, "phi1": th}


@newton_solution.solver
def _(v):
    spec = pendulum(2 * v["c"], 1.0, driven=(v["theta"],))
    system, _, _ = build_system(load_model(spec))
    q = np.array([v["x0"], v["y0"], v["phi0"]])
    q1 = q + np.linalg.solve(system.jacobian(q, 0.0), -system.constraints(q, 0.0))
    return {"x1": q1[0], "y1": q1[1], "phi1": q1[2]}


@problem(
    "gear-pair",
    3,
    "Speed ratio of a gear pair",
    draw=lambda rng: {"R1": pick(rng, 0.02, 0.06, 3), "R2": pick(rng, 0.07, 0.12, 3), "w1": pick(rng, 5.0, 30.0, 1)},
    statement=lambda v: (
        f"Two external spur gears on fixed axles, pitch radii R1 = {fmt(v['R1'])} m and R2 = {fmt(v['R2'])} m; gear 1 "
        f"turns at {fmt(v['w1'])} rad/s. Find the angular velocity of gear 2 (eq. 3.29)."
    ),
)
def gear_solution(v: dict) -> tuple[str, Answers]:
    w2 = -v["R1"] / v["R2"] * v["w1"]
    return f"Rolling without slip: R1 w1 = -R2 w2, so w2 = -R1 w1 / R2 = {fmt(w2)} rad/s.", {"w2": w2}


@gear_solution.solver
def _(v):
    R1, R2 = v["R1"], v["R2"]
    spec = planar_model(
        [{"name": "g1", "mass": 1.0, "inertia": 1e-3, "location": [0.0, 0.0], "orientation": 0.0},
         {"name": "g2", "mass": 1.0, "inertia": 1e-3, "location": [R1 + R2, 0.0], "orientation": 0.0}],
        [{"name": "a1", "type": "revolute", "body1": "ground", "body2": "g1", "location": [0.0, 0.0]},
         {"name": "a2", "type": "revolute", "body1": "ground", "body2": "g2", "location": [R1 + R2, 0.0]},
         {"name": "mesh", "type": "gear", "body1": "g1", "body2": "g2", "point1": [0.0, 0.0],
          "point2": [R1 + R2, 0.0], "radius1": R1, "radius2": R2}],
        motors=[{"name": "drive", "type": "angle", "joint": "a1",
                 "function": {"type": "polynomial", "coefficients": [0, v["w1"]]}}],
    )  # fmt: skip
    return {"w2": _run_to(spec, 0.05, steps=5).coordinate("g2.phi", 1)[-1]}


@problem(
    "rack-pinion",
    3,
    "Rack and pinion",
    draw=lambda rng: {"R": pick(rng, 0.02, 0.08, 3), "w": pick(rng, 2.0, 12.0, 1), "turns": pick(rng, 0.2, 0.9)},
    statement=lambda v: (
        f"A pinion of pitch radius R = {fmt(v['R'])} m on a fixed axle drives a rack. It turns at {fmt(v['w'])} rad/s. "
        f"How far has the rack moved after {fmt(v['turns'])} of a turn, and how fast does it move (eq. 3.31)?"
    ),
)
def rack_solution(v: dict) -> tuple[str, Answers]:
    travel = v["R"] * 2 * math.pi * v["turns"]
    return (
        f"The slide equals the arc rolled: s = R theta = {fmt(v['R'])} x 2 pi x {fmt(v['turns'])} = {fmt(travel)} m; "
        f"v = R w = {fmt(v['R'] * v['w'])} m/s (sense: the pinion rolls along the rack).",
        {"travel": travel, "speed": v["R"] * v["w"]},
    )


@rack_solution.solver
def _(v):
    R = v["R"]
    spec = planar_model(
        [{"name": "pinion", "mass": 1.0, "inertia": 1e-3, "location": [0.0, R], "orientation": 0.0},
         {"name": "rack", "mass": 1.0, "inertia": 1e-2, "location": [0.0, -0.01], "orientation": 0.0}],
        [{"name": "axle", "type": "revolute", "body1": "ground", "body2": "pinion", "location": [0.0, R]},
         {"name": "guide", "type": "prismatic", "body1": "ground", "body2": "rack", "location": [0.0, -0.01],
          "axis": [1.0, 0.0]},
         {"name": "mesh", "type": "rack_pinion", "body1": "rack", "body2": "pinion", "point1": [0.0, 0.0],
          "point2": [0.0, R], "axis": [1.0, 0.0], "radius": R}],
        motors=[{"name": "drive", "type": "angle", "joint": "axle",
                 "function": {"type": "polynomial", "coefficients": [0, v["w"]]}}],
    )  # fmt: skip
    run = _run_to(spec, 2 * math.pi * v["turns"] / v["w"], steps=10)
    x = run.coordinate("rack.x")
    return {"travel": abs(x[-1] - x[0]), "speed": abs(run.coordinate("rack.x", 1)[-1])}


# == chapters 5-7: planar dynamics ===================================================================================
@problem(
    "pendulum-period",
    5,
    "Small oscillations of a physical pendulum",
    draw=lambda rng: {"L": pick(rng, 0.3, 1.5), "m": pick(rng, 0.5, 3.0)},
    statement=lambda v: (
        f"A uniform rod of length L = {fmt(v['L'])} m and mass m = {fmt(v['m'])} kg swings about a pin at one end "
        "(g = 9.81 m/s^2). Find its moment of inertia about the pin (eq. 5.6, 5.8) and the period of small "
        "oscillations."
    ),
    tolerance=2e-4,
)
def period_solution(v: dict) -> tuple[str, Answers]:
    L, m = v["L"], v["m"]
    J_O = m * L**2 / 12 + m * (L / 2) ** 2
    period = 2 * math.pi * math.sqrt(J_O / (m * 9.81 * L / 2))
    text = (
        f"J_O = m L^2 / 12 + m (L/2)^2 = m L^2 / 3 = {fmt(J_O)} kg m^2. Linearized: J_O theta'' + m g (L/2) theta = 0, "
        f"T = 2 pi sqrt(J_O / (m g L / 2)) = 2 pi sqrt(2 L / (3 g)) = {fmt(period)} s."
    )
    return text, {"period": period}


@period_solution.solver
def _(v):
    from solutions.dynamics import forward_dynamics

    amplitude = 0.01  # rad from the hanging position: the period differs from the linear one by 6e-6
    spec = pendulum(v["L"], v["m"], angle=-math.pi / 2 + amplitude)
    system, q0, qd0 = build_system(load_model(spec))
    guess = 2 * math.pi * math.sqrt(2 * v["L"] / (3 * 9.81))
    run = forward_dynamics(
        system, q0, qd0, 1.3 * guess, 260, "baumgarte", "DOP853", rtol=1e-10, atol=1e-12, engine="numpy"
    )
    swing = run.coordinate("rod.phi") + math.pi / 2
    k = np.flatnonzero((swing[:-1] > 0) & (swing[1:] <= 0))  # downward crossings of the hanging position
    up = np.flatnonzero((swing[:-1] < 0) & (swing[1:] >= 0))
    crossing = [run.t[i] - swing[i] * (run.t[i + 1] - run.t[i]) / (swing[i + 1] - swing[i]) for i in (k[0], up[0])]
    return {"period": 2 * (crossing[1] - crossing[0])}


@problem(
    "point-force",
    5,
    "The generalized force of a force on a body",
    draw=lambda rng: {
        "phi": pick(rng, -1.5, 1.5),
        "sx": pick(rng, 0.1, 0.5),
        "sy": pick(rng, -0.1, 0.1),
        "Fx": pick(rng, -50.0, 50.0, 1),
        "Fy": pick(rng, -50.0, 50.0, 1),
    },
    statement=lambda v: (
        f"A force F = ({fmt(v['Fx'])}, {fmt(v['Fy'])}) N (global) acts at the point s' = ({fmt(v['sx'])}, "
        f"{fmt(v['sy'])}) m of a body at angle phi = {fmt(v['phi'])} rad. Find its generalized force Q_i (eq. 5.10)."
    ),
)
def point_force_solution(v: dict) -> tuple[str, Answers]:
    c, s = math.cos(v["phi"]), math.sin(v["phi"])
    Bs = np.array([-s * v["sx"] - c * v["sy"], c * v["sx"] - s * v["sy"]])
    moment = Bs @ [v["Fx"], v["Fy"]]
    text = (
        f"B s' = ({fmt(Bs[0])}, {fmt(Bs[1])}); Q_i = [F; (B s')^T F] = ({fmt(v['Fx'])}, {fmt(v['Fy'])}, "
        f"{fmt(moment)}): the force and its moment about the centre of mass."
    )
    return text, {"Qx": v["Fx"], "Qy": v["Fy"], "Qphi": moment}


@point_force_solution.solver
def _(v):
    from solutions.planar.forces import point_force

    Q = point_force(v["phi"], np.array([v["sx"], v["sy"]]), np.array([v["Fx"], v["Fy"]]))
    return {"Qx": Q[0], "Qy": Q[1], "Qphi": Q[2]}


@problem(
    "spring-force",
    5,
    "Generalized forces of a spring between two bodies",
    draw=lambda rng: {
        "k": pick(rng, 100.0, 2000.0, 0),
        "l0": pick(rng, 0.1, 0.3),
        "xj": pick(rng, 0.3, 0.6),
        "yj": pick(rng, -0.2, 0.2),
        "phi_j": pick(rng, -1.0, 1.0),
        "sj": pick(rng, 0.05, 0.15),
    },
    statement=lambda v: (
        f"A spring (k = {fmt(v['k'])} N/m, free length l0 = {fmt(v['l0'])} m) joins the centre of body i at the origin "
        f"to the point s_j' = ({fmt(v['sj'])}, 0) m of body j, whose centre is at ({fmt(v['xj'])}, {fmt(v['yj'])}) m "
        f"and angle phi_j = {fmt(v['phi_j'])} rad. Find the tension and the generalized forces on both bodies "
        "(eq. 5.12-5.14)."
    ),
)
def spring_solution(v: dict) -> tuple[str, Answers]:
    c, s = math.cos(v["phi_j"]), math.sin(v["phi_j"])
    P = np.array([v["xj"] + c * v["sj"], v["yj"] + s * v["sj"]])
    length = float(np.linalg.norm(P))
    u = P / length
    f = v["k"] * (length - v["l0"])
    Bs = np.array([-s * v["sj"], c * v["sj"]])
    Qj = -f * np.array([u[0], u[1], Bs @ u])
    text = (
        f"P_j = ({fmt(P[0])}, {fmt(P[1])}), l = {fmt(length)} m, u = d/l = ({fmt(u[0])}, {fmt(u[1])}); "
        f"f = k (l - l0) = {fmt(f)} N.\nQ_i = f [u; 0] = ({fmt(f * u[0])}, {fmt(f * u[1])}, 0); "
        f"Q_j = -f [u; (B_j s_j')^T u] = ({fmt(Qj[0])}, {fmt(Qj[1])}, {fmt(Qj[2])})."
    )
    return text, {"f": f, "Qix": f * u[0], "Qiy": f * u[1], "Qjx": Qj[0], "Qjy": Qj[1], "Qjphi": Qj[2]}


@spring_solution.solver
def _(v):
    from solutions.generalized_forces import build_forces
    from solutions.planar.forces import TSDA

    c, s = math.cos(v["phi_j"]), math.sin(v["phi_j"])
    P = [v["xj"] + c * v["sj"], v["yj"] + s * v["sj"]]
    spec = planar_model(
        [{"name": "i", "mass": 1.0, "inertia": 0.01, "location": [0.0, 0.0], "orientation": 0.0},
         {"name": "j", "mass": 1.0, "inertia": 0.01, "location": [v["xj"], v["yj"]], "orientation": v["phi_j"]}],
        [],
        springs=[{"type": "TSDA", "body1": "i", "body2": "j", "point1": [0.0, 0.0], "point2": P,
                  "spring_coefficient": v["k"], "free_length": v["l0"]}],
        gravity=(0.0, 0.0),
    )  # fmt: skip
    model = load_model(spec)
    system, q, _ = build_system(model)
    forces = build_forces(model)
    Q = forces.generalized_forces(q, np.zeros_like(q), 0.0)
    spring = next(e for e in forces.elements if isinstance(e, TSDA))
    length, rate = spring.state(q[:3], q[3:], np.zeros(3), np.zeros(3))
    f = spring.tension(0.0, length, rate)
    return {"f": f, "Qix": Q[0], "Qiy": Q[1], "Qjx": Q[3], "Qjy": Q[4], "Qjphi": Q[5]}


@problem(
    "motor-torque",
    5,
    "Inverse dynamics: the torque that turns a crank at constant speed",
    draw=lambda rng: {
        "L": pick(rng, 0.2, 1.0),
        "m": pick(rng, 0.5, 4.0),
        "w": pick(rng, 1.0, 6.0),
        "theta": pick(rng, -1.5, 1.5),
    },
    statement=lambda v: (
        f"A uniform rod (L = {fmt(v['L'])} m, m = {fmt(v['m'])} kg) is driven about a pin at one end at the constant "
        f"rate {fmt(v['w'])} rad/s in a vertical plane (g = 9.81 m/s^2, angle from the horizontal). Find the motor "
        f"torque and the pin's reaction on the rod at theta = {fmt(v['theta'])} rad (eq. 5.80, 5.70)."
    ),
)
def torque_solution(v: dict) -> tuple[str, Answers]:
    L, m, w, th = v["L"], v["m"], v["w"], v["theta"]
    c = L / 2
    torque = m * 9.81 * c * math.cos(th)
    a = -c * w**2 * np.array([math.cos(th), math.sin(th)])  # centripetal acceleration of the centre
    R = m * a - m * np.array([0.0, -9.81])  # m a = R + m g
    text = (
        f"With theta'' = 0, J_O theta'' = T - m g (L/2) cos(theta), so T = m g (L/2) cos(theta) = {fmt(torque)} N m.\n"
        f"The centre accelerates with -(L/2) w^2 (cos, sin) = ({fmt(a[0])}, {fmt(a[1])}) m/s^2; "
        f"R = m a - m g = ({fmt(R[0])}, {fmt(R[1])}) N."
    )
    return text, {"torque": torque, "Rx": R[0], "Ry": R[1]}


@torque_solution.solver
def _(v):
    from solutions.inverse_dynamics import inverse_dynamics

    spec = pendulum(v["L"], v["m"], angle=v["theta"], driven=(0.0, v["w"]))
    system, q0, _ = build_system(load_model(spec))
    result = inverse_dynamics(system, q0, t_end=1e-3, steps=1)
    return {"torque": result.reactions["drive.effort"][0], "Rx": result.reactions["O.Fx"][0],
            "Ry": result.reactions["O.Fy"][0]}  # fmt: skip


@problem(
    "release-reaction",
    5,
    "The pin reaction at the release of a rod",
    draw=lambda rng: {"L": pick(rng, 0.3, 2.0), "m": pick(rng, 0.5, 5.0)},
    statement=lambda v: (
        f"A uniform rod (L = {fmt(v['L'])} m, m = {fmt(v['m'])} kg), pinned at one end, is released at rest from the "
        "horizontal. Find its angular acceleration and the pin's reaction on it at the instant of release (eq. 5.70)."
    ),
)
def release_solution(v: dict) -> tuple[str, Answers]:
    L, m, g = v["L"], v["m"], 9.81
    alpha = -3 * g / (2 * L)
    Ry = m * g + m * alpha * L / 2
    text = (
        f"J_O alpha = -m g L/2 with J_O = m L^2/3: alpha = -3 g / (2 L) = {fmt(alpha)} rad/s^2. The centre accelerates "
        f"downwards by |alpha| L/2 = {fmt(-alpha * L / 2)} m/s^2, so R_y - m g = m alpha L / 2: R_y = m g / 4 = "
        f"{fmt(Ry)} N, R_x = 0."
    )
    return text, {"alpha": alpha, "Ry": Ry, "Rx": 0.0}


@release_solution.solver
def _(v):
    from solutions.dynamics import forward_dynamics

    system, q0, qd0 = build_system(load_model(pendulum(v["L"], v["m"])))
    run = forward_dynamics(system, q0, qd0, 1e-4, 1, "baumgarte", "DOP853", rtol=1e-12, atol=1e-12, engine="numpy")
    return {"alpha": run.qdd[0, 2], "Ry": run.reactions["O.Fy"][0], "Rx": run.reactions["O.Fx"][0]}


@problem(
    "rk4-step",
    6,
    "One step of the classical Runge-Kutta method",
    draw=lambda rng: {"k": pick(rng, 0.5, 5.0), "y0": pick(rng, 0.5, 2.0), "h": pick(rng, 0.05, 0.4)},
    statement=lambda v: (
        f"Take one RK4 step (eq. 6.12) of size h = {fmt(v['h'])} for y' = -{fmt(v['k'])} y from y(0) = {fmt(v['y0'])}, "
        "and compare with the exact solution."
    ),
)
def rk4_solution(v):
    k, y0, h = v["k"], v["y0"], v["h"]
    k1 = -k * y0
    k2 = -k * (y0 + h / 2 * k1)
    k3 = -k * (y0 + h / 2 * k2)
    k4 = -k * (y0 + h * k3)
    y1 = y0 + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    text = (
        f"k1 = {fmt(k1)}, k2 = {fmt(k2)}, k3 = {fmt(k3)}, k4 = {fmt(k4)}; y1 = y0 + h/6 (k1 + 2 k2 + 2 k3 + k4) = "
        f"{fmt(y1)} (exact {fmt(y0 * math.exp(-k * h))}: y1 = y0 (1 - kh + (kh)^2/2 - (kh)^3/6 + (kh)^4/24))."
    )
    return text, {"y1": y1}


@rk4_solution.solver
def _(v):
    from solutions.integrators import rk4_step

    return {"y1": float(rk4_step(lambda t, y: -v["k"] * y, 0.0, np.array([v["y0"]]), v["h"])[0])}


@problem(
    "consistent-velocity",
    6,
    "Consistent initial velocities",
    draw=lambda rng: {
        "L": pick(rng, 0.4, 1.5),
        "m": pick(rng, 0.5, 3.0),
        "vx": pick(rng, -1.0, 1.0),
        "vy": pick(rng, -1.0, 1.0),
        "w": pick(rng, -3.0, 3.0),
    },
    statement=lambda v: (
        f"A uniform rod (L = {fmt(v['L'])} m, m = {fmt(v['m'])} kg) lies along the x axis, pinned at the origin. The "
        f"given initial velocities (x', y', phi') = ({fmt(v['vx'])}, {fmt(v['vy'])}, {fmt(v['w'])}) violate the pin. "
        "Find the consistent velocities of least kinetic-energy change (eq. 6.2)."
    ),
)
def consistent_solution(v: dict) -> tuple[str, Answers]:
    L, m = v["L"], v["m"]
    c, J = L / 2, m * L**2 / 12
    w = (m * c * v["vy"] + J * v["w"]) / (m * c**2 + J)
    text = (
        f"The pin requires x' = 0 and y' = c phi' (c = L/2). Minimizing m (x' - x0')^2 + m (y' - y0')^2 + J (phi' - "
        f"phi0')^2 on them: x' = 0 and phi' = (m c y0' + J phi0') / (m c^2 + J) = {fmt(w)} rad/s (the angular "
        f"momentum about the pin is kept), y' = c phi' = {fmt(c * w)} m/s."
    )
    return text, {"vx": 0.0, "vy": c * w, "w": w}


@consistent_solution.solver
def _(v):
    from solutions.dynamics import consistent_initial_conditions
    from solutions.mass_matrix import mass_matrix

    model = load_model(pendulum(v["L"], v["m"]))
    system, q0, _ = build_system(model)
    _, qd, _ = consistent_initial_conditions(system, mass_matrix(model), q0, np.array([v["vx"], v["vy"], v["w"]]))
    return {"vx": qd[0], "vy": qd[1], "w": qd[2]}


@problem(
    "baumgarte",
    5,
    "Baumgarte's stabilization of a drifting constraint",
    draw=lambda rng: {"alpha": pick(rng, 2.0, 20.0, 1), "psi0": pick(rng, 1e-3, 1e-2, 4), "t": pick(rng, 0.05, 0.5)},
    statement=lambda v: (
        f"With alpha = beta = {fmt(v['alpha'])} 1/s in eq. 5.29, a constraint error starts at "
        f"Psi(0) = {fmt(v['psi0'])} with Psi'(0) = 0. What is it at t = {fmt(v['t'])} s?"
    ),
)
def baumgarte_solution(v: dict) -> tuple[str, Answers]:
    a, t = v["alpha"], v["t"]
    psi = v["psi0"] * (1 + a * t) * math.exp(-a * t)
    text = (
        "Psi'' + 2 alpha Psi' + alpha^2 Psi = 0 is critically damped: Psi = (A + B t) e^(-alpha t), A = Psi(0), "
        f"B = alpha Psi(0). Psi(t) = Psi(0) (1 + alpha t) e^(-alpha t) = {fmt(psi)}."
    )
    return text, {"psi": psi}


@baumgarte_solution.solver
def _(v):
    from solutions.formulations import baumgarte_gamma
    from solutions.integrators import rk4_step

    def rhs(t, y):  # the error dynamics: Psi'' = gamma_bar - gamma with gamma = 0
        return np.array([y[1], baumgarte_gamma(np.zeros(1), y[:1], y[1:], v["alpha"], v["alpha"])[0]])

    y, steps = np.array([v["psi0"], 0.0]), 400
    for k in range(steps):
        y = rk4_step(rhs, k * v["t"] / steps, y, v["t"] / steps)
    return {"psi": y[0]}


# == chapters 8-10: spatial ==========================================================================================
def _axis(rng) -> tuple[float, float, float]:
    u = rng.standard_normal(3)
    u = np.round(u / np.linalg.norm(u), 2)
    return tuple(float(x) for x in u / np.linalg.norm(u))


@problem(
    "euler-parameters",
    8,
    "Euler parameters and the rotation matrix",
    draw=lambda rng: {"u": _axis(rng), "chi": pick(rng, 0.3, 3.0)},
    statement=lambda v: (
        f"A body is turned by chi = {fmt(v['chi'])} rad about the unit axis u = ({', '.join(fmt(x) for x in v['u'])}). "
        "Give its Euler parameters (eq. 8.10) and the first row of its rotation matrix (eq. 8.8 or 8.12)."
    ),
)
def euler_solution(v: dict) -> tuple[str, Answers]:
    u, chi = np.array(v["u"]), v["chi"]
    p = np.concatenate([[math.cos(chi / 2)], u * math.sin(chi / 2)])
    ut = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    A = np.eye(3) + math.sin(chi) * ut + (1 - math.cos(chi)) * ut @ ut
    text = (
        f"p = (cos(chi/2), u sin(chi/2)) = ({', '.join(fmt(x) for x in p)}).\n"
        f"Rodrigues: A = I + sin(chi) u~ + (1 - cos(chi)) u~^2; first row ({', '.join(fmt(x) for x in A[0])})."
    )
    return text, {"e0": p[0], "e1": p[1], "e2": p[2], "e3": p[3], "A11": A[0, 0], "A12": A[0, 1], "A13": A[0, 2]}


@euler_solution.solver
def _(v):
    from solutions.rotations import from_axis_angle, rotation_matrix

    p = from_axis_angle(np.array(v["u"]), v["chi"])
    A = rotation_matrix(p)
    return {"e0": p[0], "e1": p[1], "e2": p[2], "e3": p[3], "A11": A[0, 0], "A12": A[0, 1], "A13": A[0, 2]}


@problem(
    "angular-velocity",
    8,
    "Angular velocity from Euler-parameter rates",
    draw=lambda rng: {"u": _axis(rng), "chi": pick(rng, 0.3, 3.0), "rate": pick(rng, -5.0, 5.0)},
    statement=lambda v: (
        f"A body turns about the fixed unit axis u = ({', '.join(fmt(x) for x in v['u'])}); at the angle chi = "
        f"{fmt(v['chi'])} rad its rate is chi' = {fmt(v['rate'])} rad/s. Write p and p', and compute omega = 2 G p' "
        "(eq. 8.16)."
    ),
)
def angular_velocity_solution(v: dict) -> tuple[str, Answers]:
    u, chi, rate = np.array(v["u"]), v["chi"], v["rate"]
    pd = 0.5 * rate * np.concatenate([[-math.sin(chi / 2)], u * math.cos(chi / 2)])
    omega = rate * u
    text = (
        "p = (cos(chi/2), u sin(chi/2)), p' = chi'/2 (-sin(chi/2), u cos(chi/2)) = "
        f"({', '.join(fmt(x) for x in pd)}).\n2 G p' = chi' u (sin^2 + cos^2) = "
        f"({', '.join(fmt(x) for x in omega)}) rad/s: the rotation about a fixed axis."
    )
    return text, {"wx": omega[0], "wy": omega[1], "wz": omega[2]}


@angular_velocity_solution.solver
def _(v):
    from solutions.rotations import angular_velocity, from_axis_angle

    u, chi, rate = np.array(v["u"]), v["chi"], v["rate"]
    pd = 0.5 * rate * np.concatenate([[-math.sin(chi / 2)], u * math.cos(chi / 2)])
    w = angular_velocity(from_axis_angle(u, chi), pd)
    return {"wx": w[0], "wy": w[1], "wz": w[2]}


@problem(
    "screw",
    8,
    "The screw of a rigid displacement",
    draw=lambda rng: {
        "chi": pick(rng, 0.4, 2.8),
        "d": (pick(rng, -1.0, 1.0), pick(rng, -1.0, 1.0), pick(rng, -0.5, 0.5)),
    },
    statement=lambda v: (
        f"A body is turned by chi = {fmt(v['chi'])} rad about the global z axis and then moved by d = "
        f"({', '.join(fmt(x) for x in v['d'])}) m. Find the screw axis (a point on it), the angle and the slide "
        "(eq. 8.20)."
    ),
)
def screw_solution(v: dict) -> tuple[str, Answers]:
    chi, d = v["chi"], np.array(v["d"])
    u = np.array([0.0, 0.0, 1.0])
    h = d[2]
    rho = 0.5 * (d - h * u + np.cross(u, d) / math.tan(chi / 2))
    text = (
        f"u = z, slide h = u^T d = {fmt(h)} m. The axis passes through rho = 1/2 (d - h u + cot(chi/2) u x d) = "
        f"({fmt(rho[0])}, {fmt(rho[1])}, 0) m; pitch h / chi = {fmt(h / chi)} m/rad."
    )
    return text, {"h": h, "rho_x": rho[0], "rho_y": rho[1]}


@screw_solution.solver
def _(v):
    from solutions.rotations import rodrigues, screw_parameters

    screw = screw_parameters(rodrigues(np.array([0.0, 0.0, 1.0]), v["chi"]), np.array(v["d"]))
    sign = float(np.sign(screw.axis[2]))
    return {"h": sign * screw.translation, "rho_x": screw.point[0], "rho_y": screw.point[1]}


SPATIAL_EQUATIONS = {"spherical": 3, "universal": 4, "revolute": 5, "cylindrical": 4, "prismatic": 5, "rigid": 6}
SPATIAL_MECHANISMS = ("spatial_slider_crank", "spatial_double_pendulum", "cylindrical", "revolute_revolute_skew",
                      "heavy_top")  # fmt: skip


@problem(
    "spatial-dof",
    9,
    "Degrees of freedom of a spatial mechanism",
    draw=lambda rng: {"mechanism": str(rng.choice(SPATIAL_MECHANISMS))},
    statement=lambda v: (
        f"The spatial mechanism `{v['mechanism']}` has {_describe(v['mechanism'])}. In Euler-parameter coordinates, "
        "how many coordinates and equations (with the normalizations, eq. 9.9) does it have without its motors, and "
        "how many degrees of freedom (eq. 9.14-9.19)?"
    ),
)
def spatial_dof_solution(v: dict) -> tuple[str, Answers]:
    model = _joints_of(v["mechanism"])
    nb = len(model.bodies)
    m = sum(SPATIAL_EQUATIONS[j["type"]] for j in model.joints) + nb
    text = f"n = 7 x {nb} = {7 * nb}; m = joints {m - nb} + {nb} normalizations = {m}; f = {7 * nb - m}."
    return text, {"n": 7.0 * nb, "m": float(m), "dof": 7.0 * nb - m}


@spatial_dof_solution.solver
def _(v):
    model = _joints_of(v["mechanism"])
    model.motors.clear()
    system, q0, _ = build_system(model)
    report = rank_report(system.jacobian(assemble(system, q0)[0], 0.0), system.row_owners)
    return {"n": float(system.n_coordinates), "m": float(system.n_constraints), "dof": float(report.degrees_of_freedom)}


@problem(
    "spatial-kinetic-energy",
    10,
    "Kinetic energy of a spatial body in Euler parameters",
    draw=lambda rng: {
        "m": pick(rng, 0.5, 5.0),
        "J": (pick(rng, 0.01, 0.1, 3), pick(rng, 0.01, 0.1, 3), pick(rng, 0.01, 0.1, 3)),
        "v": (pick(rng, -2.0, 2.0), pick(rng, -2.0, 2.0), pick(rng, -2.0, 2.0)),
        "w": (pick(rng, -5.0, 5.0), pick(rng, -5.0, 5.0), pick(rng, -5.0, 5.0)),
    },
    statement=lambda v: (
        f"A body of mass {fmt(v['m'])} kg with principal moments J' = diag({', '.join(fmt(x) for x in v['J'])}) kg m^2 "
        f"moves with centre velocity ({', '.join(fmt(x) for x in v['v'])}) m/s and body-frame angular velocity "
        f"omega' = ({', '.join(fmt(x) for x in v['w'])}) rad/s; its body frame is aligned with the global one "
        "(p = (1, 0, 0, 0)). Write p' (eq. 8.17) and the kinetic energy (eq. 10.3)."
    ),
)
def spatial_energy_solution(v: dict) -> tuple[str, Answers]:
    m, J, vel, w = v["m"], np.array(v["J"]), np.array(v["v"]), np.array(v["w"])
    T = 0.5 * m * vel @ vel + 0.5 * w @ (J * w)
    text = (
        f"p' = 1/2 L^T omega' = (0, {', '.join(fmt(x / 2) for x in w)}) at p = (1, 0, 0, 0).\n"
        f"T = 1/2 m v^T v + 1/2 omega'^T J' omega' = {fmt(0.5 * m * vel @ vel)} + {fmt(0.5 * w @ (J * w))} "
        f"= {fmt(T)} J."
    )
    return text, {"T": T}


@spatial_energy_solution.solver
def _(v):
    from solutions.rotations import euler_parameter_rates
    from solutions.spatial.mass import kinetic_energy

    spec = {"model": {"name": "body", "dimension": 3, "gravity": [0.0, 0.0, -9.81], "joints": [], "bodies": [
        {"name": "b", "mass": v["m"], "inertia": list(v["J"]), "location": [0.0, 0.0, 0.0],
         "orientation": [1.0, 0.0, 0.0, 0.0]}]}}  # fmt: skip
    model = load_model(spec)
    p = np.array([1.0, 0.0, 0.0, 0.0])
    qd = np.concatenate([v["v"], euler_parameter_rates(p, np.array(v["w"]), frame="body")])
    return {"T": kinetic_energy(model, np.concatenate([[0.0, 0.0, 0.0], p]), qd)}
