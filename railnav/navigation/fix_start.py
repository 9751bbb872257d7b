"""Where a filter starts from GNSS position fixes: the first fix that agrees with the track.

`initial_from_fixes` projects the trip's first fixes on the track (horizontally,
`trackmodel.Track.project`) and takes the first one whose offsets from the track are
within the gate: across the track within ``g·√(σ_cross² + track_cross_sigma_m²)`` and,
beyond a track end, along it within ``g·σ_along`` (``g`` the square root of the χ²₁
quantile of ``config.gate_probability``, the filter's own row gate). A fix far off the
track (a wrong flag, a jump) is never a start. Its speed: the fix's velocity along the
track where it has one, else the difference of ``s`` to the next fix that agrees within
`MAX_SPEED_BASELINE_S`, else 0 with σ `UNKNOWN_SPEED_SIGMA_MPS`. The filter turns it into
its state (`railnav.filters.common.start_on_track`).

`initial_at_fix` starts at a given fix whether or not it agrees with the track (a network
run's candidates near the fix, a spawn); the difference of ``s`` is then a speed only when
that fix agrees too: the projection of a fix off the track may be anywhere along it (a
receiver jump 100 m across and 60 m ahead made the speed −140 m/s), so a start fix that
does not agree has the fix's own velocity or none (0, σ `UNKNOWN_SPEED_SIGMA_MPS`).

Heights: with ``config.fix_model.use_height``, a start fix whose ellipsoidal height is
outside the gate from the track's height is an error (the track has no heights, or
another height datum): better said at the start than seen as every fix rejected.
"""
from __future__ import annotations

import logging
import math

import numpy as np
import numpy.typing as npt

from ekf.gating import chi2_threshold
from railnav.errors import ConfigError, FixesOffTrackError, RailnavError
from railnav.filters.common import scalar_point
from railnav.filters.track_frame import track_axes_many_n, track_axes_n
from railnav.navigation.initialization import GnssFix, InitialState
from trackmodel.earth import C_n_e

