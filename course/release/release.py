"""``mbd release hwN``: one command to release the next assignment, unable to leak a solution.

Steps, each refusing with a clear message (``ReleaseError``) instead of releasing something wrong:

1. the homework must be one of the course's (hw1, hw2, hw3) with a source folder ``assignments/hwN/``;
2. ``modules/`` must be in sync with ``solutions/`` (``make modules``) and committed;
3. nbgrader's generate step (``generate_assignment``, with ``course/nbgrader_config.py``) writes the
   student notebooks to ``build/release/hwN/``;
4. the hwN student package is built from ``solutions/`` into ``build/release/hwN/modules/``: hwN and later
   regions stubbed, earlier ones filled in; the checker ``mbdkit/`` (the public checks with their stored
   expected values), ``pyproject.toml`` and a README for students make the folder a kit that installs
   with ``pip install ./`` (``kit``);
5. the leak check scans the whole release folder; on any leak the folder is deleted;
6. where an exchange is configured (``CourseDirectory.course_id`` and ``Exchange.root``), nbgrader's
   release step copies the folder to the exchange.

The returned ``ReleaseReport`` says what was released (``report.summary()``).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from .generator import HOMEWORKS, REPO, RegionError, build_package, modules_differences
from .kit import build_kit, course_dependencies
from .leakcheck import find_leaks

CONFIG = Path("course", "nbgrader_config.py")


class ReleaseError(Exception):
    """A release refused: the message says why and what to do."""


@dataclass
class ReleaseReport:
    """What ``release`` did."""

    homework: str
    folder: Path
    notebooks: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    to_write: list[str] = field(default_factory=list)
    kit: list[str] = field(default_factory=list)
    given: list[str] = field(default_factory=list)
    later: list[str] = field(default_factory=list)
    exchange: str | None = None
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0
    size: int = 0
    """Bytes of the release folder (what is handed out)."""
    installs: list[str] = field(default_factory=list)
    """What ``pip install ./`` of the kit installs (its pyproject's dependencies)."""
    notes_kind: str = ""
    """Whether the kit's notes show the notebooks' outputs (``course.notes.build.kit_notes``)."""

    def summary(self) -> str:
        """What was released, for the instructor (``mbd release`` prints it)."""
        lines = [
            f"released {self.homework} into {self.folder} ({self.seconds:.1f} s)",
            f"  notebooks:        {', '.join(self.notebooks)}",
            f"  student package:  {self.folder / 'modules'} ({len(self.files)} files)",
            f"  to write:         {len(self.to_write)} functions raise NotImplementedError for {self.homework}",
        ]
        lines += [f"                    {name}" for name in self.to_write]
        lines.append(
            f"  checker:          {self.folder / 'mbdkit'} (public checks, stored expected values); students "
            f"install the kit with `pip install ./` ({len(self.kit)} files with pyproject.toml and README.md)"
        )
        lines.append(
            f"  size:             {self.size / 1e6:.1f} MB to hand out; pip install ./ adds {', '.join(self.installs)}"
        )
        lines.append(f"  course notes:     {self.folder / 'notes' / 'index.html'} (offline; {self.notes_kind})")
        if self.given:
            lines.append(f"  given, filled in: {len(self.given)} functions of earlier homeworks")
        if self.later:
            lines.append(f"  later homeworks:  {len(self.later)} functions stubbed until their homework")
        lines.append("  leak check:       clean")
        lines.append(
            f"  exchange:         released to {self.exchange}"
            if self.exchange
            else "  exchange:         none configured; hand out the release folder"
        )
        lines += [f"  note: {note}" for note in self.notes]
        return "\n".join(lines)


NOTES_AS_WRITTEN = "text and equations, as MBD_KIT_NOTES=as-written asks; without it a release executes them once"


def load_config(course_dir: Path):
    """The traitlets Config of ``course/nbgrader_config.py``."""
    from traitlets.config.loader import PyFileConfigLoader

    path = course_dir / CONFIG
    if not path.is_file():
        raise ReleaseError(f"no nbgrader configuration at {path}")
    return PyFileConfigLoader(path.name, path=str(path.parent)).load_config()


def _check_homework(homework: str, course_dir: Path) -> Path:
    if homework not in HOMEWORKS:
        raise ReleaseError(f"unknown homework {homework!r}: this course has {', '.join(HOMEWORKS)}")
    source = course_dir / "assignments" / homework
    if not any(source.glob("*.ipynb")):
        raise ReleaseError(f"{homework} has no notebook in {source}: nothing to release")
    return source


def _git_changes(course_dir: Path, folder: str) -> list[str] | None:
    """Uncommitted changes under ``folder`` (porcelain lines); None when this is not a git work tree."""
    try:
        done = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=all", "--", folder],
            cwd=course_dir,
            capture_output=True,
            text=True,
            check=False,
        )
    except FileNotFoundError:
        return None
    if done.returncode != 0:
        return None
    return [line for line in done.stdout.splitlines() if line.strip()]


