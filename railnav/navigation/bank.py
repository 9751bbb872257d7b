r"""Parallel-track identification: one constrained filter per candidate track, in lockstep.

The hypotheses are "the train is on track j" (the tracks of a double line, the routes
after a switch). `navigate_tracks` runs one constrained INS/GNSS filter per candidate
track over the same data, chunk by chunk in lockstep (`railnav.navigation.loop.ChunkLoop`:
every chunk ends at a GNSS epoch or after `MAX_CHUNK_S`), and after each chunk (a *cycle*):

1. **Evidence.** Each filter's fault screen (`railnav.filters.fault_detection.RowScreen.last`)
   holds the epoch's GNSS innovations at its prior and their full covariance
   ``S = H P Hᵀ + R``, for every row it saw (used or not). The cycle's log-likelihood of
   track j is ``log N(ν_j; 0, S_j)`` over one set of rows for all hypotheses: the rows
   that **some** filter used (the union; rows seen by every filter). A row that the
   filter on the wrong track rejects or excludes because the 4.5-m offset biases it
   (its drift test does see that) is exactly the evidence against that track, and
   counts; a row every filter refuses (a satellite fault) does not. A cycle without an
   epoch (GNSS outage) brings no evidence. The accelerometer pseudo-observation is not
   used as evidence: the curvature of two tracks 4.5 m apart differs by 0.75 % in a 600-m
   curve, less than surveyed track geometry can be trusted.
2. **Switching prior.** The track index is a Markov chain that leaves a track at
   `TrackBankConfig.crossing_rate_per_s` to the others alike
   (`ekf.uniform_switching`): ``Π(Δt) = 11ᵀ/J + (I − 11ᵀ/J) e^{−J ε Δt/(J−1)}``. The
   probabilities follow the exact forward recursion of that chain given the likelihoods
   (`ekf.switching_update`): ``μ_j ∝ L_j Σ_i Π_ij(Δt) μ_i``. Without evidence (an outage)
   they relax towards the stationary ``1/J``: for two tracks ``μ − ½`` decays as
   ``e^{−2εt}``. ε also sets a floor ``~ε Δt / (1 − e^{−λ})`` under the probability of the
   wrong track (λ the evidence per epoch), from which noisy epochs lift it: with
   λ ≈ 0.6 ± 1.3 nats per epoch (4.5 m, σ_pr = 3 m, measured) the wrong track's log-odds
   is a random walk reflected at that floor whose excursions above it are exponential
   with rate ``2 mean/var`` ≈ 0.7 per nat, so "> 0.99 at 95 % of the epochs" needs the
   floor ``≲ 0.01 e^{−3/0.7}``, ε ≲ 5e-5 /s. The default ε = 1e-5 /s (one crossing per
   ~28 h of running: crossovers of a double line are used in disruptions only) keeps the
   identification through outages (μ − ½ halves in 9.6 h); give a larger ε where trains
   do change tracks (station throats), and 0 for a line without crossovers (a static
   bank).
3. **States (IMM, Blom & Bar-Shalom 1988; `ekf.imm_starts`).** Each filter restarts the next
   cycle from the mixture ``Σ_i μ_{i|j} x_{i→j}`` of all filters' estimates brought onto its
   own track (`convert_state`: the position ``r_i(s_i)`` projected onto track j gives
   ``s_j``; attitude kept relative to the track, speed and the other states as they are;
   the covariance is kept: the mapping's Jacobian is the identity to ``O(κ d)``, 0.75 %
   in a 600-m curve at 4.5 m). The weights use the previous cycle's interval (cycles are
   equal, 1 s, except at outage edges); weights below `min_mixing_weight` are skipped.
   The filter on an unlikely track is thus kept near the likely one (it would otherwise
   drift on its wrong geometry), ready if the train does cross.

A filter whose vehicle leaves its track (`railnav.navigation.loop.beyond_track`) stops; its
hypothesis gets probability 0 from then on.

Identifiability: the per-epoch evidence between two tracks ``d`` apart is about
``d²/(2σ_x²)`` nats, ``σ_x`` the cross-track σ of one epoch's GNSS position (≈ HDOP σ_pr);
with white errors it accumulates without bound, so any spacing is identified in time
(d = 4.5 m, σ_pr = 3 m: ~0.5–1 nat per epoch); errors correlated over τ (multipath,
atmosphere) bring one such evidence per τ only, and a bias of the GNSS position across
the track of the order of ``d/2`` makes the wrong track as likely as the right one:
no time helps then.
"""
from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

