r"""Reading a recorded IMU log: jittered times, gaps and dropouts, increments, units, mounting.

`read_imu_log` reads a CSV log with an `strapdown.imu_spec.ImuSpec` (default: railnav's own
``imu.csv`` layout) into an `Imu` in the project's convention (SI, vehicle axes x forward,
y left, z up, instantaneous samples; `strapdown.rk4`) and an `ImuLog` that says what the
file's timing was:

* **Times** need only increase strictly: jitter, dropped samples and gaps are kept as they
  are, and every integrator of the project steps on the actual intervals (``dt`` per step:
  `ekf.step`, the navigator's sample grid). The *nominal* interval is ``1 / rate_hz`` of the
  spec, else the median step; a median step outside 0.1 ms – 0.1 s (10 kHz – 10 Hz) or more
  than 20 % off the spec's rate is an error (a time unit mistaken: ms read as s).
* **Gaps**: a step of at least `ImuSpec.gap_report_s` (default 5 nominal intervals) is listed
  in `ImuLog.gaps`; a step longer than `ImuSpec.max_gap_s` is an error (the filter would
  integrate a blind interval on interpolated inputs). `ImuLog.dropped_samples` counts the
  samples missing at the nominal rate.
* **Increments** (``kind = "increments"``): each row's Δv, Δθ cover the interval that ends
  at its time stamp, the step from the previous stamp (the first row, and a row after a
  dropout of more than half an interval, cover one nominal interval: a dropped sample's own
  increment is lost). The mean rate ``Δ/interval`` is the instantaneous rate at the
  interval's midpoint to second order, so it becomes a sample at that midpoint.
* **Units and mounting**: columns scaled to SI (`ImuSpec.accel_factor`, `gyro_factor`), then
  rotated into the vehicle frame (`ImuSpec.mounting_matrix`).
* **Plausibility** (``check=True``, `strapdown.imu_checks.check_imu_plausible`): the common
  unit and axis mistakes are errors before any filtering.

Time: with ``time_reference = "trip"`` the log's times are seconds from the trip start, as
given; with ``"gps"`` they are GPS seconds, the first sample becomes ``time_s = 0`` and
`ImuLog.start_gps_time_s` is its GPS time.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from strapdown.errors import ImuInputError
from strapdown.imu import Imu, read_imu_columns
from strapdown.imu_spec import DEFAULT_GAP_REPORT_INTERVALS, TIME_UNITS, ImuSpec

__all__ = ["ImuLog", "read_imu_log", "MIN_INTERVAL_S", "MAX_INTERVAL_S", "RATE_MISMATCH",
           "DROPOUT_INTERVALS"]

Array = npt.NDArray[np.float64]

#: Nominal intervals accepted, s (10 kHz ... 10 Hz): anything else is a time unit mistaken.
MIN_INTERVAL_S, MAX_INTERVAL_S = 1e-4, 0.1
#: Largest relative difference between the median step and the spec's ``rate_hz``.
RATE_MISMATCH = 0.2
#: A step longer than this many nominal intervals has dropped samples (an increment row
#: after it covers one nominal interval).
DROPOUT_INTERVALS = 1.5


@dataclass(frozen=True, eq=False)
class ImuLog:
    """An IMU log as read (module docstring).

    Attributes
    ----------
    imu : Imu
        Samples in the vehicle frame, SI, times s from the trip start.
    path : str
    spec : ImuSpec
    start_gps_time_s : float or None
        GPS time of ``time_s = 0`` for a log with GPS times (None: times from the trip start).
    nominal_interval_s : float
    gaps : tuple of (start_s, duration_s)
        Steps of at least the spec's report threshold (s from the trip start).
    dropped_samples : int
        Samples missing at the nominal rate.
    step_jitter_s : float
        Standard deviation of the steps shorter than `DROPOUT_INTERVALS` intervals about
        the nominal interval, s.
    """

    imu: Imu
    path: str
    spec: ImuSpec
    start_gps_time_s: float | None
    nominal_interval_s: float
    gaps: tuple[tuple[float, float], ...]
    dropped_samples: int
    step_jitter_s: float

    def summary(self) -> dict:
        """The ``imu`` entry of a run's ``summary.json``."""
        return {"path": self.path, "spec": self.spec.name, "samples": int(self.imu.time_s.size),
                "kind": self.spec.kind, "nominal_rate_hz": 1.0 / self.nominal_interval_s,
                "step_jitter_s": self.step_jitter_s, "dropped_samples": self.dropped_samples,
                "gaps": [list(g) for g in self.gaps]}


