r"""What hypotheses on different tracks share: evidence on a common basis and states
brought from one track to another. The network navigator
(`railnav.navigation.network_weights`, `railnav.navigation.hypothesis_step`,
`railnav.navigation.stacked_fixes`) and the runs over candidate tracks built on it
(`railnav.jobs.tracks`: ``railnav run TRACK_A TRACK_B``) use them.

1. **Evidence** (`common_log_likelihoods`). Each filter's fault screen
   (`railnav.filters.fault_detection.RowScreen.last`) holds the epoch's innovations at its
   prior and their full covariance ``S = H P Hᵀ + R``, for every row it saw (used or not).
   The cycle's log-likelihood of hypothesis j is ``log N(ν_j; 0, S_j)`` over one set of
   rows for all hypotheses (`evidence_rows`): the rows that **some** filter used (the
   union; rows seen by every filter). A row that the filter on the wrong track rejects or
   excludes because the 4.5-m offset biases it (its drift test does see that) is exactly
   the evidence against that track, and counts; a row every filter refuses (a satellite
   fault) does not. A cycle without an epoch (GNSS outage) brings no evidence.
2. **States across tracks** (`convert_state`, `moved_state`): the position ``r_i(s_i)``
   projected onto track j gives ``s_j``; attitude kept relative to the track, speed and
   the other states as they are; the covariance is kept (the mapping's Jacobian is the
   identity to ``O(κ d)``, 0.75 % in a 600-m curve at 4.5 m). The IMM restarts of
   hypotheses abreast use it (`railnav.navigation.state_conversion.converted`, with a
   Newton shortcut).

**The crossing prior's default.** The track of hypotheses abreast is a Markov chain that
leaves a track at ε (`railnav.defaults.DEFAULT_CROSSING_RATE_PER_S`;
`railnav.navigation.network_weights.crossing_matrix`). For two tracks ``μ − ½`` decays as
``e^{−2εt}`` without evidence. ε also sets a floor ``~ε Δt / (1 − e^{−λ})`` under the
probability of the wrong track (λ the evidence per epoch), from which noisy epochs lift
it: with λ ≈ 0.6 ± 1.3 nats per epoch (4.5 m, σ_pr = 3 m, measured) the wrong track's
log-odds is a random walk reflected at that floor whose excursions above it are
exponential with rate ``2 mean/var`` ≈ 0.7 per nat, so "> 0.99 at 95 % of the epochs"
needs the floor ``≲ 0.01 e^{−3/0.7}``, ε ≲ 5e-5 /s. The default ε = 1e-5 /s (one
crossing per ~28 h of running: crossovers of a double line are used in disruptions only)
keeps the identification through outages (μ − ½ halves in 9.6 h); give a larger ε where
trains do change tracks (station throats), and 0 for a line without crossovers.

Identifiability: the per-epoch evidence between two tracks ``d`` apart is about
``d²/(2σ_x²)`` nats, ``σ_x`` the cross-track σ of one epoch's GNSS position (≈ HDOP σ_pr);
with white errors it accumulates without bound, so any spacing is identified in time
(d = 4.5 m, σ_pr = 3 m: ~0.5–1 nat per epoch); errors correlated over τ (multipath,
atmosphere) bring one such evidence per τ only, and a bias of the GNSS position across
the track of the order of ``d/2`` makes the wrong track as likely as the right one:
no time helps then. Weights that count such epochs whole are confidently wrong: with
simulated code multipath (σ 1 and 2 m/sin(el), τ 60 s) a run without a start gave B
P >= 0.99 for 89 and 161 of ~490 cycles, in 2 and 4 runs of 5
(``benchmarks/bench_network_spawn_gnss.py``); declare τ
(`railnav.navigation.network_config.NetworkNavConfig.evidence_correlation_s`) and the
rows' whole variance. The accelerometer pseudo-observation is no evidence between parallel
tracks (`railnav.jobs.tracks.track_nav`): the curvature of two tracks 4.5 m apart
differs by 0.75 % in a 600-m curve, less than surveyed track geometry can be trusted.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
from scipy.linalg import lapack

from ekf.update import LOG_2PI
from railnav.errors import RailnavError

__all__ = ["convert_state", "moved_state", "moved_states", "common_log_likelihoods",
           "evidence_rows"]

Array = npt.NDArray[np.float64]


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
    return moved_states(filt.layout, np.asarray(x, dtype=float)[None], np.array([s_new]),
                        *(np.array([float(getattr(p, name))]) for name in
                          ("azimuth", "elevation") for p in (p_src, p_tgt)))[0]


def moved_states(layout, xs: Array, s_new: Array, az_src: Array, az_tgt: Array,
                 el_src: Array, el_tgt: Array) -> Array:
    """`moved_state` of K states of one layout at once, shape (K, n): ``s = s_new`` and the
    attitude turned by ``az_tgt − az_src`` (wrapped to ±π) and ``el_tgt − el_src``
    (NumPy's elementwise operations, each the scalar one: the same numbers)."""
    out = np.array(xs, dtype=float)
    out[:, layout.index("s")] = s_new
    if "yaw" not in layout.names:
        return out                          # no attitude (the GNSS-only filter)
    out[:, layout.index("yaw")] += (az_tgt - az_src + math.pi) % (2 * math.pi) - math.pi
    out[:, layout.index("pitch")] += el_tgt - el_src
    return out


def evidence_rows(screens: Sequence) -> set:
    """Keys of the rows the evidence uses: seen by every filter, used by at least one."""
    # the keys as Python strings (`tolist`): hashing NumPy's string scalars costs more
    seen = set.intersection(*(set(e.keys.tolist()) for e in screens))
    return seen & set.union(*(set(e.keys[e.used].tolist()) for e in screens))


def common_log_likelihoods(screens: Sequence, common: set | None = None) -> Array:
    """``log N(ν_j; 0, S_j)`` of each filter's latest epoch over the `evidence_rows`.

    Parameters
    ----------
    screens : sequence of railnav.filters.fault_detection.EpochScreen
        The same epoch screened by each filter.
    common : set, optional
        Their `evidence_rows`, when already known.

    Returns
    -------
    ndarray, shape (J,)
        0 for all when there is no such row.
    """
    common = evidence_rows(screens) if common is None else common
    out = np.zeros(len(screens))
    if not common:
        return out
    for j, e in enumerate(screens):
        keys = e.keys.tolist()
        idx = [k for k, key in enumerate(keys) if key in common]
        if len(idx) == len(keys):                   # every row: the arrays as they are
            nu, S = e.innov, e.S
        else:
            idx = np.array(idx)
            nu, S = e.innov[idx], e.S[np.ix_(idx, idx)]
        # LAPACK's Cholesky and triangular solve as `scipy.linalg.cholesky(lower=True)` and
        # `solve_triangular(lower=True)` call them (the same bits), without their wrappers
        L, info = lapack.dpotrf(S, lower=True, clean=True)
        if info == 0:
            white, info = lapack.dtrtrs(L, nu, lower=True)
        if info != 0:
            raise np.linalg.LinAlgError(f"the innovation covariance of filter {j} is not "
                                        f"positive definite (LAPACK info {info})")
        out[j] = -0.5 * (white @ white + 2.0 * np.log(L.diagonal()).sum() + len(idx) * LOG_2PI)
    return out
