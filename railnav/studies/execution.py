"""Where a study's runs execute: in this process, a local process pool, or Dask.

`execute` yields the rows of `railnav.studies.runs.run_one` as runs finish (in completion
order; the caller orders the table). Three engines, one contract:

* ``workers=1`` without a scheduler: a plain loop in this process (no start-up cost;
  notebooks and small studies);
* no scheduler, ``workers > 1``: a `concurrent.futures.ProcessPoolExecutor` on the local
  cores (``spawn`` start method: each worker imports the package afresh);
* a scheduler: **Dask distributed** — ``"local"`` starts a `dask.distributed.LocalCluster`
  of ``workers`` single-threaded worker processes; ``"tcp://HOST:PORT"`` connects to a
  running cluster (its workers need this package installed; the runs carry their
  track files' text, so no shared file system is needed); a
  `dask.distributed.Client` is used as it is (and not closed).

The caller ends an execution with ``stop()`` however it ends (an exception, Ctrl-C): the
runs not started are cancelled, the rows of runs that finished meanwhile are handed back
(so none is lost), and runs in progress in other processes are abandoned (their rows are
not written, so a resumed study redoes them). Worker processes ignore Ctrl-C: the main
process handles it, once, without a traceback per worker.
"""
from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import signal
import threading
from collections.abc import Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed

from railnav.errors import ConfigError
from railnav.studies.runs import RunSpec, run_one

__all__ = ["execute", "Rows", "default_workers", "sigint_blocked", "LOCAL_SCHEDULER",
           "CONNECT_TIMEOUT_S"]

log = logging.getLogger(__name__)

#: ``scheduler`` value that starts a Dask `LocalCluster` on this machine.
LOCAL_SCHEDULER = "local"
#: How long to wait for a Dask scheduler, s.
CONNECT_TIMEOUT_S = 20.0


