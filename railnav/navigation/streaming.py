"""Streaming mode: a simulated trip of any length filtered with memory flat in its length.

`stream_simulated` is `railnav.jobs.run.run_simulated` for trips too long to hold (a 10-hour
trip at 100 Hz is 3.6 M IMU samples): the trip is simulated segment by segment
(`railnav.simulation.trip_stream`), one `ekf.CdFilter` engine consumes the segments' chunks as they
come (`railnav.navigation.loop.ChunkLoop`: the same chunking and track re-linearization as
`railnav.navigate`), and each segment's stored estimates are compared with its truth
(`railnav.evaluation.metrics.error_series`), added to running statistics
(`railnav.evaluation.running_stats.RunningSummary`) and appended to the output files, then dropped.
Nothing grows with the trip but the output files. The divergence monitor
(`railnav.navigation.monitor`, track-based filters) runs as in `railnav.navigate`: the
``status`` and protection-level columns are written with the estimates and its counts are in
``summary.json`` (``statistics.monitor``); its records are dropped once counted.

GNSS epochs are declared at the nominal epoch times (every ``1/gnss_rate_hz`` s outside the
outages) before their observations exist; an epoch is served from its segment's
`railnav.filters.gnss_epochs.GnssEpochs` when the filter reaches it. The constellation is the
shipped broadcast file re-issued over the trip (`gnss_obs.ephemeris_reissue`), used by
the simulator and the filter alike. Only the inertial filters (``constrained``,
``unconstrained``) stream.

Outputs (with ``out_dir``), each written to a temporary file as the run goes and moved in
place at its end: ``estimates.csv`` and ``errors.csv`` at ``estimates_rate_hz``, and
``summary.json`` (the layout of ``railnav run``'s, ``mode: "streaming"``).
"""
from __future__ import annotations

import contextlib
import functools
import itertools
import json
import logging
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pandas as pd

from ekf.history import FilterResult, concatenate_results
from ekf.layout import StateLayout
from ekf.series import Epoch
from gnss_obs.ephemeris_reissue import reissue_ephemerides
from gnss_obs.rinex_nav import RinexNav, read_rinex_nav
from gnss_obs.sim_events import in_outages
from gnss_obs.simulate import default_nav_path
from railnav.config import DEFAULT_SYSTEMS, NavigatorConfig
from railnav.errors import ConfigError
from railnav.evaluation.metrics import error_series
from railnav.evaluation.running_stats import RunningCounts, RunningSummary
from railnav.filters.protocol import FILTER_KINDS, filter_kind, make_filter
from railnav.navigation.initialization import initial_from_truth
from railnav.navigation.loop import EPOCH_TIME_TOL_S, ChunkLoop
from railnav.navigation.navigator import run_monitor
from railnav.navigation.result import estimates_frame
from railnav.navigation.stream_output import StreamMonitor, StreamWriter, stream_summary
from railnav.simulation.scenarios import RNG_STREAMS, Scenario
from railnav.simulation.trip import navigator_config_for
from railnav.simulation.trip_stream import TripSegment, epoch_step, trip_segments
from trackmodel.files import atomic_write_text

