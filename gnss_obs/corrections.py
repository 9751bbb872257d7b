"""Propagation corrections: look angles, troposphere (Saastamoinen + Niell); the ionosphere
(Klobuchar) is `gnss_obs.ionosphere`, re-exported here.

All delays are positive path lengths in metres added to the geometric range. The
functions are plain NumPy, vectorized over satellites; the SPP/navigator measurement prep
(`gnss_obs.epoch`) and the simulator (`gnss_obs.simulate`) call these same functions, so a
simulated delay is removed exactly by the filter's correction (by design: the simulator
tests the estimator, not the atmosphere models).

* Troposphere: zenith hydrostatic delay of Saastamoinen (Davis et al. 1985 form) and zenith
  wet delay of Saastamoinen, from a standard atmosphere at the receiver height (pressure,
  temperature, relative humidity `STANDARD_HUMIDITY`), mapped with the Niell (1996)
  hydrostatic and wet mapping functions (with the seasonal term and the height correction).
* Ionosphere: the GPS broadcast Klobuchar model (IS-GPS-200N §20.3.3.5.2.5) gives the L1
  group delay; other frequencies scale by ``(f_L1 / f)²`` (first-order ionosphere).

References
----------
J. Saastamoinen, "Atmospheric correction for the troposphere and stratosphere in radio
ranging of satellites", Geophys. Monogr. 15, 1972; J.L. Davis et al., Radio Science 20(6),
1985; A.E. Niell, "Global mapping functions for the atmosphere delay at radio wavelengths",
JGR 101(B2), 1996; J.A. Klobuchar, IEEE Trans. AES-23(3), 1987; IS-GPS-200N.
"""
from __future__ import annotations

import bisect
import math

import numpy as np
import numpy.typing as npt

from gnss_obs.constants import DAY_S
from gnss_obs.ionosphere import ionosphere_scale, klobuchar_core, klobuchar_delay_s
from trackmodel.earth import WGS84, Ellipsoid, ecef_to_geodetic

__all__ = ["look_angles", "standard_atmosphere", "zenith_delays_m", "niell_mapping",
           "troposphere_delay_m", "klobuchar_delay_s",
           "enu_look_angles", "klobuchar_core", "troposphere_terms", "slant_troposphere_m",
           "ionosphere_scale", "day_of_year", "STANDARD_HUMIDITY", "IONOSPHERE_MODELS"]

Array = npt.NDArray[np.float64]

#: How a measurement model handles the ionosphere (`gnss_obs.measurements.MeasurementConfig`):
#: the Klobuchar delay of this module, the ionosphere-free combination of two signals, or
#: nothing. Here, in a module without pandas, so the ``railnav spp`` parser can offer them.
IONOSPHERE_MODELS = ("klobuchar", "iono-free", "none")

# --- standard atmosphere (as in RTKLIB's tropmodel; Berg 1948 lapse formulas) -----------
#: Sea-level pressure hPa, temperature K, and relative humidity (0-1) of the standard atmosphere.
SEA_LEVEL_PRESSURE_HPA = 1013.25
SEA_LEVEL_TEMPERATURE_K = 288.15
STANDARD_HUMIDITY = 0.5
_PRESSURE_HEIGHT_PER_M = 2.2557e-5
_PRESSURE_EXPONENT = 5.2568
_LAPSE_RATE_K_PER_M = 6.5e-3
# Saastamoinen constants: ZHD = 0.0022768 P / (1 - 0.00266 cos 2φ - 0.00028 h_km) (m, hPa).
_ZHD_M_PER_HPA = 0.0022768
_ZHD_LAT = 0.00266
_ZHD_HEIGHT_PER_M = 0.28e-6
# ZWD = 0.002277 (1255/T + 0.05) e  (m, K, hPa).
_ZWD_M_PER_HPA = 0.002277
_ZWD_T = 1255.0
_ZWD_OFFSET = 0.05

# --- Niell (1996) mapping-function coefficients at |lat| = 15, 30, 45, 60, 75 deg ----------
_NIELL_LAT_RAD = np.deg2rad([15.0, 30.0, 45.0, 60.0, 75.0])
_NIELL_HYD_AVG = np.array([
    [1.2769934e-3, 1.2683230e-3, 1.2465397e-3, 1.2196049e-3, 1.2045996e-3],
    [2.9153695e-3, 2.9152299e-3, 2.9288445e-3, 2.9022565e-3, 2.9024912e-3],
    [62.610505e-3, 62.837393e-3, 63.721774e-3, 63.824265e-3, 64.258455e-3]])
