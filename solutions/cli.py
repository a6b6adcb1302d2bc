"""The ``mbd`` command line: run and check models (DESIGN section 6).

A user error (a bad file, a bad option, a mechanism that cannot be assembled or analysed) prints one
message and exits with code 2; it never shows a traceback.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

import numpy as np

from .analysis import run_analysis
from .assembly import System, build_system
from .diagnostics import AnalysisError, command_line_words, rank_report
from .io.model import IMPORTED, Model, ModelError, load_model
from .kinematics import assemble
from .results import DERIVED, Result
from .rotation_matrices import euler_rotation, planar_rotation
from .settings import ANALYSES, DYNAMIC_ONLY, FLAG, NAME, WHOLE, read_settings, table

USER_ERROR = 2


class UsageError(ValueError):
    """A command-line option that does not fit the model."""


POINT_FRAMES = ("global", "body")
"""How ``--point`` reads x, y (, z): ``@global`` (the default) a point in the file's configuration, ``@body`` a
point in the body's frame as the file gives it, as ``frame: body`` reads a model file's points (from the centre
of mass, or from ``location`` for a body with ``com:``)."""


def _parse_point(text: str, model: Model, number: int) -> tuple[str, int, np.ndarray]:
    """'[LABEL=]BODY:x,y[,z][@body]' -> (label, body index, body-frame point s').

    x, y (, z) are global, in the file's configuration (s' = A^T (P - r), eq. 2.10 read backwards), or with
    '@body' in the file's body frame (s' = x - c' for a body with ``com`` c', else s' = x); the label defaults
    to 'BODY.pN'.
    """
    form = "x,y" if model.dimension == 2 else "x,y,z"
    usage = (
        f"--point {text!r}: write [LABEL=]BODY:{form} (a global point in the file's configuration) or "
        f"[LABEL=]BODY:{form}@body (in the body's frame, as frame: body reads a model file)"
    )
    label, _, spec = text.rpartition("=")
    spec, _, frame = spec.partition("@")
    if (frame or "global") not in POINT_FRAMES:
        raise UsageError(usage)
    try:
        body, coords = spec.split(":")
        values = np.array([float(v) for v in coords.split(",")])
    except ValueError:
        raise UsageError(usage) from None
    try:
        index = model.body_index(body)
    except KeyError:
        names = ", ".join(b.name for b in model.bodies)
        raise UsageError(f"--point {text!r}: no body named '{body}' (bodies: {names})") from None
    if values.size != model.dimension or index < 0:
        raise UsageError(f"--point {text!r}: give {model.dimension} coordinates ({form}) of a point of a moving body")
    label, b = label or f"{body}.p{number}", model.bodies[index]
    if frame == "body":
        return label, index, values if b.com is None else values - b.com
    if model.dimension == 3:
        return label, index, euler_rotation(b.orientation).T @ (values - b.location)
    return label, index, planar_rotation(b.orientation).T @ (values - b.location)


def _check_coords(names: list[str], system: System, points: dict) -> None:
    """Refuse a --coords name before the run: a coordinate, a --point column ('LABEL.x') or a derived column.

    Derived columns (energy, residuals) exist after some analyses only: ``plot_result`` checks them.
    """
    for name in names:
        if name in system.coordinate_names or name.rsplit(".", 1)[0] in points or name.startswith(DERIVED):
            continue
        known = ", ".join(system.coordinate_names)
        hint = f"; --point columns: {', '.join(f'{label}.x' for label in points)}, ..." if points else ""
        raise UsageError(f"--coords {name}: no such coordinate (coordinates: {known}{hint})")


def _unused_note(args, result: Result) -> str | None:
    """A note naming the options given for a dynamic analysis when another one ran, else None."""
    unused = [f"--{option}" for option in DYNAMIC_ONLY if getattr(args, option) is not None]
    analysis = result.info.get("analysis")
    if not unused or analysis == "dynamic":
        return None
    return f"note: not used by the {analysis} analysis: {', '.join(unused)}"


def restart_line(result: Result) -> str | None:
    """One line for a run that ``auto`` made again with another formulation (``info['restarted']``): when the
    first run stopped next to a singular position and which formulation ran instead; None for a run that went
    through at once. The line is the same whichever engine ran (what stopped the first run there, the Guard or
    the integrator's step, is ``info['restarted']['why']``, and may differ: the engines check at other times)."""
    restarted = result.info.get("restarted")
    if not restarted:
        return None
    when = "" if restarted["t"] is None else f" at t = {restarted['t']:.6g} s"
    return (
        f"mbd run: restarted: the {restarted['stopped']} formulation stopped next to a singular position{when}; auto "
        f"ran the analysis again from t = 0 with {restarted['formulation']}, which passes singular positions"
    )


def tightened_line(result: Result) -> str | None:
    """One line for a run at the default rtol that ran again at a tighter one (``info['tightened']``): the estimated
    error of the first (a second run at 100 x rtol, eq. 6.62) exceeded the accuracy; None for a run that did not."""
    tightened = result.info.get("tightened")
    if not tightened:
        return None
    return (
        f"mbd run: tightened: estimated position error {tightened['estimate']:.2g} m at rtol {tightened['was']:.2g} "
        f"(from a run at 100 x rtol, eq. 6.62) exceeds the accuracy, {tightened['bound']:.2g} m; ran the analysis "
        f"again at rtol {tightened['rtol']:.2g} (eq. 6.64)"
    )


def run_summary(result: Result) -> str:
    info = result.info
    lines = [f"{info.get('analysis', 'analysis')} analysis: {result.t.size} output points to t = {result.t[-1]:g} s"]
    moved = info.get("assembly", {}).get("moved", {})
    shifted = {k: v for k, v in moved.items() if v["translation"] > 1e-9 or v["rotation"] > 1e-9}
    if shifted:
        parts = [f"{k} {v['translation']:.3g} m / {v['rotation']:.3g} rad" for k, v in shifted.items()]
        lines.append("assembly moved " + ", ".join(parts))
    for key in ("formulation", "integrator", "newton_iterations", "rhs_evaluations", "max_constraint_residual"):
        if key in info:
            value = info[key]
            lines.append(f"{key.replace('_', ' ')}: {value:.3g}" if isinstance(value, float) else f"{key}: {value}")
    if "engine" in info.get("chosen", {}):
        lines.append(f"engine: {info['chosen']['engine']} ({info['chosen']['engine_why']})")
    if "wall_time" in info:
        lines.append(f"wall time: {info['wall_time']:.3g} s")
    lines += [f"note: {note}" for note in info.get("notes", [])]  # e.g. redundant joints: reactions not unique
    lines += [f"warning: {warning}" for warning in info.get("warnings", [])]
    return command_line_words("\n".join(lines))


RESULT_FILES = (".csv", ".npz")
"""What ``mbd run --out`` writes (``io.results.write_result``)."""


def check_outputs(args) -> None:
    """Refuse, before anything runs, an output the run could not write (UsageError, one line): --out of another
    kind than .csv or .npz, --plot of a kind matplotlib does not write, --animate other than .html, .gif or
    .mp4 (with ffmpeg), a folder that does not exist."""
    outputs = {"--out": args.out, "--plot": args.plot, "--animate": args.animate}
    for option, path in ((o, Path(p)) for o, p in outputs.items() if p):
        if not path.parent.is_dir():
            raise UsageError(f"{option} {path}: no folder {path.parent} (make it first, or write elsewhere)")
    if args.out and Path(args.out).suffix.lower() not in RESULT_FILES:
        raise UsageError(f"--out {args.out}: results are written as FILE.csv (a table) or FILE.npz (numpy arrays)")
    if args.plot:
        from matplotlib.backend_bases import FigureCanvasBase

        kinds = FigureCanvasBase.get_supported_filetypes()
        if Path(args.plot).suffix.lower().lstrip(".") not in kinds:
            raise UsageError(f"--plot {args.plot}: a plot is written as one of .{', .'.join(sorted(kinds))}")
    if args.animate and Path(args.animate).suffix.lower() not in (".html", ".htm"):
        from .animation import check_writable

        try:
            check_writable(Path(args.animate))
        except ValueError as err:
            raise UsageError(f"--animate {err}") from None


def read_model(path: str) -> Model:
    """``load_model``, saying on stderr what an import of a URDF or MJCF file left out (one line each)."""
    model = load_model(path)
    for line in model.dropped:
        print(f"mbd: import {Path(path).name}: {line}", file=sys.stderr)
    return model


def command_import(args) -> int:
    """``mbd import FILE.urdf|FILE.xml [--out MODEL.yaml]``: write the model file of a URDF or MJCF file
    (``io.importers``), with what it dropped on stderr and in the file's header; the model is checked by loading
    it, so a file that imports is a file that ``mbd run`` takes."""
    from .io.importers import import_file, model_text

    source = Path(args.file)
    if source.suffix.lower() not in IMPORTED:
        raise UsageError(f"{source}: import reads URDF (.urdf) and MJCF (.xml) files; a .yaml model runs as it is")
    out = Path(args.out or f"{source.stem}.yaml")
    if out.suffix.lower() not in (".yaml", ".yml"):
        raise UsageError(f"--out {out}: the model file is YAML, FILE.yaml")
    if not out.parent.is_dir():
        raise UsageError(f"--out {out}: no folder {out.parent} (make it first, or write elsewhere)")
    imported = import_file(source)
    load_model(imported.data)  # a model the schema and the references accept (ModelError otherwise)
    try:
        out.write_text(model_text(imported, source.name))
    except OSError as err:
        raise UsageError(f"--out {out}: cannot write ({err.strerror})") from None
    for line in imported.dropped:
        print(f"mbd: import {source.name}: {line}", file=sys.stderr)
    print(f"model written to {out}")
    return 0


def command_run(args) -> int:
    check_outputs(args)
    model = read_model(args.model)
    system, q0, qd0 = build_system(model)
    points = {}
    for number, text in enumerate(args.point or [], start=1):
        label, body, local = _parse_point(text, model, number)
        points[label] = (body, local)
    settings = read_settings(model.simulation, **{f.name: getattr(args, f.name) for f in table()})
    _check_coords(args.coords or [], system, points)
    if args.rotations and model.dimension != 3:
        raise UsageError(
            "--rotations: a planar body's angle phi, its rate and acceleration are the columns BODY.phi, BODY.phi_d, "
            "BODY.phi_dd"
        )
    result = run_analysis(system, q0, qd0, settings, points=points)
    for line in (restart_line(result), tightened_line(result)):
        if line:
            print(line, file=sys.stderr)
    if args.rotations:
        from .kinematics import rotation_columns

        result.points.update(rotation_columns(result, [b.name for b in model.bodies]))
    print(run_summary(result))
    note = _unused_note(args, result)
    if note:
        print(note)
    if args.out:
        from .io.results import write_result

        try:
            path = write_result(result, args.out)
        except OSError as err:
            raise UsageError(f"--out {args.out}: cannot write ({err.strerror})") from None
        print(f"results written to {path}")
    if args.animate:
        from .animation import animate_result
        from .viewer import result_view

        try:
            if Path(args.animate).suffix.lower() in (".html", ".htm"):
                result_view(model, system, result).write_html(args.animate)
            else:
                animate_result(model, system, result, args.animate)
        except ValueError as err:
            raise UsageError(f"--animate {args.animate}: {err}") from None
        except OSError as err:
            raise UsageError(f"--animate {args.animate}: cannot write ({err.strerror})") from None
        print(f"animation written to {args.animate}")
    if args.plot:
        from .plotting import plot_result

        try:
            path = plot_result(result, args.plot, coordinates=args.coords)
        except OSError as err:
            raise UsageError(f"--plot {args.plot}: cannot write ({err.strerror})") from None
        except ValueError as err:  # a --coords name the result does not have (plotting says which)
            raise UsageError(str(err)) from None
        print(f"plot written to {path}")
    return 0


def check_report(model, system, q0) -> tuple[list[str], np.ndarray]:
    """What ``mbd check`` says of a model (bodies, joints, degrees of freedom, redundant equations by joint,
    the assembly's residual and moves), and the assembled coordinates."""
    lines = [f"model {model.name} ({model.source}): {model.dimension}D"]
    lines.append(f"bodies ({len(model.bodies)}): " + ", ".join(b.name for b in model.bodies))
    lines += [f"  joint {j['name']}: {j['type']} {j['body1']} - {j['body2']}" for j in model.joints]
    lines += [f"  motor {m['name']}: {m['type']}" for m in model.motors]
    q, assembly = assemble(system, q0)
    report = rank_report(system.jacobian(q, 0.0), system.row_owners)
    lines.append(
        f"coordinates: {system.n_coordinates}, constraint equations: {system.n_constraints}, rank: {report.rank}"
    )
    lines.append(f"degrees of freedom: {report.degrees_of_freedom}")
    if report.n_redundant:
        lines.append(f"redundant equations: {report.n_redundant} (joints: {', '.join(report.redundant_joints)})")
    else:
        lines.append("redundant equations: none")
    lines.append(f"assembly: residual {assembly['residual']:.3g} after {assembly['iterations']} Newton iteration(s)")
    for name, moved in assembly["moved"].items():
        lines.append(f"  {name} moved {moved['translation']:.3g} m, {moved['rotation']:.3g} rad")
    return lines, q


def command_check(args) -> int:
    model = read_model(args.model)
    system, q0, _ = build_system(model)
    print("\n".join(check_report(model, system, q0)[0]))
    return 0


def command_view(args) -> int:
    """``mbd view MODEL [RESULT]``: one offline page; the model as the file places it and as assembly makes it
    consistent, with ``mbd check``'s report, or, with a result of ``mbd run`` (CSV or NPZ), its motion."""
    from .viewer import model_view, result_view

    model = read_model(args.model)
    system, q0, _ = build_system(model)
    lines, q = check_report(model, system, q0)
    out = Path(args.out or f"{Path(args.model).stem}.html")
    if out.suffix.lower() not in (".html", ".htm"):
        raise UsageError(f"--out {out}: the view is a page, FILE.html")
    if not out.parent.is_dir():
        raise UsageError(f"--out {out}: no folder {out.parent}")
    if args.result:
        from .io.results import read_result

        try:
            result = read_result(args.result, system.coordinate_names, [b.name for b in model.bodies])
        except (OSError, ValueError) as err:
            raise UsageError(f"{args.result}: {err}") from None
        try:
            title = f"{model.name}: {Path(args.result).name}"
            view = result_view(
                model, system, result, trace=args.trace, plots=args.plot, reactions=args.reactions,
                forces=args.forces, title=title,
            )  # fmt: skip
        except ValueError as err:
            raise UsageError(f"{args.result}: {err}") from None
    else:
        view = model_view(model, q, before=q0, title=f"{model.name}: as assembled (grey: as the file places it)")
    try:
        view.write_html(out, "\n".join(lines))
    except OSError as err:
        raise UsageError(f"--out {out}: cannot write ({err.strerror})") from None
    print(f"view written to {out}")
    return 0


def command_sweep(args) -> int:
    """``mbd sweep``: run a model over parameter values (``solutions.sweep``); a table, an NPZ and plots."""
    from .batch import BatchError, cluster_for, describe
    from .sweep import SweepError, make_sweep, run_sweep

    jobs = args.jobs if args.jobs is not None else (1 if args.cluster is None else 2)
    try:
        cluster_for(jobs, args.cluster)  # a bad --jobs or --cluster refused before the model is read
        sweep = make_sweep(
            args.model,
            args.set or [],
            args.output,
            zipped=args.zip,
            analysis=args.analysis,
            t_end=args.t_end,
            steps=args.steps,
            engine=args.engine,
        )
        out = args.out or f"sweep-{Path(args.model).stem}"
        where = describe(cluster_for(jobs, args.cluster, len(sweep.sets)))
        print(f"{len(sweep.sets)} runs of {args.model} ({'zipped' if sweep.zipped else 'grid'}) {where}")
        options = {"progress": not args.no_progress, "resume": not args.fresh}
        result = run_sweep(sweep, out, jobs=jobs, cluster=args.cluster, **options)
    except (SweepError, BatchError) as err:
        raise UsageError(str(err)) from None
    except OSError as err:
        raise UsageError(f"--out {args.out}: cannot write ({err.strerror})") from None
    resumed = f", {result.resumed} resumed" if result.resumed else ""
    print(f"{len(result.rows)} runs, {result.failed} failed{resumed}, {result.seconds:.3g} s")
    for path in result.files:
        print(f"written: {path}")
    return 0


INTERRUPTED = 130
"""The exit code after Ctrl-C (128 + SIGINT), as a shell gives; what was done is kept and the same command
resumes (``mbd grade``, ``mbd sweep``)."""


def command_derive(args: argparse.Namespace) -> int:
    """Print the symbolic Psi, Psi_q, Psi_t and gamma of a model (``symbolic.py``)."""
    from .symbolic import derive

    print(derive(args.model).report(latex=args.latex, simplify=args.simplify))
    return 0


def add_derive(sub) -> None:
    """``mbd derive MODEL [--latex] [--simplify]``."""
    derive = sub.add_parser("derive", help="print a model's constraint equations, Jacobian and gamma symbolically")
    derive.add_argument("model", help="model file (YAML or JSON)")
    derive.add_argument("--latex", action="store_true", help="LaTeX instead of plain text")
    derive.add_argument("--simplify", action="store_true", help="simplify every expression (slow for big models)")
    derive.set_defaults(handler=command_derive)


def add_import(sub) -> None:
    """``mbd import FILE.urdf|FILE.xml [--out MODEL.yaml]``."""
    command = sub.add_parser(
        "import", help="write the model file of a URDF or MJCF (MuJoCo) file; says on stderr what it drops"
    )
    command.add_argument("file", help="a URDF (.urdf) or MJCF (.xml) file")
    command.add_argument("--out", help="the model file to write (default: FILE's name .yaml, here)")
    command.set_defaults(handler=command_import)


EXPORTS = {"mjcf": ".xml", "urdf": ".urdf", "fmu": ".fmu"}
"""The formats of ``mbd export`` and the suffix of the file written by default."""


def command_export(args) -> int:
    """``mbd export MODEL --to mjcf|urdf|fmu [--out FILE]``: the model in another code's format (``io.mjcf``,
    ``io.urdf``; the FMU by ``io.fmu`` where installed), written to FILE or MODEL's stem here."""
    out = Path(args.out or f"{Path(args.model).stem}{EXPORTS[args.to]}")
    if not out.parent.is_dir():
        raise UsageError(f"--out {out}: no folder {out.parent} (make it first, or write elsewhere)")
    if args.to == "fmu":
        try:
            from .io.fmu import export_fmu
        except ImportError:
            raise UsageError(
                "--to fmu: the FMU export needs the module solutions/io/fmu.py, not installed here"
            ) from None
        export_fmu(args.model, out)
        print(f"FMU written to {out}")
        return 0
    model = load_model(args.model)
    if args.to == "mjcf":
        from .io.mjcf import Stiffness, export_mjcf

        for option, value in (("--timestep", args.timestep), ("--solref", args.solref)):
            if value is not None and not value > 0:
                raise UsageError(f"{option} {value}: give a time > 0 in s, e.g. 1e-4")
        if args.solimp is not None and not (0 < args.solimp[0] <= args.solimp[1] < 1 and args.solimp[2] > 0):
            raise UsageError(f"--solimp {' '.join(map(str, args.solimp))}: give 0 < DMIN <= DMAX < 1 and WIDTH > 0")
        given = {"timestep": args.timestep, "time_constant": args.solref, "solimp": args.solimp and tuple(args.solimp)}
        stiffness = Stiffness(**{key: value for key, value in given.items() if value is not None})
        text, notes = export_mjcf(model, stiffness), []
    else:
        from .io.urdf import export_urdf

        text, notes = export_urdf(model)
    try:
        out.write_text(text)
    except OSError as err:
        raise UsageError(f"--out {out}: cannot write ({err.strerror})") from None
    for note in notes:
        print(f"note: {note}")
    print(f"{args.to.upper()} written to {out}")
    return 0


def add_export(sub) -> None:
    """``mbd export MODEL --to mjcf|urdf|fmu [--out FILE] [--timestep H] [--solref T]``."""
    export = sub.add_parser("export", help="write a model for another code: MuJoCo's MJCF, URDF (open trees), an FMU")
    export.add_argument("model", help="model file (YAML or JSON)")
    export.add_argument("--to", required=True, choices=list(EXPORTS), help="the format: mjcf, urdf or fmu")
    export.add_argument("--out", help="the file to write (default: MODEL's name with .xml, .urdf or .fmu, here)")
    export.add_argument("--timestep", type=float, help="MJCF: MuJoCo's integration step in s (default 1e-4)")
    export.add_argument(
        "--solref", type=float, metavar="T", help="MJCF: the equalities' time constant in s (default: two steps)"
    )
    export.add_argument(
        "--solimp", type=float, nargs=3, metavar=("DMIN", "DMAX", "WIDTH"),
        help="MJCF: the equalities' impedance (default 0.9999 0.9999 0.001: stiff)",
    )  # fmt: skip
    export.set_defaults(handler=command_export)


COMMANDS = "mbd.commands"
"""The entry-point group through which the course's other packages add their commands to ``mbd`` (as
``jupyter`` finds ``jupyter-NAME``): each entry is a function ``add(sub)`` that adds its subparser, with
``handler`` (and ``options=True`` for a command that takes its own options, ``mbd notes``, ``mbd bench``).
The course's ``pyproject.toml`` registers the instructor's commands and the self-check; this package knows
none of them, and where the course is not installed (a student's kit) ``mbd`` has the solver's commands only."""

OWN = ("run", "check", "view", "sweep", "derive", "export", "import")
"""The solver's own commands: ``mbd`` looks for the others only when asked for something else."""


def registered_commands() -> list:
    """The entry points of ``COMMANDS`` installed here, by name."""
    from importlib.metadata import entry_points

    return sorted(entry_points(group=COMMANDS), key=lambda entry: entry.name)


def add_settings(parser: argparse.ArgumentParser, names: tuple[str, ...] | None = None) -> None:
    """An option for every setting (``settings.Settings``; or those ``names``): --t-end for t_end, and so on,
    with the setting's help; an option not given is None, so the model file's value or the default holds."""
    types = {NAME: str, WHOLE: int, FLAG: None}
    for f in table():
        if names is not None and f.name not in names:
            continue
        option, takes = f"--{f.name.replace('_', '-')}", f.metadata["takes"]
        if takes == FLAG:
            parser.add_argument(option, action="store_const", const=True, help=f.metadata["help"])
        else:
            choices = ANALYSES if f.name == "analysis" else None
            parser.add_argument(option, type=types.get(takes, float), choices=choices, help=f.metadata["help"])


def add_sweep(sub) -> None:
    """``mbd sweep MODEL --set KEY=VALUES ...`` (``solutions.sweep``)."""
    sweep = sub.add_parser("sweep", help="run a model over a grid or sample of parameter values (a table and plots)")
    sweep.add_argument("model", help="model file (YAML or JSON)")
    sweep.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUES",
        help="a key of the model file and its values: bodies[crank].mass=0.5,1,2 (a list), =0.5:2:4 (start:stop:num), "
        "=uniform(0.5, 2, n=20, seed=1) or =normal(1, 0.1, n=20, seed=1) (repeatable)",
    )
    sweep.add_argument(
        "--output",
        action="append",
        metavar="EXPR",
        help="a summary per run: max|min|mean|rms|absmax|final|initial(COLUMN), e.g. max(slider.x), "
        "rms(drive.torque), or residual (default: residual; repeatable)",
    )
    sweep.add_argument("--zip", action="store_true", help="take the keys' values together instead of their full grid")
    add_settings(sweep, ("analysis", "t_end", "steps"))
    sweep.add_argument("--engine", default="numpy", help="numpy (default) or compiled (numba)")
    sweep.add_argument("--out", help="folder for sweep.csv, sweep.npz and plots/ (default: sweep-MODEL)")
    sweep.add_argument("--jobs", type=int, help="worker processes (default 1: runs here; more: a local Dask cluster)")
    sweep.add_argument(
        "--cluster",
        metavar="local|tcp://HOST:PORT",
        help="run on Dask: 'local' (a LocalCluster of --jobs workers, the default when --jobs > 1) or a scheduler",
    )
    sweep.add_argument("--fresh", action="store_true", help="run every set again instead of resuming")
    sweep.add_argument("--no-progress", action="store_true", help="no progress bar")
    sweep.set_defaults(handler=command_sweep)


