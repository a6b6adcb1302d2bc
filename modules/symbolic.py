# Generated from solutions/symbolic.py by `make modules` (every homework stubbed): do not edit by hand.
"""Symbolic derivation of a model's constraint equations with SymPy: Psi, Psi_q, Psi_t and gamma.

The same model file the numeric solver reads is turned into symbolic expressions in the body coordinates
q (``x_crank``, ``phi_crank``, ...), their rates q' (``xd_crank``, ...) and the time t, so that a student can
check a hand derivation, and the notes can print the equations of a whole mechanism (``mbd derive MODEL``).

Only the *geometry* is taken from the numeric build (which bodies an element connects, its body-frame
points and axes, its constants and driver functions: the data input of the program, eq. 9.20); every
formula is written here again from the course notes, independently of the numeric code:

- planar points and vectors:  r^P = r + A(phi) s'  (eq. 2.1, 2.2),  d_ij  (eq. 2.7)
- planar pairs and drivers:   revolute (3.17), relative angle (3.21), pin in a slot (3.24), distance (3.27),
                              gear (3.29), rack and pinion and prismatic driver (3.31, 3.35), cams (3.32,
                              3.33), coordinate drivers (3.34)
- spatial rotation:           A(p) = G(p) L(p)^T = (e0^2 - e^T e) I + 2 e e^T + 2 e0 e~  (eq. 8.12, 8.15)
- spatial basic constraints:  dot-1 (9.10), dot-2 (9.11), spherical (9.12), distance (9.13), the joints
                              stacked from them (9.14-9.19), drivers (9.21, 9.22), normalization (9.9)

Psi_q is the symbolic Jacobian of Psi, Psi_t its time derivative, and gamma follows the definition
(eq. 3.4, DESIGN section 3) by differentiation, never by a hand-written formula:

    gamma = -(Psi_q q')_q q' - 2 Psi_qt q' - Psi_tt
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sympy as sp

from .assembly import System, build_system
from .functions import Constant, EccentricCircle, Fourier, Harmonic, Polynomial, SmoothRamp
from .io.model import Model, load_model
from .rotation_matrices import rotation_entries

Vector = sp.Matrix


# -- driver and profile functions ------------------------------------------------------------------------------
def function_expression(function: object, x: sp.Expr) -> sp.Expr:
    """The symbolic f(x) of a driver or profile function of ``solutions.functions``.

    Raises
    ------
    TypeError
        For a function with no closed form (a Python callable).
    """
    if isinstance(function, Constant):
        return sp.Float(function.c)
    if isinstance(function, Polynomial):
        return sum((sp.Float(c) * x**k for k, c in enumerate(function.coefficients)), sp.Integer(0))
    if isinstance(function, Harmonic):
        return function.offset + function.amplitude * sp.sin(function.frequency * x + function.phase)
    if isinstance(function, Fourier):
        terms = [
            a * sp.cos((k + 1) * function.frequency * x) + b * sp.sin((k + 1) * function.frequency * x)
            for k, (a, b) in enumerate(zip(function.a, function.b, strict=True))
        ]
        return function.a0 + sum(terms, sp.Integer(0))
    if isinstance(function, SmoothRamp):
        span = function.end - function.start
        tau = (x - function.start) / span
        rise = function.end_value - function.start_value
        inside = function.start_value + rise * (tau - sp.sin(2 * sp.pi * tau) / (2 * sp.pi))
        return sp.Piecewise(
            (function.start_value, x <= function.start), (function.end_value, x >= function.end), (inside, True)
        )
    if isinstance(function, EccentricCircle):
        e, a = function.eccentricity, function.radius
        return e * sp.cos(x) + sp.sqrt(a**2 - (e * sp.sin(x)) ** 2)
    raise TypeError(f"no symbolic form for the function {type(function).__name__}: give it as a model-file function")


# -- rotations -----------------------------------------------------------------------------------------------------
def planar_rotation(phi: sp.Expr) -> sp.Matrix:
    """A(phi) (eq. 2.2). Written with sympy's cos and sin: ``rotation_matrices.planar_rotation_entries`` takes
    math.cos, which takes no symbol."""
    return sp.Matrix([[sp.cos(phi), -sp.sin(phi)], [sp.sin(phi), sp.cos(phi)]])


def spatial_rotation(p: sp.Matrix) -> sp.Matrix:
    """A(p) = G(p) L(p)^T (eq. 8.12, 8.15), the homogeneous quadratic form (a rotation when p^T p = 1)."""
    return sp.Matrix(3, 3, rotation_entries(*p))


# -- the derivation --------------------------------------------------------------------------------------------------
@dataclass
class Derivation:
    """The symbolic constraint equations of a model: row labels, q, q', t and the four arrays."""

    name: str
    labels: list[str]
    q: sp.Matrix
    qd: sp.Matrix
    t: sp.Symbol
    psi: sp.Matrix
    jacobian: sp.Matrix = field(init=False)
    psi_t: sp.Matrix = field(init=False)
    gamma: sp.Matrix = field(init=False)

    def __post_init__(self):
        q, qd, t = self.q, self.qd, self.t
        self.jacobian = self.psi.jacobian(q)
        self.psi_t = self.psi.diff(t)
        # Psi' = Psi_q q' + Psi_t, and its time derivative at q'' = 0 (eq. 3.3): d/dt Psi' = (Psi')_q q' + (Psi')_t
        # = (Psi_q q')_q q' + 2 Psi_qt q' + Psi_tt, so gamma = -((Psi')_q q' + (Psi')_t)  (eq. 3.4)
        velocity = self.jacobian * qd + self.psi_t
        self.gamma = -(velocity.jacobian(q) * qd + velocity.diff(t))

    def functions(self) -> dict:
        """NumPy functions of (q, q', t) for the four arrays: {'psi': f(q, t), 'jacobian': f(q, t),
        'psi_t': f(q, t), 'gamma': f(q, q', t)}, each returning a float array of the numeric shapes."""
        q, qd, t = list(self.q), list(self.qd), self.t
        compiled = {
            "psi": sp.lambdify((q, t), self.psi, "numpy", cse=True),
            "jacobian": sp.lambdify((q, t), self.jacobian, "numpy", cse=True),
            "psi_t": sp.lambdify((q, t), self.psi_t, "numpy", cse=True),
            "gamma": sp.lambdify((q, qd, t), self.gamma, "numpy", cse=True),
        }

        def vector(name):
            return lambda *args: np.asarray(compiled[name](*args), dtype=float).reshape(-1)

        return {
            "psi": vector("psi"),
            "psi_t": vector("psi_t"),
            "gamma": vector("gamma"),
            "jacobian": lambda *args: np.asarray(compiled["jacobian"](*args), dtype=float).reshape(
                len(self.labels), len(q)
            ),
        }

    def report(self, latex: bool = False, simplify: bool = False) -> str:
        """Psi, Psi_q (by non-zero entry), Psi_t and gamma, row by row, as plain text or LaTeX."""

        def show(expr):
            expr = sp.simplify(expr) if simplify else expr
            return sp.latex(expr) if latex else sp.sstr(expr)

        lines = [f"model {self.name}: {len(self.labels)} equations in {len(self.q)} coordinates"]
        lines.append("q = " + ", ".join(map(str, self.q)) + f"; their rates {self.qd[0]}, ...; time {self.t}")
        for k, label in enumerate(self.labels):
            lines.append(f"\n[{label}]")
            lines.append(f"  Psi     = {show(self.psi[k])}")
            for c, coordinate in enumerate(self.q):
                if self.jacobian[k, c] != 0:
                    lines.append(f"  dPsi/d{coordinate} = {show(self.jacobian[k, c])}")
            if self.psi_t[k] != 0:
                lines.append(f"  Psi_t   = {show(self.psi_t[k])}")
            lines.append(f"  gamma   = {show(self.gamma[k])}")
        return "\n".join(lines)


