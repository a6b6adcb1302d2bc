"""Hand-ins from a learning platform's "download all submissions" (``mbd grade --lms``, nbgrader's ``zip_collect``).

A platform names each student's files in its download after the student; a preset says how, and gives the
student id (the platform's own number), the name and whether the hand-in was late. As the platforms write them
(read from their source):

- **Moodle** (mod/assign: ``classes/downloader.php`` since 4.1, ``locallib.php`` before): one folder per student
  ``Full Name_12345_assignsubmission_file/`` (``..._file_/`` in Moodle 3.1 to 4.0) holding the uploaded files, or,
  with "Download submissions in folders" off, the prefix on every file: ``Full Name_12345_assignsubmission_file_
  hw1-handin.zip``. 12345 is the assignment's participant number (the grading worksheet's "Participant 12345",
  the id under blind marking, where the name is "Participant"), not the user id: it differs between
  assignments. An underscore of a name becomes a space. Online text is ``..._assignsubmission_onlinetext...``.
  A resubmission replaces the files: the download holds the last one.
- **Canvas** (``lib/content_zipper.rb``): every file of the latest submission, flat, as ``lastnamefirstname_
  12345_67890_hw1-handin.zip`` (the sortable name in lower case without spaces or punctuation, the user id, the
  file's attachment id, the file's name), ``lastnamefirstname_LATE_12345_...`` when it came late,
  ``anon_Ab1cD_67890_...`` when the assignment hides the students; online text ``..._12345_text.html``, a link
  ``..._link.html``. A file uploaded again under the same name is renamed ``hw1-1.ipynb``
  (``Attachment.make_unique_filename``).
- **Any other platform**: a regular expression that matches the name of one student's folder or file
  (``re.fullmatch``), with the group ``(?P<student_id>...)``; optional groups ``name`` (or ``first_name`` and
  ``last_name``), ``late`` (non-empty: late), ``timestamp`` (a later one wins between two hand-ins of a student)
  and ``file_id`` (the student's own file name, where the platform puts it in the same name).

Inside a student's files, what is graded is found as ``mbd handin`` writes it: the notebook ``hwN.ipynb`` and the
package ``modules/``, in the shallowest folder that holds ``modules/`` (a hand-in zip is opened as a folder of its
name, as nbgrader's ``zip_collect`` unpacks it: a zip of the whole kit folder, with ``build/lib/modules`` and
``.venv/``, gives the kit's own ``modules/``). The only notebook under another name there (``hw1 (1).ipynb``,
Canvas's ``hw1-1.ipynb``) is taken as ``hw1.ipynb`` and said so. Everything else is skipped and counted by
reason, and nothing collected is one line that says what was expected (exit code 2).
"""

from __future__ import annotations

import csv
import os
import re
import shutil
import sys
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

PACKAGE = "modules"
COLLECTED = "collected.csv"
"""What was collected, one row per student (id, name, late, notebook, package files, note): written beside the
collected folders."""
EXTENSIONS = (".py", ".json")
"""The package's files that are collected (nbgrader's ``FileNameCollectorPlugin.valid_ext`` on its route)."""
ARCHIVES = (".zip",)
"""Hand-ins opened as folders (nbgrader's extractor also opens .gz)."""
NOTEBOOK_BYTES = 64 * 2**20
NESTED_ZIP_BYTES = 256 * 2**20
"""A hand-in zip inside a download larger than this (unpacked) is not opened."""
SAFE_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.@+-]{0,99}")
"""A student id that is a folder name everywhere (the platforms' numbers, ``anon_Ab1cD``, e-mail addresses)."""


class LmsError(ValueError):
    """A preset, download or option that cannot be used (one line for the instructor)."""


