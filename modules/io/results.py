# Generated from solutions/io/results.py by `make modules` (every homework stubbed): do not edit by hand.
"""Data output: results as CSV (one column per quantity, DESIGN section 5) and NPZ (same arrays)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..results import Result


def result_columns(result: Result) -> dict[str, np.ndarray]:
    """Columns in file order: t, coordinates, velocities (_d), accelerations (_dd), points, reactions, force
    elements."""
    columns = {"t": result.t}
    for suffix, array in (("", result.q), ("_d", result.qd), ("_dd", result.qdd)):
        for k, name in enumerate(result.coordinate_names):
            columns[name + suffix] = array[:, k]
    columns.update(result.points)
    columns.update(result.reactions)
    columns.update(result.forces)
    return columns


def write_csv(result: Result, path: str | Path) -> Path:
    """Write a result as CSV with a header row of column names; returns the path."""
    path = Path(path)
    columns = result_columns(result)
    table = np.column_stack(list(columns.values()))
    np.savetxt(path, table, delimiter=",", header=",".join(columns), comments="", fmt="%.17g")
    return path


def write_npz(result: Result, path: str | Path) -> Path:
    """Write a result as NPZ: every CSV column plus the arrays q, qd, qdd, lam and the info."""
    path = Path(path)
    arrays = {name: values for name, values in result_columns(result).items()}
    arrays.update(q=result.q, qd=result.qd, qdd=result.qdd, coordinate_names=np.array(result.coordinate_names))
    if result.lam is not None:
        arrays["lam"] = result.lam
    arrays["info"] = np.array(json.dumps(result.info, default=str))
    np.savez_compressed(path, **arrays)
    return path


def read_csv(path: str | Path) -> dict[str, np.ndarray]:
    """Read a result CSV back as a mapping column name -> values."""
    with open(path) as handle:
        names = handle.readline().strip().split(",")
    table = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {name: table[:, k] for k, name in enumerate(names)}


def read_result(path: str | Path, coordinate_names: list[str], body_names: list[str]) -> Result:
    """A result as ``write_result`` wrote it (CSV or NPZ) back, for a model with these coordinates: q, q', q''
    (zero where a column is absent) and the file's other numeric columns (points, reactions, energies) as points.

    Raises
    ------
    ValueError
        A file that cannot be read as a result, or one without t and every coordinate (another model's).
    """
    path = str(path)
    try:
        columns = dict(np.load(path, allow_pickle=False)) if path.endswith(".npz") else read_csv(path)
    except (OSError, ValueError) as err:
        raise ValueError(f"cannot read a result ({err})") from None
    missing = [n for n in ["t", *coordinate_names] if n not in columns]
    if missing:
        raise ValueError(f"no column {', '.join(missing[:5])}: not a result of this model (mbd run --out)")
    t, suffixes = columns["t"], ("", "_d", "_dd")
    arrays = [np.column_stack([columns.get(n + s, np.zeros_like(t)) for n in coordinate_names]) for s in suffixes]
    derived = {n + s for n in coordinate_names for s in suffixes}
    others = {
        k: v
        for k, v in columns.items()
        if k != "t" and k not in derived and np.shape(v) == t.shape and np.issubdtype(np.asarray(v).dtype, np.number)
    }
    return Result(t, *arrays, list(coordinate_names), list(body_names), points=others)


def write_result(result: Result, path: str | Path) -> Path:
    """Write by extension: .csv or .npz."""
    path = Path(path)
    if path.suffix == ".npz":
        return write_npz(result, path)
    return write_csv(result, path)
