"""``mbd serve``: pre- and post-processing with nothing but a browser (a classroom or a lab machine).

A local web application (Tornado, the web framework Jupyter's server runs on): open an example or upload a
model file, edit it with the model file's own validation (an error shown with its line, in ``mbd check``'s
words) and the mechanism redrawn as one types (``viewer.model_view``, as assembly makes it consistent over the
file's placement), run the analysis the file asks for (``analysis.run_analysis`` with the file's
``simulation`` settings), then play the result (``viewer.result_view``) and download its CSV and NPZ.

Every request that reads a model is hostile: the server never parses a model itself. Each check and each run
is a child process of its own (``python -m solutions.serve child KIND``) in a work folder of its own, under
limits of the operating system (address space, CPU seconds, file size) and a wall-clock deadline, its reply
one JSON file that the server reads bounded and checks key by key. A request body is at most
``MAX_MODEL_BYTES``; a path is never taken from a request (a job is a random id, a download one of two names).
By default the server listens on 127.0.0.1 only; ``--host 0.0.0.0`` serves a classroom.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import re
import resource
import secrets
import shutil
import signal
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

MAX_MODEL_BYTES = 200_000
"""The largest model text accepted (the course's largest model file is 3 kB)."""
CHECK_SECONDS = 20.0
"""Wall-clock seconds of a check (validation, assembly, the model's view)."""
RUN_SECONDS = 120.0
"""Wall-clock seconds of a run (``--run-seconds``); its CPU seconds are bounded the same."""
MEMORY_BYTES = 2 * 2**30
"""Address space of a child (RLIMIT_AS)."""
FILE_BYTES = 200 * 2**20
"""The largest file a child may write (RLIMIT_FSIZE)."""
REPLY_BYTES = 20 * 2**20
"""The largest reply read from a child (a view of a long run is a few hundred kB)."""
RUNNING = 2
"""Runs at the same time; more wait their turn."""
WAITING = 20
"""Runs running or waiting at most; a run asked beyond is refused (503), as is a check beyond ``CHECKING``."""
CHECKING = 4
"""Checks at the same time (one per editor being typed in); more wait their turn."""
KEPT_JOBS = 50
"""Finished jobs kept (with their files); the oldest go first."""
DOWNLOADS = ("result.csv", "result.npz")
PROGRESS = "progress"
"""The file a running child keeps its progress in: the fraction of t_end reached, as a decimal number."""
PROGRESS_SECONDS = 0.25
"""How often at most a child rewrites its progress file."""
NAME = re.compile(r"[A-Za-z0-9_.]{1,100}")
"""A result column or a joint, point or force element name asked for in the view."""
VIEW_KEYS = ("plots", "trace", "reactions", "forces")
"""What a run's view may be asked (``viewer.result_view``'s keywords): result columns plotted, joints or points
traced, joints whose reaction forces and force elements whose forces are arrows."""
EXAMPLE_NAME = re.compile(r"[a-z0-9_]{1,64}")
PATH_IN_MESSAGE = re.compile(r"^(?:[^:\n]*: )?((?:model|simulation)(?:\.[A-Za-z_][A-Za-z0-9_]*|\[\d+\])*)")
LINE_IN_MESSAGE = re.compile(r"line (\d+), column \d+")


# -- the child: one check or one run --------------------------------------------------------------------------
def line_of(text: str, message: str) -> int | None:
    """The line of the model text that an error message is about: the YAML parser's line, or the line of the key
    path the message names (``model.bodies[1].mass``), found in the YAML's node tree; None when neither."""
    found = LINE_IN_MESSAGE.search(message)
    if found:
        return int(found.group(1))
    named = PATH_IN_MESSAGE.match(message)
    if not named:
        return None
    import yaml

    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return None
    line = None
    for part in re.findall(r"[A-Za-z_][A-Za-z0-9_]*|\[\d+\]", named.group(1)):
        if isinstance(node, yaml.MappingNode) and not part.startswith("["):
            entry = next(((k, v) for k, v in node.value if getattr(k, "value", None) == part), None)
            if entry is None:
                break
            line, node = entry[0].start_mark.line + 1, entry[1]
        elif isinstance(node, yaml.SequenceNode) and part.startswith("["):
            index = int(part[1:-1])
            if index >= len(node.value):
                break
            node = node.value[index]
            line = node.start_mark.line + 1
        else:
            break
    return line


def _refusal(text: str, err: Exception) -> dict:
    message = str(err).replace("model.yaml: ", "", 1)
    return {"ok": False, "errors": [{"line": line_of(text, message), "message": message}]}


def check(text: str, folder: Path) -> dict:
    """What ``mbd check`` says of the model text and its view (assembled, over the file's placement in grey)."""
    from .assembly import build_system
    from .cli import check_report
    from .io.model import ModelError, load_model
    from .viewer import model_view

    path = folder / "model.yaml"
    path.write_text(text)
    try:
        model = load_model(path)
        system, q0, _ = build_system(model)
        lines, q = check_report(model, system, q0)
    except (ModelError, ValueError, ArithmeticError) as err:
        return _refusal(text, err)
    view = model_view(model, q, before=q0, title=f"{model.name}: as assembled (grey: as the file places it)")
    return {"ok": True, "report": lines[1:], "figure": view.figure}


def run(text: str, folder: Path) -> dict:
    """The analysis the model asks for, with its ``simulation`` settings: the result's view (with the columns
    ``plots``, the paths of the joints or points ``trace`` and the arrows of ``reactions`` and ``forces`` that the
    server wrote to ``view.json``), its summary,
    and the result written as ``result.csv`` and ``result.npz`` in the job's folder."""
    from .analysis import run_analysis
    from .assembly import build_system
    from .cli import run_summary
    from .io.model import ModelError, load_model
    from .io.results import write_result
    from .settings import read_settings
    from .viewer import result_view

    path = folder / "model.yaml"
    path.write_text(text)
    try:
        model = load_model(path)
        system, q0, qd0 = build_system(model)
        settings = read_settings(model.simulation)
        result = run_analysis(system, q0, qd0, settings, progress=progress_file(folder, settings.t_end))
    except (ModelError, ValueError, ArithmeticError, RuntimeError) as err:
        return _refusal(text, err)
    for name in DOWNLOADS:
        write_result(result, folder / name)
    summary = run_summary(result)
    asked = json.loads((folder / "view.json").read_text()) if (folder / "view.json").is_file() else {}
    try:
        view = result_view(model, system, result, title=f"{model.name}: {summary.split(':')[0]}", **asked)
    except ValueError as err:  # a column or a joint the result has not: the message lists those it has
        return {"ok": False, "errors": [{"line": None, "message": f"the view: {err}"}]}
    return {"ok": True, "summary": summary, "figure": view.figure, "files": list(DOWNLOADS)}


def progress_file(folder: Path, t_end: float):
    """``progress(t)`` for a run: the fraction t / t_end written to the job's ``PROGRESS`` file (whole or not at
    all: written beside it, then renamed), at most every ``PROGRESS_SECONDS``."""
    last = [0.0]

    def progress(t: float) -> None:
        now = time.monotonic()
        if now - last[0] < PROGRESS_SECONDS or t_end <= 0:
            return
        last[0] = now
        (folder / f"{PROGRESS}.tmp").write_text(f"{min(max(t / t_end, 0.0), 1.0):.4f}")
        os.replace(folder / f"{PROGRESS}.tmp", folder / PROGRESS)

    return progress


def read_progress(folder: Path) -> float | None:
    """A running child's progress (``progress_file``), read bounded and checked: a number from 0 to 1, or None."""
    try:
        with open(folder / PROGRESS, "rb") as f:
            text = f.read(16).decode("ascii")
        value = float(text) if re.fullmatch(r"[01]\.\d{4}", text) else None
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    return value if value is not None and 0.0 <= value <= 1.0 else None


def child(kind: str) -> int:
    """The child's whole life: the model text on stdin, the reply as reply.json in the working folder."""
    text = sys.stdin.buffer.read(MAX_MODEL_BYTES + 1).decode("utf-8", errors="replace")
    folder = Path.cwd()
    reply = (check if kind == "check" else run)(text, folder)
    (folder / "reply.json").write_text(json.dumps(reply, separators=(",", ":")))
    return 0


def _limits(seconds: float) -> None:
    """In the child before it starts: its own process group, address space, CPU seconds, file size."""
    os.setsid()
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_BYTES, MEMORY_BYTES))
    cpu = int(seconds) + 1
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))
    resource.setrlimit(resource.RLIMIT_FSIZE, (FILE_BYTES, FILE_BYTES))


