"""Leak check of a release folder: what a student receives must hold nothing they should not see.

For a release of homework N, a leak is

- the text of a solution region of hwN or later: any non-trivial line of one (whitespace ignored) that
  is not also public -- a line that appears outside those regions is public anyway;
- a solution marker (``### BEGIN SOLUTION`` / ``### END SOLUTION``): a region was not cut;
- a hidden scene: derived from the course secret when one is configured (``autograder.secret``; without one
  nobody can make them), found as its YAML or JSON text (whitespace normalized, whole or embedded) or by
  its own numbers (three or more of the values that are not the public scene's, written in full); a
  hidden scene of an instructor's own folder (``$MBD_HIDDEN_SCENES``) or a file of an old course's
  ``autograder/scenes/hidden/`` or ``autograder/reference/hidden/`` (no longer in the repository, maybe
  still on the instructor's disk): found by the hash of its bytes, of its text with whitespace normalized,
  or embedded in a text file; a stored NPZ of any scene that is not public;
- a file of ``solutions/`` that holds a region of hwN or later, byte for byte, or any folder named
  ``solutions``, ``autograder`` or ``hidden``;
- an instructor-only part of ``solutions/`` (``generator.INSTRUCTOR_ONLY``: the compiled engine, the per-type
  batched forms of the joints), which writes out every formula outside any region: a folder or file at its
  place under its name (``compiled/``, ``planar/batched.py``), or a file with its text under any name;

The public scenes' expected values are meant to be there: the kit's checker compares with them.
- compiled Python (``*.pyc``, ``__pycache__``): it carries the code it was compiled from;
- the instructor's solutions of the lecture exercises (``course/lectures/solutions/``): a file of them, whole,
  renamed or embedded, or any line of one (whitespace ignored, at least ``MIN_PROSE_LINE`` long) that the
  course's public material (lecture notebooks, notes, ``solutions/``, ``assignments/``) does not hold too.

Notebooks are read as JSON: every string in them (sources, outputs, metadata) is scanned.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .generator import BEGIN, END, INSTRUCTOR_ONLY, REPO, build_source, homework_index, scan_regions, source_files

HIDDEN_SCENES = Path("autograder", "scenes", "hidden")
LECTURE_SOLUTIONS = Path("course", "lectures", "solutions")
"""The worked solutions of the lecture exercises, one Markdown file per lecture: the instructor's only."""
PUBLIC_MATERIAL = (Path("course", "lectures"), Path("course", "notes"), Path("assignments"))
"""Folders whose notebooks and Markdown students may read: a line of a lecture solution quoted from them (an
equation of the notes, say) is public."""
MIN_PROSE_LINE = 40
"""A line of a lecture solution shorter than this (whitespace removed) is not searched for: a table rule, a
heading, a short formula."""
REFERENCE_RUNS = Path("autograder", "reference", "hidden")
INSTRUCTOR_FILES = tuple(p for p in INSTRUCTOR_ONLY if p.endswith(".py"))
"""The instructor-only files, found by their path's end: ``planar/batched.py`` anywhere in a release."""
FORBIDDEN_FOLDERS = ("solutions", "autograder", "hidden", *(p for p in INSTRUCTOR_ONLY if p not in INSTRUCTOR_FILES))
MIN_LINE = 16
"""A region line shorter than this (whitespace removed) is trivial: ``return value``, ``else:``, ``q = q + dq``."""
MIN_EMBEDDED = 64
"""A grader file shorter than this (whitespace normalized) is not searched for inside other files."""


@dataclass(frozen=True)
class Leak:
    """One thing found in a release folder that must not be there."""

    path: str
    kind: str
    detail: str

    def __str__(self) -> str:
        return f"{self.path}: {self.kind}: {self.detail}"


def _squeeze(text: str) -> str:
    """A line with all whitespace removed: the form in which lines are compared."""
    return "".join(text.split())


