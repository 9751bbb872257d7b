"""The section table as rows of text or a DataFrame: parsing with located errors.

Columns (the track file format, `trackmodel.io`):

===================  ========  ==========================================================
column               required  meaning
===================  ========  ==========================================================
lat_deg, lon_deg     row 1     origin latitude/longitude, degrees (later rows: empty)
h_m                  row 1     origin ellipsoidal height, m (later rows: empty)
length_m             yes       section length, m, > 0
azimuth_deg          yes       start azimuth, degrees clockwise from north; empty on a
                               later row = continue the previous section's end azimuth
elevation_deg        yes       start elevation, degrees, |ϑ| < 90; empty on a later row
                               = continue the previous end elevation
curvature_1pm        no        start curvature dA/ds, 1/m, + = clockwise (empty = 0)
curvature_end_1pm    no        end curvature, 1/m: a clothoid (empty = constant)
elevation_end_deg    no        end elevation, degrees: a vertical curve (empty = constant)
===================  ========  ==========================================================

Values beyond the plausibility limits (`trackmodel.plausibility`: radius, turn, length,
azimuth, longitude, height, kinks) are errors at their row and column.
"""
from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence

import pandas as pd

from trackmodel.errors import TrackError, TrackFileError
from trackmodel.origin import Origin
from trackmodel.plausibility import ImplausibleTrackError, check_table
from trackmodel.sections import MAX_ELEVATION_DEG, Section

__all__ = ["ORIGIN_COLUMNS", "REQUIRED_COLUMNS", "OPTIONAL_COLUMNS", "ALL_COLUMNS",
           "sections_from_rows", "sections_from_frame", "sections_to_frame", "located"]

ORIGIN_COLUMNS = ("lat_deg", "lon_deg", "h_m")
REQUIRED_COLUMNS = ("length_m", "azimuth_deg", "elevation_deg")
OPTIONAL_COLUMNS = ("curvature_1pm", "curvature_end_1pm", "elevation_end_deg")
ALL_COLUMNS = ORIGIN_COLUMNS + REQUIRED_COLUMNS + OPTIONAL_COLUMNS

Cell = str | float | None
#: Longest column name quoted in an error message, characters.
_MAX_SHOWN = 40


def _number(cell: Cell, *, row: int, column: str, path) -> float | None:
    """A finite float, or None for an empty cell."""
    if cell is None or (isinstance(cell, float) and math.isnan(cell)):
        return None
    text = str(cell).strip()
    if not text:
        return None
    try:
        value = float(text)
    except ValueError:
        raise TrackFileError(f"{text!r} is not a number", path=path, row=row,
                             column=column) from None
    if not math.isfinite(value):
        raise TrackFileError(f"{text!r} must be a finite number", path=path, row=row,
                             column=column)
    return value


def _check_columns(columns: Sequence[str], path) -> None:
    if not columns:
        raise TrackFileError("empty file (no header line)", path=path)
    unknown = [c for c in columns if c not in ALL_COLUMNS]
    if unknown:
        name = unknown[0]
        if len(name) > _MAX_SHOWN or not name.isprintable():   # e.g. a stray quote's swallow
            name = repr(name[:_MAX_SHOWN]) + ("..." if len(name) > _MAX_SHOWN else "")
        raise TrackFileError(f"unknown column (expected some of {', '.join(ALL_COLUMNS)})",
                             path=path, column=name)
    missing = [c for c in REQUIRED_COLUMNS + ORIGIN_COLUMNS if c not in columns]
    if missing:
        raise TrackFileError("required column missing", path=path, column=missing[0])


def _origin(values: dict[str, float | None], path) -> Origin:
    for name in ORIGIN_COLUMNS:
        if values[name] is None:
            raise TrackFileError("the origin is missing: row 1 needs lat_deg, lon_deg, h_m",
                                 path=path, row=1, column=name)
    try:
        return Origin(values["lat_deg"], values["lon_deg"], values["h_m"])
    except TrackError as exc:
        column = getattr(exc, "column", None) or "lat_deg"
        raise TrackFileError(str(exc), path=path, row=1, column=column) from None


