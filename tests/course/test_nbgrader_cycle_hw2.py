"""The nbgrader cycle of hw2 (tests/course/nbgrader_cycle.py: the class, the cycle and the tests of every
homework)."""

from __future__ import annotations

from .nbgrader_cycle import *  # noqa: F403 (the cycle fixture and the tests of every homework)

HOMEWORK = "hw2"
