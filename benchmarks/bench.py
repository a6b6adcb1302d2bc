"""``mbd bench``: run time against error for every scene, formulation, integrator and tolerance, beside peers.

For each scene (planar: the double pendulum, the free slider-crank, the four-bar with a spring, Andrews'
squeezing mechanism; spatial: the double pendulum, the carriage pendulum, the skew two-link, the heavy top)
every configuration below is run at several tolerances and judged against a high-accuracy reference that
does not come from the configuration under test:

- minimal coordinates where the scene has them, integrated by DOP853 at rtol = atol = 1e-13: Lagrange's
  equations in the joint angles (double pendulum), the crank-angle equation (slider-crank), the cart
  position and pendulum angle (carriage pendulum), the Euler angles of the heavy symmetric top;
- the published solution at t = 0.03 s (Andrews' mechanism, IVP Test Set);
- otherwise two different formulations at rtol = atol = 1e-12: the joint-coordinate formulation (minimal
  coordinates, open trees) or partitioning, and qr (DOP853); a run is judged against the one that is not
  its own formulation, and their difference is reported.

The error of a run is the largest position error of any body centre on the output grid (m); Andrews' is
the largest error of its seven published angles at the end (rad). Per run: the error, the wall time of
the whole ``forward_dynamics`` call (median of up to ``--repeats`` runs; one for runs over 0.3 s),
right-hand-side evaluations, matrix factorizations (every call of numpy's and scipy's solve, LU,
Cholesky, QR, SVD and lstsq, counted in the first run) and peak memory (tracemalloc's peak, in one
more run over a tenth of the time span, with the same output grid, at the loosest and the tightest setting of
each configuration).

Configurations: every formulation with dop853 (joint-coordinates on the scenes that are open trees);
baumgarte with solve_ivp's RK45, DOP853 and Radau, this package's rk45 and dop853, fixed-step rk4 and the
implicit index-3 HHT; ``auto`` (the method ``choose_method`` picks); and the straightforward path -- the
element loop (``System(..., vectorized=False)``) with solve_ivp's RK45 -- against which the structural gains
are shown. Peers
(``peers.py``: MuJoCo, Exudyn, when installed) run the same scenes in the same run.

Output: ``benchmarks/results/bench.md`` (tables), ``benchmarks/results/<scene>.png`` (work-precision
diagrams), ``benchmarks/results/bench.json`` (every run); the Markdown also goes to standard output and
a progress bar to standard error::

    .venv/bin/python benchmarks/bench.py             # everything, under 10 minutes
    .venv/bin/python benchmarks/bench.py --quick     # smoke run, seconds
    .venv/bin/python benchmarks/bench.py --scene double_pendulum --no-peers
    .venv/bin/python benchmarks/bench.py --stress      # and stress.py beside it, on the second core
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")  # before NumPy is imported: the matrices are small

import argparse  # noqa: E402
import contextlib  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
from collections.abc import Callable  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # noqa: E402
import scipy.linalg  # noqa: E402
import yaml  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from solutions.assembly import System, build_system  # noqa: E402
from solutions.batch import progress_bar  # noqa: E402
from solutions.diagnostics import AnalysisError  # noqa: E402
from solutions.dynamics import (  # noqa: E402
    EquationsOfMotion,
    consistent_initial_conditions,
    forward_dynamics,
    prepare,
)
from solutions.formulations import make_formulation  # noqa: E402
from solutions.generalized_forces import build_forces  # noqa: E402
from solutions.io.model import Model, load_model  # noqa: E402
from solutions.joint_coordinates import open_tree as joint_coordinates_open_tree  # noqa: E402
from solutions.joint_coordinates import supports as joint_coordinates_supports  # noqa: E402
from solutions.kinematics import kinematic_analysis  # noqa: E402
from solutions.mass_matrix import mass_matrix  # noqa: E402
from solutions.rotations import rotation_matrix  # noqa: E402

MODELS = ROOT / "course" / "models"
RESULTS = Path(__file__).resolve().parent / "results"
TARGETS = (1e-6, 1e-9)
PEER_TARGETS = (1e-3, 1e-6, 1e-9)
DIVERGENCE = {"divergence": "check"}
"""Our runs' divergence check (``dynamics.judge_divergence``: a second run at 100 x rtol where the motion can be
chaotic, on by default): ``--divergence skip`` leaves it out, the work the peers do (``chains.DIVERGENCE``)."""
PREPARED = [False]
"""With ``--prepared`` our timed runs are ``prepared.run`` of one ``dynamics.prepare`` per scene, configuration and
setting, its preparation (``prepare`` and a first run, which makes what the runs share) timed apart
(``Run.prepare_seconds``), as the peers' model building is left out of their timing."""
DIVERGENCE_SAID = {
    "check": "with the divergence check (a second run at 100 x rtol where the motion can be chaotic, on by default).",
    "skip": "without the divergence check (`--divergence skip`: the second run at 100 x rtol the peers do not make).",
}
"""The errors of the table against the peers (the issue's three: at 1e-3 the peers' fixed steps are coarse)."""


# -- scenes and their references ------------------------------------------------------------------------------
@dataclass
class Scene:
    """A model, its time span and output grid, its reference and how a run is judged."""

    key: str
    title: str
    source: str | dict  # a file in course/models, or a model mapping
    t_end: float
    outputs: int
    reference: str  # "minimal", "published" or "formulations"
    rk4_steps: tuple[float, ...] = ()
    peers: bool = False
    dimension: int = 2
    model: Model | None = None
    ref_times: np.ndarray | None = None
    ref_positions: np.ndarray | None = None  # (outputs + 1, bodies, dim), or Andrews' 7 end angles
    ref_alternative: np.ndarray | None = None  # the second formulation's reference
    ref_formulation: str = ""  # the formulation of ref_positions, when it is a formulation's run
    ref_note: str = ""

    @property
    def tree(self) -> bool:
        """An open tree of joints: the joint-coordinate formulation takes it with no cut constraint."""
        return joint_coordinates_open_tree(build_system(self.load())[0]) is None

    def load(self) -> Model:
        if self.model is None:
            self.model = load_model(MODELS / self.source if isinstance(self.source, str) else self.source)
            self.dimension = self.model.dimension
        return self.model


def free_slider_crank() -> dict:
    """slider_crank_flywheel.yaml without its gas force and load torque: the coasting engine under gravity."""
    data = yaml.safe_load((MODELS / "slider_crank_flywheel.yaml").read_text())
    data["model"]["forces"] = []
    data["model"]["name"] = "slider-crank-free"
    return data


def body_positions(q: np.ndarray, dimension: int) -> np.ndarray:
    """Body centres (N, nb, dim) from body coordinates (N, n)."""
    per = 3 if dimension == 2 else 7
    q = np.atleast_2d(q)
    return q.reshape(q.shape[0], -1, per)[:, :, :dimension]


def _joint(model: Model, name: str) -> np.ndarray:
    return np.asarray(next(j for j in model.joints if j["name"] == name)["location"], dtype=float)


def _tight(f, y0, times) -> np.ndarray:
    solution = solve_ivp(f, (times[0], times[-1]), y0, method="DOP853", rtol=1e-13, atol=1e-13, t_eval=times)
    return solution.y


