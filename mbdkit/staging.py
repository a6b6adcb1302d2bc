"""What the grader takes of a submitted package: its regular files, never what a link points to.

A student hands in an archive; unpacking it (tar, unzip) keeps symbolic links, and a hard link is another
name of a file somewhere else on the machine. The grader runs as root, so reading through either would
show the student a file they could not read themselves (``modules -> ../../solutions`` passes every check;
a hard link to a root-only file comes back in the feedback). So:

- ``modules`` itself must be a real folder, not a link: otherwise the submission is refused (``refusal``),
  and every check fails with a message naming the link (nothing of the student's is there to grade);
- in it, only regular files with one name (``st_nlink == 1``) are taken; a symbolic link (to a file or a
  folder), a hard link, a FIFO, a device or a socket is left out and named in the result (``note``):
  what it points to is never read, so leaving it out is safe, and a stray link (an editor's lock file
  ``.#name.py`` is one) does not cost the checks that do not need it.

Every folder and file is opened relative to its parent's descriptor with ``O_NOFOLLOW`` (a link swapped in
between the scan and the read is not followed either) and checked again after opening (regular, one name,
the inode scanned). Names may be any bytes: they stay ``str`` with surrogate escapes (``os.fsencode`` gives
the bytes back) and are shown with ``readable``.
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass, field

MAX_DEPTH = 32
"""Folders nested deeper than this are left out."""
MAX_ENTRIES = 20_000
"""Entries scanned at most (files and folders); the rest are left out."""
NOFOLLOW = os.O_RDONLY | os.O_NOFOLLOW | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
FOLDER = NOFOLLOW | os.O_DIRECTORY


def readable(name: str) -> str:
    """A name (of any bytes) as printable text: undecodable bytes as ``\\xe9``, control characters escaped."""
    try:
        text = os.fsencode(name).decode("utf-8", "backslashreplace")
    except UnicodeEncodeError:  # a lone surrogate that is no escaped byte (from JSON text, say)
        text = name.encode("utf-8", "backslashreplace").decode("utf-8")
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


@dataclass
class File:
    """A regular file of the package, as scanned."""

    path: str
    """Relative to the package folder, '/'-separated."""
    size: int
    device: int
    inode: int
    mtime_ns: int


@dataclass
class Scan:
    """What a package folder holds: its regular files and what is left out, with the reason."""

    files: list[File] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)
    """Relative path -> why it is left out ('a symbolic link', ...)."""
    refused: str | None = None
    """Why nothing of the folder is taken (``modules`` is a link, not a folder), or None."""


def _kind(mode: int, links: int) -> str | None:
    """Why an entry that is not a folder is left out, or None for a regular file with one name."""
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if not stat.S_ISREG(mode):
        return "not a regular file"
    if links != 1:
        return f"a hard link (one of {links} names of a file that may lie outside the submission)"
    return None


def refusal(folder: str | os.PathLike, package: str) -> str | None:
    """Why ``folder/package`` cannot be graded at all (it is a link, or not a folder); None when it can
    (also when it is missing: the checks say so)."""
    path = os.path.join(os.fspath(folder), package)
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as err:
        return f"{package}/ cannot be read ({err.strerror})"
    if stat.S_ISLNK(info.st_mode):
        try:
            target = f" (to {readable(os.readlink(path))})"
        except OSError:
            target = ""
        return (
            f"{package} is a symbolic link{target}, not a folder: the grader takes only the files you hand in; "
            f"hand in the folder {package}/ itself (an archive without links)"
        )
    if not stat.S_ISDIR(info.st_mode):
        return f"{package} is not a folder: hand in the folder {package}/ with your Python files"
    return None


def scan(folder: str | os.PathLike, package: str) -> Scan:
    """The regular files of ``folder/package`` (without ``__pycache__`` and ``.pyc``) and what is left out."""
    found = Scan(refused=refusal(folder, package))
    if found.refused is not None:
        return found
    try:
        root = os.open(os.path.join(os.fspath(folder), package), FOLDER)
    except OSError as err:
        found.refused = f"{package}/ cannot be read ({err.strerror})"
        return found
    try:
        _scan(root, "", 0, found)
    finally:
        os.close(root)
    found.files.sort(key=lambda f: f.path)
    return found


def _scan(fd: int, relative: str, depth: int, found: Scan) -> None:
    try:
        entries = sorted(os.scandir(fd), key=lambda e: e.name)
    except OSError:
        found.skipped[relative or "."] = "a folder that cannot be read"
        return
    for entry in entries:
        path = f"{relative}{entry.name}"
        if entry.name == "__pycache__" or entry.name.endswith((".pyc", ".pyo")):
            continue
        if len(found.files) + len(found.skipped) >= MAX_ENTRIES:
            found.skipped[path] = f"beyond the first {MAX_ENTRIES} entries"
            continue
        try:
            info = entry.stat(follow_symlinks=False)
        except OSError:
            found.skipped[path] = "cannot be read"
            continue
        if stat.S_ISDIR(info.st_mode):
            if depth >= MAX_DEPTH:
                found.skipped[path] = f"nested deeper than {MAX_DEPTH} folders"
                continue
            try:
                sub = os.open(entry.name, FOLDER, dir_fd=fd)
            except OSError:
                found.skipped[path] = "a folder that cannot be read"
                continue
            try:
                _scan(sub, path + "/", depth + 1, found)
            finally:
                os.close(sub)
            continue
        reason = _kind(info.st_mode, info.st_nlink)
        if reason is not None:
            found.skipped[path] = reason
        else:
            found.files.append(File(path, info.st_size, info.st_dev, info.st_ino, info.st_mtime_ns))


def open_file(folder: str | os.PathLike, package: str, file: File) -> int:
    """A descriptor of a scanned file, opened without following any link on the way, and still the file
    scanned (regular, one name, the same inode); OSError otherwise."""
    parts = file.path.split("/")
    fd = os.open(os.path.join(os.fspath(folder), package), FOLDER)
    try:
        for part in parts[:-1]:
            sub = os.open(part, FOLDER, dir_fd=fd)
            os.close(fd)
            fd = sub
        handle = os.open(parts[-1], NOFOLLOW, dir_fd=fd)
    finally:
        os.close(fd)
    info = os.fstat(handle)
    if _kind(info.st_mode, info.st_nlink) is not None or (info.st_dev, info.st_ino) != (file.device, file.inode):
        os.close(handle)
        raise OSError(f"{readable(file.path)} changed since it was scanned")
    return handle


def select(found: Scan, max_files: int, max_file_bytes: int, max_total: int) -> list[File]:
    """The files to stage within the caps (Python files first); the others join ``found.skipped``."""
    chosen, total = [], 0
    for file in sorted(found.files, key=lambda f: (not f.path.endswith(".py"), f.path)):
        if len(chosen) >= max_files:
            found.skipped[file.path] = f"beyond the first {max_files} files"
        elif file.size > max_file_bytes:
            found.skipped[file.path] = f"larger than {max_file_bytes // 2**20} MiB"
        elif total + file.size > max_total:
            found.skipped[file.path] = f"beyond the {max_total // 2**20} MiB a submission may hold"
        else:
            chosen.append(file)
            total += file.size
    return chosen


def stage(folder: str | os.PathLike, package: str, destination: str | os.PathLike, caps: tuple[int, int, int]) -> Scan:
    """Copy the regular files of ``folder/package`` into ``destination/package`` (files 0644, folders
    0755), within ``caps`` = (files, bytes a file, bytes in all); returns the scan with what was left out."""
    found = scan(folder, package)
    target = os.path.join(os.fspath(destination), package)
    os.makedirs(target, mode=0o755, exist_ok=True)
    os.chmod(target, 0o755)
    if found.refused is not None:
        return found
    max_files, max_file_bytes, max_total = caps
    for file in select(found, max_files, max_file_bytes, max_total):
        try:
            handle = open_file(folder, package, file)
        except OSError:
            found.skipped[file.path] = "changed or vanished while it was staged"
            continue
        with os.fdopen(handle, "rb") as f:
            data = f.read(max_file_bytes + 1)
        if len(data) > max_file_bytes:
            found.skipped[file.path] = f"larger than {max_file_bytes // 2**20} MiB"
            continue
        out = os.path.join(target, *file.path.split("/"))
        _make_folders(target, os.path.dirname(out))
        with open(out, "wb") as f:
            f.write(data)
        os.chmod(out, 0o644)
    return found


def _make_folders(target: str, folder: str) -> None:
    os.makedirs(folder, mode=0o755, exist_ok=True)
    while folder != target and len(folder) > len(target):
        os.chmod(folder, 0o755)
        folder = os.path.dirname(folder)


def note(found: Scan, package: str, most: int = 5) -> str:
    """One sentence naming what was left out and why (empty when nothing was)."""
    if not found.skipped:
        return ""
    items = [f"{package}/{readable(path)} ({why})" for path, why in sorted(found.skipped.items())]
    more = f" and {len(items) - most} more" if len(items) > most else ""
    return (
        f"the grader left out {', '.join(items[:most])}{more}: it takes only regular files of the submission "
        "(no links, FIFOs or devices), within its size limits"
    )
