"""Write RINEX 3.04 observation and navigation files (simulated data takes the reading path).

`write_rinex_obs` writes the table `read_rinex_obs` returns (columns in
`gnss_obs.rinex_obs`); `write_rinex_nav` writes a `RinexNav`. Reading a written file gives
back the same values to the format's precision: observations to 0.001 (F14.3), epochs
to 1e-7 s (F11.7), navigation values to 12 decimals of the mantissa (D19.12). Both write
atomically (`trackmodel.files.atomic_write`): a failed write leaves no file behind.
"""
from __future__ import annotations

import datetime as _dt
import os

import numpy as np
import pandas as pd

from gnss_obs._nav_header import IONO_KEYS
from gnss_obs._nav_layout import KM_FIELDS, LAYOUTS, TIME_SCALE
from gnss_obs._obs_records import KIND_COLUMNS
from gnss_obs.errors import GnssInputError
from gnss_obs.gpstime import from_gps_time_s, gps_time_s_to_calendar
from gnss_obs.rinex_nav import RinexNav
from gnss_obs.rinex_obs import ObsHeader
from trackmodel.files import atomic_write

__all__ = ["write_rinex_obs", "write_rinex_nav", "derive_obs_types"]

_VERSION = 3.04
#: Largest magnitude F14.3 can hold.
_F14_MAX = 1e10 - 1e-3
_TICKS_PER_S = 10_000_000  # F11.7 seconds
_KM = 1000.0
_TYPES_PER_LINE = 13
_SLOTS_PER_LINE = 8
_BLANK_VALUE = " " * 14
_BLANK_NAV = " " * 19
_PROGRAM = "railnav"
_REQUIRED = ("gps_time_s", "sv", "signal")


def _head(content: str, label: str) -> str:
    return f"{content:<60.60}{label:<20}"


def derive_obs_types(table: pd.DataFrame) -> dict[str, list[str]]:
    """Observation types a table needs: per system, per signal, C L D S where present."""
    out: dict[str, list[str]] = {}
    for system, rows in table.groupby(table["sv"].str[0], sort=True):
        types = []
        for signal in sorted(rows["signal"].unique()):
            sub = rows[rows["signal"] == signal]
            types += [k + signal for k, c in KIND_COLUMNS.items() if sub[c].notna().any()]
        out[system] = types
    return out


def _labels(t: np.ndarray, header: ObsHeader) -> list[tuple]:
    """Calendar labels (y, m, d, h, min, whole s, 1e-7 s ticks) of GPS times, exactly rounded."""
    labels = from_gps_time_s(t, header.time_system, leap_seconds=header.leap_seconds)
    whole = np.floor(labels)
    ticks = np.round((labels - whole) * _TICKS_PER_S).astype(np.int64)
    whole = whole + (ticks == _TICKS_PER_S)
    ticks = np.where(ticks == _TICKS_PER_S, 0, ticks)
    y, mo, d, h, mi, s = gps_time_s_to_calendar(whole)
    return list(zip(y, mo, d, h, mi, np.round(s).astype(np.int64), ticks))


