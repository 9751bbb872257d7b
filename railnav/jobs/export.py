"""The estimated trajectory in the formats other tools read (``railnav run --export``).

`write_exports` writes an ``estimates.csv``-shaped table (`railnav.navigation.result`) as
``<name>.<ext>`` for each format of `EXPORT_FORMATS`, atomically:

* ``geojson`` (RFC 7946, the standard library's `json`): a FeatureCollection of one
  LineString (the trajectory, ``[lon, lat, h]``) followed by one Point per estimate whose
  ``properties`` are every column of its row — the σ columns, and whatever optional
  columns the table carries (e.g. the protection interval ``s_min_m``/``s_max_m``) pass
  through unchanged;
* ``kml`` (OGC KML 2.2, `xml.etree.ElementTree`: simplekml is not among the packages this
  project may use, and KML is a few elements of plain XML): a LineString Placemark
  (absolute altitudes, the ellipsoidal height) and one Placemark per estimate with its
  UTC ``TimeStamp`` and every column as ``ExtendedData``;
* ``gpx`` (GPX 1.1 by gpxpy): one track segment, a point per estimate with its UTC time,
  ``ele`` = the ellipsoidal height with ``geoidheight`` 0 (their sum is the ellipsoidal
  height, as `gnss_obs.fixes.gpx_reader` reads it), and every other column, with
  ``course_deg``, in an ``estimate`` extension element of the namespace `GPX_NAMESPACE`
  (GPX 1.1 has no speed or course fields);
* ``nmea`` (NMEA 0183 by pynmea2's sentence builder, `gnss_obs.fixes.writers`): GGA, RMC,
  VTG and GST per estimate — the GST carries the σ north/east/up; the quality is 6 / mode
  ``E`` ("estimated"), which is what a filter's output is, not a receiver fix.

Course over ground is ``atan2(v_east, v_north)``. Times are UTC from ``gps_time_s``
(`gnss_obs.gpstime.from_gps_time_s`: the leap seconds of the date).

**Without heights** (``h_m`` empty, as in a run on a network without heights,
`railnav.navigation.result.without_heights`) no format invents one: GeoJSON positions are
``[lon, lat]`` (RFC 7946 §3.1.1: the altitude is optional), KML coordinates ``lon,lat``
with ``clampToGround`` (KML 2.2: the altitude is ignored), GPX points have no ``ele``
(optional in GPX 1.1) and no ``geoidheight``, NMEA's GGA has empty altitude and geoid
separation fields and GST an empty height σ (NMEA 0183's null field: "not available").
None of the four formats requires a height. A table with heights on some rows only has
them left out of every position.
"""
from __future__ import annotations

import datetime as dt
import json
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gnss_obs.gpstime import gps_time_s_to_utc_iso
from railnav.errors import ConfigError
from trackmodel.files import atomic_write, atomic_write_text

if TYPE_CHECKING:                   # pandas only where a table is written (start-up)
    import pandas as pd

__all__ = ["EXPORT_FORMATS", "write_exports", "write_run_exports", "parse_export_formats",
           "GPX_NAMESPACE",
           "KML_NAMESPACE"]

#: Formats of `write_exports`, in the order they are written.
EXPORT_FORMATS = ("geojson", "kml", "gpx", "nmea")
#: Namespace of the extension elements of a GPX export (a URN: nothing to resolve).
GPX_NAMESPACE = "urn:railnav:gpx:estimate:1"
KML_NAMESPACE = "http://www.opengis.net/kml/2.2"
_GPX_PREFIX = "railnav"
#: Columns the GPX point carries in its own fields (not repeated in the extension).
_GPX_OWN = ("lat_deg", "lon_deg", "h_m")


def parse_export_formats(text: str) -> tuple[str, ...]:
    """``geojson,kml`` -> the formats, checked (order kept, repeats dropped)."""
    formats = tuple(dict.fromkeys(f.strip().lower() for f in text.split(",") if f.strip()))
    unknown = [f for f in formats if f not in EXPORT_FORMATS]
    if not formats or unknown:
        raise ConfigError(f"--export {text!r}: formats are {', '.join(EXPORT_FORMATS)}")
    return formats


