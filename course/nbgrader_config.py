"""nbgrader configuration of the course (read by ``mbd release`` and by ``nbgrader`` run from ``course/``).

Layout, relative to the repository root (the course root):

    assignments/hwN/        nbgrader's source folders: the notebooks and public files only
    build/release/hwN/      what students get: the notebook without solutions and the hwN student
                            package ``modules/`` (built from solutions/ by ``mbd release hwN``)
    build/submitted, build/autograded, build/feedback, build/gradebook.db
                            nbgrader's working folders while grading (not committed: build/ is ignored)

Nothing of the reference code (``solutions/``) or of the grader's data (``autograder/``) is inside
``assignments/``: the student package is generated into the release folder, never into the source.

To release through an exchange (JupyterHub), set ``c.CourseDirectory.course_id`` and ``c.Exchange.root``
below: ``mbd release hwN`` then also runs nbgrader's release step.
"""

import os

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
c.CourseDirectory.ignore = [".ipynb_checkpoints", "*.pyc", "__pycache__", "feedback", ".pytest_cache"]


def _student_modules() -> list:
    """Every file of the student package, as it sits beside the notebook: modules/<path of solutions/>."""
    files = []
    for folder, dirs, names in os.walk(SOLUTIONS):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for name in sorted(names):
            if not name.endswith((".pyc", ".pyo")):
                rel = os.path.relpath(os.path.join(folder, name), SOLUTIONS)
                files.append(os.path.join("modules", rel))
    return files


# A student edits the package's .py files and submits them beside the notebook: autograde must grade
# theirs, not copy the source folder's over them (nbgrader issue #940).
c.Autograde.exclude_overwriting = {hw: _student_modules() for hw in HOMEWORKS}

# Any stderr output, even a warning, zeroes a test cell: drop the harmless ones before grading.
c.IgnorePattern.enabled = True
c.IgnorePattern.pattern = r"(?:\w*Warning: |Matplotlib is building the font cache|warnings\.warn\()"

# Execution limits: a student's cell may run a short simulation, but never hang the grader.
c.Execute.timeout = 120
c.Execute.startup_timeout = 60
c.Execute.interrupt_on_timeout = True

# Exchange (optional): uncomment both to let `mbd release hwN` also run nbgrader's release step.
# c.CourseDirectory.course_id = "mbd"
# c.Exchange.root = "/srv/nbgrader/exchange"
