"""nbgrader configuration of the course: read by ``mbd release`` and by ``nbgrader`` run from the repository root
(through ``nbgrader_config.py`` there) or from ``course/``; every path below is absolute, so both give the same.

Layout, relative to the repository root (the course root):

    assignments/hwN/        nbgrader's source folders: the notebooks and public files only
    build/release/hwN/      what students get, the student kit built by ``mbd release hwN``: the notebook
                            without solutions, its scenes, the hwN student package ``modules/`` (built from
                            solutions/) and the student-side checker with its install file and README
    build/downloaded/hwN/archive/
                            submissions downloaded from a learning platform, for ``nbgrader zip_collect hwN``
    build/submitted, build/autograded, build/feedback, build/gradebook.db, build/grades.csv
                            nbgrader's working folders while grading (not committed: build/ is ignored)

Nothing of the reference code (``solutions/``) or of the grader's data (``autograder/``) is inside
``assignments/``: the student package is generated into the release folder, never into the source. That is
why nbgrader's own generate step cannot build a release: it copies ``assignments/hwN/`` only. Run by hand
(``nbgrader generate_assignment hwN``), it hands over to ``mbd release hwN`` (``_release_the_kit`` below).

To release through an exchange (JupyterHub), set ``c.CourseDirectory.course_id`` and ``c.Exchange.root``
below: ``mbd release hwN`` then also runs nbgrader's release step.
"""

import os
import shutil
import sys
import traceback

c = get_config()  # noqa: F821 -- injected by traitlets when it loads this file

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOLUTIONS = os.path.join(ROOT, "solutions")
HOMEWORKS = ("hw1", "hw2", "hw3")

c.CourseDirectory.root = ROOT
c.CourseDirectory.source_directory = "assignments"
c.CourseDirectory.release_directory = os.path.join("build", "release")
c.CourseDirectory.submitted_directory = os.path.join("build", "submitted")
c.CourseDirectory.autograded_directory = os.path.join("build", "autograded")
c.CourseDirectory.feedback_directory = os.path.join("build", "feedback")
c.CourseDirectory.solution_directory = os.path.join("build", "solution")
c.CourseDirectory.source_with_tests_directory = os.path.join("build", "source_with_tests")
c.CourseDirectory.db_url = "sqlite:///" + os.path.join(ROOT, "build", "gradebook.db")
os.makedirs(os.path.join(ROOT, "build"), exist_ok=True)  # the gradebook's folder: sqlite does not create it
# The kit's notes/ (the course notes' site, ~4 MB) and models/ (the example models) are the course's, not the
# student's work: not submitted, not copied into autograded/ or feedback/ (course/release/kit.py writes them).
c.CourseDirectory.ignore = [
    ".ipynb_checkpoints", "*.pyc", "__pycache__", "feedback", ".pytest_cache", "notes", "models"
]  # fmt: skip

# `nbgrader export` writes its CSV here, not into the folder it is run from (`--to FILE` still overrides it:
# the option sets ExportPlugin.to too, and the command line wins over this file).
c.ExportPlugin.to = os.path.join(ROOT, "build", "grades.csv")

# nbgrader runs the `alembic` command to create the gradebook: when nbgrader was started as .venv/bin/nbgrader
# without an activated virtualenv, that command is not on PATH, and every gradebook step would fail.
if shutil.which("alembic") is None and os.path.isfile(os.path.join(os.path.dirname(sys.executable), "alembic")):
    os.environ["PATH"] = os.pathsep.join([os.path.dirname(sys.executable), os.environ.get("PATH", "")])


def _student_modules() -> list:
    """Every file of the student package, as it sits beside the notebook: modules/<path of solutions/>, without
    the instructor-only folders and files (``release.generator.INSTRUCTOR_ONLY``; tests/course/test_release.py
    checks that the two agree)."""
    instructor_only = ("compiled", "planar/batched.py", "spatial/batched.py", "serve.py", "io/fmu.py")
    instructor_only += ("io/fmu_slave.py",)
    files = []
    for folder, dirs, names in os.walk(SOLUTIONS):
        here = os.path.relpath(folder, SOLUTIONS).replace(os.sep, "/")
        place = {name: name if here == "." else f"{here}/{name}" for name in dirs + names}
        dirs[:] = sorted(d for d in dirs if d != "__pycache__" and place[d] not in instructor_only)
        kept = [n for n in sorted(names) if not n.endswith((".pyc", ".pyo")) and place[n] not in instructor_only]
        files += [f"modules/{place[name]}" for name in kept]
    return files


