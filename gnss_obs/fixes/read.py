"""Any fix file: its format told from its content, read, and its σ completed.

`detect_fix_format` looks at the first bytes (`SNIFF_BYTES`), never at the file name:

* ``ubx``: the UBX sync characters ``0xB5 0x62`` (never in a text file: 0xB5 is not ASCII);
* ``gpx``: XML whose root element is ``gpx``;
* ``nmea``: a line that starts with ``$`` or ``!`` and has a ``*hh`` checksum;
* ``csv``: anything else with a comma in its first line; a first line with semicolons or
  tabs and no comma is a table with another separator, refused as such.

`read_fixes` reads with the format's reader (`gnss_obs.fixes.csv_reader`, ``nmea_reader``,
``ubx_reader``, ``gpx_reader``) and fills the σ the file lacks from the fix class
(`gnss_obs.fixes.quality.apply_fix_sigmas`).
"""
from __future__ import annotations

import logging
import os
import re

from gnss_obs.errors import GnssInputError
from gnss_obs.fixes.quality import FixSigmas, apply_fix_sigmas, fix_sigma_table
from gnss_obs.fixes.table import FixLog

__all__ = ["read_fixes", "detect_fix_format", "FIX_FORMATS", "SNIFF_BYTES"]

log = logging.getLogger(__name__)

#: Bytes looked at to tell the format.
SNIFF_BYTES = 4096
#: The formats `read_fixes` reads.
FIX_FORMATS = ("csv", "nmea", "ubx", "gpx")
_UBX_SYNC = b"\xb5\x62"
_NMEA_LINE = re.compile(rb"^[$!][A-Z0-9]{3,6},[^\r\n]*\*[0-9A-Fa-f]{2}\s*$", re.MULTILINE)
_GPX_ROOT = re.compile(rb"<(?:\w+:)?gpx[\s>]")
#: Separators of other tables, named in the error that refuses them.
_OTHER_SEPARATORS = {b";": "semicolons (';')", b"\t": "tabs"}


def detect_fix_format(path: str | os.PathLike) -> str:
    """The format of a fix file, from its content (module docstring).

    Raises
    ------
    GnssInputError
        An empty file, a table separated by semicolons or tabs, or content none of the
        rules recognises.
    OSError
        If the file cannot be opened.
    """
    with open(path, "rb") as fh:
        head = fh.read(SNIFF_BYTES)
    if not head.strip():
        raise GnssInputError("empty fix file", path=path)
    if _UBX_SYNC in head:
        return "ubx"
    text = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if text.startswith(b"<") and _GPX_ROOT.search(head):
        return "gpx"
    if _NMEA_LINE.search(head):
        return "nmea"
    first_line = text.split(b"\n", 1)[0]
    if b"," in first_line:
        return "csv"
    for sep, name in _OTHER_SEPARATORS.items():
        if sep in first_line:
            raise GnssInputError(f"a table separated by {name}: a fix CSV is separated by "
                                 "commas (',', with '.' decimal points)", path=path)
    raise GnssInputError("not a fix file this reader knows (CSV, NMEA 0183, u-blox UBX, "
                         "GPX)", path=path)


def read_fixes(path: str | os.PathLike, *, format: str | None = None,
               sigmas: dict[str, FixSigmas] | None = None, date=None) -> FixLog:
    """Read a fix file and complete its σ.

    Parameters
    ----------
    path : str or os.PathLike
    format : str, optional
        One of `FIX_FORMATS`; default: `detect_fix_format`.
    sigmas : dict of str to gnss_obs.fixes.quality.FixSigmas, optional
        σ of the fix classes the file lacks (classes not given keep
        `gnss_obs.fixes.quality.DEFAULT_FIX_SIGMAS`).
    date : datetime.date, optional
        NMEA logs without RMC: the UTC date of the first epoch.

    Returns
    -------
    gnss_obs.fixes.table.FixLog
        Every σ filled; a summary of what was skipped is logged once.

    Raises
    ------
    GnssInputError
        Unknown format, or what the format's reader raises.
    """
    fmt = format or detect_fix_format(path)
    if fmt == "csv":
        from gnss_obs.fixes.csv_reader import read_fixes_csv as reader
    elif fmt == "nmea":
        from gnss_obs.fixes.nmea_reader import read_fixes_nmea
        def reader(p): return read_fixes_nmea(p, date=date)  # noqa: E704
    elif fmt == "ubx":
        from gnss_obs.fixes.ubx_reader import read_fixes_ubx as reader
    elif fmt == "gpx":
        from gnss_obs.fixes.gpx_reader import read_fixes_gpx as reader
    else:
        raise GnssInputError(f"unknown fix format {fmt!r} (known: {', '.join(FIX_FORMATS)})",
                             path=path)
    fixes = reader(path)
    skipped = {k: v for k, v in fixes.skipped.items() if v}
    if skipped:
        log.warning("%s: %d fixes read; skipped %s", path, len(fixes),
                    ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in skipped.items()))
    table = apply_fix_sigmas(fixes.table, fix_sigma_table(sigmas))
    return FixLog(table, fixes.format, fixes.path, fixes.time_scale,
                  utc_suffix=fixes.utc_suffix, skipped=dict(fixes.skipped))
