"""Layers that point one way (issue 24): the solver knows nothing of the course, the kit nothing of the grader.

Every import statement of the course's packages is read from the source (``ast``: also the ones inside
functions, which the import-time graph never sees) and resolved to the module it names:

    solutions  <-  mbdkit  <-  autograder  <-  course        (benchmarks: on top, loaded by path)

A package imports only packages to its left; no module imports a private name (``_name``) of another module
(a package's own private modules, ``mbdkit._child``, excepted); the graph between packages has no cycle. The
course's commands reach ``mbd`` through the entry-point group ``mbd.commands`` (``solutions.cli.COMMANDS``).
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

from solutions import cli

REPO = Path(__file__).resolve().parents[1]
ORDER = ("solutions", "mbdkit", "autograder", "course")
"""The layers, lowest first: each may import the ones before it, none after it."""
COURSE_ONLY = ("benchmarks",)


def module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> list[tuple[int, str, list[str]]]:
    """(line, module, names) of every import in a file, relative ones resolved (names: ``from M import a, b``)."""
    me = module_name(path).split(".")
    package = me if path.name == "__init__.py" else me[:-1]
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name, []) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            found.append((node.lineno, module, [alias.name for alias in node.names]))
    return found


def sources(package: str) -> list[Path]:
    return [p for p in sorted((REPO / package).rglob("*.py")) if "__pycache__" not in p.parts]


EVERY_IMPORT = {package: [(path, *i) for path in sources(package) for i in imports(path)] for package in ORDER}


def is_module(name: str) -> bool:
    path = REPO / Path(*name.split("."))
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


@pytest.mark.parametrize("package", ORDER)
def test_a_package_imports_only_the_layers_below_it(package):
    allowed = set(ORDER[: ORDER.index(package) + 1])
    wrong = [
        f"{path.relative_to(REPO)}:{line}: {module}"
        for path, line, module, _ in EVERY_IMPORT[package]
        if module.split(".")[0] in set(ORDER + COURSE_ONLY) - allowed
    ]
    assert not wrong, "\n".join(wrong)


def test_the_solver_loads_no_course_file_by_path():
    """No string in the solver's code names another package's folder or file (as ``mbd bench`` once loaded
    ``benchmarks/bench.py`` by its path)."""
    other = re.compile(rf"^({'|'.join(ORDER[1:] + COURSE_ONLY)})(/.*\.py)?$")
    wrong = []
    for path in sources("solutions"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and other.match(node.value):
                wrong.append(f"{path.relative_to(REPO)}:{node.lineno}: {node.value!r}")
    assert not wrong, "\n".join(wrong)


def test_no_private_name_is_imported_from_another_module():
    wrong = []
    for package in ORDER:
        for path, line, module, names in EVERY_IMPORT[package]:
            if module.split(".")[0] not in ORDER:
                continue
            for name in names:
                own_module = is_module(f"{module}.{name}") and module == module_name(path).rsplit(".", 1)[0]
                if name.startswith("_") and not name.startswith("__") and not own_module:
                    wrong.append(f"{path.relative_to(REPO)}:{line}: from {module} import {name}")
    assert not wrong, "\n".join(wrong)


PRIVATE_OF_DEPENDENCIES: dict[tuple[str, str], str] = {}
"""Private parts of a dependency still used, each with what for (issue 24: to be replaced by public ones)."""


def test_no_private_api_of_a_dependency():
    """No ``from dep import _name``, no ``dep._module`` (scipy's DOP853 table, nbgrader's internals...), but
    the ones listed, each for a reason."""
    wrong = []
    for package in ORDER:
        for path, line, module, names in EVERY_IMPORT[package]:
            if module.split(".")[0] in ORDER or module == "__future__":
                continue
            private = [p for p in module.split(".") if p.startswith("_") and not p.startswith("__")]
            private += [n for n in names if n.startswith("_") and not n.startswith("__")]
            if [n for n in private if (module, n) not in PRIVATE_OF_DEPENDENCIES]:
                wrong.append(f"{path.relative_to(REPO)}:{line}: {module} {names}")
    assert not wrong, "\n".join(wrong)


def test_the_packages_import_no_cycle():
    edges = {p: {m.split(".")[0] for _, _, m, _ in EVERY_IMPORT[p]} & set(ORDER) - {p} for p in ORDER}
    order = []
    while edges:
        ready = [p for p, needs in edges.items() if needs <= set(order)]
        assert ready, f"an import cycle between {sorted(edges)}"
        order += ready
        for p in ready:
            del edges[p]


ALL = {
    "run",
    "check",
    "view",
    "sweep",
    "derive",
    "export",
    "import",
    "release",
    "nbcheck",
    "notes",
    "gradebook",
    "oral",
    "bench",
    "grade",
    "secret",
    "selfcheck",
    "todo",
    "handin",
    "compile",
    "serve",
}


def commands(parser) -> set[str]:
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    return set(sub.choices)


def test_mbd_has_the_courses_commands_through_the_entry_points():
    assert {e.name for e in cli.registered_commands()} == ALL - set(cli.OWN)
    assert commands(cli.build_parser()) == ALL
    assert commands(cli.build_parser(others=False)) == set(cli.OWN)


def test_a_solver_command_imports_nothing_of_the_course():
    code = (
        "import sys; from solutions.cli import main; main(['check', 'course/models/slider_crank.yaml']); "
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'course', 'autograder', 'mbdkit', 'nbgrader'}))"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "[]"


def test_the_student_package_carries_no_instructor_command():
    text = (REPO / "modules" / "cli.py").read_text()
    for word in ("autograder", "course.", "mbdkit", "benchmarks/", "release", "grade_command"):
        assert word not in text, word
