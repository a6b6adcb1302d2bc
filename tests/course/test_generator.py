"""The generator builds student packages from solutions/: round trip, per-homework stubs, malformed regions.

The expected text of a build is computed here independently of the generator (a line-by-line rule), and
functions are checked by replaying real calls recorded on the example models (see conftest.py).
"""

from __future__ import annotations

import ast
import importlib
import inspect
import math
import shutil
import textwrap

import numpy as np
import pytest

from course.release.generator import (
    BEGIN,
    END,
    HOMEWORKS,
    INSTRUCTOR_ONLY,
    REPO,
    RegionError,
    build_package,
    build_source,
    package_files,
    scan_regions,
    source_files,
)

SOLUTIONS = REPO / "solutions"
SLIDER_CRANK = REPO / "course" / "models" / "slider_crank.yaml"
SPATIAL_SLIDER_CRANK = REPO / "course" / "models" / "spatial_slider_crank.yaml"


def expected_text(text: str, regions, first_stubbed: int) -> str:
    """The build of one file by the rule of DESIGN section 2, written out line by line."""
    by_begin = {r.begin: r for r in regions}
    out, skip_to = [], None
    for number, line in enumerate(text.split("\n"), start=1):
        if skip_to is not None:
            if number == skip_to:
                skip_to = None
            continue
        region = by_begin.get(number)
        if region is None:
            if END in line:
                continue  # the end marker of a filled-in region
            out.append(line)
        elif region.homework < first_stubbed:
            continue  # the begin marker of a filled-in region
        else:
            indent = line[: len(line) - len(line.lstrip())]
            out.append(f"{indent}raise NotImplementedError({region.pointer!r})")
            skip_to = region.end
    return "\n".join(out)


def strip_header(text: str) -> str:
    return text.split("\n", 1)[1] if text.startswith("# ") else text


def slider_crank_closed_form(t: np.ndarray) -> np.ndarray:
    theta = 10.0 * t
    return 0.1 * np.cos(theta) + np.sqrt(0.3**2 - (0.1 * np.sin(theta)) ** 2)


def part(package, name: str):
    return importlib.import_module(f"{package.__name__}.{name}")


def run_slider_crank(package):
    model = part(package, "io.model").load_model(SLIDER_CRANK)
    system, q0, _ = part(package, "assembly").build_system(model)
    return part(package, "kinematics").kinematic_analysis(system, q0, 2 * math.pi / 10, 50)


@pytest.fixture(scope="module")
def builds(tmp_path_factory):
    """The package of every homework and the one with nothing stubbed, each built once."""
    root = tmp_path_factory.mktemp("builds")
    reports = {}
    for homework in (*HOMEWORKS, None):
        name = homework or "none"
        reports[name] = build_package(root / f"student_{name}", homework, header=None)
    return root, reports


# -- round trip ------------------------------------------------------------------------------------------


def test_build_with_no_stubs_is_solutions_without_markers(builds):
    root, _ = builds
    built = root / "student_none"
    assert source_files(built) == source_files(SOLUTIONS)
    for rel in source_files(SOLUTIONS):
        reference = (SOLUTIONS / rel).read_bytes()
        if rel.suffix == ".py":
            kept = [line for line in reference.decode().split("\n") if BEGIN not in line and END not in line]
            assert (built / rel).read_text() == "\n".join(kept), rel
        else:
            assert (built / rel).read_bytes() == reference, rel


def test_build_with_no_stubs_runs_as_the_reference(builds, regions, reference_calls, tools):
    root, _ = builds
    package = tools.load_package(root / "student_none", "student_none")
    for region in regions:
        arguments = reference_calls.get((region.path, region.function))
        if arguments is None:
            continue
        reference = tools.call(tools.resolve("solutions", region), arguments)
        built = tools.call(tools.resolve("student_none", region), arguments)
        assert tools.same(built, reference), f"{region.path}:{region.function}: {built} != {reference}"
    result = run_slider_crank(package)
    np.testing.assert_allclose(result.q[:, 6], slider_crank_closed_form(result.t), rtol=0, atol=1e-10)


