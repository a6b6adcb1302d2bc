"""Likely causes of a failed check: what a wrong result looks like when it comes from a known mistake.

Two kinds of evidence, tried in order on the entries that fail:

1. **The numbers themselves**: zero where the reference is not (a missing term, or a stub), minus the
   reference (a sign), the reference times 180/pi (degrees for radians), twice or half of it, the
   matrix transposed.
2. **Known mistakes, replayed**: the reference package is run again with one function changed the way
   students get it wrong -- B(phi)^T for B(phi) (a transposed block), the quadratic-velocity terms of
   gamma dropped, Baumgarte's terms dropped or with the wrong sign, one joint's gamma negated -- and
   when that reproduces the student's numbers, that is the likely cause. This runs in the grader (never
   in the sandbox) and only for checks that fail.
"""

from __future__ import annotations

import contextlib
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .probes import PROBES, RK4_SPAN, RK4_STEPS, Job, Package, rk4_test_exact

REFERENCE = Package("solutions")


@dataclass(frozen=True)
class Hypothesis:
    """A known mistake: ``target`` (a function or method of the reference package) is replaced by
    ``make(original)`` while the probe runs again."""

    cause: str
    target: str
    make: Callable


def _package_modules(package: Package) -> list:
    prefix = package.name + "."
    return [m for n, m in list(sys.modules.items()) if m is not None and (n == package.name or n.startswith(prefix))]


@contextlib.contextmanager
def patched(package: Package, target: str, make: Callable):
    """Replace a function of the package (everywhere it was imported by name) or a method of a class.

    A module first imported while the patch is on binds the replacement too: on the way out every
    module of the package is searched for it, so nothing keeps the mistake.
    """
    parts = target.split(".")
    for cut in range(len(parts) - 1, 0, -1):
        try:
            module = package[".".join(parts[:cut])]
            attributes = parts[cut:]
            break
        except ImportError:
            continue
    else:
        raise ImportError(target)
    if len(attributes) == 1:
        original = getattr(module, attributes[0])
        replacement = make(original)
        try:
            for mod in _package_modules(package):
                for attr, value in list(vars(mod).items()):
                    if value is original:
                        setattr(mod, attr, replacement)
            yield
        finally:
            for mod in _package_modules(package):
                for attr, value in list(vars(mod).items()):
                    if value is replacement:
                        setattr(mod, attr, original)
    else:
        owner = getattr(module, attributes[0])
        own = attributes[1] in vars(owner)
        previous = vars(owner)[attributes[1]] if own else None
        setattr(owner, attributes[1], make(getattr(owner, attributes[1])))
        try:
            yield
        finally:
            if own:
                setattr(owner, attributes[1], previous)
            else:
                delattr(owner, attributes[1])


def _transposed(f):
    return lambda *a, **k: np.asarray(f(*a, **k)).T


def _zero(f):
    return lambda *a, **k: np.zeros_like(np.asarray(f(*a, **k), dtype=float))


def _negated(f):
    return lambda *a, **k: -np.asarray(f(*a, **k), dtype=float)


def _degrees(f):
    return lambda phi, *a, **k: f(np.deg2rad(phi), *a, **k)


def _baumgarte(sign: float, damping: float = 2.0, square: bool = True):
    def make(original):
        def gamma_bar(gamma, psi, psi_dot, alpha, beta):
            stiffness = beta**2 if square else beta
            return gamma + sign * (damping * alpha * psi_dot + stiffness * psi)

        return gamma_bar

    return make


def _no_baumgarte(original):
    return lambda gamma, psi, psi_dot, alpha, beta: gamma


ROTATION = "planar.bodies.rotation"
ROTATION_DERIVATIVE = "planar.bodies.rotation_derivative"
QUADRATIC = "planar.bodies.point_vector_quadratic"

BAUMGARTE_MISTAKES = [
    Hypothesis(
        "Baumgarte's terms with the wrong sign: gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi (eq. 5.29)",
        "formulations.baumgarte_gamma",
        _baumgarte(+1.0),
    ),
    Hypothesis(
        "a missing Baumgarte term: gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi, not plain gamma (eq. 5.29)",
        "formulations.baumgarte_gamma",
        _no_baumgarte,
    ),
    Hypothesis(
        "beta not squared in Baumgarte's term: gamma_bar = gamma - 2 alpha Psi' - beta^2 Psi (eq. 5.29)",
        "formulations.baumgarte_gamma",
        _baumgarte(-1.0, square=False),
    ),
    Hypothesis(
        "the factor 2 missing in Baumgarte's term 2 alpha Psi' (eq. 5.29)",
        "formulations.baumgarte_gamma",
        _baumgarte(-1.0, damping=1.0),
    ),
]

