"""The compiled integrator loops: source text that ``codegen.py`` copies into every generated scene module.

These functions call ``scene_rhs(t, z, P, D, out)``, the right-hand side the generator writes for one scene
above them; numba compiles them together with it, so a step costs no Python call at all. (They are not
compiled in this module: the placeholder below is replaced by the generated code. A compiled loop that took
the right-hand side as an argument could not be cached on disk: numba keys such a specialization on the
function object.)

- ``embedded``: an explicit embedded Runge-Kutta pair with error control and dense output to the output
  grid: Dormand-Prince 8(5,3) (DOP853) and 5(4) (RK45) with scipy's coefficients, the step-size controller
  of Hairer, Norsett and Wanner (Solving ODEs I, sec. II.4: safety 0.9, factors 0.2 to 10, the starting
  step of sec. II.4), DOP853's error estimate of sec. II.10 and its 7th-order continuous extension. Two
  variants, the same arithmetic as the two numpy loops they stand for: ``scipy_like`` follows
  ``scipy.integrate.DOP853`` / ``RK45`` step by step as ``integrators._integrate_adaptive`` drives them
  (no growth right after a rejected step, the end time clipped exactly), otherwise this package's own
  ``integrators._integrate_embedded`` (``dop853``, ``rk45``).
- ``rk4``: the classical Runge-Kutta method with a fixed step (eq. 6.12), each output interval cut into the
  fewest equal steps no longer than ``step``, as ``integrators._integrate_rk4``.

Both return the states at the output times and (evaluations, steps, rejected, status, t, h); status 0 is
success, 1 a step-size collapse, 2 the evaluation budget spent, 3 a state that is no longer finite (rk4).
"""

# fmt: off
# --- scene: replaced by the generated right-hand side ---
import numpy as np
from numba import njit

jit = njit(cache=True, nogil=True)


def scene_rhs(t, z, P, D, out):  # noqa: D103 (placeholder)
    raise NotImplementedError
# --- end scene ---

SAFETY, MIN_FACTOR, MAX_FACTOR, MIN_STEP = 0.9, 0.2, 10.0, 1e-12


@jit
def _norm(x):
    return np.sqrt(np.sum(x * x) / x.size)


@jit
def _error(dop, K, h, scale, E, E3, E5):
    """The scaled RMS error norm: DOP853's combination of its 5th and 3rd order estimates (sec. II.10), or
    h E^T K for RK45."""
    if dop:
        err5 = (K.T @ E5) / scale
        err3 = (K.T @ E3) / scale
        e5, e3 = np.sum(err5 * err5), np.sum(err3 * err3)
        if e5 == 0.0 and e3 == 0.0:
            return 0.0
        return abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * scale.size)
    return _norm((K.T @ E) * h / scale)


