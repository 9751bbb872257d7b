"""The Rauch–Tung–Striebel smoother over a finished run (``railnav run --smooth``).

A run navigated with ``NavigatorConfig(rts_smoothing=True)`` keeps, for every filter step,
the filtered and predicted moments and the step's transition (`ekf.history.SmootherData`).
`smooth_result` runs the engine's one smoother backward over them (`ekf.smoother.rts_smooth`:
``x_{k|N} = x_{k|k} + C_k (x_{k+1|N} − x_{k+1|k})``, ``C_k = P_{k|k} Φ_kᵀ P_{k+1|k}⁻¹``) and
returns the run's smoothed twin: a `NavigationResult` with the same stored times, layout
and innovations, whose states, covariances and ``estimates`` table are the smoothed ones
(so `railnav.evaluation.metrics.error_series` scores it as it scores the filter).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ekf.smoother import rts_smooth
from railnav.errors import RailnavError
from railnav.navigation.result import NavigationResult, estimates_frame, integrity_columns

__all__ = ["smooth_result"]


def smooth_result(result: NavigationResult) -> NavigationResult:
    """The smoothed twin of a run (module docstring).

    Parameters
    ----------
    result : NavigationResult
        From `railnav.navigate` with ``NavigatorConfig(rts_smoothing=True)``.

    Returns
    -------
    NavigationResult
        ``x``, ``P`` and ``estimates`` smoothed at ``result.time_s``; everything else
        as in `result`.

    Raises
    ------
    RailnavError
        When the run kept no smoother data.
    """
    data = result.raw.smoother
    if data is None:
        raise RailnavError("this run kept no smoother data: navigate with "
                           "NavigatorConfig(rts_smoothing=True)")
    smoothed = rts_smooth(data, result.raw.x_final, result.raw.P_final)
    index = np.searchsorted(data.t, result.time_s)
    index = np.clip(index, 0, data.t.size - 1)
    if not np.array_equal(data.t[index], result.time_s):
        raise RailnavError("the stored estimates are not at filter steps: cannot smooth")
    x, P = smoothed.x[index], smoothed.P[index]
    estimates = estimates_frame(result.filter_object, result.time_s, x, P,
                                start_gps_time_s=result.start_gps_time_s)
    if result.monitor is not None:       # the run's statuses, the smoothed σ in the PL
        estimates = estimates.assign(**integrity_columns(
            estimates, result.monitor, result.filter_object.config))
    return replace(result, x=x, P=P, estimates=estimates)
