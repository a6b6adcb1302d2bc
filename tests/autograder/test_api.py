"""The notebook API: public checks with the grader's messages, nothing on stderr."""

from __future__ import annotations

import numpy as np
import pytest

from autograder.api import GraderPoints, SandboxedExecute, SaveGraderPoints, autograde_steps, check_call
from autograder.cli import grade_command
from mbdkit.api import GRADED_OUTSIDE, check, selfcheck
from mbdkit.cli import selfcheck_command


@pytest.fixture(scope="module")
def students(make_submissions):
    return make_submissions("api", {"good": "reference", "bad": "gamma_sign", "empty": "skeleton"}, "hw1")


def test_check_passes_quietly(students, capfd):
    check("hw1", "revolute", students / "good")
    out, err = capfd.readouterr()
    assert err == "" and "hw1 revolute: all" in out


def test_check_raises_with_the_graders_message(students, capfd):
    with pytest.raises(AssertionError) as failure:
        check("hw1", "revolute", students / "bad" / "modules")
    message = str(failure.value)
    assert "four_bar.gamma.revolute" in message and "a sign error" in message
    assert "four_bar.jacobian.revolute" not in message
    assert capfd.readouterr().err == ""


def test_unknown_group(students):
    with pytest.raises(ValueError, match="groups: "):
        check("hw1", "no-such-group", students / "good")


def test_selfcheck_reports_every_public_check(students, capsys):
    assert selfcheck("hw1", students / "empty") == 1
    report = capsys.readouterr().out
    assert "FAIL four_bar.constraints.revolute" in report and "hidden" not in report.split("\n\n")[0]
    assert selfcheck_command("hw9", students / "good") == 2


def test_grade_command_user_errors(tmp_path, capsys):
    assert grade_command("hw9", tmp_path) == 2
    assert grade_command("hw1", tmp_path / "missing", tmp_path / "out") == 2
    err = capsys.readouterr().err
    assert "no folder" in err and err.startswith("mbd: error:")
    assert not (tmp_path / "out").exists()  # a refused run leaves nothing behind


def test_selfcheck_of_a_missing_folder_says_so_once(tmp_path, capsys):
    assert selfcheck_command("hw1", tmp_path / "no-such-folder") == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.startswith("mbd: error: no folder")
    (tmp_path / "empty").mkdir()
    assert selfcheck_command("hw1", tmp_path / "empty") == 2
    assert "no package modules/" in capsys.readouterr().err


def test_while_nbgrader_autogrades_check_grades_nothing(tmp_path, monkeypatch, capfd):
    monkeypatch.setenv("NBGRADER_EXECUTION", "autograde")
    assert check("hw1", "revolute", tmp_path / "no-package-here") is None  # needs no package, no grader
    assert selfcheck("hw1", tmp_path / "no-package-here") == 0
    out, err = capfd.readouterr()
    assert out == GRADED_OUTSIDE.format(what="hw1 revolute") + "\n" + GRADED_OUTSIDE.format(what="hw1") + "\n"
    assert err == ""


def test_a_test_cell_names_its_group_by_one_call():
    assert check_call('# Graded: the revolute joint.\ncheck("hw1", "revolute")') == ("hw1", "revolute")
    assert check_call("mbdkit.check('hw2', 'rk4')") == ("hw2", "rk4")
    for source in (
        "check(homework, 'rk4')",
        "check('hw1', 'a'); check('hw1', 'b')",
        "check('hw1')",
        "assert x",
        "check(",
    ):
        assert check_call(source) is None, source


def test_nbgraders_steps_run_the_notebook_in_the_sandbox_and_take_the_points_from_the_grader():
    from nbgrader.converters.autograde import Autograde
    from nbgrader.preprocessors import Execute, SaveAutoGrades

    default = Autograde.class_traits()["autograde_preprocessors"].default()
    steps = autograde_steps(default)
    assert Execute not in steps and steps.index(SandboxedExecute) == default.index(Execute)
    saved = steps.index(SaveAutoGrades)
    assert steps[saved - 1] is GraderPoints and steps[saved + 1] is SaveGraderPoints


def test_a_notebook_runs_each_request_once_while_its_package_is_unchanged(students, tmp_path, monkeypatch, capsys):
    """A notebook's graded cells, then its selfcheck: a request met before on the same package is answered from
    the process's store (none of the student's code run) with the same outcome, the others in the one child kept
    running between cells; an edited file (a changed gamma) runs again in a new child, and says so."""
    import shutil

    from mbdkit import api
    from mbdkit.sandbox import Sandbox

    run, start = Sandbox._request, Sandbox._start
    requests: list[str] = []
    starts: list[int] = []

    def counted(self, probe, key, *args):
        requests.append(f"{probe} {key}")
        return run(self, probe, key, *args)

    def started(self):
        starts.append(1)
        return start(self)

    monkeypatch.setattr(Sandbox, "_request", counted)
    monkeypatch.setattr(Sandbox, "_start", started)
    folder = tmp_path / "student"
    shutil.copytree(students / "good", folder)
    check("hw1", "revolute", folder)
    first = len(requests)
    assert first > 0
    check("hw1", "revolute", folder)
    assert len(requests) == first, "the same cell again: nothing runs"
    assert selfcheck("hw1", folder) == 0
    every = len(requests)
    assert every > first and len(set(requests)) == every, "each request of the selfcheck runs once"
    assert selfcheck("hw1", folder) == 0 and len(requests) == every
    assert len(starts) == 1, "one child answered every cell"
    report = capsys.readouterr().out
    # the file the bad student got wrong, pasted into this package: its checks run again and fail
    shutil.copy(students / "bad" / "modules" / "planar" / "joints.py", folder / "modules" / "planar" / "joints.py")
    assert selfcheck("hw1", folder) == 1
    assert len(requests) == 2 * every, "every request runs again on the changed package"
    assert len(starts) == 2, "in a new child, which imported the changed file"
    assert "FAIL four_bar.gamma.revolute" in capsys.readouterr().out and "FAIL" not in report
    assert api._REMEMBERED[folder.resolve()][0] == api.package_digest(folder / "modules"), "kept for what it is now"


def test_timeouts_and_crashes_are_not_kept():
    from mbdkit.sandbox import Replies, Reply

    replies = Replies()
    request = Replies.key("newton", "four_bar#1", {"model": {}}, {"q": np.zeros(3)}, {})
    assert request != Replies.key("newton", "four_bar#1", {"model": {}}, {"q": np.ones(3)}, {})
    for status in ("timeout", "died", "malformed", "cpu"):
        replies.keep(request, Reply(status))
        assert replies.get(request) is None, status
    replies.keep(request, Reply("error", error={"type": "NotImplementedError"}))
    kept = replies.get(request)
    assert kept.status == "error" and kept is not replies.get(request)  # a copy each time
