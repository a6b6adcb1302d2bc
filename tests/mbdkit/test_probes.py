"""The ``planar_bodies`` probe (hw1's body functions alone): on the reference package its outputs are the closed
forms of the course notes (eq. 2.1-2.5), and a student whose bodies.py alone is written earns exactly its points."""

from __future__ import annotations

import numpy as np

from mbdkit.probes import BODY_VECTORS, PROBES, Job, Package


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


def test_bodies_alone_earn_their_points(tmp_path):
    """The issue's student: planar/bodies.py written, no joint yet; 0 before, the bodies group's points now."""
    import shutil

    from autograder.grading import grade
    from course.release import build_package
    from course.release.generator import REPO
    from mbdkit.homework import load_homework

    build_package(tmp_path / "class" / "bo" / "modules", "hw1", header=None)
    shutil.copy(REPO / "solutions" / "planar" / "bodies.py", tmp_path / "class" / "bo" / "modules" / "planar")
    book = grade("hw1", tmp_path / "class", tmp_path / "out", jobs=1, progress=False, isolation="local")
    bodies = [c for c in load_homework("hw1").checks if c.group == "bodies"]
    assert book.score("bo") == sum(c.points for c in bodies) > 0
    assert all(book.points("bo")[c.name] == c.points for c in bodies)
