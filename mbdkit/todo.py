"""What is left to write: the homework's functions that still raise ``NotImplementedError`` (``mbd todo``).

A kit's ``hwN.toml`` names the functions students write in the homework (``to_write``: file of the package and
function, ``Class.method`` for a method, in the course's order). A function is left while a ``raise
NotImplementedError`` is anywhere in its body (the stub's, or one the student kept below new code); its stub's
message says what it computes and where the notes give it ("see eq. 3.17"). The files are read, never imported:
a package that does not import yet still gets its list.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

from . import notes


@dataclass(frozen=True)
class Left:
    """A function still to write: its file in the package, name, line and what its stub says."""

    path: str
    function: str
    line: int
    says: str


def functions_of(tree: ast.Module) -> dict[str, ast.FunctionDef]:
    """The module's functions and the methods of its classes, by ``name`` and ``Class.name``."""
    found = {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            found[node.name] = node
        elif isinstance(node, ast.ClassDef):
            found.update({f"{node.name}.{f.name}": f for f in node.body if isinstance(f, ast.FunctionDef)})
    return found


def stub_message(function: ast.FunctionDef) -> str | None:
    """The message of the first ``raise NotImplementedError(...)`` in the function ('' without one); None when
    the function raises none."""
    for node in ast.walk(function):
        if isinstance(node, ast.Raise) and node.exc is not None:
            call = node.exc
            name = call.func if isinstance(call, ast.Call) else call
            if isinstance(name, ast.Name) and name.id == "NotImplementedError":
                args = call.args if isinstance(call, ast.Call) else []
                return args[0].value if args and isinstance(args[0], ast.Constant) else ""
    return None


def left_to_write(package: Path, to_write: list[tuple[str, str]]) -> list[Left]:
    """The functions of ``to_write`` that still raise NotImplementedError in ``package``, in that order (one
    missing from its file, or a file that does not parse, is left too, saying so)."""
    left, trees = [], {}
    for path, name in to_write:
        if path not in trees:
            try:
                trees[path] = functions_of(ast.parse((package / path).read_text(encoding="utf-8")))
            except (OSError, UnicodeDecodeError) as err:
                trees[path] = f"cannot read it ({type(err).__name__})"
            except SyntaxError as err:
                trees[path] = f"a syntax error at line {err.lineno}: {err.msg}"
        functions = trees[path]
        if isinstance(functions, str):
            left.append(Left(path, name, 0, functions))
        elif name not in functions:
            left.append(Left(path, name, 0, "not found in this file (renamed or deleted?)"))
        else:
            says = stub_message(functions[name])
            if says is not None:
                says = says.split(": ", 1)[1] if _is_stub(name, says) else says
                left.append(Left(path, name, functions[name].lineno, says))
    return left


def every_stub(package: Path) -> list[tuple[str, str]]:
    """Every (file, function) of the package that raises NotImplementedError, file by file (a folder without a
    kit's list: the course's own ``modules/``, every homework stubbed)."""
    pairs = []
    for path in sorted(package.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        try:
            functions = functions_of(ast.parse(path.read_text(encoding="utf-8")))
        except (OSError, UnicodeDecodeError, SyntaxError):
            continue
        relative = path.relative_to(package).as_posix()
        pairs += [(relative, name) for name, node in functions.items() if _is_stub(name, stub_message(node))]
    return pairs


def _is_stub(name: str, says: str | None) -> bool:
    """A stub of the course's generator says 'function: what it computes, see eq. N.M' (an interface's
    ``raise NotImplementedError`` in a base class says nothing of the kind)."""
    return says is not None and says.startswith((f"{name}: ", f"{name.split('.')[-1]}: "))


def report(
    homework: str, package_name: str, to_write: list[tuple[str, str]], left: list[Left], every: bool = False
) -> str:
    """The lines ``mbd todo`` prints: how many are left, grouped by file, and where to start. ``every``: the
    list is every stub of the package (no kit's list of the homework's functions)."""
    if not left:
        return f"{homework}: all {len(to_write)} functions are written. Next: mbd selfcheck {homework}\n"
    lines = [f"{homework}: {len(left)} of {len(to_write)} functions left to write (they raise NotImplementedError)"]
    if every:
        lines[0] = f"{len(left)} functions of {package_name}/ raise NotImplementedError (a kit lists only {homework}'s)"
    for path in dict.fromkeys(item.path for item in left):
        lines.append(f"{package_name}/{path}")
        for item in (i for i in left if i.path == path):
            where = f"line {item.line}: " if item.line else ""
            lines.append(f"  {item.function:28s} {where}{item.says}")
    if not every:
        first = left[0]
        lines.append(f"Start with {first.function} in {package_name}/{first.path} (the list is in the course's order).")
        lines += [
            f"Its equation in the course notes (open in a browser): {notes.link(label)}"
            for label in notes.cited(first.says)[:1]
        ]
    return "\n".join(lines) + "\n"
