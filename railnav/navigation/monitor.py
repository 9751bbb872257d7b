r"""Divergence monitor: is a filter still consistent with its data, and what to do when not.

`FilterMonitor` watches one track-based filter (states ``s``, ``v``) epoch by epoch while it
runs (`railnav.navigation.loop.ChunkLoop.monitored`) and gives each measurement epoch a
status, ``ok``, ``degraded`` or ``lost``, from four windowed tests over the last
`MonitorConfig.window_epochs` epochs. Each is a tail probability of a χ² (or binomial)
statistic that is exact when the filter's σ are right:

* **GNSS NIS**: the sum of the accepted rows' ``ν_i²/S_ii`` against χ² with one degree of
  freedom per row;
* **rejected rows**: the number of rows the χ² row gate rejected against the binomial
  law of the gate's false-rejection rate ``1 − config.gate_probability``;
* **fix disagreement**: ``d = (s_fix − s_prior)/√(σ_fix² + σ_s,prior²)`` of an independent
  single-epoch fix on the track at the epoch's prior (not yet updated with that epoch's
  measurements); ``Σ d²`` against χ²ₙ and the signed mean, ``(Σ d)²/n`` against χ²₁ (a
  filter off by a steady offset), the smaller tail doubled (Bonferroni). The fix is the
  epoch's own position rows (pseudoranges, or a fix's position rows) solved alone on the
  track, linearised at the prior (`snapshot_fix`: no extra satellite computation, and no
  projection of a fix on the whole track, which put fixes on the wrong pass of a circle
  driven round three times and said ``lost`` on 160 of 280 epochs of a consistent run).
  Where the filter's fault screen kept some of those rows out of the update (a choice
  made at the prior, so the rows left are not independent of it), the fix is instead the
  run's position fix of the epoch (`fix_log_track_fixes`) or the receiver's single-point
  fix of that epoch, solved then (`spp_fix_at`), projected on the track near the prior
  (`TrackFixes.near`);
* **pseudo-observation NIS**: the continuous (accelerometer) pseudo-observation's NIS
  summed over the window's steps against χ² with its total dimension;
* **fix disagreement too small** (``p_fix_small``, ``degraded`` only): the lower χ² tail of
  ``Σ d²`` over the last `MonitorConfig.small_window_epochs` epochs, with the fixes' own σ
  (not floored). Fixes that agree with the filter far better than both their σ say are
  correlated with it: slow multipath the filter has followed, its σ built as if the errors
  were independent and too small. On the urban drive this is what flags the fix-based
  filter's steady 2-5 m along-track errors at σ_s 0.6 m (leg 1: 134 of 157 such epochs
  unflagged without it, 7 with it); on the consistent simulations it adds no alarm.

Thresholds: a test *fails at level p* when its tail probability is below ``p``. The status is
``lost`` when the fix-disagreement test fails at `MonitorConfig.p_lost` (default 1e-6), or
the rejected-row test does and at least `MonitorConfig.lost_rejected_share` of the window's
rows were rejected, ``degraded`` when any test fails at `MonitorConfig.p_degraded` (1e-3),
else ``ok``. For a consistent filter the false ``degraded`` rate is ≤ 5·p_degraded per epoch
(five tests), false ``lost`` ≤ 2·p_lost; the windows overlap, so alarms come in runs.

Recovery (`MonitorConfig.recover`): when ``lost`` and this epoch's fix alone disagrees
beyond the χ²₁ quantile of `MonitorConfig.p_lost` (4.9σ at 1e-6), ``s`` (and ``v`` where
the fix has a speed) are re-initialised from it: the whole state through the filter's own
start-from-fix code where the run has it (`TrackFixes.start`: ``filter.initial_from_fix``,
`railnav.filters.common.start_on_track`; `railnav.navigation.fix_start.initial_at_fix`),
so that attitude, IMU biases and clock start over too; else ``s`` and ``v`` alone (σ floored
as ``start_on_track`` does), their rows and columns of ``P`` without correlations. Otherwise the ``s, v`` rows and columns of ``P`` are widened
by the window's variance factor ``f = Σ d²/n`` (``P_ss`` times ``f``): the next updates pull
the state back, and one noisy fix never replaces it.
After a recovery the windows restart, and the status is ``degraded`` until
`MonitorConfig.min_epochs` epochs have been seen again.

Real-data caveat: urban SPP errors are correlated from epoch to epoch (multipath), so the
fix-disagreement statistic is heavier-tailed than χ²ₙ; the fix σ are floored at
`MonitorConfig.min_fix_sigma_m`. The figures on the urban drive are in
``benchmarks/results/real_pieces.json``.
"""
from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
import pandas as pd

