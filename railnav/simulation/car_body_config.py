"""The settings of a simulated car body's motion (`CarBodyMotion`), light to import (the
scenario table is read without CasADi); the simulation is `railnav.simulation.car_body_motion`,
whose docstring gives the model and the numbers.
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

__all__ = ["CarBodyMotion", "DEFAULT_SUSPENSION_SIGMA_RAD"]


@dataclass(frozen=True)
class CarBodyMotion:
    """How the simulated car body moves on its track (module docstring).

    Parameters
    ----------
    bogie_spacing_m : float
        Bogie pivot spacing, m (> 0).
    imu_offset_m : float
        The IMU (the reference point) ahead of the body centre, m (|d| <= b/2).
    suspension_sigma_rad : (float, float, float)
        1σ yaw, pitch, roll of the suspension at speed, rad (>= 0).
    suspension_frequency_hz : float
        Natural frequency of the suspension's oscillators, Hz (> 0).
    suspension_damping : float
        Their damping ratio, in (0, 1).
    full_motion_speed_mps : float
        ``v_f`` of the amplitude's speed factor, m/s (> 0).
    mount_sigma_rad : float
        1σ of each mounting angle, rad (>= 0).
    """

    bogie_spacing_m: float = DEFAULT_BOGIE_SPACING_M
    imu_offset_m: float = DEFAULT_IMU_OFFSET_M
    suspension_sigma_rad: tuple[float, float, float] = DEFAULT_SUSPENSION_SIGMA_RAD
    suspension_frequency_hz: float = DEFAULT_SUSPENSION_FREQUENCY_HZ
    suspension_damping: float = DEFAULT_SUSPENSION_DAMPING
    full_motion_speed_mps: float = DEFAULT_FULL_MOTION_SPEED_MPS
    mount_sigma_rad: float = math.radians(1.0)

    def __post_init__(self) -> None:
        sigma = tuple(float(v) for v in self.suspension_sigma_rad)
        checks = [("bogie_spacing_m", self.bogie_spacing_m > 0),
                  ("imu_offset_m", abs(self.imu_offset_m) <= 0.5 * self.bogie_spacing_m),
                  ("suspension_sigma_rad", len(sigma) == 3 and min(sigma) >= 0),
                  ("suspension_frequency_hz", self.suspension_frequency_hz > 0),
                  ("suspension_damping", 0 < self.suspension_damping < 1),
                  ("full_motion_speed_mps", self.full_motion_speed_mps > 0),
                  ("mount_sigma_rad", 0 <= self.mount_sigma_rad < 0.2)]
        values = [self.bogie_spacing_m, self.imu_offset_m, *sigma, self.suspension_frequency_hz,
                  self.suspension_damping, self.full_motion_speed_mps, self.mount_sigma_rad]
        if not all(math.isfinite(v) for v in values):
            raise ConfigError("car body motion: every value must be finite")
        for name, ok in checks:
            if not ok:
                raise ConfigError(f"car body motion: bad {name} ({getattr(self, name)!r}); "
                                  "see railnav.simulation.car_body_motion.CarBodyMotion")
        object.__setattr__(self, "suspension_sigma_rad", sigma)


