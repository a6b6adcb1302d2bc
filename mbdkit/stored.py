"""Stored expected values: what the reference package computed for every check of a scene.

One compact NPZ per scene, made by the instructor's ``python -m autograder.reference``:

- ``inputs/NAME``        the states the function checks use (and the reference's own arrays that some
                         function checks take as inputs);
- ``KEY/OUTPUT``         the expected output of a probe (``KEY`` is the probe with its options);
- ``KEY/tol:OUTPUT``     a tolerance derived from the integrator's own accuracy; ``KEY/bound:QUANTITY`` a
                         bound of an invariant (drift, energy);
- ``KEY/replay:N:OUTPUT`` the output the reference gives when it makes known mistake N (its text is
                         ``meta["probes"][KEY]["causes"][N]``): a student's numbers that match it name the
                         likely cause without running any reference code;
- ``meta``               a JSON record: labels of coordinates and constraint rows, the kind of joint that
                         owns each row, the probes and their options.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .paths import data_dir


def public_reference_file(scene: str) -> Path:
    """The stored expected values of a public scene."""
    return data_dir() / "reference" / "public" / f"{scene}.npz"


@dataclass
class Reference:
    """The stored (or freshly made) expected values of one scene."""

    scene: str
    meta: dict
    arrays: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def inputs(self) -> dict[str, np.ndarray]:
        return {k.split("/", 1)[1]: v for k, v in self.arrays.items() if k.startswith("inputs/")}

    def outputs(self, key: str) -> dict[str, np.ndarray]:
        prefix = f"{key}/"
        return {k[len(prefix) :]: v for k, v in self.arrays.items() if k.startswith(prefix) and ":" not in k}

    def extra(self, key: str, name: str) -> np.ndarray | None:
        """A stored tolerance ('tol:q') or bound ('bound:energy') of a probe key."""
        return self.arrays.get(f"{key}/{name}")

    def replays(self, key: str, output: str) -> list[tuple[str, np.ndarray]]:
        """(cause, output) of every stored known mistake of a probe key that changes ``output``."""
        causes = self.meta.get("probes", {}).get(key, {}).get("causes", [])
        found = []
        for number, cause in enumerate(causes):
            array = self.arrays.get(f"{key}/replay:{number}:{output}")
            if array is not None:
                found.append((cause, array))
        return found

    def has(self, key: str) -> bool:
        return key in self.meta.get("probes", {})

    def restricted(self, keys: set[str]) -> Reference:
        """The same reference with only some probe keys (what a homework's kit needs)."""
        meta = dict(self.meta, probes={k: v for k, v in self.meta.get("probes", {}).items() if k in keys})
        arrays = {k: v for k, v in self.arrays.items() if k.startswith("inputs/") or k.split("/", 1)[0] in keys}
        return Reference(self.scene, meta, arrays)


def save_reference(reference: Reference, path: Path) -> Path:
    """Write a reference as one compressed NPZ (atomically)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = dict(reference.arrays)
    arrays["meta"] = np.array(json.dumps(reference.meta, sort_keys=True))
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, **arrays)
    tmp.replace(path)  # the kit's own atomic write: mbdkit imports nothing of solutions (solutions.batch)
    return path


def load_reference(scene: str, path: Path | None = None) -> Reference:
    """The stored reference of a scene (a public one by default)."""
    path = Path(path or public_reference_file(scene))
    if not path.is_file():
        raise FileNotFoundError(
            f"no stored expected values for scene {scene!r} ({path}); the instructor makes them with "
            "python -m autograder.reference"
        )
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays.pop("meta")))
    return Reference(scene, meta, arrays)
