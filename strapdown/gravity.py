"""Normal gravity (gravitation plus the centrifugal acceleration of the rotating Earth).

The mechanizations and the truth simulator use this one model, ``g_n`` in ENU, which
already contains the centrifugal term (so the 2017 paper's sign error in it, SEEDS.md
erratum 4, cannot arise):

* **WGS-84** (the `trackmodel.earth.WGS84` ellipsoid): Somigliana's closed formula on
  the ellipsoid, ``γ₀ = γ_e (1 + k sin²φ) / sqrt(1 − e² sin²φ)``, with the second-order
  height correction of NIMA TR8350.2 eq. 4-3,
  ``γ(h) = γ₀ [1 − 2/a (1 + f + m − 2 f sin²φ) h + 3 h²/a²]``, directed along the
  ellipsoid normal: ``g_n = [0, 0, −γ(h)]``. Neglected: the north component of normal
  gravity above the ellipsoid (plumb-line curvature, ≈ 8e-6 m/s² per km of height) and
  the h³ term.
* **sphere** (``earth.is_sphere``, the paper's model): point-mass gravitation
  ``GM/r²`` toward the centre plus the centrifugal acceleration ``Ω² r cos φ`` away from
  the axis, ``r = R + h``::

      g_n = [0,  −Ω² r cos φ sin φ,  −GM/r² + Ω² r cos² φ]

Any other ellipsoid raises `StrapdownError` (its normal-gravity constants are not here).
Functions accept NumPy arrays or CasADi symbols (`strapdown.backend`).

References
----------
NIMA TR8350.2, 3rd ed., 2000, §4.2 (eqs. 4-1, 4-3) and Table 3.4 (γ_e, k, m).
"""
from __future__ import annotations

from typing import Any

from strapdown.backend import ops_for
from strapdown.errors import StrapdownError
from trackmodel.earth import WGS84, Ellipsoid

__all__ = ["g_n", "GAMMA_E_WGS84", "SOMIGLIANA_K_WGS84", "M_WGS84"]

#: Normal gravity at the equator, m/s² (TR8350.2 Table 3.4).
GAMMA_E_WGS84 = 9.7803253359
#: Somigliana's constant k = b γ_p / (a γ_e) − 1, dimensionless (TR8350.2 Table 3.4).
SOMIGLIANA_K_WGS84 = 0.00193185265241
#: m = ω² a² b / GM, dimensionless (TR8350.2 Table 3.4).
M_WGS84 = 0.00344978650684


def g_n(lat: Any, h: Any, *, earth: Ellipsoid = WGS84) -> Any:
    """Normal gravity vector (gravitation + centrifugal) in ENU.

    Parameters
    ----------
    lat : array_like or casadi scalar
        Geodetic latitude, rad.
    h : array_like or casadi scalar
        Ellipsoidal height, m (valid for |h| up to a few km; second-order in h/a).
    earth : Ellipsoid
        `WGS84` or a sphere (see the module docstring).

    Returns
    -------
    ndarray, shape (..., 3), or casadi 3x1
        ``g_n``, m/s².

    Raises
    ------
    StrapdownError
        For an ellipsoid that is neither WGS-84 nor a sphere.
    """
    ops = ops_for(lat, h)
    sl, cl = ops.sin(lat), ops.cos(lat)
    if earth.is_sphere:
        r = earth.a_m + h
        w2r = earth.omega_radps ** 2 * r
        return ops.vec3(0.0 * lat, -w2r * cl * sl, -earth.gm_m3ps2 / (r * r) + w2r * cl * cl)
    if earth != WGS84:
        raise StrapdownError(f"no normal-gravity constants for the ellipsoid {earth.name!r}; "
                             "use WGS84 or a sphere")
    s2 = sl * sl
    gamma0 = GAMMA_E_WGS84 * (1.0 + SOMIGLIANA_K_WGS84 * s2) / ops.sqrt(1.0 - earth.e2 * s2)
    a, f = earth.a_m, earth.f
    gamma = gamma0 * (1.0 - 2.0 / a * (1.0 + f + M_WGS84 - 2.0 * f * s2) * h
                      + 3.0 * h * h / (a * a))
    return ops.vec3(0.0 * lat, 0.0 * lat, -gamma)