__all__ = ["StreamOutcome", "stream_simulated", "DEFAULT_SEGMENT_S",
           "DEFAULT_ESTIMATES_RATE_HZ"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
Progress = Callable[[int, int], None]

#: Segment length, s: 30 000 IMU samples at 100 Hz (~10 MB of truth and IMU at a time).
DEFAULT_SEGMENT_S = 300.0
#: Rate of the written estimates and errors, Hz (the statistics use every stored sample).
DEFAULT_ESTIMATES_RATE_HZ = 1.0
#: The extended constellation covers the trip plus this margin, s.
_NAV_MARGIN_S = 3600.0


@dataclass(frozen=True)
class StreamOutcome:
    """A finished streamed run.

    Attributes
    ----------
    summary : dict
        The ``summary.json`` content (as `railnav.jobs.run.RunOutcome.summary`).
    paths : tuple of pathlib.Path
        Files written (empty without ``out_dir``).
    """

    summary: dict
    paths: tuple[Path, ...] = ()


class _EpochRegistry:
    """The current segment's GNSS epochs behind the filter's ``gnss.prepare(index, r)``;
    ``index`` is the epoch number ``round(time_s · gnss_rate_hz)`` of the whole trip."""

    def __init__(self, gnss_rate_hz: float) -> None:
        self.rate = gnss_rate_hz
        #: The nominal epoch interval, s (`railnav.filters.gnss_only_noise.epoch_interval_s`).
        self.interval_s = 1.0 / gnss_rate_hz
        self.gnss = None
        self.local: dict[int, int] = {}

    def register(self, gnss) -> None:
        self.gnss = gnss
        times = gnss.time_s if gnss is not None else np.zeros(0)
        self.local = {int(round(t * self.rate)): i for i, t in enumerate(times)}

    def prepare(self, index: int, r_guess_e: Array):
        return self.gnss.prepare(self.local[index], r_guess_e)

    def observations(self, filt_obj, index: int, x: Array, P: Array):
        if index not in self.local:
            return []      # no satellite at this epoch
        return filt_obj.observations(index, x, P)


@dataclass(frozen=True, eq=False)
class _Block:
    """Stored estimates of one segment, with what `error_series` reads of a result."""

    estimates: pd.DataFrame
    filter_object: object
    x: Array
    P: Array
    layout: StateLayout


def stream_simulated(track, scenario: Scenario, *, config: NavigatorConfig | None = None,
                     seed: int = 0, systems: str = DEFAULT_SYSTEMS,
                     out_dir: str | Path | None = None,
                     estimates_rate_hz: float = DEFAULT_ESTIMATES_RATE_HZ,
                     segment_s: float = DEFAULT_SEGMENT_S,
                     window: tuple[float, float] | None = None, nav: RinexNav | None = None,
                     progress: Progress | None = None) -> StreamOutcome:
    """Simulate `scenario` on `track` and filter it in streaming mode (module docstring).

    Parameters
    ----------
    track : trackmodel.Track
    scenario : Scenario
    config : NavigatorConfig, optional
        Default `railnav.simulation.trip.navigator_config_for(scenario)`; its ``output_rate_hz`` sets
        the samples the statistics use.
    seed : int
    systems : str
        GNSS systems simulated and used.
    out_dir : path, optional
        Where to write ``estimates.csv``, ``errors.csv`` and ``summary.json`` (created).
    estimates_rate_hz : float
        Rate of the written rows, Hz (at most ``config.output_rate_hz``).
    segment_s : float
        Length of the simulated segments, s.
    window : (start_s, end_s), optional
        Extra error-summary window.
    nav : gnss_obs.RinexNav, optional
        Constellation; default the shipped file re-issued over the trip.
    progress : callable(done, total), optional
        Filter steps.

    Returns
    -------
    StreamOutcome

    Raises
    ------
    ConfigError
        For a filter that cannot stream or bad rates.
    """
    started = time.perf_counter()
    config = config or navigator_config_for(scenario, systems=systems)
    if not filter_kind(config.filter).streams:
        streaming = " and ".join(k for k in FILTER_KINDS if filter_kind(k).streams)
        raise ConfigError(f"streaming runs the {streaming} filters, not "
                          f"{config.filter!r}")
    if not (math.isfinite(estimates_rate_hz) and 0 < estimates_rate_hz):
        raise ConfigError(f"estimates_rate_hz must be finite and > 0, got {estimates_rate_hz!r}")
    if nav is None:
        end = scenario.start_gps_time_s + scenario.duration_s + _NAV_MARGIN_S
        nav = reissue_ephemerides(read_rinex_nav(default_nav_path()), end_gps_time_s=end,
                                  systems=systems)
    out = Path(out_dir) if out_dir is not None else None
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    with contextlib.ExitStack() as files:
        writer = StreamWriter(files, out, estimates_rate_hz)
        stats, counts, left, monitored = _filter_stream(track, scenario, config, seed, systems, nav,
                                             segment_s, window, writer, progress)
        summary = stream_summary(scenario, config, seed, systems, track, stats, counts, left,
                                 monitored, time.perf_counter() - started)
        paths = writer.paths
        if out is not None:
            atomic_write_text(out / "summary.json", json.dumps(summary, indent=2) + "\n")
            paths = paths + (out / "summary.json",)
    return StreamOutcome(summary, paths)


def _filter_stream(track, scenario, config, seed, systems, nav, segment_s, window, writer,
                   progress):
    """Run the engine over the segments; the running statistics, counters and left-track."""
    segments = trip_segments(scenario, track, seed=seed, config=config, nav=nav,
                             systems=systems, segment_s=segment_s)
    stats = RunningSummary(window=window, outages=scenario.outages)
    counts = RunningCounts()
    first = next(segments)
    registry = _EpochRegistry(scenario.gnss_rate_hz)
    filt_obj = make_filter(track, config, registry)
    initial = _initial_state(filt_obj, config, scenario, first, seed)
    loop = ChunkLoop(filt_obj, config, sample_interval_s=1.0 / scenario.imu_rate_hz)
    loop.monitor = run_monitor(filt_obj, None, config)
    monitored = None if loop.monitor is None else StreamMonitor(loop.monitor)
    current: dict = {}

    def blocks(segment: TripSegment):
        times = segment.gnss.time_s if segment.gnss is not None else np.zeros(0)
        return (segment.imu.time_s, segment.imu.u,
                np.searchsorted(segment.imu.time_s, times - EPOCH_TIME_TOL_S))

    def chunks() -> Iterator:
        # one segment ahead: a chunk cut by a segment's end is linearized with the next
        # segment's samples, as in one series (`ChunkLoop.chunks`'s `following`)
        ahead = itertools.chain([first], segments)
        segment = next(ahead)
        while segment is not None:
            following = next(ahead, None)
            current["segment"] = segment
            registry.register(segment.gnss)
            yield from loop.chunks(*blocks(segment), following=None if following is None
                                   else (following.imu.time_s, following.imu.u))
            if loop.left is not None:
                return
            segment = following

    epochs = _nominal_epochs(scenario, track, registry, loop)
    pending: list[FilterResult] = []
    owner: TripSegment | None = None
    total = _last_sample(scenario, track)

    def steps_done(done: int, total_steps: int) -> None:
        counts.steps = done
        if progress is not None:
            progress(done, total_steps)

    for part in loop.stream(chunks(), epochs, initial, progress=steps_done, total=total):
        segment = current["segment"]
        if owner is not None and segment is not owner:
            _flush(pending, owner, segment, filt_obj, track, scenario, stats, counts, writer,
                   monitored)
            pending = []
        owner = segment
        pending.append(part)
    if pending:
        _flush(pending, owner, None, filt_obj, track, scenario, stats, counts, writer,
               monitored)
    left = loop.left
    if left is not None:
        log.warning("stopped at t=%.3f s: s = %.2f m is beyond the track's %s", left["time_s"],
                    left["s_m"], left["end"])
    return stats, counts, left, monitored


def _initial_state(filt_obj, config: NavigatorConfig, scenario: Scenario,
                   first: TripSegment, seed: int):
    """The truth at the first sample with errors drawn from the filter's covariance
    (as `railnav.jobs.run.run_simulated`)."""
    truth = first.truth
    x_true, known = filt_obj.truth_states(truth, *first.clock_truth(truth.time_s))
    P0 = filt_obj.initial_covariance(
        sigma_s_m=config.initial_s_sigma_m or scenario.initial_s_sigma_m,
        sigma_v_mps=config.initial_v_sigma_mps or scenario.initial_v_sigma_mps)
    streams = np.random.SeedSequence(int(seed)).spawn(len(RNG_STREAMS))
    rng = np.random.default_rng(streams[RNG_STREAMS["initial"]])
    return initial_from_truth(x_true[0], P0, time_s=float(truth.time_s[0]), rng=rng,
                              drawn=known)


def _last_sample(scenario: Scenario, track) -> int:
    """Index of the trip's last IMU sample (it may end early at the track end), by
    bisection on the profile's distance (non-decreasing)."""
    n = int(math.floor(scenario.duration_s * scenario.imu_rate_hz + 1e-9)) + 1

    def on_track(k: int) -> bool:
        s = scenario.start_s + scenario.profile.evaluate(k / scenario.imu_rate_hz).s[0]
        return s <= track.length_m

    if on_track(n - 1):
        return n - 1
    lo, hi = 0, n - 1          # on_track(lo), not on_track(hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if on_track(mid) else (lo, mid)
    return lo


def _nominal_epochs(scenario: Scenario, track, registry: _EpochRegistry,
                    loop: ChunkLoop) -> Iterator[Epoch]:
    """Epochs at every GNSS epoch sample of the trip outside the outages."""
    step = epoch_step(scenario)
    k = np.arange(0, _last_sample(scenario, track) + 1, step)
    t = k / scenario.imu_rate_hz
    keep = ~in_outages(t, scenario.outages)
    return loop.epochs(t[keep], k[keep] // step,
                       observe=functools.partial(registry.observations, loop.filt))


def _flush(parts: list[FilterResult], segment: TripSegment, following: TripSegment | None,
           filt_obj, track, scenario: Scenario, stats: RunningSummary, counts: RunningCounts,
           writer, monitored: "StreamMonitor | None" = None) -> None:
    """Evaluate, summarize and write one segment's stored estimates; then forget them
    (`following`: the next segment, for the clock truth after this one's last epoch)."""
    result = concatenate_results(parts)
    counts.add(result)
    _forget_epoch_records(filt_obj)
    if result.t.size == 0:
        return
    estimates = estimates_frame(filt_obj, result.t, result.x, result.P,
                                start_gps_time_s=scenario.start_gps_time_s)
    if monitored is not None:              # the divergence monitor's status and the PL
        estimates = monitored.columns(estimates, filt_obj.config)
    block = _Block(estimates, filt_obj, result.x, result.P, result.layout)
    errors = error_series(block, segment.truth_window, track,
                          clock_truth=functools.partial(segment.clock_truth,
                                                        following=following))
    stats.add(errors)
    writer.write(estimates, errors.to_frame())


def _forget_epoch_records(filt_obj) -> None:
    """Drop what the filter object keeps per GNSS epoch for ``innovations.csv`` (row labels
    of `railnav.filters.common.EpochRowBuilder`, the records of
    `railnav.filters.fault_detection.RowScreen`, the noise scale's history): a streamed
    run does not write that file, and those lists would grow with the trip. The screen's
    channel states and the noise scale's window, which carry over from epoch to epoch,
    are kept."""
    rows = getattr(filt_obj, "rows", None)
    if rows is not None:
        rows.rows_sv.clear()
        rows.rows_kind.clear()
    screen = getattr(filt_obj, "screen", None)
    if screen is not None:
        for records in (screen.epochs, screen._sv, screen._kind):
            records.clear()
    scale = getattr(filt_obj, "noise_scale", None)
    if scale is not None:
        scale.history.clear()