@dataclass(frozen=True)
class Preset:
    """How one platform names a student's folder or file in its download."""

    name: str
    title: str
    example: str
    """The names it expects, for messages."""
    entries: tuple[re.Pattern, ...]
    not_files: tuple[re.Pattern, ...] = ()
    """Entries that are no file (online text, links): skipped, and said so."""

    def match(self, part: str) -> re.Match | None:
        return next((m for m in (p.fullmatch(part) for p in self.entries) if m), None)

    def is_not_file(self, part: str) -> bool:
        return any(p.fullmatch(part) for p in self.not_files)


PRESETS = {
    "moodle": Preset(
        "moodle",
        "Moodle",
        "'Full Name_12345_assignsubmission_file/...' or 'Full Name_12345_assignsubmission_file_NAME'",
        (re.compile(r"(?P<name>[^_/\\]*)_(?P<student_id>\d+)_assignsubmission_file(?:_(?P<file_id>.*))?"),),
        (re.compile(r"[^_/\\]*_\d+_assignsubmission_(?!file(?:_|$))\w+"),),
    ),
    "canvas": Preset(
        "canvas",
        "Canvas",
        "'lastnamefirstname_12345_67890_NAME' or 'lastnamefirstname_LATE_12345_67890_NAME'",
        (
            re.compile(r"(?:(?P<late>LATE)_)?(?P<student_id>anon_[A-Za-z0-9]+)_(?P<timestamp>\d+)_(?P<file_id>.+)"),
            re.compile(r"(?P<name>\w*?)_(?:(?P<late>LATE)_)?(?P<student_id>\d+)_(?P<timestamp>\d+)_(?P<file_id>.+)"),
        ),
        (re.compile(r"(?:\w*?_)?(?:LATE_)?(?:\d+|anon_[A-Za-z0-9]+)_(?:text|link)\.html"),),
    ),
}


def preset(spec: str) -> Preset:
    """The preset named ``spec`` (``moodle``, ``canvas``), or one made of a regular expression with the group
    ``(?P<student_id>...)``; LmsError otherwise."""
    if spec.lower() in PRESETS:
        return PRESETS[spec.lower()]
    if re.fullmatch(r"[a-z]+", spec):
        raise LmsError(f"no preset {spec!r}: moodle, canvas, or a regular expression with (?P<student_id>...)")
    try:
        pattern = re.compile(spec)
    except re.error as err:
        raise LmsError(f"{spec!r} is not a regular expression ({err})") from None
    if "student_id" not in pattern.groupindex:
        raise LmsError(f"{spec!r} has no group (?P<student_id>...): it names the student of each entry")
    return Preset("regexp", "regexp", repr(spec), (pattern,))


# -- what to collect: a plan over the download's file names -------------------------------------------------
HIDDEN = "hidden or cache files (.venv/, __pycache__/, .ipynb_checkpoints/, __MACOSX/)"
NOT_A_FILE = "online texts or links (no file handed in)"
UNSAFE = "with '..' in their names (not written)"
BAD_ID = "whose student id cannot name a folder"
OTHER_HANDIN = "of another copy of the hand-in (build/lib/, an earlier upload: not the one taken)"


@dataclass
class Student:
    """One student's entry in the download and what is collected of it (file id -> source path)."""

    id: str
    name: str = ""
    late: bool = False
    files: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def label(self) -> str:
        return f"{self.id} ({self.name})" if self.name else self.id


