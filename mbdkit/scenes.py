"""Grading scenes: a model file plus the analysis to run (its ``simulation`` block).

Three kinds, named by where they come from:

- ``slider_crank``            public: ``scenes/slider_crank.yaml``, shipped with the course and the kit;
- ``hidden/slider_crank_b``   hidden: a variant that never leaves the instructor (``autograder.scenes``);
- ``student/slider_crank``    per student: the public scene scaled by factors drawn from a seed the
                              instructor's secret enters (``autograder.scenes``).

Only public scenes are known here; the grader's ``autograder.scenes.load_scene`` knows all three.
"""

from __future__ import annotations

import copy
import hashlib
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from .paths import data_dir

PUBLIC, HIDDEN, STUDENT = "public", "hidden", "student"


def scenes_dir() -> Path:
    """The folder of the public scenes."""
    return data_dir() / "scenes"


@dataclass
class Scene:
    """A model file's content and where it came from."""

    name: str
    data: dict
    kind: str
    _fingerprint: str | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def simulation(self) -> dict:
        return self.data.get("simulation", {})

    @property
    def analysis(self) -> str:
        return self.simulation.get("analysis", "kinematic")

    @property
    def base(self) -> str:
        """The public scene this one belongs to (itself for a public scene)."""
        return self.name.split("/", 1)[-1]

    def fingerprint(self) -> str:
        """A hash of the scene's content: a stored reference is stale when it changes (computed once: a
        scene's data are not changed after it is loaded)."""
        if self._fingerprint is None:
            text = yaml.dump(self.data, Dumper=_DUMPER, sort_keys=True)
            self._fingerprint = hashlib.sha256(text.encode()).hexdigest()[:16]
        return self._fingerprint


_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml's parser where PyYAML has it
_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
_FILES: dict[tuple[str, int, int], dict] = {}


def read_scene_file(path: Path) -> dict:
    """The parsed content of a scene file, a fresh copy each time (each file is parsed once per process
    and content: the cache key holds its modification time and size)."""
    stat = path.stat()
    key = (str(path), stat.st_mtime_ns, stat.st_size)
    if key not in _FILES:
        _FILES[key] = yaml.load(path.read_text(), Loader=_LOADER)
    return copy.deepcopy(_FILES[key])


def scene_kind(name: str) -> str:
    if name.startswith("hidden/"):
        return HIDDEN
    if name.startswith("student/"):
        return STUDENT
    return PUBLIC


def job_key(scene: Scene) -> str:
    """The key a probe's job carries: the scene's name and content (per-student scenes share a name)."""
    return f"{scene.name}#{scene.fingerprint()}"


def load_public_scene(name: str) -> Scene:
    """A public scene by name."""
    if scene_kind(name) != PUBLIC:
        raise ValueError(f"{name}: not a public scene (hidden and per-student scenes are the grader's)")
    path = scenes_dir() / f"{name}.yaml"
    if not path.is_file():
        raise FileNotFoundError(f"no grading scene {name!r} ({path})")
    return Scene(name, read_scene_file(path), PUBLIC)


def public_scenes() -> list[str]:
    return sorted(p.stem for p in scenes_dir().glob("*.yaml"))
