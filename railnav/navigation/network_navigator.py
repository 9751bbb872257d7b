r"""The multiple-hypothesis navigator on a track network: which netelement, where on it.

`navigate_network` follows a train through a network (`trackmodel.network.Network`)
with a changing set of hypotheses (`railnav.navigation.hypotheses.Hypothesis`): each is
"on netelement E in orientation o, with this along-track state", one track-constrained
filter of the run's kind (constrained INS/GNSS, GNSS-only, fix-only) on E's oriented
track (`railnav.navigation.net_tracks`), made by
`railnav.navigation.hypothesis_filters.FilterFactory` (re-exported here). They start where
the first fix or single-point solution is (`railnav.navigation.network_start`) and are
stepped in lockstep, cycle by cycle: a cycle ends at each measurement epoch, or after
`railnav.navigation.loop.MAX_CHUNK_S` without one, and at the first sample where a
hypothesis reaches the end of its element (`crossing_sample`: it branches there, not up
to a cycle later on geometry extrapolated past its element). After each cycle:

1. every hypothesis's filter has propagated and taken the epoch's rows
   (`railnav.navigation.hypothesis_step.EngineStepper`);
2. the weights take the cycle's evidence on a common basis and the Markov prior of
   leaving the track for one abreast; abreast filters restart from their IMM mixture
   (`railnav.navigation.network_weights`);
3. hypotheses that have left their element branch into its navigable successors, those
   that coincide merge, the improbable ones are pruned and the count is capped
   (`railnav.navigation.hypotheses`); a hypothesis at a buffer stop whose vehicle has
   left the track dies (its `railnav.navigation.loop.TrackEndWatch`, the single-track
   runs' rule: beyond the end and moving away, then on by 3σ_s more);
4. the cycle is recorded (`railnav.navigation.network_result.NetworkRecorder`).

Hypotheses live on netelements, not on whole routes: two ways through a switch share the
geometry of everything before it exactly (the per-route refits of `railnav.jobs.network`'s
first version differed there by up to 0.15 m and leaked evidence before the switch).

If every hypothesis dies (all beyond buffer stops, or lost), the run starts again from the
next fix or single-point solution near the network (`start_hypotheses` after that time)
and says so in `NetworkResult.restarts`; with none left, it ends there.

Time: ``time_s`` is seconds from the trip start.
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from railnav.config import NavigatorConfig
from railnav.sensor_data import SensorData
from railnav.errors import ConfigError, RailnavError
from railnav.filters.protocol import FILTER_KINDS, filter_kind
from railnav.navigation.hypotheses import (
    NetworkNavConfig,
    branch,
    branch_ahead,
    evidence_share,
    merge_coinciding,
    most_probable,
    normalized_weights,
    prune,
    rebased,
)
from railnav.navigation.hypothesis_filters import FilterFactory
from railnav.navigation.hypothesis_step import EngineStepper
from railnav.navigation.loop import EPOCH_TIME_TOL_S, MAX_CHUNK_S
from railnav.navigation.navigator import trip_samples
from railnav.navigation.net_tracks import OrientedTracks
from railnav.navigation.network_result import NetworkRecorder, NetworkResult
from railnav.navigation.network_start import NetworkStart, start_hypotheses
from railnav.navigation.route_path import entered
from railnav.navigation.s_split import needs_split, split
from railnav.navigation.spawning import Spawner
from railnav.navigation.spp_epochs import correlation_s as spp_correlation_s
from railnav.navigation.spp_epochs import EpochSppFixes
from railnav.navigation.stacked_fixes import StackedFixStepper, stackable
from railnav.navigation.state_conversion import forget_offsets
from railnav.navigation.network_weights import (
    abreast,
    crossing_matrix,
    cycle_evidence,
    cycle_points,
    hypothesis_points,
    mix_states,
    reweight,
)

__all__ = ["navigate_network", "FilterFactory", "cycle_ends", "crossing_sample"]

log = logging.getLogger(__name__)

Progress = Callable[[int, int], None]

#: How often the live hypotheses are logged (INFO, ``railnav -v``), s of trip time.
REPORT_EVERY_S = 10.0


def cycle_ends(n_samples: int, epoch_samples: np.ndarray, max_len: int) -> list[int]:
    """Sample indices where cycles end: every epoch sample, and within longer gaps every
    `max_len` samples; the last sample always."""
    ends = set(int(k) for k in epoch_samples if 0 < k < n_samples)
    marks = sorted(ends | {n_samples - 1})
    out, prev = [], 0
    for m in marks:
        while m - prev > max_len:
            prev += max_len
            out.append(prev)
        out.append(m)
        prev = m
    return out


def _report(recorder, time_s: float) -> None:
    """The live hypotheses in the log (``railnav -v``)."""
    if recorder.rows:
        row = recorder.rows[-1]
        log.info("t=%.0f s: %d live hypotheses; most probable %s (%.4f) at %.1f m", time_s,
                 row["hypotheses"], row["netelement"], row["netelement_probability"],
                 row["netelement_offset_m"])


def crossing_sample(hyps, tracks, t, a: int, b: int) -> int:
    """The first sample after `a`, up to `b`, at which a hypothesis is predicted to reach
    an end of its element (``s + v Δt``; `b` when none does): a cycle ends there, so that
    it branches within a sample of its joint instead of running on past its element's end
    (module docstring)."""
    span = float(t[b] - t[a])
    first = span
    for h in hyps:
        s, v = h.s_m, float(h.x[h.index("v")])
        gone = (h.length_m - s) / v if v > 0 else (-s / v if v < 0 else np.inf)
        if 0.0 < gone < first:
            first = gone
    if first >= span:
        return b
    return int(min(max(np.searchsorted(t, t[a] + first), a + 1), b))


def _grid_points(stepper):
    """The hypotheses' track points from the fix-only stepper's grid (None: another
    stepper; the `Spawner`'s own from the tracks' nodes then)."""
    grid = getattr(stepper, "grid", None)
    if grid is None:
        return None

    def points(hyps):
        return grid.track_points([h.pieces[0][:2] for h in hyps],
                                 np.array([h.s_m for h in hyps]))
    return points


def _spp_fixes(trip, data, config, nav) -> dict:
    """The spawn test's fixes of a GNSS run without position fixes: its epochs' own
    single-point fixes and their errors' τ (`railnav.navigation.spp_epochs`), as the
    `Spawner`'s keywords; none for a run with fixes or without the test."""
    if not nav.spawn_window_epochs or (trip.fixes is not None and len(trip.fixes)) or \
            trip.gnss is None:
        return {}
    return {"spp": EpochSppFixes.of(trip.gnss, data, config),
            "spp_correlation_s": spp_correlation_s(nav, config)}