def write_exports(estimates: pd.DataFrame, out_dir: str | os.PathLike,
                  formats=EXPORT_FORMATS, *, name: str = "trajectory") -> list[Path]:
    """Write `estimates` as ``out_dir/<name>.<format>`` for each of `formats`.

    Parameters
    ----------
    estimates : pandas.DataFrame
        ``estimates.csv`` columns: at least ``gps_time_s, lat_deg, lon_deg, h_m``;
        ``speed_mps``, ``v_east_mps``, ``v_north_mps`` and the ``sigma_*`` where known.
    out_dir : path
    formats : sequence of str
        Of `EXPORT_FORMATS`.
    name : str
        File stem.

    Returns
    -------
    list of pathlib.Path
    """
    writers = {"geojson": _geojson, "kml": _kml, "gpx": _gpx, "nmea": _nmea}
    out = Path(out_dir)
    paths = []
    for fmt in formats:
        path = out / f"{name}.{fmt}"
        writers[fmt](estimates, path)
        paths.append(path)
    return paths


def write_run_exports(outcome, out_dir: str | os.PathLike,
                      formats=EXPORT_FORMATS) -> list[Path]:
    """``railnav run --export``: `write_exports` of a run's estimates (``trajectory.*``)
    and, when it was smoothed, of the smoothed ones (``smoothed.*``).

    Parameters
    ----------
    outcome : railnav.jobs.run.RunOutcome
    out_dir : path
    formats : sequence of str
        Of `EXPORT_FORMATS` (`parse_export_formats` reads ``geojson,kml``).
    """
    written = write_exports(outcome.result.estimates, out_dir, formats)
    if outcome.smoothed is not None:
        written += write_exports(outcome.smoothed.result.estimates, out_dir, formats,
                                 name="smoothed")
    return written


def _value(v):
    """A table value as JSON/XML data (NaN -> None)."""
    if isinstance(v, (float, np.floating)):
        return None if not math.isfinite(v) else float(v)
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.bool_,)):
        return bool(v)
    return v


def _text(v) -> str:
    """A table value as XML text: floats in their shortest round-trip form, NaN empty."""
    v = _value(v)
    return "" if v is None else repr(v) if isinstance(v, float) else str(v)


def _has_heights(est: pd.DataFrame) -> bool:
    """Whether every row has a height (module docstring)."""
    return bool(np.all(np.isfinite(est["h_m"].to_numpy(dtype=float))))


def _positions(est: pd.DataFrame) -> np.ndarray:
    """``lon, lat[, h]`` of each row, degrees and m, shape (N, 3) or (N, 2) without
    heights."""
    return est[["lon_deg", "lat_deg", "h_m"] if _has_heights(est)
               else ["lon_deg", "lat_deg"]].to_numpy(dtype=float)


def _geojson(est: pd.DataFrame, path: Path) -> None:
    coords = _positions(est).tolist()
    line = {"type": "Feature", "geometry": {"type": "LineString", "coordinates": coords},
            "properties": {"name": "estimated trajectory", "samples": len(est)}}
    columns = list(est.columns)
    points = [{"type": "Feature", "geometry": {"type": "Point", "coordinates": xyz},
               "properties": {c: _value(v) for c, v in zip(columns, row)}}
              for xyz, row in zip(coords, est.itertuples(index=False, name=None))]
    doc = {"type": "FeatureCollection", "features": [line, *points]}
    atomic_write_text(path, json.dumps(doc, allow_nan=False) + "\n")


