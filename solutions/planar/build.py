"""From a validated planar ``Model`` to constraint elements and initial coordinates.

Points and axes in a model file are global, in the configuration the file gives, unless the element
says ``frame: body``. Each is turned into the body frame once, here: s' = A(phi)^T (P - r).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ..functions import Constant, function_from_spec
from ..io.model import GROUND, Model, ModelError
from .bodies import R90, point_vector, rotation
from .forces import RSDA, TSDA, ForceElement, PointForce, TimeActuator, Torque, no_actuator
from .joints import (
    BodyCoordinate,
    Distance,
    FlatFaceCam,
    Gear,
    PinInSlot,
    PlanarElement,
    RelativeAngle,
    Revolute,
    RollerCam,
    Translation,
)

COORDINATE_INDEX = {"x": 0, "y": 1, "phi": 2}


def initial_coordinates(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """q0 and q0' stacked body after body: (x, y, phi) and (x', y', phi') as the file gives them."""
    q = np.array([[*b.location, b.orientation] for b in model.bodies], dtype=float).reshape(-1)
    qd = np.array([[*b.velocity, b.angular_velocity] for b in model.bodies], dtype=float).reshape(-1)
    return q, qd


class _Frames:
    """Body frames of the file's configuration, to express global points in a body's frame."""

    def __init__(self, model: Model):
        self.model = model

    @functools.cached_property
    def q0(self) -> np.ndarray:
        """q0 of the file (``initial_coordinates``), made where a global point or axis is first read: a model
        whose elements are all given in body frames, or that has none (the force elements of a pendulum under
        gravity), never needs it (5-10 us of every run's force model)."""
        return initial_coordinates(self.model)[0]

    def q(self, body: int) -> np.ndarray:
        return np.zeros(3) if body < 0 else self.q0[3 * body : 3 * body + 3]

    def local_point(self, body: int, point, frame: str) -> np.ndarray:
        point = np.asarray(point, dtype=float)
        if frame == "body":
            return point
        q = self.q(body)
        return rotation(q[2]).T @ (point - q[:2])

    def local_axis(self, body: int, axis, frame: str) -> np.ndarray:
        axis = np.asarray(axis, dtype=float)
        axis = axis / np.linalg.norm(axis)
        return axis if frame == "body" else rotation(self.q(body)[2]).T @ axis

    def origin(self, body: int) -> np.ndarray:
        return self.q(body)[:2].copy()


def _need(spec: dict, key: str, where: str, model: Model, what: str):
    if key not in spec:
        raise ModelError(f"{model.source}: {where}: missing key '{key}' ({what})")
    return spec[key]


def joint_elements(spec: dict, where: str, model: Model, frames: _Frames) -> list[PlanarElement]:
    """The constraint elements of one joint of the file (a prismatic joint gives two)."""
    name, kind, frame = spec["name"], spec["type"], spec.get("frame", "global")
    i, j = model.body_index(spec["body1"]), model.body_index(spec["body2"])

    def points(default1, default2):
        p1 = spec.get("point1", spec.get("location", default1))
        p2 = spec.get("point2", spec.get("location", default2))
        return frames.local_point(i, p1, frame), frames.local_point(j, p2, frame)

    if kind == "revolute":
        si, sj = points(None, None)
        return [Revolute(name, i, j, si=si, sj=sj)]
    if kind == "rigid":
        si, sj = points(frames.origin(j), frames.origin(j))
        return [Revolute(name, i, j, si=si, sj=sj), RelativeAngle(name, i, j, phi0=_phi0(frames, i, j))]
    if kind in ("prismatic", "revolute_prismatic"):
        si, sj = points(frames.origin(j), frames.origin(j))
        axis = frames.local_axis(i, spec["axis"], frame)
        slot = PinInSlot(name, i, j, si=si, sj=sj, axis=axis)
        if kind == "revolute_prismatic":
            return [slot]
        return [slot, RelativeAngle(name, i, j, phi0=_phi0(frames, i, j))]
    if kind == "revolute_revolute":
        si, sj = points(None, None)
        length = spec.get("length")
        if length is None:
            length = float(np.linalg.norm(point_vector(frames.q(i), si, frames.q(j), sj)))
        return [Distance(name, i, j, si=si, sj=sj, length=Constant(float(length)))]
    if kind == "gear":
        si, sj = points(frames.origin(i), frames.origin(j))
        sigma = -1.0 if spec.get("gear", "external") == "internal" else 1.0
        gear = Gear(name, i, j, si=si, sj=sj, radius_i=spec["radius1"], radius_j=spec["radius2"], sigma=sigma)
        gear.c0 = float(gear.constraints(frames.q(i), frames.q(j), 0.0)[0])
        return [gear]
    if kind == "rack_pinion":
        si, sj = points(None, frames.origin(j))
        axis = frames.local_axis(i, spec["axis"], frame)
        d = point_vector(frames.q(i), si, frames.q(j), sj)
        normal = rotation(frames.q(i)[2]) @ (R90 @ axis)
        if abs(normal @ d) < 1e-12:
            raise ModelError(
                f"{model.source}: {where}.point1: lies on the pinion's line of travel; give a point of the "
                "rack's pitch line, one pinion radius from the pinion centre"
            )
        rack = Translation(
            name, i, j, si=si, sj=sj, axis=axis, pinion_radius=spec["radius"], side=math.copysign(1.0, normal @ d)
        )
        rack.d0 = float(rack.constraints(frames.q(i), frames.q(j), 0.0)[0])
        return [rack]
    if kind == "cam":
        profile = function_from_spec(spec["profile"])
        si = frames.local_point(i, spec.get("point1", frames.origin(i)), frame)
        if spec["follower"] == "roller":
            sj = frames.local_point(j, spec.get("point2", frames.origin(j)), frame)
            return [RollerCam(name, i, j, si=si, sj=sj, profile=profile)]
        point = _need(spec, "point2", where, model, "a point on the flat face of the follower")
        normal = _need(spec, "axis", where, model, "the face normal, pointing from the cam to the follower")
        sj = frames.local_point(j, point, frame)
        return [FlatFaceCam(name, i, j, si=si, sj=sj, normal=frames.local_axis(j, normal, frame), profile=profile)]
    raise ModelError(f"{model.source}: {where}.type: '{kind}' is not a planar joint")


def _phi0(frames: _Frames, i: int, j: int) -> float:
    return float(frames.q(j)[2] - frames.q(i)[2])


def motor_elements(spec: dict, model: Model, frames: _Frames, joints: dict) -> list[PlanarElement]:
    """The driver constraint of one motor of the file.

    ``angle`` and ``linear`` motors give the rotation or displacement of their joint measured from
    the file's configuration (as Project Chrono does); ``coordinate`` and ``distance`` motors give
    the absolute value of the body coordinate or the distance.
    """
    name, kind = spec["name"], spec["type"]
    function = function_from_spec(spec["function"])
    if kind == "coordinate":
        j = model.body_index(spec["body"])
        return [BodyCoordinate(name, -1, j, index=COORDINATE_INDEX[spec["coordinate"]], function=function)]
    if kind == "distance":
        i, j = model.body_index(spec["body1"]), model.body_index(spec["body2"])
        frame = spec.get("frame", "global")
        si = frames.local_point(i, spec["point1"], frame)
        sj = frames.local_point(j, spec["point2"], frame)
        return [Distance(name, i, j, si=si, sj=sj, length=function)]
    joint_spec = joints[spec["joint"]]
    i, j = model.body_index(joint_spec["body1"]), model.body_index(joint_spec["body2"])
    if kind == "angle":
        return [RelativeAngle(name, i, j, phi0=_phi0(frames, i, j), function=function)]
    slot = next(e for e in joint_elements(joint_spec, "", model, frames) if isinstance(e, PinInSlot))
    drive = Translation(name, i, j, si=slot.si, sj=slot.sj, axis=slot.axis, function=function)
    drive.d0 = float(drive.constraints(frames.q(i), frames.q(j), 0.0)[0] + function.value(0.0))
    return [drive]


def build_elements(model: Model) -> list[PlanarElement]:
    """All constraint elements of a planar model: joints first, then drivers (motors)."""
    frames = _Frames(model)
    elements: list[PlanarElement] = []
    for k, spec in enumerate(model.joints):
        elements += joint_elements(spec, f"model.joints[{k}]", model, frames)
    joints = {spec["name"]: spec for spec in model.joints}
    for spec in model.motors:
        elements += motor_elements(spec, model, frames, joints)
    return elements


__all__ = ["GROUND", "build_elements", "initial_coordinates"]


# -- force elements (homework 2) ------------------------------------------------------------------
def spring_damper_element(spec: dict, where: str, model: Model, frames: _Frames) -> ForceElement:
    """A TSDA or RSDA of the file. A missing free length or free angle is the file configuration's."""
    name, frame = spec["name"], spec.get("frame", "global")
    i, j = model.body_index(spec["body1"]), model.body_index(spec["body2"])
    actuator = TimeActuator(function_from_spec(spec["actuator"])) if "actuator" in spec else no_actuator
    stiffness = float(spec.get("spring_coefficient", 0.0))
    damping = float(spec.get("damping_coefficient", 0.0))
    if spec["type"] == "RSDA":
        free_angle = float(spec.get("free_angle", _phi0(frames, i, j)))
        return RSDA(name, i, j, stiffness=stiffness, damping=damping, free_angle=free_angle, actuator=actuator)
    si = frames.local_point(i, spec["point1"], frame)
    sj = frames.local_point(j, spec["point2"], frame)
    length = float(np.linalg.norm(point_vector(frames.q(i), si, frames.q(j), sj)))
    if length < 1e-12:
        raise ModelError(f"{model.source}: {where}.point2: coincides with point1; a TSDA needs two distinct points")
    free_length = float(spec.get("free_length", length))
    return TSDA(
        name, i, j, si=si, sj=sj, stiffness=stiffness, damping=damping, free_length=free_length, actuator=actuator
    )


def load_element(spec: dict, where: str, model: Model, frames: _Frames) -> ForceElement:
    """A point force or a torque of the file (``value``: constant numbers or functions of time)."""
    name, frame = spec["name"], spec.get("frame", "global")
    i = model.body_index(spec["body"])
    if i < 0:
        raise ModelError(f"{model.source}: {where}.body: a load on ground does nothing; name a moving body")
    value = spec["value"]
    if spec["type"] == "torque":
        if isinstance(value, list):
            raise ModelError(f"{model.source}: {where}.value: a planar torque is one number or function, e.g. 0.5")
        return Torque(name, i, -1, function=function_from_spec(value))
    if not isinstance(value, list) or len(value) != 2:
        raise ModelError(f"{model.source}: {where}.value: a planar force takes two components, e.g. [0.0, -20.0]")
    point = frames.local_point(i, spec.get("point", frames.origin(i) if frame == "global" else [0.0, 0.0]), frame)
    components = (function_from_spec(value[0]), function_from_spec(value[1]))
    return PointForce(name, i, -1, point=point, components=components, body_fixed=frame == "body")


def force_elements(model: Model) -> list[ForceElement]:
    """All force elements of a planar model: spring-damper-actuators, then point forces and torques."""
    frames = _Frames(model)
    elements = [
        spring_damper_element(spec, f"model.spring_dampers[{k}]", model, frames)
        for k, spec in enumerate(model.spring_dampers)
    ]
    elements += [load_element(spec, f"model.forces[{k}]", model, frames) for k, spec in enumerate(model.forces)]
    return elements


__all__ += ["force_elements"]