class Parser(argparse.ArgumentParser):
    """argparse's parser, whose errors are one line ``mbd: error: ...`` (exit code 2) without the usage block,
    with the closest command or option when a word is misspelt ("did you mean --t-end?")."""

    def error(self, message: str):
        if message.startswith("unrecognized arguments: "):  # misspelt options: the closest of every command's
            words = [w for w in message.split(": ", 1)[1].split() if w.startswith("-")]
            known = [o for parser in _parsers(self) for action in parser._actions for o in action.option_strings]
        else:  # a misspelt command: "argument command: invalid choice: 'rnu' (choose from ...)"
            words = re.findall(r"invalid choice: '([^']*)'", message)
            known = [name for parser in _parsers(self) for name in _commands(parser)]
        guesses = [guess for word in words for guess in _close(word, known)]
        hint = f"; did you mean {guesses[0]}?" if guesses else ""
        self.exit(USER_ERROR, f"mbd: error: {message}{hint} (mbd {self._command()}--help lists them)\n")

    def _command(self) -> str:
        return "" if self.prog == "mbd" else f"{self.prog.split(' ', 1)[-1]} "


def _commands(parser: argparse.ArgumentParser) -> dict:
    """A parser's subcommands by name ({} for one without)."""
    return next((a.choices for a in parser._actions if isinstance(a, argparse._SubParsersAction)), {})


