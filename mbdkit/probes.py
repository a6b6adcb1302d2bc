"""Probes: what the grader asks a package to compute on a scene.

A probe ``probe(pkg, job) -> {output: array}`` runs one part of the course's API on a scene. The same
probe runs the reference package (``solutions``, inside the grader, to make the reference data) and a
student's package (``modules``, inside the sandbox child), so both are asked exactly the same thing.

This module is loaded into the sandbox before any student code: it imports nothing but the standard
library and numpy, and it never imports ``solutions``; the package is a parameter.

A probe declares the inputs it reads (``INPUTS``); a child is sent those alone, and a child of hidden or
per-student checks only states and made-up arrays (``sent_inputs``): nothing it gets is an output it is
checked on.

Function probes evaluate one element at a time, so a joint that raises costs only the rows it owns
(the others are still compared); the element's error is kept in ``job.errors``. Every output has named
axes (``AXES``) so that a message can say "state 2, row A.y, column rod.phi".
"""

from __future__ import annotations

import importlib
import importlib.util
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np


class Package:
    """A course package by name: ``pkg["kinematics"]`` imports ``<name>.kinematics``."""

    def __init__(self, name: str):
        self.name = name

    def __getitem__(self, dotted: str):
        return importlib.import_module(f"{self.name}.{dotted}")

    def has(self, dotted: str) -> bool:
        """True when the package has this module (checked without running student code)."""
        return importlib.util.find_spec(f"{self.name}.{dotted}") is not None


@dataclass
class Job:
    """One probe on one scene: the model file's content, the input states and the options."""

    key: str
    model: dict
    inputs: dict[str, np.ndarray] = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    errors: list[tuple[str, str, BaseException]] = field(default_factory=list)

    def error(self, element: str, method: str, exc: BaseException) -> None:
        """Keep the first error of each element and method."""
        if not any(e == element and m == method for e, m, _ in self.errors):
            self.errors.append((element, method, exc))

    def setting(self, option: str, key: str, default=None):
        """An option of the check, else the model file's simulation block, else the default."""
        if option in self.options:
            return self.options[option]
        return self.model.get("simulation", {}).get(key, default)


def real(value) -> np.ndarray:
    """What a package returned, as an array of real numbers; complex numbers are refused, never cut to
    their real part (float() would drop the imaginary part silently)."""
    raw = np.asarray(value)
    if np.iscomplexobj(raw):
        if np.any(raw.imag != 0):
            raise TypeError(
                "returned complex numbers (a square root or a logarithm of a negative number?); "
                "the course's quantities are real"
            )
        raw = raw.real
    return np.asarray(raw, dtype=float)


PROBES: dict[str, Callable[[Package, Job], dict]] = {}
"""Probe name -> function."""

AXES: dict[str, tuple[str, ...]] = {}
"""'probe.output' -> names of its axes: state, row (a constraint), coordinate, time, reaction."""

REQUIRES: dict[str, tuple[str, ...]] = {}
"""Probe name -> modules of the reference package it needs (a probe is offered only when they exist)."""

INPUTS: dict[str, tuple[str, ...]] = {}
"""Probe name -> the inputs it reads (``job.inputs``): a child is sent these and nothing else (``sent_inputs``)."""


def probe(name: str, axes: dict[str, tuple[str, ...]], inputs: tuple[str, ...], requires: tuple[str, ...] = ()):
    """Register a probe with the axes of each of its outputs and the inputs it reads."""

    def register(function):
        PROBES[name] = function
        REQUIRES[name] = requires
        INPUTS[name] = inputs
        for output, names in axes.items():
            AXES[f"{name}.{output}"] = names
        return function

    return register


PERTURBED = ("t", "q_pert", "qd_pert")
"""Three times of the scene's own run with its positions and velocities moved off the constraint manifold."""
CONSISTENT = ("t", "q", "qd")
"""The same times with the run's own positions and velocities (on the manifold)."""
OFF_THE_RUN = {"q": "q_pert", "qd": "qd_pert"}
"""A hidden or per-student child gets the perturbed state where a public one gets the run's own: the run's
positions are what ``newton`` converges to, its velocities what ``velocity`` returns, rows of a whole run."""
MADE_UP = ("gamma_pert", "psi_pert", "psi_dot_pert", "M_pert", "jacobian_pert", "Q_pert", "lam")
"""Inputs that are the reference's own results (gamma, Psi, Psi', M, Psi_q and Q at the checked states, the
run's lambda): the expected outputs of other probes, or what they follow from (one solve of M, Psi_q, Q and
gamma gives a formulation's q'' and lambda). A hidden or per-student child gets made-up arrays instead."""


