# Generated from solutions/functions.py by `make modules` (every homework stubbed): do not edit by hand.
"""Scalar functions of one variable with their first two derivatives.

Drivers prescribe a coordinate as a function of time, f(t); cams describe a profile as a function of
an angle. The kinematic equations need the function and its derivatives: the driver constraint
Psi = q - f(t) has Psi_t = -f'(t) and contributes f''(t) to gamma (course notes, eq. 3.34).

Every function here is a small dataclass with three methods, ``value``, ``first`` and ``second``.
``function_from_spec`` builds one from the mapping a model file gives, e.g.
``{type: polynomial, coefficients: [0.0, 10.0]}``; ``PythonFunction`` wraps any Python callable.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol


class ScalarFunction(Protocol):
    """f(x) with f'(x) and f''(x)."""

    def value(self, x: float) -> float: ...

    def first(self, x: float) -> float: ...

    def second(self, x: float) -> float: ...


@dataclass(frozen=True)
class Constant:
    """f(x) = c."""

    c: float

    def value(self, x: float) -> float:
        return self.c

    def first(self, x: float) -> float:
        return 0.0

    def second(self, x: float) -> float:
        return 0.0


@dataclass(frozen=True)
class Polynomial:
    """f(x) = c0 + c1 x + c2 x^2 + ... (coefficients in increasing order)."""

    coefficients: tuple[float, ...]

    def value(self, x: float) -> float:
        result = 0.0
        for c in reversed(self.coefficients):  # Horner's scheme
            result = result * x + c
        return result

    def first(self, x: float) -> float:
        result = 0.0
        for k in range(len(self.coefficients) - 1, 0, -1):
            result = result * x + k * self.coefficients[k]
        return result

    def second(self, x: float) -> float:
        result = 0.0
        for k in range(len(self.coefficients) - 1, 1, -1):
            result = result * x + k * (k - 1) * self.coefficients[k]
        return result


@dataclass(frozen=True)
class Harmonic:
    """f(x) = offset + amplitude * sin(frequency * x + phase), frequency in rad per unit of x."""

    amplitude: float
    frequency: float
    phase: float = 0.0
    offset: float = 0.0

    def value(self, x: float) -> float:
        return self.offset + self.amplitude * math.sin(self.frequency * x + self.phase)

    def first(self, x: float) -> float:
        return self.amplitude * self.frequency * math.cos(self.frequency * x + self.phase)

    def second(self, x: float) -> float:
        w = self.frequency
        return -self.amplitude * w * w * math.sin(w * x + self.phase)


@dataclass(frozen=True)
class Fourier:
    """f(x) = a0 + sum_k (a_k cos(k w x) + b_k sin(k w x)), k = 1 .. len(a)."""

    a0: float
    a: tuple[float, ...]
    b: tuple[float, ...]
    frequency: float = 1.0

    def _terms(self, x: float, order: int) -> float:
        total = 0.0
        for k, (ak, bk) in enumerate(zip(self.a, self.b, strict=True), start=1):
            w = k * self.frequency
            c, s = math.cos(w * x), math.sin(w * x)
            if order == 0:
                total += ak * c + bk * s
            elif order == 1:
                total += w * (-ak * s + bk * c)
            else:
                total += -w * w * (ak * c + bk * s)
        return total

    def value(self, x: float) -> float:
        return self.a0 + self._terms(x, 0)

    def first(self, x: float) -> float:
        return self._terms(x, 1)

    def second(self, x: float) -> float:
        return self._terms(x, 2)


@dataclass(frozen=True)
class SmoothRamp:
    """Cycloidal step from ``start_value`` at ``start`` to ``end_value`` at ``end``.

    With tau = (x - start) / (end - start) in [0, 1],
    f = v0 + (v1 - v0) (tau - sin(2 pi tau) / (2 pi)); f' and f'' are zero at both ends, so a
    driver that ramps up starts and stops without a jump in velocity or acceleration.
    """

    start: float
    end: float
    start_value: float
    end_value: float

    def _tau(self, x: float) -> float:
        return min(max((x - self.start) / (self.end - self.start), 0.0), 1.0)

    def value(self, x: float) -> float:
        tau = self._tau(x)
        return self.start_value + (self.end_value - self.start_value) * (
            tau - math.sin(2.0 * math.pi * tau) / (2.0 * math.pi)
        )

    def first(self, x: float) -> float:
        tau = self._tau(x)
        span = self.end - self.start
        return (self.end_value - self.start_value) * (1.0 - math.cos(2.0 * math.pi * tau)) / span

    def second(self, x: float) -> float:
        tau = self._tau(x)
        span = self.end - self.start
        rise = self.end_value - self.start_value
        return rise * 2.0 * math.pi * math.sin(2.0 * math.pi * tau) / span**2


