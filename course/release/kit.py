"""The student kit of homework N: everything a student needs, and nothing they must not see.

``mbd release hwN`` writes it into ``build/release/hwN/``::

    hwN.ipynb          the assignment (nbgrader's generate step)
    scenes/            its public model files (copied by nbgrader from ``assignments/hwN/``)
    modules/           the student package: hwN and later stubbed, earlier homework filled in
    mbdkit/            the checker (``mbdkit``'s code) with, in ``mbdkit/data/``, the homework's public
                       checks, their scenes and stored expected values (no hidden or per-student scene)
    models/            the course's example model files (``course/models/``), which the notes use
    notes/             the course notes as a site that opens from disk (``course.notes.build.kit_notes``: every
                       chapter and lecture, equations rendered offline, ``#eq-N.M`` anchors, search)
    pyproject.toml     ``pip install ./`` installs ``mbdkit``, the ``mbd`` command and what they need
    README.md          for students: install, open, what to write, self-check, hand in

The checker compares a student's numbers with stored values and names likely causes from stored
known mistakes: nothing in the kit runs, holds or installs the reference package.
"""

from __future__ import annotations

import json
import shutil
import tomllib
from pathlib import Path

from course.notes import chapters, equation_texts
from course.notes.build import kit_notes
from mbdkit.homework import CheckSpec, load_homework
from mbdkit.stored import load_reference, save_reference

from .generator import REPO

CHECKER = "mbdkit"
NOTES = "notes"
"""The kit's folder of the course notes' site."""
MODELS = "models"
"""The kit's folder of the course's example model files."""
KIT_EXTRAS = ("jupyterlab>=4",)
"""What a student needs beyond the solver's own dependencies: JupyterLab (it brings the kernel)."""
INSTRUCTOR_ONLY = ("nbgrader", "numba", "dask", "sphinx", "myst-nb", "jupyter-server-mathjax")
"""Dependencies of the course repository that a student does not need: nbgrader (the instructor's), numba (the
compiled engine, which no kit holds) and Dask (``mbd sweep --jobs N`` and ``mbd grade`` on a cluster; a kit's
sweep runs here, and asking it for a cluster says to install Dask): 233 MB of site-packages a kit's venv does not
fill (numba 35, llvmlite 173, dask 17, distributed 8); the notes' site builder (Sphinx, MyST-NB, the MathJax wheel):
a kit holds the built site (``notes/``)."""


