"""Summary plots of a study table: error at the end of GNSS outages against their length.

A study row (`railnav.studies.runs`) holds, for each of its outages, the errors at the
outage's last stored sample. `outage_end_table` turns the rows into the tidy table of
`railnav.evaluation.outage_plots` (labels + `railnav.evaluation.outage_plots.OUTAGE_COLUMNS`, one row per run
and outage, at ``time_into_outage_s`` = its end), so the same plotting code serves the
notebooks' per-run tables and the studies: `plot_study` draws, per combination of the
other grid axes (track, speed, GNSS σ, outage start), the median and central band over
the replicates of |error| at the outage end against the outage length, one panel per IMU
grade and one line per filter (`railnav.evaluation.outage_plots.plot_errors_at_durations`).
"""
from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from railnav.evaluation.outage_plots import (
    DEFAULT_BAND,
    OUTAGE_COLUMNS,
    TIME_DECIMALS,
    plot_errors_at_durations,
)
from trackmodel.files import atomic_write

__all__ = ["outage_end_table", "plot_study", "LABEL_COLUMNS", "FIGURE_QUANTITIES",
           "GROUP_COLUMNS"]

log = logging.getLogger(__name__)

#: Study columns carried into `outage_end_table` as labels (those present).
LABEL_COLUMNS = ("track", "scenario", "imu_grade", "speed_mps", "filter",
                 "sigma_pseudorange_m", "sigma_range_rate_mps", "systems", "replicate", "seed",
                 "run_id")
#: Columns whose combinations get figures of their own (when they vary).
GROUP_COLUMNS = ("track", "speed_mps", "sigma_pseudorange_m", "sigma_range_rate_mps",
                 "outage_start_s")
#: Quantities drawn by `plot_study`, one figure each.
FIGURE_QUANTITIES = ("along_track_m", "horizontal_m")
_DPI = 110


def outage_end_table(table: pd.DataFrame) -> pd.DataFrame:
    """The errors at each outage's end of the successful runs of a study table.

    Parameters
    ----------
    table : pandas.DataFrame
        ``results.parquet`` of `railnav.studies.study.run_study`.

    Returns
    -------
    pandas.DataFrame
        `LABEL_COLUMNS` present in `table`, then `railnav.evaluation.outage_plots.OUTAGE_COLUMNS`:
        ``outage_start_s, outage_duration_s, time_into_outage_s`` (the last stored sample
        in the outage, s from its start) and the errors there, m (``horizontal_m`` =
        hypot(along, cross)). Outages without a stored sample are left out.
    """
    ok = table[table["status"] == "ok"] if "status" in table else table
    labels = [c for c in LABEL_COLUMNS if c in ok.columns]
    frames = []
    k = 1
    while f"outage{k}_start_s" in ok.columns:
        p = f"outage{k}_"
        sub = ok[ok[p + "start_s"].notna() & ok[p + "end_sample_s"].notna()]
        along, cross = sub[p + "along_track_end_m"], sub[p + "cross_track_end_m"]
        columns = {"outage_start_s": sub[p + "start_s"],
                   "outage_duration_s": sub[p + "duration_s"],
                   "time_into_outage_s": np.round(sub[p + "end_sample_s"] - sub[p + "start_s"],
                                                  TIME_DECIMALS),
                   "along_track_m": along, "cross_track_m": cross,
                   "vertical_m": sub[p + "vertical_end_m"],
                   "horizontal_m": np.hypot(along, cross),
                   "position_3d_m": sub[p + "position_3d_end_m"]}
        frames.append(pd.concat([sub[labels], pd.DataFrame(columns)], axis=1))
        k += 1
    if not frames:
        return pd.DataFrame(columns=labels + list(OUTAGE_COLUMNS))
    return pd.concat(frames, ignore_index=True)[labels + list(OUTAGE_COLUMNS)]


def plot_study(table: pd.DataFrame, out_dir: str | os.PathLike) -> list[Path]:
    """Write the summary figures of a study table into `out_dir` (module docstring).

    Files are ``error_growth_<quantity>[_<k>].png`` (``k`` numbers the combinations of
    `GROUP_COLUMNS` when there are several, named in each figure's title).

    Returns
    -------
    list of pathlib.Path
        The files written (none when no run had an outage with a stored sample).
    """
    ends = outage_end_table(table)
    if ends.empty:
        log.info("no outage ends in the table: no summary plot")
        return []
    groups = [c for c in GROUP_COLUMNS if c in ends.columns and ends[c].nunique() > 1]
    combos = list(ends.groupby(groups, sort=True)) if groups else [((), ends)]
    written = []
    for k, (key, sub) in enumerate(combos, start=1):
        durations = sorted(sub["outage_duration_s"].unique())
        key = key if isinstance(key, tuple) else (key,)
        title = ", ".join(f"{c} = {v}" for c, v in zip(groups, key))
        suffix = f"_{k}" if len(combos) > 1 else ""
        for quantity in FIGURE_QUANTITIES:
            fig = plot_errors_at_durations(sub, durations, quantity=quantity)
            if title:
                fig.suptitle(f"{title}; shaded: central {DEFAULT_BAND:.0%} of the runs")
            path = Path(out_dir) / f"error_growth_{quantity.removesuffix('_m')}{suffix}.png"
            _save(fig, path)
            written.append(path)
    return written


def _save(fig: Figure, path: Path) -> None:
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=_DPI)
