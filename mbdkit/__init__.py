"""The course's checker, as students get it: the public checks of a homework on your own ``modules/``.

In a notebook::

    from mbdkit import check
    check("hw1", "revolute")      # raises AssertionError with the grader's message when a check fails

From a terminal: ``mbd selfcheck hw1`` (every public check), ``mbd run MODEL`` and ``mbd check MODEL``
(your own solver in ``modules/`` on a model file).

The checks compare what your package computes with stored expected values of the public scenes; your
code runs in a separate process with time and memory limits, so an endless loop costs one check. The
same code is the first stage of the instructor's grader, which adds hidden scenes and your own variant
of each public scene.

This file imports nothing at start: the sandbox process loads this package before any student code.
"""

__all__ = ["check", "selfcheck"]


def __getattr__(name: str):
    if name in __all__:
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'mbdkit' has no attribute {name!r}")
