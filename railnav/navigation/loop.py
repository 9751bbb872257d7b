"""The one chunk loop: a filter object driven through `ekf.CdFilter` chunk by chunk.

In-memory runs (`railnav.navigation.navigator`) and streamed runs
(`railnav.navigation.streaming`) run a filter through a `ChunkLoop`:

* the samples are cut into chunks that end at GNSS epoch samples or after `MAX_CHUNK_S`,
  and each chunk's inputs (track linearization, per-step parameters) are computed from
  the engine's latest posterior (`ChunkLoop.chunks`, consumed lazily by the engine);
* each GNSS epoch's rows are built at the prior of that epoch (`ChunkLoop.epochs`);
* the loop stops, and says where (`ChunkLoop.left`), when a track-based filter's vehicle
  leaves the track at one of its ends (`beyond_track`, made sequential by `TrackEndWatch`:
  a vehicle that turns round just past an end is not stopped).

Time: ``t`` is seconds from the trip start.
"""
from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterable, Iterator

import numpy as np
import numpy.typing as npt

from ekf.cd_filter import CdFilter, FilterConfig
from ekf.gating import Gate
from ekf.series import Epoch, InputSeries
from ekf.step import WINDOW_TOL_S, StepOptions, window_median_at
from railnav.filters.common import JACOBIAN_WINDOW_S
from railnav.navigation.initialization import InitialState

__all__ = ["ChunkLoop", "TrackEndWatch", "beyond_track", "filter_engine", "EPOCH_TIME_TOL_S",
           "MAX_CHUNK_S", "END_MARGIN_SIGMA"]

Array = npt.NDArray[np.float64]
Progress = Callable[[int, int], None]

#: A GNSS epoch within this of a sample time is taken at that sample, s.
EPOCH_TIME_TOL_S = 1e-6
#: Longest chunk between track re-linearizations when no GNSS epoch comes (outages), s.
MAX_CHUNK_S = 1.0
#: Rows of the Jacobian's running median computed together, in one call (~41 s at 100 Hz,
#: 200 kB: a long in-memory run does not hold a second copy of its samples).
LIN_BATCH_SAMPLES = 4096
#: A run stops when ``s`` is beyond a track end, and ``v`` points away from it, each by more
#: than this many of its σ (3σ: a vehicle standing at an end is flagged with probability
#: below 1e-3 per epoch even if the two errors were fully correlated).
END_MARGIN_SIGMA = 3.0


