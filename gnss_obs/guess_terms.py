"""The part of an epoch's preparation that depends on the receiver guess, per satellite.

`gnss_obs.epoch.prepare_epochs` splits its work at a receiver guess in three:

* `receiver_terms`: what depends on the guess only (its position, the sines and cosines
  of its latitude and longitude, the troposphere's zenith delays and Niell terms, the
  Klobuchar model's receiver numbers): `RECEIVER_TERMS` Python floats a guess;
* `satellite_columns`: what depends on the satellites only (their states at transmission,
  the ionosphere's frequency scale, the C/N0 amplitude, the numerator and denominator of
  the ionosphere-free noise gain of the σ): `SATELLITE_COLUMNS` columns, computed once
  for a whole file's epochs by a filter (`railnav.filters.gnss_epochs`);
* `satellite_terms`: the rest, per satellite at one guess (flight time, Sagnac rotation,
  look angles, slant troposphere and ionosphere, σ): the `OUTPUTS`. It is written with
  elementwise NumPy ufuncs and operators only, from the owners of each formula
  (`gnss_obs.transmission`, `gnss_obs.corrections`, `gnss_obs.ionosphere`, `sigmas_of`),
  so the same code runs on NumPy arrays (`evaluate_numpy`: K guesses' columns against N
  satellites) and on CasADi symbols, from which a filter compiles one C function a
  satellite (`railnav.filters.guess_kernel`).
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import numpy.typing as npt

from gnss_obs.constants import SPEED_OF_LIGHT_MPS, WEEK_S
from gnss_obs.corrections import enu_look_angles, slant_troposphere_m, troposphere_terms
from gnss_obs.ionosphere import ionosphere_scale, klobuchar_core
from gnss_obs.measurements import MeasurementConfig
from gnss_obs.transmission import sagnac_cos_sin, sagnac_turn

__all__ = ["RECEIVER_TERMS", "SATELLITE_COLUMNS", "OUTPUTS", "receiver_terms",
           "unknown_receiver_terms", "satellite_columns", "satellite_columns_batch",
           "satellite_terms", "evaluate_numpy",
           "sigmas_of", "cn0_amplitude", "iono_free_gain", "uses_klobuchar"]

Array = npt.NDArray[np.float64]

#: Receiver terms: x, y, z (m), sin/cos of latitude and longitude, latitude and longitude
#: in semicircles, GPS seconds of week, 9 troposphere terms, Klobuchar α (4) and β (4).
RECEIVER_TERMS = 27
#: Satellite columns: position and velocity at transmission (ECEF of transmission),
#: ionosphere scale (f_L1/f)², C/N0 amplitude, ionosphere-free noise gain's numerator and
#: denominator.
SATELLITE_COLUMNS = 10
#: `satellite_terms`: position (3 numbers) and velocity (3) in ECEF of reception,
#: ionosphere and troposphere delays (m), elevation and azimuth (rad), σ of pseudorange
#: and range rate.
OUTPUTS = ("sat_pos_e", "sat_vel_e", "iono_m", "tropo_m", "elevation", "azimuth",
           "sigma_pr_m", "sigma_rr_mps")
#: Elevation floor of the 1/sin(elevation) weighting, rad.
MIN_WEIGHT_ELEVATION_RAD = np.deg2rad(5.0)
_TROPOSPHERE_TERMS = 9


def uses_klobuchar(config: MeasurementConfig, klobuchar) -> bool:
    """Whether the ionosphere is the broadcast Klobuchar model (with its coefficients)."""
    return config.ionosphere == "klobuchar" and klobuchar is not None


def receiver_terms(r_rx_e: list, lat: float, lon: float, h: float, gps_time_s: float,
                   config: MeasurementConfig, klobuchar) -> list:
    """The `RECEIVER_TERMS` floats of a known guess (ECEF `r_rx_e`, geodetic `lat`, `lon`
    (rad), `h` (m)) at `gps_time_s`: the troposphere's and Klobuchar's zero when the
    configuration does not use them."""
    tropo = troposphere_terms(lat, h, gps_time_s) if config.troposphere \
        else (0.0,) * _TROPOSPHERE_TERMS
    iono = [lat / math.pi, lon / math.pi, float(gps_time_s) % WEEK_S,
            *np.asarray(klobuchar[0], dtype=float).tolist(),
            *np.asarray(klobuchar[1], dtype=float).tolist()] \
        if uses_klobuchar(config, klobuchar) else [0.0] * 11
    return [*r_rx_e, math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon),
            *iono[:3], *tropo, *iono[3:]]


def unknown_receiver_terms(r_rx_e: list) -> list:
    """The terms of a guess too far off for look angles and atmosphere (only its position
    counts: `gnss_obs.epoch` replaces what depends on the rest)."""
    return [*r_rx_e, 0.0, 1.0, 0.0, 1.0] + [0.0] * (RECEIVER_TERMS - 7)


def cn0_amplitude(cn0_dbhz: Array, config: MeasurementConfig) -> Array:
    """``10^(max(cn0_ref - C/N0, 0) / 20)`` (1 for unknown C/N0 or without a reference)."""
    if not np.isfinite(config.cn0_ref_dbhz):
        return np.ones(np.shape(cn0_dbhz))
    deficit = np.where(np.isfinite(cn0_dbhz), config.cn0_ref_dbhz - cn0_dbhz, 0.0)
    return 10.0 ** (np.maximum(deficit, 0.0) / 20.0)


def iono_free_gain(frequency_hz: Array, frequency2_hz: Array,
                   config: MeasurementConfig) -> tuple[Array, Array]:
    """Noise gain ``sqrt(f1⁴ + f2⁴) / (f1² - f2²)`` of the ionosphere-free combination as
    its numerator and denominator (1 and 1 for single-frequency pseudoranges)."""
    if not config.iono_free:
        return np.ones(np.shape(frequency_hz)), np.ones(np.shape(frequency_hz))
    g1, g2 = frequency_hz ** 2, frequency2_hz ** 2
    return np.sqrt(g1 * g1 + g2 * g2), g1 - g2


def sigmas_of(inv_sin, amplitude, gain: tuple, config: MeasurementConfig) -> tuple:
    """Pseudorange and range-rate σ (`gnss_obs.epoch.measurement_sigmas`) from
    ``1/sin(max(el, 5°))`` (1 without elevation weighting), the C/N0 `amplitude` and the
    noise `gain` (`iono_free_gain`'s numerator and denominator): operators and ``np.sqrt``
    only (also CasADi symbols)."""
    factor = inv_sin * amplitude
    if config.sigma_model == "additive":
        var = config.sigma_pr_m ** 2 + 0.0 * factor
        if config.elevation_weighting:
            var = var + (config.sigma_pr_elevation_m * inv_sin) ** 2
        if np.isfinite(config.cn0_ref_dbhz):
            var = var + (config.sigma_pr_cn0_m * amplitude) ** 2
        sigma_pr = np.sqrt(var)
    else:
        sigma_pr = config.sigma_pr_m * factor
        if config.sigma_pr_floor_m > 0.0:
            sigma_pr = np.sqrt(config.sigma_pr_floor_m ** 2 + sigma_pr ** 2)
    return sigma_pr * gain[0] / gain[1], config.sigma_rr_mps * factor


def satellite_columns(states, meas: dict, config: MeasurementConfig) -> Array:
    """The `SATELLITE_COLUMNS` of the satellites of `states` (`transmit_states`) with
    measurements `meas` (one epoch's or many's: rows in the same order), shape (N, 10)."""
    return np.column_stack([states.r_e, states.v_e, ionosphere_scale(meas["frequency_hz"]),
                            cn0_amplitude(meas["cn0_dbhz"], config),
                            *iono_free_gain(meas["frequency_hz"], meas["frequency2_hz"],
                                            config)])


def satellite_columns_batch(epochs: list, transmit: list, config: MeasurementConfig
                            ) -> list[Array]:
    """`satellite_columns` of many epochs (`transmit`: each one's `transmit_states`) in
    one vectorized pass: one C-contiguous (N, 10) array an epoch."""
    if not epochs:
        return []
    names = ("frequency_hz", "frequency2_hz", "cn0_dbhz")
    meas = {k: np.concatenate([e.meas[k] for e in epochs]) for k in names}
    states = SimpleNamespace(r_e=np.concatenate([t[0].r_e for t in transmit]),
                             v_e=np.concatenate([t[0].v_e for t in transmit]))
    bounds = np.cumsum([len(e) for e in epochs])[:-1]
    return np.split(satellite_columns(states, meas, config), bounds)


def satellite_terms(rx, sat, config: MeasurementConfig, with_klobuchar: bool,
                    where=np.where) -> list:
    """The `OUTPUTS` of satellites `sat` (the `SATELLITE_COLUMNS`) at a receiver `rx` (the
    `RECEIVER_TERMS`): numbers, arrays that broadcast, or CasADi symbols (`where`:
    ``np.where`` or ``casadi.if_else``); the position and velocity as 3-tuples."""
    x, y, z, sl, cl, so, co, lat_sc, lon_sc, sow = rx[:10]
    tropo_terms, alpha, beta = rx[10:19], rx[19:23], rx[23:27]
    sx, sy, sz, vx, vy, vz, scale, amplitude = sat[:8]
    dx, dy, dz = sx - x, sy - y, sz - z
    tau = np.sqrt(dx * dx + dy * dy + dz * dz) / SPEED_OF_LIGHT_MPS
    c, s = sagnac_cos_sin(tau)
    px, py = sagnac_turn(c, s, sx, sy)
    qx, qy = sagnac_turn(c, s, vx, vy)
    elevation, azimuth = enu_look_angles(sl, cl, so, co, px - x, py - y, dz)
    zero = 0.0 * elevation
    tropo = slant_troposphere_m(elevation, tropo_terms) if config.troposphere else zero
    iono = SPEED_OF_LIGHT_MPS * klobuchar_core(alpha, beta, lat_sc, lon_sc, sow, elevation,
                                               azimuth, where) * scale \
        if with_klobuchar else zero
    inv_sin = 1.0 / np.sin(np.maximum(elevation, MIN_WEIGHT_ELEVATION_RAD)) \
        if config.elevation_weighting else 1.0 + zero
    sigma_pr, sigma_rr = sigmas_of(inv_sin, amplitude, sat[8:10], config)
    return [(px, py, sz), (qx, qy, vz), iono, tropo, elevation, azimuth, sigma_pr, sigma_rr]


def evaluate_numpy(rx: Array, sat: Array, config: MeasurementConfig,
                   with_klobuchar: bool) -> list[Array]:
    """`satellite_terms` of K receivers `rx` (K, `RECEIVER_TERMS`) and N satellites `sat`
    (N, `SATELLITE_COLUMNS`) in NumPy: the `OUTPUTS`, each (K, N), the position and
    velocity (K, N, 3)."""
    columns = tuple(rx.T[:, :, None])
    out = satellite_terms(columns, tuple(sat.T), config, with_klobuchar)
    shape = (rx.shape[0], sat.shape[0])
    return [np.stack(np.broadcast_arrays(*a, np.zeros(shape))[:3], axis=-1)
            for a in out[:2]] + [np.broadcast_to(a, shape) for a in out[2:]]