def _parsers(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """The parser and its subcommands' parsers."""
    return [parser, *_commands(parser).values()]


def _close(word: str, known: list[str]) -> list[str]:
    import difflib

    return [] if word in known else difflib.get_close_matches(word.split("=")[0], known, n=1, cutoff=0.6)


def build_parser(others: bool = True) -> argparse.ArgumentParser:
    """``mbd``'s parser: the solver's commands and (``others``) those the course's packages register."""
    parser = Parser(prog="mbd", description="Multibody dynamics course: reference solver.")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run an analysis of a model file")
    run.add_argument("model", help="model file (YAML or JSON; a URDF or MJCF file is imported)")
    add_settings(run)
    run.add_argument(
        "--out",
        help="write results to FILE.csv or FILE.npz: t, BODY.x .. with _d and _dd, --point columns, JOINT.Fx .., "
        "DRIVER.effort and (dynamic, inverse) each force element's ELEMENT.force (a spring-damper's tension, N, "
        "positive pulling), ELEMENT.torque (rotational, N m), ELEMENT.Fx .. (point force) and ELEMENT.power (W put "
        "into the bodies)",
    )
    run.add_argument("--plot", help="plot coordinates and points against time to FILE.png")
    run.add_argument(
        "--animate",
        help="animate the mechanism to FILE.html (a page that plays, turns and zooms, offline), .gif or .mp4",
    )
    run.add_argument("--coords", nargs="+", metavar="NAME", help="coordinates to plot, e.g. slider.x crank.phi")
    run.add_argument(
        "--point",
        action="append",
        metavar="[LABEL=]BODY:x,y[,z][@body]",
        help="also report position, velocity and acceleration (LABEL.x .y [.z], _d, _dd) of a body point given "
        "globally in the file's configuration, or with @body in the body's frame (as frame: body in a model file), "
        "in every analysis (repeatable)",
    )
    run.add_argument(
        "--rotations",
        action="store_true",
        help="spatial models: also report each body's angular velocity in rad/s, global (BODY.wx .wy .wz) and "
        "in the body frame (BODY.wx_body ..), its angular acceleration in rad/s^2 (BODY.wx_d .., BODY.wx_body_d ..) "
        "and its rotation matrix (BODY.A11 .. BODY.A33)",
    )
    run.set_defaults(handler=command_run)
    check = sub.add_parser("check", help="validate and assemble a model; report DOF and redundancies")
    check.add_argument("model", help="model file (YAML or JSON; a URDF or MJCF file is imported)")
    check.set_defaults(handler=command_check)
    view = sub.add_parser("view", help="draw a model (as the file places it and assembled) or a result, to FILE.html")
    view.add_argument("model", help="model file (YAML or JSON; a URDF or MJCF file is imported)")
    view.add_argument("result", nargs="?", help="a result of this model written by mbd run --out (CSV or NPZ)")
    view.add_argument("--out", help="the page to write (default: MODEL's name .html, here)")
    view.add_argument(
        "--trace", nargs="+", metavar="NAME", help="joints or points (mbd run --point LABEL) whose paths are drawn"
    )
    view.add_argument("--plot", nargs="+", metavar="COLUMN", help="result columns plotted against time beside it")
    view.add_argument(
        "--reactions", nargs="+", metavar="JOINT", help="joints whose reaction forces are arrows (a dynamic result)"
    )
    view.add_argument(
        "--forces", nargs="+", metavar="ELEMENT", help="force elements (point forces, spring-dampers) drawn as arrows"
    )
    view.set_defaults(handler=command_view)
    add_sweep(sub)
    add_derive(sub)
    add_export(sub)
    add_import(sub)
    if others:
        for entry in registered_commands():
            entry.load()(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``mbd``; returns the exit code (0 success, 2 user error)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(others=not argv or argv[0] not in OWN)  # `mbd run` loads nothing else
    args, extra = parser.parse_known_args(argv)
    if getattr(args, "options", False) is True:
        args.options = extra  # the command's own options (mbd notes --help, mbd bench --help)
    elif extra:  # said by the command's parser: its options are the ones to guess from
        _commands(parser).get(args.command, parser).error(f"unrecognized arguments: {' '.join(extra)}")
    try:
        return args.handler(args)
    except (ModelError, AnalysisError, UsageError) as err:
        print(f"mbd: error: {command_line_words(str(err))}", file=sys.stderr)
        return USER_ERROR
    except BrokenPipeError:  # output piped into a command that stopped reading (e.g. `| head`)
        sys.stderr.close()
        return 0
    except KeyboardInterrupt as err:  # Ctrl-C: one line (how far it got, when the command knows), no traceback
        done = f"; {err.args[0]}" if err.args and isinstance(err.args[0], str) else ""
        print(f"mbd: interrupted{done}", file=sys.stderr)
        return INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