def double_pendulum_positions(model: Model, times: np.ndarray) -> np.ndarray:
    """Lagrange's equations in the joint angles theta_1, theta_2 (measured from hanging down):

    M11 t1'' + M12 t2'' + m2 l1 a2 sin(t1 - t2) t2'^2 + (m1 a1 + m2 l1) g sin t1 = 0
    M12 t1'' + M22 t2'' - m2 l1 a2 sin(t1 - t2) t1'^2 + m2 a2 g sin t2 = 0
    M11 = m1 a1^2 + I1 + m2 l1^2, M12 = m2 l1 a2 cos(t1 - t2), M22 = m2 a2^2 + I2 (a: pivot to centre).
    """
    upper, lower = model.bodies
    o, a = _joint(model, "O"), _joint(model, "A")
    g = -float(model.gravity[1])
    l1, a1, a2 = np.linalg.norm(a - o), np.linalg.norm(upper.location - o), np.linalg.norm(lower.location - a)
    m1, m2, i1, i2 = upper.mass, lower.mass, upper.inertia, lower.inertia
    m11, m22 = m1 * a1**2 + i1 + m2 * l1**2, m2 * a2**2 + i2

    def f(t, y):
        t1, t2, w1, w2 = y
        m12, s = m2 * l1 * a2 * math.cos(t1 - t2), m2 * l1 * a2 * math.sin(t1 - t2)
        rhs = [-s * w2 * w2 - (m1 * a1 + m2 * l1) * g * math.sin(t1), s * w1 * w1 - m2 * a2 * g * math.sin(t2)]
        det = m11 * m22 - m12 * m12
        return [w1, w2, (m22 * rhs[0] - m12 * rhs[1]) / det, (m11 * rhs[1] - m12 * rhs[0]) / det]

    def down(v):
        return math.atan2(v[0], -v[1])

    t1, t2 = _tight(f, [down(upper.location - o), down(lower.location - a), 0.0, 0.0], times)[:2]
    e1, e2 = np.stack([np.sin(t1), -np.cos(t1)], 1), np.stack([np.sin(t2), -np.cos(t2)], 1)
    return np.stack([o + a1 * e1, o + l1 * e1 + a2 * e2], axis=1)


def slider_crank_positions(model: Model, times: np.ndarray) -> np.ndarray:
    """The crank-angle equation M(theta) theta'' + C(theta) theta'^2 = Q(theta) of the free engine.

    With the rod angle phi (r sin theta + l sin phi = 0), phi_1 = -r cos(theta) / (l cos phi) and
    phi_2 = (r sin(theta) + l phi_1^2 sin phi) / (l cos phi) its first two derivatives in theta, the rod's
    centre G = A + c (cos phi, sin phi) and the piston x_B = r cos theta + l cos phi give
    M = I_crank + m_rod |G_1|^2 + I_rod phi_1^2 + m_piston x_B1^2, C = m_rod G_1.G_2 + I_rod phi_1 phi_2 +
    m_piston x_B1 x_B2, Q = -m_rod g G_1y (the crank is balanced, the piston slides horizontally).
    """
    crank, rod, piston = model.bodies
    o, a, b = _joint(model, "O"), _joint(model, "A"), _joint(model, "B")
    r, length, c = np.linalg.norm(a - o), np.linalg.norm(b - a), np.linalg.norm(rod.location - a)
    g = -float(model.gravity[1])

    def geometry(theta):
        s, co = math.sin(theta), math.cos(theta)
        sp = -r * s / length
        cp = math.sqrt(1 - sp * sp)
        p1 = -r * co / (length * cp)
        p2 = (r * s + length * p1 * p1 * sp) / (length * cp)
        g1 = np.array([-r * s, r * co]) + c * p1 * np.array([-sp, cp])
        g2 = np.array([-r * co, -r * s]) + c * p2 * np.array([-sp, cp]) - c * p1 * p1 * np.array([cp, sp])
        xb1 = -r * s - length * p1 * sp
        xb2 = -r * co - length * p2 * sp - length * p1 * p1 * cp
        return sp, cp, g1, g2, xb1, xb2, p1, p2

    def f(t, y):
        _, _, g1, g2, xb1, xb2, p1, p2 = geometry(y[0])
        mass = crank.inertia + rod.mass * g1 @ g1 + rod.inertia * p1 * p1 + piston.mass * xb1 * xb1
        coriolis = rod.mass * g1 @ g2 + rod.inertia * p1 * p2 + piston.mass * xb1 * xb2
        return [y[1], (-rod.mass * g * g1[1] - coriolis * y[1] ** 2) / mass]

    theta = _tight(f, [crank.orientation, crank.angular_velocity], times)[0]
    out = np.zeros((times.size, 3, 2))
    for k, th in enumerate(theta):
        sp, cp, *_ = geometry(th)
        pin = o + r * np.array([math.cos(th), math.sin(th)])
        out[k] = [o, pin + c * np.array([cp, sp]), [o[0] + r * math.cos(th) + length * cp, o[1]]]
    return out


def carriage_pendulum_positions(model: Model, times: np.ndarray) -> np.ndarray:
    """Cart position x and pendulum angle theta (about the rail's normal y, from hanging down):

    (M + m) x'' + m a (cos theta theta'' - sin theta theta'^2) + k (x - x0) = 0
    (J + m a^2) theta'' + m a cos theta x'' + m g a sin theta = 0
    with a the pivot-to-centre distance and J the pendulum's moment about its centre and the axis y.
    """
    carriage, pendulum = model.bodies
    spring = model.spring_dampers[0]
    k = float(spring["spring_coefficient"])
    anchor, free = np.asarray(spring["point1"], float), float(spring["free_length"])
    a = float(np.linalg.norm(pendulum.location - carriage.location))
    m_c, m, g = carriage.mass, pendulum.mass, -float(model.gravity[2])
    J = float(np.asarray(pendulum.inertia)[1, 1]) if np.ndim(pendulum.inertia) == 2 else pendulum.inertia[1]

    def f(t, y):
        x, th, v, w = y
        mass = np.array([[m_c + m, m * a * math.cos(th)], [m * a * math.cos(th), J + m * a * a]])
        force = [m * a * math.sin(th) * w * w - k * (x - anchor[0] - free), -m * g * a * math.sin(th)]
        acc = np.linalg.solve(mass, force)
        return [v, w, acc[0], acc[1]]

    v0 = float(carriage.velocity[0])
    x, th = _tight(f, [carriage.location[0], 0.0, v0, 0.0], times)[:2]
    out = np.zeros((times.size, 2, 3))
    out[:, 0, 0] = x
    out[:, 1, 0] = x + a * np.sin(th)
    out[:, 1, 2] = -a * np.cos(th)
    return out


def heavy_top_positions(model: Model, times: np.ndarray) -> np.ndarray:
    """The heavy symmetric top in 3-1-3 Euler angles (precession phi, nutation theta, spin psi) about its tip:

    A theta'' = A phi'^2 sin theta cos theta - C w3 phi' sin theta + m g l sin theta,
    phi' = (p_phi - C w3 cos theta) / (A sin^2 theta),  psi' = w3 - phi' cos theta,
    with w3 and p_phi = A phi' sin^2 theta + C w3 cos theta constant, A = J_1 + m l^2, C = J_3.
    The centre of mass is l (sin theta sin phi, -sin theta cos phi, cos theta).
    """
    (top,) = model.bodies
    inertia = np.asarray(top.inertia, dtype=float)
    inertia = np.diag(inertia) if inertia.ndim == 2 else inertia
    m, g = top.mass, -float(model.gravity[2])
    l = float(np.linalg.norm(top.location))
    A, C = inertia[0] + m * l * l, inertia[2]
    axis = rotation_matrix(np.asarray(top.orientation)) @ np.array([0.0, 0.0, 1.0])
    theta0, phi0 = math.acos(axis[2]), math.atan2(axis[0], -axis[1])
    omega = np.asarray(top.angular_velocity, dtype=float)
    w3 = float(omega @ axis)
    # phi' from the angular velocity's component along z beyond the spin's: omega_z = phi' + psi' cos theta
    phi_dot0 = (omega[2] - w3 * math.cos(theta0)) / math.sin(theta0) ** 2
    p_phi = A * phi_dot0 * math.sin(theta0) ** 2 + C * w3 * math.cos(theta0)
    line = np.array([math.cos(phi0), math.sin(phi0), 0.0])
    theta_dot0 = float(omega @ line)

    def f(t, y):
        th, th_d, ph = y
        s, c = math.sin(th), math.cos(th)
        ph_d = (p_phi - C * w3 * c) / (A * s * s)
        return [th_d, (A * ph_d * ph_d * s * c - C * w3 * ph_d * s + m * g * l * s) / A, ph_d]

    th, _, ph = _tight(f, [theta0, theta_dot0, phi0], times)
    positions = l * np.stack([np.sin(th) * np.sin(ph), -np.sin(th) * np.cos(ph), np.cos(th)], axis=1)
    return positions[:, None, :]