def _section(values: dict[str, float | None], row: int, path) -> Section:
    length = values["length_m"]
    if length is None or length <= 0.0:
        raise TrackFileError(f"must be a length > 0 m, got {length!r}", path=path, row=row,
                             column="length_m")
    for name in ("elevation_deg", "elevation_end_deg"):
        value = values.get(name)
        if value is not None and not abs(value) < MAX_ELEVATION_DEG:
            raise TrackFileError(f"must satisfy -90 < {name} < 90, got {value!r}",
                                 path=path, row=row, column=name)
    if row == 1:
        for name in ("azimuth_deg", "elevation_deg"):
            if values[name] is None:
                raise TrackFileError("the first section needs a value", path=path, row=1,
                                     column=name)
    try:
        return Section(length_m=length, azimuth_deg=values["azimuth_deg"],
                       elevation_deg=values["elevation_deg"],
                       curvature_1pm=values.get("curvature_1pm") or 0.0,
                       curvature_end_1pm=values.get("curvature_end_1pm"),
                       elevation_end_deg=values.get("elevation_end_deg"))
    except ImplausibleTrackError as exc:
        raise located(exc, path, row=row) from None


def located(exc: ImplausibleTrackError, path, *, row: int | None = None) -> TrackFileError:
    """`exc` as a file error at its section's row (1-based) and column."""
    if row is None and exc.section is not None:
        row = exc.section + 1
    return TrackFileError(exc.message, path=path, row=row, column=exc.column)


def sections_from_rows(columns: Sequence[str], rows: Sequence[Mapping[str, Cell]], *,
                       path: str | os.PathLike | None = None):
    """Sections and origin from table rows.

    Parameters
    ----------
    columns : sequence of str
        The header.
    rows : sequence of mapping column -> cell
        Data rows; a cell is text, a float (NaN = empty) or None (empty).
    path : path, optional
        For error messages.

    Returns
    -------
    sections : tuple of Section
    origin : trackmodel.origin.Origin

    Raises
    ------
    TrackFileError
        With the row (1-based, header not counted) and column of the first problem,
        including values beyond the plausibility limits (`trackmodel.plausibility`).
    """
    _check_columns(list(columns), path)
    if not rows:
        raise TrackFileError("no section rows after the header", path=path)
    sections, origin = [], None
    for row, cells in enumerate(rows, start=1):
        values = {c: _number(cells.get(c), row=row, column=c, path=path) for c in columns}
        for c in ALL_COLUMNS:
            values.setdefault(c, None)
        if row == 1:
            origin = _origin(values, path)
        else:
            given = [c for c in ORIGIN_COLUMNS if values[c] is not None]
            if given:
                raise TrackFileError("the origin belongs on row 1 only (leave it empty)",
                                     path=path, row=row, column=given[0])
        sections.append(_section(values, row, path))
    try:
        check_table(sections, lon_deg=origin.lon_deg, h_m=origin.h_m, warn=False)
    except ImplausibleTrackError as exc:
        raise located(exc, path) from None
    return tuple(sections), origin


def sections_from_frame(frame: pd.DataFrame):
    """Sections and origin from a DataFrame with the track columns (NaN = empty cell)."""
    rows = frame.to_dict(orient="records")
    return sections_from_rows([str(c) for c in frame.columns], rows)


def sections_to_frame(sections: Sequence[Section], origin: Origin) -> pd.DataFrame:
    """The table as a DataFrame with the file's columns (None for empty cells).

    Optional columns appear only when a section uses them.
    """
    records = []
    for i, sec in enumerate(sections):
        rec = dict.fromkeys(ORIGIN_COLUMNS)
        if i == 0:
            rec.update(lat_deg=origin.lat_deg, lon_deg=origin.lon_deg, h_m=origin.h_m)
        rec.update(length_m=sec.length_m, azimuth_deg=sec.azimuth_deg,
                   elevation_deg=sec.elevation_deg, curvature_1pm=sec.curvature_1pm,
                   curvature_end_1pm=sec.curvature_end_1pm,
                   elevation_end_deg=sec.elevation_end_deg)
        records.append(rec)
    frame = pd.DataFrame.from_records(records, columns=list(ALL_COLUMNS)).astype(object)
    frame = frame.where(frame.notna(), None)
    used = [c for c in OPTIONAL_COLUMNS
            if c != "curvature_1pm" and frame[c].notna().any()]
    if any(sec.curvature_1pm != 0.0 for sec in sections) or used:
        used.insert(0, "curvature_1pm")
    return frame[list(ORIGIN_COLUMNS + REQUIRED_COLUMNS) + used]