def test_the_student_package_does_not_name_solutions(builds):
    """Every import is relative and no resource is looked up under the name 'solutions'."""
    root, _ = builds
    for rel in source_files(root / "student_none"):
        if rel.suffix != ".py":
            continue
        for node in ast.walk(ast.parse((root / "student_none" / rel).read_text())):
            if isinstance(node, ast.ImportFrom):
                assert node.level > 0 or not (node.module or "").startswith("solutions"), f"{rel}:{node.lineno}"
            elif isinstance(node, ast.Import):
                assert not any(a.name.startswith("solutions") for a in node.names), f"{rel}:{node.lineno}"
            elif isinstance(node, ast.Constant) and isinstance(node.value, str):
                assert node.value != "solutions" and not node.value.startswith("solutions."), f"{rel}:{node.lineno}"


def test_no_student_package_holds_the_instructor_only_parts(builds):
    """The compiled engine and the per-type (batched) forms are in solutions/ and in no build: not in any
    homework's package, nor in modules/; everything else of solutions/ is in every build."""
    root, _ = builds
    reference = {p.as_posix() for p in package_files(SOLUTIONS)}
    instructor = {f for f in reference for part in INSTRUCTOR_ONLY if f == part or f.startswith(f"{part}/")}
    assert {"planar/batched.py", "spatial/batched.py", "compiled/kernels.py"} <= instructor
    for folder in [root / f"student_{name}" for name in (*HOMEWORKS, "none")] + [REPO / "modules"]:
        assert {p.as_posix() for p in package_files(folder)} == reference - instructor, folder


@pytest.mark.parametrize(("homework", "scene"), [("hw2", SLIDER_CRANK), ("none", SPATIAL_SLIDER_CRANK)])
def test_a_student_system_evaluates_every_element_by_the_loop(builds, tools, homework, scene):
    """Without the batched forms a student's System (the per-type pass asked for, the default) evaluates the
    elements one by one, with no error, and gives the reference's arrays, which come from batched groups."""
    from solutions.assembly import build_system
    from solutions.io.model import load_model

    root, _ = builds
    package = tools.load_package(root / f"student_{homework}", f"student_{homework}")
    assert part(package, "assembly").batched_forms(2) is None and part(package, "assembly").batched_forms(3) is None
    system, q, qd = part(package, "assembly").build_system(part(package, "io.model").load_model(scene))
    assert system.vectorized and system.groups == []
    assert system._loop == list(range(len(system.elements)))
    reference, _, _ = build_system(load_model(scene))
    assert reference.groups, "the reference evaluates this scene by batched groups"
    t = 0.37
    for name, args in [("constraints", (q, t)), ("jacobian", (q, t)), ("psi_t", (q, t)), ("gamma", (q, qd, t))]:
        expected = getattr(reference, name)(*args)
        np.testing.assert_allclose(getattr(system, name)(*args), expected, rtol=1e-12, atol=1e-12, err_msg=name)


# -- per homework ----------------------------------------------------------------------------------------


def test_regions_exist_for_every_homework(regions):
    tags = {r.tag for r in regions}
    assert set(HOMEWORKS) <= tags, f"solution regions found only for {sorted(tags)}"


def test_every_region_points_to_its_function_and_an_equation(regions):
    for region in regions:
        assert region.pointer.startswith(f"{region.function}: "), region
        assert "see eq. " in region.pointer, f"{region.path}:{region.begin}: no 'eq.' in the docstrings of " + (
            f"{region.function} or its module"
        )


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_build_text_follows_the_rule(builds, homework):
    root, _ = builds
    first = HOMEWORKS.index(homework) + 1
    for rel in source_files(SOLUTIONS):
        if rel.suffix != ".py":
            continue
        text = (SOLUTIONS / rel).read_text()
        expected = expected_text(text, scan_regions(text, rel.as_posix()), first)
        assert (root / f"student_{homework}" / rel).read_text() == expected, rel


