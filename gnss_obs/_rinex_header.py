"""RINEX header framing shared by the observation and navigation readers.

A RINEX header is 60 columns of content followed by a label in columns 61–80, closed
by ``END OF HEADER``; the first line is ``RINEX VERSION / TYPE`` (RINEX 2.11 §5.1,
RINEX 3.04 §5.1). This module finds the header, checks version and file type, and hands
back ``(label, content, line_number)`` triples; each reader interprets its own labels.
"""
from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass

from gnss_obs.constants import BDT_MINUS_GPST_S
from gnss_obs.errors import GnssInputError

__all__ = ["HeaderLine", "RinexStart", "split_header", "float_field", "int_field",
           "leap_seconds_field", "lenient_floats", "warn_lenient"]

_LABEL_COLUMN = 60
_VERSION_LABEL = "RINEX VERSION / TYPE"
_END_LABEL = "END OF HEADER"
#: Supported major versions.
_MAJOR_VERSIONS = (2, 3, 4)


@dataclass(frozen=True)
class HeaderLine:
    """One header line: its label (columns 61–80), content (columns 1–60), 1-based line."""

    label: str
    content: str
    line: int


@dataclass(frozen=True)
class RinexStart:
    """The framing of a RINEX file.

    Attributes
    ----------
    version : float
        Format version, e.g. 3.04.
    file_type : str
        ``"O"`` observation, ``"N"`` navigation (``"G"``/``"H"`` RINEX 2 GLONASS/SBAS nav).
    system : str
        Satellite system letter of the first line (``"M"`` mixed), blank in some files.
    header : list of HeaderLine
    body_start : int
        0-based index of the first line after ``END OF HEADER``.
    """

    version: float
    file_type: str
    system: str
    header: list[HeaderLine]
    body_start: int


def split_header(lines: list[bytes], path: str | os.PathLike, *,
                 expected_types: str) -> RinexStart:
    """Find and check the header of a RINEX file.

    Parameters
    ----------
    lines : list of bytes
        The file's lines.
    path : str or os.PathLike
        File name for error messages.
    expected_types : str
        File-type letters the caller reads (``"O"``, or ``"NGH"`` for navigation).

    Raises
    ------
    GnssInputError
        Empty file, first line not ``RINEX VERSION / TYPE``, a version other than 2.xx or
        3.xx, a file type not in `expected_types`, or no ``END OF HEADER``.
    """
    if not lines:
        raise GnssInputError("empty file", path=path, line=1)
    first = lines[0].decode("ascii", errors="replace")
    if first[_LABEL_COLUMN:].strip() != _VERSION_LABEL:
        raise GnssInputError("not a RINEX file: first line is not 'RINEX VERSION / TYPE'",
                             path=path, line=1)
    try:
        version = float(first[:9])
        if not math.isfinite(version):       # 'inf', 'nan' convert, and int() fails
            raise ValueError(version)
    except ValueError:
        raise GnssInputError(f"bad RINEX version {first[:9].strip()!r}",
                             path=path, line=1, column="version") from None
    if int(version) not in _MAJOR_VERSIONS:
        raise GnssInputError(f"unsupported RINEX version {version:.2f} (reads 2.xx, 3.xx and "
                             "4.xx)",
                             path=path, line=1, column="version")
    file_type = first[20:21]
    if file_type not in expected_types:
        raise GnssInputError(f"wrong file type {file_type!r}: expected one of "
                             f"{', '.join(repr(t) for t in expected_types)}",
                             path=path, line=1, column="file type")
    header = []
    for i, raw in enumerate(lines):
        text = raw.decode("ascii", errors="replace")
        label = text[_LABEL_COLUMN:].strip()
        if label == _END_LABEL:
            return RinexStart(version, file_type, first[40:41].strip(), header, i + 1)
        header.append(HeaderLine(label, text[:_LABEL_COLUMN], i + 1))
    raise GnssInputError("header has no 'END OF HEADER' line", path=path, line=len(lines))


