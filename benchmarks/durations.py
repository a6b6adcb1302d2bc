"""Per-file and per-test durations of a test run, from pytest's JUnit XML, as the Markdown table of
benchmarks/results/tests.md.

    python -m pytest -n 2 --dist loadfile --no-loadscope-reorder --durations=0 --junitxml=build/junit.xml
    python benchmarks/durations.py build/junit.xml --wall SECONDS --note "load ..." >> benchmarks/results/tests.md

A file's time is the sum of its tests' (setup, call and teardown: JUnit's ``time``), which is the time it holds
one pytest-xdist worker: a file longer than the run's wall time divided by the workers is a unit too long to
balance (split it into files, as the nbgrader cycle is: tests/course/test_nbgrader_cycle_hwN.py).

Where tests/conftest.py recorded when each test started and on which worker (the properties ``started`` and
``worker``), a table per worker says where the run's wall time went: the start (pytest and the workers started,
the tests collected) before the worker's first test, the sum of its tests' times, the gaps between them, and the
time it sat done before the run ended (the last unit on the other worker).
"""

from __future__ import annotations

import argparse
import datetime
import xml.etree.ElementTree as ET
from collections import defaultdict


def durations(junit: str, what: str = "time") -> dict[str, float]:
    """Seconds per test (``file::name``), from the JUnit XML file: wall (``time``) or CPU (``cpu``: the property
    tests/conftest.py records: the CPU seconds of the worker and all it started, sandboxes too, where the worker
    has a cpuacct group of its own, else of the worker and its waited children)."""
    times = {}
    for test, case in _cases(junit):
        if what == "time":
            value = case.get("time", 0.0)
        else:
            value = next((p.get("value") for p in case.iter("property") if p.get("name") == what), 0.0)
        times[test] = float(value)
    return times


def properties(junit: str, name: str) -> dict[str, str]:
    """The property ``name`` of each test (``file::name``) that has it, from the JUnit XML file."""
    found = {}
    for test, case in _cases(junit):
        value = next((p.get("value") for p in case.iter("property") if p.get("name") == name), None)
        if value is not None:
            found[test] = value
    return found


def _cases(junit: str):
    """(``file::name``, the testcase element) of each test of the JUnit XML file."""
    for case in ET.parse(junit).getroot().iter("testcase"):
        module = case.get("classname", "").split(".")
        where = "/".join(part for part in module if not part[:1].isupper()) + ".py"
        yield f"{where}::{case.get('name')}", case


def suite_span(junit: str) -> tuple[float, float] | None:
    """(start, end) of the run in seconds since the epoch: the test suite's ``timestamp`` and ``time``."""
    suite = ET.parse(junit).getroot()
    suite = suite if suite.tag == "testsuite" else suite.find("testsuite")
    if suite is None or suite.get("timestamp") is None:
        return None
    start = datetime.datetime.fromisoformat(suite.get("timestamp"))
    if start.tzinfo is None:
        start = start.astimezone()  # pytest writes the local time without its zone
    return start.timestamp(), start.timestamp() + float(suite.get("time", 0.0))


def workers_table(times: dict[str, float], started: dict[str, str], worker: dict[str, str], span) -> str:
    """Per worker: seconds from the run's start to its first test, busy (its tests' times), idle between its
    tests, done before the run ended, and its number of tests (module docstring)."""
    if not started or span is None:
        return ""
    start, end = span
    lines = ["| worker | start-up s | busy s | gaps s | done before the end s | tests |"]
    lines.append("|---|---:|---:|---:|---:|---:|")
    for name in sorted(set(worker.values())):
        tests = sorted((float(started[t]), times[t]) for t in started if worker.get(t) == name and t in times)
        first, last = tests[0][0], max(t + d for t, d in tests)
        busy = sum(d for _, d in tests)
        gaps = last - first - busy
        lines.append(f"| {name} | {first - start:.0f} | {busy:.0f} | {gaps:.0f} | {end - last:.0f} | {len(tests)} |")
    return "\n".join(lines) + "\n"


def per_file(times: dict[str, float]) -> dict[str, tuple[float, int]]:
    """(seconds, tests) per test file."""
    files: dict[str, list[float]] = defaultdict(list)
    for test, seconds in times.items():
        files[test.split("::")[0]].append(seconds)
    return {name: (sum(values), len(values)) for name, values in files.items()}


def table(times: dict[str, float], wall: float | None, note: str, slowest: int = 30, cpu=None) -> str:
    """The Markdown section: totals, the slowest files, the slowest tests (with their CPU seconds when given)."""
    files, cpu = per_file(times), cpu or {}
    cpu_files = per_file(cpu)
    total = sum(times.values())
    lines = [f"## {datetime.date.today().isoformat()}: {len(times)} tests, {len(files)} files", ""]
    if wall is not None:
        lines.append(f"- wall time {wall:.0f} s ({wall / 60:.1f} min)")
    lines.append(f"- sum of the tests' times {total:.0f} s ({total / 60:.1f} min of worker time)")
    if cpu:
        lines.append(f"- CPU of the tests and what they started {sum(cpu.values()):.0f} s (tests/conftest.py)")
    lines += [f"- {note}", ""]
    lines += ["| file | seconds | CPU s | tests |", "|---|---:|---:|---:|"]
    for name, (seconds, count) in sorted(files.items(), key=lambda kv: -kv[1][0])[:slowest]:
        lines.append(f"| {name} | {seconds:.1f} | {cpu_files.get(name, (0.0, 0))[0]:.1f} | {count} |")
    lines += ["", "| test | seconds | CPU s |", "|---|---:|---:|"]
    for name, seconds in sorted(times.items(), key=lambda kv: -kv[1])[:slowest]:
        lines.append(f"| {name} | {seconds:.1f} | {cpu.get(name, 0.0):.1f} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("junit", help="pytest's --junitxml file")
    parser.add_argument("--wall", type=float, default=None, help="the run's wall time, seconds")
    parser.add_argument("--note", default="", help="the command, the machine and its load")
    parser.add_argument("--slowest", type=int, default=30)
    args = parser.parse_args()
    times = durations(args.junit)
    print(table(times, args.wall, args.note, args.slowest, durations(args.junit, "cpu")))
    started, worker = properties(args.junit, "started"), properties(args.junit, "worker")
    print(workers_table(times, started, worker, suite_span(args.junit)))


if __name__ == "__main__":
    main()
