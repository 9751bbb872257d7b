"""What an observation header declares, checked against the epochs the file holds.

A RINEX observation header may state ``TIME OF FIRST OBS``, ``TIME OF LAST OBS`` (RINEX
3.04 Table A2: the time of the last observation record), ``# OF SATELLITES`` and, per
satellite, ``PRN / # OF OBS`` (the number of observations of each type). A file cut short
(a download or copy that stopped at an epoch boundary) reads without a framing error:
only these declarations tell. The reader reports what they contradict as **one warning
per file with the counts** ("155 of 180 epochs ... missing: truncated file?"), and reads
what is there.

Why a warning and not an error: the declarations are optional, and real writers get them
wrong in harmless ways (a header written before recording stopped, a file windowed by a
tool that kept the original header); the epochs present are exact. An observation file
cut *inside* an epoch or a record is an error (`gnss_obs.rinex_obs`). Observations of
more epochs or satellites than declared are not reported (nothing is missing).
"""
from __future__ import annotations

import logging
import os

import numpy as np
import pandas as pd

from gnss_obs.gpstime import gpst_label as _label

__all__ = ["check_declarations"]

log = logging.getLogger("gnss_obs.rinex_obs")

#: Without an INTERVAL, epochs closer than this to a declared time match it, s.
_DEFAULT_TOLERANCE_S = 0.5
#: Satellites named in a warning before "...".
_NAMED = 3


def check_declarations(header, epoch_gps_time_s: np.ndarray, table: pd.DataFrame, *,
                       systems: str | None, first_declared: bool,
                       path: str | os.PathLike) -> list[str]:
    """Compare the header's declarations with the file's epochs; warn once if they differ.

    Parameters
    ----------
    header : gnss_obs.rinex_obs.ObsHeader
    epoch_gps_time_s : ndarray, shape (n_epochs,)
        Observation epochs read (flags 0 and 1), s since the GPS epoch.
    table : pandas.DataFrame
        The observation table (only the systems kept).
    systems : str or None
        The systems kept (None: all), so that satellites not read are not counted missing.
    first_declared : bool
        Whether the header gave ``TIME OF FIRST OBS``.
    path : str or os.PathLike
        The file, for the warning.

    Returns
    -------
    list of str
        The contradictions found (also logged as one warning).
    """
    problems = _time_problems(header, epoch_gps_time_s, first_declared)
    problems += _count_problems(header, table, systems)
    if problems:
        log.warning("%s: fewer observations than the header declares (%s): truncated file?",
                    os.fspath(path), "; ".join(problems))
    return problems


def _time_problems(header, t: np.ndarray, first_declared: bool) -> list[str]:
    interval = header.interval_s if header.interval_s and header.interval_s > 0 else None
    tol = 0.5 * interval if interval else _DEFAULT_TOLERANCE_S
    out = []
    if len(t) == 0:
        if first_declared or header.last_obs_gps_time_s is not None:
            out.append("no observation epoch, although the header gives TIME OF FIRST/LAST OBS")
        return out
    first, last = float(np.min(t)), float(np.max(t))
    declared_first = header.first_obs_gps_time_s if first_declared else first
    declared_last = header.last_obs_gps_time_s if header.last_obs_gps_time_s is not None \
        else last
    expected = (int(round((max(declared_last, last) - min(declared_first, first)) / interval))
                + 1 if interval else None)
    for end, declared, found, gap in (("first", declared_first, first, first - declared_first),
                                      ("last", declared_last, last, declared_last - last)):
        if gap <= tol:
            continue
        text = (f"TIME OF {end.upper()} OBS is {_label(declared)} GPST, the {end} epoch "
                f"{_label(found)}")
        if expected is not None:
            text += (f": {int(round(gap / interval))} of {expected} epochs at the "
                     f"{interval:g} s INTERVAL missing")
        out.append(text)
    return out


def _count_problems(header, table: pd.DataFrame, systems: str | None) -> list[str]:
    out = []
    kept = {sv: c for sv, c in header.obs_counts.items()
            if c and (systems is None or sv[:1] in systems)}
    if kept:
        found = table.groupby("sv")["gps_time_s"].nunique() if len(table) else pd.Series(
            dtype=np.int64)
        short = {sv: (int(found.get(sv, 0)), max(c)) for sv, c in sorted(kept.items())
                 if found.get(sv, 0) < max(c)}
        if short:
            named = ", ".join(f"{sv} {n} of {d}" for sv, (n, d) in list(short.items())[:_NAMED])
            more = ", ..." if len(short) > _NAMED else ""
            out.append(f"PRN / # OF OBS: {len(short)} of {len(kept)} satellites have fewer "
                       f"epochs than declared ({named}{more})")
    if header.n_satellites is not None and systems is None:
        n = table["sv"].nunique() if len(table) else 0
        if n < header.n_satellites:
            out.append(f"# OF SATELLITES declares {header.n_satellites}, {n} observed")
    return out
