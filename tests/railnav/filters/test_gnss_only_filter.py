"""GNSS-only track-constrained filter: process model vs closed form, correlated-error
inflation vs the AR(1) variance of the mean, Huber weights, simulated trips (NEES over
seeds, a station stop, a reversal with a hand-made truth), leaving the track's end."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import block_diag

from ekf.cd_filter import CdFilter
from ekf.consistency import chi2_band
from ekf.model import MeasurementModel
from ekf.series import InputSeries
from ekf.update import Observation
from gnss_obs.oscillator import oscillator_from_name, process_noise
from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.simulate import GnssSimConfig, default_nav_path, simulate_gnss
from railnav.config import NavigatorConfig
from railnav.filters.constrained_model import ISB_RANDOM_WALK_M2PS
from railnav.filters.gnss_only import GnssOnlyFilter
from railnav.filters.code_bias import CodeBiasConfig
from railnav.filters.gnss_only_noise import (
    correlation_inflation,
    correlation_time_s,
    heading_inflation,
)
from railnav.filters.gnss_only_model import build_gnss_only_model
from railnav.filters.robust_rows import huber_inflate, huber_variance_scale
from railnav.jobs.run import run_simulated
from railnav.navigation.initialization import InitialState
from railnav.navigation.loop import END_MARGIN_SIGMA
from railnav.navigation.navigator import navigate
from railnav.sensor_data import SensorData
from railnav.simulation.profiles import constant_speed, station_stop_profile
from railnav.simulation.scenarios import DEFAULT_START_GPS_TIME_S, TRACKS_DIR, Scenario
from railnav.simulation.trip import navigator_config_for
from trackmodel.earth import C_n_e
from trackmodel.io import read_track
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

#: Rounding of the propagated mean and covariance, relative to the largest entry.
RTOL_ROUNDING = 1e-10
#: The AR(1) variance-of-the-mean factor at n = 1e5 samples differs from its limit by
#: 2ρ/(n(1−ρ)²)·(1−ρⁿ) relative, < 3e-4 for τ ≤ 20 Δt.
RTOL_AR1_LIMIT = 1e-3
#: Along-track and speed errors stay within this many σ at every stored sample of a run
#: (~1500 correlated samples: 4.5σ has a 7e-6 two-sided tail per sample).
MAX_SIGMAS = 4.5
SEEDS = range(8)
#: The track's curvature against the rows' |dt_e/ds| (with the frame's rotation), relative.
RTOL_FRAME_CURVATURE = 1e-3
NEES_TIME_S = 140.0          # one time per run (runs are independent, samples are not)
STRAIGHT = TRACKS_DIR / "east_west.csv"   # its first 10 km are a straight due east


def _config(**overrides) -> NavigatorConfig:
    """What the simulator does: constant σ, white errors, a TCXO."""
    sc = Scenario(name="t", profile=constant_speed(10.0), duration_s=10.0,
                  sigma_pseudorange_m=3.0, sigma_range_rate_mps=0.1)
    return navigator_config_for(sc, filter="gnss-only", **overrides)


# -- process model ---------------------------------------------------------------------------
def test_layout_names_follow_the_systems():
    assert build_gnss_only_model(()).layout.names == ("s", "v", "clock_bias", "clock_drift")
    assert build_gnss_only_model(("E", "C")).layout.names[-2:] == ("isb_E", "isb_C")


def test_propagation_matches_closed_form_discretization(rng):
    """Mean and covariance over 1 s (10 steps) against Φ P Φᵀ + Q written out: the
    constant-velocity Q of white acceleration (Bar-Shalom §6.2.2), the oscillator's Q
    (`gnss_obs.oscillator.process_noise`) and the ISB random walk."""
    model = build_gnss_only_model(("E",))
    sigma_a, dt, steps = 0.7, 0.1, 10
    osc = oscillator_from_name("tcxo")
    q_c = model.process_noise_density(along_accel_sigma_mps2=sigma_a, oscillator=osc)
    A = rng.standard_normal((5, 5))
    P0 = A @ A.T + np.eye(5)
    x0 = np.array([12.0, -3.0, 150.0, 0.4, 2.0])
    filt = CdFilter(model.process)
    filt.reset(x0, P0)
    t = np.arange(steps + 1) * dt
    filt.propagate(InputSeries(t=t, u=np.zeros((t.size, 0)), q_c=q_c))
    T = t[-1]
    F2 = np.array([[1.0, T], [0.0, 1.0]])
    Phi = block_diag(F2, F2, [[1.0]])
    Q = block_diag(sigma_a ** 2 * np.array([[T ** 3 / 3, T ** 2 / 2], [T ** 2 / 2, T]]),
                   process_noise(osc, T), [[ISB_RANDOM_WALK_M2PS * T]])
    P_expected = Phi @ P0 @ Phi.T + Q
    # The engine's step takes the noise over a step at its midpoint: on a variance term
    # ∫ q (T − τ)² dτ that quadrature errs by q T dt²/12 (the midpoint rule's bound with
    # f'' = 2q); the linear and constant terms are exact.
    quadrature = max(q_c[0], q_c[2]) * T * dt ** 2 / 12.0
    np.testing.assert_allclose(filt.x, Phi @ x0, rtol=0, atol=RTOL_ROUNDING * 150.0)
    np.testing.assert_allclose(filt.P, P_expected, rtol=0,
                               atol=quadrature + RTOL_ROUNDING * np.abs(P_expected).max())
    np.testing.assert_allclose(filt.P - Phi @ P0 @ Phi.T, Q, rtol=0.01,
                               atol=RTOL_ROUNDING * np.abs(P_expected).max())


# -- correlated errors, robust weights -------------------------------------------------------
@pytest.mark.parametrize("tau_s", [2.0, 20.0])
def test_inflation_is_the_ar1_variance_of_the_mean(tau_s):
    """n·Var(mean)/σ² = 1 + 2 Σ (1 − k/n) ρᵏ for an AR(1) sequence, summed directly."""
    n, dt = 100_000, 1.0
    rho = math.exp(-dt / tau_s)
    k = np.arange(1, n)
    exact = 1.0 + 2.0 * np.sum((1.0 - k / n) * rho ** k)
    assert correlation_inflation(tau_s, dt) == pytest.approx(exact, rel=RTOL_AR1_LIMIT)
    assert correlation_inflation(0.0, dt) == 1.0


@pytest.mark.parametrize("speed_mps", [0.0, 0.5, -1.0, 4.0, 30.0])
def test_moving_inflation_is_the_ar1_variance_of_the_mean_over_distance(speed_mps):
    """Errors that decorrelate over a distance d, sampled every |v| Δt metres, are AR(1)
    in the epoch index with ρ = exp(−|v| Δt / d); standing, ρ = exp(−Δt / τ): the
    factor is the AR(1) sum with the shorter correlation's (the smaller) ρ."""
    n, dt, tau_s, d_m = 100_000, 1.0, 20.0, 20.0
    rho = min(math.exp(-dt / tau_s), math.exp(-abs(speed_mps) * dt / d_m))
    k = np.arange(1, n)
    exact = 1.0 + 2.0 * np.sum((1.0 - k / n) * rho ** k)
    tau = correlation_time_s(tau_s, d_m, speed_mps)
    assert correlation_inflation(tau, dt) == pytest.approx(exact, rel=RTOL_AR1_LIMIT)
    assert correlation_time_s(tau_s, 0.0, speed_mps) == tau_s     # d = 0: the time alone


