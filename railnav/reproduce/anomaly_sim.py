"""Truth and sensor signals of the 2021 adaptive-processing experiment (SEEDS.md §2).

The truth is the paper's (§3): constant height ``H`` (vertical speed 0), constant
horizontal velocity ``V_x = V_y``, starting at ``x = y = 0``; no acceleration. Sensors at
every ``t_k = k T`` (paper eqs. 1, 3–6):

* INS accelerations ``a + Δa (+ g on the up axis) + σ_a (2T/α_a)^½ n`` — the sample at
  ``t_k`` is the control of the step ``t_k → t_{k+1}`` (eqs. 8–13), so the truth, which has
  zero acceleration, is exactly the paper's process model;
* barometer ``H + ΔH + u``, ``u`` first-order Gauss–Markov started from its stationary
  distribution ``N(0, σ_BV²)``;
* GNSS ``x, y`` (``σ_x = σ_y``) and ``R0 + H`` (``σ_z``), plus the additive faults;
* speed sensor ``V_x, V_y`` with ``σ_V``.

The noise is drawn from the ``rng`` passed in, in a fixed order (accelerometers, baro,
GNSS horizontal, GNSS height, speed), so a seed gives one data set.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.signal import lfilter

from railnav.errors import ConfigError
from railnav.reproduce.anomaly_models import HORIZONTAL, VERTICAL, AnomalyParams
from strapdown.imu_errors import STANDARD_GRAVITY_MPS2

__all__ = ["GnssFault", "AnomalyData", "simulate_anomaly"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class GnssFault:
    """An additive error of the GNSS fix on ``start_s <= t < start_s + duration_s``.

    Attributes
    ----------
    start_s, duration_s : float
        Seconds from the start of the run; ``duration_s > 0``.
    offset_north_m, offset_east_m, offset_up_m : float
        Error added to the GNSS north, east position and height, m.
    """

    start_s: float
    duration_s: float
    offset_north_m: float = 0.0
    offset_east_m: float = 0.0
    offset_up_m: float = 0.0

    def __post_init__(self) -> None:
        values = (self.start_s, self.duration_s, self.offset_north_m, self.offset_east_m,
                  self.offset_up_m)
        if not all(np.isfinite(values)) or self.start_s < 0.0 or self.duration_s <= 0.0:
            raise ConfigError(f"GnssFault needs finite offsets, start_s >= 0 and "
                              f"duration_s > 0, got {self}")

    @property
    def end_s(self) -> float:
        """First time after the fault, s."""
        return self.start_s + self.duration_s

    def active(self, t: Array) -> Array:
        """Mask of the samples ``t (N,)`` (s) inside the fault, shape (N,)."""
        return (t >= self.start_s) & (t < self.end_s)


@dataclass(frozen=True, eq=False)
class AnomalyData:
    """One simulated run.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Time from the start, s.
    truth_horizontal : ndarray, shape (N, 6)
        True state in the ``HORIZONTAL`` layout (m, m/s, m/s²).
    truth_vertical : ndarray, shape (N, 4)
        True state in the ``VERTICAL`` layout (m, m/s, m, m/s²).
    accel_ins_mps2 : ndarray, shape (N, 3)
        INS accelerations north, east, up (up includes ``g``), m/s².
    gravity_mps2 : float
        The ``g`` in the up accelerometer, m/s².
    baro_m : ndarray, shape (N,)
        Barometric relative height, m.
    gnss_pos_m : ndarray, shape (N, 2)
        GNSS north, east position, m.
    gnss_height_m : ndarray, shape (N,)
        GNSS height ``R0 + H`` (+ fault), m.
    speed_mps : ndarray, shape (N, 2)
        Speed-sensor north, east velocity, m/s.
    gnss_fault : ndarray of bool, shape (N,)
        A fault is active.
    """

    t: Array
    truth_horizontal: Array
    truth_vertical: Array
    accel_ins_mps2: Array
    gravity_mps2: float
    baro_m: Array
    gnss_pos_m: Array
    gnss_height_m: Array
    speed_mps: Array
    gnss_fault: Array


def _truth(params: AnomalyParams, t: Array) -> tuple[Array, Array]:
    n = t.size
    horizontal = np.zeros((n, HORIZONTAL.size))
    horizontal[:, HORIZONTAL.slice("pos")] = params.velocity_mps * t[:, None]
    horizontal[:, HORIZONTAL.slice("vel")] = params.velocity_mps
    horizontal[:, HORIZONTAL.slice("accel_bias")] = params.accel_bias_mps2
    vertical = np.zeros((n, VERTICAL.size))
    vertical[:, VERTICAL.index("height")] = params.height_m
    vertical[:, VERTICAL.index("baro_bias")] = params.baro_bias_m
    vertical[:, VERTICAL.index("bias_a_up")] = params.accel_bias_mps2
    return horizontal, vertical


def _gauss_markov(rng: np.random.Generator, n: int, params: AnomalyParams) -> Array:
    """Stationary first-order Gauss–Markov samples ``u_{k+1} = φ u_k + σ(1−φ²)^½ n`` (eq. 4)."""
    drive = params.sigma_baro_drive_m * rng.standard_normal(n)
    drive[0] = params.sigma_baro_m * rng.standard_normal()
    return lfilter([1.0], [1.0, -params.baro_correlation], drive)


def simulate_anomaly(params: AnomalyParams, *, duration_s: float,
                     faults: tuple[GnssFault, ...] = (),
                     rng: np.random.Generator) -> AnomalyData:
    """Simulate truth and sensors for ``duration_s`` at the paper's rate ``1/T``.

    Parameters
    ----------
    params : AnomalyParams
    duration_s : float
        Length of the run, s (> ``params.dt``).
    faults : tuple of GnssFault
        Additive GNSS errors (they add up where they overlap).
    rng : numpy.random.Generator

    Returns
    -------
    AnomalyData

    Raises
    ------
    ConfigError
        ``duration_s`` not finite or shorter than one step.
    """
    if not (np.isfinite(duration_s) and duration_s > params.dt):
        raise ConfigError(f"duration_s must be a finite number > {params.dt} s, got {duration_s}")
    t = params.dt * np.arange(int(round(duration_s / params.dt)) + 1)
    n = t.size
    horizontal, vertical = _truth(params, t)
    accel = np.zeros((n, 3))
    accel[:, :2] = horizontal[:, HORIZONTAL.slice("accel_bias")]
    accel[:, 2] = vertical[:, VERTICAL.index("bias_a_up")] + STANDARD_GRAVITY_MPS2
    accel += params.sigma_accel_sample_mps2 * rng.standard_normal((n, 3))
    height = vertical[:, VERTICAL.index("height")]
    baro = height + vertical[:, VERTICAL.index("baro_bias")] + _gauss_markov(rng, n, params)
    gnss_pos = horizontal[:, HORIZONTAL.slice("pos")] \
        + params.sigma_gnss_horizontal_m * rng.standard_normal((n, 2))
    gnss_height = params.gnss_height_offset_m + height \
        + params.sigma_gnss_height_m * rng.standard_normal(n)
    speed = horizontal[:, HORIZONTAL.slice("vel")] \
        + params.sigma_speed_mps * rng.standard_normal((n, 2))
    any_fault = np.zeros(n, dtype=bool)
    for fault in faults:
        on = fault.active(t)
        gnss_pos[on] += (fault.offset_north_m, fault.offset_east_m)
        gnss_height[on] += fault.offset_up_m
        any_fault |= on
    return AnomalyData(t=t, truth_horizontal=horizontal, truth_vertical=vertical,
                       accel_ins_mps2=accel, gravity_mps2=STANDARD_GRAVITY_MPS2, baro_m=baro,
                       gnss_pos_m=gnss_pos, gnss_height_m=gnss_height, speed_mps=speed,
                       gnss_fault=any_fault)
