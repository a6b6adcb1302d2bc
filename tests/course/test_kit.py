"""The student kit as a student meets it: installed into a fresh virtual environment, on its own.

Each homework is released (`mbd release hwN` on a scratch copy of the course), its kit is built into a
wheel and installed with ``--no-deps`` into a new venv; the dependencies (numpy, scipy, JupyterLab, ...)
come from this venv's site-packages through a ``.pth`` line, so nothing is downloaded and nothing of the
course is importable there (the editable install of this repository is not). Then, as the kit's README
says: ``mbd selfcheck`` on the skeleton and on the reference pasted in, ``mbd run`` on a scene, the
notebook executed headless with the reference pasted in (the one run of each homework notebook with the
reference: test_notebooks.py runs the released ones on the skeleton); and a scan of what the install put
into site-packages.
"""

from __future__ import annotations

import ast
import json
import re
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import urllib.parse
import zipfile
from pathlib import Path

import nbformat
import pytest

from course.release import HOMEWORKS, build_package, find_leaks, release
from course.release.generator import REPO, all_regions
from mbdkit.homework import load_homework
from solutions.viewer import MIME as VIEW

KIT_RUN = """
import sys
import nbformat
from nbclient import NotebookClient

nb = nbformat.read(sys.argv[1], as_version=4)
where = "import importlib.util, sys; print('PREFIX', sys.prefix)\\n"
where += "print('SOLUTIONS', importlib.util.find_spec('solutions'))"
nb.cells.append(nbformat.v4.new_code_cell(where))
here = {"metadata": {"path": "."}}
NotebookClient(nb, timeout=300, kernel_name="python3", allow_errors=True, resources=here).execute()
nbformat.write(nb, sys.argv[2])
"""


