"""RINEX 2.1x observation records, reduced to the RINEX 3 shape the table builder reads.

Observation codes are mapped to RINEX 3 codes (signal = band + tracking attribute) so
that version 2 and 3 files give the same table. The mapping follows the signals GPS
receivers of the RINEX 2 era tracked (and gfzrnx's 2 -> 3 conversion):

======  =====  =====  =========================================================
system  RINEX 2            RINEX 3                 why
======  =================  ======================  =================================
G       C1 L1 D1 S1        C1C L1C D1C S1C         L1 C/A code and the phase tracked on it
G       P1                 C1W                     P(Y) code (semi-codeless, "W")
G       P2 L2 D2 S2        C2W L2W D2W S2W         L2 P(Y): phase and code of the same signal
G       C2                 C2X                     L2C (M+L): attribute unknown in RINEX 2
G       C5 L5 D5 S5        C5X L5X D5X S5X         L5 I+Q
R       C1 L1 D1 S1 / P1   1C / C1P                C/A and P code, band 1
R       C2 / P2 L2 D2 S2   C2C / C2P L2P D2P S2P   band 2
S       C1 L1 D1 S1        1C                      SBAS L1 C/A
other   <k><n>             <k><n>X                 attribute unknown ("X")
======  =================  ======================  =================================

So on GPS a file with ``C1 P1 P2 L1 L2`` gives rows ``1C`` (C1, L1), ``1W`` (P1) and
``2W`` (P2, L2). Epoch lines with a 2-digit year read 80–99 as 19xx and 00–79 as 20xx
(RINEX 2.11 §6.4). A blank system letter in a satellite code means GPS.
"""
from __future__ import annotations

import math

import numpy as np

from gnss_obs._fixedwidth import calendar_fields, char_table, parse_ints
from gnss_obs._obs_records import EpochWalk, flag_and_count
from gnss_obs.errors import GnssInputError
from gnss_obs.gpstime import calendar_to_gps_time_s

__all__ = ["map_v2_types", "walk_epochs", "V2_TO_V3"]

#: Explicit RINEX 2 -> 3 code mapping per system (others: append "X").
V2_TO_V3 = {
    "G": {"C1": "C1C", "L1": "L1C", "D1": "D1C", "S1": "S1C", "P1": "C1W",
          "P2": "C2W", "L2": "L2W", "D2": "D2W", "S2": "S2W", "C2": "C2X"},
    "R": {"C1": "C1C", "L1": "L1C", "D1": "D1C", "S1": "S1C", "P1": "C1P",
          "C2": "C2C", "P2": "C2P", "L2": "L2P", "D2": "D2P", "S2": "S2P"},
    "S": {"C1": "C1C", "L1": "L1C", "D1": "D1C", "S1": "S1C"},
}
_EPOCH_COLUMNS = {"year": (1, 3), "month": (4, 6), "day": (7, 9), "hour": (10, 12),
                  "minute": (13, 15)}
_SECOND = (15, 26)
_FLAG = (28, 29)
_COUNT = (29, 32)
_SATS = (32, 68)
_SATS_PER_LINE = 12
_TYPES_PER_LINE = 5
_FIELD_WIDTH = 16
_LINE_WIDTH = _TYPES_PER_LINE * _FIELD_WIDTH
_VALID_ENDS = (0, 14, 15)
_EVENT_FLAGS = (2, 3, 4, 5)
_CYCLE_SLIP_FLAG = 6
_CENTURY_PIVOT = 80


def map_v2_types(system: str, types: list[str]) -> list[str]:
    """RINEX 3 codes of RINEX 2 observation codes for one system (see module table)."""
    table = V2_TO_V3.get(system, {})
    return [table.get(t, f"{t}X") for t in types]


