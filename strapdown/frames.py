"""Earth rate, transport rate and radii of curvature in the local-level ENU frame.

Owns the rotation rates of the navigation frame ``n`` (East-North-Up, ARCHITECTURE.md
"Physics")::

    ω_ie_n = [0, Ω cos φ, Ω sin φ]
    ω_en_n = [−v_N/(R_M + h),  v_E/(R_N + h),  v_E tan φ/(R_N + h)]

with ``Ω`` the Earth's rotation rate and ``R_M, R_N`` the meridian and prime-vertical
radii of the `trackmodel.earth.Ellipsoid`. Functions accept NumPy arrays (leading axes
broadcast, vectors ``(..., 3)``) or CasADi symbols (`strapdown.backend`).
"""
from __future__ import annotations

from typing import Any

from strapdown.backend import NumpyOps, ops_for
from trackmodel.earth import WGS84, Ellipsoid, radii

__all__ = ["radii_of_curvature", "omega_ie_n", "omega_en_n"]


def radii_of_curvature(lat: Any, *, earth: Ellipsoid = WGS84) -> tuple[Any, Any]:
    """Meridian and prime-vertical radii ``R_M, R_N`` (m) at geodetic latitude `lat` (rad).

    NumPy input is delegated to `trackmodel.earth.radii` (the owner); the CasADi branch
    writes the same closed form symbolically and is tested against it.
    """
    ops = ops_for(lat)
    if ops is NumpyOps:
        return radii(lat, earth=earth)
    s = ops.sin(lat)
    w2 = 1.0 - earth.e2 * s * s
    R_N = earth.a_m / ops.sqrt(w2)
    return R_N * (1.0 - earth.e2) / w2, R_N


def omega_ie_n(lat: Any, *, earth: Ellipsoid = WGS84) -> Any:
    """Earth rotation rate in ``n``, rad/s, shape (..., 3) or casadi 3x1.

    Parameters
    ----------
    lat : array_like or casadi scalar
        Geodetic latitude, rad.
    earth : Ellipsoid
        Supplies the rotation rate ``omega_radps``.
    """
    ops = ops_for(lat)
    omega = earth.omega_radps
    return ops.vec3(0.0 * lat, omega * ops.cos(lat), omega * ops.sin(lat))


def omega_en_n(v_n: Any, lat: Any, h: Any, *, earth: Ellipsoid = WGS84) -> Any:
    """Transport rate (rotation of ``n`` relative to ECEF) in ``n``, rad/s.

    Parameters
    ----------
    v_n : array_like, shape (..., 3), or casadi 3x1
        Velocity relative to the Earth in ENU, m/s.
    lat : array_like or casadi scalar
        Geodetic latitude, rad.
    h : array_like or casadi scalar
        Ellipsoidal height, m.
    earth : Ellipsoid

    Returns
    -------
    ndarray, shape (..., 3), or casadi 3x1
    """
    ops = ops_for(v_n, lat, h)
    R_M, R_N = radii_of_curvature(lat, earth=earth)
    v_E, v_N = ops.comp(v_n, 0), ops.comp(v_n, 1)
    return ops.vec3(-v_N / (R_M + h), v_E / (R_N + h), v_E * ops.tan(lat) / (R_N + h))
