"""Grading scenes: a model file plus the analysis to run (its ``simulation`` block).

Three kinds, named by where they come from:

- ``slider_crank``            public: ``autograder/scenes/slider_crank.yaml``, shipped with the course
                              and in every student kit (``mbdkit.scenes``);
- ``hidden/slider_crank_b``   hidden: a variant of the public scene ``slider_crank`` derived at grading time
                              from it and the course secret (``autograder.secret``): other dimensions,
                              masses, driver laws, springs, loads and (dynamic scenes) initial velocities,
                              drawn from a seed of the secret and the hidden scene's name; nothing of it is
                              stored in the repository. ``$MBD_HIDDEN_SCENES`` names an instructor's own
                              folder of hand-written hidden scenes (``NAME_b.yaml``) instead;
- ``student/slider_crank``    per student: the public scene scaled by factors drawn from a seed made of
                              the student's id, the homework and the course secret, so copying a
                              classmate's numbers does not pass.

A per-student variant scales lengths by s, masses by a and time by 1/b (drivers run b times faster),
so it is the same mechanism with other numbers: it assembles wherever the public scene does. A hidden
variant starts from such a scaling and then changes what leaves the assembled configuration at t = 0 as it
is: each body's mass and inertia on its own, each driver's law (its rate, amplitude, an added acceleration,
its phase; the driver's value at t = 0 kept), spring rates, damping, free lengths and angles, loads, and the
initial velocities along the constraints' null space. So it assembles where the public scene does, and small
enough factors keep the mechanism's character (tests/autograder/test_secret.py runs every hidden scene for
many secrets).
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import json
import math
import os
from pathlib import Path

import numpy as np

from mbdkit.scenes import HIDDEN, STUDENT, Scene, read_scene_file, scene_kind
from solutions.batch import write_atomic

from .secret import course_secret

SCENES = Path(__file__).resolve().parent / "scenes"
HIDDEN_ENV = "MBD_HIDDEN_SCENES"


def hidden_override() -> Path | None:
    """An instructor's own folder of hidden scenes (``$MBD_HIDDEN_SCENES``), or None: derived ones."""
    folder = os.environ.get(HIDDEN_ENV)
    return Path(folder).resolve() if folder else None


def hidden_base(name: str) -> str:
    """The public scene a hidden one is derived from: ``hidden/four_bar_b`` -> ``four_bar``."""
    stem = name.split("/", 1)[1]
    base, sep, _ = stem.rpartition("_")
    if not sep or not base:
        raise ValueError(f"{name}: a hidden scene is named hidden/PUBLIC_TAG (hidden/four_bar_b)")
    return base


def scene_path(name: str) -> Path:
    """The model file of a public scene (or of a hidden one in ``$MBD_HIDDEN_SCENES``)."""
    kind = scene_kind(name)
    if kind == HIDDEN:
        folder = hidden_override()
        if folder is None:
            raise ValueError(f"{name}: a hidden scene has no file; it is derived from {hidden_base(name)}")
        return folder / f"{name.split('/', 1)[1]}.yaml"
    if kind == STUDENT:
        raise ValueError(f"{name}: a per-student scene has no file; it is made from {name.split('/', 1)[1]}")
    return SCENES / f"{name}.yaml"


def load_scene(name: str, student: str | None = None, homework: str = "") -> Scene:
    """The scene called ``name``; a ``student/...`` scene needs the student's id; hidden and per-student
    scenes need the course secret (``SecretMissing`` without one)."""
    kind = scene_kind(name)
    if kind == STUDENT:
        if student is None:
            raise ValueError(f"{name}: a per-student scene needs the student's id")
        base = load_scene(name.split("/", 1)[1])
        seed = student_seed(student, homework, base.name)
        return Scene(name, variant(base.data, seed), STUDENT)
    if kind == HIDDEN and hidden_override() is None:
        return derived_hidden(name)
    path = scene_path(name)
    if not path.is_file():
        raise FileNotFoundError(f"no grading scene {name!r} ({path})")
    return Scene(name, read_scene_file(path), kind)


def course_cache() -> Path:
    """The grader's cache, outside the repository: ``$XDG_CACHE_HOME/mbd-course`` (default ``~/.cache``)."""
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base, "mbd-course").resolve()


_SOURCE: dict[str, str] = {}


