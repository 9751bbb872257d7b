"""Monte Carlo studies: a grid of scenarios × seeds, run anywhere, one tidy table.

`run_study` is the one entry point behind ``railnav study CONFIG.toml --out DIR`` and the
notebooks: it expands the configuration (`railnav.studies.config.StudyConfig`, from TOML by
`railnav.studies.file.load_study_config`) into runs (`railnav.studies.runs`), skips those
already in ``DIR`` (resume), executes the rest in this process, on a local process pool
or on Dask (`railnav.studies.execution`), writes finished rows in atomic parquet parts every
``chunk_runs`` runs (`railnav.studies.store`), and finally merges them into
``DIR/results.parquet`` — one row per run, parameters then error figures, ordered by the
grid (not by completion), so the same configuration gives the same table whatever the
number of workers (up to ``runtime_s``). Summary plots are drawn by
`railnav.studies.plots`.

``DIR`` also receives ``study.json`` (the configuration as run). Progress is reported as
``progress(runs_done, runs_total)``, runs found on disk counting as done.
"""
from __future__ import annotations

import json
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from railnav.errors import ConfigError
from railnav.studies.config import StudyConfig
from railnav.studies.execution import execute, sigint_blocked
from railnav.studies.runs import STATUS_COLUMNS, expand_grid, metric_columns
from railnav.studies.store import PARTS_DIR, PartStore
from trackmodel.files import LOCK_FILE, atomic_write_text, directory_lock

__all__ = ["StudyResult", "run_study", "STUDY_FILE", "StudyInterrupted"]

log = logging.getLogger(__name__)

#: The configuration as run, inside the output folder.
STUDY_FILE = "study.json"

Progress = Callable[[int, int], None]


@dataclass(frozen=True, eq=False)
class StudyResult:
    """A finished study.

    Attributes
    ----------
    config : StudyConfig
    out_dir : pathlib.Path
    table : pandas.DataFrame
        ``results.parquet``: one row per run (`railnav.studies.runs`).
    results_path : pathlib.Path
    runs_total : int
    runs_resumed : int
        Runs found finished in `out_dir` and not run again.
    runs_failed : int
        Rows with ``status == "failed"``.
    plots : tuple of pathlib.Path
    """

    config: StudyConfig
    out_dir: Path
    table: pd.DataFrame
    results_path: Path
    runs_total: int
    runs_resumed: int
    runs_failed: int
    plots: tuple[Path, ...] = field(default=())

    def to_frame(self) -> pd.DataFrame:
        """The results table."""
        return self.table


def run_study(config: StudyConfig, out_dir: str | Path, *, scheduler=None,
              workers: int | None = None, progress: Progress | None = None,
              plots: bool = True) -> StudyResult:
    """Run a study into `out_dir`, resuming what is already there (module docstring).

    Parameters
    ----------
    config : StudyConfig
    out_dir : path
        Output folder (created).
    scheduler : None, "local", "tcp://HOST:PORT" or dask.distributed.Client
        None: this process (``workers == 1``) or a local process pool; otherwise Dask
        (`railnav.studies.execution`).
    workers : int, optional
        Local worker processes; default: the usable cores.
    progress : callable(done, total), optional
        Called after each finished run (and once at the start).
    plots : bool
        Draw the summary plots (`railnav.studies.plots.plot_study`) into `out_dir`.

    Returns
    -------
    StudyResult

    Raises
    ------
    ConfigError
        For an output path that is a file or a non-empty folder that is not a study's,
        a bad worker count or scheduler.
    trackmodel.errors.InputError
        When another study holds the lock on `out_dir` (`trackmodel.files.directory_lock`).
    StudyInterrupted
        On Ctrl-C (a `KeyboardInterrupt`), after the finished runs are saved; running the
        same study again resumes the rest (an interrupted run is never a failed one).
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ConfigError(f"{out}: exists and is not a directory")
    _check_study_folder(out)
    with directory_lock(out, what="study"):
        try:
            return _run_locked(config, out, scheduler=scheduler, workers=workers,
                               progress=progress, plots=plots)
        except KeyboardInterrupt:
            ids = {s.run_id for s in expand_grid(config)}
            done = len(PartStore(out).finished_ids() & ids)
            raise StudyInterrupted(f"interrupted: {done} of {len(ids)} runs are saved in "
                                   f"{out}; the same command resumes the rest") from None


def _check_study_folder(out: Path) -> None:
    """Refuse a non-empty `out` that is not a study's folder (none of its ``study.json``,
    ``parts`` or lock): a study resumes in its own folder only, and writes nothing beside
    someone else's files."""
    if not out.is_dir():
        return
    names = {p.name for p in out.iterdir()}
    if names and not names & {STUDY_FILE, PARTS_DIR, LOCK_FILE}:
        raise ConfigError(f"{out}: exists, is not empty and is not a study's folder: nothing "
                          "was written (give a new --out, or the folder of the study to "
                          "resume)")


def _run_locked(config: StudyConfig, out: Path, *, scheduler, workers, progress,
                plots: bool) -> StudyResult:
    """`run_study` while holding the lock on `out`."""
    specs = expand_grid(config)
    store = PartStore(out)
    atomic_write_text(out / STUDY_FILE, json.dumps(config.to_dict(), indent=2) + "\n")
    finished = store.finished_ids()
    todo = [s for s in specs if s.run_id not in finished]
    resumed = len(specs) - len(todo)
    if resumed:
        log.info("%d of %d runs already in %s: not run again", resumed, len(specs), out)
    _execute(todo, store, config.chunk_runs, done=resumed, total=len(specs),
             scheduler=scheduler, workers=workers, progress=progress)
    n_outages = max((len(s.outages) for s in specs), default=0)
    columns = (list(specs[0].parameters()) if specs else []) + metric_columns(n_outages) \
        + list(STATUS_COLUMNS)
    table, path = store.merge([s.run_id for s in specs], columns)
    failed = int((table["status"] == "failed").sum()) if len(table) else 0
    if failed:
        log.warning("%d of %d runs failed (see the error column of %s)", failed, len(table),
                    path)
    drawn: tuple[Path, ...] = ()
    if plots and len(table):
        from railnav.studies.plots import plot_study
        drawn = tuple(plot_study(table, out))
    return StudyResult(config, out, table, path, len(specs), resumed, failed, drawn)


def _execute(todo, store: PartStore, chunk_runs: int, *, done: int, total: int, scheduler,
             workers, progress: Progress | None) -> None:
    """Run `todo`, writing a part every `chunk_runs` rows and, when the loop ends or is
    interrupted, whatever has finished (with Ctrl-C held off while it is saved)."""
    tick = progress or (lambda d, t: None)
    tick(done, total)
    buffer: list[dict] = []
    rows = execute(todo, scheduler=scheduler, workers=workers)
    try:
        for row in rows:
            buffer.append(row)
            done += 1
            if len(buffer) >= chunk_runs:
                store.write(buffer)
                buffer = []
            tick(done, total)
    finally:
        with sigint_blocked():         # a second Ctrl-C waits until the rows are saved
            store.write(buffer + rows.stop())


class StudyInterrupted(KeyboardInterrupt):
    """Ctrl-C stopped a study: its finished runs are saved, a rerun resumes the rest."""
