"""A trip's railway sensors for the navigator: odometer and balise epochs, the IMU's arm.

`track_sensor_epochs` cuts the odometer readings and balise passages of `SensorData` to
the run (`railnav.filters.odometer_epochs.OdometerEpochs`,
`railnav.filters.balise_epochs.BaliseEpochs`: times from the trip start, σ, balises
projected on the track), the streams of the run's epoch schedule; `imu_at_reference` moves
the IMU's specific force to the reference point when the IMU has a lever arm
(`strapdown.lever_arm`, `railnav.filters.track_frame.LeverArms.imu_m`).
"""
from __future__ import annotations

import numpy as np

from railnav.errors import RailnavError
from railnav.filters.balise_epochs import BaliseEpochs
from railnav.filters.odometer_epochs import OdometerEpochs

__all__ = ["track_sensor_epochs", "imu_at_reference"]


def track_sensor_epochs(data, config, track, *, span_s: tuple[float, float]) -> dict:
    """``{"odometer": OdometerEpochs, "balises": BaliseEpochs}`` of the sensors `data` has.

    Parameters
    ----------
    data : railnav.sensor_data.SensorData
    config : railnav.NavigatorConfig
        Its ``odometer_model`` and ``balise_model``.
    track : trackmodel.Track or None
        Projects balises given as coordinates (needed with balises).
    span_s : (float, float)
        The run's first and last sample, s from the trip start.

    Raises
    ------
    railnav.errors.ConfigError
        A sensor file whose times miss the run, a balise off the track.
    """
    out = {}
    if data.odometer is not None:
        out["odometer"] = OdometerEpochs.from_log(data.odometer,
                                                  start_gps_time_s=data.start_gps_time_s,
                                                  config=config.odometer_model, span_s=span_s)
    if data.balises is not None:
        if track is None:
            raise RailnavError("balise passages need the run's track")
        out["balises"] = BaliseEpochs.from_log(data.balises, track,
                                               start_gps_time_s=data.start_gps_time_s,
                                               config=config.balise_model, span_s=span_s)
    return out


def imu_at_reference(imu, config):
    """`imu` moved from its lever arm to the reference point (itself without an arm)."""
    arm = np.asarray(config.lever_arms.imu_m, dtype=float)
    if imu is None or not arm.any():
        return imu
    from strapdown.lever_arm import move_specific_force
    return move_specific_force(imu, -arm)
