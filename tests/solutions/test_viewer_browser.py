"""The viewer as people see it: JupyterLab 4 in headless Chromium (Playwright), offline, with Lab's default
notebook windowing; a notebook with a planar and a spatial view, executed headless as a student's Run All leaves
it, opened untrusted, played, saved, reopened and played again; and the page of ``mbd view``. Every request that
leaves 127.0.0.1 fails the test. Screenshots are kept in build/test-artifacts/browser/ (look at them).

Chromium is Debian's (``make test`` installs it as it installs bubblewrap); where it or Playwright is missing the
tests skip with one line saying so."""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path
from urllib.parse import urlparse

import nbformat
import pytest
from nbclient import NotebookClient

from course.notes import linked, note_pages
from course.notes.build import build_notes
from solutions.cli import main

from ..conftest import execute_notebook
from .test_serve import Server

REPO = Path(__file__).resolve().parents[2]
ARTIFACTS = REPO / "build" / "test-artifacts" / "browser"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
LOCAL = {"127.0.0.1", "localhost", ""}
NO_NEWS = {"disabledExtensions": {"@jupyterlab/apputils-extension:announcements": True}}
"""Lab's page configuration: the plugin that asks to fetch news from the web, off."""
TYPESET = (
    "() => window.MathJax && MathJax.Hub && MathJax.Hub.queue.pending === 0 && "
    "document.querySelectorAll('.MathJax_Display').length > 0"
)
"""A page of the notes whose MathJax has typeset its displays."""
CURRENT_TIME = ".slider-group > text.slider-label"
"""The slider's current value ("t = 0.000 s"), the first label of Plotly's slider."""

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (make test installs it)")
if CHROMIUM is None:
    pytest.skip(
        "Debian's chromium is not installed (make test installs it as root): browser tests skipped",
        allow_module_level=True,
    )

pytestmark = pytest.mark.filterwarnings("ignore::ResourceWarning")  # Playwright's driver pipes, closed at exit

CELLS = [
    """import os
os.chdir(os.environ["MBD_REPO"])
from solutions.assembly import build_system
from solutions.dynamics import forward_dynamics
from solutions.io.model import load_model
from solutions.kinematics import kinematic_analysis
from solutions.viewer import notebook_animation""",
    """model = load_model("course/models/slider_crank.yaml")
system, q0, qd0 = build_system(model)
result = kinematic_analysis(system, q0, 0.6283185307179586, 100)
notebook_animation(model, system, result, trace=["A"], plots=["slider.x"])""",
    "Long text between the two views, as in the homework. " * 300,
    """model = load_model("course/models/spatial_double_pendulum.yaml")
system, q0, qd0 = build_system(model)
notebook_animation(model, system, forward_dynamics(system, q0, qd0, 1.0, 100))""",
]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def notebook(tmp_path_factory) -> Path:
    """The notebook after a headless Run All (unsigned: JupyterLab opens it untrusted)."""
    folder = tmp_path_factory.mktemp("lab")
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_markdown_cell(c) if c.startswith("Long") else nbformat.v4.new_code_cell(c) for c in CELLS
    ]
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    os.environ["MBD_REPO"] = str(REPO)
    execute_notebook(NotebookClient(nb, timeout=300))
    nb.cells.insert(0, nbformat.v4.new_markdown_cell(linked("The revolute joint (eq. 3.17).", note_pages())))
    build_notes(folder / "notes", execute=False, paths=[REPO / "course" / "notes" / "ch03_planar_constraints.ipynb"])
    nbformat.write(nb, folder / "views.ipynb")  # with a statement's link into a kit's notes/ beside it
    return folder / "views.ipynb"


class Lab:
    """A JupyterLab server on 127.0.0.1 for one folder, with a Jupyter data folder of its own (a fresh machine:
    no notebook is trusted), stopped at exit."""

    def __init__(self, folder: Path, data: Path):
        self.port = free_port()
        environment = dict(os.environ, JUPYTER_DATA_DIR=str(data), JUPYTER_CONFIG_DIR=str(data / "config"))
        (data / "config" / "labconfig").mkdir(parents=True)  # no question about fetching news
        (data / "config" / "labconfig" / "page_config.json").write_text(json.dumps(NO_NEWS))
        self.process = subprocess.Popen(
            [sys.executable, "-m", "jupyterlab", "--no-browser", f"--port={self.port}", "--ip=127.0.0.1",
             "--ServerApp.token=", "--ServerApp.password=", "--ServerApp.disable_check_xsrf=True",
             "--allow-root", f"--ServerApp.root_dir={folder}", "--LabApp.news_url=",
             "--LabApp.check_for_updates_class=jupyterlab.NeverCheckForUpdate"],
            env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        deadline = time.monotonic() + 60
        while True:
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{self.port}/api/status", timeout=2).close()
                return
            except OSError:
                if time.monotonic() > deadline or self.process.poll() is not None:
                    raise RuntimeError("JupyterLab did not start") from None
                time.sleep(0.3)

    def url(self, path: str) -> str:
        return f"http://127.0.0.1:{self.port}/lab/tree/{path}"

    def stop(self) -> None:
        self.process.terminate()
        self.process.wait(timeout=20)


@pytest.fixture(scope="module")
def browser():
    with sync_api.sync_playwright() as playwright:
        flags = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-sync",
                 "--disable-background-networking", "--disable-component-update"]  # fmt: skip
        chromium = playwright.chromium.launch(executable_path=CHROMIUM, args=flags)
        yield chromium
        chromium.close()


