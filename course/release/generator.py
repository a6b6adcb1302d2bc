"""Build a student package from ``solutions/``: the one source of truth for the skeleton.

A body, or part of one, that students write in homework N is fenced in ``solutions/`` with nbgrader's own
delimiters, tagged with the homework::

    ### BEGIN SOLUTION hw2
    ...
    ### END SOLUTION

The student package for homework N keeps the regions of earlier homeworks filled in (without their
markers), so a student's hw2 never depends on their own hw1, and replaces every region of hwN and later by
``raise NotImplementedError("<function>: <what to implement>, see <course equation>")``. Everything else --
signatures, type hints, docstrings, helpers -- is copied as it is.

The regions are cut by nbgrader's ``ClearSolutions`` preprocessor (its ``_replace_solution_region``, with
the delimiters and code stub configured here), so the notebooks and the ``.py`` files follow one rule. What
nbgrader does not do is checked first, with file and line: nested, unterminated, unopened or mistagged
regions, and regions outside a function body.

Command line (``make modules`` runs the first form)::

    python -m course.release modules             # every region stubbed: the browsing copy
    python -m course.release --homework hw2 DEST  # the hw2 student package
"""

from __future__ import annotations

import argparse
import ast
import filecmp
import fnmatch
import os
import re
import shutil
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import nbformat
from nbgrader.preprocessors import ClearSolutions

HOMEWORKS = ("hw1", "hw2", "hw3")
"""The homework tags, in course order: a region tagged hw2 is filled in from hw3 on."""

BEGIN = "### BEGIN SOLUTION"
END = "### END SOLUTION"
IGNORED = ("__pycache__", "*.pyc", "*.pyo", ".DS_Store", ".ipynb_checkpoints")
"""Files of ``solutions/`` that never go into a student package."""
INSTRUCTOR_ONLY = ("compiled", "planar/batched.py", "spatial/batched.py", "serve.py", "io/fmu.py", "io/fmu_slave.py")
"""Folders and files of ``solutions/`` (paths relative to it) that never go into a student package. The first
three write out, outside any solution region, every formula the students write: the compiled engine's kernels,
for numba (a student package runs on numpy: ``engine`` falls back); the per-type (batched) forms of the joints,
a speed-up (a student package's System evaluates the element methods one by one). ``serve.py`` is ``mbd
serve``, a command of the instructor's and the lab's, not the kit's; ``io/fmu.py`` and its slave build an FMU,
which carries the reference solver's source, with a dev dependency (pythonfmu3)."""

REPO = Path(__file__).resolve().parents[2]
_STUB_TOKEN = "@@MBD_STUB@@"
_EQUATION = re.compile(r"\beqs?\.\s*(\d+(?:\.\d+)*(?:\s*(?:,|-|–|and)\s*\d+(?:\.\d+)*)*)")
_TAG = re.compile(r"^hw\d+$")

ROLES = {
    "constraints": "the constraint equations Psi",
    "jacobian": "the Jacobian Psi_q",
    "psi_t": "Psi_t, the partial time derivative of Psi",
    "gamma": "gamma, the right side of Psi_q q'' = gamma",
    "mass_matrix": "the mass matrix M",
    "generalized_forces": "the generalized forces Q",
}
"""What a method without its own docstring computes, by its course name."""


class RegionError(ValueError):
    """A solution region that cannot be built: names the file and the line."""

    def __init__(self, path: str, line: int, message: str):
        super().__init__(f"{path}:{line}: {message}")
        self.path, self.line = path, line


@dataclass(frozen=True)
class Region:
    """One fenced region of a source file (lines are 1-based, markers included)."""

    path: str
    begin: int
    end: int
    tag: str
    function: str
    text: tuple[str, ...]
    pointer: str

    @property
    def qualified_name(self) -> str:
        """The function as module.function, e.g. ``planar.joints.Revolute.gamma``."""
        return f"{Path(self.path).with_suffix('').as_posix().replace('/', '.')}.{self.function}"

    @property
    def homework(self) -> int:
        return HOMEWORKS.index(self.tag) + 1


@dataclass
class BuildReport:
    """What a build wrote: the files, and which functions were stubbed and which filled in."""

    homework: str | None
    destination: Path
    files: list[str] = field(default_factory=list)
    stubbed: list[Region] = field(default_factory=list)
    filled: list[Region] = field(default_factory=list)

    def stubbed_functions(self) -> list[str]:
        return _unique(r.qualified_name for r in self.stubbed)

    def filled_functions(self) -> list[str]:
        return _unique(r.qualified_name for r in self.filled)


def _unique(items) -> list:
    return list(dict.fromkeys(items))