def _normalize(text: str) -> str:
    return "\n".join(" ".join(line.split()) for line in text.splitlines() if line.strip())


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def secret_lines(homework: str, solutions: Path) -> dict[str, str]:
    """{squeezed line: 'file:line (function)'} of every non-trivial line of a region of hwN or later
    that appears nowhere, not even inside a longer line, in the public part of the reference (the student
    package of hwN)."""
    first = homework_index(homework)
    secret, public = {}, set()
    for rel in source_files(solutions):
        if rel.suffix != ".py":
            continue
        text = (solutions / rel).read_text(encoding="utf-8")
        built, _, _ = build_source(text, rel.as_posix(), homework)
        public.update(_squeeze(line) for line in built.splitlines())
        for region in scan_regions(text, rel.as_posix()):
            if region.homework < first:
                continue
            for offset, line in enumerate(region.text, start=region.begin + 1):
                squeezed = _squeeze(line)
                if len(squeezed) >= MIN_LINE:
                    secret.setdefault(squeezed, f"solutions/{rel.as_posix()}:{offset} ({region.function})")
    public_text = "\n".join(public)
    return {line: where for line, where in secret.items() if line not in public_text}


def _grader_files(course: Path) -> list[Path]:
    """Hidden data on the instructor's disk: an own hidden folder, an old course's hidden folders."""
    from autograder.scenes import hidden_override

    files = []
    for root in (course / HIDDEN_SCENES, course / REFERENCE_RUNS, hidden_override()):
        if root is not None and root.is_dir():
            files += sorted(p for p in root.rglob("*") if p.is_file())
    return files


def lecture_solution_files(course: Path) -> list[Path]:
    """The Markdown files of ``course/lectures/solutions/`` (none when the folder is not there)."""
    folder = course / LECTURE_SOLUTIONS
    return sorted(folder.glob("*.md")) if folder.is_dir() else []


def _public_text(course: Path) -> str:
    """The squeezed text students may read anyway: every cell of the lecture and notes notebooks and the
    assignments, their Markdown files, and every source file of ``solutions/`` (docstrings and comments)."""
    texts = []
    for folder in PUBLIC_MATERIAL:
        for path in sorted((course / folder).rglob("*")) if (course / folder).is_dir() else []:
            if LECTURE_SOLUTIONS.as_posix() in path.as_posix() or ".ipynb_checkpoints" in path.parts:
                continue
            if path.suffix == ".ipynb":
                cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
                texts += ["".join(cell["source"]) for cell in cells]
            elif path.suffix == ".md":
                texts.append(path.read_text(encoding="utf-8"))
    solutions = course / "solutions"
    if solutions.is_dir():
        texts += [
            (solutions / rel).read_text(encoding="utf-8") for rel in source_files(solutions) if rel.suffix == ".py"
        ]
    return "\n".join(_squeeze(line) for text in texts for line in text.splitlines())


def lecture_solution_lines(course: Path) -> dict[str, str]:
    """{squeezed line: 'course/lectures/solutions/LNN.md:line'} of every line of the lecture solutions at least
    MIN_PROSE_LINE long that appears nowhere, not even inside a longer line, in the public material."""
    found = {}
    for path in lecture_solution_files(course):
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            squeezed = _squeeze(line)
            if len(squeezed) >= MIN_PROSE_LINE:
                found.setdefault(squeezed, f"{path.relative_to(course).as_posix()}:{number}")
    if not found:
        return {}
    public = _public_text(course)
    return {line: where for line, where in found.items() if line not in public}


MIN_NUMBERS = 3
"""A file holding this many of a hidden scene's own numbers (full precision) holds the hidden scene."""


def _floats(value) -> set[float]:
    if isinstance(value, float):
        return {value}
    if isinstance(value, dict):
        return {x for v in value.values() for x in _floats(v)}
    if isinstance(value, list):
        return {x for v in value for x in _floats(v)}
    return set()


