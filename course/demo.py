"""``make demo``: the course's main job, end to end, on its own demo data.

1. **Examples.** Runs every example model in ``course/models/`` with the analysis it needs (kinematic when
   its drivers leave no degree of freedom, dynamic otherwise), writes each result as CSV and a plot of its
   coordinates, and two animations (offline pages of the viewer, HTML).
2. **Run time against error.** Forward dynamics of the physical pendulum over one period, against its
   exact period (an elliptic integral), for RK4 at four steps and RK45 and DOP853 at four tolerances.
3. **Release.** Releases homework 1 as ``mbd release hw1`` does (nbgrader's generate step, the hw1 student
   package, the leak check), from a scratch copy of the course so that the working tree is never touched
   and an uncommitted ``modules/`` does not stop the demo.
4. **A demo class.** Four submissions in nbgrader's layout ``submitted/{student}/hw1/``, each the released
   notebook with a student package: the reference (everything written), the untouched skeleton, and two
   students with a typical bug each (a sign in the revolute joint's gamma; the sign of a driver's Psi_t).
5. **Grading.** Grades the class as ``mbd grade hw1`` does (``autograder.grading.grade``, in parallel),
   prints the gradebook, writes a feedback page per student. The hidden and per-student scenes come from a
   demo secret of the demo's own (``out/demo/demo-secret``, made once), never from the course's secret.

Every output goes under ``out/demo/``; the last lines say where each one is. Run: ``make demo`` or
``python -m course.demo [--skip-examples]``.
"""

from __future__ import annotations

import argparse
import csv
import os
import secrets
import shutil
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from solutions.analysis import choose_analysis, run_analysis
from solutions.assembly import build_system
from solutions.diagnostics import AnalysisError
from solutions.io.model import ModelError, load_model
from solutions.io.results import write_csv
from solutions.kinematics import assemble
from solutions.plotting import plot_result, save_figure, work_precision_figure
from solutions.settings import read_settings
from solutions.viewer import result_view

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "course" / "models"
OUT = ROOT / "out" / "demo"
HOMEWORK = "hw1"
ANIMATED = ("slider_crank.yaml", "four_bar_spring.yaml")
"""Example models the demo also animates (a kinematic and a dynamic run)."""

MUTATIONS = {
    "bug_revolute_gamma": (
        "planar/joints.py",
        "class Revolute(",
        "return point_vector_quadratic(qi, self.si, qj, self.sj, qdi, qdj)",
        "return -point_vector_quadratic(qi, self.si, qj, self.sj, qdi, qdj)",
        "a sign flipped in the revolute joint's gamma (eq. 3.17)",
    ),
    "bug_driver_psi_t": (
        "planar/joints.py",
        "class RelativeAngle(",
        "return np.array([-self.function.first(t)])",
        "return np.array([self.function.first(t)])",
        "the sign of the rotational driver's Psi_t flipped (eq. 3.34)",
    ),
}
"""Demo students with one typical bug each: (file of the package, the class it is in, the reference's code, the
buggy code, what it is). The first occurrence of the code after the class statement is replaced."""


# -- 1. the example models -------------------------------------------------------------------------------
def run_examples(out: Path, animate: tuple[str, ...] = ANIMATED) -> list[dict]:
    """Run every example model; return one row per model for the summary table."""
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for path in sorted(MODELS.glob("*.yaml")):
        row = {"model": path.name}
        start = time.perf_counter()
        try:
            model = load_model(path)
            system, q0, qd0 = build_system(model)
            settings = read_settings(model.simulation)
            if settings.analysis == "auto":
                settings = settings.replace(analysis=choose_analysis(system, assemble(system, q0)[0]))
            analysis = settings.analysis
            result = run_analysis(system, q0, qd0, settings)
            outputs = [write_csv(result, out / f"{path.stem}.csv"), plot_result(result, out / f"{path.stem}.png")]
            if path.name in animate:  # a page that plays, turns and zooms in any browser, offline
                outputs.append(result_view(model, system, result).write_html(out / f"{path.stem}.html"))
            row.update(analysis=analysis, status="ok", outputs=", ".join(p.name for p in outputs))
        except (ModelError, AnalysisError, ImportError) as err:
            row.update(analysis="-", status=f"failed: {err}", outputs="-")
        row["seconds"] = time.perf_counter() - start
        rows.append(row)
    return rows


