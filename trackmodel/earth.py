"""The Earth model: ellipsoid, radii of curvature, geodetic <-> ECEF <-> ENU.

This module is the single owner of the Earth's shape for the whole project (see
ARCHITECTURE.md, "Conventions"); `strapdown` (gravity, Earth rate) and `gnss_obs`
import it, nothing copies it.

Conventions
-----------
* Geodetic latitude ``lat`` and longitude ``lon`` in radians, ellipsoidal height ``h`` in
  metres. Degrees exist only at file/CLI boundaries.
* ``e`` is ECEF (Earth-centred, Earth-fixed), ``n`` the local-level East-North-Up frame.
  ``C_n_e`` maps an ENU vector to ECEF: ``v_e = C_n_e @ v_n``; its columns are the east,
  north and up unit vectors written in ECEF.
* Arrays broadcast over leading axes; vectors have their 3 components last, ``(..., 3)``.
* Two models: `WGS84` (default, for real data) and `sphere(radius_m)` (the 2017 paper's
  spherical Earth, erratum 8 of SEEDS.md: fine for that scenario only). Both carry the
  WGS-84 gravitational constant and rotation rate; the GPS interface specification's
  slightly different rotation rate belongs to `gnss_obs` under its own name.

References
----------
NIMA TR8350.2, "Department of Defense World Geodetic System 1984", 3rd ed., 2000.
H. Vermeille, "Direct transformation from geocentric coordinates to geodetic
coordinates", Journal of Geodesy 76, 451-454, 2002.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "Ellipsoid", "WGS84", "SPHERE_RADIUS_M", "OMEGA_E_WGS84", "GM_WGS84", "sphere",
    "earth_from_name", "radii", "geodetic_to_ecef", "ecef_to_geodetic", "C_n_e",
    "ecef_to_enu", "enu_to_ecef", "isometric_latitude", "latitude_from_isometric",
]

Array = npt.NDArray[np.float64]

#: WGS-84 angular velocity of the Earth, rad/s (TR8350.2 Table 3.1).
OMEGA_E_WGS84 = 7.292115e-5
#: WGS-84 gravitational constant (including the atmosphere), m^3/s^2.
GM_WGS84 = 3.986004418e14
#: Mean Earth radius used for the spherical model by default, m (the 2017 paper's ``r``
#: is not given numerically; 6371 km is the IUGG mean radius R1 rounded to the km).
SPHERE_RADIUS_M = 6_371_000.0


@dataclass(frozen=True)
class Ellipsoid:
    """An Earth model: a rotating ellipsoid of revolution (a sphere when ``f == 0``).

    Parameters
    ----------
    name : str
        ``"wgs84"`` or ``"sphere"``; written to track files.
    a_m : float
        Semi-major axis (equatorial radius), m.
    f : float
        Flattening, dimensionless, ``0 <= f < 1``.
    gm_m3ps2 : float
        Gravitational constant GM, m^3/s^2.
    omega_radps : float
        Rotation rate, rad/s.
    """

    name: str
    a_m: float
    f: float
    gm_m3ps2: float = GM_WGS84
    omega_radps: float = OMEGA_E_WGS84

    def __post_init__(self) -> None:
        if not (np.isfinite(self.a_m) and self.a_m > 0):
            raise ValueError(f"a_m must be a positive finite radius in metres, got {self.a_m!r}")
        if not (0.0 <= self.f < 1.0):
            raise ValueError(f"flattening must satisfy 0 <= f < 1, got {self.f!r}")

    @property
    def b_m(self) -> float:
        """Semi-minor (polar) axis, m."""
        return self.a_m * (1.0 - self.f)

    @property
    def e2(self) -> float:
        """First eccentricity squared, dimensionless."""
        return self.f * (2.0 - self.f)

    @property
    def is_sphere(self) -> bool:
        """True when the flattening is zero."""
        return self.f == 0.0


#: The WGS-84 ellipsoid (TR8350.2): a = 6378137 m, 1/f = 298.257223563.
WGS84 = Ellipsoid("wgs84", 6_378_137.0, 1.0 / 298.257223563)


def sphere(radius_m: float = SPHERE_RADIUS_M) -> Ellipsoid:
    """A spherical Earth of the given radius (m), WGS-84 GM and rotation rate."""
    return Ellipsoid("sphere", float(radius_m), 0.0)


def earth_from_name(name: str, *, radius_m: float | None = None) -> Ellipsoid:
    """Earth model from its file/CLI name: ``"wgs84"`` or ``"sphere"`` (optional radius, m).

    Raises
    ------
    ValueError
        For any other name, or a radius given with ``wgs84``.
    """
    key = name.strip().lower()
    if key == "wgs84":
        if radius_m is not None:
            raise ValueError("radius_m applies to earth=sphere only")
        return WGS84
    if key == "sphere":
        return sphere(SPHERE_RADIUS_M if radius_m is None else radius_m)
    raise ValueError(f"earth must be 'wgs84' or 'sphere', got {name!r}")


def _vectors(a: npt.ArrayLike, name: str) -> Array:
    """`a` as float vectors with 3 components last; never guesses the layout."""
    a = np.asarray(a, dtype=float)
    if a.shape[-1:] != (3,):
        raise ValueError(f"{name} must have shape (..., 3), got {a.shape}")
    return a


def radii(lat: npt.ArrayLike, *, earth: Ellipsoid = WGS84) -> tuple[Array, Array]:
    """Meridian and prime-vertical radii of curvature.

    Parameters
    ----------
    lat : array_like
        Geodetic latitude, rad.
    earth : Ellipsoid

    Returns
    -------
    M, N : ndarray, same shape as `lat`
        Meridian radius ``a(1-e²)/(1-e² sin²φ)^{3/2}`` and prime-vertical radius
        ``a/(1-e² sin²φ)^{1/2}``, m.
    """
    lat = np.asarray(lat, dtype=float)
    if earth.f == 0.0:      # a sphere: both are a (NaN where φ is not finite), as below
        N = earth.a_m + 0.0 * lat
        return N.copy(), N
    s = np.sin(lat)
    w2 = 1.0 - earth.e2 * s * s
    N = earth.a_m / np.sqrt(w2)
    M = N * (1.0 - earth.e2) / w2
    return M, N


def geodetic_to_ecef(lat: npt.ArrayLike, lon: npt.ArrayLike, h: npt.ArrayLike, *,
                     earth: Ellipsoid = WGS84) -> Array:
    """ECEF position of geodetic coordinates.

    Parameters
    ----------
    lat, lon : array_like
        Geodetic latitude and longitude, rad (broadcast together).
    h : array_like
        Height above the ellipsoid, m.
    earth : Ellipsoid

    Returns
    -------
    r_e : ndarray, shape (..., 3)
        Position in ECEF, m.
    """
    lat, lon, h = (np.asarray(x, dtype=float) for x in (lat, lon, h))
    one = lat.ndim == 0 and lon.ndim == 0 and h.ndim == 0   # one point (every fix epoch):
    if not one:                                             # no broadcasting nor stacking
        lat, lon, h = np.broadcast_arrays(lat, lon, h)
    _, N = radii(lat, earth=earth)
    cl = np.cos(lat)
    xyz = ((N + h) * cl * np.cos(lon), (N + h) * cl * np.sin(lon),
           (N * (1.0 - earth.e2) + h) * np.sin(lat))
    return np.array(xyz) if one else np.stack(xyz, axis=-1)


def ecef_to_geodetic(r_e: npt.ArrayLike, *, earth: Ellipsoid = WGS84) -> tuple[Array, Array, Array]:
    """Geodetic coordinates of an ECEF position (Vermeille 2002, closed form).

    Exact to numerical precision for points farther than ~50 km from the Earth's centre
    (everything a navigator meets, satellites included).

    Parameters
    ----------
    r_e : array_like, shape (..., 3)
        Position in ECEF, m.
    earth : Ellipsoid

    Returns
    -------
    lat, lon, h : ndarray, shape (...)
        Geodetic latitude and longitude (rad), ellipsoidal height (m).

    Raises
    ------
    ValueError
        If the last axis does not have length 3.
    """
    r_e = _vectors(r_e, "r_e")
    x, y, z = r_e[..., 0], r_e[..., 1], r_e[..., 2]
    a, e2 = earth.a_m, earth.e2
    e4 = e2 * e2
    rho2 = x * x + y * y
    p = rho2 / (a * a)
    q = (1.0 - e2) / (a * a) * z * z
    r = (p + q - e4) / 6.0
    s = e4 * p * q / (4.0 * r ** 3)
    t = np.cbrt(1.0 + s + np.sqrt(s * (2.0 + s)))
    u = r * (1.0 + t + 1.0 / t)
    v = np.sqrt(u * u + e4 * q)
    w = e2 * (u + v - q) / (2.0 * v)
    k = np.sqrt(u + v + w * w) - w
    D = k * np.sqrt(rho2) / (k + e2)
    dz = np.hypot(D, z)
    lat = 2.0 * np.arctan2(z, D + dz)
    lon = np.arctan2(y, x)
    h = (k + e2 - 1.0) / k * dz
    return lat, lon, h


def C_n_e(lat: npt.ArrayLike, lon: npt.ArrayLike) -> Array:
    """Rotation matrix from the local ENU frame to ECEF.

    Parameters
    ----------
    lat, lon : array_like
        Geodetic latitude and longitude, rad (broadcast together).

    Returns
    -------
    C_n_e : ndarray, shape (..., 3, 3)
        ``v_e = C_n_e @ v_n``; columns are east, north, up in ECEF.
    """
    lat, lon = np.asarray(lat, dtype=float), np.asarray(lon, dtype=float)
    if lat.ndim == 0 and lon.ndim == 0:     # one point (every GNSS epoch): no stacking
        sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
        return np.array([[-so, -sl * co, cl * co], [co, -sl * so, cl * so], [0.0, cl, sl]])
    lat, lon = np.broadcast_arrays(lat, lon)
    sl, cl = np.sin(lat), np.cos(lat)
    so, co = np.sin(lon), np.cos(lon)
    out = np.empty(lat.shape + (3, 3))     # filled column by column: no stacked copies
    np.negative(so, out=out[..., 0, 0])
    out[..., 1, 0], out[..., 2, 0] = co, 0.0
    np.multiply(-sl, co, out=out[..., 0, 1])
    np.multiply(-sl, so, out=out[..., 1, 1])
    out[..., 2, 1] = cl
    np.multiply(cl, co, out=out[..., 0, 2])
    np.multiply(cl, so, out=out[..., 1, 2])
    out[..., 2, 2] = sl
    return out


def ecef_to_enu(r_e: npt.ArrayLike, *, lat0: float, lon0: float, h0: float,
                earth: Ellipsoid = WGS84) -> Array:
    """ENU coordinates of ECEF points relative to a geodetic origin.

    Parameters
    ----------
    r_e : array_like, shape (..., 3)
        Points in ECEF, m.
    lat0, lon0 : float
        Origin latitude and longitude, rad.
    h0 : float
        Origin height, m.
    earth : Ellipsoid

    Returns
    -------
    r_n : ndarray, shape (..., 3)
        East, north, up offsets from the origin, m.
    """
    d = _vectors(r_e, "r_e") - geodetic_to_ecef(lat0, lon0, h0, earth=earth)
    return np.einsum("ji,...j->...i", C_n_e(lat0, lon0), d)


def enu_to_ecef(r_n: npt.ArrayLike, *, lat0: float, lon0: float, h0: float,
                earth: Ellipsoid = WGS84) -> Array:
    """ECEF points of ENU offsets from a geodetic origin (inverse of `ecef_to_enu`).

    Parameters
    ----------
    r_n : array_like, shape (..., 3)
        East, north, up offsets, m.
    lat0, lon0 : float
        Origin latitude and longitude, rad.
    h0 : float
        Origin height, m.
    earth : Ellipsoid

    Returns
    -------
    r_e : ndarray, shape (..., 3)
        ECEF position, m.
    """
    return geodetic_to_ecef(lat0, lon0, h0, earth=earth) + np.einsum(
        "ij,...j->...i", C_n_e(lat0, lon0), _vectors(r_n, "r_n"))


def isometric_latitude(lat: npt.ArrayLike, *, earth: Ellipsoid = WGS84) -> Array:
    """Isometric latitude ``ψ(φ) = atanh(sin φ) − e·atanh(e sin φ)``, rad.

    On the sphere this is the paper's ``ln tan(π/4 + φ/2)``. ``dψ/dφ = M / (N cos φ)``.
    """
    s = np.sin(np.asarray(lat, dtype=float))
    e = np.sqrt(earth.e2)
    return np.arctanh(s) - e * np.arctanh(e * s)


def latitude_from_isometric(psi: npt.ArrayLike, *, earth: Ellipsoid = WGS84,
                            tol_rad: float = 1e-15, max_iter: int = 20) -> Array:
    """Inverse of `isometric_latitude` (fixed-point iteration; exact on the sphere).

    Parameters
    ----------
    psi : array_like
        Isometric latitude, rad.
    earth : Ellipsoid
    tol_rad : float
        Convergence tolerance on latitude, rad.
    max_iter : int
        Iteration limit (convergence is geometric with ratio ~e², 5-6 steps suffice).

    Returns
    -------
    lat : ndarray
        Geodetic latitude, rad.
    """
    psi = np.asarray(psi, dtype=float)
    lat = np.arcsin(np.tanh(psi))  # the spherical answer
    e = np.sqrt(earth.e2)
    if e == 0.0:
        return lat
    for _ in range(max_iter):
        new = np.arcsin(np.tanh(psi + e * np.arctanh(e * np.sin(lat))))
        done = np.all(np.abs(new - lat) <= tol_rad)
        lat = new
        if done:
            break
    return lat
