"""Nothing hidden in the repository (issue 23): a course secret kept outside it, hidden scenes derived from the
public ones and that secret at grading time, their references computed and cached outside the repository.

The test session's secret is set in ``tests/conftest.py`` (``pytest_configure``); tests that need none, or
another one, change ``$MBD_GRADER_SECRET`` with ``monkeypatch``.
"""

from __future__ import annotations

import json
import shutil
import stat
import subprocess
from pathlib import Path

import numpy as np
import pytest

from autograder import grading, reference, scenes, secret
from autograder.scenes import hidden_base, hidden_seed, hidden_variant, load_scene
from mbdkit.homework import available_homeworks, load_homework
from mbdkit.probes import PROBES, Job
from mbdkit.scenes import job_key

REPO = Path(__file__).resolve().parents[2]
HIDDEN = sorted({c.scene for hw in available_homeworks() for c in load_homework(hw).checks if c.kind == "hidden"})
SECRETS = [f"course-secret-{i}" for i in range(10)]


def _tracked() -> list[str]:
    if shutil.which("git") is None or not (REPO / ".git").exists():
        pytest.skip("not a git checkout")
    out = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True, check=True).stdout
    return [name for name in out.decode().split("\0") if name]


def test_git_tracks_no_hidden_scene_reference_or_secret():
    files = _tracked()
    assert "autograder/scenes/four_bar.yaml" in files and "autograder/reference/public/four_bar.npz" in files
    assert [f for f in files if "hidden" in Path(f).parts] == []
    secrets_named = [f for f in files if "secret" in Path(f).name.lower() and Path(f).suffix != ".py"]
    assert secrets_named == []
    stored = []
    for name in (f for f in files if f.endswith(".npz")):
        with np.load(REPO / name, allow_pickle=False) as data:
            if "meta" in data.files:
                stored.append(json.loads(str(data["meta"]))["scene"])
    assert stored and all("/" not in scene for scene in stored), "a stored reference of a hidden or per-student scene"


