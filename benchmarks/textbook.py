"""The textbook code against `mbd run`, as whole processes: the free slider-crank to 1e-6 (issue 25's target).

The textbook code is what a student of the course would write on a page: the crank, rod and piston in Cartesian
coordinates q = (x, y, phi) per body, the revolute and prismatic constraints written out with their Jacobian and
gamma, Lagrange multipliers from the augmented system [[M, Psi_q^T], [Psi_q, 0]] solved by ``numpy.linalg.solve``,
Baumgarte's stabilization (alpha = beta = 5, eq. 5.29) and ``scipy.integrate.solve_ivp``. It imports numpy and
scipy only; ``python benchmarks/textbook.py --run METHOD RTOL OUT.npy`` is the whole program.

``--compare`` (the default) measures, for the free slider-crank of ``benchmarks/bench.py`` (slider_crank_flywheel
without its gas force and load torque, 5 s, 100 output steps):

1. the textbook code's fastest setting reaching a position error of 1e-6 m (RK45 and DOP853, rtol = atol from
   1e-5 to 1e-11), its error against the minimal-coordinate reference of ``bench.slider_crank_positions`` (the
   crank-angle ODE at 1e-13);
2. ``mbd run`` of the same model file with no simulation settings (every default: formulation, integrator and
   engine auto, accuracy 1e-6), and with ``--engine numpy``, its error from the CSV it writes;
3. interleaved rounds of the whole processes (the textbook program, each ``mbd run``), the ratio of each to the
   textbook program of its round; the median and spread of the ratios.

The compiled engine's code must be on disk for ``mbd run``'s default to take it (``mbd compile``); the table says
which engine ran and why (the run's own summary line).

``--in-process`` compares the textbook code with the numpy engine in one process, per scene of issue 25's bench
(the planar double pendulum, 10 s; the free slider-crank, 5 s; the spatial double pendulum, 5 s; 100 output
steps each), each scene written out as a textbook would (``double_pendulum_rhs``, ``slider_crank_rhs``,
``spatial_double_pendulum_rhs``: the spatial one in Euler parameters with p^T p = 1 as a constraint and the
Euler-parameter equations of motion, Haug 1989, sec. 11.3), against ``forward_dynamics(..., "baumgarte",
"dop853", engine="numpy")``, the same formulation, method and alpha = beta = 5:

- at equal rtol (rtol = atol = 1e-6, 1e-7, 1e-8): paired rounds, this thread's CPU time (``time.thread_time``,
  steadier than the wall on a shared machine), the ratio textbook / engine of each round (above 1: the engine is
  faster), its median and spread, the errors and right-hand-side evaluations of both; and the same for the engine
  with the checks the textbook code does not make switched off (``UNCHECKED``): what those checks cost;
- at equal error (largest body-centre error 1e-6 m, the references of ``bench.prepare_reference``: minimal
  coordinates for the planar scenes, the joint-coordinate formulation at 1e-13 for the spatial one): each code at
  the loosest rtol = atol of the grid 1e-5, 5e-6, 2e-6, 1e-6, ... 1e-11 that reaches it, then paired rounds.

    .venv/bin/python benchmarks/textbook.py --in-process --rounds 5
"""

from __future__ import annotations

import argparse
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before NumPy is imported: the matrices are small

import numpy as np  # noqa: E402

ALPHA = BETA = 5.0
T_END, STEPS = 5.0, 100
G = 9.81
MASSES = np.array([5.0, 5.0, 0.5, 1.0, 1.0, 7.5e-3, 0.5, 0.5, 1.0e-4])  # (m, m, I) of crank, rod, piston
CRANK_A = np.array([0.1, 0.0])  # crank pin A in the crank's frame (centre on the axis O)
ROD_A, ROD_B = np.array([-0.15, 0.0]), np.array([0.15, 0.0])  # A and B in the rod's frame (centre mid-rod)


# -- the textbook code ----------------------------------------------------------------------------------------------
def rot(phi):
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


def drot(phi):
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[-s, -c], [c, -s]])


