"""Code-differential GNSS: pseudorange corrections from a base station of known position.

`base_corrections` computes, at every base epoch, each satellite's pseudorange correction
(the range-domain DGNSS of RTCM SC-104 message types 1/31, and RTKLIB's ``PMODE_DGPS``)::

    PRC_s = P_s(base) - ρ̂_s(base)  -  median over the system's satellites of the same

where ``ρ̂`` is the full model of `gnss_obs.epoch` at the known base position: geometric
range to the broadcast (or precise) satellite position at transmission with Sagnac,
satellite clock and group delay, troposphere and Klobuchar ionosphere. What is left is
what the broadcast models get wrong — orbit and clock errors, the ionosphere and
troposphere the models miss — plus the base's own multipath and noise. Removing the
per-system median takes out the base receiver clock (and inter-system bias), so a
correction does not jump with the base clock and can be used for a few seconds.

`apply_corrections` subtracts, from each rover measurement (`select_measurements` table),
the correction of the same satellite and signal from the latest base epoch at or before
the rover epoch (``gps_time_s`` + `TIME_MATCH_S`), no older than ``max_age_s``; rover
measurements without a correction are dropped (DGNSS positions use corrected satellites
only). The rover then solves with the same models: what the base and the rover share —
satellite orbit and clock errors, most of the atmosphere at 15 km — cancels, and the
per-system clock estimates absorb the medians.

References: RTCM 10402.3 (DGNSS corrections); RTKLIB rtkpos.c/pntpos.c (``PMODE_DGPS``);
Misra & Enge, *Global Positioning System*, 2nd ed., §7.2.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import pandas as pd

from gnss_obs.epoch import prepare_epoch, split_epochs
from gnss_obs.errors import GnssError
from gnss_obs.measurements import (
    MeasurementConfig,
    glonass_channels,
    select_measurements,
)
from gnss_obs.observables import predict_pseudorange
from gnss_obs.transmission import transmit_states_batch
from trackmodel.earth import geodetic_to_ecef

__all__ = ["DgpsConfig", "CORRECTION_COLUMNS", "base_corrections", "apply_corrections",
           "base_position_e", "TIME_MATCH_S", "Augmentation", "augment", "augment_files"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
#: Columns of a correction table.
CORRECTION_COLUMNS = ["gps_time_s", "sv", "signal", "correction_m", "elevation_deg"]
#: A base epoch up to this much after a rover epoch counts as simultaneous, s (tags of
#: receivers that do not sit exactly on the second).
TIME_MATCH_S = 0.05
_MIN_RECEIVER_RADIUS_M = 6.0e6


@dataclass(frozen=True)
class DgpsConfig:
    """Code-differential settings.

    Parameters
    ----------
    max_age_s : float
        Oldest correction applied, s (RTKLIB ``maxage`` default 30 s).
    base_elevation_mask_deg : float
        Corrections of satellites lower than this at the base are not made, deg.
    """

    max_age_s: float = 30.0
    base_elevation_mask_deg: float = 5.0

    def __post_init__(self) -> None:
        if not (self.max_age_s >= 0 and np.isfinite(self.max_age_s)):
            raise GnssError(f"max_age_s must be a finite number >= 0, got {self.max_age_s!r}")
        if not -90.0 <= self.base_elevation_mask_deg < 90.0:
            raise GnssError("base_elevation_mask_deg must be in [-90, 90)")


def base_position_e(header, given_lat_lon_h: tuple[float, float, float] | None = None) -> Array:
    """The base antenna position, ECEF (m): given (lat°, lon°, h m) or the header's.

    Raises
    ------
    GnssError
        When none is given and the header's ``APPROX POSITION XYZ`` is absent (zero).
    """
    if given_lat_lon_h is not None:
        lat_deg, lon_deg, h_m = given_lat_lon_h
        if not (-90.0 <= lat_deg <= 90.0 and -180.0 <= lon_deg <= 360.0 and np.isfinite(h_m)):
            raise GnssError(f"base position {given_lat_lon_h}: need -90 <= lat <= 90, "
                            "-180 <= lon <= 360 (degrees) and a finite height (m)")
        return np.asarray(geodetic_to_ecef(np.deg2rad(lat_deg), np.deg2rad(lon_deg), h_m),
                          dtype=float)
    r = np.asarray(header.approx_position_e, dtype=float)
    if np.linalg.norm(r) < _MIN_RECEIVER_RADIUS_M:
        raise GnssError("the base file's header has no APPROX POSITION XYZ: give the base "
                        "position (LAT,LON,H)")
    return r


def _median_by_system(system: np.ndarray, values: Array) -> Array:
    out = np.empty_like(values)
    for s in np.unique(system):
        m = system == s
        out[m] = np.median(values[m])
    return out


def base_corrections(base_obs, nav, config: MeasurementConfig, *, r_base_e: npt.ArrayLike,
                     dgps: DgpsConfig | None = None, precise=None,
                     progress: Callable[[int, int], None] | None = None) -> pd.DataFrame:
    """Per-epoch, per-satellite pseudorange corrections of a base station (module docstring).

    Parameters
    ----------
    base_obs : RinexObs
        Base observations (smoothed or not: smoothing the base too averages its noise).
    nav : RinexNav
        Broadcast navigation (and Klobuchar coefficients).
    config : MeasurementConfig
        The rover's measurement settings (same systems, signals and models).
    r_base_e : array_like, shape (3,)
        Base antenna position, ECEF, m (`base_position_e`).
    dgps : DgpsConfig, optional
    precise : gnss_obs.precise.PreciseOrbits, optional
        Precise orbits and clocks instead of the broadcast ones (use the same as the rover).
    progress : callable(done, total), optional

    Returns
    -------
    pandas.DataFrame
        `CORRECTION_COLUMNS`: base epoch, satellite, signal, correction (m), elevation at
        the base (deg).
    """
    cfg = dgps or DgpsConfig()
    r_base_e = np.asarray(r_base_e, dtype=float)
    channels = glonass_channels(base_obs.header.glonass_slots, nav.records)
    meas = select_measurements(base_obs.table, config, glonass_channels=channels)
    if len(meas) == 0:
        raise GnssError(f"base file: no measurements of systems {config.systems!r}")
    epochs = split_epochs(meas, nav.records, config)
    tx = transmit_states_batch(epochs, config, precise=precise)
    alpha, beta = nav.header.iono_gps_alpha, nav.header.iono_gps_beta
    klob = None if alpha is None or beta is None else (np.asarray(alpha), np.asarray(beta))
    parts = []
    for i, (epoch, states) in enumerate(zip(epochs, tx)):
        prep = prepare_epoch(epoch, config, r_rx_e=r_base_e, klobuchar=klob, transmit=states)
        prep = prep.subset(np.isfinite(prep.pseudorange_m) & (
            prep.elevation >= np.deg2rad(cfg.base_elevation_mask_deg)))
        if len(prep):
            rho, _, _ = predict_pseudorange(prep, r_e=r_base_e, b_m=0.0)
            residual = prep.pseudorange_m - rho
            signal = dict(zip(epoch.meas["sv"], epoch.meas["signal"]))
            parts.append(pd.DataFrame({
                "gps_time_s": epoch.gps_time_s, "sv": prep.sv,
                "signal": [signal[s] for s in prep.sv],
                "correction_m": residual - _median_by_system(prep.system, residual),
                "elevation_deg": np.rad2deg(prep.elevation)}))
        if progress is not None:
            progress(i + 1, len(epochs))
    if not parts:
        raise GnssError("base file: no epoch gives a correction")
    return pd.concat(parts, ignore_index=True)[CORRECTION_COLUMNS]


def apply_corrections(meas: pd.DataFrame, corrections: pd.DataFrame, *,
                      max_age_s: float = DgpsConfig.max_age_s) -> pd.DataFrame:
    """Rover measurements minus the latest base correction of the same satellite and signal.

    Parameters
    ----------
    meas : pandas.DataFrame
        `select_measurements` table of the rover.
    corrections : pandas.DataFrame
        `base_corrections` output.
    max_age_s : float
        Oldest usable correction, s.

    Returns
    -------
    pandas.DataFrame
        The rows of `meas` that have a correction, ``pseudorange_m`` corrected, plus a
        column ``correction_age_s``.
    """
    # the keys as plain objects on both sides: an iono-free table's combined signal names
    # come out of pandas' string operations with its string dtype, which merge_asof will
    # not match against object columns
    keys = {"sv": lambda d: d["sv"].astype(object), "signal": lambda d: d["signal"].astype(object)}
    rover = meas.reset_index(drop=True).assign(_row=lambda d: np.arange(len(d)),
                                               _t=lambda d: d["gps_time_s"] + TIME_MATCH_S,
                                               **keys)
    base = corrections.rename(columns={"gps_time_s": "_tb"}).assign(_t=lambda d: d["_tb"],
                                                                    **keys)
    merged = pd.merge_asof(rover.sort_values("_t"), base[["_t", "_tb", "sv", "signal",
                                                          "correction_m"]].sort_values("_t"),
                           on="_t", by=["sv", "signal"], direction="backward")
    age = merged["gps_time_s"].to_numpy() - merged["_tb"].to_numpy()
    ok = np.isfinite(merged["correction_m"].to_numpy()) & (age <= max_age_s)
    merged = merged[ok].sort_values("_row")
    dropped = len(rover) - len(merged)
    if dropped:
        log.info("DGPS: %d of %d rover measurements without a correction younger than "
                 "%.0f s were dropped", dropped, len(rover), max_age_s)
    out = meas.reset_index(drop=True).iloc[merged["_row"].to_numpy()].copy()
    out["pseudorange_m"] = out["pseudorange_m"].to_numpy() - merged["correction_m"].to_numpy()
    out["correction_age_s"] = np.maximum(merged["gps_time_s"].to_numpy()
                                         - merged["_tb"].to_numpy(), 0.0)
    return out.reset_index(drop=True)


@dataclass(frozen=True, eq=False)
class Augmentation:
    """What `augment` prepares for `solve_spp` and the navigator's GNSS rows.

    Attributes
    ----------
    obs : RinexObs
        The rover observations, carrier-smoothed when asked.
    corrections : pandas.DataFrame or None
        Base corrections (`base_corrections`), None without a base.
    precise : gnss_obs.precise.PreciseOrbits or None
    max_age_s : float
        Oldest correction to apply, s.
    """

    obs: object
    corrections: pd.DataFrame | None
    precise: object
    max_age_s: float


def augment(obs, nav, config: MeasurementConfig, *, base_obs=None,
            base_lat_lon_h: tuple[float, float, float] | None = None,
            dgps: DgpsConfig | None = None, smoothing=None, sp3=()) -> Augmentation:
    """Carrier smoothing, base corrections and precise orbits in one step.

    Parameters
    ----------
    obs, nav : RinexObs, RinexNav
        Rover observations and broadcast navigation.
    config : MeasurementConfig
    base_obs : RinexObs, optional
        Base-station observations: code-differential corrections (smoothed like the rover).
    base_lat_lon_h : (lat_deg, lon_deg, h_m), optional
        Base position; default the base header's ``APPROX POSITION XYZ``.
    dgps : DgpsConfig, optional
    smoothing : gnss_obs.smoothing.SmoothingConfig, optional
        Carrier-smooth rover (and base) code with these settings; None = raw code.
    sp3 : sequence of Sp3
        Precise products; empty = broadcast orbits and clocks.
    """
    from gnss_obs.coverage import check_sp3_coverage
    from gnss_obs.precise import PreciseOrbits
    from gnss_obs.smoothing import smooth_observations

    cfg = dgps or DgpsConfig()
    check_sp3_coverage(obs, sp3)
    precise = PreciseOrbits.from_sp3(*sp3) if sp3 else None
    if smoothing is not None:
        obs = smooth_observations(obs, smoothing)
    corrections = None
    if base_obs is not None:
        r_base = base_position_e(base_obs.header, base_lat_lon_h)
        if smoothing is not None:
            base_obs = smooth_observations(base_obs, smoothing)
        corrections = base_corrections(base_obs, nav, config, r_base_e=r_base, dgps=cfg,
                                       precise=precise)
    elif base_lat_lon_h is not None:
        raise GnssError("a base position was given without a base observation file")
    return Augmentation(obs, corrections, precise, cfg.max_age_s)


def augment_files(obs, nav, config: MeasurementConfig, *, base_path=None,
                  base_lat_lon_h: tuple[float, float, float] | None = None, smoothing=None,
                  sp3_paths=(), max_age_s: float | None = None) -> Augmentation:
    """`augment` with the base observations and SP3 products read from their files.

    Parameters
    ----------
    obs, nav, config, base_lat_lon_h, smoothing
        As for `augment`.
    base_path : path, optional
        Base-station RINEX observations.
    sp3_paths : sequence of path
        Precise orbit/clock files.
    max_age_s : float, optional
        Oldest base correction applied (default `DgpsConfig`'s).
    """
    from gnss_obs.rinex_obs import read_rinex_obs
    from gnss_obs.sp3 import read_sp3

    dgps = DgpsConfig() if max_age_s is None else DgpsConfig(max_age_s=max_age_s)
    return augment(obs, nav, config,
                   base_obs=read_rinex_obs(base_path) if base_path is not None else None,
                   base_lat_lon_h=base_lat_lon_h, dgps=dgps, smoothing=smoothing,
                   sp3=[read_sp3(p) for p in sp3_paths])
