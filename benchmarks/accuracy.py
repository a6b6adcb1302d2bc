"""Issue 14 study: position error against independent references at the default settings and at given rtol.

    PYTHONPATH=. python benchmarks/accuracy.py          # about a minute; the table is in benchmarks/accuracy.md

- a pendulum (course/models/simple_pendulum.yaml) released level, against Jacobi's sn (elliptic integrals);
- the chain of N parallelogram loops (tests/solutions/mechanisms.py) through its singular positions, against
  its one-degree-of-freedom equation integrated by scipy at rtol 1e-12;
- the Sarrus linkage (over-constrained 6R) with each integrator at its defaults, against its own equation.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
import scipy.special

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests" / "solutions"))

from mechanisms import SARRUS, chain_theta, parallelogram_chain, sarrus, sarrus_theta  # noqa: E402

from solutions.assembly import build_system  # noqa: E402
from solutions.dynamics import forward_dynamics  # noqa: E402
from solutions.io.model import load_model  # noqa: E402


def pendulum(t_end: float, rtol: float | None) -> tuple[float, dict]:
    system, q0, qd0 = build_system(load_model(REPO / "course" / "models" / "simple_pendulum.yaml"))
    result = forward_dynamics(system, q0, qd0, t_end, 2000, rtol=rtol)
    w0, k = math.sqrt(1.5 * 9.81), math.sin(math.pi / 4)
    psi = 2 * np.arcsin(k * scipy.special.ellipj(scipy.special.ellipk(k * k) - w0 * result.t, k * k)[0])
    phi = result.q[:, 2]
    error = np.abs(np.stack([np.cos(phi), np.sin(phi)], 1) - np.stack([np.sin(psi), -np.cos(psi)], 1)).max()
    return float(error), result.info


def chain(n: int, formulation: str) -> tuple[float, dict]:
    system, q0, qd0 = build_system(load_model(parallelogram_chain(n)))
    result = forward_dynamics(system, q0, qd0, 3.0, 150, formulation=formulation)
    theta = chain_theta(n, result.t)
    error = max(np.abs(result.q[:, system.coordinate_names.index(f"crank{k}.phi")] - theta).max() for k in range(n + 1))
    return float(error), result.info


def sarrus_run(integrator: str) -> tuple[float, dict]:
    system, q0, qd0 = build_system(load_model(sarrus()))
    result = forward_dynamics(system, q0, qd0, 1.0, 50, integrator=integrator)
    z = result.q[:, system.coordinate_names.index("top.z")]
    return float(np.abs(z - 2 * SARRUS["L"] * np.cos(sarrus_theta(result.t))).max()), result.info


def main() -> None:
    rows = []
    for t_end, rtol in ((300.0, None), (300.0, 1e-8), (2000.0, None), (2000.0, 1e-8)):
        start = time.perf_counter()
        error, info = pendulum(t_end, rtol)
        rows.append((f"pendulum {t_end:g} s", "auto", f"{info['rtol']:.3g}", error, bool(info["warnings"]),
                     time.perf_counter() - start))  # fmt: skip
    for n in (1, 2, 10):
        start = time.perf_counter()
        error, info = chain(n, "auto")
        rows.append((f"chain N={n}, 3 s", info["formulation"], f"{info['rtol']:.3g}", error, bool(info["warnings"]),
                     time.perf_counter() - start))  # fmt: skip
    for integrator in ("auto", "hht", "generalized-alpha"):
        start = time.perf_counter()
        error, info = sarrus_run(integrator)
        rows.append((f"Sarrus 1 s, {integrator}", info["formulation"], f"{info['rtol']:.3g}", error,
                     bool(info["warnings"]), time.perf_counter() - start))  # fmt: skip
    print("| scene | formulation | rtol | max error (m or rad) | warns | wall s |")
    print("| --- | --- | --- | --- | --- | --- |")
    for scene, formulation, rtol, error, warned, wall in rows:
        print(f"| {scene} | {formulation} | {rtol} | {error:.2g} | {'yes' if warned else 'no'} | {wall:.1f} |")


if __name__ == "__main__":
    main()
