"""A homework's checks and points, read from ``hwN.toml`` (``autograder/`` in the course, ``mbdkit/data/`` in a kit).

Each ``[[check]]`` table names a scene (or a list ``scenes``, one check each), a probe (what the
student's package is asked to compute, see ``probes``), the outputs compared, the points and the group
a notebook cell checks (``api.check("hw1", "revolute")``). Optional keys: ``rows`` (compare only the
constraint rows of these joint types), ``options`` (of the probe, e.g. the integrator), ``timeout``
(wall-clock seconds), ``rtol``/``atol``, ``name`` and ``description``.
"""

from __future__ import annotations

import hashlib
import json
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from .paths import data_dir
from .probes import AXES
from .scenes import PUBLIC, scene_kind

DEFAULT_TIMEOUT = {"function": 10.0, "run": 60.0}


@dataclass(frozen=True)
class CheckSpec:
    """One check: a probe on a scene, which outputs to compare, and its points."""

    name: str
    scene: str
    probe: str
    outputs: tuple[str, ...]
    points: float
    group: str
    rows: tuple[str, ...] = ()
    options: dict = field(default_factory=dict, hash=False, compare=False)
    timeout: float = 10.0
    rtol: float | None = None
    atol: float | None = None
    description: str = ""

    @property
    def kind(self) -> str:
        """public, hidden or student: whose numbers the check uses."""
        return scene_kind(self.scene)

    @property
    def probe_key(self) -> str:
        """The probe with its options: the key of its reference outputs."""
        return probe_key(self.probe, self.options)

    @property
    def visibility(self) -> str:
        """Gradescope's visibility: hidden checks show after the grades are published."""
        return "visible" if self.kind != "hidden" else "after_published"


def probe_outputs(probe: str) -> list[str]:
    """Every output of a probe, from its registered axes."""
    return [key.split(".", 1)[1] for key in AXES if key.split(".", 1)[0] == probe]


def probe_key(probe: str, options: dict) -> str:
    if not options:
        return probe
    digest = hashlib.sha256(json.dumps(options, sort_keys=True).encode()).hexdigest()[:8]
    return f"{probe}-{digest}"


@dataclass
class Homework:
    """A homework: its name, title and checks (in the order of the file)."""

    name: str
    title: str
    checks: list[CheckSpec]
    source: Path | None = None
    instructor_groups: tuple[str, ...] = ()
    budget: float | None = None
    """Wall-clock seconds the grader gives all the checks of one submission (``budget`` in the file)."""
    to_write: tuple[tuple[str, str], ...] = ()
    """The (file of the package, function) pairs students write, in the course's order (``to_write`` in a kit's
    file: ``mbd todo``); empty in the course's own files."""
    """Groups graded only by the instructor (hidden scenes, the student's own variants), named in a kit's
    file, which holds the public checks only."""
    total: float | None = None
    """The points of all the homework's checks where the file holds only some (``total`` in a kit's file: the
    self-check says the homework's scale, not the public checks' points alone)."""

    @property
    def max_score(self) -> float:
        return sum(c.points for c in self.checks)

    @property
    def out_of(self) -> float:
        """The homework's total as it is graded (``total``, else the points of its checks)."""
        return self.total if self.total is not None else self.max_score

    def public(self) -> list[CheckSpec]:
        """The checks a student can run before submitting (public scenes only)."""
        return [c for c in self.checks if c.kind == PUBLIC]

    def groups(self) -> list[str]:
        return list(dict.fromkeys([*(c.group for c in self.checks), *self.instructor_groups]))

    def graded_later(self, group: str) -> bool:
        """True for a group with no public check: it runs only when the instructor grades."""
        return group in self.groups() and not any(c.group == group for c in self.public())

    def select(self, names: list[str] | None = None) -> Homework:
        """The homework restricted to some checks (by name), e.g. a quick subset in tests."""
        if names is None:
            return self
        unknown = sorted(set(names) - {c.name for c in self.checks})
        if unknown:
            raise KeyError(f"{self.name}: no checks named {', '.join(unknown)}")
        selected = [c for c in self.checks if c.name in names]
        return Homework(self.name, self.title, selected, self.source, self.instructor_groups, self.budget)

    def fingerprint(self) -> str:
        text = json.dumps([self.budget, *(c.__dict__ for c in self.checks)], sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def homework_file(homework: str) -> Path:
    return data_dir() / f"{homework}.toml"


def available_homeworks() -> list[str]:
    return sorted(p.stem for p in data_dir().glob("hw*.toml"))


def _checks(entry: dict, source: str) -> list[CheckSpec]:
    scenes = entry.get("scenes") or [entry.get("scene")]
    if not scenes or scenes[0] is None:
        raise ValueError(f"{source}: a [[check]] needs 'scene' or 'scenes'")
    probe = entry["probe"]
    outputs = entry.get("outputs") or ([entry["output"]] if "output" in entry else probe_outputs(probe))
    rows = tuple(entry.get("rows", ()))
    kind = "run" if probe.endswith("_run") else "function"
    checks = []
    label = entry.get("label") or probe
    if "label" not in entry:
        if kind == "run" and len(outputs) == 1:
            label = f"{label}.{outputs[0]}"
        if rows:
            label = f"{label}.{'+'.join(rows)}"
    for scene in scenes:
        name = entry["name"] if "name" in entry and len(scenes) == 1 else f"{scene}.{label}"
        checks.append(
            CheckSpec(
                name=name,
                scene=scene,
                probe=probe,
                outputs=tuple(outputs),
                points=float(entry.get("points", 1.0)),
                group=entry.get("group", probe),
                rows=rows,
                options=dict(entry.get("options", {})),
                timeout=float(entry.get("timeout", DEFAULT_TIMEOUT[kind])),
                rtol=entry.get("rtol"),
                atol=entry.get("atol"),
                description=entry.get("description", ""),
            )
        )
    return checks


def load_homework(homework: str | Path) -> Homework:
    """Read ``<homework>.toml`` from the data folder (or a .toml file given by path)."""
    path = Path(homework) if str(homework).endswith(".toml") else homework_file(str(homework))
    if not path.is_file():
        known = ", ".join(available_homeworks()) or "none"
        raise FileNotFoundError(f"no checks for homework {homework!r} (known: {known})")
    data = tomllib.loads(path.read_text())
    checks = [c for entry in data.get("check", []) for c in _checks(entry, path.name)]
    names = [c.name for c in checks]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ValueError(f"{path.name}: check names used twice: {', '.join(duplicates)}")
    groups = tuple(data.get("instructor_groups", ()))
    budget = float(data["budget"]) if "budget" in data else None
    to_write = tuple((str(file), str(function)) for file, function in data.get("to_write", ()))
    total = float(data["total"]) if "total" in data else None
    return Homework(
        data.get("homework", path.stem), data.get("title", ""), checks, path, groups, budget, to_write, total
    )