def run(command: list[str], cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess:
    return subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def kits(tmp_path_factory):
    """{homework: kit folder, "course": the course}: every homework released from one scratch copy."""
    from course.demo import scratch_course

    course = scratch_course(tmp_path_factory.mktemp("course") / "course")
    kits = {}
    for homework in HOMEWORKS:
        kit = tmp_path_factory.mktemp("students") / homework
        shutil.copytree(release(homework, course).folder, kit)
        kits[homework] = kit
    kits["course"] = course
    return kits


@pytest.fixture(scope="module")
def student_env(tmp_path_factory, kits):
    """{homework: (python, environment variables, site-packages)}: a fresh venv per homework, holding
    that homework's kit installed from its wheel with ``--no-deps``."""
    envs = {}
    for homework in HOMEWORKS:
        kit = kits[homework]
        root = tmp_path_factory.mktemp(f"venv-{homework}")
        venv = root / "env"
        subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
        python = venv / "bin" / "python"
        where = "import sysconfig; print(sysconfig.get_paths()['purelib'])"
        site = Path(run([str(python), "-c", where], root, {}).stdout.strip())
        (site / "course_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
        wheel = build_wheel(kit, root / "wheel")
        pip = [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index", "-q"]
        done = subprocess.run([*pip, str(wheel)], capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        env = {"PATH": f"{venv / 'bin'}:/usr/bin:/bin", "HOME": str(root), "MPLBACKEND": "Agg"}
        envs[homework] = python, {**env, "OPENBLAS_NUM_THREADS": "1"}, site
    return envs


def build_wheel(kit: Path, out: Path) -> Path:
    """The kit's wheel, built offline with this venv's setuptools (``pip install ./`` does the same)."""
    command = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(out)]
    done = subprocess.run([*command, str(kit)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    shutil.rmtree(kit / "build", ignore_errors=True)  # setuptools' build folder, not the student's
    (wheel,) = out.glob("*.whl")
    return wheel


def kit_checks(kit: Path, homework: str) -> list:
    """The public checks as the kit holds them."""
    return load_homework(kit / "mbdkit" / "data" / f"{homework}.toml").checks


def install(student_env, homework: str) -> tuple[Path, dict]:
    python, env, _ = student_env[homework]
    return python, env


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_the_kit_has_what_its_readme_says(kits, homework):
    kit = kits[homework]
    names = {p.name for p in kit.iterdir()}
    assert {f"{homework}.ipynb", "modules", "scenes", "mbdkit", "pyproject.toml", "README.md"} <= names
    readme = (kit / "README.md").read_text()
    for step in ("pip install ./", f"jupyter lab {homework}.ipynb", f"mbd selfcheck {homework}", "Hand in"):
        assert step in readme
    assert find_leaks(kit, homework) == []
    course = load_homework(kits["course"] / "autograder" / f"{homework}.toml")
    assert kit_checks(kit, homework) == course.public()  # every public check, with its points, and no other


PROVIDES = {"pyyaml": {"yaml"}, "jupyterlab": {"IPython", "ipykernel", "nbformat", "traitlets", "tornado"}}
"""Import names of a dependency other than its own name (JupyterLab brings the kernel and its libraries)."""


def imported_roots(folder: Path) -> dict[str, set[str]]:
    """{top-level module imported anywhere in the .py files under ``folder``: the files importing it}."""
    found: dict[str, set[str]] = {}
    for path in folder.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            for name in names:
                found.setdefault(name.split(".")[0], set()).add(path.relative_to(folder).as_posix())
    return found


def test_the_kit_installs_what_it_imports_and_nothing_of_the_instructors(kits):
    """A light kit: its dependencies hold neither numba (the compiled engine, which no kit holds) nor Dask nor
    nbgrader, and every module the kit's code imports is the standard library's, the kit's own or a declared
    dependency's; Dask only where a cluster is asked for, after a check that names the missing package."""
    kit = kits["hw3"]
    declared = tomllib.loads((kit / "pyproject.toml").read_text())["project"]["dependencies"]
    names = {re.split(r"[<>=\[ ;]", d)[0].lower() for d in declared}
    assert not names & {"numba", "llvmlite", "dask", "distributed", "nbgrader"}, names
    provided = set(names) | {n for d in names for n in PROVIDES.get(d, ())}
    roots = imported_roots(kit / "modules") | imported_roots(kit / "mbdkit")
    foreign = {r: f for r, f in roots.items() if r not in sys.stdlib_module_names and r not in ("modules", "mbdkit")}
    assert set(foreign) - provided == {"dask"}, {r: foreign[r] for r in set(foreign) - provided}
    assert foreign["dask"] == {"batch.py"}
    assert "pip install 'dask[distributed]'" in (kit / "modules" / "batch.py").read_text()


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_selfcheck_in_a_fresh_venv_on_the_skeleton_and_on_the_reference(student_env, kits, homework, tmp_path):
    python, env = install(student_env, homework)
    kit = kits[homework]
    public = kit_checks(kit, homework)

    assert run([str(python), "-c", "import solutions"], kit, env).returncode != 0
    assert run([str(python), "-c", "import autograder"], kit, env).returncode != 0

    skeleton = run(["mbd", "selfcheck", homework], kit, env)
    assert skeleton.returncode == 0, skeleton.stderr
    assert "not implemented yet" in skeleton.stdout and skeleton.stderr == ""
    assert f"0 of {len(public)} public checks pass, 0 of " in skeleton.stdout
    assert "The homework is out of 100: the other " in skeleton.stdout  # its scale, as graded, not the public points
    urls = re.findall(r"^  eq\. (\d+\.\d+): (file://\S+)#eq-(\d+\.\d+)$", skeleton.stdout, flags=re.M)
    assert urls and "The equations cited above, in the course notes" in skeleton.stdout  # the stubs cite them
    for label, url, anchor in urls:  # each opens the kit's own notes at the equation
        page = Path(urllib.parse.unquote(urllib.parse.urlparse(url).path))
        assert label == anchor and page.parent == (kit / "notes").resolve() and f'id="eq-{label}"' in page.read_text()
    asked = [(r.path, r.function) for r in all_regions() if r.tag == homework]
    asked = list(dict.fromkeys(asked))  # what the release asked of this homework, from the course's regions
    todo = run(["mbd", "todo", homework], kit, env)
    assert todo.returncode == 0 and todo.stdout.startswith(f"{homework}: {len(asked)} of {len(asked)} functions left")
    assert all(f"  {function} " in todo.stdout for _, function in asked)
    assert f"Start with {asked[0][1]} in modules/{asked[0][0]}" in todo.stdout
    where = re.search(r"Its equation in the course notes \(open in a browser\): (notes/\S+)#eq-(\S+)$", todo.stdout)
    assert where and f'id="eq-{where.group(2)}"' in (kit / where.group(1)).read_text()

    student = tmp_path / "student"
    shutil.copytree(kit, student)
    shutil.rmtree(student / "modules")
    build_package(student / "modules", None, header=None)  # the reference, as a student who got it all right
    done = run(["mbd", "selfcheck", homework], student, env)
    assert done.returncode == 0 and f"{len(public)} of {len(public)} public checks pass" in done.stdout, done.stdout
    todo = run(["mbd", "todo", homework], student, env)
    assert todo.stdout == f"{homework}: all {len(asked)} functions are written. Next: mbd selfcheck {homework}\n"
    handed = run(["mbd", "handin", homework], student, env)
    assert handed.returncode == 0 and handed.stderr == "", handed.stderr
    with zipfile.ZipFile(student / f"{homework}-handin.zip") as archive:
        names = archive.namelist()
    assert names[0] == f"{homework}.ipynb"
    assert all(n.startswith("modules/") and "__pycache__" not in n for n in names[1:])

    missing = run(["mbd", "selfcheck", homework, str(tmp_path / "no-such-folder")], kit, env)
    assert missing.returncode == 2 and missing.stderr.count("mbd: error:") == 1 and missing.stdout == ""


def test_mbd_run_uses_the_students_own_package(student_env, kits, tmp_path):
    python, env = install(student_env, "hw1")
    student = tmp_path / "hw1"
    shutil.copytree(kits["hw1"], student)
    scene = sorted((student / "scenes").glob("*.yaml"))[0]
    stubbed = run(["mbd", "run", str(scene)], student, env)
    assert stubbed.returncode == 2 and "Traceback" not in stubbed.stderr
    assert stubbed.stderr.startswith("mbd: error: not implemented yet in your modules/:")
    shutil.rmtree(student / "modules")
    build_package(student / "modules", None, header=None)
    done = run(["mbd", "run", str(scene), "--out", "r.csv"], student, env)
    assert done.returncode == 0, done.stderr
    assert (student / "r.csv").is_file() and "kinematic analysis" in done.stdout


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_the_notebook_runs_headless_in_the_fresh_venv(student_env, kits, homework, tmp_path):
    """With the reference pasted into modules/, the notebook runs to the end in the student's own kernel: no
    cell raises or writes to stderr, every graded cell passes (or says the instructor grades it), the plots and
    the viewers are drawn. The release keeps every code cell of the source notebook as it is
    (asserted here), so this is also the run of the source notebook (``assignments/hwN``) with the reference."""
    source = nbformat.read(REPO / "assignments" / homework / f"{homework}.ipynb", as_version=4)
    released = nbformat.read(kits[homework] / f"{homework}.ipynb", as_version=4)
    assert [c.source for c in released.cells if c.cell_type == "code"] == [
        c.source for c in source.cells if c.cell_type == "code"
    ]
    python, env = install(student_env, homework)
    student = tmp_path / homework
    shutil.copytree(kits[homework], student)
    shutil.rmtree(student / "modules")
    build_package(student / "modules", None, header=None)
    done = run([str(python), "-c", KIT_RUN, f"{homework}.ipynb", "executed.ipynb"], student, env)
    assert done.returncode == 0, done.stderr[-2000:]
    nb = nbformat.read(student / "executed.ipynb", as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert all(c.execution_count is not None for c in code)
    failures = [
        (c.source.splitlines()[0], o.get("evalue", "")[:300])
        for c in code
        for o in c.outputs
        if o.output_type == "error"
    ]
    assert failures == []
    said = {c.source.splitlines()[0]: stderr(c) for c in code if stderr(c)}
    assert said == {}, said
    graded = [c for c in code if c.metadata.get("nbgrader", {}).get("grade")]
    assert graded
    for cell in graded:
        out = "".join(o.get("text", "") for o in cell.outputs if o.output_type == "stream")
        assert "checks passed" in out or "checked when the instructor grades" in out, (cell.source, out)
    data = [o.get("data", {}) for c in code for o in c.outputs]
    assert sum("image/png" in d for d in data) >= 3  # plots
    views = [d[VIEW] for d in data if VIEW in d]  # the viewer (solutions/viewer.py): the motion as data
    assert views and all(v["frames"] and len(json.dumps(v)) < 200_000 for v in views)
    assert not any("<script" in d.get("text/html", "") for d in data)  # no player of pictures, no script
    assert (student / "executed.ipynb").stat().st_size < 2_000_000  # after Run All (hw3 was 13.8 MB with players)
    last = "".join(o.get("text", "") for o in code[-1].outputs)
    assert f"PREFIX {python.parent.parent}" in last and "SOLUTIONS None" in last


def stderr(cell) -> str:
    """What a cell wrote to stderr but matplotlib's one-time note in a new home (its font cache)."""
    text = "".join(o.text for o in cell.get("outputs", []) if o.output_type == "stream" and o.name == "stderr")
    return "\n".join(line for line in text.splitlines() if "building the font cache" not in line)


def test_nothing_the_install_put_into_site_packages_is_a_leak(student_env, kits):
    for homework in HOMEWORKS:
        site = student_env[homework][2]
        installed = [p for p in site.iterdir() if p.name.startswith(("mbdkit", "mbd_course"))]
        assert {p.name for p in installed} >= {"mbdkit"}
        assert not (site / "solutions").exists() and not (site / "autograder").exists()
        for path in installed:
            assert find_leaks(path, homework, installed=True) == [], path
        record = next(site.glob("mbd_course_*.dist-info")) / "RECORD"
        assert not [line for line in record.read_text().splitlines() if line.startswith(("solutions/", "autograder/"))]
        stored = sorted((site / "mbdkit" / "data" / "reference" / "public").glob("*.npz"))
        checks = kit_checks(kits[homework], homework)
        assert [p.stem for p in stored] == sorted({c.scene for c in checks})  # public scenes of this homework only
