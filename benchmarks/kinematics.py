"""Benchmark of the kinematic analysis: microseconds per time step, and how they grow with size.

Three Markdown tables:

1. every kinematic example model in course/models/ (drivers leave no degree of freedom) over the
   time grid of its ``simulation`` block, on the numpy engine and on the compiled one (``engine="compiled"``,
   ``solutions/compiled/kinematic.py``; "-" where its kernels do not cover the model);
2. where a time step of the driven slider-crank (slider_crank.yaml) spends its time: each part timed
   alone at the states of the run, times the number of calls per step; and the compiled step;
3. a chain of N four-bar loops, N = 1, 2, 4, ..., 64, built here as a model mapping, both engines.

A time step of ``kinematic_analysis`` is one Newton-Raphson position solve (from a second-order
predictor), one LU factorization of Psi_q and the velocity and acceleration solves. The one-time set-up
(assembly of the file's configuration and the SVD rank check) is timed separately and subtracted:

    us/step = (median time of a whole run - median set-up time) / number of time points

Medians over ``--repeats`` runs, wall time by time.perf_counter. The compiled runs are timed warm: one run
first (it compiles the scene's module, or loads it from the cache: the seconds are printed), then the timed
ones, each a whole ``kinematic_analysis`` call (choosing the engine, the scene's data, the compiled steps) minus
the same set-up. This is a benchmark, not a test: the numbers depend on the machine. Run::

    .venv/bin/python benchmarks/kinematics.py            # full run, about a minute
    .venv/bin/python benchmarks/kinematics.py --quick    # smoke run, a few seconds

BLAS runs single-threaded unless OPENBLAS_NUM_THREADS (or OMP_NUM_THREADS) is set: the matrices of a
time step are small (n <= 387 here) and a multi-threaded OpenBLAS on a busy machine spends far more
time waiting for its threads than computing (an LU of a 195 x 195 Psi_q took 94 ms instead of 0.7 ms).
"""

from __future__ import annotations

import os

for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")  # must be set before NumPy is imported

import argparse  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import scipy  # noqa: E402

from solutions.assembly import System, build_system  # noqa: E402
from solutions.diagnostics import AnalysisError, rank_report  # noqa: E402
from solutions.io.model import load_model  # noqa: E402
from solutions.kinematics import assemble, determinant_sign, kinematic_analysis, require_no_freedom  # noqa: E402
from solutions.linalg import lu_factor, lu_solve, solve  # noqa: E402

MODELS = Path(__file__).resolve().parents[1] / "course" / "models"

# One loop of the chain: a drag link (Grashof double crank, the ground link is the shortest), so that
# every lever turns fully and a full crank turn is a full cycle of the whole chain.
GROUND = 0.10  # distance between neighbouring ground pivots O_{k-1}, O_k
ARM_IN = 0.25  # input arm of loop 1 (the crank)
COUPLER = 0.30
ARM_OUT = 0.28  # output arm of loop 1
SPEED = 10.0  # crank speed, rad/s
THETA0 = 0.4  # crank angle of the generated configuration, rad


def _bar(name: str, p: np.ndarray, q: np.ndarray, pivot: np.ndarray | None = None) -> dict:
    """A steel bar 20 x 10 mm from p to q (centred at ``pivot`` if given: a lever with two arms)."""
    length = float(np.linalg.norm(q - p))
    mass = 7850.0 * length * 0.02 * 0.01
    centre = (p + q) / 2 if pivot is None else pivot
    return {
        "name": name,
        "mass": mass,
        "inertia": mass * (length**2 + 0.02**2) / 12.0,
        "location": [float(centre[0]), float(centre[1])],
        "orientation": math.atan2(q[1] - p[1], q[0] - p[0]),
    }


def _circle_intersection(p: np.ndarray, rp: float, q: np.ndarray, rq: float) -> np.ndarray:
    """The intersection of the circles (p, rp) and (q, rq) on the left of the line p -> q."""
    d = q - p
    distance = float(np.linalg.norm(d))
    along = (rp**2 - rq**2 + distance**2) / (2.0 * distance)
    e = d / distance
    return p + along * e + math.sqrt(rp**2 - along**2) * np.array([-e[1], e[0]])


