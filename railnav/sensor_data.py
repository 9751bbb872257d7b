"""The sensor data of one trip, and the one time reference that links them.

`SensorData` carries the recorded or simulated measurements a navigator consumes (IMU,
GNSS observations with their navigation data and augmentation, position fixes, odometer
readings, balise passages) with ``start_gps_time_s``: the GPS time of ``time_s = 0``.
`check_gnss_pair` is the rule that GNSS observations come with their navigation data,
for files (`railnav.jobs.sensor_files`) and read data alike. What the navigator runs and
assumes is `railnav.config.NavigatorConfig`'s.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnss_obs.fixes.table import FixLog
from gnss_obs.rinex_nav import RinexNav
from gnss_obs.rinex_obs import RinexObs
from railnav.errors import ConfigError
from strapdown.imu import Imu

__all__ = ["SensorData", "check_gnss_pair"]


def check_gnss_pair(obs, nav) -> None:
    """GNSS observations and navigation data (files or read) go together.

    Raises
    ------
    ConfigError
        When one is given without the other.
    """
    if (obs is None) != (nav is None):
        raise ConfigError("--obs and --nav go together: GNSS observations need their "
                          "navigation data")


@dataclass(frozen=True, eq=False)
class SensorData:
    """Measurements for one trip.

    Parameters
    ----------
    start_gps_time_s : float
        GPS time of ``time_s = 0``, s since 1980-01-06.
    imu : strapdown.Imu or None
        IMU samples (``time_s`` from the trip start); None for the GNSS-only filter.
    obs : gnss_obs.RinexObs or None
        GNSS observations; None for pure dead reckoning on the track.
    nav : gnss_obs.RinexNav or None
        Broadcast navigation data (required with `obs`).
    augmentation : gnss_obs.Augmentation or None
        Base-station corrections and precise orbits for the GNSS rows
        (`gnss_obs.augment`; its carrier-smoothed observations are `obs`).
    fixes : gnss_obs.fixes.table.FixLog or None
        GNSS position fixes with every σ (`gnss_obs.fixes.read_fixes`).
    odometer : railnav.sensors.odometer.OdometerLog or None
        Odometer readings (`railnav.sensors.odometer.read_odometer_csv`).
    balises : railnav.sensors.balises.BaliseLog or None
        Balise passages (`railnav.sensors.balises.read_balises_csv`).
    imu_log : strapdown.imu_log.ImuLog or None
        How the IMU file was read (its timing, gaps: ``summary.json``), for file runs.
    """

    start_gps_time_s: float
    imu: Imu | None = None
    obs: RinexObs | None = None
    nav: RinexNav | None = None
    augmentation: object = None
    fixes: FixLog | None = None
    odometer: object = None
    balises: object = None
    imu_log: object = None

    def __post_init__(self) -> None:
        if not np.isfinite(self.start_gps_time_s):
            raise ConfigError(f"start_gps_time_s must be finite, got {self.start_gps_time_s!r}")
        check_gnss_pair(self.obs, self.nav)
        if self.imu is None and self.obs is None and self.fixes is None:
            raise ConfigError("no sensor data: give an IMU, GNSS observations or fixes")

    @property
    def end_s(self) -> float:
        """The trip's last time, s from its start: the last IMU sample, else the last GNSS
        epoch or fix."""
        if self.imu is not None:
            return float(self.imu.time_s[-1])
        times = [float(frame["gps_time_s"].max()) for frame in (
            self.obs.table if self.obs is not None else None,
            self.fixes.table if self.fixes is not None else None)
            if frame is not None and len(frame)]
        return max(times) - self.start_gps_time_s if times else 0.0