def open_page(browser, url: str, outside: list[str]):
    page = browser.new_page(viewport={"width": 1000, "height": 720})
    page.on("request", lambda r: outside.append(r.url) if urlparse(r.url).hostname not in LOCAL and
            not r.url.startswith(("data:", "blob:", "file:", "about:")) else None)  # fmt: skip
    page.goto(url)
    return page


def slider_time(view) -> str:
    return view.locator(CURRENT_TIME).text_content()


def play_each_view(page, name: str, count: int = 2) -> list[tuple[str, str]]:
    """The notebook's ``count`` viewers, scrolled to one after the other (Lab renders a cell only near the view):
    each of a non-zero size, one click on Play, the slider's time before and after (screenshots kept)."""
    page.wait_for_selector(".jp-RenderedPlotly", timeout=60_000)
    views = page.locator(".jp-RenderedPlotly")
    times = []
    for k in range(count):
        for _ in range(40):  # scroll the notebook down until the next view is rendered
            if views.count() > k:
                break
            page.evaluate("document.querySelector('.jp-WindowedPanel-outer').scrollBy(0, 600)")
            page.wait_for_timeout(250)
        view = views.nth(k)
        view.scroll_into_view_if_needed()
        view.locator(".updatemenu-button").first.wait_for(timeout=30_000)
        box = view.bounding_box()
        assert box and box["width"] > 300 and box["height"] > 300, (name, k, box)
        before = slider_time(view)
        view.locator(".updatemenu-button").first.click()  # Play
        page.wait_for_timeout(600)
        times.append((before, slider_time(view)))
        page.screenshot(path=str(ARTIFACTS / f"{name}-view{k + 1}.png"))
    return times


def test_the_views_play_in_jupyterlab_untrusted_offline_and_after_save_and_reopen(notebook, browser, tmp_path):
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    outside: list[str] = []
    lab = Lab(notebook.parent, tmp_path / "data")
    try:
        page = open_page(browser, lab.url(notebook.name), outside)
        first = play_each_view(page, "lab-untrusted")
        page.keyboard.press("Control+s")
        page.wait_for_timeout(1500)
        page.reload()
        reopened = play_each_view(page, "lab-reopened")
        link = page.locator(".jp-RenderedMarkdown a", has_text="3.17").get_attribute("href")  # Lab's /files/ URL
        notes = open_page(browser, link, outside)  # as a middle-click opens it: a tab of its own
        page.close()
        notes.wait_for_function(TYPESET, timeout=30000)
        top = notes.evaluate("() => document.getElementById('eq-3.17').getBoundingClientRect().top")
        notes.screenshot(path=str(ARTIFACTS / "lab-link-eq-3.17.png"))
    finally:
        lab.stop()
    assert -2 < top < 60, top  # the statement's link, opened in a tab, lands on eq. 3.17, typeset by the notes' MathJax
    assert len(first) == len(reopened) == 2
    for before, after in first + reopened:
        assert before == "t = 0.000 s" and after != before, (before, after)  # it plays on the first click
    assert outside == []
    saved = nbformat.read(notebook, as_version=4)
    assert len(nbformat.writes(saved)) < 2_000_000


def test_the_page_of_mbd_view_draws_and_plays_offline(browser, tmp_path):
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    outside: list[str] = []
    model = REPO / "course" / "models" / "spatial_slider_crank.yaml"
    assert main(["view", str(model), "--out", str(tmp_path / "model.html")]) == 0
    page = open_page(browser, (tmp_path / "model.html").as_uri(), outside)
    page.wait_for_selector(".main-svg", timeout=30_000)
    page.wait_for_timeout(500)
    page.screenshot(path=str(ARTIFACTS / "mbd-view-model.png"))
    assert "degrees of freedom: 0" in page.inner_text("pre")
    assert page.locator("#view").bounding_box()["height"] > 300
    csv = tmp_path / "crank.csv"
    assert main(["run", str(REPO / "course" / "models" / "slider_crank.yaml"), "--steps", "50", "--out", str(csv)]) == 0
    assert main(["view", str(REPO / "course" / "models" / "slider_crank.yaml"), str(csv), "--out",
                 str(tmp_path / "run.html"), "--trace", "A", "--plot", "slider.x"]) == 0  # fmt: skip
    page.goto((tmp_path / "run.html").as_uri())
    times = play_each_view_page(page)
    page.screenshot(path=str(ARTIFACTS / "mbd-view-result.png"))
    assert times[0] == "t = 0.000 s" and times[1] != times[0]
    assert outside == []


