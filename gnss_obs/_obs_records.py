"""Satellite observation records -> the tidy observation table (RINEX 2 and 3 alike).

The readers reduce both versions to *satellite records*: the satellite code (``G05``) in
columns 1–3 followed by one 16-column field per observation type of its system (14 for
the value in F14.3, then the loss-of-lock indicator LLI and the signal strength SSI),
in the order of the header's type list. This module converts all records of a system at
once and regroups the fields by signal: the table has one row per epoch × satellite ×
signal (band + attribute, ``"1C"``) with the code, carrier, Doppler and C/N0 of that
signal side by side. A row exists when at least one of the four is present.

``lli`` is the carrier phase's LLI (RINEX 3.04 §5.3: the indicator belongs to the phase);
``ssi`` is the carrier's signal-strength digit, or the code's when no carrier was kept.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from gnss_obs._fixedwidth import char_table, parse_floats
from gnss_obs.errors import GnssInputError

__all__ = ["TABLE_COLUMNS", "KIND_COLUMNS", "EpochWalk", "tidy_observations", "empty_table",
           "flag_and_count", "MAX_EPOCH_FLAG"]

#: Observation code letter -> table column.
KIND_COLUMNS = {"C": "pseudorange_m", "L": "carrier_cycles", "D": "doppler_hz", "S": "cn0_dbhz"}
#: Columns of the observation table, in order.
TABLE_COLUMNS = ["gps_time_s", "sv", "system", "prn", "signal", "band", "pseudorange_m",
                 "carrier_cycles", "doppler_hz", "cn0_dbhz", "lli", "ssi", "epoch_flag"]

_SV_WIDTH = 3
_FIELD_WIDTH = 16
_VALUE_WIDTH = 14
#: Valid (rstripped line length - 3) % 16: ends after a value, an LLI, or an SSI/blank field.
_VALID_ENDS = (0, _VALUE_WIDTH, _VALUE_WIDTH + 1)
_SPACE = ord(" ")
_ZERO = ord("0")


@dataclass
class EpochWalk:
    """What a version-specific walker hands to the common table builder.

    ``records``: satellite records (``"G05"`` + 16 columns per type); ``record_line``:
    their 1-based lines; ``record_epoch``: index of their epoch; ``epoch_fields``: calendar
    label arrays ``year month day hour minute second`` of the observation epochs;
    ``epoch_flag``: their flags; ``events``: dicts with ``time_label_s, epoch_flag, line,
    n_records, text``.
    """

    records: list[bytes]
    record_line: np.ndarray
    record_epoch: np.ndarray
    epoch_fields: dict[str, np.ndarray]
    epoch_flag: np.ndarray
    events: list[dict]


#: Largest RINEX epoch flag (6: cycle-slip records).
MAX_EPOCH_FLAG = 6


def flag_and_count(line: bytes, flag_cols: tuple[int, int], count_cols: tuple[int, int],
                   line_no: int, path) -> tuple[int, int]:
    """Epoch flag (blank = 0) and number of records of an epoch line, checked."""
    try:
        flag = int(line[flag_cols[0]:flag_cols[1]].strip() or b"0")
        count = int(line[count_cols[0]:count_cols[1]])
    except ValueError:
        raise GnssInputError("bad epoch flag or number of satellites", path=path,
                             line=line_no, column="epoch flag") from None
    if not 0 <= flag <= MAX_EPOCH_FLAG or count < 0:
        raise GnssInputError(f"epoch flag {flag} / count {count} out of range (flag 0-6)",
                             path=path, line=line_no, column="epoch flag")
    return flag, count


def empty_table() -> pd.DataFrame:
    """An observation table with no rows and the contract's columns and dtypes."""
    return _frame({c: np.empty(0) for c in TABLE_COLUMNS})