def _toml_value(value) -> str:
    """A TOML literal of a string, number, boolean, list or flat table (what a check holds)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a TOML basic string
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no TOML form for {value!r}")


def checks_toml(
    homework: str,
    title: str,
    checks: list[CheckSpec],
    instructor_groups: list[str],
    to_write: list[tuple[str, str]] = (),
    total: float | None = None,
) -> str:
    """The kit's ``hwN.toml``: the public checks only, each written out in full (one scene each), the groups
    only the instructor's grading runs, the functions students write (``mbd todo``) and the homework's total
    (all its checks' points: what the self-check says the homework is out of)."""
    lines = [
        f"# {homework}: the public checks of the course's autograder (the instructor's grader also runs",
        "# hidden variants of these scenes and your own variant of each).",
        f"homework = {_toml_value(homework)}",
        f"title = {_toml_value(title)}",
        *([f"total = {_toml_value(float(total))}"] if total is not None else []),
        f"instructor_groups = {_toml_value(instructor_groups)}",
        f"to_write = {_toml_value([list(pair) for pair in to_write])}",
    ]
    for check in checks:
        table = {
            "name": check.name,
            "scene": check.scene,
            "probe": check.probe,
            "outputs": list(check.outputs),
            "points": check.points,
            "group": check.group,
            "rows": list(check.rows),
            "options": check.options,
            "timeout": check.timeout,
            "rtol": check.rtol,
            "atol": check.atol,
            "description": check.description,
        }
        lines += ["", "[[check]]"]
        lines += [f"{key} = {_toml_value(value)}" for key, value in table.items() if value not in (None, "")]
    return "\n".join(lines) + "\n"


def write_checker(
    folder: Path, homework: str, course_dir: Path = REPO, to_write: list[tuple[str, str]] = ()
) -> list[CheckSpec]:
    """``folder/mbdkit``: the checker's code and the homework's public checks, scenes and expected values
    (from the course's ``autograder/``: its ``hwN.toml``, public scenes and public references), with the
    functions students write (``to_write``: (file, function) pairs)."""
    grader = course_dir / "autograder"
    target = folder / CHECKER
    shutil.copytree(course_dir / CHECKER, target, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "data"))
    spec = load_homework(grader / f"{homework}.toml")
    checks = spec.public()
    data = target / "data"
    (data / "scenes").mkdir(parents=True)
    later = [group for group in spec.groups() if spec.graded_later(group)]
    (data / f"{homework}.toml").write_text(checks_toml(spec.name, spec.title, checks, later, to_write, spec.out_of))
    for scene in sorted({c.scene for c in checks}):
        shutil.copyfile(grader / "scenes" / f"{scene}.yaml", data / "scenes" / f"{scene}.yaml")
        keys = {c.probe_key for c in checks if c.scene == scene}
        stored = load_reference(scene, grader / "reference" / "public" / f"{scene}.npz").restricted(keys)
        save_reference(stored, data / "reference" / "public" / f"{scene}.npz")
    (data / EQUATIONS).write_text(json.dumps(equations_of_the_notes(), indent=0, sort_keys=True))
    return checks


EQUATIONS = "equations.json"
"""The checker's copy of the notes' labelled equations (``mbdkit.notes``: a failed check shows those it cites)."""


def equations_of_the_notes() -> dict[str, list[str]]:
    """{"3.17": [its chapter's page in the kit's notes/, its TeX]} for every labelled equation of the notes."""
    pages = {path.with_suffix(".html").name: equation_texts(path) for path in chapters()}
    return {label: [page, tex] for page, texts in pages.items() for label, tex in texts.items()}


def course_dependencies(course_dir: Path = REPO) -> list[str]:
    """The solver's dependencies as the course's pyproject.toml states them, less the instructor's tools."""
    project = tomllib.loads((course_dir / "pyproject.toml").read_text())["project"]
    keep = [d for d in project["dependencies"] if not d.lower().startswith(INSTRUCTOR_ONLY)]
    return keep + list(KIT_EXTRAS)


def pyproject(homework: str, title: str, course_dir: Path = REPO) -> str:
    """The kit's ``pyproject.toml``: installs ``mbdkit`` (with its data) and the ``mbd`` command."""
    project = tomllib.loads((course_dir / "pyproject.toml").read_text())["project"]
    dependencies = "".join(f"    {_toml_value(d)},\n" for d in course_dependencies(course_dir))
    return f"""# Homework kit of the multibody dynamics course: `pip install ./` in this folder.
[build-system]
requires = ["setuptools>=61"]
build-backend = "setuptools.build_meta"

[project]
name = "mbd-course-{homework}"
version = {_toml_value(project["version"])}
description = {_toml_value(f"{title}: the self-check and tools of the homework")}
requires-python = {_toml_value(project["requires-python"])}
dependencies = [
{dependencies}]

[project.scripts]
mbd = "mbdkit.cli:main"

[tool.setuptools]
packages = ["mbdkit"]

[tool.setuptools.package-data]
mbdkit = ["data/*.toml", "data/*.json", "data/scenes/*.yaml", "data/reference/public/*.npz"]
"""


