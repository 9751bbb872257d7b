"""How `railnav.navigation.monitor.FilterMonitor` recovers a filter it finds ``lost``
(`MonitorConfig.recover`): when ``lost`` (two fixes or more disagree) and this
epoch's fix alone disagrees beyond the χ²₁ quantile of `MonitorConfig.p_lost` (4.9σ at
1e-6), ``s`` (and ``v`` where the fix has a speed) are re-initialised from it: the whole
state through the filter's own start-from-fix code where the run has it (`TrackFixes.start`:
``filter.initial_from_fix``, `railnav.filters.common.start_on_track`;
`railnav.navigation.fix_start.initial_at_fix`),
so that attitude, IMU biases and clock start over too (the attitude from the track at the
fix, its error from the fix's along-track error correlated with ``s`` in ``P``,
`railnav.filters.start_attitude`); else ``s`` and ``v`` alone (σ floored
as ``start_on_track`` does), their rows and columns of ``P`` without correlations.
Otherwise the ``s, v`` rows and columns of ``P`` are widened by the window's variance
factor ``f = Σ d²/n`` (``P_ss`` times ``f``): the next updates pull the state back, and one
noisy fix never replaces it.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

from railnav.navigation.monitor_config import MonitorConfig
from railnav.navigation.track_fixes import TrackFixes

__all__ = ["reinitialised", "widened"]

Array = npt.NDArray[np.float64]


def widened(x: Array, P: Array, i_s: int, i_v: int, d2_window: Array) -> tuple[Array, Array]:
    """`x` and `P` with the ``s, v`` rows and columns of ``P`` widened by the window's
    variance factor ``f = mean(d²)`` (`d2_window`, NaN where no fix; at least 1)."""
    x, P = x.copy(), P.copy()
    factor = max(float(np.nanmean(d2_window)) if np.isfinite(d2_window).any() else 1.0, 1.0)
    for i in (i_s, i_v):
        P[i, :] *= np.sqrt(factor)
        P[:, i] *= np.sqrt(factor)
    return x, P


def reinitialised(f: TrackFixes, j: int, x: Array, P: Array, i_s: int, i_v: int,
                  cfg: MonitorConfig) -> tuple[Array, Array]:
    """The state started over from fix `j` of `f`: the whole state through the run's
    start-from-fix code where it has one (``f.start``), else ``s`` (and ``v`` where the fix
    has a speed) alone, σ floored at the config's minima, without correlations."""
    x, P = x.copy(), P.copy()
    # a track through the same place twice (a loop, laps of a ring): the fix's pass
    # nearest the filter, where the fix cannot tell the passes apart (`TrackFixes.near`)
    s_fix, sigma_fix = f.near(j, float(x[i_s]))
    if f.start is not None:
        try:
            x0, P0 = f.start(int(f.source[j]))
        except (ValueError, ArithmeticError, np.linalg.LinAlgError):
            x0 = None                  # no start from this fix: s and v alone
        if x0 is not None:
            x0 = np.array(x0, dtype=float)
            x0[i_s] = s_fix
            return x0, np.asarray(P0, dtype=float)
    reset = [i_s]
    x[i_s] = s_fix
    var = {i_s: max(sigma_fix, cfg.min_fix_sigma_m) ** 2}
    if np.isfinite(f.v_mps[j]):
        x[i_v] = f.v_mps[j]
        var[i_v] = max(f.sigma_v_mps[j], cfg.min_fix_sigma_mps) ** 2
        reset.append(i_v)
    for i in reset:
        P[i, :] = 0.0
        P[:, i] = 0.0
        P[i, i] = var[i]
    return x, P
