"""RINEX navigation files (4.0x and 3.0x mixed, 2.1x) -> one table per system.

Versions: RINEX 3.0x (any mix of systems); RINEX 4.0x, its legacy-message records (GPS/
QZSS/NavIC LNAV, Galileo INAV/FNAV, BeiDou D1/D2, GLONASS FDMA, SBAS) and the GPS/Galileo
ION records (`gnss_obs._rinex4_nav`; CNAV-type, STO and EOP records are skipped with one
warning); RINEX 2.1x files of type ``N`` (GPS), ``G`` (GLONASS), ``H`` (SBAS) and the
RINEX 2.12 / teqc / RTKLIB types ``E`` or ``L`` (Galileo) and ``J`` or ``Q`` (QZSS), whose
records have the RINEX 2 columns and the RINEX 3 field order of their system.

`read_rinex_nav` returns a `RinexNav`: the `NavHeader` (ionosphere coefficients, time
system corrections, leap seconds) and ``records``, a DataFrame per system letter, one row
per broadcast record, sorted by (``sv``, ``toc_gps_s``), in SI units (s, m, rad, rad/s).

Keplerian systems (``G E C J I``) have the columns of `KEPLER_FIELDS`: ``sv, prn,
toc_gps_s`` (clock reference epoch in GPS time: GPS/GAL/QZS labels as they are, BDT
+14 s), the clock polynomial ``af0_s af1_sps af2_sps2``, ``iode``, the 16 orbit elements
(``crs_m delta_n_radps m0_rad cuc_rad e cus_rad sqrt_a_sqrtm toe_sow cic_rad omega0_rad
cis_rad i0_rad crc_m omega_rad omega_dot_radps idot_radps``), ``week`` (int, as in the
file: continuous GPS week for G/E/J/I, BDT week for C), ``sv_accuracy_m, health, tgd_s,
iodc, transmission_time_sow, fit_interval_h`` (NaN where the system has no such value:
``tgd_s`` is GPS/QZSS/NavIC only) and ``toe_gps_s``, the ephemeris reference time as GPS
seconds (``week × 604800 + toe``; for BeiDou ``(week + 1356) × 604800 + toe + 14``).
Galileo adds ``data_sources`` (int; bit 0 I/NAV E1-B, bit 1 F/NAV E5a-I, bit 2 I/NAV
E5b-I), ``nav_type`` (``"FNAV"`` when bit 1 is set, else ``"INAV"``), ``bgd_e5a_e1_s``,
``bgd_e5b_e1_s``. BeiDou adds ``tgd1_s`` (B1I), ``tgd2_s`` (B2I), ``aode``, ``aodc`` (and
repeats them as ``iode``, ``iodc``). QZSS ``fit_interval_h`` is the file's fit flag.

GLONASS (``R``): ``sv, prn, toc_gps_s`` (UTC labels + leap seconds of the header, else
the leap-second table), ``clock_bias_s`` = the RINEX value = -τn, ``tau_n_s`` = τn,
``gamma_n``, ``message_frame_time_s`` (as in the file: seconds of the UTC week in RINEX 3,
of the UTC day in RINEX 2), ``x_m y_m z_m vx_mps vy_mps vz_mps ax_mps2 ay_mps2 az_mps2``
(PZ-90, converted from km), ``health``, ``freq_channel`` (int), ``age_days``.
SBAS (``S``): ``sv, prn, toc_gps_s, af0_s, af1_sps, message_frame_time_s``, position,
velocity, acceleration in m as for GLONASS, ``health, ura, iodn``. Records of other
systems raise an error; duplicate records are kept.

References: RINEX 3.04 §5.4, Tables A6–A17; RINEX 2.11 Tables A4, A11.
"""
from __future__ import annotations

