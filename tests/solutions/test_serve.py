"""``mbd serve`` (solutions/serve.py) over HTTP, as a hostile client would use it: errors with their line, bodies
too large, paths that are not the server's, a run that outlives its limit. In a browser (open, edit, run,
download): tests/solutions/test_viewer_browser.py."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from solutions.serve import MAX_MODEL_BYTES, PROGRESS, line_of, progress_file, read_progress

REPO = Path(__file__).resolve().parents[2]
SLIDER_CRANK = (REPO / "course" / "models" / "slider_crank.yaml").read_text()
DOUBLE_PENDULUM = (REPO / "course" / "models" / "double_pendulum.yaml").read_text()


def test_an_error_is_placed_at_the_line_of_its_key_or_of_the_yaml_parser():
    text = SLIDER_CRANK
    rows = text.splitlines()
    rod = next(k for k, row in enumerate(rows, start=1) if "name: rod" in row)
    drive = next(k for k, row in enumerate(rows, start=1) if "name: drive" in row)
    simulation = next(k for k, row in enumerate(rows, start=1) if row.startswith("simulation:"))
    assert line_of(text, "model.bodies[1].mass: expected number, got 'abc'") == rod
    assert line_of(text, "model.yaml: model.motors[0].function: unknown type") == drive
    assert line_of(text, "simulation.end_time: must be positive") == simulation
    assert line_of(text, "model.bodies[7].mass: x") == next(k for k, r in enumerate(rows, 1) if "bodies:" in r)
    assert line_of(text, "line 4, column 7: malformed YAML (...)") == 4
    assert line_of(text, "the model has no degrees of freedom") is None
    assert line_of("model: [", "model.name: x") is None  # not YAML: no tree to place the key in


class Server:
    """``mbd serve --port 0`` in a process of its own (the course's models as examples); ``url`` from the line it
    prints; ``stop`` ends it."""

    def __init__(self, *options: str):
        command = [sys.executable, "-m", "solutions.cli", "serve", "--port", "0", *options]
        command += ["--examples", str(REPO / "course" / "models")]
        self.process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        line = self.process.stdout.readline()
        assert line.startswith("mbd serve: http://127.0.0.1:"), line
        self.url = line.split()[2].rstrip("/")

    def stop(self) -> None:
        self.process.terminate()
        self.process.wait(timeout=20)
        self.process.stdout.close()

    def ask(self, path: str, body: str | bytes | None = None) -> tuple[int, bytes]:
        data = body.encode() if isinstance(body, str) else body
        try:
            with urllib.request.urlopen(urllib.request.Request(self.url + path, data=data), timeout=60) as reply:
                return reply.status, reply.read()
        except urllib.error.HTTPError as err:
            return err.code, err.read()

    def json(self, path: str, body: str | None = None) -> dict:
        status, data = self.ask(path, body)
        assert status == 200, (path, status, data[:300])
        return json.loads(data)

    def finished(self, job: str) -> dict:
        for _ in range(400):
            status = self.json(f"/jobs/{job}")
            if status["state"] in ("done", "failed"):
                return status
            subprocess.run(["sleep", "0.1"], check=True)
        raise AssertionError(f"job {job} did not finish")


@pytest.fixture(scope="module")
def server():
    running = Server()
    yield running
    running.stop()


def test_a_check_answers_the_report_and_the_view_or_the_error_at_its_line(server):
    good = server.json("/check", SLIDER_CRANK)
    assert good["ok"] and "degrees of freedom: 0" in good["report"]
    assert {t["name"] for t in good["figure"]["data"] if "name" in t} >= {"crank", "rod", "slider"}
    bad = server.json("/check", SLIDER_CRANK.replace("type: prismatic", "type: prismatik"))
    (error,) = bad["errors"]
    assert not bad["ok"] and "prismatik" in error["message"] and "did you mean" in error["message"]
    assert SLIDER_CRANK.splitlines()[error["line"] - 1].lstrip().startswith("- {name: S")
    broken = server.json("/check", "model:\n  name: [x\n")
    assert broken["errors"][0]["line"] == 3 and "malformed YAML" in broken["errors"][0]["message"]


def test_what_is_not_the_servers_is_refused_and_the_server_stays(server):
    status, _ = server.ask("/check", b"x" * (MAX_MODEL_BYTES + 10))
    assert status in (400, 413)
    assert server.ask("/examples/..%2F..%2Fetc%2Fpasswd")[0] == 404
    assert server.ask("/examples/no_such_model")[0] == 404
    assert server.ask("/jobs/" + "0" * 32)[0] == 404
    assert server.ask("/jobs/../../etc/passwd")[0] == 404
    job = server.json("/run", SLIDER_CRANK)["job"]
    assert server.finished(job)["state"] == "done"
    assert server.ask(f"/jobs/{job}/model.yaml")[0] == 404  # only the result's two files are downloads
    assert server.ask(f"/jobs/{job}/reply.json")[0] == 404
    status, csv = server.ask(f"/jobs/{job}/result.csv")
    assert status == 200 and csv.startswith(b"t,crank.x,")
    assert "slider_crank" in server.json("/examples")["examples"]


def test_a_run_that_outlives_its_limit_is_stopped_with_one_line(server):
    pendulum = (REPO / "course" / "models" / "simple_pendulum.yaml").read_text()
    endless = pendulum.replace("end_time: 4.0, output_steps: 400", "end_time: 1.0e+6, output_steps: 1000000")
    assert endless != pendulum  # a pendulum swinging for 12 days of time: nothing stops it but the limit (the
    # slider-crank's kinematic run at one output a second stopped at its first dead point on a fast machine)
    strict = Server("--run-seconds", "3")
    try:
        status = strict.finished(strict.json("/run", endless)["job"])
    finally:
        strict.stop()
    assert status["state"] == "failed" and status["errors"][0]["message"] in (
        "stopped after 3 s (the server's limit)",
        "the run failed: out of memory or time",
    )
    failed = server.finished(server.json("/run", SLIDER_CRANK.replace("body2: crank", "body2: crankk"))["job"])
    assert failed["state"] == "failed" and "crankk" in failed["errors"][0]["message"]


def test_a_run_is_viewed_with_the_plots_and_traces_asked_for(server):
    done = server.finished(server.json("/run?plots=slider.x&trace=A", SLIDER_CRANK)["job"])
    names = {t.get("name") for t in done["figure"]["data"]}
    assert done["state"] == "done" and {"slider.x", "path of A"} <= names
    wrong = server.finished(server.json("/run?plots=slider.q", SLIDER_CRANK)["job"])
    assert wrong["errors"][0]["message"].startswith("the view: no result column slider.q (columns: t, crank.x,")
    status, reply = server.ask("/run?trace=../etc", SLIDER_CRANK)
    assert status == 400 and b"at most 10 names" in reply
    four_bar = (REPO / "course" / "models" / "four_bar_spring.yaml").read_text()
    short = re.sub(r"end_time: [0-9.e+-]+", "end_time: 0.2", four_bar)
    arrows = server.finished(server.json("/run?reactions=A,B&forces=spring", short)["job"])
    names = {t.get("name") for t in arrows["figure"]["data"]}
    assert arrows["state"] == "done" and {"reaction forces", "applied forces"} <= names, arrows.get("errors")


def test_the_server_bounds_what_runs_at_once(tmp_path, monkeypatch):
    """At most CHECKING checks and RUNNING runs at a time (each a child process); beyond WAITING runs a new one is
    refused until some finish. The children replaced by a short sleep that counts them."""
    import asyncio

    from solutions import serve

    now = {"running": 0, "most": 0}

    async def child(kind, text, folder, seconds):
        now["running"] += 1
        now["most"] = max(now["most"], now["running"])
        await asyncio.sleep(0.02)
        now["running"] -= 1
        return {"ok": True}

    monkeypatch.setattr(serve, "in_child", child)

    async def scenario():
        server = serve.Server(tmp_path)
        await asyncio.gather(*(server.check("model: {}") for _ in range(3 * serve.CHECKING)))
        checks, now["most"] = now["most"], 0
        jobs = [server.start("model: {}", {}) for _ in range(serve.WAITING)]
        full = server.busy("run")
        while any(server.status(j)["state"] != "done" for j in jobs):
            await asyncio.sleep(0.02)
        return checks, now["most"], full, server.busy("run")

    checks, runs, full, later = asyncio.run(scenario())
    assert (checks, runs, full, later) == (serve.CHECKING, serve.RUNNING, True, False)


def test_a_run_tells_its_progress_as_the_fraction_of_its_end_time(tmp_path, monkeypatch):
    """The child's progress file holds t / t_end (at most every PROGRESS_SECONDS); the server reads it bounded and
    takes only a number from 0 to 1."""
    clock = iter([100.0, 100.1, 100.4, 101.0])
    monkeypatch.setattr("solutions.serve.time.monotonic", lambda: next(clock))
    progress = progress_file(tmp_path, 2.0)
    progress(0.5)
    assert read_progress(tmp_path) == 0.25
    progress(1.0)  # 0.1 s later: not written
    assert read_progress(tmp_path) == 0.25
    progress(1.5)
    assert read_progress(tmp_path) == 0.75
    progress(2.0)
    assert read_progress(tmp_path) == 1.0
    for written in ("2.0000", "-0.5000", "nan", "0.5" * 1000, "\xff\xfe", ""):
        (tmp_path / PROGRESS).write_text(written, errors="surrogateescape")
        assert read_progress(tmp_path) is None, written
    (tmp_path / PROGRESS).unlink()
    assert read_progress(tmp_path) is None


def test_a_long_run_reports_how_far_it_is_while_it_runs(server):
    """A numpy run of 12 s of motion at tight tolerance: while it runs, its status gives a growing fraction of
    t_end; once done, none."""
    slow = DOUBLE_PENDULUM.replace("end_time: 2.0", "end_time: 12.0").replace("output_steps: 200", "output_steps: 600")
    slow = slow.replace("atol: 1.0e-12}", "atol: 1.0e-12, engine: numpy}")
    job = server.json("/run", slow)["job"]
    seen = []
    for _ in range(600):
        status = server.json(f"/jobs/{job}")
        if status["state"] != "running":
            if status["state"] == "done":
                break
            assert status["state"] == "queued", status
        elif status["fraction"] is not None:
            seen.append(status["fraction"])
        subprocess.run(["sleep", "0.1"], check=True)
    assert status["state"] == "done" and "fraction" not in status, status.get("errors")
    assert len(seen) >= 2 and seen == sorted(seen) and 0.0 <= seen[0] < seen[-1] <= 1.0, seen
