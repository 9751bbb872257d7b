"""One epoch's single-point fix from a receiver guess (`gnss_obs.spp` runs it per epoch).

1. satellite states at transmission (`gnss_obs.transmission.transmit_states`, independent
   of the guess, or the caller's);
2. Gauss-Newton on the pseudorange model (`gnss_obs.observables`) for ECEF position and one
   clock per system present (``b_sat = S @ clocks``, `observables.system_bias_matrix`),
   re-preparing corrections and the elevation mask at every iterate (`gnss_obs.epoch`);
   from a guess far from the surface (a cold start from the Earth's centre) the first
   iterates use no corrections until a step is below `COARSE_STEP_M`;
3. RAIM/FDE (`gnss_obs.raim`): χ² test of the weighted residuals, exclusion of the worst
   standardized residual, re-solution; protection-level-style HPL/VPL and DOPs;
4. velocity and clock drift from the range rates (``-λ D``) of the kept satellites, linear
   WLS with its own FDE.

`fix_epoch` returns the `gnss_obs.spp_result.EpochFix`, or None with too few satellites or
a singular geometry.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from gnss_obs.dop import Dop, dilution_of_precision
from gnss_obs.epoch import (
    MAX_RECEIVER_HEIGHT_M,
    MIN_RECEIVER_RADIUS_M,
    EpochData,
    PreparedEpoch,
    prepare_epoch,
)
from gnss_obs.observables import (
    predict_pseudorange,
    predict_range_rate,
    system_bias_matrix,
)
from gnss_obs.raim import (
    FdeResult,
    WlsStep,
    fault_detection_exclusion,
    protection_levels,
    wls_step,
)
from gnss_obs.spp_config import SppConfig
from gnss_obs.spp_result import EpochFix
from gnss_obs.transmission import transmit_states
from trackmodel.earth import C_n_e, ecef_to_geodetic

__all__ = ["fix_epoch", "COARSE_STEP_M"]

Array = npt.NDArray[np.float64]

#: Fewest Doppler measurements for a velocity: 4 unknowns + 1 redundant (an untestable
#: velocity is not reported).
_MIN_DOPPLER_SATS = 5
#: A cold start's coarse iterations (no mask, weights or corrections) end once a position
#: step is below this, m: the guess is then good enough for elevations and delays.
COARSE_STEP_M = 1.0e3


@dataclass
class _Context:
    """What the steps of one epoch share: the configuration, the Klobuchar coefficients,
    the precise orbits (None: broadcast)."""

    config: SppConfig
    klobuchar: tuple[np.ndarray, np.ndarray] | None
    precise: object = None


def _candidates(prep: PreparedEpoch, cfg: SppConfig) -> npt.NDArray[np.bool_]:
    ok = np.isfinite(prep.pseudorange_m)
    if np.all(np.isfinite(prep.elevation)):
        ok &= prep.elevation >= np.deg2rad(cfg.elevation_mask_deg)
    if cfg.min_cn0_dbhz > 0:
        ok &= ~(prep.cn0_dbhz < cfg.min_cn0_dbhz)
    return ok


def _design(prep: PreparedEpoch, r_e: Array, systems: str):
    have = set(prep.system.tolist())
    present = "".join(s for s in systems if s in have)
    S = system_bias_matrix(prep.system, present)
    rho, H_r, _ = predict_pseudorange(prep, r_e=r_e, b_m=0.0)
    return np.hstack([H_r, S]), prep.pseudorange_m - rho, present


def _prepare(epoch: EpochData, tx, ctx: _Context, r_e: Array, excluded: set[str], *,
             coarse: bool = False) -> PreparedEpoch:
    prep = prepare_epoch(epoch, ctx.config.measurement, r_rx_e=r_e, klobuchar=ctx.klobuchar,
                         transmit=tx, coarse=coarse)
    return _usable(prep, ctx.config, excluded)


def _usable(prep: PreparedEpoch, cfg: SppConfig, excluded=()) -> PreparedEpoch:
    """`prep`'s satellites that `_candidates` keeps and that are not `excluded` (all kept:
    `prep` itself, the same arrays)."""
    keep = _candidates(prep, cfg)
    if excluded:
        keep &= ~np.isin(prep.sv, list(excluded))
    return prep if keep.all() else prep.subset(keep)


def _gauss_newton(epoch: EpochData, tx, ctx: _Context, r_e: Array,
                  excluded: set[str]) -> tuple[Array, PreparedEpoch] | None:
    """Iterate position + clocks to convergence; returns the final iterate and its data.

    From a guess far from the surface (cold start) the first iterates use no mask, weights
    or corrections (`prepare_epoch(coarse=True)`) until a step is below `COARSE_STEP_M`.
    """
    cfg = ctx.config
    coarse = not _near_surface(r_e)
    for _ in range(cfg.max_iter):
        prep = _prepare(epoch, tx, ctx, r_e, excluded, coarse=coarse)
        H, z, present = _design(prep, r_e, cfg.measurement.systems)
        if len(prep) < H.shape[1] or not (np.isfinite(H).all() and np.isfinite(z).all()):
            return None             # too few satellites, or iterates gone astray
        try:
            dx = wls_step(H, z, prep.sigma_pr_m).dx
        except np.linalg.LinAlgError:
            return None
        r_e = r_e + dx[:3]
        step = np.linalg.norm(dx[:3])
        if coarse:
            coarse = step > COARSE_STEP_M or not _near_surface(r_e)
        elif step < cfg.tol_m:
            break
    return r_e, _prepare(epoch, tx, ctx, r_e, excluded)


def _near_surface(r_e: Array) -> bool:
    if np.linalg.norm(r_e) < MIN_RECEIVER_RADIUS_M:
        return False
    return abs(float(ecef_to_geodetic(r_e)[2])) < MAX_RECEIVER_HEIGHT_M


def _position(epoch: EpochData, tx, ctx: _Context, r0: Array, prepared=None):
    """Position fix with FDE: (r_e, prep, FdeResult, present systems) or None (`prepared`:
    the epoch prepared at `r0`, `gnss_obs.spp.solve_spp_epoch`'s)."""
    cfg = ctx.config
    excluded: set[str] = set()
    r_e = r0
    while True:
        if prepared is not None and not excluded:   # r0's own preparation: no iteration
            solved = r0, _usable(prepared, cfg)
        else:
            solved = _gauss_newton(epoch, tx, ctx, r_e, excluded)
        if solved is None:
            return None
        r_e, prep = solved
        H, z, present = _design(prep, r_e, cfg.measurement.systems)
        if len(prep) < H.shape[1]:
            return None
        max_excl = cfg.max_exclusions - len(excluded) if cfg.raim else 0
        fde = fault_detection_exclusion(H, z, prep.sigma_pr_m, p_false_alarm=cfg.p_false_alarm,
                                        max_exclusions=max_excl, huber_k=cfg.huber_k)
        every = (H, z, prep.sigma_pr_m) if not excluded else every   # all rows
        if fde.n_excluded == 0:
            if prepared is not None and not excluded and \
                    np.linalg.norm(fde.step.dx[:3]) > cfg.tol_m:
                prepared, r_e = None, r_e + fde.step.dx[:3]    # too far: iterate from there
                continue
            r_e = r_e + fde.step.dx[:3]
            return r_e, prep, fde, present, sorted(excluded), every
        excluded |= set(prep.sv[~fde.kept])


def _velocity(prep: PreparedEpoch, r_e: Array, cfg: SppConfig
              ) -> tuple[FdeResult, PreparedEpoch] | None:
    """Doppler velocity + drift with FDE over the satellites of the position fix."""
    sub = prep.subset(np.isfinite(prep.range_rate_mps))
    if len(sub) < _MIN_DOPPLER_SATS:
        return None
    rr, _, H_v, H_d = predict_range_rate(sub, r_e=r_e, v_e=np.zeros(3), d_mps=0.0)
    H = np.hstack([H_v, H_d[:, None]])
    try:
        fde = fault_detection_exclusion(H, sub.range_rate_mps - rr, sub.sigma_rr_mps,
                                        p_false_alarm=cfg.p_false_alarm,
                                        max_exclusions=cfg.max_exclusions if cfg.raim else 0,
                                        huber_k=cfg.huber_k)
    except np.linalg.LinAlgError:
        return None
    return fde, sub


def _sky(epoch: EpochData, tx, ctx: _Context, r_e: Array, clocks: dict[str, float]) -> dict:
    """Per-satellite look angles and pseudorange residuals at the fix (all tracked)."""
    full = prepare_epoch(epoch, ctx.config.measurement, r_rx_e=r_e, klobuchar=ctx.klobuchar,
                         transmit=tx)
    b_sat = np.array([clocks.get(s, np.nan) for s in full.system])
    rho, _, _ = predict_pseudorange(full, r_e=r_e, b_m=np.nan_to_num(b_sat))
    return {"sv": full.sv, "system": full.system, "elevation": full.elevation,
            "azimuth": full.azimuth, "cn0_dbhz": full.cn0_dbhz,
            "pr_residual_m": np.where(np.isfinite(b_sat), full.pseudorange_m - rho, np.nan)}


def fix_epoch(epoch: EpochData, config: SppConfig, guess: Array, *,
              klobuchar: tuple[Array, Array] | None = None, precise=None, transmit=None,
              details: bool = True, prepared: PreparedEpoch | None = None
              ) -> EpochFix | None:
    """The fix of one epoch from the receiver guess `guess` (ECEF, m, shape (3,); the
    Earth's centre: a cold start), with the navigation header's `klobuchar` coefficients
    (``ionosphere="klobuchar"``) and `precise` orbits and clocks (a
    `gnss_obs.precise.PreciseOrbits`; None: the broadcast ones); `transmit`, `details`
    and `prepared` as `gnss_obs.spp.solve_spp_epoch`'s. None: too few satellites or a
    singular geometry (module docstring)."""
    ctx = _Context(config, klobuchar, precise)
    tx = transmit_states(epoch, config.measurement, precise=ctx.precise) if transmit is None \
        else transmit
    pos = _position(epoch, tx, ctx, guess, prepared)
    if pos is None:
        return None
    r_e, prep, fde, present, excluded, every = pos
    lat, lon, _ = ecef_to_geodetic(r_e)
    C = C_n_e(lat, lon)
    T = np.eye(3 + len(present))
    T[:3, :3] = C.T  # ECEF -> ENU for the position block
    step_enu = _to_enu(fde.step, T) if details else None
    # without details the covariance is all it needs (the same product as `_to_enu`'s)
    cov_enu = (T @ fde.step.cov @ T.T if step_enu is None else step_enu.cov)[:3, :3]
    ref_clock = float(fde.step.dx[3])  # the others are inter-system biases on top of it
    clocks = {s: ref_clock + (float(fde.step.dx[3 + i]) if i else 0.0)
              for i, s in enumerate(present)}
    hpl = vpl = float("nan")
    dop, sky = Dop(*(float("nan"),) * 5), {}
    if details:
        hpl, vpl = protection_levels(step_enu, horizontal=(0, 1), vertical=2,
                                     p_false_alarm=config.p_false_alarm,
                                     p_missed_detection=config.p_missed_detection)
        H, _, _ = _design(prep, r_e, present)
        dop = dilution_of_precision(H[:, :3], H[:, 3:], lat=float(lat), lon=float(lon))
        sky = _sky(epoch, tx, ctx, r_e, clocks)
    fix = EpochFix(gps_time_s=epoch.gps_time_s, r_e=r_e, cov_enu=cov_enu,
                   clocks=clocks, used_sv=prep.sv.copy(), excluded_sv=excluded,
                   n_tracked=len(epoch), raim_ok=fde.raim_ok,
                   chi2=fde.step.test_statistic, dof=fde.step.dof, hpl_m=hpl, vpl_m=vpl,
                   dop=dop, sky=sky, pr_rows=every)
    vel = _velocity(prep, r_e, config) if config.velocity else None
    if vel is not None:
        vfde, sub = vel
        fix.v_e = vfde.step.dx[:3]
        fix.clock_drift_mps = float(vfde.step.dx[3])
        fix.cov_v_enu = C.T @ vfde.step.cov[:3, :3] @ C
        fix.doppler_sv = sub.sv[vfde.kept]
        fix.velocity_raim_ok = vfde.raim_ok
        fix.chi2_doppler, fix.dof_doppler = vfde.step.test_statistic, vfde.step.dof
    return fix


def _to_enu(step: WlsStep, T: Array) -> WlsStep:
    """The WlsStep with its state turned by the block rotation T (x_enu = T x)."""
    return replace(step, dx=T @ step.dx, cov=T @ step.cov @ T.T, gain=T @ step.gain)