ANDREWS_REFERENCE = np.array(
    [
        15.81077119629904,
        -15.75637105984298,
        0.04082224013073101,
        -0.5347301163226948,
        0.5244099658805304,
        0.5347301163226948,
        1.048080741042263,
    ]
)
"""(beta, Theta, gamma, Phi, delta, Omega, epsilon) at t = 0.03 s: IVP Test Set, andrews.f, subroutine andsoln."""


def andrews_angles(q: np.ndarray) -> np.ndarray:
    p = q[2::3]
    return np.array([p[0], p[1] - p[0], p[2], p[3] - p[4], p[4], p[5] - p[6], p[6]])


MINIMAL = {
    "double_pendulum": double_pendulum_positions,
    "slider_crank": slider_crank_positions,
    "carriage_pendulum": carriage_pendulum_positions,
    "heavy_top": heavy_top_positions,
}


def scenes() -> list[Scene]:
    return [
        Scene(
            "double_pendulum",
            "planar double pendulum",
            "double_pendulum.yaml",
            10.0,
            100,
            "minimal",
            (2e-3, 5e-4),
            peers=True,
        ),
        Scene(
            "slider_crank",
            "free slider-crank (closed loop)",
            free_slider_crank(),
            5.0,
            100,
            "minimal",
            (1e-3, 5e-4),
            peers=True,
        ),
        Scene(
            "four_bar_spring",
            "four-bar with spring-damper-actuator",
            "four_bar_spring.yaml",
            2.0,
            100,
            "formulations",
            (2e-3, 5e-4),
        ),
        Scene("andrews", "Andrews' squeezing mechanism", "andrews.yaml", 0.03, 30, "published", (1e-5, 5e-6)),
        Scene(
            "spatial_double_pendulum",
            "spatial double pendulum",
            "spatial_double_pendulum.yaml",
            5.0,
            100,
            "formulations",
            (2e-3, 5e-4),
            peers=True,
        ),
        Scene(
            "carriage_pendulum",
            "carriage with pendulum (spatial)",
            "carriage_pendulum.yaml",
            3.0,
            100,
            "minimal",
            (5e-3, 1e-3),
        ),
        Scene(
            "revolute_revolute_skew",
            "two links on skew revolute axes (spatial)",
            "revolute_revolute_skew.yaml",
            2.0,
            100,
            "formulations",
            (2e-3, 5e-4),
        ),
        Scene("heavy_top", "heavy symmetric top", "heavy_top.yaml", 1.0, 100, "minimal", (1e-3, 2.5e-4)),
    ]


def prepare_reference(scene: Scene, quick: bool) -> None:
    """The scene's reference on its output grid (or at its end, Andrews')."""
    model = scene.load()
    scene.ref_times = np.linspace(0.0, scene.t_end, scene.outputs + 1)
    if scene.reference == "published":
        scene.ref_positions, scene.ref_note = ANDREWS_REFERENCE, "published solution (IVP Test Set), t = 0.03 s"
        if not quick:  # how far the published values themselves can be trusted: two formulations at 1e-13
            ends = [andrews_angles(run_coordinates(scene, f, "DOP853", 1e-13)[-1]) for f in ("baumgarte", "projection")]
            scene.ref_note += (
                f"; baumgarte and projection at rtol = atol = 1e-13 agree to {np.max(np.abs(ends[0] - ends[1])):.1e} "
                f"rad and both differ from it by {np.max(np.abs(ends[0] - ANDREWS_REFERENCE)):.1e} rad "
                f"({np.max(np.abs(ends[0] - ANDREWS_REFERENCE) / np.abs(ANDREWS_REFERENCE)):.0e} relative): "
                "the precision of the published angles bounds the errors this scene can show"
            )
    elif scene.reference == "minimal":
        scene.ref_positions = MINIMAL[scene.key](model, scene.ref_times)
        scene.ref_note = "minimal coordinates, DOP853 at rtol = atol = 1e-13"
        check = run_positions(scene, "baumgarte", "DOP853", 1e-11)
        scene.ref_note += (
            f"; a baumgarte/DOP853 run at 1e-11 differs by {np.max(np.abs(check - scene.ref_positions)):.1e} m"
        )
    else:
        tol = 1e-10 if quick else 1e-12
        scene.ref_formulation = "joint-coordinates" if scene.tree else "partitioning"
        first = 1e-13 if scene.tree and not quick else tol  # minimal coordinates: no constraint error to floor it
        scene.ref_positions = run_positions(scene, scene.ref_formulation, "DOP853", first)
        scene.ref_alternative = run_positions(scene, "qr", "DOP853", tol)
        difference = float(np.max(np.abs(scene.ref_positions - scene.ref_alternative)))
        scene.ref_note = (
            f"{scene.ref_formulation} (DOP853 at rtol = atol = {first:.0e}) and qr (at {tol:.0e}); "
            f"they differ by {difference:.1e} m"
        )


def run_coordinates(scene: Scene, formulation: str, integrator: str, tol: float) -> np.ndarray:
    system, q0, qd0 = build_system(scene.load())
    result = forward_dynamics(system, q0, qd0, scene.t_end, scene.outputs, formulation, integrator, rtol=tol, atol=tol)
    return result.q


def run_positions(scene: Scene, formulation: str, integrator: str, tol: float) -> np.ndarray:
    return body_positions(run_coordinates(scene, formulation, integrator, tol), scene.dimension)


def run_error(scene: Scene, formulation: str, q: np.ndarray) -> float:
    """Largest position error of any body centre on the grid (m); Andrews': largest angle error at the end (rad)."""
    if scene.reference == "published":
        return float(np.max(np.abs(andrews_angles(q[-1]) - scene.ref_positions)))
    reference = scene.ref_positions
    if formulation == scene.ref_formulation and scene.ref_alternative is not None:
        reference = scene.ref_alternative  # never judge a formulation against itself
    return float(np.max(np.abs(body_positions(q, scene.dimension) - reference)))


# -- counting factorizations ----------------------------------------------------------------------------------
FACTORIZATIONS = [
    (np.linalg, ("solve", "qr", "svd", "lstsq", "cholesky", "inv", "cond")),
    (scipy.linalg, ("lu_factor", "cho_factor", "qr", "svd", "solve", "lstsq")),
]