_NIELL_HYD_AMP = np.array([
    [0.0, 1.2709626e-5, 2.6523662e-5, 3.4000452e-5, 4.1202191e-5],
    [0.0, 2.1414979e-5, 3.0160779e-5, 7.2562722e-5, 11.723375e-5],
    [0.0, 9.0128400e-5, 4.3497037e-5, 84.795348e-5, 170.37206e-5]])
_NIELL_WET = np.array([
    [5.8021897e-4, 5.6794847e-4, 5.8118019e-4, 5.9727542e-4, 6.1641693e-4],
    [1.4275268e-3, 1.5138625e-3, 1.4572752e-3, 1.5007428e-3, 1.7599082e-3],
    [4.3472961e-2, 4.6729510e-2, 4.3908931e-2, 4.4626982e-2, 5.4736038e-2]])
_NIELL_HEIGHT = (2.53e-5, 5.49e-3, 1.14e-3)
#: The tables in Python floats, for one receiver's latitude (`_interp_lat`).
_NIELL_LAT_LIST = _NIELL_LAT_RAD.tolist()
#: The three tables' rows together (hydrostatic average, amplitude, wet): one
#: interpolation of a receiver's latitude for all nine.
_NIELL_ALL = np.vstack([_NIELL_HYD_AVG, _NIELL_HYD_AMP, _NIELL_WET])
_NIELL_ROWS = {id(_NIELL_ALL): _NIELL_ALL.tolist()}
#: Day of year of the hydrostatic minimum (northern hemisphere); +half a year in the south.
_NIELL_DOY_MIN = 28.0
_YEAR_DAYS = 365.25
#: Elevation floor of the mapping functions, rad (they diverge at the horizon).
_MIN_ELEVATION_RAD = np.deg2rad(1.0)
#: GPS epoch 1980-01-06 is day 6 of its year; day-of-year phase of GPS time.
_GPS_EPOCH_DOY = 6.0


def look_angles(r_rx_e: npt.ArrayLike, r_sat_e: npt.ArrayLike, *,
                earth: Ellipsoid = WGS84, geodetic: tuple | None = None
                ) -> tuple[Array, Array]:
    """Elevation and azimuth of satellites seen from a receiver.

    Parameters
    ----------
    r_rx_e : array_like, shape (3,) or (N, 3)
        Receiver position, ECEF, m.
    r_sat_e : array_like, shape (N, 3)
        Satellite positions, ECEF, m.
    earth : Ellipsoid
    geodetic : (lat, lon), optional
        The receiver's geodetic latitude and longitude, rad, when the caller has them
        (``ecef_to_geodetic(r_rx_e, earth=earth)[:2]``; not computed again).

    Returns
    -------
    elevation, azimuth : ndarray, shape (N,)
        Elevation above the ellipsoid's tangent plane, rad; azimuth clockwise from north
        in [0, 2π), rad.
    """
    r_rx_e = np.asarray(r_rx_e, dtype=float)
    r_sat_e = np.asarray(r_sat_e, dtype=float)
    lat, lon = ecef_to_geodetic(r_rx_e, earth=earth)[:2] if geodetic is None else geodetic
    los_e = r_sat_e - r_rx_e
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    return enu_look_angles(sl, cl, so, co, los_e[..., 0], los_e[..., 1], los_e[..., 2])


def enu_look_angles(sin_lat, cos_lat, sin_lon, cos_lon, dx, dy, dz):
    """Elevation and azimuth (rad, azimuth in [0, 2π)) of the lines of sight ``(dx, dy,
    dz)`` (ECEF, m) from a receiver of those latitude and longitude sines and cosines:
    the line turned into east, north, up (`trackmodel.earth.C_n_e`'s columns), each
    component summed in the order x, y, z. Elementwise NumPy ufuncs and operators only,
    so it also takes CasADi symbols (`gnss_obs.guess_terms`)."""
    east = -sin_lon * dx + cos_lon * dy
    north = (-sin_lat * cos_lon) * dx + (-sin_lat * sin_lon) * dy + cos_lat * dz
    up = (cos_lat * cos_lon) * dx + (cos_lat * sin_lon) * dy + sin_lat * dz
    elevation = np.arctan2(up, np.hypot(east, north))
    return elevation, np.mod(np.arctan2(east, north), 2.0 * np.pi)