@pytest.mark.parametrize("speed_mps", [0.0, 0.5, -1.0, 5.0, 30.0])
def test_heading_inflation_is_the_ar1_variance_of_the_mean_over_distance(speed_mps):
    """A heading error that decorrelates over d, sampled every |v| Δt metres: AR(1) in the
    epoch index with ρ = exp(−|v| Δt / d), standing exp(−Δt / τ) (the smaller ρ); the
    factor is the AR(1) sum, and 1 with d = 0 (off) or τ = 0 (white: simulated data)."""
    n, dt, tau_s, d_m = 100_000, 1.0, 20.0, 5.0
    rho = min(math.exp(-dt / tau_s), math.exp(-abs(speed_mps) * dt / d_m))
    k = np.arange(1, n)
    exact = 1.0 + 2.0 * np.sum((1.0 - k / n) * rho ** k)
    assert heading_inflation(tau_s, d_m, speed_mps, dt) == pytest.approx(exact,
                                                                         rel=RTOL_AR1_LIMIT)
    assert heading_inflation(tau_s, 0.0, speed_mps, dt) == 1.0
    assert heading_inflation(0.0, d_m, speed_mps, dt) == 1.0


def test_huber_scale_closed_form():
    r = np.array([0.0, 1.0, -1.5, 3.0, -30.0])
    np.testing.assert_allclose(huber_variance_scale(r, 1.5), [1.0, 1.0, 1.0, 2.0, 20.0])