import logging
import os
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from gnss_obs._fixedwidth import (
    calendar_fields,
    char_table,
    check_ascii,
    check_last_line,
    parse_floats,
    parse_ints,
    read_text_bytes,
    split_lines,
)
from gnss_obs._nav_header import NavHeader, parse_nav_header
from gnss_obs._nav_layout import (
    INT_FIELDS,
    KEPLER_FIELDS,
    KM_FIELDS,
    LAYOUTS,
    TIME_SCALE,
    continuation_lines,
)
from gnss_obs._rinex4_nav import record_starts_v4
from gnss_obs._rinex_header import split_header, warn_lenient
from gnss_obs.constants import BDT_MINUS_GPST_S, BDT_WEEK0_GPS_WEEK, SYSTEM_NAMES, WEEK_S
from gnss_obs.errors import GnssInputError
from gnss_obs.gpstime import calendar_to_gps_time_s, to_gps_time_s

__all__ = ["NavHeader", "RinexNav", "read_rinex_nav", "KEPLER_FIELDS"]

log = logging.getLogger(__name__)

_KM = 1000.0
#: RINEX 2 navigation file type -> system letter (E/L Galileo and J/Q QZSS: RINEX 2.12).
_V2_FILE_SYSTEM = {"N": "G", "G": "R", "H": "S", "E": "E", "L": "E", "J": "J", "Q": "J"}
_RINEX4 = 4
_FNAV_BIT = 1 << 1
_V2_CENTURY_PIVOT = 80


@dataclass(frozen=True, eq=False)
class _Columns:
    """Fixed columns of a record's lines for one format version (0-based, stop exclusive)."""

    sv: tuple[int, int]
    calendar: dict[str, tuple[int, int]]
    second: tuple[int, int]
    first_values: tuple[tuple[int, int], ...]
    orbit_values: tuple[tuple[int, int], ...]
    indent: int


_V3 = _Columns((0, 3), {"year": (4, 8), "month": (9, 11), "day": (12, 14), "hour": (15, 17),
                        "minute": (18, 20)}, (21, 23), ((23, 42), (42, 61), (61, 80)),
               ((4, 23), (23, 42), (42, 61), (61, 80)), 4)
_V2 = _Columns((0, 2), {"year": (3, 5), "month": (6, 8), "day": (9, 11), "hour": (12, 14),
                        "minute": (15, 17)}, (17, 22), ((22, 41), (41, 60), (60, 79)),
               ((3, 22), (22, 41), (41, 60), (60, 79)), 3)
_LINE_WIDTH = 80


@dataclass(frozen=True, eq=False)
class RinexNav:
    """A read navigation file: header, one record table per system letter, and the file
    it was read from (None when built in memory)."""

    header: NavHeader
    records: dict[str, pd.DataFrame]
    path: str | None = None


def read_rinex_nav(path: str | os.PathLike) -> RinexNav:
    """Read a RINEX 4.0x, 3.0x or 2.1x navigation file (versions in the module docstring).

    Parameters
    ----------
    path : str or os.PathLike
        Plain or compressed navigation file.

    Returns
    -------
    RinexNav
        Header and per-system record tables (columns in the module docstring).

    Raises
    ------
    GnssInputError
        One line with file and line number: empty, truncated or malformed file (a record
        with too few lines or a bad number, a last line cut without its line end,
        a byte that is not ASCII, a date such as month 13), an unsupported version or
        system, or a file that is not a navigation file.
    """
    data = read_text_bytes(path)
    lines = split_lines(data)
    start = split_header(lines, path, expected_types="".join(_V2_FILE_SYSTEM))
    if start.version >= 3 and start.file_type != "N":
        raise GnssInputError(f"wrong file type {start.file_type!r} for RINEX "
                             f"{start.version:.2f} navigation: expected 'N'", path=path, line=1,
                             column="file type")
    v2_system = _V2_FILE_SYSTEM[start.file_type] if start.version < 3 else None
    notes: list[str] = []
    header = parse_nav_header(start.header, start.version, path, notes,
                              system=v2_system or "M")
    warn_lenient(log, path, notes)
    body = lines[start.body_start:]
    check_ascii(body, start.body_start + 1, path)
    check_last_line(data, lines, _LINE_WIDTH - (start.version < 3), path)
    if int(start.version) == _RINEX4:
        groups, skipped, iono = record_starts_v4(body, start.body_start + 1, start.version,
                                                 path)
        header = replace(header, **{k: v for k, v in iono.items()
                                    if getattr(header, k) is None})
        if skipped:
            log.warning("%s: RINEX 4 records not read (no RINEX 3 layout): %s", path,
                        ", ".join(f"{n} {k}" for k, n in sorted(skipped.items())))
    else:
        groups = _record_starts(body, start.body_start + 1, start.version, v2_system, path)
    cols = _V3 if v2_system is None else _V2
    records = {s: _system_frame(s, body, idx, start.body_start + 1, start.version, cols,
                                header.leap_seconds, path)
               for s, idx in sorted(groups.items())}
    if not any(len(f) for f in records.values()):    # a user of it is told which files
        log.warning("%s: no navigation records after the header (empty or truncated file?)",
                    path)
    log.debug("%s: %s", path, {s: len(f) for s, f in records.items()})
    return RinexNav(header, records, os.fspath(path))