class _Bodies:
    """Symbolic coordinates of the bodies: q, q' and, per body, its position and rotation matrix."""

    def __init__(self, system: System):
        self.dimension = system.model.dimension
        names = [body.name for body in system.model.bodies]
        per_body = ("x", "y", "phi") if self.dimension == 2 else ("x", "y", "z", "e0", "e1", "e2", "e3")
        self.q = sp.Matrix([sp.Symbol(f"{c}_{name}", real=True) for name in names for c in per_body])
        self.qd = sp.Matrix([sp.Symbol(f"{c}d_{name}", real=True) for name in names for c in per_body])
        self.n = len(per_body)

    def coordinates(self, body: int) -> sp.Matrix:
        if body < 0:  # ground
            return sp.Matrix([0, 0, 0]) if self.dimension == 2 else sp.Matrix([0, 0, 0, 1, 0, 0, 0])
        return self.q[self.n * body : self.n * body + self.n, 0]

    def position(self, body: int) -> sp.Matrix:
        return self.coordinates(body)[: self.dimension, 0]

    def angle(self, body: int) -> sp.Expr:
        return self.coordinates(body)[2]

    def rotation(self, body: int) -> sp.Matrix:
        qb = self.coordinates(body)
        return planar_rotation(qb[2]) if self.dimension == 2 else spatial_rotation(qb[3:, 0])

    def vector(self, body: int, components) -> sp.Matrix:
        """A vector fixed in a body, global components A s' (eq. 2.1, 8.1)."""
        return self.rotation(body) * sp.Matrix(np.asarray(components, dtype=float))

    def point(self, body: int, components) -> sp.Matrix:
        """r + A s' (eq. 2.1, 9.1)."""
        return self.position(body) + self.vector(body, components)