def readme(homework: str, title: str, to_write: list[tuple[str, str]], checks: list[CheckSpec]) -> str:
    """The kit's README: for students, short. ``to_write``: (file in the package, function) pairs."""
    groups = list(dict.fromkeys(c.group for c in checks))
    files: dict[str, list[str]] = {}
    for path, function in to_write:
        files.setdefault(path, []).append(f"`{function}`")
    functions = "\n".join(f"- `modules/{path}`: {', '.join(names)}" for path, names in files.items())
    return f"""# {homework}: {title}

Your kit for this homework:

| | |
|---|---|
| `{homework}.ipynb` | the assignment: read it first, answer in it, run it top to bottom |
| `modules/` | your package: the functions you write raise `NotImplementedError` |
| `scenes/` | the model files the notebook uses |
| `mbdkit/` | the self-check (public checks, with expected values) and the `mbd` command |
| `models/` | the course's example mechanisms (model files), which the notes and lectures use |
| `notes/` | the course notes: open `notes/index.html` in a browser (no network needed) |

## 1. Install (once)

Python 3.11 or newer, on Linux or macOS (on Windows, in WSL). In this folder:

```
python3 -m venv .venv
source .venv/bin/activate
pip install ./
```

## 2. Open the notebook

```
jupyter lab {homework}.ipynb
```

Run the cells from the top; the cells marked *Graded* check your work as you go.

## 3. What to write

Replace the `raise NotImplementedError(...)` in these functions (each names its equation in the course
notes: eq. 3.17 is at `notes/ch03_planar_constraints.html#eq-3.17`, and `notes/index.html` lists every
equation with a link); do not change their signatures. In the notebook each "eq. N.M" is a link: open it in a
new browser tab (middle-click, or right-click and *Open Link in New Tab*) to land on the equation; a plain click
opens the chapter inside JupyterLab, which typesets its equations once you press *Trust HTML* (the page is the
course's own). A failed check shows the equations it cites, typeset, under its cell. `mbd todo {homework}`
lists what is left, file by file, and where to start.

{functions}

## 4. Check your work

```
mbd selfcheck {homework}           # every public check, with the likely cause of each failure
mbd run scenes/<model>.yaml --plot out.png   # your own solver on a model file
```

The notebook's graded cell for a group of checks is `check("{homework}", "<group>")`; the groups:
{", ".join(groups)}. The grader also runs hidden variants of these scenes and your own variant of
each: code that passes here for the right reasons passes there. In the notebook, a check that ran before
on the same files is not run again (a cell run twice, `selfcheck(...)` after the graded cells); save a
change to `modules/` and the next check runs everything on it.

## 5. Hand in

The notebook, run from top to bottom, and your `modules/` folder beside it, as your instructor asks:
nbgrader's *Submit* button, or `mbd handin {homework}`, which checks that your package imports and writes
`{homework}-handin.zip` with the notebook and `modules/` and nothing else.
"""


def build_kit(
    folder: Path, homework: str, to_write: list[tuple[str, str]], course_dir: Path = REPO
) -> tuple[list[str], bool]:
    """Add the checker, ``pyproject.toml``, ``README.md``, the notes and the models to a release folder; the files
    written, and whether the notes hold the notebooks' outputs (``kit_notes``).
    ``to_write``: the (file, function) pairs students write in this homework."""
    folder = Path(folder)
    spec = load_homework(course_dir / "autograder" / f"{homework}.toml")
    checks = write_checker(folder, homework, course_dir, to_write)
    (folder / "pyproject.toml").write_text(pyproject(homework, spec.title, course_dir))
    (folder / "README.md").write_text(readme(homework, spec.title, to_write, checks))
    site, executed = kit_notes()
    shutil.copytree(site, folder / NOTES, dirs_exist_ok=True)
    shutil.copytree(REPO / "course" / "models", folder / MODELS, dirs_exist_ok=True)  # as the notes: the code's
    checker = [p for p in (folder / CHECKER).rglob("*") if p.is_file()]
    models = sorted((folder / MODELS).iterdir())
    written = [folder / "pyproject.toml", folder / "README.md", folder / NOTES / "index.html", *models, *checker]
    return sorted(p.relative_to(folder).as_posix() for p in written), executed