def read_imu_log(path: str | os.PathLike, spec: ImuSpec | None = None, *,
                 check: bool = True) -> ImuLog:
    """Read an IMU log (module docstring).

    Parameters
    ----------
    path : path
        CSV file (``#`` lines are comments).
    spec : ImuSpec, optional
        Its layout; default railnav's ``imu.csv`` (`strapdown.imu.IMU_COLUMNS`, SI, rates).
    check : bool
        Refuse implausible data (`strapdown.imu_checks.check_imu_plausible`).

    Raises
    ------
    ImuInputError
        Missing columns, a value that is not a finite number (its row and column), fewer
        than 2 rows, times that do not increase (their row), an implausible rate, a gap
        longer than ``spec.max_gap_s``, implausible data (with `check`); an empty file, a
        byte that is not UTF-8, a row with more fields than the header (its line).
    """
    spec = spec or ImuSpec()
    columns = (spec.time_column, *spec.accel_columns, *spec.gyro_columns)
    values = read_imu_columns(path, columns, layout=spec.name)
    raw_t = values[spec.time_column]
    step = np.diff(raw_t) * TIME_UNITS[spec.time_unit]
    nominal = _nominal_interval(step, spec, path)
    _check_gaps(step, spec, path)
    factor = TIME_UNITS[spec.time_unit]
    gps = spec.time_reference == "gps"
    times = (raw_t - raw_t[0]) * factor if gps else raw_t * factor   # GPS s: keep precision
    f = np.column_stack([values[c] for c in spec.accel_columns]) * spec.accel_factor
    w = np.column_stack([values[c] for c in spec.gyro_columns]) * spec.gyro_factor
    if spec.kind == "increments":
        times, f, w = _rates_from_increments(times, step, f, w, nominal)
    start_gps = None
    if gps:
        start_gps, times = float(raw_t[0] * factor + times[0]), times - times[0]
    M = spec.mounting_matrix()
    if not np.array_equal(M, np.eye(3)):
        f, w = f @ M.T, w @ M.T
    imu = Imu(time_s=times, f_b=f, omega_ib_b=w)
    log = ImuLog(imu=imu, path=str(path), spec=spec, start_gps_time_s=start_gps,
                 nominal_interval_s=nominal, gaps=_gaps(imu.time_s, spec, nominal),
                 dropped_samples=int(np.sum(np.maximum(np.rint(step / nominal) - 1, 0))),
                 step_jitter_s=_jitter(step, nominal))
    if check:
        from strapdown.imu_checks import check_imu_plausible
        check_imu_plausible(imu, path=path, spec=spec)
    return log


def _nominal_interval(step: Array, spec: ImuSpec, path) -> float:
    """The nominal sample interval, s, checked against plausible IMU rates."""
    median = float(np.median(step))
    nominal = 1.0 / spec.rate_hz if spec.rate_hz is not None else median
    if not MIN_INTERVAL_S <= median <= MAX_INTERVAL_S:
        raise ImuInputError(f"median time step {median:.6g} s ({1.0 / median:.6g} Hz) is not "
                            f"an IMU's (10 Hz to 10 kHz): is the time unit right (units.time "
                            f"= {spec.time_unit!r})?", path=path, column=spec.time_column)
    if abs(median / nominal - 1.0) > RATE_MISMATCH:
        raise ImuInputError(f"median time step {median:.6g} s disagrees with rate_hz = "
                            f"{spec.rate_hz:g} (interval {nominal:.6g} s)", path=path,
                            column=spec.time_column)
    return nominal


def _check_gaps(step: Array, spec: ImuSpec, path) -> None:
    long = np.flatnonzero(step > spec.max_gap_s)
    if long.size:
        k = int(long[0])
        raise ImuInputError(f"a {step[k]:.3f}-s gap in the samples (longer than max_gap_s = "
                            f"{spec.max_gap_s:g} s)", path=path, row=k + 2,
                            column=spec.time_column)


def _rates_from_increments(times: Array, step: Array, dv: Array, dtheta: Array,
                           nominal: float) -> tuple[Array, Array, Array]:
    """Mean rates of increment rows as samples at their intervals' midpoints."""
    interval = np.concatenate([[nominal], step])
    interval[1:][step > DROPOUT_INTERVALS * nominal] = nominal
    mid = times - 0.5 * interval
    return mid, dv / interval[:, None], dtheta / interval[:, None]


def _gaps(t: Array, spec: ImuSpec, nominal: float) -> tuple[tuple[float, float], ...]:
    threshold = spec.gap_report_s if spec.gap_report_s is not None else \
        DEFAULT_GAP_REPORT_INTERVALS * nominal
    step = np.diff(t)
    return tuple((float(t[k]), float(step[k])) for k in np.flatnonzero(step >= threshold))


def _jitter(step: Array, nominal: float) -> float:
    regular = step[step < DROPOUT_INTERVALS * nominal]
    return float(np.sqrt(np.mean((regular - nominal) ** 2))) if regular.size else 0.0
