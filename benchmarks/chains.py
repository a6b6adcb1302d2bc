"""Scaling with the number of bodies: chains of N = 2 ... 64 uniform bars, 1 s simulated at rtol = atol = 1e-6.

Three families (issue 25), generated here as model mappings:

- ``planar``: a pendulum chain of N bars (0.5 m, 1 kg) on revolute joints, hanging from the ground, released at
  rest with the whole chain straight at 45 degrees from the vertical, under gravity;
- ``spatial``: the same chain in space on spherical joints, the bars along x, then each turned 30 degrees more
  about the vertical than the one above it (a chain that swings out of every plane), released at rest;
- ``loops``: an IFToMM-A02-like chain of N parallelogram four-bars: N + 1 cranks (0.5 m, 1 kg) pinned to the
  ground 0.5 m apart and N couplers (0.5 m, 1 kg) pinning the cranks' tips together: 2N + 1 bodies, N loops, one
  degree of freedom. The cranks hang 60 degrees from the vertical and start at rest, so the chain swings as one
  pendulum and never reaches the flat (singular) position.

References that do not come from the solver: the planar chain against Lagrange's equations in the bars' absolute
angles, sum_j a_ij [cos(t_i - t_j) t_j'' + sin(t_i - t_j) t_j'^2] = -dV/dt_i (a_ij = m l^2 (N - max(i, j) - 1/2) off
the diagonal, J + m l^2 (N - i - 3/4) on it, counting from 0 at the top); the loop chain against its one-degree-of-
freedom equation ((N + 1) J_O + N m l^2) t'' = -(N + 1/2) ... (``loop_reference``); both DOP853 at rtol = atol =
1e-12; the spatial chain against Kane's equations in the bars' absolute angular velocities with quaternions
(``spatial_reference``: the moment about each joint of the bars below it, a dense 3N x 3N matrix written out here),
DOP853 at rtol = atol = 1e-12. None of them uses the package's code; each agrees with the package's
joint-coordinates and Baumgarte runs at rtol 1e-12 to 1e-11 m (tests/benchmarks/test_chains.py).

Per family, N and configuration: the wall time of the whole ``forward_dynamics`` call for 1 s (the best of
``--repeats``; a compiled configuration's first call is timed apart: "first call +s" is its time over the best,
the compilation when the structure was not cached, about 0 otherwise), the right-hand-
side evaluations, the time per evaluation and the largest position error of a body centre (m). The growth of the
time per evaluation with N is fitted as N^p over N >= 8. A configuration whose run at some N takes longer than
``--limit`` seconds is not run at larger N ("where it breaks"). With ``--prepared`` ours is timed as ``prepared.run``
of one ``dynamics.prepare`` per N and configuration (MuJoCo's timing leaves out compiling its model; "first call +s"
then holds the preparation: ``prepare``, and the first run, which makes what the runs share).

With ``--mujoco``, MuJoCo's fastest configuration reaching 1e-6 m against the same references and ours at its
cheapest tolerance reaching it, then both in interleaved rounds (``paired``): the planar and spatial chains as nested
bodies written here (``mujoco_chain``), the loop chain as ``mbd export --to mjcf`` writes it (``mujoco_loops``: a
tree of hinges, each loop closed by a soft ``connect`` equality whose solref and solimp are searched too, CLOSURES).

    .venv/bin/python benchmarks/chains.py                  # N = 2 ... 64, every family (tens of minutes)
    .venv/bin/python benchmarks/chains.py --quick          # N = 2, 4, 8, numpy only (a minute)
    .venv/bin/python benchmarks/chains.py --family planar --sizes 2 8 32
    .venv/bin/python benchmarks/chains.py --family planar --sizes 2 4 --prepared --cpu   # prepared.run
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks.bench import body_positions  # noqa: E402
from benchmarks.peers import interleaved  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.diagnostics import AnalysisError  # noqa: E402
from solutions.dynamics import forward_dynamics, prepare  # noqa: E402
from solutions.io.model import load_model  # noqa: E402

LENGTH, MASS, GRAVITY = 0.5, 1.0, 9.81
INERTIA = MASS * LENGTH**2 / 12.0
T_END, OUTPUTS, TOL = 1.0, 100, 1e-6
DIVERGENCE = "skip"
"""Our runs leave out the divergence guard (``dynamics.judge_divergence``: a second run at 100 x rtol where the motion
can be chaotic, which the loop chain's one autonomous degree of freedom never is): the study times the same work
MuJoCo does; what the guard adds to a call is ``benchmarks/call_cost.py``'s row "whole call with the divergence
check"."""
SIZES = (2, 4, 8, 16, 32, 64)
CPU = [False]
"""With ``--cpu`` every timer reads this thread's CPU time (``time.thread_time``, as ``call_cost.py --cpu``): steadier
on a machine other work shares; what it leaves out is waiting, and neither our call nor MuJoCo's rollout (its step
loop in the calling thread) waits."""


PREPARED = [False]
"""With ``--prepared`` our runs are ``prepared.run`` of one ``dynamics.prepare`` (``ours_call``)."""


def now() -> float:
    """The timers' clock: wall time, or this thread's CPU time with ``--cpu``."""
    return time.thread_time() if CPU[0] else time.perf_counter()


# -- the chains ------------------------------------------------------------------------------------------------
def planar_chain(n: int, angle: float = math.radians(45.0)) -> dict:
    """N bars hanging from the ground point (0, 0), straight, ``angle`` from the downward vertical."""
    axis = np.array([math.sin(angle), -math.cos(angle)])
    phi = math.atan2(axis[1], axis[0])
    bodies, joints = [], []
    for i in range(n):
        centre = (i + 0.5) * LENGTH * axis
        bodies.append({"name": f"b{i}", "mass": MASS, "inertia": INERTIA, "location": centre.tolist(),
                       "orientation": phi})  # fmt: skip
        pin = (i * LENGTH * axis).tolist()
        joints.append({"name": f"j{i}", "type": "revolute", "body1": "ground" if i == 0 else f"b{i - 1}",
                       "body2": f"b{i}", "location": pin})  # fmt: skip
    return {"model": {"name": f"planar-chain-{n}", "dimension": 2, "gravity": [0.0, -GRAVITY],
                      "bodies": bodies, "joints": joints}}  # fmt: skip


def spatial_chain(n: int, turn: float = math.radians(30.0)) -> dict:
    """N bars on spherical joints, horizontal, bar i turned i * ``turn`` about the vertical from the x axis."""
    radius = 0.01
    inertia = [MASS * radius**2 / 2.0, INERTIA + MASS * radius**2 / 4.0, INERTIA + MASS * radius**2 / 4.0]
    bodies, joints, pin = [], [], np.zeros(3)
    for i in range(n):
        direction = np.array([math.cos(i * turn), math.sin(i * turn), 0.0])
        p = [math.cos(i * turn / 2.0), 0.0, 0.0, math.sin(i * turn / 2.0)]  # about z: the body x axis along the bar
        bodies.append({"name": f"b{i}", "mass": MASS, "inertia": inertia,
                       "location": (pin + 0.5 * LENGTH * direction).tolist(), "orientation": p})  # fmt: skip
        joints.append({"name": f"j{i}", "type": "spherical", "body1": "ground" if i == 0 else f"b{i - 1}",
                       "body2": f"b{i}", "location": pin.tolist()})  # fmt: skip
        pin = pin + LENGTH * direction
    return {"model": {"name": f"spatial-chain-{n}", "dimension": 3, "gravity": [0.0, 0.0, -GRAVITY],
                      "bodies": bodies, "joints": joints}}  # fmt: skip


def loop_chain(n: int, angle: float = math.radians(60.0), rate: float = 0.0, frames: str = "centre") -> dict:
    """N parallelogram four-bars in a row: cranks c0..cN from ground pivots (k L, 0), couplers k0..k(N-1).

    ``rate``: the cranks' starting angular velocity (rad/s; fast enough, the chain swings through the flat,
    singular position). ``frames``: "centre" places each body's frame at its centre of mass; "joint" at its
    first joint (a crank at its pivot, a coupler at its left pin) with the centre given as ``com`` in that frame,
    as engineers write bodies (then a body's velocity is that of its frame's origin)."""
    crank = np.array([math.sin(angle), -math.cos(angle)])  # from the pivot to the tip
    turn = np.array([-crank[1], crank[0]])  # crank turned +90 degrees: a tip's velocity is rate L turn
    phi = math.atan2(crank[1], crank[0])
    joint = frames == "joint"
    bodies, joints = [], []
    for k in range(n + 1):
        pivot = np.array([k * LENGTH, 0.0])
        frame = pivot if joint else pivot + 0.5 * LENGTH * crank
        bodies.append({"name": f"c{k}", "mass": MASS, "inertia": INERTIA, "location": frame.tolist(),
                       "orientation": phi, "angular_velocity": rate,
                       "velocity": (rate * (frame - pivot) @ crank * turn).tolist()})  # fmt: skip
        if joint:
            bodies[-1]["com"] = [0.5 * LENGTH, 0.0]
        joints.append({"name": f"o{k}", "type": "revolute", "body1": "ground", "body2": f"c{k}",
                       "location": pivot.tolist()})  # fmt: skip
    for k in range(n):
        tip = np.array([k * LENGTH, 0.0]) + LENGTH * crank
        frame = tip if joint else tip + [0.5 * LENGTH, 0.0]
        bodies.append({"name": f"k{k}", "mass": MASS, "inertia": INERTIA, "location": frame.tolist(),
                       "orientation": 0.0, "velocity": (rate * LENGTH * turn).tolist()})  # fmt: skip
        if joint:
            bodies[-1]["com"] = [0.5 * LENGTH, 0.0]
        joints.append({"name": f"a{k}", "type": "revolute", "body1": f"c{k}", "body2": f"k{k}",
                       "location": tip.tolist()})  # fmt: skip
        joints.append({"name": f"b{k}", "type": "revolute", "body1": f"k{k}", "body2": f"c{k + 1}",
                       "location": (tip + [LENGTH, 0.0]).tolist()})  # fmt: skip
    return {"model": {"name": f"loop-chain-{n}", "dimension": 2, "gravity": [0.0, -GRAVITY],
                      "bodies": bodies, "joints": joints}}  # fmt: skip


# -- references independent of the solver ---------------------------------------------------------------------
def _tight(f, y0: np.ndarray, times: np.ndarray) -> np.ndarray:
    solution = solve_ivp(f, (times[0], times[-1]), y0, method="DOP853", t_eval=times, rtol=1e-12, atol=1e-12)
    assert solution.success, solution.message
    return solution.y.T


def planar_reference(n: int, times: np.ndarray, angle: float = math.radians(45.0)) -> np.ndarray:
    """Body centres (len(times), n, 2) from Lagrange's equations in the absolute angles (module docstring)."""
    below = n - 1 - np.arange(n)  # bars below bar i
    a = MASS * LENGTH**2 * (n - np.maximum.outer(np.arange(n), np.arange(n)) - 0.5)
    np.fill_diagonal(a, INERTIA + MASS * LENGTH**2 * (below + 0.25))
    weight = MASS * GRAVITY * LENGTH * (below + 0.5)  # dV/dt_i = weight_i cos t_i, V = sum m g y

    def f(t, y):
        theta, rate = y[:n], y[n:]
        difference = theta[:, None] - theta[None, :]
        matrix = a * np.cos(difference)
        rhs = -(a * np.sin(difference)) @ rate**2 - weight * np.cos(theta)
        return np.concatenate([rate, np.linalg.solve(matrix, rhs)])

    theta0 = np.full(n, math.atan2(-math.cos(angle), math.sin(angle)))
    theta = _tight(f, np.concatenate([theta0, np.zeros(n)]), times)[:, :n]
    links = LENGTH * np.stack([np.cos(theta), np.sin(theta)], axis=-1)  # (T, n, 2)
    return np.cumsum(links, axis=1) - 0.5 * links


def loop_reference(n: int, times: np.ndarray, angle: float = math.radians(60.0), rate: float = 0.0) -> np.ndarray:
    """Body centres (len(times), 2n + 1, 2), cranks then couplers, from the chain's one equation in the crank
    angle t (starting at ``rate``): the cranks turn about their pivots, the couplers translate with the cranks'
    tips, so T = ((n + 1) J_O + n m l^2) t'^2 / 2 and V = ((n + 1) m l / 2 + n m l) g sin t, J_O = J + m l^2 / 4.
    The parallelogram branch throughout, through every flat position (t = k pi)."""
    inertia = (n + 1) * (INERTIA + MASS * LENGTH**2 / 4.0) + n * MASS * LENGTH**2
    weight = ((n + 1) * MASS * LENGTH / 2.0 + n * MASS * LENGTH) * GRAVITY

    def f(t, y):
        return [y[1], -weight * math.cos(y[0]) / inertia]

    theta = _tight(f, np.array([math.atan2(-math.cos(angle), math.sin(angle)), rate]), times)[:, 0]
    tip = LENGTH * np.stack([np.cos(theta), np.sin(theta)], axis=-1)  # (T, 2)
    pivots = LENGTH * np.arange(n + 1)
    cranks = np.stack([pivots[None, :] + 0.5 * tip[:, :1], np.broadcast_to(0.5 * tip[:, 1:], (len(times), n + 1))], -1)
    couplers = np.stack(
        [pivots[None, :n] + tip[:, :1] + 0.5 * LENGTH, np.broadcast_to(tip[:, 1:], (len(times), n))], axis=-1
    )
    return np.concatenate([cranks, couplers], axis=1)


def _quaternion_matrices(p: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) of the quaternions p (n, 4), normalized first: A = (2 e0^2 - 1) I + 2 (e e^T +
    e0 e~), written out here (not the package's function)."""
    p = p / np.linalg.norm(p, axis=1, keepdims=True)
    e0, e = p[:, 0], p[:, 1:]
    tilde = np.zeros((len(p), 3, 3))
    tilde[:, 0, 1], tilde[:, 0, 2], tilde[:, 1, 2] = -e[:, 2], e[:, 1], -e[:, 0]
    tilde -= np.swapaxes(tilde, 1, 2)
    return (2 * e0**2 - 1)[:, None, None] * np.eye(3) + 2 * (e[:, :, None] * e[:, None, :] + e0[:, None, None] * tilde)


def spatial_reference(n: int, times: np.ndarray, turn: float = math.radians(30.0)) -> np.ndarray:
    """Body centres (len(times), n, 3) of the spatial chain from Kane's equations in the bars' absolute angular
    velocities w_k (global axes), with each bar's unit vector e_k = A_k x along it and d = L e_k from a joint to
    the next, L/2 e_k to the centre: the moment about joint k of everything below it,

        sum_j M_kj w_j' = L m e_k x [sum_(i > k) (g - b_i) + (g - b_k) / 2] - w_k x J_k w_k,
        M_kj = -m L^2 c_kj [e_k~][e_j~] (+ J_k on the diagonal),  c_kj = N - 1 - max(k, j) + (1/2, or 1/4 if k = j),

    b_i = L [sum_(j < i) w_j x (w_j x e_j) + 1/2 w_i x (w_i x e_i)] the centres' accelerations at w' = 0 and J_k = A_k J
    A_k^T; orientations as quaternions p_k' = 1/2 (0, w_k) p_k. DOP853 at rtol = atol = 1e-12. Written for this
    benchmark alone (no code of the package), so it judges every code's spatial chain, ours included."""
    radius = 0.01
    J = np.diag([MASS * radius**2 / 2.0, INERTIA + MASS * radius**2 / 4.0, INERTIA + MASS * radius**2 / 4.0])
    g = np.array([0.0, 0.0, -GRAVITY])
    index = np.arange(n)
    c = n - 1 - np.maximum.outer(index, index) + np.where(np.eye(n, dtype=bool), 0.25, 0.5)

    def f(t, y):
        p, w = y[: 4 * n].reshape(n, 4), y[4 * n :].reshape(n, 3)
        A = _quaternion_matrices(p)
        e = A[:, :, 0]
        inertia = A @ J @ np.swapaxes(A, 1, 2)
        # [e_k~][e_j~] = e_j e_k^T - (e_k . e_j) I, block (k, j) of the 3n x 3n matrix
        products = np.einsum("ja,kb->kjab", e, e) - np.einsum("ka,ja->kj", e, e)[:, :, None, None] * np.eye(3)
        blocks = -MASS * LENGTH**2 * c[:, :, None, None] * products
        blocks[index, index] += inertia
        matrix = blocks.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)
        h = np.cross(w, np.cross(w, e))
        b = LENGTH * (np.cumsum(h, axis=0) - 0.5 * h)  # sum over j < i of h_j, and half of h_i
        load = g - b
        below = np.cumsum(load[::-1], axis=0)[::-1] - load  # sum over i > k
        rhs = MASS * LENGTH * np.cross(e, below + 0.5 * load) - np.cross(w, np.einsum("kab,kb->ka", inertia, w))
        wd = np.linalg.solve(matrix, rhs.ravel())
        pd = 0.5 * np.concatenate(
            [-(w * p[:, 1:]).sum(1)[:, None], p[:, :1] * w + np.cross(w, p[:, 1:])], axis=1
        )  # (0, w) p: (-w . e, e0 w + w x e)
        return np.concatenate([pd.ravel(), wd])

    p0 = np.array([[math.cos(i * turn / 2.0), 0.0, 0.0, math.sin(i * turn / 2.0)] for i in range(n)])
    states = _tight(f, np.concatenate([p0.ravel(), np.zeros(3 * n)]), times)
    centres = []
    for y in states:
        links = LENGTH * _quaternion_matrices(y[: 4 * n].reshape(n, 4))[:, :, 0]
        centres.append(np.cumsum(links, axis=0) - 0.5 * links)
    return np.array(centres)


FAMILIES = {"planar": planar_chain, "spatial": spatial_chain, "loops": loop_chain}
REFERENCES = {
    "planar": "Lagrange's equations in the absolute angles",
    "spatial": "Kane's equations in the absolute angular velocities",
    "loops": "the crank angle's equation",
}


# -- runs ------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Config:
    engine: str
    formulation: str
    integrator: str = "dop853"

    @property
    def label(self) -> str:
        return f"{self.engine} {self.formulation} {self.integrator}"


CONFIGS = (
    Config("numpy", "baumgarte"),
    Config("numpy", "joint-coordinates"),
    Config("compiled", "baumgarte"),
    Config("compiled", "joint-coordinates"),
)


@dataclass
class Row:
    family: str
    n: int
    config: str
    seconds: float = math.nan
    evaluations: int = 0
    error: float = math.nan
    compile_seconds: float = math.nan
    failure: str = ""
    setting: tuple = ()  # MuJoCo's (integrator, k[, closure]): what the paired rounds run again

    @property
    def us_per_evaluation(self) -> float:
        return 1e6 * self.seconds / self.evaluations if self.evaluations else math.nan


def reference(family: str, n: int, system, q0, qd0, times: np.ndarray) -> np.ndarray:
    if family == "planar":
        return planar_reference(n, times)
    if family == "loops":
        return loop_reference(n, times)
    return spatial_reference(n, times)


def ours_call(scene, config: Config, options: dict):
    """Our run as the study times it: ``forward_dynamics``, or with ``--prepared`` ``run`` of one ``prepare``d run
    made here (the caller's first call makes what its runs share: timed apart, as MuJoCo's model compilation)."""
    system, q0, qd0, _ = scene
    if PREPARED[0]:
        prepared = prepare(system, T_END, OUTPUTS, config.formulation, config.integrator, **options)
        return lambda: prepared.run(q0, qd0)
    return lambda: forward_dynamics(system, q0, qd0, T_END, OUTPUTS, config.formulation, config.integrator, **options)


def run(family: str, n: int, config: Config, truth: np.ndarray, repeats: int, scene, tol: float = TOL) -> Row:
    dimension = scene[3]
    row = Row(family, n, config.label if tol == TOL else f"{config.label}, rtol = atol = {tol:g}", setting=(tol,))
    options = dict(rtol=tol, atol=tol, engine=config.engine, divergence=DIVERGENCE)
    try:
        call = ours_call(scene, config, options)
        if config.engine == "compiled" or PREPARED[0]:
            start = now()
            call()
            row.compile_seconds = now() - start  # compilation (or loading the cache), the preparation and one run
        best = math.inf
        for _ in range(repeats):
            start = now()
            result = call()
            best = min(best, now() - start)
            if best > 1.0:
                break
    except AnalysisError as err:
        row.failure = str(err).splitlines()[0][:80]
        return row
    engine = result.info.get("chosen", {}).get("engine", config.engine)
    if engine != config.engine:
        row.failure = f"ran on {engine}: {result.info['chosen'].get('engine_why', '')}"[:80]
    row.seconds, row.evaluations = best, int(result.info["rhs_evaluations"])
    row.compile_seconds = row.compile_seconds - best if config.engine == "compiled" else math.nan
    row.error = float(np.max(np.linalg.norm(body_positions(result.q, dimension) - truth, axis=-1)))
    return row


# -- MuJoCo, the same chains in its minimal coordinates (the loop chain: a tree and connect equalities) ------------
MUJOCO_INTEGRATORS = ("RK4", "implicitfast", "Euler")
SUBSTEPS = (1, 2, 3, 4, 5, 6, 8, 10, 12, 16, 20, 25, 32, 40, 50, 64, 80, 100, 128, 160, 200, 256, 320, 400, 512)
"""Steps per output interval tried: h = (output interval) / k. Each integrator's cheapest k that reaches the error
target is its configuration; the fastest of those is MuJoCo's for the table."""
MUJOCO_TARGET = TOL
"""The position error (m) a MuJoCo configuration must reach: the tolerance the project's runs are asked."""
MUJOCO_SECONDS = 20.0
"""A MuJoCo integrator whose run takes longer than this stops searching smaller steps."""
MUJOCO_SLOWER = 2.0
"""A scan also stops once a run takes this many times the fastest configuration already found: smaller steps cost
more still, so it cannot win (first-order Euler and implicitfast need some 10^4 steps per second for 1e-6 m)."""
CLOSURES = (
    (None, (0.9999, 0.9999, 0.001)),
    (None, (0.99, 0.99, 0.001)),
    (None, (0.9, 0.95, 0.001)),
    (0.02, (0.9999, 0.9999, 0.001)),
    (0.02, (0.9, 0.95, 0.001)),
)
"""The loop closures' softness tried on the loop chain, stiff first: (solref time constant, solimp). A time constant
None is two steps (the exporter's default, the stiffest MuJoCo keeps stable: it raises a shorter one to 2h), 0.02 s
MuJoCo's default; solimp (dmin, dmax, width) from the stiffest MuJoCo allows (0.9999) to its default (0.9, 0.95,
0.001). A connect equality is a soft constraint: the error it lets the loop open by counts in the position error."""


def mujoco_chain(family: str, n: int, h: float, integrator: str) -> str:
    """MJCF of the planar or spatial chain (``planar_chain``, ``spatial_chain``): nested bodies, each frame at its
    joint (hinge about z, or ball), the bar's centre and inertia in it, the file's initial configuration at qpos 0
    (planar) or at the bodies' orientations (spatial), at rest."""
    option = f'<option gravity="{{}}" integrator="{integrator}" timestep="{h!r}"/>'
    bodies, closing = [], []
    if family == "planar":
        angle = math.radians(45.0)
        axis = np.array([math.sin(angle), -math.cos(angle), 0.0])
        for i in range(n):
            pos = np.zeros(3) if i == 0 else LENGTH * axis
            bodies.append(
                f'<body pos="{_v(pos)}"><joint type="hinge" axis="0 0 1"/><inertial pos="{_v(0.5 * LENGTH * axis)}" '
                f'mass="{MASS!r}" diaginertia="{INERTIA!r} {INERTIA!r} {INERTIA!r}"/>'
            )
            closing.append("</body>")
        gravity = [0.0, -GRAVITY, 0.0]
    else:
        turn, radius = math.radians(30.0), 0.01
        inertia = [MASS * radius**2 / 2.0, INERTIA + MASS * radius**2 / 4.0, INERTIA + MASS * radius**2 / 4.0]
        for i in range(n):  # each bar turned `turn` about z from its parent; frame x along the bar
            pos = np.zeros(3) if i == 0 else np.array([LENGTH, 0.0, 0.0])
            quat = [1.0, 0.0, 0.0, 0.0] if i == 0 else [math.cos(turn / 2.0), 0.0, 0.0, math.sin(turn / 2.0)]
            bodies.append(
                f'<body pos="{_v(pos)}" quat="{_v(quat)}"><joint type="ball"/><inertial pos="{0.5 * LENGTH!r} 0 0" '
                f'mass="{MASS!r}" diaginertia="{_v(inertia)}"/>'
            )
            closing.append("</body>")
        gravity = [0.0, 0.0, -GRAVITY]
    return f"<mujoco>{option.format(_v(gravity))}<worldbody>{''.join(bodies)}{''.join(closing)}</worldbody></mujoco>"


def _v(x) -> str:
    return " ".join(repr(float(c)) for c in x)


def mujoco_loops(n: int, h: float, integrator: str, closure: tuple = CLOSURES[0]) -> str:
    """MJCF of the loop chain (``loop_chain``) as ``mbd export --to mjcf`` writes it (``solutions.io.mjcf``): a
    spanning tree of hinges, each loop closed by a ``connect`` equality with the ``closure``'s solref time constant
    and solimp (CLOSURES), its keyframe 'initial' the chain's starting state; the step h and ``integrator`` set."""
    from solutions.io.mjcf import Stiffness, export_mjcf

    time_constant, solimp = closure
    xml = export_mjcf(load_model(loop_chain(n)), Stiffness(timestep=h, time_constant=time_constant, solimp=solimp))
    return xml.replace('integrator="RK4"', f'integrator="{integrator}"', 1)


def effective_closure(closure: tuple, h: float) -> tuple:
    """The closure MuJoCo integrates at step h: its time constant raised to 2h at least (MuJoCo's refsafe)."""
    time_constant, solimp = closure
    return max(time_constant or 0.0, 2.0 * h), solimp


def closure_label(closure: tuple) -> str:
    time_constant, solimp = closure
    return f"solref {'2h' if time_constant is None else f'{time_constant:g}'}, solimp {solimp[0]:g} {solimp[1]:g}"


class MujocoRun:
    """One MuJoCo configuration of a chain, ready to run 1 s: h = interval / k, ``mujoco.rollout`` (the step loop in
    C, no Python per step) from the chain's initial state (the loop chain: its MJCF's keyframe). ``ids``: MuJoCo's
    bodies in the order of the family's model (the reference's)."""

    def __init__(self, family: str, n: int, k: int, integrator: str, closure: tuple | None = None):
        import mujoco

        self.k = k
        h = T_END / OUTPUTS / k
        if family == "loops":
            self.model = mujoco.MjModel.from_xml_string(mujoco_loops(n, h, integrator, closure or CLOSURES[0]))
            self.data = mujoco.MjData(self.model)
            mujoco.mj_resetDataKeyframe(self.model, self.data, 0)
            names = [body["name"] for body in loop_chain(n)["model"]["bodies"]]
            self.ids = [self.model.body(name).id for name in names]
        else:
            self.model = mujoco.MjModel.from_xml_string(mujoco_chain(family, n, h, integrator))
            self.data = mujoco.MjData(self.model)
            self.ids = list(range(1, self.model.nbody))
        self.qpos0 = self.data.qpos.copy()
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.state = np.empty(mujoco.mj_stateSize(self.model, spec))
        mujoco.mj_getState(self.model, self.data, self.state, spec)

    def __call__(self) -> tuple[float, np.ndarray]:
        """(seconds, the states after every step) of one rollout."""
        from mujoco import rollout

        start = now()
        states, _ = rollout.rollout(self.model, self.data, self.state[None], nstep=OUTPUTS * self.k)
        return now() - start, states


def mujoco_attempt(family: str, n: int, k: int, integrator: str, truth: np.ndarray, repeats: int, closure=None):
    """(seconds of the best of ``repeats`` rollouts of 1 s, error (m)) at h = interval / k, the body centres at the
    output times from its states afterwards (``closure``: the loop chain's, CLOSURES)."""
    run = MujocoRun(family, n, k, integrator, *([closure] if closure else []))
    best, states = math.inf, None
    for _ in range(repeats):
        seconds, states = run()
        best = min(best, seconds)
    centres = mujoco_centres(run, states, 3 if family == "spatial" else 2)
    return best, float(np.max(np.linalg.norm(centres - truth, axis=-1)))


def mujoco_centres(run: MujocoRun, states: np.ndarray, dimension: int) -> np.ndarray:
    """The body centres (OUTPUTS + 1, bodies, dimension) at the output times from a rollout's states: its first
    state, then the state after every k steps (t_1 ... t_end)."""
    import mujoco

    model, data, k = run.model, run.data, run.k
    centres = []
    for q in [run.qpos0, *states[0, k - 1 :: k, 1 : 1 + model.nq]]:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        centres.append(data.xipos[run.ids, :dimension].copy())
    return np.array(centres)


def mujoco_run(family: str, n: int, truth: np.ndarray, repeats: int, target: float = MUJOCO_TARGET) -> Row:
    """MuJoCo's fastest configuration that reaches ``target`` (m): for each integrator (and, on the loop chain, each
    closure of CLOSURES) the first k of SUBSTEPS that does, timed; the fastest of them (the table's row names it, and
    the target when it is not MUJOCO_TARGET: the error the project's joint-coordinates run reached, where that is
    larger). A scan gives up after a run longer than MUJOCO_SECONDS, or than MUJOCO_SLOWER times the fastest found."""
    found, tried = [], set()
    for integrator in MUJOCO_INTEGRATORS:
        for closure in CLOSURES if family == "loops" else (None,):
            for k in SUBSTEPS:
                model = (integrator, k, closure and effective_closure(closure, T_END / OUTPUTS / k))
                if model in tried:  # a time constant under 2h is 2h: this closure is an earlier one at this k
                    continue
                tried.add(model)
                seconds, error = mujoco_attempt(family, n, k, integrator, truth, 1, closure)
                if error <= target:
                    seconds, error = mujoco_attempt(family, n, k, integrator, truth, repeats, closure)
                    found.append((seconds, error, integrator, k, closure))
                    break
                if seconds > MUJOCO_SECONDS or found and seconds > MUJOCO_SLOWER * min(f[0] for f in found):
                    break
    matched = "" if target == MUJOCO_TARGET else f" (error <= {target:.2g}, as joint coordinates)"
    if not found:
        failure = f"no integrator reached {target:g} m with k <= {SUBSTEPS[-1]}"
        return Row(family, n, f"MuJoCo{matched}", failure=failure)
    seconds, error, integrator, k, closure = min(found, key=lambda f: f[0])
    steps = OUTPUTS * k
    stages = 4 if integrator == "RK4" else 1
    soft = f", {closure_label(closure)}" if closure else ""
    label = f"MuJoCo {integrator} h = {T_END / steps:.3g}{soft}{matched}"
    setting = (integrator, k, closure) if closure else (integrator, k)
    return Row(family, n, label, seconds, stages * steps, error, setting=setting)


OUR_TOLERANCES = (1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8, 3e-9, 1e-9)
"""rtol = atol tried, loose to tight, for our cheapest run reaching the error target (``ours_at_target``)."""


def ours_at_target(family: str, n: int, truth: np.ndarray, repeats: int, scene, limit: float) -> Row | None:
    """``PAIRED`` at the loosest of OUR_TOLERANCES whose error is at most MUJOCO_TARGET (timed again with
    ``repeats``), as MuJoCo's step is the largest that reaches it: each code at its cheapest setting for the same
    error. None where none does, or a run takes longer than ``limit`` seconds first."""
    for tol in OUR_TOLERANCES:
        row = run(family, n, PAIRED, truth, 1, scene, tol)
        if row.failure or row.seconds > limit:
            return None
        if row.error <= MUJOCO_TARGET:
            row = run(family, n, PAIRED, truth, repeats, scene, tol)
            row.config += f" (error <= {MUJOCO_TARGET:g})"
            return row
    return None


def paired(family: str, n: int, config: Config, scene, mujoco: Row, rounds: int, tol: float = TOL) -> list[float]:
    """Ours / MuJoCo's time in each of ``rounds`` interleaved rounds: a round times one call of ``config`` and one
    rollout of MuJoCo's configuration, the order alternating from round to round, so that both meet the same state
    of the machine; the spread of the ratios is the measurement's own."""
    integrator, k, *closure = mujoco.setting  # the loop chain's closure too
    theirs = MujocoRun(family, n, k, integrator, *closure)
    options = dict(rtol=tol, atol=tol, engine=config.engine, divergence=DIVERGENCE)
    call = ours_call(scene, config, options)
    if PREPARED[0]:
        call()  # the preparation, outside the rounds

    def ours() -> float:
        start = now()
        call()
        return now() - start

    return interleaved(ours, lambda: theirs()[0], rounds)


PAIRED = Config("compiled", "joint-coordinates")
"""Our configuration that the paired rounds set against MuJoCo's."""


def paired_table(pairs: list, rounds: int) -> list[str]:
    """The paired rounds' ratios, per N and MuJoCo configuration: median and range."""
    if not pairs:
        return []
    lines = [f"Paired rounds at equal error (<= {MUJOCO_TARGET:g} m, each at its cheapest setting): {PAIRED.label} / "
             f"MuJoCo, {rounds} interleaved rounds each; below 1: ours faster:", "",
             "| N | ours | MuJoCo | median ratio | lowest | highest |", "|---:|---|---|---:|---:|---:|"]  # fmt: skip
    for n, ours, label, ratios in pairs:
        lines.append(f"| {n} | {ours} | {label} | {np.median(ratios):.2f} | {min(ratios):.2f} | {max(ratios):.2f} |")
    return lines + [""]


def growth(rows: list[Row]) -> float:
    """p of time per evaluation ~ N^p, least squares in log-log over N >= 8 (NaN with fewer than two points)."""
    points = [(r.n, r.us_per_evaluation) for r in rows if r.n >= 8 and not r.failure and r.evaluations]
    if len(points) < 2:
        return math.nan
    n, us = np.log([p[0] for p in points]), np.log([p[1] for p in points])
    return float(np.polyfit(n, us, 1)[0])


def fmt(x: float, spec: str) -> str:
    return "" if x is None or not np.isfinite(x) else format(x, spec)


def table(family: str, rows: list[Row], configs: tuple[Config, ...]) -> list[str]:
    judged = f"an independent ODE at 1e-12: {REFERENCES[family]}"
    lines = [f"## {family} (error against {judged})", "",
             "| N | configuration | ms per simulated s | rhs evaluations | us per rhs | error (m) | first call +s |",
             "|---:|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    for r in rows:
        if r.failure and not r.evaluations:
            lines.append(f"| {r.n} | {r.config} | failed: {r.failure} | | | | |")
            continue
        note = f" ({r.failure})" if r.failure else ""
        lines.append(
            f"| {r.n} | {r.config}{note} | {fmt(1e3 * r.seconds / T_END, '.1f')} | {r.evaluations} | "
            f"{fmt(r.us_per_evaluation, '.0f')} | {fmt(r.error, '.1e')} | {fmt(r.compile_seconds, '.1f')} |"
        )
    lines += ["", "| configuration | time per rhs ~ N^p, p over N >= 8 |", "|---|---:|"]
    for config in configs:
        lines.append(f"| {config.label} | {fmt(growth([r for r in rows if r.config == config.label]), '.2f')} |")
    if any(r.config.startswith("MuJoCo") for r in rows):
        at_target = [r for r in rows if r.config.startswith("MuJoCo") and "as joint coordinates" not in r.config]
        lines.append(f"| MuJoCo (error <= {MUJOCO_TARGET:g} m) | {fmt(growth(at_target), '.2f')} |")
        ours = [r for r in rows if r.config.endswith(f"(error <= {MUJOCO_TARGET:g})")]
        lines.append(f"| {PAIRED.label} (error <= {MUJOCO_TARGET:g} m) | {fmt(growth(ours), '.2f')} |")
    return lines + [""]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="mbd bench --scaling", description=__doc__.splitlines()[0])
    parser.add_argument("--family", nargs="*", choices=list(FAMILIES), default=list(FAMILIES), help="default: all")
    parser.add_argument("--sizes", nargs="*", type=int, default=list(SIZES), help="chain sizes N (default 2 ... 64)")
    parser.add_argument("--quick", action="store_true", help="N = 2, 4, 8 on the numpy engine only")
    parser.add_argument("--repeats", type=int, default=3, help="timed calls per run, the best kept (default 3)")
    parser.add_argument("--limit", type=float, default=60.0, help="seconds a run may take before larger N are left out")
    parser.add_argument("--out", type=Path, default=None, help="write the Markdown here too")
    parser.add_argument("--mujoco", action="store_true", help="MuJoCo's fastest configuration too (extra [bench])")
    parser.add_argument("--configs", nargs="*", help="only these configurations ('compiled joint-coordinates dop853')")
    parser.add_argument(
        "--rounds", type=int, default=7, help="interleaved rounds of ours against MuJoCo's configuration (--mujoco)"
    )
    parser.add_argument("--cpu", action="store_true", help="time this thread's CPU, not the wall (a shared machine)")
    parser.add_argument(
        "--prepared", action="store_true", help="time ours as prepared.run of one dynamics.prepare (prepared apart)"
    )
    args = parser.parse_args(argv)
    CPU[0], PREPARED[0] = args.cpu, args.prepared
    if args.mujoco:
        try:
            import mujoco  # noqa: F401
        except ImportError:
            parser.error("--mujoco needs MuJoCo: pip install -e '.[bench]' (or pip install mujoco)")
    sizes = [n for n in args.sizes if n <= 8] if args.quick else args.sizes
    configs = tuple(c for c in CONFIGS if c.engine == "numpy") if args.quick else CONFIGS
    configs = tuple(c for c in configs if not args.configs or c.label in args.configs)
    clock = "thread CPU" if args.cpu else "wall"
    lines = ["# Scaling with the number of bodies (benchmarks/chains.py)", "",
             f"{T_END:g} s simulated, {OUTPUTS} output intervals, rtol = atol = {TOL:g}; machine: {os.cpu_count()} "
             f"cores, load average {os.getloadavg()[0]:.1f} at the start; times: {clock}"
             f"{'; ours: prepared.run, first call +s: the preparation' if args.prepared else ''}."
             f" Command: `python benchmarks/chains.py "
             f"{' '.join(argv if argv is not None else sys.argv[1:])}`.", ""]  # fmt: skip
    for family in args.family:
        rows, broken, pairs = [], set(), []
        for n in sizes:
            system, q0, qd0 = build_system(load_model(FAMILIES[family](n)))
            dimension = system.model.dimension
            truth = reference(family, n, system, q0, qd0, np.linspace(0.0, T_END, OUTPUTS + 1))
            for config in configs:
                if config.label in broken:
                    continue
                row = run(family, n, config, truth, args.repeats, (system, q0, qd0, dimension))
                rows.append(row)
                said = f"{family} N={n} {config.label}: {fmt(1e3 * row.seconds, '.1f')} ms {row.failure}"
                print(said, file=sys.stderr, flush=True)
                if row.failure and not row.evaluations or row.seconds > args.limit:
                    broken.add(config.label)
            if args.mujoco:  # both at their cheapest setting reaching MUJOCO_TARGET
                scene = (system, q0, qd0, dimension)
                ours = ours_at_target(family, n, truth, args.repeats, scene, args.limit)
                theirs = mujoco_run(family, n, truth, args.repeats, MUJOCO_TARGET)
                for row in (ours, theirs):
                    if row is not None:
                        rows.append(row)
                        said = f"{family} N={n} {row.config}: {fmt(1e3 * row.seconds, '.1f')} ms {row.failure}"
                        print(said, file=sys.stderr, flush=True)
                if ours is not None and theirs.setting and args.rounds:
                    ratios = paired(family, n, PAIRED, scene, theirs, args.rounds, ours.setting[0])
                    pairs.append((n, f"rtol = {ours.setting[0]:g}", theirs.config, ratios))
        lines += table(family, rows, configs) + paired_table(pairs, args.rounds)
        if args.out:  # after each family: a long run that is stopped keeps what it measured
            args.out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