@contextlib.contextmanager
def counting_factorizations():
    """Count every call of numpy's and scipy's dense factorizations (solve = one LU) while inside."""
    counter = {"n": 0}
    saved = []
    for module, names in FACTORIZATIONS:
        for name in names:
            original = getattr(module, name)
            saved.append((module, name, original))

            def wrapped(*args, _original=original, **kwargs):
                counter["n"] += 1
                return _original(*args, **kwargs)

            setattr(module, name, wrapped)
    try:
        yield counter
    finally:
        for module, name, original in saved:
            setattr(module, name, original)


# -- one run --------------------------------------------------------------------------------------------------
@dataclass
class Config:
    """One way to run a scene."""

    label: str
    formulation: str
    integrator: str
    vectorized: bool = True
    fixed_step: bool = False
    family: str = ""
    engine: str = "numpy"

    def settings(self, tol: float) -> dict:
        common = {"formulation": self.formulation, "integrator": self.integrator, "engine": self.engine, **DIVERGENCE}
        if self.fixed_step:
            return {**common, "step": tol}
        return {**common, "rtol": tol, "atol": tol}


@dataclass
class Run:
    scene: str
    config: str
    family: str
    setting: float
    error: float = float("nan")
    ms: float = float("nan")
    evaluations: int = 0
    us_per_evaluation: float = float("nan")
    steps: int = 0
    factorizations: int = 0
    peak_kib: float = float("nan")
    repeats: int = 0
    failure: str = ""
    chosen: str = ""
    us_per_step: float = float("nan")
    compile_seconds: float = float("nan")  # the compiled engine: its first run in this process (load or compile)
    prepare_seconds: float = float("nan")  # with --prepared: prepare and its first run, outside the timing
    cached: bool = False

    @property
    def ok(self) -> bool:
        return not self.failure and np.isfinite(self.error)


def warm_up(system, q0, qd0, scene: Scene, config: Config, settings: dict, run: Run) -> None:
    """A compiled configuration's first run, outside the timing: it compiles the scene's module (or loads it from
    the cache); its cost goes to ``compile_seconds``. A run the compiled engine does not take is a failure."""
    start = time.perf_counter()
    with np.errstate(all="ignore"):
        result = forward_dynamics(system, q0, qd0, scene.t_end / scene.outputs, 1, **settings)
    run.compile_seconds = time.perf_counter() - start
    run.cached = bool(result.info.get("compiled", {}).get("cached", False))
    if result.info.get("chosen", {}).get("engine") != "compiled":
        run.failure = result.info["chosen"]["engine_why"][:100]


def our_call(system, q0, qd0, scene: Scene, settings: dict, run: Run):
    """Our timed call: ``forward_dynamics``, or with ``--prepared`` ``run`` of one ``prepare`` made here, whose
    preparation and first run go to ``run.prepare_seconds``."""
    if not PREPARED[0]:
        return lambda: forward_dynamics(system, q0, qd0, scene.t_end, scene.outputs, **settings)
    start = time.perf_counter()
    prepared = prepare(system, scene.t_end, scene.outputs, **settings)
    with np.errstate(all="ignore"):
        prepared.run(q0, qd0)
    run.prepare_seconds = time.perf_counter() - start
    return lambda: prepared.run(q0, qd0)


def execute(scene: Scene, config: Config, setting: float, repeats: int, memory: bool = False) -> Run:
    """Timed runs (median wall time), the first also counting factorizations; with ``memory``, one more run
    under tracemalloc for the peak memory."""
    model = scene.load()
    system, q0, qd0 = build_system(model)
    if not config.vectorized:
        system = System(model, system.elements, vectorized=False)
    run = Run(scene.key, config.label, config.family, setting)
    settings = config.settings(setting)
    try:
        if config.engine == "compiled":
            warm_up(system, q0, qd0, scene, config, settings, run)
            if run.failure:
                return run
        call = our_call(system, q0, qd0, scene, settings, run)
        times = []
        while len(times) < max(1, repeats) and (not times or sum(times) < 0.3):
            with np.errstate(all="ignore"), counting_factorizations() if not times else contextlib.nullcontext() as c:
                start = time.perf_counter()
                result = call()
                times.append(time.perf_counter() - start)
            if len(times) == 1:
                run.factorizations = c["n"]
                run.error = run_error(scene, config.formulation, result.q)
                run.evaluations = int(result.info.get("rhs_evaluations", 0))
                run.steps = int(result.info.get("integrator_steps", result.info.get("steps", 0)))
                run.chosen = (result.info.get("chosen") or {}).get("integrator", "")
        run.ms, run.repeats = 1e3 * statistics.median(times), len(times)
        run.us_per_evaluation = 1e3 * run.ms / max(run.evaluations, 1)
        run.us_per_step = 1e3 * run.ms / max(run.steps, 1)
        if memory:  # over a tenth of the span, on the same output grid: the peak does not grow with time
            tracemalloc.start()
            with np.errstate(all="ignore"):
                forward_dynamics(system, q0, qd0, scene.t_end / 10, scene.outputs, **settings)
            run.peak_kib = tracemalloc.get_traced_memory()[1] / 1024
            tracemalloc.stop()
    except (AnalysisError, np.linalg.LinAlgError, FloatingPointError, ValueError) as err:
        if tracemalloc.is_tracing():
            tracemalloc.stop()
        run.failure = str(err).splitlines()[0][:100]
    return run


# -- what each configuration family runs ------------------------------------------------------------------------
FORMULATIONS = ("baumgarte", "partitioning", "qr", "svd", "projection")


RK4_SUBSTEPS = (1, 2, 3, 4, 5, 6, 8, 10, 12, 16)
"""Steps per output interval of our fixed-step runs in joint coordinates on the peers' scenes: h = interval / k, the
grid of the peers' RK4 (``peers.SUBSTEPS``) up to where DOP853 is the cheaper way to the finer errors (a fourth-order
step's error falls as h^4: at 1e-3 on the double pendulum k = 3, 1200 evaluations, as MuJoCo's RK4)."""


def plan(scene: Scene, quick: bool) -> list[tuple[Config, tuple[float, ...]]]:
    """The configurations of a scene and the tolerances (or rk4 steps) each runs at."""
    main = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-11)  # fine near the targets: the cheapest setting there
    two = (1e-6, 1e-9)
    if quick:
        main = two = (1e-5,)
    entries = [
        (Config("baumgarte dop853", "baumgarte", "dop853", family="formulation"), main),
        (
            Config(
                "straightforward: element loop + solve_ivp RK45",
                "baumgarte",
                "RK45",
                vectorized=False,
                family="baseline",
            ),
            (1e-5,) if quick else (1e-5, 1e-7, 1e-9),
        ),
        (Config("auto", "auto", "auto", family="auto"), two),
    ]
    if joint_coordinates_supports(build_system(scene.load())[0]) is None:  # a tree, or closed loops cut
        joint = Config("joint-coordinates dop853", "joint-coordinates", "dop853", family="formulation")
        entries.insert(1, (joint, main))
    baumgarte = Config("compiled baumgarte dop853", "baumgarte", "dop853", family="compiled", engine="compiled")
    compiled = [(baumgarte, main)]
    if joint_coordinates_supports(build_system(scene.load())[0]) is None:
        joint = Config("compiled joint-coordinates dop853", "joint-coordinates", "dop853", family="compiled")
        joint.engine = "compiled"
        compiled.append((joint, main))
        if scene.peers and not quick:  # a fixed step h = output interval / k, as the peers' steps are searched
            rk4 = Config("compiled joint-coordinates rk4", "joint-coordinates", "rk4", fixed_step=True)
            rk4.family, rk4.engine = "compiled", "compiled"
            compiled.append((rk4, tuple(scene.t_end / scene.outputs / k for k in RK4_SUBSTEPS)))
    if quick:  # the compiled engine on the double pendulum only (its module is one the tests compile anyway)
        return entries + (compiled[:1] if scene.key == "double_pendulum" else [])
    entries += compiled
    entries += [
        (Config("compiled projection dop853", "projection", "dop853", family="compiled", engine="compiled"), two),
        (
            Config("compiled baumgarte rk4", "baumgarte", "rk4", fixed_step=True, family="compiled", engine="compiled"),
            scene.rk4_steps,
        ),
    ]
    entries += [(Config(f"{f} dop853", f, "dop853", family="formulation"), two) for f in FORMULATIONS[1:]]
    entries += [
        (Config("baumgarte DOP853 (solve_ivp)", "baumgarte", "DOP853", family="integrator"), (1e-5, 1e-7, 1e-9)),
        (Config("baumgarte RK45 (solve_ivp)", "baumgarte", "RK45", family="integrator"), (1e-6, 1e-8)),
        (Config("baumgarte rk45", "baumgarte", "rk45", family="integrator"), (1e-6, 1e-8)),
        (Config("baumgarte Radau", "baumgarte", "Radau", family="integrator"), (1e-6,)),
        (Config("hht (index 3)", "baumgarte", "hht", family="integrator"), (1e-4, 1e-6)),
        (Config("baumgarte rk4", "baumgarte", "rk4", fixed_step=True, family="integrator"), scene.rk4_steps),
        (Config("element loop + dop853", "baumgarte", "dop853", vectorized=False, family="baseline"), (1e-9,)),
    ]
    return entries