from ekf.bank import imm_starts, switching_update, uniform_switching
from ekf.history import concatenate_results
from ekf.update import LOG_2PI
from railnav.config import NavigatorConfig, SensorData
from railnav.defaults import DEFAULT_CROSSING_RATE_PER_S
from railnav.errors import ConfigError, RailnavError
from railnav.filters.protocol import FILTER_KINDS, filter_kind, make_filter
from railnav.navigation.bank_result import TrackBankResult
from railnav.navigation.initialization import InitialState, initial_from_gnss
from railnav.navigation.loop import EPOCH_TIME_TOL_S, ChunkLoop
from railnav.navigation.navigator import trip_samples
from railnav.navigation.result import NavigationResult
from trackmodel.earth import C_n_e

__all__ = ["TrackBankConfig", "navigate_tracks", "convert_state", "moved_state",
           "Correspondence", "common_log_likelihoods", "evidence_rows",
           "DEFAULT_CROSSING_RATE_PER_S"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]
Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class TrackBankConfig:
    """The multiple-model part of parallel-track identification.

    Parameters
    ----------
    crossing_rate_per_s : float
        ε >= 0: the rate at which the train leaves its track for another, 1/s.
    min_mixing_weight : float
        IMM mixing weights below this are skipped (they move a start by less than this
        fraction of the difference of two filters' estimates), in [0, 1).
    """

    crossing_rate_per_s: float = DEFAULT_CROSSING_RATE_PER_S
    min_mixing_weight: float = 1e-6

    def __post_init__(self) -> None:
        rate = self.crossing_rate_per_s
        if not (isinstance(rate, (int, float)) and math.isfinite(rate) and rate >= 0):
            raise ConfigError(f"crossing_rate_per_s must be a finite number >= 0, got {rate!r}")
        w = self.min_mixing_weight
        if not (isinstance(w, (int, float)) and 0.0 <= w < 1.0):
            raise ConfigError(f"min_mixing_weight must be in [0, 1), got {w!r}")


def convert_state(source, target, x: Array, P: Array) -> tuple[Array, Array]:
    """A constrained filter's state on `source`'s track expressed on `target`'s track.

    Parameters
    ----------
    source, target : railnav.filters.constrained.ConstrainedFilter
        Filters of one layout on two tracks running the same direction.
    x : ndarray, shape (n,)
    P : ndarray, shape (n, n)

    Returns
    -------
    x, P : ndarray
        ``s`` of the nearest point of the target track (plus any excess beyond the source
        track's ends), yaw and pitch changed by the difference of the tracks' azimuth and
        elevation there; the covariance unchanged (module docstring).

    Raises
    ------
    RailnavError
        If the tracks run in opposite directions there.
    """
    lay = source.layout
    i_s = lay.index("s")
    s_raw = float(x[i_s])
    s_src = min(max(s_raw, 0.0), source.track.length_m)
    p_src = source.track.at(s_src)
    s_tgt = float(target.track.project(p_src.lat, p_src.lon, p_src.h).s[0]) + (s_raw - s_src)
    p_tgt = target.track.at(min(max(s_tgt, 0.0), target.track.length_m))
    if float(np.dot(p_src.u_n, p_tgt.u_n)) <= 0.0:
        raise RailnavError(f"candidate tracks must run in the same direction (not so at "
                           f"s = {s_src:.1f} m)")
    return moved_state(source, x, s_tgt, p_src, p_tgt), P


