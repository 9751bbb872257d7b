"""Fitting a track (section table) to a surveyed polyline.

Steps (`fit_track`):

1. Clean the polyline (`trackmodel.polyline.clean_polyline`: duplicates, stops, spikes),
   keeping the given order: the track runs from the first point to the last. A survey
   that turns round is refused (its legs are listed: `split_legs`).
2. Map the points to a Mercator plane at the first point (`trackmodel.mercator`:
   conformal, so a direction in the plane *is* the geographic azimuth and a plane curve of
   straights, arcs and clothoids maps one to one onto sections), with the map scale, the
   elevation and the height folded into ``w(s)``, plane metres per track metre.
3. Fit the vertical profile if heights are given (`trackmodel.profile`) and the
   horizontal curve (`trackmodel.horizontal`): a first segmentation of a smooth reference
   into straights, arcs and transitions, least squares with free joints, pieces added
   where a point is outside the tolerance and removed while none is.
4. Cut sections at the union of the horizontal and vertical joints. Every section after
   the first continues the previous one's end azimuth and elevation: the tangent is
   continuous by construction.
5. Build the `Track` on the Earth model and **verify**: project every input point
   (cleaned-away ones included) on the exact track; the horizontal deviation is reported.
   If it exceeds the tolerance, the fit is repeated with a tighter internal tolerance.

Curvatures are capped at ``1 / min_radius_m``: `DEFAULT_MIN_RADIUS_M` (5 m) admits the
street corners of a tram or of a car's survey; a main line may ask for more (e.g.
``min_radius_m=150``). A survey that cannot be fitted within the tolerance under that cap
(a polyline with a sharp corner) raises `TrackError` naming the point.
"""
from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from trackmodel.blas import single_blas_thread
from trackmodel.earth import WGS84, Ellipsoid
from trackmodel.errors import TrackError
from trackmodel.fit_defaults import DEFAULT_TOL_M, DEFAULT_VTOL_M
from trackmodel.fit_plane import PlaneFit
from trackmodel.horizontal import fit_horizontal
from trackmodel.mercator import MercatorPlane
from trackmodel.origin import Origin
from trackmodel.polyline import (
    Polyline,
    clean_polyline,
    find_reversal,
    local_enu,
    split_legs,
)
from trackmodel.profile import Profile, fit_vertical, flat_profile
from trackmodel.sections import Section
from trackmodel.track import Track

log = logging.getLogger(__name__)

__all__ = ["TrackFit", "fit_track", "DEFAULT_TOL_M", "DEFAULT_VTOL_M", "DEFAULT_MIN_RADIUS_M"]

Array = npt.NDArray[np.float64]

#: Smallest radius of a fitted curve, m: a car's or a tram's tightest street corner.
DEFAULT_MIN_RADIUS_M = 5.0
#: The plane fit aims inside this fraction of the tolerance (margin for the exact track),
#: and a fit that fails the verification is repeated with the tolerance times `TIGHTEN`.
INNER_TOL_FRACTION = 0.95
TIGHTEN = 0.8
MAX_VERIFY_ROUNDS = 3
#: Shortest horizontal piece, m, and shortest vertical piece (survey heights are noisier
#: than positions; vertical curves of railways and tramways are tens of metres long).
MIN_PIECE_M = 1.0
MIN_VERTICAL_PIECE_M = 20.0
#: Refits allowed to each of the simplification and the pruning.
MAX_FITS = 12
#: A vertical joint this close to a horizontal one is moved onto it, m (the height moves
#: by at most the elevation change times this: millimetres).
JOINT_MERGE_M = 0.5
#: Spacing of the table of w(s), plane metres per track metre, m (with the vertical
#: joints added): w follows cos ϑ, which changes within a vertical curve of a few metres
#: (a 10-m table put 0.1 m of along-track error into a street corner on a steep curve).
SPEED_TABLE_STEP_M = 1.0