# -- the server -----------------------------------------------------------------------------------------------
@dataclass
class Job:
    folder: Path
    state: str = "queued"  # queued, running, done, failed
    started: float = field(default_factory=time.monotonic)
    finished: float | None = None
    reply: dict = field(default_factory=dict)


def read_reply(folder: Path, kind: str) -> dict:
    """The child's reply, read bounded and checked key by key: what the page may show, nothing else."""
    path = folder / "reply.json"
    if not path.is_file() or path.stat().st_size > REPLY_BYTES:
        raise ValueError("no reply")
    data = json.loads(path.read_text())
    if not isinstance(data, dict) or not isinstance(data.get("ok"), bool):
        raise ValueError("a malformed reply")
    if not data["ok"]:
        errors = [e for e in data.get("errors", []) if isinstance(e, dict) and isinstance(e.get("message"), str)]
        lines = [e["line"] if isinstance(e.get("line"), int) else None for e in errors]
        shown = [{"line": line, "message": e["message"][:2000]} for line, e in zip(lines, errors, strict=True)]
        return {"ok": False, "errors": shown[:20]}
    figure = data.get("figure")
    if not isinstance(figure, dict):
        raise ValueError("a reply without its view")
    if kind == "check":
        report = [str(line)[:500] for line in data.get("report", [])][:200]
        return {"ok": True, "report": report, "figure": figure}
    files = [name for name in data.get("files", []) if name in DOWNLOADS and (folder / name).is_file()]
    return {"ok": True, "summary": str(data.get("summary", ""))[:4000], "figure": figure, "files": files}