def _frame(cols: dict) -> pd.DataFrame:
    df = pd.DataFrame({c: cols[c] for c in TABLE_COLUMNS})
    for c in ("prn", "band", "lli", "ssi", "epoch_flag"):
        df[c] = df[c].astype(np.int64)
    for c in ("sv", "system", "signal"):
        df[c] = df[c].astype(object)
    return df


def tidy_observations(records: list[bytes], record_line: npt.NDArray[np.int64],
                      record_epoch: npt.NDArray[np.int64], *,
                      epoch_gps_time_s: npt.NDArray[np.float64],
                      epoch_flag: npt.NDArray[np.int64], obs_types: dict[str, list[str]],
                      scale: dict[str, dict[str, float]], systems: str | None,
                      path) -> pd.DataFrame:
    """Build the observation table from satellite records.

    Parameters
    ----------
    records : list of bytes
        Satellite records (``"G05"`` + 16 columns per observation type).
    record_line : ndarray of int, shape (len(records),)
        1-based file line of each record, for error messages.
    record_epoch : ndarray of int, shape (len(records),)
        Index into the epoch arrays of each record.
    epoch_gps_time_s : ndarray of float, shape (n_epochs,)
        Epoch time, s since the GPS epoch (GPS time).
    epoch_flag : ndarray of int, shape (n_epochs,)
        RINEX epoch flag (0 or 1 for observation epochs).
    obs_types : dict of str to list of str
        Observation types per system letter, RINEX 3 codes (``"C1C"``).
    scale : dict of str to dict of str to float
        ``SYS / SCALE FACTOR`` divisors per system and type (absent = 1).
    systems : str or None
        System letters to keep (all when None).
    path : str or os.PathLike
        File name for error messages.

    Returns
    -------
    pandas.DataFrame
        Columns `TABLE_COLUMNS`, sorted by (gps_time_s, sv, signal).
    """
    letters = np.frombuffer(b"".join(r[:1].ljust(1) for r in records), dtype="S1")
    parts = []
    for system in sorted({str(s) for s in letters.astype(str)}):
        if systems is not None and system not in systems:
            continue
        rows = np.flatnonzero(letters == system.encode())
        if system not in obs_types:
            raise GnssInputError(f"satellite of system {system!r} not declared in the header",
                                 path=path, line=int(record_line[rows[0]]), column="satellite")
        parts.extend(_system_rows(system, [records[i] for i in rows], record_line[rows],
                                  record_epoch[rows], obs_types[system],
                                  scale.get(system, {}), path))
    if not parts:
        return empty_table()
    cols = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    epoch = cols.pop("epoch")
    cols["gps_time_s"] = epoch_gps_time_s[epoch]
    cols["epoch_flag"] = epoch_flag[epoch]
    order = np.lexsort((cols.pop("signal_key"), cols.pop("sv_key"), cols["gps_time_s"]))
    return _frame({k: v[order] for k, v in cols.items()})


def _check_lengths(lines: list[bytes], chars, line_no, path) -> None:
    """Reject records cut inside a field or with more fields than the header declares."""
    width = chars.shape[1]
    nonspace = chars != _SPACE
    used = np.where(nonspace.any(axis=1), width - nonspace[:, ::-1].argmax(axis=1), 0)
    bad = ~np.isin((used - _SV_WIDTH) % _FIELD_WIDTH, _VALID_ENDS) | (used < _SV_WIDTH)
    long = np.fromiter((len(ln) > width and ln[width:].strip() != b"" for ln in lines),
                       dtype=bool, count=len(lines))
    if bad.any() or long.any():
        i = int(np.flatnonzero(bad | long)[0])
        what = ("more observations than the header declares for its system" if long[i]
                else "truncated or misaligned observation record (fields are 16 columns)")
        raise GnssInputError(what, path=path, line=int(line_no[i]))


