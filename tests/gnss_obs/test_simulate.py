"""The measurement simulator: agreement with the independent CasADi models, RINEX round
trip, outages, faults and noise statistics."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from gnss_obs.errors import GnssError, GnssInputError
from gnss_obs.epoch import prepare_epoch, split_epochs
from gnss_obs.measurements import MeasurementConfig, glonass_channels, select_measurements
from gnss_obs.observables import predict_pseudorange, predict_range_rate
from gnss_obs.rinex_obs import read_rinex_obs
from gnss_obs.sim_events import in_outages
from gnss_obs.simulate import (DEFAULT_START_GPS_TIME_S, GnssSimConfig, Outage,
                               SatelliteFault, simulate_gnss, write_simulation)
from trackmodel.earth import C_n_e, geodetic_to_ecef

#: Two independent implementations (simulator light-time iteration vs. pseudorange-based
#: transmission time + CasADi model) must agree to 1 mm (the lead's requirement) and 1 mm/s.
ATOL_PR_M = 1e-3
ATOL_RR_MPS = 1e-3
LAT, LON, H = np.deg2rad(41.6), np.deg2rad(2.35), 120.0


def _trajectory(n: int, speed_mps: float = 20.0, dt: float = 1.0):
    t = DEFAULT_START_GPS_TIME_S + dt * np.arange(n)
    v_e = np.tile(C_n_e(LAT, LON) @ np.array([0.5, np.sqrt(0.75), 0.0]) * speed_mps, (n, 1))
    r_e = geodetic_to_ecef(LAT, LON, H) + v_e * (t - t[0])[:, None]
    return t, r_e, v_e


def test_casadi_models_reproduce_noise_free_measurements(nav, rng):
    """Noise-free simulated pseudorange and range rate of a moving receiver with a drifting
    clock, all four systems, against the estimator's path (split_epochs -> prepare_epoch ->
    CasADi) evaluated at the true position, velocity and clock."""
    t, r_e, v_e = _trajectory(30)
    cfg = GnssSimConfig(systems="GECR", sigma_pr_m=0.0, sigma_rr_mps=0.0,
                        clock_bias0_m=2.0e4, clock_drift0_mps=150.0)
    sim = simulate_gnss(t, r_e, v_e, nav, cfg, rng=rng)
    mc = MeasurementConfig(systems="GECR")
    meas = select_measurements(sim.obs.table, mc, glonass_channels=glonass_channels(
        sim.obs.header.glonass_slots, nav.records))
    truth = sim.satellites.set_index(["gps_time_s", "sv"])
    klob = (nav.header.iono_gps_alpha, nav.header.iono_gps_beta)
    for k, epoch in enumerate(split_epochs(meas, nav.records, mc)):
        key = list(zip(np.full(len(epoch), epoch.gps_time_s), epoch.meas["sv"]))
        epoch.meas["pseudorange_m"] = truth.loc[key, "pseudorange_free_m"].to_numpy()
        epoch.meas["range_rate_mps"] = truth.loc[key, "range_rate_free_mps"].to_numpy()
        p = prepare_epoch(epoch, mc, r_rx_e=r_e[k], klobuchar=klob)
        assert len(p) == len(epoch) and set(p.system) == set("GECR")
        rho, _, _ = predict_pseudorange(p, r_e=r_e[k], b_m=sim.clock["clock_bias_m"][k])
        rr, *_ = predict_range_rate(p, r_e=r_e[k], v_e=v_e[k],
                                    d_mps=sim.clock["clock_drift_mps"][k])
        np.testing.assert_allclose(rho, p.pseudorange_m, rtol=0, atol=ATOL_PR_M)
        np.testing.assert_allclose(rr, p.range_rate_mps, rtol=0, atol=ATOL_RR_MPS)


def test_rinex_round_trip_reads_back_the_table(nav, rng, tmp_path):
    t, r_e, v_e = _trajectory(20)
    sim = simulate_gnss(t, r_e, v_e, nav, GnssSimConfig(systems="GER"), rng=rng)
    obs_path, nav_path = write_simulation(tmp_path, sim, nav)
    back = read_rinex_obs(obs_path)
    cols = ["gps_time_s", "sv", "signal", "pseudorange_m", "doppler_hz", "cn0_dbhz"]
    pd.testing.assert_frame_equal(back.table[cols].reset_index(drop=True),
                                  sim.obs.table[cols].reset_index(drop=True), atol=1e-9,
                                  rtol=0, check_dtype=False)
    assert back.header.glonass_slots == sim.obs.header.glonass_slots
    assert nav_path.is_file()


def test_outages_faults_and_mask(nav, rng):
    t, r_e, v_e = _trajectory(60)
    faults = (SatelliteFault("G05", 10.0, 20.0, step_m=50.0, ramp_mps=2.0),)
    outages = (Outage(5.0, 5.0), Outage(20.0, 10.0, max_satellites=4),
               Outage(40.0, 5.0, max_satellites=99, elevation_mask_deg=40.0))
    cfg = GnssSimConfig(systems="GE", faults=faults, outages=outages, elevation_mask_deg=15.0)
    sim = simulate_gnss(t, r_e, v_e, nav, cfg, rng=rng)
    s = sim.satellites
    rel = s["gps_time_s"] - t[0]
    per_epoch = s.groupby(rel).size().reindex(np.arange(60.0), fill_value=0).to_numpy()
    assert (per_epoch[5:10] == 0).all() and (per_epoch[20:30] == 4).all()
    assert (per_epoch[:5] > 4).all()
    assert (s["elevation_deg"] >= 15.0).all()
    assert (s.loc[(rel >= 40) & (rel < 45), "elevation_deg"] >= 40.0).all()
    kept = s[(rel >= 20) & (rel < 30)]
    highest = s[rel < 5].groupby("gps_time_s")["elevation_deg"].apply(
        lambda e: np.sort(e.to_numpy())[-4:].min())
    assert kept["elevation_deg"].min() >= highest.min() - 1.0  # the 4 highest were kept
    g05 = s[s["sv"] == "G05"]
    expected = np.where((g05["gps_time_s"] - t[0] >= 10) & (g05["gps_time_s"] - t[0] < 30),
                        50.0 + 2.0 * (g05["gps_time_s"] - t[0] - 10.0), 0.0)
    np.testing.assert_allclose(g05["fault_m"], expected)
    table = sim.obs.table.set_index(["gps_time_s", "sv"])
    pr = table.loc[list(zip(g05["gps_time_s"], g05["sv"])), "pseudorange_m"].to_numpy()
    np.testing.assert_allclose(pr - g05["pseudorange_free_m"] - g05["noise_pr_m"], expected,
                               atol=5e-4)  # RINEX rounding to 1 mm


def test_outage_over_the_whole_trip_is_an_error_not_an_empty_file(nav, rng):
    t, r_e, v_e = _trajectory(10)
    cfg = GnssSimConfig(outages=(Outage(0.0, 10.0),))
    with pytest.raises(GnssError, match="no satellite is observed"):
        simulate_gnss(t, r_e, v_e, nav, cfg, rng=rng)


def test_noise_has_the_configured_sigma(nav, rng):
    """Sample variance of the injected noise in its χ² 99.9 % band (elevation-independent),
    and the written Doppler is -ρ̇/λ of the noisy range rate."""
    t, r_e, v_e = _trajectory(200)
    cfg = GnssSimConfig(systems="G", sigma_pr_m=3.0, sigma_rr_mps=0.4)
    sim = simulate_gnss(t, r_e, v_e, nav, cfg, rng=rng)
    n = len(sim.satellites)
    for col, sigma in (("noise_pr_m", 3.0), ("noise_rr_mps", 0.4)):
        ratio = (sim.satellites[col] ** 2).sum() / sigma ** 2
        assert stats.chi2.ppf(5e-4, n) < ratio < stats.chi2.ppf(1 - 5e-4, n)
    wavelength = 299_792_458.0 / 1575.42e6
    rr = sim.satellites["range_rate_free_mps"] + sim.satellites["noise_rr_mps"]
    np.testing.assert_allclose(-wavelength * sim.obs.table["doppler_hz"], rr, atol=1e-3)


def test_multipath_is_a_correlated_bias(nav, rng):
    t, r_e, v_e = _trajectory(300)
    cfg = GnssSimConfig(systems="G", sigma_pr_m=0.0, multipath_sigma_m=2.0,
                        multipath_tau_s=30.0)
    s = simulate_gnss(t, r_e, v_e, nav, cfg, rng=rng).satellites
    one = s[s["sv"] == s["sv"].iloc[0]]["multipath_m"].to_numpy()
    lag1 = np.corrcoef(one[:-1], one[1:])[0, 1]
    assert lag1 > np.exp(-1 / 30.0) - 0.1  # e^{-Δt/τ} ≈ 0.967
    assert 0.5 < s["multipath_m"].std() < 8.0  # 2 m scaled by 1/sin(el)


@pytest.mark.parametrize("bad", ["shape", "nan", "order"])
def test_rejects_bad_trajectories(nav, rng, bad):
    t, r_e, v_e = _trajectory(5)
    if bad == "shape":
        r_e = r_e.T
    elif bad == "nan":
        v_e[2, 1] = np.nan
    else:
        t = t[::-1]
    with pytest.raises(GnssInputError):
        simulate_gnss(t, r_e, v_e, nav, rng=rng)


def test_config_validation():
    for kwargs in (dict(systems="GX"), dict(sigma_pr_m=-1.0), dict(oscillator="maser"),
                   dict(multipath_tau_s=0.0)):
        with pytest.raises(GnssError):
            GnssSimConfig(**kwargs)
    with pytest.raises(GnssError):
        Outage(-1.0, 5.0)
    with pytest.raises(GnssError):
        SatelliteFault("G01", 0.0, 0.0)


def test_outage_is_one_window_type():
    """Issue 12: one outage type. A total outage unpacks as, and equals, its
    (start_s, duration_s) pair; a partial one does not; times count from the origin."""
    total, partial = Outage(100.0, 50.0), Outage(100.0, 50.0, max_satellites=4)
    assert tuple(total) == (100.0, 50.0) and total == (100.0, 50.0)
    assert hash(total) == hash((100.0, 50.0))
    assert partial != (100.0, 50.0) and partial != total and total.total
    assert not partial.total
    assert Outage.of([5, 2]) == Outage(5.0, 2.0)
    np.testing.assert_array_equal(in_outages([99.9, 100.0, 149.9, 150.0], [total, partial]),
                                  [False, True, True, False])


def test_outage_times_count_from_the_stated_origin(nav, rng):
    """Issue 12: an outage is in seconds from the trip start, whatever the first simulated
    epoch (a streamed segment starts mid-trip). Reference: the epochs inside
    [origin + 5, origin + 8) are the ones without observations, for a call that starts at
    the origin and one that starts 4 s later."""
    t, r_e, v_e = _trajectory(20)
    cfg = GnssSimConfig(systems="G", outages=(Outage(5.0, 3.0),),
                        time_origin_gps_time_s=float(t[0]))
    for first in (0, 4):
        sim = simulate_gnss(t[first:], r_e[first:], v_e[first:], nav, cfg, rng=rng)
        seen = np.unique(sim.obs.table["gps_time_s"].to_numpy()) - t[0]
        expected = [s for s in np.arange(first, 20.0) if not 5.0 <= s < 8.0]
        np.testing.assert_allclose(seen, expected, atol=1e-6)
