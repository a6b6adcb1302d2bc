# Generated from solutions/batch.py by `make modules` (every homework stubbed): do not edit by hand.
"""Batches of independent tasks, here or on Dask: the runs of a sweep (``mbd sweep``), the submissions of a
class (``mbd grade``).

Where the tasks run is one rule (``cluster_for``), the same from Python and from the command line::

    cluster None, jobs 1 (or one task)    here, one task after another                (``Serial``)
    cluster None, jobs N > 1              a Dask LocalCluster of N worker processes    (``Dask``)
    cluster 'local'                       the same
    cluster 'tcp://HOST:PORT'             the workers of a Dask scheduler already running

A LocalCluster has one single-threaded worker process per job (never more than there are tasks). Dask, not a
process pool, runs every parallel batch: a task whose worker dies (killed, out of memory) runs again on
another worker, where a pool would fail every task still queued.

Only this process (the client) writes files: each task returns its result, ``run`` hands it to the caller
once (a task that Dask ran twice, its first worker dying after the result came back, is taken once), and the
caller writes it at once, atomically (``write_atomic``), so a stopped batch resumes from what it wrote: the
caller says which tasks are done (``done``: the keys whose stored result has the right fingerprint).

Kill semantics. After a SIGKILL of the client no worker of its LocalCluster is left: the nannies are objects
in the client's own process (distributed's ``LocalCluster``; no nanny process of their own), so each worker
is the client's child, which the kernel kills with it (``PR_SET_PDEATHSIG``, set in every worker by
``die_with_parent``; Dask's ``AsyncProcess`` also ends a worker whose parent's pipe closes). A nanny plugin
setting the signal would set it in the client itself (killing it with its shell), so the worker sets it. The
workers of a scheduler started by hand are not the client's to end: they finish their current task and wait
for the next client. Ctrl-C in the client closes its LocalCluster, which ends the workers.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import sys
import traceback
import uuid
from collections.abc import Callable, Collection, Hashable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

LOCAL = "local"
"""``cluster`` naming a LocalCluster started (and ended) by the batch."""
ADDRESS = re.compile(r"(tcp|tls|inproc|ucx|ws|wss)://\S+")


class BatchError(RuntimeError):
    """A batch that cannot start: a bad cluster address, a scheduler that does not answer, no Dask."""


# -- where tasks run --------------------------------------------------------------------------------------------
def check_cluster(cluster: str | None) -> None:
    """Refuse a ``cluster`` that is neither None, 'local' nor a scheduler address (``BatchError``)."""
    if cluster not in (None, LOCAL) and not ADDRESS.fullmatch(str(cluster)):
        raise BatchError(f"--cluster {cluster}: write 'local' or a scheduler address such as tcp://HOST:8786")


def cluster_for(jobs: int = 1, cluster: str | None = None, tasks: int | None = None) -> str | None:
    """The one rule: None (here) for ``jobs`` 1 or at most one of ``tasks`` without a ``cluster``; else the
    Dask cluster the batch runs on: ``cluster`` ('local' or a scheduler address), by default 'local'.

    Raises
    ------
    BatchError
        For ``jobs`` < 1 or a ``cluster`` that is neither 'local' nor an address.
    """
    check_cluster(cluster)
    if jobs < 1:
        raise BatchError(f"--jobs {jobs}: must be a whole number >= 1")
    if cluster is None and (jobs == 1 or (tasks is not None and tasks <= 1)):
        return None
    return cluster or LOCAL


def describe(cluster: str | None) -> str:
    """'here', 'on a local Dask cluster' or 'on tcp://HOST:PORT' (a ``cluster_for`` answer)."""
    if cluster is None:
        return "here"
    return "on a local Dask cluster" if cluster == LOCAL else f"on {cluster}"


@dataclass(frozen=True)
class Finished:
    """One task's end: its key and what it returned, or the error it raised (for a Dask task whose workers all
    died: ``KilledWorker``)."""

    key: Hashable
    value: Any = None
    error: BaseException | None = None

    @property
    def traceback(self) -> str:
        """The error's traceback ('' for a task that returned)."""
        return "" if self.error is None else "".join(traceback.format_exception(self.error))