def check_modules(course_dir: Path) -> list[str]:
    """Refuse a stale or dirty ``modules/``; returns notes (e.g. that git was not there to ask)."""
    try:
        stale = modules_differences(course_dir / "modules", course_dir / "solutions")
    except RegionError as err:
        raise ReleaseError(f"solutions/ has a malformed solution region: {err}") from None
    if stale:
        listing = "\n  ".join(stale[:10]) + ("\n  ..." if len(stale) > 10 else "")
        raise ReleaseError(
            f"modules/ is stale: it does not match solutions/ ({len(stale)} files):\n  {listing}\n"
            "run `make modules`, review and commit it, then release again"
        )
    changes = _git_changes(course_dir, "modules")
    if changes is None:
        return ["not a git work tree: modules/ checked against solutions/ only, not for uncommitted changes"]
    if changes:
        listing = "\n  ".join(changes[:10])
        raise ReleaseError(
            f"modules/ is dirty: it has uncommitted changes:\n  {listing}\ncommit them, then release again"
        )
    return []


def _nbgrader_api(config):
    from nbgrader.apps import NbGraderAPI
    from nbgrader.coursedir import CourseDirectory

    return NbGraderAPI(CourseDirectory(config=config), config=config)


def _nbgrader_failed(step: str, result: dict) -> ReleaseError:
    log = [line for line in (result.get("log") or "").splitlines() if line.strip()]
    errors = [line for line in log if line.startswith(("[ERROR]", "[WARNING]", "[CRITICAL]"))] or log
    detail = "\n  ".join(errors[-15:]) or (result.get("error") or "").strip()
    return ReleaseError(f"nbgrader's {step} step failed:\n  {detail}")


def _alembic_head() -> str:
    """The gradebook schema version nbgrader writes into a new gradebook, read in-process.

    nbgrader asks for it by running the ``alembic`` command (``nbgrader.api.get_alembic_version``): a
    second Python start-up of several seconds, and a failure when the venv's bin/ is not on PATH.
    """
    import nbgrader
    from alembic.config import Config
    from alembic.script import ScriptDirectory

    config = Config()  # alembic's public API over the migration scripts nbgrader ships (nbgrader/alembic/)
    config.set_main_option("script_location", str(Path(nbgrader.__file__).parent / "alembic"))
    return ScriptDirectory.from_config(config).get_current_head()


@contextlib.contextmanager
def _nbgrader_environment():
    """Run nbgrader's steps with the gradebook version read in-process, and the venv's bin/ on PATH."""
    import nbgrader.api

    original = getattr(nbgrader.api, "get_alembic_version", None)
    if original is not None:
        nbgrader.api.get_alembic_version = _alembic_head
    old_path = os.environ.get("PATH", "")
    bin_dir = str(Path(sys.executable).parent)
    if shutil.which("alembic") is None:
        os.environ["PATH"] = os.pathsep.join([bin_dir, old_path]) if old_path else bin_dir
    try:
        yield
    finally:
        os.environ["PATH"] = old_path
        if original is not None:
            nbgrader.api.get_alembic_version = original