def print_examples(rows: list[dict]) -> None:
    width = max(len(r["model"]) for r in rows)
    print(f"\n{'model':<{width}}  {'analysis':<9}  {'time':>7}  outputs")
    for r in rows:
        print(f"{r['model']:<{width}}  {r['analysis']:<9}  {r['seconds']:6.2f}s  {r['outputs']}  {r['status']}")


# -- 2. the release ----------------------------------------------------------------------------------------
def scratch_course(destination: Path) -> Path:
    """A copy of the course for releasing and grading: notebooks, nbgrader configuration, reference, checker, grader.

    ``modules/`` is built fresh from ``solutions/`` (so it is in sync), and the copy is not a git work tree
    (so uncommitted changes in this repository's ``modules/`` do not stop the demo).
    """
    from course.release import build_modules

    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".ipynb_checkpoints")
    for folder in ("assignments", "solutions", "mbdkit", "autograder"):  # nbgrader's autograde imports autograder
        shutil.copytree(ROOT / folder, destination / folder, ignore=ignore)
    shutil.copy2(ROOT / "pyproject.toml", destination / "pyproject.toml")
    (destination / "course").mkdir(parents=True)
    shutil.copy2(ROOT / "course" / "nbgrader_config.py", destination / "course" / "nbgrader_config.py")
    build_modules(destination / "modules", destination / "solutions")
    return destination


def release_homework(out: Path, homework: str = HOMEWORK):
    """``mbd release hwN`` on a scratch copy of the course; the release folder is copied to ``out``."""
    from course.release import release

    with tempfile.TemporaryDirectory(prefix="mbd-demo-course-") as tmp:
        course = scratch_course(Path(tmp) / "course")
        report = release(homework, course)
        if out.exists():
            shutil.rmtree(out)
        shutil.copytree(report.folder, out)
    report.folder = out
    return report