async def in_child(kind: str, text: str, folder: Path, seconds: float) -> dict:
    """One check or run in a child process under limits, its reply read by ``read_reply``; a child that fails,
    is killed or outlives ``seconds`` is one line of error."""
    command = [sys.executable, "-s", "-P", "-m", "solutions.serve", "child", kind]  # not the job folder, no user site
    root = str(Path(__file__).resolve().parents[1])
    environment = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "HOME": str(folder), "PYTHONPATH": root}
    environment.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MPLBACKEND="Agg", XDG_CACHE_HOME=str(folder))
    process = await asyncio.create_subprocess_exec(
        *command,
        stdin=asyncio.subprocess.PIPE,
        stdout=asyncio.subprocess.DEVNULL,
        stderr=asyncio.subprocess.PIPE,
        cwd=folder,
        env=environment,
        preexec_fn=lambda: _limits(seconds),
    )
    try:
        _, stderr = await asyncio.wait_for(process.communicate(text.encode()), timeout=seconds)
    except TimeoutError:
        os.killpg(process.pid, signal.SIGKILL)
        await process.wait()
        return {"ok": False, "errors": [{"line": None, "message": f"stopped after {seconds:g} s (the server's limit)"}]}
    finally:
        if process.returncode is None:
            os.killpg(process.pid, signal.SIGKILL)
    try:
        return read_reply(folder, kind)
    except (OSError, ValueError):
        last = stderr.decode(errors="replace").strip().splitlines()[-1:] or [f"exit code {process.returncode}"]
        reason = "out of memory or time" if process.returncode and process.returncode < 0 else last[0][:300]
        return {"ok": False, "errors": [{"line": None, "message": f"the {kind} failed: {reason}"}]}


