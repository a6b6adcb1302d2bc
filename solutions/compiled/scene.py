"""What a scene has, for the compiled engine: its element and force types, and their data as arrays.

``describe(system, forces, masses)`` reads the elements of an assembled ``System`` and a force model and
returns a ``Scene``: for every element type of its dimension, the kernel that evaluates it (``kernels.py``)
and its data (an int array and a float array, one row per element; no rows for a type the scene lacks); the
functions of time as a table; the constant part of Q (gravity), the masses. The model is data: every scene of
a dimension runs on one compiled module (``Scene.key``), compiled once per machine, whatever its elements,
dimensions, masses or initial state; the module skips a kernel without rows. A scene with anything the
kernels do not cover gets ``Scene.unsupported``, a reason the engine reports when it falls back to numpy.

No numba here: this module is imported to decide whether the compiled engine can run at all.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..functions import Constant, EccentricCircle, Fourier, Harmonic, Polynomial, SmoothRamp

FUNCTION_KINDS = {Constant: 0, Polynomial: 1, Harmonic: 2, SmoothRamp: 3, Fourier: 4, EccentricCircle: 5}
"""The function types the kernels evaluate (``kernels.function``); a Python callable cannot be compiled."""
SLOTS = (
    "planar_revolute", "planar_along", "planar_angle", "planar_coordinate", "planar_distance",
    "planar_tsda", "planar_rsda", "planar_load",
    "spatial_spherical", "spatial_dot1", "spatial_dot2", "spatial_normalization",
    "spatial_tsda", "spatial_rsda", "spatial_load",
    "planar_gear", "planar_roller_cam", "planar_flat_cam",
    "spatial_translation", "spatial_rotation", "spatial_distance", "spatial_coordinate",
    "tree",
)  # fmt: skip
"""The element data of every kernel has a fixed place in D = (ints, floats, offsets) (``packed``): one signature for
every scene (``tree``: the joints of a joint-coordinates scene, ``tree.py``)."""


KIND_NAMES = ("constant", "polynomial", "harmonic", "smooth ramp", "Fourier", "eccentric circle")


class Unsupported(Exception):
    """Something the compiled kernels do not cover (the message says what)."""


@dataclass
class Scene:
    """The compiled engine's view of one scene (see the module docstring)."""

    dimension: int
    n: int
    m: int
    constraint_kernels: list[tuple[str, np.ndarray, np.ndarray]] = field(default_factory=list)
    force_kernels: list[tuple[str, np.ndarray, np.ndarray]] = field(default_factory=list)
    function_kinds: np.ndarray = None
    function_params: np.ndarray = None
    Q0: np.ndarray = None
    mass_diagonal: np.ndarray = None  # planar: M as its diagonal
    masses: np.ndarray = None  # spatial
    inertias: np.ndarray = None
    weights: np.ndarray = None
    energies: bool = False
    drivers: bool = False
    unsupported: str | None = None
    first: frozenset = frozenset()
    """The elements described first in each constraint kernel's data (``describe``'s ``first``: a joint-coordinates
    tree's cut elements, which its integration evaluates alone: ``tree.TreeScene.data``)."""
    first_counts: dict = field(default_factory=dict)
    """Their count in each constraint kernel that has any (by name)."""
    packed_data: tuple | None = field(default=None, repr=False, compare=False)  # ``data()``, made once
    row_columns: np.ndarray | None = field(default=None, repr=False, compare=False)
    """A large Psi_q's rows' columns (m, w) (``history.row_columns``): its history is kept by those blocks
    (``history.BlockedJacobians``); None: dense (a small Psi_q, or rows that reach further)."""

    @property
    def key(self) -> str:
        """What the compiled module depends on: the dimension alone. Every scene of a dimension has every kernel
        of it (``scene_arrays``: those it lacks with no rows) and the energy terms are chosen at run time, so one
        module, compiled once per machine, runs every model of the course's element types."""
        return f"d{self.dimension}"

    def data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """D = (ints, floats, offsets): the element data of every kernel in its slot of ``SLOTS`` (``packed``), made
        at the first call (a run asks for it at its start rates, its loop and its output checks)."""
        if self.packed_data is None:
            self.packed_data = packed([*self.constraint_kernels, *self.force_kernels], SLOTS)
        return self.packed_data


