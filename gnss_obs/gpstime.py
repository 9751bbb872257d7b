"""GPS time: the project's one time scale, and conversions into and out of it.

Convention (ARCHITECTURE.md, "Time"): time is GPS time in seconds (float64) since the GPS
epoch 1980-01-06 00:00:00 GPST, named ``gps_time_s``. Other scales are converted once,
at the boundary, by `to_gps_time_s`:

* GPST and Galileo System Time (GST): identical labels (GST is steered to GPST; the
  residual GGTO is nanoseconds and is a model term, not a calendar offset);
* BeiDou time: ``BDT = GPST - 14 s``;
* UTC: ``GPST = UTC + leap seconds`` (18 s since 2017-01-01);
* ``GLO`` (RINEX time-system name of GLONASS): **UTC**. GLONASS system time is kept on
  UTC(SU) + 3 h, but RINEX defines the ``GLO`` time tags as UTC (RINEX 3.04 §3.2 and
  Table A1 footnote; RINEX 2.11 §8.2 "GLONASS is basically running on UTC") and RTKLIB
  reads them so (``rinex.c`` ``decode_obsh``: ``"GLO"`` -> ``TSYS_UTC``). So ``GLO`` labels convert
  exactly like ``UTC`` labels: no 3 h shift (issue 16, defect 1).

Calendar fields are converted with integer day arithmetic (no datetime objects in loops),
so whole RINEX files convert in one vectorized call.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from gnss_obs.constants import BDT_MINUS_GPST_S, DAY_S, WEEK_S

__all__ = ["GPS_EPOCH", "calendar_to_gps_time_s", "gps_time_s_to_calendar",
           "week_sow_to_gps_time_s", "gps_time_s_to_week_sow", "to_gps_time_s",
           "from_gps_time_s", "datetime64_to_gps_time_s", "gps_time_s_to_datetime64",
           "leap_seconds_at", "TIME_SYSTEMS", "utc_datetime64_to_gps_time_s",
           "gps_time_s_to_utc_iso", "days_in_month", "gpst_label"]

#: The GPS epoch as a label, 1980-01-06 00:00:00.
GPS_EPOCH = np.datetime64("1980-01-06T00:00:00", "ns")
#: GPS seconds (open interval) that datetime64[ns] can label: int64 nanoseconds both from
#: the GPS epoch and from 1970 (the label's own count), a millisecond to spare for rounding
#: (float64's spacing there is ~2 µs).
_NS_RANGE_S = ((np.iinfo(np.int64).min + 1) / 1e9 + 1e-3,
               (np.iinfo(np.int64).max - int(GPS_EPOCH.astype(np.int64))) / 1e9 - 1e-3)
_GPS_EPOCH_DAYS = 3657  # days from 1970-01-01 to 1980-01-06

#: Time systems `to_gps_time_s` understands (RINEX 3 names).
TIME_SYSTEMS = ("GPS", "GAL", "BDT", "UTC", "GLO", "QZS", "IRN")

#: Leap seconds GPST - UTC, from the date each took effect (IERS Bulletin C), as
#: (UTC calendar label in GPS-epoch seconds, leap seconds). Used only when a file's header
#: does not give them.
_LEAP_TABLE = [
    ("1981-07-01", 1), ("1982-07-01", 2), ("1983-07-01", 3), ("1985-07-01", 4),
    ("1988-01-01", 5), ("1990-01-01", 6), ("1991-01-01", 7), ("1992-07-01", 8),
    ("1993-07-01", 9), ("1994-07-01", 10), ("1996-01-01", 11), ("1997-07-01", 12),
    ("1999-01-01", 13), ("2006-01-01", 14), ("2009-01-01", 15), ("2012-07-01", 16),
    ("2015-07-01", 17), ("2017-01-01", 18),
]


def _days_from_civil(year, month, day):
    """Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm)."""
    y = np.asarray(year, dtype=np.int64) - (np.asarray(month) <= 2)
    era = np.floor_divide(y, 400)
    yoe = y - era * 400
    m = np.asarray(month, dtype=np.int64)
    doy = (153 * (m + np.where(m > 2, -3, 9)) + 2) // 5 + np.asarray(day, dtype=np.int64) - 1
    doe = yoe * 365 + yoe // 4 - yoe // 100 + doy
    return era * 146097 + doe - 719468


def days_in_month(year: npt.ArrayLike, month: npt.ArrayLike) -> npt.NDArray[np.int64]:
    """Number of days of a month of the proleptic Gregorian calendar (`month` in 1..12)."""
    m = np.asarray(month, dtype=np.int64)
    next_year = np.asarray(year, dtype=np.int64) + (m == 12)
    return _days_from_civil(next_year, m % 12 + 1, 1) - _days_from_civil(year, m, 1)


def calendar_to_gps_time_s(year: npt.ArrayLike, month: npt.ArrayLike, day: npt.ArrayLike,
                           hour: npt.ArrayLike = 0, minute: npt.ArrayLike = 0,
                           second: npt.ArrayLike = 0.0) -> npt.NDArray[np.float64]:
    """Seconds since the GPS epoch of calendar labels, read in the same time scale.

    The labels are taken as they are (no leap seconds applied): use `to_gps_time_s` to
    move labels of another scale (UTC, BDT, GLONASST) to GPS time.

    Parameters
    ----------
    year, month, day, hour, minute : array_like of int
    second : array_like of float

    Returns
    -------
    ndarray of float64
        Seconds since 1980-01-06 00:00:00 in the labels' scale.
    """
    days = _days_from_civil(year, month, day) - _GPS_EPOCH_DAYS
    whole = (days * DAY_S + np.asarray(hour, dtype=np.int64) * 3600
             + np.asarray(minute, dtype=np.int64) * 60)
    return whole.astype(np.float64) + np.asarray(second, dtype=np.float64)


def gps_time_s_to_calendar(t: npt.ArrayLike) -> tuple[np.ndarray, ...]:
    """Calendar fields (year, month, day, hour, minute, second) of seconds since the GPS epoch."""
    t = np.asarray(t, dtype=np.float64)
    days = np.floor(t / DAY_S).astype(np.int64)
    sod = t - days * DAY_S
    z = days + _GPS_EPOCH_DAYS + 719468
    era = np.floor_divide(z, 146097)
    doe = z - era * 146097
    yoe = (doe - doe // 1460 + doe // 36524 - doe // 146096) // 365
    doy = doe - (365 * yoe + yoe // 4 - yoe // 100)
    mp = (5 * doy + 2) // 153
    day = doy - (153 * mp + 2) // 5 + 1
    month = mp + np.where(mp < 10, 3, -9)
    year = yoe + era * 400 + (month <= 2)
    hour = (sod // 3600).astype(np.int64)
    minute = ((sod - hour * 3600) // 60).astype(np.int64)
    second = sod - hour * 3600 - minute * 60
    return year, month, day, hour, minute, second


def week_sow_to_gps_time_s(week: npt.ArrayLike, sow: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """GPS week number (continuous, not modulo 1024) and seconds of week -> GPS seconds."""
    return np.asarray(week, dtype=np.float64) * WEEK_S + np.asarray(sow, dtype=np.float64)


def gps_time_s_to_week_sow(t: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """GPS seconds -> (continuous GPS week, seconds of week)."""
    t = np.asarray(t, dtype=np.float64)
    week = np.floor(t / WEEK_S).astype(np.int64)
    return week, t - week * WEEK_S


def datetime64_to_gps_time_s(dt: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """numpy datetime64 labels (taken in GPS time) -> seconds since the GPS epoch."""
    dt = np.asarray(dt, dtype="datetime64[ns]")
    return (dt - GPS_EPOCH).astype("timedelta64[ns]").astype(np.int64) / 1e9


def gps_time_s_to_datetime64(t: npt.ArrayLike) -> np.ndarray:
    """Seconds since the GPS epoch -> numpy datetime64[ns] labels in GPS time.

    A time that is not finite, or outside what datetime64[ns] can label from the GPS epoch
    (1687-09-26 to 2262-04-11), gives NaT: a damaged file's epoch in a message, not an
    overflowed label.
    """
    t = np.asarray(t, dtype=np.float64)
    ok = np.isfinite(t) & (t > _NS_RANGE_S[0]) & (t < _NS_RANGE_S[1])
    ns = np.round(np.where(ok, t, 0.0) * 1e9).astype(np.int64)
    out = np.where(ok, GPS_EPOCH + ns.astype("timedelta64[ns]"), np.datetime64("NaT", "ns"))
    return out[()] if out.ndim == 0 else out


def leap_seconds_at(t_utc_labels_s: npt.ArrayLike) -> np.ndarray:
    """GPST - UTC (s) in force at UTC labels given as seconds since 1980-01-06 (table to 2017)."""
    t = np.asarray(t_utc_labels_s, dtype=np.float64)
    starts = datetime64_to_gps_time_s(np.array([d for d, _ in _LEAP_TABLE], dtype="datetime64[ns]"))
    values = np.array([0] + [n for _, n in _LEAP_TABLE])
    return values[np.searchsorted(starts, t, side="right")]


def to_gps_time_s(labels_s: npt.ArrayLike, system: str, *,
                  leap_seconds: float | None = None) -> npt.NDArray[np.float64]:
    """Move time labels of a GNSS time scale to GPS time.

    Parameters
    ----------
    labels_s : array_like
        Calendar labels of `system` expressed as seconds since 1980-01-06 00:00:00
        (as `calendar_to_gps_time_s` returns them).
    system : {"GPS", "GAL", "QZS", "IRN", "BDT", "UTC", "GLO"}
        RINEX 3 time-system name of the labels.
    leap_seconds : float, optional
        GPST - UTC, s, for ``UTC`` and ``GLO`` (both UTC labels in RINEX). Taken from
        `leap_seconds_at` when omitted.

    Returns
    -------
    ndarray of float64
        GPS time, s since the GPS epoch.
    """
    t = np.asarray(labels_s, dtype=np.float64)
    if system in ("GPS", "GAL", "QZS", "IRN"):
        return t.copy()
    if system == "BDT":
        return t - BDT_MINUS_GPST_S
    if system in ("UTC", "GLO"):  # RINEX "GLO" labels are UTC (module docstring)
        leap = leap_seconds_at(t) if leap_seconds is None else leap_seconds
        return t + leap
    raise ValueError(f"unknown time system {system!r}; expected one of {TIME_SYSTEMS}")


def from_gps_time_s(t: npt.ArrayLike, system: str, *,
                    leap_seconds: float | None = None) -> npt.NDArray[np.float64]:
    """Inverse of `to_gps_time_s`: GPS time -> labels of `system` (s since 1980-01-06)."""
    t = np.asarray(t, dtype=np.float64)
    if system in ("GPS", "GAL", "QZS", "IRN"):
        return t.copy()
    if system == "BDT":
        return t + BDT_MINUS_GPST_S
    if system in ("UTC", "GLO"):
        if leap_seconds is None:
            leap = leap_seconds_at(t - leap_seconds_at(t))
        else:
            leap = leap_seconds
        return t - leap
    raise ValueError(f"unknown time system {system!r}; expected one of {TIME_SYSTEMS}")


def utc_datetime64_to_gps_time_s(dt: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """UTC labels as numpy datetime64 -> GPS time, s since the GPS epoch (leap seconds
    from `leap_seconds_at`)."""
    return to_gps_time_s(datetime64_to_gps_time_s(dt), "UTC")


def gps_time_s_to_utc_iso(t: npt.ArrayLike, *, suffix: str = "") -> np.ndarray:
    """GPS time -> ISO 8601 UTC labels to the millisecond, ``YYYY-MM-DDTHH:MM:SS.sss``
    followed by `suffix` (e.g. ``"Z"``); the inverse of `utc_datetime64_to_gps_time_s`.

    Returns
    -------
    ndarray of str
    """
    labels = gps_time_s_to_datetime64(from_gps_time_s(t, "UTC"))
    text = np.datetime_as_string(labels.astype("datetime64[ms]"), unit="ms")
    return np.char.add(text, suffix) if suffix else text


def gpst_label(t: float) -> str:
    """``YYYY-MM-DD HH:MM:SS`` of a GPS time, in GPS time (for messages)."""
    label = str(np.datetime_as_string(gps_time_s_to_datetime64(t).astype("datetime64[s]")))
    return label if label == "NaT" else label.replace("T", " ")