def default_workers() -> int:
    """Worker count when none is given: the usable cores."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:           # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def execute(specs: Sequence[RunSpec], *, scheduler=None,
            workers: int | None = None) -> "Rows":
    """Run `specs`; iterate the result for each run's row as it finishes (module
    docstring), and call its ``stop()`` at the end, however it ends.

    Parameters
    ----------
    specs : sequence of RunSpec
    scheduler : None, "local", str or dask.distributed.Client
    workers : int, optional
        Local processes (pool or `LocalCluster`); default `default_workers`.

    Raises
    ------
    ConfigError
        For a bad worker count or a scheduler that cannot be reached.
    """
    workers = default_workers() if workers is None else workers
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ConfigError(f"workers must be an integer >= 1, got {workers!r}")
    if not specs:
        return Rows(iter(()))
    if scheduler is not None:
        return _DaskRows(specs, scheduler, workers)
    if workers == 1:
        return Rows(run_one(spec) for spec in specs)
    return _PoolRows(specs, workers)


class Rows:
    """Rows of runs as they finish; `stop` ends the execution.

    The base class runs in this process: a run interrupted there has no row.
    """

    def __init__(self, rows: Iterator[dict]) -> None:
        self._rows = rows

    def __iter__(self) -> "Rows":
        return self

    def __next__(self) -> dict:
        return next(self._rows)

    def stop(self) -> list[dict]:
        """Cancel what has not started; return the rows of runs that finished but were
        not taken yet (other processes' runs can end between two rows)."""
        return []


def _ignore_interrupts() -> None:
    """In a worker process: Ctrl-C is the main process's to handle (it stops the
    workers and keeps what finished), not a traceback per worker."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class _PoolRows(Rows):
    def __init__(self, specs: Sequence[RunSpec], workers: int) -> None:
        context = multiprocessing.get_context("spawn")
        self.pool = ProcessPoolExecutor(max_workers=min(workers, len(specs)),
                                        mp_context=context, initializer=_ignore_interrupts)
        with sigint_blocked():         # workers start in submit
            self.futures = [self.pool.submit(run_one, spec) for spec in specs]
        self.taken: set = set()
        super().__init__(as_completed(self.futures))

    def __next__(self) -> dict:
        future = next(self._rows)
        self.taken.add(future)
        return future.result()

    def stop(self) -> list[dict]:
        for future in self.futures:
            future.cancel()
        left = [f.result() for f in self.futures if f not in self.taken and f.done()
                and not f.cancelled() and f.exception() is None]
        running = list((getattr(self.pool, "_processes", None) or {}).values())
        self.pool.shutdown(wait=False, cancel_futures=True)
        for process in running:       # our own workers, busy with runs no one will read
            if process.is_alive():
                process.terminate()
        return left


def _quiet_dask() -> None:
    """Dask logs its cluster's life at INFO through its own handler: keep that to
    warnings unless this program logs at DEBUG (``railnav -vv``)."""
    if logging.getLogger().getEffectiveLevel() > logging.DEBUG:
        logging.getLogger("distributed").setLevel(logging.WARNING)


def _worker_log_level() -> int:
    """Log level of LocalCluster workers: critical only, everything at ``railnav -vv``.
    A stopped study's workers, killed in mid-run, log cancelled tasks and lost heartbeats
    (with tracebacks) that say nothing to a user; a run's own failure is its row's
    ``error``, and a lost worker surfaces in this process when its row is fetched."""
    debug = logging.getLogger().getEffectiveLevel() <= logging.DEBUG
    return logging.DEBUG if debug else logging.CRITICAL


@contextlib.contextmanager
def sigint_blocked() -> Iterator[None]:
    """Hold Ctrl-C off in the block (in the main thread; elsewhere a no-op): SIGINT is
    blocked, and delivered when the block ends. Threads and processes started in the
    block inherit the blocked mask (kept across exec): they never see Ctrl-C."""
    if not hasattr(signal, "pthread_sigmask") or \
            threading.current_thread() is not threading.main_thread():
        yield
        return
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


class _DaskRows(Rows):
    def __init__(self, specs: Sequence[RunSpec], scheduler, workers: int) -> None:
        self.client, self.cluster, self.own = _dask_client(scheduler, workers)
        self.futures = self.client.map(run_one, list(specs),
                                       key=[f"run-{s.run_id}" for s in specs])
        self.taken: set[str] = set()
        from dask.distributed import as_completed as dask_completed
        super().__init__(iter(dask_completed(self.futures)))

    def __next__(self) -> dict:
        future = next(self._rows)
        self.taken.add(future.key)
        return future.result()

    def stop(self) -> list[dict]:
        done = [f for f in self.futures if f.key not in self.taken and f.status == "finished"]
        try:
            left = self.client.gather(done) if done else []
        except Exception as exc:     # noqa: BLE001 - a lost worker: those runs are redone
            log.warning("finished runs could not be fetched (%s): a resumed study redoes "
                        "them", exc)
            left = []
        if self.cluster is None:      # someone else's cluster: stop our runs on it
            self.client.cancel([f for f in self.futures if not f.done()])
        else:                         # ours: its busy workers are killed, as they should be
            logging.getLogger("distributed").setLevel(_worker_log_level())
        if self.own:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()
        return list(left)


def _dask_client(scheduler, workers: int):
    """(client, cluster or None, whether the client is ours to close)."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise ConfigError("a Dask scheduler needs dask.distributed: "
                          "pip install 'railnav[cluster]'") from None
    _quiet_dask()
    if isinstance(scheduler, Client):
        return scheduler, None, False
    if scheduler == LOCAL_SCHEDULER:
        with sigint_blocked():
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=_worker_log_level())
        return Client(cluster), cluster, True
    if isinstance(scheduler, str):
        try:
            return Client(scheduler, timeout=CONNECT_TIMEOUT_S), None, True
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError(f"cannot reach the Dask scheduler {scheduler!r}: {exc}") from None
    raise ConfigError(f"scheduler must be 'local', an address or a dask Client, got "
                      f"{scheduler!r}")
