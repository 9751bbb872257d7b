"""RINEX 4.0x navigation bodies: record framing, the legacy-message records, ION records.

A RINEX 4 navigation body is a sequence of records each opened by a line ``> TYPE SV MSG``
(RINEX 4.01 §5.4, Table A31): ``TYPE`` is ``EPH`` (ephemeris), ``STO`` (system time
offset), ``EOP`` (Earth orientation) or ``ION`` (ionosphere). An ``EPH`` record of the
legacy messages — GPS/QZSS/NavIC ``LNAV``, Galileo ``INAV``/``FNAV``, BeiDou ``D1``/``D2``,
GLONASS ``FDMA`` (4 broadcast-orbit lines, as from RINEX 3.05), SBAS ``SBAS`` — has the
RINEX 3 layout under its ``>`` line, so `record_starts_v4` hands its first line to the
RINEX 3 record parser. Other messages (``CNAV``, ``CNV1``-``CNV3``, ...), ``STO`` and
``EOP`` records are skipped and counted; the reader says so in one warning.

``ION`` records replace the header's ``IONOSPHERIC CORR`` lines in RINEX 4: the first GPS
``LNAV`` record (Klobuchar α0-α3, β0-β3) and the first Galileo ``IFNV`` record (NeQuick-G
ai0-ai2) are read into the header's ``iono_gps_alpha/beta`` and ``iono_gal``.
"""
from __future__ import annotations

import numpy as np

from gnss_obs._nav_layout import LAYOUTS, continuation_lines
from gnss_obs.errors import GnssInputError

__all__ = ["record_starts_v4", "LEGACY_MESSAGES"]

#: Messages whose EPH records have the RINEX 3 layout, per system letter.
LEGACY_MESSAGES = {"G": ("LNAV",), "J": ("LNAV",), "I": ("LNAV",), "E": ("INAV", "FNAV"),
                   "C": ("D1", "D2"), "R": ("FDMA",), "S": ("SBAS",)}
#: Value columns of an ION record's lines (4X then D19.12 fields; the first line opens
#: with the transmission epoch, so its values start at column 24).
_FIRST_VALUES = ((23, 42), (42, 61), (61, 80))
_NEXT_VALUES = ((4, 23), (23, 42), (42, 61), (61, 80))


def _numbers(line: bytes, spans, line_no: int, path, what: str) -> list[float]:
    text = line.decode("ascii", errors="replace").replace("D", "E").replace("d", "e")
    try:
        return [float(text[a:b]) for a, b in spans]
    except ValueError:
        raise GnssInputError(f"{what}: a value is not a number", path=path,
                             line=line_no) from None


def _ion(body, i: int, system: str, message: str, first_line: int, path, iono: dict) -> None:
    """Read a GPS LNAV (Klobuchar) or Galileo IFNV (NeQuick-G) ION record once."""
    if system == "G" and message == "LNAV" and "iono_gps_alpha" not in iono:
        if i + 3 >= len(body):
            raise GnssInputError("file ends inside an ION record", path=path,
                                 line=first_line + i)
        a = _numbers(body[i + 1], _FIRST_VALUES, first_line + i + 1, path, "ION LNAV")
        b = _numbers(body[i + 2], _NEXT_VALUES, first_line + i + 2, path, "ION LNAV")
        c = _numbers(body[i + 3], _NEXT_VALUES[:1], first_line + i + 3, path, "ION LNAV")
        iono["iono_gps_alpha"] = np.array(a + b[:1])
        iono["iono_gps_beta"] = np.array(b[1:] + c)
    elif system == "E" and message == "IFNV" and "iono_gal" not in iono:
        if i + 1 >= len(body):
            raise GnssInputError("file ends inside an ION record", path=path,
                                 line=first_line + i)
        iono["iono_gal"] = np.array(_numbers(body[i + 1], _FIRST_VALUES, first_line + i + 1,
                                             path, "ION IFNV"))


def record_starts_v4(body: list[bytes], first_line: int, version: float, path
                     ) -> tuple[dict[str, list[int]], dict[str, int], dict]:
    """Locate the legacy-message EPH records of a RINEX 4 navigation body.

    Parameters
    ----------
    body : list of bytes
        Lines after ``END OF HEADER``.
    first_line : int
        1-based file line of ``body[0]``.
    version : float
    path : str or os.PathLike
        For messages.

    Returns
    -------
    groups : dict of str to list of int
        System letter -> index (into `body`) of the first line of each record in RINEX 3
        layout (the line after ``>``).
    skipped : dict of str to int
        ``"EPH G01 CNAV"``-style keys without the satellite (``"EPH G CNAV"``, ``"STO"``)
        -> number of records skipped.
    iono : dict
        ``iono_gps_alpha``, ``iono_gps_beta``, ``iono_gal`` from ION records (absent keys
        when the file has none).

    Raises
    ------
    GnssInputError
        A body line outside a record, a ``>`` line without type, or a truncated record.
    """
    groups: dict[str, list[int]] = {}
    skipped: dict[str, int] = {}
    iono: dict = {}
    i, n = 0, len(body)
    while i < n:
        line = body[i]
        if not line.strip():
            i += 1
            continue
        if line[:1] != b">":
            raise GnssInputError("expected a record line starting with '>' (RINEX 4)",
                                 path=path, line=first_line + i)
        parts = line[1:].decode("ascii", errors="replace").split()
        if not parts:
            raise GnssInputError("record line without a type", path=path, line=first_line + i)
        kind = parts[0]
        system = parts[1][:1] if len(parts) > 1 else ""
        message = parts[2] if len(parts) > 2 else ""
        if kind == "EPH" and message in LEGACY_MESSAGES.get(system, ()) and system in LAYOUTS:
            k = continuation_lines(system, version)
            if i + 2 + k > n or any(body[j][:1] == b">" for j in range(i + 1, i + 2 + k)):
                raise GnssInputError(f"EPH {system} {message} record has fewer than {k + 1} "
                                     "lines", path=path, line=first_line + i)
            groups.setdefault(system, []).append(i + 1)
            i += 2 + k
            continue
        if kind == "ION":
            _ion(body, i, system, message, first_line, path, iono)
        key = f"{kind} {system} {message}".strip() if kind == "EPH" else kind
        if not (kind == "ION" and (system, message) in (("G", "LNAV"), ("E", "IFNV"))):
            skipped[key] = skipped.get(key, 0) + 1
        i += 1
        while i < n and body[i][:1] != b">":
            i += 1
    return groups, skipped, iono
