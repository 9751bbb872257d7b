"""Per-epoch measurement preparation at a receiver guess: satellites, corrections, weights.

For each epoch (`gnss_obs.epoch_table.split_epochs`, re-exported here with `EpochData` and
`EpochColumns`), `prepare_epoch` turns the selected measurements (`gnss_obs.measurements`)
and broadcast ephemerides into a `PreparedEpoch` of arrays over satellites that the
measurement models (`gnss_obs.observables`) consume (`prepare_epochs`: at K receiver
guesses at once, a bank's hypotheses):

* **satellites at transmission** and the clock of the signal used
  (`gnss_obs.transmission.transmit_states`: they do not depend on the guess), turned into
  the ECEF frame of the reception instant by the Earth's rotation during the flight from
  the guess (`gnss_obs.transmission.sagnac_rotation`);
* **delays**: troposphere and ionosphere (`gnss_obs.corrections`) at the guess;
* **standard deviations** of pseudorange and range rate from elevation and C/N0
  (`measurement_sigmas`).

The model is then ``ρ = |sat_pos_e - r_e| + b - sat_clock_m + iono_m + tropo_m`` and
``ρ̇ = e·(sat_vel_e - v_e) + d - sat_clock_drift_mps``.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, fields, replace

import numpy as np
import numpy.typing as npt

from gnss_obs.constants import SPEED_OF_LIGHT_MPS
from gnss_obs.corrections import (
    ionosphere_scale,
    klobuchar_delay_s,
    look_angles,
    troposphere_delay_m,
    troposphere_delays_m,
)
from gnss_obs.epoch_table import EpochColumns, EpochData, split_epochs
from gnss_obs.measurements import MeasurementConfig
from gnss_obs.transmission import sagnac_rotation, transmit_states
from trackmodel.earth import ecef_to_geodetic

__all__ = ["EpochData", "EpochColumns", "PreparedEpoch", "split_epochs", "prepare_epoch",
           "prepare_epochs", "measurement_sigmas", "MIN_RECEIVER_RADIUS_M"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: A receiver guess closer to the Earth's centre than this (m), or higher above the
#: ellipsoid than `MAX_RECEIVER_HEIGHT_M`, is "unknown" (a cold start's early iterates): no
#: elevation, atmosphere or weighting is computed from it.
MIN_RECEIVER_RADIUS_M = 1.0e6
MAX_RECEIVER_HEIGHT_M = 1.0e5
#: Elevation floor of the 1/sin(elevation) weighting, rad.
_MIN_WEIGHT_ELEVATION_RAD = np.deg2rad(5.0)
#: `_prepared`'s rows of one guess: known, or not.
_ONE, _NONE = np.zeros(1, dtype=np.intp), np.zeros(0, dtype=np.intp)


@dataclass(frozen=True)
class PreparedEpoch:
    """Everything the pseudorange and range-rate models need, per satellite (N rows).

    Attributes
    ----------
    gps_time_s : float
        Reception time tag (receiver time), s since the GPS epoch.
    sv, system : ndarray of str, shape (N,)
    sat_pos_e : ndarray, shape (N, 3)
        Satellite position at transmission, in ECEF of the reception instant, m.
    sat_vel_e : ndarray, shape (N, 3)
        Satellite velocity relative to ECEF, same frame, m/s.
    sat_clock_m : ndarray, shape (N,)
        ``c (δt_sv + relativity - group delay)`` of the signal used, m.
    sat_clock_drift_mps : ndarray, shape (N,)
        ``c dδt_sv/dt``, m/s.
    iono_m, tropo_m : ndarray, shape (N,)
        Ionospheric and tropospheric delays at the receiver guess, m.
    elevation, azimuth : ndarray, shape (N,)
        From the receiver guess, rad (NaN at a cold start).
    pseudorange_m, range_rate_mps, cn0_dbhz : ndarray, shape (N,)
        Measurements (range rate NaN without Doppler).
    sigma_pr_m, sigma_rr_mps : ndarray, shape (N,)
        Measurement standard deviations, m and m/s.
    """

    gps_time_s: float
    sv: np.ndarray
    system: np.ndarray
    sat_pos_e: Array
    sat_vel_e: Array
    sat_clock_m: Array
    sat_clock_drift_mps: Array
    iono_m: Array
    tropo_m: Array
    elevation: Array
    azimuth: Array
    pseudorange_m: Array
    range_rate_mps: Array
    cn0_dbhz: Array
    sigma_pr_m: Array
    sigma_rr_mps: Array

    @property
    def delays_m(self) -> Array:
        """Total propagation delay ``iono_m + tropo_m``, m, shape (N,)."""
        return self.iono_m + self.tropo_m

    def __len__(self) -> int:
        return len(self.sv)

    def subset(self, index: npt.ArrayLike) -> "PreparedEpoch":
        """The satellites selected by a boolean mask or integer index."""
        return replace(self, **{f.name: getattr(self, f.name)[index] for f in fields(self)
                                if f.name != "gps_time_s"})


def measurement_sigmas(elevation: Array, cn0_dbhz: Array, config: MeasurementConfig, *,
                       frequency_hz: Array, frequency2_hz: Array) -> tuple[Array, Array]:
    """Pseudorange (m) and range-rate (m/s) standard deviations per satellite.

    Range rate, and the pseudorange with ``config.sigma_model == "product"``:
    ``σ = σ_zenith / sin(max(el, 5°)) · 10^(max(cn0_ref - C/N0, 0) / 20)``. Pseudorange
    with ``"additive"`` (RTKLIB's ``varerr`` with its SNR term, demo5):
    ``σ² = σ_pr² + σ_el² / sin²(max(el, 5°)) + σ_cn0² · 10^(max(cn0_ref - C/N0, 0)/10)``,
    the elevation term only with ``elevation_weighting`` and the C/N0 term only with a
    finite ``cn0_ref_dbhz`` (no weighting: ``σ_pr`` alone, as the simulator draws it).
    The pseudorange σ is then multiplied by the noise gain ``sqrt(f1⁴ + f2⁴) / (f1² - f2²)``
    of the ionosphere-free combination. Unknown elevation (NaN) counts as zenith and
    unknown C/N0 as no deficit.
    """
    inv_sin = np.ones(np.shape(elevation))      # (np.ones_like, without its wrapper)
    if config.elevation_weighting:
        el = np.where(np.isfinite(elevation), elevation, np.pi / 2)
        inv_sin = 1.0 / np.sin(np.maximum(el, _MIN_WEIGHT_ELEVATION_RAD))
    amplitude = np.ones(np.shape(elevation))   # C/N0 deficit as an amplitude ratio
    if np.isfinite(config.cn0_ref_dbhz):
        deficit = np.where(np.isfinite(cn0_dbhz), config.cn0_ref_dbhz - cn0_dbhz, 0.0)
        amplitude = 10.0 ** (np.maximum(deficit, 0.0) / 20.0)
    factor = inv_sin * amplitude
    if config.sigma_model == "additive":
        var = np.full_like(factor, config.sigma_pr_m ** 2)
        if config.elevation_weighting:
            var = var + (config.sigma_pr_elevation_m * inv_sin) ** 2
        if np.isfinite(config.cn0_ref_dbhz):
            var = var + (config.sigma_pr_cn0_m * amplitude) ** 2
        sigma_pr = np.sqrt(var)
    else:
        sigma_pr = config.sigma_pr_m * factor
        if config.sigma_pr_floor_m > 0.0:
            sigma_pr = np.sqrt(config.sigma_pr_floor_m ** 2 + sigma_pr ** 2)
    if config.iono_free:
        g1, g2 = frequency_hz ** 2, frequency2_hz ** 2
        sigma_pr = sigma_pr * np.sqrt(g1 * g1 + g2 * g2) / (g1 - g2)
    return sigma_pr, config.sigma_rr_mps * factor


def prepare_epoch(epoch: EpochData, config: MeasurementConfig, *, r_rx_e: npt.ArrayLike,
                  klobuchar: tuple[np.ndarray, np.ndarray] | None = None,
                  transmit=None, coarse: bool = False) -> PreparedEpoch:
    """Prepared per-satellite data of one epoch at a receiver position guess.

    Parameters
    ----------
    epoch : EpochData
        One element of `split_epochs`.
    config : MeasurementConfig
    r_rx_e : array_like, shape (3,)
        Receiver position guess, ECEF, m (near the origin = unknown: no corrections).
    klobuchar : (alpha, beta), optional
        Broadcast Klobuchar coefficients (``NavHeader.iono_gps_alpha/beta``); required for
        ``config.ionosphere == "klobuchar"``, else the ionosphere is 0.
    transmit : optional
        The result of `gnss_obs.transmission.transmit_states` for this epoch (it does not
        depend on the guess; pass it to skip recomputing in an iteration).
    coarse : bool
        Treat the guess as unknown (no elevation, corrections or weighting), as for a
        cold start's early iterates, which may be hundreds of km off.

    Returns
    -------
    PreparedEpoch
        Satellites whose clock for the used signal is known (no NaN group delay).

    Raises
    ------
    ValueError
        `r_rx_e` is not one 3-vector.
    """
    r_rx_e = np.asarray(r_rx_e, dtype=float)
    if r_rx_e.shape != (3,):
        raise ValueError(f"r_rx_e must have shape (3,), got {r_rx_e.shape}")
    return _prepared(epoch, config, r_rx_e, klobuchar, transmit, coarse, None)[0]


def prepare_epochs(epoch: EpochData, config: MeasurementConfig, *, r_rx_e: npt.ArrayLike,
                   klobuchar: tuple[np.ndarray, np.ndarray] | None = None,
                   transmit=None, coarse: bool = False,
                   elevation_mask_rad: float | None = None) -> list[PreparedEpoch]:
    """`prepare_epoch` at K receiver guesses at once (a bank's hypotheses).

    What does not depend on the guess (the satellites at transmission, their clocks, the
    measurements) is shared; the flight time, Sagnac rotation, look angles, ionosphere
    and σ of all K guesses are computed together, elementwise, and the troposphere from
    each guess's receiver terms (`gnss_obs.corrections.troposphere_delays_m`): each
    guess's numbers are those it would have alone, to the bit.

    Parameters
    ----------
    epoch, config, klobuchar, transmit, coarse
        As `prepare_epoch`.
    r_rx_e : array_like, shape (K, 3), or (3,)
        Receiver position guesses, ECEF, m (one guess, shape (3,) or (1, 3): a list of
        one, computed as `prepare_epoch` computes it).
    elevation_mask_rad : float, optional
        Keep only the satellites with a finite pseudorange at or above this elevation
        (rad; NaN elevations, at an unknown guess, are below it).

    Returns
    -------
    list of PreparedEpoch
        One per guess, in order: its satellites with a known clock (and above the mask).
    """
    r_rx_e = np.asarray(r_rx_e, dtype=float)
    if r_rx_e.ndim not in (1, 2) or r_rx_e.shape[-1] != 3:
        raise ValueError(f"r_rx_e must have shape (K, 3) or (3,), got {r_rx_e.shape}")
    # one guess of K: the same numbers through the one-guess path, at half its cost
    return _prepared(epoch, config, r_rx_e[0] if r_rx_e.shape[0] == 1 and r_rx_e.ndim == 2
                     else r_rx_e, klobuchar, transmit, coarse, elevation_mask_rad)


def _prepared(epoch: EpochData, config: MeasurementConfig, r_rx_e: Array, klobuchar,
              transmit, coarse: bool, elevation_mask_rad: float | None
              ) -> list[PreparedEpoch]:
    """`prepare_epoch` (`r_rx_e` shape (3,)) and `prepare_epochs` (shape (K, 3)): the
    guess-dependent arrays with the guesses' axis leading (none for one guess), the
    receiver terms of one guess as Python floats, of K guesses as (K, 1) columns."""
    states, clock_m = transmit if transmit is not None else transmit_states(epoch, config)
    several = r_rx_e.ndim == 2
    guesses = r_rx_e if several else r_rx_e[None, :]
    lead, meas, n = r_rx_e.shape[:-1], epoch.meas, len(epoch)
    # |r| > MIN_RECEIVER_RADIUS_M, without np.linalg.norm's generic axis handling (one
    # guess: a Python bool, its index array only where it is known)
    rows = np.flatnonzero([not coarse and math.hypot(*r) > MIN_RECEIVER_RADIUS_M
                           for r in guesses.tolist()]) if several else \
        (_ONE if not coarse and math.hypot(*r_rx_e.tolist()) > MIN_RECEIVER_RADIUS_M
         else _NONE)
    if rows.size:
        lat, lon, h = ecef_to_geodetic(guesses[rows] if several else r_rx_e)
        height_ok = np.abs(h) < MAX_RECEIVER_HEIGHT_M
        if several:
            rows, lat, lon, h = rows[height_ok], lat[height_ok], lon[height_ok], h[height_ok]
        elif not height_ok:
            rows = rows[:0]
    # np.linalg.norm(d, axis=-1)'s own reduction (sqrt of the sums of d * d: the same
    # bits), without its generic argument handling
    d = states.r_e - r_rx_e[..., None, :]                           # (..., N, 3)
    tau = np.sqrt(np.add.reduce(d * d, axis=-1)) / SPEED_OF_LIGHT_MPS
    if several:
        sat_pos_e, sat_vel_e = sagnac_rotation(np.broadcast_to(states.r_e, d.shape),
                                               np.broadcast_to(states.v_e, d.shape), tau)
    else:
        sat_pos_e, sat_vel_e = sagnac_rotation(states.r_e, states.v_e, tau)
    iono = tropo = None
    if rows.size:
        # the guesses' rows and their receiver terms: (K, 1) columns, or one guess's floats
        pick, column = (rows, lambda a: a[:, None]) if several else (Ellipsis, float)
        elevation, azimuth = look_angles(r_rx_e[pick][..., None, :], sat_pos_e[pick],
                                         geodetic=(column(lat), column(lon)))
        if config.troposphere:
            tropo = (troposphere_delays_m if several else troposphere_delay_m)(
                elevation, lat, h, gps_time_s=epoch.gps_time_s)
        if config.ionosphere == "klobuchar" and klobuchar is not None:
            iono = SPEED_OF_LIGHT_MPS * klobuchar_delay_s(
                *klobuchar, lat=column(lat), lon=column(lon), elevation=elevation,
                azimuth=azimuth, gps_time_s=epoch.gps_time_s) \
                * ionosphere_scale(meas["frequency_hz"])
        if several and rows.size < guesses.shape[0]:      # some guesses unknown
            elevation, azimuth, iono, tropo = (
                None if a is None else _fill(a, rows, lead + (n,), fill)
                for a, fill in ((elevation, np.nan), (azimuth, np.nan), (iono, 0.0),
                                (tropo, 0.0)))
    else:
        elevation = azimuth = np.full(lead + (n,), np.nan)
    iono = np.zeros(lead + (n,)) if iono is None else iono
    tropo = np.zeros(lead + (n,)) if tropo is None else tropo
    sigma_pr, sigma_rr = measurement_sigmas(elevation, meas["cn0_dbhz"], config,
                                            frequency_hz=meas["frequency_hz"],
                                            frequency2_hz=meas["frequency2_hz"])
    ok = np.isfinite(clock_m)
    if elevation_mask_rad is not None:
        ok = ok & np.isfinite(meas["pseudorange_m"]) & (elevation >= elevation_mask_rad)
    shared = {"gps_time_s": epoch.gps_time_s, "sv": meas["sv"], "system": meas["system"],
              "sat_clock_m": clock_m,
              "sat_clock_drift_mps": SPEED_OF_LIGHT_MPS * states.clock_drift_sps,
              "pseudorange_m": meas["pseudorange_m"], "range_rate_mps": meas["range_rate_mps"],
              "cn0_dbhz": meas["cn0_dbhz"]}
    own = (sat_pos_e, sat_vel_e, iono, tropo, elevation, azimuth, sigma_pr, sigma_rr)
    if not several:
        return [_guess_epoch(shared, own, ok)]
    ok = np.broadcast_to(ok, lead + (n,))
    return [_guess_epoch(shared, tuple(a[k] for a in own), ok[k])
            for k in range(guesses.shape[0])]


def _guess_epoch(shared: dict, own: tuple, ok: npt.NDArray[np.bool_]) -> PreparedEpoch:
    """One guess's `PreparedEpoch`: the `shared` fields and its own arrays (in the order
    of `_prepared`'s ``own``), its satellites `ok` (the arrays' rows `ok` taken before
    the epoch is made: what `PreparedEpoch.subset` of the whole gives, made once)."""
    pos, vel, iono, tropo, elevation, azimuth, sigma_pr, sigma_rr = own
    if np.count_nonzero(ok) != ok.size:
        shared = {k: v if k == "gps_time_s" else v[ok] for k, v in shared.items()}
        pos, vel, iono, tropo, elevation, azimuth, sigma_pr, sigma_rr = (a[ok] for a in own)
    return PreparedEpoch(**shared, sat_pos_e=pos, sat_vel_e=vel, iono_m=iono, tropo_m=tropo,
                         elevation=elevation, azimuth=azimuth, sigma_pr_m=sigma_pr,
                         sigma_rr_mps=sigma_rr)


def _fill(values: Array, rows: Array, shape: tuple, fill: float) -> Array:
    """`values` of the guesses `rows` in an array of `shape` filled with `fill`."""
    out = np.full(shape, fill)
    out[rows] = values
    return out