def _record_starts(body: list[bytes], first_line: int, version: float, v2_system: str | None,
                   path) -> dict[str, list[int]]:
    """Index of every record's epoch line, grouped by system; checks record lengths."""
    indent = _V3.indent if v2_system is None else _V2.indent
    groups: dict[str, list[int]] = {}
    i, n = 0, len(body)
    while i < n:
        line = body[i]
        if not line.strip():
            i += 1
            continue
        system = v2_system or line[:1].decode("ascii", errors="replace")
        if v2_system is not None and not line[:indent].strip():
            raise GnssInputError(f"expected the first line of a record (satellite number in "
                                 f"columns 1-2): records are longer than a RINEX 2 "
                                 f"{SYSTEM_NAMES[v2_system]} record, is the file type letter "
                                 "on line 1 right?", path=path, line=first_line + i)
        if line[:1] == b" " and v2_system is None:
            raise GnssInputError("expected the first line of a record (satellite code in "
                                 "columns 1-3)", path=path, line=first_line + i)
        if system not in LAYOUTS:
            raise GnssInputError(f"unsupported satellite system {system!r}", path=path,
                                 line=first_line + i, column="satellite")
        k = continuation_lines(system, version)
        if i + 1 + k > n:
            raise GnssInputError(f"file ends inside a record ({k} broadcast-orbit lines "
                                 f"needed, {n - i - 1} present)", path=path,
                                 line=first_line + i)
        for j in range(i + 1, i + 1 + k):
            if body[j][:indent].strip() or not body[j].strip():
                raise GnssInputError(f"record of {system} has fewer than {k} broadcast-orbit "
                                     "lines", path=path, line=first_line + j)
        groups.setdefault(system, []).append(i)
        i += 1 + k
    return groups


def _system_frame(system: str, body, idx: list[int], first_line: int, version: float,
                  cols: _Columns, leap_seconds: int | None, path) -> pd.DataFrame:
    """Parse all records of one system into its table."""
    starts = np.asarray(idx, dtype=np.int64)
    lines0 = first_line + starts
    chars = char_table([body[i] for i in idx], _LINE_WIDTH)
    frame = {"sv": [], "prn": _prn(chars, cols, lines0, system, path)}
    frame["sv"] = np.array([f"{system}{p:02d}" for p in frame["prn"]], dtype=object)
    frame["toc_gps_s"] = _toc_gps_s(chars, cols, lines0, system, version, leap_seconds, path)
    names = iter(LAYOUTS[system])
    for k in range(continuation_lines(system, version) + 1):
        if k:
            chars = char_table([body[i + k] for i in idx], _LINE_WIDTH)
        spans = cols.first_values if k == 0 else cols.orbit_values
        for span in spans:
            name = next(names, None)
            if name is not None:
                frame[name] = _values(chars, span, first_line + starts + k, name, path)
    table = _finish(system, pd.DataFrame(frame))
    _check_reference_times(table, lines0, path)
    return table.sort_values(["sv", "toc_gps_s"], kind="stable", ignore_index=True)