def _planar_rows(element, bodies: _Bodies, t: sp.Symbol) -> list[sp.Expr]:
    kind = type(element).__name__
    i, j = element.i, element.j
    if kind in ("Revolute", "PinInSlot", "Distance", "Translation", "Gear", "RollerCam", "FlatFaceCam"):
        d = bodies.point(j, element.sj) - bodies.point(i, element.si)  # eq. 2.7
    if kind == "Revolute":  # eq. 3.17
        return list(-d)
    if kind == "RelativeAngle":  # eq. 3.21
        return [bodies.angle(j) - bodies.angle(i) - element.phi0 - function_expression(element.function, t)]
    if kind == "PinInSlot":  # eq. 3.24: n_i = A_i R v_i'
        v = np.asarray(element.axis, dtype=float)
        n = bodies.vector(i, [-v[1], v[0]])
        return [(n.T * d)[0]]
    if kind == "Distance":  # eq. 3.27
        length = function_expression(element.length, t)
        return [((d.T * d)[0] - length**2) / 2]
    if kind == "Translation":  # eq. 3.31, 3.35
        v = bodies.vector(i, element.axis)
        rolling = element.side * element.pinion_radius * (bodies.angle(j) - bodies.angle(i))
        return [(v.T * d)[0] + rolling - element.d0 - function_expression(element.function, t)]
    if kind == "Gear":  # eq. 3.29
        theta = sp.atan2(d[1], d[0])
        ri, rj, sigma = element.radius_i, element.radius_j, element.sigma
        return [ri * (bodies.angle(i) - theta) + sigma * rj * (bodies.angle(j) - theta) - element.c0]
    if kind == "RollerCam":  # eq. 3.32
        polar = sp.atan2(d[1], d[0]) - bodies.angle(i)
        return [sp.sqrt((d.T * d)[0]) - function_expression(element.profile, polar)]
    if kind == "FlatFaceCam":  # eq. 3.33
        u = bodies.vector(j, element.normal)
        alpha = float(np.arctan2(element.normal[1], element.normal[0]))
        psi = bodies.angle(j) - bodies.angle(i) + alpha
        return [(u.T * d)[0] - function_expression(element.profile, psi)]
    if kind == "BodyCoordinate":  # eq. 3.34
        return [bodies.coordinates(j)[element.index] - function_expression(element.function, t)]
    raise TypeError(f"no symbolic form for the planar element {element.name!r} ({kind})")


def _spatial_part(part, i: int, j: int, bodies: _Bodies) -> list[sp.Expr]:
    kind = type(part).__name__
    if kind == "Dot1":  # eq. 9.10
        return [(bodies.vector(i, part.ai).T * bodies.vector(j, part.aj))[0]]
    d = bodies.point(j, part.sj) - bodies.point(i, part.si)
    if kind == "Dot2":  # eq. 9.11
        return [(bodies.vector(i, part.ai).T * d)[0]]
    if kind == "Spherical":  # eq. 9.12
        return list(-d)
    raise TypeError(f"no symbolic form for the basic constraint {kind}")


def _spatial_rows(element, bodies: _Bodies, t: sp.Symbol) -> list[sp.Expr]:
    kind = type(element).__name__
    i, j = element.i, element.j
    if kind == "Joint":  # eq. 9.14-9.19
        return [row for part in element.parts for row in _spatial_part(part, i, j, bodies)]
    if kind == "EulerNormalization":  # eq. 9.9
        p = bodies.coordinates(j)[3:, 0]
        return [(p.T * p)[0] - 1]
    if kind == "RotationDriver":  # eq. 9.21
        theta = element.angle0 + function_expression(element.function, t)
        fi, gi = np.asarray(element.fi, dtype=float), np.asarray(element.gi, dtype=float)
        n = bodies.rotation(i) * (-sp.sin(theta) * sp.Matrix(fi) + sp.cos(theta) * sp.Matrix(gi))
        return [(n.T * bodies.vector(j, element.fj))[0]]
    if kind == "TranslationDriver":  # eq. 9.22
        d = bodies.point(j, element.sj) - bodies.point(i, element.si)
        return [(bodies.vector(i, element.axis).T * d)[0] - element.offset - function_expression(element.function, t)]
    if kind == "DistanceDriver":  # eq. 9.13 with L(t)
        d = bodies.point(j, element.sj) - bodies.point(i, element.si)
        return [((d.T * d)[0] - function_expression(element.length, t) ** 2) / 2]
    if kind == "CoordinateDriver":
        return [bodies.coordinates(j)[element.index] - function_expression(element.function, t)]
    raise TypeError(f"no symbolic form for the spatial element {element.name!r} ({kind})")


def derive_system(system: System) -> Derivation:
    """The symbolic Psi, Psi_q, Psi_t and gamma of an assembled ``System``, rows in the system's order."""
    bodies = _Bodies(system)
    t = sp.Symbol("t", real=True)
    rows_of = _planar_rows if system.model.dimension == 2 else _spatial_rows
    psi = [row for element in system.elements for row in rows_of(element, bodies, t)]
    return Derivation(system.model.name, list(system.labels), bodies.q, bodies.qd, t, sp.Matrix(psi))


def derive(model: Model | str | Path) -> Derivation:
    """The symbolic constraint equations of a model (a ``Model`` or a model file)."""
    if not isinstance(model, Model):
        model = load_model(model)
    system, _, _ = build_system(model)
    return derive_system(system)


__all__ = ["Derivation", "derive", "derive_system", "function_expression", "planar_rotation", "spatial_rotation"]
