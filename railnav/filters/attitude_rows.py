r"""Attitude follows the track: a pseudo-observation of the body's attitude against the track.

A rail vehicle's body is held by the track: its yaw follows the track azimuth, its pitch the
grade and its roll the cant (0: the track model has none), up to

* the **mounting** of the IMU on the body: three small constant angles ``m`` (yaw, pitch,
  roll of the IMU in body axes), states ``mount_yaw, mount_pitch, mount_roll``
  (`MOUNT_STATES`) appended to the layout like the odometer's scale
  (`railnav.filters.sensor_rows.sensor_states`): random constants with the prior
  N(0, ``mount_sigma_rad``²), default 1°;
* the **chord**: the body is the chord between its bogie pivots
  (`railnav.filters.car_body`: ``δψ(s), δθ(s)``, −b/(2R) over the leading bogie), a known
  function of ``s`` given the vehicle's geometry;
* the **suspension**: the body's small yaw, pitch and roll on its springs, the rows' noise
  (1σ `TrackAttitudeConfig.sigma_rad`, default 1 / 2 / 3 mrad, the simulator's
  `railnav.simulation.car_body_config.DEFAULT_SUSPENSION_SIGMA_RAD`).

Rows, at every ``interval_s`` (default 2 s: the simulated suspension, a 1-Hz oscillator with
damping 0.3, has lost its correlation by then, ρ(2 s) = 0.02; the rows are treated as
white), ``z = 0`` and::

    C_body_n = C_b_n(ψ, θ, φ) M(m)ᵀ  →  (ψ_b, θ_b, φ_b)   (strapdown.euler convention;
                                                         M = strapdown.euler.relative_dcm)
    h_yaw   = wrap(ψ_b − A(s) − δψ(s)),   h_pitch = θ_b − ϑ(s) − δθ(s),   h_roll = φ_b

with the track and the chord linearized about the prior's ``s₀`` (``A₀ + A'(s − s₀)``,
``δψ₀ + δψ'(s − s₀)``, the same for the pitch), so that ``∂h/∂s`` is the track's. One
CasADi expression; its Jacobian (`ekf.MeasurementModel`) is tested against central
differences. Each angle is one scalar row (a selector in the row parameters) screened
``row`` by row at the prior (`railnav.filters.fault_detection`), ``sv`` `ATTITUDE_SV`,
kinds `ATTITUDE_ROW_KINDS`.

Not modelled: a body's quasi-static roll outwards in curves (its flexibility times the cant
deficiency, ~1° at 25 m/s on R 500 m for a flexibility of 0.2); with real vehicles the roll
row's σ should cover it, or the roll row be left out (``use_roll=False``).
"""
from __future__ import annotations

import functools

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.model import MeasurementModel
from ekf.update import Observation
from railnav.filters.attitude_config import MOUNT_STATES, TrackAttitudeConfig
from railnav.filters.car_body import chord_offsets
from strapdown.euler import C_b_n, relative_dcm

__all__ = ["TrackAttitudeConfig", "MOUNT_STATES", "ATTITUDE_SV", "ATTITUDE_ROW_KINDS",
           "build_attitude_rows", "AttitudeRowBuilder", "attitude_epoch_times",
           "ATTITUDE_PARAMETERS"]

Array = npt.NDArray[np.float64]

#: ``innovations.csv`` ``sv`` and kinds of the rows.
ATTITUDE_SV = "track_attitude"
ATTITUDE_ROW_KINDS = ("att_yaw", "att_pitch", "att_roll")
#: Row parameters: a selector of the angle, then the track and the chord at ``s₀``.
ATTITUDE_PARAMETERS = ("sel_yaw", "sel_pitch", "sel_roll", "azimuth", "elevation",
                       "azimuth_rate_1pm", "elevation_rate_1pm", "chord_yaw", "chord_pitch",
                       "chord_yaw_rate_1pm", "chord_pitch_rate_1pm", "s0")


