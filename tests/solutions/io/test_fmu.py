"""The FMU of a model (solutions/io/fmu.py) run by fmpy, an FMU simulator that is not ours (issue 28).

fmpy runs the FMUs in a fresh Python that has not imported mbd-course (as a tool that imports FMUs would): it
validates their modelDescription.xml, simulates them over a span at the file's output interval, with the file's
parameters and with one changed, and tells which ``solutions`` and ``fastjsonschema`` the slave imported. Each
run is compared, column by column, with ``mbd run --out FILE.csv`` of the same file (or of the file edited as the
parameter was) at the same tolerances. The FMUs are built once for the module.
"""

from __future__ import annotations

import importlib.util
import json
import os
import platform
import shutil
import subprocess
import sys
import sysconfig
import textwrap
import zipfile
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest
import yaml

from solutions import cli
from solutions.io.fmu import FmuError, export_fmu, fmi_name, main, model_parameters, requirements, with_parameters
from solutions.io.results import read_csv

MODELS = Path(__file__).resolve().parents[3] / "course" / "models"
HOST = Path(__file__).with_name("fmi3_host.c")
HEAVIER = 1.5
"""The upper rod's mass in the parameter study (the file's: 1.0 kg)."""
STIFFER = 80.0
"""The four-bar spring's stiffness in the parameter study (the file's: 50 N/m)."""
LOOP_SPAN = 0.5
"""The closed loop's span here (s): a quarter of the file's, at the file's output interval."""
FASTER = 15.0
"""The slider-crank's crank speed in the parameter study, rad/s (the file's drive: phi = 10 t)."""
TURN = 0.6283185307179586
"""The slider-crank file's span: one crank turn at 10 rad/s, 200 output steps."""

FMPY = textwrap.dedent(
    """
    import json, sys
    import numpy as np
    from fmpy import extract, read_model_description, simulate_fmu
    from fmpy.validation import validate_fmu

    runs, folder = json.loads(sys.argv[1]), sys.argv[2]
    report = {"problems": {}, "starts": {}, "unzipdir": {}}
    for name, (fmu, stop, interval, start_values) in runs.items():
        if fmu not in report["unzipdir"]:
            report["problems"][fmu] = validate_fmu(fmu)
            report["unzipdir"][fmu] = str(extract(fmu))
            variables = read_model_description(fmu).modelVariables
            report["starts"][fmu] = {v.name: float(v.start) for v in variables if v.causality == "parameter"}
        result = simulate_fmu(report["unzipdir"][fmu], stop_time=stop, output_interval=interval,
                              start_values=start_values)
        np.save(f"{folder}/{name}.npy", result)
    report["modules"] = {name: sys.modules[name].__file__ for name in ("solutions", "fastjsonschema")}
    print(json.dumps(report))
    """
)


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fmu")


@pytest.fixture(scope="module")
def fmus(folder) -> dict[str, Path]:
    """The FMUs of the double pendulum (a chain), of the spring-loaded four-bar (a closed loop) and of the
    slider-crank (a closed loop driven by its motor: a kinematic analysis)."""
    names = ("double_pendulum", "four_bar_spring", "slider_crank")
    return {name: export_fmu(MODELS / f"{name}.yaml", folder / f"{name}.fmu") for name in names}


