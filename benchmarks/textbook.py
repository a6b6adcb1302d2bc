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
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

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


def rhs(t, y):
    q, qd = y[:9], y[9:]
    J = jacobian(q)
    M = np.diag(MASSES)
    Q = np.array([0.0, -MASSES[0] * G, 0.0, 0.0, -MASSES[3] * G, 0.0, 0.0, -MASSES[6] * G, 0.0])
    rhs_c = gamma(q, qd) - 2 * ALPHA * (J @ qd) - BETA**2 * constraints(q)
    A = np.block([[M, J.T], [J, np.zeros((8, 8))]])
    qdd = np.linalg.solve(A, np.concatenate([Q, rhs_c]))[:9]
    return np.concatenate([qd, qdd])


def textbook(method: str, rtol: float) -> np.ndarray:
    """Body centres (steps + 1, 3, 2) on the output grid."""
    from scipy.integrate import solve_ivp

    q0 = np.array([0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.4, 0.0, 0.0])
    qd0 = np.array([0.0, 0.0, 50.0, 0.0, 2.5, -50.0 / 3.0, 0.0, 0.0, 0.0])
    times = np.linspace(0.0, T_END, STEPS + 1)
    solution = solve_ivp(rhs, (0.0, T_END), np.concatenate([q0, qd0]), method=method, rtol=rtol, atol=rtol,
                         t_eval=times)  # fmt: skip
    return solution.y[:9].T.reshape(-1, 3, 3)[:, :, :2]


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
            centres = np.stack([np.stack([table[f"{b}x"], table[f"{b}y"]], axis=-1) for b in ("crank", "rod",
                                                                                               "piston")], axis=1)
            errors[name] = error(centres)
        seconds: dict[str, list[float]] = {name: [] for name in commands}
        for _ in range(rounds):
            for name, command in commands.items():
                seconds[name].append(timed(command)[0])
    base = seconds[next(iter(commands))]
    print(f"\n## Free slider-crank to 1e-6 m: the textbook code against `mbd run` ({time.strftime('%Y-%m-%d')})\n")
    print(f"`python benchmarks/textbook.py --rounds {rounds}`; whole processes, {rounds} interleaved rounds; ratio: "
          "the textbook program's time over the run's, paired by round (above 1: faster than the textbook).\n")
    print("| program | error (m) | median s | textbook / it, median | min-max | engine |")
    print("|---|---:|---:|---:|---:|---|")
    for name in commands:
        ratios = [b / s for b, s in zip(base, seconds[name], strict=True)]
        engine = next((line[len("engine: "):] for line in summaries[name].splitlines() if line.startswith("engine:")),
                      "-")  # fmt: skip
        print(f"| {name} | {errors[name]:.2g} | {statistics.median(seconds[name]):.3f} | "
              f"{statistics.median(ratios):.2f} | {min(ratios):.2f}-{max(ratios):.2f} | {engine} |")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", nargs=3, metavar=("METHOD", "RTOL", "OUT"), help="run the textbook code only")
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    if args.run:
        method, rtol, out = args.run
        np.save(out, textbook(method, float(rtol)))
        return 0
    compare(args.rounds)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
