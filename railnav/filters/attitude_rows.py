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
  `railnav.filters.suspension_noise.DEFAULT_SUSPENSION_SIGMA_RAD`). Its rates, sampled
  by the IMU and interpolated by the filter, also leave the attitude a random walk between
  the samples, which the filter takes as more gyro noise whenever these rows are on
  (`railnav.filters.suspension_noise`: for a tactical IMU it outweighs the gyros' own).

Rows, at every ``interval_s`` (default 2 s: the simulated suspension, a 1-Hz oscillator with
damping 0.3, has lost its correlation by then, ρ(2 s) = 0.02; the rows are treated as
white), ``z = 0`` and::

    C_body_n = C_b_n(ψ, θ, φ) M(m)ᵀ  →  (ψ_b, θ_b, φ_b)   (strapdown.euler convention;
                                                         M = strapdown.euler.relative_dcm)
    h_yaw   = wrap(ψ_b − A(s) − δψ(s)),   h_pitch = θ_b − ϑ(s) − δθ(s),   h_roll = φ_b

with the track and the chord linearized about the prior's ``s₀`` (``A₀ + A'(s − s₀)``,
``δψ₀ + δψ'(s − s₀)``, the same for the pitch), so that ``∂h/∂s`` is the track's.

**When s is uncertain** (a GNSS outage), that line is only good within a few metres of a
curve's or a vertical curve's onset: with σ_s = 20 m at the entry of R 500 m, the
azimuth over ±σ_s bends by 40 mrad against the yaw row's 1 mrad. A row taken at face value
then turns the attitude (or drags ``s``) by the mismatch — measured: a MEMS 300-s outage on
``curvy`` ended 5.1 km off with σ_s 6 m. The rows therefore take the chord's azimuth and
elevation ``g(s)`` over the prior ``N(s₀, σ_s²)``
(`railnav.filters.geometry_noise.angle_statistics`): above
`railnav.filters.geometry_noise.STATISTICAL_MIN_SIGMA_M` the line is the statistical
linearization (mean and regression slope over the prior; the chord parameters then 0, the
line carries them), and the part the line leaves out, ``E[(g − line)²]``, is added to the
row's variance. That remainder is a function of where the train is against the feature
and of the error of ``s``, so it repeats from row to row while the train crosses the
prior's window: it is held for ``T_c = 2 σ_s/|v|``
(`railnav.filters.geometry_noise.remainder_correlation_s`) and the added variance is
multiplied by ``max(1, T_c/interval_s)``, the rows' count over one correlation time (the
same reasoning as the curvature row's density). With GNSS (σ_s < 1 m) and away from the
features both vanish and the rows are as before. One
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
from railnav.filters.car_body import chord_angles, chord_offsets
from railnav.filters.geometry_noise import (STATISTICAL_MIN_SIGMA_M, angle_statistics,
                                            remainder_correlation_s)
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
    use_pitch : bool
        With the pitch row; False where the track's grade is unknown (a network without
        heights, `railnav.filters.grade_noise`: the row would hold the body's pitch to the
        level track's, an error of the whole grade).
    """

    def __init__(self, layout: StateLayout, track, config: TrackAttitudeConfig, *,
                 use_pitch: bool = True) -> None:
        self.track, self.config = track, config
        self.model = build_attitude_rows(layout)
        self.i_s, self.i_v = layout.index("s"), layout.index("v")
        self.axes = tuple(k for k, used in enumerate((True, use_pitch, config.use_roll))
                          if used)

    def _chord(self, s: Array, azimuth0: float) -> Array:
        """The chord's azimuth (relative to `azimuth0`, wrapped) and elevation at ``s``,
        shape (K, 2)."""
        yaw, pitch = chord_angles(self.track, s, bogie_spacing_m=self.config.bogie_spacing_m,
                                  imu_offset_m=self.config.imu_offset_m)
        return np.column_stack([np.angle(np.exp(1j * (yaw - azimuth0))), pitch])

    def geometry(self, s0: float, sigma_s_m: float, speed_mps: float
                 ) -> tuple[list[float] | None, Array]:
        """What an uncertain ``s`` does to the rows (module docstring): the statistical
        line's ``(azimuth, elevation, azimuth_rate, elevation_rate)`` (None: σ_s small, the
        local expansion is kept) and the variance added to the yaw and pitch rows, rad²."""
        azimuth0 = float(self.track.at(s0).azimuth)
        value, slope, variance = angle_statistics(lambda s: self._chord(s, azimuth0), s0,
                                                  sigma_s_m)
        t_c = remainder_correlation_s(sigma_s_m=sigma_s_m, speed_mps=abs(speed_mps),
                                      step_s=self.config.interval_s)
        variance = variance * max(1.0, t_c / self.config.interval_s)
        if sigma_s_m <= STATISTICAL_MIN_SIGMA_M:
            return None, variance
        return [azimuth0 + float(value[0]), float(value[1]), float(slope[0]),
                float(slope[1])], variance

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
        R = np.array([self.config.sigma_rad[k] ** 2 for k in self.axes])
        if P is not None:
            sigma_s = float(np.sqrt(max(P[self.i_s, self.i_s], 0.0)))
            line, added = self.geometry(s0, sigma_s, float(x[self.i_v]))
            if line is not None:
                common[:4] = line
                common[4:8] = [0.0, 0.0, 0.0, 0.0]
            R += np.array([added[k] if k < 2 else 0.0 for k in self.axes])  # yaw, pitch
        p = np.array([[*np.eye(3)[k], *common] for k in self.axes])
        obs = Observation(self.model, np.zeros((len(self.axes), 1)), R, p)
        return ([obs], np.full(len(self.axes), ATTITUDE_SV, dtype=object),
                np.array([ATTITUDE_ROW_KINDS[k] for k in self.axes], dtype=object))
