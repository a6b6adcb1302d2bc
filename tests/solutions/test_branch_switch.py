"""Issue 29, item 2: a run through singular positions stays on the physical branch, or says so.

The chain of N parallelogram four-bars of benchmarks/chains.py (``loop_chain``: cranks 0.5 m, 60 degrees from the
vertical, thrown at 8 rad/s) swings through its flat positions, where Psi_q loses one rank per loop (N at once:
det Psi_q keeps its sign for even N). Joint coordinates with cut joints used to leave the parallelogram branch there
and finish with exit 0, no warning and the bodies 0.4 m off. The truth is ``loop_reference``: the chain's one
equation in the crank angle, integrated by scipy at 1e-12 (no code of the package), the parallelogram branch
through every flat position. Each run, on both engines and with the bodies written both ways (frames at the centres
of mass, and at the joints with ``com:``), must stay within 1e-6 m of it or stop or warn by name.
"""

from __future__ import annotations

import importlib.util
import math
import sys
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import chains  # noqa: E402
from solutions.assembly import build_system  # noqa: E402
from solutions.cli import main  # noqa: E402
from solutions.diagnostics import AnalysisError, BranchSwitchError  # noqa: E402
from solutions.dynamics import forward_dynamics  # noqa: E402
from solutions.guard import BRANCH_JUMP, Guard, branch_verdict  # noqa: E402
from solutions.io.model import load_model  # noqa: E402

ANGLE, RATE, TOL = math.radians(60.0), 8.0, 7e-10
SPANS = {1: 1.35, 2: 1.35, 10: 1.35, 40: 0.2}
"""Seconds run: three flat positions (t = 0.07, 0.9 to 1.0, 1.28 s), the N = 40 chain its first only."""


@cache
def reference(n: int) -> tuple[np.ndarray, np.ndarray]:
    times = np.linspace(0.0, SPANS[n], round(100 * SPANS[n]) + 1)
    return times, chains.loop_reference(n, times, ANGLE, RATE)


@cache
def outcome(n: int, engine: str, frames: str) -> tuple[str, object]:
    """('result', Result) or ('stopped', the AnalysisError) of the joint-coordinates run."""
    system, q0, qd0 = build_system(load_model(chains.loop_chain(n, ANGLE, RATE, frames)))
    times, _ = reference(n)
    try:
        result = forward_dynamics(
            system, q0, qd0, times[-1], times.size - 1, "joint-coordinates", "dop853", rtol=TOL, atol=TOL, engine=engine
        )
    except AnalysisError as err:
        return "stopped", err
    return "result", result


def test_the_reference_passes_flat_positions():
    """The crank centres' height 0.25 sin(theta) changes sign at every flat position: three in 1.35 s, one in 0.2 s."""
    for n, crossings in ((2, 3), (40, 1)):
        _, truth = reference(n)
        assert np.count_nonzero(np.diff(np.sign(truth[:, 0, 1]))) == crossings


@pytest.mark.parametrize("frames", ["centre", "joint"])
@pytest.mark.parametrize("engine", ["numpy", "compiled"])
@pytest.mark.parametrize("n", [1, 2, 10, 40])
def test_joint_coordinates_stay_on_the_physical_branch_or_say_so(n, engine, frames):
    kind, found = outcome(n, engine, frames)
    if kind == "stopped":
        message = str(found)
        assert ("singular configuration" in message or "branch switch" in message) and "t = " in message, message
        return
    assert found.info["formulation"] == "joint-coordinates"
    if engine == "compiled":  # or handed to numpy, where it passed near a singular position between output times
        chosen = found.info["chosen"]
        assert chosen["engine"] == "compiled" or "passed near a singular position" in chosen["engine_why"], chosen
    if any(w.startswith("branch:") for w in found.info["warnings"]):
        return
    _, truth = reference(n)
    centres = found.q.reshape(found.t.size, -1, 3)[:, :, :2]
    assert np.max(np.linalg.norm(centres - truth, axis=-1)) < 1e-6
    passed = found.info["singular_positions"]
    assert passed and all(c["branch"] == "kept" for c in passed)  # judged, not missed