ROTATION_MISTAKES = [
    Hypothesis(
        "a transposed block: B(phi)^T used where B(phi) = dA/dphi belongs (eq. 2.5)", ROTATION_DERIVATIVE, _transposed
    ),
    Hypothesis("a transposed block: A(phi)^T used where A(phi) belongs (eq. 2.2)", ROTATION, _transposed),
    Hypothesis("degrees for radians: the angle converted as if it were in degrees", ROTATION, _degrees),
]
QUADRATIC_MISTAKE = Hypothesis(
    "a missing quadratic-velocity term: the A s' phi'^2 terms of gamma (eq. 3.17)", QUADRATIC, _zero
)


SPATIAL_ROTATION_MISTAKES = [
    Hypothesis(
        "a transposed rotation matrix: A(p)^T used where A(p) belongs (eq. 8.12)",
        "rotations.rotation_matrix",
        _transposed,
    ),
    Hypothesis(
        "G(p) used where L(p) belongs: the angular velocity in the global frame, not the body frame (eq. 8.14)",
        "rotations.l_matrix",
        lambda original: REFERENCE["rotations"].g_matrix,
    ),
    Hypothesis(
        "L(p) used where G(p) belongs: the angular velocity in the body frame, not the global frame (eq. 8.14)",
        "rotations.g_matrix",
        lambda original: REFERENCE["rotations"].l_matrix,
    ),
]
SPATIAL_QUADRATIC_MISTAKES = [
    Hypothesis(
        "a missing quadratic-velocity term: the (d_ij'')_v part of gamma, B(p', s') p' (eq. 9.12)",
        "spatial.bodies.point_vector_quadratic",
        _zero,
    ),
    Hypothesis(
        "a missing quadratic-velocity term: the (a'')_v part of gamma, B(p', a') p' (eq. 9.10)",
        "spatial.bodies.body_vector_quadratic",
        _zero,
    ),
]
SPATIAL_MASS_MISTAKES = [
    Hypothesis(
        "the quadratic-velocity force Q_v = 8 L(p')^T J' L(p') p is missing (eq. 10.5)",
        "spatial.mass.quadratic_velocity_force",
        _zero,
    ),
]


_CLASSES: dict[str, dict[str, list[str]]] = {}


def _element_classes(job: Job, method: str) -> list[str]:
    """Class paths of the scene's constraint elements (in the reference package) that define ``method``."""
    if job.key not in _CLASSES:
        model = REFERENCE["io.model"].load_model(job.model)
        system, _, _ = REFERENCE["assembly"].build_system(model)
        classes = list(dict.fromkeys(type(e) for e in system.elements))
        _CLASSES[job.key] = {
            name: [f"{c.__module__.split('.', 1)[1]}.{c.__name__}" for c in classes if name in vars(c)]
            for name in ("gamma", "psi_t")
        }
    return _CLASSES[job.key][method]


def _per_element(job: Job, method: str, cause: str, make: Callable) -> list[Hypothesis]:
    return [
        Hypothesis(cause.format(name=path.rsplit(".", 1)[1]), f"{path}.{method}", make)
        for path in _element_classes(job, method)
    ]


def hypotheses(probe: str, job: Job) -> list[Hypothesis]:
    """The known mistakes worth replaying for a failed check of ``probe``."""
    planar = job.model.get("model", {}).get("dimension", 2) == 2
    rotation = ROTATION_MISTAKES if planar else SPATIAL_ROTATION_MISTAKES
    quadratic = [QUADRATIC_MISTAKE] if planar else SPATIAL_QUADRATIC_MISTAKES

    def gamma_signs():
        return _per_element(job, "gamma", "gamma with the wrong sign in {name}.gamma", _negated)

    def psi_t_signs():
        return _per_element(job, "psi_t", "Psi_t with the wrong sign in {name}.psi_t", _negated)

    table = {
        "constraints": lambda: rotation,
        "jacobian": lambda: rotation,
        "gamma": lambda: quadratic + rotation,
        "rotation_matrices": lambda: SPATIAL_ROTATION_MISTAKES,
        "spatial_mass_matrix": lambda: SPATIAL_ROTATION_MISTAKES,
        "quadratic_velocity": lambda: SPATIAL_ROTATION_MISTAKES,
        "generalized_forces": lambda: [] if planar else SPATIAL_MASS_MISTAKES,
        "velocity": psi_t_signs,
        "acceleration": lambda: quadratic + gamma_signs(),
        "kinematic_run": lambda: quadratic + gamma_signs() + psi_t_signs(),
        "baumgarte_gamma": lambda: BAUMGARTE_MISTAKES,
        "accelerations": lambda: (
            BAUMGARTE_MISTAKES + quadratic + gamma_signs() + ([] if planar else SPATIAL_MASS_MISTAKES)
        ),
        "dynamic_run": lambda: BAUMGARTE_MISTAKES[:2],
    }
    return table[probe]() if probe in table else []


_REPLAYS: dict[tuple, dict | None] = {}


