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
inflated over their correlation time (``config.pseudorange_correlation_s`` standing,
shorter moving, ``config.pseudorange_correlation_m``;
`railnav.filters.gnss_only_noise.correlation_inflation`) so that the filter does not
average them as if they were independent. The antenna's velocity is not exactly
``v t(s)`` (a map's heading error, a vehicle that does not follow the fitted line): the
range-rate rows get that angle's share (``config.track_heading_sigma_rad``,
`railnav.filters.gnss_only_noise.heading_covariance_mps2`); without it a few degrees of
heading mismatch read as Doppler errors that the filter explained by moving ``s`` along
the track's curvature
(``δs ≈ δψ/κ``: on the urban drive's leg 1 part 4 the first epoch's update moved ``s`` by
−5.95 m, −0.25 m of it from the pseudoranges). That angle is one per epoch, common to the
epoch's range-rate rows: as independent row variances the filter averaged it over the
satellites. Code fixes (single-point, DGPS) get the
same inflation with ``config.fix_model.correlated_code_errors``
(`GnssOnlyFilter._fix_rows`). What inflation cannot model, the part of the code errors
that lasts minutes, is a state shared by each epoch's position rows
(`railnav.filters.code_bias`, ``config.code_bias``). Gross outliers are rejected by
the engine's χ² row gate (``config.gate_probability``). The rows' σ get the adaptive noise
scale of each kind (`railnav.filters.noise_scale`, ``config.noise_scale``), estimated from
the rows' innovations at the prior, which this filter evaluates for it. Optionally (`huber_k`) the rows
are also down-weighted with Huber's weight at the prior (`railnav.filters.robust_rows`); it is off
by default: at a prior made over-confident by correlated errors it down-weights the good
rows too. Measured on the urban drive's first leg (``benchmarks/results/real_data.json``,
horizontal RMS, GPS / GPS+Galileo): before the heading term, default 1.23 / 1.60 m on the
395 epochs up to the track's end, where the filter stopped (1.20 / 1.41 m with τ alone,
which was tuned there and is worse on other pieces: `correlation_time_s`); with it the
default run no longer leaves the track's end while the car turns round there, and scores
467 epochs, 1.76 / 2.00 m (SPP 3.15 / 3.25 m); on the same epochs as before, white
pseudoranges (τ = 0) 2.05 → 2.08 m and Huber k = 1.5 1.22 → 1.24 m (GPS). With the heading
angle common to an epoch's rows and the slow code error's state: 1.68 / 1.87 m on the
467 epochs (without the state 1.84 / 2.09 m).
"""
from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from ekf.packing import unpack_sym
from ekf.update import Observation
from gnss_obs.oscillator import oscillator_from_name
from railnav.config import NavigatorConfig
from railnav.filters import code_bias as cb
from railnav.filters.common import ROW_KINDS, GnssRowBuilder, start_on_track
from railnav.filters.estimate_columns import track_estimates
from railnav.filters.constrained_model import isb_state_name
from railnav.filters.fault_detection import RowScreen
from railnav.filters.fix_rows import FixRowBuilder, stack_epoch_rows
from railnav.filters.gnss_only_model import CODE_BIAS_STATE, build_gnss_only_model
from railnav.filters.gnss_only_noise import (
    correlation_inflation,
    epoch_interval_s,
    heading_covariance_mps2,
    heading_inflation,
    heading_sigma_rad,
    pseudorange_inflation,
    robust_heading_sigma_rad,
)
from railnav.filters.ins_clock_model import clock_offset_columns
from railnav.filters.noise_scale import NoiseScale
from railnav.filters.odometer_epochs import SCALE_STATE
from railnav.filters.robust_rows import huber_inflate
from railnav.filters.sensor_rows import SensorRows, sensor_densities, sensor_states
from trackmodel.track import Track

__all__ = ["GnssOnlyFilter", "CODE_FIX_QUALITIES"]

log = logging.getLogger(__name__)

Array = npt.NDArray[np.float64]


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
    code_bias : bool
        Whether the state carries the slow code error (`railnav.filters.code_bias`:
        ``config.code_bias`` on, correlated pseudoranges, and pseudoranges or code fixes
        taken as correlated).
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
        self.code_bias = config.code_bias.enabled and config.pseudorange_correlation_s > 0.0 \
            and (gnss is not None or (fixes is not None
                                      and config.fix_model.correlated_code_errors))
        self.model = build_gnss_only_model(
            self.isb_systems, clock=clock, extra_blocks=extra,
            code_bias_time_s=config.code_bias.time_s if self.code_bias else 0.0)
        self.layout = self.model.layout
        self.process = self.model.process
        self.q_c = self.model.process_noise_density(
            along_accel_sigma_mps2=config.along_accel_sigma_mps2,
            oscillator=oscillator_from_name(config.oscillator),
            extra_q=sensor_densities(config, extra))
        self.isb_names = tuple(isb_state_name(s) for s in self.isb_systems)
        self.rows = GnssRowBuilder(track, self.layout, gnss, config, self.isb_names) \
            if clock else None
        self._bias_rows = cb.code_bias_rows(self.layout, self.isb_names) \
            if self.code_bias and clock else None
        self._clock_columns = clock_offset_columns(self.layout)
        self.schedule = schedule
        self.fix_rows = None if fixes is None else FixRowBuilder(
            track, self.layout, fixes, config.fix_model, antenna_m=config.lever_arms.antenna_m)
        self.sensors = SensorRows(self.layout, config, odometer=odometer, balises=balises)
        self.screen = None if fixes is None and not self.sensors else \
            RowScreen(config.fault_detection, None)
        interval = epoch_interval_s(gnss)
        self.gnss_interval_s = interval
        self.pseudorange_inflation = correlation_inflation(config.pseudorange_correlation_s,
                                                           interval)
        self.n_inflated = 0
        #: The GNSS rows' adaptive noise scale (`railnav.filters.noise_scale`).
        self.noise_scale = NoiseScale(config.noise_scale)
        #: The fix rows' factor standing, for the monitor (1: the fixes are taken as white).
        self.fix_inflation = self.pseudorange_inflation \
            if fixes is not None and config.fix_model.correlated_code_errors else 1.0

    def use_noise_scale(self, scale) -> None:
        """Scale the GNSS rows by `scale` from now on (a bank's hypothesis:
        `railnav.filters.bank_noise_scale.BankNoiseScale.member`)."""
        self.noise_scale = scale

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
        inflated for correlated errors (and the rows at ``s + σ_e b`` with the code-bias
        state), range-rate covariance for the velocity's angle to the track
        (`heading_covariance_mps2`), then (with `huber_k`) Huber-weighted; with fixes,
        the fix rows too, and the rows the fault screen lets through."""
        g, f = (index, -1) if self.schedule is None else self.schedule.split(index)
        self.noise_scale.begin_epoch()
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
        and stood 8 m behind, horizontal max 9.1 m against SPP's 8.8). With the code-bias
        state their position rows are at ``s + σ_e b`` (`railnav.filters.code_bias`).
        Carrier (RTK) fixes keep their variances."""
        obs, sv, kind = self.fix_rows.observations(index, x)
        if not self.config.fix_model.correlated_code_errors or \
                str(self.fix_rows.fixes.quality[index]) not in CODE_FIX_QUALITIES:
            return obs, sv, kind
        if self.code_bias:              # the position rows at s + σ_e b, σ_e = k σ_along
            pos = obs[0]
            scale = self.config.code_bias.sigma * math.sqrt(float(pos.R[0]))
            obs = [replace(pos, model=cb.code_bias_fix_position(self.layout),
                           p=np.column_stack([pos.p, np.full(pos.p.shape[0], scale)]))] + \
                obs[1:]
        factor = self.inflation_at(float(x[self.layout.index("v")]))
        if factor != 1.0:
            obs = [replace(o, R=o.R * factor) for o in obs]
        return obs, sv, kind

    def inflation_at(self, speed_mps: float) -> float:
        """The pseudorange variance factor at the prior's speed
        (`railnav.filters.gnss_only_noise.pseudorange_inflation`)."""
        return pseudorange_inflation(self.config, speed_mps, self.gnss_interval_s)

    def _gnss_rows(self, index: int, x: Array, P: Array) -> list[Observation]:
        speed = float(x[self.layout.index("v")])
        factor = self.inflation_at(speed)
        scale = self.noise_scale.variance_factor
        models = self.rows.rows
        rows, own = [], []
        for obs in self.rows.observations(index, x):
            kind = ROW_KINDS[0] if obs.model is models.pseudorange else ROW_KINDS[1]
            own.append((kind, obs.R, scale[kind] * (factor if kind == ROW_KINDS[0] else 1.0)))
            if scale[kind] != 1.0:
                obs = replace(obs, R=obs.R * scale[kind])
            if kind == ROW_KINDS[0]:
                if self._bias_rows is not None:
                    obs = self._biased_pseudoranges(obs, x)
                if factor != 1.0:
                    obs = replace(obs, R=obs.R * factor)
            else:
                obs = self._heading_rows(obs, x, P, speed)
            rows.append(obs)
        if self.noise_scale.feeding:
            self.noise_scale.add(_scale_rows(rows, own, x, P))
        if self.huber_k is None:
            return rows
        diagonal = [o for o in rows if o.R.ndim == 1]       # not the range-rate covariance
        weighted, n = huber_inflate(diagonal, x, P, k=self.huber_k)
        self.n_inflated += n
        return weighted + [o for o in rows if o.R.ndim != 1]

    def _biased_pseudoranges(self, obs: Observation, x: Array) -> Observation:
        """The pseudorange rows at ``s + σ_e b`` (`railnav.filters.code_bias`): σ_e = k σ_1,
        σ_1 the along-track σ of these rows solved alone with their white variances (0
        where they cannot be: fewer rows than unknowns)."""
        _, H = obs.model.evaluate(x, obs.p)
        variance = cb.snapshot_variance_s(H, obs.R, self.layout.index("s"),
                                          self._clock_columns)
        scale = self.config.code_bias.sigma * math.sqrt(variance) \
            if math.isfinite(variance) else 0.0
        return replace(obs, model=self._bias_rows.pseudorange, p=cb.with_scale(obs.p, scale))

    def _heading_rows(self, obs: Observation, x: Array, P: Array, speed: float
                      ) -> Observation:
        """Range-rate rows with the velocity's angle to the track (`heading_covariance_mps2`,
        `heading_sigma_rad`; `heading_inflation` for an angle that lasts a distance): the
        covariance, or only its diagonal where the fault screen tests the rows one by one
        (it takes diagonal ``R``); with the code-bias state, the rows of its model at
        σ_e = 0."""
        cfg = self.config
        if cfg.track_heading_sigma_rad > 0.0 and speed != 0.0:
            sigma = heading_sigma_rad(obs.p, cfg.track_heading_sigma_rad,
                                      cfg.track_heading_curvature_m)
            if cfg.track_heading_huber_k is not None:
                z_pred, H = obs.model.evaluate(x, obs.p)
                sigma = robust_heading_sigma_rad(obs.z.reshape(-1) - z_pred, H, P, obs.R,
                                                 obs.p, speed, sigma,
                                                 cfg.track_heading_huber_k)
            cov = heading_covariance_mps2(obs.p, speed, sigma) * heading_inflation(
                cfg.pseudorange_correlation_s, cfg.track_heading_correlation_m, speed,
                self.gnss_interval_s)
            obs = replace(obs, R=obs.R + cov.diagonal() if self.screen is not None
                          else np.diag(obs.R) + cov)
        if self._bias_rows is not None:
            obs = replace(obs, model=self._bias_rows.range_rate, p=cb.with_scale(obs.p, 0.0))
        return obs

    def initial_covariance(self, *, sigma_s_m: float, sigma_v_mps: float) -> Array:
        """Diagonal initial covariance in the layout's order (config's clock and ISB σ;
        the code-bias state's stationary variance, 1)."""
        cfg = self.config
        var = {"s": sigma_s_m ** 2, "v": sigma_v_mps ** 2,
               "clock_bias": cfg.initial_clock_bias_sigma_m ** 2,
               "clock_drift": cfg.initial_clock_drift_sigma_mps ** 2,
               SCALE_STATE: cfg.odometer_model.scale_sigma ** 2, CODE_BIAS_STATE: 1.0}
        return np.diag([var.get(name, cfg.initial_isb_sigma_m ** 2)
                        for name in self.layout.names])

    def initial_from_fix(self, fix, *, restart: bool = False) -> tuple[Array, Array]:
        """State and covariance at a GNSS fix (`railnav.navigation.initialization.GnssFix`): the fix
        projected on the track, the speed its velocity along the tangent
        (`railnav.filters.common.start_on_track`); with the code-bias state, the fix's
        along-track variance with its slow part (`railnav.filters.code_bias.start_variance_m2`);
        `restart`: the fix's own σ (`start_on_track`)."""
        values, sigma_s, sigma_v = start_on_track(self.track, self.config, fix,
                                                  self.isb_names, restart=restart)
        x0 = np.array([values.get(name, 0.0) for name in self.layout.names])
        if self.code_bias:
            sigma_s = math.sqrt(sigma_s ** 2 + cb.start_variance_m2(sigma_s,
                                                                     self.config.code_bias))
        return x0, self.initial_covariance(sigma_s_m=sigma_s, sigma_v_mps=sigma_v)

    def truth_states(self, truth, clock_bias_m: Array, clock_drift_mps: Array
                     ) -> tuple[Array, npt.NDArray[np.bool_]]:
        """True states at the truth's samples (``truth.s``, ``truth.v``, the clock); every
        component is known (the simulator has one receiver clock: inter-system biases 0)
        but an odometer's scale factor and the code-bias state.

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
        return x, np.array([name not in (SCALE_STATE, CODE_BIAS_STATE)
                            for name in self.layout.names])

    def estimates(self, x: Array, P_packed: Array) -> dict[str, Array]:
        """Estimate columns (`railnav.navigation.result`) of stored states."""
        var = np.diagonal(unpack_sym(P_packed), axis1=1, axis2=2)
        return track_estimates(self.track, self.layout, x, var)


def _scale_rows(rows: list[Observation], own: list, x: Array, P: Array) -> dict:
    """``{kind: (ν, a, b)}`` of an epoch's GNSS rows for `NoiseScale.add`: innovations at
    the prior, their variance but the rows' own (``a``: ``H P Hᵀ`` and the update
    variance less the scaled own), the own variances ``b``; `own` is ``(kind, b, factor
    on b in the update)`` of each observation of `rows`."""
    parts: dict[str, list] = {}
    for obs, (kind, b, applied) in zip(rows, own):
        z_pred, H = obs.model.evaluate(x, obs.p)
        R = obs.R if obs.R.ndim == 1 else np.diagonal(obs.R)
        a = np.einsum("ij,jk,ik->i", H, P, H) + R - applied * b
        parts.setdefault(kind, []).append((obs.z.reshape(-1) - z_pred, a, b))
    return {kind: tuple(np.concatenate(c) for c in zip(*found))
            for kind, found in parts.items()}
