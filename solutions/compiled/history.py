"""What a compiled run reports besides its motion: Psi, Psi_q and Psi_t over the output grid, from its generated
module at every output time in one call (``constraint_arrays``); the residuals and the joint reactions made from
them are ``output_history``'s (shared with the numpy engine, which evaluates the same arrays through the
``System``), named here too.
"""

from __future__ import annotations

import numpy as np

from ..output_history import joint_reactions, planar_reactions, residuals, spatial_reactions


def constraint_arrays(module, scene, times: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Psi, Psi_q, Psi_t) at every output time, shapes (N, m), (N, m, n), (N, m), from the compiled module."""
    from . import parameters

    N, n, m = times.size, scene.n, scene.m
    psi, jac, psit = np.zeros((N, m)), np.zeros((N, m, n)), np.zeros((N, m))
    module.constraint_arrays(times, np.ascontiguousarray(Y), parameters(scene, 0.0, 0.0), scene.data(), psi, jac, psit)
    return psi, jac, psit


__all__ = ["constraint_arrays", "joint_reactions", "planar_reactions", "residuals", "spatial_reactions"]