def constraints(q):
    r1, p1, r2, p2, r3, p3 = q[0:2], q[2], q[3:5], q[5], q[6:8], q[8]
    return np.concatenate([
        r1,                                                   # O: crank centre on the ground's origin
        r1 + rot(p1) @ CRANK_A - r2 - rot(p2) @ ROD_A,        # A: crank pin = rod's end
        r2 + rot(p2) @ ROD_B - r3,                            # B: rod's end = piston centre
        [r3[1], p3],                                          # cylinder: piston on the x axis, not turning
    ])  # fmt: skip


def jacobian(q):
    p1, p2 = q[2], q[5]
    J = np.zeros((8, 9))
    J[0:2, 0:2] = np.eye(2)
    J[2:4, 0:2], J[2:4, 2] = np.eye(2), drot(p1) @ CRANK_A
    J[2:4, 3:5], J[2:4, 5] = -np.eye(2), -drot(p2) @ ROD_A
    J[4:6, 3:5], J[4:6, 5] = np.eye(2), drot(p2) @ ROD_B
    J[4:6, 6:8] = -np.eye(2)
    J[6, 7], J[7, 8] = 1.0, 1.0
    return J


def gamma(q, qd):
    p1, p2, w1, w2 = q[2], q[5], qd[2], qd[5]
    g = np.zeros(8)
    g[2:4] = rot(p1) @ CRANK_A * w1**2 - rot(p2) @ ROD_A * w2**2
    g[4:6] = rot(p2) @ ROD_B * w2**2
    return g


def slider_crank_rhs(t, y):
    q, qd = y[:9], y[9:]
    J = jacobian(q)
    M = np.diag(MASSES)
    Q = np.array([0.0, -MASSES[0] * G, 0.0, 0.0, -MASSES[3] * G, 0.0, 0.0, -MASSES[6] * G, 0.0])
    rhs_c = gamma(q, qd) - 2 * ALPHA * (J @ qd) - BETA**2 * constraints(q)
    A = np.block([[M, J.T], [J, np.zeros((8, 8))]])
    qdd = np.linalg.solve(A, np.concatenate([Q, rhs_c]))[:9]
    return np.concatenate([qd, qdd])


SLIDER_CRANK_START = np.concatenate([
    [0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.4, 0.0, 0.0],               # q: crank, rod, piston
    [0.0, 0.0, 50.0, 0.0, 2.5, -50.0 / 3.0, 0.0, 0.0, 0.0],       # q': consistent at the head dead centre
])  # fmt: skip


def textbook(method: str, rtol: float, scene: str = "slider_crank") -> np.ndarray:
    """Body centres (steps + 1, bodies, dimension) on the output grid of one scene, by ``solve_ivp``."""
    from scipy.integrate import solve_ivp

    rhs, y0, t_end, per, dimension = TEXTBOOK[scene]
    n = y0.size // 2
    times = np.linspace(0.0, t_end, STEPS + 1)
    solution = solve_ivp(rhs, (0.0, t_end), y0, method=method, rtol=rtol, atol=rtol, t_eval=times)
    return solution.y[:n].T.reshape(times.size, -1, per)[:, :, :dimension]


# -- the planar double pendulum, written out the same way ---------------------------------------------------------
DP_MASSES = np.array([1.0, 1.0, 0.08333333333333333, 0.6, 0.6, 0.032])  # (m, m, I) of the upper and lower rods
UPPER_O, UPPER_A = np.array([-0.5, 0.0]), np.array([0.5, 0.0])  # O and A in the upper rod's frame (1 m rod)
LOWER_A = np.array([-0.4, 0.0])  # A in the lower rod's frame (0.8 m rod)
DP_START = np.concatenate([
    [0.4330127018922193, -0.25, -0.5235987755982988, 1.2660254037844386, -0.5, 0.0],  # course/models/double_pendulum
    np.zeros(6),                                                                        # released at rest
])  # fmt: skip


