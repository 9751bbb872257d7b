"""Track files (``.csv``): reading with located one-line errors, and writing.

Format: an optional comment line ``# earth=wgs84`` or ``# earth=sphere radius_m=6371000``
(default WGS-84), other ``#`` lines are free comments (provenance), then a CSV header and
one row per section with the columns of `trackmodel.table`; the first row also carries
the origin ``lat_deg, lon_deg, h_m``. Example::

    # earth=sphere radius_m=6371000
    lat_deg,lon_deg,h_m,length_m,azimuth_deg,elevation_deg
    50.45,30.52,100.0,25000.0,30.0,3.0

Numbers are written with ``repr`` (shortest exact decimal), so a file read and written
again is unchanged and a track written and read again is the same track.
"""
from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence

from trackmodel.earth import WGS84, Ellipsoid, earth_from_name
from trackmodel.errors import TrackFileError
from trackmodel.files import atomic_write_text
from trackmodel.plausibility import ImplausibleTrackError
from trackmodel.table import located, sections_from_rows, sections_to_frame
from trackmodel.textfile import read_text
from trackmodel.track import Track

__all__ = ["read_track", "write_track", "parse_track_text", "track_to_text", "EARTH_KEY"]

EARTH_KEY = "earth"


def _earth_from_comment(text: str, *, line: int, path) -> Ellipsoid:
    """Earth model from ``# earth=NAME [radius_m=R]``."""
    fields: dict[str, str] = {}
    for token in text.lstrip("#").split():
        key, sep, value = token.partition("=")
        if not sep:
            raise TrackFileError(f"expected key=value, got {token!r}", path=path, line=line)
        fields[key.strip().lower()] = value.strip()
    unknown = set(fields) - {EARTH_KEY, "radius_m"}
    if unknown:
        raise TrackFileError(f"unknown key {sorted(unknown)[0]!r} (expected earth=, radius_m=)",
                             path=path, line=line)
    radius = fields.get("radius_m")
    try:
        radius_m = None if radius is None else float(radius)
    except ValueError:
        raise TrackFileError(f"radius_m {radius!r} is not a number", path=path,
                             line=line) from None
    try:
        return earth_from_name(fields[EARTH_KEY], radius_m=radius_m)
    except ValueError as exc:
        raise TrackFileError(str(exc), path=path, line=line) from None


def parse_track_text(text: str, *, path: str | os.PathLike | None = None) -> Track:
    """Track from the text of a track file (see the module docstring).

    Raises
    ------
    TrackFileError
        Located by line (header comments), row and column.
    """
    earth: Ellipsoid | None = None
    body = []
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if stripped.startswith("#"):
            if f"{EARTH_KEY}=" in stripped.replace(" ", ""):
                if earth is not None:
                    raise TrackFileError("earth given twice", path=path, line=number)
                earth = _earth_from_comment(stripped, line=number, path=path)
        elif stripped:
            body.append(line)
    reader = csv.reader(io.StringIO("\n".join(body)))
    header = [c.strip() for c in next(reader, [])]
    rows = []
    for row, cells in enumerate(reader, start=1):
        if len(cells) != len(header):     # more: a stray value; fewer: a row cut short
            raise TrackFileError(f"{len(cells)} fields but the header has {len(header)}"
                                 + (" (a row cut short?)" if len(cells) < len(header) else ""),
                                 path=path, row=row)
        rows.append(dict(zip(header, cells)))
    sections, origin = sections_from_rows(header, rows, path=path)
    try:
        return Track(sections, origin, WGS84 if earth is None else earth)
    except ImplausibleTrackError as exc:      # found while walking the sections (latitude)
        raise located(exc, path) from None


def read_track(path: str | os.PathLike) -> Track:
    """Read a track file.

    Parameters
    ----------
    path : str or os.PathLike

    Returns
    -------
    Track

    Raises
    ------
    TrackFileError
        For anything that is not a valid track file (one line, with row and column; a byte
        that is not UTF-8 with its line).
    OSError
        If the file cannot be opened.
    """
    return parse_track_text(read_text(path, error=TrackFileError), path=path)


def _cell(value) -> str:
    return "" if value is None else repr(float(value))


def track_to_text(track: Track, *, comments: Sequence[str] = ()) -> str:
    """The text of the track file of `track` (free `comments` lines after the earth line)."""
    earth = track.earth
    head = f"# earth={earth.name}"
    if earth.is_sphere:
        head += f" radius_m={earth.a_m!r}"
    elif earth.name == "sphere" or earth.a_m != earth_from_name(earth.name).a_m:
        raise TrackFileError(f"cannot write earth {earth!r}: only wgs84 and spheres")
    lines = [head] + [f"# {c}" for c in comments]
    frame = sections_to_frame(track.sections, track.origin)
    lines.append(",".join(frame.columns))
    for record in frame.itertuples(index=False):
        lines.append(",".join(_cell(v) for v in record))
    return "\n".join(lines) + "\n"


def write_track(track: Track, path: str | os.PathLike, *, comments: Sequence[str] = ()) -> None:
    """Write `track` as a track file (atomically).

    Parameters
    ----------
    track : Track
    path : str or os.PathLike
    comments : sequence of str
        Free comment lines (e.g. provenance), written after the ``# earth=`` line.
    """
    atomic_write_text(path, track_to_text(track, comments=comments))

