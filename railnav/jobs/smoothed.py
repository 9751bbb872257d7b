"""A run's smoothed twin, scored like the run itself (``railnav run --smooth``).

`smooth_outcome` adds to a finished `railnav.jobs.run.RunOutcome` (navigated with
``NavigatorConfig(rts_smoothing=True)``) the RTS-smoothed result
(`railnav.navigation.smoothing.smooth_result`), its errors against the run's truth (scored
by the same function as the filter's) and a ``summary.json`` section ``smoothed``:
``{"method": "rts", "errors": <railnav.evaluation.metrics.summarize of the smoothed
errors> or null}``. `railnav.jobs.run.write_run` then writes ``smoothed.csv`` (the
``estimates.csv`` columns) and, with a truth, ``smoothed_errors.csv``.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from railnav.evaluation.metrics import ErrorSeries, summarize
from railnav.navigation.result import CSV_DECIMALS, CSV_FLOAT_FORMAT, NavigationResult
from railnav.navigation.smoothing import smooth_result
from trackmodel.files import atomic_write_csv

__all__ = ["SmoothedRun", "smooth_outcome", "write_smoothed"]


@dataclass(frozen=True, eq=False)
class SmoothedRun:
    """The smoothed twin of a run: its result and, with a truth, its errors."""

    result: NavigationResult
    errors: ErrorSeries | None = None


def smooth_outcome(outcome, score: Callable[[NavigationResult], ErrorSeries | None] | None,
                   *, window=None):
    """`outcome` with its smoothed twin (module docstring).

    Parameters
    ----------
    outcome : railnav.jobs.run.RunOutcome
    score : callable(NavigationResult) -> ErrorSeries or None, optional
        How the run was scored (None: no truth).
    window : (start_s, end_s), optional
        The run's summary window.

    Returns
    -------
    railnav.jobs.run.RunOutcome
        With ``smoothed`` set and ``summary["smoothed"]``.
    """
    result = smooth_result(outcome.result)
    errors = score(result) if score is not None else None
    section = {"method": "rts", "errors": None if errors is None else summarize(
        errors, window=window, outages=outcome.result.outages)}
    return replace(outcome, summary={**outcome.summary, "smoothed": section},
                   smoothed=SmoothedRun(result, errors))


def write_smoothed(smoothed: SmoothedRun | None, out: Path) -> list[Path]:
    """Write ``smoothed.csv`` (and ``smoothed_errors.csv`` with a truth that has samples of
    the run: `railnav.evaluation.metrics.ErrorSeries.compared`) into `out`; the
    paths written (none without a smoothed twin)."""
    if smoothed is None:
        return []
    tables = {"smoothed.csv": smoothed.result.estimates}
    if smoothed.errors is not None and smoothed.errors.compared:
        tables["smoothed_errors.csv"] = smoothed.errors.to_frame()
    for name, frame in tables.items():
        atomic_write_csv(out / name, frame, float_format=CSV_FLOAT_FORMAT, decimals=CSV_DECIMALS)
    return [out / name for name in tables]
