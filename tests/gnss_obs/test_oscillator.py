"""Receiver clock model: Allan-coefficient conversion, process noise, sampled statistics."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from gnss_obs.constants import SPEED_OF_LIGHT_MPS
from gnss_obs.errors import GnssError
from gnss_obs.oscillator import (OSCILLATORS, Oscillator, oscillator_from_name, process_noise,
                                 simulate_clock)


def test_allan_conversion_closed_form():
    """q_b = c² h0 / 2, q_d = 2π² c² h_-2 (Brown & Hwang §9.3)."""
    osc = Oscillator.from_allan(h0_s=2e-19, h_minus2_per_s=2e-20)
    assert osc.q_bias_m2ps == pytest.approx(SPEED_OF_LIGHT_MPS ** 2 * 1e-19, rel=1e-15)
    assert osc.q_drift_m2ps3 == pytest.approx(SPEED_OF_LIGHT_MPS ** 2 * 4e-20 * np.pi ** 2,
                                              rel=1e-15)


def test_perfect_clock_is_a_straight_line(rng):
    t = 1000.0 + np.arange(50) * 0.7
    bias, drift = simulate_clock(t, OSCILLATORS["perfect"], bias0_m=12.0, drift0_mps=-3.0,
                                 rng=rng)
    np.testing.assert_allclose(bias, 12.0 - 3.0 * (t - t[0]), rtol=0, atol=1e-9)
    np.testing.assert_array_equal(drift, -3.0)


def test_sampled_increments_have_the_process_noise_covariance(rng):
    """The innovations w_k = x_{k+1} - F x_k of one long realisation are independent with
    covariance Q(Δt): each sample variance within its χ² 99.9 % band, the correlation
    within 4σ."""
    osc, dt, n = OSCILLATORS["tcxo"], 2.0, 4000
    bias, drift = simulate_clock(np.arange(n + 1) * dt, osc, bias0_m=0.0, drift0_mps=0.0,
                                 rng=rng)
    w = np.stack([bias[1:] - bias[:-1] - drift[:-1] * dt, np.diff(drift)], axis=1)
    Q = process_noise(osc, dt)
    for k in range(2):
        ratio = (w[:, k] ** 2).sum() / Q[k, k]  # zero-mean: n degrees of freedom
        assert stats.chi2.ppf(5e-4, n) < ratio < stats.chi2.ppf(1 - 5e-4, n)
    rho = np.corrcoef(w.T)[0, 1]
    rho_true = Q[0, 1] / np.sqrt(Q[0, 0] * Q[1, 1])
    assert abs(rho - rho_true) < 4 * (1 - rho_true ** 2) / np.sqrt(n)


def test_unknown_preset_and_negative_psd():
    with pytest.raises(GnssError, match="unknown oscillator"):
        oscillator_from_name("cesium")
    with pytest.raises(GnssError):
        Oscillator(-1.0, 0.0)
