"""The mechanism views of a student's notebook in nbgrader's feedback page: played there, checked first.

While nbgrader autogrades, the notebook's ``notebook_animation`` cells make views (``solutions.viewer``: a Plotly
figure as an ``application/vnd.plotly.v1+json`` output). nbconvert's HTML does not draw that output type, so
``views_in_feedback`` (a preprocessor of ``nbgrader generate_feedback``, ``course/nbgrader_config.py``) gives each
view an HTML form that plays it in the page (``solutions.viewer.embed_views``), with plotly.js inlined once: the
page stays one file that opens offline.

The figure was made by the student's code in the grader's sandbox: it is data from a hostile source, and the page
is opened by the student and by the instructor. So a view is drawn only when it is what the viewer makes and
nothing more (``safe_figure``): a JSON object of at most ``MAX_FIGURE_BYTES`` with data, layout and frames, every
trace a 2D or 3D scatter (no trace type that loads map tiles or shapes from the network), no layout images or
template (which may name a URL), the course's own Plotly options; it is written into the page with every ``<``,
``>`` and ``&`` escaped (``solutions.viewer.embedded``), so nothing in it can end its script. Anything else stays
the plain-text line of the output.
"""

from __future__ import annotations

import json

MAX_FIGURE_BYTES = 2_000_000
"""The largest view drawn (the viewer's own are 40-200 kB)."""
TRACE_TYPES = {"scatter", "scatter3d"}
"""What the viewer draws with; Plotly's other trace types include maps and geographies fetched from the web."""
LAYOUT_DROPPED = ("images", "template", "mapbox", "map", "geo")
"""Layout keys that can make Plotly fetch something from the network: removed."""
PASSIVE_TAGS = (
    "p", "div", "span", "pre", "br", "hr", "h1", "h2", "h3", "h4", "h5", "h6", "sub", "sup", "dl", "dt", "dd",
    "table", "thead", "tbody", "tfoot", "tr", "th", "td", "caption",
)  # fmt: skip
"""HTML tags a student's output or answer keeps besides bleach's (text and tables: a pandas table stays one)."""


def _traces_ok(traces) -> bool:
    return isinstance(traces, list) and all(
        isinstance(t, dict) and t.get("type", "scatter") in TRACE_TYPES for t in traces
    )


def safe_figure(figure) -> dict | None:
    """The figure as the page may draw it, or None when it is not a view of the viewer's kind (module docstring)."""
    from solutions.viewer import CONFIG

    if not isinstance(figure, dict) or set(figure) - {"data", "layout", "frames", "config"}:
        return None
    try:
        size = len(json.dumps(figure, allow_nan=False))
    except (TypeError, ValueError):
        return None
    layout, frames = figure.get("layout", {}), figure.get("frames", [])
    if size > MAX_FIGURE_BYTES or not isinstance(layout, dict) or not isinstance(frames, list):
        return None
    framed = all(isinstance(frame, dict) and _traces_ok(frame.get("data", [])) for frame in frames)
    if not _traces_ok(figure.get("data")) or not framed:
        return None
    layout = {key: value for key, value in layout.items() if key not in LAYOUT_DROPPED}
    return {"data": figure["data"], "layout": layout, "frames": frames, "config": dict(CONFIG)}


def views_in_feedback():
    """The preprocessor of ``nbgrader generate_feedback`` that gives each safe view its player, plotly.js inlined
    before the first (``solutions.viewer.embed_views``; nbconvert's preprocessors are off unless enabled)."""
    from nbconvert.preprocessors import Preprocessor
    from traitlets import Bool

    from solutions.viewer import embed_views, plotly_js

    class ViewsInFeedback(Preprocessor):
        enabled = Bool(True)

        def preprocess(self, nb, resources):
            embed_views(nb, f'<script id="plotly-js">{plotly_js()}</script>', "view", check=safe_figure)
            return nb, resources

    return ViewsInFeedback


def student_html_sanitized():
    """The preprocessor of every HTML page nbgrader makes of a submission (``c.HTMLExporter.preprocessors``:
    ``generate_feedback``'s pages and the formgrader's, which the instructor opens in the Jupyter server's origin):
    nbconvert's ``SanitizeHTML`` (bleach) over the notebook before its template, so that no script, event handler
    or other active markup a student wrote into a markdown answer or made a cell output reaches the page. Kept
    as they are: the outputs nbconvert calls safe (text, PNG, JPEG, LaTeX, JSON) and the mechanism views' data
    (``safe_figure`` checks them when the feedback step gives them a player, after this one); removed:
    JavaScript, SVG and every other active output type; of HTML, the tags of text and tables (``PASSIVE_TAGS``)
    with their classes. A markdown cell is cleaned only when it holds a tag (``<name `` or ``<name>``, ``</``,
    ``<!``, ``<?``): a ``<`` in a formula or in code stays as written."""
    import re

    from bleach import ALLOWED_ATTRIBUTES, ALLOWED_TAGS
    from nbconvert.preprocessors.sanitize import SanitizeHTML
    from traitlets import Bool

    from solutions.viewer import MIME

    tag = re.compile(r"<(?:[A-Za-z][\w-]*[\s/>]|/[A-Za-z]|!|\?)")

    class StudentHTMLSanitized(SanitizeHTML):
        enabled = Bool(True)

        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.safe_output_keys = {*self.safe_output_keys, MIME}
            self.tags = sorted({*ALLOWED_TAGS, *PASSIVE_TAGS})
            self.attributes = {**ALLOWED_ATTRIBUTES, "*": ["class"], "td": ["class", "colspan", "rowspan"],
                               "th": ["class", "colspan", "rowspan"]}  # fmt: skip

        def preprocess_cell(self, cell, resources, index):
            if cell.cell_type in ("markdown", "raw") and not tag.search(cell.source):
                return cell, resources
            return super().preprocess_cell(cell, resources, index)

    return StudentHTMLSanitized
