"""railnav/reproduce/anomaly_sim.py: the sensor noises have the paper's statistics (eqs. 1, 4) and the
faults land where they are declared.

References: the stationary Gauss–Markov process has variance ``σ²`` and lag-1
autocorrelation ``φ = e^{−γT}``; the accelerometer noise is white with standard deviation
``σ_a (2T/α_a)^½``. Sample statistics are compared at ``Z_SIGMA`` standard errors."""
from __future__ import annotations

import numpy as np
import pytest

from railnav.errors import ConfigError
from railnav.reproduce.anomaly_models import HORIZONTAL, VERTICAL, AnomalyParams
from railnav.reproduce.anomaly_sim import GnssFault, simulate_anomaly

#: Sampling tolerance in standard errors of the statistic (two-sided ~1e-4 false failure).
Z_SIGMA = 4.0
#: Long enough for tight sample statistics (50 000 samples), still < 0.1 s.
DURATION_S = 1000.0
#: Floating-point agreement of the truth with its closed form (values up to 1e4 m).
ATOL_TRUTH_M = 1e-9


@pytest.fixture(scope="module")
def data():
    return simulate_anomaly(AnomalyParams(), duration_s=DURATION_S,
                            rng=np.random.default_rng(7))


def test_baro_noise_is_stationary_gauss_markov(data):
    p = AnomalyParams()
    u = data.baro_m - data.truth_vertical[:, VERTICAL.index("height")] - p.baro_bias_m
    phi = np.exp(-p.baro_noise_rate_per_s * p.dt)
    # effective number of independent samples of an AR(1) series: N (1 − φ)/(1 + φ)
    n_eff = u.size * (1 - phi) / (1 + phi)
    assert np.var(u) == pytest.approx(p.sigma_baro_m ** 2,
                                      abs=Z_SIGMA * np.sqrt(2 / n_eff) * p.sigma_baro_m ** 2)
    lag1 = np.corrcoef(u[:-1], u[1:])[0, 1]
    assert lag1 == pytest.approx(phi, abs=Z_SIGMA * np.sqrt((1 - phi ** 2) / u.size))


def test_accelerometer_noise_and_bias(data):
    p = AnomalyParams()
    sigma = p.sigma_accel_mps2 * np.sqrt(2 * p.dt / p.accel_noise_rate_per_s)
    noise = data.accel_ins_mps2 - [p.accel_bias_mps2, p.accel_bias_mps2,
                                   p.accel_bias_mps2 + data.gravity_mps2]
    n = noise.shape[0]
    np.testing.assert_allclose(noise.std(axis=0), sigma, atol=Z_SIGMA * sigma / np.sqrt(2 * n))
    np.testing.assert_allclose(noise.mean(axis=0), 0.0, atol=Z_SIGMA * sigma / np.sqrt(n))


def test_truth_is_constant_velocity_at_constant_height(data):
    p = AnomalyParams()
    np.testing.assert_allclose(data.truth_horizontal[:, HORIZONTAL.slice("pos")],
                               p.velocity_mps * np.c_[data.t, data.t], atol=ATOL_TRUTH_M)
    assert data.t[-1] == pytest.approx(DURATION_S)
    assert np.all(data.truth_vertical[:, VERTICAL.index("height")] == p.height_m)


def test_faults_add_their_offsets_inside_the_window(rng):
    p = AnomalyParams()
    fault = GnssFault(start_s=2.0, duration_s=3.0, offset_north_m=100.0, offset_up_m=-50.0)
    d = simulate_anomaly(p, duration_s=8.0, faults=(fault,), rng=rng)
    inside = (d.t >= 2.0) & (d.t < 5.0)
    np.testing.assert_array_equal(d.gnss_fault, inside)
    err_n = d.gnss_pos_m[:, 0] - d.truth_horizontal[:, HORIZONTAL.index("north")]
    err_h = d.gnss_height_m - p.gnss_height_offset_m - p.height_m
    for err, offset, sigma in ((err_n, 100.0, p.sigma_gnss_horizontal_m),
                               (err_h, -50.0, p.sigma_gnss_height_m)):
        assert err[inside].mean() == pytest.approx(offset,
                                                   abs=Z_SIGMA * sigma / np.sqrt(inside.sum()))
        assert err[~inside].mean() == pytest.approx(0.0,
                                                    abs=Z_SIGMA * sigma / np.sqrt((~inside).sum()))


@pytest.mark.parametrize("kwargs", [{"start_s": -1.0, "duration_s": 1.0},
                                    {"start_s": 0.0, "duration_s": 0.0},
                                    {"start_s": 0.0, "duration_s": 1.0,
                                     "offset_up_m": float("inf")}])
def test_bad_fault_raises(kwargs):
    with pytest.raises(ConfigError):
        GnssFault(**kwargs)


def test_too_short_run_raises(rng):
    with pytest.raises(ConfigError, match="duration_s"):
        simulate_anomaly(AnomalyParams(), duration_s=0.0, rng=rng)