def source_fingerprint(package: str) -> str:
    """A hash of a package's Python source (``solutions``, ``autograder``), read once per process."""
    if package not in _SOURCE:
        root = Path(__file__).resolve().parents[1] / package
        digest = hashlib.sha256()
        for path in sorted(root.rglob("*.py")):
            if "__pycache__" not in path.parts:
                digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
        _SOURCE[package] = digest.hexdigest()
    return _SOURCE[package]


_DERIVED: dict[tuple[str, int], tuple[dict, str]] = {}


def derived_hidden(name: str) -> Scene:
    """A hidden scene derived from the secret: made once per secret, public scene and source of the derivation
    (this package and the reference package), kept in ``course_cache()/scenes`` so that grading workers read
    it instead of making it again (a planar kinematic one runs its span, some 0.1 s); then, with its
    fingerprint, held for the rest of the process (the public scene files do not change while grading)."""
    seed = hidden_seed(name)
    if (name, seed) not in _DERIVED:
        base = load_scene(hidden_base(name))
        sources = f"{source_fingerprint('autograder')}|{source_fingerprint('solutions')}"
        text = f"{name}|{seed}|{base.fingerprint()}|{sources}"
        path = course_cache() / "scenes" / f"{hashlib.sha256(text.encode()).hexdigest()[:40]}.json"
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError):
            data = hidden_variant(base.data, seed, name)
            with contextlib.suppress(OSError):  # an unwritable cache costs the time, not the scene
                write_atomic(path, json.dumps(data))
        _DERIVED[name, seed] = (data, Scene(name, data, HIDDEN).fingerprint())
    data, fingerprint = _DERIVED[name, seed]
    scene = Scene(name, copy.deepcopy(data), HIDDEN)
    scene._fingerprint = fingerprint
    return scene


def hidden_seed(name: str) -> int:
    """The seed of a hidden scene: from the course secret and the scene's name."""
    text = f"hidden|{course_secret()}|{name}"
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "little")


def student_seed(student: str, homework: str, scene: str) -> int:
    """A seed for a student's variant of a scene, from the id, the homework and the course secret."""
    text = f"{course_secret()}|{homework}|{scene}|{student}"
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


def _scaled_profile(profile: dict, s: float) -> dict:
    """A cam profile (pitch curve or support function) of a cam s times larger."""
    profile = dict(profile)
    for key in ("radius", "eccentricity", "a0"):
        if isinstance(profile.get(key), int | float):
            profile[key] = profile[key] * s
    for key in ("a", "b"):
        if isinstance(profile.get(key), list):
            profile[key] = _scaled(profile[key], s)
    return profile


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
            if isinstance(item.get("profile"), dict):  # a cam's profile: lengths of its curve
                item["profile"] = _scaled_profile(item["profile"], s)
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
        if isinstance(value, list):  # components: numbers or laws
            force["value"] = [_scale_function(v, factor, b) for v in value]
        elif value is not None:
            force["value"] = _scale_function(value, factor, b)
    data.setdefault("model", model)["name"] = f"{model.get('name', 'scene')}-variant"
    return data


# -- hidden variants -----------------------------------------------------------------------------------------
HIDDEN_MASS = (0.7, 1.4)
"""Range of each body's own mass factor in a hidden variant (its inertia: that times 0.85 .. 1.15)."""
HIDDEN_LAW = (0.8, 1.2)
"""Range of each driver's amplitude factor (the motion's size about its value at t = 0)."""
HIDDEN_ACCELERATION = (-0.25, 0.35)
"""A polynomial driver gains a t^2 term that changes its rate at the end of the run by 2 x this fraction."""
HIDDEN_SPIN = (0.5, 1.5)
"""Largest change of a body's angular velocity (rad/s), or of its speed over the mechanism's size, in a dynamic
hidden variant's initial state."""


HIDDEN_STRETCH = 0.12
"""A planar hidden variant is stretched by 1 + HIDDEN_STRETCH x U(-1, 1) along x and, on its own, along y:
other proportions (a four-bar's links change length each by its own factor). Where that loses the
mechanism's character (a kinematic run meets a singular position: a Grashof four-bar that no longer turns),
half of it is tried, then none."""


