"""Grading on Dask (``grade(..., cluster=...)``, ``mbd grade --cluster``): the same gradebook, results and
feedback as grading one by one, on a LocalCluster and on one whose worker is killed mid-run (its task runs
again, nothing is lost, nothing counted twice); only the client writes; a bad address is refused."""

from __future__ import annotations

import json
import os
import signal
import threading
import time
from pathlib import Path

import pytest

from autograder.grading import grade
from mbdkit import isolation as osi
from mbdkit.homework import CheckSpec, Homework, load_homework
from solutions.cli import main

ROOT = Path(__file__).resolve().parents[2]
CLASS = {"ann": "reference", "bob": "skeleton", "cem": "gamma_sign"}

pytestmark = pytest.mark.skipif(osi.problem() is not None, reason="grading needs bubblewrap (see the README)")


def quick_homework() -> Homework:
    """Three cheap checks of hw1 (as test_grading's), one on each student's own variant of the slider-crank."""
    checks = load_homework("hw1").select(["slider_crank.gamma.revolute", "slider_crank.newton"]).checks
    checks.append(
        CheckSpec("student/slider_crank.velocity", "student/slider_crank", "velocity", ("qd",), 2.0, "velocity")
    )
    return Homework("hw1", "quick", checks)


@pytest.fixture(scope="module")
def submissions(make_submissions):
    return make_submissions("cluster-class", CLASS, "hw1")


@pytest.fixture(scope="module")
def serial(submissions, tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    return grade(quick_homework(), submissions, out, jobs=1, progress=False), out


def _outputs(out: Path) -> dict[str, dict]:
    found = {}
    for path in sorted((out / "results").glob("*.json")):
        data = json.loads(path.read_text())
        found[path.stem] = {t["name"]: (t["score"], t["output"]) for t in data["tests"]}
    return found


def test_same_gradebook_on_a_cluster_and_resume(cluster, submissions, serial, tmp_path):
    address, _ = cluster
    book, out = serial
    assert book.score("ann") == book.max_score and book.score("bob") == 0 < book.score("cem") < book.max_score
    there = grade(quick_homework(), submissions, tmp_path, cluster=address, progress=False)
    assert (tmp_path / "gradebook.csv").read_text() == (out / "gradebook.csv").read_text()
    assert _outputs(tmp_path) == _outputs(out)
    assert sorted(p.name for p in (tmp_path / "feedback").iterdir()) == ["ann.html", "bob.html", "cem.html"]
    assert not list(tmp_path.rglob(".*.tmp"))
    assert all(not row["resumed"] for row in there.rows.values())
    # a run stopped after one student resumes with the other two: nothing lost, nothing graded again
    (tmp_path / "results" / "bob.json").unlink()
    again = grade(quick_homework(), submissions, tmp_path, cluster=address, progress=False)
    assert sorted(s for s, row in again.rows.items() if not row["resumed"]) == ["bob"]
    assert (tmp_path / "gradebook.csv").read_text() == (out / "gradebook.csv").read_text()


def test_a_worker_killed_mid_run_loses_nothing_and_counts_nothing_twice(cluster, submissions, serial, tmp_path):
    address, client = cluster
    book, out = serial
    pids = client.run(os.getpid)
    killed = []

    def kill_a_busy_worker():
        deadline = time.time() + 120
        while time.time() < deadline and not killed:
            busy = [w for w, tasks in client.processing().items() if any("grade-" in str(t) for t in tasks)]
            if busy:
                time.sleep(0.5)  # inside the grading of a submission: its sandbox is running
                if any("grade-" in str(t) for t in client.processing().get(busy[0], ())):  # still grading
                    os.kill(pids[busy[0]], signal.SIGKILL)
                    killed.append(busy[0])
            time.sleep(0.02)

    killer = threading.Thread(target=kill_a_busy_worker)
    killer.start()
    result = grade(quick_homework(), submissions, tmp_path, cluster=address, progress=False, resume=False)
    killer.join()
    assert killed, "no worker was busy to kill"
    assert sorted(result.rows) == ["ann", "bob", "cem"]
    assert (tmp_path / "gradebook.csv").read_text() == (out / "gradebook.csv").read_text()
    assert _outputs(tmp_path) == _outputs(out)


def test_a_bad_cluster_address_is_refused_before_any_output(submissions, tmp_path, capsys):
    out = tmp_path / "grades"
    code = main(["grade", "hw1", str(submissions), "--out", str(out), "--cluster", "nowhere"])
    assert code == 2 and not out.exists()
    err = capsys.readouterr().err.strip()
    assert err.startswith("mbd: error: --cluster nowhere") and "tcp://HOST:8786" in err and "\n" not in err


CORES = min(os.cpu_count() or 1, 8)


@pytest.mark.parametrize(("argv", "jobs"), [([], CORES), (["--jobs", "2"], 2), (["--jobs", "1"], 1)])
def test_mbd_grade_jobs_above_one_means_a_local_cluster(submissions, tmp_path, monkeypatch, argv, jobs):
    """``mbd grade --jobs N``, N > 1 (the default on a machine of several cores): ``--cluster local``."""
    import autograder.cli

    seen = {}

    def fake_grade(homework, submissions_dir, out_dir, **options):
        seen.update(options)
        raise FileNotFoundError("stop here")

    monkeypatch.setattr(autograder.cli, "grade", fake_grade)
    assert main(["grade", "hw1", str(submissions), "--out", str(tmp_path / "out"), *argv]) == 2
    assert seen["jobs"] == jobs and seen["cluster"] == ("local" if jobs > 1 else None)
