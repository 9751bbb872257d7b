"""Fixes from u-blox UBX binary logs (pyubx2): NAV-PVT, with NAV-COV where present.

NAV-PVT gives, per epoch: GPS time of week ``iTOW`` (ms), the UTC date and time, the fix
type and flags, latitude, longitude, ellipsoidal height, NED velocity, ground speed,
heading of motion and their accuracy estimates (hAcc, vAcc, sAcc). NAV-COV, matched on
``iTOW``, gives the position covariance in NED (m²), which replaces hAcc/vAcc where valid.

Time: ``gps_time_s = week · 604800 + iTOW / 1000``, the week from the first message with a
valid UTC date (UTC + leap seconds, `gnss_obs.gpstime`), then counted on where iTOW wraps.

The fix class: ``carrSoln`` 2 (fixed) ``rtk_fixed``, 1 (float) ``rtk_float``, else
``diffSoln`` ``dgps``, else fix type 1 (dead reckoning only) ``dead_reckoning`` and 2, 3, 4
(2-D, 3-D, GNSS + dead reckoning) ``single``; fix types 0 (no fix) and 5 (time only) and
messages without ``gnssFixOk`` (except dead reckoning) are dropped (``no_fix``).

σ: hAcc is taken as the 1σ of each horizontal axis (u-blox calls it the "horizontal
accuracy estimate" without a confidence level; per axis is the conservative reading), vAcc
as the vertical and sAcc as the speed 1σ.
Messages with a bad checksum are skipped and counted (``bad_checksum``); a file without
NAV-PVT is an error that says which messages it has.
"""
from __future__ import annotations

import collections
import os

import numpy as np
from pyubx2 import ERR_LOG, UBX_PROTOCOL, UBXReader

from gnss_obs.constants import WEEK_S
from gnss_obs.errors import GnssInputError
from gnss_obs.fixes.table import FixLog, fix_frame
from gnss_obs.gpstime import calendar_to_gps_time_s, to_gps_time_s

__all__ = ["read_fixes_ubx", "MM", "UBX_FIX_TYPES"]

#: Millimetres (and mm/s) in m (m/s): the NAV-PVT integer units.
MM = 1e-3
#: NAV-PVT ``fixType`` values with a position: 1 dead reckoning, 2 2-D, 3 3-D, 4 GNSS + DR.
UBX_FIX_TYPES = {1: "dead_reckoning", 2: "single", 3: "single", 4: "single"}


def read_fixes_ubx(path: str | os.PathLike) -> FixLog:
    """Read the NAV-PVT (and NAV-COV) fixes of a UBX log (module docstring).

    Returns
    -------
    gnss_obs.fixes.table.FixLog
        ``time_scale`` GPS; ``timestamp`` holds the NAV-PVT UTC fields as ISO 8601.

    Raises
    ------
    GnssInputError
        No NAV-PVT, no valid UTC date to fix the GPS week, or no usable fix.
    """
    errors: list[Exception] = []
    pvt, cov, seen = [], {}, collections.Counter()
    with open(path, "rb") as fh:
        reader = UBXReader(fh, protfilter=UBX_PROTOCOL, quitonerror=ERR_LOG,
                           errorhandler=errors.append)
        for _, msg in reader:
            if msg is None:
                continue
            seen[msg.identity] += 1
            if msg.identity == "NAV-PVT":
                pvt.append(msg)
            elif msg.identity == "NAV-COV" and msg.posCovValid:
                cov[msg.iTOW] = msg
    skipped = {"bad_checksum": len(errors), "no_fix": 0}
    if not pvt:
        found = ", ".join(f"{k} x{v}" for k, v in sorted(seen.items())) or "no UBX message"
        raise GnssInputError(f"no NAV-PVT message (found: {found}; {len(errors)} bad)",
                             path=path)
    weeks = _weeks(pvt, path)
    rows = [_row(m, week, cov.get(m.iTOW)) for m, week in zip(pvt, weeks)]
    kept = [r for r in rows if r["quality"] is not None]
    skipped["no_fix"] = len(rows) - len(kept)
    if not kept:
        raise GnssInputError(f"no NAV-PVT with a fix ({len(rows)} messages)", path=path)
    columns = {k: np.array([r[k] for r in kept],
                           dtype=object if k in ("quality", "flag", "timestamp") else float)
               for k in kept[0]}
    table, dup = fix_frame(columns, path=path)
    skipped["duplicate_time"] = dup
    return FixLog(table, "ubx", os.fspath(path), "GPS", utc_suffix="Z", skipped=skipped)