def replay(probe: str, job: Job, hypothesis: Hypothesis) -> dict | None:
    """The probe's outputs with the reference package made to commit the mistake (None if it fails).

    Kept for the next output of the same probe call (a run's q and q' share their replays)."""
    key = (probe, job.key, json.dumps(job.options, sort_keys=True), hypothesis.target, hypothesis.cause)
    if key not in _REPLAYS:
        if len(_REPLAYS) > 64:
            _REPLAYS.clear()
        try:
            with patched(REFERENCE, hypothesis.target, hypothesis.make):
                _REPLAYS[key] = PROBES[probe](REFERENCE, Job(job.key, job.model, job.inputs, job.options))
        except Exception:  # noqa: BLE001 - a mistake that makes the reference fail explains nothing
            _REPLAYS[key] = None
    return _REPLAYS[key]


def structural(expected: np.ndarray, got: np.ndarray, failing: np.ndarray, allowed: np.ndarray) -> str | None:
    """What the numbers alone say about the failing entries."""
    e, g, a = expected[failing], got[failing], allowed[failing]
    if e.size == 0:
        return None
    if not np.all(np.isfinite(g)):
        return "NaN or infinity: a division by zero, or a function of a value outside its domain?"
    if np.all(np.abs(g) <= a) and np.any(np.abs(e) > a):
        return "you get zero where the reference does not: a missing term (or a function still to write)"
    if np.all(np.abs(g + e) <= a):
        return "a sign error: you get minus the expected value"
    big = np.abs(e) > 10 * a
    if np.any(big):
        ratio = g[big] / e[big]
        for factor, text in (
            (180 / np.pi, "degrees for radians: you get the expected value times 180/pi"),
            (np.pi / 180, "radians for degrees: you get the expected value times pi/180"),
            (2.0, "a factor 2: you get twice the expected value"),
            (0.5, "a factor 1/2: you get half the expected value"),
        ):
            if np.all(np.abs(ratio - factor) <= 1e-6 * factor + 1e-9):
                return text
    return None


def transposed(expected: np.ndarray, got: np.ndarray, rtol: float = 1e-6) -> bool:
    """Whether ``got`` is ``expected`` with its last two axes swapped (and that is not the same thing)."""
    if expected.ndim < 2:
        return False
    swapped = np.swapaxes(expected, -1, -2)
    atol = rtol * max(1.0, float(np.max(np.abs(expected), initial=0.0)))
    if got.shape != swapped.shape or (swapped.shape == expected.shape and np.allclose(swapped, expected, rtol, atol)):
        return False
    return bool(np.allclose(got, swapped, rtol=rtol, atol=atol))


def rk4_order(got: np.ndarray) -> str | None:
    """The order of convergence a student's rk4_step shows on the test ODE (it should be 4)."""
    exact = rk4_test_exact(RK4_SPAN)
    errors = np.linalg.norm(got - exact, axis=1)
    if not np.all(np.isfinite(errors)):
        return None
    if errors[-1] >= 0.5 * errors[-2]:
        return (
            "your rk4_step does not converge as the step shrinks: the stage weights should be "
            "1/6, 2/6, 2/6, 1/6 (they must sum to 1)"
        )
    order = float(np.log2(errors[-2] / errors[-1]))
    if order < 3.5:
        return (
            f"your rk4_step converges with order {order:.1f}, not 4 (errors {errors[-2]:.2g} and {errors[-1]:.2g} "
            f"for {RK4_STEPS[-2]} and {RK4_STEPS[-1]} steps): a stage weight (1/6, 2/6, 2/6, 1/6) or a stage "
            "time (t + h/2, t + h) is wrong"
        )
    return None


def likely_cause(
    probe: str,
    output: str,
    expected: np.ndarray,
    got: np.ndarray,
    failing: np.ndarray,
    allowed: np.ndarray,
    job: Job | None,
    select: Callable[[np.ndarray], np.ndarray] = lambda x: x,
) -> str | None:
    """The most likely cause of a failure, or None. ``select`` applies the check's row filter."""
    if probe == "rk4" and output == "y":
        found = rk4_order(got)
        if found:
            return found
    # a replayed mistake names the formula; "minus the expected value" may be only what it looks like
    # (B^T s' is -B s' in one component for a point on the body's x axis)
    if not np.all(np.isfinite(got[failing])) or job is None:
        return structural(expected, got, failing, allowed)
    for hypothesis in hypotheses(probe, job):
        outputs = replay(probe, job, hypothesis)
        if outputs is None or output not in outputs:
            continue
        candidate = select(np.asarray(outputs[output], dtype=float))
        if candidate.shape != got.shape:
            continue
        if np.all(np.abs(candidate[failing] - got[failing]) <= allowed[failing]):
            return hypothesis.cause
    return structural(expected, got, failing, allowed)
