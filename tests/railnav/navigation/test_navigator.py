"""The track-constrained navigator against the simulated truth (railnav/navigation/navigator.py).

References: the truth of the simulator, which shares no code with the filter's model
(ECEF-derived IMU, independent light-time GNSS); the χ² distribution for NEES/NIS.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import chi2

from railnav.jobs.run import run_simulated
from railnav.navigation.navigator import _insert_samples, navigate
from railnav.sensor_data import SensorData
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for, simulate_trip
from trackmodel.io import read_track

#: Probability of the consistency bands (two-sided). Seeds are fixed, so a pass is
#: deterministic; the band is what a correct filter meets 99 % of the time.
BAND = 0.99


@pytest.fixture(scope="module")
def paper_track():
    return read_track(TRACKS_DIR / "paper2017.csv")


def _short(duration_s, **changes):
    return replace(get_scenario("paper2017"), duration_s=duration_s, **changes)


def test_accurate_gnss_pins_the_along_track_state(paper_track):
    """With 5 cm / 5 mm/s GNSS the estimate must sit on the truth: bound = 5 σ of a
    single-epoch fix along the track, 5·0.05/√8 ≈ 0.09 m, and 5·0.005/√8 m/s."""
    sc = _short(120.0, outages=(), sigma_pseudorange_m=0.05, sigma_range_rate_mps=0.005)
    out = run_simulated(paper_track, sc, seed=4)
    late = out.errors.time_s >= 20.0
    assert np.max(np.abs(out.errors.along_track_m[late])) < 0.09
    assert np.max(np.abs(out.errors.speed_mps[late])) < 0.009
    # cross-track and vertical errors: zero by construction, up to the chord of the track
    assert np.max(np.abs(out.errors.cross_track_m)) < 1e-6
    assert np.max(np.abs(out.errors.vertical_m[late])) < 1e-4
    # tilt is observed through gravity by the accelerometer pseudo-observation
    assert np.max(np.abs(out.errors.pitch_rad[late])) < 1e-4
    assert np.max(np.abs(out.errors.roll_rad[late])) < 1e-4


def test_nees_and_nis_are_consistent(paper_track):
    """8 runs of 200 s with a 50-s outage: run-averaged NEES at the end inside the χ²
    band of 8·7 degrees of freedom; NIS of the pseudo-observation (2 per step) and of the
    GNSS rows (1 per row) inside the bands of their sample sizes."""
    sc = _short(200.0, outages=((100.0, 50.0),))
    nees, nis_c, nis_pr, n_pr, steps = [], [], [], 0, 0
    for seed in range(8):
        out = run_simulated(paper_track, sc, seed=seed)
        nees.append(out.errors.nees[-1])
        r = out.result
        nis_c.append(r.nis_continuous_mean * r.n_steps)
        steps += r.n_steps
        rows = r.innovations[(r.innovations["kind"] == "pseudorange") & r.innovations["accepted"]]
        nis_pr.append(rows["nis"].sum())
        n_pr += len(rows)
    dof = out.errors.nees_dof
    lo, hi = (chi2.ppf(p, dof * 8) / 8 for p in ((1 - BAND) / 2, (1 + BAND) / 2))
    assert lo <= np.mean(nees) <= hi
    # the continuous NIS of consecutive steps is correlated through the state: the band of
    # independent samples is too tight, so only its mean is checked to 5 %
    assert np.sum(nis_c) / steps == pytest.approx(2.0, rel=0.05)
    lo, hi = (chi2.ppf(p, n_pr) / n_pr for p in ((1 - BAND) / 2, (1 + BAND) / 2))
    # gated rows (probability 0.9999) make the accepted NIS a little smaller: widen only
    # the lower bound by the gate's missing tail
    assert lo * 0.995 <= np.sum(nis_pr) / n_pr <= hi


def test_outage_has_no_gnss_updates_and_the_uncertainty_grows(paper_track):
    sc = _short(120.0, outages=((40.0, 30.0),))
    out = run_simulated(paper_track, sc, seed=1)
    t = out.result.innovations["time_s"].to_numpy()
    assert not np.any((t >= 40.0) & (t < 70.0))
    assert np.any(t < 40.0) and np.any(t >= 70.0)
    est = out.result.estimates
    sig = est["sigma_s_m"].to_numpy()
    ts = est["time_s"].to_numpy()
    before = sig[np.searchsorted(ts, 40.0)]
    end = sig[np.searchsorted(ts, 69.9)]
    assert end > before
    # the errors stay inside the filter's own 4σ through the outage
    inside = (ts >= 40.0) & (ts < 70.0)
    assert np.all(np.abs(out.errors.along_track_m[inside]) < 4 * sig[inside])


def test_start_from_the_first_gnss_fix(paper_track):
    """Without an initial state the filter starts at the first SPP fix projected on the
    track (reference: the truth; bound: a few SPP σ of 15 m² pseudoranges)."""
    sc = _short(90.0, outages=())
    trip = simulate_trip(sc, track=paper_track, seed=2)
    config = navigator_config_for(sc)
    result = navigate(trip.track, trip.sensor_data(), config)
    s_true = np.interp(result.time_s, trip.truth.time_s, trip.truth.s)
    err = result.estimates["s_m"].to_numpy() - s_true
    assert abs(err[0]) < 30.0
    assert np.max(np.abs(err[result.time_s >= 60.0])) < 3.0


def test_no_gnss_and_no_initial_state_is_refused(paper_track):
    from railnav.errors import RailnavError
    sc = _short(10.0, outages=())
    trip = simulate_trip(sc, track=paper_track, seed=0, gnss=False)
    data = SensorData(sc.start_gps_time_s, imu=trip.simulation.imu_measured)
    with pytest.raises(RailnavError, match="no GNSS data to start from"):
        navigate(trip.track, data, navigator_config_for(sc))


def test_epochs_between_imu_samples_become_samples():
    """Reference: linear interpolation written here."""
    t = np.arange(0.0, 1.0, 0.1)
    u = np.column_stack([t ** 2, np.sin(t)])
    epochs = np.array([0.3, 0.35, 0.72, 5.0])   # on a sample, between, between, outside
    t2, u2 = _insert_samples(t, u, epochs)
    np.testing.assert_allclose(t2, np.sort(np.concatenate([t, [0.35, 0.72]])))
    for k in (0, 1):
        np.testing.assert_allclose(u2[:, k], np.interp(t2, t, u[:, k]))


def test_navigator_config_for_takes_overrides_of_its_own_fields():
    """Regression (baselines review): an override of a field the scenario also sets."""
    sc = get_scenario("curvy")
    config = navigator_config_for(sc, filter="unconstrained", imu_errors="mems",
                                  gate_probability=None)
    assert config.imu.name == "mems" and config.filter == "unconstrained"
    assert config.gate_probability is None and config.oscillator == sc.clock