@dataclass
class Collection:
    """What a download holds for a homework: students with their files, what is skipped (reason -> paths)."""

    preset: Preset
    homework: str
    students: dict[str, Student] = field(default_factory=dict)
    skipped: dict[str, list[str]] = field(default_factory=dict)
    paths: list[str] = field(default_factory=list)
    """Every file of the download (relative paths)."""
    archives: int = 0
    matched: int = 0
    """Files whose name matched the preset (a student's entry)."""

    @property
    def notebook(self) -> str:
        return f"{self.homework}.ipynb"

    @property
    def handed_in(self) -> list[Student]:
        return [s for s in self.students.values() if s.files]

    def skip(self, reason: str, path: str) -> None:
        self.skipped.setdefault(reason, []).append(path)

    def sources(self) -> dict[str, tuple[str, str]]:
        """Source path -> (student id, file id) of every file collected."""
        return {src: (s.id, file_id) for s in self.students.values() for file_id, src in s.files.items()}

    def summary(self, source: str) -> str:
        """A few lines: how many students and files, what was skipped and why, the students to look at."""
        students = self.handed_in
        files = [f for s in students for f in s.files]
        notebooks = sum(f == self.notebook for f in files)
        lines = [
            f"{self.preset.title} preset: {len(students)} students, {len(files)} files collected from {source} "
            f"({notebooks} notebooks {self.notebook}, {len(files) - notebooks} files of {PACKAGE}/)"
            + (f"; {self.archives} hand-in zips opened" if self.archives else "")
        ]
        if self.skipped:
            counted = sorted(self.skipped.items(), key=lambda item: -len(item[1]))
            parts = [
                f"{len(paths)} {reason}" + (f" (e.g. {paths[0]})" if reason.startswith("not named") else "")
                for reason, paths in counted
            ]
            lines.append(f"  skipped {sum(len(p) for _, p in counted)} files: " + "; ".join(parts))
        late = [s.id for s in students if s.late]
        if late:
            lines.append(f"  late ({len(late)}): {', '.join(late[:20])}" + (" ..." if len(late) > 20 else ""))
        noted = [f"{s.label}: {'; '.join(s.notes)}" for s in self.students.values() if s.notes]
        for line in noted[:8]:
            lines.append(f"  {line}")
        if len(noted) > 8:
            lines.append(f"  ... and {len(noted) - 8} more students with a note ({COLLECTED})")
        return "\n".join(lines)

    def nothing(self, source: str, option: str) -> str:
        """The line when nothing was collected: what the preset expected, and the preset the names fit if any
        (``option`` shows how to choose one, e.g. ``--lms {}``)."""
        text = f"0 submissions found in {source}: "
        if self.matched:
            return text + (
                f"{len(self.students)} students' files matched the {self.preset.title} preset's names, but none "
                f"held {self.notebook} or {PACKAGE}/"
            )
        text += f"no file matched the {self.preset.title} preset's names ({self.preset.example})"
        return text + hint(self.paths, self.homework, option, but=self.preset.name)

    def write_csv(self, path: Path) -> None:
        """``collected.csv``: one row per student of the download, the name the platform gave, late, notes."""
        with open(path, "w", newline="") as f:
            out = csv.writer(f)
            out.writerow(["student", "name", "late", "notebook_from", "package_files", "note"])
            for s in sorted(self.students.values(), key=lambda s: s.id):
                package = sum(f.startswith(PACKAGE + "/") for f in s.files)
                out.writerow(
                    [
                        s.id,
                        s.name,
                        "late" if s.late else "",
                        s.files.get(self.notebook, ""),
                        package,
                        "; ".join(s.notes),
                    ]
                )


def hint(paths: list[str], homework: str, option: str, but: str = "") -> str:
    """``; is it Canvas's download? --lms canvas`` when the names fit another preset, else how to give one."""
    for name, other in PRESETS.items():
        if name != but and plan(paths, other, homework).handed_in:
            return f"; is it {other.title}'s download? {option.format(name)}"
    return f"; give the platform's preset or a regular expression: {option.format('moodle|canvas|REGEXP')}"


def split(path: str) -> tuple[str, ...]:
    """A path's parts, either separator (zips made on Windows use backslashes)."""
    return tuple(p for p in re.split(r"[/\\]", path) if p not in ("", "."))


def hidden(parts: tuple[str, ...]) -> bool:
    return any(p.startswith(".") or p in ("__MACOSX", "__pycache__") for p in parts) or parts[-1].endswith(
        (".pyc", ".pyo")
    )