@pytest.mark.parametrize("engine", ["numpy", "compiled"])
def test_a_run_that_leaves_the_branch_unchecked_stops_by_name_checked(engine, monkeypatch):
    """N = 2: the same runs with the Guard's branch check switched off. Each that leaves the parallelogram (here all
    four: 0.39-0.45 m off from t = 1.29 s, exit 0, no warning) stops with the check, naming the branch switch near
    its time and what to try; one that stays on it (rounding decides, so another machine may differ) is unchanged.
    N = 10 passes its two flat positions, each judged 'kept'."""
    _, truth = reference(2)
    for frames in ("centre", "joint"):
        with monkeypatch.context() as patch:
            patch.setattr(Guard, "check_branches", lambda *args, **kwargs: None)
            patch.setattr(Guard, "check_branches_before", lambda *args, **kwargs: None)
            kind, unchecked = outcome.__wrapped__(2, engine, frames)
        kind_checked, checked = outcome(2, engine, frames)
        if kind == "stopped":  # stopped by the other checks already: so it is with the branch check
            assert kind_checked == "stopped"
            continue
        error = np.linalg.norm(unchecked.q.reshape(truth.shape[0], -1, 3)[:, :, :2] - truth, axis=-1).max(axis=1)
        if error.max() < 1e-6:
            assert kind_checked == "result" and np.array_equal(checked.q, unchecked.q)
            continue
        left = float(reference(2)[0][np.argmax(error > 1e-6)])  # the first output time off the reference
        assert kind_checked == "stopped" and isinstance(checked, BranchSwitchError), checked
        near = float(str(checked).split("near t = ")[1].split(" s")[0])
        assert left - 0.02 <= near <= left and "augmented-lagrangian" in str(checked)
    kind, result = outcome(10, engine, "centre")
    assert kind == "result" and [c["branch"] for c in result.info["singular_positions"]] == ["kept"] * 2


def test_auto_restarts_where_joint_coordinates_switch(tmp_path, capsys):
    """``mbd run`` with joint coordinates stops with one line and exit code 2; the augmented Lagrangian run of the
    same chain follows the reference through the three flat positions."""
    model = chains.loop_chain(2, ANGLE, RATE)
    path = tmp_path / "loops.yaml"
    path.write_text(yaml.safe_dump(model))
    argv = ["run", str(path), "--t-end", "1.35", "--steps", "135", "--rtol", str(TOL), "--atol", str(TOL)]
    code = main([*argv, "--formulation", "joint-coordinates", "--integrator", "dop853", "--engine", "numpy"])
    err = capsys.readouterr().err
    assert code == 2 and "branch switch" in err and "Traceback" not in err
    system, q0, qd0 = build_system(load_model(model))
    times, truth = reference(2)
    result = forward_dynamics(system, q0, qd0, times[-1], times.size - 1, "augmented-lagrangian", "dop853",
                              rtol=TOL, atol=TOL, engine="numpy")  # fmt: skip
    centres = result.q.reshape(times.size, -1, 3)[:, :, :2]
    assert np.max(np.linalg.norm(centres - truth, axis=-1)) < 1e-6
    assert [c.get("branch") for c in result.info["singular_positions"]].count("kept") == 3


def test_branch_verdict_on_motions_made_by_hand():
    """One body (a unit disc of radius of gyration 1) turning at w = 2 rad/s about a pivot 1 m off its centre,
    sampled h = 0.01 s apart: kept; the same with the velocity reversed at the second sample (a switch that turns
    it back): switched; samples 1 s apart (the velocity turns by 2 rad between them): cannot tell."""
    weights = np.ones((1, 3))
    bodies = [type("Body", (), {"name": "disc"})()]
    w = 2.0

    def state(t: float, sign: float = 1.0):
        a = w * t
        qd = sign * np.array([-w * math.sin(a), w * math.cos(a), w])
        qdd = np.array([-w * w * math.cos(a), -w * w * math.sin(a), 0.0])
        return qd, qdd

    assert branch_verdict(weights, 0.01, state(0.3), state(0.31), bodies)[0] == "kept"
    verdict, jump, body = branch_verdict(weights, 0.01, state(0.3), state(0.31, -1.0), bodies)
    assert (verdict, body) == ("switched", "disc") and jump > 2 * w  # twice the centre's speed, at least
    assert branch_verdict(weights, 1.0, state(0.3), state(1.3), bodies)[0] == "cannot tell"
    # a body stopped dead (the crank a folding parallelogram leaves flat): a change of its whole speed
    stopped = (np.zeros(3), np.zeros(3))
    assert branch_verdict(weights, 0.01, state(0.3), stopped, bodies)[0] == "switched"
    assert BRANCH_JUMP < 0.5