def test_huber_inflation_of_a_linear_row():
    """z = pᵀx rows: S = pᵀPp + R by hand; outliers get S' = S·r/k, the others keep R."""
    import casadi as ca
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 2)
    model = MeasurementModel.from_expression(x, p, ca.dot(p, x), "dot")
    model = MeasurementModel(model.h, "dot", compiled=False)
    P = np.array([[2.0, 0.5], [0.5, 1.0]])
    x0 = np.array([1.0, -1.0])
    rows = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    R = np.array([1.0, 4.0, 0.5])
    S = np.einsum("ij,jk,ik->i", rows, P, rows) + R
    pred = rows @ x0
    z = pred + np.array([0.5, 10.0, -1.0]) * np.sqrt(S)       # r = 0.5, 10, 1
    (obs,), n = huber_inflate([Observation(model, z[:, None], R, rows)], x0, P, k=1.5)
    assert n == 1
    S_new = S - R + obs.R
    np.testing.assert_allclose(S_new, S * np.array([1.0, 10.0 / 1.5, 1.0]), rtol=1e-12)


# -- simulated trips --------------------------------------------------------------------------
def _scenario(profile, duration_s=150.0) -> Scenario:
    return Scenario(name="gnss_only_test", profile=profile, duration_s=duration_s,
                    imu_rate_hz=10.0, sigma_pseudorange_m=3.0, sigma_range_rate_mps=0.1)


def test_nees_in_chi2_band_over_seeds():
    """Constant speed on a straight; the filter's model is the truth's up to a tiny
    acceleration noise (0.01 m/s²/√s), the clock is simulated with the filter's
    oscillator: the average NEES (4 states) at one time over the seeds is χ²-consistent."""
    track = read_track(STRAIGHT)
    sc = _scenario(constant_speed(15.0))
    cfg = navigator_config_for(sc, filter="gnss-only", along_accel_sigma_mps2=0.01)
    nees = []
    for seed in SEEDS:
        out = run_simulated(track, sc, config=cfg, seed=seed)
        k = int(np.argmin(np.abs(out.errors.time_s - NEES_TIME_S)))
        assert out.errors.nees_dof == 4
        nees.append(out.errors.nees[k])
    low, high = chi2_band(4, len(nees))
    assert low <= np.mean(nees) <= high


def _within_sigmas(out) -> None:
    est, err = out.result.estimates, out.errors
    assert np.all(np.abs(err.along_track_m) <= MAX_SIGMAS * est["sigma_s_m"])
    assert np.all(np.abs(err.speed_mps) <= MAX_SIGMAS * est["sigma_speed_mps"])


def test_station_stop_is_tracked():
    """Brake to v = 0, stand 30 s, leave (raised-cosine accelerations up to 1.5 m/s²):
    with the default acceleration noise every error stays within its σ bound, and the
    speed at the stop is zero within that bound."""
    track = read_track(STRAIGHT)
    sc = _scenario(station_stop_profile(cruise_speed_mps=15.0, accel_time_s=20.0,
                                        brake_time_s=20.0, cruise_before_stop_s=30.0,
                                        dwell_s=30.0, start_dwell_s=5.0))
    out = run_simulated(track, sc, config=navigator_config_for(sc, filter="gnss-only"),
                        seed=3)
    truth_v = np.interp(out.errors.time_s, out.truth.time_s, out.truth.v)
    assert np.any(truth_v == 0.0) and out.result.left_track is None
    _within_sigmas(out)