def test_the_notes_chapter_plays_its_view_offline(browser, tmp_path):
    """Chapter 5 of the notes built as `mbd notes` builds it (executed), opened from disk with no network: its
    equations typeset by the site's own MathJax (no source left, no error), a link to eq. 5.25 opens with that
    equation at the top of the window, and its view of the slider-crank's turn, with the reaction arrows, plays
    on the first click. Nothing is asked of the network."""
    from course.notes.build import build_notes

    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    outside: list[str] = []
    chapter = REPO / "course" / "notes" / "ch05_planar_dynamics.ipynb"
    build_notes(tmp_path, paths=[chapter])
    page = open_page(browser, (tmp_path / "ch05_planar_dynamics.html").as_uri() + "#eq-5.25", outside)
    page.wait_for_function(TYPESET, timeout=30000)
    page.wait_for_timeout(500)
    page.screenshot(path=str(ARTIFACTS / "notes-ch05-eq-5.25.png"))
    displays = page.locator(".MathJax_Display").count()
    assert displays == page.locator("div.math").count() > 20, displays  # every display typeset
    assert page.locator(".MathJax .merror").count() == 0 and "\\tag{" not in page.inner_text("div.body")
    top = page.evaluate("() => document.getElementById('eq-5.25').getBoundingClientRect().top")
    assert -2 < top < 60, top  # the window opens on the equation
    view = page.locator(".mbd-view").first
    view.scroll_into_view_if_needed()
    times = play_each_view_page(page, view)
    box = view.bounding_box()
    page.screenshot(path=str(ARTIFACTS / "notes-ch05-view.png"))
    assert box and box["width"] > 300 and box["height"] > 300, box
    assert times[0] == "t = 0.000 s" and times[1] != times[0]
    assert outside == []


TEMPLATE_CDN = ("https://cdnjs.cloudflare.com/ajax/libs/require.js/", "https://cdnjs.cloudflare.com/ajax/libs/mathjax/")
"""What nbconvert's templates still ask a CDN for (MathJax and require.js: issue 27 makes the math offline)."""


def feedback_page(nb, folder: Path) -> Path:
    """The notebook's page as ``nbgrader generate_feedback`` writes it into ``folder``: the course's feedback
    template and steps (course/nbgrader_config.py: the views given their players, autograder/views.py; the total
    and MathJax written beside the page, autograder/nbpages.py)."""
    from nbconvert import HTMLExporter
    from nbconvert.writers import FilesWriter
    from traitlets.config.loader import PyFileConfigLoader

    from autograder.nbpages import feedback_summary, mathjax_beside
    from autograder.views import views_in_feedback

    config = PyFileConfigLoader("nbgrader_config.py", path=str(REPO / "course")).load_config()
    exporter = HTMLExporter(config=config, template_name="mbd_feedback")  # the student's markup cleaned first
    for step in (feedback_summary(), mathjax_beside(), views_in_feedback()):
        exporter.register_preprocessor(step, enabled=True)
    graded = {"notebook": "feedback", "score": 1.0, "max_score": 2.0, "late_penalty": 0.0}
    body, resources = exporter.from_notebook_node(nb, resources={"nbgrader": graded})
    FilesWriter(build_directory=str(folder)).write(body, resources, notebook_name="feedback")  # as nbgrader's writer
    return folder / "feedback.html"


EQUATION = "The revolute joint, eq. 3.17: $$\\Psi = \\mathbf{r}_i + \\mathbf{A}_i \\mathbf{s}'_i - \\mathbf{r}_j = 0$$"
"""A cell with an equation for the feedback page (the notebook's cells have none; hw1's statement has 24)."""