def plan(
    paths: list[str], chosen: Preset, homework: str, extensions=EXTENSIONS, problems: dict[str, str] | None = None
) -> Collection:
    """What to collect of a download's files (paths relative to it, '/'-separated; a hand-in zip's files under a
    folder of its name): every file is one student's, taken, or skipped with its reason."""
    found = Collection(chosen, homework, paths=list(paths))
    unmatched = f"not named as the {chosen.title} preset's entries"
    entries: dict[str, list[tuple[tuple[str, ...], str, str]]] = {}
    for path in sorted(paths):
        parts = split(path)
        if problems and path in problems:
            found.skip(problems[path], path)
        elif ".." in parts:
            found.skip(UNSAFE, path)
        elif not parts or hidden(parts):
            found.skip(HIDDEN, path)
        elif parts[-1].lower().endswith(ARCHIVES):
            found.archives += 1
        else:
            entry = next(((i, chosen.match(p)) for i, p in enumerate(parts) if chosen.match(p)), None)
            if entry is None:
                found.skip(NOT_A_FILE if any(map(chosen.is_not_file, parts)) else unmatched, path)
                continue
            i, match = entry
            groups = {k: v for k, v in match.groupdict().items() if v}
            student = groups["student_id"]
            if not SAFE_ID.fullmatch(student):
                found.skip(BAD_ID, path)
                continue
            found.matched += 1
            record = found.students.setdefault(student, Student(student))
            name = groups.get("name") or " ".join(filter(None, (groups.get("first_name"), groups.get("last_name"))))
            record.name = record.name or name
            record.late = record.late or "late" in groups
            inside = ((groups["file_id"],) if "file_id" in groups else ()) + parts[i + 1 :]
            order = groups.get("timestamp", "").zfill(20)
            entries.setdefault(student, []).append((inside, order, path))
    for student, files in entries.items():
        choose(found, found.students[student], files, tuple(extensions))
    return found


def kit_root(inside: tuple[str, ...]) -> tuple[str, ...] | None:
    """The folder a file says is a hand-in's: the one holding ``modules/`` for a file of the package, the
    notebook's own folder for a notebook; None for any other file."""
    if PACKAGE in inside[:-1]:
        return inside[: inside.index(PACKAGE)]
    return inside[:-1] if inside[-1].endswith(".ipynb") else None


def uploaded_as(name: str, homework: str) -> bool:
    """Whether a file name is the homework's notebook, or Canvas's name for it uploaded again (``hw1-1.ipynb``)."""
    return re.fullmatch(rf"{re.escape(homework)}(?:-\d+)?\.ipynb", name) is not None


def choose(found: Collection, student: Student, files: list, extensions: tuple[str, ...]) -> None:
    """Take one student's notebook and package: from the shallowest folder holding ``modules/`` (between two at
    the same depth, the later upload), else the shallowest folder holding a notebook."""
    outside = f"outside {found.notebook} and {PACKAGE}/ (scenes, mbdkit/, README, ...)"
    package_roots, notebook_roots = {}, {}
    for inside, order, _ in files:
        root = kit_root(inside)
        if root is not None:
            roots = package_roots if PACKAGE in inside[:-1] else notebook_roots
            roots[root] = max(order, roots.get(root, ""))
    roots = package_roots or notebook_roots
    if not roots:
        student.notes.append(f"nothing to grade: no {found.notebook} or {PACKAGE}/ (it holds {files[0][0][-1]!r})")
        for _, _, path in files:
            found.skip(outside, path)
        return
    depth = min(len(r) for r in roots)
    level = sorted((r for r in roots if len(r) == depth), key=lambda r: (roots[r], r))
    root = level[-1]
    if len(level) > 1:
        student.notes.append(f"{len(level)} hand-ins; took the later one {'/'.join(root) or '(top)'!r}")
    notebooks = [(inside[-1], path) for inside, _, path in files if kit_root(inside) == root and PACKAGE not in inside]
    taken = [path for name, path in notebooks if name == found.notebook]
    if not taken and len(notebooks) == 1:
        taken = [notebooks[0][1]]
        student.notes.append(f"notebook {notebooks[0][0]!r} taken as {found.notebook}")
    elif not taken and notebooks:
        names = ", ".join(repr(name) for name, _ in notebooks)
        student.notes.append(f"no {found.notebook} but several notebooks ({names}): none taken")
    elif not notebooks:
        elsewhere = sorted((len(i), path) for i, _, path in files if uploaded_as(i[-1], found.homework))
        taken = [elsewhere[0][1]] if elsewhere else []
        student.notes.append(f"{found.notebook} from beside the hand-in" if elsewhere else f"no {found.notebook}")
    for inside, _, path in files:
        in_package = len(inside) > len(root) + 1 and inside[: len(root) + 1] == (*root, PACKAGE)
        if path in taken:
            student.files[found.notebook] = path
        elif in_package and inside[-1].endswith(extensions):
            student.files["/".join(inside[len(root) :])] = path
        elif in_package:
            found.skip(f"in {PACKAGE}/ but not {'/'.join(extensions)}", path)
        elif kit_root(inside) is not None:
            found.skip(OTHER_HANDIN, path)
        else:
            found.skip(outside, path)
    if not any(f.startswith(PACKAGE + "/") for f in student.files):
        student.notes.append(f"no {PACKAGE}/")