# A student edits the package's .py files and submits them beside the notebook: autograde must grade
# theirs, not copy the source folder's over them (nbgrader issue #940).
c.Autograde.exclude_overwriting = {hw: _student_modules() for hw in HOMEWORKS}


def _drop_submitted_checker():
    """A preprocessor that removes a checker (``mbdkit/``) handed in with a submission before its notebook
    runs: the notebook's ``check`` is the course's (the points never come from the notebook: see below)."""
    from nbconvert.preprocessors import Preprocessor
    from traitlets import Bool

    class DropSubmittedChecker(Preprocessor):
        enabled = Bool(True)  # nbconvert's preprocessors are off unless enabled

        def preprocess(self, nb, resources):
            folder = resources.get("metadata", {}).get("path") or ""
            if folder and os.path.exists(os.path.join(folder, "mbdkit")):
                shutil.rmtree(os.path.join(folder, "mbdkit"), ignore_errors=True)
            return nb, resources

    return DropSubmittedChecker


def _autograde_steps() -> list:
    """nbgrader's autograde steps, with the notebook's kernel in the grader's bubblewrap sandbox (nothing of the
    course visible) and every graded cell's points from the grader's own run of the submission, written into
    the gradebook from outside the kernel (``autograder/api.py``)."""
    from nbgrader.converters.autograde import Autograde

    from autograder.api import autograde_steps

    return [_drop_submitted_checker(), *autograde_steps(Autograde.class_traits()["autograde_preprocessors"].default())]


c.Autograde.autograde_preprocessors = _autograde_steps()


def _feedback_steps() -> list:
    """nbgrader's feedback steps, then each graded cell's group, the page's total and summary
    (``autograder/nbpages.py``), and the notebook's mechanism views given a player in the page, each checked
    first: the student's code made them (``autograder/views.py``)."""
    from nbgrader.converters.generate_feedback import GenerateFeedback

    from autograder.nbpages import feedback_summary, mathjax_beside
    from autograder.views import views_in_feedback

    defaults = GenerateFeedback.class_traits()["preprocessors"].default()
    return [*defaults, feedback_summary(), mathjax_beside(), views_in_feedback()]


c.GenerateFeedback.preprocessors = _feedback_steps()


def _generate_steps() -> list:
    """nbgrader's generate steps, after one that makes each 'eq. N.M' of the statement a link into the kit's
    notes (``notes/chNN_*.html#eq-N.M``, the site ``mbd release`` puts beside the notebook): before the locked
    cells' checksums are computed, so a student's notebook validates."""
    from nbconvert.preprocessors import Preprocessor
    from nbgrader.converters.generate_assignment import GenerateAssignment
    from traitlets import Bool

    from course.notes import linked, note_pages

    class LinkEquations(Preprocessor):
        enabled = Bool(True)

        def preprocess(self, nb, resources):
            pages = note_pages()
            for cell in nb.cells:
                if cell.cell_type == "markdown":
                    cell.source = linked(cell.source, pages)
            return nb, resources

    return [LinkEquations, *GenerateAssignment.class_traits()["preprocessors"].default()]


c.GenerateAssignment.preprocessors = _generate_steps()


def _templates() -> tuple[list, list]:
    """(template base folders, further template folders) of nbgrader's pages: nbgrader's own and the course's
    (``autograder/templates``: mbd_feedback and mbd_formgrade extend nbgrader's feedback and formgrade pages,
    found through nbgrader's templates folder; mbd_shared holds their MathJax set-up)."""
    import nbgrader

    from autograder.nbpages import TEMPLATES

    formgrader = os.path.join(os.path.dirname(nbgrader.__file__), "server_extensions", "formgrader")
    bootstrap = os.path.join(formgrader, "static", "node_modules", "bootstrap", "dist", "css")  # the feedback's CSS
    folders = [os.path.join(formgrader, "templates"), str(TEMPLATES)]
    return folders, [bootstrap, folders[0], str(TEMPLATES / "mbd_shared")]