from trackmodel.earth import C_n_e, ecef_to_geodetic

__all__ = ["MonitorConfig", "FilterMonitor", "TrackFixes", "spp_track_fixes", "spp_fix_at",
           "fix_log_track_fixes", "snapshot_fix", "STATUSES", "status_at"]

Array = npt.NDArray[np.float64]

#: The statuses, from best to worst.
STATUSES = ("ok", "degraded", "lost")
#: An epoch's fix is the one within this of its time, s.
FIX_TIME_TOL_S = 1e-3


@dataclass(frozen=True)
class MonitorConfig:
    """Windows and thresholds of `FilterMonitor` (module docstring).

    Parameters
    ----------
    enabled : bool
    window_epochs : int
        Epochs in each test's window.
    small_window_epochs : int
        Epochs of the lower-tail fix test (``p_fix_small``: disagreements too small).
    min_epochs : int
        Epochs after a start or recovery before the status may be ``ok``.
    p_degraded, p_lost : float
        Tail probabilities below which a test flags ``degraded`` / ``lost``.
    recover : bool
        Re-initialise (or widen) when ``lost``. Off by default. It was turned off when,
        on a consistent 100 m/s run round R = 100 m (`tests/railnav/filters/
        test_joint_noise.py`), the monitor said ``lost`` on 160 of 280 epochs and its
        restarts took the NEES from 7.6 to 7.8e8; the cause (single-point fixes projected
        on the wrong pass of the circle) is fixed (module docstring: 0 of 290 epochs
        lost, `tests/railnav/navigation/test_monitor.py`), but recovery on by default
        has not been measured across the simulated cases yet.
    lost_rejected_share : float
        The rejected-row test says ``lost`` only when at least this share of the window's
        rows was rejected (fewer: the rows, not the prior, are bad: multipath).
    min_fix_sigma_m, min_fix_sigma_mps : float
        Floors of a fix's along-track σ of position and speed.
    """

    enabled: bool = True
    window_epochs: int = 10
    small_window_epochs: int = 30
    min_epochs: int = 3
    p_degraded: float = 1e-3
    p_lost: float = 1e-6
    recover: bool = False
    lost_rejected_share: float = 0.5
    min_fix_sigma_m: float = 1.0
    min_fix_sigma_mps: float = 0.05