def _reversal_run(track: Track, duration_s: float, speed_mps: float, seed: int,
                  filter_track: Track | None = None):
    """Hand-made truth (the profiles are for v >= 0): s = s0 + (V T/π) sin(π t/T),
    v = V cos(π t/T): forwards, a stop at T/2, then backwards; GNSS simulated on it
    (on `track`; the filter's track `filter_track`, default the same)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s + 0.5)
    s0 = 200.0
    s = s0 + speed_mps * duration_s / math.pi * np.sin(math.pi * t / duration_s)
    v = speed_mps * np.cos(math.pi * t / duration_s)
    point = track.at(s)
    v_e = v[:, None] * np.einsum("kij,kj->ki", C_n_e(point.lat, point.lon), point.u_n)
    nav = read_rinex_nav(default_nav_path())
    sim = simulate_gnss(DEFAULT_START_GPS_TIME_S + t, point.r_e, v_e, nav,
                        GnssSimConfig(systems="G", sigma_pr_m=3.0, sigma_rr_mps=0.1),
                        rng=rng)
    config = _config()
    data = SensorData(DEFAULT_START_GPS_TIME_S, obs=sim.obs, nav=nav)
    filt = GnssOnlyFilter(track, config)
    P0 = filt.initial_covariance(sigma_s_m=3.0, sigma_v_mps=0.2)
    clock = sim.clock
    x_true0 = np.array([s[0], v[0], clock["clock_bias_m"].iloc[0],
                        clock["clock_drift_mps"].iloc[0]])
    x0 = x_true0 + np.linalg.cholesky(P0) @ rng.standard_normal(4)
    result = navigate(filter_track or track, data, config,
                      initial=InitialState(0.0, x0, P0))
    return result, t, s, v


def test_reversal_is_tracked():
    track = read_track(STRAIGHT)
    result, t, s, v = _reversal_run(track, 120.0, 8.0, seed=5)
    est = result.estimates
    s_true = np.interp(est["time_s"], t, s)
    v_true = np.interp(est["time_s"], t, v)
    assert v_true.min() < -7.0 and result.left_track is None     # it did reverse
    assert np.all(np.abs(est["s_m"] - s_true) <= MAX_SIGMAS * est["sigma_s_m"])
    assert np.all(np.abs(est["speed_mps"] - v_true) <= MAX_SIGMAS * est["sigma_speed_mps"])


def test_a_vehicle_that_turns_round_just_past_the_end_is_not_stopped():
    """A terminus: the truth runs 4 m past the end of the filter's track (a 600 m straight
    cut at 259.7 m; σ_s ~0.7 m), stops and comes back. The filter's state does go beyond
    the end by 3σ_s while moving away by 3σ_v (`beyond_track` alone ended this run at
    17-18 s, seeds 2 and 3; 3 m past: at 19 s; 2 m past: never), yet the run goes on to
    the end of the drive (`TrackEndWatch`), the state's ``s`` within its bound. Its limit:
    6 m past, this run is stopped at 19 s (it moves on by 3σ_s once beyond by 3σ_s)."""
    from railnav.navigation.loop import beyond_track
    origin = Origin(45.0, 7.0, 250.0)
    turn_m = 200.0 + 5.0 * 40.0 / math.pi                    # _reversal_run's s0 + V T/π
    short = Track([Section(turn_m - 4.0, 90.0, 0.3)], origin)
    result, t, s, v = _reversal_run(Track([Section(600.0, 90.0, 0.3)], origin), 40.0, 5.0,
                                    seed=2, filter_track=short)
    filt = GnssOnlyFilter(short, _config())
    from ekf.packing import unpack_sym
    P = [unpack_sym(p) for p in result.P]
    assert any(beyond_track(filt, x, Pk, 0.0) is not None for x, Pk in zip(result.x, P))
    assert result.left_track is None and result.time_s[-1] >= t[-1] - 1.0
    i = result.layout.index("s")
    s_true = np.interp(result.time_s, t, s)
    sigma = np.sqrt([Pk[i, i] for Pk in P])
    assert np.all(np.abs(result.x[:, i] - s_true) <= MAX_SIGMAS * sigma)


def test_run_stops_when_the_vehicle_leaves_the_track_end():
    """The truth runs on a 600 m straight; the filter's track is its first 300 m. The run
    stops after the truth passes 300 m (s beyond the end by 3σ and moving on), not before
    the truth is past the end, and not long after."""
    origin = Origin(45.0, 7.0, 250.0)
    long_track = Track([Section(600.0, 90.0, 0.3)], origin)
    short = Track([Section(300.0, 90.0, 0.3)], origin)
    sc = _scenario(constant_speed(10.0), duration_s=50.0)
    out_long = run_simulated(long_track, sc, config=navigator_config_for(
        sc, filter="gnss-only"), seed=1)
    assert out_long.result.left_track is None
    trip_data = out_long.trip.sensor_data()
    filt = GnssOnlyFilter(short, _config())
    P0 = filt.initial_covariance(sigma_s_m=1.0, sigma_v_mps=0.1)
    x0 = out_long.result.x[0]
    result = navigate(short, trip_data, _config(), initial=InitialState(
        float(out_long.result.time_s[0]), x0, P0))
    left = result.left_track
    assert left is not None and left["end"] == "end"
    truth_s_at_stop = np.interp(left["time_s"], out_long.truth.time_s, out_long.truth.s)
    assert truth_s_at_stop > short.length_m
    assert left["s_m"] > short.length_m + END_MARGIN_SIGMA * left["sigma_s_m"]
    travel_after_end_m = 10.0 * 10.0   # 10 s at 10 m/s: the σ of s is ~1 m
    assert truth_s_at_stop < short.length_m + travel_after_end_m
    assert result.estimates["time_s"].iloc[-1] <= left["time_s"]


# -- the velocity's angle to the track ---------------------------------------------------------
def _rows_at(track, config, s_m: float, speed_mps: float):
    """The filter's GNSS rows of one simulated epoch at ``s``, speed `speed_mps`."""
    from railnav.filters.gnss_epochs import GnssEpochs
    t = np.array([0.0, 1.0])
    point = track.at(np.array([s_m, s_m]))
    v_e = speed_mps * np.einsum("kij,kj->ki", C_n_e(point.lat, point.lon), point.u_n)
    nav = read_rinex_nav(default_nav_path())
    sim = simulate_gnss(DEFAULT_START_GPS_TIME_S + t, point.r_e, v_e, nav,
                        GnssSimConfig(systems="G", sigma_pr_m=3.0, sigma_rr_mps=0.1),
                        rng=np.random.default_rng(0))
    gnss = GnssEpochs.from_files(sim.obs, nav, config.measurement,
                                 start_gps_time_s=DEFAULT_START_GPS_TIME_S, end_s=1.0)
    filt = GnssOnlyFilter(track, config, gnss)
    x = np.zeros(filt.layout.size)
    x[filt.layout.index("s")], x[filt.layout.index("v")] = s_m, speed_mps
    return filt, filt.observations(0, x, np.eye(filt.layout.size)), point


