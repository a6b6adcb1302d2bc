# Generated from solutions/io/model.py by `make modules` (every homework stubbed): do not edit by hand.
"""Data input: read a model file (YAML or JSON), validate it, and return a ``Model``.

Validation has two layers. The JSON Schema shipped beside this file (``schema.json``) checks keys,
types and value ranges; ``_check_references`` then checks what a schema cannot: names that refer to
other elements, vector sizes against the model's dimension, duplicate names. Every problem becomes a
``ModelError`` whose text names the file, the key path and what to write instead, e.g.::

    four_bar.yaml: model.joints[2].body2: no body named 'couplr' (bodies: crank, coupler, rocker)
"""

from __future__ import annotations

import difflib
import functools
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import fastjsonschema
import numpy as np
import yaml

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


@functools.cache
def _schema() -> dict:
    text = resources.files(__package__).joinpath("schema.json").read_text()
    return json.loads(text)


@functools.cache
def _fast_validator():
    """The schema compiled once (per process) by fastjsonschema: it decides whether a file is valid.
    ``jsonschema``, whose import takes seconds (it imports every format checker's backend), is imported
    only to explain an invalid file."""
    return fastjsonschema.compile(_schema())


def schema_errors(data: dict) -> list:
    """The JSON Schema errors of a model file's content ([] when it is valid)."""
    try:
        _fast_validator()(data)
        return []
    except fastjsonschema.JsonSchemaException:
        import jsonschema  # the full list of errors, for the best message

        return list(jsonschema.Draft202012Validator(_schema()).iter_errors(data))


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


def _read_text(path: Path) -> dict:
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
    return data


def load_model(source: str | Path | Mapping) -> Model:
    """Read and validate a model file, or a mapping with the same content.

    Parameters
    ----------
    source : path to a ``.yaml``/``.yml``/``.json`` file, or a mapping ``{"model": ..., "simulation": ...}``

    Returns
    -------
    Model

    Raises
    ------
    ModelError
        With a message naming the file, the key path and the fix.
    """
    if isinstance(source, Mapping):
        data, label = dict(source), "<model>"
    else:
        path = Path(source)
        data, label = _read_text(path), path.name
    errors = schema_errors(data)
    if errors:
        import jsonschema

        best = jsonschema.exceptions.best_match(errors, key=_error_rank)
        raise ModelError(f"{label}: {_schema_message(best)}")
    return _build(data, label)


def _error_rank(error):
    # jsonschema's best_match keeps the error with the highest key. A misspelt key is reported as the unknown
    # key it is (with 'did you mean'), rather than as the required key it hides.
    return (-len(error.absolute_path), error.validator == "oneOf", error.validator == "additionalProperties")


def _vector(value, size: int, where: str, label: str) -> np.ndarray:
    if len(value) != size:
        raise ModelError(f"{label}: {where}: expected {size} numbers for a {size}D model, got {list(value)}")
    return np.asarray(value, dtype=float)


def _spatial_body(b: dict, where: str, label: str) -> Body:
    """A spatial body: inertia about the centre of mass in the body frame (3 principal moments or a 3x3
    matrix), orientation as Euler parameters [e0, e1, e2, e3] (normalised here), angular velocity global."""
    inertia = b["inertia"]
    if isinstance(inertia, int | float):
        raise ModelError(
            f"{label}: {where}.inertia: a spatial body takes 3 principal moments [Jxx, Jyy, Jzz] or a 3x3 matrix"
        )
    inertia = np.asarray(inertia, dtype=float)
    inertia = np.diag(inertia) if inertia.ndim == 1 else inertia
    if not np.allclose(inertia, inertia.T) or np.any(np.linalg.eigvalsh(0.5 * (inertia + inertia.T)) <= 0):
        raise ModelError(f"{label}: {where}.inertia: must be symmetric and positive definite, got {inertia.tolist()}")
    orientation = b.get("orientation", [1.0, 0.0, 0.0, 0.0])
    if isinstance(orientation, int | float):
        raise ModelError(
            f"{label}: {where}.orientation: a spatial body takes 4 Euler parameters [e0, e1, e2, e3], "
            "e.g. [1.0, 0.0, 0.0, 0.0] for the global orientation"
        )
    orientation = np.asarray(orientation, dtype=float)
    size = float(np.linalg.norm(orientation))
    if size < 1e-12:
        raise ModelError(
            f"{label}: {where}.orientation: the Euler parameters are zero; write [cos(a/2), u sin(a/2)] "
            "for a rotation a about the unit axis u, e.g. [1.0, 0.0, 0.0, 0.0]"
        )
    angular_velocity = b.get("angular_velocity", [0.0] * 3)
    if isinstance(angular_velocity, int | float):
        raise ModelError(f"{label}: {where}.angular_velocity: a spatial body takes a 3-vector (global frame)")
    return Body(
        name=b["name"],
        mass=float(b["mass"]),
        inertia=inertia,
        location=_vector(b["location"], 3, f"{where}.location", label),
        orientation=orientation / size,
        velocity=_vector(b.get("velocity", [0.0] * 3), 3, f"{where}.velocity", label),
        angular_velocity=_vector(angular_velocity, 3, f"{where}.angular_velocity", label),
    )


def _build(data: dict, label: str) -> Model:
    spec = data["model"]
    dim = spec.get("dimension", 2)
    gravity = _vector(spec.get("gravity", [0.0] * dim), dim, "model.gravity", label)
    bodies = []
    for k, b in enumerate(spec["bodies"]):
        where = f"model.bodies[{k}]"
        if b["name"] == GROUND:
            raise ModelError(f"{label}: {where}.name: 'ground' is reserved for the fixed frame; rename the body")
        if dim == 3:
            bodies.append(_spatial_body(b, where, label))
            continue
        if not isinstance(b["inertia"], int | float):
            raise ModelError(
                f"{label}: {where}.inertia: a planar body takes one number (moment about its centre of mass)"
            )
        if not isinstance(b.get("orientation", 0.0), int | float):
            raise ModelError(f"{label}: {where}.orientation: a planar body takes one angle in rad")
        bodies.append(
            Body(
                name=b["name"],
                mass=float(b["mass"]),
                inertia=float(b["inertia"]),
                location=_vector(b["location"], dim, f"{where}.location", label),
                orientation=float(b.get("orientation", 0.0)),
                velocity=_vector(b.get("velocity", [0.0] * dim), dim, f"{where}.velocity", label),
                angular_velocity=float(b.get("angular_velocity", 0.0)),
            )
        )
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
            where = f"model.{section}[{k}]"
            for key in ("body1", "body2", "body"):
                if key in item:
                    _check_body(item[key], f"{where}.{key}", model, label)
            if item.get("body1") is not None and item.get("body1") == item.get("body2"):
                raise ModelError(
                    f"{label}: {where}.body2: connects '{item['body1']}' to itself; name two different bodies"
                )
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
    joints = {j["name"]: j for j in model.joints}
    for k, motor in enumerate(model.motors):
        where = f"model.motors[{k}]"
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