class ChunkLoop:
    """One filter object, its engine, and the chunks and epochs that feed it.

    Parameters
    ----------
    filt : railnav.filters.protocol.Filter
    config : railnav.config.NavigatorConfig
        Gate and output rate of the engine (`filter_engine`).
    sample_interval_s : float
        Typical interval of the samples, s (chunk length and storage decimation).

    Attributes
    ----------
    engine : ekf.CdFilter
    left : dict or None
        Where the vehicle left the track (`TrackEndWatch`, `beyond_track`'s record) once
        it has; the chunks and epochs stop there.
    """

    def __init__(self, filt, config, *, sample_interval_s: float) -> None:
        self.filt = filt
        self.engine = filter_engine(filt, config, sample_interval_s=sample_interval_s)
        self.max_len = max(1, int(round(MAX_CHUNK_S / sample_interval_s)))
        self.left: dict | None = None
        self._end = TrackEndWatch()
        self.monitor = None      # a railnav.navigation.monitor.FilterMonitor, optional
        #: The latest samples within a window of the last block's end, and one more,
        #: ``(t, u)`` (the next block's windows look back to them).
        self._history: tuple[Array, Array] = (np.zeros(0), np.zeros((0, 0)))
        #: ``(first, rows)``: the current block's ``u_lin`` from its sample ``first``.
        self._lin: tuple[int, Array] | None = None
        if hasattr(filt, "sample_interval_s"):   # a filter that scales densities by it
            filt.sample_interval_s = float(sample_interval_s)

    def chunks(self, t: Array, u: Array, at_sample: npt.NDArray[np.intp], *,
               following: tuple[Array, Array] | None = None
               ) -> Iterator[InputSeries]:
        """The engine's input chunks of samples ``t`` (module docstring).

        Several calls may feed one stream with consecutive sample blocks (streaming); a
        chunk then ends where a block ends. Each chunk carries ``u_lin``, the Jacobian's
        running median (`filter_engine`) over the whole centred window: it looks back
        into the earlier chunks and blocks and ahead into the block and, given it, the
        next one (`following`), so that it is the same however the samples are cut (into
        blocks longer than the window: a shorter block between two others leaves the
        rows before it one block of look-ahead, and their windows may shrink).

        Parameters
        ----------
        t : ndarray, shape (M,)
            Sample times, s from the trip start (after the engine's last sample, if any).
        u : ndarray, shape (M, n_u)
            Raw inputs of the samples (IMU ``[f_b, ω_ib_b]``).
        at_sample : ndarray of int
            Indices into `t` of the GNSS epoch samples, increasing.
        following : (t, u) of the next block, optional
            The next call's arguments (streaming); without, a block's end is a chunk's.
        """
        engine, filt = self.engine, self.filt
        window = engine.propagator.data.jacobian_window_s
        start = 0
        bounds = iter(at_sample)
        next_epoch = next(bounds, None)
        self._lin = None
        while start < t.size and self.left is None:
            if math.isfinite(engine.t):
                factor = _degraded_variance_factor(self.monitor)
                self.left = self._end.check(filt, engine.x, engine.P, engine.t,
                                            variance_factor=factor)
                if self.left is not None:
                    return
            stop = min(start + self.max_len, t.size)
            while next_epoch is not None and next_epoch < start:
                next_epoch = next(bounds, None)
            if next_epoch is not None and next_epoch < stop:
                stop = next_epoch + 1
            u_lin = None if window <= 0.0 else \
                self._linearization(t, u, start, stop, following, window)
            t_prev = engine.t if math.isfinite(engine.t) else t[0]
            u_c, p_c, r_c = filt.inputs(t[start:stop], u[start:stop], engine.x, engine.P,
                                        t_prev)
            if u_lin is not None and stop == t.size:
                self._keep_recent(t, u, window)
            yield InputSeries(t=t[start:stop], u=u_c, p=p_c,
                              q_c=getattr(filt, "step_q_c", filt.q_c), r_c=r_c,
                              u_lin=u_lin)
            start = stop

    def _linearization(self, t: Array, u: Array, start: int, stop: int, following,
                       window: float) -> Array:
        """``u_lin`` of chunk ``start:stop``: rows of the running median computed
        `LIN_BATCH_SAMPLES` at a time (`_lin_rows`)."""
        lin = self._lin
        if lin is None or start < lin[0] or stop > lin[0] + lin[1].shape[0]:
            last = max(stop, min(start + LIN_BATCH_SAMPLES, t.size))
            self._lin = lin = (start, self._lin_rows(t, u, start, last, following, window))
        return lin[1][start - lin[0]:stop - lin[0]]

    def _lin_rows(self, t: Array, u: Array, start: int, stop: int, following,
                  window: float) -> Array:
        """Rows ``start:stop`` of the block's ``u_lin``: `ekf.step.window_median_at` of
        the samples around them, looking back into earlier blocks (``_history``) and
        ahead into the next one (`chunks`'s `following`): the whole series' windows,
        which shrink only at the run's first and last samples."""
        reach = window + WINDOW_TOL_S      # more than the half window each side needs
        if self._history[1].shape[1:] != u.shape[1:]:
            self._history = (np.zeros(0), np.zeros((0,) + u.shape[1:]))
        back = max(int(np.searchsorted(t, t[start] - reach, side="left")) - 1, 0)
        ahead = min(int(np.searchsorted(t, t[stop - 1] + reach, side="right")) + 1, t.size)
        t_c, u_c = [t[back:ahead]], [u[back:ahead]]
        first = start - back
        if back == 0:
            t_c.insert(0, self._history[0])
            u_c.insert(0, self._history[1])
            first += self._history[0].size
        if ahead == t.size and following is not None:
            more = int(np.searchsorted(following[0], t[-1] + reach, side="right")) + 1
            t_c.append(following[0][:more])
            u_c.append(following[1][:more])
        return window_median_at(np.concatenate(t_c), np.concatenate(u_c, axis=0), first,
                                first + stop - start, window)

    def _keep_recent(self, t: Array, u: Array, window: float) -> None:
        """Keep in ``_history`` the samples the next block's windows look back to: those
        within a window of the block's last one, and one more."""
        reach = window + WINDOW_TOL_S
        back = max(int(np.searchsorted(t, t[-1] - reach, side="left")) - 1, 0)
        t_h, u_h = t[back:], u[back:]
        if back == 0:
            t_h = np.concatenate([self._history[0], t_h])
            u_h = np.concatenate([self._history[1], u_h], axis=0)
            keep = max(int(np.searchsorted(t_h, t_h[-1] - reach, side="left")) - 1, 0)
            t_h, u_h = t_h[keep:], u_h[keep:]
        self._history = (t_h.copy(), u_h.copy())

    def epochs(self, times: Iterable[float], indices: Iterable[int], *,
               observe: Callable | None = None) -> Iterator[Epoch]:
        """The GNSS epochs at `times` (s), whose rows are ``observe(index, x, P)`` at
        their prior (default: the filter's ``observations``); they stop where the vehicle
        left the track."""
        observe = self.filt.observations if observe is None else observe
        for time_s, index in zip(times, indices):
            if self.left is not None:
                return
            rows = functools.partial(observe, int(index))
            if self.monitor is not None:
                rows = functools.partial(_watched, self.monitor, float(time_s), rows)
            yield Epoch(float(time_s), rows)

    def stream(self, chunks: Iterable[InputSeries], epochs: Iterable[Epoch],
               initial: InitialState, *, progress: Progress | None = None,
               total: int | None = None):
        """`ekf.CdFilter.stream` from `initial`: the results chunk by chunk."""
        results = self.engine.stream(chunks, epochs, x0=initial.x0, P0=initial.P0,
                                     progress=progress, total=total)
        return results if self.monitor is None else self._monitored(results)

    def _monitored(self, results):
        """The results, each chunk's epoch tested by `monitor`; a recovery replaces the
        engine's posterior before the next chunk is built from it."""
        engine = self.engine
        for result in results:
            recovered = self.monitor.epoch(result, engine.x, engine.P)
            if recovered is not None:
                engine.x, engine.P = recovered
            yield result


