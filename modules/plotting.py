# Generated from solutions/plotting.py by `make modules` (every homework stubbed): do not edit by hand.
"""Plots of results: coordinates against time, paths of joints, reactions, energy, constraint drift.

Every function returns a matplotlib ``Figure`` made without pyplot (no global state, no backend to
choose): in a notebook the figure shows itself when it is the value of a cell; ``plot_result`` and
``save_figure`` write PNG files (``mbd run --plot``). The mechanism itself and its animation are drawn
by ``animation.py``.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .results import DERIVED, Result

UNITS = {"x": "m", "y": "m", "z": "m", "phi": "rad", "e0": "-", "e1": "-", "e2": "-", "e3": "-"}
AXES = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
"""Reaction columns in the global frame (DESIGN section 5); others (``_local``, ``_joint``) are left out."""
"""Prefixes of result columns that are not body points (constraint residuals, energies)."""


def new_figure(rows: int = 1, columns: int = 1, size: tuple[float, float] | None = None, **subplots):
    """(figure, 2D array of axes) on an Agg canvas."""
    fig = Figure(figsize=size or (8.0, 2.6 * rows + 0.6), dpi=90)
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, columns, squeeze=False, **subplots)
    return fig, axes


def save_figure(fig: Figure, path: str | Path, dpi: int = 110) -> Path:
    """Write a figure (PNG, SVG or PDF by the suffix)."""
    path = Path(path)
    fig.savefig(path, dpi=dpi)
    return path


def _point_columns(result: Result) -> list[str]:
    """Body-point columns of a result (positions only), without residual or energy columns."""
    return [k for k in result.points if not k.endswith("_d") and "_dd" not in k and not k.startswith(DERIVED)]


def coordinates_figure(result: Result, coordinates: list[str] | None = None) -> Figure:
    """Chosen coordinates (default: all) and requested points against time, one panel per kind (x, y, phi).

    Raises
    ------
    ValueError
        If a name is neither a coordinate nor a point column of the result.
    """
    names = coordinates or result.coordinate_names + _point_columns(result)
    series = {}
    for name in names:
        if name in result.coordinate_names:
            series[name] = result.coordinate(name)
        elif name in result.points:
            series[name] = result.points[name]
        else:
            raise ValueError(f"--coords {name}: not in the result (coordinates: {', '.join(result.coordinate_names)})")
    order = list(UNITS)
    kinds = sorted({name.rsplit(".", 1)[-1] for name in series}, key=lambda k: order.index(k) if k in UNITS else 99)
    fig, axes = new_figure(len(kinds), 1, sharex=True)
    for ax, kind in zip(axes[:, 0], kinds, strict=True):
        for name, values in series.items():
            if name.rsplit(".", 1)[-1] == kind:
                ax.plot(result.t, values, label=name)
        ax.set_ylabel(f"{kind} [{UNITS.get(kind, '')}]")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle(f"{result.info.get('analysis', '')} analysis")
    fig.tight_layout()
    return fig


def plot_result(result: Result, path: str | Path, coordinates: list[str] | None = None) -> Path:
    """Plot chosen coordinates (default: all) and requested points against time into a PNG file.

    Parameters
    ----------
    result : a Result of any analysis
    path : the PNG file to write
    coordinates : names such as 'slider.x' or point columns such as 'crank@0.1,0.0.y'

    Raises
    ------
    ValueError
        If a name is neither a coordinate nor a point column of the result.
    """
    return save_figure(coordinates_figure(result, coordinates), path)


def paths_figure(model, result: Result, joints: list[str] | None = None) -> Figure:
    """Paths of joint points over a run (planar: in the x-y plane), with the mechanism at the start."""
    from .animation import draw_mechanism, joint_paths, mechanism_geometry

    if model.dimension != 2:
        raise ValueError("paths_figure draws planar mechanisms; plot a spatial run with coordinates_figure")
    paths = joint_paths(mechanism_geometry(model), result, joints)
    fig, axes = new_figure(1, 1, size=(6.0, 4.6))
    ax = axes[0, 0]
    draw_mechanism(model, result.q, ax=ax, title=f"{model.name}: paths of the joints")
    offset = len(model.bodies)  # the bodies take the first colours of the cycle
    for k, (name, path) in enumerate(paths.items()):
        ax.plot(path[:, 0], path[:, 1], lw=1.0, ls="--", color=f"C{(offset + k) % 10}", label=f"path of {name}")
    ax.relim()
    ax.autoscale_view()
    ax.set_aspect("equal")
    ax.legend(loc="best", fontsize="small")
    fig.tight_layout()
    return fig


def reaction_columns(system, result: Result) -> dict[str, np.ndarray]:
    """The result's joint reactions; computed from its multipliers when the analysis did not store them."""
    if result.reactions:
        return result.reactions
    if result.lam is None:
        raise ValueError("the result has no Lagrange multipliers: reactions need a dynamic or inverse analysis")
    from .reactions import joint_reactions

    return joint_reactions(system, result.q, result.lam, result.t)