def test_the_views_play_in_nbgraders_feedback_page_offline(notebook, browser, tmp_path):
    """The executed notebook's two views (planar and spatial) in the feedback page nbgrader writes: each has a
    non-zero size and plays on the first click, the page opened from disk, plotly.js inside it; its equation
    rendered by the MathJax written beside it, every request that is not a file aborted."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    nb = nbformat.read(notebook, as_version=4)
    nb.cells.insert(0, nbformat.v4.new_markdown_cell(EQUATION))
    page_file = feedback_page(nb, tmp_path)
    outside: list[str] = []
    page = browser.new_page(viewport={"width": 1000, "height": 720})
    page.route("**/*", lambda route: route.continue_() if route.request.url.startswith("file:") else route.abort())
    page.on(
        "request", lambda r: None if r.url.startswith(("file:", "data:", "blob:", "about:")) else outside.append(r.url)
    )
    page.goto(page_file.as_uri())
    page.wait_for_function("window.MathJax && MathJax.Hub && MathJax.Hub.queue.pending === 0", timeout=30_000)
    formula = page.locator(".MathJax_Display").first
    formula.wait_for(timeout=30_000)
    page.screenshot(path=str(ARTIFACTS / "feedback-math.png"))
    assert formula.bounding_box()["height"] > 10 and "\\mathbf" not in page.inner_text("body")  # typeset, not TeX
    assert page.locator(".MathJax_Display .MathJax span").count() > 10  # MathJax's HTML-CSS glyphs
    views = page.locator(".mbd-view")
    assert views.count() == 2
    for k in range(2):
        view = views.nth(k)
        view.scroll_into_view_if_needed()
        before, after = play_each_view_page(page, view)
        box = view.bounding_box()
        page.screenshot(path=str(ARTIFACTS / f"feedback-view{k + 1}.png"))
        assert box and box["width"] > 300 and box["height"] > 300, box
        assert before == "t = 0.000 s" and after != before, (k, before, after)
    assert outside == []


def play_each_view_page(page, view=None) -> tuple[str, str]:
    """The slider's time before and after one click on Play of the page's first view (or of ``view``)."""
    view = view or page
    view.locator(".updatemenu-button").first.wait_for(timeout=30_000)
    before = slider_time(view)
    view.locator(".updatemenu-button").first.click()
    page.wait_for_timeout(600)
    return before, slider_time(view)


def test_mbd_serve_opens_edits_runs_and_downloads_offline(browser, tmp_path):
    """An example opened, drawn and checked; a key edited to an error (shown with its line) and back; the model
    run, its result played and its CSV downloaded: all from the browser, no request leaving the machine."""
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    outside: list[str] = []
    server = Server()
    try:
        page = open_page(browser, server.url + "/", outside)
        page.set_viewport_size({"width": 1400, "height": 900})
        page.wait_for_selector("#examples option[value=slider_crank]", state="attached", timeout=30_000)
        page.select_option("#examples", "slider_crank")
        page.wait_for_function("document.getElementById('report').textContent.includes('degrees of freedom')")
        assert "degrees of freedom: 0" in page.inner_text("#report")
        assert page.locator("#view .main-svg").first.bounding_box()["height"] > 300
        text = page.input_value("#model")
        line = next(k for k, row in enumerate(text.splitlines(), start=1) if "name: rod" in row)
        page.fill("#model", text.replace("name: rod,    mass: 1.0", "name: rod,    mass: abc"))
        page.wait_for_function("document.getElementById('errors').textContent.length > 0")
        assert page.inner_text("#errors") == f"line {line}: model.bodies[1].mass: expected number, got 'abc'"
        page.click("#errors")  # the editor selects the error's line
        selection = "(m => m.value.slice(m.selectionStart, m.selectionEnd))(document.getElementById('model'))"
        selected = page.evaluate(selection)
        assert selected.strip().startswith("- {name: rod,    mass: abc"), selected
        page.screenshot(path=str(ARTIFACTS / "mbd-serve-error.png"))
        page.fill("#model", text)
        page.wait_for_function("document.getElementById('errors').textContent === ''")
        page.fill("#plots", "slider.x crank.phi_d")
        page.fill("#trace", "A")
        page.click("#run")
        page.wait_for_selector("#downloads a", timeout=60_000)
        names = page.evaluate("document.getElementById('result').data.map(t => t.name)")
        assert {"slider.x", "crank.phi_d", "path of A"} <= set(names), names
        assert "kinematic analysis: 201 output points" in page.inner_text("#summary")
        before, after = play_each_view_page(page, page.locator("#result"))
        assert before == "t = 0.000 s" and after != before
        page.screenshot(path=str(ARTIFACTS / "mbd-serve.png"))
        with page.expect_download() as download:
            page.click("#downloads a[href$='result.csv']")
        saved = tmp_path / "result.csv"
        download.value.save_as(saved)
        header = saved.read_text().splitlines()[0].split(",")
        assert header[:2] == ["t", "crank.x"] and "slider.x" in header and len(saved.read_text().splitlines()) == 202
        page.close()
    finally:
        server.stop()
    assert outside == []
