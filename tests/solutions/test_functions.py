"""Time and profile functions: f' and f'' of every type against central finite differences.

The differences use the fourth-order stencil f'(x) = (-f(x+2h) + 8 f(x+h) - 8 f(x-h) + f(x-2h)) / 12h,
whose truncation error (~h^4) and round-off error (~eps/h) are both far below the tolerance used.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from solutions.functions import (
    Constant,
    EccentricCircle,
    Fourier,
    Harmonic,
    Polynomial,
    PythonFunction,
    SmoothRamp,
    function_from_spec,
)

H = 1e-3


def fd(f, x, h=H):
    """Fourth-order central difference of a scalar function."""
    return (-f(x + 2 * h) + 8 * f(x + h) - 8 * f(x - h) + f(x - 2 * h)) / (12 * h)


FUNCTIONS = {
    "constant": Constant(2.5),
    "polynomial": Polynomial((0.3, -1.2, 0.7, 0.25, -0.05)),
    "harmonic": Harmonic(amplitude=0.8, frequency=2.3, phase=0.4, offset=-0.1),
    "fourier": Fourier(a0=0.2, a=(0.5, -0.3, 0.1), b=(0.2, 0.4, -0.15), frequency=1.7),
    "smooth_ramp": SmoothRamp(start=0.5, end=2.0, start_value=-0.4, end_value=1.3),
    "eccentric_circle": EccentricCircle(radius=0.06, eccentricity=0.02),
}

POINTS = np.linspace(-1.9, 3.1, 11)  # includes points before, inside and after the ramp


@pytest.mark.parametrize("name", FUNCTIONS)
def test_first_derivative_matches_finite_differences(name):
    f = FUNCTIONS[name]
    for x in POINTS:
        expected = fd(f.value, x)
        assert f.first(x) == pytest.approx(expected, rel=1e-8, abs=1e-9), (name, x)


@pytest.mark.parametrize("name", FUNCTIONS)
def test_second_derivative_matches_finite_differences(name):
    f = FUNCTIONS[name]
    for x in POINTS:
        # of the analytic first derivative, and (less accurately) twice of the value itself
        assert f.second(x) == pytest.approx(fd(f.first, x), rel=1e-8, abs=1e-9), (name, x)
        second_of_value = fd(lambda y: fd(f.value, y, 1e-2), x, 1e-2)
        assert f.second(x) == pytest.approx(second_of_value, rel=1e-5, abs=1e-6), (name, x)


def test_values_against_their_definitions():
    x = 0.7
    assert FUNCTIONS["polynomial"].value(x) == pytest.approx(0.3 - 1.2 * x + 0.7 * x**2 + 0.25 * x**3 - 0.05 * x**4)
    assert FUNCTIONS["harmonic"].value(x) == pytest.approx(-0.1 + 0.8 * math.sin(2.3 * x + 0.4))
    w = 1.7
    expected = 0.2 + sum(
        a * math.cos(k * w * x) + b * math.sin(k * w * x)
        for k, (a, b) in enumerate(zip((0.5, -0.3, 0.1), (0.2, 0.4, -0.15), strict=True), start=1)
    )
    assert FUNCTIONS["fourier"].value(x) == pytest.approx(expected)
    # the eccentric circle is the polar radius of a circle: the point lies on the circle
    e, a = 0.02, 0.06
    for theta in np.linspace(-3, 3, 13):
        rho = FUNCTIONS["eccentric_circle"].value(theta)
        point = rho * np.array([math.cos(theta), math.sin(theta)])
        assert np.hypot(point[0] - e, point[1]) == pytest.approx(a, rel=1e-12)


def test_smooth_ramp_starts_and_stops_smoothly():
    ramp = FUNCTIONS["smooth_ramp"]
    for x in (0.5, 2.0, -3.0, 5.0):
        assert ramp.first(x) == pytest.approx(0.0, abs=1e-12)
        assert ramp.second(x) == pytest.approx(0.0, abs=1e-12)
    assert ramp.value(0.0) == pytest.approx(-0.4)
    assert ramp.value(0.5) == pytest.approx(-0.4)
    assert ramp.value(1.25) == pytest.approx(0.5 * (-0.4 + 1.3))  # half way by symmetry
    assert ramp.value(2.0) == pytest.approx(1.3)
    assert ramp.value(9.0) == pytest.approx(1.3)


def _f(x):
    return math.sin(3.0 * x) * math.exp(0.5 * x)


def _df(x):
    return math.exp(0.5 * x) * (3.0 * math.cos(3.0 * x) + 0.5 * math.sin(3.0 * x))


def _ddf(x):
    return math.exp(0.5 * x) * (3.0 * math.cos(3.0 * x) - 8.75 * math.sin(3.0 * x))


@pytest.mark.parametrize("x", [-2.0, -0.3, 0.0, 0.9, 2.5, 4.0])
def test_python_function_finite_difference_fallback(x):
    """Without derivatives given, f' and f'' come from differences, accurate to ~1e-9 and ~1e-6."""
    f = PythonFunction(_f)
    scale = math.exp(0.5 * x) * 10.0  # the size of f, f', f'' here
    assert f.value(x) == pytest.approx(_f(x), rel=1e-15)
    assert abs(f.first(x) - _df(x)) < 1e-9 * scale
    assert abs(f.second(x) - _ddf(x)) < 1e-6 * scale


def test_python_function_uses_given_derivatives():
    f = PythonFunction(_f, df=lambda x: 11.0, ddf=lambda x: -7.0)
    assert f.first(0.3) == 11.0
    assert f.second(0.3) == -7.0


def test_python_function_through_spec():
    f = function_from_spec(_f)
    assert isinstance(f, PythonFunction)
    assert f.first(0.4) == pytest.approx(_df(0.4), rel=1e-8)


SPECS = [
    (3.0, Constant(3.0)),
    ({"type": "constant", "value": -1.5}, Constant(-1.5)),
    ({"type": "polynomial", "coefficients": [0.0, 10.0, 2.0]}, Polynomial((0.0, 10.0, 2.0))),
    (
        {"type": "harmonic", "amplitude": 0.1, "frequency": 2.0, "phase": 0.3, "offset": 1.0},
        Harmonic(0.1, 2.0, 0.3, 1.0),
    ),
    ({"type": "fourier", "a0": 1.0, "a": [0.5, 0.1], "b": [0.0, 0.2]}, Fourier(1.0, (0.5, 0.1), (0.0, 0.2), 1.0)),
    ({"type": "fourier", "a": [0.5]}, Fourier(0.0, (0.5,), (0.0,), 1.0)),
    (
        {"type": "smooth_ramp", "start": 0.1, "end": 1.0, "start_value": 0.0, "end_value": 2.0},
        SmoothRamp(0.1, 1.0, 0.0, 2.0),
    ),
    ({"type": "eccentric_circle", "radius": 0.05, "eccentricity": 0.01}, EccentricCircle(0.05, 0.01)),
]


@pytest.mark.parametrize("spec, expected", SPECS)
def test_function_from_spec(spec, expected):
    f = function_from_spec(spec)
    assert type(f) is type(expected)
    for x in (-0.4, 0.2, 0.55, 1.3):
        assert f.value(x) == pytest.approx(expected.value(x))
        assert f.first(x) == pytest.approx(expected.first(x))
        assert f.second(x) == pytest.approx(expected.second(x))


def test_function_from_spec_rejects_unknown_type():
    with pytest.raises(ValueError, match="unknown function type 'cubic'"):
        function_from_spec({"type": "cubic"})