def float_field(h: HeaderLine, start: int, stop: int, *, path, column: str,
                d_exponent: bool = False) -> float:
    """A real number from columns ``start:stop`` of a header line (``D`` exponents allowed)."""
    text = h.content[start:stop]
    if d_exponent:
        text = text.replace("D", "E").replace("d", "e")
    try:
        return float(text)
    except ValueError:
        raise GnssInputError(f"{text.strip()!r} is not a number", path=path, line=h.line,
                             column=column) from None


def int_field(h: HeaderLine, start: int, stop: int, *, path, column: str) -> int:
    """An integer from columns ``start:stop`` of a header line."""
    text = h.content[start:stop]
    try:
        return int(text)
    except ValueError:
        raise GnssInputError(f"{text.strip()!r} is not an integer", path=path, line=h.line,
                             column=column) from None


#: ``LEAP SECONDS``: current leap seconds (I6, columns 1-6) and the time-system identifier
#: (A3, columns 25-27; ``GPS``, ``BDS`` or blank = GPS) of RINEX 3.04 Tables A2 and A5.
_LEAP_COLUMNS = (0, 6)
_LEAP_SYSTEM_COLUMNS = (24, 27)


def leap_seconds_field(h: HeaderLine, *, path) -> int:
    """GPST - UTC (s) from a ``LEAP SECONDS`` header line.

    RINEX 3.04 (Tables A2 and A5) lets the line give BeiDou's leap seconds (BDT - UTC)
    when columns 25-27 say ``BDS``; since ``BDT = GPST - 14 s`` these are 14 s fewer than
    GPST - UTC (4 against 18 in 2020), so ``BDS`` values are returned + 14 s.

    Raises
    ------
    GnssInputError
        A non-integer count or an identifier other than ``GPS``, ``BDS`` or blank.
    """
    value = int_field(h, *_LEAP_COLUMNS, path=path, column="leap seconds")
    system = h.content[slice(*_LEAP_SYSTEM_COLUMNS)].strip()
    if system in ("", "GPS"):
        return value
    if system == "BDS":
        return value - int(BDT_MINUS_GPST_S)  # BDT - GPST = -14 s
    raise GnssInputError(f"leap seconds of time system {system!r}: expected GPS, BDS or blank",
                         path=path, line=h.line, column="leap seconds time system")


def lenient_floats(h: HeaderLine, spans, *, path, column: str, notes: list[str],
                   d_exponent: bool = False) -> list[float]:
    """Real numbers from fixed columns, or, if they do not convert, from whitespace tokens.

    Some writers put a header field one column off (georinex's ``demo.10o`` APPROX
    POSITION XYZ, ``demo.10n`` DELTA-UTC). When the fixed columns do not convert but the
    line's first 60 columns hold exactly ``len(spans)`` numbers separated by blanks, the
    meaning is unambiguous: those are read, and a note naming the line is appended to
    `notes` (the reader logs them once per file, `warn_lenient`), as RTKLIB tolerates them.

    Raises
    ------
    GnssInputError
        Neither the columns nor the tokens give the expected numbers.
    """
    try:
        return [float_field(h, a, b, path=path, column=column, d_exponent=d_exponent)
                for a, b in spans]
    except GnssInputError as exc:
        text = h.content.replace("D", "E").replace("d", "e") if d_exponent else h.content
        tokens = text.split()
        if len(tokens) != len(spans):
            raise exc from None
        try:
            values = [float(t) for t in tokens]
        except ValueError:
            raise exc from None
    notes.append(f"line {h.line}: {h.label} fields out of their columns, read by blanks")
    return values


def warn_lenient(log: logging.Logger, path, notes: list[str]) -> None:
    """One warning per file listing the lines that were read leniently (none: silent)."""
    if notes:
        log.warning("%s: read leniently (RINEX column layout not followed): %s", path,
                    "; ".join(notes))
