"""Per-epoch measurement preparation at a receiver guess: satellites, corrections, weights.

For each epoch (`gnss_obs.epoch_table.split_epochs`, re-exported here with `EpochData` and
`EpochColumns`), `prepare_epoch` turns the selected measurements (`gnss_obs.measurements`)
and broadcast ephemerides into a `PreparedEpoch` of arrays over satellites that the
measurement models (`gnss_obs.observables`) consume (`prepare_epochs`: at K receiver
guesses at once, a bank's hypotheses):

* **satellites at transmission** and the clock of the signal used
  (`gnss_obs.transmission.transmit_states`: they do not depend on the guess), turned into
  the ECEF frame of the reception instant by the Earth's rotation during the flight from
  the guess (`gnss_obs.transmission.sagnac_turn`);
* **delays**: troposphere and ionosphere (`gnss_obs.corrections`) at the guess;
* **standard deviations** of pseudorange and range rate from elevation and C/N0
  (`measurement_sigmas`).

What depends on the guess is computed per satellite by `gnss_obs.guess_terms` (in NumPy,
or by a filter's compiled C function of the same code). The model is then
``ρ = |sat_pos_e - r_e| + b - sat_clock_m + iono_m + tropo_m`` and
``ρ̇ = e·(sat_vel_e - v_e) + d - sat_clock_drift_mps``.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, fields, replace

import numpy as np
import numpy.typing as npt

from gnss_obs.constants import SPEED_OF_LIGHT_MPS
from gnss_obs.epoch_table import EpochColumns, EpochData, split_epochs
from gnss_obs.guess_terms import (
    MIN_WEIGHT_ELEVATION_RAD,
    cn0_amplitude,
    evaluate_numpy,
    iono_free_gain,
    receiver_terms,
    satellite_columns,
    sigmas_of,
    unknown_receiver_terms,
    uses_klobuchar,
)
from gnss_obs.measurements import MeasurementConfig
from gnss_obs.transmission import transmit_states
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
        inv_sin = 1.0 / np.sin(np.maximum(el, MIN_WEIGHT_ELEVATION_RAD))
    return sigmas_of(inv_sin, cn0_amplitude(cn0_dbhz, config),
                     iono_free_gain(frequency_hz, frequency2_hz, config), config)


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
                   elevation_mask_rad: float | None = None,
                   evaluate=None) -> list[PreparedEpoch]:
    """`prepare_epoch` at K receiver guesses at once (a bank's hypotheses).

    What does not depend on the guess (the satellites at transmission, their clocks, the
    measurements, `gnss_obs.guess_terms.satellite_columns`) is shared; each guess's
    receiver terms are its own (`gnss_obs.guess_terms.receiver_terms`), and the flight
    time, Sagnac rotation, look angles, delays and σ of all K guesses are computed
    together, elementwise (`gnss_obs.guess_terms.satellite_terms`): each guess's numbers
    are those it would have alone, to the bit.

    Parameters
    ----------
    epoch, config, klobuchar, coarse
        As `prepare_epoch`.
    transmit : optional
        As `prepare_epoch`, optionally with the epoch's
        `gnss_obs.guess_terms.satellite_columns` as a third item.
    r_rx_e : array_like, shape (K, 3), or (3,)
        Receiver position guesses, ECEF, m (one guess, shape (3,) or (1, 3): a list of
        one, computed as `prepare_epoch` computes it).
    elevation_mask_rad : float, optional
        Keep only the satellites with a finite pseudorange at or above this elevation
        (rad; NaN elevations, at an unknown guess, are below it).
    evaluate : callable, optional
        ``evaluate(rx, sat, config, with_klobuchar)``: the satellite terms of K guesses
        (`gnss_obs.guess_terms.evaluate_numpy`, the default; a filter's compiled one,
        `railnav.filters.guess_kernel`).

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
                     else r_rx_e, klobuchar, transmit, coarse, elevation_mask_rad, evaluate)


