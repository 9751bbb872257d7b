"""Plausibility limits of a track: values no railway has, refused before any geometry is built.

A track file with one flipped digit can describe something no vehicle follows — a radius of
5 m over 3 km (95 full circles), a curvature of 1e6 1/m, a length of 1e30 m, a longitude of
400° or an instant 180° turn — and building it would integrate for minutes or hours, or
give a track the filter then follows into nonsense. These checks run on the section table
alone, in microseconds, before `trackmodel.track.Track` computes anything, and name the
first offending section and column:

=============================  ============================================================
limit                          why
=============================  ============================================================
|κ| ≤ `MAX_CURVATURE_1PM`      a horizontal radius of at least `MIN_RADIUS_M` (2 m): below
                               any rail or road vehicle's turning circle (tram curves reach
                               ~15 m; the street corners of the shipped car path,
                               ``data/tracks/barcelona_drive.csv``, 2.5 m)
|turn| ≤ `MAX_SECTION_TURN_DEG`  one section turns at most two full circles (720°); a spiral
                               loop of a mountain line turns 360°
L ≤ `MAX_TRACK_LENGTH_M`       10 000 km for the whole track: longer than the longest line
                               (the Trans-Siberian, 9 289 km)
|A| ≤ `MAX_ABS_AZIMUTH_DEG`    azimuths are written within ±360°
|λ0| ≤ `MAX_ABS_LON_DEG`       the origin's longitude within ±180°
`MIN_H_M` ≤ h ≤ `MAX_H_M`      ellipsoidal height everywhere on the track within
                               −1 000…10 000 m (the highest railway is at 5 072 m, the
                               deepest tunnel 240 m below sea level, and the geoid departs
                               from the ellipsoid by at most ~110 m)
kink ≤ `MAX_KINK_DEG`          where a row gives its own azimuth or elevation, it may differ
                               from the previous section's end by at most 5°: a vehicle
                               cannot follow an angle (fit a polyline with ``railnav track
                               fit`` instead of writing its vertices as straights); kinks
                               above `KINK_WARN_DEG` are logged
|φ| < 89.9° along the track    checked as the track is built (`check_latitude_reach`):
                               longitude is undefined at a pole
=============================  ============================================================

The height along the track is known before any integration, because ``dh/ds = sin ϑ``
depends on the elevation profile alone (`section_heights`).
"""
from __future__ import annotations

import logging
import math
from collections.abc import Sequence

from trackmodel.errors import TrackError

__all__ = ["ImplausibleTrackError", "MIN_RADIUS_M", "MAX_CURVATURE_1PM",
           "MAX_SECTION_TURN_DEG", "MAX_TRACK_LENGTH_M", "MAX_ABS_AZIMUTH_DEG",
           "MAX_ABS_LON_DEG", "MIN_H_M", "MAX_H_M", "MAX_KINK_DEG", "KINK_WARN_DEG",
           "MAX_TRACK_LAT_DEG", "check_section_values", "check_origin_values", "check_table",
           "section_heights", "check_latitude_reach"]

log = logging.getLogger(__name__)

MIN_RADIUS_M = 2.0
MAX_CURVATURE_1PM = 1.0 / MIN_RADIUS_M
MAX_SECTION_TURN_DEG = 720.0
MAX_TRACK_LENGTH_M = 1.0e7
MAX_ABS_AZIMUTH_DEG = 360.0
MAX_ABS_LON_DEG = 180.0
MIN_H_M = -1_000.0
MAX_H_M = 10_000.0
MAX_KINK_DEG = 5.0
KINK_WARN_DEG = 0.1
#: Latitudes along the track stay inside ±89.9° (as the origin's, `trackmodel.origin`).
MAX_TRACK_LAT_DEG = 89.9