# -- the index-3 integrators (hht, generalized-alpha: solutions/implicit.py) ---------------------------------------
INDEX3_TOL = 1e-6
"""rtol = atol of the index-3 runs: a few hundred steps over 1.35 s; second order, so 2-3 mm off the reference
(each run says so: its accuracy warning), where a branch switch puts bodies 0.4 m off."""


def flat_times(n: int) -> np.ndarray:
    """When the reference chain is flat (the cranks' centres at height 0, interpolated between output times)."""
    times, truth = reference(n)
    height = truth[:, 0, 1]
    k = np.flatnonzero(np.diff(np.sign(height)))
    return times[k] - height[k] * (times[k + 1] - times[k]) / (height[k + 1] - height[k])


@cache
def index3_outcome(n: int, integrator: str, frames: str, steps: int | None = None, engine: str = "numpy"):
    """('result', Result) or ('stopped', the AnalysisError) of an index-3 run of the chain over SPANS[n], with the
    output times of ``reference`` (or ``steps`` of them)."""
    system, q0, qd0 = build_system(load_model(chains.loop_chain(n, ANGLE, RATE, frames)))
    times, _ = reference(n)
    try:
        result = forward_dynamics(system, q0, qd0, times[-1], steps or times.size - 1, "auto", integrator,
                                  rtol=INDEX3_TOL, atol=INDEX3_TOL, engine=engine)  # fmt: skip
    except AnalysisError as err:
        return "stopped", err
    return "result", result


def centre_error(result, n: int) -> float:
    """The largest distance of a body centre from the reference (m), at the reference's output times."""
    times, truth = reference(n)
    k = np.searchsorted(times, result.t - 1e-12)
    assert np.allclose(times[k], result.t)
    return float(np.max(np.linalg.norm(result.q.reshape(result.t.size, -1, 3)[:, :, :2] - truth[k], axis=-1)))


@pytest.mark.parametrize("frames", ["centre", "joint"])
@pytest.mark.parametrize("integrator", ["hht", "generalized-alpha"])
@pytest.mark.parametrize("n", [1, 2])
def test_index3_integrators_stay_on_the_physical_branch_or_say_so(n, integrator, frames):
    """Through the three flat positions: on the reference within the run's accuracy, with every crossing recorded
    near the reference's flat times and judged 'kept' (or a stop or warning by name)."""
    kind, found = index3_outcome(n, integrator, frames)
    if kind == "stopped":
        message = str(found)
        assert ("singular configuration" in message or "branch switch" in message) and "t = " in message, message
        return
    assert found.info["integrator"] == integrator
    if any(w.startswith("branch:") for w in found.info["warnings"]):
        return
    error = centre_error(found, n)
    assert error < 1e-2  # a switch: 0.4 m
    assert any(w.startswith("accuracy:") for w in found.info["warnings"])  # 2-3 mm is more than 1e-6 L: it says so
    passed = found.info["singular_positions"]
    assert [c["branch"] for c in passed] == ["kept"] * 3, passed
    assert np.allclose([c["t"] for c in passed], flat_times(n), atol=0.01)


def test_index3_crossings_between_output_times_are_judged():
    """Output times 0.05 s apart (27 over 1.35 s): each of the three flat positions is recorded at a step between
    two output times, near the reference's, and judged from the steps around it: 'kept'."""
    kind, coarse = index3_outcome(2, "hht", "centre", steps=27)
    assert kind == "result"
    passed = coarse.info["singular_positions"]
    assert [c["branch"] for c in passed] == ["kept"] * 3, passed
    assert np.allclose([c["t"] for c in passed], flat_times(2), atol=0.01)
    assert not np.any(np.isin([c["t"] for c in passed], coarse.t))  # each found at a step between output times
    assert centre_error(coarse, 2) < 1e-2


def test_index3_runs_on_numpy_whatever_the_engine_asked_and_says_why():
    """One verdict: the compiled engine has no index-3 integrator, so ``engine="compiled"`` gives the numpy run, bit
    for bit, and says so."""
    _, numpy_run = index3_outcome(2, "hht", "centre")
    kind, asked = index3_outcome(2, "hht", "centre", engine="compiled")
    assert kind == "result" and np.array_equal(asked.q, numpy_run.q)
    assert asked.info["chosen"]["engine"] == "numpy" and "index-3" in asked.info["chosen"]["engine_why"]