@pytest.mark.parametrize("speed_mps", [12.0, -4.0])
def test_heading_covariance_is_the_range_rate_covariance_of_a_rotated_velocity(speed_mps):
    """Second method: the velocity ``v (t + ψ n)`` (the track frame's tangent and
    horizontal normal from `track_axes_n`, one ψ ~ N(0, σ²) drawn per epoch for all the
    satellites) through the range-rate observable itself; the sample covariance of the
    epoch's ρ̇ against the covariance the filter adds to its range-rate rows (its rows
    with σ_ψ against its rows without). 20000 draws: the entries of a rank-one Gaussian
    covariance have a relative standard error of √(2/n) = 1 % (5 % allowed, and 5 % of
    the largest entry for entries near zero)."""
    from gnss_obs.observables import build_measurement_model
    from railnav.filters.track_frame import track_axes_n
    track = read_track(TRACKS_DIR / "curvy.csv")
    sigma, n = 0.05, 20_000
    filt, rows, point = _rows_at(track, _config(track_heading_sigma_rad=sigma), 900.0,
                                 speed_mps)
    _, rows0, _ = _rows_at(track, _config(track_heading_sigma_rad=0.0), 900.0, speed_mps)
    rr = [o for o in rows if o.model is filt.rows.rows.range_rate][0]
    rr0 = [o for o in rows0 if o.model is filt.rows.rows.range_rate][0]
    added = rr.R - np.diag(rr0.R)
    pr = [o for o in rows if o.model is filt.rows.rows.pseudorange][0]
    pr0 = [o for o in rows0 if o.model is filt.rows.rows.pseudorange][0]
    np.testing.assert_array_equal(pr.R, pr0.R)                 # pseudoranges untouched
    C = C_n_e(float(point.lat[0]), float(point.lon[0]))
    axes = track_axes_n(type(point)(**{f: getattr(point, f)[0]
                                       for f in point.__dataclass_fields__}))
    t_e, n_e = (C @ axes[k] for k in ("along", "left"))
    psi = sigma * np.random.default_rng(1).standard_normal((n, 1))
    v_e = speed_mps * (t_e + psi * n_e)
    f = build_measurement_model().range_rate
    r_e = np.asarray(point.r_e[0], dtype=float)
    sat_pos, sat_vel = rr.p[:, 13:16], rr.p[:, 16:19]
    assert added.shape[0] >= 4 and np.all(added.diagonal() > 0.0)
    rho_dot = np.array([np.asarray(f(np.tile(r_e[:, None], (1, n)), v_e.T, 0.0,
                                     np.tile(sat_pos[i][:, None], (1, n)),
                                     np.tile(sat_vel[i][:, None], (1, n)), 0.0)[0]).ravel()
                        for i in range(added.shape[0])])
    np.testing.assert_allclose(np.cov(rho_dot), added, rtol=0.05,
                               atol=0.05 * np.abs(added).max())


