"""Where the checker finds a homework's checks, public scenes and stored expected values.

A student kit carries them inside the package (``mbdkit/data/``); in the course repository they are the
grader's own files (``autograder/``). Both hold the same layout::

    hwN.toml                 the checks of homework N, their points and groups
    scenes/NAME.yaml         the public grading scenes
    reference/public/NAME.npz  the stored expected values of every public check
"""

from __future__ import annotations

from pathlib import Path

PACKAGE_DATA = Path(__file__).resolve().parent / "data"
COURSE_DATA = Path(__file__).resolve().parents[1] / "autograder"


def data_dir() -> Path:
    """The folder holding the homework files, scenes and expected values (kit first, then the course)."""
    return PACKAGE_DATA if PACKAGE_DATA.is_dir() else COURSE_DATA