def double_pendulum_rhs(t, y):
    q, qd = y[:6], y[6:]
    r1, p1, r2, p2, w1, w2 = q[0:2], q[2], q[3:5], q[5], qd[2], qd[5]
    psi = np.concatenate([r1 + rot(p1) @ UPPER_O, r1 + rot(p1) @ UPPER_A - r2 - rot(p2) @ LOWER_A])
    J = np.zeros((4, 6))
    J[0:2, 0:2], J[0:2, 2] = np.eye(2), drot(p1) @ UPPER_O
    J[2:4, 0:2], J[2:4, 2] = np.eye(2), drot(p1) @ UPPER_A
    J[2:4, 3:5], J[2:4, 5] = -np.eye(2), -drot(p2) @ LOWER_A
    g = np.concatenate([rot(p1) @ UPPER_O * w1**2, rot(p1) @ UPPER_A * w1**2 - rot(p2) @ LOWER_A * w2**2])
    M = np.diag(DP_MASSES)
    Q = np.array([0.0, -DP_MASSES[0] * G, 0.0, 0.0, -DP_MASSES[3] * G, 0.0])
    rhs_c = g - 2 * ALPHA * (J @ qd) - BETA**2 * psi
    A = np.block([[M, J.T], [J, np.zeros((4, 4))]])
    qdd = np.linalg.solve(A, np.concatenate([Q, rhs_c]))[:6]
    return np.concatenate([qd, qdd])


# -- the spatial double pendulum: Euler parameters, p^T p = 1 as a constraint (Haug 1989, ch. 9 and 11) ----------
SDP_MASS, SDP_INERTIA = 1.0, np.diag([2.0e-4, 0.0834, 0.0834])  # each rod: 1 kg, principal moments about its centre
ROD_BACK, ROD_TIP = np.array([-0.5, 0.0, 0.0]), np.array([0.5, 0.0, 0.0])  # its ends in its frame (1 m along x)
SDP_START = np.concatenate([
    [0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],                                          # rod 1 along x from O
    [1.0, 0.5, 0.0, 0.7071067811865476, 0.0, 0.0, 0.7071067811865476],           # rod 2 along y from A
    np.zeros(14),                                                                  # released at rest
])  # fmt: skip


