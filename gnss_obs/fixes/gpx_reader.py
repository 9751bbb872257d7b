"""Fixes from GPX 1.0/1.1 files (gpxpy): track points (else route points) with a time.

Per point: latitude, longitude, the UTC ``time``; the ellipsoidal height only where the
point gives both ``ele`` and ``geoidheight`` (GPX's ``ele`` is above mean sea level, and
``geoidheight`` is the geoid above the WGS-84 ellipsoid, as in NMEA GGA); GPX 1.0's
``speed`` (m/s) and ``course`` (deg). The fix class from ``fix``: ``dgps`` -> ``dgps``,
``2d``/``3d``/``pps`` -> ``single``, ``none`` -> dropped (``no_fix``); a point without
``fix`` (most loggers write none) is ``single``. Points without a time are dropped
(``no_time``).
"""
from __future__ import annotations

import os
from datetime import timezone

import gpxpy
import gpxpy.gpx
import numpy as np

from gnss_obs.errors import GnssInputError
from gnss_obs.fixes.table import FixLog, fix_frame
from gnss_obs.gpstime import utc_datetime64_to_gps_time_s

__all__ = ["read_fixes_gpx", "GPX_FIX"]

#: GPX ``fix`` values -> fix class (None: no fix); absent: ``single``.
GPX_FIX = {"none": None, "2d": "single", "3d": "single", "pps": "single", "dgps": "dgps",
           None: "single"}


def read_fixes_gpx(path: str | os.PathLike) -> FixLog:
    """Read the fixes of a GPX file (module docstring).

    Raises
    ------
    GnssInputError
        Not a GPX file (with the parser's line and column), or no point with a time.
    """
    try:
        with open(path, encoding="utf-8") as fh:
            gpx = gpxpy.parse(fh)
    except (gpxpy.gpx.GPXException, UnicodeDecodeError) as exc:
        raise GnssInputError(f"not a valid GPX file ({' '.join(str(exc).split())})",
                             path=path) from None
    points = [p for t in gpx.tracks for s in t.segments for p in s.points]
    if not points:
        points = [p for r in gpx.routes for p in r.points]
    timed = [p for p in points if p.time is not None]
    skipped = {"no_time": len(points) - len(timed), "no_fix": 0}
    kept = [p for p in timed if GPX_FIX.get(p.type_of_gpx_fix, "single") is not None]
    skipped["no_fix"] = len(timed) - len(kept)
    if not kept:
        raise GnssInputError(f"no track or route point with a time and a fix "
                             f"({len(points)} points)", path=path)
    try:
        stamps = np.array([_utc_naive(p.time) for p in kept], dtype="datetime64[ns]")
    except ValueError as exc:        # e.g. a UTC offset of 24 h or more ("+31:00")
        raise GnssInputError(f"a point's time is not a valid UTC time "
                             f"({' '.join(str(exc).split())})", path=path) from None
    nan = np.nan

    def values(get) -> np.ndarray:
        return np.array([nan if (v := get(p)) is None else float(v) for p in kept])

    columns = {
        "gps_time_s": utc_datetime64_to_gps_time_s(stamps),
        "timestamp": np.array([p.time.isoformat() for p in kept], dtype=object),
        "lat_deg": values(lambda p: p.latitude), "lon_deg": values(lambda p: p.longitude),
        "h_m": values(lambda p: None if p.elevation is None or p.geoid_height is None
                      else p.elevation + p.geoid_height),
        "speed_mps": values(lambda p: p.speed), "course_deg": values(lambda p: p.course),
        "quality": np.array([GPX_FIX.get(p.type_of_gpx_fix, "single") for p in kept],
                            dtype=object),
        "flag": np.array([p.type_of_gpx_fix or "" for p in kept], dtype=object)}
    table, dup = fix_frame(columns, path=path)
    skipped["duplicate_time"] = dup
    return FixLog(table, "gpx", os.fspath(path), "UTC", utc_suffix="Z", skipped=skipped)


def _utc_naive(time) -> np.datetime64:
    """A gpxpy time (aware, or naive = UTC) as a naive UTC datetime64."""
    if time.tzinfo is not None:
        time = time.astimezone(timezone.utc).replace(tzinfo=None)
    return np.datetime64(time, "ns")
