r"""Standstill detection: from the IMU (a variance and level test over a window), vetoed by
the odometer and the GNSS speed when present.

The IMU samples are cut into consecutive windows of ``window_s`` (default 1 s). A window is
**still** when all four tests pass:

* accelerometer variance: ``T_a = (1/W) Σ |f_k − f̄|² / σ_f²`` ≤ ``variance_ratio`` (default
  4.5), ``σ_f`` the grade's per-sample white noise (density × √rate). Still, ``W T_a`` is
  χ² with ``3(W − 1)`` degrees of freedom: mean ≈ 3, 1σ ≈ 0.24 at W = 100, so 4.5 is 6σ above
  the mean (a missed detection of ~1e-9 per window from the noise alone);
* gyro variance: the same with the gyro's σ;
* level: ``| |f̄| − g |`` ≤ ``level_tol_mps2`` (default 0.1 m/s²: a MEMS accelerometer's
  3-mg bias and 1000-ppm scale together are 0.04 m/s²);
* rate: ``|ω̄|`` ≤ ``rate_tol_radps`` (default 5e-4 rad/s: Earth rate 7.3e-5, a MEMS bias
  of 10 °/h = 4.8e-5 and the window mean's noise ~1e-4 fit under it; a car body moving on
  a 600-m curve at 1 m/s turns at 1.7e-3 rad/s).

* constancy: the window and its `StandstillConfig.constancy_windows` neighbours on each
  side pass the tests above and their mean specific forces agree within
  ``constancy_tol_mps2`` (default 0.01 m/s², per axis, the range over the span; default 1
  neighbour): a vehicle
  at rest feels the same specific force all along, one that brakes to a stop does not
  (the raised-cosine braking of the simulated profiles: 25 m/s in 50 s, still 0.16 m/s and
  0.02 m/s² 5 s before the stop, passes the four tests above; this one first passes ~1.5 s
  before the stop, at 5 mm/s). The neighbours make the detection non-causal: in real time
  it comes ``constancy_windows × window_s`` late (default 1 s); a run applies each row at
  its window's end.

A vehicle moving smoothly at constant speed on a straight level track, with no vibration,
passes every IMU test: only vibration tells it from a standstill. Real vehicles vibrate, and
the simulator's car body (`railnav.simulation.car_body_motion`) does (1–3 mrad at ~1 Hz, its
rates ~100× a MEMS gyro's per-sample noise), but the plain simulator does not. Hence the
**vetoes**: a window is not still when the odometer reads a speed above its dead band, or a
GNSS fix a speed above ``max(gnss_speed_tol_mps, 3σ)`` within it; and every zero-speed row
is screened at the filter's prior (`railnav.filters.standstill_rows`), which rejects one
whose speed is many σ from zero. The detection figures (false alarms and missed detections
against the simulated stops) are in ``benchmarks/results/track_attitude.json``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from railnav.errors import ConfigError

__all__ = ["StandstillConfig", "StandstillEpochs", "detect_standstill", "window_statistics",
           "NOMINAL_GRAVITY_MPS2"]

Array = npt.NDArray[np.float64]

#: |g| the level test compares with, m/s² (normal gravity varies ±0.03 m/s² with latitude
#: and height: inside the level tolerance).
NOMINAL_GRAVITY_MPS2 = 9.80665


@dataclass(frozen=True)
class StandstillConfig:
    """Standstill detection and its rows (module docstring; `railnav.filters.standstill_rows`).

    Parameters
    ----------
    window_s : float
        Window length, s (> 0).
    variance_ratio : float
        Largest mean ``|f − f̄|²/σ²`` (and the gyro's) of a still window (> 0).
    level_tol_mps2 : float
        Largest ``| |f̄| − g |`` of a still window, m/s² (> 0).
    rate_tol_radps : float
        Largest ``|ω̄|`` of a still window, rad/s (> 0).
    constancy_tol_mps2 : float
        Largest range of the windows' mean specific force over a still span, m/s² (> 0).
    constancy_windows : int
        Neighbours on each side of a still window that must be still with it (>= 0).
    gnss_speed_tol_mps : float
        A fix's speed above ``max(this, 3σ)`` vetoes its window, m/s (> 0).
    zero_speed_sigma_mps : float
        1σ of the zero-speed row, m/s (> 0): a standing train creeps by less.
    yaw_rate_update : bool
        Also the zero-angular-rate row about the track normal (needs gyro bias states).
    """

    window_s: float = 1.0
    variance_ratio: float = 4.5
    level_tol_mps2: float = 0.1
    rate_tol_radps: float = 5e-4
    constancy_tol_mps2: float = 0.01
    constancy_windows: int = 1
    gnss_speed_tol_mps: float = 0.2
    zero_speed_sigma_mps: float = 0.01
    yaw_rate_update: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.constancy_windows, int) and self.constancy_windows >= 0):
            raise ConfigError(f"standstill: constancy_windows must be an integer >= 0, got "
                              f"{self.constancy_windows!r}")
        for name in ("window_s", "variance_ratio", "level_tol_mps2", "rate_tol_radps",
                     "constancy_tol_mps2", "gnss_speed_tol_mps", "zero_speed_sigma_mps"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"standstill: {name} must be a finite number > 0, "
                                  f"got {value!r}")


@dataclass(frozen=True, eq=False)
class StandstillEpochs:
    """The still windows of a run (arrays of N windows, in time order).

    Attributes
    ----------
    time_s : ndarray
        The window's last sample, s from the trip start (the row's epoch).
    omega_mean_radps : ndarray, shape (N, 3)
        Mean gyro reading over the window, rad/s (b).
    omega_sigma_radps : ndarray
        1σ of that mean from the gyro's white noise, rad/s.
    """

    time_s: Array
    omega_mean_radps: Array
    omega_sigma_radps: Array

    def __len__(self) -> int:
        return self.time_s.size


def _noise_sigmas(imu_errors, rate_hz: float) -> tuple[float, float]:
    """Per-sample white-noise σ of the accelerometer (m/s²) and gyro (rad/s)."""
    from railnav.filters.ins_clock_model import (   # CasADi: not at import (config reads us)
        IDEAL_ACCEL_NOISE_DENSITY_MPS2_RTHZ,
        IDEAL_GYRO_NOISE_DENSITY_RADPS_RTHZ,
    )
    accel = imu_errors.accel_noise_density_mps2_rthz or IDEAL_ACCEL_NOISE_DENSITY_MPS2_RTHZ
    gyro = imu_errors.gyro_noise_density_radps_rthz or IDEAL_GYRO_NOISE_DENSITY_RADPS_RTHZ
    return accel * math.sqrt(rate_hz), gyro * math.sqrt(rate_hz)


def window_statistics(t: Array, u: Array, *, window_s: float) -> dict[str, Array]:
    """Per window: last time, sample count, mean ``f`` and ``ω``, and the mean squared
    deviations ``|f − f̄|²``, ``|ω − ω̄|²`` (``u`` = ``[f_b, ω_ib_b]``, (M, 6); two passes,
    exact for long trips)."""
    t = np.asarray(t, dtype=float)
    k = np.floor((t - t[0]) / window_s + 1e-9).astype(np.intp)
    starts = np.flatnonzero(np.concatenate([[True], np.diff(k) > 0]))
    n = np.diff(np.concatenate([starts, [t.size]]))
    mean = np.add.reduceat(u, starts, axis=0) / n[:, None]
    dev = u - np.repeat(mean, n, axis=0)
    var = np.add.reduceat(dev * dev, starts, axis=0) / n[:, None]
    return {"time_s": t[starts + n - 1], "count": n, "f_mean": mean[:, :3],
            "omega_mean": mean[:, 3:], "f_var": var[:, :3].sum(axis=1),
            "omega_var": var[:, 3:].sum(axis=1)}


def detect_standstill(t: Array, u: Array, config: StandstillConfig, imu_errors, *,
                      odometer=None, fixes=None) -> tuple[StandstillEpochs, dict[str, Array]]:
    """The still windows of IMU samples (module docstring).

    Parameters
    ----------
    t : ndarray, shape (M,)
        Sample times, s from the trip start.
    u : ndarray, shape (M, 6)
        ``[f_b, ω_ib_b]``, m/s² and rad/s.
    config : StandstillConfig
    imu_errors : strapdown.imu_errors.ImuErrors
        The grade the filter assumes (its white-noise densities).
    odometer : railnav.filters.odometer_epochs.OdometerEpochs, optional
    fixes : railnav.filters.fix_epochs.FixEpochs, optional

    Returns
    -------
    StandstillEpochs
        The still windows.
    dict
        Every window's ``time_s`` and ``still`` (bool), for the detection figures.
    """
    w = window_statistics(t, u, window_s=config.window_s)
    rate = float((t.size - 1) / (t[-1] - t[0]))
    sigma_f, sigma_w = _noise_sigmas(imu_errors, rate)
    full = w["count"] >= 0.9 * config.window_s * rate
    still = (full & (w["f_var"] / sigma_f ** 2 <= config.variance_ratio)
             & (w["omega_var"] / sigma_w ** 2 <= config.variance_ratio)
             & (np.abs(np.linalg.norm(w["f_mean"], axis=1) - NOMINAL_GRAVITY_MPS2)
                <= config.level_tol_mps2)
             & (np.linalg.norm(w["omega_mean"], axis=1) <= config.rate_tol_radps))
    still = _constant_spans(still, w["f_mean"], config)
    still &= ~_vetoed(w["time_s"], config, odometer, fixes)
    k = np.flatnonzero(still)
    epochs = StandstillEpochs(time_s=w["time_s"][k], omega_mean_radps=w["omega_mean"][k],
                              omega_sigma_radps=sigma_w / np.sqrt(w["count"][k]))
    return epochs, {"time_s": w["time_s"], "still": still}


def _constant_spans(still: npt.NDArray[np.bool_], f_mean: Array,
                    config: StandstillConfig) -> npt.NDArray[np.bool_]:
    """Still windows whose ±n neighbours are still and agree in mean specific force."""
    n = config.constancy_windows
    if n == 0 or still.size == 0:
        return still
    from numpy.lib.stride_tricks import sliding_window_view
    pad_still = np.concatenate([np.zeros(n, bool), still, np.zeros(n, bool)])
    pad_f = np.concatenate([np.full((n, 3), np.nan), f_mean, np.full((n, 3), np.nan)])
    span_still = sliding_window_view(pad_still, 2 * n + 1).all(axis=1)
    spans = sliding_window_view(pad_f, 2 * n + 1, axis=0)          # (K, 3, 2n+1)
    with np.errstate(invalid="ignore"):
        spread = (spans.max(axis=2) - spans.min(axis=2)).max(axis=1)
    return still & span_still & (np.nan_to_num(spread, nan=np.inf) <= config.constancy_tol_mps2)


def _vetoed(end_s: Array, config: StandstillConfig, odometer, fixes) -> npt.NDArray[np.bool_]:
    """Windows ``(end − window_s, end]`` in which the odometer or a fix reads motion."""
    veto = np.zeros(end_s.size, dtype=bool)
    sources = []
    if odometer is not None:
        sources.append((odometer.time_s, ~odometer.standstill & (odometer.speed_mps > 0)))
    if fixes is not None and len(fixes):
        speed = np.linalg.norm(np.nan_to_num(fixes.v_n_mps[:, :2]), axis=1)
        tol = np.maximum(config.gnss_speed_tol_mps, 3.0 * np.nan_to_num(fixes.sigma_speed_mps))
        sources.append((fixes.time_s, np.isfinite(fixes.v_n_mps[:, 0]) & (speed > tol)))
    for times, moving in sources:
        moving_t = np.asarray(times)[moving]
        if moving_t.size:
            hi = np.searchsorted(moving_t, end_s, side="right")
            lo = np.searchsorted(moving_t, end_s - config.window_s, side="right")
            veto |= hi > lo
    return veto