def sent_inputs(probe: str, inputs: dict[str, np.ndarray], public: bool, dimension: int = 2) -> dict[str, np.ndarray]:
    """What a child running ``probe`` on a scene is sent of the scene's reference ``inputs``: only what the
    probe reads (``INPUTS``). A child of hidden or per-student checks is sent only times and states that are
    no probe's output (``t``, ``q_pert``, ``qd_pert``; the perturbed states stand in for the run's own ``q``
    and ``qd``) and, for the reference's results a probe takes as its inputs (``MADE_UP``), arrays of their
    shape made up from a fixed seed, which say nothing of the scene: a function's formula is checked on them
    as well. The reference makes a scene's expected values from exactly what its child is sent (this function,
    in ``autograder.reference``). Anything else raises KeyError: a new input must be placed here first."""
    names = INPUTS[probe]
    if public:
        return {name: inputs[name] for name in names}
    sent = {}
    for name in names:
        if name in OFF_THE_RUN:
            sent[name] = inputs[OFF_THE_RUN[name]]
        elif name in PERTURBED:
            sent[name] = inputs[name]
        elif name in MADE_UP:
            sent[name] = made_up(name, np.shape(inputs[name]), dimension)
        else:
            raise KeyError(f"probe {probe}: input {name!r} may not be sent to a child of hidden or per-student checks")
    return sent


