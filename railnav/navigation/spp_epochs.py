r"""Each GNSS epoch's own single-point fix: the position fixes of a GNSS run's spawn test
(`railnav.navigation.spawning`; issue 14 §3, "in the network navigator, spawn new
hypotheses", for runs on pseudoranges without a fix log).

`epoch_spp_fixes` solves every GNSS epoch of a run (`railnav.filters.gnss_epochs.GnssEpochs`,
the epochs the hypotheses' filters read, with their satellites' states at transmission)
alone (a network run: `EpochSppFixes`, each epoch as the run reaches it) by
`gnss_obs.spp.solve_spp_epoch`, with the run's measurement settings and
elevation mask (`railnav.navigation.track_fixes.spp_config_of`): weighted least squares
with the pseudorange σ model the run declares (`gnss_obs.MeasurementConfig.sigma_model`,
``sigma_pr_m``), the receiver's χ² fault detection and exclusion and Huber weights. The
horizontal covariance is the solution's own, ``(Aᵀ W A)⁻¹`` in ENU: the fix the spawn test
compares with the hypotheses is as good as that model says and no better.

The fixes are independent of the hypotheses (no prior enters), so a set of hypotheses that
started wrong cannot pull them along. An epoch whose fault detection still fails after the
exclusions (``raim_ok`` False) or with too few satellites has no fix (NaN).

Linearized at a hypothesis (`EpochSppFixes.solve`'s ``linearized``, the network run's):
the epoch's satellites as the most probable hypothesis's filter prepared them at its prior
(`railnav.filters.common.EpochRowBuilder.latest`: the same function, settings and
transmission states as the fix's own preparation) are the start of the fix, which is then
the fault screen's one least-squares step from there, without a preparation of its own,
when that step is below `TOL_M` (else it is solved from the extrapolated guess as without
one). Only the linearization point comes from the hypothesis: the fix is still the
pseudoranges' own least-squares solution, but its corrections and weights (troposphere,
ionosphere, Sagnac, elevation σ) are those at that point instead of at the plain
least-squares solution (where `gnss_obs.solve_spp` takes its last step): their gradients,
of order 1e-3 per metre, move it by ~1e-3 of the step (the geometry's own linearization
error, δ²/(2ρ), is < 1e-5 m). Measured against `solve_spp`: ≤ 1.1 cm, median 2.4 mm, at
most 7.3e-4 of the distance, in the ``pruned`` 1000-s run of
`benchmarks/bench_network_speed.py` (every epoch linearized, steps ≤ 27.5 m, median 8.2
m); on curvy (σ_pr 3 m) < 1 % of the fix's smallest horizontal σ
(`tests/railnav/navigation/test_spp_epochs.py`), against the metres the spawn test
compares. A hypothesis that is wrong by more than `TOL_M` gets the fix of the guess path.

**Scale.** The fixes' pseudoranges feed a `railnav.filters.noise_scale.NoiseScale` of
their own (``NavigatorConfig.noise_scale``; None: none), from each fix's post-fit
residuals (`residual_rows`: the plain weighted least squares of every usable satellite
before any exclusion, over ``√(1 − h)``), the epochs before it counting. These residuals
know no hypothesis, whereas the bank's scale (`railnav.filters.bank_noise_scale`) is fed
by its most probable hypothesis, wrong ones included. Not the solution's own residuals:
the exclusions keep the satellites until the χ² test at the told σ passes, and Huber's
weights near an L1 fit leave half the rows near 0 (k² 2.4-2.9 and 3.2-3.9 at 60, 120 and
300 s where the plain residuals give 5.0-7.3, pseudoranges 3 m told 1 m). Told right,
``k²`` stays 1 (the sign test). Its upper bound (`NoiseScale.upper_bound`) decides
whether a spawn restarts the bank's scale (`BankNoiseScale.restart_above`): a bank's
factor above it was raised by rows noisier than the receiver's, a wrong hypothesis's.

The fixes' covariance stays the solution's (the told σ), not scaled by this ``k²``.
Scaled (tried, stop 39), the told-too-small case (3 tracks 4.5 m apart, curvy,
pseudoranges 3 m told 1 m, 300 s, seeds 1-5) lost its false spawns (72 → 0) with the
share of cycles on the right netelement unchanged (99.80 %), and the fixes' horizontal
NEES against the truth fell from 21.0 to 3.36 (χ²₂: 2); but with 2 m of code multipath
the navigator is not told about (``benchmarks/bench_network_spawn_gnss.py
--multipath-sigma 2``, parallel tracks 15 m apart, spawning) the multipath raised the
fixes' scale and took the test's power: right 0.721 → 0.643 of the cycles and
confident-wrong cycles 152 → 202. Unscaled, every series of that benchmark is as
before, and the restart alone gives back the fast recovery of a wrong start.

Their errors are as correlated from epoch to epoch as the pseudoranges' are: the run's
``NavigatorConfig.pseudorange_correlation_s`` (0 for simulated trips, whose errors are
white; 20 s by default, urban code multipath). `correlation_s` gives the τ the spawn test
counts them with (`railnav.navigation.hypotheses.evidence_share`).

Cost: one solve per epoch, from a guess extrapolated from the last fixes (`_guess`: the
straight line through up to `GUESS_FIXES` of them): two preparations of the epoch, one
Gauss-Newton iteration (two in 0.7 % of the epochs of the 1000-s paper run, 22 % from
the last two fixes alone) and the fault screen's step, without protection levels, DOP or
sky (~0.8 ms of CPU an epoch with GPS, 2.6 ms with `gnss_obs.spp.SppConfig`'s defaults).
Linearized at a hypothesis: no preparation and no iteration, the fault screen's step
alone. In the ``pruned`` 1000-s run of `benchmarks/bench_network_speed.py` (every epoch
linearized) these fixes take 0.29 s of CPU (0.82 s from the guess; with
`gnss_obs.observables.predict_pseudorange` through the function's buffer; a machine loaded
2.5-3); `NetworkNavConfig.spawn_window_epochs` = 0 turns test, status column and these
fixes off.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from railnav.filters.common import ROW_KINDS
from railnav.filters.fix_epochs import FixEpochs
from railnav.filters.noise_scale import NoiseScale
from railnav.navigation.track_fixes import spp_config_of
from trackmodel.earth import ecef_to_geodetic

__all__ = ["epoch_spp_fixes", "EpochSppFixes", "correlation_s", "residual_rows",
           "SPP_QUALITY"]

#: The fix class (`gnss_obs.fixes.table.FIX_QUALITIES`) of a receiver's single-point fix.
SPP_QUALITY = "single"
#: Gauss-Newton stops below this step, m (`gnss_obs.spp.SppConfig.tol_m`): from a guess
#: extrapolated from the last fixes (off by their errors, metres), one iteration.
#: The fault screen's least-squares step from the last iterate follows, so the fix is off
#: by the linearisation's error only, ``δ²/(2ρ)`` for a step δ at a range ρ ≈ 2e7 m:
#: ≤ 2e-5 m.
TOL_M = 30.0
#: Fixes further apart than this are not extrapolated from, s.
GUESS_GAP_S = 5.0
#: Most fixes the guess is extrapolated from: a line through 8 fixes 1 s apart is off by
#: ~1.2 σ of one fix (two: 2.2 σ) and, on a train accelerating at 1 m/s², by 7 m more.
GUESS_FIXES = 8


def epoch_spp_fixes(gnss, data, config) -> FixEpochs | None:
    """The single-point fix of each epoch of `gnss` (module docstring), one per epoch in
    its order (NaN position where an epoch has none); None without epochs.

    Parameters
    ----------
    gnss : railnav.filters.gnss_epochs.GnssEpochs or None
        The run's epochs (``TripSamples.gnss``).
    data : railnav.sensor_data.SensorData
        Its navigation file (``data.nav``) and the observation header's approximate
        position (the first guess).
    config : railnav.NavigatorConfig
        The run's measurement settings and elevation mask.

    Returns
    -------
    railnav.filters.fix_epochs.FixEpochs or None
        As `EpochSppFixes.fixes`, every epoch solved.
    """
    solver = EpochSppFixes.of(gnss, data, config)
    if solver is None:
        return None
    for k in range(len(gnss.epochs)):
        solver.solve(k)
    return solver.fixes


class EpochSppFixes:
    """The single-point fixes of a run's GNSS epochs, each solved when the run reaches it
    (`solve`, in time order: the guess of each comes from the fixes before it).

    Parameters
    ----------
    gnss, data, config
        As `epoch_spp_fixes` (`gnss` with epochs, `data.nav` given: `of`).

    Attributes
    ----------
    fixes : railnav.filters.fix_epochs.FixEpochs
        ``time_s`` of the epochs (s from the trip start), ``lat``/``lon`` (rad), ``h_m``,
        ``cov_n_m2`` the ENU position covariance (m², (E, 3, 3)), ``quality``
        `SPP_QUALITY`; no velocity; NaN until solved, and where an epoch has no fix.
    """

    def __init__(self, gnss, data, config) -> None:
        # a position is all it needs; the fault screen's step after the iterations leaves
        # an error of the order of (last step)² / (2 range): TOL_M costs ~2e-5 m at most
        self.cfg = replace(spp_config_of(config), velocity=False, tol_m=TOL_M)
        self.gnss, self.nav = gnss, data.nav
        n = len(gnss.epochs)
        nan = np.full(n, np.nan)
        self.fixes = FixEpochs(time_s=np.asarray(gnss.time_s, dtype=float), lat=nan,
                               lon=nan.copy(), h_m=nan.copy(),
                               cov_n_m2=np.full((n, 3, 3), np.nan),
                               v_n_mps=np.full((n, 3), np.nan),
                               sigma_speed_mps=nan.copy(),
                               quality=np.full(n, SPP_QUALITY, dtype=object))
        self._transmit = getattr(gnss, "transmit", None) or [None] * n
        self._approx = getattr(getattr(data.obs, "header", None), "approx_position_e", None)
        # the filters' preparations are this fix's when prepared alike (`solve`)
        self._alike = getattr(gnss, "config", None) == self.cfg.measurement and \
            getattr(gnss, "elevation_mask_rad", None) == np.deg2rad(self.cfg.elevation_mask_deg)
        self._solved = np.zeros(n, dtype=bool)
        self._last: list = []                          # the last fixes (time, r_e)
        #: The fixes' own noise scale (module docstring, "Scale"): the pseudoranges' k²
        #: from the post-fit residuals of the fixes before, whatever the hypotheses.
        self.noise_scale = NoiseScale(getattr(config, "noise_scale", None))

    @classmethod
    def of(cls, gnss, data, config) -> "EpochSppFixes | None":
        """The solver of a run's epochs; None without epochs or navigation file."""
        if gnss is None or data.nav is None or not len(gnss.epochs):
            return None
        return cls(gnss, data, config)

    def solve(self, k: int, linearized=None) -> None:
        """Solve epoch `k` into `fixes` (once; later calls do nothing).

        Parameters
        ----------
        k : int
            The epoch.
        linearized : (ndarray (3,), gnss_obs.PreparedEpoch), optional
            A receiver position (ECEF, m) and the epoch's satellites prepared there by
            the run's filters (`railnav.filters.common.EpochRowBuilder.latest`, a
            hypothesis's prior): the fix is then the one least-squares step from it
            (`gnss_obs.spp.solve_spp_epoch`'s ``prepared``) when that step is below
            `TOL_M`, else solved from the extrapolated guess as without it.
        """
        if self._solved[k]:
            return
        from gnss_obs.spp import solve_spp_epoch
        self._solved[k] = True
        time_s = float(self.gnss.time_s[k])
        if linearized is not None and self._alike:
            approx, prepared = linearized
        else:
            approx, prepared = _guess(self._last, time_s, self._approx), None
        fix = solve_spp_epoch(self.gnss.epochs[k], self.nav, self.cfg,
                              transmit=self._transmit[k], details=False,
                              approx_e=approx, prepared=prepared)
        if fix is None:
            return
        if self.noise_scale.feeding and fix.pr_rows is not None:
            self.noise_scale.add({ROW_KINDS[0]: residual_rows(*fix.pr_rows)})
        if not fix.raim_ok or not np.all(np.isfinite(fix.r_e)):
            return
        r_e = np.asarray(fix.r_e, dtype=float)
        f = self.fixes
        f.lat[k], f.lon[k], f.h_m[k] = (float(np.asarray(a).reshape(-1)[0])
                                        for a in ecef_to_geodetic(r_e))
        f.cov_n_m2[k] = fix.cov_enu      # the told σ's (module docstring, "Scale")
        self._last = (self._last + [(time_s, r_e)])[-GUESS_FIXES:]


