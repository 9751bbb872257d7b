"""The navigator: runs a filter over a trip's sensor data on a track.

`navigate` is the one entry point behind ``railnav run`` and the notebooks. It

1. cuts the GNSS observations into epochs (`railnav.filters.gnss_epochs`), without the outage
   windows;
2. builds the sample grid: the IMU samples (a sample is inserted, its input interpolated,
   where a GNSS epoch falls between two), or for the GNSS-only filter a grid at the
   output rate plus the epochs;
3. starts from the given `InitialState` or from the first GNSS fix
   (`railnav.navigation.initialization`);
4. streams the samples through `ekf.CdFilter` in chunks that end at GNSS epochs, so that
   each chunk's track linearization starts from the latest posterior, and each epoch's
   rows are built at the prior of that epoch (a callable `ekf.Epoch`);
5. stops early, with a warning, when a track-based filter's vehicle leaves the track
   (`beyond_track`: ``s`` beyond an end and the speed pointing away from the track, each by
   more than `END_MARGIN_SIGMA` σ; the vehicle drove off the part of the line the track
   describes, e.g. a survey's first leg); the result says where
   (`NavigationResult.left_track`);
6. assembles a `railnav.navigation.result.NavigationResult` (estimates, innovations, statistics).

Time: ``time_s`` is seconds from the trip start, whose GPS time is
``SensorData.start_gps_time_s``.

Filter objects (`make_filter`; `railnav.filters.constrained.ConstrainedFilter` is the
reference implementation) provide:

* ``layout`` (`ekf.StateLayout`), ``process`` (`ekf.CdModel`), ``q_c`` (its noise
  densities), ``needs_imu``, and ``rows`` with ``rows_sv``/``rows_kind`` lists (one array
  per processed epoch: the satellite and kind of each GNSS row, for ``innovations.csv``);
* ``inputs(t, u, x_prev, P_prev, t_prev) -> (u, p, r_c)``: the engine inputs, per-step
  parameters and continuous-measurement noise densities (None: none) of the samples ``t``
  that follow the state ``x_prev`` (covariance ``P_prev``) at ``t_prev``;
* ``observations(index, x, P) -> list of ekf.Observation``: the rows of GNSS epoch
  ``index`` at the prior ``(x, P)``;
* ``estimates(x, P_packed) -> dict of columns`` (`railnav.navigation.result`);
* ``initial_covariance(*, sigma_s_m, sigma_v_mps)``, ``initial_from_fix(fix)`` and
  ``truth_states(truth, clock_bias_m, clock_drift_mps) -> (x_true, known)``.
"""
from __future__ import annotations

import functools
import logging
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ekf.cd_filter import CdFilter, FilterConfig
from ekf.gating import Gate
from ekf.history import concatenate_results
from ekf.series import Epoch, InputSeries
from railnav.errors import RailnavError
from railnav.filters.gnss_epochs import GnssEpochs
from railnav.config import NavigatorConfig, SensorData
from railnav.navigation.result import NavigationResult