def _check_inputs(config: NavigatorConfig, data: SensorData) -> None:
    kind = filter_kind(config.filter)
    if not (kind.banks or (kind.fixes and data.fixes is not None)):
        raise ConfigError(f"a network run needs a filter that screens its rows "
                          f"({', '.join(k for k in FILTER_KINDS if filter_kind(k).banks)}, "
                          f"or any filter with fixes), not {config.filter!r}")


def navigate_network(network, data: SensorData, config: NavigatorConfig = NavigatorConfig(),
                     *, nav: NetworkNavConfig = NetworkNavConfig(),
                     start: NetworkStart | None = None, outages=(), initial=None,
                     near=None, progress: Progress | None = None) -> NetworkResult:
    """Navigate on a network with hypotheses that branch, merge and die (module docstring).

    Parameters
    ----------
    network : trackmodel.network.Network
    data : SensorData
    config : NavigatorConfig
    nav : NetworkNavConfig
    start : NetworkStart, optional
        A known start netelement (default: every netelement near the first fix).
    outages : sequence of (start_s, duration_s)
    initial : callable(filter object, element, orientation) -> InitialState or None, optional
        Each start candidate's own initial state (simulations).
    near : (lat, lon), optional
        With `initial`: the candidates are the netelements near this point (rad).
    progress : callable(done, total), optional
        Cycles done of all.

    Returns
    -------
    NetworkResult
    """
    started = time.perf_counter()
    _check_inputs(config, data)
    forget_offsets()              # this run's numbers: not those of the runs before it
    trip = trip_samples(data, config, outages=outages)
    tracks = OrientedTracks(network)
    # the hypotheses' filters without the one-sided bound (`railnav.filters.one_sided`):
    # the Gaussian sum carries a multimodal s, and the truncation at an onset, itself
    # (`railnav.navigation.s_split`), and a bound that widens one hypothesis's rows
    # would widen the continuous evidence's common covariance (the widest S) and blind
    # the weights (outage_20min seed 5 lost for good with it; its limits there)
    factory = FilterFactory(tracks, replace(config, one_sided=False), trip)
    t0, hyps = start_hypotheses(network, tracks, factory, trip, data, config, nav,
                                start=start, initial=initial, near=near, seed_scale=True)
    t, u, epoch_idx = trip.from_time(t0)
    at_sample = np.searchsorted(t, trip.epoch_times[epoch_idx] - EPOCH_TIME_TOL_S)
    stepper = StackedFixStepper(config, trip, tracks, t,
                                fix_bias_sigma_m=nav.fix_bias_sigma_m,
                                fix_bias_tau_s=nav.evidence_correlation_s) \
        if nav.stacked and stackable(config, trip) else EngineStepper(config, t, u, tracks,
                                                                      stacked=nav.stacked)
    if nav.fix_bias_sigma_m > 0.0 and not isinstance(stepper, StackedFixStepper):
        raise ConfigError("fix_bias_sigma_m: only fix-only runs with stacked=True model "
                          "the fixes' bias (railnav.navigation.fix_bias)")
    run = _Run(network, tracks, factory, trip, data, config, nav, stepper,
               NetworkRecorder(tracks, factory, nav, start_gps_time_s=data.start_gps_time_s),
               t, dict(zip(at_sample.tolist(), epoch_idx.tolist())))
    dt = float(np.median(np.diff(t)))
    ends = cycle_ends(t.size, at_sample, max(1, int(round(MAX_CHUNK_S / dt))))
    if 0 in run.epoch_of:   # the start epoch is used, as `railnav.navigate` uses it
        ends = [0] + ends
    run.spawner = Spawner(nav, trip, config.fix_model.track_cross_sigma_m,
                          lambda after_s: start_hypotheses(network, tracks, factory, trip,
                                                           data, config, nav,
                                                           after_s=after_s),
                          p_degraded=config.monitor.p_degraded,
                          points=_grid_points(stepper), network=network,
                          noise_scale=factory.noise_scale, **_spp_fixes(trip, data, config, nav))
    hyps = run.cycles(hyps, ends, progress)
    run.recorder.spawns.extend(run.spawner.spawns)
    if run.spawner.active:
        run.recorder.status_records = run.spawner.frame()
    return run.recorder.result(network, config, nav, hyps, outages=outages,
                               runtime_s=time.perf_counter() - started)