def tilde(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def rotation(p):
    """A(p) = (2 e0^2 - 1) I + 2 (e e^T + e0 e~)."""
    e0, e = p[0], p[1:]
    return (2 * e0**2 - 1) * np.eye(3) + 2 * (np.outer(e, e) + e0 * tilde(e))


def b_matrix(p, a):
    """B(p, a') = d(A(p) a')/dp = 2 [(e0 I + e~) a', e a'^T - (e0 I + e~) a'~] (3 x 4)."""
    e0, e = p[0], p[1:]
    C = e0 * np.eye(3) + tilde(e)
    return 2 * np.column_stack([C @ a, np.outer(e, a) - C @ tilde(a)])


def l_matrix(p):
    """L(p) = [-e, -e~ + e0 I] (3 x 4): omega' = 2 L p'."""
    return np.column_stack([-p[1:], -tilde(p[1:]) + p[0] * np.eye(3)])


def spatial_double_pendulum_rhs(t, y):
    q, qd = y[:14], y[14:]
    r1, p1, r2, p2 = q[0:3], q[3:7], q[7:10], q[10:14]
    pd1, pd2 = qd[3:7], qd[10:14]
    psi = np.concatenate([
        r1 + rotation(p1) @ ROD_BACK,                                       # O: rod 1's back end on the ground
        r1 + rotation(p1) @ ROD_TIP - r2 - rotation(p2) @ ROD_BACK,         # A: rod 2's back end on rod 1's tip
        [p1 @ p1 - 1.0, p2 @ p2 - 1.0],                                     # unit Euler parameters
    ])  # fmt: skip
    J = np.zeros((8, 14))
    J[0:3, 0:3], J[0:3, 3:7] = np.eye(3), b_matrix(p1, ROD_BACK)
    J[3:6, 0:3], J[3:6, 3:7] = np.eye(3), b_matrix(p1, ROD_TIP)
    J[3:6, 7:10], J[3:6, 10:14] = -np.eye(3), -b_matrix(p2, ROD_BACK)
    J[6, 3:7], J[7, 10:14] = 2 * p1, 2 * p2
    g = np.concatenate([
        -b_matrix(pd1, ROD_BACK) @ pd1,
        -b_matrix(pd1, ROD_TIP) @ pd1 + b_matrix(pd2, ROD_BACK) @ pd2,
        [-2 * pd1 @ pd1, -2 * pd2 @ pd2],
    ])  # fmt: skip
    M = np.zeros((14, 14))
    Q = np.zeros(14)
    for k, (p, pd) in enumerate(((p1, pd1), (p2, pd2))):
        L, Ld = l_matrix(p), l_matrix(pd)
        M[7 * k : 7 * k + 3, 7 * k : 7 * k + 3] = SDP_MASS * np.eye(3)
        M[7 * k + 3 : 7 * k + 7, 7 * k + 3 : 7 * k + 7] = 4 * L.T @ SDP_INERTIA @ L
        Q[7 * k + 2] = -SDP_MASS * G
        Q[7 * k + 3 : 7 * k + 7] = 8 * Ld.T @ SDP_INERTIA @ Ld @ p  # the quadratic-velocity term
    rhs_c = g - 2 * ALPHA * (J @ qd) - BETA**2 * psi
    A = np.block([[M, J.T], [J, np.zeros((8, 8))]])
    qdd = np.linalg.solve(A, np.concatenate([Q, rhs_c]))[:14]
    return np.concatenate([qd, qdd])


TEXTBOOK = {
    "double_pendulum": (double_pendulum_rhs, DP_START, 10.0, 3, 2),
    "slider_crank": (slider_crank_rhs, SLIDER_CRANK_START, T_END, 3, 2),
    "spatial_double_pendulum": (spatial_double_pendulum_rhs, SDP_START, 5.0, 7, 3),
}
"""(rhs, y0, end time, coordinates per body, dimension) of each scene's textbook code (bench.scenes' spans)."""


# -- the comparison ----------------------------------------------------------------------------------------------
def compare(rounds: int) -> None:
    import os
    import statistics
    import subprocess
    import tempfile
    import time
    from pathlib import Path

    import yaml

    here = Path(__file__).resolve().parent
    sys.path.insert(0, str(here))
    from bench import free_slider_crank, slider_crank_positions

    from solutions.io.model import load_model

    data = free_slider_crank()
    data["simulation"] = {"end_time": T_END, "output_steps": STEPS}  # every other setting: the default
    times = np.linspace(0.0, T_END, STEPS + 1)
    reference = slider_crank_positions(load_model(data), times)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "MBD_ENGINE")}
    env.setdefault("OPENBLAS_NUM_THREADS", "1")

    def error(centres: np.ndarray) -> float:
        return float(np.max(np.linalg.norm(centres - reference, axis=-1)))

    def timed(command: list[str]) -> tuple[float, str]:
        start = time.perf_counter()
        out = subprocess.run(command, env=env, check=True, capture_output=True, text=True)
        return time.perf_counter() - start, out.stdout

    with tempfile.TemporaryDirectory() as tmp:
        model = Path(tmp) / "free_slider_crank.yaml"
        model.write_text(yaml.safe_dump(data))
        best = None
        for method in ("RK45", "DOP853"):  # the textbook's fastest setting to 1e-6
            for rtol in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11):
                start = time.perf_counter()
                e = error(textbook(method, rtol))
                seconds = time.perf_counter() - start
                if e <= 1e-6:
                    if best is None or seconds < best[2]:
                        best = (method, rtol, seconds, e)
                    break
        method, rtol, _, textbook_error = best
        out = Path(tmp) / "textbook.npy"
        commands = {
            f"textbook ({method}, rtol = atol = {rtol:g})": [sys.executable, __file__, "--run", method, str(rtol),
                                                            str(out)],
            "mbd run (defaults)": [sys.executable, "-m", "solutions.cli", "run", str(model), "--out",
                                   str(Path(tmp) / "default.csv")],
            "mbd run --engine numpy": [sys.executable, "-m", "solutions.cli", "run", str(model), "--engine", "numpy",
                                       "--out", str(Path(tmp) / "numpy.csv")],
        }  # fmt: skip
        summaries = {name: timed(command)[1] for name, command in commands.items()}  # warm-up
        errors = {next(iter(commands)): textbook_error}
        for name, csv in (("mbd run (defaults)", "default.csv"), ("mbd run --engine numpy", "numpy.csv")):
            table = np.genfromtxt(Path(tmp) / csv, delimiter=",", names=True)
            centres = np.stack(
                [np.stack([table[f"{b}x"], table[f"{b}y"]], axis=-1) for b in ("crank", "rod", "piston")], axis=1
            )
            errors[name] = error(centres)
        seconds: dict[str, list[float]] = {name: [] for name in commands}
        for _ in range(rounds):
            for name, command in commands.items():
                seconds[name].append(timed(command)[0])
    base = seconds[next(iter(commands))]
    print(f"\n## Free slider-crank to 1e-6 m: the textbook code against `mbd run` ({time.strftime('%Y-%m-%d')})\n")
    print(
        f"`python benchmarks/textbook.py --rounds {rounds}`; whole processes, {rounds} interleaved rounds; ratio: "
        "the textbook program's time over the run's, paired by round (above 1: faster than the textbook).\n"
    )
    print("| program | error (m) | median s | textbook / it, median | min-max | engine |")
    print("|---|---:|---:|---:|---:|---|")
    for name in commands:
        ratios = [b / s for b, s in zip(base, seconds[name], strict=True)]
        engine = next((line[len("engine: "):] for line in summaries[name].splitlines() if line.startswith("engine:")),
                      "-")  # fmt: skip
        print(
            f"| {name} | {errors[name]:.2g} | {statistics.median(seconds[name]):.3f} | "
            f"{statistics.median(ratios):.2f} | {min(ratios):.2f}-{max(ratios):.2f} | {engine} |"
        )