def _exchange_configured(config) -> bool:
    return bool(config.CourseDirectory.get("course_id")) and "root" in config.get("Exchange", {})


def release(homework: str, course_dir: Path | None = None) -> ReleaseReport:
    """Release ``homework`` ('hw1', 'hw2', 'hw3') of the course in ``course_dir`` (this repository by default).

    Raises
    ------
    ReleaseError
        Unknown homework, stale or dirty ``modules/``, a malformed region, an nbgrader failure, or a leak
        (the release folder is deleted then). The message says what to do.
    """
    start = time.perf_counter()
    course_dir = Path(course_dir or REPO).resolve()
    _check_homework(homework, course_dir)
    notes = check_modules(course_dir)
    config = load_config(course_dir)
    api = _nbgrader_api(config)
    folder = Path(api.coursedir.format_path(api.coursedir.release_directory, ".", homework))
    Path(api.coursedir.root, "build").mkdir(parents=True, exist_ok=True)

    with _nbgrader_environment():
        result = api.generate_assignment(homework, force=True, create=True)
    if not result["success"]:
        raise _nbgrader_failed("generate_assignment", result)
    try:
        built = build_package(folder / "modules", homework, course_dir / "solutions")
    except (RegionError, ValueError) as err:
        shutil.rmtree(folder, ignore_errors=True)
        raise ReleaseError(f"cannot build the {homework} student package: {err}") from None

    index = HOMEWORKS.index(homework) + 1
    now = [r for r in built.stubbed if r.homework == index]
    later = {r.qualified_name for r in built.stubbed if r.homework > index}
    asked = list(dict.fromkeys((r.path, r.function) for r in now))
    kit, notes_executed = build_kit(folder, homework, asked, course_dir)

    leaks = find_leaks(folder, homework, course_dir)
    if leaks:
        shutil.rmtree(folder, ignore_errors=True)
        listing = "\n  ".join(str(leak) for leak in leaks[:20]) + ("\n  ..." if len(leaks) > 20 else "")
        raise ReleaseError(
            f"{homework} not released: the release folder would leak ({len(leaks)} findings):\n  {listing}\n"
            f"the folder {folder} was deleted; remove the leak from assignments/{homework}/ and release again"
        )
    report = ReleaseReport(
        homework=homework,
        folder=folder,
        notebooks=sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*.ipynb")),
        files=built.files,
        to_write=list(dict.fromkeys(r.qualified_name for r in now)),
        kit=kit,
        given=built.filled_functions(),
        later=sorted(later),
        notes=notes,
        size=sum(p.stat().st_size for p in folder.rglob("*") if p.is_file()),
        installs=[re.split(r"[<>=\[ ;]", d)[0] for d in course_dependencies(course_dir)],
        notes_kind="with the notebooks' outputs" if notes_executed else NOTES_AS_WRITTEN,
    )
    if not report.to_write:
        report.notes.append(f"no solution region is tagged {homework}: students have nothing to write in modules/")

    if _exchange_configured(config):
        with _nbgrader_environment():
            result = api.release_assignment(homework)
        if not result["success"]:
            raise _nbgrader_failed("release_assignment", result)
        report.exchange = str(Path(config.Exchange.root, config.CourseDirectory.course_id, "outbound", homework))
    report.seconds = time.perf_counter() - start
    return report


def command(homework: str, course_dir: Path | None = None) -> int:
    """``mbd release hwN``: release, print what was released; on a refusal print why and return 2."""
    try:
        report = release(homework, course_dir)
    except ReleaseError as err:
        print(f"mbd: error: {err}", file=sys.stderr)
        return 2
    print(report.summary())
    return 0
