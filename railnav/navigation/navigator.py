"""The navigator: runs a filter over a trip's sensor data on a track.

`navigate` is the one entry point behind ``railnav run`` and the notebooks. It

1. cuts the GNSS observations into epochs (`railnav.filters.gnss_epochs`) and the GNSS
   position fixes to the trip (`railnav.filters.fix_epochs.FixEpochs`), both without the
   outage windows (the one place where a run skips GNSS data), the odometer readings and
   balise passages to the run (`railnav.navigation.sensors`), and merges them into one
   epoch schedule (`railnav.filters.fix_epochs.EpochSchedule`);
2. builds the sample grid: the IMU samples (a sample is inserted, its input interpolated,
   where an epoch falls between two), or for a filter that needs no IMU a grid at the
   output rate plus the epochs;
3. builds the filter object once (`railnav.filters.protocol.make_filter`) and starts it from
   the given `InitialState` (or one computed from the filter object), or from the first
   single-point GNSS fix of the observations (`railnav.navigation.initialization`), or,
   without observations, from the first position fix that agrees with the track
   (`railnav.navigation.fix_start`);
4. runs it through the chunk loop (`railnav.navigation.loop.ChunkLoop`), which stops early,
   with a warning, when a track-based filter's vehicle leaves the track; the result says
   where (`NavigationResult.left_track`);
5. assembles a `railnav.navigation.result.NavigationResult` (estimates, innovations,
   statistics).

Time: ``time_s`` is seconds from the trip start, whose GPS time is
``SensorData.start_gps_time_s``.
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ekf.history import concatenate_results
from railnav.config import NavigatorConfig
from railnav.errors import RailnavError
from railnav.filters.body_rows import body_stream_epochs
from railnav.filters.fix_epochs import EpochSchedule, FixEpochs
from railnav.filters.gnss_epochs import GnssEpochs
from railnav.filters.protocol import Filter, filter_kind, make_filter
from railnav.navigation.fix_start import initial_from_fixes
from railnav.navigation.initialization import InitialState, initial_from_gnss
from railnav.navigation.loop import EPOCH_TIME_TOL_S, ChunkLoop
from railnav.navigation.monitor import FilterMonitor
from railnav.navigation.result import NavigationResult
from railnav.navigation.sensors import imu_at_reference, track_sensor_epochs
from railnav.navigation.track_fixes import fix_log_track_fixes, spp_fix_at
from railnav.sensor_data import SensorData

__all__ = ["navigate", "TripSamples", "trip_samples", "Start", "run_monitor"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
Progress = Callable[[int, int], None]
#: Where a run starts: a state, or a function of the run's filter object that gives one
#: (e.g. the truth plus a draw from the filter's own initial covariance).
Start = InitialState | Callable[[Filter], InitialState]


def navigate(track, data: SensorData, config: NavigatorConfig = NavigatorConfig(), *,
             outages=(), initial: Start | None = None,
             progress: Progress | None = None) -> NavigationResult:
    """Run a filter over a trip.

    Parameters
    ----------
    track : trackmodel.Track
        The track the vehicle is on (the unconstrained filter uses it only for its initial
        attitude from a GNSS fix and for the outputs).
    data : SensorData
        IMU and/or GNSS data with their common time reference.
    config : NavigatorConfig
    outages : sequence of gnss_obs.Outage
        GNSS outages (s from the trip start): the GNSS data inside a total outage are not
        used.
    initial : InitialState or callable(filter object) -> InitialState, optional
        Start here instead of at the first GNSS fix.
    progress : callable(done, total), optional
        Called with the number of filter steps done.

    Returns
    -------
    NavigationResult

    Raises
    ------
    RailnavError
        Inconsistent inputs (no IMU for an inertial filter, no GNSS and no initial state).
    ekf.FilterDivergedError
        If the covariance loses positive definiteness.
    """
    started = time.perf_counter()
    trip = trip_samples(data, config, outages=outages, track=track, body=True)
    others = (trip.fixes is not None or trip.odometer is not None or trip.balises is not None
              or bool(trip.body))
    filt = make_filter(track, config, trip.gnss, fixes=trip.fixes,
                       schedule=trip.schedule if others else None, odometer=trip.odometer,
                       balises=trip.balises, body=trip.body)
    if initial is None and trip.gnss is None and trip.fixes is not None:
        initial = initial_from_fixes(filt, trip.fixes, config)
    elif initial is None:
        initial = initial_from_gnss(filt, data, config, trip.gnss)
    elif callable(initial):
        initial = initial(filt)
    if initial.noise_seed and hasattr(filt, "noise_scale"):
        filt.noise_scale.seed(initial.noise_seed)
    t, u, epoch_idx = trip.from_time(initial.time_s)
    loop = ChunkLoop(filt, config, sample_interval_s=float(np.median(np.diff(t))))
    loop.monitor = run_monitor(filt, data, config, trip.fixes, start_s=float(t[0]))
    at_sample = np.searchsorted(t, trip.epoch_times[epoch_idx] - EPOCH_TIME_TOL_S)
    parts = list(loop.stream(loop.chunks(t, u, at_sample),
                             loop.epochs(t[at_sample], epoch_idx), initial,
                             progress=progress, total=t.size - 1))
    left = loop.left
    if left is not None:
        left["gps_time_s"] = left["time_s"] + data.start_gps_time_s
        log.warning("stopped at t=%.3f s: s = %.2f m is beyond the track's %s (length %.2f m); "
                    "the data after it were not used", left["time_s"], left["s_m"],
                    left["end"], left["track_length_m"])
    return NavigationResult.assemble(
        filt, config, concatenate_results(parts), start_gps_time_s=data.start_gps_time_s,
        outages=outages, epoch_indices=epoch_idx, epoch_times=trip.epoch_times,
        runtime_s=time.perf_counter() - started, left_track=left,
        monitor=None if loop.monitor is None else loop.monitor.frame())


def run_monitor(filt, data: SensorData | None, config: NavigatorConfig, fixes=None, *,
                start_s: float = 0.0) -> FilterMonitor | None:
    """The divergence monitor of a run (`railnav.navigation.monitor`): for a track-based
    filter with ``config.monitor.enabled``; None otherwise. Its fix test solves each
    epoch's own rows on the track (`railnav.navigation.snapshot.snapshot_fix`); a recovery
    restarts from the run's position fix of the epoch or, without fixes, from the
    single-point fix of its GNSS observations, solved then (`spp_fix_at`; `data` None, a
    streamed run: the restart widens the covariance only). `start_s` is
    kept for callers (unused: nothing is solved ahead)."""
    names = getattr(getattr(filt, "layout", None), "names", ())
    if not config.monitor.enabled or "s" not in names or "v" not in names \
            or getattr(filt, "track", None) is None:
        return None
    screen = getattr(filt, "screen", None)
    if fixes is not None:
        return FilterMonitor(filt.layout, fix_log_track_fixes(filt.track, fixes, filt=filt,
                                                              config=config),
                             config.monitor, config.gate_probability, screen=screen,
                             pseudorange_inflation=getattr(filt, "fix_inflation", 1.0))
    fix_at = spp_fix_at(filt.track, data, config, filt=filt) \
        if data is not None and data.obs is not None and data.nav is not None else None
    return FilterMonitor(filt.layout, None, config.monitor, config.gate_probability,
                         fix_at=fix_at, screen=screen,
                         pseudorange_inflation=getattr(filt, "pseudorange_inflation", 1.0))


@dataclass(frozen=True, eq=False)
class TripSamples:
    """What a run filters: the sample grid (GNSS epochs inserted) and the GNSS epochs.

    Attributes
    ----------
    t : ndarray, shape (M,)
        Sample times, s from the trip start.
    u : ndarray, shape (M, n_u)
        Inputs of the samples (interpolated at inserted epochs).
    gnss : railnav.filters.gnss_epochs.GnssEpochs or None
    epoch_times : ndarray, shape (E,)
        Measurement epoch times (GNSS epochs and fixes), s from the trip start.
    fixes : railnav.filters.fix_epochs.FixEpochs or None
    schedule : railnav.filters.fix_epochs.EpochSchedule
        Which GNSS epoch, fix, odometer reading and balise passage each epoch has.
    odometer : railnav.filters.odometer_epochs.OdometerEpochs or None
    balises : railnav.filters.balise_epochs.BaliseEpochs or None
    body : dict
        The attitude and standstill streams (`railnav.filters.body_rows`; empty: none).
    """

    t: Array
    u: Array
    gnss: GnssEpochs | None
    epoch_times: Array
    fixes: FixEpochs | None = None
    schedule: EpochSchedule | None = None
    odometer: object = None
    balises: object = None
    body: dict = field(default_factory=dict)

    def from_time(self, start_s: float) -> tuple[Array, Array, npt.NDArray[np.intp]]:
        """Samples ``t, u`` from `start_s` on and the indices of the epochs they reach.

        Raises
        ------
        RailnavError
            Fewer than two samples from `start_s`.
        """
        first = int(np.searchsorted(self.t, start_s - EPOCH_TIME_TOL_S))
        t, u = self.t[first:], self.u[first:]
        if t.size < 2:
            raise RailnavError("fewer than two samples after the initial time: nothing to "
                               "filter")
        return t, u, np.flatnonzero(self.epoch_times >= t[0] - EPOCH_TIME_TOL_S)


def trip_samples(data: SensorData, config: NavigatorConfig, *, outages=(),
                 track=None, body: bool = False) -> TripSamples:
    """The samples and GNSS epochs of a trip (steps 1–2 of `navigate`; also used to run
    several filters over the same data, `railnav.navigation.network_navigator`); `track` projects
    balises given as coordinates; `body`: also the attitude and standstill streams that
    ``config`` asks for (`railnav.filters.body_rows.body_stream_epochs`; one filter only)."""
    samples_t, samples_u = _sample_times(data, config)
    gnss = fixes = None
    if data.obs is not None:
        gnss = GnssEpochs.from_files(data.obs, data.nav, config.measurement,
                                     start_gps_time_s=data.start_gps_time_s,
                                     end_s=float(samples_t[-1]), outages=outages,
                                     elevation_mask_deg=config.elevation_mask_deg,
                                     augmentation=data.augmentation)
    if data.fixes is not None:
        fixes = FixEpochs.from_table(data.fixes.table, start_gps_time_s=data.start_gps_time_s,
                                     end_s=float(samples_t[-1]), outages=outages)
    sensors = track_sensor_epochs(data, config, track, span_s=(float(samples_t[0]),
                                                               float(samples_t[-1])))
    streams = body_stream_epochs(config, samples_t, samples_u,
                                 odometer=sensors.get("odometer"), fixes=fixes) if body else {}
    schedule = EpochSchedule.merge(gnss.time_s if gnss is not None else [],
                                   fixes.time_s if fixes is not None else [],
                                   tol_s=EPOCH_TIME_TOL_S,
                                   extra={k: v.time_s for k, v in {**sensors,
                                                                   **streams}.items()})
    if data.imu is not None:
        _check_overlap(data, samples_t, schedule.time_s)
    samples_t, samples_u = _insert_samples(samples_t, samples_u, schedule.time_s)
    return TripSamples(samples_t, samples_u, gnss, schedule.time_s, fixes, schedule,
                       sensors.get("odometer"), sensors.get("balises"), streams)


def _gnss_sources(data: SensorData) -> list[tuple[str, Array]]:
    """(name, GPS times) of the GNSS observations and fixes given (names: their files)."""
    return [(name, frame["gps_time_s"].to_numpy(dtype=float)) for name, frame in (
        (getattr(data.obs, "path", None) or "GNSS observations",
         data.obs.table if data.obs is not None else None),
        (getattr(data.fixes, "path", None) or "GNSS fixes",
         data.fixes.table if data.fixes is not None else None)) if frame is not None]


def _check_overlap(data: SensorData, t: Array, epoch_times: Array) -> None:
    """An error when no GNSS epoch or fix falls within the IMU samples' time span."""
    sources = _gnss_sources(data)
    inside = (epoch_times >= t[0] - EPOCH_TIME_TOL_S) & (epoch_times <= t[-1] + EPOCH_TIME_TOL_S)
    if not sources or inside.any():
        return
    if not any(g.size for _, g in sources):
        raise RailnavError(f"{', '.join(name for name, _ in sources)}: no GNSS observation "
                           "or fix in the file")
    spans = "; ".join(f"{name} {np.min(g) - data.start_gps_time_s:.1f} to "
                      f"{np.max(g) - data.start_gps_time_s:.1f} s" if g.size else f"{name} empty"
                      for name, g in sources)
    raise RailnavError(f"the IMU samples ({t[0]:.1f} to {t[-1]:.1f} s from the trip start, "
                       f"GPS time {data.start_gps_time_s:.1f} s) and the GNSS data ({spans}) "
                       "do not overlap: check the IMU's time_s and start_gps_time_s",
                       arguments=("start_gps_time_s",))