# -- in one process, per scene: at equal rtol and at equal error --------------------------------------------------
EQUAL_RTOLS = (1e-6, 1e-7, 1e-8)
TARGET = 1e-6
"""The error both codes must reach for the equal-error comparison (m, largest body-centre error on the grid)."""
RTOL_GRID = tuple(sorted((float(f"{m}e-{e}") for e in range(5, 12) for m in (1, 2, 5)), reverse=True)[2:])
"""rtol = atol 1e-5, 5e-6, 2e-6, 1e-6, 5e-7, ... 1e-11: the settings searched for the equal-error comparison."""


UNCHECKED = {"drift_limit": None, "singular_ratio": None, "stiffness": "off", "divergence": "skip"}
"""The engine's checks that the textbook code does not make (the Guard's drift and singularity checks after every
step, the stiffness monitor, the divergence check's companion run of a chaotic scene), switched off for the row that
compares the integration alone."""


def engine_runner(scene, **checks):
    """f(rtol) -> (q history, right-hand sides) of the numpy engine on a bench scene: baumgarte (alpha = beta = 5),
    the package's dop853, the same settings as the textbook code; ``checks``: settings of the run's checks."""
    from solutions.assembly import build_system
    from solutions.dynamics import forward_dynamics

    system, q0, qd0 = build_system(scene.load())

    def run(rtol: float):
        result = forward_dynamics(system, q0, qd0, scene.t_end, scene.outputs, "baumgarte", "dop853", rtol=rtol,
                                  atol=rtol, engine="numpy", **checks)  # fmt: skip
        return result.q, result.info["rhs_evaluations"]

    return run