#: Largest |toc - toe| of a Keplerian record, s: both are the record's issue time (hours
#: apart at most); more means a wrong week (e.g. modulo 1024) or a wrong date.
_MAX_TOC_TOE_S = float(WEEK_S)


def _check_reference_times(table: pd.DataFrame, lines, path) -> None:
    if "toe_gps_s" not in table:
        return
    gap = np.abs(table["toc_gps_s"].to_numpy() - table["toe_gps_s"].to_numpy())
    bad = ~(gap <= _MAX_TOC_TOE_S)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise GnssInputError(f"the clock epoch and the ephemeris week/toe are "
                             f"{gap[i] / WEEK_S:.1f} weeks apart: a wrong week number or date",
                             path=path, line=int(lines[i]), column="week")


def _values(chars, span, lines, name, path) -> np.ndarray:
    values = parse_floats(chars, *span, path=path, lines=lines, column=name, d_exponent=True)
    block = chars[:, span[0]:span[1]]
    cut = ~np.isnan(values) & (block[:, -1] == ord(" "))
    if cut.any():
        i = int(np.flatnonzero(cut)[0])
        raise GnssInputError("truncated or misaligned value (D19.12 fields are right-aligned)",
                             path=path, line=int(lines[i]), column=name)
    if name in INT_FIELDS:
        if np.isnan(values).any():
            i = int(np.flatnonzero(np.isnan(values))[0])
            raise GnssInputError("missing value", path=path, line=int(lines[i]), column=name)
        return values.astype(np.int64)
    return values


def _prn(chars, cols: _Columns, lines, system, path) -> np.ndarray:
    a, b = cols.sv
    if b - a == 3:
        wrong = chars[:, 0] != ord(system)
        if wrong.any():
            raise GnssInputError("satellite system changed inside a record group", path=path,
                                 line=int(lines[np.flatnonzero(wrong)[0]]), column="satellite")
        a += 1
    prn = parse_ints(chars, a, b, path=path, lines=lines, column="satellite", blank=-1)
    if (prn < 0).any():
        raise GnssInputError("missing satellite number", path=path,
                             line=int(lines[np.flatnonzero(prn < 0)[0]]), column="satellite")
    return prn


def _toc_gps_s(chars, cols: _Columns, lines, system, version, leap_seconds, path) -> np.ndarray:
    f = calendar_fields(chars, cols.calendar, cols.second, lines, path)
    if version < 3:
        f["year"] = np.where(f["year"] < _V2_CENTURY_PIVOT, 2000, 1900) + f["year"]
    labels = calendar_to_gps_time_s(f["year"], f["month"], f["day"], f["hour"], f["minute"],
                                    f["second"])
    return to_gps_time_s(labels, TIME_SCALE[system], leap_seconds=leap_seconds)


def _finish(system: str, df: pd.DataFrame) -> pd.DataFrame:
    """Unit conversions and derived columns of one system's table."""
    for name in KM_FIELDS:
        if name in df:
            df[name] = df[name] * _KM
    if system == "R":
        df.insert(df.columns.get_loc("clock_bias_s") + 1, "tau_n_s", -df["clock_bias_s"])
        return df
    if system == "S":
        return df
    if system == "C":
        df["iode"] = df["aode"]
        df["iodc"] = df["aodc"]
    if system == "E":
        df["nav_type"] = np.where(df["data_sources"].to_numpy() & _FNAV_BIT, "FNAV", "INAV")
        df["nav_type"] = df["nav_type"].astype(object)
    for name in KEPLER_FIELDS:
        if name not in df:
            df[name] = np.nan
    toe = df["week"].to_numpy() * float(WEEK_S) + df["toe_sow"].to_numpy()
    if system == "C":
        toe = toe + BDT_WEEK0_GPS_WEEK * float(WEEK_S) - BDT_MINUS_GPST_S
    df["toe_gps_s"] = toe
    extras = [c for c in df.columns if c not in KEPLER_FIELDS and c not in
              ("sv", "prn", "toc_gps_s", "toe_gps_s")]
    return df[["sv", "prn", "toc_gps_s", *KEPLER_FIELDS, "toe_gps_s", *extras]]
