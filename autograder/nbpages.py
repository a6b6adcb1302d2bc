"""nbgrader's pages of a submission as people read them: the feedback page a student opens from disk and the
formgrader's page the instructor opens in the Jupyter server.

nbgrader's own templates label every graded cell "Test cell", head the page with nbgrader's total (the checks'
100 points plus the written answers' 10, graded by hand: /110, where ``mbd grade`` says /100) and load MathJax
from a CDN (their ``mathjax()`` is called without nbconvert's ``mathjax_url``): offline, every equation stays
raw LaTeX. The course's templates (``autograder/templates``, set in ``course/nbgrader_config.py``) extend
nbgrader's and take from here:

- ``feedback_summary`` (a ``generate_feedback`` step, after nbgrader's ``GetGrades``): each graded test cell's
  group (its ``check("hwN", "group")``, the instructor's source), the page's one total on the homework's scale
  (the checks' points, the same as ``mbd grade``'s, with the written answers said apart), and the summary of
  ``mbd grade``'s page: each cause of the failures once, the costliest first (``autograder.feedback.causes_part``),
  and the points and checks passed per group, from the outcomes ``autograder.api.GraderPoints`` kept in the
  notebook.
- ``mathjax_beside`` (a ``generate_feedback`` step): the MathJax 2.7 of the ``jupyter-server-mathjax`` wheel
  (``MATHJAX_FILES``) written beside the page, in ``mathjax/``, through nbconvert's ``resources["outputs"]``
  (nbgrader's own writer puts them into the student's feedback folder), so that the page, opened from disk,
  renders its equations with no network.

nbgrader's templates call nbconvert's ``mathjax()`` macro without a URL, so ``HTMLExporter.mathjax_url`` does not
reach them: the course's template folders hold a ``mathjax.html.j2`` of their own, found before nbconvert's,
whose ``mathjax()`` loads the copy beside the feedback page, or on the formgrader's page the Jupyter server's
(``jupyter_server_mathjax``, relative to the page), set up for the only fonts the wheel ships (STIX-Web).
"""

from __future__ import annotations

from pathlib import Path

TEMPLATES = Path(__file__).parent / "templates"
"""The course's nbgrader templates (``mbd_feedback``, ``mbd_formgrade``; ``mbd_shared``: their MathJax set-up)."""

MATHJAX_FOLDER = "mathjax"
"""The folder beside a feedback page that holds its MathJax (``templates/mbd_feedback/mathjax.html.j2`` loads
``mathjax/MathJax.js``)."""

MATHJAX_FILES = (
    "MathJax.js",
    "config/TeX-AMS-MML_HTMLorMML-full.js",
    "config/Safe.js",
    "extensions/Safe.js",
    "extensions/MathMenu.js",
    "extensions/MathZoom.js",
    "extensions/TeX/",
    "jax/element/mml/optable/",
    "jax/output/HTML-CSS/",
    "fonts/HTML-CSS/STIX-Web/woff/",
)
"""What a page's formulas load from the wheel, folders whole (169 files, 1.9 MB of its 12 MB). Measured in
headless Chromium on hw1's feedback page (24 formulas): the first four files, then STIX-Web's font data and fonts
(under ``jax/output/HTML-CSS/`` and ``fonts/``) and the operator tables (``jax/element/mml/optable/``) as
characters need them; the menu and zoom load on a click, ``extensions/TeX/`` for the macros the combined
configuration leaves out (``\\cancel``, ``\\bbox``, ...). Not the SVG output, MathML, the localizations, the
a11y extensions."""


def mathjax_root() -> Path:
    """The MathJax folder of the ``jupyter-server-mathjax`` wheel."""
    import jupyter_server_mathjax

    return Path(jupyter_server_mathjax.__file__).parent / "static"


def mathjax_files() -> dict[str, bytes]:
    """{path under ``mathjax/``: content} of every file of ``MATHJAX_FILES``."""
    root, files = mathjax_root(), {}
    for entry in MATHJAX_FILES:
        paths = sorted(p for p in (root / entry).rglob("*") if p.is_file()) if entry.endswith("/") else [root / entry]
        for path in paths:
            files[path.relative_to(root).as_posix()] = path.read_bytes()
    return files


