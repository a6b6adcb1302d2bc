"""The course secret: what makes the hidden and per-student scenes unknowable from the repository.

Hidden scenes (``hidden/four_bar_b``) and each student's own variants (``student/four_bar``) are derived at
grading time from the public scenes and this secret (``autograder.scenes``), so the repository, which may be
public, holds none of them. The secret is a random string kept outside the repository:

- ``$MBD_GRADER_SECRET`` when set (a grading server, CI, ``make demo``'s own), else
- the file ``$XDG_CONFIG_HOME/mbd-course/secret`` (default ``~/.config/mbd-course/secret``, mode 0600),
  made once by ``mbd secret --init``.

Back the file up with the gradebooks: without it, this term's hidden scenes and per-student variants cannot
be made again (a new secret gives new ones, and every result is graded anew). Grading refuses to start when
no secret is configured (``SecretMissing``): there is no default.
"""

from __future__ import annotations

import hashlib
import os
import secrets
from pathlib import Path

ENV = "MBD_GRADER_SECRET"
INIT_COMMAND = "mbd secret --init"


class SecretMissing(RuntimeError):
    """No course secret is configured: grading cannot make its hidden and per-student scenes."""


def config_dir() -> Path:
    """``$XDG_CONFIG_HOME/mbd-course``, default ``~/.config/mbd-course``."""
    base = os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config"
    return Path(base) / "mbd-course"


def secret_file() -> Path:
    """Where ``mbd secret --init`` keeps the course secret."""
    return config_dir() / "secret"


def course_secret() -> str:
    """The course secret: ``$MBD_GRADER_SECRET``, else the secret file; raises ``SecretMissing`` (saying how
    to make one) when neither is there or the one found is empty."""
    value = os.environ.get(ENV)
    if value is not None:
        if not value.strip():
            raise SecretMissing(f"${ENV} is empty: unset it to use {secret_file()}, or give it the course secret")
        return value.strip()
    path = secret_file()
    try:
        value = path.read_text(encoding="utf-8").strip()
    except FileNotFoundError:
        raise SecretMissing(
            f"no course secret (it derives the hidden and per-student scenes): run `{INIT_COMMAND}` once "
            f"(writes {path}; back it up) or set ${ENV}"
        ) from None
    except (OSError, UnicodeDecodeError) as err:
        raise SecretMissing(f"cannot read the course secret {path}: {err}") from None
    if not value:
        raise SecretMissing(f"the course secret {path} is empty: delete it and run `{INIT_COMMAND}`")
    return value


def secret_digest() -> str:
    """A short hash of the secret (for fingerprints and cache keys: it changes with the secret and reveals
    nothing of it)."""
    return hashlib.sha256(f"mbd-course-secret|{course_secret()}".encode()).hexdigest()[:16]


def init_secret() -> tuple[Path, bool]:
    """Write a new random secret to ``secret_file()`` (mode 0600) unless one is there; returns (path, made)."""
    path = secret_file()
    path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:
        return path, False
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(secrets.token_hex(32) + "\n")
    return path, True


def secret_command(init: bool = False) -> int:
    """``mbd secret [--init]``: say where the course secret is (with ``init``, make it first)."""
    from mbdkit.cli import error

    if init:
        try:
            path, made = init_secret()
        except OSError as err:
            return error(f"cannot write the course secret: {err}")
        if made:
            print(f"course secret written to {path} (mode 0600)")
            print("back it up: the hidden and per-student scenes of this course are made from it")
        else:
            print(f"a course secret is already there: {path} (kept; delete it first to make a new one)")
    if os.environ.get(ENV) is not None:
        print(f"${ENV} is set: grading uses it (it overrides {secret_file()})")
    try:
        course_secret()
    except SecretMissing as err:
        return error(str(err))
    if not init and os.environ.get(ENV) is None:
        print(f"course secret: {secret_file()} (back it up)")
    return 0
