"""Single-point positioning: per-epoch weighted least squares with RAIM/FDE, Doppler velocity.

`solve_spp` is the public entry point shared by the ``railnav spp`` command and the
notebooks. Per epoch:

1. measurements (`gnss_obs.measurements`) and ephemerides (`gnss_obs.ephemeris`), satellite
   states at transmission (`gnss_obs.epoch.transmit_states`, independent of the guess);
2. Gauss-Newton on the pseudorange model (`gnss_obs.observables`) for ECEF position and one
   clock per system present (``b_sat = S @ clocks``, `observables.system_bias_matrix`),
   re-preparing corrections and the elevation mask at every iterate; the guess is the
   previous fix (within `SppConfig.max_gap_s`), else the file's approximate position, else
   the Earth's centre (cold start: no corrections until the iterate is near the surface);
3. RAIM/FDE (`gnss_obs.raim`): χ² test of the weighted residuals, exclusion of the worst
   standardized residual, re-solution; protection-level-style HPL/VPL and DOPs;
4. velocity and clock drift from the range rates (``-λ D``) of the kept satellites, linear
   WLS with its own FDE.

Inter-system offsets (GPS-Galileo time offset, GLONASS time, BeiDou time, receiver
inter-system hardware delays) are estimated per epoch as one bias per non-reference
system; the header's ``TIME SYSTEM CORR`` values are not applied. Every epoch of the
observation file has a row: epochs with fewer usable satellites than unknowns — one, none
of the configured systems, or none with an ephemeris — give a row of NaN with ``fix_ok``
False (issue 16: one-satellite epochs used to vanish); their count goes to one warning and
to `SppResult.n_no_fix`.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from gnss_obs.coverage import check_nav_coverage
from gnss_obs.dgps import apply_corrections
from gnss_obs.dop import Dop, dilution_of_precision
from gnss_obs.epoch import (
    MAX_RECEIVER_HEIGHT_M,
    MIN_RECEIVER_RADIUS_M,
    EpochData,
    PreparedEpoch,
    prepare_epoch,
    split_epochs,
    transmit_states,
)
from gnss_obs.errors import GnssError
from gnss_obs.measurements import (
    MeasurementConfig,
    glonass_channels,
    select_measurements,
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
from gnss_obs.spp_result import EpochFix, SppResult, assemble_result
from trackmodel.earth import C_n_e, ecef_to_geodetic

__all__ = ["SppConfig", "SppResult", "solve_spp", "solve_spp_epoch"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]

#: Fewest Doppler measurements for a velocity: 4 unknowns + 1 redundant (an untestable
#: velocity is not reported).
_MIN_DOPPLER_SATS = 5
#: A cold start's coarse iterations (no mask, weights or corrections) end once a position
#: step is below this, m: the guess is then good enough for elevations and delays.
COARSE_STEP_M = 1.0e3


@dataclass
class _Context:
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
    the epoch prepared at `r0`, `solve_spp_epoch`'s)."""
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


def _solve_epoch(epoch: EpochData, ctx: _Context, guess: Array, *, transmit=None,
                 details: bool = True, prepared=None) -> EpochFix | None:
    cfg = ctx.config
    tx = transmit_states(epoch, cfg.measurement, precise=ctx.precise) if transmit is None \
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
                                     p_false_alarm=cfg.p_false_alarm,
                                     p_missed_detection=cfg.p_missed_detection)
        H, _, _ = _design(prep, r_e, present)
        dop = dilution_of_precision(H[:, :3], H[:, 3:], lat=float(lat), lon=float(lon))
        sky = _sky(epoch, tx, ctx, r_e, clocks)
    fix = EpochFix(gps_time_s=epoch.gps_time_s, r_e=r_e, cov_enu=cov_enu,
                   clocks=clocks, used_sv=prep.sv.copy(), excluded_sv=excluded,
                   n_tracked=len(epoch), raim_ok=fde.raim_ok,
                   chi2=fde.step.test_statistic, dof=fde.step.dof, hpl_m=hpl, vpl_m=vpl,
                   dop=dop, sky=sky, pr_rows=every)
    vel = _velocity(prep, r_e, cfg) if cfg.velocity else None
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


def _initial_guess(approx_e: Array | None) -> Array:
    if approx_e is not None and np.linalg.norm(approx_e) > MIN_RECEIVER_RADIUS_M:
        return np.asarray(approx_e, dtype=float).copy()
    return np.zeros(3)


def _every_epoch(epochs: list[EpochData], table) -> list[EpochData]:
    """`epochs` plus an empty `EpochData` for each observation epoch without usable data."""
    times = np.unique(table["gps_time_s"].to_numpy())
    have = {e.gps_time_s for e in epochs}
    empty = [EpochData(float(t), {"sv": np.array([], dtype=object)}, {}) for t in times
             if float(t) not in have]
    return sorted(epochs + empty, key=lambda e: e.gps_time_s) if empty else epochs