class ImplausibleTrackError(TrackError):
    """A track parameter outside the plausibility limits (module docstring).

    Attributes
    ----------
    section : int or None
        0-based index of the section (None: the origin or the whole track).
    column : str or None
        The track file's column of the value.
    """

    def __init__(self, message: str, *, section: int | None = None,
                 column: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.section = section
        self.column = column


def check_section_values(sec, *, index: int | None = None) -> None:
    """Limits on one row's own values: curvature, azimuth, length, turn.

    Parameters
    ----------
    sec : trackmodel.sections.Section
    index : int, optional
        The section's index, for the error.

    Raises
    ------
    ImplausibleTrackError
    """
    for column, value in (("curvature_1pm", sec.curvature_1pm),
                          ("curvature_end_1pm", sec.curvature_end_1pm)):
        if value is not None and abs(value) > MAX_CURVATURE_1PM:
            raise ImplausibleTrackError(
                f"{float(value)!r} 1/m is a radius of {1.0 / abs(value):.3g} m, below the minimum "
                f"{MIN_RADIUS_M:g} m (|curvature| <= {MAX_CURVATURE_1PM:g} 1/m)",
                section=index, column=column)
    if sec.azimuth_deg is not None and abs(sec.azimuth_deg) > MAX_ABS_AZIMUTH_DEG:
        raise ImplausibleTrackError(
            f"must satisfy -360 <= azimuth_deg <= 360, got {float(sec.azimuth_deg)!r}",
            section=index, column="azimuth_deg")
    if sec.length_m > MAX_TRACK_LENGTH_M:
        raise ImplausibleTrackError(
            f"{float(sec.length_m)!r} m is longer than any railway (at most "
            f"{MAX_TRACK_LENGTH_M:g} m)", section=index, column="length_m")
    turn_deg = math.degrees(sec.turn_rad)
    if abs(turn_deg) > MAX_SECTION_TURN_DEG:
        column = "curvature_1pm" if sec.curvature_end_1pm is None else "curvature_end_1pm"
        raise ImplausibleTrackError(
            f"the section turns {turn_deg:.4g}° over {sec.length_m:g} m, more than "
            f"{MAX_SECTION_TURN_DEG:g}° (two full circles): check the curvature and the length",
            section=index, column=column)


def check_origin_values(lon_deg: float, h_m: float) -> None:
    """Limits on the origin's longitude and height (its latitude: `trackmodel.origin`).

    Raises
    ------
    ImplausibleTrackError
        With ``section=0`` and the column.
    """
    if not abs(lon_deg) <= MAX_ABS_LON_DEG:
        raise ImplausibleTrackError(f"origin must satisfy -180 <= lon_deg <= 180, got "
                                    f"{float(lon_deg)!r}", section=0, column="lon_deg")
    if not MIN_H_M <= h_m <= MAX_H_M:
        raise ImplausibleTrackError(f"origin must satisfy {MIN_H_M:g} <= h_m <= {MAX_H_M:g} "
                                    f"(ellipsoidal height, m), got {float(h_m)!r}",
                                    section=0, column="h_m")


def section_heights(h0_m: float, elevation0: float, elevation1: float,
                    length_m: float) -> tuple[float, float, float]:
    """End height and the height range of a section with linearly varying elevation.

    ``dh/ds = sin ϑ(s)`` with ``ϑ`` linear from `elevation0` to `elevation1` (rad), so
    ``h(t) − h0 = t sin(ϑ0 + d/2) · sin(d/2)/(d/2)`` with ``d = (ϑ1 − ϑ0) t / L`` (exact,
    and stable as ``d → 0``); the extremes are at the ends and where ``ϑ = 0``.

    Returns
    -------
    h_end, h_min, h_max : float
        Metres.
    """
    def height(t: float) -> float:
        half = 0.5 * (elevation1 - elevation0) * t / length_m
        sinc = 1.0 if half == 0.0 else math.sin(half) / half
        return h0_m + t * math.sin(elevation0 + half) * sinc

    h_end = height(length_m)
    candidates = [h0_m, h_end]
    if elevation0 * elevation1 < 0.0:      # the grade changes sign: a summit or a sag
        candidates.append(height(length_m * elevation0 / (elevation0 - elevation1)))
    return h_end, min(candidates), max(candidates)


def _kink_deg(given: float, continued: float) -> float:
    """|given − continued| wrapped to [0, 180], degrees."""
    return abs((given - continued + 180.0) % 360.0 - 180.0)


def check_table(sections: Sequence, *, lon_deg: float, h_m: float, warn: bool = True) -> None:
    """Every limit that needs only the table: values, total length, kinks, heights.

    Parameters
    ----------
    sections : sequence of trackmodel.sections.Section
    lon_deg, h_m : float
        The origin's longitude (degrees) and height (m).
    warn : bool
        Log the kinks below `MAX_KINK_DEG` (once per track: `Track` does).

    Raises
    ------
    ImplausibleTrackError
        Located at the first offending section and column.
    """
    check_origin_values(lon_deg, h_m)
    total_m, azimuth, elevation, h = 0.0, None, None, h_m
    kinks = []
    for k, sec in enumerate(sections):
        check_section_values(sec, index=k)
        total_m += sec.length_m
        if total_m > MAX_TRACK_LENGTH_M:
            raise ImplausibleTrackError(f"the track is {total_m:.6g} m long up to here, longer "
                                        f"than any railway (at most {MAX_TRACK_LENGTH_M:g} m)",
                                        section=k, column="length_m")
        for column, given, continued in (("azimuth_deg", sec.azimuth_deg, azimuth),
                                         ("elevation_deg", sec.elevation_deg, elevation)):
            if given is None or continued is None:
                continue
            kink = _kink_deg(given, continued)
            if kink > MAX_KINK_DEG:
                raise ImplausibleTrackError(
                    f"{float(given)!r} turns the track by {kink:.4g}° at the joint (the previous "
                    f"section ends at {continued:.6g}°): at most {MAX_KINK_DEG:g}°; leave it "
                    "empty to continue, or use a curve", section=k, column=column)
            if kink > KINK_WARN_DEG:
                kinks.append((kink, k, column))
        azimuth = (sec.azimuth_deg if sec.azimuth_deg is not None else azimuth)
        elevation = (sec.elevation_deg if sec.elevation_deg is not None else elevation)
        if azimuth is None or elevation is None:
            return                  # the table's own check reports the missing first values
        end_elevation = elevation if sec.elevation_end_deg is None else sec.elevation_end_deg
        h, h_low, h_high = section_heights(h, math.radians(elevation),
                                           math.radians(end_elevation), sec.length_m)
        if h_low < MIN_H_M or h_high > MAX_H_M:
            raise ImplausibleTrackError(
                f"the track's height reaches {h_low if h_low < MIN_H_M else h_high:.6g} m in "
                f"this section, outside {MIN_H_M:g}..{MAX_H_M:g} m: check the elevation and "
                "the length", section=k, column="elevation_deg")
        azimuth += math.degrees(sec.turn_rad)
        elevation = end_elevation
    if kinks and warn:
        worst = max(kinks)
        log.warning("%d joint(s) change the track's direction abruptly (largest %.3g° at "
                    "section %d, %s): the track has no curve there", len(kinks), worst[0],
                    worst[1] + 1, worst[2])


def check_latitude_reach(lat0: float, length_m: float, *, min_radius_m: float,
                         index: int) -> None:
    """Refuse a section that might come closer to a pole than `MAX_TRACK_LAT_DEG`.

    ``|dφ/ds| ≤ 1/(M + h)``, so a section of length L starting at ``φ0`` stays within
    ``|φ0| + L/min_radius_m`` (rad); `min_radius_m` is the smallest meridian radius plus
    `MIN_H_M`. Conservative: a long east-west section near 89° is refused too.

    Raises
    ------
    ImplausibleTrackError
    """
    reach = abs(lat0) + length_m / min_radius_m
    if not reach < math.radians(MAX_TRACK_LAT_DEG):
        raise ImplausibleTrackError(
            f"the section starts at latitude {math.degrees(lat0):.6g}° and is "
            f"{length_m:g} m long: it may come closer to a pole than {MAX_TRACK_LAT_DEG}°",
            section=index, column="length_m")
