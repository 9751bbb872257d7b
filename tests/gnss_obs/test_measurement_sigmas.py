"""The pseudorange σ models against their closed forms, and the urban model against the
spread of real residuals (the shipped excerpt, left out of its calibration)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gnss_obs.epoch import measurement_sigmas
from gnss_obs.errors import GnssError
from gnss_obs.measurements import URBAN_CODE_SIGMAS, MeasurementConfig
from gnss_obs.residuals import known_position_residuals
from railnav.config import NavigatorConfig

EL_DEG = np.array([90.0, 30.0, 30.0, 2.0, np.nan])
CN0_DBHZ = np.array([50.0, 45.0, 25.0, 50.0, np.nan])


def _sigmas(config: MeasurementConfig, el_deg=EL_DEG, cn0=CN0_DBHZ):
    f = np.full(len(el_deg), 1575.42e6)
    return measurement_sigmas(np.deg2rad(el_deg), cn0, config, frequency_hz=f,
                              frequency2_hz=f * np.nan)


def test_additive_closed_form():
    """σ² = a² + b²/sin²el + c²·10^(max(45 - C/N0, 0)/10), written out per point: zenith
    at 50 dB-Hz, 30° at the reference C/N0, 30° 20 dB below it, 2° (held at 5°), and
    unknown elevation and C/N0 (zenith, no deficit)."""
    a, b, c = 2.0, 1.5, 0.5
    cfg = MeasurementConfig(sigma_model="additive", sigma_pr_m=a, sigma_pr_elevation_m=b,
                            sigma_pr_cn0_m=c, sigma_rr_mps=0.1)
    s_pr, s_rr = _sigmas(cfg)
    expected = np.sqrt([a * a + b * b + c * c,
                        a * a + 4 * b * b + c * c,
                        a * a + 4 * b * b + 100 * c * c,
                        a * a + (b / np.sin(np.deg2rad(5.0))) ** 2 + c * c,
                        a * a + b * b + c * c])
    np.testing.assert_allclose(s_pr, expected, rtol=1e-14)
    # the range rate keeps the product form
    np.testing.assert_allclose(s_rr, 0.1 * np.array([1.0, 2.0, 20.0,
                                                     1 / np.sin(np.deg2rad(5.0)), 1.0]))


def test_product_floor_closed_form():
    cfg = MeasurementConfig(sigma_pr_m=1.5, sigma_pr_floor_m=2.0)
    s_pr, _ = _sigmas(cfg)
    product = 1.5 * np.array([1.0, 2.0, 20.0, 1 / np.sin(np.deg2rad(5.0)), 1.0])
    np.testing.assert_allclose(s_pr, np.hypot(2.0, product), rtol=1e-14)


@pytest.mark.parametrize("model", [{}, URBAN_CODE_SIGMAS, {"sigma_pr_floor_m": 3.0}])
def test_unweighted_is_the_simulators_constant_sigma(model):
    """Without elevation and C/N0 weighting every model is σ_pr alone (the simulator draws
    white noise of σ_pr: `railnav.simulation.trip` configures the filters so)."""
    cfg = replace(MeasurementConfig(**model), elevation_weighting=False,
                  cn0_ref_dbhz=float("nan"))
    s_pr, s_rr = _sigmas(cfg)
    floor = cfg.sigma_pr_floor_m
    np.testing.assert_allclose(s_pr, np.hypot(floor, cfg.sigma_pr_m) if floor else
                               cfg.sigma_pr_m, rtol=1e-15)
    np.testing.assert_allclose(s_rr, cfg.sigma_rr_mps, rtol=1e-15)


@pytest.mark.parametrize("bad", [dict(sigma_model="sigma-epsilon"),
                                 dict(sigma_pr_cn0_m=-1.0),
                                 dict(sigma_pr_elevation_m=float("nan")),
                                 dict(sigma_pr_floor_m=float("inf"))])
def test_bad_sigma_settings_raise(bad):
    with pytest.raises(GnssError):
        MeasurementConfig(**bad)


def _normalized_rms(residuals, config: MeasurementConfig) -> float:
    n = len(residuals)
    sigma, _ = measurement_sigmas(np.deg2rad(residuals["elevation_deg"].to_numpy()),
                                  residuals["cn0_dbhz"].to_numpy(), config,
                                  frequency_hz=np.full(n, np.nan),
                                  frequency2_hz=np.full(n, np.nan))
    return float(np.sqrt(np.mean((residuals["pr_residual_m"].to_numpy() / sigma) ** 2)))


def test_urban_sigmas_spread_on_the_real_excerpt(nav, rover_obs, reference):
    """Pseudorange residuals at the PPK reference, 12:40:00-12:42:59 (outside the 12:43 to
    U-turn window `URBAN_CODE_SIGMAS` was fitted on), divided by the urban model's σ: RMS 1
    within three standard errors of an RMS from ``n_eff`` independent Gaussian samples,
    ``1/sqrt(2 n_eff)``. The residuals are correlated in time, so ``n_eff`` counts one
    sample per satellite track and per two correlation times (the navigator's default
    `pseudorange_correlation_s`, 20 s: the time over which urban code errors decorrelate).
    The old product model (RMS 0.85 here) also passes this overall test; it fails per C/N0
    class on the rest of the drive (``benchmarks/results/pseudorange_sigma.json``)."""
    mc = MeasurementConfig(systems="GE")
    r_e = reference[["x_m", "y_m", "z_m"]].to_numpy()
    res = known_position_residuals(rover_obs, nav, mc,
                                   times_s=reference["gps_time_s"].to_numpy(), r_e=r_e)
    t = res["gps_time_s"].to_numpy()
    assert t.max() - t.min() == pytest.approx(179.0) and len(res) > 1500
    tau_s = NavigatorConfig().pseudorange_correlation_s
    n_eff = sum(max(1.0, (g["gps_time_s"].max() - g["gps_time_s"].min()) / (2 * tau_s))
                for _, g in res.groupby("sv"))
    tolerance = 3.0 / np.sqrt(2.0 * n_eff)
    assert 0.2 < tolerance < 0.35          # ~14 tracks of 3 minutes
    assert _normalized_rms(res, replace(mc, **URBAN_CODE_SIGMAS)) == \
        pytest.approx(1.0, abs=tolerance)