def four_bar_chain(n_loops: int, steps: int = 200) -> dict:
    """A model mapping of ``n_loops`` four-bar loops in series, driven by one motor on the crank.

    Ground pivots O_k = (k GROUND, 0), k = 0..N. Loop k is ground O_{k-1} O_k, an input arm pivoted
    at O_{k-1} (the crank for k = 1, else lever k-1), coupler k and the output arm of lever k pivoted
    at O_k: each loop shares its output lever with the next loop's input. Odd loops are copies of
    loop 1; even loops are loop 1 run backwards and turned by 180 deg (input arm ARM_OUT, output
    arm ARM_IN), so that a pair of loops passes the crank's rotation on unchanged. (Identical loops
    in series would compound the drag link's speed ratio, between 0.6 and 1.7, into extreme lever speeds.)
    The levers are straight bars with their two arms on opposite sides of the pivot.
    """
    pivots = [np.array([k * GROUND, 0.0]) for k in range(n_loops + 1)]
    a = ARM_IN * np.array([math.cos(THETA0), math.sin(THETA0)])  # loop 1's pins relative to O_0
    b = _circle_intersection(a, COUPLER, pivots[1], ARM_OUT)
    bodies = [_bar("crank", pivots[0], pivots[0] + a)]
    joints = [{"name": "O0", "type": "revolute", "body1": "ground", "body2": "crank", "location": [0.0, 0.0]}]
    driver = "crank"
    for k in range(1, n_loops + 1):
        if k % 2:  # a copy of loop 1
            pin_in, pin_out = pivots[k - 1] + a, pivots[k - 1] + b
        else:  # loop 1 reversed and turned by 180 deg about O_{k-1}
            pin_in, pin_out = pivots[k - 1] + (pivots[1] - b), pivots[k] - a
        arm = pin_out - pivots[k]
        bodies.append(_bar(f"coupler{k}", pin_in, pin_out))
        bodies.append(_bar(f"lever{k}", pivots[k] - arm, pivots[k] + arm, pivot=pivots[k]))
        for name, body1, body2, point in (
            (f"A{k}", driver, f"coupler{k}", pin_in),
            (f"B{k}", f"coupler{k}", f"lever{k}", pin_out),
            (f"O{k}", "ground", f"lever{k}", pivots[k]),
        ):
            joints.append({"name": name, "type": "revolute", "body1": body1, "body2": body2, "location": list(point)})
        driver = f"lever{k}"
    motor = {
        "name": "drive",
        "type": "angle",
        "joint": "O0",
        "function": {"type": "polynomial", "coefficients": [0.0, SPEED]},
    }
    return {
        "model": {
            "name": f"four-bar chain x{n_loops}",
            "dimension": 2,
            "bodies": bodies,
            "joints": joints,
            "motors": [motor],
        },
        "simulation": {"end_time": 2.0 * math.pi / SPEED, "output_steps": steps},
    }


def measure(system: System, q0: np.ndarray, t_end: float, steps: int, repeats: int, engine: str = "numpy") -> dict:
    """Median wall (and CPU) times of ``repeats`` kinematic analyses minus set-up; Newton iterations per step.

    ``engine="compiled"``: after a first run (compiling or loading, its seconds in 'first_s'); {'fallback': why}
    if the compiled kernels do not cover the model."""
    setup, runs = [], []
    first = None
    if engine != "numpy":
        wall = time.perf_counter()
        result = kinematic_analysis(system, q0, t_end, steps, engine=engine)
        first = time.perf_counter() - wall
        if result.info["chosen"]["engine"] != "compiled":
            return {"fallback": result.info["chosen"]["engine_why"]}
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        q, _ = assemble(system, q0, 0.0)
        require_no_freedom(system, q, 0.0)
        setup.append((time.perf_counter() - wall, time.process_time() - cpu))
        wall, cpu = time.perf_counter(), time.process_time()
        result = kinematic_analysis(system, q0, t_end, steps, engine=engine)
        runs.append((time.perf_counter() - wall, time.process_time() - cpu))
    points = steps + 1

    def per_step(k: int) -> float:
        run, prep = statistics.median(r[k] for r in runs), statistics.median(s[k] for s in setup)
        return 1e6 * max(run - prep, 0.0) / points

    return {
        "us_per_step": per_step(0),
        "cpu_us_per_step": per_step(1),
        "newton_per_step": result.info["newton_iterations"] / points,
        "setup_ms": 1e3 * statistics.median(s[0] for s in setup),
        "residual": result.info["max_constraint_residual"],
        "first_s": first,
        "chosen": result.info.get("chosen"),
    }


def _compiled(m: dict | None, numpy_us: float) -> str:
    """The compiled columns: us/step, CPU us/step, numpy / compiled."""
    if "fallback" in m:
        return "- | - | -"
    return f"{m['us_per_step']:.1f} | {m['cpu_us_per_step']:.1f} | {numpy_us / max(m['us_per_step'], 1e-9):.0f}x"


