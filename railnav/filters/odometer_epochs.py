r"""Odometer readings for a filter: the model's settings and the trip's readings.

* `OdometerConfig`: what the odometer rows (`railnav.filters.odometer_rows`) assume: the
  reading's white noise, the scale-factor state's prior and drift, and the standstill rule;
* `OdometerEpochs`: an odometer file's readings (`railnav.sensors.odometer`) cut to the
  run, times from the trip start, each with its total σ (the file's or the model's, and the
  quantization of a pulse count in quadrature, ``q/√12`` for a step ``q``) and whether it
  is a **standstill** reading: no motion (a speed at or below
  `OdometerConfig.standstill_speed_mps`, or no pulse) for at least
  `OdometerConfig.standstill_window_s`. A standstill reading becomes a zero-speed row of
  σ ``max(zero_speed_sigma_mps, threshold/√3, L/(window √3))`` (``L`` the pulse length: no
  pulse over the window bounds ``|v| < L/window``; uniform within the bound).

A fault of the wheel (slip in traction, slide in braking) is not the reader's business:
the rows are screened at the prior like every measurement (`railnav.filters.odometer_rows`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from railnav.defaults import DEFAULT_ODOMETER_SIGMA_MPS
from railnav.errors import ConfigError

__all__ = ["OdometerConfig", "OdometerEpochs", "SCALE_STATE"]

Array = npt.NDArray[np.float64]

#: The odometer's scale-factor state (dimensionless: the reading is ``(1 + k) |v|``).
SCALE_STATE = "odo_scale"


@dataclass(frozen=True)
class OdometerConfig:
    """What the odometer rows assume.

    Parameters
    ----------
    sigma_speed_mps : float
        1σ white noise of a reading without a σ of its own, m/s (> 0). Default 0.05 m/s:
        a tachometer's jitter and the vehicle's pitching over the wheel.
    estimate_scale : bool
        Add the scale-factor state ``odo_scale`` (reading = ``(1 + k) |v|``).
    scale_sigma : float
        Prior 1σ of ``k`` (> 0). Default 0.02: a nominal circumference within 2 % of the
        worn wheel's (wheels wear from ~920 to ~840 mm in service, and are re-entered at
        each re-profiling).
    scale_walk_per_rts : float
        Random walk of ``k``, 1/√s (>= 0): 1e-5 lets it wander 0.06 % in an hour
        (wear is far slower; rail conditions change the effective rolling radius a little).
    standstill_window_s : float
        No motion for this long makes a standstill reading, s (> 0).
    zero_speed_sigma_mps : float
        Smallest σ of a zero-speed row, m/s (> 0).
    standstill_speed_mps : float
        Readings at or below this are "no motion" (a speed sensor's dead band), m/s (>= 0).
    """

    sigma_speed_mps: float = DEFAULT_ODOMETER_SIGMA_MPS
    estimate_scale: bool = True
    scale_sigma: float = 0.02
    scale_walk_per_rts: float = 1e-5
    standstill_window_s: float = 1.0
    zero_speed_sigma_mps: float = 0.005
    standstill_speed_mps: float = 0.0

    def __post_init__(self) -> None:
        for name, low_ok in (("sigma_speed_mps", False), ("scale_sigma", False),
                             ("scale_walk_per_rts", True), ("standstill_window_s", False),
                             ("zero_speed_sigma_mps", False), ("standstill_speed_mps", True)):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value)
                    and (value >= 0 if low_ok else value > 0)):
                raise ConfigError(f"{name} must be a finite number {'>=' if low_ok else '>'}"
                                  f" 0, got {value!r}")


@dataclass(frozen=True, eq=False)
class OdometerEpochs:
    """The readings of a run (arrays of N readings, in time order; module docstring).

    Attributes
    ----------
    time_s : ndarray
        s from the trip start.
    speed_mps : ndarray
        Speed magnitude, m/s.
    direction : ndarray
        +1 / −1 relative to the track's +s, 0: unknown.
    sigma_mps : ndarray
        Total 1σ of a moving reading, m/s.
    standstill : ndarray of bool
    zero_sigma_mps : ndarray
        1σ of the zero-speed row of a standstill reading, m/s.
    path : str
    """

    time_s: Array
    speed_mps: Array
    direction: Array
    sigma_mps: Array
    standstill: npt.NDArray[np.bool_]
    zero_sigma_mps: Array
    path: str

    def __len__(self) -> int:
        return self.time_s.size

    @classmethod
    def from_log(cls, log, *, start_gps_time_s: float, config: OdometerConfig,
                 span_s: tuple[float, float]) -> "OdometerEpochs":
        """The readings of `log` (`railnav.sensors.odometer.OdometerLog`) within the run.

        Parameters
        ----------
        log : railnav.sensors.odometer.OdometerLog
        start_gps_time_s : float
            GPS time of the trip start, s.
        config : OdometerConfig
        span_s : (float, float)
            The run's first and last sample, s from the trip start.

        Raises
        ------
        ConfigError
            No reading within the run (located at the file).
        """
        t = log.relative_time_s(start_gps_time_s)
        keep = (t >= span_s[0]) & (t <= span_s[1])
        if not keep.any():
            raise ConfigError(f"odometer times [{t[0]:.1f}, {t[-1]:.1f}] s miss the run "
                              f"[{span_s[0]:.1f}, {span_s[1]:.1f}] s (from the trip start)",
                              path=log.path)
        t, speed, res = t[keep], log.speed_mps[keep], log.resolution_mps[keep]
        sigma = np.where(np.isfinite(log.sigma_mps[keep]), log.sigma_mps[keep],
                         config.sigma_speed_mps)
        still = speed <= config.standstill_speed_mps
        standstill = still & (t - _still_since(t, still) >= config.standstill_window_s)
        zero = max(config.zero_speed_sigma_mps, config.standstill_speed_mps / math.sqrt(3),
                   log.pulse_length_m / (config.standstill_window_s * math.sqrt(3)))
        return cls(time_s=t, speed_mps=speed, direction=log.direction[keep],
                   sigma_mps=np.sqrt(sigma ** 2 + res ** 2 / 12.0), standstill=standstill,
                   zero_sigma_mps=np.full(t.size, zero), path=log.path)


def _still_since(t: Array, still: npt.NDArray[np.bool_]) -> Array:
    """For each reading, the time of the first reading of its run of still readings (the
    reading's own time where it moves)."""
    start = np.where(still & ~np.concatenate([[False], still[:-1]]), t, np.nan)
    start = np.where(still, start, t)
    idx = np.where(np.isfinite(start), np.arange(t.size), 0)
    np.maximum.accumulate(idx, out=idx)
    return start[idx]
