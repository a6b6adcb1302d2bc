"""Stale machine code in numba's cache of this package's own modules, removed before it is loaded.

numba's cache (``cache=True``) keeps a function's machine code beside its file, in ``__pycache__``, and renews it
when that file's modification time or size changes: the function's own file only. A function that calls a
compiled function of another file has that callee compiled into its own machine code (numba compiles the callee
into the caller's library), so when only the callee's file changes (an edit, a ``git pull``, a branch
checkout), the caller's cached code still runs the old callee: ``history_kernels`` runs ``kernels``' rotation
entries, ``kernels`` runs ``rotation_matrices``', ``singular``, ``kinematic_loop`` and ``kernels`` run ``lapack``'s
LAPACK routines, ``spatial_history_kernels`` runs ``history_kernels``' joint forces. (The generated modules do not
have this problem: their cache names hash the files they call, ``codegen``.)

So the files other files' compiled functions call (``CALLED``) leave a stamp in the cache directory, their
modification times and sizes; where it is not the one on disk, every cached machine code of the package is
removed, and each function is compiled again at its next use, as on a new machine (``mbd compile`` does it
at once). A wheel's installation writes every file anew, which numba sees by itself; a checkout is where the
stamp matters. Where the package's ``__pycache__`` cannot be written, numba keeps its cache elsewhere and
nothing is done here.
"""

from __future__ import annotations

import os
from pathlib import Path

HERE = Path(__file__).parent
CALLED = ("kernels.py", "../rotation_matrices.py", "lapack.py", "history_kernels.py")
"""The files whose compiled functions other files' cached functions call (module docstring)."""
STAMP = "mbd-called-files.stamp"


def stamp(package: Path = HERE, called: tuple[str, ...] = CALLED) -> str:
    """The modification time (ns) and size of each of the ``called`` files of ``package``, one line each."""
    lines = []
    for name in called:
        status = (package / name).stat()
        lines.append(f"{name} {status.st_mtime_ns} {status.st_size}")
    return "\n".join(lines) + "\n"


def forget_stale_machine_code(package: Path = HERE, called: tuple[str, ...] = CALLED) -> int:
    """Remove the cached machine code of ``package`` (numba's ``*.nbi`` index and ``*.nbc`` code files in its
    ``__pycache__``) where the stamp of its ``called`` files changed since it was written, then write the new
    stamp; the number of files removed (module docstring). Nothing where the cache cannot be written."""
    cache = package / "__pycache__"
    try:
        now = stamp(package, called)
        before = (cache / STAMP).read_text() if (cache / STAMP).exists() else None
        if before == now:
            return 0
        removed = 0
        if cache.is_dir():
            for path in cache.iterdir():
                if path.suffix in (".nbi", ".nbc"):
                    path.unlink(missing_ok=True)
                    removed += 1
        cache.mkdir(exist_ok=True)
        temporary = cache / f"{STAMP}.{os.getpid()}"
        temporary.write_text(now)
        os.replace(temporary, cache / STAMP)  # whole or not at all: another process may read it now
        return removed
    except OSError:  # a read-only installation: numba caches elsewhere, and a reinstallation renews every file
        return 0


__all__ = ["CALLED", "forget_stale_machine_code", "stamp"]