@pytest.fixture(scope="module")
def fmpy_runs(fmus, folder) -> dict:
    """fmpy's runs in a fresh interpreter (FMPY), by name: the results and what fmpy reported."""
    pendulum, loop = str(fmus["double_pendulum"]), str(fmus["four_bar_spring"])
    runs = {
        "pendulum": (pendulum, 2.0, 0.01, {}),
        "heavier": (pendulum, 2.0, 0.01, {"upper.mass": HEAVIER}),
        "loop": (loop, LOOP_SPAN, 0.005, {}),
        "stiffer": (loop, LOOP_SPAN, 0.005, {"spring.spring_coefficient": STIFFER}),
        "crank": (str(fmus["slider_crank"]), TURN, TURN / 200, {}),
        "faster": (str(fmus["slider_crank"]), TURN, TURN / 200, {"drive.function.coefficients[2]": FASTER}),
    }
    done = subprocess.run(
        [sys.executable, "-c", FMPY, json.dumps(runs), str(folder)], cwd=folder, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr[-3000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    report["results"] = {name: np.load(folder / f"{name}.npy") for name in runs}
    return report


def mbd_run(model: Path, out: Path, *options: str) -> dict[str, np.ndarray]:
    """``mbd run MODEL --out FILE.csv`` on the numpy engine (what the FMU advances), read back."""
    assert cli.main(["run", str(model), "--engine", "numpy", "--out", str(out), *options]) == 0
    return read_csv(out)


def edited(folder: Path, name: str, change) -> Path:
    """The model file ``name`` with ``change(data['model'])`` applied, written beside the FMUs."""
    data = yaml.safe_load((MODELS / f"{name}.yaml").read_text())
    change(data["model"])
    path = folder / f"{name}-edited.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def differences(fmu_result: np.ndarray, csv: dict[str, np.ndarray]) -> dict[str, float]:
    """max |FMU - CSV| of every CSV column, the FMU's output found by its FMI name; time against t."""
    assert fmu_result.shape == csv["t"].shape
    found = {"t": float(np.max(np.abs(fmu_result["time"] - csv["t"])))}
    found.update({k: float(np.max(np.abs(fmu_result[fmi_name(k)] - v))) for k, v in csv.items() if k != "t"})
    return found


def test_fmpy_validates_the_fmus_and_the_slave_runs_on_what_the_fmu_carries(fmpy_runs):
    """No problem in modelDescription.xml; the slave imported the solver and the schema validator from the FMU's
    resources, not from the environment (where mbd-course is installed too)."""
    assert all(problems == [] for problems in fmpy_runs["problems"].values()), fmpy_runs["problems"]
    unzipped = [Path(d).resolve() for d in fmpy_runs["unzipdir"].values()]
    for module, file in fmpy_runs["modules"].items():
        assert any(d / "resources" in Path(file).resolve().parents for d in unzipped), (module, file)


def test_the_fmu_names_what_it_needs_where_it_runs(fmus):
    """resources/requirements.txt (pythonfmu3's convention, for ``pythonfmu3 deploy``): numpy, scipy, pyyaml."""
    with zipfile.ZipFile(fmus["double_pendulum"]) as fmu:
        needed = fmu.read("resources/requirements.txt").decode().split()
        assert {"resources/model.yaml", "resources/fmu_slave.py", "resources/solutions/dynamics.py"} <= set(
            fmu.namelist()
        )
        assert not any(name.startswith("resources/solutions/compiled/") for name in fmu.namelist())
    assert needed == requirements() and [n.split(">")[0] for n in needed] == ["numpy", "scipy", "pyyaml"]


def test_the_double_pendulum_fmu_runs_in_fmpy_as_mbd_run(fmpy_runs, folder):
    """Done-when of issue 28: every column of ``mbd run``'s CSV within 1e-6 (measured: 9e-9, the accelerations;
    positions 2e-10), on the same output times; the parameters are the file's masses and inertias and the
    tolerances mbd run takes from it."""
    starts = fmpy_runs["starts"][next(f for f in fmpy_runs["starts"] if "double_pendulum" in f)]
    assert starts == {
        "upper.mass": 1.0, "upper.inertia": 1 / 12, "lower.mass": 0.6, "lower.inertia": 0.032,
        "rtol": 1e-10, "atol": 1e-12,
    }  # fmt: skip
    csv = mbd_run(MODELS / "double_pendulum.yaml", folder / "pendulum.csv")
    found = differences(fmpy_runs["results"]["pendulum"], csv)
    assert len(found) == 1 + 3 * 6 + 2 + 6 + 2 * 3  # t, q q' q'' of two bodies, residuals, energies, reactions
    assert max(found.values()) < 1e-6, sorted(found.items(), key=lambda kv: -kv[1])[:3]


def test_a_mass_set_in_the_fmu_runs_as_the_file_edited(fmpy_runs, folder):
    """upper.mass set before initialization: the run of the file with that mass, not the file's run."""
    model = edited(folder, "double_pendulum", lambda m: m["bodies"][0].update(mass=HEAVIER))
    csv = mbd_run(model, folder / "heavier.csv")
    assert max(differences(fmpy_runs["results"]["heavier"], csv).values()) < 1e-6
    moved = differences(fmpy_runs["results"]["pendulum"], csv)
    assert moved["lower.x"] > 1e-2  # the mass changes the motion: the test above can tell


def test_a_closed_loop_with_a_spring_damper_and_actuator_runs_in_fmpy_as_mbd_run(fmpy_runs, folder):
    """The four-bar with its spring-damper-actuator (Baumgarte, RK45 at mbd run's default tolerance, which the
    FMU states as its parameter rtol): positions within 1e-6 m (measured: 1e-8), every column within 1e-6 of
    its largest value (the accelerations' 3e2 rad/s^2 differ by 1e-5: rtol 1e-8 times their size); a stiffer
    spring set in the FMU runs as the edited file."""
    name = "four_bar_spring"
    starts = fmpy_runs["starts"][next(f for f in fmpy_runs["starts"] if name in f)]
    assert {"spring.spring_coefficient", "spring.actuator.amplitude", "coupler.inertia"} <= set(starts)
    steps = str(round(LOOP_SPAN / 0.005))
    tolerances = [
        "--t-end",
        str(LOOP_SPAN),
        "--steps",
        steps,
        "--rtol",
        str(starts["rtol"]),
        "--atol",
        str(starts["atol"]),
    ]
    stiffer = edited(folder, name, lambda m: m["spring_dampers"][0].update(spring_coefficient=STIFFER))
    for run, model in (("loop", MODELS / f"{name}.yaml"), ("stiffer", stiffer)):
        csv = mbd_run(model, folder / f"{run}.csv", *tolerances)
        found = differences(fmpy_runs["results"][run], csv)
        assert max(found[f"{body}.{c}"] for body in ("crank", "coupler", "rocker") for c in ("x", "y")) < 1e-6
        relative = {k: v / max(1.0, float(np.max(np.abs(csv[k])))) for k, v in found.items()}
        assert max(relative.values()) < 1e-6, sorted(relative.items(), key=lambda kv: -kv[1])[:3]
    assert max(differences(fmpy_runs["results"]["loop"], csv).values()) > 1e-3  # the stiffness changes the run


def test_a_driven_slider_crank_runs_its_kinematics_in_fmpy_as_mbd_run(fmpy_runs, folder):
    """Drivers that leave no degree of freedom: the FMU runs mbd run's kinematic analysis (measured: the same
    numbers, to the bit), no tolerances among its parameters; the crank speed set in the FMU (the drive's second
    polynomial coefficient) runs as the edited file."""
    starts = fmpy_runs["starts"][next(f for f in fmpy_runs["starts"] if "slider_crank" in f)]
    assert starts["drive.function.coefficients[2]"] == 10.0 and "rtol" not in starts
    faster = edited(folder, "slider_crank", lambda m: m["motors"][0]["function"]["coefficients"].__setitem__(1, FASTER))
    for run, model in (("crank", MODELS / "slider_crank.yaml"), ("faster", faster)):
        found = differences(fmpy_runs["results"][run], mbd_run(model, folder / f"{run}.csv"))
        assert len(found) == 1 + 3 * 9 and max(found.values()) < 1e-9, found  # t, q q' q'' of three bodies
    assert abs(fmpy_runs["results"]["faster"]["crank.phi_d"][-1] - FASTER) < 1e-9


def test_structured_names_and_parameters_of_a_spatial_driven_model():
    """A name part that is not an identifier is quoted; a spatial body's principal moments are inertia[1..3];
    a motor's function gives its numbers; an unnamed element is named by its place; an edit lands in its key."""
    assert fmi_name("upper.phi_d") == "upper.phi_d" and fmi_name("slider-1.x") == "'slider-1'.x"
    data = yaml.safe_load((MODELS / "spatial_double_pendulum_driven.yaml").read_text())
    data["model"]["bodies"][0]["name"] = "arm-1"
    data["model"]["spring_dampers"] = [{"type": "RSDA", "body1": "ground", "body2": "arm-1", "spring_coefficient": 2.0}]
    data["model"]["motors"][0]["function"] = {"type": "polynomial", "coefficients": [0.64, 0.01]}
    parameters = model_parameters(data)
    assert parameters["'arm-1'.inertia[2]"] == (("bodies", 0, "inertia", 1), data["model"]["bodies"][0]["inertia"][1])
    assert parameters["spring_dampers[1].spring_coefficient"] == (("spring_dampers", 0, "spring_coefficient"), 2.0)
    assert parameters["leg2.function.amplitude"] == (("motors", 1, "function", "amplitude"), -0.04)
    assert parameters["leg1.function.coefficients[2]"] == (("motors", 0, "function", "coefficients", 1), 0.01)
    assert not any(".function.type" in name for name in parameters)
    changed = with_parameters(data, {"'arm-1'.inertia[2]": 7.0})
    assert changed["model"]["bodies"][0]["inertia"][1] == 7.0 and data["model"]["bodies"][0]["inertia"][1] != 7.0


def test_what_an_fmu_cannot_run_is_refused_in_one_line(tmp_path, capsys, monkeypatch):
    """An index-3 integrator (its own loop, not stepped), a file that is not .fmu, a missing builder: exit 2, one
    line that says what to do; nothing written but the edited model."""
    model = edited(tmp_path, "double_pendulum", lambda m: None)
    data = yaml.safe_load(model.read_text())
    data["simulation"]["integrator"] = "hht"
    model.write_text(yaml.safe_dump(data))
    assert main([str(model), "--out", str(tmp_path / "s.fmu")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "simulation.integrator hht" in err and "choose an ODE integrator" in err
    with pytest.raises(FmuError, match="FILE.fmu"):
        export_fmu(MODELS / "double_pendulum.yaml", tmp_path / "d.zip")
    monkeypatch.setitem(sys.modules, "pythonfmu3", None)  # as if not installed
    with pytest.raises(FmuError, match=r"pip install 'mbd-course\[dev\]'"):
        export_fmu(MODELS / "double_pendulum.yaml", tmp_path / "d.fmu")
    assert list(tmp_path.iterdir()) == [model]


def test_an_importer_in_c_runs_the_fmu_once_libpython_is_loaded(fmus, fmpy_runs, folder):
    """The FMI 3.0 C API, as a tool that is not Python calls it (fmi3_host.c, built here): without libpython
    loaded the FMU's binary does not load (pythonfmu3's loader links to none, as fmu.py says); with it preloaded
    and the environment's packages on PYTHONPATH, 200 steps give the end position that fmpy's run gave. (The host
    ends with _exit: pythonfmu3's loader crashes when it finalizes Python at unload, fmi3_host.c says why.)"""
    gcc = shutil.which("gcc")
    if gcc is None or not sysconfig.get_config_var("Py_ENABLE_SHARED") or platform.machine() != "x86_64":
        pytest.skip("needs gcc and a shared libpython on Linux x86_64")
    headers = Path(importlib.util.find_spec("fmpy").origin).parent / "c-code"
    host = folder / "fmi3_host"
    subprocess.run([gcc, "-O1", "-o", str(host), str(HOST), f"-I{headers}", "-ldl"], check=True)
    unzipped = folder / "double_pendulum"
    with zipfile.ZipFile(fmus["double_pendulum"]) as fmu:
        fmu.extractall(unzipped)
    description = ElementTree.parse(unzipped / "modelDescription.xml").getroot()
    reference = next(v.get("valueReference") for v in description.iter("Float64") if v.get("name") == "lower.x")
    binary = unzipped / "binaries" / "x86_64-linux" / "double_pendulum.so"
    command = [str(host), str(binary), str(unzipped / "resources"), description.get("instantiationToken"), reference]
    command += ["200", "0.01"]
    alone = subprocess.run(command, capture_output=True, text=True)
    assert alone.returncode == 1 and "undefined symbol" in alone.stderr
    libpython = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("LDLIBRARY")
    env = {**os.environ, "LD_PRELOAD": str(libpython), "PYTHONPATH": sysconfig.get_paths()["purelib"]}
    done = subprocess.run(command, capture_output=True, text=True, env=env, cwd=folder)
    assert done.returncode == 0, done.stderr[-2000:]
    assert abs(float(done.stdout) - fmpy_runs["results"]["pendulum"]["lower.x"][-1]) < 1e-9