class Executor:
    """Runs ``task(shared, item)`` for each item and yields a ``Finished`` per task as it ends, in any order;
    a task may end twice (``run`` takes it once). Used as a context manager: workers, if any, are started at
    the first task and ended on leaving it."""

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """End the workers (nothing to end here)."""

    def results(self, task: Callable, shared: Any, items: Mapping[Hashable, Any], name: str) -> Iterator[Finished]:
        raise NotImplementedError


class Serial(Executor):
    """Each task in this process, one after another."""

    def results(self, task: Callable, shared: Any, items: Mapping[Hashable, Any], name: str) -> Iterator[Finished]:
        for key, item in items.items():
            try:
                finished = Finished(key, task(shared, item))
            except Exception as err:  # noqa: BLE001 - a task's error is its result, as on Dask
                finished = Finished(key, error=err)
            yield finished


class Dask(Executor):
    """Tasks on Dask: a LocalCluster of ``jobs`` single-threaded worker processes (``cluster`` 'local') or the
    scheduler at ``cluster``; ``setup`` runs in every worker, also in one that replaces a worker that died."""

    def __init__(self, cluster: str, jobs: int = 1, setup: Callable[[], None] | None = None):
        self.cluster, self.jobs, self.setup = cluster, jobs, setup
        self.client = self.local = None

    def start(self) -> None:
        """Start the LocalCluster or reach the scheduler, and set up its workers (``BatchError`` if not)."""
        import logging

        try:
            from dask.distributed import Client, LocalCluster
        except ImportError:
            raise BatchError("a cluster needs Dask: pip install 'dask[distributed]'") from None
        if self.cluster == LOCAL:
            self.local = LocalCluster(
                n_workers=self.jobs,
                threads_per_worker=1,
                processes=True,
                memory_limit=0,
                dashboard_address=":0",
                silence_logs=logging.CRITICAL,  # a task's error comes back with its result; the rest is Dask's
                # own noise, such as a worker's heartbeat that meets the scheduler closing at the end of a run
                env={"PYTHONPATH": os.pathsep.join(p for p in (_package_root(), os.environ.get("PYTHONPATH")) if p)},
            )
            self.client = Client(self.local)
        else:
            try:
                self.client = Client(self.cluster, timeout="10s")
            except OSError as err:
                raise BatchError(f"--cluster {self.cluster}: cannot reach the scheduler ({err})") from None
        self.client.register_plugin(_worker_plugin(self.setup))

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
        if self.local is not None:
            self.local.close()
        self.client = self.local = None

    def results(self, task: Callable, shared: Any, items: Mapping[Hashable, Any], name: str) -> Iterator[Finished]:
        if not items:
            return
        if self.client is None:
            self.start()
        from dask.distributed import as_completed

        token = uuid.uuid4().hex[:8]  # task keys unique on a scheduler that several clients share
        prefix = re.sub(r"\s+", "-", name)
        if shared is not None:  # a task of its own, not scattered data: made again if every worker holding it dies
            shared = self.client.submit(_shared, shared, key=f"{prefix}-shared-{token}", pure=False)
        keys = {}
        for key, item in items.items():
            keys[self.client.submit(task, shared, item, key=f"{prefix}-{key}-{token}", pure=False)] = key
        for future in as_completed(keys):
            try:
                finished = Finished(keys[future], future.result())
            except Exception as err:  # noqa: BLE001 - its workers died on every retry (KilledWorker), or it raised
                finished = Finished(keys[future], error=err)
            yield finished


def _shared(value: Any) -> Any:
    """The argument common to a batch's tasks, as a Dask task: the scheduler keeps it in the graph, so a worker
    killed with the only copy costs a recomputation, not the batch (data sent by ``scatter`` would be lost with
    it: every task waiting for it cancelled)."""
    return value


