"""Measurement residuals at a known receiver position: how large the errors really are.

`known_position_residuals` evaluates the full measurement model of `gnss_obs.epoch` (the
same corrections as the SPP and the filters: satellites at transmission, Sagnac, clocks and
group delays, Klobuchar, troposphere) at a position known from elsewhere — a reference
trajectory of a moving receiver, or a surveyed base station — and returns, per epoch and
satellite,

* the pseudorange residual ``P - ρ̂(r)`` less the receiver clock: per epoch the median over
  all satellites of ``P - ρ̂ - isb_sys``, with one inter-system bias per system for the
  whole file (the median over the file of the system's residuals less the epoch clocks,
  GPS or the first system the reference), alternated `CLOCK_ITERATIONS` times. Fixing the
  position leaves one unknown per epoch; the median is robust to the multipath outliers
  (one epoch's clock error is common to its rows, ~``1.25 σ/√n``);
* the range-rate residual ``-λ D - ρ̂̇(r, v)`` less the clock drift (the per-epoch median),
  when a velocity is given (zero for a static receiver);
* the model's σ of each (`gnss_obs.epoch.measurement_sigmas` with the given config), so
  that ``residual / σ`` is the normalized residual whose spread should be 1.

What the residuals hold: code noise and multipath, the broadcast orbit and clock errors
(signal-in-space range error) and what the atmosphere models leave, plus the reference
position's own error (cm for a PPK trajectory). Satellites below `elevation_mask_deg` are
left out, as in the SPP and the filters.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pandas as pd

from gnss_obs.epoch import prepare_epoch, split_epochs
from gnss_obs.measurements import MeasurementConfig, glonass_channels, select_measurements
from gnss_obs.observables import predict_pseudorange, predict_range_rate
from gnss_obs.transmission import transmit_states_batch

__all__ = ["known_position_residuals", "RESIDUAL_COLUMNS", "CLOCK_ITERATIONS",
           "TIME_MATCH_S"]

#: Columns of the `known_position_residuals` table.
RESIDUAL_COLUMNS = ["gps_time_s", "sv", "system", "elevation_deg", "cn0_dbhz",
                    "pr_residual_m", "sigma_pr_m", "rr_residual_mps", "sigma_rr_mps"]
#: Alternations of the per-epoch clock and the per-file inter-system biases.
CLOCK_ITERATIONS = 3
#: An epoch matches a known position at most this far in time, s.
TIME_MATCH_S = 1e-3


def known_position_residuals(obs, nav, config: MeasurementConfig, *,
                             times_s: npt.ArrayLike, r_e: npt.ArrayLike,
                             v_e: npt.ArrayLike | None = None,
                             elevation_mask_deg: float = 10.0) -> pd.DataFrame:
    """Residuals of the measurements at known positions (module docstring).

    Parameters
    ----------
    obs : RinexObs
    nav : RinexNav
        Broadcast ephemerides and the Klobuchar coefficients of its header.
    config : MeasurementConfig
        Systems, signals, corrections and the σ model to report.
    times_s : array_like, shape (K,)
        GPS times of the known positions, s, increasing.
    r_e : array_like, shape (K, 3) or (3,)
        Known antenna positions, ECEF, m (one row for a static receiver).
    v_e : array_like, shape (K, 3) or (3,), optional
        Known antenna velocities, ECEF, m/s (NaN rows: no range-rate residual there);
        None: no range-rate residuals.
    elevation_mask_deg : float
        Satellites lower than this are left out, deg.

    Returns
    -------
    pandas.DataFrame
        `RESIDUAL_COLUMNS`, one row per epoch (matched within `TIME_MATCH_S`) and
        satellite above the mask.
    """
    times = np.asarray(times_s, dtype=float)
    r_all = np.broadcast_to(np.asarray(r_e, dtype=float), (times.size, 3))
    v_all = None if v_e is None else np.broadcast_to(np.asarray(v_e, dtype=float),
                                                     (times.size, 3))
    meas = select_measurements(obs.table, config, glonass_channels=glonass_channels(
        obs.header.glonass_slots, nav.records))
    epochs = split_epochs(meas, nav.records, config)
    klob = None
    if config.ionosphere == "klobuchar" and nav.header.iono_gps_alpha is not None:
        klob = (np.asarray(nav.header.iono_gps_alpha, dtype=float),
                np.asarray(nav.header.iono_gps_beta, dtype=float))
    mask = np.deg2rad(elevation_mask_deg)
    parts = []
    for epoch, tx in zip(epochs, transmit_states_batch(epochs, config)):
        k = int(np.clip(np.searchsorted(times, epoch.gps_time_s), 0, times.size - 1))
        if k > 0 and abs(times[k - 1] - epoch.gps_time_s) < abs(times[k] - epoch.gps_time_s):
            k -= 1
        if abs(times[k] - epoch.gps_time_s) > TIME_MATCH_S:
            continue
        r = r_all[k]
        prep = prepare_epoch(epoch, config, r_rx_e=r, klobuchar=klob, transmit=tx)
        prep = prep.subset(np.isfinite(prep.pseudorange_m) & (prep.elevation >= mask))
        if not len(prep):
            continue
        rho, _, _ = predict_pseudorange(prep, r_e=r, b_m=0.0)
        rr = np.full(len(prep), np.nan)
        if v_all is not None and np.all(np.isfinite(v_all[k])):
            rho_dot, _, _, _ = predict_range_rate(prep, r_e=r, v_e=v_all[k], d_mps=0.0)
            rr = prep.range_rate_mps - rho_dot
        parts.append(pd.DataFrame({
            "gps_time_s": epoch.gps_time_s, "sv": prep.sv, "system": prep.system,
            "elevation_deg": np.rad2deg(prep.elevation), "cn0_dbhz": prep.cn0_dbhz,
            "pr_residual_m": prep.pseudorange_m - rho, "sigma_pr_m": prep.sigma_pr_m,
            "rr_residual_mps": rr, "sigma_rr_mps": prep.sigma_rr_mps}))
    if not parts:
        return pd.DataFrame({c: [] for c in RESIDUAL_COLUMNS})
    table = pd.concat(parts, ignore_index=True)
    table["pr_residual_m"] = _less_clock(table, "pr_residual_m", inter_system=True)
    table["rr_residual_mps"] = _less_clock(table, "rr_residual_mps", inter_system=False)
    return table[RESIDUAL_COLUMNS]


def _less_clock(table: pd.DataFrame, column: str, *, inter_system: bool) -> np.ndarray:
    """`column` less its per-epoch median (and per-system biases: module docstring)."""
    values = table[column].to_numpy()
    epoch = table["gps_time_s"].to_numpy()
    system = table["system"].to_numpy().astype(str)
    _, index = np.unique(epoch, return_inverse=True)
    bias = np.zeros(values.size)
    systems = list(dict.fromkeys(system))
    first = "G" if "G" in systems else systems[0]
    for _ in range(CLOCK_ITERATIONS if inter_system else 0):
        clock = _group_median(values - bias, index)
        for s in systems:
            rows = (system == s) & np.isfinite(values)
            if s != first and rows.any():
                bias[system == s] = np.median(values[rows] - clock[index[rows]])
    return values - bias - _group_median(values - bias, index)[index]


def _group_median(values: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Median of the finite `values` per group `index` (NaN for a group without any)."""
    out = np.full(index.max() + 1, np.nan)
    order = np.argsort(index, kind="stable")
    bounds = np.flatnonzero(np.diff(index[order])) + 1
    for rows in np.split(order, bounds):
        finite = values[rows][np.isfinite(values[rows])]
        if finite.size:
            out[index[rows[0]]] = np.median(finite)
    return out