def hidden_variant(data: dict, seed: int, name: str = "hidden") -> dict:
    """A hidden variant of the model file ``data`` (see the module's docstring), the same for one seed."""
    rng = np.random.default_rng(seed)
    data = variant(data, int(rng.integers(2**62)))
    model = data["model"]
    simulation = data.get("simulation", {})
    end_time = float(simulation.get("end_time", 1.0))
    _vary_masses(model, rng)
    _vary_springs(model, rng)
    _vary_loads(model, rng)
    laws = [_vary_law(m["function"], rng, end_time) if "function" in m else None for m in model.get("motors", [])]
    stretches = [1.0 + rng.uniform(-1.0, 1.0, 2) * HIDDEN_STRETCH * share for share in (1.0, 0.5)]
    kinematic = simulation.get("analysis", "kinematic") == "kinematic"
    candidates = [(stretch, laws) for stretch in (*stretches, None)] + [(None, None)]  # the last: the public laws
    for stretch, new_laws in candidates:
        candidate = copy.deepcopy(data)
        for motor, law in zip(candidate["model"].get("motors", []), new_laws or [], strict=False):
            if law is not None:
                motor["function"] = law
        if stretch is not None and not _stretch(candidate["model"], *stretch):
            continue  # a model this stretch does not apply to (gears, cams, body-frame points)
        if not kinematic or _runs_through(candidate):
            break
    if not kinematic:
        _vary_velocities(candidate, rng)
    candidate["model"]["name"] = f"{name.split('/', 1)[-1].replace('_', '-')}-hidden"
    return _plain(candidate)


STRETCHED_OUT = ("gear", "rack_pinion", "cam")
"""Joints whose circles and profiles an unequal stretch would turn into other curves."""


def _stretch(model: dict, sx: float, sy: float) -> bool:
    """Stretch a planar model by sx along x and sy along y at its configuration in the file: every global
    point, the axes, the drivers of coordinates, sliders and distances and the springs' free lengths follow,
    so the file's configuration stays assembled. False (nothing changed) for a model it does not apply to."""
    items = [i for section in ("joints", "motors", "spring_dampers", "forces") for i in model.get(section, [])]
    if (
        model.get("dimension", 2) != 2
        or any(j.get("type") in STRETCHED_OUT for j in model.get("joints", []))
        or any(i.get("frame") == "body" for i in items)
        or any("com" in b for b in model["bodies"])
    ):
        return False
    stretch = np.array([sx, sy])

    def mapped(point) -> list[float]:
        return [float(v) for v in stretch * np.asarray(point, dtype=float)]

    def distance_ratio(item) -> float:
        d = np.asarray(item["point1"], dtype=float) - np.asarray(item["point2"], dtype=float)
        return float(np.linalg.norm(stretch * d) / np.linalg.norm(d)) if np.linalg.norm(d) > 0 else 1.0

    joints = {j["name"]: j for j in model.get("joints", [])}
    axes = {name: np.asarray(j["axis"], dtype=float) for name, j in joints.items() if "axis" in j}
    for motor in model.get("motors", []):  # the drivers' laws first, from the file's own points and axes
        kind, factor = motor.get("type"), 1.0
        if kind == "coordinate" and motor.get("coordinate") in ("x", "y"):
            factor = sx if motor["coordinate"] == "x" else sy
        elif kind == "linear" and motor.get("joint") in axes:
            u = axes[motor["joint"]] / np.linalg.norm(axes[motor["joint"]])
            factor = float(np.linalg.norm(stretch * u))
        elif kind == "distance" and "point1" in motor:
            factor = distance_ratio(motor)
        if factor != 1.0:
            motor["function"] = _scale_function(motor["function"], factor, 1.0)
    for spring in model.get("spring_dampers", []):
        if isinstance(spring.get("free_length"), int | float) and "point1" in spring:
            spring["free_length"] *= distance_ratio(spring)
    for item in items:
        if isinstance(item.get("length"), int | float) and "point1" in item:
            item["length"] *= distance_ratio(item)
        if "axis" in item:
            axis = stretch * np.asarray(item["axis"], dtype=float)
            item["axis"] = [float(v) for v in axis / np.linalg.norm(axis)]
        for key in POINT_KEYS:
            if key in item:
                item[key] = mapped(item[key])
    for body in model["bodies"]:
        body["location"] = mapped(body["location"])
        if "velocity" in body:  # made consistent again by _vary_velocities (dynamic scenes)
            body["velocity"] = mapped(body["velocity"])
    return True