def test_heading_covariance_is_inflated_for_a_correlated_heading():
    """Closed form: with ``track_heading_correlation_m`` d the range-rate rows' heading
    covariance is (1 + ρ)/(1 − ρ) times that without, ρ = exp(−|v| Δt / d) at 12 m/s
    (d / |v| below τ = 20 s), Δt = 1 s; the rows' own variances are kept."""
    track = read_track(TRACKS_DIR / "curvy.csv")
    sigma, d_m, speed, s_m = 0.03, 5.0, 12.0, 9540.0
    base = dict(track_heading_sigma_rad=sigma, pseudorange_correlation_s=20.0,
                code_bias=CodeBiasConfig(sigma=0.0))
    filt, rows, _ = _rows_at(track, _config(**base), s_m, speed)
    _, rows_d, _ = _rows_at(track, _config(**base, track_heading_correlation_m=d_m), s_m,
                            speed)
    _, rows0, _ = _rows_at(track, _config(**{**base, "track_heading_sigma_rad": 0.0}), s_m,
                           speed)
    rr, rr_d, rr0 = ([o for o in r if o.model is filt.rows.rows.range_rate][0]
                     for r in (rows, rows_d, rows0))
    rho = math.exp(-speed * 1.0 / d_m)
    added = rr.R - np.diag(rr0.R)
    assert np.abs(added).max() > 0.0
    np.testing.assert_allclose(rr_d.R - np.diag(rr0.R), (1.0 + rho) / (1.0 - rho) * added,
                               rtol=RTOL_ROUNDING, atol=RTOL_ROUNDING * np.abs(added).max())


def test_heading_sigma_grows_with_the_curvature():
    """Closed form: σ_ψ² + (κ d)², κ the track's curvature at the rows' ``s`` (curvy.csv
    at 9540 m is in an arc of R 600 m): the added covariance scales by that ratio."""
    track = read_track(TRACKS_DIR / "curvy.csv")
    sigma, d_m, s_m = 0.03, 20.0, 9540.0
    kappa = abs(float(track.at(np.array([s_m])).curvature_1pm[0]))
    assert kappa > 1e-3
    filt, rows, _ = _rows_at(track, _config(track_heading_sigma_rad=sigma), s_m, 12.0)
    _, rows_d, _ = _rows_at(track, _config(track_heading_sigma_rad=sigma,
                                           track_heading_curvature_m=d_m), s_m, 12.0)
    _, rows0, _ = _rows_at(track, _config(track_heading_sigma_rad=0.0), s_m, 12.0)
    rr, rr_d, rr0 = ([o for o in r if o.model is filt.rows.rows.range_rate][0]
                     for r in (rows, rows_d, rows0))
    ratio = (sigma ** 2 + (kappa * d_m) ** 2) / sigma ** 2
    # the rows' κ is |dt_e/ds| in ECEF: it also holds the ENU frame's rotation per metre
    # (~1/R_earth = 1.6e-7 /m, 1e-4 of this κ), which the track's curvature leaves out
    np.testing.assert_allclose(rr_d.R - np.diag(rr0.R), ratio * (rr.R - np.diag(rr0.R)),
                               rtol=RTOL_FRAME_CURVATURE)