def _degraded_variance_factor(monitor) -> float:
    """The monitor's variance factor ``f`` of its last epoch while ``degraded`` (the
    factor `railnav.navigation.protection` puts on σ_s there), else 1: how much wider
    `TrackEndWatch` takes σ before it says the vehicle has left the track."""
    if monitor is None or not monitor.records:
        return 1.0
    last = monitor.records[-1]
    f = last.get("variance_factor", np.nan)
    return float(f) if last.get("status") == "degraded" and np.isfinite(f) and f > 1.0 \
        else 1.0


def _watched(monitor, time_s: float, rows, x: Array, P: Array):
    """`rows` at the prior ``x, P``, given to `monitor` with the prior (its snapshot fix
    is solved from them)."""
    observations = rows(x, P)
    monitor.prior(time_s, x, P, observations)
    return observations


def filter_engine(filt, config, *, sample_interval_s: float) -> CdFilter:
    """The EKF engine of a run: the filter object's process model, the configured gate,
    estimates stored at ``config.output_rate_hz`` with their full covariance (and every
    step for the RTS smoother with ``config.rts_smoothing``). A process with a continuous
    measurement (the constrained filter's track pseudo-observation) has its Jacobian
    evaluated at the running median of the inputs over `JACOBIAN_WINDOW_S`
    (`ekf.step.StepOptions.jacobian_window_s`; `ChunkLoop.chunks` gives each chunk the
    median over the whole window, across chunks and blocks).

    Parameters
    ----------
    filt : railnav.filters.protocol.Filter
    config : railnav.config.NavigatorConfig
    sample_interval_s : float
        Typical interval of the filter's samples, s (sets the storage decimation).
    """
    store_every = max(1, int(round(1.0 / (config.output_rate_hz * sample_interval_s))))
    gate = None if config.gate_probability is None else Gate(config.gate_probability,
                                                             scope="rows")
    step = StepOptions(jacobian_window_s=JACOBIAN_WINDOW_S if filt.process.n_c else 0.0)
    return CdFilter(filt.process, FilterConfig(step=step, gate=gate, store_every=store_every,
                                               full_covariance=True,
                                               time_tol_s=EPOCH_TIME_TOL_S,
                                               smoothing=config.rts_smoothing))


