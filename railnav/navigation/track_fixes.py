r"""Independent fixes of a track-based filter's position on its track, for the divergence
monitor (`railnav.navigation.monitor`).

* `TrackFixes`: fixes of the whole trip (`spp_track_fixes`: the receiver's single-point
  fixes; `fix_log_track_fixes`: a run's position-fix log) projected on the track, the one
  near the filter where the track passes the same place twice (`TrackFixes.near`,
  `project_near`); `spp_fix_at` solves one epoch's single-point fix when it is asked for.

(An epoch's own rows solved on the track at the prior: `railnav.navigation.snapshot`.)

Times are s from the trip start; an epoch's fix is the one within `FIX_TIME_TOL_S` of it.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from railnav.filters.track_frame import track_axes_many_n
from trackmodel.earth import C_n_e, ecef_to_geodetic

__all__ = ["FIX_TIME_TOL_S", "TrackFixes", "project_near", "spp_track_fixes", "spp_fix_at",
           "fix_log_track_fixes"]

Array = npt.NDArray[np.float64]

#: An epoch's fix is the one within this of its time, s.
FIX_TIME_TOL_S = 1e-3

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
    lat, lon : ndarray, shape (N,), optional
        The fixes' geodetic coordinates, rad (`near` projects them near a guess).
    cov_enu_m2 : ndarray, shape (N, 3, 3), optional
        Their ENU covariances, m².
    distance_m : ndarray, shape (N,), optional
        Horizontal distance of each fix from its whole-track projection ``s_m``, m
        (`on_track`; `near` compares the projection near a guess with it).
    sigma_cross_m : ndarray, shape (N,), optional
        σ of each fix across the track (the horizontal normal at ``s_m``), m
        (`off_track`).
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
    distance_m: Array | None = None
    sigma_cross_m: Array | None = None

    @classmethod
    def on_track(cls, track, *, time_s, lat, lon, cov_enu_m2, v_enu_mps=None,
                 cov_v_enu_m2ps2=None) -> "TrackFixes":
        """Project fixes (radians; ENU covariances (N, 3, 3)) on `track`."""
        time_s = np.asarray(time_s, dtype=float)
        proj = track.project(np.asarray(lat, dtype=float), np.asarray(lon, dtype=float))
        points = proj.point
        u = np.asarray(points.u_n, dtype=float).reshape(-1, 3)
        var_s = np.einsum("ki,kij,kj->k", u, cov_enu_m2, u)
        cross = track_axes_many_n(np.asarray(points.azimuth, dtype=float).reshape(-1))["cross"]
        var_cross = np.einsum("ki,kij,kj->k", cross, cov_enu_m2, cross)
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
                   cov_enu_m2=np.asarray(cov_enu_m2, dtype=float)[order], track=track,
                   distance_m=np.asarray(proj.distance_m, dtype=float)[order],
                   sigma_cross_m=np.sqrt(var_cross)[order])

    def off_track(self, j: int, *, floor_m: float, gate_sigma: float) -> bool:
        """Whether fix `j` lies farther from the track than `gate_sigma` times its σ across
        it (floored at `floor_m`): not a position on this track at all (a jump of the
        receiver's solution, another track), whatever the filter's state; False without
        the distances."""
        if self.distance_m is None or self.sigma_cross_m is None:
            return False
        return bool(self.distance_m[j] > gate_sigma * max(float(self.sigma_cross_m[j]),
                                                          floor_m))

    def near(self, j: int, s_guess: float) -> tuple[float, float]:
        """``s`` and σ_s of fix `j` projected on the track near `s_guess` (Newton from it,
        as `project_near`), where that point is about as near the fix as the whole-track
        projection's (`s_m`; `NEAR_TOL_M`): a track that passes the same place twice (a
        loop, a circle driven round more than once) projects a fix on either pass, and the
        one near the filter is the one to compare with it. Without the fix's coordinates:
        ``s_m[j]``."""
        if self.track is None or self.lat is None:
            return float(self.s_m[j]), float(self.sigma_s_m[j])
        loc = self.track.projector.project(self.lat[j], self.lon[j], s_guess=s_guess)
        s_loc, dist_loc = float(loc.s[0]), float(loc.distance_m[0])
        # the whole-track projection's distance (`on_track`: not projected again; Newton
        # from s_m[j] moves it by < its tolerance, 1e-7 m, and its distance by ~1e-14 m)
        dist_glob = float(self.distance_m[j]) if self.distance_m is not None else \
            project_near(self.track, self.lat[j], self.lon[j], float(self.s_m[j]))[1]
        sigma_h = float(np.sqrt(np.linalg.eigvalsh(self.cov_enu_m2[j][:2, :2]).max()))
        if not dist_loc <= dist_glob + max(NEAR_TOL_M, NEAR_TOL_SIGMA * sigma_h):
            return float(self.s_m[j]), float(self.sigma_s_m[j])
        u = np.asarray(loc.point.u_n[0], dtype=float)          # the track at s_loc
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
    from gnss_obs.spp import solve_spp
    table = data.obs.table
    t = table["gps_time_s"].to_numpy() - data.start_gps_time_s
    sub = replace(data.obs, table=table[(t >= start_s - FIX_TIME_TOL_S)
                                        & (t <= end_s + FIX_TIME_TOL_S)])
    if len(sub.table) == 0:
        return None
    return _spp_on_track(track, data, solve_spp(sub, data.nav, spp_config_of(config)), filt)


def spp_config_of(config):
    """The single-point solution's settings of a run: its measurements and mask."""
    from gnss_obs.spp import SppConfig
    return SppConfig(measurement=config.measurement, elevation_mask_deg=config.elevation_mask_deg)


