"""Data input: read a model file (YAML or JSON), validate it, and return a ``Model``.

Validation has two layers. The JSON Schema shipped beside this file (``schema.json``) checks keys,
types and value ranges; ``_check_references`` then checks what a schema cannot: names that refer to
other elements, vector sizes against the model's dimension, duplicate names. Every problem becomes a
``ModelError`` whose text names the file, the key path and what to write instead, e.g.::

    four_bar.yaml: model.joints[2].body2: no body named 'couplr' (bodies: crank, coupler, rocker)
"""

from __future__ import annotations

import contextlib
import difflib
import functools
import hashlib
import json
import marshal
import math
import os
import re
import sys
import types
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from importlib.util import MAGIC_NUMBER
from pathlib import Path
from typing import Any

import fastjsonschema
import numpy as np
import yaml

from ..batch import write_atomic
from ..rotation_matrices import euler_rotation, planar_rotation

GROUND = "ground"


class ModelError(ValueError):
    """A model file (or an in-memory model description) that cannot be used, with the reason."""


@dataclass
class Body:
    """A rigid body: mass properties and the configuration the file gives (global frame)."""

    name: str
    mass: float
    inertia: Any  # planar: polar moment about the centre of mass; spatial: 3 or 3x3
    location: np.ndarray
    orientation: Any = 0.0  # planar: angle phi in rad; spatial: Euler parameters
    velocity: np.ndarray | None = None
    angular_velocity: Any = 0.0
    com: np.ndarray | None = None  # the file's com: centre of mass in the file's body frame (None: at location)
    has_mass: bool = True  # False: the file gives no mass properties (kinematic analyses only)


@dataclass
class Model:
    """A validated model. Joints, motors and force elements keep the file's mappings (with names)."""

    name: str
    dimension: int
    gravity: np.ndarray
    bodies: list[Body]
    joints: list[dict] = field(default_factory=list)
    motors: list[dict] = field(default_factory=list)
    spring_dampers: list[dict] = field(default_factory=list)
    forces: list[dict] = field(default_factory=list)
    simulation: dict = field(default_factory=dict)
    source: str = "<model>"
    dropped: list[str] = field(default_factory=list)  # imported from URDF or MJCF: what the import left out

    def require_masses(self, analysis: str) -> None:
        """Refuse an analysis that needs the mass matrix when a body of the file gives no mass properties.

        Raises
        ------
        ModelError
            Naming the first body without ``mass`` and ``inertia``.
        """
        for k, body in enumerate(self.bodies):
            if not body.has_mass:
                raise ModelError(
                    f"{self.source}: model.bodies[{k}]: '{body.name}' has no mass and inertia, so the model is "
                    f"kinematic only; give every body mass and inertia for a {analysis} analysis "
                    "(or run --analysis kinematic)"
                )

    def body_index(self, name: str) -> int:
        """Index of a body in ``bodies`` (-1 for ground)."""
        if name == GROUND:
            return -1
        for k, body in enumerate(self.bodies):
            if body.name == name:
                return k
        raise KeyError(name)


KEY_EXAMPLES = {
    "location": "[0.0, 0.0]",
    "point1": "[0.0, 0.0]",
    "point2": "[0.1, 0.0]",
    "axis": "[1.0, 0.0]",
    "radius": "0.05",
    "radius1": "0.05",
    "radius2": "0.1",
    "follower": "roller",
    "profile": "{type: eccentric_circle, radius: 0.06, eccentricity: 0.01}",
    "joint": "O",
    "body": "crank",
    "coordinate": "x",
    "function": "{type: polynomial, coefficients: [0.0, 1.0]}",
    "type": "revolute",
    "body1": "ground",
    "body2": "crank",
    "bodies": "[{name: crank, mass: 1.0, inertia: 0.01, location: [0.0, 0.0]}]",
    "model": "{name: ..., bodies: [...], joints: [...]}",
    "name": "crank",
    "value": "1.0",
}
"""Examples shown with a missing key, when the schema gives none."""


SCHEMA = "schema.json"
"""The JSON Schema of a model file, beside this module."""


@functools.cache
def _schema_text() -> str:
    return resources.files(__package__).joinpath(SCHEMA).read_text()


@functools.cache
def _schema() -> dict:
    return json.loads(_schema_text())


