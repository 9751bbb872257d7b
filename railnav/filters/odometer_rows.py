r"""Odometer rows: the wheel's speed as an observation of ``v`` with a scale-factor state.

A tachometer reads the speed magnitude scaled by the wheel's error (wear, a nominal
circumference): ``m = (1 + k) |v| + e``. With the direction ``d = ±1`` of the run along
the track (the file's ``direction``, else the sign of the prior's ``v`` when it is more
than `DIRECTION_SIGMA` of its σ from zero), the row is::

    z = m,    h(x) = (1 + k) d v,    ∂h/∂v = (1 + k) d,    ∂h/∂k = d v

``k`` is the state ``odo_scale`` (`SCALE_STATE`; with `OdometerConfig.estimate_scale`;
without it ``h = d v``); row parameter ``[d]``. A moving reading whose direction the
prior cannot tell (the vehicle about to start) is skipped and counted. A **standstill**
reading (`railnav.filters.odometer_epochs`) is a zero-speed row, ``z = 0``, ``h = (1+k) v``
with its own σ: the odometer's obvious observation of a stop.

**Slip and slide.** A wheel that spins in traction reads too fast, one that locks in
braking too slow, for seconds. The rows go through the filter's fault screen
(`railnav.filters.fault_detection.RowScreen`) as one *channel* (``sv`` ``odometer``):
each row is tested at the prior, a row that fails is rejected, three failures in five
readings exclude the channel, the drift CUSUM catches a slow creep, and the channel is
re-admitted after ten consistent readings. Rows not used are ``rejected``/``excluded`` in
``innovations.csv``; `railnav.filters.sensor_rows.slip_episodes` groups them into
episodes, slip (innovation > 0: the wheel faster than the vehicle) or slide, for
``summary.json``.
"""
from __future__ import annotations

import functools

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.model import MeasurementModel
from ekf.update import Observation
from railnav.filters.odometer_epochs import SCALE_STATE, OdometerConfig, OdometerEpochs

__all__ = ["SCALE_STATE", "ODOMETER_SV", "ODOMETER_ROW_KINDS", "build_odometer_rows",
           "OdometerRowBuilder", "DIRECTION_SIGMA"]

Array = npt.NDArray[np.float64]

#: ``innovations.csv`` ``sv`` of the odometer rows (one channel of the fault screen).
ODOMETER_SV = "odometer"
#: Kinds of odometer rows: a moving reading, a standstill.
ODOMETER_ROW_KINDS = ("odo_speed", "odo_zero_speed")
#: The prior tells the direction when ``|v|`` exceeds this many σ_v.
DIRECTION_SIGMA = 3.0


@functools.lru_cache(maxsize=None)
def build_odometer_rows(layout: StateLayout) -> MeasurementModel:
    """The odometer row model of a layout with ``v`` (and ``odo_scale`` if it has one)."""
    x = ca.SX.sym("x", layout.size)
    d = ca.SX.sym("d", 1)
    v = x[layout.index("v")]
    scale = 1.0 + x[layout.index(SCALE_STATE)] if SCALE_STATE in layout.names else 1.0
    return MeasurementModel.from_expression(x, d, scale * d[0] * v, "odometer_speed")


class OdometerRowBuilder:
    """The odometer row of each reading at the prior.

    Parameters
    ----------
    layout : ekf.StateLayout
    epochs : OdometerEpochs
    config : OdometerConfig

    Attributes
    ----------
    skipped : int
        Moving readings skipped because the prior could not tell the direction.
    """

    def __init__(self, layout: StateLayout, epochs: OdometerEpochs,
                 config: OdometerConfig) -> None:
        self.epochs, self.config = epochs, config
        self.model = build_odometer_rows(layout)
        self.i_v = layout.index("v")
        self.skipped = 0

    def observations(self, index: int, x: Array, P: Array):
        """The row of reading `index` at the prior ``(x, P)``: ``(observations, sv, kind)``,
        or None when it is skipped."""
        e = self.epochs
        if e.standstill[index]:
            return self._row(0.0, 1.0, e.zero_sigma_mps[index], ODOMETER_ROW_KINDS[1])
        d = float(e.direction[index])
        if d == 0.0:
            v, sigma_v = float(x[self.i_v]), float(np.sqrt(max(P[self.i_v, self.i_v], 0.0)))
            if abs(v) <= DIRECTION_SIGMA * sigma_v and e.speed_mps[index] > 0.0:
                self.skipped += 1
                return None
            d = 1.0 if v >= 0.0 else -1.0
        return self._row(float(e.speed_mps[index]), d, e.sigma_mps[index],
                         ODOMETER_ROW_KINDS[0])

    def _row(self, z: float, d: float, sigma: float, kind: str):
        obs = Observation(self.model, np.array([[z]]), np.array([sigma ** 2]),
                          np.array([[d]]))
        return [obs], np.array([ODOMETER_SV], dtype=object), np.array([kind], dtype=object)
