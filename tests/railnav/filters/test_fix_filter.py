"""Filters on GNSS position fixes: NEES and NIS consistency on simulated trips whose fixes
are drawn with the σ the filter is told (`railnav.simulation.fixes`, a quality mix), for
the GNSS-only filter on fixes alone ([s, v]) and the constrained INS filter with fixes.

References: the χ² band of the mean of independent NEES / NIS values
(`ekf.consistency.chi2_band`, SciPy's χ² quantiles); the truth from the simulator.
"""
from __future__ import annotations

import numpy as np
import pytest

from ekf.consistency import chi2_band
from railnav.config import NavigatorConfig
from railnav.evaluation.metrics import error_series
from railnav.navigation.initialization import initial_from_truth
from railnav.navigation.navigator import navigate
from railnav.sensor_data import SensorData
from railnav.simulation.fixes import FixSimConfig, trip_fixes
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import TRACKS_DIR, Scenario
from railnav.simulation.trip import navigator_config_for, simulate_trip
from trackmodel.io import read_track

SEEDS = range(16)          # chosen before the run: 16 independent trips
#: One NEES time per run (runs are independent; samples within a run are not).
NEES_TIME_S = 100.0
STRAIGHT = read_track(TRACKS_DIR / "east_west.csv")    # its first 10 km are straight
#: A mix of every class with a σ a receiver would claim (dead reckoning left out: its
#: real errors are drifts, not the white errors simulated here).
MIX = (("rtk_fixed", 0.25), ("rtk_float", 0.25), ("dgps", 0.25), ("single", 0.25))
INITIAL_S_SIGMA_M, INITIAL_V_SIGMA_MPS = 2.0, 0.5
#: The GNSS-only filter's white acceleration, m/s²/√s: negligible (its position variance
#: over 1 s, σ_a²/3 ~ 3e-13 m², is far below the best fix's 1e-3 m²), so that the model is
#: the truth's (constant speed). At 0.01 m/s²/√s the filter is conservative here: NEES of
#: [s, v] ~1.2-1.5 at 20-140 s over 30 seeds, the process noise the truth does not have.
ALONG_ACCEL_MPS2 = 1e-6


def _run(seed: int, config: NavigatorConfig, scenario: Scenario):
    trip = simulate_trip(scenario, track=STRAIGHT, seed=seed, gnss=False)
    fixes = trip_fixes(trip, FixSimConfig(rate_hz=1.0, quality_mix=MIX, segment_s=20.0))
    data = SensorData(scenario.start_gps_time_s, imu=trip.simulation.imu_measured,
                      fixes=fixes)
    if not config.filter.startswith("constrained"):
        data = SensorData(scenario.start_gps_time_s, fixes=fixes)

    def start(filt):
        x_true, known = filt.truth_states(trip.truth, *trip.clock_truth(trip.truth.time_s))
        P0 = filt.initial_covariance(sigma_s_m=INITIAL_S_SIGMA_M,
                                     sigma_v_mps=INITIAL_V_SIGMA_MPS)
        rng = np.random.default_rng(1000 + seed)
        return initial_from_truth(x_true[0], P0, time_s=0.0, rng=rng, drawn=known)

    result = navigate(STRAIGHT, data, config, initial=start)
    errors = error_series(result, trip.truth, STRAIGHT, clock_truth=trip.clock_truth)
    return result, errors


def _check(runs, dof: int) -> None:
    nees, nis = [], []
    for result, errors in runs:
        k = int(np.argmin(np.abs(errors.time_s - NEES_TIME_S)))
        assert errors.nees_dof == dof
        nees.append(errors.nees[k])
        inn = result.innovations
        nis.append(inn.loc[(inn["kind"] == "fix_along") & inn["accepted"], "nis"].to_numpy())
    low, high = chi2_band(dof, len(nees))
    assert low <= np.mean(nees) <= high
    nis = np.concatenate(nis)
    low, high = chi2_band(1, nis.size)
    assert low <= nis.mean() <= high


def test_gnss_only_filter_on_fixes_alone_is_consistent():
    """Constant speed on a straight, the filter's white acceleration negligible
    (`ALONG_ACCEL_MPS2`): NEES of [s, v] at one time over the seeds and the NIS of every
    used along-track row inside their 95 % χ² bands."""
    sc = Scenario(name="fix_test", profile=constant_speed(15.0), duration_s=150.0,
                  imu_rate_hz=10.0)
    config = NavigatorConfig(filter="gnss-only", along_accel_sigma_mps2=ALONG_ACCEL_MPS2)
    runs = [_run(seed, config, sc) for seed in SEEDS]
    assert runs[0][0].layout.names == ("s", "v")
    _check(runs, dof=2)


