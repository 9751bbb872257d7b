r"""Standstill rows: zero speed, and zero angular rate about the track normal.

At each still window (`railnav.filters.standstill.detect_standstill`), at its last sample:

* **zero speed**: ``z = 0``, ``h = v``, 1σ `StandstillConfig.zero_speed_sigma_mps`;
* **zero angular rate in yaw about the track normal** (with gyro bias states and
  `StandstillConfig.yaw_rate_update`): the window's mean gyro reading ``ω̄`` corrected by the
  bias estimate and the Earth rate, about the track normal in body axes, is zero::

      z = 0,   h = n_bᵀ (ω̄ − b_g) − n_bᵀ C_n_b ω_ie_n,    n_b = C_n_b n_n

  with ``n_n`` the track's normal at the prior's ``s`` (the third column of the track
  frame, `strapdown.euler.C_b_n` at ``(A, ϑ, 0)``) and ``C_n_b`` from the state's attitude;
  1σ the window mean's white noise, ``σ_ω/√W`` (`StandstillEpochs.omega_sigma_radps`). The
  same gyro samples drive the propagation; the row adds what they cannot: that the vehicle
  does not turn.

``sv`` `STANDSTILL_SV`, kinds `STANDSTILL_ROW_KINDS`, screened ``row`` by row at the prior:
a zero-speed row at a prior many σ from zero (a false detection while cruising) is rejected
and counted in ``innovations.csv``.
"""
from __future__ import annotations

import functools

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.model import MeasurementModel
from ekf.update import Observation
from strapdown.euler import C_b_n
from strapdown.frames import omega_ie_n

__all__ = ["STANDSTILL_SV", "STANDSTILL_ROW_KINDS", "build_zero_speed_rows",
           "build_zero_rate_rows", "StandstillRowBuilder"]

Array = npt.NDArray[np.float64]

STANDSTILL_SV = "standstill"
STANDSTILL_ROW_KINDS = ("zero_speed", "zero_yaw_rate")
_GYRO_BIAS = ("b_gx", "b_gy", "b_gz")


@functools.lru_cache(maxsize=None)
def build_zero_speed_rows(layout: StateLayout) -> MeasurementModel:
    """``h = v`` on a layout with ``v``."""
    x = ca.SX.sym("x", layout.size)
    return MeasurementModel.from_expression(x, ca.SX.sym("p", 1), x[layout.index("v")],
                                            "zero_speed")


@functools.lru_cache(maxsize=None)
def build_zero_rate_rows(layout: StateLayout) -> MeasurementModel:
    """The zero angular rate row (module docstring); parameters ``[ω̄ (3), n_n (3), ω_ie_n
    (3)]``."""
    x = ca.SX.sym("x", layout.size)
    p = ca.SX.sym("p", 9)
    C = C_b_n(*(x[layout.index(n)] for n in ("yaw", "pitch", "roll")))
    b_g = ca.vertcat(*(x[layout.index(n)] for n in _GYRO_BIAS))
    n_b = ca.mtimes(C.T, p[3:6])
    h = ca.dot(n_b, p[0:3] - b_g - ca.mtimes(C.T, p[6:9]))
    return MeasurementModel.from_expression(x, p, h, "zero_yaw_rate")


class StandstillRowBuilder:
    """The standstill rows of each still window at the prior.

    Parameters
    ----------
    layout : ekf.StateLayout
    track : trackmodel.Track
    epochs : railnav.filters.standstill.StandstillEpochs
    config : railnav.filters.standstill.StandstillConfig
    """

    def __init__(self, layout: StateLayout, track, epochs, config) -> None:
        self.track, self.epochs, self.config = track, epochs, config
        self.zero_speed = build_zero_speed_rows(layout)
        self.i_s = layout.index("s")
        use_rate = config.yaw_rate_update and all(n in layout.names for n in _GYRO_BIAS)
        self.zero_rate = build_zero_rate_rows(layout) if use_rate else None

    def observations(self, index: int, x: Array, P: Array):
        """``(observations, sv, kind)`` of still window `index` at the prior ``(x, P)``."""
        obs = [Observation(self.zero_speed, np.zeros((1, 1)),
                           np.array([self.config.zero_speed_sigma_mps ** 2]), np.zeros((1, 1)))]
        kinds = [STANDSTILL_ROW_KINDS[0]]
        if self.zero_rate is not None:
            pt = self.track.at(float(np.clip(x[self.i_s], 0.0, self.track.length_m)))
            normal = C_b_n(float(pt.azimuth), float(pt.elevation), 0.0)[:, 2]
            earth = np.asarray(omega_ie_n(float(pt.lat), earth=self.track.earth), dtype=float)
            p = np.concatenate([self.epochs.omega_mean_radps[index], normal, earth])[None, :]
            obs.append(Observation(self.zero_rate, np.zeros((1, 1)),
                                   np.array([self.epochs.omega_sigma_radps[index] ** 2]), p))
            kinds.append(STANDSTILL_ROW_KINDS[1])
        return obs, np.full(len(kinds), STANDSTILL_SV, dtype=object), np.array(kinds,
                                                                                dtype=object)