# -- mbd grade: a download (zip or folder) unpacked into one folder per student ---------------------------
class Download:
    """The files of a platform's download, a zip or the folder it was unpacked into, every hand-in zip in it
    opened as a folder of its name (as nbgrader's ``zip_collect`` unpacks it); read only what is collected.
    Links are not followed; a zip that cannot be read is skipped with the reason."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.paths: list[str] = []
        self.problems: dict[str, str] = {}
        self._where: dict[str, tuple[zipfile.ZipFile | None, str]] = {}
        self._opened: list = []
        if self.path.is_dir():
            self._walk_folder()
        elif zipfile.is_zipfile(self.path):
            self._walk_zip(self._keep(zipfile.ZipFile(self.path)), "", nested=False)
        elif self.path.exists():
            raise LmsError(f"{self.path} is neither a zip nor a folder: give the platform's download (a .zip)")
        else:
            raise LmsError(f"no file or folder {self.path}")

    def __enter__(self) -> Download:
        return self

    def __exit__(self, *_) -> None:
        for handle in reversed(self._opened):
            handle.close()

    def _keep(self, handle):
        """An open zip or temporary file, closed with the Download."""
        self._opened.append(handle)
        return handle

    def _add(self, logical: str, archive: zipfile.ZipFile | None, name: str, nested: bool) -> None:
        """A file of the download; a zip in it is opened (a hand-in), a zip in a hand-in is not."""
        self.paths.append(logical)
        self._where[logical] = (archive, name)
        if logical.lower().endswith(ARCHIVES) and not hidden(split(logical)):
            if nested:
                self.problems[logical] = "zips inside a hand-in zip (not opened)"
            else:
                self._open_nested(logical)

    def _walk_folder(self) -> None:
        for folder, dirs, names in os.walk(self.path):
            dirs.sort()
            for name in sorted(names):
                full = os.path.join(folder, name)
                logical = os.path.relpath(full, self.path).replace(os.sep, "/")
                if os.path.islink(full) or not os.path.isfile(full):
                    self.paths.append(logical)
                    self.problems[logical] = "links and special files (not followed)"
                else:
                    self._add(logical, None, full, nested=False)

    def _walk_zip(self, archive: zipfile.ZipFile, prefix: str, nested: bool) -> None:
        for info in archive.infolist():
            if not info.is_dir():
                self._add(prefix + info.filename, archive, info.filename, nested)

    def _open_nested(self, logical: str) -> None:
        """Open a hand-in zip as the folder ``logical`` without .zip; one inside the download is copied to an
        anonymous temporary file first (at most NESTED_ZIP_BYTES), so that no hand-in is held in memory."""
        archive, name = self._where[logical]
        try:
            if archive is None:
                inner = self._keep(zipfile.ZipFile(name))
            else:
                if archive.getinfo(name).file_size > NESTED_ZIP_BYTES:  # a zip yields no more than it declares
                    raise zipfile.BadZipFile("too large")
                copy = self._keep(tempfile.TemporaryFile())
                with archive.open(name) as f:
                    shutil.copyfileobj(f, copy)
                inner = self._keep(zipfile.ZipFile(copy))
            self._walk_zip(inner, logical[: -len(Path(logical).suffix)] + "/", nested=True)
        except (zipfile.BadZipFile, OSError, RuntimeError, NotImplementedError, EOFError):
            self.problems[logical] = "hand-in zips that cannot be opened (damaged, encrypted, over 256 MB)"

    def read(self, logical: str, limit: int) -> bytes | None:
        """The file's bytes, or None when it is larger than ``limit`` (whatever the zip says of its size)."""
        archive, name = self._where[logical]
        with archive.open(name) if archive else open(name, "rb") as f:
            data = f.read(limit + 1)
        return data if len(data) <= limit else None


