"""Balise files: "the vehicle passed a known position at time t" (point anchors).

``--balises FILE`` (`read_balises_csv`) is a CSV table (`railnav.sensors.tables`: time
``gps_time_s`` or ``time_s``, one passage per row, strictly increasing) whose rows give the
position passed either as a track distance, ``s_m`` (m along the run's track), or as a
coordinate, ``lat_deg, lon_deg`` (+ ``h_m``, unused), projected on the track when the run
starts (`railnav.filters.balise_rows`). Optional columns: ``sigma_m`` (1σ of the passage
position along the track: the balise's surveyed position and the reader's timing, m;
empty: the model's), ``id`` (a name for ``innovations.csv``). A row may give either form;
a row with neither is an error. The passage is that of the vehicle's balise reader (its
forward offset from the reference point: `railnav.filters.lever_arm.LeverArms`).
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.errors import ConfigError
from railnav.sensors.tables import (
    TIME_COLUMNS,
    optional_column,
    read_timed_csv,
    relative_times,
)
from trackmodel.files import atomic_write_csv

__all__ = ["BaliseLog", "read_balises_csv", "write_balises_csv"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class BaliseLog:
    """Balise passages (N rows, in time order).

    Attributes
    ----------
    time_s : ndarray, shape (N,)
        In the file's reference (`time_column`), s.
    time_column : str
    s_m : ndarray, shape (N,)
        Track distance of the passage, m (NaN: given as a coordinate).
    lat_deg, lon_deg : ndarray, shape (N,)
        Its coordinate, deg (NaN: given as a distance).
    sigma_m : ndarray, shape (N,)
        The file's 1σ, m (NaN: none given).
    ids : ndarray of str, shape (N,)
        The ``id`` column, else ``row<k>``.
    path : str
    """

    time_s: Array
    time_column: str
    s_m: Array
    lat_deg: Array
    lon_deg: Array
    sigma_m: Array
    ids: np.ndarray
    path: str

    def __len__(self) -> int:
        return self.time_s.size

    def relative_time_s(self, start_gps_time_s: float) -> Array:
        """Passage times in seconds from the trip start."""
        return relative_times(self.time_s, self.time_column, start_gps_time_s)


def read_balises_csv(path: str | os.PathLike) -> BaliseLog:
    """Read a balise file (module docstring).

    Raises
    ------
    ConfigError
        As `railnav.sensors.tables.read_timed_csv`; neither ``s_m`` nor ``lat_deg,
        lon_deg`` columns; a row with neither form, half a coordinate, a latitude beyond
        ±90° or a longitude beyond ±180°, a negative distance, a σ <= 0 (their row).
    """
    frame, column, times = read_timed_csv(path, "balise")
    if "s_m" not in frame.columns and not {"lat_deg", "lon_deg"} <= set(frame.columns):
        raise ConfigError("needs the column s_m or the columns lat_deg, lon_deg", path=path)
    s = optional_column(frame, "s_m", path)
    lat, lon = optional_column(frame, "lat_deg", path), optional_column(frame, "lon_deg", path)
    sigma = optional_column(frame, "sigma_m", path)
    checks = ((np.isfinite(lat) != np.isfinite(lon), "lat_deg",
               "a coordinate needs both lat_deg and lon_deg"),
              (~np.isfinite(s) & ~np.isfinite(lat), "s_m",
               "no position: give s_m or lat_deg, lon_deg"),
              (np.abs(lat) > 90, "lat_deg", "latitude beyond ±90°"),
              (np.abs(lon) > 180, "lon_deg", "longitude beyond ±180°"),
              (s < 0, "s_m", "a track distance is >= 0"),
              (sigma <= 0, "sigma_m", "sigma_m must be > 0"))
    for bad, col, message in checks:
        if np.any(bad):
            raise ConfigError(message, path=path, row=int(np.flatnonzero(bad)[0]) + 1,
                              column=col)
    if "id" in frame.columns:
        ids = np.array(["" if pd.isna(v) else str(v).strip() for v in frame["id"]],
                       dtype=object)
    else:
        ids = np.array([f"row{k + 1}" for k in range(len(frame))], dtype=object)
    return BaliseLog(times, column, s, lat, lon, sigma, ids, str(path))


def write_balises_csv(path: str | os.PathLike, time_s: Array, s_m: Array, *,
                      sigma_m: Array | None = None, ids=None,
                      time_column: str = TIME_COLUMNS[1]) -> None:
    """Write a balise file with track distances (module docstring), atomically."""
    data = {time_column: np.asarray(time_s, dtype=float), "s_m": np.asarray(s_m, dtype=float)}
    if sigma_m is not None:
        data["sigma_m"] = np.asarray(sigma_m, dtype=float)
    if ids is not None:
        data["id"] = list(ids)
    atomic_write_csv(path, pd.DataFrame(data), float_format="%.17g")
