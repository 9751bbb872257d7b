"""The monitors' statuses, ``ok``, ``degraded``, ``lost``, and the status in force at a time.

A status is given per tested measurement epoch (`railnav.navigation.monitor.FilterMonitor`
of a single-track run; `railnav.navigation.spawning.Spawner.frame` and
`railnav.navigation.network_status` of a network run); `status_at` carries it over the
estimates' times, as the ``status`` column of ``estimates.csv``.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pandas as pd

from railnav.navigation.track_fixes import FIX_TIME_TOL_S

__all__ = ["STATUSES", "status_at"]

Array = npt.NDArray[np.float64]

#: The statuses, from best to worst.
STATUSES = ("ok", "degraded", "lost")


def status_at(records: pd.DataFrame, time_s: Array) -> npt.NDArray[np.object_]:
    """The status in force at each of `time_s`: that of the last tested epoch at or before
    it (``ok`` before the first; every sample ``ok`` without records)."""
    time_s = np.asarray(time_s, dtype=float)
    if records is None or len(records) == 0:
        return np.full(time_s.size, STATUSES[0], dtype=object)
    j = np.searchsorted(records["time_s"].to_numpy(), time_s + FIX_TIME_TOL_S, side="right") - 1
    status = records["status"].to_numpy(dtype=object)
    return np.where(j >= 0, status[np.maximum(j, 0)], STATUSES[0]).astype(object)
