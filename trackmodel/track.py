"""The track: a section table on an Earth model, queried along the distance ``s``.

`Track` is immutable. Building it resolves the table (`trackmodel.sections`), walks the
sections from the origin computing each start point (closed form for straights,
`trackmodel.loxodrome`; one ODE integration for arcs, clothoids and vertical curves,
`trackmodel.integrated`), so that the position is continuous across joints. `Track.at`
then answers vectorised queries for any array of ``s`` in ``[0, length_m]``; a query of
one point (a float, or an array of one) is answered in Python floats
(`trackmodel.one_point`: the same bits, ~5x faster than NumPy on arrays of one).
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field, fields
from functools import cached_property

import numpy as np
import numpy.typing as npt
import pandas as pd

from trackmodel.earth import WGS84, Ellipsoid, geodetic_to_ecef
from trackmodel.errors import TrackError
from trackmodel.integrated import ChebyshevSections, integrate_section
from trackmodel.loxodrome import loxodrome_position
from trackmodel.one_point import point_at
from trackmodel.origin import Origin
from trackmodel.plausibility import (
    MAX_TRACK_LAT_DEG,
    MIN_H_M,
    ImplausibleTrackError,
    check_latitude_reach,
    check_table,
)
from trackmodel.sections import Section, SectionArrays, tangent_frame
from trackmodel.table import sections_from_frame

# Origin is defined in trackmodel.origin (the table parser needs it without the track).
__all__ = ["Origin", "Track", "TrackPoint", "S_TOLERANCE_M"]

Array = npt.NDArray[np.float64]

#: Queries this far outside [0, length_m] are clamped to the ends (rounding of a caller's
#: sum of section lengths); farther is an error.
S_TOLERANCE_M = 1e-6
#: Scalar queries of `Track.at` whose points a track keeps for a repeated query.
RECENT_POINTS = 32


def _s_error(length_m: float, lo: float | None = None, hi: float | None = None) -> TrackError:
    """`Track.check_s`'s error: ``s`` not finite (no `lo`), or values in [lo, hi] beyond
    the track's ends (more than `S_TOLERANCE_M`)."""
    if lo is None:
        return TrackError("s must be finite (NaN or inf given)")
    return TrackError(f"s must satisfy 0 <= s <= {length_m!r} m (the track length), "
                      f"got values in [{lo!r}, {hi!r}]")


@dataclass(frozen=True)
class TrackPoint:
    """The track at along-track distances ``s``: arrays shaped like the query.

    For a query of shape (N,) scalar fields have shape (N,) and vectors (N, 3); a scalar
    query gives shape () and (3,).

    Attributes
    ----------
    s : ndarray
        Along-track distance, m.
    lat, lon : ndarray
        Geodetic latitude and longitude, rad.
    h : ndarray
        Ellipsoidal height, m.
    r_e : ndarray, (..., 3)
        ECEF position, m.
    u_n : ndarray, (..., 3)
        Unit tangent in ENU, ``[cosϑ sinA, cosϑ cosA, sinϑ]``.
    du_ds_n : ndarray, (..., 3)
        ``d u_n / ds`` of the ENU components (zero on a straight), 1/m.
    d2u_ds2_n : ndarray, (..., 3)
        ``d² u_n / ds²``, 1/m².
    azimuth : ndarray
        Azimuth A, clockwise from north, rad in [0, 2π).
    elevation : ndarray
        Elevation ϑ, positive uphill, rad.
    curvature_1pm : ndarray
        ``dA/ds``, 1/m, positive turning clockwise.
    elevation_rate : ndarray
        ``dϑ/ds``, rad/m.
    section : ndarray of int
        Index of the section (a joint belongs to the section it starts).
    """

    s: Array
    lat: Array
    lon: Array
    h: Array
    r_e: Array
    u_n: Array
    du_ds_n: Array
    d2u_ds2_n: Array
    azimuth: Array
    elevation: Array
    curvature_1pm: Array
    elevation_rate: Array
    section: npt.NDArray[np.intp]

    def to_frame(self) -> pd.DataFrame:
        """Scalar fields as columns (radians, metres); 1-D queries only."""
        return pd.DataFrame({f.name: getattr(self, f.name) for f in fields(self)
                             if np.ndim(getattr(self, f.name)) == 1})


