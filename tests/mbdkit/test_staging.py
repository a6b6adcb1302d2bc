"""What the grader takes of a submitted package (``mbdkit.staging``): regular files with one name, never what
a link points to; names of any bytes."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from mbdkit import staging

CAPS = (100, 2**20, 4 * 2**20)


@pytest.fixture
def package(tmp_path) -> Path:
    root = tmp_path / "sub" / "modules"
    (root / "inner").mkdir(parents=True)
    (root / "__init__.py").write_text("x = 1\n")
    (root / "inner" / "a.py").write_text("y = 2\n")
    outside = tmp_path / "outside.txt"
    outside.write_text("not the student's")
    os.link(outside, root / "hard.txt")
    (root / "soft.py").symlink_to(outside)
    (root / "folder").symlink_to(tmp_path)
    os.mkfifo(root / "fifo")
    with open(os.fsencode(root) + b"/caf\xe9.py", "w") as f:
        f.write("z = 3\n")
    return root


def test_only_regular_files_with_one_name_are_staged(package, tmp_path):
    found = staging.stage(package.parent, "modules", tmp_path / "staged", CAPS)
    staged = tmp_path / "staged" / "modules"
    copied = sorted(os.fsencode(p.relative_to(staged)) for p in staged.rglob("*") if p.is_file())
    assert copied == [b"__init__.py", b"caf\xe9.py", b"inner/a.py"]
    assert (staged / "inner" / "a.py").read_text() == "y = 2\n"
    assert found.skipped == {
        "fifo": "a FIFO",
        "folder": "a symbolic link",
        "hard.txt": "a hard link (one of 2 names of a file that may lie outside the submission)",
        "soft.py": "a symbolic link",
    }
    note = staging.note(found, "modules")
    assert "modules/hard.txt (a hard link" in note and "modules/soft.py (a symbolic link)" in note


def test_the_package_itself_a_link_is_refused(tmp_path):
    (tmp_path / "eve").mkdir()
    (tmp_path / "eve" / "modules").symlink_to(tmp_path)
    found = staging.stage(tmp_path / "eve", "modules", tmp_path / "staged", CAPS)
    assert found.refused.startswith(f"modules is a symbolic link (to {tmp_path})")
    assert not list((tmp_path / "staged" / "modules").iterdir())


def test_a_file_swapped_for_a_link_after_the_scan_is_not_read(package, tmp_path):
    found = staging.scan(package.parent, "modules")
    init = next(f for f in found.files if f.path == "__init__.py")
    (package / "__init__.py").unlink()
    (package / "__init__.py").symlink_to(tmp_path / "outside.txt")
    with pytest.raises(OSError):
        staging.open_file(package.parent, "modules", init)


def test_names_are_shown_readably():
    assert staging.readable(os.fsdecode(b"caf\xe9.py")) == "caf\\xe9.py"
    assert staging.readable("a\nb") == "a\\nb"
    assert staging.readable("plain.py") == "plain.py"
