"""Fitting a track (section table) to a surveyed polyline.

Steps (`fit_track`):

1. Clean the polyline (`trackmodel.polyline.clean_polyline`: duplicates, stops, spikes),
   keeping the given order: the track runs from the first point to the last.
2. Map the points to a Mercator plane at the first point (conformal, so a direction in
   the plane *is* the geographic azimuth: a plane clothoid spline in ``s`` maps one to one
   onto sections, `trackmodel.clothoid`), with the map scale, the elevation and the
   height folded into ``w(s)``, plane metres per track metre.
3. Fit the vertical profile (if heights are given, `trackmodel.profile`) and the horizontal
   clothoid spline (`trackmodel.fit_plane`), adding knots where a point is outside the
   tolerance and then removing the knots that are not needed (`trackmodel.knots`).
4. Cut sections at the union of the horizontal and vertical knots. Every section after the
   first continues the previous one's end azimuth and elevation: the tangent is
   continuous by construction.
5. Build the `Track` on the Earth model and **verify**: project every input point
   (cleaned-away ones included) on the exact track; the horizontal deviation is reported.
   If it exceeds the tolerance, the plane fit is repeated with a tighter internal
   tolerance (the plane model and the track agree to millimetres, so this is rare).
"""
from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from trackmodel.earth import (WGS84, Ellipsoid, isometric_latitude, latitude_from_isometric,
                              radii)
from trackmodel.errors import TrackError
from trackmodel.fit_plane import PlaneFit, fit_plane
from trackmodel.fit_plane import initial_knots as initial_plane_knots
from trackmodel.knots import initial_knots, prune_knots, refine_knots
from trackmodel.polyline import (Polyline, clean_polyline, find_reversal, local_enu,
                                 split_legs)
from trackmodel.profile import Profile, fit_profile, flat_profile
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

log = logging.getLogger(__name__)

__all__ = ["TrackFit", "fit_track", "DEFAULT_TOL_M", "DEFAULT_VTOL_M"]

Array = npt.NDArray[np.float64]

DEFAULT_TOL_M = 0.5
DEFAULT_VTOL_M = 1.0
#: The plane fit aims inside this fraction of the tolerance (margin for the exact track).
INNER_TOL_FRACTION = 0.95
INITIAL_KNOT_SPACING_M = 200.0
MAX_VERIFY_ROUNDS = 3
#: Vertical knots are at least this far apart, m (survey heights are noisier than
#: positions; vertical curves of railways and tramways are tens of metres and longer).
MIN_VERTICAL_KNOT_GAP_M = 20.0
#: Joints closer than this are merged when horizontal and vertical knots are combined, m.
JOINT_MERGE_M = 1e-6


@dataclass(frozen=True)
class TrackFit:
    """A fitted track and its deviations from the survey.

    Attributes
    ----------
    track : Track
    residuals : pandas.DataFrame
        One row per input point: ``s_m, cross_track_m, vertical_m, horizontal_m`` (the
        horizontal distance to the track, m), ``kept`` (False for points removed as
        duplicates or spikes before the fit).
    max_horizontal_m : float
        Largest horizontal deviation over the kept points, m.
    """

    track: Track
    residuals: pd.DataFrame
    max_horizontal_m: float

    @property
    def n_sections(self) -> int:
        """Number of sections."""
        return len(self.track.sections)


