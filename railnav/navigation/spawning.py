r"""New hypotheses when every live one disagrees with the fixes (issue 14 §3, "in the
network navigator, spawn new hypotheses").

The network navigator's hypotheses come from the start (`railnav.navigation.network_start`)
and from branching and splitting; none is ever created where the data say the train is.
A start on the wrong one of two parallel tracks (the fix-only filter uses the fix's
along-track component and a cross-track row that the map's error widens,
`railnav.filters.fix_epochs.FixModelConfig.track_cross_sigma_m`, so it never leaves its
element), or an along-track start error larger than the fault screen's gate (every later
row is rejected, the filter dead-reckons), stays wrong with probability 1 to the end.

`Spawner` watches the navigator's own evidence at each epoch with a position fix, on the
hypotheses' posteriors: for each live hypothesis ``h`` the horizontal disagreement of the
fix with the track point at its ``s``,

``d_h² = eᵀ (Σ_fix + σ_s² t tᵀ + σ_c² c cᵀ)⁻¹ e``

(``e`` the fix minus the track point in east/north, ``t`` and ``c`` the track's horizontal
tangent and normal there, ``σ_c`` `FixModelConfig.track_cross_sigma_m`), and of the epoch
the best of them, ``d² = min_h d_h²``. The sum over the last
`NetworkNavConfig.spawn_window_epochs` fix epochs is tested against χ² with two degrees of
freedom per epoch: when its tail probability is below `NetworkNavConfig.spawn_p_value`
(with no hypothesis agreeing, over a whole window), new hypotheses are started from this
epoch's fix exactly as at the start (every netelement within
`NetworkNavConfig.start_radius_m`, each orientation an inertial filter needs), together
carrying `NetworkNavConfig.spawn_probability` of the total, the others scaled to the rest;
their path (``route.csv``) starts with the most probable hypothesis's path up to then, so
that the route of a run that recovered shows where the navigator had been wrong.
The evidence of the next epochs then decides between old and new (common basis,
`railnav.navigation.network_weights`). The window restarts after a spawn, so at most one
spawn per window. The test's outcome per fix epoch is the ``status`` column of the network
run's ``estimates.csv`` (`Spawner.frame`, read by `railnav.navigation.monitor.status_at`: the
divergence monitor's statuses and thresholds, on the navigator's own evidence; runs without
fixes have no status column).

Honesty of the test: if any live hypothesis is the truth with a right σ, its ``d_h²`` is
χ²₂ at its prior; the minimum over hypotheses is smaller, and the posterior (which took this
fix) is nearer the fix than the prior, so the false-spawn rate is below ``spawn_p_value``
per window. Correlated fix errors (a receiver's bias wandering over a minute) make the
window's sum heavier-tailed than χ²: false spawns are then more frequent, and cost only
short-lived extra hypotheses (counted, `NetworkResult.spawns`).

Limits: only runs with position fixes (`railnav.filters.fix_epochs.FixEpochs`) spawn; GNSS
runs without fixes would need a single-point solution per epoch (the divergence monitor's
`railnav.navigation.monitor.spp_track_fixes`, 5 s of a 7.6-s run) and do not spawn yet.
"""
from __future__ import annotations

import logging
import math

import numpy as np
import numpy.typing as npt
from scipy.stats import chi2

from railnav.errors import ConfigError, RailnavError
from railnav.navigation.hypotheses import entered
from trackmodel.earth import C_n_e, geodetic_to_ecef

__all__ = ["Spawner", "fix_disagreement"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]


def fix_disagreement(hyps, fixes, k: int, cross_sigma_m: float) -> Array:
    """``d_h²`` of fix `k` against each hypothesis's track point (module docstring),
    shape (K,).

    Parameters
    ----------
    hyps : list of railnav.navigation.hypotheses.Hypothesis
    fixes : railnav.filters.fix_epochs.FixEpochs
    k : int
        The fix.
    cross_sigma_m : float
        σ of the track's centre-line across, m.
    """
    lat, lon = float(fixes.lat[k]), float(fixes.lon[k])
    r_fix = np.asarray(geodetic_to_ecef(lat, lon, 0.0), dtype=float).reshape(3)
    C_e_n = C_n_e(lat, lon).T
    cov_fix = np.asarray(fixes.cov_n_m2[k], dtype=float)[:2, :2]
    out = np.empty(len(hyps))
    for j, h in enumerate(hyps):
        track = h.filt.track
        p = track.at(min(max(h.s_m, 0.0), track.length_m))
        r = np.asarray(geodetic_to_ecef(float(p.lat), float(p.lon), 0.0), dtype=float)
        e = (r_fix - r.reshape(3)) @ C_e_n.T         # east, north, up of fix − point
        t = np.asarray(p.u_n, dtype=float)[:2]
        t = t / max(float(np.linalg.norm(t)), 1e-12)
        c = np.array([-t[1], t[0]])
        i_s = h.index("s")
        cov = cov_fix + max(float(h.P[i_s, i_s]), 0.0) * np.outer(t, t) + \
            cross_sigma_m ** 2 * np.outer(c, c)
        out[j] = float(e[:2] @ np.linalg.solve(cov, e[:2]))
    return out


