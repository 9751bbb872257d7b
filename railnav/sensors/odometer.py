"""Odometer (wheel tachometer) files: speed readings, or pulse counts and a wheel.

``--odometer FILE`` (`read_odometer_csv`) is a CSV table (`railnav.sensors.tables`: time
``gps_time_s`` or ``time_s``) with either

* ``speed_mps``: the wheel's speed, >= 0 (a tachometer's magnitude), instantaneous at each
  time; or
* ``pulses``: the cumulative count of a wheel's pulse generator (integers, never
  decreasing: a counter that wraps must be unwrapped first), with the nominal wheel
  circumference (m) and the pulses per revolution given beside the file. Each interval's
  count becomes its mean speed ``Δn · L / Δt``, ``L = circumference / pulses per
  revolution`` (the pulse length), at the interval's midpoint (the instantaneous speed
  there to second order), with the quantization step ``L / Δt`` of that interval;

and optionally ``direction`` (+1: towards increasing track distance ``s``, −1: towards
decreasing; 0 or empty: not known) and ``sigma_mps`` (the reading's 1σ, m/s; empty: the
model's, `railnav.filters.odometer_epochs.OdometerConfig`). A reading's scale error (wheel
wear, the nominal circumference) and its slips are the filter's business
(`railnav.filters.odometer_rows`), not the reader's.
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
from trackmodel.errors import finite_column
from trackmodel.files import atomic_write_csv

__all__ = ["OdometerLog", "read_odometer_csv", "write_odometer_csv", "ODOMETER_KINDS"]

Array = npt.NDArray[np.float64]

#: The two layouts: the column each needs.
ODOMETER_KINDS = {"speed": "speed_mps", "pulses": "pulses"}


@dataclass(frozen=True, eq=False)
class OdometerLog:
    """Odometer readings as speeds (N rows, in time order).

    Attributes
    ----------
    time_s : ndarray, shape (N,)
        Reading times in the file's reference (`time_column`), s (pulses: the midpoints).
    time_column : str
        ``gps_time_s`` or ``time_s``.
    speed_mps : ndarray, shape (N,)
        Speed magnitude, m/s (>= 0).
    direction : ndarray, shape (N,)
        +1, −1, or 0 (unknown) relative to the track's +s.
    resolution_mps : ndarray, shape (N,)
        Quantization step of each reading, m/s (0 for a speed sensor).
    sigma_mps : ndarray, shape (N,)
        The file's 1σ of each reading, m/s (NaN: none given).
    kind : str
        ``speed`` or ``pulses``.
    path : str
    pulse_length_m : float
        Distance per pulse, m (0 for a speed sensor).
    """

    time_s: Array
    time_column: str
    speed_mps: Array
    direction: Array
    resolution_mps: Array
    sigma_mps: Array
    kind: str
    path: str
    pulse_length_m: float = 0.0

    def __len__(self) -> int:
        return self.time_s.size

    def relative_time_s(self, start_gps_time_s: float) -> Array:
        """Reading times in seconds from the trip start."""
        return relative_times(self.time_s, self.time_column, start_gps_time_s)


def read_odometer_csv(path: str | os.PathLike, *, wheel_circumference_m: float | None = None,
                      pulses_per_rev: float | None = None) -> OdometerLog:
    """Read an odometer file (module docstring).

    Parameters
    ----------
    path : path
    wheel_circumference_m, pulses_per_rev : float, optional
        The nominal wheel and the pulse generator (needed for ``pulses``, refused without).

    Raises
    ------
    ConfigError
        As `railnav.sensors.tables.read_timed_csv`; neither or both of ``speed_mps`` and
        ``pulses``; a negative speed, a decreasing or fractional pulse count, a direction
        other than +1, −1, 0 (their row); pulses without the wheel, or a wheel given for
        speeds; fewer than 2 pulse rows.
    """
    frame, column, times = read_timed_csv(path, "odometer")
    present = [k for k, c in ODOMETER_KINDS.items() if c in frame.columns]
    if len(present) != 1:
        raise ConfigError(f"needs one of the columns {' or '.join(ODOMETER_KINDS.values())}"
                          f"{' (not both)' if present else ''}", path=path)
    kind = present[0]
    wheel = (wheel_circumference_m, pulses_per_rev)
    if kind == "speed" and any(w is not None for w in wheel):
        raise ConfigError("the wheel circumference and pulses per revolution are for pulse "
                          "counts; this file has speed_mps", path=path)
    direction = _direction(frame, path)
    sigma = optional_column(frame, "sigma_mps", path)
    if np.any(sigma <= 0):
        raise ConfigError("sigma_mps must be > 0", path=path,
                          row=int(np.flatnonzero(sigma <= 0)[0]) + 1, column="sigma_mps")
    if kind == "speed":
        speed = finite_column(frame, "speed_mps", path=path, error=ConfigError)
        if np.any(speed < 0):
            raise ConfigError("speed_mps must be >= 0 (the direction goes in a direction "
                              "column)", path=path, row=int(np.flatnonzero(speed < 0)[0]) + 1,
                              column="speed_mps")
        return OdometerLog(times, column, speed, direction, np.zeros_like(speed), sigma,
                           kind, str(path))
    return _from_pulses(frame, column, times, direction, sigma, wheel, path)


def _direction(frame: pd.DataFrame, path) -> Array:
    values = optional_column(frame, "direction", path)
    bad = np.flatnonzero(np.isfinite(values) & ~np.isin(values, (-1.0, 0.0, 1.0)))
    if bad.size:
        raise ConfigError("direction must be 1, -1, 0 or empty", path=path,
                          row=int(bad[0]) + 1, column="direction")
    return np.nan_to_num(values, nan=0.0)


def _from_pulses(frame, column: str, times: Array, direction: Array, sigma: Array, wheel,
                 path) -> OdometerLog:
    """Interval mean speeds of a cumulative pulse count."""
    circumference, per_rev = wheel
    if circumference is None or per_rev is None:
        raise ConfigError("pulse counts need the wheel circumference and the pulses per "
                          "revolution (--wheel-circumference-m, --pulses-per-rev)", path=path)
    if not (np.isfinite(circumference) and circumference > 0 and np.isfinite(per_rev)
            and per_rev > 0):
        raise ConfigError(f"wheel circumference ({circumference!r} m) and pulses per "
                          f"revolution ({per_rev!r}) must be > 0", path=path)
    count = finite_column(frame, "pulses", path=path, error=ConfigError)
    for bad, what in ((count != np.round(count), "an integer count"),
                      (np.concatenate([[False], np.diff(count) < 0]),
                       "never decreasing (unwrap a counter that wraps)")):
        if bad.any():
            raise ConfigError(f"pulses must be {what}", path=path,
                              row=int(np.flatnonzero(bad)[0]) + 1, column="pulses")
    if count.size < 2:
        raise ConfigError("pulse counts need at least 2 rows", path=path)
    pulse_m = float(circumference) / float(per_rev)
    dt = np.diff(times)
    return OdometerLog(0.5 * (times[1:] + times[:-1]), column, np.diff(count) * pulse_m / dt,
                       direction[1:], pulse_m / dt, sigma[1:], "pulses", str(path), pulse_m)


def write_odometer_csv(path: str | os.PathLike, time_s: Array, *, speed_mps: Array | None = None,
                       pulses: Array | None = None, direction: Array | None = None,
                       time_column: str = TIME_COLUMNS[1]) -> None:
    """Write an odometer file (module docstring), atomically: speeds or pulse counts."""
    if (speed_mps is None) == (pulses is None):
        raise ConfigError("give speed_mps or pulses")
    data = {time_column: np.asarray(time_s, dtype=float)}
    if speed_mps is not None:
        data["speed_mps"] = np.asarray(speed_mps, dtype=float)
    else:
        data["pulses"] = np.asarray(pulses, dtype=np.int64)
    if direction is not None:
        data["direction"] = np.asarray(direction, dtype=np.int64)
    atomic_write_csv(path, pd.DataFrame(data), float_format="%.17g")
