"""The Mercator plane of a fit: conformal, so a direction in the plane is the azimuth.

``X = c Δλ``, ``Y = c Δψ`` (ψ the isometric latitude, `trackmodel.earth`) with
``c = N(φ0) cos φ0`` at a reference point: plane metres equal ground metres there, and a
curve's plane direction is its geographic azimuth everywhere. A track of length element
``ds`` (3-D metres, elevation ϑ, height h) moves ``w ds`` plane metres with

    w = c cos ϑ / ((N(φ) + h) cos φ),

so the fitter works with plane curves ``z(s)`` whose speed is this ``w(s)``
(`trackmodel.clothoid`).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from trackmodel.earth import (
    Ellipsoid,
    isometric_latitude,
    latitude_from_isometric,
    radii,
)

__all__ = ["MercatorPlane"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class MercatorPlane:
    """Mercator plane at a reference point.

    Parameters
    ----------
    lat0, lon0 : float
        Reference latitude and longitude, rad.
    earth : Ellipsoid
    """

    lat0: float
    lon0: float
    earth: Ellipsoid

    @property
    def c(self) -> float:
        """Plane metres per radian of longitude, m."""
        return float(radii(self.lat0, earth=self.earth)[1] * math.cos(self.lat0))

    def to_plane(self, lat: Array, lon: Array) -> npt.NDArray[np.complex128]:
        """Plane points ``X + iY`` (m) of latitudes and longitudes (rad), shape (N,)."""
        dlon = np.angle(np.exp(1j * (lon - self.lon0)))
        dpsi = isometric_latitude(lat, earth=self.earth) - isometric_latitude(
            self.lat0, earth=self.earth)
        return self.c * (dlon + 1j * dpsi)

    def from_plane(self, z) -> tuple[Array, Array]:
        """Latitude and longitude (rad) of plane points z (m)."""
        psi = isometric_latitude(self.lat0, earth=self.earth) + np.imag(z) / self.c
        return latitude_from_isometric(psi, earth=self.earth), self.lon0 + np.real(z) / self.c

    def speed(self, s: Array, lat: Array, elevation: Array, height: Array
              ) -> Callable[[Array], Array]:
        """``w(s)``: plane metres per track metre, tabulated.

        Parameters
        ----------
        s : ndarray, shape (K,)
            Along-track positions of the table, m, increasing (a few metres apart or
            closer: w changes by ~1e-7 per metre, and linear interpolation is used).
        lat, elevation, height : ndarray, shape (K,)
            Latitude (rad), elevation (rad) and height (m) of the track there.

        Returns
        -------
        callable
            ``w(s)`` for an array of s (m), constant beyond the table.
        """
        _, N = radii(lat, earth=self.earth)
        w = self.c * np.cos(elevation) / ((N + height) * np.cos(lat))
        return lambda x: np.interp(x, s, w)
