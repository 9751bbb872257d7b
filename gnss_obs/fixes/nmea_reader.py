"""Fixes from NMEA 0183 sentences (pynmea2): GGA, RMC, VTG, GST, GSA.

A receiver sends one burst of sentences per epoch. The sentences with a UTC time of day
(GGA, RMC, GST) open or join the epoch of that time; VTG and GSA, which carry none, join
the epoch of the sentence before them. Per epoch:

* position from GGA (else RMC); ellipsoidal height = GGA altitude above mean sea level +
  geoid separation, only when the sentence gives both (else NaN);
* the fix class from GGA's quality (1 single, 2 DGPS, 3 PPS = single, 4 RTK fixed, 5 RTK
  float, 6 dead reckoning; 0 none, 7 manual and 8 simulator are not measured fixes and are
  dropped), else from RMC's status and mode (A, D, R, F, E); a GSA fix type 1 (no fix) drops
  the epoch;
* speed and course from RMC (knots) or VTG (km/h);
* σ from GST (σ of latitude, longitude and altitude errors, m).

The date comes from RMC (GGA has only the time of day); epochs before the first RMC take
its date, and a time of day that goes back by more than 12 h starts the next day. A file
without RMC needs the `date` argument.

Sentences without a valid checksum are skipped and counted (``bad_checksum``), as are
lines that are not NMEA (``not_nmea``) and other sentence types (``other``); a sentence
with a valid checksum whose fields cannot be read is an error at its line.
"""
from __future__ import annotations

import datetime as _dt
import os

import numpy as np
import pynmea2

from gnss_obs.errors import GnssInputError
from gnss_obs.fixes.table import FixLog, fix_frame
from gnss_obs.gpstime import utc_datetime64_to_gps_time_s

__all__ = ["read_fixes_nmea", "KNOT_MPS", "KMPH_MPS", "GGA_QUALITY", "RMC_MODE"]

#: One knot (international nautical mile per hour) in m/s.
KNOT_MPS = 1852.0 / 3600.0
#: One km/h in m/s.
KMPH_MPS = 1.0 / 3.6
#: GGA fix quality -> fix class (None: not a measured fix).
GGA_QUALITY = {0: None, 1: "single", 2: "dgps", 3: "single", 4: "rtk_fixed", 5: "rtk_float",
               6: "dead_reckoning", 7: None, 8: None}
#: RMC mode indicator (NMEA 2.3+) -> fix class (None: not a measured fix).
RMC_MODE = {"A": "single", "D": "dgps", "P": "dgps", "R": "rtk_fixed", "F": "rtk_float",
            "E": "dead_reckoning", "N": None, "M": None, "S": None}
_TIMED = ("GGA", "RMC", "GST")
_HALF_DAY_S = 43_200.0
_DAY = _dt.timedelta(days=1)


def read_fixes_nmea(path: str | os.PathLike, *, date: _dt.date | None = None) -> FixLog:
    """Read the fixes of an NMEA 0183 log (module docstring).

    Parameters
    ----------
    path : str or os.PathLike
    date : datetime.date, optional
        UTC date of the first epoch, for logs without RMC.

    Returns
    -------
    gnss_obs.fixes.table.FixLog
        ``time_scale`` UTC; ``skipped`` counts ``bad_checksum``, ``not_nmea``, ``other``,
        ``no_fix``, ``duplicate_time``.

    Raises
    ------
    GnssInputError
        Nothing usable left, no date, or unreadable fields in a sentence with a valid
        checksum (with its line).
    """
    skipped = {"bad_checksum": 0, "not_nmea": 0, "other": 0, "no_fix": 0}
    epochs = _epochs(path, skipped)
    if not epochs:
        raise GnssInputError(f"no GGA or RMC sentence with a valid checksum ({_counts(skipped)})",
                             path=path)
    _assign_dates(epochs, date, path)
    rows = [row for row in (_fix(e) for e in epochs) if row is not None]
    skipped["no_fix"] = len(epochs) - len(rows)
    if not rows:
        raise GnssInputError(f"no valid fix in {len(epochs)} epochs ({_counts(skipped)})",
                             path=path)
    columns = {k: np.array([r[k] for r in rows], dtype=object if k in ("quality", "flag",
                                                                         "timestamp") else float)
               for k in rows[0]}
    stamps = np.array([r["timestamp"] for r in rows], dtype="datetime64[ns]")
    columns["gps_time_s"] = utc_datetime64_to_gps_time_s(stamps)
    columns["timestamp"] = np.char.add(np.datetime_as_string(stamps.astype("datetime64[ms]"),
                                                             unit="ms"), "Z").astype(object)
    table, dup = fix_frame(columns, path=path)
    skipped["duplicate_time"] = dup
    return FixLog(table, "nmea", os.fspath(path), "UTC", utc_suffix="Z", skipped=skipped)


def _counts(skipped: dict) -> str:
    return ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in skipped.items() if v) or "empty"


