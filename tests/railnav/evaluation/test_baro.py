"""The barometric check against the track (railnav/evaluation/baro.py).

References: the Gaussian posterior of a constant bias after n readings in closed form; a
textbook scalar Kalman filter written here (division, no engine) for the random-walk
bias; binomial bands of the false-flag rate; the 2021 paper's +100 m GNSS height jump;
an end-to-end simulated trip with single-point GNSS heights (`gnss_obs.solve_spp`).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import binom

from gnss_obs.spp import SppConfig, solve_spp
from railnav.errors import ConfigError
from railnav.evaluation.baro import BaroConfig, baro_track_check, simulate_baro
from railnav.jobs.run import run_simulated
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for
from trackmodel.earth import ecef_to_geodetic
from trackmodel.io import read_track

#: Same closed form by another route: relative agreement.
RTOL = 1e-10
N = 2000
BIAS_M = 7.0   # the 2021 paper's ΔH


def _flat(rng, n=N, bias_m=BIAS_M, config=BaroConfig(bias_walk_mps=0.0)):
    t = np.arange(n, dtype=float)
    h = 300.0 + 0.02 * t
    return t, h, simulate_baro(t, h, bias_m=bias_m, config=config, rng=rng)


def test_constant_bias_is_the_gaussian_posterior(rng):
    config = BaroConfig(bias_walk_mps=0.0)
    t, h, baro = _flat(rng, config=config)
    sigma_track = np.full(N, 0.5)
    check = baro_track_check(t, baro, h, sigma_track, config=config)
    r = config.sigma_m ** 2 + 0.25
    n = np.arange(1, N + 1)
    info = n / r + 1 / config.initial_bias_sigma_m ** 2
    np.testing.assert_allclose(check.bias_m, np.cumsum(baro - h) / r / info, rtol=RTOL)
    np.testing.assert_allclose(check.sigma_bias_m, 1 / np.sqrt(info), rtol=RTOL)
    assert abs(check.bias_m[-1] - BIAS_M) < 4 * check.sigma_bias_m[-1]
    assert not check.bias_flag.any()


def test_random_walk_bias_is_the_textbook_filter(rng):
    config = BaroConfig(bias_walk_mps=0.05)
    t = np.cumsum(rng.uniform(0.5, 1.5, size=300))
    h = np.full(t.size, 120.0)
    baro = simulate_baro(t, h, bias_m=-4.0, config=config, rng=rng)
    check = baro_track_check(t, baro, h, np.zeros(t.size), config=config)
    b, p = 0.0, config.initial_bias_sigma_m ** 2
    for k in range(t.size):
        if k:
            p += config.bias_walk_mps ** 2 * (t[k] - t[k - 1])
        gain = p / (p + config.sigma_m ** 2)
        b, p = b + gain * (baro[k] - h[k] - b), (1 - gain) * p
        assert check.bias_m[k] == pytest.approx(b, rel=RTOL, abs=1e-12)
        assert check.sigma_bias_m[k] == pytest.approx(np.sqrt(p), rel=RTOL)


def test_consistent_gnss_heights_are_flagged_at_the_test_level(rng):
    """Binomial 99.9 % band of the 3σ test's 0.27 % over 5000 epochs."""
    t, h, baro = _flat(rng, n=5000)
    sigma_gnss = 6.0
    gnss = h + sigma_gnss * rng.standard_normal(t.size)
    check = baro_track_check(t, baro, h, np.zeros(t.size), gnss_time_s=t, gnss_h_m=gnss,
                             gnss_sigma_h_m=np.full(t.size, sigma_gnss))
    p = 2 * (1 - 0.99865)
    lo, hi = binom.ppf([0.0005, 0.9995], t.size, p)
    assert lo <= check.gnss_flag.sum() <= hi


def test_a_gnss_height_jump_is_flagged(rng):
    """The 2021 paper's case: +100 m of GNSS height for 10 s at t = 600 s."""
    t, h, baro = _flat(rng, n=1200)
    gnss = h + 5.0 * rng.standard_normal(t.size)
    jump = (t >= 600) & (t < 610)
    gnss[jump] += 100.0
    check = baro_track_check(t, baro, h, np.zeros(t.size), gnss_time_s=t, gnss_h_m=gnss,
                             gnss_sigma_h_m=np.full(t.size, 5.0))
    assert check.gnss_flag[jump].all()
    assert check.gnss_flag[~jump].mean() < 0.01


def test_bias_beyond_the_limit_is_flagged(rng):
    t, h, baro = _flat(rng, n=300, bias_m=60.0)
    check = baro_track_check(t, baro, h, np.zeros(t.size))
    assert check.bias_flag[50:].all() and check.bias_m[-1] == pytest.approx(60.0, abs=0.5)


def test_bad_input_is_refused():
    t = np.arange(3.0)
    with pytest.raises(ConfigError, match="NaN"):
        baro_track_check(t, [1.0, np.nan, 2.0], t, t)
    with pytest.raises(ConfigError, match="increasing"):
        baro_track_check(t[::-1], t, t, t)
    with pytest.raises(ConfigError, match="expected 3"):
        baro_track_check(t, t[:2], t, t)
    with pytest.raises(ConfigError, match="sigma_m"):
        BaroConfig(sigma_m=0.0)


def test_end_to_end_with_single_point_heights():
    """A 60-s curvy trip: baro from the true height (bias 7 m) against the filter's track
    height; GNSS heights from the single-point solution of the trip's observations."""
    track = read_track(TRACKS_DIR / "curvy.csv")
    sc = replace(get_scenario("curvy"), duration_s=60.0)
    out = run_simulated(track, sc, seed=3)
    est = out.result.estimates
    t = est["time_s"].to_numpy()
    h_true = np.interp(t, out.truth.time_s, out.truth.h)
    baro = simulate_baro(t, h_true, bias_m=BIAS_M, rng=np.random.default_rng(5))
    spp = solve_spp(out.trip.gnss.obs, out.trip.nav,   # the simulator's σ model
                    SppConfig(measurement=navigator_config_for(sc).measurement))
    h_gnss = ecef_to_geodetic(spp.r_e)[2]
    check = baro_track_check(t, baro, est["h_m"], est["sigma_up_m"],
                             gnss_time_s=spp.gps_time_s - sc.start_gps_time_s,
                             gnss_h_m=h_gnss, gnss_sigma_h_m=np.sqrt(spp.cov_enu_m2[:, 2, 2]))
    assert abs(check.bias_m[-1] - BIAS_M) < 4 * check.sigma_bias_m[-1]
    # 61 consistent heights at the 3σ test: P(more than 2 flags) = 0.06 %
    assert check.gnss_flag.sum() <= 2