@dataclass
class _Run:
    """What the cycles of a run share."""

    network: object
    tracks: OrientedTracks
    factory: FilterFactory
    trip: object
    data: SensorData
    config: NavigatorConfig
    nav: NetworkNavConfig
    stepper: object
    recorder: NetworkRecorder
    t: np.ndarray
    epoch_of: dict
    spawner: Spawner | None = None

    def cycles(self, hyps, ends: list[int], progress) -> list:
        """Every cycle (module docstring); the last hypotheses."""
        t, nav = self.t, self.nav
        a, c, last_epoch, next_report = 0, 0, -np.inf, -np.inf
        while c < len(ends):
            b = ends[c]
            if b < a:                               # before a restart's first epoch
                c += 1
                continue
            stop = crossing_sample(hyps, self.tracks, t, a, b)
            epoch = self.epoch_of.get(b) if stop == b else None
            outcome = self.step(hyps, a, stop, epoch)
            share = 1.0
            if epoch is not None:
                share, last_epoch = evidence_share(nav, float(t[stop]) - last_epoch), \
                    float(t[stop])
            hyps = _after_cycle(hyps, outcome, self.tracks, self.factory, nav,
                                float(t[stop]), float(t[stop] - t[a]), self.recorder, share)
            if self.spawner is not None:            # every live hypothesis disagrees
                hyps = self.spawner.after_epoch(hyps, epoch, float(t[stop]))
            a = stop
            c += stop == b                          # else a joint reached within it
            while not hyps and a is not None:       # every hypothesis left the network
                a, hyps = self.start_again(a)
            if a is None:
                break
            if progress is not None:
                progress(c, len(ends))
            if t[a] >= next_report:
                next_report = float(t[a]) + REPORT_EVERY_S
                _report(self.recorder, float(t[a]))
        return hyps

    def step(self, hyps, a: int, b: int, epoch: int | None):
        """The stepper's cycle (`EngineStepper.step`), the noise scale fed by the
        hypothesis most probable before it (`railnav.filters.bank_noise_scale`)."""
        scale = self.factory.noise_scale
        if epoch is not None and hyps:
            scale.epoch(getattr(hyps[most_probable(hyps)].filt, "noise_scale", None))
        outcome = self.stepper.step(hyps, a, b, epoch)
        scale.end_epoch()
        return outcome

    def start_again(self, a: int):
        """New hypotheses from the next fix near the network after every one died (module
        docstring), their first epoch used as a start's is: the sample index and the
        hypotheses, or ``(None, [])`` when no fix is left."""
        t = self.t
        log.warning("every hypothesis left the network at t=%.1f s: starting again from "
                    "the next fix near it", t[a])
        self.recorder.restarts.append(float(t[a]))
        self.factory.noise_scale.restart()
        try:
            t_new, hyps = start_hypotheses(self.network, self.tracks, self.factory, self.trip,
                                           self.data, self.config, self.nav,
                                           after_s=float(t[a]), seed_scale=True)
        except (ConfigError, RailnavError) as exc:
            log.warning("no start again: %s", exc)
            return None, []
        a = int(np.searchsorted(t, t_new - EPOCH_TIME_TOL_S))
        outcome = self.step(hyps, a, a, self.epoch_of.get(a))
        return a, _after_cycle(hyps, outcome, self.tracks, self.factory, self.nav,
                               float(t[a]), 0.0, self.recorder)