def test_an_index3_run_that_leaves_the_branch_stops_by_name(monkeypatch):
    """A branch switch made by hand: the velocities reversed at the first step past the first flat position
    (t = 0.072 s), the accelerations kept (a motion that turns back there, as a folding crank does). Unchecked, the
    run completes and ends 0.4 m and more off the reference, with no branch warning; checked, it stops with the
    branch switch named near t = 0.072 s."""
    from solutions import implicit

    step = implicit.Index3Stepper.step
    flat = float(flat_times(1)[0])

    def reversing(self, t, h, *state):
        new = step(self, t, h, *state)
        if new is not None and t < flat + 5e-4 <= t + h:
            return (new[0], -new[1], *new[2:])
        return new

    monkeypatch.setattr(implicit.Index3Stepper, "step", reversing)
    with monkeypatch.context() as patch:
        patch.setattr(Guard, "check_branches", lambda *args, **kwargs: None)
        patch.setattr(Guard, "check_branches_before", lambda *args, **kwargs: None)
        kind, unchecked = index3_outcome.__wrapped__(1, "hht", "centre")
    assert kind == "result" and centre_error(unchecked, 1) > 0.1
    assert not any(w.startswith("branch:") for w in unchecked.info["warnings"])
    kind, checked = index3_outcome.__wrapped__(1, "hht", "centre")
    assert kind == "stopped" and isinstance(checked, BranchSwitchError), checked
    near = float(str(checked).split("near t = ")[1].split(" s")[0])
    assert abs(near - flat) < 0.005 and "augmented-lagrangian" in str(checked)


def test_an_index3_run_checks_the_drift_as_the_others():
    """The Guard's drift check at the output times, with its message: a fixed step (no tolerance to loosen the limit)
    and a limit below the round-off of the constraints (1e-16 of the size) stop the run at an output time."""
    system, q0, qd0 = build_system(load_model(chains.loop_chain(1, ANGLE, RATE)))
    drift = r"constraint drift at t = 0\.0[1-5] s: the positions are .* m off constraint"
    with pytest.raises(AnalysisError, match=drift):
        forward_dynamics(system, q0, qd0, 0.05, 5, "auto", "hht", step=0.005, drift_limit=1e-16, engine="numpy")


def test_an_index3_run_whose_newton_iterations_fail_at_a_singular_position_says_so():
    """N = 2 at a fixed step of 1 ms: a step lands next to the second flat position (t = 0.903 s), where the iteration
    matrix loses rank with Psi_q, and Newton fails (here; rounding decides, so another machine may pass it: then the
    run is judged as the others). The stop names the singular position, its joints, and what to try."""
    system, q0, qd0 = build_system(load_model(chains.loop_chain(2, ANGLE, RATE)))
    times, _ = reference(2)
    try:
        result = forward_dynamics(system, q0, qd0, times[-1], times.size - 1, "auto", "hht", step=0.001, engine="numpy")
    except AnalysisError as err:
        message = str(err)
        assert "Newton iterations did not converge" in message and "next to a singular position" in message
        t = float(message.split("The last step, at t = ")[1].split(" s")[0])
        assert abs(t - flat_times(2)[1]) < 0.005 and "joints o0, o1, o2" in message, message
        return
    assert centre_error(result, 2) < 1e-2
    assert [c["branch"] for c in result.info["singular_positions"]] == ["kept"] * 3


def test_a_crossing_recorded_between_coarse_output_times_gets_a_verdict():
    """The augmented Lagrangian records the singular positions it passes step by step (``through``); where the
    output times are too coarse for a dip to show at them (9 intervals over 1.35 s: 0.15 s apart), each such
    crossing is judged over the output interval that holds it: every one has a verdict, and the velocities cannot
    tell over 0.15 s, so the run says so by name (it stayed on the branch: within 1e-6 m of the reference)."""
    system, q0, qd0 = build_system(load_model(chains.loop_chain(2, ANGLE, RATE)))
    result = forward_dynamics(system, q0, qd0, SPANS[2], 9, "augmented-lagrangian", "dop853", divergence="skip")
    crossings = result.info["singular_positions"]
    assert len(crossings) == 3 and all(c.get("branch") in ("kept", "cannot tell") for c in crossings), crossings
    warned = [w for w in result.info["warnings"] if w.startswith("branch: cannot tell")]
    assert len(warned) == 1 and all(f"{c['t']:.6g}" in warned[0] for c in crossings if c["branch"] == "cannot tell")
    truth = chains.loop_reference(2, result.t, ANGLE, RATE)
    assert np.max(np.abs(result.q.reshape(len(result.t), -1, 3)[:, :, :2] - truth)) < 1e-6