def standard_atmosphere(h: npt.ArrayLike, *, humidity: float = STANDARD_HUMIDITY
                        ) -> tuple[Array, Array, Array]:
    """Pressure (hPa), temperature (K) and water-vapour pressure (hPa) at height `h` (m).

    Heights below 0 m are taken as 0 m (as RTKLIB does). A scalar `h` (one receiver)
    gives Python floats (`_receiver_scalar`).
    """
    h = _floor_zero(h)
    exp = math.exp if isinstance(h, float) else np.exp
    pressure = SEA_LEVEL_PRESSURE_HPA * (1.0 - _PRESSURE_HEIGHT_PER_M * h) ** _PRESSURE_EXPONENT
    temperature = SEA_LEVEL_TEMPERATURE_K - _LAPSE_RATE_K_PER_M * h
    t_c = temperature - 273.15
    # Magnus formula for the saturation vapour pressure over water, hPa.
    vapour = humidity * 6.108 * exp(17.15 * t_c / (t_c + 234.7))
    return pressure, temperature, vapour


def _receiver_scalar(value) -> bool:
    """Whether `value` is one finite number (a receiver's latitude or height): the
    receiver terms are then computed in Python floats, whose arithmetic and `math`
    functions (exp, cos, pow) give NumPy's bits at a fraction of the cost of 0-d arrays
    (`tests/gnss_obs/test_corrections.py` checks the scalar path against the batch)."""
    if isinstance(value, float):          # a Python or NumPy float (np.float64 is one)
        return math.isfinite(value)
    return np.ndim(value) == 0 and math.isfinite(value)


def _floor_zero(h):
    """``max(h, 0)``: a float for one finite height, else an array."""
    if _receiver_scalar(h):
        return max(float(h), 0.0)
    return np.maximum(np.asarray(h, dtype=float), 0.0)


def zenith_delays_m(lat: npt.ArrayLike, h: npt.ArrayLike, *,
                    humidity: float = STANDARD_HUMIDITY) -> tuple[Array, Array]:
    """Saastamoinen zenith hydrostatic and wet delays of the standard atmosphere, m.

    Parameters
    ----------
    lat : array_like
        Geodetic latitude, rad.
    h : array_like
        Ellipsoidal height, m (used as the height above sea level).
    humidity : float
        Relative humidity, 0-1.
    """
    pressure, temperature, vapour = standard_atmosphere(h, humidity=humidity)
    h = _floor_zero(h)
    scalar = isinstance(h, float) and _receiver_scalar(lat)
    cos_2lat = math.cos(2.0 * float(lat)) if scalar else np.cos(2.0 * np.asarray(lat))
    zhd = _ZHD_M_PER_HPA * pressure / (1.0 - _ZHD_LAT * cos_2lat - _ZHD_HEIGHT_PER_M * h)
    zwd = _ZWD_M_PER_HPA * (_ZWD_T / temperature + _ZWD_OFFSET) * vapour
    return zhd, zwd


def _continued_fraction(sin_el: Array, a, b, c) -> Array:
    return (1.0 + a / (1.0 + b / (1.0 + c))) / (sin_el + a / (sin_el + b / (sin_el + c)))


def _interp_lat(table: Array, abs_lat: Array) -> list:
    """`np.interp` of each row of `table` over `_NIELL_LAT_RAD` at `abs_lat`; for one
    latitude (a receiver's), the rows in Python floats with `np.interp`'s own arithmetic,
    ``slope · (x − x_j) + y_j`` (the same bits, without NumPy calls)."""
    if _receiver_scalar(abs_lat):
        x, xp, rows = float(abs_lat), _NIELL_LAT_LIST, _NIELL_ROWS[id(table)]
        if x <= xp[0]:
            return [row[0] for row in rows]
        if x >= xp[-1]:
            return [row[-1] for row in rows]
        j = bisect.bisect_right(xp, x) - 1
        if xp[j] == x:
            return [row[j] for row in rows]
        dx = xp[j + 1] - xp[j]
        return [(row[j + 1] - row[j]) / dx * (x - xp[j]) + row[j] for row in rows]
    return [np.interp(abs_lat, _NIELL_LAT_RAD, row) for row in table]


def niell_mapping(elevation: npt.ArrayLike, lat: npt.ArrayLike, h: npt.ArrayLike, *,
                  day_of_year: npt.ArrayLike) -> tuple[Array, Array]:
    """Niell (1996) hydrostatic and wet mapping functions (dimensionless, 1 at zenith).

    Parameters
    ----------
    elevation : array_like
        Satellite elevation, rad (floored at 1°).
    lat : array_like
        Receiver geodetic latitude, rad.
    h : array_like
        Receiver height, m.
    day_of_year : array_like
        Day of year (1.0 = 1 January 00:00), fractional.
    """
    sin_el = np.sin(np.maximum(np.asarray(elevation, dtype=float), _MIN_ELEVATION_RAD))
    return _niell_map(sin_el, _niell_terms(lat, h, day_of_year))


