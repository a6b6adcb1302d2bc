"""Grading on Dask: ``grade(..., cluster="local" | "tcp://HOST:PORT")`` (``mbd grade --cluster``).

Each submission is one Dask task. A worker grades it exactly as a process-pool worker does: it is set up
like one (``grading.worker_init``: one BLAS thread for its sandboxes, SIGKILL when its parent process
dies), and it runs the student's code in the same sandbox per submission (bubblewrap, or the unsafe local
sandbox when asked), which never imports the reference package. The worker returns the result and the
feedback page; only the client writes them (atomically, as each arrives) and the gradebook, so a stopped
run resumes from the results it has (``grade``'s fingerprints) and loses nothing.

A task whose worker dies (killed, out of memory) is run again on another worker by Dask; a result is
taken once per student, so nothing is counted twice. On a cluster of several machines every worker must
see the submissions folder at the same path (a shared file system) and have bubblewrap, the course
repository (or the installed ``mbd-course``) and its stored references.

After a SIGKILL of the client (``mbd grade``) on a LocalCluster no process is left: its nannies are objects
in the client's own process (distributed's ``LocalCluster``; no nanny process of their own), so each worker
is the client's child, which the kernel kills with it (``PR_SET_PDEATHSIG``, set by ``setup_worker``; Dask's
``AsyncProcess`` also ends a worker whose parent's pipe closes), and each sandbox dies with its worker
(bubblewrap's ``--die-with-parent``). A nanny plugin setting the signal would set it in the client itself
(killing the grader with its shell), so there is none. Workers of a scheduler started by hand are not the
client's to end: they finish their current task (within its time limit) and wait for the next client.
"""

from __future__ import annotations

import os
import traceback
from pathlib import Path

from mbdkit.homework import Homework
from mbdkit.sandbox import Limits, without_main
from solutions.sweep import SweepError, check_cluster, open_client, progress_bar

from .grading import Gradebook, Submission, grade_one, internal_error, worker_init, write_graded


class ClusterError(RuntimeError):
    """A cluster that cannot be used (a bad address, a scheduler that does not answer, no Dask)."""


def setup_worker() -> None:
    """In every Dask worker (also one that replaces a worker that died): as ``grading.worker_init``."""
    worker_init(os.getppid())


def grade_remote(
    homework: Homework, submission: Submission, limits: Limits, forbidden: tuple, isolation: str
) -> tuple[str, dict, str, str, float]:
    """On a worker: grade one submission; returns (student, result JSON, feedback HTML, log of an internal
    error or '', seconds), writing nothing (``grading.grade_one``: it never raises for the submission)."""
    return submission.student, *grade_one(homework, submission, limits, forbidden, isolation)


def grade_on_cluster(
    homework: Homework,
    todo: list[Submission],
    book: Gradebook,
    out_dir: Path,
    limits: Limits,
    forbidden: tuple,
    isolation: str,
    cluster: str,
    jobs: int,
    progress: bool = True,
    done: int = 0,
) -> Gradebook:
    """Grade the submissions ``todo`` on Dask, adding their rows to ``book`` (written after each one).

    ``cluster``: 'local' (a LocalCluster of ``jobs`` worker processes) or a scheduler address.
    ``done``: submissions already in ``book`` (resumed), for the progress bar.

    Raises
    ------
    ClusterError
        If the cluster cannot be used. A task that fails on every retry (its workers killed) is that
        student's internal error (``grading.internal_error``), graded again on the next run.
    """
    try:
        check_cluster(cluster)
    except SweepError as err:
        raise ClusterError(str(err)) from None
    total = done + len(todo)
    with progress_bar(total, f"grading {homework.name}", progress and total > 0, done, "student") as bar:
        if not todo:
            return book
        from dask.distributed import as_completed

        worker_init()  # LocalCluster workers inherit one BLAS thread from here
        try:
            with without_main(), open_client(cluster, jobs, setup_worker) as client:
                futures = [
                    client.submit(
                        grade_remote,
                        homework,
                        submission,
                        limits,
                        forbidden,
                        isolation,
                        key=f"grade-{homework.name}-{submission.student}",
                        pure=False,
                    )
                    for submission in todo
                ]
                students = {future.key: submission.student for future, submission in zip(futures, todo, strict=True)}
                for future in as_completed(futures):
                    try:
                        student, result, page, log, seconds = future.result()
                    except Exception as err:  # noqa: BLE001 - its workers died on every retry (KilledWorker)
                        student = students[future.key]
                        log = f"{student}: the task failed on the cluster\n{traceback.format_exc()}"
                        result, page = internal_error(homework, student, type(err).__name__, isolation)
                        seconds = None
                    if student in book.rows:  # counted once, whatever Dask ran twice
                        continue
                    book.rows[student] = write_graded(out_dir, student, result, page, log, seconds)
                    book.write_csv()
                    bar.update(1)
        except SweepError as err:
            raise ClusterError(str(err)) from None
    return book
