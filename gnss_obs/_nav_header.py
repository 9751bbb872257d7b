"""RINEX navigation header records: ionosphere coefficients, time corrections, leap seconds."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnss_obs._rinex_header import (
    HeaderLine,
    float_field,
    int_field,
    leap_seconds_field,
    lenient_floats,
)

__all__ = ["NavHeader", "parse_nav_header", "IONO_KEYS"]

#: ``IONOSPHERIC CORR`` type (RINEX 3) -> NavHeader attribute.
IONO_KEYS = {"GPSA": "iono_gps_alpha", "GPSB": "iono_gps_beta", "GAL": "iono_gal",
             "BDSA": "iono_bds_alpha", "BDSB": "iono_bds_beta", "QZSA": "iono_qzs_alpha",
             "QZSB": "iono_qzs_beta", "IRNA": "iono_irn_alpha", "IRNB": "iono_irn_beta"}
#: Number of coefficients per ionosphere model (NeQuick-G has three: ai0, ai1, ai2).
_N_COEFF = {"GAL": 3}
_KLOBUCHAR_COEFFS = 4
_IONO_V3_COLUMNS = ((5, 17), (17, 29), (29, 41), (41, 53))
_IONO_V2_COLUMNS = ((2, 14), (14, 26), (26, 38), (38, 50))


@dataclass(frozen=True, kw_only=True, eq=False)
class NavHeader:
    """Navigation header values.

    Attributes
    ----------
    version : float
        Format version.
    leap_seconds : int or None
        GPST - UTC, s (``LEAP SECONDS``).
    iono_gps_alpha, iono_gps_beta : ndarray, shape (4,), or None
        Klobuchar coefficients α (s, s/semicircle, s/semicircle², s/semicircle³) and
        β (s, s/semicircle, ...), as broadcast.
    iono_gal : ndarray, shape (3,), or None
        NeQuick-G effective ionisation coefficients ai0 (sfu), ai1 (sfu/deg), ai2 (sfu/deg²).
    iono_bds_alpha, iono_bds_beta, iono_qzs_alpha, iono_qzs_beta, iono_irn_alpha, \
iono_irn_beta : ndarray, shape (4,), or None
        Klobuchar-type coefficients of BeiDou, QZSS and NavIC.
    time_corrections : dict of str to tuple
        ``TIME SYSTEM CORR`` type (``"GPUT"``, ``"GAGP"``...) ->
        ``(a0_s, a1_sps, ref_time_sow, ref_week)``; RINEX 2 ``DELTA-UTC`` is ``"GPUT"``.
    """

    version: float
    leap_seconds: int | None = None
    iono_gps_alpha: np.ndarray | None = None
    iono_gps_beta: np.ndarray | None = None
    iono_gal: np.ndarray | None = None
    iono_bds_alpha: np.ndarray | None = None
    iono_bds_beta: np.ndarray | None = None
    iono_qzs_alpha: np.ndarray | None = None
    iono_qzs_beta: np.ndarray | None = None
    iono_irn_alpha: np.ndarray | None = None
    iono_irn_beta: np.ndarray | None = None
    time_corrections: dict[str, tuple] = field(default_factory=dict)


def _coefficients(h: HeaderLine, columns, n: int, path, key: str) -> np.ndarray:
    return np.array([float_field(h, a, b, path=path, column=key, d_exponent=True)
                     for a, b in columns[:n]])


_DELTA_UTC_COLUMNS = ((3, 22), (22, 41), (41, 50), (50, 59))


def parse_nav_header(records: list[HeaderLine], version: float, path,
                     notes: list[str] | None = None, *, system: str = "M") -> NavHeader:
    """Interpret the header records of a RINEX 2, 3 or 4 navigation file.

    Lines read leniently (`gnss_obs._rinex_header.lenient_floats`) are noted in `notes`.
    `system` is the system of a RINEX 2 file: a Galileo file's ``ION ALPHA`` holds the three
    NeQuick-G coefficients ai0-ai2 (RINEX 2.12), read into ``iono_gal``.
    """
    notes = [] if notes is None else notes
    values: dict = {"version": version, "time_corrections": {}}
    for h in records:
        c = h.content
        if h.label == "IONOSPHERIC CORR":
            key = c[:4].strip()
            if key in IONO_KEYS:
                n = _N_COEFF.get(key, _KLOBUCHAR_COEFFS)
                values[IONO_KEYS[key]] = _coefficients(h, _IONO_V3_COLUMNS, n, path, key)
        elif h.label == "ION ALPHA" and system == "E":
            values["iono_gal"] = np.array(lenient_floats(
                h, _IONO_V2_COLUMNS[:_N_COEFF["GAL"]], path=path, notes=notes, column=h.label,
                d_exponent=True))
        elif h.label in ("ION ALPHA", "ION BETA"):
            attr = "iono_gps_alpha" if h.label == "ION ALPHA" else "iono_gps_beta"
            values[attr] = np.array(lenient_floats(h, _IONO_V2_COLUMNS, path=path, notes=notes,
                                                   column=h.label, d_exponent=True))
        elif h.label == "TIME SYSTEM CORR":
            values["time_corrections"][c[:4].strip()] = (
                float_field(h, 5, 22, path=path, column="a0", d_exponent=True),
                float_field(h, 22, 38, path=path, column="a1", d_exponent=True),
                float(int_field(h, 38, 45, path=path, column="reference time")),
                int_field(h, 45, 50, path=path, column="reference week"))
        elif h.label == "DELTA-UTC: A0,A1,T,W":
            a0, a1, t, w = lenient_floats(h, _DELTA_UTC_COLUMNS, path=path, notes=notes,
                                          column="DELTA-UTC", d_exponent=True)
            values["time_corrections"]["GPUT"] = (a0, a1, float(int(t)), int(w))
        elif h.label == "LEAP SECONDS":
            values["leap_seconds"] = leap_seconds_field(h, path=path)
    return NavHeader(**values)
