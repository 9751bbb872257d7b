"""The GNSS-only track-constrained filter: ``[s, v, clock]`` from pseudoranges and Doppler,
and ``[s, v]`` from GNSS position fixes (`railnav.filters.fix_rows`), or both.

`GnssOnlyFilter` is what `railnav.navigate` drives for ``filter="gnss-only"``: data without
an IMU. The process model is along-track kinematics with white acceleration
(`railnav.filters.gnss_only_model`); the receiver is on the track, ``r_e(s)``, ``v_e = v t_e(s)``,
and each GNSS epoch gives pseudorange and range-rate rows at the prior's point on the track
(`railnav.filters.common.GnssRowBuilder`, `railnav.filters.gnss_rows`, the same rows as the
constrained INS/GNSS filter). The speed is signed, so stops (``v = 0``) and reversals
(``v < 0``) need nothing special.

Real (urban) pseudorange errors are correlated from epoch to epoch (code multipath while
the vehicle is slow or stopped, residual ionosphere): the pseudorange variances are
inflated by `correlation_inflation` of the correlation time (``config.pseudorange_correlation_s``
standing, shorter moving: `correlation_time_s`, ``config.pseudorange_correlation_m``) so
that the filter does not average them as if they were independent. The antenna's velocity
is not exactly ``v t(s)`` (a map's heading error, a vehicle that does not follow the
fitted line): the range-rate variances get that angle's share, `heading_variance_mps2`
(``config.track_heading_sigma_rad``); without it a few degrees of heading mismatch read as
Doppler errors that the filter explained by moving ``s`` along the track's curvature
(``δs ≈ δψ/κ``: on the urban drive's leg 1 part 4 the first epoch's update moved ``s`` by
−5.95 m, −0.25 m of it from the pseudoranges). Code fixes (single-point, DGPS) get the
same inflation with ``config.fix_model.correlated_code_errors``
(`GnssOnlyFilter._fix_rows`). Gross outliers are rejected by
the engine's χ² row gate (``config.gate_probability``). Optionally (`huber_k`) the rows
are also down-weighted with Huber's weight at the prior (`railnav.filters.robust_rows`); it is off
by default: at a prior made over-confident by correlated errors it down-weights the good
rows too. Measured on the urban drive's first leg (``benchmarks/results/real_data.json``,
horizontal RMS, GPS / GPS+Galileo): before the heading term, default 1.23 / 1.60 m on the
395 epochs up to the track's end, where the filter stopped (1.20 / 1.41 m with τ alone,
which was tuned there and is worse on other pieces: `correlation_time_s`); with it the
default run no longer leaves the track's end while the car turns round there, and scores
467 epochs, 1.76 / 2.00 m (SPP 3.15 / 3.25 m); on the same epochs as before, white
pseudoranges (τ = 0) 2.05 → 2.08 m and Huber k = 1.5 1.22 → 1.24 m (GPS).
"""
from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from ekf.packing import unpack_sym
from ekf.update import Observation
from gnss_obs.oscillator import oscillator_from_name
from railnav.config import NavigatorConfig
from railnav.filters.common import GnssRowBuilder, start_on_track, track_estimates
from railnav.filters.constrained_model import isb_state_name
from railnav.filters.fault_detection import RowScreen
from railnav.filters.fix_rows import FixRowBuilder, stack_epoch_rows
from railnav.filters.gnss_only_model import build_gnss_only_model
from railnav.filters.gnss_rows import TRACK_ROW_NAMES
from railnav.filters.odometer_epochs import SCALE_STATE
from railnav.filters.robust_rows import huber_inflate
from railnav.filters.sensor_rows import SensorRows, sensor_densities, sensor_states
from trackmodel.earth import WGS84
from trackmodel.track import Track

__all__ = ["GnssOnlyFilter", "correlation_inflation", "correlation_time_s",
           "heading_variance_mps2", "CODE_FIX_QUALITIES"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]


def correlation_time_s(correlation_s: float, correlation_m: float, speed_mps: float) -> float:
    """The pseudorange errors' correlation time at a speed: ``min(τ, d / |v|)``.

    Code multipath is a function of where the antenna is among the reflectors: standing,
    it repeats epoch after epoch (correlation time τ, set by the satellites' slow motion);
    moving, it decorrelates over a distance ``d`` travelled. Measured on the urban drive
    (``benchmarks/results/real_pieces.json``, every piece): with τ alone (20 s) the filter
    held a start-up error of 5-9 m for a minute while the car drove at 5 m/s (leg 1
    part 4: horizontal RMS 5.36 m against single-point 3.87 m); with ``d`` = 20 m as
    well, 3.50 m, and the RMS is below the single-point RMS on every piece.

    Parameters
    ----------
    correlation_s : float
        τ, s (0: white).
    correlation_m : float
        ``d``, m (0: τ alone).
    speed_mps : float
        ``v``, m/s (signed).

    Returns
    -------
    float
        s.
    """
    speed = abs(float(speed_mps))
    if correlation_m <= 0.0 or speed * correlation_s <= correlation_m:
        return float(correlation_s)
    return float(correlation_m) / speed