@dataclass(frozen=True)
class TrackFit:
    """A fitted track and its deviations from the survey.

    Attributes
    ----------
    track : Track
    residuals : pandas.DataFrame
        One row per input point: ``s_m, cross_track_m, along_m, vertical_m, horizontal_m``
        (the horizontal distance to the track, m), ``kept`` (False for points removed as
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


def _speed(plane: MercatorPlane, s: Array, lat: Array, profile: Profile, length: float):
    """Tabulated ``w(s)`` from the points' latitudes (rad) at their positions s (m)."""
    grid = np.linspace(0.0, length, max(2, int(np.ceil(length / SPEED_TABLE_STEP_M)) + 1))
    grid = np.union1d(grid, profile.knots[profile.knots < length])
    return plane.speed(grid, np.interp(grid, s, lat), profile.elevation_at(grid),
                       profile.height_at(grid))


def _cuts(horizontal: Array, vertical: Array) -> Array:
    """Section joints: the horizontal ones, and the vertical ones not within
    `JOINT_MERGE_M` of a horizontal one, m."""
    L = horizontal[-1]
    inner = vertical[(vertical > JOINT_MERGE_M) & (vertical < L - JOINT_MERGE_M)]
    near = np.abs(inner[:, None] - horizontal[None, :]).min(axis=1, initial=np.inf)
    return np.unique(np.concatenate([horizontal, inner[near > JOINT_MERGE_M]]))


def _sections(fit: PlaneFit, profile: Profile) -> tuple[Section, ...]:
    """Sections cut at the joints; each takes its curvature and elevation at both ends
    from the piece it lies in (tangent continuous by construction)."""
    hp, vp = fit.curve.pieces, profile.shape.pieces
    cuts = _cuts(hp.knots, vp.knots)
    a, b = cuts[:-1], cuts[1:]
    j, k = hp.piece_of(0.5 * (a + b)), vp.piece_of(0.5 * (a + b))
    kappa0, kappa1 = hp.value(a, j), hp.value(b, j)
    elev0, elev1 = np.degrees(vp.value(a, k)), np.degrees(vp.value(b, k))
    sections = []
    for i in range(len(a)):
        first = i == 0
        sections.append(Section(
            length_m=float(b[i] - a[i]),
            azimuth_deg=math.degrees(fit.curve.azimuth0 % (2 * math.pi)) if first else None,
            elevation_deg=float(elev0[i]) if first else None,
            curvature_1pm=float(kappa0[i]),
            curvature_end_1pm=None if kappa1[i] == kappa0[i] else float(kappa1[i]),
            elevation_end_deg=None if elev1[i] == elev0[i] else float(elev1[i])))
    return tuple(sections)


def _verify(track: Track, poly: Polyline, kept: npt.NDArray[np.intp]) -> pd.DataFrame:
    proj = track.project(poly.lat, poly.lon, poly.h)
    mask = np.zeros(len(poly), dtype=bool)
    mask[kept] = True
    return pd.DataFrame({"s_m": proj.s, "cross_track_m": proj.cross_track_m,
                         "along_m": proj.along_m, "vertical_m": proj.vertical_m,
                         "horizontal_m": np.hypot(proj.cross_track_m, proj.along_m),
                         "kept": mask})


def _prepare(lat, lon, h, earth: Ellipsoid) -> tuple[Polyline, npt.NDArray[np.intp], Polyline]:
    """The polyline, the indices of the points kept by cleaning, and those points; raises
    for too few points or a survey that turns round."""
    poly = Polyline(np.asarray(lat, float), np.asarray(lon, float),
                    None if h is None else np.asarray(h, float))
    if len(poly) < 2:
        raise TrackError("a polyline needs at least 2 points")
    kept = clean_polyline(poly, earth=earth)
    if len(kept) < 2:
        raise TrackError("all points are within a metre of the first one: nothing to fit")
    pts = poly.take(kept)
    reversal = find_reversal(local_enu(pts, earth)[:, :2])
    if reversal is not None:
        i = int(kept[reversal])
        legs = split_legs(poly, earth=earth)
        spans = ", ".join(f"{k + 1}: points {leg[0]}-{leg[-1]}" for k, leg in enumerate(legs))
        raise TrackError(
            f"the survey reverses its direction after point {i} (0-based; lat "
            f"{math.degrees(poly.lat[i]):.7f}°, lon {math.degrees(poly.lon[i]):.7f}°): a track "
            f"has one direction; fit each leg separately (legs {spans}; "
            "trackmodel.polyline.split_legs, railnav track fit --leg N)")
    return poly, kept, pts