def packed(kernels: list, slots: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """D = (ints, floats, offsets): the rows of every kernel's data (``kernels``: (name, ints, floats)) stacked in
    the order of ``slots``, padded with zeros to the widest, kernel s in rows offsets[s]:offsets[s + 1] (none
    when the scene lacks it). Three arrays, whatever the scene: a compiled call passes each array it takes as
    several machine words, and one int and one float array per slot (46 arrays) made every right-hand side 1.2-2.4x
    slower (benchmarks/results/rhs_cost.md)."""
    present = {name: (ints, floats) for name, ints, floats in kernels if ints.shape[0]}  # those with rows
    blocks = [present.get(name) for name in slots]
    starts, width_i, width_f = [0], 1, 1  # in one pass over the slots
    for block in blocks:
        starts.append(starts[-1] + (0 if block is None else block[0].shape[0]))
        if block is not None:
            width_i, width_f = max(width_i, block[0].shape[1]), max(width_f, block[1].shape[1])
    ints, floats = np.zeros((starts[-1], width_i), dtype=np.int64), np.zeros((starts[-1], width_f))
    for s, block in enumerate(blocks):
        if block is not None:  # a kernel without rows has nothing to copy (most of a dimension's kernels, in a scene)
            ints[starts[s] : starts[s + 1], : block[0].shape[1]] = block[0]
            floats[starts[s] : starts[s + 1], : block[1].shape[1]] = block[1]
    return ints, floats, np.array(starts, dtype=np.int64)


class Functions:
    """The functions of time of a scene, as a table (kind, parameters) the kernels evaluate."""

    def __init__(self):
        self.items: list = []

    def index(self, function) -> int:
        if function is None:
            return -1
        if isinstance(function, Constant) and function.c == 0.0:
            return -1
        kind = FUNCTION_KINDS.get(type(function))
        if kind is None:
            what = getattr(function, "name", type(function).__name__)
            raise Unsupported(f"a {type(function).__name__} function ({what}: only {', '.join(KIND_NAMES)} compile)")
        if kind == 0:
            params = [function.c]
        elif kind == 1:
            params = [len(function.coefficients), *function.coefficients]
        elif kind == 2:
            params = [function.amplitude, function.frequency, function.phase, function.offset]
        elif kind == 3:
            params = [function.start, function.end, function.start_value, function.end_value]
        elif kind == 4:
            params = [len(function.a), function.frequency, function.a0, *function.a, *function.b]
        else:
            params = [function.radius, function.eccentricity]
        self.items.append((kind, [float(p) for p in params]))
        return len(self.items) - 1

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        width = max([len(p) for _, p in self.items] + [1])
        kinds = np.array([k for k, _ in self.items] + [0], dtype=np.int64)  # one spare row: never empty
        params = np.zeros((len(self.items) + 1, width))
        for r, (_, p) in enumerate(self.items):
            params[r, : len(p)] = p
        return kinds, params


def _group(rows: dict, name: str, ints: list, floats: list) -> None:
    """One element's row of kernel ``name``: its ints and floats added to the kernel's flat lists, with the count of
    rows (a kernel's rows have one width; ``scene_arrays`` makes each list an array: a flat list converts 3-4x faster
    than a list of rows, 4 us of a loop chain of four's start). A kernel's entry is made at its first element
    (``setdefault`` made a spare entry, three lists, at every element)."""
    group = rows.get(name)
    if group is None:
        rows[name] = [ints, floats, 1]
        return
    group[0] += ints
    group[1] += floats
    group[2] += 1


def leading(first: dict, later: dict) -> dict:
    """Each constraint kernel's rows (``_group``'s [ints, floats, count]) of the elements described first, then of
    the others, each group in the elements' order; the count of the first appended to each kernel's entry
    (``Scene.first_counts``). A tree's cut elements first in its scene's own data: where a joint-coordinates run's
    integration reads them alone, with no reordering of the kernels' arrays at every run (``tree.TreeScene.data``)."""
    for group in first.values():
        group.append(group[2])
    for name, (ints, floats, count) in later.items():
        group = first.get(name)
        if group is None:  # none of the kernel's elements first (every kernel of an open tree): its lists as made
            first[name] = [ints, floats, count, 0]
        else:
            group[0] += ints
            group[1] += floats
            group[2] += count
    return first


def _entries(*vectors) -> list[float]:
    """The entries of body-frame vectors (arrays, or sequences), one after the other, as Python floats: an array's
    by ``tolist`` (unpacking one makes a numpy scalar of every entry: 1.6 us an element against 0.4)."""
    entries = []
    for x in vectors:
        entries += x.tolist() if isinstance(x, np.ndarray) else x
    return entries


def scene_arrays(rows: dict, order: tuple[str, ...]) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(kernel, ints, floats) of every kernel in ``order``: those the scene lacks with no rows (the compiled module
    of a dimension calls them all, and skips a kernel without rows: one module for every scene)."""
    out = []
    for name in order:
        if name in rows:
            ints, floats, count = rows[name][:3]
            floats_array = np.array(floats, dtype=float).reshape(count, -1) if floats else np.zeros((count, 1))
            out.append((name, np.array(ints, dtype=np.int64).reshape(count, -1), floats_array))
        else:
            out.append((name, _NO_INTS, _NO_FLOATS))
    return out


_NO_INTS, _NO_FLOATS = np.zeros((0, 1), dtype=np.int64), np.zeros((0, 1))
"""The data of a kernel a scene lacks (no rows), one pair for all: read only (``packed`` copies rows, and has none
to copy from these)."""
_NO_INTS.flags.writeable = _NO_FLOATS.flags.writeable = False


def _actuator(element, functions: Functions) -> int:
    actuator = element.actuator
    if getattr(actuator, "__name__", "") == "no_actuator":
        return -1
    if type(actuator).__name__ == "TimeActuator":
        return functions.index(actuator.function)
    raise Unsupported(
        f"the actuator of {element.name} (a Python callable of time, length and speed; a function of time compiles)"
    )


PLANAR_CONSTRAINTS = (
    "planar_revolute", "planar_along", "planar_angle", "planar_coordinate", "planar_distance",
    "planar_gear", "planar_roller_cam", "planar_flat_cam",
)  # fmt: skip
PLANAR_FORCES = ("planar_tsda", "planar_rsda", "planar_load")
SPATIAL_CONSTRAINTS = (
    "spatial_spherical", "spatial_dot1", "spatial_dot2", "spatial_normalization",
    "spatial_translation", "spatial_rotation", "spatial_distance", "spatial_coordinate",
)  # fmt: skip
SPATIAL_FORCES = ("spatial_tsda", "spatial_rsda", "spatial_load")


def planar_constraints(system, functions: Functions, first: frozenset = frozenset()) -> dict:
    from ..planar import joints as pj

    leading_rows, later = {}, {}  # the kernels' rows of the elements in ``first``, of the others (``leading``)
    for element, where in zip(system.elements, system.rows, strict=True):
        rows = leading_rows if element.name in first else later
        i, j, row = element.i, element.j, where.start
        kind = type(element)
        if kind is pj.Revolute:
            _group(rows, "planar_revolute", [i, j, row], _entries(element.si, element.sj))
        elif kind is pj.PinInSlot:
            _group(rows, "planar_along", [i, j, row, -1], [*element.si, *element.sj, *element._normal, 0.0, 0.0])
        elif kind is pj.Translation:
            f = functions.index(element.function)
            rolling = element.side * element.pinion_radius
            _group(rows, "planar_along", [i, j, row, f], [*element.si, *element.sj, *element.axis, element.d0, rolling])
        elif kind is pj.RelativeAngle:
            _group(rows, "planar_angle", [i, j, row, functions.index(element.function)], [element.phi0])
        elif kind is pj.BodyCoordinate and i < 0:
            _group(rows, "planar_coordinate", [j, row, element.index, functions.index(element.function)], [])
        elif kind is pj.Distance:
            f = functions.index(element.length)
            if f < 0:  # a zero length: the function table needs an entry anyway
                f = functions.index(Constant(1e-300))
            _group(rows, "planar_distance", [i, j, row, f], _entries(element.si, element.sj))
        elif kind is pj.Gear:
            radii = [element.radius_i, element.radius_j, element.sigma, element.c0]
            _group(rows, "planar_gear", [i, j, row], [*element.si, *element.sj, *radii])
        elif kind is pj.RollerCam:
            _group(rows, "planar_roller_cam", [i, j, row, functions.index(element.profile)], [*element.si, *element.sj])
        elif kind is pj.FlatFaceCam:
            floats = [*element.si, *element.sj, *element.normal, element._alpha]
            _group(rows, "planar_flat_cam", [i, j, row, functions.index(element.profile)], floats)
        else:
            raise Unsupported(f"a planar {kind.__name__} element ({element.name})")
    return leading(leading_rows, later)


def _planar_forces(forces, functions: Functions) -> dict:
    from ..planar import forces as pf

    rows: dict = {}
    for element in forces.elements:
        kind = type(element)
        if kind is pf.TSDA:
            f = _actuator(element, functions)
            k, c, l0 = element.stiffness, element.damping, element.free_length
            _group(rows, "planar_tsda", [element.i, element.j, f], [*element.si, *element.sj, k, c, l0])
        elif kind is pf.RSDA:
            f = _actuator(element, functions)
            _group(
                rows, "planar_rsda", [element.i, element.j, f], [element.stiffness, element.damping, element.free_angle]
            )
        elif kind is pf.PointForce:
            fx, fy = (functions.index(c) for c in element.components)
            _group(rows, "planar_load", [element.i, fx, fy, int(element.body_fixed), -1], [*element.point])
        elif kind is pf.Torque:
            _group(rows, "planar_load", [element.i, -1, -1, 0, functions.index(element.function)], [0.0, 0.0])
        else:
            raise Unsupported(f"a planar {kind.__name__} force ({element.name})")
    return rows


def spatial_constraints(system, functions: Functions, first: frozenset = frozenset()) -> dict:
    from ..spatial import joints as sj

    leading_rows, later = {}, {}  # the kernels' rows of the elements in ``first``, of the others (``leading``)
    for element, where in zip(system.elements, system.rows, strict=True):
        rows = leading_rows if element.name in first else later
        i, j, row = element.i, element.j, where.start
        kind = type(element)
        if kind is sj.EulerNormalization:
            _group(rows, "spatial_normalization", [j, row], [])
        elif kind is sj.Joint:
            for part in element.parts:
                if type(part) is sj.Spherical:
                    _group(rows, "spatial_spherical", [i, j, row], _entries(part.si, part.sj))
                elif type(part) is sj.Dot1:
                    _group(rows, "spatial_dot1", [i, j, row], _entries(part.ai, part.aj))
                elif type(part) is sj.Dot2:
                    _group(rows, "spatial_dot2", [i, j, row], _entries(part.ai, part.si, part.sj))
                else:
                    raise Unsupported(f"a {type(part).__name__} constraint in joint {element.name}")
                row += len(part.labels)
        elif kind is sj.TranslationDriver:
            f = functions.index(element.function)
            floats = [*element.axis, *element.si, *element.sj, element.offset]
            _group(rows, "spatial_translation", [i, j, row, f], floats)
        elif kind is sj.RotationDriver:
            f = functions.index(element.function)
            _group(rows, "spatial_rotation", [i, j, row, f], [*element.fi, *element.gi, *element.fj, element.angle0])
        elif kind is sj.DistanceDriver:
            _group(rows, "spatial_distance", [i, j, row, functions.index(element.length)], [*element.si, *element.sj])
        elif kind is sj.CoordinateDriver and i < 0:
            f = functions.index(element.function)
            _group(rows, "spatial_coordinate", [j, row, element.index, f], [])
        else:
            raise Unsupported(f"a spatial {kind.__name__} element ({element.name})")
    return leading(leading_rows, later)


def _spatial_forces(forces, functions: Functions) -> dict:
    from ..spatial import forces as sf

    rows: dict = {}
    for element in forces.elements:
        kind = type(element)
        if kind is sf.TSDA:
            f = _actuator(element, functions)
            k, c, l0 = element.stiffness, element.damping, element.free_length
            _group(rows, "spatial_tsda", [element.i, element.j, f], [*element.si, *element.sj, k, c, l0])
        elif kind is sf.RSDA:
            f = _actuator(element, functions)
            vectors = [*element.fi, *element.gi, *element.hi, *element.fj]
            _group(
                rows,
                "spatial_rsda",
                [element.i, element.j, f],
                [*vectors, element.stiffness, element.damping, element.free_angle],
            )
        elif kind in (sf.PointForce, sf.Torque):
            components = [functions.index(c) for c in element.components]
            point = element.point if kind is sf.PointForce else np.zeros(3)
            load = 0 if kind is sf.PointForce else 1
            _group(rows, "spatial_load", [element.i, load, int(element.body_fixed), *components], [*point])
        else:
            raise Unsupported(f"a spatial {kind.__name__} force ({element.name})")
    return rows


def force_data(forces, dimension: int) -> tuple[list[tuple[str, np.ndarray, np.ndarray]], np.ndarray, np.ndarray]:
    """((kernel, ints, floats) of every force kernel of the dimension, the function kinds, their parameters): the force
    rows a scene's module reads (``describe``), each kernel's rows in the elements' order, for what the elements exert
    at the output times (``element_history``). Raises ``Unsupported`` where ``describe`` would."""
    functions = Functions()
    if dimension == 2:
        kernels = scene_arrays(_planar_forces(forces, functions), PLANAR_FORCES)
    else:
        kernels = scene_arrays(_spatial_forces(forces, functions), SPATIAL_FORCES)
    return kernels, *functions.arrays()


def describe(system, M, forces, first: frozenset = frozenset()) -> Scene:
    """The scene's kernels and data (module docstring); ``unsupported`` says why it cannot be compiled. ``first``: the
    names of the elements whose rows come first in each constraint kernel's data (``Scene.first``)."""
    model = system.model
    scene = Scene(model.dimension, system.n_coordinates, system.n_constraints)
    scene.drivers = bool(model.motors)
    scene.energies = not forces.is_conservative or scene.drivers
    functions = Functions()
    try:
        if forces.user_forces:
            raise Unsupported("user forces (Python callables)")
        if model.dimension == 2:
            diagonal = None if callable(M) else np.diagonal(M)
            if diagonal is None or np.count_nonzero(M) != np.count_nonzero(diagonal):  # a nonzero off the diagonal
                raise Unsupported("a planar mass matrix that is not diagonal")
            rows = planar_constraints(system, functions, first)
            constraints = scene_arrays(rows, PLANAR_CONSTRAINTS)
            loads = scene_arrays(_planar_forces(forces, functions), PLANAR_FORCES)
            scene.mass_diagonal = diagonal.astype(float)
            scene.Q0 = np.asarray(forces.gravity, dtype=float).copy()
        else:
            if type(M).__name__ != "SpatialMassMatrix":
                raise Unsupported("a spatial mass matrix given by the caller (masses=)")
            rows = spatial_constraints(system, functions, first)
            constraints = scene_arrays(rows, SPATIAL_CONSTRAINTS)
            loads = scene_arrays(_spatial_forces(forces, functions), SPATIAL_FORCES)
            scene.Q0 = np.asarray(forces.gravity, dtype=float).copy()
            scene.masses = np.array([b.mass for b in model.bodies], dtype=float)
            scene.inertias = np.array(M.inertias, dtype=float).reshape(-1, 3, 3)  # the model's, as M holds them
            scene.weights = np.array(M.weights, dtype=float)
    except Unsupported as why:
        scene.unsupported = str(why)
        return scene
    scene.constraint_kernels, scene.force_kernels = constraints, loads
    scene.first, scene.first_counts = first, {name: group[3] for name, group in rows.items() if group[3]}
    scene.function_kinds, scene.function_params = functions.arrays()
    scene.row_columns = _row_columns(system)
    return scene


def _row_columns(system) -> np.ndarray | None:
    """``Scene.row_columns``: those of a Psi_q of more than ``ONE_PASS_LARGEST`` entries (whose history the output
    stage writes in two passes, ``compiled.run``), else None."""
    from . import ONE_PASS_LARGEST, history

    if system.n_constraints * system.n_coordinates <= ONE_PASS_LARGEST:
        return None
    return history.row_columns(system)


__all__ = ["Scene", "Unsupported", "describe", "force_data"]
