"""The constrained filter's rows of the vehicle body: attitude against the track, standstill.

Two optional streams of the run's epoch schedule (`BODY_STREAMS`), both off by default:

* ``attitude`` (``NavigatorConfig.track_attitude``): the attitude rows every
  `railnav.filters.attitude_config.TrackAttitudeConfig.interval_s`
  (`railnav.filters.attitude_rows`), with the mounting states (`body_states`);
* ``standstill`` (``NavigatorConfig.standstill``): zero speed and zero yaw rate at each
  still window of the IMU (`railnav.filters.standstill`, `railnav.filters.standstill_rows`).

`body_stream_epochs` makes the streams from the run's IMU samples (the navigator,
`railnav.navigation.navigator.trip_samples`); `BodyRows` gives an epoch's rows to the
filter's fault screen, ``row`` by row. Only the constrained filter takes them (it has the
attitude the rows observe).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from railnav.errors import ConfigError
from railnav.filters.attitude_config import MOUNT_STATES
from railnav.filters.attitude_rows import AttitudeRowBuilder, attitude_epoch_times
from railnav.filters.sensor_rows import SensorRows
from railnav.filters.standstill import detect_standstill
from railnav.filters.standstill_rows import StandstillRowBuilder

__all__ = ["BODY_STREAMS", "AttitudeEpochs", "body_states", "body_densities", "mount_truth",
           "body_stream_epochs", "BodyRows"]

Array = npt.NDArray[np.float64]

#: The schedule's streams of the body rows.
BODY_STREAMS = ("attitude", "standstill")


@dataclass(frozen=True, eq=False)
class AttitudeEpochs:
    """The attitude rows' epochs, s from the trip start."""

    time_s: Array

    def __len__(self) -> int:
        return self.time_s.size


def body_states(config) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """The mounting block ``(("mount", MOUNT_STATES),)`` with ``config.track_attitude``."""
    return (("mount", MOUNT_STATES),) if config.track_attitude is not None else ()


def body_densities(config) -> tuple[float, ...]:
    """Spectral densities of `body_states`: 0 (random constants; the model floors them at a
    tiny positive value)."""
    return tuple(0.0 for _, names in body_states(config) for _ in names)


def mount_truth(truth, n: int) -> dict[str, Array]:
    """The true mounting angles of a car-body truth
    (`railnav.simulation.car_body_motion.CarBodyTruth`) as state values, (n,) each; empty
    for a truth without them."""
    mount = getattr(truth, "mount_rad", None)
    if mount is None:
        return {}
    return {name: np.full(n, float(value)) for name, value in zip(MOUNT_STATES, mount)}


def body_stream_epochs(config, t: Array, u: Array, *, odometer=None, fixes=None) -> dict:
    """``{"attitude": AttitudeEpochs, "standstill": StandstillEpochs}`` of what `config`
    asks for (empty by default).

    Parameters
    ----------
    config : railnav.NavigatorConfig
    t : ndarray, shape (M,)
        The run's IMU sample times, s from the trip start.
    u : ndarray, shape (M, 6)
        Their ``[f_b, ω_ib_b]``.
    odometer, fixes : optional
        The run's odometer readings and GNSS fixes (the standstill vetoes).

    Raises
    ------
    ConfigError
        The rows asked of a filter other than the constrained one.
    """
    wanted = [name for name, value in (("track_attitude", config.track_attitude),
                                       ("standstill", config.standstill)) if value is not None]
    if not wanted:
        return {}
    if config.filter != "constrained":
        raise ConfigError(f"{' and '.join(wanted)}: only with the constrained filter "
                          f"(not {config.filter})")
    out = {}
    if config.track_attitude is not None:
        times = attitude_epoch_times((float(t[0]), float(t[-1])), config.track_attitude)
        out["attitude"] = AttitudeEpochs(times)
    if config.standstill is not None:
        out["standstill"], _ = detect_standstill(t, u, config.standstill, config.imu,
                                                 odometer=odometer, fixes=fixes)
    return out


class BodyRows(SensorRows):
    """The attitude and standstill rows of a constrained filter (module docstring; the
    epochs' rows come from `railnav.filters.sensor_rows.SensorRows.parts`).

    Parameters
    ----------
    layout : ekf.StateLayout
    track : trackmodel.Track
    config : railnav.NavigatorConfig
    streams : dict
        `body_stream_epochs`' result.
    """

    modes = {stream: "row" for stream in BODY_STREAMS}

    def __init__(self, layout, track, config, streams: dict) -> None:  # noqa: D107
        self.builders = {}
        if "attitude" in streams:
            # no pitch row where the grade is unknown (railnav.filters.grade_noise)
            self.builders["attitude"] = AttitudeRowBuilder(
                layout, track, config.track_attitude, use_pitch=config.grade_sigma_rad == 0.0)
        if "standstill" in streams:
            self.builders["standstill"] = StandstillRowBuilder(layout, track,
                                                               streams["standstill"],
                                                               config.standstill)