def homework_index(homework: str | None) -> int:
    """1 for hw1, ..., and len(HOMEWORKS) + 1 for None (nothing stubbed)."""
    if homework is None:
        return len(HOMEWORKS) + 1
    if homework not in HOMEWORKS:
        raise ValueError(f"unknown homework {homework!r}: the course has {', '.join(HOMEWORKS)}")
    return HOMEWORKS.index(homework) + 1


# --------------------------------------------------------------------------------------------------------------
# Finding and checking regions


def _marker(line: str) -> str | None:
    """'begin', 'end' or None, by the same substring rule as nbgrader's ClearSolutions."""
    if BEGIN in line:
        return "begin"
    if END in line:
        return "end"
    return None


def _functions(tree: ast.AST):
    """(qualified name, node, enclosing class node or None) for every function in a module."""
    found = []

    def visit(node, prefix, cls):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = f"{prefix}{child.name}"
                found.append((name, child, cls))
                visit(child, f"{name}.", None)
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.", child)
            elif not isinstance(child, ast.expr):  # functions are defined by statements only
                visit(child, prefix, cls)

    visit(tree, "", None)
    return found


def _summary(docstring: str | None) -> str:
    """First paragraph of a docstring as one line, cut before its equation reference or first sentence end."""
    if not docstring:
        return ""
    paragraph = " ".join(docstring.strip().split("\n\n")[0].split())
    paragraph = paragraph.replace("``", "")
    cut = re.search(r"\s*\(?\s*\beqs?\.\s*\d", paragraph)
    if cut:
        paragraph = paragraph[: cut.start()]
    else:
        sentence = re.search(r"\.(\s|$)", paragraph)
        paragraph = paragraph[: sentence.start()] if sentence else paragraph
    return paragraph.strip(" .,;:")


def _equation(*docstrings: str | None) -> str | None:
    for doc in docstrings:
        match = _EQUATION.search(doc or "")
        if match:
            return f"eq. {match.group(1)}"
    return None


def _pointer(qualname: str, func: ast.AST, cls: ast.ClassDef | None, module_doc: str | None, path: str) -> str:
    """The stub's message: '<function>: <what to implement>, see <course equation>'."""
    own = ast.get_docstring(func)
    class_doc = ast.get_docstring(cls) if cls is not None else None
    what = _summary(own)
    if not what:
        role = ROLES.get(func.name, f"{func.name}()")
        what = f"{role} ({_summary(class_doc)})" if class_doc else role
    equation = _equation(own, class_doc)
    if equation is None:
        module_eq = _equation(module_doc)
        equation = f"{module_eq} and the notes in {path}" if module_eq else f"the notes in {path}"
    return f"{qualname}: {what}, see {equation}"


def scan_regions(text: str, path: str) -> list[Region]:
    """Every solution region of one source file, checked.

    Raises
    ------
    RegionError
        Nested, unterminated or unopened regions, a missing or unknown homework tag, an empty region,
        or a region that is not inside a function body (a stub there would break the import).
    """
    lines = text.split("\n")
    spans = []
    open_at, tag = None, None
    for number, line in enumerate(lines, start=1):
        kind = _marker(line)
        if kind is None:
            continue
        words = line.strip().split()
        if kind == "begin":
            if open_at is not None:
                raise RegionError(
                    path, number, f"nested solution region: the region opened at line {open_at} is not closed"
                )
            if not line.strip().startswith(BEGIN) or len(words) != 4 or not _TAG.match(words[3]):
                raise RegionError(
                    path,
                    number,
                    f"mistagged region {line.strip()!r}: write '{BEGIN} hwN' with N in 1..{len(HOMEWORKS)}",
                )
            if words[3] not in HOMEWORKS:
                raise RegionError(
                    path, number, f"unknown homework tag {words[3]!r}: the course has {', '.join(HOMEWORKS)}"
                )
            open_at, tag = number, words[3]
        else:
            if open_at is None:
                raise RegionError(path, number, f"'{END}' without a '{BEGIN} hwN' before it")
            if not line.strip().startswith(END) or len(words) not in (3, 4) or (len(words) == 4 and words[3] != tag):
                raise RegionError(
                    path, number, f"mistagged end {line.strip()!r}: the region opened at line {open_at} is {tag}"
                )
            spans.append((open_at, number, tag))
            open_at = None
    if open_at is not None:
        raise RegionError(path, open_at, f"unterminated solution region: no '{END}' after it")
    if not spans:
        return []

    try:
        tree = ast.parse(text, filename=path)
    except SyntaxError as err:
        raise RegionError(path, err.lineno or 0, f"not valid Python: {err.msg}") from None
    functions = _functions(tree)
    module_doc = ast.get_docstring(tree)
    regions = []
    for begin, end, tag in spans:
        body = [k for k in range(begin + 1, end) if lines[k - 1].strip() and not lines[k - 1].strip().startswith("#")]
        if not body:
            raise RegionError(path, begin, "empty solution region: there is no code between the markers")
        inside = [(name, f, c) for name, f, c in functions if f.lineno < begin and body[-1] <= f.end_lineno]
        if not inside:
            raise RegionError(
                path, begin, "solution region outside a function body: a stub there would break the import"
            )
        name, func, cls = max(inside, key=lambda item: item[1].lineno)  # the innermost
        signature_end = max([func.lineno] + [n.end_lineno for n in ast.walk(func.args) if hasattr(n, "end_lineno")])
        if func.returns is not None:
            signature_end = max(signature_end, func.returns.end_lineno)
        indent = len(lines[begin - 1]) - len(lines[begin - 1].lstrip())
        if begin <= signature_end or indent <= func.col_offset:
            raise RegionError(path, begin, f"solution region is not inside the body of {name}")
        if ast.get_docstring(func) and begin <= func.body[0].end_lineno:
            raise RegionError(path, begin, f"solution region inside the docstring of {name}")
        regions.append(
            Region(
                path=path,
                begin=begin,
                end=end,
                tag=tag,
                function=name,
                text=tuple(lines[begin : end - 1]),
                pointer=_pointer(name, func, cls, module_doc, path),
            )
        )
    return regions


