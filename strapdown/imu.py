"""The IMU record: instantaneous specific force and angular rate in body axes.

``imu.csv`` columns (ARCHITECTURE.md CLI contract): ``time_s, ax_mps2, ay_mps2, az_mps2,
wx_radps, wy_radps, wz_radps`` — the specific force (m/s²) and the angular rate of the
body with respect to inertial space (rad/s), both in body axes (x forward, y left,
z up), *instantaneous* values at ``time_s`` (see `strapdown.rk4` for how integration
uses them). Times increase strictly; they may jitter and have gaps (every integrator of the
navigator steps on the actual intervals). Recorded logs in other layouts and units are read
by `strapdown.imu_log.read_imu_log` with an `strapdown.imu_spec.ImuSpec`.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from strapdown.errors import ImuColumnsError, ImuInputError
from trackmodel.errors import finite_column
from trackmodel.textfile import read_csv_table

__all__ = ["Imu", "IMU_COLUMNS", "read_imu_csv", "read_imu_columns"]

#: A missing-columns message lists at most this many of the file's columns.
_SHOWN_COLUMNS = 12
#: Read CSV floats exactly (pandas < 3 needs "round_trip"; pandas 3 does it by default and
#: deprecates the argument).
_EXACT_FLOATS = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}

Array = npt.NDArray[np.float64]

#: Columns of imu.csv holding ``f_b`` (m/s², b) and ``ω_ib_b`` (rad/s, b).
_ACCEL_COLUMNS = ("ax_mps2", "ay_mps2", "az_mps2")
_GYRO_COLUMNS = ("wx_radps", "wy_radps", "wz_radps")
#: Column names of imu.csv, in order.
IMU_COLUMNS = ("time_s",) + _ACCEL_COLUMNS + _GYRO_COLUMNS


@dataclass(frozen=True)
class Imu:
    """IMU samples.

    Attributes
    ----------
    time_s : ndarray, shape (N,)
        Sample times, s (strictly increasing).
    f_b : ndarray, shape (N, 3)
        Specific force in body axes, m/s².
    omega_ib_b : ndarray, shape (N, 3)
        Angular rate of ``b`` w.r.t. inertial space, in body axes, rad/s.
    """

    time_s: Array
    f_b: Array
    omega_ib_b: Array

    def __post_init__(self) -> None:
        n = np.shape(self.time_s)[0] if np.ndim(self.time_s) == 1 else -1
        if n < 0 or np.shape(self.f_b) != (n, 3) or np.shape(self.omega_ib_b) != (n, 3):
            raise ImuInputError(f"IMU arrays must be time (N,), f_b and omega_ib_b (N, 3); got "
                                f"{np.shape(self.time_s)}, {np.shape(self.f_b)}, "
                                f"{np.shape(self.omega_ib_b)}")

    @property
    def dt(self) -> float:
        """Mean sample interval, s (from the first and last sample; the interval of a
        uniform record)."""
        return float((self.time_s[-1] - self.time_s[0]) / (len(self.time_s) - 1))

    @property
    def u(self) -> Array:
        """Model inputs ``[f_b, ω_ib_b]``, shape (N, 6) (`strapdown.kinematics.INPUT_NAMES`)."""
        return np.concatenate([self.f_b, self.omega_ib_b], axis=-1)

    def to_frame(self) -> pd.DataFrame:
        """The imu.csv table (columns `IMU_COLUMNS`)."""
        data = np.column_stack([self.time_s, self.f_b, self.omega_ib_b])
        return pd.DataFrame(data, columns=list(IMU_COLUMNS))


def read_imu_csv(path: str | os.PathLike) -> Imu:
    """Read an imu.csv file (railnav's layout, `IMU_COLUMNS`: SI rates, times from the trip
    start). Jitter and gaps are kept as they are; `strapdown.imu_log.read_imu_log` reads
    the same file with its timing checked and reported and the data's plausibility tested.

    Raises
    ------
    ImuInputError
        Missing columns, non-numeric or non-finite values (located by row and column),
        fewer than 2 rows, times that do not increase (their row); an empty file, a byte
        that is not UTF-8 or a row with more fields than the header (located by line).
    """
    v = read_imu_columns(path, IMU_COLUMNS, layout="imu.csv")
    return Imu(time_s=v[IMU_COLUMNS[0]],
               f_b=np.column_stack([v[c] for c in _ACCEL_COLUMNS]),
               omega_ib_b=np.column_stack([v[c] for c in _GYRO_COLUMNS]))


def read_imu_columns(path: str | os.PathLike, columns, *, layout: str) -> dict:
    """The named columns of an IMU table as floats, the first one (time) increasing.

    Parameters
    ----------
    path : path
        CSV file (``#`` lines are comments).
    columns : sequence of str
        Time column first.
    layout : str
        Who names the columns, for the message (``"imu.csv"``, a spec file).

    Raises
    ------
    ImuInputError
        As `read_imu_csv`.
    """
    frame = read_csv_table(path, error=ImuInputError, comment="#", **_EXACT_FLOATS)
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        found = [str(c) for c in frame.columns]
        shown = ", ".join(found[:_SHOWN_COLUMNS]) + (
            f", ... ({len(found)} columns)" if len(found) > _SHOWN_COLUMNS else "")
        raise ImuColumnsError(f"missing column{'s' if len(missing) > 1 else ''} "
                              f"{', '.join(missing)} of the {layout} layout; the file has "
                              f"{shown}", path=path, missing=missing, found=found)
    values = {c: finite_column(frame, c, path=path, error=ImuInputError) for c in columns}
    if len(frame) < 2:
        raise ImuInputError("needs at least 2 samples", path=path)
    t = values[columns[0]]
    bad = np.flatnonzero(~(np.diff(t) > 0.0))
    if bad.size:
        k = int(bad[0])
        raise ImuInputError(f"time does not increase ({float(t[k + 1])!r} after {float(t[k])!r})",
                            path=path, row=k + 2, column=columns[0])
    return values