def moved_state(filt, x: Array, s_new: float, p_src, p_tgt) -> Array:
    """``x`` with ``s = s_new``, the attitude turned from `p_src`'s azimuth/elevation to
    `p_tgt`'s."""
    lay = filt.layout
    out = np.array(x, dtype=float)
    out[lay.index("s")] = s_new
    if "yaw" not in lay.names:
        return out                          # no attitude (the GNSS-only filter)
    turn = (float(p_tgt.azimuth) - float(p_src.azimuth) + math.pi) % (2 * math.pi) - math.pi
    out[lay.index("yaw")] += turn
    out[lay.index("pitch")] += float(p_tgt.elevation) - float(p_src.elevation)
    return out


class Correspondence:
    """`convert_state` between the filters of a bank, fast: the target ``s`` from one
    Newton step along the target's tangent, started from the last offset ``s_j − s_i``
    found for the pair (the offset drifts by ``~κ d`` per metre: centimetres per cycle),
    falling back to `convert_state`'s projection when the step exceeds `NEWTON_MAX_STEP_M`.

    Parameters
    ----------
    filters : sequence of ConstrainedFilter
    """

    #: A Newton step longer than this (m) means the guess was poor: project instead.
    NEWTON_MAX_STEP_M = 1.0

    def __init__(self, filters: Sequence) -> None:
        self.filters = list(filters)
        self._offset: dict[tuple[int, int], float] = {}

    def __call__(self, i: int, j: int, x: Array, P: Array) -> tuple[Array, Array]:
        """Filter i's estimate in filter j's coordinates."""
        src, tgt = self.filters[i], self.filters[j]
        i_s = src.layout.index("s")
        s_raw = float(x[i_s])
        if (i, j) not in self._offset:
            out = convert_state(src, tgt, x, P)
            self._offset[(i, j)] = float(out[0][i_s]) - s_raw
            return out
        s_src = min(max(s_raw, 0.0), src.track.length_m)
        guess = min(max(s_src + self._offset[(i, j)], 0.0), tgt.track.length_m)
        p_src, p_tgt = src.track.at(s_src), tgt.track.at(guess)
        t_e = p_tgt.r_e - p_src.r_e   # target point minus source point
        tangent_e = C_n_e(float(p_tgt.lat), float(p_tgt.lon)) @ np.asarray(p_tgt.u_n)
        step = -float(t_e @ tangent_e)
        if abs(step) > self.NEWTON_MAX_STEP_M or float(np.dot(p_src.u_n, p_tgt.u_n)) <= 0.0:
            out = convert_state(src, tgt, x, P)
            self._offset[(i, j)] = float(out[0][i_s]) - s_raw
            return out
        s_tgt = guess + step
        self._offset[(i, j)] = s_tgt - s_src
        return moved_state(src, x, s_tgt + (s_raw - s_src), p_src,
                      tgt.track.at(min(max(s_tgt, 0.0), tgt.track.length_m))), P


def evidence_rows(screens: Sequence) -> set:
    """Keys of the rows the evidence uses: seen by every filter, used by at least one."""
    seen = set.intersection(*(set(e.keys) for e in screens))
    return seen & set.union(*(set(e.keys[e.used]) for e in screens))


def common_log_likelihoods(screens: Sequence) -> Array:
    """``log N(ν_j; 0, S_j)`` of each filter's latest epoch over the `evidence_rows`.

    Parameters
    ----------
    screens : sequence of railnav.filters.fault_detection.EpochScreen
        The same epoch screened by each filter.

    Returns
    -------
    ndarray, shape (J,)
        0 for all when there is no such row.
    """
    common = evidence_rows(screens)
    out = np.zeros(len(screens))
    if not common:
        return out
    for j, e in enumerate(screens):
        idx = np.array([k for k, key in enumerate(e.keys) if key in common])
        nu, S = e.innov[idx], e.S[np.ix_(idx, idx)]
        L = sla.cholesky(S, lower=True, check_finite=False)
        white = sla.solve_triangular(L, nu, lower=True, check_finite=False)
        out[j] = -0.5 * (white @ white + 2.0 * np.sum(np.log(np.diag(L))) + idx.size * LOG_2PI)
    return out


