"""The fix table: what every fix reader returns, one row per position fix.

A *fix* is a receiver's own position solution (NMEA GGA/RMC, u-blox NAV-PVT, a GPX track
point, a CSV row), as opposed to the raw pseudoranges of RINEX. Every reader of
`gnss_obs.fixes` returns the same plain `pandas.DataFrame`, `FIX_COLUMNS` in this order:

==================  =========================================================================
column              meaning
==================  =========================================================================
``gps_time_s``      GPS time of the fix, s since 1980-01-06 (`gnss_obs.gpstime`)
``timestamp``       the file's own time label as text (ISO 8601 UTC for NMEA, CSV and GPX;
                    the NAV-PVT UTC fields for UBX), or empty
``lat_deg``         geodetic latitude (WGS-84), deg
``lon_deg``         longitude, deg
``h_m``             ellipsoidal height, m (NaN where the file gives none, or only a height
                    above mean sea level without the geoid separation)
``speed_mps``       horizontal speed over ground, m/s (NaN: none)
``course_deg``      course over ground, deg clockwise from true north (NaN: none)
``v_east_mps`` ...  ``v_east_mps, v_north_mps, v_up_mps``: velocity in ENU, m/s, where the
                    file gives its components (UBX NAV-PVT); NaN otherwise
``sigma_east_m``    1σ of the east position error, m (``sigma_north_m``, ``sigma_up_m``)
``cov_en_m2``       east–north covariance, m² (0 where the file gives none)
``sigma_speed_mps`` 1σ of the speed, m/s
``quality``         the fix class, one of `FIX_QUALITIES`
``flag``            the file's own quality flag as text (``NARROW_INT3``, ``GGA 4``, ...)
``sigma_source``    ``file`` where the σ came from the file (GST, hAcc/vAcc, NAV-COV, σ
                    columns), ``table`` where `gnss_obs.fixes.quality` filled them in
==================  =========================================================================

The readers fill the σ they find and leave NaN elsewhere; `gnss_obs.fixes.read.read_fixes`
fills the rest from the quality class (`gnss_obs.fixes.quality.apply_fix_sigmas`).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:                 # pandas is imported where a table is built
    import pandas as pd

from gnss_obs.errors import GnssInputError

__all__ = ["FIX_COLUMNS", "FIX_QUALITIES", "DEAD_RECKONING", "FixLog", "fix_frame",
           "SIGMA_COLUMNS", "TIME_SCALES"]

#: Fix classes, best first: carrier-phase fixed, carrier-phase float, code-differential,
#: single point, dead reckoning (the receiver's own propagation without GNSS).
FIX_QUALITIES = ("rtk_fixed", "rtk_float", "dgps", "single", "dead_reckoning")
#: The class of a receiver's own inertial extrapolation of its last GNSS solution (NMEA GGA 6,
#: u-blox fix type 1, a log's ``PROPAGATED``): not a measurement of where it is now.
DEAD_RECKONING = FIX_QUALITIES[-1]
#: The position and speed σ columns (NaN until a σ is known).
SIGMA_COLUMNS = ("sigma_east_m", "sigma_north_m", "sigma_up_m", "sigma_speed_mps")
#: Columns of the fix table, in order (module docstring).
FIX_COLUMNS = ("gps_time_s", "timestamp", "lat_deg", "lon_deg", "h_m", "speed_mps",
               "course_deg", "v_east_mps", "v_north_mps", "v_up_mps", *SIGMA_COLUMNS[:3],
               "cov_en_m2", SIGMA_COLUMNS[3], "quality", "flag", "sigma_source")
#: Time scales of fix files: ``UTC`` labels (NMEA, ISO timestamps, GPX) or ``GPS`` time of
#: week (UBX iTOW).
TIME_SCALES = ("UTC", "GPS")


@dataclass(frozen=True, eq=False)
class FixLog:
    """A fix file as read.

    Attributes
    ----------
    table : pandas.DataFrame
        `FIX_COLUMNS`, in time order (``gps_time_s``), one row per epoch.
    format : str
        ``csv``, ``nmea``, ``ubx`` or ``gpx``.
    path : str
    time_scale : str
        ``UTC`` or ``GPS`` (`TIME_SCALES`): the scale of the file's own time labels.
    utc_suffix : str
        How the file marks UTC in its timestamps (``""``: naive labels, ``"Z"``), so that
        outputs can write times the way the file does.
    skipped : dict of str to int
        Records read but not kept, by reason (``bad_checksum``, ``no_fix``,
        ``duplicate_time``, ...).
    """

    table: pd.DataFrame
    format: str
    path: str
    time_scale: str
    utc_suffix: str = ""
    skipped: dict[str, int] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.table)


def fix_frame(columns: dict, *, path: str | os.PathLike) -> tuple[pd.DataFrame, int]:
    """The fix table from reader columns: missing columns filled, repeated times dropped
    (the first kept). The rows must be in time order: a time that goes back is an error (a
    wrong or cut time label; sorted, it had moved a fix minutes away and the run's start
    with it).

    Parameters
    ----------
    columns : dict of str to array_like
        At least ``gps_time_s, lat_deg, lon_deg, quality, flag``; every array of the same
        length.
    path : str or os.PathLike
        The file, for errors.

    Returns
    -------
    table : pandas.DataFrame
        `FIX_COLUMNS`.
    n_duplicates : int
        Rows dropped for a repeated time.

    Raises
    ------
    GnssInputError
        No row, a latitude or longitude out of range, a quality not in `FIX_QUALITIES`, or
        a time that goes back (named by the file's own time labels).
    """
    import pandas as pd  # here, not at import: the CLI parser reads this module

    n = len(columns["gps_time_s"])
    if n == 0:
        raise GnssInputError("no usable fix in the file", path=path)
    nan = np.full(n, np.nan)
    defaults = {"timestamp": np.full(n, "", dtype=object), "cov_en_m2": np.zeros(n),
                "sigma_source": np.full(n, "", dtype=object)}
    frame = pd.DataFrame({c: columns.get(c, defaults.get(c, nan)) for c in FIX_COLUMNS})
    for name, limit in (("lat_deg", 90.0), ("lon_deg", 180.0)):
        bad = np.flatnonzero(~(np.abs(frame[name].to_numpy(dtype=float)) <= limit))
        if bad.size:
            raise GnssInputError(f"{float(frame[name].iloc[bad[0]])!r} is not in [-{limit:g}, "
                                 f"{limit:g}]", path=path, column=name)
    unknown = sorted(set(frame["quality"]) - set(FIX_QUALITIES))
    if unknown:
        raise GnssInputError(f"unknown fix quality {unknown[0]!r} (known: "
                             f"{', '.join(FIX_QUALITIES)})", path=path, column="quality")
    times = frame["gps_time_s"].to_numpy(dtype=float)
    back = np.flatnonzero(np.diff(times) < 0.0)
    if back.size:
        later, earlier = (_time_label(frame, i) for i in (back[0] + 1, back[0]))
        raise GnssInputError(f"time goes back: {later} after {earlier} (fixes must be in "
                             f"time order)", path=path)
    dup = frame["gps_time_s"].duplicated(keep="first").to_numpy()
    return frame[~dup].reset_index(drop=True), int(dup.sum())


def _time_label(frame, i: int) -> str:
    """Row `i`'s time as the file writes it (its ``timestamp``), else its GPS seconds."""
    label = frame["timestamp"].iloc[i]
    return str(label) if label else f"{frame['gps_time_s'].iloc[i]:.3f} s GPS"