def test_the_whole_array_prefilter_flags_every_step_the_verdict_calls_a_switch():
    """``possible_switches`` (all steps at once) keeps every step ``branch_verdict`` (one step) calls 'switched'
    and drops the smooth ones: two bodies moving as q' = sin(w t) (q'' its derivative), then one body's
    velocity reversed from sample 6 on (a switch between samples 5 and 6), and a smaller kink at 12."""
    from solutions.guard import possible_switches

    t = np.linspace(0.0, 1.0, 21)
    qd = np.stack([np.sin(3.0 * t + phase) for phase in np.linspace(0.0, 1.0, 6)], axis=1)
    qdd = np.stack([3.0 * np.cos(3.0 * t + phase) for phase in np.linspace(0.0, 1.0, 6)], axis=1)
    qd[6:, :3] *= -1.0
    qdd[6:, :3] *= -1.0
    qd[12:, 3] += 0.3
    weights, bodies = np.ones((2, 3)), [type("Body", (), {"name": name}) for name in ("a", "b")]
    steps = np.arange(t.size - 1)
    flagged = possible_switches(weights, t, qd, qdd, steps)
    verdicts = [branch_verdict(weights, t[k + 1] - t[k], (qd[k], qdd[k]), (qd[k + 1], qdd[k + 1]), bodies)[0]
                for k in steps]  # fmt: skip
    switched = {k for k in steps if verdicts[k] == "switched"}
    assert 5 in switched and switched <= set(np.flatnonzero(flagged))
    assert not flagged[:5].any() and not flagged[6:11].any() and verdicts[0] == "kept"
    seen = set()  # kinks from nothing to a switch: every step the verdict calls a switch is flagged
    for kink in np.linspace(0.0, 0.6, 121):
        bent = qd.copy()
        bent[12:, 3] += kink
        verdict = branch_verdict(weights, t[12] - t[11], (bent[11], qdd[11]), (bent[12], qdd[12]), bodies)[0]
        assert possible_switches(weights, t, bent, qdd, np.array([11]))[0] or verdict != "switched", kink
        seen.add(verdict)
    assert {"kept", "switched"} <= seen  # the grid crosses the verdict's threshold


def test_the_prefilter_flags_the_same_steps_taken_apart_or_together():
    """``possible_switches`` over consecutive steps (views of the histories) and over steps taken apart (index
    arrays) flags each step alike: every other step, and the steps one by one, against all steps at once."""
    from solutions.guard import possible_switches

    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.01, 0.03, 31))
    qd, qdd = rng.standard_normal((31, 6)), rng.standard_normal((31, 6))
    qd[17:, :3] *= -1.0  # a switch between samples 16 and 17
    weights = np.array([[1.0, 1.0, 0.2], [1.0, 1.0, 0.5]])
    together = possible_switches(weights, t, qd, qdd, np.arange(30))
    assert together[16]
    for part in (np.arange(0, 30, 2), np.arange(1, 30, 2), np.array([3, 16, 29])):
        np.testing.assert_array_equal(possible_switches(weights, t, qd, qdd, part), together[part])
    alone = [possible_switches(weights, t, qd, qdd, np.array([k]))[0] for k in range(30)]
    np.testing.assert_array_equal(alone, together)


def test_the_compiled_prefilter_flags_the_steps_numpy_s_flags():
    """``compiled.branches.possible_switches`` (one pass, a compiled run's) flags the steps ``possible_switches``
    (numpy's whole arrays) flags: random histories with switches and kinks from nothing past the threshold, and a
    NaN (numpy's max keeps it: no step flagged there)."""
    pytest.importorskip("numba")
    from solutions.compiled import branches
    from solutions.guard import possible_switches

    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.01, 0.03, 41))
    weights = np.array([[1.0, 1.0, 0.2], [1.0, 1.0, 0.5], [1.0, 1.0, 0.0]])
    steps = np.arange(40)
    for kink in np.linspace(0.0, 2.0, 41):
        qd, qdd = rng.standard_normal((41, 9)), rng.standard_normal((41, 9))
        qd[17:, :3] *= -1.0
        qd[30:, 4] += kink
        qd[35, 7] = np.nan if kink > 1.9 else qd[35, 7]
        compiled = branches.possible_switches(weights, t, qd, qdd, steps, 0.5 * BRANCH_JUMP)
        np.testing.assert_array_equal(compiled, possible_switches(weights, t, qd, qdd, steps), err_msg=f"{kink}")
        part = steps[::3].copy()
        np.testing.assert_array_equal(branches.possible_switches(weights, t, qd, qdd, part, 0.5 * BRANCH_JUMP),
                                      compiled[part])  # fmt: skip
    assert not compiled[34] and not compiled[35]  # the NaN's two steps