def unpack(download: str | Path, chosen: Preset, homework: str, dest: str | Path) -> Collection:
    """Collect a download into ``dest/STUDENT/`` (``hwN.ipynb`` and ``modules/``, as ``mbd grade`` takes a
    folder of student folders) and ``dest/collected.csv``; the Collection says what was taken and skipped."""
    from mbdkit.isolation import MAX_FILE_BYTES

    dest = Path(dest)
    with Download(download) as source:
        found = plan(source.paths, chosen, homework, problems=source.problems)
        for student in found.handed_in:
            for file_id, path in list(student.files.items()):
                try:
                    data = source.read(path, NOTEBOOK_BYTES if file_id.endswith(".ipynb") else MAX_FILE_BYTES)
                except (zipfile.BadZipFile, OSError, RuntimeError, EOFError):
                    data = None
                if data is None:
                    del student.files[file_id]
                    found.skip("too large to be graded or damaged in the zip", path)
                    continue
                target = dest / student.id / Path(*file_id.split("/"))
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_bytes(data)
    found.students = {k: s for k, s in found.students.items() if s.files or s.notes}
    dest.mkdir(parents=True, exist_ok=True)
    found.write_csv(dest / COLLECTED)
    return found


# -- nbgrader zip_collect: the presets as its collector plugin ----------------------------------------------
QUIET = (
    "Skipped submission with no match information provided",
    "Regular expression ",
    "Directory not found. Creating: ",
)
"""nbgrader's warnings, one per skipped file or folder made, that the summary replaces (counted there by reason;
a Moodle download of 30 hand-ins gave hundreds)."""


def quiet(record) -> bool:
    """A logging filter: False for nbgrader's per-file warnings (QUIET)."""
    return not str(record.msg).startswith(QUIET)


