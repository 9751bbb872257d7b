r"""Each GNSS epoch's own single-point fix: the position fixes of a GNSS run's spawn test
(`railnav.navigation.spawning`; issue 14 §3, "in the network navigator, spawn new
hypotheses", for runs on pseudoranges without a fix log).

`epoch_spp_fixes` solves every GNSS epoch of a run (`railnav.filters.gnss_epochs.GnssEpochs`,
the epochs the hypotheses' filters read, with their satellites' states at transmission)
alone by `gnss_obs.spp.solve_spp_epoch`, with the run's measurement settings and
elevation mask (`railnav.navigation.track_fixes.spp_config_of`): weighted least squares
with the pseudorange σ model the run declares (`gnss_obs.MeasurementConfig.sigma_model`,
``sigma_pr_m``), the receiver's χ² fault detection and exclusion and Huber weights. The
horizontal covariance is the solution's own, ``(Aᵀ W A)⁻¹`` in ENU: the fix the spawn test
compares with the hypotheses is as good as that model says and no better.

The fixes are independent of the hypotheses (no prior enters), so a set of hypotheses that
started wrong cannot pull them along. An epoch whose fault detection still fails after the
exclusions (``raim_ok`` False) or with too few satellites has no fix (NaN).

Their errors are as correlated from epoch to epoch as the pseudoranges' are: the run's
``NavigatorConfig.pseudorange_correlation_s`` (0 for simulated trips, whose errors are
white; 20 s by default, urban code multipath). `correlation_s` gives the τ the spawn test
counts them with (`railnav.navigation.hypotheses.evidence_share`).

Cost: one solve per epoch, from a guess extrapolated from the last fixes (`_guess`: the
straight line through up to `GUESS_FIXES` of them): one Gauss-Newton iteration (two in
0.7 % of the epochs of the 1000-s paper run, 22 % from the last two fixes alone) and the
fault screen's step, without protection levels, DOP or sky (~0.8 ms of CPU an epoch with
GPS, 2.6 ms with `gnss_obs.spp.SppConfig`'s defaults).
In the ``pruned`` 1000-s run of `benchmarks/bench_network_speed.py` these fixes take
~0.9 s of CPU and the spawn test's own work (`railnav.navigation.spawning`) ~0.15 s
(on a machine loaded 2-3; 1.2-1.4 s and 0.6 s before the guess from 8 fixes and the
test's points from nodes); `NetworkNavConfig.spawn_window_epochs` = 0 turns test,
status column and these fixes off.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from railnav.filters.fix_epochs import FixEpochs
from railnav.navigation.track_fixes import spp_config_of
from trackmodel.earth import ecef_to_geodetic

__all__ = ["epoch_spp_fixes", "correlation_s", "SPP_QUALITY"]

#: The fix class (`gnss_obs.fixes.table.FIX_QUALITIES`) of a receiver's single-point fix.
SPP_QUALITY = "single"
#: Gauss-Newton stops below this step, m (`gnss_obs.spp.SppConfig.tol_m`): from a guess
#: extrapolated from the last fixes (off by their errors, metres), one iteration.
#: The fault screen's least-squares step from the last iterate follows, so the fix is off
#: by the linearisation's error only, ``δ²/(2ρ)`` for a step δ at a range ρ ≈ 2e7 m:
#: ≤ 2e-5 m.
TOL_M = 30.0
#: Fixes further apart than this are not extrapolated from, s.
GUESS_GAP_S = 5.0
#: Most fixes the guess is extrapolated from: a line through 8 fixes 1 s apart is off by
#: ~1.2 σ of one fix (two: 2.2 σ) and, on a train accelerating at 1 m/s², by 7 m more.
GUESS_FIXES = 8


def epoch_spp_fixes(gnss, data, config) -> FixEpochs | None:
    """The single-point fix of each epoch of `gnss` (module docstring), one per epoch in
    its order (NaN position where an epoch has none); None without epochs.

    Parameters
    ----------
    gnss : railnav.filters.gnss_epochs.GnssEpochs or None
        The run's epochs (``TripSamples.gnss``).
    data : railnav.SensorData
        Its navigation file (``data.nav``) and the observation header's approximate
        position (the first guess).
    config : railnav.NavigatorConfig
        The run's measurement settings and elevation mask.

    Returns
    -------
    railnav.filters.fix_epochs.FixEpochs or None
        ``time_s`` of the epochs (s from the trip start), ``lat``/``lon`` (rad), ``h_m``,
        ``cov_n_m2`` the ENU position covariance (m², (E, 3, 3)), ``quality``
        `SPP_QUALITY`; no velocity.
    """
    from gnss_obs.spp import solve_spp_epoch
    if gnss is None or data.nav is None or not len(gnss.epochs):
        return None
    # a position is all it needs; the fault screen's step after the iterations leaves an
    # error of the order of (last step)² / (2 range): TOL_M costs ~2e-5 m at most
    cfg = replace(spp_config_of(config), velocity=False, tol_m=TOL_M)
    n = len(gnss.epochs)
    r_e = np.full((n, 3), np.nan)
    cov = np.full((n, 3, 3), np.nan)
    transmit = getattr(gnss, "transmit", None) or [None] * n
    approx = getattr(getattr(data.obs, "header", None), "approx_position_e", None)
    last: list = []                               # the last fixes (time, r_e)
    for k, epoch in enumerate(gnss.epochs):
        fix = solve_spp_epoch(epoch, data.nav, cfg, transmit=transmit[k], details=False,
                              approx_e=_guess(last, float(gnss.time_s[k]), approx))
        if fix is None or not fix.raim_ok or not np.all(np.isfinite(fix.r_e)):
            continue
        r_e[k], cov[k] = fix.r_e, fix.cov_enu
        last = (last + [(float(gnss.time_s[k]), np.asarray(fix.r_e, dtype=float))]
                )[-GUESS_FIXES:]
    lat, lon, h = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    ok = np.all(np.isfinite(r_e), axis=1)
    if ok.any():
        lat[ok], lon[ok], h[ok] = (np.asarray(a, dtype=float).reshape(-1)
                                   for a in ecef_to_geodetic(r_e[ok]))
    return FixEpochs(time_s=np.asarray(gnss.time_s, dtype=float), lat=lat, lon=lon, h_m=h,
                     cov_n_m2=cov, v_n_mps=np.full((n, 3), np.nan),
                     sigma_speed_mps=np.full(n, np.nan),
                     quality=np.full(n, SPP_QUALITY, dtype=object))


def _guess(last: list, time_s: float, approx):
    """The first guess of the epoch at `time_s`: the least-squares line through the latest
    fixes (``(time_s, r_e)``, oldest first) that follow each other at most `GUESS_GAP_S`
    apart, the last of them at most that before it, evaluated at `time_s` (one fix: that
    fix); else `approx` (the file's approximate position)."""
    if not last or time_s - last[-1][0] > GUESS_GAP_S:
        return approx
    first = len(last) - 1
    while first > 0 and last[first][0] - last[first - 1][0] <= GUESS_GAP_S:
        first -= 1
    if first == len(last) - 1:
        return last[-1][1]
    t = np.array([tk for tk, _ in last[first:]])
    d = np.array([rk for _, rk in last[first:]]) - last[-1][1]     # from the last, m
    dt = t - t.mean()
    return last[-1][1] + d.mean(axis=0) + (dt @ d) * ((time_s - t.mean()) / (dt @ dt))


def correlation_s(nav, config) -> float:
    """τ of the single-point fixes' errors (module docstring): the larger of the run's
    `NetworkNavConfig.evidence_correlation_s` and its pseudoranges'
    ``NavigatorConfig.pseudorange_correlation_s``, s."""
    return max(float(nav.evidence_correlation_s), float(config.pseudorange_correlation_s))