def _sample_times(data: SensorData, config: NavigatorConfig) -> tuple[Array, Array]:
    """Sample times (s) and inputs of the filter before epochs are inserted."""
    if not filter_kind(config.filter).needs_imu:
        if data.obs is None and data.fixes is None:
            raise RailnavError(f"the {config.filter} filter needs GNSS observations or fixes")
        sources = _gnss_sources(data)
        t_obs = np.unique(np.concatenate([g for _, g in sources])) - data.start_gps_time_s
        t_obs = t_obs[t_obs >= -EPOCH_TIME_TOL_S]
        if t_obs.size < 2:
            raise RailnavError(f"{', '.join(name for name, _ in sources)}: fewer than two "
                               "GNSS epochs or fixes after the trip start")
        grid = np.arange(t_obs[0], t_obs[-1], 1.0 / config.output_rate_hz)
        # a grid time within the tolerance of an epoch is that epoch (2.5-Hz fixes at
        # fractional GPS seconds fell 1e-7 s beside 10-Hz grid times: two rows each)
        t = np.union1d(grid[~_near(t_obs, grid)], t_obs)
        return t, np.zeros((t.size, 0))
    if data.imu is None:
        raise RailnavError(f"the {config.filter} filter needs IMU data")
    t = np.asarray(data.imu.time_s, dtype=float)
    if t.size < 2 or not np.all(np.diff(t) > 0):
        raise RailnavError("IMU times must be increasing with at least two samples")
    return t, imu_at_reference(data.imu, config).u


def _near(t: Array, x: Array) -> Array:
    """Which of `x` lie within ``EPOCH_TIME_TOL_S`` of a time of `t` (sorted, >= 2)."""
    j = np.clip(np.searchsorted(t, x), 1, t.size - 1)
    return np.minimum(np.abs(t[j] - x), np.abs(t[j - 1] - x)) <= EPOCH_TIME_TOL_S


def _insert_samples(t: Array, u: Array, epoch_times: Array) -> tuple[Array, Array]:
    """Add samples at epoch times that fall between samples (inputs interpolated)."""
    inside = (epoch_times >= t[0] - EPOCH_TIME_TOL_S) & (epoch_times <= t[-1] + EPOCH_TIME_TOL_S)
    e = epoch_times[inside]
    new = e[~_near(t, e)]
    if new.size == 0:
        return t, u
    t_all = np.union1d(t, new)
    if u.shape[1] == 0:
        return t_all, np.zeros((t_all.size, 0))
    u_all = np.column_stack([np.interp(t_all, t, u[:, k]) for k in range(u.shape[1])])
    log.debug("%d GNSS epochs between IMU samples: samples inserted", new.size)
    return t_all, u_all
