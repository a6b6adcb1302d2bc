# Generated from solutions/spatial/build.py by `make modules` (every homework stubbed): do not edit by hand.
"""From a validated spatial ``Model`` to constraint elements and initial coordinates.

Points and axes in a model file are global, in the configuration the file gives, unless the element
says ``frame: body`` (then ``point1``/``point2`` are in the frames of body1/body2, ``axis`` in the frame
of body1 and ``axis2`` in that of body2). As in Project Chrono, a joint is placed by one definition
frame in that configuration: its origin at ``location`` and its z axis h along ``axis``; x and y axes
f and g complete it (``joint_axes``). The frame is then fixed in each of the two bodies,

    s' = A_0^T (P - r_0),    f' = A_0^T f,  g' = A_0^T g,  h' = A_0^T h       (course notes, eq. 9.20)

with r_0, A_0 the body's position and orientation in the file, so the two copies coincide there and
every joint equation holds in the file's configuration if it is consistent. Motors measure their
rotation or translation from the file's configuration, as Chrono's motors do. Every body adds its
Euler-parameter normalization constraint p^T p - 1 = 0.
"""

from __future__ import annotations

import numpy as np

from ..functions import function_from_spec
from ..io.model import Model, ModelError
from ..rotations import euler_parameter_rates, rotation_matrix
from .joints import (
    JOINTS,
    CoordinateDriver,
    DistanceDriver,
    EulerNormalization,
    Joint,
    JointFrame,
    RotationDriver,
    SpatialElement,
    TranslationDriver,
)

COORDINATE_INDEX = {"x": 0, "y": 1, "z": 2}
AXIS_REQUIRED = ("revolute", "cylindrical", "prismatic", "universal")


