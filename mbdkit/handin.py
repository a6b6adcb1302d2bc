"""The hand-in: a zip of exactly what the instructor grades (``mbd handin hwN``).

What is graded is the notebook ``hwN.ipynb`` and the package ``modules/`` beside it; nothing else of the homework
folder goes in (no ``.venv/``, ``build/``, ``*.egg-info``, ``mbdkit/``, scenes, caches or notebook checkpoints), and of
``modules/`` what the grader takes of it (``staging``: regular files; a link is left out, a linked ``modules`` refused).
Before writing, the package is imported in a fresh interpreter, every module of it, so that a package that does
not import (a syntax error, a missing name at module level) is refused with the error, not handed in.
"""

from __future__ import annotations

import json
import subprocess
import sys
import zipfile
from pathlib import Path

from . import staging
from .runner import PACKAGE

SKIPPED = ".ipynb_checkpoints"
"""JupyterLab's copies of the package's files, left out of the zip (the grader would take them, and ignore them)."""
IMPORT_TIMEOUT = 120.0
IMPORT_EVERY_MODULE = """
import importlib, pkgutil, sys
sys.path.insert(0, ".")
import {package}
for module in pkgutil.walk_packages({package}.__path__, "{package}."):
    importlib.import_module(module.name)
"""


class HandinError(ValueError):
    """What keeps a folder from being handed in (one line for the student)."""


def package_files(folder: Path) -> list[str]:
    """The package's files that go into the hand-in, as the grader takes them (``staging.scan``: its regular
    files, without caches and links), relative to ``folder``; HandinError when the grader would take none."""
    found = staging.scan(folder, PACKAGE)
    if found.refused is not None:
        raise HandinError(found.refused)
    return [f"{PACKAGE}/{f.path}" for f in found.files if SKIPPED not in f.path.split("/")]


def import_error(folder: Path) -> str | None:
    """The last line of the error when the package in ``folder`` does not import (every module); None when it
    does."""
    command = [sys.executable, "-c", IMPORT_EVERY_MODULE.format(package=PACKAGE)]
    try:
        done = subprocess.run(command, cwd=folder, capture_output=True, text=True, timeout=IMPORT_TIMEOUT)
    except subprocess.TimeoutExpired:
        return f"importing it did not finish in {IMPORT_TIMEOUT:g} s (code at module level that runs forever?)"
    if done.returncode == 0:
        return None
    lines = [line for line in done.stderr.strip().splitlines() if line.strip()]
    return lines[-1] if lines else f"python exited with code {done.returncode}"


def handin(homework: str, folder: Path, out: Path | None = None) -> tuple[Path, list[str]]:
    """Write the hand-in zip of ``folder`` (default ``folder/hwN-handin.zip``); the zip and what it holds.

    Raises
    ------
    HandinError
        No notebook, a notebook that is not one, no package, or a package that does not import.
    """
    folder = Path(folder).resolve()
    notebook, package = folder / f"{homework}.ipynb", folder / PACKAGE
    if not notebook.is_file():
        raise HandinError(f"no {notebook.name} in {folder}: run mbd handin in your homework folder")
    try:
        json.loads(notebook.read_text(encoding="utf-8"))["cells"]
    except (ValueError, KeyError, TypeError, UnicodeDecodeError):
        raise HandinError(f"{notebook.name} is not a notebook (damaged?): save it again from JupyterLab") from None
    if not (package / "__init__.py").is_file():
        raise HandinError(f"no {PACKAGE}/ (with __init__.py) in {folder}")
    problem = import_error(folder)
    if problem is not None:
        raise HandinError(f"your {PACKAGE}/ does not import, so it cannot be graded: {problem}")
    out = Path(out) if out is not None else folder / f"{homework}-handin.zip"
    if not out.parent.is_dir():
        raise HandinError(f"no folder {out.parent} for {out.name}")
    names = [notebook.name, *package_files(folder)]
    partial = out.with_name(out.name + ".partial")
    with zipfile.ZipFile(partial, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name in names:
            archive.write(folder / name, name)
    partial.replace(out)
    return out, names


def summary(out: Path, names: list[str], folder: Path) -> str:
    """What ``mbd handin`` prints: the zip, its size and what it holds."""
    kb = out.stat().st_size / 1024
    notebook_kb = (Path(folder) / names[0]).stat().st_size / 1024
    package = len(names) - 1
    return (
        f"wrote {out} ({kb:.0f} kB): {names[0]} ({notebook_kb:.0f} kB) and {PACKAGE}/ ({package} files); "
        "nothing else of the folder. Hand in this file.\n"
    )