@dataclass(frozen=True)
class TrackFixes:
    """Independent single-epoch fixes projected on a track.

    Attributes
    ----------
    time_s : ndarray, shape (N,)
        s from the trip start, increasing.
    s_m, sigma_s_m : ndarray, shape (N,)
        Distance along the track of the fix's projection and its σ along the tangent, m.
    v_mps, sigma_v_mps : ndarray, shape (N,)
        Speed along the tangent and its σ (NaN where the fix has none), m/s.
    source : ndarray of int, shape (N,)
        Index of each fix in the source it was built from (before sorting).
    start : callable(int) -> (x0, P0), optional
        The filter's whole start from source fix ``i`` (its own start-from-fix code): a
        recovery restarts every state (attitude, IMU biases, clock) from it.
    """

    time_s: Array
    s_m: Array
    sigma_s_m: Array
    v_mps: Array
    sigma_v_mps: Array
    source: npt.NDArray[np.intp] | None = None
    start: Callable[[int], tuple[Array, Array]] | None = None
    lat: Array | None = None
    lon: Array | None = None
    cov_enu_m2: Array | None = None
    track: object = None

    @classmethod
    def on_track(cls, track, *, time_s, lat, lon, cov_enu_m2, v_enu_mps=None,
                 cov_v_enu_m2ps2=None) -> "TrackFixes":
        """Project fixes (radians; ENU covariances (N, 3, 3)) on `track`."""
        time_s = np.asarray(time_s, dtype=float)
        proj = track.project(np.asarray(lat, dtype=float), np.asarray(lon, dtype=float))
        u = np.asarray(track.at(proj.s).u_n, dtype=float).reshape(-1, 3)
        var_s = np.einsum("ki,kij,kj->k", u, cov_enu_m2, u)
        if v_enu_mps is None:
            v = sv = np.full(time_s.size, np.nan)
        else:
            v = np.einsum("ki,ki->k", u, v_enu_mps)
            sv = np.sqrt(np.einsum("ki,kij,kj->k", u, cov_v_enu_m2ps2, u)) \
                if cov_v_enu_m2ps2 is not None else np.full(time_s.size, np.nan)
        order = np.argsort(time_s, kind="stable")
        return cls(time_s[order], np.asarray(proj.s)[order], np.sqrt(var_s)[order],
                   np.asarray(v, dtype=float)[order], np.asarray(sv, dtype=float)[order],
                   source=order, lat=np.asarray(lat, dtype=float).reshape(-1)[order],
                   lon=np.asarray(lon, dtype=float).reshape(-1)[order],
                   cov_enu_m2=np.asarray(cov_enu_m2, dtype=float)[order], track=track)

    def near(self, j: int, s_guess: float) -> tuple[float, float]:
        """``s`` and σ_s of fix `j` projected on the track near `s_guess` (Newton from it,
        `project_near`), where that point is about as near the fix as the whole-track
        projection's (`s_m`; `NEAR_TOL_M`): a track that passes the same place twice (a loop, a circle
        driven round more than once) projects a fix on either pass, and the one near the
        filter is the one to compare with it. Without the fix's coordinates: ``s_m[j]``."""
        if self.track is None or self.lat is None:
            return float(self.s_m[j]), float(self.sigma_s_m[j])
        s_loc, dist_loc = project_near(self.track, self.lat[j], self.lon[j], s_guess)
        _, dist_glob = project_near(self.track, self.lat[j], self.lon[j], float(self.s_m[j]))
        sigma_h = float(np.sqrt(np.linalg.eigvalsh(self.cov_enu_m2[j][:2, :2]).max()))
        if not dist_loc <= dist_glob + max(NEAR_TOL_M, NEAR_TOL_SIGMA * sigma_h):
            return float(self.s_m[j]), float(self.sigma_s_m[j])
        u = np.asarray(self.track.at(s_loc).u_n, dtype=float).reshape(3)
        return s_loc, float(np.sqrt(u @ self.cov_enu_m2[j] @ u))

    def with_start(self, start: Callable[[int], tuple[Array, Array]]) -> "TrackFixes":
        """The same fixes with the filter's start function (`TrackFixes.start`)."""
        return replace(self, start=start)

    def at(self, time_s: float) -> int | None:
        """Index of the fix at `time_s` (within `FIX_TIME_TOL_S`), or None."""
        j = int(np.searchsorted(self.time_s, time_s - FIX_TIME_TOL_S))
        if j < self.time_s.size and abs(self.time_s[j] - time_s) <= FIX_TIME_TOL_S \
                and np.isfinite(self.s_m[j]):
            return j
        return None


#: A projection near the filter replaces the whole-track one when it is at most this much
#: farther from the fix: `NEAR_TOL_SIGMA` times the fix's largest horizontal σ, at least
#: `NEAR_TOL_M` (two passes of the track through the same place, which the fix cannot
#: tell apart; a track of repeated arcs puts them a centimetre apart).
NEAR_TOL_M, NEAR_TOL_SIGMA = 1.0, 3.0


def project_near(track, lat: float, lon: float, s_guess: float) -> tuple[float, float]:
    """The track point nearest to a point (rad, horizontal) on the pass of the track
    through `s_guess` (`trackmodel.project.Projector.project` from that guess):
    ``(s, distance)``."""
    proj = track.projector.project(lat, lon, s_guess=s_guess)
    return float(proj.s[0]), float(proj.distance_m[0])


