"""The mechanism views of a student's notebook in nbgrader's feedback page (autograder/views.py): drawn only when
they are what the viewer makes, written so that nothing in them can end their script. Played in chromium in
nbgrader's own feedback template: tests/solutions/test_viewer_browser.py."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from urllib.parse import urljoin

import nbformat
import pytest

from autograder.views import MAX_FIGURE_BYTES, safe_figure, views_in_feedback
from solutions.io.model import load_model
from solutions.viewer import CONFIG, MIME, model_view

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def figure() -> dict:
    return model_view(load_model(REPO / "course" / "models" / "slider_crank.yaml")).figure


def test_a_view_of_the_viewers_kind_is_drawn_with_the_courses_options_and_no_remote_parts(figure):
    assert safe_figure(figure) == {**figure, "frames": figure.get("frames", []), "config": CONFIG}
    dressed = copy.deepcopy(figure)
    dressed["config"] = {"showLink": True, "linkText": "x", "plotlyServerURL": "https://example.org"}
    dressed["layout"]["images"] = [{"source": "https://example.org/pixel.png"}]
    dressed["layout"]["template"] = {"layout": {"images": [{"source": "https://example.org/t.png"}]}}
    drawn = safe_figure(dressed)
    assert drawn["config"] == CONFIG and "images" not in drawn["layout"] and "template" not in drawn["layout"]


def test_what_the_viewer_does_not_make_is_not_drawn(figure):
    hostile = []
    for trace_type in ("scattergeo", "scattermapbox", "choropleth", "image"):
        bad = copy.deepcopy(figure)
        bad["data"].append({"type": trace_type, "lon": [0], "lat": [0]})
        hostile.append(bad)
        framed = copy.deepcopy(figure)
        framed["frames"] = [{"data": [{"type": trace_type}]}]
        hostile.append(framed)
    hostile += [
        None, "figure", [figure], {**figure, "extra": 1}, {**figure, "frames": {"a": 1}}, {**figure, "layout": []},
        {**figure, "data": [{"x": [float("nan")]}]}, {**figure, "data": [{"x": ["y" * MAX_FIGURE_BYTES]}]},
        {**figure, "data": "scatter"}, {**figure, "data": ["scatter"]},
    ]  # fmt: skip
    assert [safe_figure(h) for h in hostile] == [None] * len(hostile)


def test_the_feedback_step_gives_each_safe_view_a_player_and_escapes_it(figure):
    titled = copy.deepcopy(figure)
    titled["layout"]["title"] = {"text": "</script><script>alert(1)</script> & <b>"}
    bad = copy.deepcopy(figure)
    bad["data"].append({"type": "scattergeo"})
    nb = nbformat.v4.new_notebook()
    outputs = [nbformat.v4.new_output("display_data", data={MIME: f, "text/plain": "view"}) for f in (titled, bad)]
    nb.cells = [nbformat.v4.new_code_cell("views", outputs=outputs)]
    step = views_in_feedback()()
    nb, _ = step.preprocess(nb, {})
    html = nb.cells[0].outputs[0]["data"]["text/html"]
    assert html.startswith('<script id="plotly-js">') and html.count('class="mbd-view"') == 1
    player = html.split('<div id="view-1"', 1)[1]
    assert "</script><script>alert" not in player and "<b>" not in player
    figure_json = player.split("const figure = ", 1)[1].split(";\nPlotly.newPlot", 1)[0]
    assert json.loads(figure_json)["layout"]["title"]["text"] == titled["layout"]["title"]["text"]
    assert "text/html" not in nb.cells[0].outputs[1]["data"]  # not the viewer's kind: its plain-text line only


HOSTILE_ANSWER = "My answer <script>fetch('/api/contents')</script>, with $a < b$ and `x<y`."
HOSTILE_OUTPUT = "<img src=x onerror=\"fetch('/api')\"><table><tr><td>1.5</td></tr></table>"


def rendered(template: str) -> str:
    """A submission with a markdown answer and an output that carry scripts, made into the course's page ``template``
    ("mbd_feedback" or "mbd_formgrade", which extend nbgrader's) by an exporter with the course's nbgrader
    configuration (its template folders, its steps), as nbgrader makes it."""
    from nbconvert import HTMLExporter
    from traitlets.config.loader import PyFileConfigLoader

    from autograder.nbpages import feedback_summary

    config = PyFileConfigLoader("nbgrader_config.py", path=str(REPO / "course")).load_config()
    exporter = HTMLExporter(config=config, template_name=template)
    if template == "mbd_feedback":
        exporter.register_preprocessor(feedback_summary(), enabled=True)  # the page's total (generate_feedback's)
    answer = {"solution": True, "grade": True, "grade_id": "why", "points": 2, "score": 1.0}
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_markdown_cell(HOSTILE_ANSWER, metadata={"nbgrader": answer}),
        nbformat.v4.new_markdown_cell("A plain answer: $a < b$ and `x<y`."),
        nbformat.v4.new_code_cell("show()", outputs=[nbformat.v4.new_output(
            "display_data", data={"text/html": HOSTILE_OUTPUT, "application/javascript": "alert('js')",
                                  "image/svg+xml": "<svg onload=\"alert('svg')\"></svg>", "text/plain": "shown"})]),
    ]  # fmt: skip
    resources = {"nbgrader": {"notebook": "hw", "score": 1.0, "max_score": 2.0, "late_penalty": 0.0}, "index": 0,
                 "total": 1, "base_url": "/", "student": "rex", "notebook_path": "hw.ipynb"}  # fmt: skip
    return exporter.from_notebook_node(nb, resources=resources)[0]


@pytest.mark.parametrize("template", ["mbd_feedback", "mbd_formgrade"])
def test_no_script_a_student_writes_reaches_nbgraders_pages(template):
    """nbgrader's feedback page (returned to the student) and the formgrader's page (opened by the instructor in
    the Jupyter server's origin): the answer's script and the output's event handler are text, the JavaScript and
    SVG outputs gone; the table stays a table and a markdown cell without a tag as written."""
    page = rendered(template)
    assert "<script>fetch(" not in page and "&lt;script&gt;fetch(" in page
    assert "<img" not in page and "&lt;img src=" in page
    assert "alert('js')" not in page and "alert('svg')" not in page
    assert "<td>1.5</td>" in page
    assert "A plain answer: $a &lt; b$ and <code>x&lt;y</code>." in page


@pytest.mark.parametrize("template", ["mbd_feedback", "mbd_formgrade"])
def test_nbgraders_pages_load_mathjax_from_the_wheel_not_a_cdn(template):
    """nbgrader's templates call nbconvert's mathjax() without a URL (a CDN): the course's load the feedback
    page's copy beside it (written by its step, autograder.nbpages.mathjax_beside) or the Jupyter server's
    (jupyter_server_mathjax, relative to the formgrader's BASE/formgrader/submissions/ID/)."""
    import jupyter_server_mathjax

    from autograder.nbpages import MATHJAX_FILES, mathjax_beside

    page = rendered(template)
    sources = re.findall(r'<script[^>]* src="([^"]*)"', page)
    mathjax = [url for url in sources if "MathJax.js" in url]
    assert "cdnjs" not in page and not [url for url in sources if "://" in url], sources
    assert len(mathjax) == 1 and 'webFont: "STIX-Web"' in page  # the only fonts the wheel ships
    path = mathjax[0].split("?", 1)[0]
    if template == "mbd_feedback":
        assert path == "mathjax/MathJax.js"
        _, resources = mathjax_beside()().preprocess(nbformat.v4.new_notebook(), {})
        written = resources["outputs"]
        assert "mathjax/MathJax.js" in written and "mathjax/config/TeX-AMS-MML_HTMLorMML-full.js" in written
        assert mathjax[0].split("config=")[1].split(",")[0] == "TeX-AMS-MML_HTMLorMML-full"
        assert len(MATHJAX_FILES) < len(written) < 300 and sum(map(len, written.values())) < 3_000_000
    else:  # the server's static path of jupyter_server_mathjax, from the submission's page three folders down
        server = urljoin("http://host/base/formgrader/submissions/1234/", path)
        assert server == "http://host/base/static/jupyter_server_mathjax/MathJax.js"
        assert (Path(jupyter_server_mathjax.__file__).parent / "static" / "MathJax.js").is_file()
