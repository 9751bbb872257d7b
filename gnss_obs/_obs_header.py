"""RINEX observation header records (3.0x and 2.1x) -> the fields `ObsHeader` holds."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gnss_obs._fixedwidth import check_calendar
from gnss_obs._rinex2_obs import map_v2_types
from gnss_obs._rinex_header import (
    HeaderLine,
    float_field,
    int_field,
    leap_seconds_field,
    lenient_floats,
    split_header,
)
from gnss_obs.errors import GnssInputError
from gnss_obs.gpstime import calendar_to_gps_time_s, to_gps_time_s

__all__ = ["ParsedObsHeader", "parse_obs_header", "DEFAULT_TIME_SYSTEM"]

#: Time system of a single-system file without one in TIME OF FIRST OBS (RINEX 3.04
#: §5.3 TIME OF FIRST OBS); mixed files default to GPS.
DEFAULT_TIME_SYSTEM = {"G": "GPS", "R": "GLO", "E": "GAL", "C": "BDT", "J": "QZS",
                       "I": "IRN", "S": "GPS", "M": "GPS", "": "GPS"}
#: Header records with one value per line: fixed columns (0-based, stop exclusive).
_XYZ_COLUMNS = ((0, 14), (14, 28), (28, 42))
_TYPES_PER_LINE_V3 = 13
_TYPES_PER_LINE_V2 = 9
_GLONASS_SLOTS_PER_LINE = 8


@dataclass
class ParsedObsHeader:
    """A header while reading: ``values`` holds the `gnss_obs.rinex_obs.ObsHeader` fields
    found so far (keyword -> value); the rest is what only the reader needs."""

    version: float
    body_start: int
    file_system: str
    values: dict = field(default_factory=dict)
    scale: dict[str, dict[str, float]] = field(default_factory=dict)
    first_obs_labels: tuple | None = None
    last_obs_labels: tuple | None = None
    last_counted: str | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def obs_types(self) -> dict[str, list[str]]:
        return self.values.setdefault("obs_types", {})

    @property
    def time_system(self) -> str:
        return self.values["time_system"]

    @property
    def leap_seconds(self) -> int | None:
        return self.values.get("leap_seconds")


def parse_obs_header(lines: list[bytes], path) -> ParsedObsHeader:
    """Parse the header of an observation file.

    Raises
    ------
    GnssInputError
        Framing problems (`split_header`), a malformed record, or no observation types.
    """
    start = split_header(lines, path, expected_types="O")
    head = ParsedObsHeader(start.version, start.body_start, start.system,
                           {"version": start.version, "signal_strength_unit": ""})
    head.values["time_system"] = DEFAULT_TIME_SYSTEM.get(start.system, "GPS")
    records = start.header
    v2_types: list[str] = []
    i = 0
    while i < len(records):
        h = records[i]
        if h.label == "SYS / # / OBS TYPES":
            i = _obs_types_v3(records, i, head, path)
            continue
        if h.label == "# / TYPES OF OBSERV":
            i, v2_types = _obs_types_v2(records, i, path)
            continue
        _simple_record(h, head, path)
        i += 1
    if int(head.version) == 2:
        systems = "G" if start.system in ("G", "") else ("GRES" if start.system == "M"
                                                         else start.system)
        head.values["obs_types"] = {s: map_v2_types(s, v2_types) for s in systems}
    if not any(head.obs_types.values()):
        raise GnssInputError("header declares no observation types", path=path,
                             line=start.body_start)
    for name, labels in (("first_obs_gps_time_s", head.first_obs_labels),
                         ("last_obs_gps_time_s", head.last_obs_labels)):
        if labels is not None:
            head.values[name] = float(to_gps_time_s(calendar_to_gps_time_s(*labels),
                                                    head.time_system,
                                                    leap_seconds=head.leap_seconds))
    return head


def _simple_record(h: HeaderLine, head: ParsedObsHeader, path) -> None:
    """Records of one line each."""
    c = h.content
    if h.label == "MARKER NAME":
        head.values["marker_name"] = c.strip()
    elif h.label == "REC # / TYPE / VERS":
        head.values["receiver"] = c[20:40].strip()
    elif h.label == "ANT # / TYPE":
        head.values["antenna"] = c[20:40].strip()
    elif h.label == "APPROX POSITION XYZ":
        head.values["approx_position_e"] = np.array(lenient_floats(
            h, _XYZ_COLUMNS, path=path, column="XYZ", notes=head.notes))
    elif h.label == "INTERVAL":
        head.values["interval_s"] = float_field(h, 0, 10, path=path, column="interval")
    elif h.label == "LEAP SECONDS":
        head.values["leap_seconds"] = leap_seconds_field(h, path=path)
    elif h.label == "SIGNAL STRENGTH UNIT":
        head.values["signal_strength_unit"] = c[:20].strip()
    elif h.label == "TIME OF FIRST OBS":
        head.first_obs_labels = _time_of_obs(h, path)
        system = _time_system(h, head.notes, path)
        if system:
            head.values["time_system"] = system
    elif h.label == "TIME OF LAST OBS":
        head.last_obs_labels = _time_of_obs(h, path)
    elif h.label == "# OF SATELLITES":
        head.values["n_satellites"] = int_field(h, 0, 6, path=path, column="# of satellites")
    elif h.label == "PRN / # OF OBS":
        _obs_counts(h, head, path)
    elif h.label == "GLONASS SLOT / FRQ #":
        head.values.setdefault("glonass_slots", {}).update(_glonass_slots(h, head.notes, path))
    elif h.label == "SYS / SCALE FACTOR":
        _scale_factor(h, head, path)


#: TIME OF FIRST/LAST OBS: five I6 calendar fields, then the seconds (F13.7, columns 31-43).
_TIME_FIELDS = ("year", "month", "day", "hour", "minute")
_TIME_SECOND_COLUMNS = (30, 43)
#: PRN / # OF OBS: satellite (columns 4-6), then up to 9 counts I6 from column 7.
_COUNT_SV_COLUMNS = (3, 6)
_COUNTS_PER_LINE = 9
_COUNT_WIDTH = 6


def _time_of_obs(h: HeaderLine, path) -> tuple:
    """Calendar labels ``(year, month, day, hour, minute, second)`` of a TIME OF ... OBS."""
    column = h.label.lower()
    labels = [int_field(h, 6 * k, 6 * k + 6, path=path, column=column)
              for k in range(len(_TIME_FIELDS))]
    second = float_field(h, *_TIME_SECOND_COLUMNS, path=path, column=column)
    fields = {name: np.array([v]) for name, v in zip(_TIME_FIELDS, labels)}
    check_calendar({**fields, "second": np.array([second])}, np.array([h.line]), path)
    return (*labels, second)


def _obs_counts(h: HeaderLine, head: ParsedObsHeader, path) -> None:
    """``PRN / # OF OBS``: observations per type of one satellite (continuation lines
    have a blank satellite and extend the previous one's list)."""
    counts = head.values.setdefault("obs_counts", {})
    sv = h.content[slice(*_COUNT_SV_COLUMNS)]
    if sv.strip():
        sv = sv[0].replace(" ", "G") + sv[1:].replace(" ", "0")
        head.last_counted = sv
    elif head.last_counted is None:
        raise GnssInputError("continuation line without a satellite before it", path=path,
                             line=h.line, column="PRN / # OF OBS")
    first = _COUNT_SV_COLUMNS[1]
    spans = [(first + _COUNT_WIDTH * k, first + _COUNT_WIDTH * (k + 1))
             for k in range(_COUNTS_PER_LINE)]
    values = [int_field(h, a, b, path=path, column="# of obs") for a, b in spans
              if h.content[a:b].strip()]
    counts.setdefault(head.last_counted, []).extend(values)