def fit_track(lat: npt.ArrayLike, lon: npt.ArrayLike, h: npt.ArrayLike | None = None, *,
              tol_m: float = DEFAULT_TOL_M, vtol_m: float = DEFAULT_VTOL_M,
              min_radius_m: float = DEFAULT_MIN_RADIUS_M, earth: Ellipsoid = WGS84,
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
    min_radius_m : float
        Smallest radius of curvature of the track, m.
    earth : Ellipsoid
    progress : callable(done, total), optional
        Called as refinement rounds complete.

    Returns
    -------
    TrackFit

    Raises
    ------
    TrackError
        Fewer than 2 distinct points, a survey that turns round, a bad tolerance or
        radius, or no fit within tolerance.
    """
    if not (tol_m > 0 and vtol_m > 0 and min_radius_m > 0):
        raise TrackError(f"tolerances and the radius must be > 0 m, got tol_m={tol_m!r}, "
                         f"vtol_m={vtol_m!r}, min_radius_m={min_radius_m!r}")
    poly, kept, pts = _prepare(lat, lon, h, earth)
    with single_blas_thread():
        return _fit(poly, kept, pts, tol_m=tol_m, vtol_m=vtol_m, kappa_max=1.0 / min_radius_m,
                    earth=earth, progress=progress)


def _fit(poly: Polyline, kept, pts: Polyline, *, tol_m: float, vtol_m: float,
         kappa_max: float, earth: Ellipsoid, progress) -> TrackFit:
    plane = MercatorPlane(float(pts.lat[0]), float(pts.lon[0]), earth)
    P = plane.to_plane(pts.lat, pts.lon)
    s = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(P)))])
    profile = (flat_profile(s[-1]) if pts.h is None else
               fit_vertical(s, pts.h, vtol_m=vtol_m, min_length_m=MIN_VERTICAL_PIECE_M,
                            max_fits=MAX_FITS).profile)
    tol_inner = INNER_TOL_FRACTION * tol_m
    fit = None
    for round_ in range(MAX_VERIFY_ROUNDS):
        w_of_s = _speed(plane, s, pts.lat, profile, s[-1])
        fit = fit_horizontal(P, s, w_of_s, tol_m=tol_inner, kappa_max=kappa_max,
                             min_length_m=MIN_PIECE_M, max_fits=MAX_FITS, warm=fit,
                             progress=progress)
        if pts.h is not None and round_ == 0:
            s = np.maximum.accumulate(fit.s)
            profile = fit_vertical(s, pts.h, vtol_m=vtol_m, min_length_m=MIN_VERTICAL_PIECE_M,
                                   max_fits=MAX_FITS).profile
            fit = fit_horizontal(P, s, _speed(plane, s, pts.lat, profile, fit.curve.length),
                                 tol_m=tol_inner, kappa_max=kappa_max,
                                 min_length_m=MIN_PIECE_M, max_fits=MAX_FITS, warm=fit)
        lat0, lon0 = plane.from_plane(fit.curve.z0)
        track = Track(_sections(fit, profile),
                      Origin(math.degrees(lat0), math.degrees(lon0), profile.h0), earth)
        residuals = _verify(track, poly, kept)
        worst = float(residuals.loc[residuals.kept, "horizontal_m"].max())
        log.info("fit round %d: %d horizontal and %d vertical pieces, %d sections, max "
                 "horizontal deviation %.3f m", round_, len(fit.shape.kinds),
                 len(profile.shape.kinds), len(track.sections), worst)
        if worst <= tol_m:
            return TrackFit(track, residuals, worst)
        tol_inner *= TIGHTEN
    i = int(residuals.loc[residuals.kept, "horizontal_m"].idxmax())
    raise TrackError(
        f"could not fit within {tol_m} m (best {worst:.3f} m, at point {i} (0-based; lat "
        f"{math.degrees(poly.lat[i]):.7f}°, lon {math.degrees(poly.lon[i]):.7f}°)) with "
        f"radii of at least {1.0 / kappa_max:g} m: check the survey there for a sharp "
        "corner or a gross error")