def navigate_tracks(tracks: Sequence, data: SensorData,
                    config: NavigatorConfig = NavigatorConfig(), *,
                    names: Sequence[str] | None = None, outages=(),
                    initial: Sequence[InitialState] | Callable | None = None,
                    bank: TrackBankConfig = TrackBankConfig(),
                    progress: Progress | None = None) -> TrackBankResult:
    """Identify the track among candidates while navigating on each (module docstring).

    Parameters
    ----------
    tracks : sequence of trackmodel.Track
        The candidate tracks (>= 2), running the same direction from abreast starts.
    data : SensorData
        IMU and GNSS.
    config : NavigatorConfig
        Must be the constrained filter's.
    names : sequence of str, optional
        One per track (default ``track0, track1, …``).
    outages : sequence of (start_s, duration_s)
    initial : sequence of InitialState, or callable(filter objects) -> that, optional
        One per track at the same time; default: the first GNSS fix projected onto each.
    bank : TrackBankConfig
    progress : callable(done, total), optional
        Filter steps summed over the tracks.

    Returns
    -------
    TrackBankResult
    """
    started = time.perf_counter()
    names = tuple(names) if names is not None else tuple(f"track{j}" for j in range(len(tracks)))
    if len(tracks) < 2 or len(names) != len(tracks) or len(set(names)) != len(names):
        raise ConfigError("a track bank needs at least two tracks with distinct names")
    _check_bank_inputs(config, data)
    trip = trip_samples(data, config, outages=outages)
    filters = [make_filter(track, config, trip.gnss) for track in tracks]
    if callable(initial):
        initial = initial(filters)
    elif initial is None:
        initial = [initial_from_gnss(f, data, config, trip.gnss) for f in filters]
    if len(initial) != len(tracks) or len({round(i.time_s, 9) for i in initial}) != 1:
        raise ConfigError("give one initial state per track, all at the same time")
    t, u, epoch_idx = trip.from_time(initial[0].time_s)
    lockstep = _Lockstep(filters, config, t, u, trip.epoch_times, epoch_idx, initial)
    record = _run_bank(lockstep, bank, progress)
    results = []
    for f, parts, loop in zip(filters, lockstep.parts, lockstep.loops):
        raw = concatenate_results(parts)
        left_track = None if loop.left is None else dict(
            loop.left, gps_time_s=loop.left["time_s"] + data.start_gps_time_s)
        results.append(NavigationResult.assemble(
            f, config, raw, start_gps_time_s=data.start_gps_time_s, outages=outages,
            epoch_indices=epoch_idx, epoch_times=trip.epoch_times,
            runtime_s=time.perf_counter() - started, left_track=left_track))
    return TrackBankResult(names=names, results=tuple(results), bank=bank,
                           start_gps_time_s=float(data.start_gps_time_s),
                           runtime_s=time.perf_counter() - started, **record)


def _check_bank_inputs(config: NavigatorConfig, data) -> None:
    """A bank runs a filter kind that banks, on GNSS observations (no position fixes)."""
    if not filter_kind(config.filter).banks:
        raise ConfigError(f"parallel-track identification runs a filter that can run in a "
                          f"bank ({', '.join(k for k in FILTER_KINDS if filter_kind(k).banks)}"
                          f"), not {config.filter!r}")
    if data.fixes is not None:
        raise ConfigError("GNSS position fixes work with one track (a track bank runs on "
                          "GNSS observations)")