@pytest.mark.parametrize("homework", HOMEWORKS)
def test_build_stubs_exactly_the_right_functions(builds, regions, reference_calls, tools, homework):
    root, reports = builds
    name = f"student_{homework}"
    tools.load_package(root / name, name)
    first = HOMEWORKS.index(homework) + 1
    report = reports[homework]
    assert {(r.path, r.begin) for r in report.stubbed} == {(r.path, r.begin) for r in regions if r.homework >= first}
    assert {(r.path, r.begin) for r in report.filled} == {(r.path, r.begin) for r in regions if r.homework < first}
    replayed = 0
    for region in regions:
        reference, built = tools.resolve("solutions", region), tools.resolve(name, region)
        assert built is not None, f"{region.function} missing from the {homework} package"
        assert str(inspect.signature(built)) == str(inspect.signature(reference)), region.function
        assert inspect.getdoc(built) == inspect.getdoc(reference), region.function
        stubbed_here = any(
            r.homework >= first for r in regions if (r.path, r.function) == (region.path, region.function)
        )
        arguments = reference_calls.get((region.path, region.function))
        if stubbed_here:
            outcome = tools.call(built, arguments if arguments is not None else dict.fromkeys(_parameters(built)))
            assert outcome[0] == "raise" and isinstance(outcome[1], NotImplementedError), (region.function, outcome)
            assert str(outcome[1]).startswith(f"{region.function}: "), str(outcome[1])
            assert str(outcome[1]) in {r.pointer for r in regions if r.function == region.function}
        elif arguments is not None:
            expected = tools.call(reference, arguments)
            got = tools.call(built, arguments)
            assert tools.same(got, expected), f"{homework}: {region.function} differs from the reference"
            replayed += 1
    if first > 1:
        assert replayed > 0, "no filled-in function was exercised by the example models"


def _parameters(func) -> list[str]:
    code = func.__code__
    return list(code.co_varnames[: code.co_argcount + code.co_kwonlyargcount])


def test_hw2_package_runs_hw1_and_stops_at_hw2(builds, tools):
    root, _ = builds
    package = tools.load_package(root / "student_hw2", "student_hw2")
    reference = tools.load_package(root / "student_none", "student_none")
    result, expected = run_slider_crank(package), run_slider_crank(reference)
    np.testing.assert_array_equal(result.q, expected.q)
    np.testing.assert_array_equal(result.qdd, expected.qdd)
    np.testing.assert_allclose(result.q[:, 6], slider_crank_closed_form(result.t), rtol=0, atol=1e-10)
    with pytest.raises(NotImplementedError, match=r"^mass_matrix: .*see eq\. "):
        part(package, "mass_matrix").mass_matrix(part(package, "io.model").load_model(SLIDER_CRANK))


def test_hw1_package_stops_at_the_first_kinematics_function(builds, tools):
    root, _ = builds
    package = tools.load_package(root / "student_hw1", "student_hw1")
    with pytest.raises(NotImplementedError, match=r"^\w+(\.\w+)*: .*see eq\. "):
        run_slider_crank(package)


# -- malformed regions ----------------------------------------------------------------------------------

GOOD = '''\
"""A module (eq. 1.1)."""


def area(r: float) -> float:
    """Area of a disc, pi r^2 (eq. 1.2)."""
    ### BEGIN SOLUTION hw1
    return 3.14159 * r * r
    ### END SOLUTION
'''


@pytest.mark.parametrize(
    ("source", "line", "message"),
    [
        (GOOD.replace("    return 3.14159", "    ### BEGIN SOLUTION hw2\n    return 3.14159"), 7, "nested"),
        (GOOD.replace("    ### END SOLUTION\n", ""), 6, "unterminated"),
        (GOOD.replace("SOLUTION hw1", "SOLUTION"), 6, "mistagged"),
        (GOOD.replace("SOLUTION hw1", "SOLUTION hw 1"), 6, "mistagged"),
        (GOOD.replace("SOLUTION hw1", "SOLUTION hw9"), 6, "unknown homework tag 'hw9'"),
        (GOOD.replace("### END SOLUTION", "### END SOLUTION hw2"), 8, "mistagged end"),
        (GOOD.replace("    ### BEGIN SOLUTION hw1\n", ""), 7, "without a"),
        (GOOD.replace("    return 3.14159 * r * r\n", ""), 6, "empty"),
        (GOOD + "\n### BEGIN SOLUTION hw1\nPI = 3.14159\n### END SOLUTION\n", 10, "outside a function"),
    ],
    ids=["nested", "unterminated", "untagged", "bad-tag", "unknown-tag", "end-tag", "unopened", "empty", "module"],
)
def test_malformed_regions_name_file_and_line(source, line, message):
    with pytest.raises(RegionError, match=message) as caught:
        build_source(source, "pkg/geometry.py", "hw1")
    assert str(caught.value).startswith(f"pkg/geometry.py:{line}: "), str(caught.value)


