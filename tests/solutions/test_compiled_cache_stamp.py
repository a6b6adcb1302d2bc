"""Cached machine code that a change of a called file made stale is removed before it loads (compiled.cache_stamp):
numba itself renews a function's cache only when the function's own file changes."""

from __future__ import annotations

import os

from solutions.compiled import cache_stamp


def _package(tmp_path):
    package = tmp_path / "package"
    (package / "__pycache__").mkdir(parents=True)
    (package / "kernels.py").write_text("def f():\n    return 1\n")
    (package / "history_kernels.py").write_text("from .kernels import f\n")
    names = ("history_kernels.g-10.py311.nbi", "history_kernels.g-10.py311.1.nbc")
    code = [package / "__pycache__" / name for name in names]
    for path in code:
        path.write_bytes(b"machine code")
    pyc = package / "__pycache__" / "kernels.cpython-311.pyc"
    pyc.write_bytes(b"bytecode")
    return package, code, pyc


def test_the_machine_code_goes_when_a_called_file_changes_and_stays_otherwise(tmp_path):
    package, code, pyc = _package(tmp_path)
    called = ("kernels.py",)
    # no stamp yet (a cache of unknown age): removed, and the stamp written
    assert cache_stamp.forget_stale_machine_code(package, called) == 2
    assert not any(path.exists() for path in code) and pyc.exists()
    assert (package / "__pycache__" / cache_stamp.STAMP).read_text() == cache_stamp.stamp(package, called)
    for path in code:  # numba compiles again and writes its cache
        path.write_bytes(b"machine code")
    assert cache_stamp.forget_stale_machine_code(package, called) == 0  # nothing changed: kept
    assert all(path.exists() for path in code)
    (package / "history_kernels.py").write_text("from .kernels import f  # the caller's own file: numba's business\n")
    assert cache_stamp.forget_stale_machine_code(package, called) == 0
    kernels = package / "kernels.py"
    kernels.write_text("def f():\n    return 2\n")  # the same size: the modification time tells
    status = kernels.stat()
    os.utime(kernels, ns=(status.st_atime_ns, status.st_mtime_ns + 1_000_000))
    assert cache_stamp.forget_stale_machine_code(package, called) == 2
    assert not any(path.exists() for path in code) and pyc.exists()


def test_a_cache_that_cannot_be_written_is_left_alone(tmp_path):
    package, code, _ = _package(tmp_path)
    assert cache_stamp.forget_stale_machine_code(package, ("missing.py",)) == 0  # an OSError: nothing done
    assert all(path.exists() for path in code)


def test_the_package_stamps_the_files_its_cached_functions_call():
    """Each file in CALLED exists, and its compiled functions are called from another file's cached ones."""
    here = cache_stamp.HERE
    for name in cache_stamp.CALLED:
        assert (here / name).is_file(), name
    sources = {path.name: path.read_text() for path in here.glob("*.py")}
    spatial = sources["spatial_history_kernels.py"]  # compiled by history_kernels' eager (cache=True)
    assert "from .kernels import" in spatial and "from .history_kernels import" in spatial and "eager" in spatial
    assert "cache=True" in sources["history_kernels.py"]
    assert "from .lapack import" in sources["singular.py"] and "cache=True" in sources["singular.py"]
    assert "from ..rotation_matrices import" in sources["kernels.py"] and "cache=True" in sources["kernels.py"]
