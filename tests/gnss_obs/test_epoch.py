"""Per-epoch preparation: σ model, group delay of combinations."""
from __future__ import annotations

import numpy as np
import pytest

from gnss_obs.constants import SPEED_OF_LIGHT_MPS, WEEK_S
from gnss_obs.ephemeris import select_ephemeris
from gnss_obs.epoch import measurement_sigmas, prepare_epoch, split_epochs
from gnss_obs.measurements import MeasurementConfig, select_measurements

T_1240 = 2134 * WEEK_S + 45_600.0


def test_sigma_model_closed_form():
    cfg = MeasurementConfig(sigma_pr_m=1.5, sigma_rr_mps=0.1, cn0_ref_dbhz=45.0)
    el = np.deg2rad(np.array([90.0, 30.0, 30.0, 2.0]))
    cn0 = np.array([50.0, 45.0, 25.0, 50.0])
    f = np.full(4, 1575.42e6)
    s_pr, s_rr = measurement_sigmas(el, cn0, cfg, frequency_hz=f, frequency2_hz=f * np.nan)
    np.testing.assert_allclose(s_pr, [1.5, 3.0, 30.0, 1.5 / np.sin(np.deg2rad(5.0))])
    np.testing.assert_allclose(s_rr / s_pr, 0.1 / 1.5)


def test_iono_free_noise_gain():
    """σ_IF = σ sqrt(f1⁴ + f2⁴)/(f1² - f2²): 2.98 for GPS L1/L2."""
    cfg = MeasurementConfig(ionosphere="iono-free", elevation_weighting=False)
    s, _ = measurement_sigmas(np.array([1.0]), np.array([50.0]), cfg,
                              frequency_hz=np.array([1575.42e6]),
                              frequency2_hz=np.array([1227.60e6]))
    assert s[0] == pytest.approx(2.9783, abs=1e-4)


def test_prepared_epoch_on_real_data(nav, rover_obs):
    """At 12:40 near Barcelona every prepared GPS L1 satellite has a clock (TGD known), a
    positive tropospheric delay of 2-25 m and a Klobuchar delay of 1-20 m. The L1 clock is
    the L1/L2 (ionosphere-free) clock minus c·TGD: the pair's group delay cancels
    (IS-GPS-200N §20.3.3.3.3.2 defines TGD so)."""
    r_rx = rover_obs.header.approx_position_e
    klob = (nav.header.iono_gps_alpha, nav.header.iono_gps_beta)
    out = {}
    for iono in ("klobuchar", "iono-free"):
        cfg = MeasurementConfig(systems="G", ionosphere=iono)
        meas = select_measurements(rover_obs.table[rover_obs.table["gps_time_s"] == T_1240], cfg)
        epoch = split_epochs(meas, nav.records, cfg)[0]
        out[iono] = prepare_epoch(epoch, cfg, r_rx_e=r_rx, klobuchar=klob)
    p = out["klobuchar"]
    assert len(p) == 8 and np.all(np.isfinite(p.sat_clock_m))
    assert np.all((p.tropo_m > 2) & (p.tropo_m < 25)) and np.all((p.iono_m > 1) & (p.iono_m < 20))
    q = out["iono-free"]
    assert np.all(q.iono_m == 0)
    common = np.isin(p.sv, q.sv)
    tgd = select_ephemeris(nav.records, q.sv, np.full(len(q), T_1240))["tgd_s"].to_numpy()
    np.testing.assert_allclose(p.sat_clock_m[common] - q.sat_clock_m,
                               -SPEED_OF_LIGHT_MPS * tgd, rtol=0, atol=1e-6)