def spp_track_fixes(track, data, config, *, start_s: float = 0.0, end_s: float = np.inf,
                    filt=None) -> TrackFixes | None:
    """The receiver's single-point fixes (`gnss_obs.solve_spp`, the run's systems and mask)
    of the epochs of ``data.obs`` from `start_s` to `end_s` (s from the trip start), on
    `track`; None without observations or fixes. With the filter object `filt`, a recovery
    restarts it from the fix (``filt.initial_from_fix``,
    `railnav.navigation.initialization.GnssFix`)."""
    if data.obs is None or data.nav is None:
        return None
    from gnss_obs.spp import SppConfig, solve_spp
    from railnav.navigation.initialization import GnssFix
    table = data.obs.table
    t = table["gps_time_s"].to_numpy() - data.start_gps_time_s
    sub = replace(data.obs, table=table[(t >= start_s - FIX_TIME_TOL_S)
                                        & (t <= end_s + FIX_TIME_TOL_S)])
    if len(sub.table) == 0:
        return None
    spp = solve_spp(sub, data.nav, SppConfig(measurement=config.measurement,
                                             elevation_mask_deg=config.elevation_mask_deg))
    ok = np.all(np.isfinite(spp.r_e), axis=1)
    if not ok.any():
        return None
    r_e = spp.r_e[ok]
    lat, lon, _ = ecef_to_geodetic(r_e, earth=track.earth)
    C = C_n_e(lat, lon)                                   # (N, 3, 3): ENU -> ECEF
    v_e = np.nan_to_num(spp.v_e[ok])
    v_enu = np.einsum("kji,kj->ki", C, v_e)
    v_enu[~np.all(np.isfinite(spp.v_e[ok]), axis=1)] = np.nan
    fixes = TrackFixes.on_track(track, time_s=spp.gps_time_s[ok] - data.start_gps_time_s,
                                lat=lat, lon=lon, cov_enu_m2=spp.cov_enu_m2[ok],
                                v_enu_mps=v_enu, cov_v_enu_m2ps2=spp.cov_v_enu_m2ps2[ok])
    rows = np.flatnonzero(ok)
    if filt is None or not hasattr(filt, "initial_from_fix"):
        return fixes

    def start(i: int) -> tuple[Array, Array]:
        k = int(rows[i])
        if not np.all(np.isfinite(spp.v_e[k])):
            raise ValueError("no velocity")
        return filt.initial_from_fix(GnssFix(
            time_s=float(spp.gps_time_s[k] - data.start_gps_time_s), r_e=spp.r_e[k],
            v_e=spp.v_e[k], clock_bias_m={n: float(spp.clock_bias_m[n][k])
                                          for n in spp.systems},
            clock_drift_mps=float(spp.clock_drift_mps[k]), cov_enu_m2=spp.cov_enu_m2[k],
            cov_v_enu_m2ps2=spp.cov_v_enu_m2ps2[k]))
    return fixes.with_start(start)


def spp_fix_at(track, data, config, *, filt=None) -> Callable[[float], TrackFixes | None]:
    """``fix_at(time_s)``: the single-point fix of the one epoch at `time_s` on `track`
    (`spp_track_fixes` of that epoch alone, solved when asked: a recovery's restart), or
    None."""
    def fix_at(time_s: float) -> TrackFixes | None:
        return spp_track_fixes(track, data, config, start_s=time_s, end_s=time_s, filt=filt)
    return fix_at


def fix_log_track_fixes(track, fixes, *, filt=None, config=None) -> TrackFixes | None:
    """The position fixes a run reads (`railnav.filters.fix_epochs.FixEpochs`), on `track`;
    with the filter object `filt` and its `config`, a recovery restarts it from the fix
    (`railnav.navigation.fix_start.initial_at_fix`)."""
    if fixes is None or len(fixes.time_s) == 0:
        return None
    speed_var = np.asarray(fixes.sigma_speed_mps, dtype=float) ** 2
    cov_v = np.einsum("k,ij->kij", speed_var, np.eye(3))
    out = TrackFixes.on_track(track, time_s=fixes.time_s, lat=fixes.lat, lon=fixes.lon,
                              cov_enu_m2=fixes.cov_n_m2, v_enu_mps=fixes.v_n_mps,
                              cov_v_enu_m2ps2=cov_v)
    if filt is None or not hasattr(filt, "initial_from_fix"):
        return out
    from railnav.navigation.fix_start import initial_at_fix

    def start(i: int) -> tuple[Array, Array]:
        initial = initial_at_fix(filt, fixes, i, config)
        return initial.x0, initial.P0
    return out.with_start(start)


def _chi2_sf(value: float, dof: float) -> float:
    from scipy.special import chdtrc
    return float(chdtrc(dof, value)) if dof > 0 else 1.0