def _digit_column(chars, col, line_no, path, column) -> np.ndarray:
    """An LLI or SSI column: one digit, blank = 0."""
    c = chars[:, col].astype(np.int64)
    ok = (c == _SPACE) | ((c >= _ZERO) & (c <= _ZERO + 9))
    if not ok.all():
        i = int(np.flatnonzero(~ok)[0])
        raise GnssInputError(f"{chr(c[i])!r} is not a digit", path=path,
                             line=int(line_no[i]), column=column)
    return np.where(c == _SPACE, 0, c - _ZERO)


def _satellite_numbers(chars, line_no, path) -> np.ndarray:
    """PRN of each record from columns 2–3 (a blank tens digit reads as 0)."""
    d = chars[:, 1:_SV_WIDTH].astype(np.int64)
    d = np.where(d == _SPACE, _ZERO, d) - _ZERO
    ok = ((d >= 0) & (d <= 9)).all(axis=1)
    if not ok.all():
        i = int(np.flatnonzero(~ok)[0])
        raise GnssInputError(f"{bytes(chars[i, :_SV_WIDTH]).decode(errors='replace')!r} "
                             "is not a satellite code", path=path, line=int(line_no[i]),
                             column="satellite")
    return d[:, 0] * 10 + d[:, 1]


def _system_rows(system: str, lines: list[bytes], line_no, epoch, types: list[str],
                 scale: dict[str, float], path) -> list[dict]:
    """Table columns for all records of one system, one dict per signal."""
    width = _SV_WIDTH + _FIELD_WIDTH * len(types)
    chars = char_table(lines, width)
    _check_lengths(lines, chars, line_no, path)
    prn = _satellite_numbers(chars, line_no, path)
    signals: dict[str, dict[str, int]] = {}
    for j, code in enumerate(types):
        if code[0] in KIND_COLUMNS:
            signals.setdefault(code[1:], {})[code[0]] = j
    n = len(lines)
    out = []
    for signal, kinds in signals.items():
        cols, lli, ssi = {}, np.zeros(n, np.int64), np.zeros(n, np.int64)
        for kind, column in KIND_COLUMNS.items():
            if kind not in kinds:
                cols[column] = np.full(n, np.nan)
                continue
            start = _SV_WIDTH + _FIELD_WIDTH * kinds[kind]
            code = kind + signal
            cols[column] = parse_floats(chars, start, start + _VALUE_WIDTH, path=path,
                                        lines=line_no, column=code) / scale.get(code, 1.0)
            if kind in ("C", "L"):
                lli_k = _digit_column(chars, start + _VALUE_WIDTH, line_no, path, code + " LLI")
                ssi_k = _digit_column(chars, start + _VALUE_WIDTH + 1, line_no, path,
                                      code + " SSI")
                keep = np.isfinite(cols[column])
                ssi = np.where(keep, ssi_k, ssi)  # "L" comes after "C": the carrier's wins
                if kind == "L":
                    lli = np.where(keep, lli_k, lli)
        present = np.isfinite(np.column_stack(list(cols.values()))).any(axis=1)
        rows = np.flatnonzero(present)
        out.append(_signal_columns(system, signal, prn[rows], epoch[rows],
                                   {k: v[rows] for k, v in cols.items()}, lli[rows], ssi[rows]))
    return out


def _signal_columns(system, signal, prn, epoch, values, lli, ssi) -> dict:
    n = len(prn)
    unique = np.unique(prn)
    names = np.array([f"{system}{p:02d}" for p in unique], dtype=object)
    cols = {
        "epoch": epoch, "sv": names[np.searchsorted(unique, prn)],
        "system": np.full(n, system, dtype=object), "prn": prn,
        "signal": np.full(n, signal, dtype=object), "band": np.full(n, _band(signal), np.int64),
        "lli": lli, "ssi": ssi,
        "sv_key": ord(system) * 1000 + prn,
        "signal_key": np.full(n, ord(signal[0]) * 256 + ord(signal[-1]), np.int64),
    }
    cols.update(values)
    return cols


def _band(signal: str) -> int:
    return int(signal[0]) if signal[:1].isdigit() else 0
