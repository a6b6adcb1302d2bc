"""Generate, cache and load the compiled module of a scene's dimension: the model is data.

For a ``Scene`` (``scene.py``) the generator writes a Python module with

- ``scene_rhs(t, z, P, D, out)``: y' = (q', q'') (and D', W_applied', W_drivers' when the run keeps the energy
  balance: dampers, actuators, loads or drivers, ``dynamics.EquationsOfMotion``; a number of P says so), q'' and
  lambda from the Baumgarte-stabilized augmented system of eq. 5.30,

      [ M      Psi_q^T ] [ q''    ]   [ Q                                  ]
      [ Psi_q  0       ] [ lambda ] = [ gamma - 2 alpha Psi' - beta^2 Psi  ]      (eq. 5.29, 5.30)

  assembled by calling every kernel of the dimension's element and force types on its slot of the element
  data D, skipping a kernel whose slot has no rows (a branch: the elements a scene lacks cost nothing), the
  spatial mass matrix and quadratic-velocity term only in the spatial module; solved by the range-space form of
  eq. 5.31, Psi_q M^-1 Psi_q^T factored by Cholesky: a spatial one with M^-1 applied body by body (its 4 x 4
  Euler-parameter blocks factored, ``spatial_range_space_solve``), a planar one (M diagonal) with S whole for a small
  scene (``dense_range_space_solve``) and within its envelope from n + m = ``RANGE_SPACE_SIZE``
  (``range_space_solve``); by the LU of eq. 5.30 with partial pivoting (as ``formulations.Baumgarte``'s LAPACK
  gesv) where neither applies (a body without mass, dependent rows). Given an ``out`` longer than z, it also writes
  lambda after y', and given one longer still Psi, Psi_t and Psi_q (row by row) after lambda: the outputs at the
  output times (``loops.output_history``) come from the same function as the integration. A state of another size
  than the scene's, or an ``out`` longer than y' but too short for lambda, gets ``out`` filled with NaN (numba
  checks no bounds: it wrote past ``out``'s end);
- ``constraint_arrays(T, Y, P, D, Psi, Psi_q, Psi_t)``: the constraints at given states (``history.py``);
both with the fixed signatures of ``loops.py``, whose integrator loops (compiled once per machine) take
them as first-class functions. (One function for the integration and the outputs: numba optimizes every
kernel a function calls again in each function that calls it, so each one more costs seconds of compilation.)

Both are compiled by numba with ``cache=True``. The module is written once per dimension to the
cache directory (``cache_directory()``: ``$MBD_COMPILED_CACHE``, else ``$XDG_CACHE_HOME/mbd-course/compiled``,
else ``~/.cache/mbd-course/compiled``), named by a hash of its text, of ``kernels.py`` and ``loops.py``
and of the numba version; numba keeps the machine code beside it in ``__pycache__``. Every later run of a
scene of that dimension (any elements, dimensions, masses, initial state) loads that machine code: a
machine compiles each module once, not once per model.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import importlib.util
import os
import sys
from functools import cache
from pathlib import Path

from ..batch import write_atomic
from .scene import PLANAR_CONSTRAINTS, SLOTS, SPATIAL_CONSTRAINTS, Scene

HERE = Path(__file__).parent

CONSTRAINT_CALLS = {
    "planar_revolute": "{name}(q, qd, t, {ints}, {floats}, psi, jac, gam)",
    "planar_along": "{name}(q, qd, t, {ints}, {floats}, fk, fp, psi, jac, psit, gam)",
    "planar_angle": "{name}(q, qd, t, {ints}, {floats}, fk, fp, psi, jac, psit, gam)",
    "planar_coordinate": "{name}(q, qd, t, {ints}, {floats}, fk, fp, psi, jac, psit, gam)",
    "planar_distance": "{name}(q, qd, t, {ints}, {floats}, fk, fp, psi, jac, psit, gam)",
    "planar_gear": "{name}(q, qd, t, {ints}, {floats}, psi, jac, gam)",
    "planar_roller_cam": "{name}(q, qd, t, {ints}, {floats}, fk, fp, psi, jac, psit, gam)",
    "planar_flat_cam": "{name}(q, qd, t, {ints}, {floats}, fk, fp, psi, jac, psit, gam)",
    "spatial_spherical": "{name}(q, qd, t, {ints}, {floats}, psi, jac, gam)",
    "spatial_dot1": "{name}(q, qd, t, {ints}, {floats}, psi, jac, gam)",
    "spatial_dot2": "{name}(q, qd, t, {ints}, {floats}, psi, jac, gam)",
    "spatial_normalization": "{name}(q, qd, t, {ints}, psi, jac, gam)",
    "spatial_translation": "{name}(q, qd, t, {ints}, {floats}, fk, fp, psi, jac, psit, gam)",
    "spatial_rotation": "{name}(q, qd, t, {ints}, {floats}, fk, fp, psi, jac, psit, gam)",
    "spatial_distance": "{name}(q, qd, t, {ints}, {floats}, fk, fp, psi, jac, psit, gam)",
    "spatial_coordinate": "{name}(q, qd, t, {ints}, {floats}, fk, fp, psi, jac, psit, gam)",
}
FORCE_CALL = "{name}(q, qd, t, {ints}, {floats}, fk, fp, Q, power)"


def cache_directory() -> Path:
    """Where generated modules and numba's machine code live (module docstring)."""
    if os.environ.get("MBD_COMPILED_CACHE"):
        return Path(os.environ["MBD_COMPILED_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "mbd-course" / "compiled"


def slot_bounds(slot: int, offsets: str = "D[2]") -> tuple[str, str]:
    """The source of the first row of ``slot`` in the element data (``scene.packed``) and of the row after its last."""
    return f"{offsets}[{slot}]", f"{offsets}[{slot + 1}]"


def slot_rows(slot: int, offsets: str = "D[2]") -> str:
    """The source of the slice of ``slot``'s rows in the element data: ``first : stop``."""
    return " : ".join(slot_bounds(slot, offsets))


def kernel_call(
    call: str, name: str, indent: str, slot: int, data: tuple = ("D[0]", "D[1]", "D[2]"), stops: str = ""
) -> list[str]:
    """The call of kernel ``name`` on its rows of the element data (``data``: the names of ints, floats and offsets;
    ``scene.packed``), the rows of ``slot``, made only when it has rows: a scene's module calls every kernel of
    its dimension. ``stops``: a shift added to the index of the slot's stop (" + cut": a tree's cut rows alone,
    ``tree.TreeScene.data``)."""
    ints, floats, offsets = data
    first, stop = slot_bounds(slot, offsets)
    if stops:  # the slot's stop further on in the offsets: offsets[slot + 1 + shift]
        stop = f"{offsets}[{slot + 1}{stops}]"
    rows = f"{first} : {stop}"
    call = call.format(name=name, ints=f"{ints}[{rows}]", floats=f"{floats}[{rows}]")
    return [f"{indent}if {stop} > {first}:", f"{indent}    {call}"]


def constraint_calls(scene: Scene, indent: str, stops: str = "", written: dict = CONSTRAINT_CALLS) -> list[str]:
    """The calls of the scene's constraint kernels, each on its slot of the element data D when it has rows (``stops``:
    ``kernel_call``'s; ``written``: each kernel's call, a tree's module calls some by another form)."""
    calls = [(written[name], name) for name, _, _ in scene.constraint_kernels]
    return [line for call, name in calls for line in kernel_call(call, name, indent, SLOTS.index(name), stops=stops)]


def force_calls(scene: Scene, indent: str) -> list[str]:
    """The calls of the scene's force kernels, each on its slot of D when it has rows (Q and power += theirs)."""
    names = [name for name, _, _ in scene.force_kernels]
    return [line for name in names for line in kernel_call(FORCE_CALL, name, indent, SLOTS.index(name))]


def generate(scene: Scene) -> str:
    """The source text of the scene's module (module docstring)."""
    names = [name for name, _, _ in (*scene.constraint_kernels, *scene.force_kernels)]
    planar_solvers = {"range_space_solve", "dense_range_space_solve", "RANGE_SPACE_SIZE"}
    solver = {"spatial_mass", "spatial_range_space_solve"} if scene.dimension == 3 else planar_solvers
    imports = sorted({*names, "augmented_solve", *solver})
    lines = [
        f'"""Generated by solutions.compiled.codegen for the dimension {scene.key!r}: do not edit."""',
        "import numpy as np",
        "from numba import njit",
        "",
        f"from solutions.compiled.kernels import {', '.join(imports)}",
        "from solutions.compiled.loops import CONSTRAINT_ARRAYS_SIGNATURE, RHS_SIGNATURE",
        "",
        "",
        "@njit(RHS_SIGNATURE, cache=True, nogil=True)",
        "def scene_rhs(t, z, P, D, out):",
        "    \"\"\"y' = (q', q''[, P_dissipated, P_applied, P_drivers]), q'' and lambda of eq. 5.30 with gamma",
        '    stabilized (eq. 5.29); when ``out`` is longer than z, lambda after y\' (``loops.outputs``)."""',
        "    Q0, mass, masses, inertias, weights, fk, fp, ab, dims = P",
        "    n, m = dims[0], dims[1]",
        "    nz = 2 * n + dims[2]  # q, q' and the energy balance's three states (P[8][2] = 3 or 0)",
        "    if z.size != nz or (out.size != nz and out.size < nz + m):  # (y'[, lambda[, Psi, Psi_t, Psi_q]])",
        "        out[:] = np.nan  # a size it does not know: NaN, not a write past out's end (no bounds checks)",
        "        return",
        "    q, qd = z[:n].copy(), z[n : 2 * n].copy()",
        "    if out.size == z.size + 3 * m + m * n:  # Psi, Psi_t, Psi_q into the outputs (``loops.output_history``)",
        "        rows = out[z.size + m :]",
        "        rows[:] = 0.0",
        "    else:",
        "        rows = np.zeros(2 * m + m * n)",
        "    psi, psit, gam = rows[:m], rows[m : 2 * m], np.zeros(m)",
        "    jac = rows[2 * m :].reshape((m, n))",
        "    qdd, lam = np.empty(n), np.empty(m)",
        "    Q, power = Q0.copy(), np.zeros(3)",
    ]
    lines += constraint_calls(scene, "    ") + force_calls(scene, "    ")
    if scene.dimension == 3:
        lines += [
            "    M = np.zeros((n, n))",
            "    spatial_mass(q, qd, masses, inertias, weights, M, Q)  # M(q) and Q += Q_v (eq. 10.4, 10.5)",
            "    if not spatial_range_space_solve(M, jac, psi, psit, gam, Q, qd, ab, qdd, lam):  # eq. 5.31 by blocks",
            "        augmented_solve(mass, M, True, jac, psi, psit, gam, Q, qd, ab, qdd, lam)  # else eq. 5.30's LU",
        ]
    else:
        lines += [
            "    if n + m < RANGE_SPACE_SIZE:  # eq. 5.31 with a dense S (a small scene), else within its envelope",
            "        solved = dense_range_space_solve(mass, jac, psi, psit, gam, Q, qd, ab, qdd, lam)",
            "    else:",
            "        solved = range_space_solve(mass, jac, psi, psit, gam, Q, qd, ab, qdd, lam)",
            "    if not solved:  # a mass not positive, dependent rows: the LU of eq. 5.30",
            "        augmented_solve(mass, jac, False, jac, psi, psit, gam, Q, qd, ab, qdd, lam)",
        ]
    lines += [
        "    for i in range(n):  # loops, not slice assignments (``loops._copy``)",
        "        out[i], out[n + i] = qd[i], qdd[i]",
        "    if dims[2]:  # the energy balance's three powers (``parameters``: three extra states)",
        "        power[2] = lam @ psit  # the drivers' power (eq. 5.61; zero without drivers: Psi_t = 0)",
        "        out[2 * n], out[2 * n + 1], out[2 * n + 2] = power[0], power[1], power[2]",
        "    if out.size > z.size:  # the outputs: lambda of every row",
        "        for i in range(m):",
        "            out[z.size + i] = lam[i]",
        "",
        "",
        "@njit(CONSTRAINT_ARRAYS_SIGNATURE, cache=True, nogil=True)",
        "def constraint_arrays(T, Y, P, D, PSI, JAC, PSIT):",
        '    """Psi, Psi_q and Psi_t at every output time T[k] from the states Y[k] (eq. 4.1-4.3), for the checks."""',
        "    fk, fp = P[5], P[6]",
        "    n, m = P[8][0], P[8][1]",
        "    gam = np.zeros(m)",
        "    for k in range(T.size):",
        "        t, q, qd = T[k], Y[k, :n].copy(), Y[k, n : 2 * n].copy()",
        "        psi, psit, jac = PSI[k], PSIT[k], JAC[k]",
    ]
    lines += constraint_calls(scene, "        ")
    return "\n".join(lines) + "\n"


@functools.cache
def _engine_fingerprint() -> bytes:
    """The kernels (and the rotation matrices they compile), the loops and numba's version: what every generated
    module's machine code depends on."""
    from importlib.metadata import version

    sources = ("kernels.py", "../rotation_matrices.py", "lapack.py", "loops.py")
    return b"".join((HERE / name).read_bytes() for name in sources) + version("numba").encode()


@functools.lru_cache(maxsize=256)
def _fingerprint(text: str) -> str:
    return hashlib.sha256(text.encode() + _engine_fingerprint()).hexdigest()[:20]


def _module_name(scene: Scene) -> tuple[str, str]:
    return named_module(scene.key, kernel_names(scene), lambda: generate(scene))


def kernel_names(scene: Scene) -> tuple[str, ...]:
    """The kernels a scene's module calls: with its dimension (``Scene.key``) all that its source text depends on."""
    return tuple(name for name, _, _ in (*scene.constraint_kernels, *scene.force_kernels))


_NAMES: dict[tuple, tuple[str, str]] = {}


def named_module(key: str, kernels: tuple[str, ...], text, prefix: str = "mbd_scene_", sources: tuple[str, ...] = ()):
    """(module name, source text) of a generated module, made once per process for its key and kernels (writing the
    text and hashing it costs a compiled call's fixed time, and a dimension's text never changes)."""
    if (prefix, key, kernels) not in _NAMES:
        source = text()
        _NAMES[prefix, key, kernels] = generated_name(prefix, source, sources), source
    return _NAMES[prefix, key, kernels]


def is_cached(scene: Scene) -> bool:
    """Whether numba's machine code for the scene's dimension is on disk (its index file, ``*.nbi``), or its
    module is loaded in this process already (from another cache directory, say): no compilation either way."""
    return is_generated_cached(_module_name(scene)[0], "scene_rhs")


def load(scene: Scene) -> tuple[object, bool]:
    """The scene's compiled module (written to the cache directory if new), and whether numba's machine code
    for it was on disk already (a cached module: no compilation)."""
    return load_generated(*_module_name(scene), "scene_rhs")


# -- the kinematic analysis: the constraint kernels alone (kinematic.py, kinematic_loop.py) ------------------------
KINEMATIC_SLOTS = (*PLANAR_CONSTRAINTS, *SPATIAL_CONSTRAINTS)
"""The constraint kernels in the order of their rows in the kinematic data D = (ints, floats, offsets)."""


def generate_kinematic(scene: Scene) -> str:
    """The source text of a scene's kinematic module: ``evaluate(t, q, q', F, D, Psi, Psi_q, Psi_t, gamma)``, every
    constraint kernel of the scene's dimension, each called when it has rows, with the fixed signature of
    ``kinematic_loop.py`` (whose step loop, compiled once per machine, takes it as a first-class function)."""
    names = sorted({name for name, _, _ in scene.constraint_kernels})
    lines = [
        f'"""Generated by solutions.compiled.codegen (kinematic) for the dimension {scene.key!r}: do not edit."""',
        "from numba import njit",
        "",
        *([f"from solutions.compiled.kernels import {', '.join(names)}"] if names else []),
        "from solutions.compiled.kinematic_loop import EVALUATE_SIGNATURE",
        "",
        "",
        "@njit(EVALUATE_SIGNATURE, cache=True, nogil=True)",
        "def evaluate(t, q, qd, F, D, psi, jac, psit, gam):",
        '    """Psi, Psi_q, Psi_t and gamma at (t, q, q\') (eq. 4.1-4.4)."""',
        "    fk, fp = F",
        "    ints, floats, o = D",
        "    jac[:, :] = 0.0",
        "    psit[:] = 0.0",
    ]
    for name, _, _ in scene.constraint_kernels:
        s = KINEMATIC_SLOTS.index(name)
        lines += kernel_call(CONSTRAINT_CALLS[name], name, "    ", s, ("ints", "floats", "o"))
    return "\n".join(lines) + "\n"


@cache
def _kinematic_sources() -> bytes:
    """What the compiled kinematic code depends on besides its text: the kernels, the loop, numba's version."""
    from importlib.metadata import version

    sources = ("kernels.py", "../rotation_matrices.py", "lapack.py", "kinematic_loop.py")
    return b"".join((HERE / name).read_bytes() for name in sources) + version("numba").encode()


@cache
def _kinematic_name_of(text: str) -> str:
    return f"mbd_kinematic_{hashlib.sha256(text.encode() + _kinematic_sources()).hexdigest()[:20]}"


def _kinematic_name(scene: Scene) -> tuple[str, str]:
    text = generate_kinematic(scene)
    return _kinematic_name_of(text), text


def is_kinematic_cached(scene: Scene) -> bool:
    """Whether numba's machine code for the scene's kinematic module is on disk (its index file, ``*.nbi``)."""
    return is_generated_cached(_kinematic_name(scene)[0], "evaluate")


def load_kinematic(scene: Scene) -> tuple[object, bool]:
    """The scene's kinematic module (written to the cache directory if new, as ``load``), and whether its machine
    code was on disk already."""
    return load_generated(*_kinematic_name(scene), "evaluate")


def generated_name(prefix: str, text: str, sources: tuple[str, ...] = ()) -> str:
    """The cache name of a generated module other than the scene's own (``projection.py``, ``tree.py``): prefix
    and a hash of its text, of the kernel files it imports (``sources``, beside this file) and of ``_fingerprint``'s."""
    return prefix + _fingerprint(text + _sources_text(sources))


@functools.cache
def _sources_text(sources: tuple[str, ...]) -> str:
    return "".join((HERE / source).read_text() for source in sources)


def load_generated(name: str, text: str, probe: str) -> tuple[object, bool]:
    """The generated module ``name`` with source ``text`` (written to the cache directory if new), and whether
    numba's machine code of its function ``probe`` was on disk already: ``load`` for any generated module."""
    if name in sys.modules:
        return sys.modules[name], True
    directory = cache_directory()
    path = directory / f"{name}.py"
    if not path.exists():
        write_atomic(path, text)  # a parallel run never imports half a file
    with _one_compilation(directory, name, is_generated_cached(name, probe)):
        cached = is_generated_cached(name, probe)  # another process may have compiled it while this one waited
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)  # numba compiles the explicit signatures here, or loads them from disk
    return module, cached


@contextlib.contextmanager
def _one_compilation(directory: Path, name: str, cached: bool):
    """While one process compiles a generated module, the others that need it wait for it (an advisory lock on
    ``<name>.lock`` in the cache directory) and then load its machine code from disk: a module is compiled once
    per machine, not once per process that starts at the same time (two runs, pytest's workers). No lock where
    the module is cached already, or where the platform has no ``fcntl``."""
    try:
        import fcntl
    except ImportError:  # not POSIX: each process compiles what it does not find
        fcntl = None
    if cached or fcntl is None:
        yield
        return
    with open(directory / f"{name}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def is_generated_cached(name: str, probe: str) -> bool:
    """Whether numba's machine code of ``probe`` in the generated module ``name`` is on disk (or loaded already)."""
    return name in sys.modules or any((cache_directory() / "__pycache__").glob(f"{name}.{probe}-*.nbi"))


__all__ = [
    "cache_directory",
    "generate",
    "KINEMATIC_SLOTS",
    "generate_kinematic",
    "generated_name",
    "kernel_names",
    "named_module",
    "is_cached",
    "is_generated_cached",
    "is_kinematic_cached",
    "load",
    "load_generated",
    "load_kinematic",
]
