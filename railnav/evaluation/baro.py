r"""Barometric check against the track: the 2021 paper's integrity monitor, applied to rail.

Ivanov et al. (2021, SEEDS.md §2) fuse a barometric altimeter with GNSS height in a
vertical channel, estimate the baro bias ``ΔH`` and refuse GNSS when the estimate exceeds
``ΔH_max``: a GNSS height error shows up as a bias change. On a railway the height of the
vehicle is known from the track once ``s`` is: ``h = h_track(s)``, with σ ``|sin ϑ| σ_s``
(the ``sigma_up_m`` of ``estimates.csv``). `baro_track_check` therefore

1. estimates the baro bias **against the track height** with a scalar Kalman filter:
   ``b_{k+1} = b_k + w_k`` (a random walk of density `BaroConfig.bias_walk_mps`², the
   weather's pressure drift), ``y_k = h_baro,k − h_track,k = b_k + v_k``,
   ``var v = σ_baro² + σ_track²`` (`ekf.kalman_update`, the engine's update);
2. raises the **bias flag** when ``|b̂| > max_bias_m`` (the paper's monitor: a baro that
   reads that far from the track means the track position — the filter's ``s`` on a
   grade, or the track itself — is wrong);
3. compares each **GNSS height** (e.g. the single-point solution, which does not know the
   track) with the calibrated baro height ``h_baro − b̂``: the **GNSS flag** is raised when
   they differ by more than `gnss_sigma_factor` σ, ``σ² = σ_gnss² + P_b + σ_baro²``. A GNSS
   position error that stays consistent across satellites (spoofing, a common fault) and
   which RAIM cannot see shows here as a height disagreement.

`simulate_baro` draws baro readings (constant bias + bias walk + white noise) from a true
height for simulations.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.errors import ConfigError

__all__ = ["BaroConfig", "BaroCheck", "baro_track_check", "simulate_baro"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class BaroConfig:
    """The baro altimeter and the monitor.

    Parameters
    ----------
    sigma_m : float
        White noise of one baro reading, m (2021 paper: σ_baro = 1 m).
    bias_walk_mps : float
        Random walk of the bias, m/√s (weather; 0.01: ~0.6 m in an hour).
    initial_bias_sigma_m : float
        Prior σ of the bias, m (2021 paper: 25 m, its P0 of 625 m²).
    max_bias_m : float
        The paper's ``ΔH_max``: a larger bias estimate raises the bias flag, m.
    gnss_sigma_factor : float
        GNSS heights farther than this many σ from the calibrated baro are flagged (3: a
        consistent height passes with probability 0.9973).
    """

    sigma_m: float = 1.0
    bias_walk_mps: float = 0.01
    initial_bias_sigma_m: float = 25.0
    max_bias_m: float = 50.0
    gnss_sigma_factor: float = 3.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            low_ok = value >= 0 if f.name == "bias_walk_mps" else value > 0
            if not (isinstance(value, (int, float)) and math.isfinite(value) and low_ok):
                raise ConfigError(f"{f.name} must be a finite number "
                                  f"{'>= 0' if f.name == 'bias_walk_mps' else '> 0'}, "
                                  f"got {value!r}")


@dataclass(frozen=True, eq=False)
class BaroCheck:
    """Result of `baro_track_check`.

    Attributes
    ----------
    time_s, bias_m, sigma_bias_m : ndarray, shape (N,)
        At each baro reading: the bias estimate and its σ, m.
    bias_flag : ndarray of bool, shape (N,)
    gnss_time_s, gnss_h_m, baro_h_m, disagreement_m, sigma_disagreement_m : ndarray, (M,)
        At each GNSS height: the GNSS height, the calibrated baro height, their difference
        and its σ, m.
    gnss_flag : ndarray of bool, shape (M,)
    """

    time_s: Array
    bias_m: Array
    sigma_bias_m: Array
    bias_flag: npt.NDArray[np.bool_]
    gnss_time_s: Array
    gnss_h_m: Array
    baro_h_m: Array
    disagreement_m: Array
    sigma_disagreement_m: Array
    gnss_flag: npt.NDArray[np.bool_]

    def to_frame(self) -> pd.DataFrame:
        """The per-reading table: ``time_s, bias_m, sigma_bias_m, bias_flag``."""
        return pd.DataFrame({"time_s": self.time_s, "bias_m": self.bias_m,
                             "sigma_bias_m": self.sigma_bias_m, "bias_flag": self.bias_flag})

    def gnss_frame(self) -> pd.DataFrame:
        """The per-GNSS-height table: ``time_s, gnss_h_m, baro_h_m, disagreement_m,
        sigma_disagreement_m, gnss_flag``."""
        return pd.DataFrame({"time_s": self.gnss_time_s, "gnss_h_m": self.gnss_h_m,
                             "baro_h_m": self.baro_h_m, "disagreement_m": self.disagreement_m,
                             "sigma_disagreement_m": self.sigma_disagreement_m,
                             "gnss_flag": self.gnss_flag})


def _series(name: str, value, n: int | None = None) -> Array:
    a = np.asarray(value, dtype=float).reshape(-1)
    if n is not None and a.size != n:
        raise ConfigError(f"{name} has {a.size} values, expected {n}")
    if not np.all(np.isfinite(a)):
        raise ConfigError(f"{name} has NaN or infinite values")
    return a


def baro_track_check(time_s, baro_h_m, track_h_m, sigma_track_h_m, *, gnss_time_s=(),
                     gnss_h_m=(), gnss_sigma_h_m=(), config: BaroConfig = BaroConfig()
                     ) -> BaroCheck:
    """Baro bias against the track and the GNSS height check (module docstring).

    Parameters
    ----------
    time_s : array_like, shape (N,)
        Times of the baro readings, s, increasing.
    baro_h_m : array_like, shape (N,)
        Baro altitude readings, m.
    track_h_m, sigma_track_h_m : array_like, shape (N,)
        The track height at the navigated ``s`` and its σ at those times, m
        (``estimates.csv``: ``h_m``, ``sigma_up_m``, interpolated).
    gnss_time_s, gnss_h_m, gnss_sigma_h_m : array_like, shape (M,)
        GNSS heights to check and their σ, m (may be empty).
    config : BaroConfig

    Returns
    -------
    BaroCheck

    Raises
    ------
    ConfigError
        Lengths that differ, NaN values, times not increasing.
    """
    # here, not at the top: `simulate_baro` (every simulated trip, `railnav simulate`) runs
    # without the engine's update, which loads scipy.linalg and scipy.special (~0.08 s)
    from ekf.update import kalman_update

    t = _series("time_s", time_s)
    if t.size == 0 or np.any(np.diff(t) <= 0):
        raise ConfigError("baro time_s must be non-empty and increasing")
    y = _series("baro_h_m", baro_h_m, t.size) - _series("track_h_m", track_h_m, t.size)
    r_var = config.sigma_m ** 2 + _series("sigma_track_h_m", sigma_track_h_m, t.size) ** 2
    b, P = np.zeros(1), np.array([[config.initial_bias_sigma_m ** 2]])
    bias, var = np.empty(t.size), np.empty(t.size)
    H = np.ones((1, 1))
    for k in range(t.size):
        if k:
            P = P + config.bias_walk_mps ** 2 * (t[k] - t[k - 1])
        b, P, _ = kalman_update(b, P, np.array([y[k] - b[0]]), H, np.array([r_var[k]]))
        bias[k], var[k] = b[0], P[0, 0]
    tg = _series("gnss_time_s", gnss_time_s)
    hg = _series("gnss_h_m", gnss_h_m, tg.size)
    sg = _series("gnss_sigma_h_m", gnss_sigma_h_m, tg.size)
    baro = _series("baro_h_m", baro_h_m)
    k = np.clip(np.searchsorted(t, tg, side="right") - 1, 0, t.size - 1)   # latest reading
    calibrated = np.interp(tg, t, baro) - bias[k]
    diff = hg - calibrated
    sigma = np.sqrt(sg ** 2 + var[k] + config.sigma_m ** 2)
    return BaroCheck(time_s=t, bias_m=bias, sigma_bias_m=np.sqrt(var),
                     bias_flag=np.abs(bias) > config.max_bias_m, gnss_time_s=tg, gnss_h_m=hg,
                     baro_h_m=calibrated, disagreement_m=diff, sigma_disagreement_m=sigma,
                     gnss_flag=np.abs(diff) > config.gnss_sigma_factor * sigma)


def simulate_baro(time_s, true_h_m, *, bias_m: float, config: BaroConfig = BaroConfig(),
                  rng: np.random.Generator) -> Array:
    """Baro readings of a true height: ``h + b0 + walk + white noise``.

    Parameters
    ----------
    time_s : array_like, shape (N,)
        Reading times, s, increasing.
    true_h_m : array_like, shape (N,)
        True height, m.
    bias_m : float
        Bias at the first reading, m.
    config : BaroConfig
        Its ``sigma_m`` and ``bias_walk_mps``.
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (N,)
    """
    t = _series("time_s", time_s)
    h = _series("true_h_m", true_h_m, t.size)
    steps = np.sqrt(np.diff(t)) * config.bias_walk_mps * rng.standard_normal(t.size - 1)
    walk = np.concatenate([[0.0], np.cumsum(steps)])
    return h + bias_m + walk + config.sigma_m * rng.standard_normal(t.size)