def validator_cache() -> Path:
    """Where the compiled schema validator is kept: ``$XDG_CACHE_HOME/mbd-course/schema`` (else ~/.cache/...)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "mbd-course" / "schema"


@functools.cache
def _fast_validator():
    """The schema compiled by fastjsonschema: it decides whether a file is valid. ``jsonschema``, whose
    import takes a second (it imports every format checker's backend), is imported only to explain an
    invalid file.

    fastjsonschema writes the validator as Python source, half a megabyte for this schema, which takes
    about 0.1 s to generate and compile: longer than a short ``mbd run``. So the compiled code is kept in
    ``validator_cache()``, named by a hash of the schema, fastjsonschema's version and Python's bytecode
    version, and loaded from there (in a millisecond) by the next process; a cache that is missing,
    stale, unreadable or not writable only means compiling again."""
    name, code = _validator_code()
    namespace = {}
    exec(code, namespace)
    return namespace[name]


def _validator_code() -> tuple[str, types.CodeType]:
    """The name of the validating function and the compiled code that defines it: from the cache, else compiled."""
    key = hashlib.sha256(f"{_schema_text()}|{fastjsonschema.VERSION}|{MAGIC_NUMBER.hex()}".encode()).hexdigest()
    path = validator_cache() / f"validator-{key[:20]}.marshal"
    try:
        name, code = marshal.loads(path.read_bytes())
        if isinstance(name, str) and isinstance(code, types.CodeType):
            return name, code
    except (OSError, EOFError, ValueError, TypeError):  # not there yet, or not whole: compile it again
        pass
    source = fastjsonschema.compile_to_code(_schema())
    name = re.search(r"^def (\w+)\(", source, re.MULTILINE).group(1)  # the first function validates the root
    code = compile(source, f"<fastjsonschema validator of {SCHEMA}>", "exec")
    with contextlib.suppress(OSError):  # a read-only home, a full disk: the next process compiles again
        write_atomic(path, marshal.dumps((name, code)))  # whole or not at all, when two processes write it at once
    return name, code


def schema_errors(data: dict) -> list:
    """The JSON Schema errors of a model file's content ([] when it is valid).

    Importing ``jsonschema`` can take seconds, loading the fastjsonschema validator a millisecond (once
    compiled and cached, ``_fast_validator``), and validating with either takes milliseconds: so
    fastjsonschema decides, unless ``jsonschema`` is imported already (a grading sandbox imports it once
    for all its processes; the two give the same verdict, tests/solutions/test_model_files.py), and
    ``jsonschema`` lists the errors of an invalid file."""
    if "jsonschema" not in sys.modules:
        try:
            _fast_validator()(data)
            return []
        except fastjsonschema.JsonSchemaException:
            pass
    return list(_full_validator().iter_errors(data))


SLOW_FORMAT_BACKENDS = ("rfc3987_syntax",)
"""Packages that ``import jsonschema`` imports for a format checker and that take long to import:
rfc3987_syntax (the "iri" formats, in recent jsonschema versions) builds its grammar, about a second."""


@functools.cache
def _full_validator():
    """``jsonschema``'s validator, which lists every error of an invalid file. The schema checks no "format",
    so jsonschema is imported with the SLOW_FORMAT_BACKENDS held back: it then leaves out their format
    checkers, as when they are not installed (which jsonschema allows); importing them later works as usual."""
    held = [name for name in SLOW_FORMAT_BACKENDS if name not in sys.modules]
    for name in held:
        sys.modules[name] = None  # `import name` raises ImportError while this is set
    try:
        import jsonschema
    finally:
        for name in held:
            if sys.modules.get(name, "") is None:
                del sys.modules[name]
    return jsonschema.Draft202012Validator(_schema())


def _key_path(path) -> str:
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "(top level)"


def _schema_message(error) -> str:
    """Turn a JSON Schema error into 'key.path: what is wrong (what to write)'."""
    where = _key_path(error.absolute_path)
    value = error.instance
    kind = error.validator
    if kind == "required":
        missing = error.message.split("'")[1]
        examples = error.schema.get("properties", {}).get(missing, {}).get("examples")
        example = examples[0] if examples else KEY_EXAMPLES.get(missing)
        hint = f" (write e.g. {missing}: {example})" if example is not None else ""
        section = next((p for p in reversed(error.absolute_path) if isinstance(p, str)), "")
        element = {"joints": "joint", "motors": "motor", "spring_dampers": "spring-damper", "forces": "load"}
        kind = f" a {value['type']} {element.get(section, 'element')} needs it" if "type" in value else ""
        return f"{_key_path([*error.absolute_path, missing])}: missing key '{missing}'{hint}{';' if kind else ''}{kind}"
    if kind == "additionalProperties":
        known = sorted(error.schema.get("properties", {}))
        unknown = [k for k in value if k not in known]
        close = difflib.get_close_matches(unknown[0], known, n=1)
        hint = f"did you mean '{close[0]}'?" if close else f"known keys: {', '.join(known)}"
        return f"{_key_path([*error.absolute_path, unknown[0]])}: unknown key '{unknown[0]}' ({hint})"
    if kind in ("enum", "const"):
        options = error.validator_value if kind == "enum" else [error.validator_value]
        close = difflib.get_close_matches(str(value), [str(o) for o in options], n=1)
        hint = f"did you mean '{close[0]}'? " if close else ""
        return f"{where}: unknown value {value!r} ({hint}one of: {', '.join(map(str, options))})"
    if kind == "type":
        return f"{where}: expected {error.validator_value}, got {value!r}"
    if kind in ("exclusiveMinimum", "minimum"):
        sign = ">" if kind == "exclusiveMinimum" else ">="
        return f"{where}: must be {sign} {error.validator_value}, got {value!r}"
    if kind in ("minItems", "maxItems"):
        return f"{where}: wrong number of entries in {value!r} ({error.message})"
    if kind == "oneOf":
        description = error.schema.get("description")
        return f"{where}: {value!r} is not valid here" + (f"; expected {description}" if description else "")
    return f"{where}: {error.message}"


IMPORTED = (".urdf", ".xml", ".mjcf")
"""Files of other codes that a model is imported from on the fly (``importers.py``): URDF and MJCF."""


def read_data(path: Path) -> tuple[dict, list[str]]:
    """A model file's content and, for a URDF or MJCF file (imported on the fly), what the import dropped."""
    if path.suffix.lower() in IMPORTED:
        from .importers import import_file

        imported = import_file(path)
        return imported.data, imported.dropped
    return read_text(path), []


def read_text(path: Path) -> dict:
    """A model file's content: YAML or JSON as written, or a URDF or MJCF file imported (``read_data``)."""
    if path.suffix.lower() in IMPORTED:
        return read_data(path)[0]
    try:
        text = path.read_text()
    except OSError as err:
        raise ModelError(f"{path}: cannot read the file ({err.strerror})") from None
    if not text.strip():
        raise ModelError(f"{path.name}: the file is empty; a model file starts with 'model:' (see course/models/)")
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(err, "problem", None) or str(err)
        raise ModelError(f"{path.name}: {where}malformed YAML ({problem}); check indentation and brackets") from None
    if data is None:
        raise ModelError(f"{path.name}: the file holds only comments; a model file starts with 'model:'")
    if not isinstance(data, dict):
        raise ModelError(f"{path.name}: expected a mapping with the key 'model', got {type(data).__name__}")
    return _words_read_as_booleans(data)


OFF_WORDS = ("stiffness",)
"""Simulation keys one of whose values is the word ``off``, which YAML 1.1 (PyYAML) reads as false."""


def _words_read_as_booleans(data: dict) -> dict:
    """``simulation: {stiffness: off}`` as written: YAML 1.1 reads an unquoted off as the boolean false, which the
    schema would refuse ("unknown value False"); the word is what the writer meant."""
    simulation = data.get("simulation")
    if isinstance(simulation, dict):
        for key in OFF_WORDS:
            if simulation.get(key) is False:
                simulation[key] = "off"
    return data


def load_model(source: str | Path | Mapping) -> Model:
    """Read and validate a model file, or a mapping with the same content.

    Parameters
    ----------
    source : path to a ``.yaml``/``.yml``/``.json`` file, or a mapping ``{"model": ..., "simulation": ...}``;
        a ``.urdf`` or MJCF ``.xml`` file is imported (``importers.import_file``), and the model's ``dropped``
        lists what the import left out

    Returns
    -------
    Model

    Raises
    ------
    ModelError
        With a message naming the file, the key path and the fix.
    """
    dropped: list[str] = []
    if isinstance(source, Mapping):
        data, label = dict(source), "<model>"
    else:
        path = Path(source)
        (data, dropped), label = read_data(path), path.name
    errors = schema_errors(data)
    if errors:
        import jsonschema

        best = jsonschema.exceptions.best_match(errors, key=_error_rank)
        raise ModelError(f"{label}: {_schema_message(best)}")
    model = _build(data, label)
    model.dropped = dropped
    return model


def _error_rank(error):
    # jsonschema's best_match keeps the error with the highest key. A misspelt key is reported as the unknown
    # key it is (with 'did you mean'), rather than as the required key it hides.
    return (-len(error.absolute_path), error.validator == "oneOf", error.validator == "additionalProperties")


def _vector(value, size: int, where: str, label: str) -> np.ndarray:
    if len(value) != size:
        raise ModelError(f"{label}: {where}: expected {size} numbers for a {size}D model, got {list(value)}")
    return np.asarray(value, dtype=float)


ANGLE_UNITS = {"deg": math.pi / 180.0, "rad": 1.0}
"""Factor from a file's angle unit to rad."""

ORTHONORMAL_TOLERANCE = 1e-6
"""Largest |A^T A - I| entry of a rotation matrix in a file (rounding of printed values stays below it)."""


def _unit(spec: dict, where: str, label: str, example: str) -> float:
    if "unit" not in spec:
        raise ModelError(
            f"{label}: {where}.unit: missing key 'unit': state the unit of the angles (write e.g. {example})"
        )
    return ANGLE_UNITS[spec["unit"]]


def planar_orientation(value, where: str, label: str) -> float:
    """A planar body's angle phi in rad: a number (rad) or {angle: a, unit: deg|rad}."""
    if isinstance(value, int | float):
        return float(value)
    if not isinstance(value, Mapping) or set(value) - {"angle", "unit"} or "angle" not in value:
        raise ModelError(
            f"{label}: {where}: a planar body takes one angle: a number in rad, or e.g. {{angle: 30, unit: deg}}"
        )
    return float(value["angle"]) * _unit(value, where, label, "{angle: 30, unit: deg}")


ORIENTATION_FORMS = {
    "euler_parameters": ("euler_parameters",),
    "rotation_matrix": ("rotation_matrix",),
    "euler_313": ("euler_313", "unit"),
    "euler_123": ("euler_123", "unit"),
    "axis_angle": ("axis", "angle", "unit"),
}
"""The mapping forms of a spatial orientation and the keys each takes."""


def spatial_orientation(value, where: str, label: str) -> np.ndarray:
    """Unit Euler parameters p of a spatial orientation in any form a file may give (eq. 8.10, 8.12, 8.13):

    [e0, e1, e2, e3] or {euler_parameters: [...]} (normalised); {rotation_matrix: A} (columns the body
    axes, orthonormal with det A = +1; p by Shepperd's method, eq. 8.13); {euler_313: [psi, theta, phi],
    unit} (A = Rz(psi) Rx(theta) Rz(phi), eq. 8.6); {euler_123: [phi, theta, psi], unit} (A = Rx(phi)
    Ry(theta) Rz(psi), eq. 8.7); {axis: u, angle: chi, unit} (p = (cos chi/2, u sin chi/2), eq. 8.10).
    """
    forms = "; or a mapping, e.g. {euler_313: [90, 30, 0], unit: deg} (see the schema's orientation)"
    if isinstance(value, int | float):
        raise ModelError(
            f"{label}: {where}: a spatial body takes 4 Euler parameters [e0, e1, e2, e3], "
            f"e.g. [1.0, 0.0, 0.0, 0.0] for the global orientation{forms}"
        )
    from ..rotations import euler_parameters, from_axis_angle, from_euler_123, from_euler_313  # spatial only

    if not isinstance(value, Mapping):
        value = {"euler_parameters": value}
    keys = set(value)
    form = next((name for name, needs in ORIENTATION_FORMS.items() if needs[0] in keys), None)
    if form is None or keys - set(ORIENTATION_FORMS[form]):
        given = ", ".join(sorted(keys))
        raise ModelError(
            f"{label}: {where}: cannot read an orientation from the keys {given}; give exactly one of "
            "euler_parameters, rotation_matrix, euler_313 + unit, euler_123 + unit, axis + angle + unit"
        )
    if form == "euler_parameters":
        p = np.asarray(value["euler_parameters"], dtype=float)
        size = float(np.linalg.norm(p))
        if size < 1e-12:
            raise ModelError(
                f"{label}: {where}: the Euler parameters are zero; write [cos(a/2), u sin(a/2)] "
                "for a rotation a about the unit axis u, e.g. [1.0, 0.0, 0.0, 0.0]"
            )
        return p / size
    if form == "rotation_matrix":
        A = np.asarray(value["rotation_matrix"], dtype=float)
        error = float(np.max(np.abs(A.T @ A - np.eye(3))))
        if error > ORTHONORMAL_TOLERANCE or np.linalg.det(A) <= 0.0:
            why = (
                f"A^T A differs from I by {error:.2g}" if error > ORTHONORMAL_TOLERANCE else "det A < 0 (a reflection)"
            )
            raise ModelError(
                f"{label}: {where}.rotation_matrix: not a rotation ({why}); give the body's x, y, z axes in global "
                "components as the columns: unit, mutually orthogonal, right-handed"
            )
        return euler_parameters(A)
    if form == "axis_angle":
        axis = np.asarray(value["axis"], dtype=float)
        if not np.any(axis):
            raise ModelError(f"{label}: {where}.axis: the axis is zero; give a direction, e.g. [0.0, 0.0, 1.0]")
        factor = _unit(value, where, label, "{axis: [0, 0, 1], angle: 90, unit: deg}")
        return from_axis_angle(axis, float(value["angle"]) * factor)
    example = "{" + form + ": [90, 30, 0], unit: deg}"
    factor = _unit(value, where, label, example)
    angles = [float(a) * factor for a in value[form]]
    return (from_euler_313 if form == "euler_313" else from_euler_123)(*angles)


def _mass_properties(b: dict, where: str, label: str, dim: int) -> tuple[float, Any, bool]:
    """(mass, inertia, has_mass): both given, or neither (a kinematic model)."""
    if "mass" not in b and "inertia" not in b:
        return 0.0, (0.0 if dim == 2 else np.zeros((3, 3))), False
    for key, example in (("mass", "1.0"), ("inertia", "0.01" if dim == 2 else "[0.01, 0.01, 0.02]")):
        if key not in b:
            raise ModelError(
                f"{label}: {where}.{key}: missing key '{key}' (write e.g. {key}: {example}); a kinematic model may "
                "leave out both mass and inertia"
            )
    inertia = b["inertia"]
    if dim == 2:
        if not isinstance(inertia, int | float):
            raise ModelError(
                f"{label}: {where}.inertia: a planar body takes one number (moment about its centre of mass)"
            )
        return float(b["mass"]), float(inertia), True
    if isinstance(inertia, int | float):
        raise ModelError(
            f"{label}: {where}.inertia: a spatial body takes 3 principal moments [Jxx, Jyy, Jzz] or a 3x3 matrix"
        )
    inertia = np.asarray(inertia, dtype=float)
    inertia = np.diag(inertia) if inertia.ndim == 1 else inertia
    scale = float(np.max(np.abs(inertia), initial=0.0))
    if not np.allclose(inertia, inertia.T) or np.any(np.linalg.eigvalsh(0.5 * (inertia + inertia.T)) < -1e-12 * scale):
        raise ModelError(
            f"{label}: {where}.inertia: must be symmetric and positive definite (or [0, 0, 0] for a point mass), "
            f"got {inertia.tolist()}"
        )
    return float(b["mass"]), inertia, True


def _body(b: dict, where: str, label: str, dim: int) -> Body:
    """A body as the solver takes it: the file's frame converted once to the centre-of-mass frame.

    With ``com`` c' (in the file's body frame, origin ``location`` r_o, orientation A), the centre of mass
    is r = r_o + A c' and its velocity r' = r_o' + omega x (A c') (planar: omega R90 A c', eq. 2.11);
    the body-frame axes stay those of the file.
    """
    mass, inertia, has_mass = _mass_properties(b, where, label, dim)
    if dim == 3:
        p = spatial_orientation(b.get("orientation", [1.0, 0.0, 0.0, 0.0]), f"{where}.orientation", label)
        angular_velocity = b.get("angular_velocity", [0.0] * 3)
        if isinstance(angular_velocity, int | float):
            raise ModelError(f"{label}: {where}.angular_velocity: a spatial body takes a 3-vector (global frame)")
        omega = _vector(angular_velocity, 3, f"{where}.angular_velocity", label)
        orientation: Any = p
        A = euler_rotation(p)  # not the students' rotation_matrix: it may be a stub when their package loads a model
    else:
        if not isinstance(b.get("angular_velocity", 0.0), int | float):
            raise ModelError(f"{label}: {where}.angular_velocity: a planar body takes one number in rad/s")
        orientation = planar_orientation(b.get("orientation", 0.0), f"{where}.orientation", label)
        omega = float(b.get("angular_velocity", 0.0))
        A = planar_rotation(orientation)
    location = _vector(b["location"], dim, f"{where}.location", label)
    velocity = _vector(b.get("velocity", [0.0] * dim), dim, f"{where}.velocity", label)
    com = None
    if "com" in b:
        com = _vector(b["com"], dim, f"{where}.com", label)
        offset = A @ com
        location = location + offset
        velocity = velocity + (np.cross(omega, offset) if dim == 3 else omega * np.array([-offset[1], offset[0]]))
    return Body(
        name=b["name"],
        mass=mass,
        inertia=inertia,
        location=location,
        orientation=orientation,
        velocity=velocity,
        angular_velocity=omega,
        com=com,
        has_mass=has_mass,
    )


BODY_POINT_KEYS = {
    "joints": (("point1", "body1"), ("point2", "body2")),
    "motors": (("point1", "body1"), ("point2", "body2")),
    "spring_dampers": (("point1", "body1"), ("point2", "body2")),
    "forces": (("point", "body"),),
}
"""The points of an element given with ``frame: body``, and the body whose frame each is in."""


def _shift_body_points(model: Model) -> None:
    """``frame: body`` points of bodies with ``com``: from the file's body frame to the centre-of-mass frame,
    s' = s'_file - c' (the axes are the same). A joint's single ``location`` becomes point1 and point2; a
    spatial joint's omitted point (the frame's origin, ``location``) becomes -c'."""
    coms = {b.name: b.com for b in model.bodies if b.com is not None}
    if not coms:
        return
    zero = [0.0] * model.dimension
    for section, keys in BODY_POINT_KEYS.items():
        for item in getattr(model, section):
            if item.get("frame") != "body" or not any(item.get(body) in coms for _, body in keys):
                continue
            if section == "joints" and "location" in item:
                location = item.pop("location")
                item.setdefault("point1", location)
                item.setdefault("point2", location)
            for key, body in keys:
                if item.get(body) not in coms:
                    continue
                if key not in item and not (section == "joints" and model.dimension == 3):
                    continue  # an omitted force point is the centre of mass; a planar joint needs its points
                point = np.asarray(item.get(key, zero), dtype=float) - coms[item[body]]
                item[key] = point.tolist()


def _build(data: dict, label: str) -> Model:
    spec = data["model"]
    dim = spec.get("dimension", 2)
    gravity = _vector(spec.get("gravity", [0.0] * dim), dim, "model.gravity", label)
    bodies = []
    for k, b in enumerate(spec["bodies"]):
        where = f"model.bodies[{k}]"
        if b["name"] == GROUND:
            raise ModelError(f"{label}: {where}.name: 'ground' is reserved for the fixed frame; rename the body")
        bodies.append(_body(b, where, label, dim))
    model = Model(
        name=spec.get("name", label.rsplit(".", 1)[0]),
        dimension=dim,
        gravity=gravity,
        bodies=bodies,
        joints=[dict(j) for j in spec.get("joints", [])],
        motors=[dict(m) for m in spec.get("motors", [])],
        spring_dampers=[dict(s) for s in spec.get("spring_dampers", [])],
        forces=[dict(f) for f in spec.get("forces", [])],
        simulation=dict(data.get("simulation", {})),
        source=label,
    )
    _check_references(model, label)
    _shift_body_points(model)
    return model


PLANAR_JOINTS = (
    "revolute",
    "prismatic",
    "rigid",
    "revolute_revolute",
    "revolute_prismatic",
    "gear",
    "rack_pinion",
    "cam",
)
SPATIAL_JOINTS = ("spherical", "revolute", "prismatic", "cylindrical", "universal", "rigid")
VECTOR_KEYS = ("location", "point1", "point2", "axis", "axis2", "point")


def _unique_names(items: list[dict], kind: str, section: str, label: str, taken: set[str]) -> None:
    for k, item in enumerate(items):
        item.setdefault("name", f"{kind}{k + 1}")
        if item["name"] in taken:
            raise ModelError(
                f"{label}: model.{section}[{k}].name: the name '{item['name']}' is used twice; names must be unique"
            )
        taken.add(item["name"])


def _check_body(name: str, where: str, model: Model, label: str) -> None:
    names = [b.name for b in model.bodies]
    if name != GROUND and name not in names:
        close = difflib.get_close_matches(name, names, n=1)
        hint = f"did you mean '{close[0]}'? " if close else ""
        raise ModelError(f"{label}: {where}: no body named '{name}' ({hint}bodies: {', '.join(names)}, or ground)")


def _check_references(model: Model, label: str) -> None:
    """Checks a schema cannot make: references between elements, vector sizes, unique names."""
    names = [b.name for b in model.bodies]
    if len(set(names)) != len(names):
        twice = next(n for n in names if names.count(n) > 1)
        raise ModelError(f"{label}: model.bodies: the body name '{twice}' is used twice; names must be unique")
    taken: set[str] = set()
    _unique_names(model.joints, "joint", "joints", label, taken)
    _unique_names(model.motors, "motor", "motors", label, taken)
    _unique_names(model.spring_dampers, "spring", "spring_dampers", label, taken)
    _unique_names(model.forces, "force", "forces", label, taken)
    sections = {
        "joints": model.joints,
        "motors": model.motors,
        "spring_dampers": model.spring_dampers,
        "forces": model.forces,
    }
    for section, items in sections.items():
        for k, item in enumerate(items):
            _check_element(model, section, f"model.{section}[{k}]", item, label)
    joints = {j["name"]: j for j in model.joints}
    for k, motor in enumerate(model.motors):
        _check_motor(model, f"model.motors[{k}]", motor, joints, label)


def _check_element(model: Model, section: str, where: str, item: dict, label: str) -> None:
    """One joint, motor, spring or force: the bodies it names, its vectors, a joint type of the model's dimension."""
    for key in ("body1", "body2", "body"):
        if key in item:
            _check_body(item[key], f"{where}.{key}", model, label)
    if item.get("body1") is not None and item.get("body1") == item.get("body2"):
        raise ModelError(f"{label}: {where}.body2: connects '{item['body1']}' to itself; name two different bodies")
    for key in VECTOR_KEYS:
        if key in item:
            vec = _vector(item[key], model.dimension, f"{where}.{key}", label)
            if key.startswith("axis") and not np.any(vec):
                example = "[1.0, 0.0]" if model.dimension == 2 else "[0.0, 0.0, 1.0]"
                raise ModelError(f"{label}: {where}.{key}: the axis is zero; give a direction, e.g. {example}")
    allowed = PLANAR_JOINTS if model.dimension == 2 else SPATIAL_JOINTS
    if section == "joints" and item["type"] not in allowed:
        kind = "a spatial" if model.dimension == 2 else "a planar"
        raise ModelError(
            f"{label}: {where}.type: '{item['type']}' is {kind} joint; "
            f"{'planar' if model.dimension == 2 else 'spatial'} joints are {', '.join(allowed)}"
        )


def _check_motor(model: Model, where: str, motor: dict, joints: dict, label: str) -> None:
    """A motor: the joint it drives exists and is of a kind it drives; a driven coordinate the body has."""
    if motor["type"] in ("angle", "linear"):
        wanted = ("revolute",) if motor["type"] == "angle" else ("prismatic",)
        if model.dimension == 3:  # a spatial cylindrical joint takes either motor
            wanted += ("cylindrical",)
        joint = joints.get(motor["joint"])
        if joint is None:
            close = difflib.get_close_matches(motor["joint"], list(joints), n=1)
            hint = f"did you mean '{close[0]}'? " if close else ""
            known = f"joints: {', '.join(joints)}" if joints else "the model has no joints"
            raise ModelError(f"{label}: {where}.joint: no joint named '{motor['joint']}' ({hint}{known})")
        if joint["type"] not in wanted:
            raise ModelError(
                f"{label}: {where}.joint: an {motor['type']} motor drives a {' or '.join(wanted)} joint, "
                f"but '{motor['joint']}' is {joint['type']}"
            )
    if motor["type"] == "coordinate":
        if motor["body"] == GROUND:
            raise ModelError(f"{label}: {where}.body: ground cannot be driven; name a moving body")
        if motor["coordinate"] == "z" and model.dimension == 2:
            raise ModelError(f"{label}: {where}.coordinate: a planar body has x, y and phi")
        if motor["coordinate"] == "phi" and model.dimension == 3:
            raise ModelError(
                f"{label}: {where}.coordinate: a spatial body's driven coordinate is x, y or z; "
                "drive a rotation with an angle motor on a revolute or cylindrical joint"
            )
