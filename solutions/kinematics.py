"""Kinematic analysis: Newton-Raphson assembly, then positions, velocities and accelerations in time.

For a mechanism whose drivers leave no degree of freedom, at each time t (course notes, ch. 4):

1. position:      solve Psi(q, t) = 0 by Newton-Raphson,  Psi_q dq = -Psi,  q <- q + dq   (eq. 4.8)
2. velocity:      Psi_q q' = -Psi_t                                                        (eq. 4.5)
3. acceleration:  Psi_q q'' = gamma                                                        (eq. 4.6)

The Jacobian at the converged positions is factored once (LU) and the factors serve steps 2 and 3
and the diagnostics (the lock-up test, the sign of det Psi_q and the pivot ratio that flags a singular
position come from U's diagonal; an SVD is taken only where they flag one, ``locate_singular_position``).
A kinematic run needs no mass matrix and no forces, and builds neither.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field

import numpy as np

from .assembly import System
from .diagnostics import AnalysisError, involved_joints, rank_report, setting_words, singular_joints
from .linalg import lu_factor, lu_solve, minimum_norm_solution, numerical_rank, solve
from .planar.bodies import rotation, rotation_derivative
from .results import KinematicInfo, Progress, Result
from .rotation_matrices import euler_rotation, g_entries
from .settings import default_engine

LOCKUP_CONDITION = 1e10
"""Condition number of Psi_q above which a configuration counts as locked (a singular position)."""

PIVOT_DIP = 0.5
"""Largest pivot ratio min |U_ii| / max |U_ii| at a local minimum that ``dip_start`` flags. The pivot ratio is
not sigma_min / sigma_max (it may stay several times above it, as at output steps far apart from a rank loss),
so the flag is loose and cheap; the rank rule decides (``locate_singular_position``)."""


@dataclass
class NewtonResult:
    q: np.ndarray
    iterations: int
    residual: float


def newton_raphson(
    system: System, q: np.ndarray, t: float, tol: float = 1e-12, max_iterations: int = 25
) -> NewtonResult:
    """Solve Psi(q, t) = 0 for q from the estimate ``q`` (eq. 4.8).

    Iterates Psi_q dq = -Psi, q <- q + dq until max|Psi| < tol. A square Jacobian is solved
    directly; a non-square one (assembly with free degrees of freedom, or redundant constraints)
    takes the least-squares, minimum-norm correction.

    Raises
    ------
    AnalysisError
        If it does not converge, naming the residual and the worst constraint.
    """
    q = np.array(q, dtype=float)
    ### BEGIN SOLUTION hw1
    for iteration in range(max_iterations + 1):
        psi = system.constraints(q, t)
        residual = float(np.max(np.abs(psi), initial=0.0))
        if residual < tol:
            return NewtonResult(q, iteration, residual)
        if not np.isfinite(residual) or iteration == max_iterations:
            break
        jac = system.jacobian(q, t)
        if jac.shape[0] == jac.shape[1]:
            try:
                dq = solve(jac, -psi)
            except np.linalg.LinAlgError:
                dq = np.linalg.lstsq(jac, -psi, rcond=None)[0]
        else:
            dq = np.linalg.lstsq(jac, -psi, rcond=None)[0]
        q = q + dq
    ### END SOLUTION
    worst = int(np.nanargmax(np.abs(psi))) if np.any(np.isfinite(psi)) else 0
    raise AnalysisError(
        f"Newton-Raphson did not converge at t = {t:.6g} s: residual {residual:.3g} after "
        f"{max_iterations} iterations, worst constraint {system.labels[worst]}"
    )


def velocity_analysis(system: System, q: np.ndarray, t: float, lu=None) -> np.ndarray:
    """q' from Psi_q q' = -Psi_t (eq. 4.5); ``lu`` is a factorization of Psi_q to reuse."""
    ### BEGIN SOLUTION hw1
    lu = lu if lu is not None else lu_factor(system.jacobian(q, t))
    return lu_solve(lu, -system.psi_t(q, t))
    ### END SOLUTION


def acceleration_analysis(system: System, q: np.ndarray, qd: np.ndarray, t: float, lu=None) -> np.ndarray:
    """q'' from Psi_q q'' = gamma (eq. 4.6); ``lu`` is a factorization of Psi_q to reuse."""
    ### BEGIN SOLUTION hw1
    lu = lu if lu is not None else lu_factor(system.jacobian(q, t))
    return lu_solve(lu, system.gamma(q, qd, t))
    ### END SOLUTION


def assemble(system: System, q0: np.ndarray, t: float = 0.0) -> tuple[np.ndarray, dict]:
    """Make the file's approximate configuration consistent: Psi(q, t) = 0 by Newton-Raphson.

    Returns the assembled q and a report of how far each body moved (translation and rotation). Where q0 is on
    the constraints already (no Newton iteration) q is q0 itself and every body's move is exactly zero, planar or
    spatial: the angle of conj(p0) p0 would be the rounding of the quaternion product alone (up to 2e-16 rad),
    no motion, and an axis-angle per body is most of a spatial call's initial conditions (a few us a body).
    """
    try:
        solution = newton_raphson(system, q0, t)
    except AnalysisError as err:
        raise AnalysisError(f"the mechanism cannot be assembled: {err}") from None
    moved = {}
    n, dim = system.coordinates_per_body, system.model.dimension
    if solution.iterations == 0:  # q0 on the constraints already: q is q0, no body moved (exactly 0, 0)
        moved = {b.name: {"translation": 0.0, "rotation": 0.0} for b in system.model.bodies}
        return solution.q, {"iterations": 0, "residual": solution.residual, "moved": moved}
    for k, name in enumerate(b.name for b in system.model.bodies):
        old, new = q0[n * k : n * k + n], solution.q[n * k : n * k + n]
        if dim == 3:  # the angle of the relative rotation conj(p0) p
            from .rotations import conjugate, normalized, quaternion_product, to_axis_angle

            rotation = to_axis_angle(quaternion_product(conjugate(normalized(old[3:])), normalized(new[3:])))[1]
        else:
            rotation = abs(new[2] - old[2])
        moved[name] = {"translation": float(np.linalg.norm(new[:dim] - old[:dim])), "rotation": float(rotation)}
    report = {"iterations": solution.iterations, "residual": solution.residual, "moved": moved}
    return solution.q, report


def require_no_freedom(system: System, q: np.ndarray, t: float = 0.0) -> None:
    """Refuse, by name, what a kinematic analysis cannot run: free or redundant constraints."""
    report = rank_report(system.jacobian(q, t), system.row_owners)
    if report.n_redundant:
        raise AnalysisError(
            f"{report.n_redundant} redundant constraint equation(s) among joints "
            f"{', '.join(report.redundant_joints)}: remove one of them or replace it by a joint with "
            "fewer equations (e.g. revolute-revolute for revolute)"
        )
    if report.degrees_of_freedom:
        raise AnalysisError(
            f"the drivers leave {report.degrees_of_freedom} degree(s) of freedom: a kinematic analysis "
            f"needs {report.degrees_of_freedom} more motor(s), or run --analysis dynamic"
        )


def _factor_checked(system: System, q: np.ndarray, t: float):
    """LU of Psi_q, refusing a locked (singular) configuration with time, condition and joints.

    The cheap test first: U's diagonal (the pivots) spans less than LOCKUP_CONDITION unless Psi_q is
    nearly singular; only then is the condition number computed (an SVD) to decide and to name the joints.
    """
    jac = system.jacobian(q, t)
    lu = lu_factor(jac)
    pivots = np.abs(lu[0].diagonal())
    if not pivots.min() > pivots.max() / LOCKUP_CONDITION:  # also a NaN
        cond, joints = singular_joints(jac, system.row_owners)
        if not cond <= LOCKUP_CONDITION:
            raise AnalysisError(
                f"lock-up or branch point at t = {t:.6g} s: Psi_q is singular (condition number "
                f"{cond:.3g}); joints involved: {', '.join(joints)}"
            )
    return lu


def dip_start(ratios: list[float], steps: int) -> int | None:
    """The first step of the interval in which the pivot ratios so far (one per step, ``pivot_ratio``) dip
    towards zero, or None: a local minimum at the step before the last, far below its neighbours, flags the two
    intervals around it; at the first and at the last step of the run, where a neighbour is missing, the one
    neighbour stands for both (the ratio mirrored). "Far below" as ``diagnostics.passes_zero`` says it (a V, not
    a smooth minimum): less than half the larger neighbour; and below PIVOT_DIP."""
    k = len(ratios) - 1

    def dips(before: float, middle: float, after: float) -> bool:
        return middle < PIVOT_DIP and middle <= min(before, after) and 2.0 * middle < max(before, after)

    if k >= 2 and dips(*ratios[-3:]):
        return k - 2
    if k == 1 and dips(ratios[1], ratios[0], ratios[1]):
        return 0
    if k >= 1 and k == steps - 1 and dips(ratios[-2], ratios[-1], ratios[-2]):
        return k - 1
    return None


def _bracket(times: np.ndarray, t: float) -> tuple[float, float]:
    """The two output times around t (t_k <= t <= t_k+1)."""
    k = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, times.size - 2))
    return float(times[k]), float(times[k + 1])


def determinant_sign(lu) -> float:
    """Sign of det(Psi_q) from its LU factors: the sign of the product of U's diagonal, flipped once per
    row swap. A change of sign between two steps means the mechanism went through a singular position."""
    factors, pivots = lu
    negative = np.count_nonzero(factors.diagonal() < 0.0) + np.count_nonzero(pivots != np.arange(pivots.size))
    return -1.0 if negative % 2 else 1.0


def pivot_ratio(lu) -> float:
    """min |U_ii| / max |U_ii| of the LU factors of Psi_q: a free, rough measure of how near Psi_q is to a rank
    loss (it is not sigma_min / sigma_max, but it falls to zero with it); 0 for a zero or NaN matrix."""
    pivots = np.abs(lu[0].diagonal())
    top = pivots.max(initial=0.0)
    return float(pivots.min() / top) if top > 0 else 0.0


def locate_singular_position(
    system: System, t_a: float, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, t_b: float
) -> dict | None:
    """The singular position in [t_a, t_b] where the pivot ratio dipped, found and decided by the rank rule.

    A kinematic run flags an interval when the pivot ratio of its steps (``pivot_ratio``) has a local minimum
    there far below its neighbours (``dip_start``). This function then minimizes r(t) = sigma_min / sigma_max
    of Psi_q (eq. 4.20) over the interval (``scipy.optimize.minimize_scalar``, bounded Brent, on
    t = t_a + s (t_b - t_a)), at configurations on the branch of the motion: the configuration already found
    nearest to t, moved by the Taylor prediction from the solved state (q, q', q'') at t_a, corrected by
    minimum-norm Newton-Raphson (eq. 4.8, as in ``branch_step``). The rule:

        a singular position is passed  when  min over t of sigma_min / sigma_max  <=  max(m, n) sqrt(eps)

    the package's rank rule (course notes, eq. 4.22; ``linalg.rank_tolerance``): at the minimum Psi_q has lost
    rank. It counts every rank lost at once, so it sees an even rank loss (one per loop of a chain of
    parallelograms) that leaves the sign of det Psi_q unchanged. A minimum above the rule (a mechanism that
    comes near a singular position and turns back from it) is no singular position and returns None. At a
    transversal crossing r(t) falls to zero along a V; the search runs to its end (t to about 1e-8 of the
    interval), so that every singular value lost there is below the rule and counted.

    Returns
    -------
    None, or {'t': time, 'q': configuration, 'ratio': sigma_min / sigma_max, 'rank_loss': ranks lost,
    'joints': joints in the lost directions (left singular vectors)}.
    """
    import scipy.optimize

    span = t_b - t_a
    solved: list[tuple[float, np.ndarray]] = [(t_a, q)]  # configurations found, to predict from the nearest
    best: dict = {}

    def taylor(t: float) -> np.ndarray:
        dt = t - t_a
        return q + qd * dt + 0.5 * qdd * dt * dt

    def ratio(s: float) -> float:
        t = t_a + s * span
        t_near, q_near = min(solved, key=lambda item: abs(item[0] - t))
        x = q_near + taylor(t) - taylor(t_near)
        for _ in range(12):
            psi = system.constraints(x, t)
            if not np.max(np.abs(psi), initial=0.0) >= 1e-12:
                break
            x = x + minimum_norm_solution(system.jacobian(x, t), -psi)
        solved.append((t, x))
        sigma = np.linalg.svd(system.jacobian(x, t), compute_uv=False)
        r = float(sigma[-1] / sigma[0]) if sigma[0] > 0 else 0.0
        if not best or r < best["ratio"]:
            best.update(t=float(t), q=x, ratio=r)
        return r

    scipy.optimize.minimize_scalar(ratio, bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-12})
    jacobian = system.jacobian(best["q"], best["t"])
    u, sigma, _ = np.linalg.svd(jacobian)
    rank = numerical_rank(sigma, jacobian.shape)
    if rank >= min(jacobian.shape):
        return None
    best["rank_loss"] = min(jacobian.shape) - rank
    best["joints"] = involved_joints(u[:, rank:], system.row_owners, share=0.1)
    return best


def kinematic_analysis(
    system: System,
    q0: np.ndarray,
    t_end: float,
    steps: int,
    points: dict[str, tuple[int, np.ndarray]] | None = None,
    through_singular: bool = False,
    engine: str | None = None,
    progress: Progress | None = None,
) -> Result:
    """Positions, velocities and accelerations on the grid t = 0, t_end/steps, ..., t_end.

    Parameters
    ----------
    system : the assembled planar system; its drivers must leave no degree of freedom
    q0 : approximate configuration at t = 0 (assembled first)
    t_end, steps : output grid
    points : optional {label: (body index, body-frame point)} whose position, velocity and
        acceleration are added to the result as columns 'label.x', 'label.x_d', ...
    through_singular : at a singular position go on along the branch the velocities point to
        (``branch_step``) and list the position in ``info['singular_positions']`` (time, joints, the two
        output times around it) instead of stopping with an AnalysisError
    engine : ``auto``, ``numpy``, ``compiled`` or ``cached``, as for ``forward_dynamics`` (``settings.Settings``;
        None: ``auto``, or ``$MBD_ENGINE``); the compiled steps stop at the first step where anything unusual happens
        and the numpy steps go on from there (``_compiled_steps``); ``info['chosen']`` says which and why
    progress : optional ``progress(t)``, called with each output time the numpy steps reach

    Each step: q predicted from the last step and corrected by Newton-Raphson (eq. 4.8, ``position_step``),
    a stop at a singular position (``check_branch``), q' (eq. 4.5) and q'' (eq. 4.6) with Psi_q's LU factors.

    Raises
    ------
    AnalysisError
        Degrees of freedom left, redundant constraints, lock-up, non-convergence: by name.
    """
    engine = engine or default_engine()
    if through_singular:
        result = _kinematics_through_singular(system, q0, t_end, steps, points)
        if engine != "numpy":
            result.info["chosen"] = {"engine": "numpy", "engine_why": "through_singular runs on the numpy engine"}
        return result
    start = _time.perf_counter()
    q, assembly = assemble(system, q0, 0.0)  # 1. assembly at t = 0
    require_no_freedom(system, q, 0.0)
    march = KinematicSteps.empty(system, np.linspace(0.0, t_end, steps + 1))
    if engine != "numpy":  # the compiled steps fill the first rows
        _compiled_steps(engine, march, q)
    for k in range(march.first, march.times.size):  # 2. the steps
        kinematic_step(march, k, q if k == 0 else march.predict(k))
        if progress is not None:
            progress(float(march.times[k]))
    info: KinematicInfo = {
        "analysis": "kinematic",
        "steps": steps,
        "newton_iterations": march.iterations,
        "max_constraint_residual": march.max_residual,
        "assembly": assembly,
        "wall_time": _time.perf_counter() - start,
    }
    if march.chosen is not None:
        info["chosen"] = march.chosen
    return _result(system, march.times, march.Q, march.QD, march.QDD, info, points)


@dataclass
class KinematicSteps:
    """The output times of a kinematic analysis and what its steps have found so far."""

    system: System
    times: np.ndarray
    Q: np.ndarray
    QD: np.ndarray
    QDD: np.ndarray
    first: int = 0
    """The first step the numpy loop takes (the compiled steps took those before)."""
    iterations: int = 0
    max_residual: float = 0.0
    ratios: list = field(default_factory=list)
    """The pivot ratio of Psi_q's LU factors at every step (``diagnostics.pivot_ratio``)."""
    sign: int | None = None
    """The sign of det Psi_q at the last step."""
    chosen: dict | None = None

    @classmethod
    def empty(cls, system: System, times: np.ndarray) -> KinematicSteps:
        n = system.n_coordinates
        return cls(system, times, *(np.empty((times.size, n)) for _ in range(3)))

    def predict(self, k: int) -> np.ndarray:
        """q at step k by the second-order Taylor predictor from step k - 1."""
        dt = self.times[k] - self.times[k - 1]
        return self.Q[k - 1] + self.QD[k - 1] * dt + 0.5 * self.QDD[k - 1] * dt * dt


def kinematic_step(march: KinematicSteps, k: int, q: np.ndarray) -> None:
    """Step k from the prediction q: the position (``position_step``), a stop at a singular position passed
    (``check_branch``), q' (eq. 4.5) and q'' (eq. 4.6) with Psi_q's LU factors, stored in row k of ``march``."""
    system, t = march.system, march.times[k]
    q = position_step(march, k, q)
    lu = _factor_checked(system, q, t)
    check_branch(march, k, q, lu)
    qd = velocity_analysis(system, q, t, lu)
    march.Q[k], march.QD[k], march.QDD[k] = q, qd, acceleration_analysis(system, q, qd, t, lu)


def position_step(march: KinematicSteps, k: int, q: np.ndarray) -> np.ndarray:
    """Position analysis at step k from the prediction q: Newton-Raphson (eq. 4.8); a failure is reported as a
    lock-up or branch point, with the condition of Psi_q at the last position found and the joints involved."""
    system, t = march.system, march.times[k]
    try:
        solution = newton_raphson(system, q, t)
    except AnalysisError as err:
        # judge the last position found, next to the singular one (not the predictor beyond it)
        last, t_last = (march.Q[k - 1], march.times[k - 1]) if k > 0 else (q, t)
        cond, joints = singular_joints(system.jacobian(last, t_last), system.row_owners)
        raise AnalysisError(
            f"lock-up or branch point near t = {t:.6g} s: {err}; Psi_q condition number {cond:.3g} "
            f"at t = {t_last:.6g} s, joints involved: {', '.join(joints)}"
        ) from None
    march.iterations += solution.iterations
    march.max_residual = max(march.max_residual, solution.residual)
    return solution.q


def check_branch(march: KinematicSteps, k: int, q: np.ndarray, lu) -> None:
    """Stop at a singular position passed between steps k - 1 and k, where the mechanism can switch assembly
    branch: det Psi_q changed sign (an odd rank loss), or the pivot ratio of the LU factors dipped
    (``diagnostics.passes_zero``) and the minimum of sigma_min / sigma_max on the interval is below the rank
    rule of eq. 4.22 (``locate_singular_position``: an even rank loss, which keeps the sign of det Psi_q).
    The SVDs of that search are taken only at a dip, never at an ordinary step."""
    system, times, t = march.system, march.times, march.times[k]
    sign = determinant_sign(lu)
    march.ratios.append(pivot_ratio(lu))
    first = dip_start(march.ratios, times.size)
    hint = f"{setting_words('through_singular', True)} goes on along the branch of the velocities"
    if first is not None and sign == march.sign:
        found = locate_singular_position(system, times[first], march.Q[first], march.QD[first], march.QDD[first], t)
        if found is not None:
            after, before = _bracket(times, found["t"])
            raise AnalysisError(
                f"branch point passed between t = {after:.6g} s and t = {before:.6g} s: Psi_q loses "
                f"{found['rank_loss']} rank(s) at t = {found['t']:.6g} s (sigma_min / sigma_max = "
                f"{found['ratio']:.2g}), a singular position where the mechanism can switch assembly branch "
                f"though det(Psi_q) keeps its sign; joints involved: {', '.join(found['joints'])}; {hint}"
            )
    if march.sign is not None and sign != march.sign:
        _, joints = singular_joints(system.jacobian(q, t), system.row_owners)
        raise AnalysisError(
            f"branch point passed between t = {times[k - 1]:.6g} s and t = {t:.6g} s: det(Psi_q) changed "
            "sign, so the mechanism went through a singular position where it can switch assembly "
            f"branch; joints involved: {', '.join(joints)}; {hint}"
        )
    march.sign = sign


def _compiled_steps(engine: str, march: KinematicSteps, q: np.ndarray) -> None:
    """The steps the compiled engine takes (``solutions.compiled.kinematic``), from the assembled q at t = 0:
    rows 0 .. k-1 of the history filled, with the counts, pivot ratios and det sign; the numpy loop goes on
    from step k (``march.first``)."""
    try:
        from .compiled import kinematic
    except ImportError:  # a student package: the compiled engine stays with the instructor
        march.chosen = {"engine": "numpy", "engine_why": "this package has no compiled engine"}
        return
    found = kinematic.steps(engine, march.system, q, march.times, march.Q, march.QD, march.QDD)
    march.first, march.iterations, march.max_residual, march.ratios, march.sign, march.chosen = found


def _result(system: System, times, Q, QD, QDD, info: dict, points) -> Result:
    """The Result of a kinematic analysis, with the columns of the requested points."""
    result = Result(
        t=times,
        q=Q,
        qd=QD,
        qdd=QDD,
        coordinate_names=system.coordinate_names,
        body_names=[b.name for b in system.model.bodies],
        info=info,
    )
    for label, (body, point) in (points or {}).items():
        result.points.update(point_columns(result, label, body, point))
    return result


def branch_step(
    system: System,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    t: float,
    tol: float = 1e-12,
    max_iterations: int = 25,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, velocities and accelerations at t on the branch that the predicted (q, q', q'') follow
    (eq. 4.9): every solve takes the correction of least norm to the prediction, with the rank of Psi_q by the
    package's rule (``linalg.minimum_norm_solution``), so that where Psi_q has lost rank the solution stays the
    one nearest to the prediction, the branch the motion was on:

        q   <- q + dq,        dq   = argmin |dq|   subject to Psi_q dq = -Psi     (Newton-Raphson, repeated)
        q'  = q'_p + dv,      dv   = argmin |dv|   subject to Psi_q dv = -Psi_t - Psi_q q'_p
        q'' = q''_p + da,     da   = argmin |da|   subject to Psi_q da = gamma - Psi_q q''_p

    Away from singular positions these are the unique solutions of eq. 4.8, 4.5 and 4.6.

    Raises
    ------
    AnalysisError
        If Newton-Raphson does not converge.
    """
    for _ in range(max_iterations):
        psi = system.constraints(q, t)
        if not np.max(np.abs(psi), initial=0.0) >= tol:
            break
        q = q + minimum_norm_solution(system.jacobian(q, t), -psi)
    else:
        raise AnalysisError(
            f"Newton-Raphson did not converge at t = {t:.6g} s on the branch of the predicted motion "
            f"(residual {np.max(np.abs(psi)):.3g}); use more --steps"
        )
    jacobian = system.jacobian(q, t)
    qd = qd + minimum_norm_solution(jacobian, -system.psi_t(q, t) - jacobian @ qd)
    qdd = qdd + minimum_norm_solution(jacobian, system.gamma(q, qd, t) - jacobian @ qdd)
    return q, qd, qdd


def _kinematics_through_singular(system, q0, t_end, steps, points) -> Result:
    """``kinematic_analysis(..., through_singular=True)``: each step predicts (q, q', q'') from the last one
    (Taylor, second order) and corrects on its branch (``branch_step``); a singular position found on the way
    (``record_crossing``) is recorded, with the time and the joints, and passed."""
    start = _time.perf_counter()
    q, assembly = assemble(system, q0, 0.0)
    require_no_freedom(system, q, 0.0)
    march = KinematicSteps.empty(system, np.linspace(0.0, t_end, steps + 1))
    lu = lu_factor(system.jacobian(q, 0.0))
    qd = velocity_analysis(system, q, 0.0, lu)
    qdd = acceleration_analysis(system, q, qd, 0.0, lu)
    march.sign = determinant_sign(lu)
    crossings: list[dict] = []
    for k, t in enumerate(march.times):
        if k > 0:
            dt = t - march.times[k - 1]
            prediction = (q + qd * dt + 0.5 * qdd * dt * dt, qd + qdd * dt, qdd)
            q, qd, qdd = branch_step(system, *prediction, t)
        record_crossing(march, crossings, k, q)
        march.Q[k], march.QD[k], march.QDD[k] = q, qd, qdd
    for crossing in crossings:
        del crossing["step"]
    pairs = zip(march.Q, march.times, strict=True)
    residual = max(np.max(np.abs(system.constraints(qk, tk)), initial=0.0) for qk, tk in pairs)
    info: KinematicInfo = {
        "analysis": "kinematic",
        "steps": steps,
        "max_constraint_residual": float(residual),
        "assembly": assembly,
        "singular_positions": crossings,
        "warnings": [
            f"singular position at t = {c['t']:.6g} s, between t = {c['after']:.6g} s and "
            f"t = {c['until']:.6g} s (joints {', '.join(c['joints'])}): passed on the branch of the velocities"
            for c in crossings
        ],
        "wall_time": _time.perf_counter() - start,
    }
    return _result(system, march.times, march.Q, march.QD, march.QDD, info, points)


def record_crossing(march: KinematicSteps, crossings: list[dict], k: int, q: np.ndarray) -> None:
    """At step k of a run through singular positions: a sign change of det Psi_q, a condition number above
    LOCKUP_CONDITION or a dip of the pivot ratio confirmed by the rank rule (``locate_singular_position``,
    which also gives its time) adds a singular position to ``crossings`` (or extends the last one)."""
    system, times, t = march.system, march.times, march.times[k]
    jacobian = system.jacobian(q, t)
    lu = lu_factor(jacobian)
    sign, ratio = determinant_sign(lu), pivot_ratio(lu)
    locked = not ratio > 1.0 / LOCKUP_CONDITION
    # a dip of the pivot ratio also flags a crossing: an even rank loss (one per loop of a chain of
    # parallelograms) leaves the sign of det Psi_q as it was; the rank rule decides (locate_singular_position)
    march.ratios.append(ratio)
    dip = dip_start(march.ratios, times.size)
    flagged = sign != march.sign or locked
    first = max(k - 1, 0) if flagged else dip
    march.sign = sign
    if (flagged or dip is not None) and crossings and crossings[-1]["step"] >= first:
        crossings[-1]["step"] = max(crossings[-1]["step"], k) if flagged else crossings[-1]["step"]
        return
    if not (flagged or dip is not None):
        return
    found = None
    if k > 0:
        found = locate_singular_position(system, times[first], march.Q[first], march.QD[first], march.QDD[first], t)
    if found is not None:
        after, until = _bracket(times, found["t"])
        crossings.append({"t": found["t"], "after": after, "until": until, "step": k, "joints": found["joints"],
                          "condition": 1.0 / max(found["ratio"], 1e-300), "rank_loss": found["rank_loss"]})  # fmt: skip
    elif flagged:  # a sign flip or a lock-up is a singular position whatever the search found
        cond, joints = singular_joints(jacobian, system.row_owners)
        crossings.append({"t": float(t), "after": float(times[max(k - 1, 0)]), "until": float(t), "step": k,
                          "joints": joints, "condition": cond})  # fmt: skip


def point_kinematics(q, qd, qdd, body: int, point: np.ndarray):
    """Position, velocity and acceleration of a body-fixed point over time (eq. 2.10-2.12):

    r^P = r + A s',  r^P' = r' + B s' phi',  r^P'' = r'' + B s' phi'' - A s' phi'^2.
    """
    cols = slice(3 * body, 3 * body + 3)
    r, rd, rdd = q[:, cols], qd[:, cols], qdd[:, cols]
    A = np.array([rotation(phi) for phi in r[:, 2]])
    B = np.array([rotation_derivative(phi) for phi in r[:, 2]])
    As, Bs = A @ point, B @ point
    position = r[:, :2] + As
    velocity = rd[:, :2] + Bs * rd[:, 2:3]
    acceleration = rdd[:, :2] + Bs * rdd[:, 2:3] - As * rd[:, 2:3] ** 2
    return position, velocity, acceleration


def spatial_point_kinematics(q, qd, qdd, body: int, point: np.ndarray):
    """Position, velocity and acceleration of a body-fixed point of a spatial body over time (eq. 8.16):

    r^P = r + A s',  r^P' = r' + omega x A s',  r^P'' = r'' + omega' x A s' + omega x (omega x A s'),

    with omega = 2 G(p) p' and omega' = 2 G(p) p'' (G p' is orthogonal to p', so G' p' = 0).
    """
    cols = slice(7 * body, 7 * body + 7)
    r, rd, rdd = q[:, cols], qd[:, cols], qdd[:, cols]
    position, velocity, acceleration = (np.empty((len(q), 3)) for _ in range(3))
    for k in range(len(q)):
        omega, alpha = angular_rates(r[k, 3:], rd[k, 3:], rdd[k, 3:])
        As = euler_rotation(r[k, 3:] / np.linalg.norm(r[k, 3:])) @ point
        position[k] = r[k, :3] + As
        velocity[k] = rd[k, :3] + np.cross(omega, As)
        acceleration[k] = rdd[k, :3] + np.cross(alpha, As) + np.cross(omega, np.cross(omega, As))
    return position, velocity, acceleration


def angular_rates(p: np.ndarray, pd: np.ndarray, pdd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """omega = 2 G(p) p' and its rate omega' = 2 G(p) p'' (global frame, eq. 8.16)."""
    G = np.array(g_entries(*map(float, p))).reshape(3, 4)
    return 2.0 * G @ pd, 2.0 * G @ pdd


def point_columns(result: Result, label: str, body: int, point: np.ndarray) -> dict[str, np.ndarray]:
    """Columns 'label.x', 'label.y' (spatial: and 'label.z') and their _d, _dd for a body point."""
    spatial = np.asarray(point).size == 3
    kinematics = spatial_point_kinematics if spatial else point_kinematics
    position, velocity, acceleration = kinematics(result.q, result.qd, result.qdd, body, point)
    columns = {}
    for suffix, values in (("", position), ("_d", velocity), ("_dd", acceleration)):
        for k, axis in enumerate("xyz" if spatial else "xy"):
            columns[f"{label}.{axis}{suffix}"] = values[:, k]
    return columns


def rotation_columns(result: Result, bodies: list[str]) -> dict[str, np.ndarray]:
    """For each spatial body: angular velocity, global 'B.wx .wy .wz' = 2 G p' and body-frame 'B.wx_body ..'
    = A^T omega (eq. 8.16); angular acceleration, global 'B.wx_d ..' = omega' = 2 G p'' and body-frame
    'B.wx_body_d ..' = A^T omega' (the rate of A^T omega too: its other term A'^T omega = -A^T omega~ omega is
    zero); and the rotation matrix 'B.A11' .. 'B.A33' (eq. 8.12)."""
    columns: dict[str, np.ndarray] = {}
    for b, name in enumerate(bodies):
        p, pd, pdd = (x[:, 7 * b + 3 : 7 * b + 7] for x in (result.q, result.qd, result.qdd))
        A = np.array([euler_rotation(pk / np.linalg.norm(pk)) for pk in p])
        omega, alpha = (np.array(w) for w in zip(*map(angular_rates, p, pd, pdd), strict=True))
        local, local_rate = (np.einsum("kji,kj->ki", A, w) for w in (omega, alpha))
        for i, axis in enumerate("xyz"):
            columns[f"{name}.w{axis}"] = omega[:, i]
            columns[f"{name}.w{axis}_body"] = local[:, i]
        for i, axis in enumerate("xyz"):
            columns[f"{name}.w{axis}_d"] = alpha[:, i]
            columns[f"{name}.w{axis}_body_d"] = local_rate[:, i]
        for i in range(3):
            for j in range(3):
                columns[f"{name}.A{i + 1}{j + 1}"] = A[:, i, j]
    return columns
