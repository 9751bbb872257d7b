r"""New hypotheses when every live one disagrees with the fixes (issue 14 §3, "in the
network navigator, spawn new hypotheses").

The network navigator's hypotheses come from the start (`railnav.navigation.network_start`)
and from branching and splitting; none is ever created where the data say the train is.
A start on the wrong one of two parallel tracks (the fix-only filter uses the fix's
along-track component and a cross-track row that the map's error widens,
`railnav.filters.fix_epochs.FixModelConfig.track_cross_sigma_m`, so it never leaves its
element), or an along-track start error larger than the fault screen's gate (every later
row is rejected, the filter dead-reckons), stays wrong with probability 1 to the end.

`Spawner` watches the navigator's own evidence at each epoch with a position fix (or, in
runs without fixes, a GNSS epoch's single-point fix: below), on the
hypotheses' posteriors: for each live hypothesis ``h`` the horizontal disagreement of the
fix with the track point at its ``s``,

``d_h² = eᵀ (Σ_fix + σ_s² t tᵀ + σ_c² c cᵀ)⁻¹ e``

(``e`` the fix minus the track point in east/north, ``t`` and ``c`` the track's horizontal
tangent and normal there, ``σ_c`` `FixModelConfig.track_cross_sigma_m`;
`railnav.navigation.fix_disagreement`, re-exported here), and of the epoch
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
attempt per window (spawn or not: a fix whose candidates all disagree with it too gets
none, nor a window that the network itself does not explain, `Spawner._on_network`: a
train on a track the map lacks). Such a window is not ``lost`` either, only ``degraded``:
the fixes disagree with the network, not only with the hypotheses (issue 14: the real
log_28554 ended ``lost`` in the airport tunnel on fixes drifting 20-37 m from every element,
whose along-track parts agreed with the hypothesis). The test's outcome per fix epoch is
the ``status`` column of the network run's ``estimates.csv`` (`Spawner.frame`, read by
`railnav.navigation.statuses.status_at`: the
divergence monitor's statuses and thresholds, on the navigator's own evidence; runs with
neither fixes nor GNSS observations have no status column).

Correlated fix errors declared (`NetworkNavConfig.evidence_correlation_s`, e.g. 60 s for
fixes of single-point quality): each epoch counts ``(1 − ρ)/(1 + ρ)`` of an independent one
(`railnav.navigation.hypotheses.evidence_share`, the weights' rule), the window holds
``n_eff = max(1, Σ shares)`` independent epochs, and its sum scaled by ``n_eff/n`` is tested
against χ² with ``2 n_eff`` degrees of freedom (a persistent 2-m bias in five 0.4-s epochs is
one look, not five). Candidates that themselves disagree with the fix they start from
(``χ²₂`` tail below `NetworkNavConfig.spawn_p_value`) are not spawned.

Honesty of the test: if any live hypothesis is the truth with a right σ, its ``d_h²`` is
χ²₂ at its prior; the minimum over hypotheses is smaller, and the posterior (which took this
fix) is nearer the fix than the prior, so the false-spawn rate is below ``spawn_p_value``
per window. Correlated fix errors (a receiver's bias wandering over a minute) make the
window's sum heavier-tailed than χ²: false spawns are then more frequent, and cost only
short-lived extra hypotheses (counted, `NetworkResult.spawns`).

No hypothesis starts from a dead-reckoned fix (quality ``dead_reckoning``: NMEA GGA 6,
u-blox fix type 1, a log's ``PROPAGATED``): it is the receiver's own inertial extrapolation
of its last GNSS solution, with an error that drifts rather than a measurement of where the
train is now. Such fixes still count in the window's test (with their 10-m σ,
`gnss_obs.fixes.quality`); a window that fails on one keeps filling, and the first fix of
GNSS quality while it still fails gets the spawn attempt. (The real log_28554 in the airport
tunnel: its one false spawn, at 238.8 s, came from a ``PROPAGATED`` fix 24 m from the
element it started on.)

Runs without position fixes (GNSS observations, with or without an IMU) test and spawn
from each GNSS epoch's own single-point fix instead (`railnav.navigation.spp_epochs`:
the epoch's pseudoranges alone, weighted least squares with the run's σ model and the
receiver's fault exclusion, its ENU covariance; never from the hypotheses' prior, only
linearized at the most probable one's preparation of the epoch when that is near; its σ
the told one: its own residuals' noise scale only decides the restart below, `spp_epochs`,
"Scale"). Their errors are
counted as correlated over the larger of `NetworkNavConfig. evidence_correlation_s` and
the run's ``NavigatorConfig.pseudorange_correlation_s`` (0 for simulated trips; 20 s by
default for real ones: a 5-epoch window at 1 Hz is then one look). A spawn starts its
hypotheses as the run's start does (`railnav.navigation.network_start`:
``filt.initial_from_fix`` of that epoch's single-point fix), so their receiver clock
bias and drift are the fix's, not the lost hypotheses'; the hypotheses' noise scale
starts again when above the fixes'
(`railnav.filters.bank_noise_scale.BankNoiseScale.restart_above`). Measured
(`benchmarks/bench_network_spawn_gnss.py`, tactical IMU, σ_pr 3 m, 5 seeds): a start 400
m along the track, never recovered without spawning, is within 10 m from 5-7 s on (one
spawn, when the first window has filled; 8-13 s without the restart); 150 m, which the
curves between the loops correct by 11-32 s, from 5-12 s (one seed 19 s: the two
parallel tracks undecided after the spawn, 4 confident cycles on the wrong one). A start
on the wrong one of two tracks 4.5 m apart is not detected (one epoch's fix, σ ≈ 3-4 m
per axis, adds ~1.4 to the window's sum per epoch, against the χ²₁₀ tail 1e-6 at 51); 15
m apart, it is (from 5-6 s). A known start therefore starts on the tracks abreast of it
too (`railnav.navigation.network_start.with_abreast`), and the weights' evidence tells
the 4.5-m tracks apart (~1.1 nats an epoch: right from 3-18 s on, 5 seeds).
Cost: one single-point solve per GNSS epoch (one least-squares step from a hypothesis's
preparation of the epoch, ~0.3 ms of CPU; `railnav.navigation.spp_epochs`)
and each live hypothesis's track point from its track's nodes
(`trackmodel.network_points.NodePoints`: tens of µs an epoch).

Spawning is on by default (`NetworkNavConfig.spawn`; the test and the status column run
either way): see its documentation for the spawns measured on the real logs.
"""
from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np
import numpy.typing as npt
from scipy.special import chdtrc

