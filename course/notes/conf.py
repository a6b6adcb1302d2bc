"""Sphinx's configuration of the course notes' site (``course/notes/build.py`` stages the pages and builds it).

The pages are the chapters and lectures as executed notebooks (MyST-NB reads them; nothing is run again here),
the math is MathJax 2.7 from the ``jupyter-server-mathjax`` wheel copied into the site's ``_static/mathjax``
(``build.write_mathjax``): a page renders its equations from disk, with no network. Search is Sphinx's own
(``search.html``, its index a local script). The theme is Sphinx's built-in alabaster: no theme package to fetch.
"""

project = "Computational multibody dynamics: course notes"
author = "mbd-course"
copyright = "mbd-course contributors (MIT licence)"

extensions = ["myst_nb"]
myst_enable_extensions = ["dollarmath", "amsmath"]
myst_update_mathjax = False
"""No MathJax 3 configuration: a window.MathJax object set before MathJax 2 loads stops its typesetting."""
"""$...$ and $$...$$ as in Jupyter; the chapters number their displays themselves with \\tag{N.M}."""

nb_execution_mode = "off"
"""build.py executes each notebook once (nbclient) before it is staged."""
nb_merge_streams = True

exclude_patterns = [".doctrees", "_build", "**.ipynb_checkpoints"]
suppress_warnings = ["mystnb.unknown_mime_type", "myst.header"]
"""A view's plotly MIME output also carries the HTML that plays it (build.py); chapters open with '# Chapter N.'
and number their sections themselves ('## 3.2 ...')."""

templates_path = ["_templates"]
"""layout.html: a line at the top of every page that says what to do where scripts do not run (JupyterLab's
viewer of an HTML file, until it is trusted): the equations are typeset by MathJax."""
html_theme = "alabaster"
html_title = "Course notes"
html_static_path: list[str] = []
"""build.py gives the stage's _static (MathJax, plotly.js)."""
html_copy_source = False
html_show_sourcelink = False
html_show_sphinx = False
html_theme_options = {"page_width": "1180px", "sidebar_width": "250px", "fixed_sidebar": True}
html_sidebars = {"**": ["about.html", "searchfield.html", "navigation.html", "relations.html"]}

mathjax_path = "mathjax/MathJax.js?config=TeX-AMS-MML_HTMLorMML-full"
"""Relative to _static: the copy build.py makes from the jupyter-server-mathjax wheel."""
mathjax2_config = {
    "tex2jax": {"inlineMath": [["\\(", "\\)"]], "displayMath": [["\\[", "\\]"]], "processEscapes": True},
    "HTML-CSS": {"availableFonts": [], "webFont": "STIX-Web", "imageFont": None},
    "TeX": {"equationNumbers": {"autoNumber": "none"}},
    "messageStyle": "none",
}
"""MathJax 2's output with the STIX web fonts the wheel ships (it has no TeX fonts, and no image fonts)."""


def _displays_as_written(app, doctree) -> None:
    """Give MathJax each display as the chapter writes it, in \\[ ... \\]: Sphinx would wrap a display holding
    ``\\\\`` in ``split``, where the chapter's ``\\tag{N.M}`` is an error (MathJax shows the source instead)."""
    from docutils import nodes

    for block in doctree.findall(nodes.math_block):
        if not block.get("nowrap"):
            block["nowrap"] = True
            block.children = [nodes.Text("\\[" + block.astext() + "\\]")]


def setup(app):
    app.connect("doctree-read", _displays_as_written)
