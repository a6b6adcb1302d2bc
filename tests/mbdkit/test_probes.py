"""The probes of hw1's functions alone, before any joint: ``planar_bodies`` (bodies.py) and ``loop_newton``,
``loop_velocity``, ``loop_acceleration`` (kinematics.py's solvers on a slider-crank given by its loop closure). On
the reference package their outputs are closed forms (eq. 2.1-2.5; the slider-crank solved exactly), and a student
whose bodies.py and kinematics.py alone are written earns exactly their points, a wrong solver only its own lost."""

from __future__ import annotations

import numpy as np

from mbdkit.probes import BODY_VECTORS, LOOP_START, LOOP_TIMES, PROBES, Job, Package, SliderCrankLoop


def closed_forms(q: np.ndarray, qd: np.ndarray) -> dict[str, np.ndarray]:
    """A, B of every body and d, d', the velocity part of d'' from the body before it (ground first), written here."""
    si, sj = BODY_VECTORS
    q, qd = np.concatenate([np.zeros(3), q]), np.concatenate([np.zeros(3), qd])
    phi, w, r, v = q[2::3], qd[2::3], q.reshape(-1, 3)[:, :2], qd.reshape(-1, 3)[:, :2]
    A = np.array([[[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]] for a in phi])
    B = np.array([[[-np.sin(a), -np.cos(a)], [np.cos(a), -np.sin(a)]] for a in phi])
    i, j = np.arange(len(phi) - 1), np.arange(1, len(phi))
    d = r[j] + A[j] @ sj - r[i] - A[i] @ si
    d_dot = v[j] + (B[j] @ sj) * w[j, None] - v[i] - (B[i] @ si) * w[i, None]
    d_quadratic = (A[i] @ si) * w[i, None] ** 2 - (A[j] @ sj) * w[j, None] ** 2  # dB/dphi = -A
    return {"A": A[1:], "B": B[1:], "d": d, "d_dot": d_dot, "d_quadratic": d_quadratic}


def test_the_reference_gives_the_closed_forms():
    rng = np.random.default_rng(3)
    q, qd = rng.uniform(-2, 2, (3, 9)), rng.uniform(-3, 3, (3, 9))  # three states of three bodies
    job = Job("bodies#1", {}, {"t": np.zeros(3), "q_pert": q, "qd_pert": qd})
    outputs = PROBES["planar_bodies"](Package("solutions"), job)
    for k in range(3):
        expected = closed_forms(q[k], qd[k])
        for name, value in expected.items():
            np.testing.assert_allclose(outputs[name][k], value, rtol=1e-13, atol=1e-14, err_msg=name)


def slider_crank_exactly(t: float) -> np.ndarray:
    """(q, q', q'') of the loop's slider-crank at time t, written here: with s = e - r sin(theta) and
    c = sqrt(l^2 - s^2) = l cos(phi), phi = asin(s / l) and x = r cos(theta) + c, differentiated twice."""
    r, l, e = 0.1, 0.3, 0.05
    theta, w, a = 0.3 + 10 * t + 10 * t**2, 10 + 20 * t, 20.0  # the crank's driver, theta_d(t)
    s, ds = e - r * np.sin(theta), -r * np.cos(theta) * w
    dds = r * np.sin(theta) * w**2 - r * np.cos(theta) * a
    c = np.sqrt(l**2 - s**2)
    dc = -s * ds / c
    ddc = -(ds**2 + s * dds) / c - s * ds * (s * ds) / c**3
    phi, dphi, ddphi = np.arcsin(s / l), ds / c, (dds * c - ds * dc) / c**2
    x = r * np.cos(theta) + c
    dx, ddx = -r * np.sin(theta) * w + dc, -r * np.cos(theta) * w**2 - r * np.sin(theta) * a + ddc
    return np.array([[theta, phi, x], [w, dphi, dx], [a, ddphi, ddx]])


def test_the_loop_probes_give_the_slider_crank_solved_exactly():
    reference = Package("solutions")
    q = PROBES["loop_newton"](reference, Job("slider_crank", {}))["q"]
    qd = PROBES["loop_velocity"](reference, Job("slider_crank", {}))["qd"]
    qdd = PROBES["loop_acceleration"](reference, Job("slider_crank", {}))["qdd"]
    exact = np.array([slider_crank_exactly(t) for t in LOOP_TIMES])
    assert np.ptp(exact[:, 0, 0]) > 6  # the crank turns more than once: every quadrant is solved
    np.testing.assert_allclose(q, exact[:, 0], rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(qd, exact[:, 1], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(qdd, exact[:, 2], rtol=1e-11, atol=1e-11)
    loop, newton = SliderCrankLoop(), reference["kinematics"].newton_raphson  # the probe's starts need iterations
    assert all(newton(loop, loop.state(t)[0] + LOOP_START, t).iterations >= 3 for t in LOOP_TIMES)


WRONG_VELOCITY = ("return lu_solve(lu, -system.psi_t(q, t))", "return lu_solve(lu, system.psi_t(q, t))")
"""velocity_analysis with the sign of Psi_t lost (eq. 4.5): the kinematics student whose one solver is wrong."""


def test_bodies_and_kinematics_alone_earn_their_points(tmp_path):
    """The issue's students: planar/bodies.py written and no joint yet (bo), with kinematics.py too (bk), and with
    kinematics.py's velocity_analysis wrong (wv); 0 before, the groups' points of what they wrote now."""
    import json
    import shutil

    from autograder.grading import grade
    from course.release import build_package
    from course.release.generator import REPO
    from mbdkit.homework import load_homework

    for student, written in (("bo", ["planar/bodies.py"]), ("bk", ["planar/bodies.py", "kinematics.py"])):
        build_package(tmp_path / "class" / student / "modules", "hw1", header=None)
        for path in written:
            shutil.copy(REPO / "solutions" / path, tmp_path / "class" / student / "modules" / path)
    shutil.copytree(tmp_path / "class" / "bk", tmp_path / "class" / "wv")
    kinematics = tmp_path / "class" / "wv" / "modules" / "kinematics.py"
    assert WRONG_VELOCITY[0] in kinematics.read_text()
    kinematics.write_text(kinematics.read_text().replace(*WRONG_VELOCITY))
    book = grade("hw1", tmp_path / "class", tmp_path / "out", jobs=1, progress=False, isolation="local")
    checks = load_homework("hw1").checks
    bodies = [c for c in checks if c.group == "bodies"]
    solvers = [c for c in checks if c.group == "solvers"]
    assert {c.probe for c in solvers} == {"loop_newton", "loop_velocity", "loop_acceleration"}
    assert book.score("bo") == sum(c.points for c in bodies) > 0
    assert all(book.points("bo")[c.name] == c.points for c in bodies)
    assert book.score("bk") == sum(c.points for c in bodies + solvers) > book.score("bo")
    assert all(book.points("bk")[c.name] == c.points for c in bodies + solvers)
    velocity = next(c for c in solvers if c.probe == "loop_velocity")
    assert book.score("wv") == book.score("bk") - velocity.points
    assert book.points("wv")[velocity.name] == 0
    assert all(book.points("wv")[c.name] == c.points for c in bodies + solvers if c is not velocity)
    said = (tmp_path / "out" / "results" / "wv.json").read_text()
    assert "Likely cause: the sign of Psi_t" in json.dumps(json.loads(said))