__all__ = ["navigate", "InitialState", "make_filter", "TripSamples", "trip_samples",
           "EPOCH_TIME_TOL_S", "MAX_CHUNK_S", "END_MARGIN_SIGMA", "beyond_track",
           "filter_engine", "input_chunks", "max_chunk_samples"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
Progress = Callable[[int, int], None]

#: A GNSS epoch within this of a sample time is taken at that sample, s.
EPOCH_TIME_TOL_S = 1e-6
#: Longest chunk between track re-linearizations when no GNSS epoch comes (outages), s.
MAX_CHUNK_S = 1.0
#: A run stops when ``s`` is beyond a track end, and ``v`` points away from it, each by more
#: than this many of its σ (3σ: a vehicle standing at an end is flagged with probability
#: below 1e-3 per epoch even if the two errors were fully correlated).
END_MARGIN_SIGMA = 3.0


@dataclass(frozen=True)
class InitialState:
    """A filter's starting point.

    Attributes
    ----------
    time_s : float
        Time of the prior, s from the trip start.
    x0 : ndarray, shape (n,)
    P0 : ndarray, shape (n, n)
        In the filter's `ekf.StateLayout`.
    """

    time_s: float
    x0: Array
    P0: Array


def make_filter(track, config: NavigatorConfig, gnss: GnssEpochs | None):
    """The filter object of ``config.filter`` (constrained / unconstrained / gnss-only)."""
    if config.filter == "constrained":
        from railnav.filters.constrained import ConstrainedFilter
        return ConstrainedFilter(track, config, gnss)
    if config.filter == "unconstrained":
        from railnav.filters.unconstrained import UnconstrainedFilter
        return UnconstrainedFilter(track, config, gnss)
    if config.filter == "gnss-only":
        from railnav.filters.gnss_only import GnssOnlyFilter
        return GnssOnlyFilter(track, config, gnss)
    raise RailnavError(f"unknown filter {config.filter!r}")


def navigate(track, data: SensorData, config: NavigatorConfig = NavigatorConfig(), *,
             outages=(), initial: InitialState | None = None,
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
    outages : sequence of (start_s, duration_s)
        GNSS outage windows imposed on the data (s from the trip start).
    initial : InitialState, optional
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
    trip = trip_samples(data, config, outages=outages)
    filt_obj = make_filter(track, config, trip.gnss)
    if initial is None:
        from railnav.navigation.initialization import initial_from_gnss
        initial = initial_from_gnss(filt_obj, data, config, trip.gnss)
    samples_t, samples_u, epoch_idx = trip.from_time(initial.time_s)
    epoch_times = trip.epoch_times
    result, left = _run(filt_obj, config, samples_t, samples_u, epoch_times, epoch_idx,
                        initial, progress)
    if left is not None:
        left["gps_time_s"] = left["time_s"] + data.start_gps_time_s
        log.warning("stopped at t=%.3f s: s = %.2f m is beyond the track's %s (length %.2f m); "
                    "the data after it were not used", left["time_s"], left["s_m"],
                    left["end"], left["track_length_m"])
    return NavigationResult.assemble(
        filt_obj, config, result, start_gps_time_s=data.start_gps_time_s, outages=outages,
        epoch_indices=epoch_idx, epoch_times=epoch_times,
        runtime_s=time.perf_counter() - started, left_track=left)


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
        GNSS epoch times, s from the trip start.
    """

    t: Array
    u: Array
    gnss: GnssEpochs | None
    epoch_times: Array

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


def trip_samples(data: SensorData, config: NavigatorConfig, *, outages=()) -> TripSamples:
    """The samples and GNSS epochs of a trip (steps 1–2 of `navigate`; also used to run
    several filters over the same data, `railnav.navigation.bank`)."""
    samples_t, samples_u = _sample_times(data, config)
    gnss = None
    if data.obs is not None:
        gnss = GnssEpochs.from_files(data.obs, data.nav, config.measurement,
                                     start_gps_time_s=data.start_gps_time_s,
                                     end_s=float(samples_t[-1]), outages=outages,
                                     elevation_mask_deg=config.elevation_mask_deg)
    epoch_times = gnss.time_s if gnss is not None else np.zeros(0)
    samples_t, samples_u = _insert_samples(samples_t, samples_u, epoch_times)
    return TripSamples(samples_t, samples_u, gnss, epoch_times)


def _run(filt_obj, config: NavigatorConfig, t: Array, u: Array, epoch_times: Array,
         epoch_idx: npt.NDArray[np.intp], initial: InitialState, progress: Progress | None):
    """Stream the samples through the EKF; one result for the whole trip, and where the
    filter left the track (`beyond_track`) if it did (the run stops there)."""
    dt = float(np.median(np.diff(t)))
    engine = filter_engine(filt_obj, config, sample_interval_s=dt)
    at_sample = np.searchsorted(t, epoch_times[epoch_idx] - EPOCH_TIME_TOL_S)
    left: list[dict] = []
    chunks = input_chunks(filt_obj, engine, t, u, at_sample, max_len=max_chunk_samples(dt),
                          left=left)

    def epochs() -> Iterator[Epoch]:
        for k, i in zip(at_sample, epoch_idx):
            if left:
                return
            yield Epoch(float(t[k]), functools.partial(_observations, filt_obj, int(i)))

    parts = list(engine.stream(chunks, epochs(), x0=initial.x0, P0=initial.P0,
                               progress=progress, total=t.size - 1))
    return concatenate_results(parts), (left[0] if left else None)


def filter_engine(filt_obj, config: NavigatorConfig, *, sample_interval_s: float) -> CdFilter:
    """The EKF engine of a run: the filter object's process model, the configured gate,
    estimates stored at ``config.output_rate_hz`` with their full covariance.

    Parameters
    ----------
    filt_obj : filter object (`make_filter`)
    config : NavigatorConfig
    sample_interval_s : float
        Typical interval of the filter's samples, s (sets the storage decimation).
    """
    store_every = max(1, int(round(1.0 / (config.output_rate_hz * sample_interval_s))))
    gate = None if config.gate_probability is None else Gate(config.gate_probability,
                                                             scope="rows")
    return CdFilter(filt_obj.process, FilterConfig(gate=gate, store_every=store_every,
                                                   full_covariance=True,
                                                   time_tol_s=EPOCH_TIME_TOL_S))


def max_chunk_samples(sample_interval_s: float) -> int:
    """Samples in the longest chunk between re-linearizations (`MAX_CHUNK_S`)."""
    return max(1, int(round(MAX_CHUNK_S / sample_interval_s)))


def input_chunks(filt_obj, engine: CdFilter, t: Array, u: Array,
                 at_sample: npt.NDArray[np.intp], *, max_len: int,
                 left: list[dict]) -> Iterator[InputSeries]:
    """The engine's input chunks of samples ``t``: each ends at a GNSS epoch sample or after
    `max_len` samples, and its track linearization starts from the engine's latest state.

    Consumed by `ekf.CdFilter.stream` (lazily: each chunk's inputs are computed after the
    previous chunk was filtered). Several calls may feed one stream with consecutive
    sample blocks (`railnav.navigation.streaming`).

    Parameters
    ----------
    filt_obj : filter object (`make_filter`)
    engine : ekf.CdFilter
        The engine that filters the chunks.
    t : ndarray, shape (M,)
        Sample times, s from the trip start (after the engine's last sample, if any).
    u : ndarray, shape (M, n_u)
        Raw inputs of the samples (IMU ``[f_b, ω_ib_b]``).
    at_sample : ndarray of int
        Indices into `t` of the GNSS epoch samples, increasing.
    max_len : int
        Longest chunk, samples (`max_chunk_samples`).
    left : list
        Receives the `beyond_track` record when the vehicle leaves the track; the chunks
        stop there.
    """
    start = 0
    bounds = iter(at_sample)
    next_epoch = next(bounds, None)
    while start < t.size:
        if np.isfinite(engine.t):
            left.extend(beyond_track(filt_obj, engine.x, engine.P, engine.t))
            if left:
                return
        stop = min(start + max_len, t.size)
        while next_epoch is not None and next_epoch < start:
            next_epoch = next(bounds, None)
        if next_epoch is not None and next_epoch < stop:
            stop = next_epoch + 1
        t_prev = engine.t if np.isfinite(engine.t) else t[0]
        u_c, p_c, r_c = filt_obj.inputs(t[start:stop], u[start:stop], engine.x, engine.P,
                                        t_prev)
        yield InputSeries(t=t[start:stop], u=u_c, p=p_c, q_c=filt_obj.q_c, r_c=r_c)
        start = stop


def beyond_track(filt_obj, x: Array, P: Array, time_s: float) -> list[dict]:
    """Whether a track-based filter's vehicle has left the track at one of its ends.

    It has when ``s`` is beyond the end by more than `END_MARGIN_SIGMA` σ_s and ``v``
    points away from the track by more than `END_MARGIN_SIGMA` σ_v (a vehicle standing
    at an end, or coming back, is on the track).

    Parameters
    ----------
    filt_obj : filter object
        With ``layout`` and ``track``; filters without ``s`` and ``v`` states never leave.
    x : ndarray, shape (n,)
    P : ndarray, shape (n, n)
        State and covariance at `time_s`.
    time_s : float
        s from the trip start.

    Returns
    -------
    list of dict
        Empty while on the track; else one record ``{"time_s", "s_m", "sigma_s_m",
        "end": "start"|"end", "track_length_m"}``.
    """
    names = filt_obj.layout.names
    if "s" not in names or "v" not in names:
        return []
    i, j = filt_obj.layout.index("s"), filt_obj.layout.index("v")
    s, sigma = float(x[i]), float(np.sqrt(P[i, i]))
    v_margin = END_MARGIN_SIGMA * float(np.sqrt(P[j, j]))
    length = float(filt_obj.track.length_m)
    margin = END_MARGIN_SIGMA * sigma
    past_end = s > length + margin and x[j] > v_margin
    before_start = s < -margin and x[j] < -v_margin
    if not (past_end or before_start):
        return []
    return [{"time_s": float(time_s), "s_m": s, "sigma_s_m": sigma,
             "end": "end" if past_end else "start", "track_length_m": length}]


def _observations(filt_obj, index: int, x: Array, P: Array):
    return filt_obj.observations(index, x, P)


def _sample_times(data: SensorData, config: NavigatorConfig) -> tuple[Array, Array]:
    """Sample times (s) and inputs of the filter before epochs are inserted."""
    if config.filter == "gnss-only":
        if data.obs is None:
            raise RailnavError("the gnss-only filter needs GNSS observations")
        t_obs = np.unique(data.obs.table["gps_time_s"].to_numpy()) - data.start_gps_time_s
        t_obs = t_obs[t_obs >= 0]
        if t_obs.size < 2:
            raise RailnavError("fewer than two GNSS epochs after the trip start")
        grid = np.arange(t_obs[0], t_obs[-1], 1.0 / config.output_rate_hz)
        t = np.union1d(grid, t_obs)
        return t, np.zeros((t.size, 0))
    if data.imu is None:
        raise RailnavError(f"the {config.filter} filter needs IMU data")
    t = np.asarray(data.imu.time_s, dtype=float)
    if t.size < 2 or not np.all(np.diff(t) > 0):
        raise RailnavError("IMU times must be increasing with at least two samples")
    return t, data.imu.u


def _insert_samples(t: Array, u: Array, epoch_times: Array) -> tuple[Array, Array]:
    """Add samples at epoch times that fall between samples (inputs interpolated)."""
    inside = (epoch_times >= t[0] - EPOCH_TIME_TOL_S) & (epoch_times <= t[-1] + EPOCH_TIME_TOL_S)
    e = epoch_times[inside]
    j = np.clip(np.searchsorted(t, e), 1, t.size - 1)
    near = np.minimum(np.abs(t[j] - e), np.abs(t[j - 1] - e)) <= EPOCH_TIME_TOL_S
    new = e[~near]
    if new.size == 0:
        return t, u
    t_all = np.union1d(t, new)
    if u.shape[1] == 0:
        return t_all, np.zeros((t_all.size, 0))
    u_all = np.column_stack([np.interp(t_all, t, u[:, k]) for k in range(u.shape[1])])
    log.debug("%d GNSS epochs between IMU samples: samples inserted", new.size)
    return t_all, u_all
