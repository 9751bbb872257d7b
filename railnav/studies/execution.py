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

Closing the generator early (an exception in the caller, Ctrl-C) cancels the runs not
started; runs in progress in other processes are abandoned (their rows are not written,
so a resumed study redoes them).
"""
from __future__ import annotations

import logging
import multiprocessing
import os
from collections.abc import Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed

from railnav.errors import ConfigError
from railnav.studies.runs import RunSpec, run_one

__all__ = ["execute", "default_workers", "LOCAL_SCHEDULER", "CONNECT_TIMEOUT_S"]

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
            workers: int | None = None) -> Iterator[dict]:
    """Run `specs`, yielding each run's row as it finishes (module docstring).

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
        return iter(())
    if scheduler is not None:
        return _dask(specs, scheduler, workers)
    if workers == 1:
        return (run_one(spec) for spec in specs)
    return _pool(specs, workers)


def _pool(specs: Sequence[RunSpec], workers: int) -> Iterator[dict]:
    context = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(max_workers=min(workers, len(specs)), mp_context=context)
    futures = [pool.submit(run_one, spec) for spec in specs]
    try:
        for future in as_completed(futures):
            yield future.result()
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


def _quiet_dask() -> None:
    """Dask logs its cluster's life at INFO through its own handler: keep that to
    warnings unless this program logs at DEBUG (``railnav -vv``)."""
    if logging.getLogger().getEffectiveLevel() > logging.DEBUG:
        logging.getLogger("distributed").setLevel(logging.WARNING)


def _dask(specs: Sequence[RunSpec], scheduler, workers: int) -> Iterator[dict]:
    try:
        from dask.distributed import Client, LocalCluster
        from dask.distributed import as_completed as dask_completed
    except ImportError:
        raise ConfigError("a Dask scheduler needs dask.distributed: "
                          "pip install 'railnav[cluster]'") from None
    _quiet_dask()
    cluster = None
    if isinstance(scheduler, Client):
        client, own = scheduler, False
    elif scheduler == LOCAL_SCHEDULER:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client, own = Client(cluster), True
    elif isinstance(scheduler, str):
        try:
            client, own = Client(scheduler, timeout=CONNECT_TIMEOUT_S), True
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError(f"cannot reach the Dask scheduler {scheduler!r}: {exc}") from None
    else:
        raise ConfigError(f"scheduler must be 'local', an address or a dask Client, got "
                          f"{scheduler!r}")
    futures = client.map(run_one, list(specs), key=[f"run-{s.run_id}" for s in specs])
    try:
        for future in dask_completed(futures):
            yield future.result()
    finally:
        client.cancel([f for f in futures if not f.done()])
        if own:
            client.close()
        if cluster is not None:
            cluster.close()
