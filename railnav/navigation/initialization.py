"""Where a filter starts: the first GNSS fix, or the truth with drawn errors (simulation).

* `initial_from_gnss`: single-point positioning (`gnss_obs.solve_spp`) over the first epochs
  of the trip; the first epoch with a position and a Doppler velocity gives the fix, which
  the filter turns into its state (projected on the track for the track-based filters) and
  covariance (`filter.initial_from_fix`). With the noise scale on
  (``NavigatorConfig.noise_scale``), the fix's covariances are multiplied by the variance
  factors the scatter of the first fixes shows (`railnav.navigation.start_scatter`; 1
  when not significant), and the start seeds the GNSS rows' scale with them
  (`InitialState.noise_seed`, `railnav.filters.noise_scale.NoiseScale.seed`).
* `initial_from_truth`: for simulations, ``x0 = x_true + e`` with ``e ~ N(0, P0)`` drawn from
  the filter's own initial covariance, so that the filter's covariance is honest from the
  first step (needed for NEES statistics). Components whose truth is itself a draw from
  the filter's prior (the IMU biases: the simulator draws them from the grade's figures)
  start at the prior mean instead; a second draw would double their error variance.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from gnss_obs.spp import SppConfig, solve_spp
from railnav.errors import RailnavError
from railnav.filters.common import ROW_KINDS
from railnav.navigation.start_scatter import START_EPOCHS, scatter_factors

__all__ = ["InitialState", "GnssFix", "first_fix", "initial_from_gnss", "initial_from_truth",
           "noise_seed", "MAX_INITIAL_EPOCHS"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: Epochs searched for a first fix.
MAX_INITIAL_EPOCHS = 60


@dataclass(frozen=True)
class InitialState:
    """A filter's starting point.

    Attributes
    ----------
    time_s : float
        Time of the prior, s from the trip start.
    x0 : ndarray, shape (n,)
    P0 : ndarray, shape (n, n)
        In the filter's `ekf.StateLayout`.
    noise_seed : dict of str to float
        The GNSS rows' starting variance factors by kind (`NoiseScale.seed`; empty: none),
        from a start's fixes (`first_fix`'s `GnssFix.start_factors`).
    """

    time_s: float
    x0: Array
    P0: Array
    noise_seed: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class GnssFix:
    """A single-epoch GNSS solution.

    Attributes
    ----------
    time_s : float
        s from the trip start.
    r_e, v_e : ndarray, shape (3,)
        ECEF position (m) and velocity (m/s).
    clock_bias_m : dict of str to float
        Receiver clock bias seen by each system, m.
    clock_drift_mps : float
        m/s.
    cov_enu_m2, cov_v_enu_m2ps2 : ndarray, shape (3, 3)
        Position and velocity covariance in ENU, m² and (m/s)².
    start_factors : tuple of float
        The variance factors (position, velocity) already in those covariances
        (`railnav.navigation.start_scatter`; 1: none).
    """

    time_s: float
    r_e: Array
    v_e: Array
    clock_bias_m: dict[str, float]
    clock_drift_mps: float
    cov_enu_m2: Array
    cov_v_enu_m2ps2: Array
    start_factors: tuple[float, float] = (1.0, 1.0)


def first_fix(data, config, *, max_epochs: int = MAX_INITIAL_EPOCHS) -> GnssFix:
    """The first epoch of the trip with a position and a velocity.

    Parameters
    ----------
    data : railnav.SensorData
    config : railnav.NavigatorConfig
    max_epochs : int
        How many epochs to try.

    Raises
    ------
    RailnavError
        If none of them gives a fix.
    """
    table = data.obs.table
    times = np.unique(table["gps_time_s"].to_numpy())
    times = times[times >= data.start_gps_time_s - 1e-6][:max_epochs]
    name = data.obs.path or "the GNSS observations"
    if times.size == 0:
        raise RailnavError(f"{name}: no GNSS epoch at or after the trip start (GPS time "
                           f"{data.start_gps_time_s:.1f} s)")
    sub = replace(data.obs, table=table[table["gps_time_s"].isin(times)])
    spp = solve_spp(sub, data.nav, SppConfig(measurement=config.measurement,
                                            elevation_mask_deg=config.elevation_mask_deg))
    ok = np.all(np.isfinite(spp.r_e), axis=1) & np.all(np.isfinite(spp.v_e), axis=1)
    if not ok.any():
        raise RailnavError(f"{name}: no GNSS fix with velocity in the first {times.size} "
                           "epochs (too few satellites?)")
    k = int(np.argmax(ok))
    pos_factor, vel_factor = _start_factors(spp, ok, k) if config.noise_scale is not None \
        else (1.0, 1.0)
    return GnssFix(time_s=float(spp.gps_time_s[k] - data.start_gps_time_s),
                   r_e=spp.r_e[k], v_e=spp.v_e[k],
                   clock_bias_m={s: float(spp.clock_bias_m[s][k]) for s in spp.systems},
                   clock_drift_mps=float(spp.clock_drift_mps[k]),
                   cov_enu_m2=spp.cov_enu_m2[k] * pos_factor,
                   cov_v_enu_m2ps2=spp.cov_v_enu_m2ps2[k] * vel_factor,
                   start_factors=(pos_factor, vel_factor))


def _start_factors(spp, ok, k: int) -> tuple[float, float]:
    """The variance factors of fix `k`'s position and velocity from the scatter of the
    fixes `ok` from it on (`railnav.navigation.start_scatter`)."""
    use = np.flatnonzero(ok)
    use = use[use >= k][:START_EPOCHS]
    found = scatter_factors(spp.gps_time_s[use], spp.r_e[use], spp.v_e[use],
                            spp.cov_enu_m2[use], spp.cov_v_enu_m2ps2[use])
    if found.position != 1.0 or found.velocity != 1.0:
        log.info("the first fixes scatter beyond their σ (χ² %.1f/%d position, %.1f/%d "
                 "velocity): the start's variances ×%.3g and ×%.3g", found.chi2_position,
                 found.dof_position, found.chi2_velocity, found.dof_velocity,
                 found.position, found.velocity)
    return found.position, found.velocity


def initial_from_gnss(filt_obj, data, config, gnss):
    """The filter's `InitialState` at the first GNSS fix."""
    if gnss is None:
        raise RailnavError("no GNSS data to start from: give GNSS observations or fixes "
                           "(--obs/--nav, --fixes; from Python also navigate(initial=...))")
    fix = first_fix(data, config)
    x0, P0 = filt_obj.initial_from_fix(fix)
    log.info("started at t=%.3f s from a GNSS fix", fix.time_s)
    return InitialState(fix.time_s, x0, P0, noise_seed=noise_seed(fix))