def derived_hidden_scenes() -> dict[str, tuple[list[str], set[str]]]:
    """{hidden scene: (its texts as YAML and JSON, its own numbers as written in full)} of every hidden scene
    of every homework, derived with the course secret; {} when no secret is configured (or the scenes come
    from ``$MBD_HIDDEN_SCENES``, whose files are checked as they are)."""
    import yaml

    from autograder.scenes import hidden_base, hidden_override, load_scene
    from autograder.secret import SecretMissing, course_secret
    from mbdkit.homework import available_homeworks, load_homework

    try:
        course_secret()
    except SecretMissing:
        return {}
    if hidden_override() is not None:
        return {}
    names = {c.scene for hw in available_homeworks() for c in load_homework(hw).checks if c.scene.startswith("hidden/")}
    found = {}
    for name in sorted(names):
        data = load_scene(name).data
        public = _floats(load_scene(hidden_base(name)).data)
        texts = [
            yaml.safe_dump(data, sort_keys=False),
            yaml.safe_dump(data, sort_keys=False, default_flow_style=None),
            json.dumps(data),
            json.dumps(data, indent=1),
        ]
        numbers = {repr(x) for x in _floats(data) - public if len(repr(x)) >= 8}
        found[name] = (texts, numbers)
    return found


def _strings(value) -> list[str]:
    """Every string inside a JSON value."""
    if isinstance(value, str):
        return [value]
    if isinstance(value, dict):
        return [s for k, v in value.items() for s in (*_strings(k), *_strings(v))]
    if isinstance(value, list):
        return [s for item in value for s in _strings(item)]
    return []


