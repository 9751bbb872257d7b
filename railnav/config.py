"""Configuration of the navigator.

`NavigatorConfig` says which filter runs and what it assumes (IMU grade, clock, GNSS
measurement model, gating, output rate, initial uncertainty). The sensor data it consumes
and their time reference are `railnav.sensor_data.SensorData`'s.

This module owns `NavigatorConfig`'s field defaults; the defaults a command-line flag
shows, `DEFAULT_FILTER`, `DEFAULT_IMU_GRADE` and `DEFAULT_SYSTEMS`, are written once in
`railnav.defaults` (a module that imports nothing, so the parser stays light) and
re-exported here. The defaults of a simulated trip (speed profile, GNSS σ, start time)
are its scenario's (`railnav.simulation.scenarios`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from gnss_obs.errors import GnssError
from gnss_obs.measurements import MeasurementConfig
from gnss_obs.oscillator import oscillator_from_name
from railnav.defaults import DEFAULT_FILTER, DEFAULT_IMU_GRADE, DEFAULT_SYSTEMS
from railnav.errors import ConfigError
from railnav.filters.balise_epochs import BaliseModelConfig
from railnav.filters.code_bias import CodeBiasConfig
from railnav.filters.fault_config import FaultDetectionConfig
from railnav.filters.fix_epochs import FixModelConfig
from railnav.filters.noise_scale import NoiseScaleConfig
from railnav.filters.attitude_config import TrackAttitudeConfig
from railnav.filters.odometer_epochs import OdometerConfig
from railnav.filters.protocol import FILTER_KINDS, filter_kind
from railnav.filters.track_frame import LeverArms
from railnav.navigation.monitor_config import MonitorConfig
from railnav.filters.standstill import StandstillConfig
from strapdown.errors import StrapdownError
from strapdown.imu_errors import ImuErrors, imu_grade

__all__ = ["NavigatorConfig", "FILTER_KINDS", "DEFAULT_FILTER", "DEFAULT_IMU_GRADE",
           "DEFAULT_SYSTEMS"]


@dataclass(frozen=True)
class NavigatorConfig:
    """What the navigator runs and assumes.

    Parameters
    ----------
    filter : str
        A filter kind of `railnav.filters.protocol.FILTERS`: ``constrained`` (the
        track-constrained INS/GNSS filter), ``unconstrained`` (the 9-state INS/GNSS
        baseline) or ``gnss-only`` (track-constrained, no IMU).
    imu_errors : str or ImuErrors
        IMU grade the filter assumes (`strapdown.imu_errors.IMU_GRADES`).
    estimate_imu_biases : bool or None
        Augment the state with accelerometer and gyro biases; None: when the IMU grade
        has biases (anything but ``perfect`` and ``paper2017``).
    oscillator : str
        Receiver clock model (`gnss_obs.oscillator.OSCILLATORS`).
    measurement : gnss_obs.MeasurementConfig
        GNSS systems, corrections and measurement σ model.
    elevation_mask_deg : float
        Satellites lower than this are not used, deg.
    use_doppler : bool
        Update with range rates (Doppler) as well as pseudoranges.
    gate_probability : float or None
        Per-row χ² gate of the GNSS updates (probability of accepting a correct row);
        None: no gate.
    output_rate_hz : float
        Rate of the stored estimates, Hz (the filter itself runs at the IMU rate).
    initial_attitude_sigma_rad : float
        1σ of the initial attitude about the track's, rad.
    track_grade_sigma_rad : float or None
        1σ of the grade the track does not know, rad (`railnav.filters.grade_noise`: the
        start's pitch variance and the pseudo-observation's normal row carry it). None
        (default): the track's own, 0 on a track with heights; a run of recorded files on
        a network without heights (`trackmodel.network.Network.heights` False, fitted at
        h = 0) takes `railnav.filters.grade_noise.UNKNOWN_GRADE_SIGMA_RAD`
        (`railnav.jobs.network.run_files_network`). 0: the heights are known.
    initial_s_sigma_m, initial_v_sigma_mps : float or None
        1σ of the initial distance (m) and speed (m/s); None: from the first GNSS fix.
    initial_clock_bias_sigma_m, initial_clock_drift_sigma_mps : float
        1σ of the initial receiver clock, m and m/s.
    initial_isb_sigma_m : float
        1σ of the initial inter-system biases, m.
    along_accel_sigma_mps2 : float
        GNSS-only filter: along-track acceleration taken as white noise, 1σ per √s
        (spectral density ``σ²``, (m/s²)²·s). Default 1 m/s²: of the order of the largest
        service accelerations and braking of trams and urban trains (~1–1.3 m/s²), the
        white-noise-acceleration rule ``√(q T) ≈ a_max`` at T = 1 s (Bar-Shalom et al.,
        *Estimation with Applications to Tracking and Navigation*, §6.2.2).
    pseudorange_correlation_s : float
        GNSS-only and constrained (inertial) filters: correlation time of the pseudorange
        errors (code multipath, residual atmosphere), s. Treated as white, errors correlated
        from epoch to epoch make the filter average them as if independent; the pseudorange
        variances are inflated by ``(1 + ρ)/(1 − ρ)``, ``ρ = exp(−Δt/τ)`` (Δt the epoch
        interval; `railnav.filters.gnss_only_noise.pseudorange_inflation`): the variance of
        the mean of a long first-order Gauss–Markov sequence relative to white samples.
        0: white (simulated data). Default 20 s: urban code multipath at tram speeds
        (railnav.filters.gnss_only). The inertial filter inflates its pseudoranges alike
        (`railnav.filters.constrained`). Simulated multipath (``benchmarks/
        bench_consistency.py --multipath-sigma``, ``curvy_tactical``, σ_mp 1 / 2 m/sin(el),
        τ 60 s, on σ_pr 3 m, 10 seeds): told nothing, its NEES was 15.1 / 25.0 (99 % band
        [4.33, 10.42]) with 12.0 / 24.2 % of the epochs beyond 3σ_s; told the rows' variance,
        12.9 / 18.0 and 7.7 / 16.1 %; told τ as well (``_m`` 0), 5.72 / 5.80 and 0 / 0 %,
        along-track RMS 2.05 / 2.35 m against 1.74 / 3.19 m told nothing (white errors:
        0.69 m). Its fault screen then tests the inflated rows: a fault must be ``√factor``
        times larger to be rejected (×11 at τ 60 s, 1 Hz; a 30-m code step on one
        satellite was used in 78 of 100 epochs, 0 told the variance only, and moved ``s``
        by up to 4 m, inside 2σ_s), and its monitor takes its fixes as correlated with it
        (`railnav.navigation.monitor`). With
        ``fix_model.correlated_code_errors`` the gnss-only filter inflates the rows of code
        fixes (single-point, DGPS) alike; carrier (RTK) fixes keep their σ.
    pseudorange_correlation_m : float
        GNSS-only and constrained filters: distance over which the pseudorange errors
        decorrelate as the antenna moves (code multipath depends on where the antenna is
        among the reflectors), m. The correlation time used at each epoch is
        ``min(pseudorange_correlation_s, pseudorange_correlation_m / |v|)`` at the prior's
        speed (`railnav.filters.gnss_only_noise.correlation_time_s`): standing, the errors
        repeat and the full τ holds; moving, they decorrelate and the filter may follow
        its pseudoranges sooner. 0: the time alone. Default 20 m: on every piece of the
        urban drive (``benchmarks/results/real_pieces.json``) the horizontal RMS is then
        below the single-point RMS (with τ alone, 2 of 9 pieces were above it); 5 m did as
        well on the pieces but worse on the first leg. The atmosphere's residual,
        correlated over minutes whatever the speed, is not in this model.
    track_heading_sigma_rad : float
        GNSS-only filter: 1σ of the angle between the antenna's velocity and the track's
        tangent at ``s``, rad (the track's heading error, the vehicle's motion across
        and along the normal of the track: a car that does not follow the fitted line, a
        tram body's yaw). One angle per epoch, common to its range-rate rows: they get the
        covariance ``(σ_ψ v)² c cᵀ``, ``c_i = e_i·n``, ``n`` the track's horizontal normal
        (`railnav.filters.gnss_only_noise.heading_covariance_mps2`; only the variances,
        ``(σ_ψ v)² (e·n)²``, when the fault screen tests the rows). Without it a heading
        mismatch reads as a Doppler error the filter explains by moving ``s`` along the
        curvature, ``δs ≈ δψ/κ``: metres at κ = 1e-3 /m. 0: the velocity is ``v t(s)``
        exactly (simulated trips). Default 0.03 rad: the RMS angle between the urban
        drive's reference velocity and its fitted tracks' tangents on the pieces with
        no corner tighter than the fit follows is 0.03-0.05 rad (0.12-0.27 rad on the
        pieces with one; ``benchmarks/bench_real_pieces.py``); the Doppler rows' weight
        on ``s`` through the curvature is real where the track's heading is right, and
        0.04 rad already cost the 3-minute excerpt (issue 7's test: GPS+Galileo RMS
        0.504 of SPP's against 0.5; 0.03 rad: 0.488, GPS 0.423, none 0.470 and 0.386).
    track_heading_curvature_m : float
        GNSS-only filter: how far along the track (1σ, m) the vehicle's turning may lead or
        lag the track's where it curves: σ_ψ² + (κ d)² replaces σ_ψ² (κ the track's
        curvature at ``s``; with ``track_heading_sigma_rad`` > 0 only). 0: off (default).
        Measured on the urban drive's first 3 minutes (``benchmarks/bench_code_bias.py``),
        d = 2.2 m (the held-out pieces: 1.3 m). With it the gnss-only filter's epochs beyond
        3σ_s on the held-out pieces fall from 20 to 6 of 388, but on the calibration pieces
        they rise from 3 to 25 of 170 (leg 1 part 3 follows its biased rows, 4.4 m RMS) and
        the first leg's horizontal RMS from 1.68 / 1.87 to 2.07 / 1.97 m (GPS / GPS+Galileo,
        ``benchmarks/bench_real_data.py``): the Doppler rows' information on ``s`` in the
        corners is worth more there than its overconfidence costs
        (``benchmarks/results/real_pieces_heading_curvature.json``).
    track_heading_correlation_m : float
        GNSS-only filter: distance over which the velocity's angle to the track decorrelates
        as the vehicle moves, m (the track's heading error and the vehicle's path across
        the street are functions of place, not of time): the range-rate rows' heading
        covariance is inflated by ``(1 + ρ)/(1 − ρ)``, ``ρ = exp(−Δt/τ_ψ)``,
        ``τ_ψ = min(pseudorange_correlation_s, d / |v|)``
        (`railnav.filters.gnss_only_noise.heading_inflation`), as the pseudoranges are for
        theirs. Taken as one independent angle per epoch, a heading error that lasts for
        metres is averaged over epochs, and the Doppler rows' information on ``s`` through
        the curvature (``δs ≈ δψ/κ``) brings σ_s below the error. 0: off (default).
        Measured on the urban drive (``benchmarks/bench_real_pieces.py
        --heading-correlation-m``; epochs beyond 3σ_s of the gnss-only filter,
        calibration / held-out / leg 1, against 3 / 20 / 30 off): d = 3 m 0 / 16 / 26,
        5 m 0 / 11 / 25, 7 m 0 / 8 / 24, 10 m 25 / 0 / 24 (leg 1 part 3 then follows its
        biased rows, 4.40 m RMS against single-point 4.14 m). It is off because the
        Doppler rows' weight is worth more on the first three minutes than its
        overconfidence costs: at 5 m the excerpt's horizontal RMS
        (``tests/railnav/jobs/test_real_data.py``, the track ``data/tracks/
        barcelona_drive.csv``) rises to 0.56 / 0.51 of single-point's (GPS / GPS+Galileo;
        issue 7's target 0.5).
    track_heading_huber_k : float or None
        GNSS-only filter: Huber threshold on each epoch's heading angle (k σ; None: off;
        `railnav.filters.gnss_only_noise.robust_heading_sigma_rad`, with its figures).
    code_bias : railnav.filters.code_bias.CodeBiasConfig
        GNSS-only filter: the slow part of the code errors, an along-track bias state shared
        by each epoch's position rows (`railnav.filters.code_bias`); with
        ``pseudorange_correlation_s`` > 0 only (white errors have no slow part).
    fault_detection : railnav.filters.fault_config.FaultDetectionConfig or None
        Constrained filter: satellite fault detection and exclusion at each GNSS epoch's
        prior (per-row fault hypothesis, channel exclusion and re-admission, receiver
        clock jumps; `railnav.filters.fault_detection`); None: every row goes to the update (and
        its χ² gate). With GNSS position fixes (both track filters), also the fixes'
        screen (each fix's rows tested at the prior, used together or not at all).
    noise_scale : railnav.filters.noise_scale.NoiseScaleConfig or None
        GNSS-only and constrained filters: a factor ``k >= 1`` on the σ of each GNSS row
        kind (pseudorange, range rate), raised from the filter's innovations only when
        the sign test finds them significantly larger than the σ say
        (`railnav.filters.noise_scale`); None: off. Default on: with the σ right it stays
        1 and the run is the same to the bit.
    fix_model : railnav.filters.fix_epochs.FixModelConfig
        What the GNSS fix rows assume beyond each fix's σ (track centre-line σ, heights,
        speed; `railnav.filters.fix_rows`).
    odometer_model : railnav.filters.odometer_epochs.OdometerConfig
        What the odometer rows assume (noise, scale-factor state, standstill;
        `railnav.filters.odometer_rows`), with odometer readings.
    balise_model : railnav.filters.balise_epochs.BaliseModelConfig
        What the balise rows assume (`railnav.filters.balise_rows`), with balise passages.
    lever_arms : railnav.filters.track_frame.LeverArms
        Antenna, IMU and balise-reader offsets from the reference point (default none;
        the constrained and GNSS-only filters).
    monitor : railnav.navigation.monitor_config.MonitorConfig
        The divergence monitor of track-based filters (status per epoch, recovery when
        lost; default on).
    track_attitude : railnav.filters.attitude_config.TrackAttitudeConfig or None
        Constrained filter: the attitude of the body against the track as rows, with the
        IMU's mounting as states (`railnav.filters.attitude_rows`); None (default): off.
    standstill : railnav.filters.standstill.StandstillConfig or None
        Constrained filter: detect standstills from the IMU (vetoed by the odometer and the
        fixes' speed) and apply zero-speed and zero-yaw-rate rows
        (`railnav.filters.standstill_rows`); None (default): off.
    suspension_noise : bool
        Constrained filter: the IMU rides a car body on its suspension (a train), whose
        sampled angular rates leave an attitude error the gyros do not report; give it as
        gyro noise (`railnav.filters.suspension_noise`, with ``track_attitude``'s suspension
        parameters, else `TrackAttitudeConfig`'s defaults). Implied by ``track_attitude``.
        Default False (an IMU on a rigid vehicle; `navigator_config_for` sets it for a
        scenario with a car body). Without it a tactical filter on a car body is
        overconfident (median NEES 32.7 for 7 states over a 300-s outage,
        ``benchmarks/bench_track_attitude.py``).
    one_sided : bool
        Constrained filter: near the onset of a curve with a large σ_s, bound what the
        curvature pseudo-observation tells ``s`` by the prior truncated at the onset
        (`railnav.filters.one_sided`). Default True: it acts only when σ_s exceeds 2 m
        within 4σ_s of an onset (long outages), where it stops the σ collapse of
        ``outage_20min``; where it does not act, runs are bit-identical to it off. The
        network navigator runs its hypotheses without it (its Gaussian sum carries a
        multimodal ``s``).
    rts_smoothing : bool
        Keep every filter step's moments and transition for the Rauch–Tung–Striebel
        smoother (`railnav.navigation.smoothing.smooth_result`); costs
        ``8 (2 n² + 3 n)`` bytes per step (≈ 1.5 kB at n = 13: 150 MB for 1000 s at
        100 Hz).
    """

    filter: str = DEFAULT_FILTER
    imu_errors: str | ImuErrors = DEFAULT_IMU_GRADE
    estimate_imu_biases: bool | None = None
    oscillator: str = "tcxo"
    measurement: MeasurementConfig = field(default_factory=lambda: MeasurementConfig(systems=DEFAULT_SYSTEMS))
    elevation_mask_deg: float = 10.0
    use_doppler: bool = True
    gate_probability: float | None = 0.9999
    output_rate_hz: float = 10.0
    initial_attitude_sigma_rad: float = 1e-3
    track_grade_sigma_rad: float | None = None
    initial_s_sigma_m: float | None = None
    initial_v_sigma_mps: float | None = None
    initial_clock_bias_sigma_m: float = 30.0
    initial_clock_drift_sigma_mps: float = 1.0
    initial_isb_sigma_m: float = 30.0
    along_accel_sigma_mps2: float = 1.0
    pseudorange_correlation_s: float = 20.0
    pseudorange_correlation_m: float = 20.0
    track_heading_sigma_rad: float = 0.03
    track_heading_curvature_m: float = 0.0
    track_heading_correlation_m: float = 0.0
    track_heading_huber_k: float | None = 4.0
    code_bias: CodeBiasConfig = CodeBiasConfig()
    fault_detection: FaultDetectionConfig | None = FaultDetectionConfig()
    noise_scale: NoiseScaleConfig | None = NoiseScaleConfig()
    fix_model: FixModelConfig = FixModelConfig()
    rts_smoothing: bool = False
    _imu: ImuErrors = field(init=False, repr=False, compare=False)
    odometer_model: OdometerConfig = OdometerConfig()
    balise_model: BaliseModelConfig = BaliseModelConfig()
    lever_arms: LeverArms = LeverArms()
    monitor: MonitorConfig = MonitorConfig()
    track_attitude: TrackAttitudeConfig | None = None
    standstill: StandstillConfig | None = None
    suspension_noise: bool = False
    one_sided: bool = True

    def __post_init__(self) -> None:
        filter_kind(self.filter)
        try:
            object.__setattr__(self, "_imu", imu_grade(self.imu_errors))   # resolved once
            oscillator_from_name(self.oscillator)
        except (StrapdownError, GnssError) as exc:
            raise ConfigError(str(exc)) from None
        if not (-90.0 <= self.elevation_mask_deg < 90.0):
            raise ConfigError(f"elevation_mask_deg must be in [-90, 90), got "
                              f"{self.elevation_mask_deg!r}")
        if self.gate_probability is not None and not 0.0 < self.gate_probability < 1.0:
            raise ConfigError(f"gate_probability must be in (0, 1) or None, got "
                              f"{self.gate_probability!r}")
        positive = ["output_rate_hz", "initial_attitude_sigma_rad", "initial_clock_bias_sigma_m",
                    "initial_clock_drift_sigma_mps", "initial_isb_sigma_m",
                    "along_accel_sigma_mps2"]
        positive += [n for n in ("initial_s_sigma_m", "initial_v_sigma_mps")
                     if getattr(self, n) is not None]
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be a finite number > 0, got {value!r}")
        grade = self.track_grade_sigma_rad
        if grade is not None and not (isinstance(grade, (int, float)) and
                                      math.isfinite(grade) and grade >= 0):
            raise ConfigError(f"track_grade_sigma_rad must be a finite number >= 0 or None, "
                              f"got {grade!r}")
        if not (self.fault_detection is None
                or isinstance(self.fault_detection, FaultDetectionConfig)):
            raise ConfigError(f"fault_detection must be a FaultDetectionConfig or None, got "
                              f"{self.fault_detection!r}")
        for name in ("rts_smoothing", "suspension_noise"):
            if not isinstance(getattr(self, name), bool):
                raise ConfigError(f"{name} must be True or False, got {getattr(self, name)!r}")
        for name, cls in (("track_attitude", TrackAttitudeConfig),
                          ("standstill", StandstillConfig), ("noise_scale", NoiseScaleConfig)):
            if not (getattr(self, name) is None or isinstance(getattr(self, name), cls)):
                raise ConfigError(f"{name} must be a {cls.__name__} or None, got "
                                  f"{getattr(self, name)!r}")
        for name, cls in (("fix_model", FixModelConfig), ("code_bias", CodeBiasConfig),
                          ("odometer_model", OdometerConfig),
                          ("balise_model", BaliseModelConfig), ("lever_arms", LeverArms)):
            if not isinstance(getattr(self, name), cls):
                raise ConfigError(f"{name} must be a {cls.__name__}, got "
                                  f"{getattr(self, name)!r}")
        for name in ("pseudorange_correlation_s", "pseudorange_correlation_m",
                     "track_heading_sigma_rad", "track_heading_curvature_m",
                     "track_heading_correlation_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ConfigError(f"{name} must be a finite number >= 0, got {value!r}")
        k = self.track_heading_huber_k
        if k is not None and not (isinstance(k, (int, float)) and math.isfinite(k) and k > 0):
            raise ConfigError(f"track_heading_huber_k must be None or a finite number > 0, "
                              f"got {k!r}")

    @property
    def grade_sigma_rad(self) -> float:
        """`track_grade_sigma_rad`, 0 for None (the track's heights known), rad."""
        return float(self.track_grade_sigma_rad or 0.0)

    @property
    def imu(self) -> ImuErrors:
        """The IMU error parameters the filter assumes (the grade resolved once)."""
        return self._imu

    @property
    def biases_estimated(self) -> bool:
        """Whether the state carries IMU biases."""
        if self.estimate_imu_biases is not None:
            return bool(self.estimate_imu_biases)
        imu = self.imu
        return any(getattr(imu, name) > 0 for name in (
            "accel_bias_mps2", "gyro_bias_radps", "accel_bias_instability_mps2",
            "gyro_bias_instability_radps"))