# --------------------------------------------------------------------------------------------------------------
# Building


def _clear_solutions() -> ClearSolutions:
    """nbgrader's ClearSolutions, configured for the .py files of ``solutions/``."""
    return ClearSolutions(
        begin_solution_delimeter=BEGIN,
        end_solution_delimeter=END,
        code_stub={"python": f"raise NotImplementedError({_STUB_TOKEN})"},
        enforce_metadata=False,
    )


def build_source(text: str, path: str, homework: str | None) -> tuple[str, list[Region], list[Region]]:
    """The student version of one file: (text, stubbed regions, filled regions).

    ``homework`` None fills every region in (the reference without markers).
    """
    first_stubbed = homework_index(homework)
    regions = scan_regions(text, path)
    if not regions:
        return text, [], []
    filled = [r for r in regions if r.homework < first_stubbed]
    stubbed = [r for r in regions if r.homework >= first_stubbed]

    # Earlier homeworks stay filled in: drop only their marker lines.
    markers = {line for r in filled for line in (r.begin, r.end)}
    lines = [line for number, line in enumerate(text.split("\n"), start=1) if number not in markers]

    # nbgrader cuts the remaining regions, each into the stub, indented as its BEGIN line.
    cell = nbformat.v4.new_code_cell("\n".join(lines))
    _clear_solutions().preprocess_cell(cell, {"language": "python"}, 0)
    pieces = cell.source.split(_STUB_TOKEN)
    if len(pieces) != len(stubbed) + 1:
        raise RegionError(path, stubbed[0].begin if stubbed else 1, "could not match every stub to its region")
    out = pieces[0]
    for region, piece in zip(stubbed, pieces[1:], strict=True):
        out += repr(region.pointer) + piece
    try:
        ast.parse(out, filename=path)
    except SyntaxError as err:
        raise RegionError(path, err.lineno or 0, f"the stubbed file is not valid Python: {err.msg}") from None
    return out, stubbed, filled


def _ignored(name: str) -> bool:
    return any(fnmatch.fnmatch(name, pattern) for pattern in IGNORED)


def package_files(folder: Path, leave_out: tuple[str, ...] = ()) -> list[Path]:
    """The files of a package tree, sorted, relative to ``folder``: all but ``IGNORED`` ones and the folders
    and files at the paths ``leave_out`` (relative to ``folder``)."""
    files = []
    for current, dirs, names in os.walk(folder):
        here = Path(current).relative_to(folder)
        dirs[:] = sorted(d for d in dirs if not _ignored(d) and (here / d).as_posix() not in leave_out)
        files += [here / n for n in sorted(names) if not _ignored(n) and (here / n).as_posix() not in leave_out]
    return sorted(files)


def source_files(source: Path) -> list[Path]:
    """The files of a package tree that go into a student package (all but the ``INSTRUCTOR_ONLY`` ones),
    sorted, relative to ``source``."""
    return package_files(source, INSTRUCTOR_ONLY)


def header_for(homework: str | None, relpath: str, stubs: int = 1) -> str:
    """The first line of a built file: where to write (``stubs``: functions left to write in it), or that
    there is nothing to write in it."""
    if homework is None:
        return f"# Generated from solutions/{relpath}: the reference with its markers removed.\n"
    if stubs == 0:
        return (
            f"# Student package for {homework}, generated from the course's reference: nothing to write in this "
            "file (the course's own code, given whole: read it, do not change it).\n"
        )
    return (
        f"# Student package for {homework}, generated from the course's reference: write your code where a "
        "function raises NotImplementedError.\n"
    )


MODULES_HEADER = "# Generated from solutions/{path} by `make modules` (every homework stubbed): do not edit by hand.\n"


