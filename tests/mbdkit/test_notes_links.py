"""A kit's checker cites the notes' equations as links into the kit's notes/ and shows them rendered
(mbdkit/notes.py); the data it reads is what mbd release writes (course.release.kit.equations_of_the_notes)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from course.notes import chapters, equation_labels
from course.release.kit import equations_of_the_notes
from mbdkit import api, notes


@pytest.fixture
def kit(tmp_path, monkeypatch):
    """A kit's folder: notes/ with chapter 3's page, and the checker's data with the notes' equations."""
    data = tmp_path / "site-packages" / "mbdkit" / "data"
    data.mkdir(parents=True)
    (data / "equations.json").write_text(json.dumps(equations_of_the_notes()))
    (tmp_path / "kit" / "notes").mkdir(parents=True)
    (tmp_path / "kit" / "notes" / "ch03_planar_constraints.html").write_text("<html></html>")
    monkeypatch.setattr(notes, "data_dir", lambda: data)
    notes.equations.cache_clear()
    yield tmp_path / "kit"
    notes.equations.cache_clear()


def test_the_kits_equations_are_every_labelled_equation_of_the_notes_as_tex():
    equations = equations_of_the_notes()
    labels = [label for path in chapters() for label in equation_labels(path)]
    assert sorted(equations) == sorted(labels) and len(labels) > 150
    page, tex = equations["3.17"]
    assert page == "ch03_planar_constraints.html" and tex.startswith("\\begin{aligned} \\Psi &= r_i + A_i s_i'")
    assert all(tex and "\\tag" not in tex and "$$" not in tex for _, tex in equations.values())


def test_a_message_cites_its_equations_once_each_in_order(kit):
    text = "wrong sign (see eq. 3.17); eqs. 4.5, 4.6 and eq. 2.1-2.5; again eq. 3.17; eq. 99.1 is no equation"
    assert notes.cited(text) == ["3.17", "4.5", "4.6", "2.1", "2.5"]
    assert notes.link("3.17") == "notes/ch03_planar_constraints.html#eq-3.17"


def test_a_failed_check_shows_each_cited_equation_rendered_with_its_link(kit):
    shown = notes.markdown("the Jacobian of a revolute joint is wrong, see eq. 3.17", kit)
    assert "[eq. 3.17](notes/ch03_planar_constraints.html#eq-3.17): $$ \\begin{aligned} \\Psi &=" in shown
    assert shown.count("$$") == 2 and "\\tag{3.17} $$" in shown
    assert notes.markdown("nothing cited", kit) is None
    assert notes.markdown("see eq. 3.17", kit.parent) is None  # no notes beside the package: no links to nowhere


def test_a_terminal_gets_a_file_url_of_the_page_at_the_equation(kit):
    (line,) = notes.terminal_lines("see eq. 3.17", kit)
    url = line.split(": ", 1)[1]
    assert url == (kit / "notes" / "ch03_planar_constraints.html").resolve().as_uri() + "#eq-3.17"


def test_check_displays_the_equations_in_a_notebook(kit, monkeypatch):
    """In a notebook, check() shows the cited equations as Markdown (JupyterLab renders the math) before its
    AssertionError; outside one, nothing."""
    import IPython
    import IPython.display

    shown = []
    monkeypatch.setattr(IPython, "get_ipython", lambda: SimpleNamespace())
    monkeypatch.setattr(IPython.display, "display", lambda obj: shown.append(obj.data))
    api.show_equations("- revolute: the Jacobian, see eq. 3.17", kit)
    assert len(shown) == 1 and "notes/ch03_planar_constraints.html#eq-3.17" in shown[0]
    monkeypatch.setattr(IPython, "get_ipython", lambda: None)
    api.show_equations("- revolute: the Jacobian, see eq. 3.17", kit)
    assert len(shown) == 1 and "IPython" in sys.modules


def test_todo_points_at_the_first_functions_equation(kit):
    from mbdkit.todo import Left, report

    left = [Left("planar/bodies.py", "rotation", 21, "rotation: A(phi), see eq. 3.17")]
    text = report("hw1", "modules", [("planar/bodies.py", "rotation")], left)
    assert text.splitlines()[-1] == (
        "Its equation in the course notes (open in a browser): notes/ch03_planar_constraints.html#eq-3.17"
    )
    assert Path(kit / text.splitlines()[-1].split(": ")[1].split("#")[0]).exists()


def test_a_feedback_page_links_each_equation_into_the_kits_notes():
    """mbd grade's page (autograder/feedback.py): an 'eq. N.M' of a message is a link to notes/chNN_*.html#eq-N.M,
    the kit's notes beside the page; the labels come from the course's chapters where no kit data is."""
    from autograder.feedback import _row

    row = _row("four_bar", False, 0, 2, "rotation: A(phi) <wrong>, see eq. 2.2; and eq. 99.9")
    assert 'see eq. <a href="notes/ch02_planar_body_kinematics.html#eq-2.2">2.2</a>; and eq. 99.9' in row
    assert "&lt;wrong&gt;" in row