def _niell_terms(lat, h, day_of_year) -> tuple:
    """The receiver's terms of `niell_mapping`: hydrostatic ``a, b, c``, the height
    correction's ``h`` in km, wet ``a, b, c`` (Python floats for one receiver)."""
    if _receiver_scalar(lat) and _receiver_scalar(day_of_year) and _receiver_scalar(h):
        lat, h = float(lat), float(h)       # one receiver: its terms in floats
        abs_lat = abs(lat)
        doy = float(day_of_year) + (0.5 * _YEAR_DAYS if lat < 0 else 0.0)
        season = math.cos(2.0 * math.pi * (doy - _NIELL_DOY_MIN) / _YEAR_DAYS)
    else:
        lat = np.asarray(lat, dtype=float)
        abs_lat = np.abs(lat)
        doy = np.asarray(day_of_year, dtype=float) + np.where(lat < 0, 0.5 * _YEAR_DAYS, 0.0)
        season = np.cos(2.0 * np.pi * (doy - _NIELL_DOY_MIN) / _YEAR_DAYS)
    rows = _interp_lat(_NIELL_ALL, abs_lat)
    avg, amp, wet = rows[0:3], rows[3:6], rows[6:9]
    a, b, c = (m - s * season for m, s in zip(avg, amp))
    h_km = (h if isinstance(h, float) else np.asarray(h, dtype=float)) * 1e-3
    return (a, b, c, h_km, *wet)


def _niell_map(sin_el: Array, terms: tuple) -> tuple[Array, Array]:
    """`niell_mapping` from the sines of the elevations and the receiver's terms
    (`_niell_terms`; columns of K receivers' terms broadcast against (K, N) sines)."""
    a, b, c, h_km, aw, bw, cw = terms
    hydro = _continued_fraction(sin_el, a, b, c)
    ah, bh, ch = _NIELL_HEIGHT
    hydro = hydro + (1.0 / sin_el - _continued_fraction(sin_el, ah, bh, ch)) * h_km
    return hydro, _continued_fraction(sin_el, aw, bw, cw)


def day_of_year(gps_time_s: npt.ArrayLike) -> Array:
    """Approximate fractional day of year of GPS time (±1 day: enough for seasonal terms)."""
    if _receiver_scalar(gps_time_s):     # Python's % is np.mod's floored modulo (same bits)
        return (float(gps_time_s) / DAY_S + _GPS_EPOCH_DOY) % _YEAR_DAYS + 1.0
    days = np.asarray(gps_time_s, dtype=float) / DAY_S + _GPS_EPOCH_DOY
    return np.mod(days, _YEAR_DAYS) + 1.0


def troposphere_delay_m(elevation: npt.ArrayLike, lat: npt.ArrayLike, h: npt.ArrayLike, *,
                        gps_time_s: npt.ArrayLike,
                        humidity: float = STANDARD_HUMIDITY) -> Array:
    """Slant tropospheric delay, m: Saastamoinen zenith delays mapped by Niell.

    Parameters
    ----------
    elevation : array_like, shape (N,)
        Satellite elevations, rad.
    lat : float or array_like
        Receiver geodetic latitude, rad.
    h : float or array_like
        Receiver ellipsoidal height, m.
    gps_time_s : float or array_like
        GPS time, s (for the seasonal term of the mapping function).
    humidity : float
        Relative humidity of the standard atmosphere, 0-1.

    Returns
    -------
    ndarray, shape (N,)
        Slant delay, m.
    """
    zhd, zwd = zenith_delays_m(lat, h, humidity=humidity)
    m_h, m_w = niell_mapping(elevation, lat, h, day_of_year=day_of_year(gps_time_s))
    return zhd * m_h + zwd * m_w


def troposphere_terms(lat: float, h: float, gps_time_s: float, *,
                      humidity: float = STANDARD_HUMIDITY) -> tuple:
    """One receiver's terms of `troposphere_delay_m`, Python floats: the zenith
    hydrostatic and wet delays (m), then the Niell terms (`_niell_terms`)."""
    return (*zenith_delays_m(lat, h, humidity=humidity),
            *_niell_terms(lat, h, day_of_year(gps_time_s)))


def slant_troposphere_m(elevation, terms: tuple):
    """The satellites' part of `troposphere_delay_m` from a receiver's `troposphere_terms`
    (numbers, or columns of K receivers' broadcast against (K, N) elevations): elementwise
    NumPy ufuncs and operators only, so it also takes CasADi symbols
    (`gnss_obs.guess_terms`)."""
    sin_el = np.sin(np.maximum(elevation, _MIN_ELEVATION_RAD))
    m_h, m_w = _niell_map(sin_el, tuple(terms[2:]))
    return terms[0] * m_h + terms[1] * m_w
