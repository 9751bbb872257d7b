"""RINEX navigation header records: ionosphere coefficients, time corrections, leap seconds."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnss_obs._rinex_header import HeaderLine, float_field, int_field

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


def parse_nav_header(records: list[HeaderLine], version: float, path) -> NavHeader:
    """Interpret the header records of a RINEX 2 or 3 navigation file."""
    values: dict = {"version": version, "time_corrections": {}}
    for h in records:
        c = h.content
        if h.label == "IONOSPHERIC CORR":
            key = c[:4].strip()
            if key in IONO_KEYS:
                n = _N_COEFF.get(key, _KLOBUCHAR_COEFFS)
                values[IONO_KEYS[key]] = _coefficients(h, _IONO_V3_COLUMNS, n, path, key)
        elif h.label in ("ION ALPHA", "ION BETA"):
            attr = "iono_gps_alpha" if h.label == "ION ALPHA" else "iono_gps_beta"
            values[attr] = _coefficients(h, _IONO_V2_COLUMNS, _KLOBUCHAR_COEFFS, path, h.label)
        elif h.label == "TIME SYSTEM CORR":
            values["time_corrections"][c[:4].strip()] = (
                float_field(h, 5, 22, path=path, column="a0", d_exponent=True),
                float_field(h, 22, 38, path=path, column="a1", d_exponent=True),
                float(int_field(h, 38, 45, path=path, column="reference time")),
                int_field(h, 45, 50, path=path, column="reference week"))
        elif h.label == "DELTA-UTC: A0,A1,T,W":
            values["time_corrections"]["GPUT"] = (
                float_field(h, 3, 22, path=path, column="A0", d_exponent=True),
                float_field(h, 22, 41, path=path, column="A1", d_exponent=True),
                float(int_field(h, 41, 50, path=path, column="T")),
                int_field(h, 50, 59, path=path, column="W"))
        elif h.label == "LEAP SECONDS":
            values["leap_seconds"] = int_field(h, 0, 6, path=path, column="leap seconds")
    return NavHeader(**values)