def noise_seed(fix: GnssFix) -> dict[str, float]:
    """The GNSS rows' starting variance factors (`InitialState.noise_seed`) of a start at
    `fix`: its position factor for the pseudoranges, its velocity factor for the range
    rates (`railnav.navigation.start_scatter`; empty when both are 1)."""
    if fix.start_factors == (1.0, 1.0):
        return {}
    return dict(zip(ROW_KINDS, fix.start_factors))


def initial_from_truth(x_true: npt.ArrayLike, P0: npt.ArrayLike, *, time_s: float,
                       rng: np.random.Generator, drawn: npt.ArrayLike | None = None):
    """``x0 = x_true + e``, ``e ~ N(0, P0)``: an honest start for simulations.

    Parameters
    ----------
    x_true : array_like, shape (n,)
        True state at `time_s`; for components not `drawn`, the prior mean.
    P0 : array_like, shape (n, n)
        The filter's initial covariance (no correlation between drawn and other
        components).
    time_s : float
    rng : numpy.random.Generator
    drawn : array_like of bool, shape (n,), optional
        Components that get the drawn error (default all). The others start at `x_true`:
        use it for states whose simulated truth is unknown to the filter and was drawn
        from the same prior (IMU biases), so that their error is that draw alone.

    Returns
    -------
    InitialState
    """
    P0 = np.asarray(P0, dtype=float)
    error = np.linalg.cholesky(P0) @ rng.standard_normal(P0.shape[0])
    if drawn is not None:
        error = np.where(np.asarray(drawn, dtype=bool), error, 0.0)
    return InitialState(float(time_s), np.asarray(x_true, dtype=float) + error, P0)
