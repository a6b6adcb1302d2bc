"""Instructor tooling: build student packages from ``solutions/``, check them for leaks, release assignments.

- ``generator``: the student package of homework N (regions of hwN and later stubbed), and ``modules/``
- ``leakcheck``: what must never be in a release folder
- ``release``: ``mbd release hwN`` -- nbgrader's generate (and release) step around the two
"""

from .generator import HOMEWORKS, RegionError, build_modules, build_package, modules_differences
from .leakcheck import Leak, find_leaks
from .release import ReleaseError, ReleaseReport, command, release

__all__ = [
    "HOMEWORKS",
    "Leak",
    "RegionError",
    "ReleaseError",
    "ReleaseReport",
    "build_modules",
    "build_package",
    "command",
    "find_leaks",
    "modules_differences",
    "release",
]