def _after_cycle(hyps, outcome, tracks, factory, nav, time_s: float, dt_s: float,
                 recorder, share: float = 1.0) -> list:
    """Steps 2–4 of the module docstring (`share`: what the epoch's evidence counts)."""
    log_lik, rows = cycle_evidence(outcome, len(hyps), continuous=nav.continuous_evidence,
                                   share=share)
    if len(hyps) > 1:
        points, newton = cycle_points(hyps) if outcome.points is None else (None, None)
        r_e, u_e = hypothesis_points(hyps, tracks, outcome, track_points=points)
        neighbours = abreast(hyps, r_e, u_e, nav.crossing_radius_m)
        transition = crossing_matrix(neighbours, nav.crossing_rate_per_s, dt_s)
        reweight(hyps, log_lik, transition)
        mix_states(hyps, normalized_weights(hyps), transition, nav.min_mixing_weight,
                   track_points=points, newton_points=newton)
    else:                 # nothing abreast, nothing to mix: the weight is all there is
        reweight(hyps, log_lik, np.eye(len(hyps)))
    recorder.epoch(time_s, hyps, outcome, log_lik)
    out = []
    for h in hyps:
        children = branch(h, tracks, factory.child, time_s)
        if children is None and outcome.continuous:
            children = branch_ahead(h, tracks, factory.child)
        if children is not None:
            out.extend(children)
        elif h.end_watch.check(h.filt, h.x, h.P, time_s) is not None:
            log.debug("hypothesis %d left %s at its buffer stop", h.id, h.element)
        elif outcome.continuous and needs_split(h, nav):
            out.extend(split(h, tracks, factory.child))
        else:
            out.append(rebased(h, tracks, factory.child))
    for h in out:
        entered(h, time_s)
    out, merges = merge_coinciding(out, nav.merge_mahalanobis)
    out, dropped = prune(out, nav)
    if out:
        recorder.cycle(time_s, out, evidence_rows=rows, merges=merges, pruned=dropped)
    return out