OUTCOMES = "mbd_grader"
"""Where ``autograder.api.GraderPoints`` keeps the grader's outcomes in the autograded notebook's metadata."""


def written_outcomes(outcomes: list) -> list[dict]:
    """The outcomes as the notebook keeps them (JSON: what ``summary_part`` needs, no plot)."""
    keys = ("name", "group", "scene", "kind", "points", "max_points", "passed", "message", "visibility")
    return [{key: getattr(o, key) for key in keys} for o in outcomes]


def kept_outcomes(nb) -> list:
    """The outcomes ``GraderPoints`` kept in an autograded notebook (none in one autograded before it kept them,
    or whose entry is not what it writes)."""
    from mbdkit.checks import Outcome

    kept = nb.metadata.get(OUTCOMES, {}).get("outcomes", [])
    try:
        return [Outcome(**o) for o in kept]
    except TypeError:
        return []


def passed_by_group(outcomes: list) -> dict[str, str]:
    """{group: "4 of 6 checks passed"} of the outcomes."""
    groups: dict[str, list] = {}
    for o in outcomes:
        groups.setdefault(o.group, []).append(o.passed)
    return {group: f"{sum(passed)} of {len(passed)} checks passed" for group, passed in groups.items()}


def likely_cause(outcome) -> str:
    """A failed check's cause on nbgrader's page: its likely cause where the checker names one (the checks that
    a sign error in Revolute.gamma fails on every scene are one cause there; each cell below keeps its message
    with the numbers), else its message without the scene (``autograder.feedback.cause_of``)."""
    from .feedback import cause_of

    _, named, cause = outcome.message.partition("Likely cause: ")
    return f"Likely cause: {cause}" if named else cause_of(outcome)


def feedback_summary():
    """The ``generate_feedback`` step after ``GetGrades``: each graded test cell labelled by its group
    (``cell.metadata.nbgrader.mbd_group``), and ``resources["mbd"]``: the checks' points and maximum (the
    homework's scale), the written answers' (graded by hand), the failures' causes (each once, the costliest
    first: ``autograder.feedback.causes_part``) and how many checks of each group passed."""
    from nbconvert.preprocessors import Preprocessor
    from nbgrader.utils import is_grade, is_solution
    from traitlets import Bool

    from .api import check_call
    from .feedback import causes_part

    class FeedbackSummary(Preprocessor):
        enabled = Bool(True)

        def preprocess(self, nb, resources):
            checks, written = [0.0, 0.0], [0.0, 0.0]
            for cell in nb.cells:
                if not is_grade(cell):
                    continue
                grades = cell.metadata.nbgrader
                score, points = float(grades.get("score") or 0.0), float(grades.get("points") or 0.0)
                if is_solution(cell):  # a written answer (or code graded by hand)
                    written[0] += score
                    written[1] += points
                    continue
                call = check_call(cell.source) if cell.cell_type == "code" else None
                grades["mbd_group"] = call[1] if call else grades.get("grade_id", "test")
                checks[0] += score
                checks[1] += points
            outcomes = kept_outcomes(nb)
            resources["mbd"] = {
                "score": round(checks[0], 6),
                "max_score": round(checks[1], 6),
                "written": round(written[0], 6),
                "written_max": round(written[1], 6),
                "causes": causes_part(outcomes, likely_cause),
                "passed": passed_by_group(outcomes),
            }
            return nb, resources

    return FeedbackSummary


def mathjax_beside():
    """The ``generate_feedback`` step that writes MathJax beside the page (``MATHJAX_FOLDER``, the files of
    ``MATHJAX_FILES``) through nbconvert's ``resources["outputs"]``: nbgrader's writer puts them into the
    student's feedback folder with the page, which loads them (``templates/mbd_feedback/mathjax.html.j2``)."""
    from nbconvert.preprocessors import Preprocessor
    from traitlets import Bool

    class MathJaxBeside(Preprocessor):
        enabled = Bool(True)

        def preprocess(self, nb, resources):
            outputs = resources.setdefault("outputs", {})
            outputs.update({f"{MATHJAX_FOLDER}/{name}": data for name, data in mathjax_files().items()})
            return nb, resources

    return MathJaxBeside