def solve_spp(obs, nav, config: SppConfig | None = None, *,
              corrections=None, max_correction_age_s: float = 30.0, precise=None,
              progress: Callable[[int, int], None] | None = None) -> SppResult:
    """Single-point (or code-differential) positioning of every epoch of an observation file.

    Parameters
    ----------
    obs : RinexObs
        Observations (`read_rinex_obs`, or `gnss_obs.smoothing.smooth_observations` of
        it for carrier-smoothed code); epochs are tagged in GPS time.
    nav : RinexNav
        Broadcast navigation (`read_rinex_nav`), with the Klobuchar coefficients in its
        header when ``ionosphere="klobuchar"``.
    config : SppConfig, optional
    corrections : pandas.DataFrame, optional
        Base-station pseudorange corrections (`gnss_obs.dgps.base_corrections`, computed
        with the same measurement config and orbits): code-differential positioning
        (DGNSS); measurements without a correction younger than `max_correction_age_s`
        are not used.
    max_correction_age_s : float
        Oldest correction applied, s.
    precise : gnss_obs.precise.PreciseOrbits, optional
        Precise orbits and clocks (SP3) instead of the broadcast ones.
    progress : callable(done, total), optional
        Called after each epoch.

    Returns
    -------
    SppResult
        One row per epoch (``to_frame()`` gives the ``spp.csv`` columns) and per-satellite
        details (`SppResult.satellites`).

    Raises
    ------
    GnssError
        If no epoch has a measurement of the configured systems.
    GnssInputError
        If `nav` holds no record valid for the observations (`gnss_obs.coverage`).
    """
    cfg = config or SppConfig()
    mc = cfg.measurement
    channels = glonass_channels(obs.header.glonass_slots, nav.records)
    meas = select_measurements(obs.table, mc, glonass_channels=channels)
    if corrections is not None:
        meas = apply_corrections(meas, corrections, max_age_s=max_correction_age_s)
    if len(meas) == 0:
        raise GnssError(f"{obs.path or 'observations'}: no measurements of systems "
                        f"{mc.systems!r}"
                        + (" with a base correction" if corrections is not None else ""))
    check_nav_coverage(obs, nav, mc.systems)
    ctx = _Context(cfg, _klobuchar(nav, mc), precise)
    epochs = _every_epoch(split_epochs(meas, nav.records, mc), obs.table)
    fixes: list[EpochFix | None] = []
    last: EpochFix | None = None
    start = _initial_guess(obs.header.approx_position_e)
    for i, epoch in enumerate(epochs):
        recent = last is not None and epoch.gps_time_s - last.gps_time_s <= cfg.max_gap_s
        fix = _solve_epoch(epoch, ctx, last.r_e if recent else start) if len(epoch) else None
        fixes.append(fix)
        last = fix if fix is not None else last
        if progress is not None:
            progress(i + 1, len(epochs))
    result = assemble_result(epochs, fixes, mc.systems)
    if result.n_no_fix:
        log.warning("%d of %d epochs without a position fix (too few satellites or singular "
                    "geometry)", result.n_no_fix, len(epochs))
    return result


def _klobuchar(nav, mc: MeasurementConfig) -> tuple[Array, Array] | None:
    """The navigation header's Klobuchar coefficients for ``ionosphere="klobuchar"`` (a
    warning when it has none), else None."""
    if mc.ionosphere != "klobuchar":
        return None
    alpha, beta = nav.header.iono_gps_alpha, nav.header.iono_gps_beta
    if alpha is None or beta is None:
        log.warning("no Klobuchar coefficients in the navigation header: no ionosphere "
                    "correction")
        return None
    return np.asarray(alpha, dtype=float), np.asarray(beta, dtype=float)


def solve_spp_epoch(epoch: EpochData, nav, config: SppConfig | None = None, *,
                    approx_e: Array | None = None, transmit=None,
                    details: bool = True, prepared: PreparedEpoch | None = None
                    ) -> EpochFix | None:
    """The fix of one epoch as `solve_spp` solves an observation file of that epoch alone:
    from the guess `approx_e` (the file's approximate position; the Earth's centre without
    one), broadcast orbits.

    Parameters
    ----------
    epoch : EpochData
        One epoch of `gnss_obs.epoch.split_epochs` of the measurements
        (`gnss_obs.measurements.select_measurements` with ``config.measurement``: the
        selection and the ephemeris choice are made row by row, so an epoch cut from a
        longer table is the epoch of a file holding it alone).
    nav : RinexNav
    config : SppConfig, optional
    approx_e : ndarray, shape (3,), optional
        ECEF, m (``obs.header.approx_position_e``).
    transmit : optional
        The epoch's `gnss_obs.epoch.transmit_states` when the caller has them
        (`gnss_obs.epoch.transmit_states_batch`).
    details : bool
        Also the protection levels, dilutions of precision and per-satellite sky; False:
        NaN and an empty ``sky`` (the position, clocks and covariance are the same).
    prepared : PreparedEpoch, optional
        The epoch prepared at `approx_e` as `prepare_epoch` prepares it with
        ``config.measurement`` (e.g. a filter's, at its prior): the fix is then the fault
        screen's one step from `approx_e`, without preparing the epoch again, when that
        step is below ``config.tol_m`` (else iterated from there as without it). Its
        corrections and weights are then those at `approx_e`, not at the least-squares
        solution where `solve_spp` takes its last step: the fix differs by their change
        over the step (~1e-3 of it; `railnav.navigation.spp_epochs`).

    Returns
    -------
    EpochFix or None
        None: too few satellites or a singular geometry (`solve_spp`'s row without a fix).
    """
    cfg = config or SppConfig()
    if not len(epoch):
        return None
    ctx = _Context(cfg, _klobuchar(nav, cfg.measurement))
    return _solve_epoch(epoch, ctx, _initial_guess(approx_e), transmit=transmit,
                        details=details, prepared=prepared)