#: Time-system identifier of TIME OF FIRST OBS: columns 49-51 (A3 after 5X).
_TIME_SYSTEM_COLUMNS = (48, 51)
_SECOND_END = 44  # one past the seconds field (F13.7 in columns 31-43, 44 when one late)
_TIME_SYSTEMS = ("GPS", "GAL", "BDT", "GLO", "QZS", "IRN", "UTC")


def _time_system(h: HeaderLine, notes: list[str], path) -> str:
    """The time system of TIME OF FIRST OBS ('' when blank).

    Tolerated: the identifier out of its columns (georinex's ``minimal.10o`` has ``GPS`` in
    columns 50-52) when it is the last word of columns 45-60 (noted).
    """
    system = h.content[slice(*_TIME_SYSTEM_COLUMNS)].strip()
    if not system or system in _TIME_SYSTEMS:
        return system
    shifted = h.content[_SECOND_END:].split()
    if shifted and shifted[-1] in _TIME_SYSTEMS:
        notes.append(f"line {h.line}: TIME OF FIRST OBS time system {shifted[0]!r} out of "
                     "columns 49-51")
        return shifted[0]
    raise GnssInputError(f"unknown time system {system!r}", path=path, line=h.line,
                         column="time system")


def _glonass_slots(h: HeaderLine, notes: list[str], path) -> dict[str, int]:
    """``GLONASS SLOT / FRQ #``: satellite -> channel (A1,I2,1X,I2 per entry from column 5).

    Entries out of their columns are read as blank-separated ``Rnn k`` pairs (noted).
    """
    c = h.content
    slots: dict[str, int] = {}
    try:
        for k in range(_GLONASS_SLOTS_PER_LINE):
            entry = c[4 + 7 * k:11 + 7 * k]
            if entry[:3].strip():
                sv = entry[0] + entry[1:3].replace(" ", "0")
                if sv[0] != "R" or not sv[1:].isdigit():
                    raise GnssInputError(f"{entry[:3]!r} is not a GLONASS satellite", path=path,
                                         line=h.line, column="GLONASS slot")
                slots[sv] = int_field(h, 8 + 7 * k, 10 + 7 * k, path=path,
                                      column="GLONASS frequency number")
        return slots
    except GnssInputError as exc:
        tokens = c[3:].split()
        pairs = list(zip(tokens[::2], tokens[1::2]))
        ok = len(tokens) % 2 == 0 and all(
            len(sv) == 3 and sv[0] == "R" and sv[1:].isdigit()
            and k.lstrip("-").isdigit() for sv, k in pairs)
        if not ok:
            raise exc from None
    notes.append(f"line {h.line}: GLONASS SLOT / FRQ # entries out of their columns")
    return {sv: int(k) for sv, k in pairs}


