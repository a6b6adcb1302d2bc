"""The test run's durations (benchmarks/durations.py): per-file sums and, from the properties tests/conftest.py
records, where each pytest-xdist worker's wall time went, on a JUnit file written here with known numbers."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks import durations  # noqa: E402

JUNIT = """<?xml version="1.0" encoding="utf-8"?><testsuites name="pytest tests">
<testsuite name="pytest" tests="3" time="100.0" timestamp="2026-12-06T04:00:00+00:00">
<testcase classname="tests.solutions.test_a" name="test_one" time="30.0"><properties>
<property name="cpu" value="29.0"/><property name="started" value="{a}"/><property name="worker" value="gw0"/>
</properties></testcase>
<testcase classname="tests.solutions.test_a" name="test_two" time="50.0"><properties>
<property name="cpu" value="10.0"/><property name="started" value="{b}"/><property name="worker" value="gw0"/>
</properties></testcase>
<testcase classname="tests.course.test_b" name="test_three" time="70.0"><properties>
<property name="cpu" value="70.0"/><property name="started" value="{c}"/><property name="worker" value="gw1"/>
</properties></testcase>
</testsuite></testsuites>
"""
START = 1796529600.0  # 2026-12-06T04:00:00Z


def test_the_workers_table_says_where_each_workers_time_went(tmp_path):
    """gw0: first test at 10 s, 30 s busy, a 5 s gap, the next 50 s, done at 95 s of 100; gw1: from 12 s, 70 s."""
    junit = tmp_path / "junit.xml"
    junit.write_text(JUNIT.format(a=START + 10, b=START + 45, c=START + 12))
    times = durations.durations(str(junit))
    assert times["tests/solutions/test_a.py::test_one"] == 30.0
    assert durations.per_file(times)["tests/solutions/test_a.py"] == (80.0, 2)
    assert durations.suite_span(str(junit)) == (START, START + 100.0)
    started, worker = durations.properties(str(junit), "started"), durations.properties(str(junit), "worker")
    rows = durations.workers_table(times, started, worker, durations.suite_span(str(junit))).splitlines()
    assert rows[2] == "| gw0 | 10 | 80 | 5 | 5 | 2 |"
    assert rows[3] == "| gw1 | 12 | 70 | 0 | 18 | 1 |"


def test_a_run_without_the_properties_has_no_workers_table(tmp_path):
    junit = tmp_path / "junit.xml"
    junit.write_text(JUNIT.replace('<property name="started"', '<property name="other"').format(a=0, b=0, c=0))
    times = durations.durations(str(junit))
    started, worker = durations.properties(str(junit), "started"), durations.properties(str(junit), "worker")
    assert durations.workers_table(times, started, worker, durations.suite_span(str(junit))) == ""