@pytest.mark.slow
def test_constrained_filter_with_fixes_is_consistent():
    """The INS filter on the simulated IMU (tactical grade, the filter's assumption) with
    fixes instead of pseudoranges: NEES of attitude, s and v (the clock, unobserved
    without pseudoranges, starts at its truth 0 with its drawn error and is known too)."""
    sc = Scenario(name="fix_test", profile=constant_speed(20.0), duration_s=120.0,
                  imu_rate_hz=100.0, initial_s_sigma_m=INITIAL_S_SIGMA_M,
                  initial_v_sigma_mps=INITIAL_V_SIGMA_MPS)
    config = navigator_config_for(sc, filter="constrained")
    runs = [_run(seed, config, sc) for seed in SEEDS]
    _check(runs, dof=runs[0][1].nees_dof)
    assert runs[0][1].nees_dof == 7      # yaw, pitch, roll, s, v, clock bias and drift


@pytest.mark.parametrize("speed_mps", [0.0, 15.0])
def test_code_fixes_get_the_correlated_error_inflation(speed_mps):
    """The gnss-only filter's rows of a code fix (``single``, ``dgps``) with
    ``FixModelConfig.correlated_code_errors`` and the default correlated-error model
    (without the slow part's state: `test_code_bias` tests its rows) are
    its rows with white errors (τ = 0) times the AR(1)
    variance-of-the-mean factor (1 + ρ)/(1 − ρ), ρ = exp(−Δt / min(τ, d/|v|)) written out
    (Δt = 1 s, the fixes' interval; the defaults τ = 20 s, d = 20 m); carrier fixes
    (``rtk_fixed``, ``rtk_float``) keep their variances, and without the option (default)
    every fix's rows are the white ones."""
    import math

    from railnav.filters.code_bias import CodeBiasConfig
    from railnav.filters.fix_epochs import EpochSchedule, FixEpochs, FixModelConfig
    from railnav.filters.gnss_only import GnssOnlyFilter
    sc = Scenario(name="fix_test", profile=constant_speed(15.0), duration_s=20.0,
                  imu_rate_hz=10.0)
    trip = simulate_trip(sc, track=STRAIGHT, seed=2, gnss=False)
    log = trip_fixes(trip, FixSimConfig(rate_hz=1.0, quality_mix=MIX, segment_s=2.0))
    fixes = FixEpochs.from_table(log.table, start_gps_time_s=sc.start_gps_time_s)
    no_bias = CodeBiasConfig(sigma=0.0)          # the rows' models: the slow part's test
    correlated = NavigatorConfig(filter="gnss-only", code_bias=no_bias,
                                 fix_model=FixModelConfig(correlated_code_errors=True))
    white = NavigatorConfig(filter="gnss-only", pseudorange_correlation_s=0.0,
                            fix_model=FixModelConfig(correlated_code_errors=True))
    off = NavigatorConfig(filter="gnss-only")          # default: fixes white
    rows = {}
    for name, cfg in (("correlated", correlated), ("white", white), ("off", off)):
        filt = GnssOnlyFilter(STRAIGHT, cfg, fixes=fixes,
                              schedule=EpochSchedule.merge(np.zeros(0), fixes.time_s))
        x = np.array([100.0, speed_mps])
        rows[name] = [filt.observations(k, x, np.eye(2)) for k in range(len(fixes.time_s))]
    tau = min(correlated.pseudorange_correlation_s,
              correlated.pseudorange_correlation_m / speed_mps if speed_mps else math.inf)
    rho = math.exp(-1.0 / tau)
    factor = (1.0 + rho) / (1.0 - rho)
    qualities = set()
    for k, quality in enumerate(fixes.quality):
        qualities.add(str(quality))
        expected = factor if quality in ("single", "dgps") else 1.0
        for a, b, c in zip(rows["correlated"][k], rows["white"][k], rows["off"][k]):
            np.testing.assert_allclose(a.R, b.R * expected, rtol=1e-12)
            np.testing.assert_array_equal(c.R, b.R)
    assert qualities == {"rtk_fixed", "rtk_float", "dgps", "single"}