def _text_of(path: Path, data: bytes) -> str | None:
    """The scannable text of a release file, or None for a binary file."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return None
    if path.suffix == ".ipynb":
        try:
            return "\n".join(_strings(json.loads(text)))
        except json.JSONDecodeError:
            return text
    return text


def _stored_scene(path: Path) -> str | None:
    """The scene a stored reference NPZ belongs to (its meta record), or None for any other file."""
    try:
        with np.load(path, allow_pickle=False) as data:
            return str(json.loads(str(data["meta"])).get("scene", "")) if "meta" in data.files else None
    except (OSError, ValueError, KeyError):
        return None


def _source_of(compiled: Path) -> Path:
    """The .py file a ``__pycache__/NAME.cpython-311.pyc`` was compiled from."""
    return compiled.parent.parent / f"{compiled.name.split('.', 1)[0]}.py"


def _instructor_only_files(solutions: Path) -> list[Path]:
    """The .py files of the ``INSTRUCTOR_ONLY`` folders and files of ``solutions/``."""
    files = []
    for part in INSTRUCTOR_ONLY:
        place = solutions / part
        if place.is_dir():
            files += sorted(place.rglob("*.py"))
        elif place.is_file():
            files.append(place)
    return files


def find_leaks(folder: Path, homework: str, course: Path | None = None, installed: bool = False) -> list[Leak]:
    """Every leak in the release folder of ``homework``; [] when it is clean.

    ``course`` is the repository root holding ``solutions/`` and ``autograder/`` (this course by default).
    ``installed``: the folder is what pip installed (site-packages), where pip compiles every module: a
    compiled file is a leak there only without its source beside it (the source is what is scanned).
    """
    folder, course = Path(folder), Path(course or REPO)
    solutions = course / "solutions"
    secret = secret_lines(homework, solutions)
    first = homework_index(homework)

    forbidden_hashes = {}  # sha256 -> what it is
    embedded = {}  # normalized text -> what it is
    for path in _grader_files(course):
        data = path.read_bytes()
        what = f"grader data {path.relative_to(course).as_posix()}"
        forbidden_hashes[_sha(data)] = what
        text = _text_of(path, data)
        if text is not None:
            normalized = _normalize(text)
            forbidden_hashes[_sha(normalized.encode())] = what
            if len(normalized) >= MIN_EMBEDDED:
                embedded[normalized] = what
    derived = derived_hidden_scenes()
    for name, (texts, _) in derived.items():
        for text in texts:
            normalized = _normalize(text)
            forbidden_hashes[_sha(normalized.encode())] = f"the hidden scene {name}"
            embedded[normalized] = f"the hidden scene {name}"
    for rel in source_files(solutions):
        if rel.suffix == ".py":
            text = (solutions / rel).read_text(encoding="utf-8")
            if any(r.homework >= first for r in scan_regions(text, rel.as_posix())):
                forbidden_hashes[_sha(text.encode())] = f"reference file solutions/{rel.as_posix()}"
    for path in lecture_solution_files(course):  # the instructor's worked answers of the lecture exercises
        text = path.read_text(encoding="utf-8")
        what = f"lecture solutions {path.relative_to(course).as_posix()}"
        forbidden_hashes[_sha(text.encode())] = forbidden_hashes[_sha(_normalize(text).encode())] = what
        if len(_normalize(text)) >= MIN_EMBEDDED:
            embedded[_normalize(text)] = what
    answers = lecture_solution_lines(course)
    for path in _instructor_only_files(solutions):  # every formula students write, outside any region
        text = path.read_text(encoding="utf-8")
        what = f"instructor-only file solutions/{path.relative_to(solutions).as_posix()}"
        forbidden_hashes[_sha(text.encode())] = forbidden_hashes[_sha(_normalize(text).encode())] = what

    leaks = []
    for current, dirs, names in os.walk(folder):
        here = Path(current)
        for name in sorted(dirs):
            rel = (here / name).relative_to(folder).as_posix()
            if name in FORBIDDEN_FOLDERS:
                leaks.append(Leak(rel, "forbidden folder", f"a folder named {name!r} does not belong in a release"))
            if name == "__pycache__" and not installed:
                leaks.append(Leak(rel, "compiled code", "__pycache__ carries the code it was compiled from"))
        for name in sorted(names):
            path = here / name
            rel = path.relative_to(folder).as_posix()
            data = path.read_bytes()
            if any(rel == part or rel.endswith(f"/{part}") for part in INSTRUCTOR_FILES):
                leaks.append(Leak(rel, "instructor-only file", "the course's own, never in a student package"))
            if path.suffix in (".pyc", ".pyo") and not (installed and _source_of(path).is_file()):
                leaks.append(Leak(rel, "compiled code", "compiled Python carries the code it was compiled from"))
            if path.suffix == ".npz" and _stored_scene(path) is not None and "/" in _stored_scene(path):
                leaks.append(Leak(rel, "grader data", f"stored values of the scene {_stored_scene(path)}"))
            if _sha(data) in forbidden_hashes:
                leaks.append(Leak(rel, "copied file", f"identical to {forbidden_hashes[_sha(data)]}"))
                continue
            text = _text_of(path, data)
            if text is None:
                continue
            normalized = _normalize(text)
            if _sha(normalized.encode()) in forbidden_hashes:
                leaks.append(Leak(rel, "copied file", f"same text as {forbidden_hashes[_sha(normalized.encode())]}"))
                continue
            for content, what in embedded.items():
                if content in normalized:
                    leaks.append(Leak(rel, "embedded file", f"contains the whole of {what}"))
            for name, (_, numbers) in derived.items():
                held = sorted(number for number in numbers if number in text)
                if len(held) >= min(MIN_NUMBERS, len(numbers)) and held:
                    leaks.append(Leak(rel, "hidden values", f"{len(held)} numbers of the hidden scene {name}"))
            for number, line in enumerate(text.splitlines(), start=1):
                if BEGIN in line or END in line:
                    leaks.append(Leak(f"{rel}:{number}", "solution marker", line.strip()))
            squeezed_text = _squeeze(text)
            found = {}  # one leak per region function, naming its first leaked line
            for line, where in secret.items():
                if line in squeezed_text:
                    found.setdefault((where.split(":")[0], where.rsplit(" ", 1)[1]), []).append(where)
            for wheres in found.values():
                more = f" and {len(wheres) - 1} more of its lines" if len(wheres) > 1 else ""
                leaks.append(Leak(rel, "solution text", f"line {wheres[0]}{more}"))
            quoted = {}  # one leak per lecture-solution file, naming its first quoted line
            for line, where in answers.items():
                if line in squeezed_text:
                    quoted.setdefault(where.split(":")[0], []).append(where)
            for wheres in quoted.values():
                more = f" and {len(wheres) - 1} more of its lines" if len(wheres) > 1 else ""
                leaks.append(Leak(rel, "lecture solution", f"line {wheres[0]}{more}"))
    return leaks