class Spawner:
    """The disagreement window and the spawns of one run (module docstring).

    Parameters
    ----------
    nav : railnav.navigation.hypotheses.NetworkNavConfig
    trip : railnav.navigation.navigator.TripSamples
    cross_sigma_m : float
        `FixModelConfig.track_cross_sigma_m` of the run.
    start : callable(after_s) -> (time_s, list of Hypothesis)
        New hypotheses from the first fix after ``after_s`` (the run's
        `railnav.navigation.network_start.start_hypotheses`).
    """

    def __init__(self, nav, trip, cross_sigma_m: float, start,
                 p_degraded: float = 1e-3) -> None:
        self.nav, self.trip, self.cross_sigma_m, self.start = nav, trip, cross_sigma_m, start
        self.p_degraded = p_degraded
        self.window: list[float] = []
        #: One per fix epoch: ``time_s, status, p_fix, d2_min, action`` (`frame`).
        self.records: list[tuple] = []
        #: ``(time_s, hypotheses spawned)`` of every spawn.
        self.spawns: list[tuple[float, int]] = []
        self.active = bool(nav.spawn_window_epochs) and trip.fixes is not None and \
            trip.schedule is not None and len(trip.fixes) > 0

    def after_epoch(self, hyps: list, epoch: int | None, time_s: float) -> list:
        """`hyps`, with new hypotheses when the window's test fails at this epoch."""
        if not self.active or epoch is None or not hyps:
            return hyps
        _, f = self.trip.schedule.split(epoch)
        if f < 0:
            return hyps
        d2 = fix_disagreement(hyps, self.trip.fixes, f, self.cross_sigma_m)
        self.window.append(float(np.min(d2)))
        n = self.nav.spawn_window_epochs
        if len(self.window) < n:                    # after a start or a spawn
            self.records.append((time_s, "degraded", np.nan, self.window[-1], ""))
            return hyps
        self.window = self.window[-n:]
        p = float(chi2.sf(sum(self.window), 2 * n))
        status = "lost" if p < self.nav.spawn_p_value else \
            "degraded" if p < self.p_degraded else "ok"
        out = hyps if status != "lost" else self._spawn(hyps, time_s)
        self.records.append((time_s, status, p, self.window[-1] if self.window else
                             float(np.min(d2)), "spawn" if out is not hyps else ""))
        return out

    def frame(self):
        """The fix epochs' test (`railnav.navigation.monitor.status_at` reads it): ``time_s,
        status`` (``degraded`` while the window fills after a start or a spawn, ``lost``
        below `NetworkNavConfig.spawn_p_value`, ``degraded`` below the monitor's
        ``p_degraded``, else ``ok``), ``p_fix`` (the window's tail probability),
        ``d2_min`` (the epoch's best ``d_h²``), ``action`` (``spawn`` or empty)."""
        import pandas as pd
        return pd.DataFrame.from_records(self.records, columns=[
            "time_s", "status", "p_fix", "d2_min", "action"])

    def _spawn(self, hyps: list, time_s: float) -> list:
        try:
            t_new, new = self.start(time_s - 1e-3)
        except (ConfigError, RailnavError) as exc:
            log.debug("no spawn at t=%.1f s: %s", time_s, exc)
            return hyps
        if abs(t_new - time_s) > 1e-3 or not new:   # this epoch's fix is off the network
            return hyps
        self.window = []
        p = self.nav.spawn_probability
        log_w = np.array([h.log_weight for h in hyps], dtype=float)
        top = float(np.max(log_w))
        norm = top + math.log(float(np.sum(np.exp(log_w - top))))
        for h in hyps:
            h.log_weight = h.log_weight - norm + math.log1p(-p)
        best = hyps[int(np.argmax(log_w))]
        for h in new:
            h.log_weight = math.log(p / len(new))
            # the route so far is what the navigator said (the most probable hypothesis's
            # path); `railnav.navigation.hypotheses.entered` appends the new element
            h.path = best.path
            entered(h, time_s)
        self.spawns.append((float(time_s), len(new)))
        log.info("t=%.1f s: no hypothesis agrees with the fixes: %d new from the fix on %s",
                 time_s, len(new), ", ".join(sorted({h.element for h in new})))
        return list(hyps) + list(new)