# -- 3. the demo class ---------------------------------------------------------------------------------------
def _submission(released: Path, folder: Path) -> Path:
    """A student's submission folder: the released notebook and public files, package to be filled."""
    if folder.exists():
        shutil.rmtree(folder)
    shutil.copytree(released, folder, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    return folder


def _mutate(package: Path, relpath: str, anchor: str, correct: str, buggy: str, student: str) -> None:
    path = package / relpath
    text = path.read_text()
    start = text.find(anchor)
    at = text.find(correct, start) if start >= 0 else -1
    if at < 0:
        raise RuntimeError(
            f"demo student {student}: no {correct!r} after {anchor!r} in {relpath}; "
            "update MUTATIONS in course/demo.py to the reference's current code"
        )
    path.write_text(text[:at] + buggy + text[at + len(correct) :])


def make_class(released: Path, submitted: Path, homework: str = HOMEWORK) -> dict[str, str]:
    """The demo class in nbgrader's layout; returns {student: what their package holds}."""
    from course.release import build_package

    if submitted.exists():
        shutil.rmtree(submitted)
    students = {
        "reference": "the reference: every function written",
        "skeleton": "the released package, untouched",
    }
    students.update({name: f"the reference with {mutation[-1]}" for name, mutation in MUTATIONS.items()})
    for student in students:
        folder = _submission(released, submitted / student / homework)
        if student == "skeleton":
            continue
        build_package(folder / "modules", None, header=None)  # nothing stubbed: the reference, as `modules`
        if student in MUTATIONS:
            relpath, anchor, correct, buggy, _ = MUTATIONS[student]
            _mutate(folder / "modules", relpath, anchor, correct, buggy, student)
    return students


# -- 4. grading ------------------------------------------------------------------------------------------------
def grade_class(submitted: Path, out: Path, homework: str = HOMEWORK, jobs: int = 2):
    """``mbd grade hwN SUBMISSIONS --out OUT``: the gradebook (also written as CSV and feedback pages)."""
    from autograder.grading import grade
    from mbdkit import isolation

    reason = isolation.problem()
    if reason is not None:  # the demo class is the course's own code: grade it, and say how
        print(f"note: {reason}; the demo grades its own class without the sandbox (--unsafe-no-isolation)")
    with demo_secret(out.parent / "demo-secret"):
        return grade(homework, submitted, out, jobs=jobs, resume=False, isolation="os" if reason is None else "local")


@contextmanager
def demo_secret(path: Path):
    """Grade with the demo's own course secret (made once in ``path``), never the course's: it is given as
    ``$MBD_GRADER_SECRET`` (which the grading workers inherit) while the demo grades."""
    from autograder.secret import ENV, INIT_COMMAND

    if not path.is_file():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(secrets.token_hex(32) + "\n")
        path.chmod(0o600)
    where = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
    print(f"  demo secret: {where} (the demo's own; a course makes its own with `{INIT_COMMAND}`)")
    old = os.environ.get(ENV)
    os.environ[ENV] = path.read_text().strip()
    try:
        yield
    finally:
        if old is None:
            os.environ.pop(ENV, None)
        else:
            os.environ[ENV] = old


def print_gradebook(book, students: dict[str, str]) -> None:
    print(f"\n{'student':<20}  {'score':>13}  {'percent':>7}  submission")
    for student in sorted(book.rows):
        score = book.score(student)
        percent = 100.0 * score / book.max_score if book.max_score else 0.0
        print(f"{student:<20}  {score:>6g} / {book.max_score:<4g}  {percent:6.1f}%  {students.get(student, '')}")
        failed = [name for name, points in book.points(student).items() if points < book.max_points[name]]
        if failed and student != "skeleton":
            shown = ", ".join(failed[:4]) + (f", ... ({len(failed)} in all)" if len(failed) > 4 else "")
            print(f"{'':<20}  failed: {shown}")


# -- 5. run time against error ---------------------------------------------------------------------------------
def pendulum_period(model) -> float:
    """Exact period of the physical pendulum of ``simple_pendulum.yaml`` released from the horizontal:
    T = 4 K(k) / omega0, k = sin(theta0 / 2), omega0^2 = m g c / (J + m c^2)."""
    from scipy.special import ellipk

    body = model.bodies[0]
    c = float(np.linalg.norm(body.location))  # pivot at the origin, centre of mass at distance c
    g = float(np.linalg.norm(model.gravity))
    omega0 = np.sqrt(body.mass * g * c / (body.inertia + body.mass * c**2))
    return float(4.0 * ellipk(np.sin(np.pi / 4) ** 2) / omega0)  # released 90 degrees from hanging; K(m = k^2)


def run_time_study(out: Path) -> tuple[Path, Path, list[dict]]:
    """Error after one period (the rod's angle against its start) and wall time, per method and setting."""
    from solutions.dynamics import forward_dynamics

    model = load_model(MODELS / "simple_pendulum.yaml")
    system, q0, qd0 = build_system(model)
    period = pendulum_period(model)
    settings = [("rk4", {"integrator": "rk4", "step": h}, f"h = {h:g} s") for h in (0.04, 0.02, 0.01, 0.005)]
    settings += [
        (method, {"integrator": method, "rtol": tol, "atol": tol}, f"tol = {tol:.0e}")
        for method in ("RK45", "DOP853")
        for tol in (1e-4, 1e-6, 1e-8, 1e-10)
    ]
    rows = []
    for method, options, label in settings:
        times, result = [], None
        for _ in range(5):  # the best of five runs: the least disturbed by other work on the machine
            start = time.perf_counter()
            result = forward_dynamics(system, q0, qd0, period, 1, **options)
            times.append(time.perf_counter() - start)
        error = abs(float(result.q[-1, 2] - q0[2]))
        rows.append(
            {
                "method": method,
                "setting": label,
                "error": max(error, 1e-16),
                "seconds": min(times),
                "evaluations": int(result.info["rhs_evaluations"]),
            }
        )
    out.mkdir(parents=True, exist_ok=True)
    table = out / "run_time_vs_error.csv"
    with open(table, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    figure = save_figure(
        work_precision_figure(rows, f"physical pendulum, one period ({period:.4f} s)"), out / "run_time_vs_error.png"
    )
    return figure, table, rows


# -- the whole demo ------------------------------------------------------------------------------------------------
def _step(title: str) -> float:
    print(f"\n== {title}")
    return time.perf_counter()


def _done(start: float) -> None:
    print(f"({time.perf_counter() - start:.0f} s)")


def step_examples() -> tuple[list, bool]:
    start = _step(f"1. the example mechanisms of {MODELS.relative_to(ROOT)}/")
    rows = run_examples(OUT / "examples")
    print_examples(rows)
    _done(start)
    return [("example results (CSV), plots (PNG), animations (HTML pages, offline)", OUT / "examples")], all(
        r["status"] == "ok" for r in rows
    )


def step_study() -> list:
    start = _step("2. run time against error: physical pendulum, one period, against the exact period")
    figure, table, rows = run_time_study(OUT / "study")
    for row in rows:
        print(
            f"  {row['method']:<7} {row['setting']:<14} error {row['error']:.1e}  {1e3 * row['seconds']:7.1f} ms  "
            f"{row['evaluations']:6d} evaluations"
        )
    _done(start)
    return [("run time against error (plot)", figure), ("run time against error (table)", table)]


def step_release():
    start = _step(f"3. release {HOMEWORK} (as `mbd release {HOMEWORK}`, from a scratch copy of the course)")
    os.environ.setdefault("MBD_KIT_NOTES", "as-written")  # the kit's notes in seconds (a release executes them: 1 min)
    report = release_homework(OUT / "release" / HOMEWORK)
    for line in report.summary().splitlines():
        if not line.startswith(" " * 20):  # not the functions to write, one a line (`mbd release` lists them)
            print(line)
    _done(start)
    label = f"the {HOMEWORK} release: the kit students install (notebook, scenes, modules/, checker, README)"
    return report, [(label, report.folder)]


def step_class_and_grades(released: Path, jobs: int) -> tuple[list, bool]:
    _step("4. a demo class in nbgrader's layout submitted/{student}/" + HOMEWORK + "/")
    submitted = OUT / "class" / "submitted"
    students = make_class(released, submitted)
    for student, what in students.items():
        print(f"  {student:<20} {what}")

    start = _step(f"5. grade the class (as `mbd grade {HOMEWORK} {submitted.relative_to(ROOT)} --out out/demo/grades`)")
    book = grade_class(submitted, OUT / "grades", jobs=jobs)
    print_gradebook(book, students)
    ok = True
    for student, score in {"reference": book.max_score, "skeleton": 0.0}.items():
        if abs(book.score(student) - score) > 1e-9:
            print(f"  unexpected: {student} scored {book.score(student):g}, expected {score:g}")
            ok = False
    _done(start)
    return [
        ("the demo class's submissions", submitted),
        ("gradebook (one row per student, a column per check)", book.csv_path),
        ("feedback pages (HTML, one per student)", OUT / "grades" / "feedback"),
        ("results per student (JSON, Gradescope-like)", OUT / "grades" / "results"),
    ], ok


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m course.demo", description=__doc__.split("\n")[0])
    parser.add_argument("--skip-examples", action="store_true", help="skip step 1 (the example models)")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes for grading (default 2)")
    args = parser.parse_args(argv)
    begin = time.perf_counter()
    where, ok = [], True
    if not args.skip_examples:
        outputs, ok = step_examples()
        where += outputs
    where += step_study()
    report, outputs = step_release()
    where += outputs
    outputs, graded = step_class_and_grades(report.folder, args.jobs)
    where += outputs
    print(f"\n== where everything is (demo finished in {time.perf_counter() - begin:.0f} s)")
    width = max(len(what) for what, _ in where)
    for what, path in where:
        print(f"  {what:<{width}}  {path.relative_to(ROOT)}")
    return 0 if ok and graded else 1


if __name__ == "__main__":
    sys.exit(main())
