"""The timed CSV tables of the railway sensor files: time column, optional columns, errors.

Every sensor file of `railnav.sensors` is a CSV table (``#`` lines are comments) with one
time column, ``gps_time_s`` (GPS seconds, as ``estimates.csv`` of a file run) or ``time_s``
(seconds from the trip start), strictly increasing. `read_timed_csv` reads that part with
one-line located errors (`railnav.errors.ConfigError`, `trackmodel.errors` conventions:
rows 1-based, header not counted); `optional_column` reads a column that may be absent or
have empty cells; `relative_times` puts either reference on the trip's clock.
"""
from __future__ import annotations

import os

import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.errors import ConfigError
from trackmodel.errors import finite_column
from trackmodel.textfile import read_csv_table

__all__ = ["TIME_COLUMNS", "read_timed_csv", "optional_column", "relative_times"]

Array = npt.NDArray[np.float64]

#: Accepted time columns, in order of preference.
TIME_COLUMNS = ("gps_time_s", "time_s")


def read_timed_csv(path: str | os.PathLike, what: str) -> tuple[pd.DataFrame, str, Array]:
    """A sensor table, its time column's name and its times (s).

    Parameters
    ----------
    path : path
    what : str
        The kind of file, for the messages (``"odometer"``).

    Raises
    ------
    ConfigError
        Missing file (`OSError` otherwise), empty file or no rows, no time column, a time
        that is not a finite number or does not increase (its row), a malformed CSV line.
    """
    try:
        frame = read_csv_table(path, error=ConfigError, comment="#")
    except FileNotFoundError:
        raise ConfigError(f"no such {what} file", path=path) from None
    column = next((c for c in TIME_COLUMNS if c in frame.columns), None)
    if column is None:
        raise ConfigError(f"missing column {' or '.join(TIME_COLUMNS)} (the {what} file's time)",
                          path=path)
    if frame.empty:
        raise ConfigError("no rows", path=path)
    times = finite_column(frame, column, path=path, error=ConfigError)
    back = np.flatnonzero(np.diff(times) <= 0)
    if back.size:
        k = int(back[0])
        raise ConfigError(f"time does not increase ({float(times[k + 1])!r} after "
                          f"{float(times[k])!r})",
                          path=path, row=k + 2, column=column)
    return frame, column, times


def optional_column(frame: pd.DataFrame, name: str, path) -> Array:
    """Column `name` as floats, NaN where a cell is empty (all NaN when absent).

    Raises
    ------
    ConfigError
        A cell that is neither empty nor a finite number (its row).
    """
    if name not in frame.columns:
        return np.full(len(frame), np.nan)
    raw = frame[name]
    values = pd.to_numeric(raw, errors="coerce").to_numpy(dtype=float)
    blank = raw.isna().to_numpy() | (raw.astype(str).str.strip() == "").to_numpy()
    bad = np.flatnonzero(~np.isfinite(values) & ~blank)
    if bad.size:
        raise ConfigError(f"{str(raw.iloc[bad[0]]).strip()!r} is not a finite number",
                          path=path, row=int(bad[0]) + 1, column=name)
    return np.where(blank, np.nan, values)


def relative_times(times: Array, column: str, start_gps_time_s: float) -> Array:
    """Times of a sensor table in seconds from the trip start."""
    return times - start_gps_time_s if column == TIME_COLUMNS[0] else np.asarray(times)