class Server:
    """The application's state: a work folder, the jobs by id, and the limits."""

    def __init__(self, work: Path, run_seconds: float = RUN_SECONDS, examples: Path | None = None):
        self.work, self.run_seconds, self.examples = work, run_seconds, examples
        self.jobs: dict[str, Job] = {}
        self.running = asyncio.Semaphore(RUNNING)
        self.checking = asyncio.Semaphore(CHECKING)
        self.checks_waiting = 0

    def folder(self) -> Path:
        return Path(tempfile.mkdtemp(prefix="job-", dir=self.work))

    def busy(self, kind: str) -> bool:
        """Whether a new check or run would wait beyond the server's bounds (``WAITING``)."""
        if kind == "check":
            return self.checks_waiting >= WAITING
        return sum(job.finished is None for job in self.jobs.values()) >= WAITING

    async def check(self, text: str) -> dict:
        self.checks_waiting += 1
        try:
            async with self.checking:
                folder = self.folder()
                try:
                    return await in_child("check", text, folder, CHECK_SECONDS)
                finally:
                    shutil.rmtree(folder, ignore_errors=True)
        finally:
            self.checks_waiting -= 1

    def start(self, text: str, view: dict[str, list[str]]) -> str:
        """A run of the model text, its view with ``view`` ({"plots": [...], "trace": [...], ...}: ``VIEW_KEYS``);
        its job's id."""
        ident = secrets.token_hex(16)
        self.jobs[ident] = job = Job(self.folder())
        (job.folder / "view.json").write_text(json.dumps(view))
        asyncio.get_running_loop().create_task(self._run(job, text))
        self._forget()
        return ident

    async def _run(self, job: Job, text: str) -> None:
        async with self.running:
            job.state, job.started = "running", time.monotonic()
            job.reply = await in_child("run", text, job.folder, self.run_seconds)
            job.state, job.finished = ("done" if job.reply["ok"] else "failed"), time.monotonic()

    def _forget(self) -> None:
        finished = [k for k, j in self.jobs.items() if j.finished is not None]
        for ident in finished[: max(0, len(finished) - KEPT_JOBS)]:
            shutil.rmtree(self.jobs.pop(ident).folder, ignore_errors=True)

    def status(self, ident: str) -> dict | None:
        job = self.jobs.get(ident)
        if job is None:
            return None
        end = job.finished if job.finished is not None else time.monotonic()
        status = {"state": job.state, "seconds": round(end - job.started, 1), **job.reply}
        if job.state == "running":
            status["fraction"] = read_progress(job.folder)
        return status

    def example_names(self) -> list[str]:
        """The model files of the ``--examples`` folder offered in the page (their names without .yaml)."""
        if self.examples is None or not self.examples.is_dir():
            return []
        return sorted(p.stem for p in self.examples.glob("*.yaml") if EXAMPLE_NAME.fullmatch(p.stem))


def application(server: Server):
    """The Tornado application: the page, plotly.js, the examples, check, run, a job's state and files."""
    import tornado.web

    from .viewer import plotly_js

    class Base(tornado.web.RequestHandler):
        def set_default_headers(self):
            self.set_header("Cache-Control", "no-store")
            self.set_header("X-Content-Type-Options", "nosniff")

        def refused_when_busy(self, kind: str) -> bool:
            if not server.busy(kind):
                return False
            self.set_status(503)
            self.finish({"ok": False, "errors": [{"line": None, "message": f"the server is busy: {kind} later"}]})
            return True

        def model_text(self) -> str | None:
            body = self.request.body
            if len(body) > MAX_MODEL_BYTES:
                self.set_status(413)
                self.finish({"ok": False, "errors": [{"line": None, "message": "the model is larger than 200 kB"}]})
                return None
            return body.decode("utf-8", errors="replace")

    class Page(Base):
        def get(self):
            self.set_header("Content-Type", "text/html; charset=utf-8")
            self.finish(PAGE)

    class Plotly(Base):
        def get(self):
            self.set_header("Content-Type", "application/javascript")
            self.finish(script)

    class Examples(Base):
        def get(self, name: str | None = None):
            if name is None:
                return self.finish({"examples": server.example_names()})
            if name not in server.example_names():
                raise tornado.web.HTTPError(404)
            self.set_header("Content-Type", "text/plain; charset=utf-8")
            self.finish((server.examples / f"{name}.yaml").read_text())

    class Check(Base):
        async def post(self):
            text = self.model_text()
            if text is not None and not self.refused_when_busy("check"):
                self.finish(await server.check(text))

    class Run(Base):
        def post(self):
            view = {key: self.get_argument(key, "").replace(",", " ").split() for key in VIEW_KEYS}
            if any(len(names) > 10 or not all(NAME.fullmatch(n) for n in names) for names in view.values()):
                self.set_status(400)
                return self.finish({"ok": False, "errors": [{"line": None, "message": "plots, trace, reactions and "
                                    "forces: at most 10 names of letters, digits, '_' and '.', such as slider.x or "
                                    "A"}]})  # fmt: skip
            text = self.model_text()
            if text is not None and not self.refused_when_busy("run"):
                self.finish({"job": server.start(text, {k: v for k, v in view.items() if v})})

    class State(Base):
        def get(self, ident: str):
            status = server.status(ident)
            if status is None:
                raise tornado.web.HTTPError(404)
            self.finish(status)

    class Download(Base):
        def get(self, ident: str, name: str):
            status = server.status(ident)
            if status is None or name not in status.get("files", []):
                raise tornado.web.HTTPError(404)
            self.set_header("Content-Type", "text/csv" if name.endswith(".csv") else "application/octet-stream")
            self.set_header("Content-Disposition", f'attachment; filename="{name}"')
            self.finish((server.jobs[ident].folder / name).read_bytes())

    script = plotly_js()
    job = r"([0-9a-f]{32})"
    return tornado.web.Application(
        [
            (r"/", Page),
            (r"/plotly.js", Plotly),
            (r"/examples", Examples),
            (r"/examples/([a-z0-9_]+)", Examples),
            (r"/check", Check),
            (r"/run", Run),
            (rf"/jobs/{job}", State),
            (rf"/jobs/{job}/(result\.csv|result\.npz)", Download),
        ]
    )


