"""Fix tables written as CSV (our columns) or NMEA 0183 (pynmea2's sentence builder).

`write_fixes_csv` writes the `gnss_obs.fixes.table.FIX_COLUMNS` that
`gnss_obs.fixes.csv_reader` reads back (``gps_time_s`` to 17 digits, so every float
round-trips). `write_fixes_nmea` writes one burst per fix, GGA + RMC + VTG + GST, each
sentence built and checksummed by pynmea2: the ellipsoidal height as GGA's altitude with
a zero geoid separation (the sum is what the reader takes; a fix without a height has
both fields empty, NMEA's null field for "not available", which pynmea2 reads as
``None``), the fix class as GGA quality
and RMC mode (`NMEA_CODES`), latitude and longitude to 1e-7 minute (0.2 mm), time to
0.01 s. Both write atomically.
"""
from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pynmea2

from gnss_obs.fixes.nmea_reader import KMPH_MPS, KNOT_MPS
from gnss_obs.fixes.table import FIX_COLUMNS
from gnss_obs.gpstime import from_gps_time_s, gps_time_s_to_calendar
from trackmodel.files import atomic_write, atomic_write_csv

__all__ = ["write_fixes_csv", "write_fixes_nmea", "nmea_sentences", "NMEA_CODES"]

#: Fix class -> (GGA quality, RMC mode indicator).
NMEA_CODES = {"rtk_fixed": (4, "R"), "rtk_float": (5, "F"), "dgps": (2, "D"),
              "single": (1, "A"), "dead_reckoning": (6, "E")}
#: Satellites and HDOP written in GGA (the reader ignores them).
_GGA_SATELLITES, _GGA_HDOP = "12", "0.9"
_FLOAT_FORMAT = "%.17g"


def write_fixes_csv(path: str | os.PathLike, table: pd.DataFrame) -> None:
    """Write a fix table as CSV (`FIX_COLUMNS` present in `table`, in that order)."""
    columns = [c for c in FIX_COLUMNS if c in table.columns and c != "sigma_source"]
    atomic_write_csv(path, table[columns], float_format=_FLOAT_FORMAT)


def _angle(value_deg: float, width: int, hemispheres: str) -> tuple[str, str]:
    """NMEA ``(d)ddmm.mmmmmmm`` and its hemisphere letter."""
    mag = abs(value_deg)
    degrees = int(mag)
    minutes = round((mag - degrees) * 60.0, 7)
    if minutes >= 60.0:
        degrees, minutes = degrees + 1, 0.0
    return f"{degrees:0{width}d}{minutes:010.7f}", hemispheres[value_deg < 0]


def _optional(value: float, fmt: str) -> str:
    return "" if not np.isfinite(value) else format(value, fmt)


def nmea_sentences(row, utc_label_s: float) -> list[str]:
    """The GGA, RMC, VTG and GST sentences of one fix.

    Parameters
    ----------
    row : mapping
        One fix (`FIX_COLUMNS`; σ and motion may be NaN).
    utc_label_s : float
        Its UTC label as seconds since 1980-01-06 (`gnss_obs.gpstime.from_gps_time_s`).

    Returns
    -------
    list of str
        Checksummed sentences without line ends.
    """
    year, month, day, hour, minute, second = (np.asarray(v).item() for v in
                                              gps_time_s_to_calendar(utc_label_s))
    second = round(second, 2)
    tod = f"{hour:02d}{minute:02d}{second:05.2f}"
    date = f"{day:02d}{month:02d}{year % 100:02d}"
    lat, ns = _angle(float(row["lat_deg"]), 2, "NS")
    lon, ew = _angle(float(row["lon_deg"]), 3, "EW")
    quality, mode = NMEA_CODES[row["quality"]]
    h = float(row["h_m"])
    speed, course = float(row["speed_mps"]), float(row["course_deg"])
    gga = pynmea2.GGA("GP", "GGA", (tod, lat, ns, lon, ew, str(quality), _GGA_SATELLITES,
                                    _GGA_HDOP, _optional(h, ".4f"), "M",
                                    "0.0" if np.isfinite(h) else "", "M", "", ""))
    rmc = pynmea2.RMC("GP", "RMC", (tod, "A", lat, ns, lon, ew,
                                    _optional(speed / KNOT_MPS, ".4f"),
                                    _optional(course, ".3f"), date, "", "", mode))
    vtg = pynmea2.VTG("GP", "VTG", (_optional(course, ".3f"), "T", "", "M",
                                    _optional(speed / KNOT_MPS, ".4f"), "N",
                                    _optional(speed / KMPH_MPS, ".4f"), "K", mode))
    sig = [float(row[c]) for c in ("sigma_north_m", "sigma_east_m", "sigma_up_m")]
    sentences = [gga, rmc, vtg]
    if all(np.isfinite(sig[:2])):               # the height's σ empty when it is unknown
        major = max(sig[:2])
        sentences.append(pynmea2.GST("GP", "GST", (tod, "", f"{major:.4f}",
                                                   f"{min(sig[:2]):.4f}", "0.0",
                                                   *(_optional(s, ".4f") for s in sig))))
    return [str(s) for s in sentences]


def write_fixes_nmea(path: str | os.PathLike, table: pd.DataFrame) -> None:
    """Write a fix table as NMEA 0183 (module docstring), one burst per row, CRLF line
    ends."""
    utc = from_gps_time_s(table["gps_time_s"].to_numpy(dtype=float), "UTC")
    with atomic_write(path, newline="") as fh:
        for (_, row), label in zip(table.iterrows(), utc):
            for sentence in nmea_sentences(row, float(label)):
                fh.write(sentence + "\r\n")