# nbgrader's pages of a submission with the course's templates (autograder/nbpages.py): the feedback page labels each
# graded cell by its group, has one total and mbd grade's summary, wraps long lines and renders its equations
# with the MathJax written beside it; the formgrader's page (its exporter has no parent: c.HTMLExporter) loads
# the Jupyter server's MathJax (jupyter_server_mathjax). The feedback's exporter is GenerateFeedback's child:
# its section wins over c.HTMLExporter there.
c.HTMLExporter.extra_template_basedirs, c.HTMLExporter.extra_template_paths = _templates()
c.HTMLExporter.template_name = "mbd_formgrade"
c.GenerateFeedback.HTMLExporter.template_name = "mbd_feedback"
c.GenerateFeedback.HTMLExporter.extra_template_basedirs, c.GenerateFeedback.HTMLExporter.extra_template_paths = (
    _templates()
)


def _sanitized_pages() -> list:
    """Every HTML page nbgrader makes of a submission (the feedback pages, the formgrader's): the student's
    markup cleaned first (``autograder.views.student_html_sanitized``): nbconvert renders a notebook's HTML and
    scripts as they are, and nbgrader's templates render markdown answers without cleaning them."""
    from autograder.views import student_html_sanitized

    return [student_html_sanitized()]


c.HTMLExporter.preprocessors = _sanitized_pages()

# Any stderr output, even a warning, zeroes a test cell: drop the harmless ones before grading.
c.IgnorePattern.enabled = True
c.IgnorePattern.pattern = r"(?:\w*Warning: |Matplotlib is building the font cache|warnings\.warn\()"

# Execution limits: a student's cell may run a short simulation, but never hang the grader.
c.Execute.timeout = 120
c.Execute.startup_timeout = 60
c.Execute.interrupt_on_timeout = True


def _release_the_kit(assignment, student, notebooks):
    """``nbgrader generate_assignment hwN`` run by hand: finish with ``mbd release hwN``.

    nbgrader copies ``assignments/hwN/`` only, so its own output is the notebook without the student package;
    ``mbd release`` regenerates the folder as the whole student kit and checks it for leaks. When the release
    is refused, the notebook-only folder is deleted and the command fails, rather than leaving a folder that
    looks complete. ``mbd release`` runs nbgrader's step through its API, which this hook does not apply to.
    """
    if os.environ.get("MBD_RELEASE_FROM_NBGRADER"):  # already inside a release started here
        return
    folder = os.path.join(ROOT, "build", "release", assignment)
    print(
        f"nbgrader copied assignments/{assignment}/ only: completing the student kit with `mbd release {assignment}`",
        file=sys.stderr,
    )
    import logging

    from traitlets.log import get_logger

    class _NoExchangeNotice(logging.Filter):  # the release step without an exchange: not this command's concern
        def filter(self, record):
            return "Unwritable directory" not in str(record.msg)

    quiet = _NoExchangeNotice()
    get_logger().addFilter(quiet)
    os.environ["MBD_RELEASE_FROM_NBGRADER"] = "1"
    try:
        if os.path.isfile(os.path.join(ROOT, "course", "release", "__init__.py")) and ROOT not in sys.path:
            sys.path.insert(0, ROOT)
        from course.release import release

        report = release(assignment, ROOT)
    except Exception as err:  # noqa: BLE001 -- nbgrader would log a failed hook and carry on: stop here instead
        shutil.rmtree(folder, ignore_errors=True)
        reason = str(err) if type(err).__name__ == "ReleaseError" else traceback.format_exc()
        print(f"error: {reason}\n{folder} was deleted: nbgrader alone does not build the student kit", file=sys.stderr)
        raise SystemExit(2) from None
    finally:
        os.environ.pop("MBD_RELEASE_FROM_NBGRADER", None)
        get_logger().removeFilter(quiet)
    print(report.summary())