@dataclass(frozen=True)
class _Plane:
    """Mercator plane at a reference point: X = c Δλ, Y = c Δψ, c = N0 cos φ0 (metres)."""

    lat0: float
    lon0: float
    earth: Ellipsoid

    @property
    def c(self) -> float:
        return float(radii(self.lat0, earth=self.earth)[1] * math.cos(self.lat0))

    def to_plane(self, lat: Array, lon: Array) -> npt.NDArray[np.complex128]:
        dlon = np.angle(np.exp(1j * (lon - self.lon0)))
        dpsi = isometric_latitude(lat, earth=self.earth) - isometric_latitude(
            self.lat0, earth=self.earth)
        return self.c * (dlon + 1j * dpsi)

    def from_plane(self, z) -> tuple[Array, Array]:
        psi = isometric_latitude(self.lat0, earth=self.earth) + np.imag(z) / self.c
        return latitude_from_isometric(psi, earth=self.earth), self.lon0 + np.real(z) / self.c

    def w_of_s(self, lat_of_s, profile: Profile) -> Callable[[Array], Array]:
        """Plane metres per track metre: ``c cosϑ / ((N + h) cosφ)``."""
        def w(s: Array) -> Array:
            lat = lat_of_s(s)
            _, N = radii(lat, earth=self.earth)
            return (self.c * np.cos(profile.elevation_at(s))
                    / ((N + profile.height_at(s)) * np.cos(lat)))
        return w


def _horizontal(plane: _Plane, P, s, profile, lat_of_s, tol, start_knots, progress,
                start: PlaneFit | None = None) -> PlaneFit:
    w_of_s = plane.w_of_s(lat_of_s, profile)
    state: dict[str, PlaneFit] = {} if start is None else {"fit": start}

    def fit(knots: Array):
        last = state.get("fit")
        if last is not None:
            L = last.spline.knots[-1]
            knots = np.unique(np.append(knots[knots < L - 1e-3], L))
        result = fit_plane(P, last.s if last else s, knots, w_of_s,
                           start=last.spline if last else None)
        state["fit"] = result
        return (result, result.s, result.residual_m, result.spline.curvature,
                result.spline.knots)

    knots, result = refine_knots(fit, start_knots, tol, progress)
    knots, result = prune_knots(fit, knots, result, tol)
    return result[0]


def _vertical(s: Array, h: Array, tol: float, length: float) -> Profile:
    state: dict[str, Profile] = {}

    def fit(knots: Array):
        profile, r, values = fit_profile(s, h, knots, start=state.get("p"))
        state["p"] = profile
        return profile, s, r, values, knots

    knots, result = refine_knots(fit, initial_knots(length, INITIAL_KNOT_SPACING_M), tol,
                                 min_gap_m=MIN_VERTICAL_KNOT_GAP_M)
    knots, result = prune_knots(fit, knots, result, tol)
    return result[0]


def _sections(spline, profile: Profile) -> tuple[Section, ...]:
    """Sections cut at the union of the knots; tangent continuous by construction."""
    L = spline.knots[-1]
    cuts = np.unique(np.concatenate([spline.knots, profile.knots[profile.knots < L], [L]]))
    cuts = cuts[np.concatenate([[True], np.diff(cuts) > JOINT_MERGE_M])]
    cuts[-1] = L
    kappa = spline.curvature_at(cuts)
    elev = np.degrees(profile.elevation_at(cuts))
    sections = []
    for i in range(len(cuts) - 1):
        first = i == 0
        sections.append(Section(
            length_m=float(cuts[i + 1] - cuts[i]),
            azimuth_deg=math.degrees(spline.azimuth0 % (2 * math.pi)) if first else None,
            elevation_deg=float(elev[0]) if first else None,
            curvature_1pm=float(kappa[i]),
            curvature_end_1pm=None if kappa[i + 1] == kappa[i] else float(kappa[i + 1]),
            elevation_end_deg=None if elev[i + 1] == elev[i] else float(elev[i + 1])))
    return tuple(sections)


def _verify(track: Track, poly: Polyline, kept: npt.NDArray[np.intp]) -> pd.DataFrame:
    proj = track.project(poly.lat, poly.lon, poly.h)
    mask = np.zeros(len(poly), dtype=bool)
    mask[kept] = True
    return pd.DataFrame({"s_m": proj.s, "cross_track_m": proj.cross_track_m,
                         "vertical_m": proj.vertical_m,
                         "horizontal_m": np.hypot(proj.cross_track_m, proj.along_m),
                         "kept": mask})