@jit
def embedded(z0, t_out, rtol, atol, max_step, max_evaluations, dop, scipy_like, tableau, P, D):
    """Integrate from z0 at t_out[0] to t_out[-1]; states at every output time (module docstring)."""
    A, B, C, E, E3, E5, Dd, Pd = tableau
    stages = B.size
    order = 7 if dop else 4
    exponent = -1.0 / (order + 1)
    nz = z0.size
    nout = t_out.size
    Y = np.empty((nout, nz))
    t, t_end = t_out[0], t_out[-1]
    span = t_end - t
    y = z0.copy()
    f = np.empty(nz)
    scene_rhs(t, y, P, D, f)
    evaluations = 1
    # Hairer's starting step (sec. II.4), as scipy's select_initial_step and integrators.initial_step
    scale = atol + np.abs(y) * rtol
    d0, d1 = _norm(y / scale), _norm(f / scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, span)
    f1 = np.empty(nz)
    scene_rhs(t + h0, y + h0 * f, P, D, f1)
    evaluations += 1
    d2 = _norm((f1 - f) / scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    h_abs = min(100.0 * h0, h1, span, max_step)
    K = np.empty((Dd.shape[1] if dop else stages + 1, nz))
    y_new, f_new, stage = np.empty(nz), np.empty(nz), np.empty(nz)
    Y[0] = y
    k = 1
    steps = rejected = 0
    while k < nout:
        rejected_now = False
        while True:
            if evaluations >= max_evaluations:
                return Y, evaluations, steps, rejected, 2, t, h_abs
            if scipy_like:
                min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
                h_abs = max(min(h_abs, max_step), min_step) if not rejected_now else h_abs
                if h_abs < min_step:
                    return Y, evaluations, steps, rejected, 1, t, h_abs
                t_new = t + h_abs
                if t_new > t_end:
                    t_new = t_end
                h = t_new - t
                h_abs = abs(h)
            else:
                h = min(h_abs, max_step, t_end - t)
                if h < MIN_STEP * span and t_end - t > MIN_STEP * span:
                    return Y, evaluations, steps, rejected, 1, t, h
            K[0] = f
            for s in range(1, stages):
                if scipy_like:
                    stage[:] = y + (K[:s].T @ A[s, :s]) * h
                else:
                    stage[:] = y + h * (A[s, :s] @ K[:s])
                scene_rhs(t + C[s] * h, stage, P, D, K[s])
            if scipy_like:
                y_new[:] = y + h * (K[:stages].T @ B)
            else:
                y_new[:] = y + h * (B @ K[:stages])
            scene_rhs(t + h, y_new, P, D, f_new)
            K[stages] = f_new
            evaluations += stages
            scale = atol + np.maximum(np.abs(y), np.abs(y_new)) * rtol
            err = _error(dop, K[: stages + 1], h, scale, E, E3, E5)
            if err < 1.0:
                factor = MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err**exponent)
                if scipy_like and rejected_now:
                    factor = min(1.0, factor)
                if not scipy_like:
                    t_new = t_end if t_end - (t + h) < 1e-12 * max(1.0, abs(t_end)) else t + h
                break
            shrink = max(MIN_FACTOR, SAFETY * err**exponent) if np.isfinite(err) else MIN_FACTOR
            if scipy_like:
                h_abs *= shrink
            else:
                h_abs = h * shrink
            rejected_now = True
            rejected += 1
        steps += 1
        if scipy_like and h < MIN_STEP * span and t_end - t_new > MIN_STEP * span:
            return Y, evaluations, steps, rejected, 1, t_new, h
        if t_out[k] < t_new:  # dense output for the output times passed
            if dop:
                F = np.empty((7, nz))
                for s in range(stages + 1, K.shape[0]):
                    a = A[s, :s]
                    if scipy_like:
                        stage[:] = y + (K[:s].T @ a) * h
                    else:
                        stage[:] = y + h * (a @ K[:s])
                    scene_rhs(t + C[s] * h, stage, P, D, K[s])
                    evaluations += 1
                delta = y_new - y
                F[0] = delta
                F[1] = h * K[0] - delta
                F[2] = 2.0 * delta - h * (f_new + K[0])
                F[3:] = h * (Dd @ K)
            else:
                Q = K.T @ Pd
            while k < nout and t_out[k] < t_new:
                x = (t_out[k] - t) / h
                if dop:
                    out = np.zeros(nz)
                    for r in range(6, -1, -1):
                        out += F[r]
                        out *= x if (6 - r) % 2 == 0 else 1.0 - x
                    Y[k] = out + y
                else:
                    powers = np.empty(Q.shape[1])
                    powers[0] = x
                    for r in range(1, powers.size):
                        powers[r] = powers[r - 1] * x
                    Y[k] = y + h * (Q @ powers)
                k += 1
        t = t_new
        y[:] = y_new
        f[:] = f_new
        if k < nout and t_out[k] == t:
            Y[k] = y
            k += 1
        if not scipy_like:
            h_abs = h * factor
        else:
            h_abs *= factor
    return Y, evaluations, steps, rejected, 0, t, h_abs


@jit
def rk4(z0, t_out, step, P, D):
    """Fixed-step classical Runge-Kutta (eq. 6.12): k1 = f(t, y), k2 = f(t + h/2, y + h/2 k1), k3 = f(t + h/2,
    y + h/2 k2), k4 = f(t + h, y + h k3), y <- y + h/6 (k1 + 2 k2 + 2 k3 + k4)."""
    nz = z0.size
    nout = t_out.size
    Y = np.empty((nout, nz))
    y = z0.copy()
    k1, k2, k3, k4 = np.empty(nz), np.empty(nz), np.empty(nz), np.empty(nz)
    Y[0] = y
    evaluations = steps = 0
    for k in range(1, nout):
        t, span = t_out[k - 1], t_out[k] - t_out[k - 1]
        substeps = max(1, int(np.ceil(span / step - 1e-9))) if step > 0.0 else 1
        h = span / substeps
        for s in range(substeps):
            ts = t + s * h
            scene_rhs(ts, y, P, D, k1)
            scene_rhs(ts + 0.5 * h, y + 0.5 * h * k1, P, D, k2)
            scene_rhs(ts + 0.5 * h, y + 0.5 * h * k2, P, D, k3)
            scene_rhs(ts + h, y + h * k3, P, D, k4)
            y = y + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            evaluations += 4
            steps += 1
            if not np.all(np.isfinite(y)):
                return Y, evaluations, steps, 0, 3, ts + h, h
        Y[k] = y
    return Y, evaluations, steps, 0, 0, t_out[-1], 0.0