def _obs_header_lines(header: ObsHeader, types: dict[str, list[str]], first: tuple,
                      last: tuple) -> list[str]:
    systems = sorted(types)
    letter = systems[0] if len(systems) == 1 else "M"
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%d %H%M%S UTC")
    out = [_head(f"{_VERSION:9.2f}{'':11}{'OBSERVATION DATA':<20}{letter}", "RINEX VERSION / TYPE"),
           _head(f"{_PROGRAM:<20}{'':20}{now}", "PGM / RUN BY / DATE"),
           _head(header.marker_name, "MARKER NAME"),
           _head("", "OBSERVER / AGENCY"),
           _head(f"{'':20}{header.receiver:<20.20}", "REC # / TYPE / VERS"),
           _head(f"{'':20}{header.antenna:<20.20}", "ANT # / TYPE"),
           _head("".join(f"{v:14.4f}" for v in header.approx_position_e), "APPROX POSITION XYZ"),
           _head("".join(f"{0.0:14.4f}" for _ in range(3)), "ANTENNA: DELTA H/E/N")]
    for s in systems:
        codes = types[s]
        for k in range(0, max(len(codes), 1), _TYPES_PER_LINE):
            lead = f"{s}  {len(codes):3d}" if k == 0 else " " * 6
            chunk = "".join(f" {c:3}" for c in codes[k:k + _TYPES_PER_LINE])
            out.append(_head(lead + chunk, "SYS / # / OBS TYPES"))
    if header.signal_strength_unit:
        out.append(_head(header.signal_strength_unit, "SIGNAL STRENGTH UNIT"))
    if header.interval_s is not None:
        out.append(_head(f"{header.interval_s:10.3f}", "INTERVAL"))
    for label, (y, mo, d, h, mi, s, ticks) in (("TIME OF FIRST OBS", first),
                                               ("TIME OF LAST OBS", last)):
        out.append(_head(f"{y:6d}{mo:6d}{d:6d}{h:6d}{mi:6d}{s:5d}.{ticks:07d}"
                         f"{'':5}{header.time_system:<3}", label))
    out += _glonass_lines(header, types)
    out += [_head(s, "SYS / PHASE SHIFT") for s in systems]
    if header.leap_seconds is not None:
        out.append(_head(f"{header.leap_seconds:6d}", "LEAP SECONDS"))
    out.append(_head("", "END OF HEADER"))
    return out


def _glonass_lines(header: ObsHeader, types: dict[str, list[str]]) -> list[str]:
    if "R" not in types:
        return []
    slots = sorted(header.glonass_slots.items())
    out = []
    for k in range(0, max(len(slots), 1), _SLOTS_PER_LINE):
        lead = f"{len(slots):3d} " if k == 0 else " " * 4
        body = "".join(f"{sv:3} {ch:2d} " for sv, ch in slots[k:k + _SLOTS_PER_LINE])
        out.append(_head(lead + body, "GLONASS SLOT / FRQ #"))
    out.append(_head(" C1C    0.000 C1P    0.000 C2C    0.000 C2P    0.000",
                     "GLONASS COD/PHS/BIS"))
    return out


def _check_table(table: pd.DataFrame, path) -> None:
    missing = [c for c in _REQUIRED if c not in table]
    if missing:
        raise GnssInputError(f"observation table lacks columns {missing}", path=path)
    if not np.isfinite(table["gps_time_s"].to_numpy(dtype=np.float64)).all():
        raise GnssInputError("observation times must be finite", path=path,
                             column="gps_time_s")
    for column in KIND_COLUMNS.values():
        if column in table:
            v = table[column].to_numpy(dtype=np.float64)
            if (np.abs(v[np.isfinite(v)]) > _F14_MAX).any() or np.isinf(v).any():
                raise GnssInputError("values beyond the F14.3 range (|x| < 1e10)",
                                     path=path, column=column)


def _field_text(values: np.ndarray, lli: np.ndarray, ssi: np.ndarray) -> np.ndarray:
    """16-column observation fields (value F14.3, LLI, SSI; blanks for NaN/0)."""
    text = np.array([_BLANK_VALUE if v != v else f"{v:14.3f}" for v in values], dtype="U14")
    lli_c = np.where(lli > 0, lli.astype(str), " ")
    ssi_c = np.where(ssi > 0, ssi.astype(str), " ")
    return np.char.add(np.char.add(text, lli_c), ssi_c)


