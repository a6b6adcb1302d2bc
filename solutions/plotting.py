"""Plots of results: coordinates and body points against time, written as PNG."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; notebooks choose their own backend before importing pyplot
import matplotlib.pyplot as plt  # noqa: E402

from .results import Result  # noqa: E402

UNITS = {"x": "m", "y": "m", "z": "m", "phi": "rad"}


def plot_result(result: Result, path: str | Path, coordinates: list[str] | None = None) -> Path:
    """Plot chosen coordinates (default: all) and requested points against time, one panel per kind.

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
    names = coordinates or result.coordinate_names + [
        k for k in result.points if not k.endswith("_d") and "_dd" not in k
    ]
    series = {}
    for name in names:
        if name in result.coordinate_names:
            series[name] = result.coordinate(name)
        elif name in result.points:
            series[name] = result.points[name]
        else:
            raise ValueError(f"--coords {name}: not in the result (coordinates: {', '.join(result.coordinate_names)})")
    kinds = sorted(
        {name.rsplit(".", 1)[-1] for name in series}, key=lambda k: list(UNITS).index(k) if k in UNITS else 9
    )
    fig, axes = plt.subplots(len(kinds), 1, figsize=(8, 2.6 * len(kinds)), sharex=True, squeeze=False)
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
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