def _wrap(a):
    return ca.atan2(ca.sin(a), ca.cos(a))


@functools.lru_cache(maxsize=None)
def build_attitude_rows(layout: StateLayout) -> MeasurementModel:
    """The attitude row model of a layout with ``yaw, pitch, roll, s`` (and the mounting
    states when it has them)."""
    x = ca.SX.sym("x", layout.size)
    p = ca.SX.sym("p", len(ATTITUDE_PARAMETERS))
    q = {name: p[i] for i, name in enumerate(ATTITUDE_PARAMETERS)}
    yaw, pitch, roll, s = (x[layout.index(n)] for n in ("yaw", "pitch", "roll", "s"))
    if MOUNT_STATES[0] in layout.names:
        m = [x[layout.index(n)] for n in MOUNT_STATES]
        C = ca.mtimes(C_b_n(yaw, pitch, roll), relative_dcm(*m).T)
    else:
        C = C_b_n(yaw, pitch, roll)
    yaw_b = ca.atan2(C[0, 0], C[1, 0])
    pitch_b = ca.asin(C[2, 0])
    roll_b = ca.atan2(C[2, 1], C[2, 2])
    ds = s - q["s0"]
    r_yaw = _wrap(yaw_b - q["azimuth"] - q["azimuth_rate_1pm"] * ds - q["chord_yaw"]
                  - q["chord_yaw_rate_1pm"] * ds)
    r_pitch = (pitch_b - q["elevation"] - q["elevation_rate_1pm"] * ds - q["chord_pitch"]
               - q["chord_pitch_rate_1pm"] * ds)
    h = q["sel_yaw"] * r_yaw + q["sel_pitch"] * r_pitch + q["sel_roll"] * roll_b
    return MeasurementModel.from_expression(x, p, h, "track_attitude")


def attitude_epoch_times(span_s: tuple[float, float], config: TrackAttitudeConfig) -> Array:
    """Row times, s from the trip start: every ``interval_s`` after the run's first sample."""
    start, end = span_s
    return start + config.interval_s * np.arange(1, int((end - start) // config.interval_s) + 1)


class AttitudeRowBuilder:
    """The attitude rows of each epoch at the prior.

    Parameters
    ----------
    layout : ekf.StateLayout
    track : trackmodel.Track
    config : TrackAttitudeConfig
    """

    def __init__(self, layout: StateLayout, track, config: TrackAttitudeConfig) -> None:
        self.track, self.config = track, config
        self.model = build_attitude_rows(layout)
        self.i_s = layout.index("s")
        self.axes = (0, 1, 2) if config.use_roll else (0, 1)

    def observations(self, index: int, x: Array, P: Array):
        """``(observations, sv, kind)`` of the rows at the prior ``(x, P)`` (index unused:
        every epoch of the stream is alike)."""
        s0 = float(np.clip(x[self.i_s], 0.0, self.track.length_m))
        pt = self.track.at(s0)
        c = chord_offsets(self.track, np.array([s0]), bogie_spacing_m=self.config.bogie_spacing_m,
                          imu_offset_m=self.config.imu_offset_m)
        common = [float(pt.azimuth), float(pt.elevation), float(pt.curvature_1pm),
                  float(pt.elevation_rate), float(c.yaw[0]), float(c.pitch[0]),
                  float(c.yaw_rate_1pm[0]), float(c.pitch_rate_1pm[0]), s0]
        p = np.array([[*np.eye(3)[k], *common] for k in self.axes])
        R = np.array([self.config.sigma_rad[k] ** 2 for k in self.axes])
        obs = Observation(self.model, np.zeros((len(self.axes), 1)), R, p)
        return ([obs], np.full(len(self.axes), ATTITUDE_SV, dtype=object),
                np.array([ATTITUDE_ROW_KINDS[k] for k in self.axes], dtype=object))
