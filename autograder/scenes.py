"""Grading scenes: a model file plus the analysis to run (its ``simulation`` block).

Three kinds, named by where they come from:

- ``slider_crank``            public: ``autograder/scenes/slider_crank.yaml``, shipped with the course
                              and in every student kit (``mbdkit.scenes``);
- ``hidden/slider_crank_b``   hidden: a variant (dimensions, masses, initial state, driver law) in the
                              hidden folder, which never leaves the instructor's side
                              (``$MBD_HIDDEN_SCENES`` or ``autograder/scenes/hidden/``);
- ``student/slider_crank``    per student: the public scene scaled by factors drawn from a seed made of
                              the student's id, the homework and the instructor's secret
                              (``$MBD_GRADER_SECRET``), so copying a classmate's numbers does not pass.

A per-student variant scales lengths by s, masses by a and time by 1/b (drivers run b times faster),
so it is the same mechanism with other numbers: it assembles wherever the public scene does.
"""

from __future__ import annotations

import copy
import hashlib
import os
from pathlib import Path

import numpy as np

from mbdkit.scenes import HIDDEN, STUDENT, Scene, read_scene_file, scene_kind

SCENES = Path(__file__).resolve().parent / "scenes"


def hidden_dir() -> Path:
    """Where hidden scenes live: ``$MBD_HIDDEN_SCENES``, else ``autograder/scenes/hidden``."""
    return Path(os.environ.get("MBD_HIDDEN_SCENES") or SCENES / "hidden").resolve()


def grader_secret() -> str:
    """The instructor's secret mixed into per-student seeds (``$MBD_GRADER_SECRET``, else
    ``secret.txt`` in the hidden folder, else empty)."""
    secret = os.environ.get("MBD_GRADER_SECRET")
    if secret is None:
        path = hidden_dir() / "secret.txt"
        secret = path.read_text().strip() if path.is_file() else ""
    return secret


def scene_path(name: str) -> Path:
    """The model file of a public or hidden scene."""
    kind = scene_kind(name)
    if kind == HIDDEN:
        return hidden_dir() / f"{name.split('/', 1)[1]}.yaml"
    if kind == STUDENT:
        raise ValueError(f"{name}: a per-student scene has no file; it is made from {name.split('/', 1)[1]}")
    return SCENES / f"{name}.yaml"


def load_scene(name: str, student: str | None = None, homework: str = "") -> Scene:
    """The scene called ``name``; a ``student/...`` scene needs the student's id."""
    kind = scene_kind(name)
    if kind == STUDENT:
        if student is None:
            raise ValueError(f"{name}: a per-student scene needs the student's id")
        base = load_scene(name.split("/", 1)[1])
        seed = student_seed(student, homework, base.name)
        return Scene(name, variant(base.data, seed), STUDENT)
    path = scene_path(name)
    if not path.is_file():
        raise FileNotFoundError(f"no grading scene {name!r} ({path})")
    return Scene(name, read_scene_file(path), kind)


def student_seed(student: str, homework: str, scene: str) -> int:
    """A seed for a student's variant of a scene, from the id, the homework and the instructor's secret."""
    text = f"{grader_secret()}|{homework}|{scene}|{student}"
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "little")


def variant_factors(seed: int) -> dict[str, float]:
    """Length, mass and rate factors of a variant: s, a, b in [0.85, 1.2] x [0.8, 1.25] x [0.8, 1.25]."""
    rng = np.random.default_rng(seed)
    return {
        "length": float(rng.uniform(0.85, 1.2)),
        "mass": float(rng.uniform(0.8, 1.25)),
        "rate": float(rng.uniform(0.8, 1.25)),
    }


def _scale_function(spec, value: float, rate: float):
    """f(t) -> value * f(rate t), for the function specs of a model file."""
    if isinstance(spec, int | float):
        return spec * value
    spec = dict(spec)
    kind = spec.get("type")
    if kind == "constant":
        spec["value"] = spec["value"] * value
    elif kind == "polynomial":
        spec["coefficients"] = [c * value * rate**k for k, c in enumerate(spec["coefficients"])]
    elif kind == "harmonic":
        spec["amplitude"] = spec["amplitude"] * value
        spec["offset"] = spec.get("offset", 0.0) * value
        spec["frequency"] = spec["frequency"] * rate
    elif kind == "fourier":
        spec["a0"] = spec.get("a0", 0.0) * value
        spec["a"] = [c * value for c in spec.get("a", [])]
        if "b" in spec:
            spec["b"] = [c * value for c in spec["b"]]
        spec["frequency"] = spec.get("frequency", 1.0) * rate
    elif kind == "smooth_ramp":
        spec["start"] = spec.get("start", 0.0) / rate
        spec["end"] = spec["end"] / rate
        spec["start_value"] = spec.get("start_value", 0.0) * value
        spec["end_value"] = spec["end_value"] * value
    return spec


def _scaled(vector, factor: float):
    return [float(v) * factor for v in vector]


def _inertia(value, factor: float):
    if isinstance(value, int | float):
        return value * factor
    return (np.asarray(value, dtype=float) * factor).tolist()


POINT_KEYS = ("location", "point1", "point2", "point")
LENGTH_KEYS = ("length", "radius", "radius1", "radius2", "free_length")


def variant(data: dict, seed: int) -> dict:
    """The model file ``data`` with lengths times s, masses times a and drivers b times faster.

    Angles, axes and orientations stay; velocities scale by s b (angular by b); springs keep their
    natural frequency times b (k times a b^2, c times a b); applied forces scale by a s b^2.
    """
    factors = variant_factors(seed)
    s, a, b = factors["length"], factors["mass"], factors["rate"]
    data = copy.deepcopy(data)
    model = data["model"]
    for body in model["bodies"]:
        body["location"] = _scaled(body["location"], s)
        body["mass"] = body["mass"] * a
        body["inertia"] = _inertia(body["inertia"], a * s * s)
        if "velocity" in body:
            body["velocity"] = _scaled(body["velocity"], s * b)
        if "angular_velocity" in body:
            w = body["angular_velocity"]
            body["angular_velocity"] = w * b if isinstance(w, int | float) else _scaled(w, b)
    for section in ("joints", "motors", "spring_dampers", "forces"):
        for item in model.get(section, []):
            for key in POINT_KEYS:
                if key in item:
                    item[key] = _scaled(item[key], s)
            for key in LENGTH_KEYS:
                if key in item and isinstance(item[key], int | float):
                    item[key] = item[key] * s
    for motor in model.get("motors", []):
        angular = motor["type"] == "angle" or motor.get("coordinate") == "phi"
        motor["function"] = _scale_function(motor["function"], 1.0 if angular else s, b)
    for spring in model.get("spring_dampers", []):
        rotational = spring.get("type") == "RSDA"
        if "spring_coefficient" in spring:
            spring["spring_coefficient"] *= a * b * b * (s * s if rotational else 1.0)
        if "damping_coefficient" in spring:
            spring["damping_coefficient"] *= a * b * (s * s if rotational else 1.0)
        for key in ("actuator", "actuator_force", "function"):
            if key in spring:
                spring[key] = _scale_function(spring[key], a * s * b * b * (s if rotational else 1.0), b)
    for force in model.get("forces", []):
        factor = a * s * b * b * (s if force.get("type") == "torque" else 1.0)
        value = force.get("value")
        if isinstance(value, list):
            force["value"] = _scaled(value, factor)
        elif value is not None:
            force["value"] = _scale_function(value, factor, b)
    data.setdefault("model", model)["name"] = f"{model.get('name', 'scene')}-variant"
    return data