def textbook_runner(key: str):
    """f(rtol) -> (q history, right-hand sides) of the scene's textbook code (``solve_ivp``'s DOP853)."""
    from scipy.integrate import solve_ivp

    rhs, y0, t_end, _, _ = TEXTBOOK[key]
    times = np.linspace(0.0, t_end, STEPS + 1)

    def run(rtol: float):
        solution = solve_ivp(rhs, (0.0, t_end), y0, method="DOP853", rtol=rtol, atol=rtol, t_eval=times)
        return solution.y[: y0.size // 2].T, solution.nfev

    return run


def paired(runs: list, rtols: list[float], rounds: int) -> list[list[float]]:
    """CPU seconds of this thread (``time.thread_time``) of each ``runs[k](rtols[k])``, called in turn ``rounds``
    times after one warm-up call each: one list of seconds per run, its k-th entries from the same round."""
    import time

    for run, rtol in zip(runs, rtols, strict=True):
        run(rtol)
    seconds: list[list[float]] = [[] for _ in runs]
    for _ in range(rounds):
        for run, rtol, out in zip(runs, rtols, seconds, strict=True):
            start = time.thread_time()
            run(rtol)
            out.append(time.thread_time() - start)
    return seconds


def in_process(rounds: int, keys: list[str]) -> None:
    import statistics
    import time
    from pathlib import Path

    here = Path(__file__).resolve().parent
    sys.path.insert(0, str(here))
    import bench

    print(f"\n## The textbook code against the numpy engine, in one process ({time.strftime('%Y-%m-%d')})\n")
    print(f"`python benchmarks/textbook.py --in-process --rounds {rounds}`; this thread's CPU time, {rounds} paired "
          "rounds; ratio: the textbook's time over the engine's in the same round (above 1: the engine is faster). "
          "Engine: `forward_dynamics(..., 'baumgarte', 'dop853', engine='numpy')`; textbook: `solve_ivp` DOP853; "
          "both rtol = atol, alpha = beta = 5. Unchecked: the engine with the checks the textbook code does not make "
          f"switched off ({', '.join(f'{k}={v!r}' for k, v in UNCHECKED.items())}).\n")  # fmt: skip
    print("| scene | rtol textbook / engine | error textbook / engine (m) | rhs textbook / engine | textbook ms | "
          "engine ms | ratio median | min-max | unchecked ms | ratio median | min-max |")  # fmt: skip
    print("|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for scene in (s for s in bench.scenes() if s.key in keys):
        bench.prepare_reference(scene, quick=False)
        engine, unchecked, book = engine_runner(scene), engine_runner(scene, **UNCHECKED), textbook_runner(scene.key)

        def error(q: np.ndarray, _scene=scene) -> float:
            return float(np.max(np.abs(bench.body_positions(q, _scene.dimension) - _scene.ref_positions)))

        def loosest(run) -> float:
            return next((r for r in RTOL_GRID if error(run(r)[0]) <= TARGET), RTOL_GRID[-1])

        cases = [(f"{r:g}", r, r) for r in EQUAL_RTOLS]
        cases.append((f"error {TARGET:g}", loosest(book), loosest(engine)))
        for label, r_book, r_engine in cases:
            (q_book, n_book), (q_engine, n_engine) = book(r_book), engine(r_engine)
            a, b, c = paired([book, engine, unchecked], [r_book, r_engine, r_engine], rounds)
            cells = []
            for seconds in (b, c):
                ratios = [x / y for x, y in zip(a, seconds, strict=True)]
                cells.append(f"{statistics.median(seconds) * 1e3:.0f} | {statistics.median(ratios):.2f} | "
                             f"{min(ratios):.2f}-{max(ratios):.2f}")  # fmt: skip
            rtols = f"{r_book:g}" if label[0] != "e" else f"{label}: {r_book:g} / {r_engine:g}"
            print(f"| {scene.key} | {rtols} | {error(q_book):.2g} / {error(q_engine):.2g} | {n_book} / {n_engine} | "
                  f"{statistics.median(a) * 1e3:.0f} | {cells[0]} | {cells[1]} |", flush=True)  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", nargs=3, metavar=("METHOD", "RTOL", "OUT"), help="run the textbook code only")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--in-process", action="store_true", help="textbook code against the numpy engine, per scene")
    parser.add_argument("--scene", action="append", choices=tuple(TEXTBOOK), help="with --in-process: these scenes")
    args = parser.parse_args()
    if args.in_process:
        in_process(args.rounds, args.scene or list(TEXTBOOK))
        return 0
    if args.run:
        method, rtol, out = args.run
        np.save(out, textbook(method, float(rtol)))
        return 0
    compare(args.rounds)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
