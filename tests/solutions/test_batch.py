"""The batch layer (``solutions.batch``) that sweeps and grading share: one rule for where tasks run, the same
results on every executor, each task taken once, resume from the caller's done keys, one progress bar on
stderr, atomic writes and one error type."""

from __future__ import annotations

import operator

import pytest

from solutions import batch
from solutions.batch import LOCAL, BatchError, Dask, Executor, Finished, Serial, cluster_for, executor, write_atomic

ITEMS = {f"k{n}": n for n in range(6)}


def _values(where: Executor, task=pow, shared=3, items=ITEMS) -> dict:
    return {f.key: f.value for f in batch.run(task, items, where, shared=shared, progress=False)}


@pytest.mark.parametrize(
    ("jobs", "cluster", "tasks", "where", "said"),
    [
        (1, None, None, None, "here"),
        (2, None, None, LOCAL, "on a local Dask cluster"),
        (2, None, 1, None, "here"),  # one task: here, whatever jobs says
        (1, LOCAL, 1, LOCAL, "on a local Dask cluster"),  # a cluster asked for is used
        (4, "tcp://10.0.0.1:8786", None, "tcp://10.0.0.1:8786", "on tcp://10.0.0.1:8786"),
    ],
)
def test_one_rule_says_where_a_batch_runs(jobs, cluster, tasks, where, said):
    assert cluster_for(jobs, cluster, tasks) == where
    assert batch.describe(where) == said
    chosen = executor(jobs, cluster, tasks=tasks)
    assert isinstance(chosen, Serial) if where is None else (isinstance(chosen, Dask) and chosen.cluster == where)


def test_executors_return_the_same_results(cluster):
    """Here, on a running scheduler and on a LocalCluster of its own; a task's error is its result."""
    address, _ = cluster
    expected = {key: 3**n for key, n in ITEMS.items()}
    with Serial() as here, Dask(address) as there, executor(2, tasks=len(ITEMS)) as local:
        assert isinstance(local, Dask) and local.cluster == LOCAL
        for where in (here, there, local):
            assert _values(where) == expected
            failed = list(batch.run(operator.truediv, {"zero": 0, "two": 2}, where, shared=1, progress=False))
            by_key = {f.key: f for f in failed}
            assert by_key["two"].value == 0.5 and by_key["two"].error is None
            assert isinstance(by_key["zero"].error, ZeroDivisionError)
            assert "ZeroDivisionError" in by_key["zero"].traceback
        assert local.local is not None  # started at the first task
    assert local.client is None and local.local is None  # ended on leaving


class Twice(Executor):
    """An executor that gives every task's result twice (as Dask may, after a worker died)."""

    def results(self, task, shared, items, name):
        for key, item in items.items():
            yield Finished(key, task(shared, item))
            yield Finished(key, task(shared, item))


def test_a_result_is_taken_once():
    keys = [f.key for f in batch.run(pow, ITEMS, Twice(), shared=2, progress=False)]
    assert sorted(keys) == sorted(ITEMS)


def test_resume_skips_the_done_items_and_the_bar_starts_there(capsys):
    ran = []

    def task(shared, item):
        ran.append(item)
        return item

    done = {"k1", "k4"}
    finished = [f.key for f in batch.run(task, ITEMS, Serial(), done=done, name="demo", unit="run")]
    assert sorted(finished) == sorted(set(ITEMS) - done) and sorted(ran) == [0, 2, 3, 5]
    bar = capsys.readouterr().err
    assert "demo" in bar and f"{len(done)}/{len(ITEMS)}" in bar and f"{len(ITEMS)}/{len(ITEMS)}" in bar
    list(batch.run(task, ITEMS, Serial(), progress=False))
    assert capsys.readouterr().err == ""


def test_write_atomic_leaves_no_partial_file(tmp_path):
    path = tmp_path / "deep" / "table.csv"
    write_atomic(path, "old\n")
    assert path.read_text() == "old\n"

    def half_then_fail(tmp):
        tmp.write_text("half")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        write_atomic(path, half_then_fail)
    assert path.read_text() == "old\n"
    assert [p.name for p in path.parent.iterdir()] == ["table.csv"]
    write_atomic(path, b"\x00bytes")
    assert path.read_bytes() == b"\x00bytes"
    write_atomic(path, "a lone surrogate \udcff")  # never stops a write
    assert path.read_text() == "a lone surrogate \\udcff"
    assert [p.name for p in path.parent.iterdir()] == ["table.csv"]


@pytest.mark.parametrize(
    ("jobs", "cluster", "message"),
    [
        (1, "nowhere", "--cluster nowhere: write 'local' or a scheduler address such as tcp://HOST:8786"),
        (2, "http://host:8786", "--cluster http://host:8786: write 'local'"),
        (0, None, "--jobs 0: must be a whole number >= 1"),
    ],
)
def test_a_bad_cluster_or_jobs_is_one_error_with_the_fix(jobs, cluster, message):
    with pytest.raises(BatchError, match=message.replace("(", r"\(").replace(".", r"\.")):
        executor(jobs, cluster)


def test_a_scheduler_that_does_not_answer_is_one_error():
    with Dask("tcp://127.0.0.1:9") as there, pytest.raises(BatchError, match="cannot reach the scheduler"):
        list(batch.run(pow, ITEMS, there, shared=2, progress=False))


def _shared_inputs(dask_scheduler) -> list[tuple[str, bool]]:
    """(key, whether the scheduler could make it again) of every input of the batch's tasks on the scheduler."""
    tasks = [ts for ts in dask_scheduler.tasks.values() if str(ts.key).startswith("batch-k")]
    return sorted({(str(d.key), d.run_spec is not None) for ts in tasks for d in ts.dependencies})


def test_the_shared_argument_is_a_task_the_scheduler_can_make_again(cluster):
    """The batch's shared argument reaches the workers as a task of the graph, not as data sent by ``scatter``:
    a worker killed with its only copy costs a recomputation, not every task waiting for it (cancelled, as
    test_sweep's killed-worker test once saw)."""
    address, client = cluster
    seen = []
    with Dask(address) as there:
        got = {}
        for finished in batch.run(pow, ITEMS, there, shared=3, progress=False):
            if not seen:  # the first result: the other tasks and their input are still on the scheduler
                seen.extend(client.run_on_scheduler(_shared_inputs))
            got[finished.key] = finished.value
    assert len(seen) == 1 and seen[0][1], seen
    assert got == {key: 3**n for key, n in ITEMS.items()}