def _chi2_cdf(value: float, dof: float) -> float:
    from scipy.special import chdtr
    return float(chdtr(dof, value)) if dof > 0 else 1.0


def _chi2_isf(p: float, dof: int) -> float:
    from scipy.special import chdtri
    return float(chdtri(dof, p))


def _binom_sf(k: int, n: int, p: float) -> float:
    """P(X ≥ k), X ~ Binomial(n, p)."""
    if k <= 0:
        return 1.0
    from scipy.special import bdtrc
    return float(bdtrc(k - 1, n, p))


#: Row models whose rows carry a single-epoch position on the track: the GNSS pseudoranges
#: of every track-based receiver model (``<name>_pseudorange``) and a fix's position rows.
SNAPSHOT_SUFFIX, SNAPSHOT_FIX_MODEL = "_pseudorange", "fix_position"
#: The fault screen's kinds of those rows (`railnav.filters.common.ROW_KINDS`,
#: `railnav.filters.fix_rows.FIX_ROW_KINDS`).
POSITION_ROW_KINDS = ("pseudorange", "fix_along", "fix_cross", "fix_up")
#: The epoch's fix is solved from all its data (`FilterMonitor._screened_out`) when the
#: fault screen kept at least this share of the position rows, and this many, out.
SCREENED_SHARE, SCREENED_MIN_ROWS = 0.25, 2


def snapshot_fix(observations, x: Array, i_s: int, clock_columns=(), *,
                 pseudorange_inflation: float = 1.0) -> tuple[float, float, bool] | None:
    """This epoch's own fix on the track, relative to the prior: ``(δs, σ², white)``, or
    None.

    The rows are the ones the filter updates the prior ``x`` with (its
    `ekf.Observation` s, evaluated at ``x`` when they are an
    `ekf.update.EvaluatedObservations`). Of them, the position rows (`SNAPSHOT_SUFFIX`,
    `SNAPSHOT_FIX_MODEL`) are solved alone by weighted least squares, linearised at the
    prior, for ``s`` and the receiver clocks (`clock_columns`: unknown, so the prior's
    clock does not enter), every other state held at the prior; GNSS rows with the
    single-point solution's χ² fault exclusion and Huber weights
    (`gnss_obs.raim.fault_detection_exclusion` with `gnss_obs.spp.SppConfig`'s defaults).
    The solution ``s_prior + δs`` depends on this epoch's measurements only (to first order in the
    prior's error: the rows are exact to second order in ``s − s_prior``), so
    ``δs`` has the variance ``σ² + σ²_s,prior`` when both are right. It is linearised at
    the prior's ``s``, so a track that passes the same place twice (a loop) gives no
    ambiguous projection, unlike a position fix projected on the whole track.
    A filter that inflates its pseudorange variances for errors correlated in time (the
    gnss-only filter's ``pseudorange_inflation``, ×40 for τ = 20 s at 1 Hz: the weight of
    long averages) gives `pseudorange_inflation`; the snapshot keeps the inflated
    variances, and ``white`` is False: its error is then correlated with the prior's, and
    the lower tail (`FilterMonitor._small_tail`) does not hold (on the urban drive it fired
    on every epoch). Solving with ``R / inflation`` instead (one epoch's own σ) was tried:
    on the urban drive it said ``lost`` on 28 of 58 epochs of leg 2, where the gnss-only
    filter is right to 0.93 m RMS (single-epoch urban errors exceed that σ), and its
    restarts made the leg worse (1.21 m).
    None: fewer rows than unknowns, or a singular geometry.
    """
    from gnss_obs.raim import fault_detection_exclusion, wls_step
    from gnss_obs.spp import SppConfig
    if hasattr(observations, "observations"):            # ekf.EpochRows (a clock jump)
        observations = observations.observations
    if not observations:
        return None
    evaluated = getattr(observations, "innov", None) is not None \
        and observations.evaluated_at(x)
    nus, Hs, Rs, gnss = [], [], [], False
    start = 0
    for obs in observations:
        m = obs.z.size
        name = obs.model.name
        use = name.endswith(SNAPSHOT_SUFFIX) or name == SNAPSHOT_FIX_MODEL
        if use and np.ndim(obs.R) == 1:
            if evaluated:
                nu = observations.innov[start:start + m]
                H = observations.H[start:start + m]
            else:
                z_pred, H = obs.model.evaluate(x, obs.p)
                nu = obs.z.reshape(-1) - z_pred
            nus.append(nu)
            Hs.append(H)
            Rs.append(np.asarray(obs.R, dtype=float))
            gnss |= name.endswith(SNAPSHOT_SUFFIX)
        start += m
    if not nus:
        return None
    nu, H, R = np.concatenate(nus), np.vstack(Hs), np.concatenate(Rs)
    cols = [i_s] + [c for c in clock_columns if np.any(H[:, c] != 0.0)]
    A = H[:, cols]
    if nu.size < len(cols) or not np.any(A[:, 0] != 0.0):
        return None
    sigma = np.sqrt(R)
    try:
        if gnss and nu.size > len(cols):
            spp = SppConfig()               # the receiver's own SPP exclusion and weights
            step = fault_detection_exclusion(A, nu, sigma, p_false_alarm=spp.p_false_alarm,
                                             max_exclusions=spp.max_exclusions,
                                             huber_k=spp.huber_k).step
        else:
            step = wls_step(A, nu, sigma)
    except np.linalg.LinAlgError:
        return None
    var = float(step.cov[0, 0])
    if not (np.isfinite(step.dx[0]) and np.isfinite(var) and var > 0.0):
        return None
    return float(step.dx[0]), var, not (gnss and pseudorange_inflation != 1.0)