def _kml(est: pd.DataFrame, path: Path) -> None:
    ns = f"{{{KML_NAMESPACE}}}"
    ET.register_namespace("", KML_NAMESPACE)
    root = ET.Element(ns + "kml")
    doc = ET.SubElement(root, ns + "Document")
    ET.SubElement(doc, ns + "name").text = "estimated trajectory"
    line = ET.SubElement(ET.SubElement(doc, ns + "Placemark"), ns + "LineString")
    mode = "absolute" if _has_heights(est) else "clampToGround"
    ET.SubElement(line, ns + "altitudeMode").text = mode
    xyz = [",".join(repr(float(v)) for v in p) for p in _positions(est)]
    ET.SubElement(line, ns + "coordinates").text = " ".join(xyz)
    times = gps_time_s_to_utc_iso(est["gps_time_s"].to_numpy(), suffix="Z")
    columns = list(est.columns)
    for k, row in enumerate(est.itertuples(index=False, name=None)):
        mark = ET.SubElement(doc, ns + "Placemark")
        ET.SubElement(ET.SubElement(mark, ns + "TimeStamp"), ns + "when").text = str(times[k])
        data = ET.SubElement(mark, ns + "ExtendedData")
        for c, v in zip(columns, row):
            item = ET.SubElement(data, ns + "Data", name=c)
            ET.SubElement(item, ns + "value").text = _text(v)
        point = ET.SubElement(mark, ns + "Point")
        ET.SubElement(point, ns + "altitudeMode").text = mode
        ET.SubElement(point, ns + "coordinates").text = xyz[k]
    with atomic_write(path, "wb") as fh:
        ET.ElementTree(root).write(fh, encoding="utf-8", xml_declaration=True)


def _course_deg(est: pd.DataFrame) -> np.ndarray:
    if {"v_east_mps", "v_north_mps"} <= set(est.columns):
        return np.degrees(np.arctan2(est["v_east_mps"], est["v_north_mps"])) % 360.0
    return np.full(len(est), np.nan)


def _utc_datetimes(est: pd.DataFrame) -> list[dt.datetime]:
    iso = gps_time_s_to_utc_iso(est["gps_time_s"].to_numpy())
    return [dt.datetime.fromisoformat(str(s)).replace(tzinfo=dt.timezone.utc) for s in iso]


def _gpx(est: pd.DataFrame, path: Path) -> None:
    import gpxpy.gpx

    gpx = gpxpy.gpx.GPX()
    gpx.nsmap[_GPX_PREFIX] = GPX_NAMESPACE
    track = gpxpy.gpx.GPXTrack(name="estimated trajectory")
    segment = gpxpy.gpx.GPXTrackSegment()
    gpx.tracks.append(track)
    track.segments.append(segment)
    table = est.assign(course_deg=_course_deg(est))
    extra = [c for c in table.columns if c not in _GPX_OWN]
    heights = _has_heights(est)
    for when, row in zip(_utc_datetimes(table), table.itertuples(index=False)):
        point = gpxpy.gpx.GPXTrackPoint(row.lat_deg, row.lon_deg,
                                        elevation=row.h_m if heights else None, time=when)
        point.geoid_height = 0.0 if heights else None
        values = ET.Element(f"{{{GPX_NAMESPACE}}}estimate")
        for c in extra:
            ET.SubElement(values, f"{{{GPX_NAMESPACE}}}{c}").text = _text(getattr(row, c))
        point.extensions.append(values)
        segment.points.append(point)
    atomic_write_text(path, gpx.to_xml(version="1.1"))


def _nmea(est: pd.DataFrame, path: Path) -> None:
    import pandas as pd

    from gnss_obs.fixes.writers import write_fixes_nmea

    nan = np.full(len(est), np.nan)
    table = pd.DataFrame({
        "gps_time_s": est["gps_time_s"], "lat_deg": est["lat_deg"],
        "lon_deg": est["lon_deg"], "h_m": est["h_m"] if _has_heights(est) else nan,
        "speed_mps": est["speed_mps"] if "speed_mps" in est else nan,
        "course_deg": _course_deg(est),
        **{c: est[c] if c in est else nan
           for c in ("sigma_north_m", "sigma_east_m", "sigma_up_m")},
        "quality": "dead_reckoning"})            # GGA 6 / mode E: an estimated position
    write_fixes_nmea(path, table)
