"""The settings of the attitude rows (`TrackAttitudeConfig`) and the mounting states' names,
light to import (`railnav.config` reads them); the model is `railnav.filters.attitude_rows`,
whose docstring gives it and its numbers.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from railnav.errors import ConfigError
from railnav.filters.car_body import DEFAULT_BOGIE_SPACING_M, DEFAULT_IMU_OFFSET_M
from railnav.filters.suspension_noise import (DEFAULT_FULL_MOTION_SPEED_MPS,
                                              DEFAULT_SUSPENSION_DAMPING,
                                              DEFAULT_SUSPENSION_FREQUENCY_HZ,
                                              DEFAULT_SUSPENSION_SIGMA_RAD)

__all__ = ["TrackAttitudeConfig", "MOUNT_STATES"]

#: The mounting states: the IMU's yaw, pitch, roll in body axes, rad.
MOUNT_STATES = ("mount_yaw", "mount_pitch", "mount_roll")


@dataclass(frozen=True)
class TrackAttitudeConfig:
    """What the attitude rows assume (module docstring).

    Parameters
    ----------
    sigma_rad : (float, float, float)
        1σ of the body's yaw, pitch, roll about the chord (the suspension), rad (> 0).
    interval_s : float
        Time between rows, s (> 0).
    mount_sigma_rad : float
        Prior 1σ of each mounting angle, rad (> 0); the states are random constants.
    bogie_spacing_m, imu_offset_m : float
        The vehicle's chord geometry (`railnav.filters.car_body`); ``imu_offset_m`` is the
        reference point ahead of the body centre.
    use_roll : bool
        Include the roll row.
    suspension_frequency_hz, suspension_damping : float
        Natural frequency (Hz, > 0) and damping ratio (in (0, 1)) of the suspension's
        oscillators: with `sigma_rad` they set the white angular acceleration whose
        sampling error the gyros get as extra noise (`railnav.filters.suspension_noise`).
    full_motion_speed_mps : float
        ``v_f`` of the suspension amplitude's factor ``1 − exp(−(v/v_f)²)``, m/s (> 0).
    """

    sigma_rad: tuple[float, float, float] = DEFAULT_SUSPENSION_SIGMA_RAD
    interval_s: float = 2.0
    mount_sigma_rad: float = math.radians(1.0)
    bogie_spacing_m: float = DEFAULT_BOGIE_SPACING_M
    imu_offset_m: float = DEFAULT_IMU_OFFSET_M
    use_roll: bool = True
    suspension_frequency_hz: float = DEFAULT_SUSPENSION_FREQUENCY_HZ
    suspension_damping: float = DEFAULT_SUSPENSION_DAMPING
    full_motion_speed_mps: float = DEFAULT_FULL_MOTION_SPEED_MPS

    def __post_init__(self) -> None:
        sigma = tuple(float(v) for v in self.sigma_rad)
        ok = (len(sigma) == 3 and all(math.isfinite(v) and v > 0 for v in sigma)
              and all(math.isfinite(v) and v > 0 for v in (self.interval_s,
                                                          self.mount_sigma_rad,
                                                          self.bogie_spacing_m))
              and math.isfinite(self.imu_offset_m)
              and abs(self.imu_offset_m) <= 0.5 * self.bogie_spacing_m
              and all(math.isfinite(v) and v > 0 for v in (self.suspension_frequency_hz,
                                                          self.full_motion_speed_mps))
              and math.isfinite(self.suspension_damping) and 0 < self.suspension_damping < 1)
        if not ok:
            raise ConfigError(f"track attitude: sigma_rad (3 values), interval_s, "
                              f"mount_sigma_rad, bogie_spacing_m, suspension_frequency_hz "
                              f"and full_motion_speed_mps must be finite and > 0, "
                              f"suspension_damping in (0, 1), "
                              f"|imu_offset_m| <= bogie_spacing_m / 2; got {self!r}")
        object.__setattr__(self, "sigma_rad", sigma)