def _system_lines(rows: pd.DataFrame, codes: list[str], path) -> pd.DataFrame:
    """Record text per (epoch, sv) of one system: columns gps_time_s, sv, text."""
    groups = rows.groupby(["gps_time_s", "sv"], sort=True)
    pos = groups.ngroup().to_numpy()
    keys = groups.size().index
    fields = np.full((len(keys), len(codes)), " " * 16, dtype="U16")
    n = len(rows)
    lli = rows["lli"].to_numpy(np.int64) if "lli" in rows else np.zeros(n, np.int64)
    ssi = rows["ssi"].to_numpy(np.int64) if "ssi" in rows else np.zeros(n, np.int64)
    signals = rows["signal"].to_numpy()
    known = set()
    for j, code in enumerate(codes):
        column = KIND_COLUMNS.get(code[0])
        if column is None or column not in rows:
            continue
        sel = (signals == code[1:]) & rows[column].notna().to_numpy()
        known.add((code[0], code[1:]))
        use_lli = lli[sel] if code[0] == "L" else np.zeros(sel.sum(), np.int64)
        fields[pos[sel], j] = _field_text(rows[column].to_numpy()[sel], use_lli, ssi[sel])
    for kind, column in KIND_COLUMNS.items():
        if column in rows:
            present = rows.loc[rows[column].notna(), "signal"].unique()
            lost = [s for s in present if (kind, s) not in known]
            if lost:
                raise GnssInputError(f"{rows['sv'].iloc[0][0]}: observation {kind}{lost[0]} "
                                     "is not in the header's types", path=path, column=column)
    text = [sv + "".join(r).rstrip() for sv, r in zip(keys.get_level_values(1), fields)]
    return pd.DataFrame({"gps_time_s": keys.get_level_values(0), "sv": keys.get_level_values(1),
                         "text": text})


def write_rinex_obs(path: str | os.PathLike, header: ObsHeader, table: pd.DataFrame) -> None:
    """Write an observation table as a RINEX 3.04 observation file.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (replaced atomically).
    header : ObsHeader
        Marker, receiver, antenna, position, interval, time system (epochs are written
        in it), leap seconds, GLONASS channels and the observation types per system.
        When ``header.obs_types`` is empty the types come from `derive_obs_types`.
    table : pandas.DataFrame
        Columns as `read_rinex_obs` returns them: ``gps_time_s``, ``sv``, ``signal`` and
        any of ``pseudorange_m carrier_cycles doppler_hz cn0_dbhz``; optional ``lli``,
        ``ssi``, ``epoch_flag`` (0 when absent).

    Raises
    ------
    GnssInputError
        Missing columns, non-finite times, values beyond F14.3, or observations whose
        type the header does not list.
    """
    _check_table(table, path)
    if table.empty:
        raise GnssInputError("observation table is empty", path=path)
    types = header.obs_types or derive_obs_types(table)
    parts = []
    for system, rows in table.groupby(table["sv"].str[0], sort=True):
        if system not in types:
            raise GnssInputError(f"system {system!r} has no observation types in the header",
                                 path=path, column="sv")
        parts.append(_system_lines(rows, types[system], path))
    records = pd.concat(parts).sort_values(["gps_time_s", "sv"], kind="stable")
    flag = table["epoch_flag"] if "epoch_flag" in table else pd.Series(0, index=table.index)
    epoch_flag = flag.groupby(table["gps_time_s"]).max()
    epochs = epoch_flag.index.to_numpy(dtype=np.float64)
    by_epoch = records.groupby("gps_time_s", sort=True)["text"].apply(list)
    labels = _labels(epochs, header)
    out = _obs_header_lines(header, types, labels[0], labels[-1])
    for e, (y, mo, d, h, mi, s, ticks) in zip(epochs, labels):
        recs = by_epoch[e]
        out.append(f"> {y:4d} {mo:02d} {d:02d} {h:02d} {mi:02d}{s:3d}.{ticks:07d}  "
                   f"{int(epoch_flag[e]):1d}{len(recs):3d}")
        out += recs
    with atomic_write(path, newline="\n") as fh:
        fh.write("\n".join(out) + "\n")