class _Lockstep:
    """One chunk loop (`railnav.navigation.loop.ChunkLoop`) per filter over the same
    samples, advanced together."""

    def __init__(self, filters, config, t, u, epoch_times, epoch_idx, initial) -> None:
        dt = float(np.median(np.diff(t)))
        at_sample = np.searchsorted(t, epoch_times[epoch_idx] - EPOCH_TIME_TOL_S)
        self.filters = filters
        self.loops = [ChunkLoop(f, config, sample_interval_s=dt) for f in filters]
        self.engines = [loop.engine for loop in self.loops]
        self.parts: list[list] = [[] for _ in filters]
        self.total = (t.size - 1) * len(filters)
        self.streams = [loop.stream(loop.chunks(t, u, at_sample),
                                    loop.epochs(t[at_sample], epoch_idx), init)
                        for loop, init in zip(self.loops, initial)]
        self.alive = [True] * len(filters)
        self.steps = 0
        self.convert = Correspondence(filters)

    def advance(self) -> list[int] | None:
        """Filter the next chunk on every live track; the new screened epochs of each
        (None when every stream has ended)."""
        new = []
        for j, stream in enumerate(self.streams):
            if not self.alive[j]:
                new.append(0)
                continue
            before = len(self.filters[j].screen.epochs)
            part = next(stream, None)
            if part is None:
                self.alive[j] = False
                new.append(0)
                continue
            self.parts[j].append(part)
            self.steps += int(part.nis_c_count)
            new.append(len(self.filters[j].screen.epochs) - before)
        return new if any(self.alive) else None


def _run_bank(lock: _Lockstep, bank: TrackBankConfig, progress: Progress | None) -> dict:
    """The lockstep cycles: evidence, probabilities and mixing (module docstring)."""
    J = len(lock.filters)
    log_mu = np.full(J, -math.log(J))
    t_prev = float(lock.engines[0].t) if np.isfinite(lock.engines[0].t) else None
    times, probs, logliks, rows = [], [], [], []
    dt_prev = 0.0
    while (new := lock.advance()) is not None:
        alive = np.array(lock.alive)
        t_now = max(float(e.t) for e, a in zip(lock.engines, alive) if a)
        dt = t_now - t_prev if t_prev is not None else 0.0
        log_lik = np.zeros(J)
        n_rows = 0
        counts = {new[j] for j in np.flatnonzero(alive)}
        if counts != {0}:
            if len(counts) != 1:
                raise RailnavError("the track filters screened different numbers of epochs")
            screens = [lock.filters[j].screen.last for j in np.flatnonzero(alive)]
            log_lik[alive] = common_log_likelihoods(screens)
            n_rows = len(evidence_rows(screens))
        log_lik[~alive] = -np.inf
        log_mu = switching_update(log_mu, log_lik,
                                  uniform_switching(J, bank.crossing_rate_per_s, dt))
        times.append(t_now)
        probs.append(np.exp(log_mu))
        logliks.append(log_lik)
        rows.append(n_rows)
        _mix(lock, np.exp(log_mu), alive, bank, dt if dt > 0 else dt_prev)
        t_prev, dt_prev = t_now, dt if dt > 0 else dt_prev
        if progress is not None:
            progress(lock.steps, lock.total)
    return {"time_s": np.array(times), "probabilities": np.array(probs).reshape(-1, J),
            "log_likelihoods": np.array(logliks).reshape(-1, J),
            "common_rows": np.array(rows, dtype=int)}


def _mix(lock: _Lockstep, mu: Array, alive: npt.NDArray[np.bool_], bank: TrackBankConfig,
         dt: float) -> None:
    """IMM restart of the live filters for the next cycle."""
    live = np.flatnonzero(alive)
    if live.size < 2 or bank.crossing_rate_per_s == 0.0:
        return
    m = mu[live] / mu[live].sum()
    transition = uniform_switching(live.size, bank.crossing_rate_per_s, dt)
    engines = [lock.engines[j] for j in live]
    x0, P0 = imm_starts(m, transition, [e.x for e in engines], [e.P for e in engines],
                        convert=lambda i, j, x, P: lock.convert(int(live[i]), int(live[j]), x, P),
                        min_weight=bank.min_mixing_weight)
    for engine, x, P in zip(engines, x0, P0):
        engine.x, engine.P = np.asarray(x, dtype=float), np.asarray(P, dtype=float)