def _runs_through(data: dict) -> bool:
    """Whether the reference package's kinematic analysis of the scene runs its whole span (no singular
    position, no lost assembly)."""
    from solutions.assembly import build_system
    from solutions.diagnostics import AnalysisError
    from solutions.io.model import ModelError, load_model
    from solutions.kinematics import kinematic_analysis

    simulation = data.get("simulation", {})
    try:
        system, q0, _ = build_system(load_model(data))
        kinematic_analysis(system, q0, float(simulation.get("end_time", 1.0)), int(simulation.get("output_steps", 100)))
    except (AnalysisError, ModelError, ValueError, np.linalg.LinAlgError):
        return False
    return True


def _plain(value):
    """The model file with plain Python numbers (a numpy scalar has no YAML form)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.floating | np.integer):
        return value.item()
    return value


def _vary_masses(model: dict, rng: np.random.Generator) -> None:
    """Each body's mass by its own factor, its inertia by that times a change of its radius of gyration."""
    for body in model["bodies"]:
        factor = float(rng.uniform(*HIDDEN_MASS))
        gyration = float(rng.uniform(0.85, 1.15))
        if isinstance(body.get("mass"), int | float):
            body["mass"] = body["mass"] * factor
        if "inertia" in body:
            body["inertia"] = _inertia(body["inertia"], factor * gyration)


def _value_at_zero(spec) -> float | None:
    """f(0) of a function spec (None for one that is not varied)."""
    if isinstance(spec, int | float):
        return float(spec)
    kind = spec.get("type")
    if kind == "polynomial":
        return float(spec["coefficients"][0]) if spec["coefficients"] else 0.0
    if kind == "harmonic":
        return float(spec.get("offset", 0.0) + spec["amplitude"] * math.sin(spec.get("phase", 0.0)))
    if kind == "fourier":
        return float(spec.get("a0", 0.0) + sum(spec.get("a", [])))
    return None


def _vary_law(spec, rng: np.random.Generator, end_time: float):
    """Another law with the same value at t = 0: amplitude times m, a polynomial's added t^2 term, a
    harmonic's or Fourier series' frequency and phase."""
    m = float(rng.uniform(*HIDDEN_LAW))
    speed = float(rng.uniform(0.85, 1.15))
    if isinstance(spec, int | float) or spec.get("type") not in ("polynomial", "harmonic", "fourier", "smooth_ramp"):
        return spec
    spec = copy.deepcopy(spec)
    kind = spec["type"]
    if kind == "polynomial":
        c = [float(v) for v in spec["coefficients"]]
        c = c[:1] + [v * m for v in c[1:]]
        if len(c) >= 2 and c[1] != 0.0:
            c += [0.0] * (3 - len(c))
            c[2] += float(rng.uniform(*HIDDEN_ACCELERATION)) * c[1] / end_time
        spec["coefficients"] = c
    elif kind == "harmonic":
        start = _value_at_zero(spec)
        spec["amplitude"] = spec["amplitude"] * m
        spec["frequency"] = spec["frequency"] * speed
        spec["phase"] = spec.get("phase", 0.0) + float(rng.uniform(-0.4, 0.4))
        spec["offset"] = start - spec["amplitude"] * math.sin(spec["phase"])
    elif kind == "fourier":
        start = _value_at_zero(spec)
        spec["a"] = _scaled(spec.get("a", []), m)
        spec["b"] = _scaled(spec.get("b", []), m)
        spec["frequency"] = spec.get("frequency", 1.0) * speed
        spec["a0"] = start - sum(spec["a"])
    else:  # smooth_ramp
        start = spec.get("start_value", 0.0)
        spec["end_value"] = start + m * (spec["end_value"] - start)
        spec["end"] = spec["end"] / speed
    return spec


def _vary_springs(model: dict, rng: np.random.Generator) -> None:
    """Spring rates, damping, free lengths and angles, actuator laws: each by its own draw."""
    for spring in model.get("spring_dampers", []):
        if "spring_coefficient" in spring:
            spring["spring_coefficient"] *= float(rng.uniform(0.7, 1.4))
        if "damping_coefficient" in spring:
            spring["damping_coefficient"] *= float(rng.uniform(0.6, 1.5))
        if isinstance(spring.get("free_length"), int | float):
            spring["free_length"] *= float(rng.uniform(0.9, 1.1))
        if spring.get("type") == "RSDA":
            spring["free_angle"] = spring.get("free_angle", 0.0) + float(rng.uniform(-0.3, 0.3))
        for key in ("actuator", "actuator_force", "function"):
            if key in spring:
                spring[key] = _vary_load(spring[key], rng)


