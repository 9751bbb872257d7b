"""Residuals at a known position (`gnss_obs.residuals`) against simulated truth."""
from __future__ import annotations

import numpy as np
import pytest

from gnss_obs.measurements import MeasurementConfig
from gnss_obs.residuals import RESIDUAL_COLUMNS, known_position_residuals
from gnss_obs.simulate import DEFAULT_START_GPS_TIME_S, GnssSimConfig, simulate_gnss
from trackmodel.earth import geodetic_to_ecef

R0_E = geodetic_to_ecef(np.deg2rad(41.6), np.deg2rad(2.35), 120.0)
N_EPOCHS = 240


def _residuals(nav, rng, **sim):
    t = DEFAULT_START_GPS_TIME_S + np.arange(N_EPOCHS, dtype=float)
    out = simulate_gnss(t, np.tile(R0_E, (N_EPOCHS, 1)), np.zeros((N_EPOCHS, 3)), nav,
                        GnssSimConfig(systems="GE", **sim), rng=rng)
    return known_position_residuals(out.obs, nav, MeasurementConfig(systems="GE"), times_s=t,
                                    r_e=R0_E, v_e=np.zeros(3))


def test_noise_free_residuals_vanish(nav, rng):
    """The simulator and the model share every correction: without noise the residuals
    (after the clock and inter-system bias) are the RINEX rounding, below a centimetre."""
    res = _residuals(nav, rng, sigma_pr_m=0.0, sigma_rr_mps=0.0)
    assert list(res.columns) == RESIDUAL_COLUMNS and len(res) > 10 * N_EPOCHS
    assert np.abs(res["pr_residual_m"]).max() < 0.01
    assert np.abs(res["rr_residual_mps"]).max() < 1e-3


def test_white_noise_spread_is_recovered(nav, rng):
    """White noise of σ: the residual RMS is σ·sqrt(1 - (2 - π/2)/n) for a median clock
    over n satellites (Var(e - med) = σ² - 2σ²/n + πσ²/(2n)), ~0.985 σ at n ≈ 14; the RMS of
    N samples has a relative standard error 1/sqrt(2N) (1.2 % here): 4 of them allowed."""
    sigma_pr, sigma_rr = 2.0, 0.1
    res = _residuals(nav, rng, sigma_pr_m=sigma_pr, sigma_rr_mps=sigma_rr)
    n = res.groupby("gps_time_s").size().mean()
    expected = np.sqrt(1.0 - (2.0 - np.pi / 2.0) / n)
    tol = 4.0 / np.sqrt(2.0 * len(res))
    for column, sigma in (("pr_residual_m", sigma_pr), ("rr_residual_mps", sigma_rr)):
        rms = np.sqrt(np.mean(res[column].to_numpy() ** 2)) / sigma
        assert rms == pytest.approx(expected, abs=tol)
