"""Grading scenes: a model file plus the analysis to run (its ``simulation`` block).

Three kinds, named by where they come from:

- ``slider_crank``            public: ``scenes/slider_crank.yaml``, shipped with the course and the kit;
- ``hidden/slider_crank_b``   hidden: a variant that never leaves the instructor (``autograder.scenes``);
- ``student/slider_crank``    per student: the public scene scaled by factors drawn from a seed the
                              instructor's secret enters (``autograder.scenes``).

Only public scenes are known here; the grader's ``autograder.scenes.load_scene`` knows all three.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
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
        """A hash of the scene's content: a stored reference is stale when it changes."""
        return hashlib.sha256(yaml.safe_dump(self.data, sort_keys=True).encode()).hexdigest()[:16]


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
    return Scene(name, yaml.safe_load(path.read_text()), PUBLIC)


def public_scenes() -> list[str]:
    return sorted(p.stem for p in scenes_dir().glob("*.yaml"))