def test_the_compiled_screen_finds_the_steps_numpy_s_screen_finds():
    """``compiled.branches.screen`` (one pass, a compiled run's ``Guard._screen``) gives ``branch_screen``'s four
    index arrays (numpy's whole arrays): the dips, the sign's flips, the falls and the steps near a singular
    position, on random ratios at and around NEAR_SINGULAR, FALL's hundredfold and zero, with NaN and infinite
    ratios (np.minimum and np.maximum keep a NaN: no test passes there), NaN signs and turns, and without signs
    (redundant rows)."""
    pytest.importorskip("numba")
    from solutions.compiled import branches
    from solutions.guard import ALIGNED, FALL, NEAR_SINGULAR, branch_screen

    rng = np.random.default_rng(7)
    levels = np.array([0.0, 1e-4, 1e-3, 5e-3, 0.02, 0.05, 0.099, 0.1, 0.3, 1.0, np.nan, np.inf])
    found = [0, 0, 0, 0]
    for trial in range(3000):
        size = int(rng.integers(2, 14))
        ratios = rng.choice(levels, size) if trial % 2 else rng.uniform(0.0, 0.2, size)
        if trial % 3 == 0:
            ratios[rng.integers(0, size)] = np.nan
        signs = rng.choice([1.0, -1.0, np.nan] if trial % 5 == 0 else [1.0, -1.0], size)
        turns = rng.choice([0.95, -0.95, 0.5, -0.99, np.nan], size - 1)
        for given in (signs, None):
            with np.errstate(invalid="ignore"):  # inf - inf: NaN, as the screen takes it
                numpy_s = branch_screen(ratios, given, turns)
            compiled = branches.screen(ratios, np.empty(0) if given is None else given, turns, NEAR_SINGULAR, FALL,
                                       ALIGNED)  # fmt: skip
            for a, b in zip(numpy_s, compiled, strict=True):
                np.testing.assert_array_equal(a, b, err_msg=f"{ratios} {given} {turns}")
            found = [f + len(a) for f, a in zip(found, numpy_s, strict=True)]
    assert all(found)  # every test passed somewhere


def test_a_dip_between_output_times_is_found_as_passes_zero_finds_it_next_to_a_nan_too():
    """``singular_dip`` takes the first output time where sigma_r / sigma_1 dips (``diagnostics.passes_zero``,
    sample by sample: a NaN after the minimum leaves Python's min and max the other neighbour, so it still dips)."""
    from solutions.diagnostics import passes_zero
    from solutions.guard import singular_dip

    def first_by_hand(ratios):
        return next((k for k in range(1, len(ratios) - 1) if passes_zero(*ratios[k - 1 : k + 2])), None)

    cases = (
        [0.5, 0.4, 0.3, 0.4, 0.5],  # a smooth minimum far from zero
        [0.5, 0.3, 1e-6, 0.3, 0.5, 1e-7, 0.4],  # two dips: the first
        [np.nan, 1e-6, 0.3, 0.4],  # a NaN before the minimum: no dip
        [0.3, 1e-6, np.nan, 0.4],  # a NaN after it: a dip
    )

    class Spectra:  # a Guard's ratios at the output times, as its output checks made them
        rank = 1

        def __init__(self, ratios, banded):
            self.ratios, self.banded = np.array(ratios), banded  # banded: a compiled run's (``branches.first_dip``)

        def spectra(self, t, jacobians):
            return self.ratios, None, None

    rng = np.random.default_rng(11)
    levels = [0.0, 1e-6, 0.05, 0.099, 0.1, 0.3, 0.5, np.nan, np.inf]
    drawn = [list(rng.choice(levels, int(rng.integers(3, 9)))) for _ in range(400)]
    engines = (False, True) if importlib.util.find_spec("numba") else (False,)
    for ratios in [*cases, *drawn]:
        times, k = np.arange(float(len(ratios))), first_by_hand(ratios)
        for banded in engines:
            with np.errstate(invalid="ignore"):  # inf - inf
                found = singular_dip(Spectra(ratios, banded), times, None)
            assert found == (None if k is None else (times[k], ratios[k])), (ratios, banded)
