r"""Balise rows: "the reader passed track distance ``s_b`` at time t", an update of ``s``.

The vehicle's balise reader is ``F_b`` ahead of the reference point
(`railnav.filters.track_frame.LeverArms.balise_reader_forward_m`), so a passage of the
balise at ``s_b`` observes::

    z = s_b,    h(x) = s + F_b,    ∂h/∂s = 1

with the passage's σ (the file's, else `BaliseModelConfig.sigma_m`). Row parameter ``[F_b]``.
A balise given as a coordinate is projected on the track once, when the run's epochs are
built (`railnav.filters.balise_epochs.BaliseEpochs.from_log`). The rows go
through the fault screen row by row (a wrong balise is rejected, not believed), with
``sv`` ``balise:<id>`` and kind `BALISE_ROW_KIND` in ``innovations.csv``.
"""
from __future__ import annotations

import functools

import casadi as ca
import numpy as np
import numpy.typing as npt

from ekf.layout import StateLayout
from ekf.model import MeasurementModel
from ekf.update import Observation
from railnav.filters.balise_epochs import (
    BALISE_ROW_KIND,
    BALISE_SV_PREFIX,
    BaliseEpochs,
    BaliseModelConfig,
)

__all__ = ["BaliseModelConfig", "BaliseEpochs", "build_balise_rows", "BaliseRowBuilder",
           "BALISE_ROW_KIND", "BALISE_SV_PREFIX"]

Array = npt.NDArray[np.float64]


@functools.lru_cache(maxsize=None)
def build_balise_rows(layout: StateLayout) -> MeasurementModel:
    """The balise row model of a layout with ``s``."""
    x = ca.SX.sym("x", layout.size)
    forward = ca.SX.sym("forward", 1)
    return MeasurementModel.from_expression(x, forward, x[layout.index("s")] + forward[0],
                                            "balise_passage")


class BaliseRowBuilder:
    """The row of each passage.

    Parameters
    ----------
    layout : ekf.StateLayout
    epochs : BaliseEpochs
    reader_forward_m : float
        The reader's forward offset from the reference point, m.
    """

    def __init__(self, layout: StateLayout, epochs: BaliseEpochs,
                 reader_forward_m: float = 0.0) -> None:
        self.epochs, self.forward = epochs, float(reader_forward_m)
        self.model = build_balise_rows(layout)

    def observations(self, index: int, x: Array, P: Array):
        """The row of passage `index`: ``(observations, sv, kind)``."""
        e = self.epochs
        obs = Observation(self.model, np.array([[e.s_m[index]]]),
                          np.array([e.sigma_m[index] ** 2]), np.array([[self.forward]]))
        return ([obs], np.array([BALISE_SV_PREFIX + str(e.ids[index])], dtype=object),
                np.array([BALISE_ROW_KIND], dtype=object))
