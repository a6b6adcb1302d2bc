"""What a compiled run's force elements exert at its output times, and the potential energy V there.

The numpy engine asks every element's per-state methods at every output time (``generalized_forces.element_columns``
and ``ForceModel.potential_energy``, what students write): ~50 us per element and time in Python, 60-85 % of a
compiled call on a scene with a spring. A compiled run hands its q, q' histories to compiled loops instead
(``element_history_kernels``, ``spatial_element_history_kernels``), one pass over each force kernel's rows (the rows
the scene's module integrates, ``scene.force_data``), and here their numbers become the same result columns:

- 'E.force' (a spring-damper-actuator's tension), 'E.torque' (a rotational one's, or a planar torque's), 'E.Fx' ..
  (a point force, global), 'E.Mx' .. (a spatial torque, global) and 'E.power' = q_i'^T Q_i + q_j'^T Q_j, element
  after element and in each its columns in ``element_columns``' order;
- V = -Q_gravity^T q + the springs' 1/2 k (l - l0)^2 and 1/2 k (theta - theta0)^2, added element after element
  as ``potential_energy`` adds them at one state (eq. 5.20).

Within rounding of the per-state methods (``tests/solutions/test_element_history.py``). None where the force model has
what the kernels do not cover (``scene.Unsupported``): the caller takes the per-state loop.
"""

from __future__ import annotations

import numpy as np

from .scene import Unsupported, force_data

ELEMENTS = {
    (2, "TSDA"): ("planar_tsda", {"force": 0}, 1, 2),
    (2, "RSDA"): ("planar_rsda", {"torque": 0}, 1, 2),
    (2, "PointForce"): ("planar_load", {"Fx": 0, "Fy": 1}, 3, None),
    (2, "Torque"): ("planar_load", {"torque": 2}, 3, None),
    (3, "TSDA"): ("spatial_tsda", {"force": 0}, 1, 2),
    (3, "RSDA"): ("spatial_rsda", {"torque": 0}, 1, 2),
    (3, "PointForce"): ("spatial_load", {"Fx": 0, "Fy": 1, "Fz": 2}, 3, None),
    (3, "Torque"): ("spatial_load", {"Mx": 0, "My": 1, "Mz": 2}, 3, None),
}
"""For each element type of a dimension: the force kernel whose rows hold it, where its measures are in the history
kernel's row (suffix: place), the place of its power and of its potential (None: it has none)."""
WIDTHS = {"tsda": 4, "rsda": 3, "load": 4}
"""The width of a history kernel's row for each element (``element_history_kernels``' docstring)."""
SPRINGS = ("planar_tsda", "spatial_tsda")
"""The kernels whose fourth number is the spring's length l (``TSDA.state`` refuses l < 1e-12: no line of action)."""


def element_history(forces, dimension: int, times: np.ndarray, q: np.ndarray, qd: np.ndarray) -> tuple | None:
    """(the result columns of every force element, V at every output time) of a run's q, q' histories (module
    docstring); None where the kernels do not cover the force model."""
    try:
        kernels, kinds, params = force_data(forces, dimension)
    except Unsupported:
        return None
    times, q, qd = (np.ascontiguousarray(a, dtype=float) for a in (times, q, qd))
    rows = {name: _kernel_history(name, ints, floats, kinds, params, times, q, qd) for name, ints, floats in kernels}
    columns, potential = {}, -(q @ forces.gravity)
    placed = dict.fromkeys(rows, 0)  # each kernel's next row: its elements in the force model's order
    for element in forces.elements:
        kernel, measures, power, spring = ELEMENTS[dimension, type(element).__name__]
        history = rows[kernel][placed[kernel]]
        placed[kernel] += 1
        if kernel in SPRINGS and np.any(history[:, 3] < 1e-12):  # as ``TSDA.state``
            raise ValueError(f"spring-damper {element.name}: its two points coincide (length 0): no line of action")
        for suffix, place in measures.items():
            columns[f"{element.name}.{suffix}"] = history[:, place].copy()
        columns[f"{element.name}.power"] = history[:, power].copy()
        if spring is not None:
            potential = potential + history[:, spring]
    return columns, potential


def _kernel_history(name, ints, floats, kinds, params, times, q, qd) -> np.ndarray:
    """The history kernel's rows of force kernel ``name`` (elements, times, width); none where the scene lacks it."""
    out = np.empty((ints.shape[0], times.size, WIDTHS[name.split("_")[1]]))
    if ints.shape[0]:
        if name.startswith("planar"):
            from . import element_history_kernels as kernels
        else:
            from . import spatial_element_history_kernels as kernels  # compiled at its import: never by a planar run
        getattr(kernels, f"{name}_history")(times, q, qd, ints, floats, kinds, params, out)
    return out


__all__ = ["element_history"]