def fit_track(lat: npt.ArrayLike, lon: npt.ArrayLike, h: npt.ArrayLike | None = None, *,
              tol_m: float = DEFAULT_TOL_M, vtol_m: float = DEFAULT_VTOL_M,
              earth: Ellipsoid = WGS84,
              progress: Callable[[int, int], None] | None = None) -> TrackFit:
    """Fit a tangent-continuous track of straights, arcs and clothoids to a survey.

    Parameters
    ----------
    lat, lon : array_like, shape (N,)
        Surveyed geodetic latitude and longitude, rad, in the direction of the track.
    h : array_like, shape (N,), optional
        Ellipsoidal heights, m. Without them the track has h = 0 and elevation 0.
    tol_m : float
        Largest horizontal deviation of a surveyed point from the track, m.
    vtol_m : float
        Largest height deviation the vertical profile aims for, m.
    earth : Ellipsoid
    progress : callable(done, total), optional
        Called as knot-refinement rounds complete.

    Returns
    -------
    TrackFit

    Raises
    ------
    TrackError
        Fewer than 2 distinct points, a bad tolerance, or no fit within tolerance.
    """
    if not (tol_m > 0 and vtol_m > 0):
        raise TrackError(f"tolerances must be > 0 m, got tol_m={tol_m!r}, vtol_m={vtol_m!r}")
    poly = Polyline(np.asarray(lat, float), np.asarray(lon, float),
                    None if h is None else np.asarray(h, float))
    if len(poly) < 2:
        raise TrackError("a polyline needs at least 2 points")
    kept = clean_polyline(poly, earth=earth)
    if len(kept) < 2:
        raise TrackError("all points are within a metre of the first one: nothing to fit")
    pts = poly.take(kept)
    xy = local_enu(pts, earth)[:, :2]
    reversal = find_reversal(xy)
    if reversal is not None:
        i = int(kept[reversal])
        legs = split_legs(poly, earth=earth)
        spans = ", ".join(f"{k + 1}: points {leg[0]}-{leg[-1]}" for k, leg in enumerate(legs))
        raise TrackError(
            f"the survey reverses its direction after point {i} (0-based; lat "
            f"{math.degrees(poly.lat[i]):.7f}°, lon {math.degrees(poly.lon[i]):.7f}°): a track "
            f"has one direction; fit each leg separately (legs {spans}; "
            "trackmodel.polyline.split_legs, railnav track fit --leg N)")
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    plane = _Plane(float(pts.lat[0]), float(pts.lon[0]), earth)
    P = plane.to_plane(pts.lat, pts.lon)
    lat_of_s = lambda x: np.interp(x, s, pts.lat)   # noqa: E731  (first pass)
    profile = flat_profile(s[-1]) if pts.h is None else _vertical(s, pts.h, vtol_m, s[-1])
    knots = initial_plane_knots(P, s)
    tol_inner = INNER_TOL_FRACTION * tol_m
    for round_ in range(MAX_VERIFY_ROUNDS):
        fit = _horizontal(plane, P, s, profile, lat_of_s, tol_inner, knots, progress)
        if pts.h is not None:
            profile = _vertical(fit.s, pts.h, vtol_m, fit.spline.knots[-1])
            fit = _horizontal(plane, P, fit.s, profile, lat_of_s, tol_inner,
                              fit.spline.knots, progress, start=fit)
        lat0, lon0 = plane.from_plane(fit.spline.z0)
        track = Track(_sections(fit.spline, profile),
                      Origin(math.degrees(lat0), math.degrees(lon0), profile.h0), earth)
        residuals = _verify(track, poly, kept)
        worst = float(residuals.loc[residuals.kept, "horizontal_m"].max())
        log.info("fit round %d: %d sections, max horizontal deviation %.3f m", round_,
                 len(track.sections), worst)
        if worst <= tol_m:
            return TrackFit(track, residuals, worst)
        tol_inner *= 0.8
        knots = fit.spline.knots
    raise TrackError(f"could not fit within {tol_m} m (best {worst:.3f} m); "
                     "check the survey for gross errors")