def reactions_figure(system, result: Result, joints: Iterable[str] | None = None) -> Figure:
    """Reaction forces (and torques) of joints against time: what each joint exerts on its second body.

    Parameters
    ----------
    system : the assembled System of the result
    result : a dynamic or inverse-dynamics result (it holds lambda)
    joints : joint or driver names (default: all)
    """
    columns = reaction_columns(system, result)
    names = list(dict.fromkeys(k.split(".")[0] for k in columns))
    chosen = list(joints) if joints is not None else names
    unknown = [j for j in chosen if j not in names]
    if unknown:
        raise ValueError(f"no reactions of {', '.join(unknown)} (joints: {', '.join(names)})")
    global_frame = [k for k in columns if k.count(".") == 1 and k.split(".")[0] in chosen and k.split(".")[1] in AXES]
    forces = [k for k in global_frame if k.endswith(("Fx", "Fy", "Fz"))]
    moments = [k for k in global_frame if k.endswith(("Mx", "My", "Mz"))]
    largest = max((float(np.max(np.abs(columns[k]))) for k in forces), default=0.0)
    moments = [k for k in moments if np.max(np.abs(columns[k])) > 1e-9 * (1.0 + largest)]  # a pin takes no moment
    fig, axes = new_figure(2 if moments else 1, 1, sharex=True)
    for name in forces:
        axes[0, 0].plot(result.t, columns[name], label=name)
    axes[0, 0].set_ylabel("force [N]")
    if moments:
        for name in moments:
            axes[1, 0].plot(result.t, columns[name], label=name)
        axes[1, 0].set_ylabel("moment [N m]")
    for ax in axes[:, 0]:
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize="small", ncol=2)
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle("joint reactions (on the joint's second body, global frame)")
    fig.tight_layout()
    return fig


def energy_figure(result: Result) -> Figure:
    """Kinetic, potential, dissipated and supplied energy, and the balance error E(t) - E(0) (eq. 5.60)."""
    parts = [k for k in ("kinetic", "potential", "dissipated", "applied", "drivers") if f"energy.{k}" in result.points]
    if not parts:
        raise ValueError("the result has no energy columns: run a forward dynamic analysis")
    fig, axes = new_figure(2, 1, sharex=True)
    for part in parts:
        values = result.points[f"energy.{part}"]
        if np.any(values != 0.0):
            axes[0, 0].plot(result.t, values - (values[0] if part == "potential" else 0.0), label=part)
    axes[0, 0].set_ylabel("energy [J]")
    axes[0, 0].legend(loc="best", fontsize="small")
    axes[1, 0].plot(result.t, result.points["energy.error"], color="C3")
    axes[1, 0].set_ylabel("E(t) - E(0) [J]")
    axes[1, 0].set_xlabel("t [s]")
    for ax in axes[:, 0]:
        ax.grid(True, alpha=0.3)
    fig.suptitle("energy (potential from its initial value)")
    fig.tight_layout()
    return fig


def residuals(system, result: Result) -> dict[str, np.ndarray]:
    """max |Psi| and max |Psi_q q' + Psi_t| on the output grid (stored by forward dynamics, else computed)."""
    if "residual.position" in result.points:
        return {k: result.points[k] for k in ("residual.position", "residual.velocity")}
    position, velocity = np.empty(result.t.size), np.empty(result.t.size)
    for k, (t, q, qd) in enumerate(zip(result.t, result.q, result.qd, strict=True)):
        position[k] = np.max(np.abs(system.constraints(q, t)), initial=0.0)
        velocity[k] = np.max(np.abs(system.jacobian(q, t) @ qd + system.psi_t(q, t)), initial=0.0)
    return {"residual.position": position, "residual.velocity": velocity}


def drift_figure(results: dict[str, Result], system) -> Figure:
    """Constraint drift of one or more runs: max |Psi| and max |Psi_q q' + Psi_t| against time, log scale.

    Parameters
    ----------
    results : {label: result}, e.g. runs with and without Baumgarte stabilization
    system : the System all of them belong to
    """
    fig, axes = new_figure(1, 2, size=(10.0, 3.6))
    floor = 1e-17  # a residual of exactly zero cannot be drawn on a log axis
    for label, result in results.items():
        columns = residuals(system, result)
        axes[0, 0].semilogy(result.t, np.maximum(columns["residual.position"], floor), label=label)
        axes[0, 1].semilogy(result.t, np.maximum(columns["residual.velocity"], floor), label=label)
    axes[0, 0].set_ylabel("max |Psi|")
    axes[0, 1].set_ylabel("max |Psi_q q' + Psi_t|")
    for ax in axes[0]:
        ax.set_xlabel("t [s]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    fig.suptitle("constraint drift")
    fig.tight_layout()
    return fig


def work_precision_figure(rows: list[dict], title: str = "run time against error") -> Figure:
    """Run time against error, one line per method: rows of {'method', 'error', 'seconds'} (log-log)."""
    fig, axes = new_figure(1, 1, size=(6.4, 4.4))
    ax = axes[0, 0]
    for k, method in enumerate(dict.fromkeys(r["method"] for r in rows)):
        mine = sorted((r for r in rows if r["method"] == method), key=lambda r: r["error"])
        ax.loglog([r["error"] for r in mine], [r["seconds"] for r in mine], marker="o", color=f"C{k}", label=method)
    ax.set_xlabel("error")
    ax.set_ylabel("run time [s]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    ax.set_title(title)
    fig.tight_layout()
    return fig