def _vary_load(spec, rng: np.random.Generator):
    """A load's value (a number or a law) times 0.7 .. 1.3, a law's frequency and phase changed."""
    factor = float(rng.uniform(0.7, 1.3))
    if isinstance(spec, int | float):
        return spec * factor
    spec = _scale_function(spec, factor, float(rng.uniform(0.85, 1.15)))
    if spec.get("type") == "harmonic":
        spec["phase"] = spec.get("phase", 0.0) + float(rng.uniform(-1.0, 1.0))
    return spec


def _vary_loads(model: dict, rng: np.random.Generator) -> None:
    for force in model.get("forces", []):
        value = force.get("value")
        if isinstance(value, list):
            force["value"] = [_vary_load(v, rng) for v in value]
        elif value is not None:
            force["value"] = _vary_load(value, rng)


def _reach(data: dict) -> float:
    """The mechanism's size: the largest distance between two of its bodies' locations and global points (1 m
    if they all coincide)."""
    model = data["model"]
    points = [body["location"] for body in model["bodies"]]
    for section in ("joints", "motors", "spring_dampers", "forces"):
        for item in model.get(section, []):
            if item.get("frame") != "body":
                points += [item[key] for key in POINT_KEYS if isinstance(item.get(key), list)]
    points = np.array([[*map(float, p), 0.0][:3] for p in points])  # planar points as z = 0
    reach = max(float(np.linalg.norm(a - b)) for a in points for b in points)
    return reach if reach > 1e-9 else 1.0


def _vary_velocities(data: dict, rng: np.random.Generator) -> None:
    """Initial velocities that meet the varied drivers' rates at t = 0 (the least change of the file's), plus a
    motion the constraints allow (N z, N spanning the null space of Psi_q at the file's configuration, z
    random) scaled so that the largest change of a body's angular velocity, or of its speed over the mechanism's
    size (``_reach``: a slider's sliding counts as a spin), is HIDDEN_SPIN; written back as the bodies'
    ``velocity`` and ``angular_velocity``."""
    from scipy.linalg import null_space

    from solutions.assembly import build_system
    from solutions.io.model import load_model
    from solutions.rotations import angular_velocity

    model = load_model(data)
    system, q0, qd0 = build_system(model)
    jacobian = system.jacobian(q0, 0.0)
    # the drivers' new rates at t = 0: the smallest change of the file's velocities that meets them
    qd0 = qd0 - np.linalg.pinv(jacobian) @ (jacobian @ qd0 + system.psi_t(q0, 0.0))
    basis = null_space(jacobian)
    dqd = basis @ rng.standard_normal(basis.shape[1]) if basis.shape[1] else np.zeros_like(qd0)
    spatial = model.dimension == 3
    size = 7 if spatial else 3

    def spins(qd: np.ndarray) -> list[np.ndarray]:
        out = []
        for i in range(len(model.bodies)):
            block = qd[size * i : size * (i + 1)]
            out.append(angular_velocity(q0[size * i + 3 : size * i + 7], block[3:]) if spatial else block[2:3])
        return out

    def speeds(qd: np.ndarray) -> list[float]:  # |v| / size: a slider's speed counts as the spin it would be
        return [float(np.linalg.norm(qd[size * i : size * i + dimension])) / reach for i in range(len(model.bodies))]

    dimension, reach = (3 if spatial else 2), _reach(data)
    largest = max(max(float(np.linalg.norm(w)) for w in spins(dqd)), max(speeds(dqd)))
    qd = qd0 + (dqd * float(rng.uniform(*HIDDEN_SPIN)) / largest if largest > 1e-9 else 0.0)
    for i, (body, spec, omega) in enumerate(zip(model.bodies, data["model"]["bodies"], spins(qd), strict=True)):
        velocity = qd[size * i : size * i + (3 if spatial else 2)]
        if body.com is not None:  # the file gives the velocity of the frame's origin, not of the centre
            offset = body.location - np.asarray(spec["location"], dtype=float)
            turn = np.cross(omega, offset) if spatial else omega[0] * np.array([-offset[1], offset[0]])
            velocity = velocity - turn
        spec["velocity"] = [float(v) for v in velocity]
        spec["angular_velocity"] = [float(w) for w in omega] if spatial else float(omega[0])