@dataclass(frozen=True)
class EccentricCircle:
    """Polar radius of a circle of ``radius`` a whose centre is ``eccentricity`` e off the origin.

    rho(theta) = e cos(theta) + sqrt(a^2 - e^2 sin^2(theta)), for e < a. This is the pitch curve
    of an eccentric disc cam with a roller follower (a = disc radius + roller radius) and the
    classic closed-form cam of the course.
    """

    radius: float
    eccentricity: float

    def _root(self, theta: float) -> float:
        e, a = self.eccentricity, self.radius
        return math.sqrt(a * a - (e * math.sin(theta)) ** 2)

    def value(self, theta: float) -> float:
        return self.eccentricity * math.cos(theta) + self._root(theta)

    def first(self, theta: float) -> float:
        e = self.eccentricity
        s, c = math.sin(theta), math.cos(theta)
        return -e * s - e * e * s * c / self._root(theta)

    def second(self, theta: float) -> float:
        e = self.eccentricity
        s, c = math.sin(theta), math.cos(theta)
        root = self._root(theta)
        g = e * e * s * c  # numerator of the square-root term's derivative
        dg = e * e * (c * c - s * s)
        droot = -g / root
        return -e * c - (dg * root - g * droot) / (root * root)


@dataclass
class PythonFunction:
    """Any Python callable f(x), with optional callables for f' and f''.

    Missing derivatives are taken by central differences (steps eps^(1/3) and eps^(1/4) scaled
    by |x|), accurate to about 1e-10 and 1e-8 respectively for smooth f.
    """

    f: Callable[[float], float]
    df: Callable[[float], float] | None = None
    ddf: Callable[[float], float] | None = None
    name: str = field(default="python callable")

    def value(self, x: float) -> float:
        return float(self.f(x))

    def first(self, x: float) -> float:
        if self.df is not None:
            return float(self.df(x))
        h = 6.0e-6 * max(1.0, abs(x))
        return (self.f(x + h) - self.f(x - h)) / (2.0 * h)

    def second(self, x: float) -> float:
        if self.ddf is not None:
            return float(self.ddf(x))
        h = 1.2e-4 * max(1.0, abs(x))
        return (self.f(x + h) - 2.0 * self.f(x) + self.f(x - h)) / (h * h)


FUNCTION_TYPES = ("constant", "polynomial", "harmonic", "fourier", "smooth_ramp", "eccentric_circle")


def function_from_spec(spec: Mapping | float | Callable | ScalarFunction) -> ScalarFunction:
    """Build a function from a model-file mapping, a number (a constant) or a Python callable."""
    if isinstance(spec, int | float):
        return Constant(float(spec))
    if hasattr(spec, "value") and hasattr(spec, "second"):
        return spec  # already a ScalarFunction
    if callable(spec):
        return PythonFunction(spec)
    kind = spec["type"]
    if kind == "constant":
        return Constant(float(spec["value"]))
    if kind == "polynomial":
        return Polynomial(tuple(float(c) for c in spec["coefficients"]))
    if kind == "harmonic":
        return Harmonic(
            float(spec["amplitude"]),
            float(spec["frequency"]),
            float(spec.get("phase", 0.0)),
            float(spec.get("offset", 0.0)),
        )
    if kind == "fourier":
        a: Sequence[float] = spec.get("a", [])
        b: Sequence[float] = spec.get("b", [0.0] * len(a))
        return Fourier(float(spec.get("a0", 0.0)), tuple(a), tuple(b), float(spec.get("frequency", 1.0)))
    if kind == "smooth_ramp":
        return SmoothRamp(
            float(spec.get("start", 0.0)),
            float(spec["end"]),
            float(spec.get("start_value", 0.0)),
            float(spec["end_value"]),
        )
    if kind == "eccentric_circle":
        return EccentricCircle(float(spec["radius"]), float(spec["eccentricity"]))
    raise ValueError(f"unknown function type {kind!r} (one of: {', '.join(FUNCTION_TYPES)})")