# -- microseconds per right-hand side, and what skipping saves ------------------------------------------------------
def microseconds(fn: Callable[[], object], minimum: float = 0.05) -> float:
    """Best of five timings of fn, each at least ``minimum`` seconds long."""
    calls = 1
    while True:
        start = time.perf_counter()
        for _ in range(calls):
            fn()
        elapsed = time.perf_counter() - start
        if elapsed >= minimum or calls > 100000:
            break
        calls *= 4
    best = elapsed / calls
    for _ in range(4):
        start = time.perf_counter()
        for _ in range(calls):
            fn()
        best = min(best, (time.perf_counter() - start) / calls)
    return 1e6 * best


def rhs_costs(scene: Scene, quick: bool) -> dict:
    """us per right-hand side of each formulation, element loop against per-type evaluation, and the parts."""
    model = scene.load()
    system, q0, qd0 = build_system(model)
    loop = System(model, system.elements, vectorized=False)
    M, forces = mass_matrix(model), build_forces(model)
    q, qd, _ = consistent_initial_conditions(system, M, q0, qd0)
    out = {"formulations": {}}
    minimum = 0.01 if quick else 0.05
    names = ("baumgarte",) if quick else FORMULATIONS
    for name in names + (("joint-coordinates",) if scene.tree else ()):
        for label, sys_ in (("loop", loop), ("vectorized", system)):
            equations = EquationsOfMotion(make_formulation(name, sys_, M, forces), forces, bool(model.motors))
            y = equations.initial_state(q, qd, 0.0)
            states = [y, y * (1 + 1e-9)]  # alternate: the system keeps its last configuration, as in a run
            out["formulations"][(name, label)] = (
                microseconds(lambda e=equations, s=states: (e.rhs(0.01, s[0]), e.rhs(0.01, s[1])), minimum) / 2
            )
    q2 = q * (1 + 1e-9)  # a second state, so that no cached configuration is reused

    def twice(fn):
        return lambda: (fn(q), fn(q2))

    parts = {
        "Psi_q (element loop, slices)": twice(lambda x: loop.jacobian(x, 0.01)),
        "Psi_q (per type, scattered)": twice(lambda x: system.jacobian(x, 0.01)),
        "Psi, Psi_q, Psi_t, gamma (element loop)": twice(lambda x: loop.evaluate(x, qd, 0.01)),
        "Psi, Psi_q, Psi_t, gamma (one pass per type)": twice(lambda x: system.evaluate(x, qd, 0.01)),
        "M built anew": twice(lambda x: mass_matrix(model) if model.dimension == 2 else M(x)),
        "Q by the force loop": twice(lambda x: forces.generalized_forces(x, qd, 0.01)),
    }
    out["parts"] = {label: microseconds(fn, minimum) / 2 for label, fn in parts.items()}
    out["groups"] = [type(g).__name__ for g in system.groups]
    out["loop_elements"] = len(system._loop)
    out["has_force_elements"] = not forces.is_constant
    return out


def kinematic_step(quick: bool) -> dict:
    """us per kinematic time step of the driven slider-crank (slider_crank.yaml, one crank turn, 200 steps)."""
    model = load_model(MODELS / "slider_crank.yaml")
    system, q0, _ = build_system(model)
    loop = System(model, system.elements, vectorized=False)
    t_end, steps = float(model.simulation.get("end_time", 0.6283)), int(model.simulation.get("output_steps", 200))
    out = {}
    runs = (("element loop", loop, "numpy"), ("per type", system, "numpy"), ("compiled", system, "compiled"))
    for label, sys_, engine in runs:
        kinematic_analysis(sys_, q0, t_end, steps, engine=engine)  # the compiled engine: compile or load, untimed
        best = float("inf")
        for _ in range(1 if quick else 5):
            start = time.perf_counter()
            kinematic_analysis(sys_, q0, t_end, steps, engine=engine)
            best = min(best, time.perf_counter() - start)
        out[label] = 1e6 * best / (steps + 1)
    return out


# -- progress ----------------------------------------------------------------------------------------------------
def _step(bar, label: str) -> None:
    """One run done on the progress bar (``solutions.batch.progress_bar``), labelled with what comes next."""
    bar.set_postfix_str(label[:60], refresh=False)
    bar.update(1)


# -- tables and diagrams -------------------------------------------------------------------------------------------
def fmt(x: float, spec: str = ".1e") -> str:
    return "" if x is None or not np.isfinite(x) else format(x, spec)


def run_table(runs: list[Run], unit: str) -> list[str]:
    lines = [
        f"| configuration | rtol = atol (rk4: step) | error ({unit}) | time (ms) | rhs evaluations | us/evaluation "
        "| steps | factorizations | peak memory (KiB) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in runs:
        label = r.config + (f" -> {r.chosen}" if r.chosen else "")
        if r.failure:
            lines.append(f"| {label} | {r.setting:.0e} | failed: {r.failure} | | | | | | |")
            continue
        lines.append(
            f"| {label} | {r.setting:.0e} | {fmt(r.error)} | {fmt(r.ms, '.1f')} | {r.evaluations} | "
            f"{fmt(r.us_per_evaluation, '.0f')} | {r.steps} | {r.factorizations} | {fmt(r.peak_kib, '.0f')} |"
        )
    return lines


def fastest(runs: list, target: float):
    """The fastest run with error <= target (None if none reaches it)."""
    good = [r for r in runs if r.ok and r.error <= target]
    return min(good, key=lambda r: r.ms) if good else None


def work_precision_plot(scene: Scene, runs: list[Run], peer_runs: list, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10.5, 5.5))
    colours = plt.get_cmap("tab20").colors + plt.get_cmap("tab20b").colors
    ax.set_prop_cycle(color=colours)  # a colour per configuration: with the peers' there are up to 30
    series: dict[str, list] = {}
    for r in runs:
        if r.ok and r.error > 0:
            series.setdefault(r.config, []).append((r.error, r.ms))
    for r in peer_runs:
        if r.ok and r.error > 0:
            series.setdefault(f"{r.config}", []).append((r.error, r.ms))
    for label, points in sorted(series.items()):
        points.sort()
        style = "--" if label.startswith(("MuJoCo", "Exudyn")) else "-"
        marker = "s" if "straightforward" in label else ("^" if style == "--" else "o")
        ax.loglog([p[0] for p in points], [p[1] for p in points], style, marker=marker, label=label, markersize=4)
    for target in TARGETS:
        ax.axvline(target, color="grey", lw=0.6, ls=":")
    unit = "rad" if scene.reference == "published" else "m"
    ax.set_xlabel(f"max error ({unit})")
    ax.set_ylabel("wall time (ms)")
    ax.set_title(f"{scene.title}, 0 .. {scene.t_end} s")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=6, loc="center left", bbox_to_anchor=(1.01, 0.5))  # beside the axes: no curve hidden
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def ms(run) -> str:
    """A run's time in the summary: whole milliseconds, tenths below 10 ms."""
    return fmt(run.ms, ".1f" if run.ms < 10 else ".0f") if run else ""


