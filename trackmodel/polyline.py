"""Surveyed polylines: reading ``lat_deg, lon_deg[, h_m]`` files and cleaning the points.

Real surveys (GNSS drives, OpenStreetMap ways) repeat points (a vehicle standing still),
put points closer than the noise, and jitter backwards. `clean_polyline` keeps the given
order (the track runs from the first point to the last) and drops

* points closer than ``min_spacing_m`` to the previously kept point (duplicates, stops);
* single points where the path doubles back (turn of more than ``max_turn_deg`` between
  the chords before and after a point, the path going on forwards without it: a spike).

A path that really reverses (a vehicle backing up, turning round) is kept as it is:
`find_reversal` finds it, and the fitter reports it (a track has one direction).
`split_legs` cuts such a survey into its legs (one direction each), which can be fitted
one by one (``railnav track fit --leg N``).
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from trackmodel.earth import WGS84, Ellipsoid, ecef_to_enu, geodetic_to_ecef
from trackmodel.errors import TrackError, TrackFileError, finite_column
from trackmodel.plausibility import MAX_ABS_LON_DEG, MAX_H_M, MIN_H_M
from trackmodel.textfile import read_csv_table

__all__ = ["Polyline", "read_polyline", "clean_polyline", "find_reversal", "split_legs",
           "MIN_SPACING_M", "MAX_TURN_DEG", "MIN_LEG_M"]

Array = npt.NDArray[np.float64]

MIN_SPACING_M = 1.0
MAX_TURN_DEG = 135.0
#: A reversal: the direction (chords of `REVERSAL_CHORD_M`) turns by more than
#: `REVERSAL_TURN_DEG` within `REVERSAL_WINDOW_M` of path (a 10 m-radius U-turn turns only
#: ~34° in 6 m; a vehicle backing up or turning on the spot turns ~180°).
REVERSAL_CHORD_M = 3.0
REVERSAL_WINDOW_M = 6.0
REVERSAL_TURN_DEG = 150.0
POLYLINE_COLUMNS = ("lat_deg", "lon_deg")
#: Pieces between two reversals shorter than this are manoeuvres (the back-and-forth of a
#: three-point turn), not legs, m: two reversal windows.
MIN_LEG_M = 2 * REVERSAL_WINDOW_M


@dataclass(frozen=True)
class Polyline:
    """Surveyed points in order; arrays of shape (N,).

    Attributes
    ----------
    lat, lon : ndarray
        Geodetic latitude and longitude, rad.
    h : ndarray or None
        Ellipsoidal height, m (None when the survey has none).
    """

    lat: Array
    lon: Array
    h: Array | None = None

    def __post_init__(self) -> None:
        n = len(self.lat)
        if len(self.lon) != n or (self.h is not None and len(self.h) != n):
            raise TrackError("lat, lon and h must have the same length")
        arrays = [self.lat, self.lon] + ([] if self.h is None else [self.h])
        if not all(np.all(np.isfinite(a)) for a in arrays):
            raise TrackError("polyline coordinates must be finite")
        if n and np.abs(self.lat).max() >= math.radians(89.9):
            raise TrackError("polyline latitudes must satisfy |lat| < 89.9°")

    def __len__(self) -> int:
        return len(self.lat)

    def take(self, index: npt.NDArray[np.intp]) -> "Polyline":
        """The points at `index`."""
        return Polyline(self.lat[index], self.lon[index],
                        None if self.h is None else self.h[index])


#: Surveyed points a track can start from (`trackmodel.origin`, `trackmodel.plausibility`).
_POINT_LIMITS = (
    ("lat_deg", lambda x: np.abs(x) >= 89.9, "-89.9 < lat_deg < 89.9"),
    ("lon_deg", lambda x: np.abs(x) > MAX_ABS_LON_DEG, "-180 <= lon_deg <= 180"),
    ("h_m", lambda x: (x < MIN_H_M) | (x > MAX_H_M), f"{MIN_H_M:g} <= h_m <= {MAX_H_M:g}"),
)


def read_polyline(path: str | os.PathLike) -> Polyline:
    """Read a polyline CSV with columns ``lat_deg, lon_deg`` and optional ``h_m``.

    Lines starting with ``#`` are comments; other columns are ignored.

    Raises
    ------
    TrackFileError
        Missing column, empty file, non-numeric or non-finite value, a point outside
        `_POINT_LIMITS` (located by row and column); a byte that is not UTF-8 or a row with
        more fields than the header (located by line).
    """
    frame = read_csv_table(path, error=TrackFileError, comment="#", dtype=str,
                           skipinitialspace=True)
    frame.columns = [str(c).strip() for c in frame.columns]
    for c in POLYLINE_COLUMNS:
        if c not in frame.columns:
            raise TrackFileError("required column missing", path=path, column=c)
    if frame.empty:
        raise TrackFileError("no points after the header", path=path)
    cols = [c for c in ("lat_deg", "lon_deg", "h_m") if c in frame.columns]
    values = {}
    for c in cols:
        values[c] = finite_column(frame, c, path=path, error=TrackFileError)
    for column, outside, text in _POINT_LIMITS:
        bad = np.flatnonzero(outside(values[column])) if column in values else []
        if len(bad):
            value = float(values[column][bad[0]])
            raise TrackFileError(f"must satisfy {text}, got {value!r}", path=path,
                                 row=int(bad[0]) + 1, column=column)
    return Polyline(np.radians(values["lat_deg"]), np.radians(values["lon_deg"]),
                    values.get("h_m"))


def local_enu(poly: Polyline, earth: Ellipsoid = WGS84) -> Array:
    """Points in ENU at the first point (heights as given, or 0), shape (N, 3), m."""
    h = np.zeros_like(poly.lat) if poly.h is None else poly.h
    r_e = geodetic_to_ecef(poly.lat, poly.lon, h, earth=earth)
    return ecef_to_enu(r_e, lat0=poly.lat[0], lon0=poly.lon[0], h0=h[0], earth=earth)


def clean_polyline(poly: Polyline, *, min_spacing_m: float = MIN_SPACING_M,
                   max_turn_deg: float = MAX_TURN_DEG,
                   earth: Ellipsoid = WGS84) -> npt.NDArray[np.intp]:
    """Indices of the points kept (increasing): see the module docstring.

    Parameters
    ----------
    poly : Polyline
    min_spacing_m : float
        Minimum horizontal distance between kept points, m.
    max_turn_deg : float
        Points where the path turns by more than this are spikes, degrees.
    earth : Ellipsoid

    Returns
    -------
    ndarray of int
        Indices into `poly`.
    """
    xy = local_enu(poly, earth)[:, :2]
    keep = [0]
    for i in range(1, len(xy)):
        if np.hypot(*(xy[i] - xy[keep[-1]])) >= min_spacing_m:
            keep.append(i)
    keep = np.array(keep)
    cos_max = math.cos(math.radians(max_turn_deg))
    while len(keep) >= 4:
        d = np.diff(xy[keep], axis=0)
        cos_turn = np.einsum("ij,ij->i", d[:-1], d[1:]) / (
            np.linalg.norm(d[:-1], axis=1) * np.linalg.norm(d[1:], axis=1))
        spikes = np.flatnonzero(cos_turn < cos_max) + 1        # index into keep
        spikes = spikes[(spikes >= 2) & (spikes <= len(keep) - 2)]
        # a spike: without it the path goes on forwards (else it is a reversal: kept)
        onward = xy[keep[spikes + 1]] - xy[keep[spikes - 1]]
        before = xy[keep[spikes - 1]] - xy[keep[spikes - 2]]
        spikes = spikes[np.einsum("ij,ij->i", onward, before) > 0]
        if not len(spikes):
            break
        keep = np.delete(keep, spikes[::2])          # never two neighbours in one pass
    return keep


def find_reversal(xy: Array) -> int | None:
    """Index of the first point where a path of kept points reverses its direction.

    Parameters
    ----------
    xy : ndarray, shape (N, 2)
        Horizontal positions (east, north), m, of cleaned points.

    Returns
    -------
    int or None
        Index into `xy` of the point before the reversal, or None.
    """
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    ahead = np.searchsorted(s, s + REVERSAL_CHORD_M)
    later = np.searchsorted(s, s + REVERSAL_WINDOW_M)
    ok = np.flatnonzero(later < len(s))
    ok = ok[ahead[later[ok]] < len(s)]
    chord = xy[np.minimum(ahead, len(s) - 1)] - xy
    c0, c1 = chord[ok], chord[later[ok]]
    with np.errstate(invalid="ignore", divide="ignore"):   # a zero chord: NaN, no reversal
        cos_turn = np.einsum("ij,ij->i", c0, c1) / (
            np.linalg.norm(c0, axis=1) * np.linalg.norm(c1, axis=1))
    bad = np.flatnonzero(cos_turn < math.cos(math.radians(REVERSAL_TURN_DEG)))
    return int(ok[bad[0]]) if len(bad) else None


def split_legs(poly: Polyline, *, earth: Ellipsoid = WGS84) -> list[npt.NDArray[np.intp]]:
    """Cut a survey at its reversals into legs of one direction each.

    The cleaned points (`clean_polyline`) are searched for reversals (`find_reversal`)
    one after the other; a leg ends at the point before a reversal and the next starts at
    the turning point: of the points within two reversal windows after it, the one
    farthest along the leg's last direction. Pieces shorter than `MIN_LEG_M` (the
    back-and-forth of a turn manoeuvre) are dropped.

    Parameters
    ----------
    poly : Polyline
    earth : Ellipsoid

    Returns
    -------
    list of ndarray of int
        For each leg, in travel order, the indices into `poly` of its points: a contiguous
        range of the original points (repeated points included), from the leg's first kept
        point to its last. One leg when the survey never reverses.
    """
    kept = clean_polyline(poly, earth=earth)
    xy = local_enu(poly.take(kept), earth)[:, :2]
    legs, start = [], 0
    while start < len(kept):
        reversal = find_reversal(xy[start:])
        stop = len(kept) - 1 if reversal is None else start + reversal
        piece = xy[start:stop + 1]
        if np.hypot(*np.diff(piece, axis=0).T).sum() >= MIN_LEG_M:
            legs.append(np.arange(kept[start], kept[stop] + 1))
        start = _turning_point(xy, stop) if reversal is not None else len(kept)
    return legs


def _turning_point(xy: Array, stop: int) -> int:
    """Index of the point after `stop` (within two reversal windows of path) that lies
    farthest along the direction of the path's last `REVERSAL_CHORD_M` up to `stop`."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    back = max(0, int(np.searchsorted(s, s[stop] - REVERSAL_CHORD_M, side="right")) - 1)
    direction = xy[stop] - xy[back]
    last = int(np.searchsorted(s, s[stop] + 2 * (REVERSAL_CHORD_M + REVERSAL_WINDOW_M)))
    candidates = np.arange(stop + 1, min(last + 1, len(xy)))
    if candidates.size == 0:
        return len(xy)
    return int(candidates[np.argmax((xy[candidates] - xy[stop]) @ direction)])