def _package_root() -> str:
    return str(Path(__file__).resolve().parents[1])


def _worker_plugin(setup: Callable[[], None] | None):
    """A Dask worker plugin: in every worker, ``die_with_parent`` then ``setup``."""
    from dask.distributed import WorkerPlugin

    class Setup(WorkerPlugin):
        name = "mbd-batch-setup"

        def __init__(self, function):
            self.function = function

        def setup(self, worker):
            die_with_parent()
            if self.function is not None:
                self.function()

    return Setup(setup)


def die_with_parent() -> None:
    """Ask the kernel to SIGKILL this process when its parent dies (Linux's ``PR_SET_PDEATHSIG``; elsewhere
    nothing): a LocalCluster's worker dies with the client."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes

    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def executor(
    jobs: int = 1, cluster: str | None = None, setup: Callable[[], None] | None = None, tasks: int | None = None
) -> Executor:
    """Where a batch of ``tasks`` runs, by ``cluster_for``: ``Serial`` or ``Dask`` (of at most ``tasks``
    workers); ``setup`` runs in every Dask worker (``BatchError`` for a bad ``jobs`` or ``cluster``)."""
    where = cluster_for(jobs, cluster, tasks)
    if where is None:
        return Serial()
    return Dask(where, max(1, min(jobs, tasks or jobs)), setup)


# -- one batch -------------------------------------------------------------------------------------------------
def run(
    task: Callable[[Any, Any], Any],
    items: Mapping[Hashable, Any],
    where: Executor,
    *,
    shared: Any = None,
    done: Collection[Hashable] = (),
    name: str = "batch",
    unit: str = "task",
    progress: bool = True,
) -> Iterator[Finished]:
    """Run ``task(shared, item)`` for every item not ``done`` on ``where``; yield each task's ``Finished``
    once, as it arrives (the caller writes it), with one progress bar on stderr (``progress``).

    ``items``: the tasks by key (a run number, a student); ``done``: keys whose result the caller has already
    (resumed: the progress bar starts there); ``shared``: an argument common to every task (sent once to
    each worker); ``name``: the progress bar's label and the prefix of the Dask task keys.
    """
    todo = {key: item for key, item in items.items() if key not in done}
    taken = set()
    with progress_bar(len(items), name, progress and bool(todo), len(items) - len(todo), unit) as bar:
        for finished in where.results(task, shared, todo, name):
            if finished.key in taken:  # each task taken once, whatever Dask ran twice
                continue
            taken.add(finished.key)
            yield finished
            bar.update(1)


def progress_bar(total: int, desc: str, enabled: bool = True, initial: int = 0, unit: str = "task"):
    """A tqdm progress bar on stderr (a widget in a notebook), or a stand-in that does nothing."""
    if enabled:
        try:
            from tqdm.auto import tqdm
        except ImportError:
            enabled = False
    if not enabled:
        return contextlib.nullcontext(_NoBar())
    return tqdm(total=total, initial=initial, desc=desc, unit=unit, file=sys.stderr, dynamic_ncols=True)


class _NoBar:
    def update(self, n: int = 1) -> None:
        """Nothing."""

    def set_postfix_str(self, text: str = "", refresh: bool = True) -> None:
        """Nothing."""


# -- writing -----------------------------------------------------------------------------------------------------
def write_atomic(path: str | Path, content: str | bytes | Callable[[Path], object]) -> Path:
    """Write ``path`` whole or not at all: into a temporary file beside it (named for this process, so that
    parallel writers never share one), then renamed over it (``os.replace``: atomic within a file system).

    ``content``: text (UTF-8; a lone surrogate is written escaped, never stopping a write), bytes, or a
    function that writes the temporary path it is given. On any error the temporary file is removed and
    ``path`` is as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        if callable(content):
            content(tmp)
        elif isinstance(content, bytes):
            tmp.write_bytes(content)
        else:
            tmp.write_text(content, encoding="utf-8", errors="backslashreplace")
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path