@dataclass(frozen=True)
class _Solutions:
    """The `gnss_obs.SppResult` fields `_spp_on_track` reads, of one epoch's fix."""

    gps_time_s: Array
    systems: str
    r_e: Array
    v_e: Array
    clock_bias_m: dict
    clock_drift_mps: Array
    cov_enu_m2: Array
    cov_v_enu_m2ps2: Array

    @classmethod
    def of(cls, fix, systems: str) -> "_Solutions":
        """`gnss_obs.spp_result.assemble_result`'s arrays of the one fix `fix`."""
        return cls(gps_time_s=np.array([fix.gps_time_s], dtype=float), systems=systems,
                   r_e=np.array([fix.r_e]).reshape(1, 3), v_e=np.array([fix.v_e]).reshape(1, 3),
                   clock_bias_m={s: np.array([fix.clocks.get(s, np.nan)]) for s in systems},
                   clock_drift_mps=np.array([fix.clock_drift_mps]),
                   cov_enu_m2=np.array([fix.cov_enu]).reshape(1, 3, 3),
                   cov_v_enu_m2ps2=np.array([fix.cov_v_enu]).reshape(1, 3, 3))


def _spp_on_track(track, data, spp, filt) -> TrackFixes | None:
    """Single-point fixes (`gnss_obs.SppResult` or `_Solutions`) on `track`, with the
    filter's start from them (`spp_track_fixes`)."""
    from railnav.navigation.initialization import GnssFix
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
            cov_v_enu_m2ps2=spp.cov_v_enu_m2ps2[k]), restart=True)
    return fixes.with_start(start)


def spp_fix_at(track, data, config, *, filt=None) -> Callable[[float], TrackFixes | None]:
    """``fix_at(time_s)``: the single-point fix of the one epoch at `time_s` on `track`
    (`spp_track_fixes` of that epoch alone, solved when asked: a recovery's restart), or
    None.

    When `filt` reads the run's GNSS epochs (``filt.rows.gnss``, a
    `railnav.filters.gnss_epochs.GnssEpochs` of ``data`` without augmentation, with the
    run's measurement settings), the epoch is taken from them (`_FilterEpochs`) and solved
    by `gnss_obs.spp.solve_spp_epoch` with its satellites' states at transmission: the
    same fix as `spp_track_fixes` gives, which selects the measurements and ephemerides of
    the epoch again from the observation table (pandas, ~4x the solve itself).
    """
    own = _FilterEpochs.of(data, config, filt)

    def fix_at(time_s: float) -> TrackFixes | None:
        k = None if own is None else own.index_at(time_s)
        if k is None:
            return spp_track_fixes(track, data, config, start_s=time_s, end_s=time_s, filt=filt)
        from gnss_obs.spp import solve_spp_epoch
        cfg = spp_config_of(config)
        fix = solve_spp_epoch(own.gnss.epochs[k], data.nav, cfg,
                              approx_e=data.obs.header.approx_position_e,
                              transmit=own.gnss.transmit[k])
        return None if fix is None else \
            _spp_on_track(track, data, _Solutions.of(fix, cfg.measurement.systems), filt)
    return fix_at


@dataclass(frozen=True, eq=False)
class _FilterEpochs:
    """A run's GNSS epochs (`railnav.filters.gnss_epochs.GnssEpochs`) where they are the
    epochs `spp_track_fixes` would cut from ``data.obs`` (`spp_fix_at`).

    Attributes
    ----------
    gnss : railnav.filters.gnss_epochs.GnssEpochs
    obs_times_s : ndarray
        The distinct epoch times of the whole observation table, s from the trip start.
    """

    gnss: object
    obs_gps_time_s: Array
    obs_times_s: Array

    @classmethod
    def of(cls, data, config, filt) -> "_FilterEpochs | None":
        """The filter's epochs, or None where they may differ from the table's: no GNSS
        epochs on `filt`, augmentation (base corrections, precise orbits), other
        measurement settings."""
        gnss = getattr(getattr(filt, "rows", None), "gnss", None)
        if gnss is None or data is None or data.obs is None or data.nav is None \
                or getattr(data, "augmentation", None) is not None \
                or getattr(gnss, "config", None) != config.measurement \
                or len(getattr(gnss, "transmit", ())) != len(gnss.epochs):
            return None
        gps_time = np.unique(data.obs.table["gps_time_s"].to_numpy())
        return cls(gnss, gps_time, gps_time - data.start_gps_time_s)

    def index_at(self, time_s: float) -> int | None:
        """The filter's epoch at `time_s` when it is the only epoch of the table within
        `FIX_TIME_TOL_S` of it (the epoch `spp_track_fixes` solves), else None."""
        t = self.obs_times_s
        a = int(np.searchsorted(t, time_s - FIX_TIME_TOL_S, side="left"))
        b = int(np.searchsorted(t, time_s + FIX_TIME_TOL_S, side="right"))
        if b - a != 1:
            return None
        mine = self.gnss.time_s
        k = int(np.searchsorted(mine, t[a] - FIX_TIME_TOL_S))
        if k < mine.size and self.gnss.epochs[k].gps_time_s == self.obs_gps_time_s[a]:
            return k
        return None


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
        initial = initial_at_fix(filt, fixes, i, config, restart=True)
        return initial.x0, initial.P0
    return out.with_start(start)