def _obs_types_v3(records: list[HeaderLine], i: int, head: ParsedObsHeader, path) -> int:
    """Read a ``SYS / # / OBS TYPES`` record and its continuation lines; next index."""
    h = records[i]
    system = h.content[0]
    count = int_field(h, 3, 6, path=path, column="number of observation types")
    types: list[str] = []
    while True:
        for k in range(_TYPES_PER_LINE_V3):
            code = records[i].content[7 + 4 * k:10 + 4 * k].strip()
            if code and len(types) < count:
                types.append(code)
        i += 1
        if len(types) >= count or i >= len(records) or records[i].label != h.label \
                or records[i].content[0] != " ":
            break
    if len(types) != count or any(len(t) != 3 for t in types):
        raise GnssInputError(f"system {system}: {count} observation types announced, "
                             f"{len(types)} valid codes found", path=path, line=h.line,
                             column="SYS / # / OBS TYPES")
    head.obs_types[system] = types
    return i


def _obs_types_v2(records: list[HeaderLine], i: int, path) -> tuple[int, list[str]]:
    h = records[i]
    count = int_field(h, 0, 6, path=path, column="number of observation types")
    types: list[str] = []
    while i < len(records) and records[i].label == h.label and len(types) < count:
        for k in range(_TYPES_PER_LINE_V2):
            code = records[i].content[10 + 6 * k:12 + 6 * k].strip()
            if code and len(types) < count:
                types.append(code)
        i += 1
    if len(types) != count:
        raise GnssInputError(f"{count} observation types announced, {len(types)} found",
                             path=path, line=h.line, column="# / TYPES OF OBSERV")
    return i, types


def _scale_factor(h: HeaderLine, head: ParsedObsHeader, path) -> None:
    system = h.content[0]
    factor = float(int_field(h, 2, 6, path=path, column="scale factor"))
    codes = h.content[10:58].split()
    targets = codes or head.obs_types.get(system, [])
    head.scale.setdefault(system, {}).update({code: factor for code in targets})