def made_up(name: str, shape: tuple[int, ...], dimension: int) -> np.ndarray:
    """An array of ``shape`` for the input ``name`` from a fixed seed: standard normal numbers, and for a mass
    matrix (K, n, n) one of the model's structure (per body diag(m, m, J) in the plane, diag(m, m, m) and a
    symmetric positive definite 4 x 4 block in space) with made-up masses and inertias."""
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    if name != "M_pert":
        return rng.standard_normal(shape)
    states, n, _ = shape
    size = 3 if dimension == 2 else 7
    M = np.zeros(shape)
    for k in range(states):
        for body in range(n // size):
            block = slice(size * body, size * (body + 1))
            m = rng.uniform(0.5, 5.0)
            if dimension == 2:
                M[k, block, block] = np.diag([m, m, rng.uniform(0.01, 1.0)])
            else:
                a = rng.standard_normal((4, 4))
                M[k, block, block] = np.block(
                    [[m * np.eye(3), np.zeros((3, 4))], [np.zeros((4, 3)), a @ a.T + np.eye(4)]]
                )
    return M


_MODELS: dict[tuple[str, str], object] = {}


def build(pkg: Package, job: Job):
    """The package's system of the scene: (system, q0, qd0). The validated model is cached per scene."""
    return pkg["assembly"].build_system(model_of(pkg, job))


def _body_coordinates(pkg: Package, system, body: int, x: np.ndarray, velocity: bool) -> np.ndarray:
    size = system.coordinates_per_body
    if body >= 0:
        return x[size * body : size * (body + 1)]
    if velocity:
        return np.zeros(size)
    return real(pkg["assembly"].GROUND_COORDINATES[system.model.dimension])


def _element_rows(pkg: Package, job: Job, method: str) -> np.ndarray:
    """Psi, Psi_t, gamma or Psi_q of every element at every input state, element by element.

    Rows of an element that raises (or returns the wrong size) are NaN; the error is kept in job.errors.
    Function probes run at perturbed states (q_pert, qd_pert): off the constraint manifold, where every
    term of Psi shows.
    """
    system, _, _ = build(pkg, job)
    t, q, qd = job.inputs["t"], job.inputs["q_pert"], job.inputs["qd_pert"]
    m, n, size = system.n_constraints, system.n_coordinates, system.coordinates_per_body
    out = np.full((t.size, m, n) if method == "jacobian" else (t.size, m), np.nan)
    for k in range(t.size):
        for index, element in enumerate(system.elements):
            rows = system.rows[index]
            qi = _body_coordinates(pkg, system, element.i, q[k], False)
            qj = _body_coordinates(pkg, system, element.j, q[k], False)
            try:
                if method == "jacobian":
                    block = np.zeros((rows.stop - rows.start, n))
                    jac_i, jac_j = element.jacobian(qi, qj, float(t[k]))
                    if element.i >= 0:
                        block[:, size * element.i : size * (element.i + 1)] += real(jac_i)
                    if element.j >= 0:
                        block[:, size * element.j : size * (element.j + 1)] += real(jac_j)
                    out[k, rows] = block
                elif method == "gamma":
                    qdi = _body_coordinates(pkg, system, element.i, qd[k], True)
                    qdj = _body_coordinates(pkg, system, element.j, qd[k], True)
                    out[k, rows] = real(element.gamma(qi, qj, qdi, qdj, float(t[k])))
                else:
                    out[k, rows] = real(getattr(element, method)(qi, qj, float(t[k])))
            except Exception as exc:  # one element's error costs only its rows
                job.error(element.name, method, exc)
    return out


# -- hw1: planar kinematics ----------------------------------------------------------------------------
@probe("constraints", {"psi": ("state", "row")}, PERTURBED)
def constraints(pkg: Package, job: Job) -> dict:
    """Psi(q, t) element by element at the perturbed states."""
    return {"psi": _element_rows(pkg, job, "constraints")}


@probe("jacobian", {"jacobian": ("state", "row", "coordinate")}, PERTURBED)
def jacobian(pkg: Package, job: Job) -> dict:
    """Psi_q(q, t) element by element at the perturbed states."""
    return {"jacobian": _element_rows(pkg, job, "jacobian")}


@probe("psi_t", {"psi_t": ("state", "row")}, PERTURBED)
def psi_t(pkg: Package, job: Job) -> dict:
    """Psi_t(q, t) element by element at the perturbed states."""
    return {"psi_t": _element_rows(pkg, job, "psi_t")}


@probe("gamma", {"gamma": ("state", "row")}, PERTURBED)
def gamma(pkg: Package, job: Job) -> dict:
    """gamma(q, q', t) element by element at the perturbed states."""
    return {"gamma": _element_rows(pkg, job, "gamma")}


@probe("newton", {"q": ("state", "coordinate")}, ("t", "q_pert"))
def newton(pkg: Package, job: Job) -> dict:
    """newton_raphson from the perturbed positions: the assembled q at each state's time."""
    system, _, _ = build(pkg, job)
    solve = pkg["kinematics"].newton_raphson
    t, q = job.inputs["t"], job.inputs["q_pert"]
    return {"q": np.array([real(solve(system, q[k], float(t[k])).q) for k in range(t.size)])}


@probe("velocity", {"qd": ("state", "coordinate")}, ("t", "q"))
def velocity(pkg: Package, job: Job) -> dict:
    """velocity_analysis at consistent states (perturbed ones for a hidden or per-student scene): q' from
    Psi_q q' = -Psi_t."""
    system, _, _ = build(pkg, job)
    solve = pkg["kinematics"].velocity_analysis
    t, q = job.inputs["t"], job.inputs["q"]
    return {"qd": np.array([real(solve(system, q[k], float(t[k]))) for k in range(t.size)])}


@probe("acceleration", {"qdd": ("state", "coordinate")}, CONSISTENT)
def acceleration(pkg: Package, job: Job) -> dict:
    """acceleration_analysis at consistent states (perturbed ones for a hidden or per-student scene): q'' from
    Psi_q q'' = gamma."""
    system, _, _ = build(pkg, job)
    solve = pkg["kinematics"].acceleration_analysis
    t, q, qd = job.inputs["t"], job.inputs["q"], job.inputs["qd"]
    return {"qdd": np.array([real(solve(system, q[k], qd[k], float(t[k]))) for k in range(t.size)])}


@probe(
    "kinematic_run",
    {"t": ("time",), "q": ("time", "coordinate"), "qd": ("time", "coordinate"), "qdd": ("time", "coordinate")},
    (),
)
def kinematic_run(pkg: Package, job: Job) -> dict:
    """kinematic_analysis over the scene's grid (or the check's t_end and steps)."""
    system, q0, _ = build(pkg, job)
    result = pkg["kinematics"].kinematic_analysis(
        system, q0, float(job.setting("t_end", "end_time", 1.0)), int(job.setting("steps", "output_steps", 100)),
        engine="numpy",  # the reference's steps are the numpy code's on every machine, whatever is compiled there
    )  # fmt: skip
    return {"t": result.t, "q": result.q, "qd": result.qd, "qdd": result.qdd}


class SliderCrankLoop:
    """A slider-crank given by its loop-closure equations, not by joints: what the ``loop_*`` probes hand
    newton_raphson, velocity_analysis and acceleration_analysis, so that kinematics.py earns its points before
    any joint of planar/joints.py is written.

    Coordinates q = (theta, phi, x): the crank's angle, the rod's angle (both from the x axis) and the slider's
    position on its guide y = e. The crank (length r, from the origin) and the rod (length l) close the loop
    at the slider, and a driver turns the crank by theta_d(t) = theta_0 + omega t + alpha t^2 / 2:

        Psi = (r cos theta + l cos phi - x,  r sin theta + l sin phi - e,  theta - theta_d(t)) = 0

    It offers what the three functions use of a System: Psi, Psi_q, Psi_t, gamma and the rows' labels."""

    r, l, e = 0.1, 0.3, 0.05
    theta_0, omega, alpha = 0.3, 10.0, 20.0
    labels = ["loop x", "loop y", "crank driver"]
    coordinate_names = ["crank.theta", "rod.phi", "slider.x"]
    n_coordinates = n_constraints = 3

    def driver(self, t: float) -> tuple[float, float, float]:
        """theta_d and its first and second time derivatives."""
        return self.theta_0 + self.omega * t + 0.5 * self.alpha * t**2, self.omega + self.alpha * t, self.alpha

    def constraints(self, q: np.ndarray, t: float) -> np.ndarray:
        theta, phi, x = q
        r, l = self.r, self.l
        return np.array(
            [
                r * np.cos(theta) + l * np.cos(phi) - x,
                r * np.sin(theta) + l * np.sin(phi) - self.e,
                theta - self.driver(t)[0],
            ]
        )

    def jacobian(self, q: np.ndarray, t: float) -> np.ndarray:
        theta, phi, _ = q
        r, l = self.r, self.l
        return np.array(
            [[-r * np.sin(theta), -l * np.sin(phi), -1.0], [r * np.cos(theta), l * np.cos(phi), 0.0], [1.0, 0.0, 0.0]]
        )

    def psi_t(self, q: np.ndarray, t: float) -> np.ndarray:
        return np.array([0.0, 0.0, -self.driver(t)[1]])

    def gamma(self, q: np.ndarray, qd: np.ndarray, t: float) -> np.ndarray:
        """-(Psi_q q')_q q' - 2 Psi_qt q' - Psi_tt: the loop's centripetal terms and the driver's alpha."""
        (theta, phi, _), (w, v, _) = q, qd
        r, l = self.r, self.l
        return np.array(
            [
                r * np.cos(theta) * w**2 + l * np.cos(phi) * v**2,
                r * np.sin(theta) * w**2 + l * np.sin(phi) * v**2,
                self.driver(t)[2],
            ]
        )

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The consistent (q, q') at time t, the slider right of the crank (cos phi > 0)."""
        theta, w, _ = self.driver(t)
        phi = np.arcsin((self.e - self.r * np.sin(theta)) / self.l)
        v = -self.r * np.cos(theta) * w / (self.l * np.cos(phi))
        q = np.array([theta, phi, self.r * np.cos(theta) + self.l * np.cos(phi)])
        return q, np.array([w, v, -self.r * np.sin(theta) * w - self.l * np.sin(phi) * v])


LOOP_TIMES = (0.0, 0.15, 0.3, 0.45)
"""The times at which the ``loop_*`` probes solve the slider-crank: crank angles 0.3, 2.0, 4.2 and 6.8 rad."""
LOOP_START = np.array([0.15, -0.25, 0.05])
"""newton_raphson starts from the consistent positions moved by this much (rad, rad, m): several iterations."""
LOOP_AXES = ("crank", "loop")


@probe("loop_newton", {"q": LOOP_AXES}, (), requires=("kinematics",))
def loop_newton(pkg: Package, job: Job) -> dict:
    """newton_raphson on SliderCrankLoop (no joint of the package's) from estimates LOOP_START off its positions
    at LOOP_TIMES: the positions it converges to."""
    solve, loop = pkg["kinematics"].newton_raphson, SliderCrankLoop()
    return {"q": np.array([real(solve(loop, loop.state(t)[0] + LOOP_START, t).q) for t in LOOP_TIMES])}


@probe("loop_velocity", {"qd": LOOP_AXES}, (), requires=("kinematics",))
def loop_velocity(pkg: Package, job: Job) -> dict:
    """velocity_analysis on SliderCrankLoop (no joint of the package's) at its positions at LOOP_TIMES."""
    solve, loop = pkg["kinematics"].velocity_analysis, SliderCrankLoop()
    return {"qd": np.array([real(solve(loop, loop.state(t)[0], t)) for t in LOOP_TIMES])}


@probe("loop_acceleration", {"qdd": LOOP_AXES}, (), requires=("kinematics",))
def loop_acceleration(pkg: Package, job: Job) -> dict:
    """acceleration_analysis on SliderCrankLoop (no joint of the package's) at its states at LOOP_TIMES."""
    solve, loop = pkg["kinematics"].acceleration_analysis, SliderCrankLoop()
    return {"qdd": np.array([real(solve(loop, *loop.state(t), t)) for t in LOOP_TIMES])}


# -- hw2: planar forward dynamics ----------------------------------------------------------------------
def model_of(pkg: Package, job: Job):
    """The package's validated Model of the scene (cached per scene)."""
    key = (pkg.name, job.key)
    if key not in _MODELS:
        _MODELS[key] = pkg["io.model"].load_model(job.model)
    return _MODELS[key]


def _states(job: Job, perturbed: bool = True):
    t = job.inputs["t"]
    q = job.inputs["q_pert" if perturbed else "q"]
    qd = job.inputs["qd_pert" if perturbed else "qd"]
    return [(float(t[k]), q[k], qd[k]) for k in range(t.size)]


@probe("mass_matrix", {"M": ("coordinate", "coordinate")}, (), requires=("mass_matrix",))
def mass_matrix(pkg: Package, job: Job) -> dict:
    """The planar model's (constant) mass matrix."""
    return {"M": pkg["mass_matrix"].mass_matrix(model_of(pkg, job))}


@probe("generalized_forces", {"Q": ("state", "coordinate")}, PERTURBED, requires=("generalized_forces",))
def generalized_forces(pkg: Package, job: Job) -> dict:
    """Q(q, q', t) at the perturbed states (every force element contributes)."""
    forces = pkg["generalized_forces"].build_forces(model_of(pkg, job))
    return {"Q": np.array([real(forces.generalized_forces(q, qd, t)) for t, q, qd in _states(job)])}


@probe(
    "baumgarte_gamma",
    {"gamma_bar": ("state", "row")},
    ("gamma_pert", "psi_pert", "psi_dot_pert"),
    requires=("formulations",),
)
def baumgarte_gamma(pkg: Package, job: Job) -> dict:
    """gamma_bar from the reference's gamma, Psi and Psi' at the perturbed states (made-up ones for a hidden or
    per-student scene: ``sent_inputs``)."""
    f = pkg["formulations"].baumgarte_gamma
    alpha, beta = float(job.options.get("alpha", 5.0)), float(job.options.get("beta", 5.0))
    g, psi, psi_dot = job.inputs["gamma_pert"], job.inputs["psi_pert"], job.inputs["psi_dot_pert"]
    return {
        "gamma_bar": np.array(
            [real(f(g[k].copy(), psi[k].copy(), psi_dot[k].copy(), alpha, beta)) for k in range(len(g))]
        )
    }


@probe(
    "augmented_accelerations",
    {"qdd": ("state", "coordinate"), "lam": ("state", "row")},
    ("M_pert", "jacobian_pert", "Q_pert", "gamma_pert"),
    requires=("formulations",),
)
def augmented_accelerations(pkg: Package, job: Job) -> dict:
    """q'' and lambda of the augmented system from the reference's M, Psi_q, Q and gamma (made-up ones for a
    hidden or per-student scene: ``sent_inputs``)."""
    f = pkg["formulations"].augmented_accelerations
    M, J, Q, g = job.inputs["M_pert"], job.inputs["jacobian_pert"], job.inputs["Q_pert"], job.inputs["gamma_pert"]
    pairs = [f(M[k].copy(), J[k].copy(), Q[k].copy(), g[k].copy()) for k in range(len(g))]
    return {
        "qdd": np.array([real(p[0]) for p in pairs]),
        "lam": np.array([real(p[1]) for p in pairs]),
    }


@probe(
    "accelerations",
    {"qdd": ("state", "coordinate"), "lam": ("state", "row")},
    PERTURBED,
    requires=("formulations", "mass_matrix", "generalized_forces"),
)
def accelerations(pkg: Package, job: Job) -> dict:
    """A formulation's (q'', lambda) at the perturbed states, with the package's own M and Q."""
    model = model_of(pkg, job)
    system, _, _ = build(pkg, job)
    options = dict(job.options)
    name = options.pop("formulation", job.setting("formulation", "formulation", "baumgarte"))
    formulation = pkg["formulations"].make_formulation(
        name, system, pkg["mass_matrix"].mass_matrix(model), pkg["generalized_forces"].build_forces(model), **options
    )
    pairs = [formulation.accelerations(q.copy(), qd.copy(), t) for t, q, qd in _states(job)]
    return {
        "qdd": np.array([real(p[0]) for p in pairs]),
        "lam": np.array([real(p[1]) for p in pairs]),
    }


RK4_STEPS = (4, 8, 16, 32)
RK4_SPAN = 2.0


def rk4_test_rhs(t: float, y: np.ndarray) -> np.ndarray:
    """y'' + y = sin 2t as a first-order system; from y(0) = 1, y'(0) = 0 the exact solution is
    y = cos t + 2/3 sin t - 1/3 sin 2t (so every stage time matters)."""
    return np.array([y[1], -y[0] + np.sin(2.0 * t)])


def rk4_test_exact(t: float) -> np.ndarray:
    return np.array(
        [
            np.cos(t) + 2.0 / 3.0 * np.sin(t) - np.sin(2.0 * t) / 3.0,
            -np.sin(t) + 2.0 / 3.0 * np.cos(t) - 2.0 / 3.0 * np.cos(2.0 * t),
        ]
    )


@probe("rk4", {"y": ("steps", "component")}, (), requires=("integrators",))
def rk4(pkg: Package, job: Job) -> dict:
    """y(2) of y'' + y = sin 2t by N = 4, 8, 16, 32 steps of the package's rk4_step."""
    step = pkg["integrators"].rk4_step
    finals = []
    for n in RK4_STEPS:
        h, y = RK4_SPAN / n, np.array([1.0, 0.0])
        for k in range(n):
            y = real(step(rk4_test_rhs, k * h, y, h))
        finals.append(y)
    return {"y": np.array(finals)}


def reaction_labels(row_owners: list[str], dimension: int) -> list[str]:
    """Columns of the reactions probe: per joint or driver (in row order) its force and moment components."""
    parts = ("Fx", "Fy", "Mz") if dimension == 2 else ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
    return [f"{owner}.{p}" for owner in dict.fromkeys(row_owners) for p in parts]


@probe("reactions", {"reactions": ("state", "reaction")}, ("t", "q", "lam"), requires=("reactions",))
def reactions(pkg: Package, job: Job) -> dict:
    """Joint and driver reactions at the consistent states, from the reference's lambda (for a hidden or
    per-student scene: at the perturbed states, from a made-up lambda; ``sent_inputs``)."""
    system, _, _ = build(pkg, job)
    t, q, lam = job.inputs["t"], job.inputs["q"], job.inputs["lam"]
    columns = pkg["reactions"].joint_reactions(system, q.copy(), lam.copy(), t.copy())
    labels = reaction_labels(list(system.row_owners), system.model.dimension)
    return {"reactions": np.array([real(columns.get(label, np.full(t.size, np.nan))) for label in labels]).T}


@probe(
    "dynamic_run",
    {"t": ("time",), "q": ("time", "coordinate"), "qd": ("time", "coordinate"), "lam": ("time", "row")},
    (),
    requires=("dynamics",),
)
def dynamic_run(pkg: Package, job: Job) -> dict:
    """forward_dynamics over the scene's grid with the check's formulation, integrator and tolerances."""
    system, q0, qd0 = build(pkg, job)
    extra = {
        k: v
        for k, v in job.options.items()
        if k not in ("formulation", "integrator", "rtol", "atol", "step", "t_end", "steps")
    }
    extra.setdefault("engine", "numpy")  # the numpy code the student wrote; the reference's runs name theirs
    result = pkg["dynamics"].forward_dynamics(
        system,
        q0,
        qd0,
        float(job.setting("t_end", "end_time", 1.0)),
        int(job.setting("steps", "output_steps", 100)),
        formulation=job.setting("formulation", "formulation", "baumgarte"),
        integrator=job.setting("integrator", "integrator", "RK45"),
        rtol=float(job.setting("rtol", "rtol", 1e-8)),
        atol=float(job.setting("atol", "atol", 1e-10)),
        step=job.setting("step", "step", None),
        **extra,
    )
    outputs = {"t": result.t, "q": result.q, "qd": result.qd}
    if result.lam is not None:
        outputs["lam"] = result.lam
    return outputs


# -- hw3: spatial two-body dynamics --------------------------------------------------------------------
def _euler_parameters(job: Job) -> np.ndarray:
    """(K, bodies, 4) unit Euler parameters of the perturbed states."""
    q = job.inputs["q_pert"]
    return q.reshape(q.shape[0], -1, 7)[:, :, 3:]


BODY_VECTORS = (np.array([0.3, -0.1]), np.array([-0.2, 0.25]))
"""The body-fixed vectors s_i' and s_j' at which ``planar_bodies`` evaluates the point vectors (any will do)."""


@probe(
    "planar_bodies",
    {
        "A": ("state", "body", "i", "j"),
        "B": ("state", "body", "i", "j"),
        "d": ("state", "body", "i"),
        "d_dot": ("state", "body", "i"),
        "d_quadratic": ("state", "body", "i"),
    },
    PERTURBED,
    requires=("planar.bodies",),
)
def planar_bodies(pkg: Package, job: Job) -> dict:
    """The body functions alone, before any joint (eq. 2.1-2.5): A(phi) and B(phi) of every body, and d_ij, d_ij'
    and the velocity part of d_ij'' from the body before it (ground for the first) to it, with the body vectors
    BODY_VECTORS, at the perturbed states."""
    bodies = pkg["planar.bodies"]
    si, sj = BODY_VECTORS
    out: dict[str, list] = {name: [] for name in ("A", "B", "d", "d_dot", "d_quadratic")}
    for _, q, qd in _states(job):
        q, qd = np.concatenate([np.zeros(3), q]), np.concatenate([np.zeros(3), qd])  # ground first
        blocks = [(q[3 * k : 3 * k + 3], qd[3 * k : 3 * k + 3]) for k in range(q.size // 3)]
        pairs = list(zip(blocks[:-1], blocks[1:], strict=True))
        out["A"].append([real(bodies.rotation(float(qb[2]))) for qb, _ in blocks[1:]])
        out["B"].append([real(bodies.rotation_derivative(float(qb[2]))) for qb, _ in blocks[1:]])
        out["d"].append([real(bodies.point_vector(a.copy(), si, b.copy(), sj)) for (a, _), (b, _) in pairs])
        for name, f in (("d_dot", bodies.point_vector_dot), ("d_quadratic", bodies.point_vector_quadratic)):
            out[name].append([real(f(a.copy(), si, b.copy(), sj, ad.copy(), bd.copy())) for (a, ad), (b, bd) in pairs])
    return {name: np.array(values) for name, values in out.items()}


@probe(
    "rotation_matrices",
    {"A": ("state", "body", "i", "j"), "G": ("state", "body", "i", "j"), "L": ("state", "body", "i", "j")},
    ("q_pert",),
    requires=("rotations",),
)
def rotation_matrices(pkg: Package, job: Job) -> dict:
    """A(p), G(p), L(p) of every body at the perturbed states."""
    rotations = pkg["rotations"]
    p = _euler_parameters(job)
    return {
        name: np.array([[real(f(pb.copy())) for pb in pk] for pk in p])
        for name, f in (("A", rotations.rotation_matrix), ("G", rotations.g_matrix), ("L", rotations.l_matrix))
    }


@probe("spatial_mass_matrix", {"M": ("state", "coordinate", "coordinate")}, PERTURBED, requires=("spatial.mass",))
def spatial_mass_matrix(pkg: Package, job: Job) -> dict:
    """The spatial mass matrix M(q) = diag(m I, 4 L^T J' L) at the perturbed states."""
    model = model_of(pkg, job)
    f = pkg["spatial.mass"].mass_matrix
    return {"M": np.array([real(f(model, q.copy())) for _, q, _ in _states(job)])}


@probe("quadratic_velocity", {"Qv": ("state", "coordinate")}, PERTURBED, requires=("spatial.mass",))
def quadratic_velocity(pkg: Package, job: Job) -> dict:
    """The quadratic-velocity force Q_v = 8 L(p')^T J' L(p') p at the perturbed states."""
    model = model_of(pkg, job)
    f = pkg["spatial.mass"].quadratic_velocity_vector
    return {"Qv": np.array([real(f(model, q.copy(), qd.copy())) for _, q, qd in _states(job)])}


@probe("invariants", {"drift": (), "velocity_drift": (), "energy": (), "energy_scale": ()}, CONSISTENT)
def invariants(pkg: Package, job: Job) -> dict:
    """Of a trajectory (inputs t, q, qd): the constraint drift max |Psi|, the velocity drift
    max |Psi_q q' + Psi_t| and, for a conservative scene (no drivers, dampers, actuators or loads), the
    energy error max |E(t) - E(0)| with its scale. The grader measures a student's run with the
    reference package; a student kit, which has no reference, with the student's own package."""
    model = model_of(pkg, job)
    system, _, _ = build(pkg, job)
    t, q, qd = job.inputs["t"], job.inputs["q"], job.inputs["qd"]
    drift = max(float(np.max(np.abs(system.constraints(qk, tk)), initial=0.0)) for tk, qk in zip(t, q, strict=True))
    velocity = max(
        float(np.max(np.abs(system.jacobian(qk, tk) @ qdk + system.psi_t(qk, tk)), initial=0.0))
        for tk, qk, qdk in zip(t, q, qd, strict=True)
    )
    out = {"drift": np.array(drift), "velocity_drift": np.array(velocity)}
    forces = pkg["generalized_forces"].build_forces(model)
    if not model.motors and forces.is_conservative:
        history = pkg["energy"].energy_history(pkg["mass_matrix"].mass_matrix(model), forces, q, qd)
        out["energy"] = np.array(float(np.max(np.abs(history.total - history.total[0]))))
        out["energy_scale"] = np.array(float(history.scale))
    return out


# -- hw2: inverse dynamics (appended) ------------------------------------------------------------------
@probe(
    "inverse_dynamics",
    {"lam": ("state", "row")},
    CONSISTENT,
    requires=("inverse_dynamics", "mass_matrix", "generalized_forces"),
)
def inverse_dynamics(pkg: Package, job: Job) -> dict:
    """lambda of a fully driven scene at its consistent states (perturbed ones for a hidden or per-student
    scene): ``multipliers`` (Psi_q^T lambda = Q - M q'', eq. 5.80) given Psi_q and q'' of the package's
    kinematics and its own M and Q."""
    model = model_of(pkg, job)
    system, _, _ = build(pkg, job)
    multipliers = pkg["inverse_dynamics"].multipliers
    acceleration = pkg["kinematics"].acceleration_analysis
    mass = pkg["mass_matrix"]
    M = mass.mass_matrix(model)
    forces = pkg["generalized_forces"].build_forces(model)
    lam = []
    for t, q, qd in _states(job, perturbed=False):
        qdd = real(acceleration(system, q.copy(), qd.copy(), t))
        Q = real(forces.generalized_forces(q.copy(), qd.copy(), t))
        lam.append(real(multipliers(system.jacobian(q, t), mass.mass_at(M, q), qdd, Q)))
    return {"lam": np.array(lam)}