class FilterMonitor:
    """Status of one filter epoch by epoch, and its recovery (module docstring).

    Parameters
    ----------
    layout : ekf.StateLayout
        With ``s`` and ``v``.
    fixes : TrackFixes or None
        The run's position fixes on the track: the fix test's fix where the epoch's own
        rows cannot give one (`snapshot_fix`, `_screened_out`), and a restart's.
    config : MonitorConfig
    gate_probability : float or None
        The run's χ² row gate (None: the rejected-row test is off).
    fix_at : callable(time_s) -> TrackFixes or None, optional
        Without `fixes`: the epoch's single-point fix, solved when needed (`spp_fix_at`).
    screen : railnav.filters.fault_detection.RowScreen, optional
        The filter's fault screen (read only: which rows it kept out).
    pseudorange_inflation : float
        The filter's pseudorange variance factor for correlated errors (`snapshot_fix`).
    """

    def __init__(self, layout, fixes: TrackFixes | None, config: MonitorConfig,
                 gate_probability: float | None, *,
                 fix_at: Callable[[float], TrackFixes | None] | None = None,
                 screen=None, pseudorange_inflation: float = 1.0) -> None:
        self.layout, self.fixes, self.config = layout, fixes, config
        self.pseudorange_inflation = float(pseudorange_inflation)
        self.fix_at, self.screen = fix_at, screen
        self._screened = None if screen is None or not screen.epochs else screen.epochs[-1]
        self.i_s, self.i_v = layout.index("s"), layout.index("v")
        self.p_reject = None if gate_probability is None else 1.0 - gate_probability
        self._prior: tuple[float, float, float] | None = None
        self._snapshot: tuple[float, float] | None = None
        self._epoch_fixes: TrackFixes | None = None
        self._clock_columns = tuple(i for i, name in enumerate(layout.names)
                                    if name == "clock_bias" or name.startswith("isb_"))
        self._window: deque = deque(maxlen=config.window_epochs)
        self._small: deque = deque(maxlen=config.small_window_epochs)
        self._seen = 0
        self.records: list[dict] = []

    def prior(self, time_s: float, x: Array, P: Array, observations=None) -> None:
        """The prior of the epoch at `time_s` (before its update), and the rows the filter
        updates it with (`snapshot_fix` solves this epoch's fix on the track from them)."""
        self._prior = (float(time_s), float(x[self.i_s]), float(P[self.i_s, self.i_s]))
        self._snapshot = None if observations is None or self._screened_out() else \
            snapshot_fix(observations, x, self.i_s, self._clock_columns,
                         pseudorange_inflation=self.pseudorange_inflation)

    def _screened_out(self) -> bool:
        """Whether the filter's fault screen (`railnav.filters.fault_detection.RowScreen`)
        kept `SCREENED_SHARE` of this epoch's position rows (at least `SCREENED_MIN_ROWS`)
        from the update: its choice was made at the prior, so the rows left are not
        independent of it (a filter far off keeps the rows that agree with it), and the
        epoch's fix is then solved from all its data. One satellite left out (its channel
        excluded over a stretch of epochs) leaves the snapshot to the others."""
        last = None if self.screen is None or not self.screen.epochs else self.screen.epochs[-1]
        if last is None or last is self._screened:     # the screen did not run this epoch
            return False
        self._screened = last
        kind = np.array([k.rsplit("/", 1)[-1] for k in last.keys], dtype=object)
        position = np.isin(kind, POSITION_ROW_KINDS)
        out = int(np.sum(position & ~last.used))
        return out >= max(SCREENED_MIN_ROWS, SCREENED_SHARE * int(position.sum()))

    def epoch(self, chunk, x: Array, P: Array) -> tuple[Array, Array] | None:
        """Test the epoch that ended `chunk` (an `ekf.FilterResult`), posterior ``x, P``.

        Returns
        -------
        (x, P) or None
            The recovered state and covariance, or None to keep the filter's.
        """
        if chunk.t_d.size == 0 or self._prior is None:
            return None
        time_s, s_prior, var_prior = self._prior
        self._prior = None
        nis = chunk.innov_d ** 2 / chunk.s_d
        acc = np.asarray(chunk.accepted, dtype=bool)
        d = np.nan
        j = None if self.fixes is None else self.fixes.at(time_s)
        snapshot, self._snapshot = self._snapshot, None
        d_raw = np.nan
        if snapshot is not None:                       # this epoch's own rows, on the track
            ds, var_fix, white = snapshot
            d_raw = ds / np.sqrt(var_fix + var_prior) if white else np.nan
            var_fix = max(var_fix, self.config.min_fix_sigma_m ** 2)
            d = ds / np.sqrt(var_fix + var_prior)
        else:                                          # a fix from all the epoch's data
            fixes = self.fixes
            if j is None and self.fix_at is not None:
                fixes = self.fix_at(time_s)
                j = None if fixes is None else fixes.at(time_s)
            if j is not None:
                s_fix, sigma_fix = fixes.near(j, s_prior)
                d_raw = (s_fix - s_prior) / np.sqrt(sigma_fix ** 2 + var_prior)
                var_fix = max(sigma_fix, self.config.min_fix_sigma_m) ** 2
                d = (s_fix - s_prior) / np.sqrt(var_fix + var_prior)
                self._epoch_fixes = fixes
        self._window.append((float(nis[acc].sum()), int(acc.sum()), int((~acc).sum()), d * d,
                             float(chunk.nis_c_sum),
                             int(chunk.nis_c_count) * max(chunk.innov_c.shape[-1], 1)
                             if chunk.innov_c.ndim == 2 else 0, d))
        self._small.append(d_raw * d_raw)
        self._seen += 1
        status, tails = self._status()
        record = {"time_s": time_s, "status": status, **tails,
                  "sigma_s_prior_m": float(np.sqrt(var_prior)), "action": ""}
        self.records.append(record)
        if status != "lost" or not self.config.recover:
            return None
        far = np.isfinite(d) and d * d > _chi2_isf(self.config.p_lost, 1)
        fixes, self._epoch_fixes = self._epoch_fixes or self.fixes, None
        if far and j is None and self.fix_at is not None:   # solved now, for the restart
            fixes = self.fix_at(time_s)
            j = None if fixes is None else fixes.at(time_s)
        far = far and j is not None
        recovered = self._recover(fixes, j if far else None, x, P)
        record["action"] = "reinit" if far else "widen"
        self._window.clear()
        self._small.clear()
        self._seen = 0
        return recovered

    def _small_tail(self) -> float:
        """Lower χ² tail of the last `MonitorConfig.small_window_epochs` unfloored fix
        disagreements ``Σ d²``: fixes that agree with the filter far better than their σ
        and the filter's say are correlated with it (slow multipath the filter has
        followed), and the filter's σ, built as if they were independent, too small."""
        d2 = np.array(self._small, dtype=float)
        d2 = d2[np.isfinite(d2)]
        return _chi2_cdf(float(d2.sum()), int(d2.size))

    def _status(self) -> tuple[str, dict]:
        w = np.array(self._window, dtype=float)
        nis_sum, n_acc, n_rej, d2, nisc, nisc_dof = (w[:, k] for k in range(6))
        n_rows = n_acc.sum() + n_rej.sum()
        rejected_share = n_rej.sum() / n_rows if n_rows else 0.0
        have = np.isfinite(d2)
        d = w[have, 6]
        tails = {"p_gnss_nis": _chi2_sf(nis_sum.sum(), n_acc.sum()),
                 "p_rejected": 1.0 if self.p_reject is None else
                 _binom_sf(int(n_rej.sum()), int(n_acc.sum() + n_rej.sum()), self.p_reject),
                 "p_fix": min(1.0, 2.0 * min(
                     _chi2_sf(float(d2[have].sum()), int(have.sum())),
                     _chi2_sf(float(d.sum()) ** 2 / max(d.size, 1), min(d.size, 1)))),
                 "p_pseudo_nis": _chi2_sf(nisc.sum(), nisc_dof.sum()),
                 "p_fix_small": self._small_tail(),
                 "fix_disagreement_sigma": float(np.sqrt(d2[-1])) if have[-1] else np.nan,
                 "variance_factor": float(d2[have].mean()) if have.any() else np.nan}
        cfg = self.config
        if tails["p_fix"] < cfg.p_lost or (tails["p_rejected"] < cfg.p_lost
                                           and rejected_share >= cfg.lost_rejected_share):
            return "lost", tails
        worst = min(tails[k] for k in ("p_gnss_nis", "p_rejected", "p_fix", "p_pseudo_nis",
                                       "p_fix_small"))
        if worst < cfg.p_degraded or self._seen < cfg.min_epochs:
            return "degraded", tails
        return "ok", tails

    def _recover(self, f: TrackFixes | None, j: int | None, x: Array, P: Array
                 ) -> tuple[Array, Array]:
        x, P = x.copy(), P.copy()
        i_s, i_v, cfg = self.i_s, self.i_v, self.config
        if j is None:
            w = np.array(self._window, dtype=float)[:, 3]
            factor = max(float(np.nanmean(w)) if np.isfinite(w).any() else 1.0, 1.0)
            for i in (i_s, i_v):
                P[i, :] *= np.sqrt(factor)
                P[:, i] *= np.sqrt(factor)
            return x, P
        if f.start is not None:
            try:
                x0, P0 = f.start(int(f.source[j]))
            except (ValueError, ArithmeticError, np.linalg.LinAlgError):
                x0 = None                  # no start from this fix: s and v alone
            if x0 is not None:
                return np.asarray(x0, dtype=float), np.asarray(P0, dtype=float)
        reset = [i_s]
        x[i_s] = f.s_m[j]
        var = {i_s: max(f.sigma_s_m[j], cfg.min_fix_sigma_m) ** 2}
        if np.isfinite(f.v_mps[j]):
            x[i_v] = f.v_mps[j]
            var[i_v] = max(f.sigma_v_mps[j], cfg.min_fix_sigma_mps) ** 2
            reset.append(i_v)
        for i in reset:
            P[i, :] = 0.0
            P[:, i] = 0.0
            P[i, i] = var[i]
        return x, P

    def frame(self) -> pd.DataFrame:
        """One row per tested epoch: ``time_s, status``, the tests' tail probabilities,
        the fix disagreement (σ), the window's fix variance factor ``Σ d²/n``, the prior
        σ_s and the recovery ``action`` (``reinit``, ``widen`` or empty)."""
        return pd.DataFrame.from_records(self.records, columns=[
            "time_s", "status", "p_gnss_nis", "p_rejected", "p_fix", "p_pseudo_nis",
            "p_fix_small",
            "fix_disagreement_sigma", "variance_factor", "sigma_s_prior_m", "action"])


def status_at(records: pd.DataFrame, time_s: Array) -> npt.NDArray[np.object_]:
    """The status in force at each of `time_s`: that of the last tested epoch at or before
    it (``ok`` before the first; every sample ``ok`` without records)."""
    time_s = np.asarray(time_s, dtype=float)
    if records is None or len(records) == 0:
        return np.full(time_s.size, STATUSES[0], dtype=object)
    j = np.searchsorted(records["time_s"].to_numpy(), time_s + FIX_TIME_TOL_S, side="right") - 1
    status = records["status"].to_numpy(dtype=object)
    return np.where(j >= 0, status[np.maximum(j, 0)], STATUSES[0]).astype(object)