def test_a_malformed_region_stops_the_whole_build(tmp_path):
    source = tmp_path / "reference"
    (source / "pkg").mkdir(parents=True)
    (source / "__init__.py").write_text("")
    (source / "pkg" / "__init__.py").write_text("")
    (source / "pkg" / "geometry.py").write_text(GOOD.replace("    ### END SOLUTION\n", ""))
    with pytest.raises(RegionError, match=r"^pkg/geometry\.py:6: unterminated"):
        build_package(tmp_path / "out", "hw1", source)
    assert not (tmp_path / "out").exists()


def test_stub_keeps_code_around_a_partial_region(tmp_path):
    """A region that is part of a body: the code before and after it stays, the stub sits in its place."""
    text = textwrap.dedent(
        '''\
        class Disc:
            """A disc (eq. 1.3)."""

            def mass(self, density: float) -> float:
                area = 0.0
                ### BEGIN SOLUTION hw2
                area = 3.14159 * self.r**2
                ### END SOLUTION
                return density * area
        '''
    )
    built, stubbed, filled = build_source(text, "disc.py", "hw2")
    assert not filled and [r.function for r in stubbed] == ["Disc.mass"]
    assert "        area = 0.0\n        raise NotImplementedError('Disc.mass: mass() (A disc), see eq. 1.3')\n" in built
    assert built.endswith("        return density * area\n")
    given, stubbed, filled = build_source(text, "disc.py", "hw3")
    assert not stubbed and "area = 3.14159 * self.r**2" in given and BEGIN not in given


def test_generator_command_line(tmp_path, capsys):
    from course.release.generator import main

    assert main(["--homework", "hw2", str(tmp_path / "p")]) == 0
    assert "functions stubbed" in capsys.readouterr().out
    broken = tmp_path / "broken"
    shutil.copytree(SOLUTIONS, broken, ignore=shutil.ignore_patterns("__pycache__"))
    kinematics = broken / "kinematics.py"
    kinematics.write_text(kinematics.read_text().replace(END, "", 1))
    assert main(["--source", str(broken), str(tmp_path / "q")]) == 2
    assert "kinematics.py:" in capsys.readouterr().err


def test_a_build_replaces_only_a_generated_folder(tmp_path):
    with pytest.raises(ValueError, match="over"):
        build_package(SOLUTIONS, "hw1")
    handwritten = tmp_path / "modules"
    handwritten.mkdir()
    (handwritten / "mine.py").write_text("x = 1\n")
    with pytest.raises(ValueError, match="mine.py was not generated"):
        build_package(handwritten, "hw1")
    assert (handwritten / "mine.py").read_text() == "x = 1\n"
    (handwritten / "mine.py").unlink()
    build_package(handwritten, "hw2")
    build_package(handwritten, "hw1")  # a generated folder is replaced
    assert not (handwritten / "mine.py").exists() and (handwritten / "kinematics.py").is_file()


@pytest.mark.parametrize("homework", ["hw1", "hw3"])
def test_each_file_says_whether_the_student_writes_in_it(tmp_path, homework):
    """A file with a function to write says where; a file with none says there is nothing to write in it."""
    build_package(tmp_path / "modules", homework)
    said = {"write": 0, "nothing": 0}
    for path in (tmp_path / "modules").rglob("*.py"):
        first, text = path.read_text().split("\n", 1)
        to_write = "raise NotImplementedError(" in text
        assert ("write your code where a function raises NotImplementedError" in first) == to_write, path
        assert ("nothing to write in this file" in first) == (not to_write), path
        said["write" if to_write else "nothing"] += 1
    assert said["write"] and said["nothing"]