def residual_rows(H, z, sigma_m):
    """A fix's pseudorange rows as `NoiseScale.add` takes them, ``(ν, a, b)`` (module
    docstring, "Scale"): the plain weighted least-squares post-fit residuals of every
    usable satellite (`gnss_obs.raim.wls_step` of the fix's last linearized problem
    before any exclusion, `gnss_obs.spp_result.EpochFix.pr_rows`) over ``√(1 − h)`` (h
    the leverage: their variance is then λ σ²), ``a`` = 0, ``b`` = σ² (the told σ);
    rows without redundancy (``h`` → 1) left out."""
    from gnss_obs.raim import wls_step
    sigma_m = np.asarray(sigma_m, dtype=float)
    step = wls_step(H, z, sigma_m)
    redundancy = 1.0 - np.asarray(step.leverage, dtype=float)
    keep = redundancy > 1e-9
    nu = np.asarray(step.residual, dtype=float)[keep] / np.sqrt(redundancy[keep])
    return nu, np.zeros(nu.size), np.square(sigma_m[keep])


def _guess(last: list, time_s: float, approx):
    """The first guess of the epoch at `time_s`: the least-squares line through the latest
    fixes (``(time_s, r_e)``, oldest first) that follow each other at most `GUESS_GAP_S`
    apart, the last of them at most that before it, evaluated at `time_s` (one fix: that
    fix); else `approx` (the file's approximate position)."""
    if not last or time_s - last[-1][0] > GUESS_GAP_S:
        return approx
    first = len(last) - 1
    while first > 0 and last[first][0] - last[first - 1][0] <= GUESS_GAP_S:
        first -= 1
    if first == len(last) - 1:
        return last[-1][1]
    t = np.array([tk for tk, _ in last[first:]])
    d = np.array([rk for _, rk in last[first:]]) - last[-1][1]     # from the last, m
    dt = t - t.mean()
    return last[-1][1] + d.mean(axis=0) + (dt @ d) * ((time_s - t.mean()) / (dt @ dt))


def correlation_s(nav, config) -> float:
    """τ of the single-point fixes' errors (module docstring): the larger of the run's
    `NetworkNavConfig.evidence_correlation_s` and its pseudoranges'
    ``NavigatorConfig.pseudorange_correlation_s``, s."""
    return max(float(nav.evidence_correlation_s), float(config.pseudorange_correlation_s))