def summary_table(all_scenes, runs_by_scene, peers_by_scene) -> list[str]:
    """Ours (both engines, and the numpy engine alone) at 1e-6 and 1e-9, the straightforward path, the peers."""
    header = (
        "| scene | fastest to 1e-6 | time (ms) | fastest to 1e-9 | time (ms) | numpy engine to 1e-6 (ms) "
        "| numpy engine to 1e-9 (ms) | straightforward to 1e-6 (ms) | gain |"
    )
    lines = [header, "|" + "---|" * 9]
    for scene in all_scenes:
        runs = runs_by_scene.get(scene.key, [])
        if not runs:
            continue
        own = [r for r in runs if r.family != "baseline"]
        numpy_engine = [r for r in own if r.family != "compiled"]
        best6, best9 = fastest(own, 1e-6), fastest(own, 1e-9)
        base = fastest([r for r in runs if r.config.startswith("straightforward")], 1e-6)
        cells = [
            scene.title,
            f"{best6.config} {best6.setting:.0e}" if best6 else "not reached",
            ms(best6),
            f"{best9.config} {best9.setting:.0e}" if best9 else "not reached",
            ms(best9),
            ms(fastest(numpy_engine, 1e-6)) or "not reached",
            ms(fastest(numpy_engine, 1e-9)) or "not reached",
            ms(base) or "not reached",
            f"{base.ms / best6.ms:.1f}x" if base and best6 else "",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


@dataclass
class Pair:
    """Our fastest run to a target against a peer's fastest, timed again in interleaved rounds (``paired_rounds``)."""

    scene: str
    peer: str
    target: float
    ours: str
    theirs: str
    ratios: list[float]


def paired_rounds(scene: Scene, own: list[Run], tried: list, configs: dict, families: dict, rounds: int) -> list[Pair]:
    """For each peer and target of ``PEER_TARGETS``: our fastest run to the target (``configs``: our configurations
    by label) and the peer's fastest (``families``: its configurations by label), timed again in ``rounds``
    interleaved rounds (``peers.interleaved``: one call of each a round, the order alternating). Ours: the call
    ``execute`` times (``our_call``: the whole ``forward_dynamics``, or with ``--prepared`` ``prepared.run``), wall
    time; the peer's: its simulation, as its search timed it."""
    from benchmarks.peers import interleaved

    system, q0, qd0 = build_system(scene.load())
    pairs = []
    for peer in sorted({r.config.split(" ")[0] for r in tried}):
        for target in PEER_TARGETS:
            ours = fastest([r for r in own if r.family != "baseline"], target)
            theirs = fastest([r for r in tried if r.config.startswith(peer)], target)
            if ours is None or theirs is None:
                continue
            call = our_call(system, q0, qd0, scene, configs[ours.config].settings(ours.setting), Run("", "", "", 0))

            def timed(call=call) -> float:
                start = time.perf_counter()
                with np.errstate(all="ignore"):
                    call()
                return time.perf_counter() - start

            family = families[theirs.config]
            ratios = interleaved(timed, lambda f=family, h=theirs.setting: f.attempt(h)[0], rounds)
            label = f"{ours.config} {ours.setting:.0e}"
            pairs.append(Pair(scene.key, peer, target, label, theirs.described, ratios))
    return pairs


def peer_table(all_scenes, runs_by_scene, peers_by_scene, pairs: list[Pair] = ()) -> list[str]:
    """ours / peer at 1e-3, 1e-6 and 1e-9 (``peers.TARGETS``): our fastest run (either engine) over the peer's
    fastest configuration of its wide search (``peers.search``), same scene, same run; with ``pairs``
    (``paired_rounds``) the ratio is the median of the interleaved rounds, its range beside it."""
    paired = {(p.scene, p.peer, p.target): p.ratios for p in pairs}
    peer_names = sorted({r.config.split(" ")[0] for runs in peers_by_scene.values() for r in runs})
    if not peer_names:
        return ["No peer installed (`pip install -e .[bench]`: MuJoCo, Exudyn)."]
    targets = PEER_TARGETS
    header = "| scene | peer |" + "".join(
        f" peer to {t:g} (ms) | ours to {t:g} (ms) | ours / peer at {t:g} |" for t in targets
    )
    lines = [header, "|---|---|" + "---|---:|---:|" * len(targets)]
    for scene in all_scenes:
        if not scene.peers or scene.key not in runs_by_scene:
            continue
        own = [r for r in runs_by_scene[scene.key] if r.family != "baseline"]
        for p in peer_names:
            tried = [r for r in peers_by_scene.get(scene.key, []) if r.config.startswith(p)]
            if not tried:
                continue
            cells = [scene.title, p]
            for target in targets:
                peer, ours = fastest(tried, target), fastest(own, target)
                cells += [
                    f"{ms(peer)} ({peer.described})" if peer else "not reached",
                    ms(ours) or "not reached",
                    ratio_cell(ours, peer, paired.get((scene.key, p, target))),
                ]
            lines.append("| " + " | ".join(cells) + " |")
    return lines


def ratio_cell(ours, peer, ratios: list[float] | None) -> str:
    """ours / peer: the paired rounds' median (lowest-highest), else the ratio of the two medians."""
    if not (peer and ours):
        return "ours only" if ours else ""
    if not ratios:
        return f"{ours.ms / peer.ms:.2f}"
    return f"{statistics.median(ratios):.2f} ({min(ratios):.2f}-{max(ratios):.2f})"


def compiled_table(all_scenes, runs_by_scene) -> list[str]:
    """The compiled engine per scene and configuration: its first run (compiling the scene's module when the
    cache is empty) apart from the warm runs, and microseconds per right-hand side and per step of those."""
    lines = [
        "| scene | configuration | first run (s) | module | rtol (rk4: step) | error | time (ms) "
        "| evaluations | us per evaluation | steps | us per step |",
        "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for scene in all_scenes:
        by_config: dict[str, list[Run]] = {}
        for r in runs_by_scene.get(scene.key, []):
            if r.family == "compiled":
                by_config.setdefault(r.config, []).append(r)
        for config, runs in by_config.items():
            first = runs[0]
            if first.failure and not np.isfinite(first.compile_seconds):
                lines.append(f"| {scene.title} | {config} | | failed: {first.failure} | | | | | | | |")
                continue
            if first.failure:
                lines.append(f"| {scene.title} | {config} | | {first.failure} | | | | | | | |")
                continue
            good = [r for r in runs if r.ok and r.error <= 1e-6] or [r for r in runs if r.ok]
            r = min(good, key=lambda x: x.ms) if good else first
            lines.append(
                f"| {scene.title} | {config} | {fmt(first.compile_seconds, '.2f')} | "
                f"{'loaded from the cache' if first.cached else 'compiled'} | {r.setting:.0e} | {fmt(r.error)} | "
                f"{ms(r)} | {r.evaluations} | {fmt(r.us_per_evaluation, '.1f')} | {r.steps} | "
                f"{fmt(r.us_per_step, '.1f')} |"
            )
    return lines


# -- main ---------------------------------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if "--scaling" in argv:  # the scaling study instead, with its own options (chains.py)
        try:
            from benchmarks import chains
        except ImportError:  # run as a script from benchmarks/
            import chains  # type: ignore[no-redef]
        return chains.main([a for a in argv if a != "--scaling"])
    if "--processes" in argv:  # the whole-process table instead (processes.py)
        try:
            from benchmarks import processes
        except ImportError:  # run as a script from benchmarks/
            import processes  # type: ignore[no-redef]
        return processes.main([a for a in argv if a != "--processes"])
    parser = argparse.ArgumentParser(prog="mbd bench", description=__doc__.splitlines()[0])
    parser.add_argument(
        "--scaling",
        action="store_true",
        help="the scaling study instead: chains of N = 2 ... 64 bodies, with MuJoCo in paired rounds (benchmarks/"
        "chains.py; its own options: mbd bench --scaling --help)",
    )
    parser.add_argument(
        "--processes",
        action="store_true",
        help="the whole-process table instead: default mbd run against a MuJoCo program as accurate, per peer scene "
        "(benchmarks/processes.py; mbd bench --processes --help)",
    )
    parser.add_argument("--quick", action="store_true", help="smoke run: two short scenes, one tolerance")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per entry (median); 1 for runs over 0.5 s")
    parser.add_argument("--scene", action="append", help="only these scenes (keys: double_pendulum, slider_crank, ...)")
    parser.add_argument("--no-peers", action="store_true", help="skip MuJoCo and Exudyn even when installed")
    parser.add_argument("--out", type=Path, default=RESULTS, help="folder for bench.md, bench.json and the PNGs")
    parser.add_argument(
        "--divergence",
        choices=("check", "skip"),
        default="check",
        help="our runs' divergence check (a second run at 100 x rtol; default: on, as a user's); skip: the peers' work",
    )
    parser.add_argument(
        "--rounds",
        type=int,
        default=7,
        help="interleaved rounds of our fastest run against each peer's fastest, per target (0: the ratio of the "
        "two medians instead)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar on standard error")
    parser.add_argument(
        "--prepared",
        action="store_true",
        help="time ours as prepared.run of one dynamics.prepare (its preparation apart, as the peers' model building)",
    )
    parser.add_argument(
        "--keep-cache",
        dest="fresh_cache",
        action="store_false",
        help="keep the compiled engine's cache (default: an empty one, so that its compile time is measured)",
    )
    parser.add_argument(
        "--stress",
        action="store_true",
        help="also run the stress study (stress.py -> stress.md) in a second process, on the other core",
    )
    args = parser.parse_args(argv)
    DIVERGENCE["divergence"], PREPARED[0] = args.divergence, args.prepared
    stress = start_stress_study(args.out, args.quick) if args.stress else None
    cache = None
    if args.fresh_cache:  # the compiled engine compiles every scene's module anew: its compile time is measured
        import tempfile

        cache = tempfile.TemporaryDirectory(prefix="mbd-bench-compiled-")
        os.environ["MBD_COMPILED_CACHE"] = cache.name

    chosen = [s for s in scenes() if not args.scene or s.key in args.scene]
    if args.scene and not chosen:
        parser.error(f"unknown scene(s) {args.scene}; one of: {', '.join(s.key for s in scenes())}")
    if args.quick:
        chosen = [s for s in chosen if s.key in ("double_pendulum", "heavy_top")] or chosen[:1]
        for s in chosen:
            s.t_end, s.outputs = min(s.t_end, 1.0), 20
    args.out.mkdir(parents=True, exist_ok=True)
    peers = None
    if not args.no_peers:
        try:
            from benchmarks import peers as peers_module
        except ImportError:  # run as a script from benchmarks/
            import peers as peers_module  # type: ignore[no-redef]
        peers = peers_module
    plans = {s.key: plan(s, args.quick) for s in chosen}
    total = sum(len(settings) for entries in plans.values() for _, settings in entries) + 2 * len(chosen) + 1
    if peers is not None:  # a peer's scan stops where it reaches 1e-9: its length is known only as it goes
        total += sum(len(peers.families(s, args.quick)) for s in chosen if s.peers)
    with progress_bar(total, "bench", not args.no_progress, unit="run") as progress:
        start = time.perf_counter()

        runs_by_scene: dict[str, list[Run]] = {}
        peers_by_scene: dict[str, list] = {}
        costs: dict[str, dict] = {}
        pairs: list[Pair] = []
        for scene in chosen:
            prepare_reference(scene, args.quick)
            _step(progress, f"{scene.key}: reference")
            costs[scene.key] = rhs_costs(scene, args.quick)
            _step(progress, f"{scene.key}: us per rhs")
            runs = []
            for config, settings in plans[scene.key]:
                for k, setting in enumerate(settings):
                    _step(progress, f"{scene.key}: {config.label} {setting:.0e}")
                    memory = k in (0, len(settings) - 1) and config.family != "baseline"
                    runs.append(execute(scene, config, setting, args.repeats, memory))
            runs_by_scene[scene.key] = runs
            if peers is not None and scene.peers:
                families = {family.label for family in peers.families(scene, args.quick)}

                def scanned(run, scene=scene, families=families):
                    if run.config in families:  # the family's first attempt: one step of the bar per family
                        families.discard(run.config)
                        _step(progress, f"{scene.key}: {run.config}")

                peers_by_scene[scene.key] = peers.search(scene, args.quick, args.repeats, scanned)
                if args.rounds:
                    configs = {config.label: config for config, _ in plans[scene.key]}
                    families = {family.label: family for family in peers.families(scene, args.quick)}
                    pairs += paired_rounds(scene, runs, peers_by_scene[scene.key], configs, families, args.rounds)
        kinematic = kinematic_step(args.quick)
        _step(progress, "kinematic step")
    elapsed = time.perf_counter() - start

    lines = report(chosen, runs_by_scene, peers_by_scene, costs, kinematic, peers, args, elapsed, pairs)
    text = "\n".join(lines) + "\n"
    (args.out / "bench.md").write_text(text)
    for scene in chosen:
        work_precision_plot(
            scene, runs_by_scene[scene.key], peers_by_scene.get(scene.key, []), args.out / f"{scene.key}.png"
        )
    raw = {
        "runs": [vars(r) for runs in runs_by_scene.values() for r in runs],
        "peers": [vars(r) for runs in peers_by_scene.values() for r in runs],
        "pairs": [vars(p) for p in pairs],
        "rhs_costs": {
            k: {"formulations": {f"{a} {b}": v for (a, b), v in c["formulations"].items()}, "parts": c["parts"]}
            for k, c in costs.items()
        },
        "kinematic_step_us": kinematic,
        "seconds": elapsed,
    }
    (args.out / "bench.json").write_text(json.dumps(raw, indent=1, default=float))
    print(text)
    if cache is not None:
        cache.cleanup()
    return finish_stress_study(stress, args.out, args.quick) if stress is not None else 0


def start_stress_study(out: Path, quick: bool, studies: tuple[str, ...] = ()):
    """stress.py (all studies, or ``studies``) in a child process: one core each, as every timing of the bench
    is single-threaded."""
    import subprocess

    command = [sys.executable, str(Path(__file__).with_name("stress.py")), "--out", str(out)]
    command += ["--quick"] if quick else []
    for study in studies:
        command += ["--study", study]
    return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)


def finish_stress_study(child, out: Path, quick: bool) -> int:
    """Wait for the stress study; print its summary line; its exit code (1 when a case is a silent wrong answer)."""
    code = child.wait()
    table = out / ("stress_quick.md" if quick else "stress.md")
    summary = table.read_text().splitlines()[2] if table.is_file() else "no table written"
    print(f"Stress study ({table.name}): {summary}")
    return code


PREPARED_SAID = (
    "With `--prepared` ours is `prepared.run(q0, qd0)` of one `dynamics.prepare` per configuration and setting (the "
    "same result, bit for bit); its preparation (`prepare` and a first run, which makes M, the forces and the "
    "compiled plan and module) is left out, as the peers' model building: "
)


def preparation(runs_by_scene) -> str:
    """The preparations over our runs, for the report: their range (ms), and that of what the first run took more
    than the timed runs' median (what a prepared run saves from its second run on)."""
    runs = [r for runs in runs_by_scene.values() for r in runs if np.isfinite(r.prepare_seconds)]
    if not runs:
        return "none was timed."
    seconds = [1e3 * r.prepare_seconds for r in runs]
    excess = [1e3 * r.prepare_seconds - r.ms for r in runs if np.isfinite(r.ms)]
    said = f"{min(seconds):.2f} to {max(seconds):.1f} ms with the first run (median {statistics.median(seconds):.2f})"
    if excess:
        said += f"; over the timed runs' median {min(excess):.2f} to {max(excess):.1f} ms"
        said += f" (median {statistics.median(excess):.2f})"
    return said + "."


def report(chosen, runs_by_scene, peers_by_scene, costs, kinematic, peers, args, elapsed, pairs=()) -> list[str]:
    versions = peers.versions() if peers is not None else {}
    lines = [
        "# mbd bench: run time against error",
        "",
        f"Python {platform.python_version()}, NumPy {np.__version__}, SciPy {scipy.__version__}, "
        f"{platform.machine()}, {os.cpu_count()} CPUs, OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}; "
        + (", ".join(f"{k} {v}" for k, v in versions.items()) or "no peers")
        + f"; {'quick' if args.quick else 'full'} run, {elapsed:.0f} s.",
        "",
        "Error: the largest position error of any body centre on the output grid (m) against the scene's",
        "reference (Andrews: the largest error of the seven published angles at 0.03 s, rad). Time: the whole",
        "`forward_dynamics` call, median of up to "
        f"{args.repeats} runs (one for runs over 0.3 s). Factorizations: counted in the first run; peak memory",
        "(tracemalloc): a run over a tenth of the span, same output grid, at the loosest and tightest setting.",
        "",
        "## Summary: fastest configuration at equal error",
        "",
        *summary_table(chosen, runs_by_scene, peers_by_scene),
        "",
        "gain: the straightforward path (element loop + solve_ivp RK45) to 1e-6 over the fastest configuration to",
        "1e-6. The numpy engine's columns leave out the compiled engine (`--engine compiled`, solutions/compiled).",
        "",
        "## Ours against the peers, same scenes, same run",
        "",
        *peer_table(chosen, runs_by_scene, peers_by_scene, pairs),
        "",
        "ours / peer: our fastest run to the error (either engine) over the peer's fastest (below 1: we are",
        "faster). The peers have no error control on these models: each of their configurations (every MuJoCo",
        "integrator, the loop's solref, Exudyn's solvers) is searched over steps h = (output interval) / k, k up to",
        "1024, until it reaches 1e-9 or stalls (`peers.search`); the first step reaching each error is timed again.",
        "Their time is the simulation alone (model built outside the timing; MuJoCo by `mujoco.rollout`), ours the",
        "whole `forward_dynamics` call (initial conditions, the run, q'' and lambda, residuals, energies, reactions",
        "at every output time), " + DIVERGENCE_SAID[DIVERGENCE["divergence"]],
        (
            f"ours / peer: the median of {args.rounds} interleaved rounds (one call of each a round, the order "
            "alternating: `peers.interleaved`) of the two fastest, with the lowest and highest ratio; the times "
            "beside it are the medians of their own timings."
            if args.rounds
            else "ours / peer: the ratio of the two medians, each configuration timed on its own."
        ),
        *([PREPARED_SAID + preparation(runs_by_scene)] if PREPARED[0] else []),
        "",
        "## The compiled engine",
        "",
        "First run: the configuration's first call in this process, outside the timings: importing numba and",
        "loading the scene's module from the cache, or compiling it"
        + (" (the cache was emptied for this run)." if args.fresh_cache else " (the user's cache was kept)."),
        "The row gives the fastest warm run to 1e-6 (else the fastest run): us per evaluation and per step are",
        "its whole call divided by its right-hand-side evaluations and by its steps.",
        "",
        *compiled_table(chosen, runs_by_scene),
        "",
        "## Microseconds per right-hand side",
        "",
        "One evaluation of y' = f(t, y) at the initial state, best of five timings: the element loop (the",
        "straightforward path) against per-type evaluation with the Jacobian scattered through index arrays.",
        "",
        "| scene | formulation | element loop (us) | per type (us) | gain |",
        "|---|---|---:|---:|---:|",
    ]
    for scene in chosen:
        c = costs[scene.key]["formulations"]
        for name in dict.fromkeys(k[0] for k in c):
            loop, vec = c[(name, "loop")], c[(name, "vectorized")]
            lines.append(f"| {scene.title} | {name} | {loop:.0f} | {vec:.0f} | {loop / vec:.1f}x |")
    lines += [
        "",
        "## What skipping and structure save (us per call)",
        "",
        "| scene | element groups (left to the loop) | "
        + " | ".join(next(iter(costs.values()))["parts"].keys())
        + " |",
        "|---|---|" + "---:|" * len(next(iter(costs.values()))["parts"]),
    ]
    for scene in chosen:
        c = costs[scene.key]
        groups = ", ".join(c["groups"]) + (f" ({c['loop_elements']})" if c["loop_elements"] else "")
        cells = [f"{v:.1f}" for v in c["parts"].values()]
        lines.append(f"| {scene.title} | {groups} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "A dynamic run builds M and the constant (gravity-only) Q once, so neither of the last two columns is paid",
        "per evaluation in a scene without force elements; a kinematic run never builds M.",
        "",
        "Kinematic step of the driven slider-crank (slider_crank.yaml, Newton-Raphson position, LU of Psi_q,",
        "velocity, acceleration): "
        + ", ".join(f"{k} {v:.1f} us" if v < 10 else f"{k} {v:.0f} us" for k, v in kinematic.items())
        + " per time step, the whole `kinematic_analysis` call over the time steps (targets: under 50 us for",
        "the numpy engine, under 10 us compiled).",
        "",
    ]
    for scene in chosen:
        unit = "rad" if scene.reference == "published" else "m"
        lines += [
            f"## {scene.title} ({scene.key}, 0 .. {scene.t_end} s, {scene.outputs} output steps)",
            "",
            f"Reference: {scene.ref_note}. Diagram: `{scene.key}.png`.",
            "",
            *run_table(runs_by_scene[scene.key], unit),
            "",
        ]
        if peers_by_scene.get(scene.key):
            lines += ["Peers, same scene, same run:", "", *peers.table(peers_by_scene[scene.key], unit), ""]
    return lines


if __name__ == "__main__":
    sys.exit(main())