# Only the command line's generate step (its converter's parent is GenerateAssignmentApp); `mbd release` and
# the formgrader call nbgrader's API, where this section does not apply.
c.GenerateAssignmentApp.GenerateAssignment.post_convert_hook = _release_the_kit

# `nbgrader zip_collect hwN`: put what the learning platform gave into build/downloaded/hwN/archive/, and say
# which platform it came from (autograder/lms.py has how each names its files):
#   - LmsCollector.lms = "moodle": Moodle's "Download all submissions" zip (folders or files named
#     'Full Name_12345_assignsubmission_file...'); the student id is the participant number 12345;
#   - LmsCollector.lms = "canvas": Canvas's "Download Submissions" zip ('lastnamefirstname_12345_67890_hw1-handin.zip',
#     '..._LATE_12345_...' when late); the student id is the user id 12345;
#   - LmsCollector.lms = r"REGEXP", any other platform: a regular expression matching the name of ONE student's
#     folder or file (re.fullmatch), with (?P<student_id>...) and optionally (?P<name>...), (?P<late>...),
#     (?P<timestamp>...) (the later of two hand-ins wins) and (?P<file_id>...) (the student's own file name, when
#     the platform puts it in the same name). E.g. files named 'hw1_s1234567_2026-05-01T10-00_hw1-handin.zip':
#     r"hw1_(?P<student_id>s\d+)_(?P<timestamp>[\dT-]+)_(?P<file_id>.+)";
#   - LmsCollector.lms = "" (the default): nbgrader's own named_regexp below, one zip or folder per student,
#     named with the student's id, as before.
# Set it here, or per command: `nbgrader zip_collect hw1 --LmsCollector.lms=moodle`. With a preset, each
# student's hwN.ipynb and modules/ are taken from the shallowest folder holding modules/ (the hand-in zip of
# `mbd handin`, or a zip of the whole kit folder); nothing else is collected (the scenes come from
# assignments/hwN/ at autograde). zip_collect prints what it collected and skipped, by reason, in a few lines
# (build/downloaded/hwN/collected.csv: ids, names, late, notes), and exits with code 2 and one line saying
# what was expected when it collected nothing.
c.ZipCollectApp.downloaded_directory = os.path.join("build", "downloaded")  # relative to the root, as nbgrader needs
c.ZipCollectApp.strict = True  # skip notebooks that are not the released one (copies, renamed files)


def _collector():
    from autograder.lms import zip_collect_plugin

    return zip_collect_plugin()


c.ZipCollectApp.collector_plugin = _collector()
c.LmsCollector.lms = ""
c.FileNameCollectorPlugin.valid_ext = [".ipynb", ".py", ".json"]
c.FileNameCollectorPlugin.named_regexp = (
    r".*[/\\]extracted[/\\](?P<student_id>[^/\\._][^/\\]*)[/\\](?:[^/\\._][^/\\]*[/\\])?"
    r"(?P<file_id>[^/\\._][^/\\]*\.ipynb|modules[/\\].+)$"
)


# -- before autograde: every collected notebook checked against the release, safe repairs made, and what nbgrader
# -- will do with the rest printed (course/nbcheck.py; `mbd nbcheck hwN [--repair]` by hand, e.g. for formgrader)
def _check_notebooks_first(argv):
    words = [a for a in argv[1:] if not a.startswith("-")]
    if words[:1] == ["autograde"] and words[1:2] and words[1] in HOMEWORKS and not os.environ.get("MBD_NBCHECKED"):
        os.environ["MBD_NBCHECKED"] = "1"  # once per command, however often nbgrader reads this file
        if ROOT not in sys.path:
            sys.path.insert(0, ROOT)
        try:
            from course.nbcheck import check_class

            print(check_class(words[1], ROOT, repair=True).text(), file=sys.stderr)
        except Exception as err:  # noqa: BLE001 -- a check that cannot run must not stop nbgrader: say so
            print(f"warning: the notebooks were not checked before autograde ({err}); run mbd nbcheck", file=sys.stderr)


_check_notebooks_first(sys.argv)

# Exchange (optional): uncomment both to let `mbd release hwN` also run nbgrader's release step.
# c.CourseDirectory.course_id = "mbd"
# c.Exchange.root = "/srv/nbgrader/exchange"
