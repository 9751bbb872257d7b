"""Error growth through GNSS outages: a tidy table of errors inside outages, and its plots.

The table (`outage_errors`, `OUTAGE_COLUMNS`) has one row per stored sample inside an
outage, with label columns (e.g. ``filter``, ``imu_grade``, ``seed``) and the errors in the
track frame (`railnav.evaluation.metrics`): ``along_track_m``, ``cross_track_m``,
``vertical_m``, ``horizontal_m`` (``hypot(along, cross)``, the error a map shows) and
``position_3d_m``, against ``time_into_outage_s``. Any source that gives those columns —
runs of `railnav.jobs.run.run_simulated`, or a Monte Carlo study table — can be plotted:

* `growth_bands` / `plot_outage_growth`: median and a central band (95 % by default) of
  |error| over the runs against the time into the outage, one panel per group (IMU
  grade), one line per filter;
* `errors_at_durations` / `plot_errors_at_durations`: |error| at the end of outages of
  given durations. The filters are causal: the estimate ``τ`` seconds into an outage
  of length ``D ≥ τ`` has seen exactly the data of an outage of length ``τ`` (none since
  its start), so one long outage per run gives the end-of-outage error of every shorter
  duration.

Figures are `matplotlib.figure.Figure` objects (no pyplot state); the caller shows or
saves them.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt
import pandas as pd
from matplotlib.figure import Figure

from railnav.errors import RailnavError

__all__ = ["outage_errors", "growth_bands", "errors_at_durations", "plot_outage_growth",
           "plot_errors_at_durations", "ERROR_COLUMNS", "OUTAGE_COLUMNS", "DEFAULT_BAND",
           "TIME_DECIMALS"]

Array = npt.NDArray[np.float64]

#: Error columns of the table, m.
ERROR_COLUMNS = ("along_track_m", "cross_track_m", "vertical_m", "horizontal_m",
                 "position_3d_m")
#: Columns every table has besides its labels.
OUTAGE_COLUMNS = ("outage_start_s", "outage_duration_s", "time_into_outage_s") + ERROR_COLUMNS
#: Central probability of the bands.
DEFAULT_BAND = 0.95
#: Times into the outage are rounded to this many decimals before runs are grouped (stored
#: samples of runs at the same rate then coincide; 1 µs is far below any output step).
TIME_DECIMALS = 6


def outage_errors(errors, outage: tuple[float, float],
                  labels: Mapping[str, object] | None = None) -> pd.DataFrame:
    """The errors of one run inside one outage.

    Parameters
    ----------
    errors : railnav.evaluation.metrics.ErrorSeries
        Errors of the run against the truth.
    outage : (start_s, duration_s)
        The outage, s from the trip start.
    labels : mapping, optional
        Constant label columns (``filter``, ``imu_grade``, ``seed`` ...), put first.

    Returns
    -------
    pandas.DataFrame
        Labels, then `OUTAGE_COLUMNS`; one row per stored sample in ``[start, start +
        duration)``, ``time_into_outage_s`` from the outage start.
    """
    start, duration = (float(v) for v in outage)
    t = np.asarray(errors.time_s, dtype=float)
    inside = (t >= start) & (t < start + duration)
    along, cross = errors.along_track_m[inside], errors.cross_track_m[inside]
    columns = {"outage_start_s": start, "outage_duration_s": duration,
               "time_into_outage_s": np.round(t[inside] - start, TIME_DECIMALS),
               "along_track_m": along, "cross_track_m": cross,
               "vertical_m": errors.vertical_m[inside], "horizontal_m": np.hypot(along, cross),
               "position_3d_m": errors.position_3d_m[inside]}
    frame = pd.DataFrame(columns, index=pd.RangeIndex(int(inside.sum())))
    for k, (name, value) in enumerate((labels or {}).items()):
        frame.insert(k, name, value)
    return frame


def growth_bands(table: pd.DataFrame, *, quantity: str = "horizontal_m",
                 by: Sequence[str] = ("imu_grade", "filter"),
                 band: float = DEFAULT_BAND) -> pd.DataFrame:
    """Median and central band of |quantity| over runs, at each time into the outage.

    Parameters
    ----------
    table : pandas.DataFrame
        `outage_errors` rows of several runs (label columns `by`).
    quantity : str
        One of `ERROR_COLUMNS`.
    by : sequence of str
        Label columns that define a curve.
    band : float
        Central probability of the band (0.95: the 2.5th to 97.5th percentiles).

    Returns
    -------
    pandas.DataFrame
        ``*by, time_into_outage_s, runs, median, low, high`` (m).
    """
    _check(table, quantity, by)
    low_q, high_q = (1.0 - band) / 2.0, (1.0 + band) / 2.0
    grouped = table.assign(abs_error=table[quantity].abs()).groupby(
        [*by, "time_into_outage_s"], sort=True)["abs_error"]
    out = pd.DataFrame({"runs": grouped.size(), "median": grouped.median(),
                        "low": grouped.quantile(low_q), "high": grouped.quantile(high_q)})
    return out.reset_index()


def errors_at_durations(table: pd.DataFrame, durations_s: Sequence[float], *,
                        quantity: str = "horizontal_m",
                        by: Sequence[str] = ("imu_grade", "filter"),
                        band: float = DEFAULT_BAND) -> pd.DataFrame:
    """|quantity| at the end of outages of the given durations (module docstring).

    For each duration ``D`` the last stored sample with ``time_into_outage_s < D`` of each
    run is taken (runs whose outage is shorter than ``D`` do not count).

    Returns
    -------
    pandas.DataFrame
        ``*by, duration_s, runs, median, low, high`` (m).
    """
    _check(table, quantity, by)
    rows = []
    for duration in durations_s:
        sub = table[(table["time_into_outage_s"] < duration)
                    & (table["outage_duration_s"] >= duration)]
        if sub.empty:
            continue
        run_keys = [c for c in table.columns if c not in OUTAGE_COLUMNS] + ["outage_start_s"]
        last = sub.sort_values("time_into_outage_s").groupby(run_keys, sort=False).tail(1)
        rows.append(last.assign(duration_s=float(duration)))
    if not rows:
        return pd.DataFrame(columns=[*by, "duration_s", "runs", "median", "low", "high"])
    ends = pd.concat(rows, ignore_index=True)
    ends["time_into_outage_s"] = ends["duration_s"]   # group the run ends by duration
    bands = growth_bands(ends, quantity=quantity, by=by, band=band)
    return bands.rename(columns={"time_into_outage_s": "duration_s"})


def plot_outage_growth(table: pd.DataFrame, *, quantity: str = "horizontal_m",
                       panel_by: str = "imu_grade", line_by: str = "filter",
                       band: float = DEFAULT_BAND, log: bool = True) -> Figure:
    """|error| through the outage: median line and band per `line_by`, a panel per
    `panel_by` value (in order of appearance)."""
    bands = growth_bands(table, quantity=quantity, by=(panel_by, line_by), band=band)
    return _panels(bands, "time_into_outage_s", panel_by, line_by,
                   xlabel="time into the GNSS outage (s)",
                   ylabel=f"|{_label(quantity)}| (m)", band=band, log_x=False, log_y=log,
                   order=list(dict.fromkeys(table[panel_by])))


def plot_errors_at_durations(table: pd.DataFrame, durations_s: Sequence[float], *,
                             quantity: str = "horizontal_m", panel_by: str = "imu_grade",
                             line_by: str = "filter", band: float = DEFAULT_BAND) -> Figure:
    """|error| at the end of an outage against its duration (log–log), as
    `plot_outage_growth`."""
    ends = errors_at_durations(table, durations_s, quantity=quantity,
                               by=(panel_by, line_by), band=band)
    return _panels(ends, "duration_s", panel_by, line_by, xlabel="outage duration (s)",
                   ylabel=f"|{_label(quantity)}| at the outage end (m)", band=band,
                   log_x=True, log_y=True, order=list(dict.fromkeys(table[panel_by])),
                   markers=True)


def _panels(bands: pd.DataFrame, x: str, panel_by: str, line_by: str, *, xlabel: str,
            ylabel: str, band: float, log_x: bool, log_y: bool, order: list,
            markers: bool = False) -> Figure:
    """One panel per `panel_by` value; per `line_by` a median line and a shaded band."""
    n = max(len(order), 1)
    fig = Figure(figsize=(4.2 * n, 3.6), layout="constrained")
    axes = fig.subplots(1, n, sharey=True, squeeze=False)[0]
    lines = list(dict.fromkeys(bands[line_by]))
    for ax, panel in zip(axes, order):
        for k, line in enumerate(lines):
            sub = bands[(bands[panel_by] == panel) & (bands[line_by] == line)]
            if sub.empty:
                continue
            color = f"C{k}"
            runs = int(sub["runs"].max())
            ax.plot(sub[x], sub["median"], color=color, marker="o" if markers else None,
                    ms=3, label=f"{line} (median of {runs})")
            ax.fill_between(sub[x], sub["low"], sub["high"], color=color, alpha=0.2, lw=0)
        ax.set_title(str(panel))
        ax.set_xlabel(xlabel)
        ax.set_xscale("log" if log_x else "linear")
        ax.set_yscale("log" if log_y else "linear")
        ax.grid(True, which="both", lw=0.3)
    axes[0].set_ylabel(ylabel)
    axes[0].legend(fontsize=8, loc="upper left")
    fig.suptitle(f"shaded: central {band:.0%} of the runs")
    return fig


def _label(quantity: str) -> str:
    return quantity.removesuffix("_m").replace("_", " ").replace("3d", "3-D") + " error"


def _check(table: pd.DataFrame, quantity: str, by: Sequence[str]) -> None:
    if quantity not in ERROR_COLUMNS:
        raise RailnavError(f"quantity must be one of {', '.join(ERROR_COLUMNS)}, "
                         f"got {quantity!r}")
    missing = [c for c in (*by, "time_into_outage_s", quantity) if c not in table.columns]
    if missing:
        raise RailnavError(f"the table lacks the columns {missing}")