def _weeks(pvt: list, path) -> list[int]:
    """The GPS week of each message (module docstring)."""
    first = next((m for m in pvt if m.validDate and m.validTime), None)
    if first is None:
        raise GnssInputError("no NAV-PVT with a valid UTC date: the GPS week is unknown",
                             path=path)
    utc = calendar_to_gps_time_s(first.year, first.month, first.day, first.hour, first.min,
                                 first.second + max(first.nano, 0) * 1e-9)
    gps = float(to_gps_time_s(utc, "UTC"))
    week = int(round((gps - first.iTOW * MM) / WEEK_S))
    start = pvt.index(first)
    weeks = [week] * len(pvt)
    for i in range(start + 1, len(pvt)):       # forward: iTOW wraps at the week's end
        step = pvt[i].iTOW - pvt[i - 1].iTOW
        weeks[i] = weeks[i - 1] + (1 if step < -WEEK_S / 2 / MM else 0)
    for i in range(start - 1, -1, -1):          # backward from the first dated message
        step = pvt[i + 1].iTOW - pvt[i].iTOW
        weeks[i] = weeks[i + 1] - (1 if step < -WEEK_S / 2 / MM else 0)
    return weeks


def _quality(msg) -> tuple[str | None, str]:
    flag = f"fixType {msg.fixType} carrSoln {msg.carrSoln}"
    if msg.fixType not in UBX_FIX_TYPES or (not msg.gnssFixOk and msg.fixType != 1):
        return None, flag
    if msg.carrSoln == 2:
        return "rtk_fixed", flag
    if msg.carrSoln == 1:
        return "rtk_float", flag
    if msg.diffSoln and msg.fixType != 1:
        return "dgps", flag
    return UBX_FIX_TYPES[msg.fixType], flag


def _row(msg, week: int, cov) -> dict:
    """The table row of one NAV-PVT (with its NAV-COV, if any)."""
    quality, flag = _quality(msg)
    sig_h, sig_v = msg.hAcc * MM, msg.vAcc * MM
    sig_e = sig_n = sig_h
    cov_en = 0.0
    if cov is not None:
        sig_n, sig_e, sig_v = (float(np.sqrt(max(c, 0.0))) for c in
                               (cov.posCovNN, cov.posCovEE, cov.posCovDD))
        cov_en = float(cov.posCovNE)
    stamp = (f"{msg.year:04d}-{msg.month:02d}-{msg.day:02d}T{msg.hour:02d}:{msg.min:02d}:"
             f"{msg.second:02d}Z") if msg.validDate and msg.validTime else ""
    return {"gps_time_s": week * float(WEEK_S) + msg.iTOW * MM, "timestamp": stamp,
            "lat_deg": float(msg.lat), "lon_deg": float(msg.lon), "h_m": msg.height * MM,
            "speed_mps": msg.gSpeed * MM, "course_deg": float(msg.headMot),
            "v_east_mps": msg.velE * MM, "v_north_mps": msg.velN * MM,
            "v_up_mps": -msg.velD * MM, "sigma_east_m": sig_e, "sigma_north_m": sig_n,
            "sigma_up_m": sig_v, "cov_en_m2": cov_en, "sigma_speed_mps": msg.sAcc * MM,
            "quality": quality, "flag": flag}