from gnss_obs.fixes.table import DEAD_RECKONING
from railnav.errors import ConfigError, RailnavError
from railnav.navigation.fix_disagreement import fix_disagreement, fix_frames
from railnav.navigation.hypotheses import evidence_share
from railnav.navigation.route_path import entered
from railnav.navigation.spp_epochs import EpochSppFixes
from trackmodel.network_points import NodePoints


__all__ = ["Spawner", "fix_disagreement", "fix_frames"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]


def chi2_isf(p: float) -> float:
    """The χ²₂ quantile with tail `p`: ``−2 ln p``."""
    return -2.0 * math.log(p)


def _linearization(hyps: list, f: int):
    """GNSS epoch `f` as the most probable of `hyps` that prepared it did
    (`railnav.filters.common.EpochRowBuilder.latest`): its receiver guess and the
    satellites there (`railnav.navigation.spp_epochs.EpochSppFixes.solve`'s
    ``linearized``); None when none did (children born this cycle, other filters)."""
    for h in sorted(hyps, key=lambda h: -h.log_weight):
        latest = getattr(getattr(h.filt, "rows", None), "latest", None)
        if latest is not None and latest[0] == f:
            return latest[1], latest[2]
    return None


class Spawner:
    """The disagreement window and the spawns of one run (module docstring).

    Parameters
    ----------
    nav : railnav.navigation.network_config.NetworkNavConfig
    trip : railnav.navigation.navigator.TripSamples
    cross_sigma_m : float
        `FixModelConfig.track_cross_sigma_m` of the run.
    start : callable(after_s) -> (time_s, list of Hypothesis)
        New hypotheses from the first fix after ``after_s`` (the run's
        `railnav.navigation.network_start.start_hypotheses`).
    p_degraded : float
        Below this tail probability the status is ``degraded``.
    points : callable(hyps) -> (r_e, tangent_e), optional
        The hypotheses' track points (default: from the tracks' nodes,
        `trackmodel.network_points.NodePoints`: the exact points,
        `railnav.navigation.network_weights.ecef_points` of ``track_points_of``, to
        < 1e-6 m, 1e-5 m within a metre of a section joint, for ~5 % of their cost; the
        fix-only stepper's grid is its own).
    network : trackmodel.network.Network, optional
        Where `_on_network` looks for the nearest centre-lines (None: no such check).
    spp : railnav.navigation.spp_epochs.EpochSppFixes or FixEpochs, optional
        A run without position fixes: its GNSS epochs' own single-point fixes, one per
        epoch of ``trip.gnss``, each solved when the test reaches it, linearized at the
        most probable hypothesis's preparation of the epoch (`_linearization`), or given
        (`railnav.navigation.spp_epochs.epoch_spp_fixes`); a run with fixes tests those.
    noise_scale : railnav.filters.bank_noise_scale.BankNoiseScale, optional
        The hypotheses' scale, restarted at a spawn when above `spp`'s (`restart_above`).
    spp_correlation_s : float
        τ of `spp`'s errors, s (`railnav.navigation.spp_epochs.correlation_s`): the
        window counts them as `NetworkNavConfig.evidence_correlation_s` says for fixes.
    """

    def __init__(self, nav, trip, cross_sigma_m: float, start,
                 p_degraded: float = 1e-3, points=None, network=None, spp=None,
                 spp_correlation_s: float = 0.0, noise_scale=None) -> None:
        self.noise_scale = noise_scale
        self.nav, self.trip, self.cross_sigma_m, self.start = nav, trip, cross_sigma_m, start
        self._nodes = NodePoints()
        self.points = points or self._node_points
        self.network = network
        own = trip.fixes is not None and len(trip.fixes) > 0
        #: The single-point fixes' solver (None: the fixes are given).
        self._solver = spp if not own and isinstance(spp, EpochSppFixes) else None
        #: The fixes tested (the run's own, else its epochs' single-point fixes) and which
        #: of `EpochSchedule.split`'s indices is theirs.
        self.fixes, self._column = (trip.fixes, 1) if own else \
            (spp.fixes if self._solver is not None else spp, 0)
        # the window counts the single-point fixes' correlated errors (their τ)
        self._shares = nav if own else replace(
            nav, evidence_correlation_s=max(nav.evidence_correlation_s, spp_correlation_s))
        have = self.fixes is not None and len(self.fixes) > 0
        # the given fixes' frames at once; solved ones' as they come (`fix_disagreement`)
        self._frames = fix_frames(self.fixes) if have and self._solver is None else None
        self.p_degraded = p_degraded
        self.window: list[float] = []
        self.shares: list[float] = []
        self.fixes_in_window: list[int] = []
        self._last_s = -np.inf
        #: One per fix epoch: ``time_s, status, p_fix, d2_min, action, fix_off_network``
        #: (`frame`).
        self.records: list[tuple] = []
        #: ``(time_s, hypotheses spawned)`` of every spawn.
        self.spawns: list[tuple[float, int]] = []
        self.active = bool(nav.spawn_window_epochs) and have and trip.schedule is not None

    def after_epoch(self, hyps: list, epoch: int | None, time_s: float) -> list:
        """`hyps`, with new hypotheses when the window's test fails at this epoch."""
        if not self.active or epoch is None or not hyps:
            return hyps
        f = self.trip.schedule.split(epoch)[self._column]
        if f >= 0 and self._solver is not None:
            self._solver.solve(f, _linearization(hyps, f))
        if f < 0 or not np.isfinite(self.fixes.lat[f]):
            return hyps
        r_e, tangent_e = self.points(hyps)
        sigma_s = np.sqrt(np.maximum([h.P[h.index("s"), h.index("s")] for h in hyps], 0.0))
        d2 = fix_disagreement(r_e, tangent_e, sigma_s, self.fixes, f, self.cross_sigma_m,
                              self._frame(f))
        share = evidence_share(self._shares, time_s - self._last_s)
        self._last_s = time_s
        self.window.append(float(np.min(d2)))
        self.shares.append(share)
        self.fixes_in_window.append(f)
        n = self.nav.spawn_window_epochs
        off = self.window[-1] > chi2_isf(self.nav.spawn_p_value) and self._off_network(f)
        if len(self.window) < n:                    # after a start or a spawn
            self.records.append((time_s, "degraded", np.nan, self.window[-1], "", off))
            return hyps
        self.window, self.shares = self.window[-n:], self.shares[-n:]
        self.fixes_in_window = self.fixes_in_window[-n:]
        # correlated fix errors (NetworkNavConfig.evidence_correlation_s): the window holds
        # n_eff = max(1, Σ shares) independent epochs' worth; its sum scaled to that
        n_eff = max(1.0, float(sum(self.shares)))
        p = float(chdtrc(2.0 * n_eff, sum(self.window) * n_eff / n))
        status = "lost" if p < self.nav.spawn_p_value else \
            "degraded" if p < self.p_degraded else "ok"
        explained = status != "lost" or self.network is None or \
            self._on_network(self.fixes_in_window, self.shares)
        out = self._spawn(hyps, time_s, f, explained) if status == "lost" and self.nav.spawn \
            else hyps
        if not explained:           # fixes no position on the network explains: not lost
            status = "degraded"
        self.records.append((time_s, status, p, self.window[-1] if self.window else
                             float(np.min(d2)), "spawn" if out is not hyps else "", off))
        return out

    def _frame(self, f: int):
        """Fix `f`'s frame (`fix_disagreement`'s ``frame``; None: computed there)."""
        return None if self._frames is None else (self._frames[0][f], self._frames[1][f])

    def _node_points(self, hyps) -> tuple[Array, Array]:
        """The track points of `hyps` from the tracks' nodes (`points` parameter)."""
        return self._nodes.ecef([h.filt.track for h in hyps], [h.s_m for h in hyps])

    def _fix_variance(self, k: int) -> float:
        """Fix `k`'s horizontal variance's mean plus the map's across, m²."""
        return 0.5 * float(np.trace(np.asarray(self.fixes.cov_n_m2[k])[:2, :2])) + \
            self.cross_sigma_m ** 2

    def _off_network(self, k: int) -> bool:
        """Whether fix `k` is farther from every centre-line than the χ²₂ quantile of
        `NetworkNavConfig.spawn_p_value` on `_fix_variance`: no position on the network
        explains it (a receiver's jump or drift), whatever the hypotheses."""
        if self.network is None:
            return False
        radius = math.sqrt(self._fix_variance(k) * chi2_isf(self.nav.spawn_p_value))
        fx = self.fixes
        return len(self.network.project(fx.lat[k:k + 1], fx.lon[k:k + 1],
                                        radius_m=radius)) == 0

    def _on_network(self, window: list[int], shares: list[float]) -> bool:
        """Whether the network explains the window's fixes (indices; their evidence
        shares): each fix's ``d²`` to its nearest centre-line, on its horizontal
        variance's mean plus the map's across (a lower bound of any hypothesis's
        ``d_h²``: along the track nothing is asked), summed and tested as in
        `after_epoch`, passes at the ``ok`` level (tail ≥ ``p_degraded``). A window that
        even the nearest centre-lines do not explain at that level is a train on a track
        the map lacks (or faulty fixes), not hypotheses in the wrong place: spawning from
        it starts hypotheses where the train is not (the real log_28554 from 180 s:
        fixes 20–37 m from every element; at 226.8 s the live hypothesis's window tail
        was just below 1e-6 and a candidate 29 m off agreed with a dead-reckoned fix of
        σ 10 m)."""
        fx, n = self.fixes, len(window)
        reach = float(chi2_isf(self.nav.spawn_p_value)) * max(n, 1)   # beyond: fails alone
        d2 = np.full(n, reach)
        for j, k in enumerate(window):
            var = self._fix_variance(k)
            near = self.network.project(fx.lat[k:k + 1], fx.lon[k:k + 1],
                                        radius_m=math.sqrt(var * reach))
            if len(near):
                d2[j] = float(near["distance_m"].min()) ** 2 / var
        n_eff = max(1.0, float(sum(shares)))
        return float(chdtrc(2.0 * n_eff, float(d2.sum()) * n_eff / max(n, 1))) >= \
            self.p_degraded

    def frame(self):
        """The fix epochs' test (`railnav.navigation.statuses.status_at` reads it): ``time_s,
        status`` (``degraded`` while the window fills after a start or a spawn, ``lost``
        below `NetworkNavConfig.spawn_p_value`, ``degraded`` below the monitor's
        ``p_degraded``, else ``ok``), ``p_fix`` (the window's tail probability),
        ``d2_min`` (the epoch's best ``d_h²``), ``action`` (``spawn`` or empty),
        ``fix_off_network`` (the fix is beyond the ``spawn_p_value`` quantile from every
        centre-line: rejected whatever the hypotheses, `row_records` counts it for
        ``degraded`` only)."""
        import pandas as pd
        return pd.DataFrame.from_records(self.records, columns=[
            "time_s", "status", "p_fix", "d2_min", "action", "fix_off_network"])

    def _spawn(self, hyps: list, time_s: float, f: int, explained: bool = True) -> list:
        if self.fixes.quality[f] == DEAD_RECKONING:
            return hyps      # no start from an extrapolation: the window waits for a GNSS fix
        self.window, self.shares, self.fixes_in_window = [], [], []   # one attempt per window
        if not explained:                       # the network does not explain the window
            return hyps
        try:
            t_new, new = self.start(time_s - 1e-3)
        except (ConfigError, RailnavError) as exc:
            log.debug("no spawn at t=%.1f s: %s", time_s, exc)
            return hyps
        if abs(t_new - time_s) > 1e-3 or not new:   # this epoch's fix is off the network
            return hyps
        # only candidates that agree with the fix they start from (a train on a track the
        # network lacks, 10-30 m from the nearest element, gets none: it stays lost)
        r_e, tangent_e = self.points(new)
        sigma_s = np.sqrt(np.maximum([h.P[h.index("s"), h.index("s")] for h in new], 0.0))
        d2 = fix_disagreement(r_e, tangent_e, sigma_s, self.fixes, f, self.cross_sigma_m,
                              self._frame(f))
        new = [h for h, d in zip(new, d2) if chdtrc(2.0, float(d)) >= self.nav.spawn_p_value]
        if not new:
            return hyps
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
            # path); `railnav.navigation.route_path.entered` appends the new element
            h.path = best.path
            entered(h, time_s, through_joint=False)
        self.spawns.append((float(time_s), len(new)))
        if self._solver is not None and self.noise_scale is not None and \
                self.noise_scale.restart_above(self._solver.noise_scale):
            log.info("t=%.1f s: the noise scale starts again (above the fixes')", time_s)
        log.info("t=%.1f s: no hypothesis agrees with the fixes: %d new from the fix on %s",
                 time_s, len(new), ", ".join(sorted({h.element for h in new})))
        return list(hyps) + list(new)
