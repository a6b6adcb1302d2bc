"""LAPACK's routines called from compiled code: scipy's ``cython_lapack``, by name, so that the callers are cached.

The kinematic step loop (``kinematic_loop``: getrf, gesv), the Guard's band passes (``singular``: gbbrd, stebz,
gbtrf) and the kernels' large systems (``kernels.lu_solve``: gesv, the routine of ``np.linalg.solve``, called as
it calls it, without numba's wrapper, whose copy of b compiles a formatted error message into every process that
uses it: call_cost.md, thirtieth session).
"""

from __future__ import annotations

import llvmlite.binding
import numpy as np
from numba import types
from numba.extending import get_cython_function_address


def lapack(name: str, arguments: int) -> types.ExternalFunction:
    """LAPACK's ``name`` from scipy's public ``scipy.linalg.cython_lapack``, found by numba's public
    ``get_cython_function_address`` and registered with LLVM under a symbol of its own: compiled code calls it by
    that name, so the functions that call it are cached on disk (a ctypes pointer would be a dynamic global)."""
    symbol = f"mbd_lapack_{name}"
    llvmlite.binding.add_symbol(symbol, get_cython_function_address("scipy.linalg.cython_lapack", name))
    return types.ExternalFunction(symbol, types.void(*[types.voidptr] * arguments))


PIVOT_TYPE = np.int32
"""LAPACK's integer (scipy's ``cython_lapack`` takes C ints): the type of the pivots array."""

__all__ = ["PIVOT_TYPE", "lapack"]