def _epochs(path, skipped: dict) -> list[dict]:
    """One dict per epoch: the fields of its sentences (module docstring)."""
    epochs: list[dict] = []
    with open(path, encoding="ascii", errors="replace") as fh:
        for number, line in enumerate(fh, start=1):
            text = line.strip()
            if not text:
                continue
            if not text.startswith(("$", "!")):
                skipped["not_nmea"] += 1
                continue
            try:
                msg = pynmea2.parse(text, check=True)
            except pynmea2.ChecksumError:
                skipped["bad_checksum"] += 1
                continue
            except pynmea2.ParseError:
                skipped["other"] += 1
                continue
            kind = getattr(msg, "sentence_type", "")
            if kind not in _TIMED + ("VTG", "GSA"):
                skipped["other"] += 1
                continue
            try:
                _add(epochs, kind, msg)
            except (ValueError, TypeError, AttributeError) as exc:
                raise GnssInputError(f"{kind}: unreadable field ({exc})", path=path,
                                     line=number) from None
    return epochs


def _add(epochs: list[dict], kind: str, msg) -> None:
    """Put one sentence's fields into its epoch."""
    if kind in _TIMED:
        if msg.timestamp is None:
            return
        tod = msg.timestamp
        if not isinstance(tod, _dt.time):       # pynmea2 returns a field it cannot parse
            raise ValueError(f"time {tod!r}")
        seconds = tod.hour * 3600 + tod.minute * 60 + tod.second + tod.microsecond * 1e-6
        if not epochs or abs(epochs[-1]["tod_s"] - seconds) > 5e-4:
            epochs.append({"tod_s": seconds, "tod": tod})
    elif not epochs:
        return
    epoch = epochs[-1]
    if kind == "GGA":
        epoch["gga_quality"] = int(msg.gps_qual or 0)
        if msg.lat and msg.lon:
            epoch.update(lat=msg.latitude, lon=msg.longitude)
        if msg.altitude is not None and msg.geo_sep not in (None, ""):
            epoch["h_m"] = float(msg.altitude) + float(msg.geo_sep)
    elif kind == "RMC":
        epoch.update(rmc_status=msg.status, rmc_mode=(msg.mode_indicator or "")[:1])
        if msg.datestamp is not None:
            if not isinstance(msg.datestamp, _dt.date):
                raise ValueError(f"date {msg.datestamp!r}")
            epoch["date"] = msg.datestamp
        if msg.lat and msg.lon and "lat" not in epoch:
            epoch.update(lat=msg.latitude, lon=msg.longitude)
        _motion(epoch, msg.spd_over_grnd, KNOT_MPS, msg.true_course)
    elif kind == "VTG":
        _motion(epoch, msg.spd_over_grnd_kmph, KMPH_MPS, msg.true_track)
    elif kind == "GST":
        for field, column in (("std_dev_latitude", "sigma_north_m"),
                              ("std_dev_longitude", "sigma_east_m"),
                              ("std_dev_altitude", "sigma_up_m")):
            value = getattr(msg, field)
            if value is not None:
                epoch[column] = float(value)
    elif kind == "GSA" and msg.mode_fix_type:
        epoch["gsa_fix"] = int(msg.mode_fix_type)


def _motion(epoch: dict, speed, unit_mps: float, course) -> None:
    if speed is not None and "speed_mps" not in epoch:
        epoch["speed_mps"] = float(speed) * unit_mps
    if course is not None and "course_deg" not in epoch:
        epoch["course_deg"] = float(course)


def _assign_dates(epochs: list[dict], date: _dt.date | None, path) -> None:
    """Give every epoch a date (module docstring)."""
    first = next((i for i, e in enumerate(epochs) if "date" in e), None)
    if first is None and date is None:
        raise GnssInputError("no RMC sentence gives the date (GGA has the time of day "
                             "only): give the date", path=path)
    if first is None:
        current, ref_tod = date, epochs[0]["tod_s"]
    else:
        current, ref_tod = epochs[first]["date"], epochs[first]["tod_s"]
        for e in epochs[:first]:    # before the first RMC: its date, or the day before
            e["date"] = current - _DAY if e["tod_s"] - ref_tod > _HALF_DAY_S else current
        epochs = epochs[first:]
    previous = ref_tod
    for e in epochs:
        if "date" in e:
            current = e["date"]
        elif e["tod_s"] < previous - _HALF_DAY_S:
            current = current + _DAY
        e["date"], previous = current, e["tod_s"]


def _quality(epoch: dict) -> tuple[str | None, str]:
    """Fix class (None: no fix) and the flag it came from."""
    if epoch.get("gsa_fix") == 1:
        return None, "GSA 1"
    if "gga_quality" in epoch:
        q = epoch["gga_quality"]
        return GGA_QUALITY.get(q), f"GGA {q}"
    if epoch.get("rmc_status") != "A":
        return None, f"RMC {epoch.get('rmc_status', '')}"
    mode = epoch.get("rmc_mode", "")
    return (RMC_MODE.get(mode) if mode else "single"), f"RMC A{mode}"


def _fix(epoch: dict) -> dict | None:
    """The table row of an epoch, or None when it has no valid fix."""
    quality, flag = _quality(epoch)
    if quality is None or "lat" not in epoch:
        return None
    stamp = _dt.datetime.combine(epoch["date"], epoch["tod"].replace(tzinfo=None))
    nan = float("nan")
    return {"timestamp": np.datetime64(stamp, "ns"), "lat_deg": epoch["lat"],
            "lon_deg": epoch["lon"], "h_m": epoch.get("h_m", nan),
            "speed_mps": epoch.get("speed_mps", nan), "course_deg": epoch.get("course_deg", nan),
            "sigma_east_m": epoch.get("sigma_east_m", nan),
            "sigma_north_m": epoch.get("sigma_north_m", nan),
            "sigma_up_m": epoch.get("sigma_up_m", nan), "quality": quality, "flag": flag}