def example_table(steps: int | None, repeats: int) -> list[str]:
    lines = [
        "| model | bodies | n | m | steps | us/step | CPU us/step | Newton it/step | set-up ms | max residual | "
        "compiled us/step | compiled CPU us/step | numpy / compiled |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    skipped, fallbacks = [], []
    for path in sorted(MODELS.glob("*.yaml")):
        model = load_model(path)
        system, q0, _ = build_system(model)
        free = rank_report(system.jacobian(q0, 0.0), system.row_owners).degrees_of_freedom  # by rank: n - m miscounts
        if free != 0:  # redundant joints (parallel_swing.yaml: n - m = 0, one degree of freedom)
            skipped.append(f"{path.name} ({free})")
            continue
        n_steps = steps or int(model.simulation.get("output_steps", 200))
        try:
            m = measure(system, q0, float(model.simulation["end_time"]), n_steps, repeats)
            c = measure(system, q0, float(model.simulation["end_time"]), n_steps, repeats, "compiled")
            if "fallback" in c:
                fallbacks.append(f"{path.name} ({c['fallback']})")
        except AnalysisError as err:
            lines.append(
                f"| {path.name} | {system.n_bodies} | {system.n_coordinates} | {system.n_constraints} | "
                f"{n_steps} | failed: {err} | | | | | | | |"
            )
            continue
        lines.append(
            f"| {path.name} | {system.n_bodies} | {system.n_coordinates} | {system.n_constraints} | {n_steps} | "
            f"{m['us_per_step']:.0f} | {m['cpu_us_per_step']:.0f} | {m['newton_per_step']:.2f} | {m['setup_ms']:.2f} | "
            f"{m['residual']:.1e} | {_compiled(c, m['us_per_step'])} |"
        )
    if skipped:
        lines += ["", "Skipped, drivers leave degrees of freedom (a dynamics model): " + ", ".join(skipped)]
    if fallbacks:
        lines += ["", "Numpy only (the compiled kernels do not cover them): " + "; ".join(fallbacks)]
    return lines


def _best_us(fn, states: list, repeats: int) -> float:
    """Best over ``repeats`` of the mean time of fn(state) over the states (us)."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        for state in states:
            fn(state)
        best = min(best, (time.perf_counter() - start) / len(states))
    return 1e6 * best


def step_breakdown(repeats: int) -> list[str]:
    """Where a kinematic time step of the driven slider-crank spends its time (us per step).

    Each part is timed over the states of the run, at a new q each call (as in the run: Newton-Raphson
    moves q, so the configuration -- the rotated body vectors -- is computed again), and the parts that
    reuse the configuration at the same q (Psi_q, gamma) as the difference with and without them.
    """
    model = load_model(MODELS / "slider_crank.yaml")
    system, q0, _ = build_system(model)
    t_end, steps = float(model.simulation["end_time"]), int(model.simulation["output_steps"])
    result = kinematic_analysis(system, q0, t_end, steps)
    newton = result.info["newton_iterations"] / result.t.size
    states = []
    for k, (t, q, qd) in enumerate(zip(result.t, result.q, result.qd, strict=True)):
        moved = q * (1 + 1e-12 * (k % 2 + 1))  # a new q at every call, never the cached one
        jac = system.jacobian(q, t)
        states.append((t, moved, qd, jac, system.constraints(q, t), lu_factor(jac)))

    def psi(s):
        return system.constraints(s[1], s[0])

    def psi_and_jacobian(s):
        return system.constraints(s[1], s[0]), system.jacobian(s[1], s[0])

    def psi_and_gamma(s):
        return system.constraints(s[1], s[0]), system.gamma(s[1], s[2], s[0])

    def lu_and_tests(s):
        lu = lu_factor(s[3])
        pivots = np.abs(lu[0].diagonal())
        return pivots.min() > pivots.max() / 1e10, determinant_sign(lu)

    alone = {
        "psi": _best_us(psi, states, repeats),
        "psi_jac": _best_us(psi_and_jacobian, states, repeats),
        "psi_gamma": _best_us(psi_and_gamma, states, repeats),
    }

    def timed(fn) -> float:
        return _best_us(fn, states, repeats)

    parts = [
        ("Psi at a new q (rotations + Psi)", newton + 1, alone["psi"]),
        ("Psi_q at the same q", newton + 1, alone["psi_jac"] - alone["psi"]),
        ("max |Psi| (convergence test)", newton + 1, timed(lambda s: np.max(np.abs(s[4]), initial=0.0))),
        ("Newton solve Psi_q dq = -Psi", newton, timed(lambda s: solve(s[3], s[4]))),
        ("LU of Psi_q, lock-up and branch tests", 1, timed(lu_and_tests)),
        ("velocity: Psi_t + LU solve", 1, timed(lambda s: lu_solve(s[5], -system.psi_t(s[1], s[0])))),
        (
            "acceleration: gamma (same q) + LU solve",
            1,
            alone["psi_gamma"] - alone["psi"] + timed(lambda s: lu_solve(s[5], s[4])),
        ),
    ]
    lines = ["| part | calls per step | us per call | us per step |", "|---|---:|---:|---:|"]
    total = 0.0
    for label, calls, us in parts:
        total += calls * us
        lines.append(f"| {label} | {calls:.2f} | {us:.1f} | {calls * us:.1f} |")
    measured = measure(system, q0, t_end, steps, repeats)["us_per_step"]
    lines.append(f"| sum of the parts | | | {total:.0f} |")
    lines.append(f"| whole step, measured (the rest: predictor, storing, Python calls) | | | {measured:.0f} |")
    compiled = measure(system, q0, t_end, steps, repeats, "compiled")
    loop = _compiled_loop_us(system, q0, t_end, steps, repeats)
    lines.append(f"| compiled engine: whole step, measured as above (first run {compiled['first_s']:.2f} s) | | | "
                 f"{compiled['us_per_step']:.1f} |")  # fmt: skip
    lines.append(f"| compiled engine: the compiled loop alone (kinematic_loop.steps) | | | {loop:.1f} |")
    return lines


def _compiled_loop_us(system: System, q0: np.ndarray, t_end: float, steps: int, repeats: int) -> float:
    """us per step of the compiled step loop alone (no engine choice, no scene description), best of ``repeats``."""
    from solutions.compiled import kinematic

    q, _ = assemble(system, q0, 0.0)
    scene = kinematic.describe(system)
    times = np.linspace(0.0, t_end, steps + 1)
    kinematic.run(scene, q, times)
    best = float("inf")
    for _ in range(max(repeats, 5)):
        start = time.perf_counter()
        kinematic.run(scene, q, times)
        best = min(best, time.perf_counter() - start)
    return 1e6 * best / times.size


def chain_table(sizes: list[int], steps: int, repeats: int) -> list[str]:
    lines = [
        "| loops N | bodies | n | us/step | CPU us/step | us/step per body | x previous N | Newton it/step | "
        "set-up ms | max residual | compiled us/step | compiled CPU us/step | numpy / compiled |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    previous = None
    for size in sizes:
        model = load_model(four_bar_chain(size, steps))
        system, q0, _ = build_system(model)
        m = measure(system, q0, float(model.simulation["end_time"]), steps, repeats)
        c = measure(system, q0, float(model.simulation["end_time"]), steps, repeats, "compiled")
        growth = f"{m['us_per_step'] / previous:.2f}" if previous else "-"
        previous = m["us_per_step"]
        lines.append(
            f"| {size} | {system.n_bodies} | {system.n_coordinates} | {m['us_per_step']:.0f} | "
            f"{m['cpu_us_per_step']:.0f} | "
            f"{m['us_per_step'] / system.n_bodies:.1f} | {growth} | {m['newton_per_step']:.2f} | "
            f"{m['setup_ms']:.1f} | {m['residual']:.1e} | {_compiled(c, m['us_per_step'])} |"
        )
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smoke run: 20 steps, one repeat, chains up to N = 4")
    parser.add_argument("--repeats", type=int, help="runs per entry, the median is reported (default 5; quick 1)")
    args = parser.parse_args(argv)
    repeats = args.repeats or (1 if args.quick else 5)
    steps = 20 if args.quick else None
    sizes = [1, 2, 4] if args.quick else [1, 2, 4, 8, 16, 32, 64]
    print(
        f"Kinematic analysis, wall time per time step (median of {repeats}); Python {platform.python_version()}, "
        f"NumPy {np.__version__}, SciPy {scipy.__version__}, {platform.machine()}, {os.cpu_count()} CPUs, "
        f"OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}."
    )
    print(
        "us/step: wall time (time.perf_counter), CPU us/step: process time (time.process_time, less sensitive to\n"
        "a busy machine); both exclude the one-time set-up (assembly and rank check), shown separately.\n"
    )
    print("Example models (course/models), one full crank or cam turn:\n")
    print("\n".join(example_table(steps, repeats)))
    print("\nOne time step of the driven slider-crank (slider_crank.yaml), part by part:\n")
    print("\n".join(step_breakdown(repeats)))
    print(f"\nChain of N four-bar loops (drag links) driven by one crank, one crank turn in {steps or 200} steps:\n")
    print("\n".join(chain_table(sizes, steps or 200, repeats)))
    print(
        "\nFrom N = 4 on, the pivot ratio of the chain dips a few times per turn (no singular position: the loops\n"
        "never lose rank), and at each dip both engines search the interval with SVDs (numpy's\n"
        "kinematics.locate_singular_position, which the compiled engine calls too): that search, not the steps,\n"
        "takes most of the run. Where two pivot candidates are equal but for rounding, the two engines' pivot ratios\n"
        "may differ by a factor at a step, and one of them search an interval the other does not; the searches\n"
        "decide by the rank rule, so they find the same singular positions (none here)."
    )


if __name__ == "__main__":
    main()
