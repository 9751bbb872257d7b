"""The GPS broadcast ionosphere (Klobuchar) and its scale to other frequencies.

The Klobuchar model (IS-GPS-200N §20.3.3.5.2.5) gives the L1 group delay; other
frequencies scale by ``(f_L1 / f)²`` (first-order ionosphere). `klobuchar_core` is the
model in elementwise NumPy ufuncs and operators, so the filters compile it too
(`gnss_obs.guess_terms`). `gnss_obs.corrections` re-exports these names.

Reference: J.A. Klobuchar, IEEE Trans. AES-23(3), 1987; IS-GPS-200N.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from gnss_obs.constants import DAY_S, FREQUENCY_HZ, WEEK_S

__all__ = ["klobuchar_delay_s", "klobuchar_core", "ionosphere_scale"]

Array = npt.NDArray[np.float64]

_SEMICIRCLE_RAD = np.pi
_NIGHT_DELAY_S = 5e-9
_MIN_PERIOD_S = 72_000.0
_PEAK_LOCAL_TIME_S = 50_400.0
_MAX_IPP_LAT_SC = 0.416
_SEC_PER_SEMICIRCLE_LON = 43_200.0
_GPS_L1_HZ = FREQUENCY_HZ["G"][1]


def klobuchar_delay_s(alpha: npt.ArrayLike, beta: npt.ArrayLike, *, lat: float, lon: float,
                      elevation: npt.ArrayLike, azimuth: npt.ArrayLike,
                      gps_time_s: npt.ArrayLike) -> Array:
    """GPS L1 ionospheric group delay of the broadcast Klobuchar model, s.

    Parameters
    ----------
    alpha, beta : array_like, shape (4,)
        Broadcast coefficients (``GPSA``/``GPSB`` of the nav header): α in s, s/sc, s/sc²,
        s/sc³; β in s, s/sc, s/sc², s/sc³ (sc = semicircle).
    lat, lon : float
        Receiver geodetic latitude and longitude, rad.
    elevation, azimuth : array_like, shape (N,)
        Satellite elevation and azimuth, rad.
    gps_time_s : float or array_like
        GPS time, s since the GPS epoch.

    Returns
    -------
    ndarray, shape (N,)
        Vertical-to-slant L1 delay, s (IS-GPS-200N §20.3.3.5.2.5, Figure 20-4).
    """
    alpha, beta = np.asarray(alpha, dtype=float), np.asarray(beta, dtype=float)
    sow = float(gps_time_s) % WEEK_S if np.ndim(gps_time_s) == 0 else \
        np.mod(np.asarray(gps_time_s, dtype=float), WEEK_S)     # % is np.mod's modulo
    return klobuchar_core(alpha.tolist(), beta.tolist(), lat / _SEMICIRCLE_RAD,
                          lon / _SEMICIRCLE_RAD, sow, np.asarray(elevation, dtype=float),
                          np.asarray(azimuth, dtype=float))


def klobuchar_core(alpha, beta, lat_sc, lon_sc, sow, elevation, azimuth, where=np.where):
    """`klobuchar_delay_s` from the receiver's latitude and longitude in semicircles and
    the GPS seconds of week `sow`, ``alpha``/``beta`` four numbers each: elementwise NumPy
    ufuncs and operators only (and `where`, ``np.where`` or ``casadi.if_else``), so it
    also takes CasADi symbols (`gnss_obs.guess_terms`)."""
    el_sc = elevation / _SEMICIRCLE_RAD
    psi = 0.0137 / (el_sc + 0.11) - 0.022
    phi_i = np.minimum(np.maximum(lat_sc + psi * np.cos(azimuth), -_MAX_IPP_LAT_SC),
                       _MAX_IPP_LAT_SC)
    lam_i = lon_sc + psi * np.sin(azimuth) / np.cos(phi_i * _SEMICIRCLE_RAD)
    phi_m = phi_i + 0.064 * np.cos((lam_i - 1.617) * _SEMICIRCLE_RAD)
    t_local = np.mod(_SEC_PER_SEMICIRCLE_LON * lam_i + sow, DAY_S)
    slant = 1.0 + 16.0 * (0.53 - el_sc) ** 3
    phi_2 = phi_m * phi_m
    phi_3 = phi_2 * phi_m
    amplitude = np.maximum(
        alpha[0] + alpha[1] * phi_m + alpha[2] * phi_2 + alpha[3] * phi_3, 0.0)
    period = np.maximum(beta[0] + beta[1] * phi_m + beta[2] * phi_2 + beta[3] * phi_3,
                        _MIN_PERIOD_S)
    x = 2.0 * np.pi * (t_local - _PEAK_LOCAL_TIME_S) / period
    x_2 = x * x
    day = _NIGHT_DELAY_S + amplitude * (1.0 - x_2 / 2.0 + x_2 * x_2 / 24.0)
    return slant * where(np.fabs(x) < 1.57, day, _NIGHT_DELAY_S)


def ionosphere_scale(frequency_hz: npt.ArrayLike) -> Array:
    """``(f_L1 / f)²``: first-order ionospheric delay at `frequency_hz` relative to GPS L1."""
    return (_GPS_L1_HZ / np.asarray(frequency_hz, dtype=float)) ** 2
