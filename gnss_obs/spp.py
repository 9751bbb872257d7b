"""Single-point positioning: per-epoch weighted least squares with RAIM/FDE, Doppler velocity.

`solve_spp` is the public entry point shared by the ``railnav spp`` command and the
notebooks; `solve_spp_epoch` solves one epoch as `solve_spp` would solve a file holding it
alone. Per file: measurements (`gnss_obs.measurements`) and ephemerides
(`gnss_obs.ephemeris`) cut into epochs (`gnss_obs.epoch_table.split_epochs`); per epoch,
the fix of `gnss_obs.spp_epoch` (Gauss-Newton on the pseudoranges, RAIM/FDE, Doppler
velocity) from a guess: the previous fix (within `SppConfig.max_gap_s`), else the file's
approximate position, else the Earth's centre (cold start: no corrections until the
iterate is near the surface).

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

import numpy as np
import numpy.typing as npt

from gnss_obs.coverage import check_nav_coverage
from gnss_obs.dgps import apply_corrections
from gnss_obs.epoch import MIN_RECEIVER_RADIUS_M, EpochData, PreparedEpoch, split_epochs
from gnss_obs.errors import GnssError
from gnss_obs.measurements import (
    MeasurementConfig,
    glonass_channels,
    select_measurements,
)
from gnss_obs.spp_config import SppConfig
from gnss_obs.spp_epoch import fix_epoch
from gnss_obs.spp_result import EpochFix, SppResult, assemble_result

__all__ = ["SppConfig", "SppResult", "solve_spp", "solve_spp_epoch"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]


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
    klobuchar = _klobuchar(nav, mc)
    epochs = _every_epoch(split_epochs(meas, nav.records, mc), obs.table)
    fixes: list[EpochFix | None] = []
    last: EpochFix | None = None
    start = _initial_guess(obs.header.approx_position_e)
    for i, epoch in enumerate(epochs):
        recent = last is not None and epoch.gps_time_s - last.gps_time_s <= cfg.max_gap_s
        fix = fix_epoch(epoch, cfg, last.r_e if recent else start, klobuchar=klobuchar,
                        precise=precise) if len(epoch) else None
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
        The epoch's `gnss_obs.transmission.transmit_states` when the caller has them
        (`gnss_obs.transmission.transmit_states_batch`).
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
    return fix_epoch(epoch, cfg, _initial_guess(approx_e),
                     klobuchar=_klobuchar(nav, cfg.measurement), transmit=transmit,
                     details=details, prepared=prepared)