GENERATED = ("# Generated from solutions/", "# Student package for ")
"""How the first line of every generated .py file starts (a build replaces only such a folder)."""


def _check_replaceable(destination: Path, source: Path) -> None:
    """Refuse to write over the reference, or over a folder that a build did not write."""
    target, reference = destination.resolve(), source.resolve()
    if target == reference or target in reference.parents:
        raise ValueError(f"refusing to write a student package over {destination}: it holds {source}")
    if not target.exists():
        return
    for rel in package_files(target):
        if rel.suffix == ".py" and not (target / rel).read_text(errors="replace").startswith(GENERATED):
            raise ValueError(
                f"refusing to replace {destination}: {rel.as_posix()} was not generated (no generated-file header); "
                "move it away first"
            )


def build_package(
    destination: Path,
    homework: str | None,
    source: Path | None = None,
    header: str | None = "release",
) -> BuildReport:
    """Write the student package for ``homework`` into ``destination`` (replaced if it exists).

    Parameters
    ----------
    destination : folder of the package, e.g. ``modules`` or ``build/release/hw2/modules``
    homework : 'hw1', 'hw2', ...; regions of it and later homeworks are stubbed. None stubs nothing.
    source : the reference package, ``solutions/`` of the course by default
    header : 'release' (a note to the student on each .py file), 'modules' (the browsing copy's
        do-not-edit note) or None (the files exactly as built)

    Raises
    ------
    RegionError
        A malformed region, naming its file and line; nothing is written then.
    ValueError
        ``destination`` is the reference itself, or an existing folder with a .py file no build wrote.
    """
    source = Path(source or REPO / "solutions")
    destination = Path(destination)
    report = BuildReport(homework=homework, destination=destination)
    built = {}
    for rel in source_files(source):
        relpath = rel.as_posix()
        if rel.suffix != ".py":
            built[relpath] = (source / rel).read_bytes()
            continue
        text, stubbed, filled = build_source((source / rel).read_text(encoding="utf-8"), relpath, homework)
        if header == "release":
            text = header_for(homework, relpath, len(stubbed)) + text
        elif header == "modules":
            text = MODULES_HEADER.format(path=relpath) + text
        built[relpath] = text.encode("utf-8")
        report.stubbed += stubbed
        report.filled += filled
    _check_replaceable(destination, source)
    if destination.exists():
        shutil.rmtree(destination)
    for relpath, data in built.items():
        target = destination / relpath
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(data)
        report.files.append(relpath)
    return report


def all_regions(source: Path | None = None) -> list[Region]:
    """Every region of the reference package, checked."""
    source = Path(source or REPO / "solutions")
    regions = []
    for rel in source_files(source):
        if rel.suffix == ".py":
            regions += scan_regions((source / rel).read_text(encoding="utf-8"), rel.as_posix())
    return regions


# --------------------------------------------------------------------------------------------------------------
# The committed browsing copy, modules/


def build_modules(destination: Path | None = None, source: Path | None = None) -> BuildReport:
    """Regenerate ``modules/``: every region stubbed (what ``make modules`` runs)."""
    return build_package(Path(destination or REPO / "modules"), HOMEWORKS[0], source, header="modules")


def modules_differences(modules: Path | None = None, source: Path | None = None) -> list[str]:
    """How ``modules/`` differs from a fresh build: one line per missing, extra or changed file; [] when in sync."""
    modules = Path(modules or REPO / "modules")
    if not modules.is_dir():
        return [f"{modules} does not exist: run `make modules`"]
    with tempfile.TemporaryDirectory() as tmp:
        fresh = Path(tmp) / "modules"
        build_modules(fresh, source)
        expected = {p.as_posix() for p in package_files(fresh)}
        present = {p.as_posix() for p in package_files(modules)}
        lines = [f"missing: modules/{p}" for p in sorted(expected - present)]
        lines += [f"not built from solutions/: modules/{p}" for p in sorted(present - expected)]
        lines += [
            f"out of date: modules/{p}"
            for p in sorted(expected & present)
            if not filecmp.cmp(fresh / p, modules / p, shallow=False)
        ]
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m course.release", description=__doc__.split("\n")[0])
    parser.add_argument("destination", type=Path, help="folder of the package to write (replaced)")
    parser.add_argument("--homework", choices=HOMEWORKS, help="build the student package of this homework")
    parser.add_argument("--source", type=Path, default=None, help="reference package (default: solutions/)")
    args = parser.parse_args(argv)
    try:
        if args.homework:
            report = build_package(args.destination, args.homework, args.source)
        else:
            report = build_modules(args.destination, args.source)
    except (RegionError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(
        f"wrote {len(report.files)} files to {args.destination}: {len(report.stubbed_functions())} functions stubbed, "
        f"{len(report.filled_functions())} filled in"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