def walk_epochs(body: list[bytes], first_line: int, obs_types: dict[str, list[str]],
                path) -> EpochWalk:
    """Locate the epochs of a RINEX 2 body and rebuild one record per satellite.

    Parameters
    ----------
    body : list of bytes
        Lines after ``END OF HEADER``.
    first_line : int
        1-based file line of ``body[0]``.
    obs_types : dict of str to list of str
        Mapped types per system (all systems share the RINEX 2 list, so its length).
    path : str or os.PathLike
        For error messages.
    """
    n_types = len(next(iter(obs_types.values())))
    lines_per_sat = max(1, math.ceil(n_types / _TYPES_PER_LINE))
    records, record_line, record_epoch, starts, events = [], [], [], [], []
    i, n = 0, len(body)
    while i < n:
        if not body[i].strip():
            i += 1
            continue
        flag, count = flag_and_count(body[i], _FLAG, _COUNT, first_line + i, path)
        if flag in _EVENT_FLAGS:
            end = i + 1 + count
            _need(end, n, count, first_line + i, path)
            events.append(_event(body, i, end, flag, count, first_line, path))
            i = end
            continue
        sats, k = _satellites(body, i, count, first_line, path)
        end = k + count * lines_per_sat
        _need(end, n, count, first_line + i, path)
        if flag == _CYCLE_SLIP_FLAG:
            events.append(_event(body, i, end, flag, count, first_line, path))
        else:
            for s, sv in enumerate(sats):
                j = k + s * lines_per_sat
                records.append(sv + _join_data_lines(body[j:j + lines_per_sat], first_line + j,
                                                     path))
                record_line.append(first_line + j)
                record_epoch.append(len(starts))
            starts.append(i)
        i = end
    chars = char_table([body[s] for s in starts], _COUNT[1])
    lines = first_line + np.asarray(starts, dtype=np.int64)
    fields = _epoch_fields(chars, lines, path)
    flags = parse_ints(chars, *_FLAG, path=path, lines=lines, column="epoch flag")
    return EpochWalk(records, np.asarray(record_line, dtype=np.int64),
                     np.asarray(record_epoch, dtype=np.int64), fields, flags, events)


def _need(end: int, n: int, count: int, line: int, path) -> None:
    if end > n:
        raise GnssInputError(f"file ends inside an epoch ({count} satellites or records "
                             "announced)", path=path, line=line)


def _epoch_fields(chars, lines, path) -> dict[str, np.ndarray]:
    """Calendar fields of epoch lines, the two-digit year made a full one."""
    fields = calendar_fields(chars, _EPOCH_COLUMNS, _SECOND, lines, path)
    fields["year"] = np.where(fields["year"] < _CENTURY_PIVOT, 2000, 1900) + fields["year"]
    return fields


def _event(body, i, end, flag, count, first_line, path) -> dict:
    line = body[i]
    label = float("nan")
    if line[1:_SECOND[1]].strip():
        fields = _epoch_fields(char_table([line], _COUNT[1]), np.array([first_line + i]), path)
        label = float(calendar_to_gps_time_s(**{k: v[0] for k, v in fields.items()}))
    return {"time_label_s": label, "epoch_flag": flag, "line": first_line + i,
            "n_records": count,
            "text": b"\n".join(body[i + 1:end]).decode("ascii", errors="replace")}


def _satellites(body, i, count, first_line, path) -> tuple[list[bytes], int]:
    """Satellite codes of an epoch (with continuation lines); index after them."""
    n_lines = max(1, math.ceil(count / _SATS_PER_LINE))
    _need(i + n_lines, len(body), count, first_line + i, path)
    text = b"".join(body[i + k][slice(*_SATS)].ljust(_SATS[1] - _SATS[0])
                    for k in range(n_lines))
    sats = []
    for s in range(count):
        code = text[3 * s:3 * s + 3]
        system = code[:1] if code[:1] != b" " else b"G"
        number = code[1:3].replace(b" ", b"0")
        if not number.isdigit():
            raise GnssInputError(f"{code.decode(errors='replace')!r} is not a satellite code",
                                 path=path, line=first_line + i + s // _SATS_PER_LINE,
                                 column="satellite list")
        sats.append(system + number)
    return sats, i + n_lines


def _join_data_lines(lines: list[bytes], line_no: int, path) -> bytes:
    """Concatenate a satellite's 80-column data lines into one RINEX 3-shaped record."""
    for k, ln in enumerate(lines):
        used = len(ln.rstrip())
        if used > _LINE_WIDTH or used % _FIELD_WIDTH not in _VALID_ENDS:
            raise GnssInputError("truncated or misaligned observation line (fields are "
                                 "16 columns, 5 per line)", path=path, line=line_no + k)
    return b"".join(ln.ljust(_LINE_WIDTH) for ln in lines[:-1]) + lines[-1]