@dataclass(frozen=True, eq=False)
class Track:
    """A track: sections on an Earth model from an origin.

    Parameters
    ----------
    sections : sequence of Section
        The section table (stored as a tuple).
    origin : Origin
        Start point of the first section.
    earth : Ellipsoid
        `trackmodel.earth.WGS84` (default) or a `sphere`.

    Raises
    ------
    TrackError
        For an empty table or a first section without azimuth/elevation;
        `trackmodel.plausibility.ImplausibleTrackError` (with the section and column) for a
        table beyond the plausibility limits, found before anything is integrated.
    """

    sections: tuple[Section, ...]
    origin: Origin
    earth: Ellipsoid = WGS84
    table: SectionArrays = field(init=False, repr=False)
    starts: Array = field(init=False, repr=False)
    _chunks: ChebyshevSections | None = field(init=False, repr=False)
    _recent: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "sections", tuple(self.sections))
        check_table(self.sections, lon_deg=self.origin.lon_deg, h_m=self.origin.h_m)
        table = SectionArrays.resolve(self.sections)
        starts = np.empty((len(self.sections) + 1, 3))
        starts[0] = (self.origin.lat, self.origin.lon, self.origin.h)
        chunks: list = []
        lox = table.is_loxodrome
        for k in range(len(self.sections)):
            if lox[k]:
                starts[k + 1] = self._loxodrome_end(table, k, starts[k])
            else:
                check_latitude_reach(starts[k, 0], table.length[k], index=k,
                                     min_radius_m=self.earth.a_m * (1.0 - self.earth.e2) + MIN_H_M)
                new, starts[k + 1] = integrate_section(table, k, starts[k], self.earth)
                chunks.extend(new)
        object.__setattr__(self, "table", table)
        object.__setattr__(self, "starts", starts)
        object.__setattr__(self, "_chunks", ChebyshevSections.stack(chunks) if chunks else None)
        object.__setattr__(self, "_recent", {})

    def _loxodrome_end(self, table: SectionArrays, k: int, start: Array) -> list[float]:
        """End of straight section `k` (closed form); its latitude must stay off the poles
        (it changes monotonically along a loxodrome, so the end decides)."""
        with np.errstate(all="ignore"):          # a section across a pole: NaN, refused below
            end = [float(x) for x in loxodrome_position(
                start[0], start[1], start[2], azimuth=table.azimuth0[k],
                elevation=table.elevation0[k], t=table.length[k], earth=self.earth)]
        if not abs(end[0]) < math.radians(MAX_TRACK_LAT_DEG):
            raise ImplausibleTrackError(
                f"the section runs from latitude {math.degrees(start[0]):.6g}° to "
                f"{math.degrees(end[0]):.6g}°, beyond ±{MAX_TRACK_LAT_DEG}°",
                section=k, column="length_m")
        return end

    @classmethod
    def from_sections(cls, sections, *, lat: float, lon: float, h: float = 0.0,
                      earth: Ellipsoid = WGS84) -> "Track":
        """Track from sections and an origin in radians (``lat``, ``lon``) and metres (``h``)."""
        return cls(tuple(sections), Origin(math.degrees(lat), math.degrees(lon), h), earth)

    @classmethod
    def from_frame(cls, frame: pd.DataFrame, *, earth: Ellipsoid = WGS84) -> "Track":
        """Track from a table with the track file's columns (see `trackmodel.io`).

        Raises
        ------
        TrackFileError
            Located by row and column for a bad value or a missing column.
        """
        sections, origin = sections_from_frame(frame)
        return cls(sections, origin, earth)

    @cached_property
    def length_m(self) -> float:
        """Total length, m (computed once: the filters ask for it at every step)."""
        return float(self.table.s_start[-1] + self.table.length[-1])

    @property
    def end_azimuth(self) -> float:
        """Azimuth at the end of the track, rad in [0, 2π)."""
        k = len(self.sections) - 1
        return float(self.table.angles(np.array([k]), self.table.length[[k]])["A"][0])

    def check_s(self, s: npt.ArrayLike) -> Array:
        """Validated copy of ``s`` (m) clamped to ``[0, length_m]``.

        Raises
        ------
        TrackError
            For NaN/inf or a value farther than `S_TOLERANCE_M` outside the track.
        """
        s = np.array(s, dtype=float)
        if not np.all(np.isfinite(s)):
            raise _s_error(self.length_m)
        L = self.length_m
        if s.size and (s.min() < -S_TOLERANCE_M or s.max() > L + S_TOLERANCE_M):
            raise _s_error(L, float(s.min()), float(s.max()))
        return np.clip(s, 0.0, L)

    def section_of(self, s: Array) -> npt.NDArray[np.intp]:
        """Section index of each (valid) ``s``; a joint belongs to the next section
        (`trackmodel.sections.SectionArrays.section_of`)."""
        return self.table.section_of(s)

    def section_at(self, s: float) -> int:
        """`section_of` one ``s`` (m, a float), in Python floats: the same section (the
        same comparisons against the same starts; NaN, like `numpy.searchsorted`, after
        every start)."""
        k = bisect.bisect_right(self._section_starts, s) - 1
        return min(max(k, 0), len(self.sections) - 1)

    @cached_property
    def _section_starts(self) -> list[float]:
        return self.table.s_start.tolist()

    def geodetic(self, s: npt.ArrayLike) -> tuple[Array, Array, Array]:
        """Latitude (rad), longitude (rad) and height (m) at ``s`` (m), flattened to (N,)."""
        s = self.check_s(s).ravel()
        return self._geodetic(s, self.section_of(s))

    def _geodetic(self, s: Array, k: npt.NDArray[np.intp]) -> tuple[Array, Array, Array]:
        """`geodetic` of checked ``s`` (m, shape (N,)) in sections `k` (`section_of`)."""
        lat, lon, h = (np.empty_like(s) for _ in range(3))
        lox = self.table.is_loxodrome[k]
        if lox.any():
            kl = k[lox]
            lat[lox], lon[lox], h[lox] = loxodrome_position(
                self.starts[kl, 0], self.starts[kl, 1], self.starts[kl, 2],
                azimuth=self.table.azimuth0[kl], elevation=self.table.elevation0[kl],
                t=s[lox] - self.table.s_start[kl], earth=self.earth)
        if not lox.all():
            lat[~lox], lon[~lox], h[~lox] = self._chunks.position(s[~lox])
        return lat, lon, h

    def at(self, s: npt.ArrayLike) -> TrackPoint:
        """Position, tangent and curvature at along-track distances ``s``.

        Parameters
        ----------
        s : float or array_like, shape (N,)
            Along-track distance from the track start, m, in ``[0, length_m]``.

        Returns
        -------
        TrackPoint
            Fields shaped like ``s`` (vectors get a trailing axis of 3).

        Raises
        ------
        TrackError
            For NaN/inf or ``s`` outside the track.

        Notes
        -----
        The points of the last `RECENT_POINTS` scalar queries are kept (read-only arrays)
        and returned again for the same ``s``: a bank of hypotheses asks for the same
        points several times a cycle. One point is evaluated in Python floats
        (`trackmodel.one_point.point_at`), the same bits as the vectorised path gives an
        array of one; an array of several points may differ from it in the last bit on a
        straight (NumPy sums four Gauss–Legendre terms of one row by ``ddot``, of several
        rows by ``gemv``): as before, 32 of 550 points near the equator, none of the
        shipped tracks' (measured at stop 36).
        """
        if isinstance(s, float):
            point = self._recent.get(s)
            if point is None:
                point = TrackPoint(**point_at(self, self._check_one(s)))
                for value in vars(point).values():
                    value.flags.writeable = False
                if len(self._recent) >= RECENT_POINTS:
                    self._recent.pop(next(iter(self._recent)))
                self._recent[s] = point
            return point
        return self._point(s)

    def _check_one(self, s: float) -> float:
        """`check_s` of one float: the same error, the same clamp."""
        s = float(s)
        L = self.length_m
        if not math.isfinite(s):
            raise _s_error(L)
        if s < -S_TOLERANCE_M or s > L + S_TOLERANCE_M:
            raise _s_error(L, s, s)
        return min(max(s, 0.0), L)

    def _point(self, s: npt.ArrayLike) -> TrackPoint:
        shape = np.shape(s)
        if math.prod(shape) == 1:          # one point: in floats (`trackmodel.one_point`)
            one = point_at(self, self._check_one(np.asarray(s, dtype=float).reshape(())))
            vec = shape + (3,)
            return TrackPoint(**{name: value.reshape(vec if value.ndim else shape)
                                 for name, value in one.items()})
        return self._points(s)

    @cached_property
    def table_lists(self) -> list[tuple]:
        """Each section's ``(s_start, length, azimuth0, elevation0, elevation1,
        curvature0, curvature1, is_loxodrome)`` in Python values (`trackmodel.one_point`)."""
        tab = self.table
        return list(zip(tab.s_start.tolist(), tab.length.tolist(), tab.azimuth0.tolist(),
                        tab.elevation0.tolist(), tab.elevation1.tolist(),
                        tab.curvature0.tolist(), tab.curvature1.tolist(),
                        tab.is_loxodrome.tolist()))

    @cached_property
    def start_lists(self) -> list[list[float]]:
        """The section start points (`starts`) as Python floats."""
        return self.starts.tolist()

    def _points(self, s: npt.ArrayLike) -> TrackPoint:
        """`at` of any array of ``s``, vectorised."""
        shape = np.shape(s)
        flat = self.check_s(s).ravel()
        k = self.section_of(flat)
        lat, lon, h = self._geodetic(flat, k)
        ang = self.table.angles(k, flat - self.table.s_start[k])
        u, du, d2u = tangent_frame(ang["A"], ang["E"], ang["dA"], ang["dE"], ang["d2A"])
        r_e = geodetic_to_ecef(lat, lon, h, earth=self.earth)
        vec = shape + (3,)
        return TrackPoint(
            s=flat.reshape(shape), lat=lat.reshape(shape), lon=lon.reshape(shape),
            h=h.reshape(shape), r_e=r_e.reshape(vec), u_n=u.reshape(vec),
            du_ds_n=du.reshape(vec), d2u_ds2_n=d2u.reshape(vec),
            azimuth=ang["A"].reshape(shape), elevation=ang["E"].reshape(shape),
            curvature_1pm=ang["dA"].reshape(shape),
            elevation_rate=np.broadcast_to(ang["dE"], flat.shape).reshape(shape),
            section=k.reshape(shape))

    @cached_property
    def projector(self):
        """The `trackmodel.project.Projector` of this track (built on first use)."""
        from trackmodel.project import Projector
        return Projector(self)

    def project(self, lat: npt.ArrayLike, lon: npt.ArrayLike, h: npt.ArrayLike | None = None):
        """Nearest track point of geodetic points: see `trackmodel.project.Projector.project`."""
        return self.projector.project(lat, lon, h)