def correlation_inflation(correlation_s: float, interval_s: float) -> float:
    """Variance factor ``(1 + ρ)/(1 − ρ)``, ``ρ = exp(−Δt/τ)``, for errors correlated over τ.

    The variance of the mean of ``n`` samples of a first-order Gauss–Markov sequence (step
    ``Δt``, correlation time ``τ``) is ``(1 + ρ)/(1 − ρ)`` times that of ``n`` white samples
    for ``n ≫ τ/Δt``; a filter fed the sequence as white noise of that inflated variance
    gets the right weight for long averages.

    Parameters
    ----------
    correlation_s : float
        τ, s (0: white, factor 1).
    interval_s : float
        Δt, the epoch interval, s (> 0).

    Returns
    -------
    float
        >= 1.
    """
    if correlation_s <= 0.0:
        return 1.0
    rho = float(np.exp(-interval_s / correlation_s))
    return (1.0 + rho) / (1.0 - rho)


#: Columns of a range-rate row's parameters (`railnav.filters.gnss_rows.range_rate_parameters`
#: of `railnav.filters.gnss_rows.track_rows`): the reference point, the tangent, the satellite.
_R_REF = slice(1, 4)
_T_REF = slice(4, 7)
_SAT_POS = slice(len(TRACK_ROW_NAMES), len(TRACK_ROW_NAMES) + 3)


def heading_variance_mps2(p: Array, speed_mps: float, sigma_rad: float) -> Array:
    """Range-rate variance of a velocity off the track's heading: ``(σ_ψ v)² (e·n)²``.

    The antenna's velocity is ``v (t + ψ n)``, ``n`` the track's horizontal normal and ψ
    an angle of σ_ψ (small): the range rate along the line of sight ``e`` errs by
    ``v ψ e·n``, of variance ``(σ_ψ v)² (e·n)²``. The filter's model is ``v t(s)``; this
    is what it leaves out (`railnav.NavigatorConfig.track_heading_sigma_rad`). The angle
    to the track's grade is left out: heights are smooth (on the urban drive the
    isotropic variant, ``(σ_ψ v)² (1 − (e·t)²)``, also cost the Doppler rows of the
    high satellites their weight).

    Parameters
    ----------
    p : ndarray, shape (N, k)
        Range-rate row parameters (`railnav.filters.gnss_rows.range_rate_parameters` with
        the `railnav.filters.gnss_rows.track_rows` part: reference point, tangent, then the
        satellite's position; ECEF).
    speed_mps : float
        ``v`` (signed), m/s.
    sigma_rad : float
        σ_ψ, rad.

    Returns
    -------
    ndarray, shape (N,)
        (m/s)².
    """
    r = p[0, _R_REF]
    up = r / np.array([1.0, 1.0, (1.0 - WGS84.f) ** 2])    # the ellipsoid's normal at r
    normal = np.cross(up, p[0, _T_REF])     # ⊥ the tangent and the up: horizontal
    normal = normal / np.linalg.norm(normal)
    los = p[:, _SAT_POS] - r
    cross = (los @ normal) / np.linalg.norm(los, axis=1)
    return (sigma_rad * float(speed_mps)) ** 2 * cross * cross


#: Fix classes whose position errors are code errors (`gnss_obs.fixes.table.FIX_QUALITIES`):
#: their variances get the pseudoranges' correlated-error inflation.
CODE_FIX_QUALITIES = ("single", "dgps")