def initial_coordinates(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """q0 = (r, p) and q0' = (r', p') body after body, p' = 1/2 G(p)^T omega from the file's global omega."""
    q = np.concatenate([[*b.location, *b.orientation] for b in model.bodies])
    qd = np.concatenate(
        [[*b.velocity, *euler_parameter_rates(b.orientation, b.angular_velocity)] for b in model.bodies]
    )
    return q.astype(float), qd.astype(float)


def joint_axes(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(f, g, h): a right-handed unit frame with h along ``axis``.

    f is the global axis least aligned with h, made normal to h; g = h x f. For h = z this gives the
    global frame itself.
    """
    h = np.asarray(axis, dtype=float)
    h = h / np.linalg.norm(h)
    k = int(np.argmin(np.abs(h)))
    f = np.eye(3)[k] - h[k] * h
    f /= np.linalg.norm(f)
    return f, np.cross(h, f), h


class FileFrames:
    """Body frames of the file's configuration, to express global points and axes in a body's frame."""

    def __init__(self, model: Model):
        self.r = [np.zeros(3)] + [np.asarray(b.location, dtype=float) for b in model.bodies]
        self.A = [np.eye(3)] + [rotation_matrix(b.orientation) for b in model.bodies]
        self.p = [np.asarray(b.orientation, dtype=float) for b in model.bodies]

    def origin(self, body: int) -> np.ndarray:
        return self.r[body + 1].copy()

    def q(self, body: int) -> np.ndarray:
        """The body's coordinates (r, p) in the file (ground: (0, 0, 0, 1, 0, 0, 0))."""
        p = np.array([1.0, 0.0, 0.0, 0.0]) if body < 0 else self.p[body]
        return np.concatenate([self.r[body + 1], p])

    def global_point(self, body: int, point, frame: str) -> np.ndarray:
        point = np.asarray(point, dtype=float)
        return self.r[body + 1] + self.A[body + 1] @ point if frame == "body" else point

    def global_axis(self, body: int, axis, frame: str) -> np.ndarray:
        axis = np.asarray(axis, dtype=float)
        axis = self.A[body + 1] @ axis if frame == "body" else axis
        return axis / np.linalg.norm(axis)

    def local_point(self, body: int, point: np.ndarray) -> np.ndarray:
        return self.A[body + 1].T @ (point - self.r[body + 1])

    def local_axis(self, body: int, axis: np.ndarray) -> np.ndarray:
        return self.A[body + 1].T @ axis

    def joint_frame(self, body: int, point: np.ndarray, f, g, h) -> JointFrame:
        """The definition frame (P; f, g, h), given globally, as fixed in ``body``."""
        local = self.local_axis
        return JointFrame(self.local_point(body, point), local(body, f), local(body, g), local(body, h))


def joint_frames(spec: dict, where: str, model: Model, frames: FileFrames) -> tuple[JointFrame, JointFrame]:
    """The joint's definition frame as fixed in body1 and in body2 (eq. 9.20)."""
    kind, frame = spec["type"], spec.get("frame", "global")
    i, j = model.body_index(spec["body1"]), model.body_index(spec["body2"])
    default = frames.origin(j)
    if frame == "body":
        p1 = frames.global_point(i, spec.get("point1", [0.0, 0.0, 0.0]), "body")
        p2 = frames.global_point(j, spec.get("point2", [0.0, 0.0, 0.0]), "body")
    else:
        p1 = np.asarray(spec.get("point1", spec.get("location", default)), dtype=float)
        p2 = np.asarray(spec.get("point2", spec.get("location", default)), dtype=float)
    if kind in AXIS_REQUIRED and "axis" not in spec:
        what = "the axis of body1's cross arm" if kind == "universal" else "the joint axis"
        raise ModelError(f"{model.source}: {where}: missing key 'axis' ({what}, e.g. axis: [0.0, 0.0, 1.0])")
    f, g, h = joint_axes(frames.global_axis(i, spec.get("axis", [0.0, 0.0, 1.0]), frame))
    frame_i = frames.joint_frame(i, p1, f, g, h)
    if kind != "universal":
        return frame_i, frames.joint_frame(j, p2, f, g, h)
    if "axis2" not in spec:
        raise ModelError(
            f"{model.source}: {where}: missing key 'axis2' (the axis of body2's cross arm, normal to 'axis')"
        )
    h2 = frames.global_axis(j, spec["axis2"], frame)
    if abs(h2 @ h) > 1e-6:
        raise ModelError(
            f"{model.source}: {where}.axis2: the two cross arms of a universal joint must be perpendicular "
            f"(axis . axis2 = {h2 @ h:.3g}); give axis2 normal to axis"
        )
    return frame_i, frames.joint_frame(j, p2, h, np.cross(h2, h), h2)


def joint_element(spec: dict, where: str, model: Model, frames: FileFrames) -> Joint:
    """The constraint element of one joint of the file."""
    i, j = model.body_index(spec["body1"]), model.body_index(spec["body2"])
    frame_i, frame_j = joint_frames(spec, where, model, frames)
    return JOINTS[spec["type"]](spec["name"], i, j, frame_i, frame_j)


def motor_element(spec: dict, where: str, model: Model, frames: FileFrames, joints: dict) -> SpatialElement:
    """The driver constraint of one motor of the file.

    ``angle`` (revolute, cylindrical) and ``linear`` (prismatic, cylindrical) motors give the rotation
    about, or the translation along, the joint axis measured from the file's configuration;
    ``coordinate`` (x, y, z) and ``distance`` motors give absolute values.
    """
    name, kind = spec["name"], spec["type"]
    function = function_from_spec(spec["function"])
    if kind == "coordinate":
        return CoordinateDriver(
            name, -1, model.body_index(spec["body"]), index=COORDINATE_INDEX[spec["coordinate"]], function=function
        )
    if kind == "distance":
        i, j = model.body_index(spec["body1"]), model.body_index(spec["body2"])
        frame = spec.get("frame", "global")
        si = frames.local_point(i, frames.global_point(i, spec["point1"], frame))
        sj = frames.local_point(j, frames.global_point(j, spec["point2"], frame))
        return DistanceDriver(name, i, j, si=si, sj=sj, length=function)
    joint_spec = joints[spec["joint"]]
    i, j = model.body_index(joint_spec["body1"]), model.body_index(joint_spec["body2"])
    frame_i, frame_j = joint_frames(joint_spec, where, model, frames)
    if kind == "angle":
        return RotationDriver(name, i, j, fi=frame_i.f, gi=frame_i.g, fj=frame_j.f, function=function)
    drive = TranslationDriver(name, i, j, axis=frame_i.h, si=frame_i.origin, sj=frame_j.origin, function=function)
    drive.offset = float(drive.constraints(frames.q(i), frames.q(j), 0.0)[0] + function.value(0.0))
    return drive


def normalization_elements(model: Model) -> list[EulerNormalization]:
    """p_k^T p_k - 1 = 0 for every body k, named 'BODY.p' (eq. 9.9)."""
    return [EulerNormalization(f"{body.name}.p", -1, k) for k, body in enumerate(model.bodies)]


def build_elements(model: Model) -> list[SpatialElement]:
    """All constraint elements of a spatial model: joints, drivers (motors), then Euler-parameter normalizations."""
    frames = FileFrames(model)
    elements: list[SpatialElement] = []
    for k, spec in enumerate(model.joints):
        elements.append(joint_element(spec, f"model.joints[{k}]", model, frames))
    joints = {spec["name"]: spec for spec in model.joints}
    for k, spec in enumerate(model.motors):
        elements.append(motor_element(spec, f"model.motors[{k}]", model, frames, joints))
    return elements + normalization_elements(model)


__all__ = ["FileFrames", "build_elements", "initial_coordinates", "joint_axes", "joint_frames"]