def zip_collect_plugin():
    """nbgrader's FileNameCollectorPlugin with the platform presets (``LmsCollector.lms``), a summary of what
    was collected in place of a warning per skipped file, and exit code 2 when nothing was.

    ``lms`` empty (the default): nbgrader's own ``named_regexp``, as before (one zip or folder per student id);
    ``moodle``, ``canvas`` or a regular expression: the preset, over the files of ``extracted/``.
    """
    from nbgrader.plugins import FileNameCollectorPlugin
    from traitlets import Unicode

    class LmsCollector(FileNameCollectorPlugin):
        lms = Unicode(
            "",
            help="The platform the downloaded archive comes from: moodle, canvas, or a regular expression naming "
            "one student's folder or file with (?P<student_id>...); empty: named_regexp.",
        ).tag(config=True)

        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.answers: dict[str, dict] | None = None
            self.log.addFilter(quiet)
            downloaded = self.folder(getattr(self.parent, "archive_directory", ""))
            extracted = self.folder(getattr(self.parent, "extracted_directory", ""))
            if downloaded and not any_file(downloaded) and not any_file(extracted):
                print(
                    f"0 submissions: {downloaded} is empty or missing: put the platform's download zip there "
                    "(or one zip or folder per student id)",
                    file=sys.stderr,
                )
                raise SystemExit(2)

        def folder(self, step: str) -> str:
            """nbgrader's folder of a collect step (archive, extracted) for this assignment, or ''."""
            app = self.parent
            if not step or not hasattr(app, "collect_directory_structure"):
                return ""
            layout = os.path.join(app.coursedir.root, app.collect_directory_structure)
            return layout.format(
                downloaded=app.downloaded_directory, assignment_id=app.coursedir.assignment_id, collect_step=step
            )

        def collect(self, submitted_file: str) -> dict | None:
            if self.answers is None:
                self.answers = self.plan_all(submitted_file)
            return self.answers.get(submitted_file)

        def plan_all(self, first: str) -> dict[str, dict]:
            """Every file of extracted/ at once: the answers, the summary printed, exit 2 when none."""
            extracted = self.folder(getattr(self.parent, "extracted_directory", "")) or os.path.dirname(first)
            homework = self.parent.coursedir.assignment_id if self.parent else ""
            paths = sorted(
                os.path.relpath(os.path.join(d, n), extracted).replace(os.sep, "/")
                for d, _, names in os.walk(extracted)
                for n in names
            )
            record = Path(extracted).parent / COLLECTED
            option = f"nbgrader zip_collect {homework} --LmsCollector.lms={{}}"
            if not self.lms:
                record.unlink(missing_ok=True)
                return self.own_regexp(extracted, paths, homework, option)
            try:
                chosen = preset(self.lms)
            except LmsError as err:
                print(f"LmsCollector.lms: {err}", file=sys.stderr)
                raise SystemExit(2) from None
            found = plan(paths, chosen, homework, self.valid_ext)
            if not found.handed_in:
                print(found.nothing(extracted, option), file=sys.stderr)
                raise SystemExit(2)
            found.write_csv(record)
            print(found.summary(extracted) + f"\n  ids, names, notes: {record}", file=sys.stderr)
            return {
                os.path.join(extracted, *split(src)): {"student_id": s, "file_id": f}
                for src, (s, f) in found.sources().items()
            }

        def own_regexp(self, extracted: str, paths: list[str], homework: str, option: str) -> dict[str, dict]:
            """``named_regexp`` on every file as nbgrader does, counted."""
            answers, skipped = {}, {}
            for path in paths:
                full = os.path.join(extracted, *split(path))
                got = FileNameCollectorPlugin.collect(self, full)
                if got:
                    answers[full] = got
                else:
                    ext_ok = os.path.splitext(full)[1] in self.valid_ext
                    skipped.setdefault("not matching named_regexp" if ext_ok else "not of valid_ext", []).append(path)
            students = {a["student_id"] for a in answers.values()}
            if not students:
                print(
                    f"0 submissions found in {extracted}: no file matched FileNameCollectorPlugin.named_regexp "
                    f"(one zip or folder per student id){hint(paths, homework, option)}",
                    file=sys.stderr,
                )
                raise SystemExit(2)
            counted = "; ".join(f"{len(p)} {why} (e.g. {p[0]})" for why, p in skipped.items())
            print(
                f"named_regexp: {len(students)} students, {len(answers)} files matched in {extracted}"
                + (f"\n  skipped {sum(map(len, skipped.values()))} files: {counted}" if skipped else ""),
                file=sys.stderr,
            )
            return answers

    return LmsCollector


def any_file(folder: str) -> bool:
    """Whether a folder holds a file anywhere below it (False when it does not exist)."""
    return any(names for _, _, names in os.walk(folder)) if folder and os.path.isdir(folder) else False
