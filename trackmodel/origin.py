"""The start point of a track: geodetic coordinates in the track file's units.

`Origin` is shared by the track (`trackmodel.track`, which walks the sections from it)
and the section table parser (`trackmodel.table`, which reads it from row 1), so it
lives below both: the table does not depend on the track.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from trackmodel.errors import TrackError
from trackmodel.plausibility import check_origin_values

__all__ = ["Origin", "MAX_ORIGIN_LAT_DEG"]

#: Latitudes of the origin are limited to |φ| < 89.9° (longitude is undefined at a pole).
MAX_ORIGIN_LAT_DEG = 89.9


@dataclass(frozen=True)
class Origin:
    """Start point of a track, in the file's units.

    Parameters
    ----------
    lat_deg, lon_deg : float
        Geodetic latitude (|φ| < 89.9°) and longitude (|λ| <= 180°), degrees.
    h_m : float
        Ellipsoidal height, m (`trackmodel.plausibility.MIN_H_M` to `MAX_H_M`).

    Raises
    ------
    TrackError
        For a value that is not finite or a latitude outside ``(-89.9, 89.9)``;
        `trackmodel.plausibility.ImplausibleTrackError` (with the column) for a longitude
        or height outside the plausibility limits.
    """

    lat_deg: float
    lon_deg: float
    h_m: float = 0.0

    def __post_init__(self) -> None:
        for name in ("lat_deg", "lon_deg", "h_m"):
            if not math.isfinite(float(getattr(self, name))):
                raise TrackError(f"origin {name} must be finite, got {getattr(self, name)!r}")
        if not abs(self.lat_deg) < MAX_ORIGIN_LAT_DEG:
            raise TrackError(f"origin must satisfy -89.9 < lat_deg < 89.9, "
                             f"got {float(self.lat_deg)!r}")
        check_origin_values(self.lon_deg, self.h_m)

    @property
    def lat(self) -> float:
        """Latitude, rad."""
        return math.radians(self.lat_deg)

    @property
    def lon(self) -> float:
        """Longitude, rad."""
        return math.radians(self.lon_deg)

    @property
    def h(self) -> float:
        """Height, m."""
        return float(self.h_m)