def _d19(value: float) -> str:
    """A D19.12 field (E exponent), blank for NaN."""
    if value != value:
        return _BLANK_NAV
    return f"{value:19.12E}"


def _nav_header_lines(nav: RinexNav) -> list[str]:
    h = nav.header
    systems = sorted(nav.records)
    letter = systems[0] if len(systems) == 1 else "M"
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%d %H%M%S UTC")
    out = [_head(f"{_VERSION:9.2f}{'':11}{'N: GNSS NAV DATA':<20}{letter}",
                 "RINEX VERSION / TYPE"),
           _head(f"{_PROGRAM:<20}{'':20}{now}", "PGM / RUN BY / DATE")]
    for key, attr in IONO_KEYS.items():
        coeffs = getattr(h, attr)
        if coeffs is not None:
            body = "".join(f"{c:12.4E}" for c in coeffs)
            out.append(_head(f"{key:<4} {body}", "IONOSPHERIC CORR"))
    for key, (a0, a1, ref_s, week) in h.time_corrections.items():
        out.append(_head(f"{key:<4} {a0:17.10E}{a1:16.9E} {int(ref_s):6d} {int(week):4d}",
                         "TIME SYSTEM CORR"))
    if h.leap_seconds is not None:
        out.append(_head(f"{h.leap_seconds:6d}", "LEAP SECONDS"))
    out.append(_head("", "END OF HEADER"))
    return out


def _nav_records(system: str, df: pd.DataFrame, leap_seconds: int | None) -> list[str]:
    layout = LAYOUTS[system]
    values = {}
    for name in layout:
        if name is not None:
            v = df[name].to_numpy(dtype=np.float64)
            values[name] = v / _KM if name in KM_FIELDS else v
    labels = from_gps_time_s(df["toc_gps_s"].to_numpy(dtype=np.float64), TIME_SCALE[system],
                             leap_seconds=leap_seconds)
    y, mo, d, h, mi, s = gps_time_s_to_calendar(np.round(labels))
    out = []
    for r, sv in enumerate(df["sv"]):
        fields = [_d19(values[n][r]) if n is not None else _d19(0.0) for n in layout]
        out.append(f"{sv} {y[r]:4d} {mo[r]:02d} {d[r]:02d} {h[r]:02d} {mi[r]:02d} "
                   f"{int(round(s[r])):02d}" + "".join(fields[:3]))
        for k in range(3, len(fields), 4):
            out.append("    " + "".join(fields[k:k + 4]).rstrip())
    return out


def write_rinex_nav(path: str | os.PathLike, nav: RinexNav) -> None:
    """Write a `RinexNav` as a RINEX 3.04 navigation file.

    Parameters
    ----------
    path : str or os.PathLike
        Output file (replaced atomically).
    nav : RinexNav
        Header and per-system tables with the columns `read_rinex_nav` returns (SI
        units; GLONASS/SBAS positions are written back in km). Clock epochs are written
        in each system's time scale to whole seconds; spare fields as 0.

    Raises
    ------
    GnssInputError
        A system without a RINEX layout, a missing column, or a value D19.12 cannot hold.
    """
    out = _nav_header_lines(nav)
    for system in sorted(nav.records):
        df = nav.records[system]
        if system not in LAYOUTS:
            raise GnssInputError(f"no RINEX navigation layout for system {system!r}", path=path)
        missing = [n for n in LAYOUTS[system] if n is not None and n not in df]
        missing += [c for c in ("sv", "toc_gps_s") if c not in df]
        if missing:
            raise GnssInputError(f"{system} records lack columns {missing}", path=path)
        out += _nav_records(system, df, nav.header.leap_seconds)
    too_long = [ln for ln in out if len(ln) > 80]
    if too_long:
        raise GnssInputError(f"value out of D19.12 range in {too_long[0][:3]!r}", path=path)
    with atomic_write(path, newline="\n") as fh:
        fh.write("\n".join(out) + "\n")