def _prepared(epoch: EpochData, config: MeasurementConfig, r_rx_e: Array, klobuchar,
              transmit, coarse: bool, elevation_mask_rad: float | None, evaluate=None
              ) -> list[PreparedEpoch]:
    """`prepare_epoch` (`r_rx_e` shape (3,)) and `prepare_epochs` (shape (K, 3)): each
    guess's `gnss_obs.guess_terms.receiver_terms`, the satellites' columns (from
    `transmit`'s third item when given), then `evaluate` (default
    `gnss_obs.guess_terms.evaluate_numpy`) of all guesses; a guess too far off for look
    angles and atmosphere gets NaN angles, no delays and the σ of unknown elevation."""
    states, clock_m = transmit[:2] if transmit is not None else \
        transmit_states(epoch, config)
    meas, n = epoch.meas, len(epoch)
    sat = transmit[2] if transmit is not None and len(transmit) > 2 else \
        satellite_columns(states, meas, config)
    several = r_rx_e.ndim == 2
    guesses = (r_rx_e if several else r_rx_e[None, :]).tolist()
    places = _geodetic(guesses, coarse)
    rx = np.array([unknown_receiver_terms(r) if place is None else
                   receiver_terms(r, *place, epoch.gps_time_s, config, klobuchar)
                   for r, place in zip(guesses, places)])
    own = (evaluate or evaluate_numpy)(rx, sat, config, uses_klobuchar(config, klobuchar))
    unknown = [k for k, place in enumerate(places) if place is None]
    if unknown:
        own = _unknown_guesses(own, unknown, meas, config)
    ok = np.isfinite(clock_m)
    if elevation_mask_rad is not None:
        ok = ok & np.isfinite(meas["pseudorange_m"]) & (own[4] >= elevation_mask_rad)
    shared = {"gps_time_s": epoch.gps_time_s, "sv": meas["sv"], "system": meas["system"],
              "sat_clock_m": clock_m,
              "sat_clock_drift_mps": SPEED_OF_LIGHT_MPS * states.clock_drift_sps,
              "pseudorange_m": meas["pseudorange_m"], "range_rate_mps": meas["range_rate_mps"],
              "cn0_dbhz": meas["cn0_dbhz"]}
    return [_guess_epoch(shared, tuple(a[k] for a in own), ok[k])
            for k in range(len(guesses))]


def _geodetic(guesses: list, coarse: bool) -> list:
    """(lat, lon, h) of each guess (Python floats), None for one too far off: closer to
    the Earth's centre than `MIN_RECEIVER_RADIUS_M`, higher than `MAX_RECEIVER_HEIGHT_M`,
    or all of them with `coarse`."""
    if coarse:
        return [None] * len(guesses)
    near = [k for k, r in enumerate(guesses) if math.hypot(*r) > MIN_RECEIVER_RADIUS_M]
    places: list = [None] * len(guesses)
    if not near:
        return places
    lat, lon, h = ecef_to_geodetic(guesses[near[0]] if len(near) == 1 else
                                   np.array([guesses[k] for k in near]))
    found = [(float(lat), float(lon), float(h))] if len(near) == 1 else \
        zip(lat.tolist(), lon.tolist(), h.tolist())
    for k, (lat, lon, h) in zip(near, found):
        if abs(h) < MAX_RECEIVER_HEIGHT_M:
            places[k] = (lat, lon, h)
    return places


def _unknown_guesses(own: list, unknown: list, meas: dict, config: MeasurementConfig
                     ) -> list:
    """`own` (`_prepared`'s, in the order of `gnss_obs.guess_terms.OUTPUTS`) with the
    guesses `unknown` given NaN look angles, no delays and the σ of unknown elevation."""
    own = [np.array(a) for a in own]          # writable copies
    n = own[4].shape[-1]
    sigma_pr, sigma_rr = measurement_sigmas(np.full(n, np.nan), meas["cn0_dbhz"], config,
                                            frequency_hz=meas["frequency_hz"],
                                            frequency2_hz=meas["frequency2_hz"])
    for index, value in ((2, 0.0), (3, 0.0), (4, np.nan), (5, np.nan), (6, sigma_pr),
                         (7, sigma_rr)):
        own[index][unknown] = value
    return own


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