async def serve(host: str, port: int, work: Path, run_seconds: float, examples: Path | None = None) -> None:
    import tornado.httpserver
    import tornado.netutil

    server = Server(work, run_seconds, examples)
    sockets = tornado.netutil.bind_sockets(port, host)
    http = tornado.httpserver.HTTPServer(application(server), max_body_size=MAX_MODEL_BYTES + 1024)
    http.add_sockets(sockets)
    bound = sockets[0].getsockname()[1]
    shown = "127.0.0.1" if host in ("", "0.0.0.0") else host
    print(f"mbd serve: http://{shown}:{bound}/ (work folder {work}; Ctrl-C stops)", flush=True)
    await asyncio.Event().wait()


def command_serve(args: argparse.Namespace) -> int:
    """``mbd serve``: the application until Ctrl-C; the work folder (a temporary one by default) removed after."""
    work = Path(args.work) if args.work else Path(tempfile.mkdtemp(prefix="mbd-serve-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        asyncio.run(serve(args.host, args.port, work, args.run_seconds, Path(args.examples) if args.examples else None))
    except KeyboardInterrupt:
        print("mbd serve: stopped")
    except OSError as err:
        from .cli import UsageError

        raise UsageError(f"--port {args.port}: cannot listen on {args.host} ({err.strerror})") from None
    finally:
        if not args.work:
            shutil.rmtree(work, ignore_errors=True)
    return 0


def add_serve(sub) -> None:
    """Register ``mbd serve`` (entry point ``mbd.commands``)."""
    parser = sub.add_parser("serve", help="pre- and post-processing in a browser: edit, check, run and view models")
    parser.add_argument("--host", default="127.0.0.1", help="where to listen (default 127.0.0.1; 0.0.0.0: a classroom)")
    parser.add_argument("--port", type=int, default=8765, help="the port (default 8765; 0: any free one)")
    parser.add_argument("--work", help="the folder of the jobs' files (default: a temporary one, removed at the end)")
    parser.add_argument("--run-seconds", type=float, default=RUN_SECONDS, help="the limit of one run, in seconds")
    parser.add_argument("--examples", help="a folder of model files (.yaml) offered in the page, e.g. course/models")
    parser.set_defaults(handler=command_serve)


PAGE = """<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>mbd serve</title>
<script src="/plotly.js"></script>
<style>
body{margin:0;font-family:sans-serif;display:flex;height:100vh}
#left{width:40%;display:flex;flex-direction:column;padding:8px;box-sizing:border-box}
#right{width:60%;overflow:auto;padding:8px;box-sizing:border-box}
#model{flex:1;font-family:monospace;font-size:13px;white-space:pre;min-height:300px}
#errors{cursor:pointer;color:#b00020;font-family:monospace;font-size:13px;white-space:pre-wrap;min-height:1.2em}
#report,#summary{font-family:monospace;font-size:12px;white-space:pre-wrap;margin:4px 0}
button,select{margin:2px}
</style></head>
<body>
<div id="left">
  <div><select id="examples"><option value="">an example model</option></select>
  <input type="file" id="upload" accept=".yaml,.yml,.json">
  <button id="run">Run</button> <span id="state"></span></div>
  <div><input id="plots" size="28" placeholder="plot columns, e.g. slider.x crank.phi_d">
  <input id="trace" size="22" placeholder="trace joints or points, e.g. A"></div>
  <div><input id="reactions" size="28" placeholder="reaction arrows at joints, e.g. A B">
  <input id="forces" size="22" placeholder="force arrows, e.g. spring"></div>
  <textarea id="model" spellcheck="false" placeholder="a model file (YAML): open an example or a file"></textarea>
  <div id="errors"></div>
</div>
<div id="right">
  <div id="view"></div><div id="report"></div>
  <div id="summary"></div><div id="downloads"></div><div id="result"></div>
</div>
<script>
const $ = (id) => document.getElementById(id);
let timer = null, asked = 0;
function errorsText(reply) {
  return reply.errors.map(e => (e.line ? "line " + e.line + ": " : "") + e.message).join("\\n");
}
async function checkNow() {
  const number = ++asked;
  const reply = await (await fetch("/check", {method: "POST", body: $("model").value})).json();
  if (number !== asked) return;  // an older answer
  if (!reply.ok) { $("errors").textContent = errorsText(reply); return; }
  $("errors").textContent = "";
  $("report").textContent = reply.report.join("\\n");
  Plotly.react("view", reply.figure.data, reply.figure.layout, reply.figure.config);
}
function later() { clearTimeout(timer); timer = setTimeout(checkNow, 400); }
$("model").addEventListener("input", later);
$("errors").addEventListener("click", () => {  // the editor's selection on the first error's line
  const found = /^line (\\d+):/.exec($("errors").textContent);
  if (!found) return;
  const rows = $("model").value.split("\\n"), line = Number(found[1]) - 1;
  const start = rows.slice(0, line).reduce((n, row) => n + row.length + 1, 0);
  $("model").focus();
  $("model").setSelectionRange(start, start + (rows[line] || "").length);
});
$("examples").addEventListener("change", async () => {
  if (!$("examples").value) return;
  $("model").value = await (await fetch("/examples/" + $("examples").value)).text();
  checkNow();
});
$("upload").addEventListener("change", () => {
  const file = $("upload").files[0];
  if (!file) return;
  if (file.size > 200000) { $("errors").textContent = file.name + ": larger than 200 kB"; return; }
  file.text().then(text => { $("model").value = text; checkNow(); });
});
$("run").addEventListener("click", async () => {
  $("summary").textContent = ""; $("downloads").textContent = ""; Plotly.purge("result");
  const asked = new URLSearchParams(
    {plots: $("plots").value, trace: $("trace").value, reactions: $("reactions").value, forces: $("forces").value});
  const started = await (await fetch("/run?" + asked, {method: "POST", body: $("model").value})).json();
  if (!started.job) { $("errors").textContent = errorsText(started); return; }
  const job = started.job;
  while (true) {
    const status = await (await fetch("/jobs/" + job)).json();
    const reached = typeof status.fraction === "number" ? Math.round(100 * status.fraction) + " % of t_end, " : "";
    $("state").textContent = status.state + ", " + reached + status.seconds + " s";
    if (status.state === "done") {
      $("summary").textContent = status.summary;
      $("downloads").innerHTML = status.files.map(
        f => '<a download href="/jobs/' + job + '/' + f + '">' + f + '</a>').join(" ");
      const figure = status.figure;
      await Plotly.newPlot("result", figure.data, figure.layout, figure.config);
      await Plotly.addFrames("result", figure.frames || []);
      return;
    }
    if (status.state === "failed") { $("errors").textContent = errorsText(status); return; }
    await new Promise(done => setTimeout(done, 300));
  }
});
fetch("/examples").then(r => r.json()).then(list => {
  for (const name of list.examples) {
    const option = document.createElement("option"); option.value = option.textContent = name;
    $("examples").appendChild(option);
  }
});
</script></body></html>
"""
"""The page: the editor on the left (examples, upload, Run), the model's view and report, then the result's
view, summary and downloads on the right. plotly.js comes from this server (the plotly wheel's)."""


if __name__ == "__main__" and sys.argv[1:2] == ["child"] and sys.argv[2:3] in (["check"], ["run"]):
    sys.exit(child(sys.argv[2]))