__all__ = ["initial_from_fixes", "initial_at_fix", "MAX_INITIAL_FIXES", "MAX_SPEED_BASELINE_S",
           "UNKNOWN_SPEED_SIGMA_MPS", "START_GATE_PROBABILITY"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: Fixes searched for a start.
MAX_INITIAL_FIXES = 1000
#: The speed from two fixes only when they are at most this far apart, s.
MAX_SPEED_BASELINE_S = 5.0
#: σ of a start speed no fix gives, m/s (the fastest trains, 100 m/s, within 2σ).
UNKNOWN_SPEED_SIGMA_MPS = 50.0
#: The gate's probability when the configuration has no row gate.
START_GATE_PROBABILITY = 0.9999


def _offsets(track, fixes, n: int, cfg, first: int = 0):
    """s, gate-normalized cross and along offsets, and the along σ of the `n` fixes from
    fix `first` on."""
    part = slice(first, first + n)
    proj = track.project(fixes.lat[part], fixes.lon[part])
    points = proj.point
    axes = track_axes_many_n(points.azimuth)
    along_h, cross = axes["along_h"], axes["cross"]
    cov = fixes.cov_n_m2[part]
    var_along = np.einsum("ki,kij,kj->k", along_h, cov, along_h)
    var_cross = np.einsum("ki,kij,kj->k", cross, cov, cross) + cfg.track_cross_sigma_m ** 2
    return (proj.s, np.abs(proj.cross_track_m) / np.sqrt(var_cross),
            np.abs(proj.along_m) / np.sqrt(var_along), np.sqrt(var_along), points)


def initial_from_fixes(filt_obj, fixes, config) -> InitialState:
    """The filter's `InitialState` at the first fix that agrees with the track.

    Parameters
    ----------
    filt_obj : railnav.filters.protocol.Filter
        A track-based filter (``track``, ``initial_from_fix``).
    fixes : railnav.filters.fix_epochs.FixEpochs
    config : railnav.config.NavigatorConfig

    Raises
    ------
    RailnavError
        No fix.
    FixesOffTrackError
        None of the first `MAX_INITIAL_FIXES` agrees with the track.
    ConfigError
        The start fix's height disagrees with the track's (module docstring).
    """
    if len(fixes) == 0:
        raise RailnavError("no GNSS fix in the trip to start from")
    track, cfg = filt_obj.track, config.fix_model
    gate = math.sqrt(chi2_threshold(config.gate_probability or START_GATE_PROBABILITY, 1))
    n = min(len(fixes), MAX_INITIAL_FIXES)
    s, cross, along, sigma_along, points = _offsets(track, fixes, n, cfg)
    ok = (cross <= gate) & (along <= gate)
    if not ok.any():
        raise FixesOffTrackError(f"none of the first {n} GNSS fixes is within {gate:.2f} σ "
                                 f"of the track (the nearest is {np.min(cross):.0f} σ across "
                                 "it): is it the right track?")
    k = int(np.argmax(ok))
    _check_height(fixes, k, float(points.h[k]), gate, cfg)
    start = _start(filt_obj, fixes, k, s, ok, sigma_along, points)
    log.info("started at t=%.3f s from GNSS fix %d of %d (the first %d disagree with the "
             "track)", start.time_s, k + 1, len(fixes), k)
    return start


def initial_at_fix(filt_obj, fixes, k: int, config, *, restart: bool = False
                   ) -> InitialState:
    """The filter's `InitialState` at fix `k` projected on its track, whether or not the
    fix agrees with the track (a network run's candidates: every netelement near the fix);
    the speed as `initial_from_fixes` takes it, from fixes that do agree, fix `k` included
    (module docstring).

    Parameters
    ----------
    filt_obj : railnav.filters.protocol.Filter
    fixes : railnav.filters.fix_epochs.FixEpochs
    k : int
        Index of the start fix.
    config : railnav.config.NavigatorConfig
    restart : bool
        A divergence monitor's restart: the fix's own σ (`Filter.initial_from_fix`).
    """
    gate = math.sqrt(chi2_threshold(config.gate_probability or START_GATE_PROBABILITY, 1))
    n = min(len(fixes) - k, MAX_INITIAL_FIXES)
    s, cross, along, sigma_along, points = _offsets(filt_obj.track, fixes, n,
                                                    config.fix_model, first=k)
    ok = (cross <= gate) & (along <= gate)
    return _start(filt_obj, _Shifted(fixes, k), 0, s, ok, sigma_along, points,
                  restart=restart)


class _Shifted:
    """Fix arrays seen from fix `k` on (what `_start` indexes)."""

    def __init__(self, fixes, k: int) -> None:
        for name in ("time_s", "cov_n_m2", "v_n_mps", "sigma_speed_mps"):
            setattr(self, name, getattr(fixes, name)[k:])


def _start(filt_obj, fixes, k: int, s: Array, ok, sigma_along: Array, points, *,
           restart: bool = False) -> InitialState:
    """The `InitialState` at fix `k` (s, agreement and along σ of the fixes from the
    first of `s` on)."""
    point = scalar_point(points, k)
    v0, sigma_v = _start_speed(fixes, k, s, ok, sigma_along, track_axes_n(point))
    t_e = C_n_e(point.lat, point.lon) @ np.asarray(point.u_n, dtype=float)
    fix = GnssFix(time_s=float(fixes.time_s[k]), r_e=np.asarray(point.r_e, dtype=float),
                  v_e=v0 * t_e, clock_bias_m={}, clock_drift_mps=0.0,
                  cov_enu_m2=fixes.cov_n_m2[k], cov_v_enu_m2ps2=sigma_v ** 2 * np.eye(3))
    x0, P0 = filt_obj.initial_from_fix(fix, restart=True) if restart else \
        filt_obj.initial_from_fix(fix)
    return InitialState(fix.time_s, x0, P0)


def _check_height(fixes, k: int, track_h_m: float, gate: float, cfg) -> None:
    if not (cfg.use_height and np.isfinite(fixes.h_m[k])):
        return
    sigma = math.sqrt(fixes.cov_n_m2[k, 2, 2] + cfg.track_vertical_sigma_m ** 2)
    offset = float(fixes.h_m[k]) - track_h_m
    if abs(offset) > gate * sigma:
        raise ConfigError(f"the start fix is {offset:+.1f} m from the track's height (σ "
                          f"{sigma:.1f} m): the track has no heights or another height "
                          "datum; use the fixes without their heights (--no-fix-heights, "
                          "FixModelConfig(use_height=False))")


def _start_speed(fixes, k: int, s: Array, ok, sigma_along: Array, axes: dict
                 ) -> tuple[float, float]:
    """Signed speed along the track at fix `k` and its σ (module docstring; `ok`: which
    fixes agree with the track)."""
    v = fixes.v_n_mps[k]
    if np.all(np.isfinite(v[:2])):
        a = axes["along"] if np.isfinite(v[2]) else axes["along_h"]
        return float(a @ np.nan_to_num(v)), float(fixes.sigma_speed_mps[k])
    if not ok[k]:
        return 0.0, UNKNOWN_SPEED_SIGMA_MPS
    later = np.flatnonzero(ok[k + 1:]) + k + 1
    if later.size:
        j = int(later[0])
        dt = float(fixes.time_s[j] - fixes.time_s[k])
        if 0.0 < dt <= MAX_SPEED_BASELINE_S:
            return float((s[j] - s[k]) / dt), float(np.hypot(sigma_along[j], sigma_along[k]) / dt)
    return 0.0, UNKNOWN_SPEED_SIGMA_MPS