class TrackEndWatch:
    """`beyond_track` made sequential: the vehicle has left the track when it is beyond an
    end and moving away (`beyond_track`) and has moved on, since the first check of that
    unbroken run that found it so, by more than `END_MARGIN_SIGMA` σ_s.

    A vehicle that turns round at an end stops there; one that leaves goes on. A track
    fitted to a drive ends where its survey did, not where the vehicle turns: on the
    urban drive (``benchmarks/bench_real_data.py``, ``data/tracks/barcelona_drive.csv``,
    whose survey ends at SoW 46006 where the car's three-point turn begins) the reference
    runs on to 4.8 m past the end (SoW 46013) and stays beyond it until 46025; the
    gnss-only filter with the heading's Huber weight is there within 0.4 m of it at 46009
    (3.03σ_s beyond the end, its speed 0.37 m/s at 3.4σ_v away: `beyond_track` alone
    stopped the run, losing the drive back's 70 epochs); a second later its speed is
    below 3σ_v (GPS+Galileo: two epochs, 0.15 m on against 3σ_s = 3.5 m). A vehicle
    driving off the end at 10 m/s is stopped one 1-Hz epoch (10 m) later than by
    `beyond_track` alone (``tests/railnav/filters/test_gnss_only_filter.py``).

    While the divergence monitor says ``degraded``, ``P`` is taken times its variance
    factor (`check`'s ``variance_factor``, as `railnav.navigation.protection` widens the
    interval): a simulated trip run as plain files, whose train stands 12 s at the
    track's start while its filter's speed goes 1 m/s wrong at σ_v 0.1 m/s, was stopped
    at 13 s "beyond the track's start" with the truth at the start; it now runs on
    (``tests/railnav/navigation/test_end_watch_degraded.py``).
    """

    def __init__(self) -> None:
        self.first: dict | None = None

    def shifted(self, by_m: float) -> "TrackEndWatch":
        """A copy of this watch for the same vehicle where ``s`` reads `by_m` more (a
        network hypothesis's track rebased, or a component of its Gaussian sum along
        ``s``: `railnav.navigation.hypotheses`): how far it has moved since the first
        check of its run is kept."""
        out = TrackEndWatch()
        if self.first is not None:
            out.first = dict(self.first, s_m=self.first["s_m"] + by_m)
        return out

    def check(self, filt, x: Array, P: Array, time_s: float, *,
              variance_factor: float = 1.0) -> dict | None:
        """`beyond_track`'s record once the vehicle has left (class docstring), else None.

        Parameters
        ----------
        filt, x, P, time_s
            As `beyond_track`.
        variance_factor : float
            ≥ 1: ``P`` taken this many times larger (the divergence monitor's factor
            while ``degraded``, as the protection level takes it: a filter the monitor
            does not trust is not believed to have left on its own σ).
        """
        if variance_factor != 1.0:
            P = P * variance_factor
        left = beyond_track(filt, x, P, time_s)
        if left is None:
            self.first = None
            return None
        if self.first is None or self.first["end"] != left["end"]:
            self.first = left
        moved_m = abs(left["s_m"] - self.first["s_m"])
        return left if moved_m > END_MARGIN_SIGMA * left["sigma_s_m"] else None


def beyond_track(filt, x: Array, P: Array, time_s: float) -> dict | None:
    """Where a track-based filter's vehicle has left the track at one of its ends.

    It has when ``s`` is beyond the end by more than `END_MARGIN_SIGMA` σ_s and ``v``
    points away from the track by more than `END_MARGIN_SIGMA` σ_v (a vehicle standing
    at an end, or coming back, is on the track).

    Parameters
    ----------
    filt : railnav.filters.protocol.Filter
        Filters without ``s`` and ``v`` states never leave.
    x : ndarray, shape (n,)
    P : ndarray, shape (n, n)
        State and covariance at `time_s`.
    time_s : float
        s from the trip start.

    Returns
    -------
    dict or None
        None while on the track; else ``{"time_s", "s_m", "sigma_s_m",
        "end": "start"|"end", "track_length_m"}``.
    """
    names = filt.layout.names
    if "s" not in names or "v" not in names:
        return None
    i, j = filt.layout.index("s"), filt.layout.index("v")
    s, sigma = float(x[i]), float(np.sqrt(P[i, i]))
    v_margin = END_MARGIN_SIGMA * float(np.sqrt(P[j, j]))
    length = float(filt.track.length_m)
    margin = END_MARGIN_SIGMA * sigma
    past_end = s > length + margin and x[j] > v_margin
    before_start = s < -margin and x[j] < -v_margin
    if not (past_end or before_start):
        return None
    return {"time_s": float(time_s), "s_m": s, "sigma_s_m": sigma,
            "end": "end" if past_end else "start", "track_length_m": length}