class GnssOnlyFilter:
    """Model and GNSS rows of the GNSS-only filter for one track.

    Parameters
    ----------
    track : trackmodel.Track
    config : NavigatorConfig
        Uses ``measurement`` (systems, σ model), ``oscillator``, ``along_accel_sigma_mps2``,
        ``use_doppler`` and the initial σ.
    gnss : railnav.filters.gnss_epochs.GnssEpochs or None
    huber_k : float or None
        Huber threshold of the row down-weighting, in σ of the innovation (e.g.
        `railnav.filters.robust_rows.DEFAULT_HUBER_K`); None: off.
    fixes : railnav.filters.fix_epochs.FixEpochs, optional
        GNSS position fixes (`railnav.filters.fix_rows`, ``config.fix_model``), screened
        at the prior (`railnav.filters.fault_detection`, ``config.fault_detection``; the
        GNSS rows pass that screen untested). Fixes without GNSS observations: the state
        is ``[s, v]``, no clock.
    schedule : railnav.filters.fix_epochs.EpochSchedule, optional
        The epochs of `observations` (default: the GNSS epochs).
    odometer, balises : optional
        Odometer readings and balise passages (`railnav.filters.sensor_rows`), screened
        like the fixes.

    Attributes
    ----------
    pseudorange_inflation : float
        Factor on the pseudorange variances standing (`correlation_inflation` of
        ``config.pseudorange_correlation_s`` at the median epoch interval); moving, each
        epoch's factor is `inflation_at` its prior speed (smaller, never larger).
    gnss_interval_s : float
        That median epoch interval, s.
    n_inflated : int
        Rows down-weighted by the Huber weight so far.
    """


    def __init__(self, track: Track, config: NavigatorConfig, gnss=None, *,
                 huber_k: float | None = None, fixes=None, schedule=None, odometer=None,
                 balises=None) -> None:
        self.track, self.config, self.huber_k = track, config, huber_k
        clock = gnss is not None or fixes is None
        self.isb_systems = tuple(config.measurement.systems[1:]) if clock else ()
        extra = sensor_states(config, odometer)
        self.model = build_gnss_only_model(self.isb_systems, clock=clock, extra_blocks=extra)
        self.layout = self.model.layout
        self.process = self.model.process
        self.q_c = self.model.process_noise_density(
            along_accel_sigma_mps2=config.along_accel_sigma_mps2,
            oscillator=oscillator_from_name(config.oscillator),
            extra_q=sensor_densities(config, extra))
        self.isb_names = tuple(isb_state_name(s) for s in self.isb_systems)
        self.rows = GnssRowBuilder(track, self.layout, gnss, config, self.isb_names) \
            if clock else None
        self.schedule = schedule
        self.fix_rows = None if fixes is None else FixRowBuilder(
            track, self.layout, fixes, config.fix_model, antenna_m=config.lever_arms.antenna_m)
        self.sensors = SensorRows(self.layout, config, odometer=odometer, balises=balises)
        self.screen = None if fixes is None and not self.sensors else \
            RowScreen(config.fault_detection, None)
        interval = float(np.median(np.diff(gnss.time_s))) if gnss is not None and \
            len(gnss) > 1 else 1.0
        self.gnss_interval_s = interval
        self.pseudorange_inflation = correlation_inflation(config.pseudorange_correlation_s,
                                                           interval)
        self.n_inflated = 0
        #: The fix rows' factor standing, for the monitor (1: the fixes are taken as white).
        self.fix_inflation = self.pseudorange_inflation \
            if fixes is not None and config.fix_model.correlated_code_errors else 1.0

    def inputs(self, t: Array, u: Array, x_prev: Array, P_prev: Array,
               t_prev: float) -> tuple[Array, Array, None]:
        """No inputs and no per-step parameters: arrays of shape ``(M, 0)``.

        Parameters
        ----------
        t : ndarray, shape (M,)
            Sample times, s.
        u : ndarray, shape (M, 0)
        x_prev : ndarray, shape (n,)
        t_prev : float
        """
        empty = np.zeros((np.size(t), 0))
        return empty, empty, None

    def observations(self, index: int, x: Array, P: Array) -> list[Observation]:
        """GNSS rows of epoch `index` at the prior ``(x, P)``: pseudorange variances
        inflated for correlated errors, range-rate variances for the velocity's angle to
        the track (`heading_variance_mps2`), then (with `huber_k`) Huber-weighted; with fixes,
        the fix rows too, and the rows the fault screen lets through."""
        g, f = (index, -1) if self.schedule is None else self.schedule.split(index)
        rows = [] if g < 0 else self._gnss_rows(g, x, P)
        if self.screen is None:
            return rows
        gnss = None if g < 0 else (rows, self.rows.rows_sv[-1], self.rows.rows_kind[-1])
        fix = None if f < 0 else self._fix_rows(f, x)
        extra = self.sensors.parts(self.schedule, index, x, P) if self.sensors else ()
        rows, sv, kind, modes, groups = stack_epoch_rows(gnss, fix, gnss_mode="pass",
                                                         fix_group=f, extra=extra)
        return self.screen.screen(rows, sv, kind, x, P, modes=modes, groups=groups)

    def _fix_rows(self, index: int, x: Array):
        """The rows of fix `index` (`railnav.filters.fix_rows.FixRowBuilder`); those of a
        code fix (`CODE_FIX_QUALITIES`: a receiver's single-point or DGPS solution), with
        ``config.fix_model.correlated_code_errors``,
        their variances inflated by `inflation_at`, its position and its speed alike: their
        errors are its pseudoranges' and Dopplers', correlated from epoch to epoch the same
        way (the speed's too: with the position rows alone inflated, the fix-based filter
        on the urban drive's leg 1 followed single-point speeds 2.9 m/s low while braking
        and stood 8 m behind, horizontal max 9.1 m against SPP's 8.8). Carrier (RTK)
        fixes keep their variances."""
        obs, sv, kind = self.fix_rows.observations(index, x)
        if not self.config.fix_model.correlated_code_errors or \
                str(self.fix_rows.fixes.quality[index]) not in CODE_FIX_QUALITIES:
            return obs, sv, kind
        factor = self.inflation_at(float(x[self.layout.index("v")]))
        if factor != 1.0:
            obs = [replace(o, R=o.R * factor) for o in obs]
        return obs, sv, kind

    def inflation_at(self, speed_mps: float) -> float:
        """The pseudorange variance factor at the prior's speed: `correlation_inflation`
        of `correlation_time_s` (``config.pseudorange_correlation_s`` and ``_m``)."""
        cfg = self.config
        return correlation_inflation(
            correlation_time_s(cfg.pseudorange_correlation_s, cfg.pseudorange_correlation_m,
                               speed_mps), self.gnss_interval_s)

    def _gnss_rows(self, index: int, x: Array, P: Array) -> list[Observation]:
        speed = float(x[self.layout.index("v")])
        factor = self.inflation_at(speed)
        sigma_psi = self.config.track_heading_sigma_rad
        models = self.rows.rows
        rows = []
        for obs in self.rows.observations(index, x):
            if obs.model is models.pseudorange and factor != 1.0:
                obs = replace(obs, R=obs.R * factor)
            elif obs.model is models.range_rate and sigma_psi > 0.0 and speed != 0.0:
                obs = replace(obs, R=obs.R + heading_variance_mps2(obs.p, speed, sigma_psi))
            rows.append(obs)
        if self.huber_k is None:
            return rows
        rows, n = huber_inflate(rows, x, P, k=self.huber_k)
        self.n_inflated += n
        return rows

    def initial_covariance(self, *, sigma_s_m: float, sigma_v_mps: float) -> Array:
        """Diagonal initial covariance in the layout's order (config's clock and ISB σ)."""
        cfg = self.config
        var = {"s": sigma_s_m ** 2, "v": sigma_v_mps ** 2,
               "clock_bias": cfg.initial_clock_bias_sigma_m ** 2,
               "clock_drift": cfg.initial_clock_drift_sigma_mps ** 2,
               SCALE_STATE: cfg.odometer_model.scale_sigma ** 2}
        return np.diag([var.get(name, cfg.initial_isb_sigma_m ** 2)
                        for name in self.layout.names])

    def initial_from_fix(self, fix) -> tuple[Array, Array]:
        """State and covariance at a GNSS fix (`railnav.navigation.initialization.GnssFix`): the fix
        projected on the track, the speed its velocity along the tangent
        (`railnav.filters.common.start_on_track`)."""
        values, sigma_s, sigma_v = start_on_track(self.track, self.config, fix,
                                                  self.isb_names)
        x0 = np.array([values.get(name, 0.0) for name in self.layout.names])
        return x0, self.initial_covariance(sigma_s_m=sigma_s, sigma_v_mps=sigma_v)

    def truth_states(self, truth, clock_bias_m: Array, clock_drift_mps: Array
                     ) -> tuple[Array, npt.NDArray[np.bool_]]:
        """True states at the truth's samples (``truth.s``, ``truth.v``, the clock); every
        component is known (the simulator has one receiver clock: inter-system biases 0)
        but an odometer's scale factor.

        Returns
        -------
        x_true : ndarray, shape (K, n)
        known : ndarray of bool, shape (n,)
        """
        values = {"s": truth.s, "v": truth.v, "clock_bias": clock_bias_m,
                  "clock_drift": clock_drift_mps}
        x = np.zeros((np.size(truth.s), self.layout.size))
        for i, name in enumerate(self.layout.names):
            x[:, i] = values.get(name, 0.0)
        return x, np.array([name != SCALE_STATE for name in self.layout.names])

    def estimates(self, x: Array, P_packed: Array) -> dict[str, Array]:
        """Estimate columns (`railnav.navigation.result`) of stored states."""
        var = np.diagonal(unpack_sym(P_packed), axis1=1, axis2=2)
        return track_estimates(self.track, self.layout, x, var)