@pytest.fixture
def no_secret(monkeypatch, tmp_path):
    """No ``$MBD_GRADER_SECRET`` and an empty configuration folder."""
    monkeypatch.delenv(secret.ENV, raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    return tmp_path


def _class(root: Path) -> Path:
    """A class of one: the reference package as a student's (grading never gets as far as running it)."""
    (root / "submitted" / "alice" / "modules").mkdir(parents=True)
    return root / "submitted"


def test_mbd_grade_without_a_secret_refuses_in_one_line(no_secret, capsys):
    from solutions.cli import main

    submitted, out = _class(no_secret), no_secret / "grades"
    assert main(["grade", "hw1", str(submitted), "--out", str(out), "--jobs", "1"]) == 2
    said = capsys.readouterr()
    lines = said.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mbd: error: no course secret"), said.err
    assert "mbd secret --init" in lines[0] and secret.ENV in lines[0] and said.out == ""
    assert not out.exists()


def test_the_api_and_nbgraders_route_refuse_without_a_secret(no_secret, monkeypatch):
    submitted, out = _class(no_secret), no_secret / "grades"
    with pytest.raises(secret.SecretMissing, match="mbd secret --init"):
        grading.grade("hw1", submitted, out, jobs=1, progress=False)
    assert not out.exists()
    from autograder.api import grade_folder  # what nbgrader's autograde step (GraderPoints) runs

    with pytest.raises(secret.SecretMissing, match="no course secret"):
        grade_folder(submitted / "alice", "alice", {("hw1", "hidden")})
    with pytest.raises(secret.SecretMissing):
        load_scene("student/four_bar", student="alice", homework="hw1")
    monkeypatch.setenv(secret.ENV, " ")
    with pytest.raises(secret.SecretMissing, match="is empty"):
        load_scene(HIDDEN[0])


def test_mbd_secret_init_writes_a_private_secret_once(no_secret, capsys, monkeypatch):
    from solutions.cli import main

    assert main(["secret"]) == 2
    assert capsys.readouterr().err.startswith("mbd: error: no course secret")
    assert main(["secret", "--init"]) == 0
    said = capsys.readouterr().out
    path = no_secret / "config" / "mbd-course" / "secret"
    assert str(path) in said and "back it up" in said
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    first = path.read_text().strip()
    assert len(first) == 64 and int(first, 16) >= 0
    assert main(["secret", "--init"]) == 0 and "already there" in capsys.readouterr().out
    assert path.read_text().strip() == first == secret.course_secret()
    monkeypatch.setenv(secret.ENV, "from-the-environment")
    assert secret.course_secret() == "from-the-environment"


def test_hidden_scenes_are_deterministic_for_one_secret_and_differ_between_two(monkeypatch):
    assert len(HIDDEN) >= 10
    prints = {}
    for value in SECRETS[:2]:
        monkeypatch.setenv(secret.ENV, value)
        for name in HIDDEN:
            scene = load_scene(name)  # made once, then read from the cache: the same as made anew
            assert (
                scene.data
                == load_scene(name).data
                == hidden_variant(load_scene(hidden_base(name)).data, hidden_seed(name), name)
            )
            assert scene.fingerprint() != load_scene(hidden_base(name)).fingerprint()
            prints[value, name] = scene.fingerprint()
    for name in HIDDEN:
        assert prints[SECRETS[0], name] != prints[SECRETS[1], name]


def _masses(data: dict) -> list[float]:
    return [b["mass"] for b in data["model"]["bodies"]]


def test_hidden_scenes_vary_masses_laws_and_initial_state(monkeypatch):
    """Each body's mass on its own (not one common factor), every driver law, and (dynamic scenes) the
    initial velocities, as the hand-written hidden scenes did."""
    monkeypatch.setenv(secret.ENV, SECRETS[0])
    for name in HIDDEN:
        hidden, public = load_scene(name).data, load_scene(hidden_base(name)).data
        ratios = np.array(_masses(hidden)) / np.array(_masses(public))
        assert np.ptp(ratios) > 1e-3, f"{name}: masses scaled by one factor"
        laws = [m["function"] for m in hidden["model"].get("motors", [])]
        assert all(a != b["function"] for a, b in zip(laws, public["model"].get("motors", []), strict=True)), name
        if hidden["simulation"]["analysis"] == "dynamic":
            spins = [b.get("angular_velocity") for b in hidden["model"]["bodies"]]
            before = [b.get("angular_velocity") for b in public["model"]["bodies"]]
            assert spins != before, f"{name}: the same initial state"


def _run(scene) -> dict:
    """The scene's own analysis with the reference package (dynamic: at the scene's own settings)."""
    data = scene.data
    job = Job(job_key(scene), data)
    analysis = data["simulation"]["analysis"]
    if analysis == "dynamic":  # looser than the scene's own 1e-8: cheaper, and a singular position still shows
        job.options = {"engine": "numpy", "rtol": 1e-6, "atol": 1e-8}
    return PROBES[f"{analysis}_run"](reference.REFERENCE, job)


def test_hidden_scenes_assemble_and_run_for_many_secrets(monkeypatch):
    """Every hidden scene for every one of many secrets: its file's configuration is assembled (the drivers'
    values at t = 0 kept), and its own analysis runs through without a singular position (kinematic scenes:
    the run stops with an AnalysisError at one), with finite results and the constraints held."""
    from solutions.assembly import build_system
    from solutions.io.model import load_model

    for value in SECRETS:
        monkeypatch.setenv(secret.ENV, value)
        for name in HIDDEN:
            scene = load_scene(name)
            data = scene.data
            system, q0, qd0 = build_system(load_model(data))
            assert np.max(np.abs(system.constraints(q0, 0.0))) < 1e-6, f"{name} ({value}): not assembled"
            if data["simulation"]["analysis"] == "dynamic":
                velocity = system.jacobian(q0, 0.0) @ qd0 + system.psi_t(q0, 0.0)
                assert np.max(np.abs(velocity)) < 1e-6, f"{name} ({value}): inconsistent initial velocities"
            run = _run(scene)
            assert np.all(np.isfinite(run["q"])) and run["t"][-1] == pytest.approx(data["simulation"]["end_time"])
            residual = max(np.max(np.abs(system.constraints(q, t))) for t, q in zip(run["t"], run["q"], strict=True))
            assert residual < 1e-5, f"{name} ({value}): constraints off by {residual:.2g}"


def test_a_hidden_slider_is_not_thrown_at_its_springs_anchor(monkeypatch):
    """A secret whose hidden revolute-prismatic scene once started the slider at 10 m/s along the arm: the null
    space direction was nearly all sliding, and its spin (0.04 rad/s) was scaled up to HIDDEN_SPIN. The slider
    reached the hinge, where its spring's two points coincide, and the reference run (the grader's tight settings)
    stopped with "length 0", so no class could be graded with that secret. A change of speed now counts as a
    spin of speed / the mechanism's size: the slider keeps well away from the hinge."""
    monkeypatch.setenv(secret.ENV, "ab" * 32)
    scene = load_scene("hidden/revolute_prismatic_b")
    slider = next(b for b in scene.data["model"]["bodies"] if b["name"] == "slider")
    start = np.linalg.norm(slider["location"])
    assert np.linalg.norm(slider["velocity"]) <= max(scenes.HIDDEN_SPIN) * scenes._reach(scene.data)
    run = reference.base_run(scene)
    assert np.min(np.linalg.norm(run["q"][:, 7:10], axis=1)) > 0.5 * start


def test_hidden_references_are_computed_once_and_cached_outside_the_repository(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    name = "hidden/slider_crank_b"
    first = reference.hidden_reference(name, "hw1")
    files = list((tmp_path / "cache" / "mbd-course" / "references").glob("*.npz"))
    assert len(files) == 1 and not files[0].is_relative_to(REPO)
    assert any("/replay:" in key for key in first.arrays), "the known mistakes are replayed, as stored ones are"
    assert first.meta["fingerprint"] == load_scene(name).fingerprint()
    mtime = files[0].stat().st_mtime_ns
    again = reference.hidden_reference(name, "hw1")
    assert files[0].stat().st_mtime_ns == mtime and again.arrays.keys() == first.arrays.keys()
    assert all(np.array_equal(again.arrays[k], first.arrays[k], equal_nan=True) for k in first.arrays)
    monkeypatch.setenv(secret.ENV, SECRETS[3])  # another secret: another scene, another entry
    other = reference.hidden_reference(name, "hw1")
    assert len(list(files[0].parent.glob("*.npz"))) == 2
    assert not np.allclose(other.arrays["inputs/q"], first.arrays["inputs/q"])
    monkeypatch.setattr(scenes, "_SOURCE", {"solutions": "changed", "autograder": "same"})  # solutions/ changed
    reference.hidden_reference(name, "hw1")
    assert len(list(files[0].parent.glob("*.npz"))) == 3


def test_python_m_autograder_reference_covers_the_public_scenes_only():
    specs = reference.all_specs()
    assert specs and all("/" not in scene for scene in specs)
    with pytest.raises(ValueError, match="computed when grading"):
        reference.reference_file(HIDDEN[0])


def _link_lengths(data: dict) -> list[float]:
    """Ground, crank, coupler, rocker of the four-bar (from its joints' locations in the file)."""
    at = {j["name"]: np.array(j["location"]) for j in data["model"]["joints"]}
    pairs = (("O2", "O4"), ("O2", "A"), ("A", "B"), ("B", "O4"))
    return [float(np.linalg.norm(at[a] - at[b])) for a, b in pairs]


def test_a_hidden_four_bar_has_its_own_proportions_and_stays_a_grashof_crank_rocker(monkeypatch):
    public = np.array(_link_lengths(load_scene("four_bar").data))
    shapes = []
    for value in SECRETS:
        monkeypatch.setenv(secret.ENV, value)
        links = np.array(_link_lengths(load_scene("hidden/four_bar_b").data))
        ground, crank, coupler, rocker = links
        assert crank == min(links) and crank + max(links) < sum(links) - crank - max(links), f"{value}: not Grashof"
        shapes.append(links / links[0] / (public / public[0]))
    assert sum(np.ptp(shape) > 0.02 for shape in shapes) >= len(SECRETS) // 2, "proportions mostly unchanged"
