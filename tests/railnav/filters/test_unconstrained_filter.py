"""The unconstrained INS/GNSS baseline (railnav/filters/unconstrained.py) against the truth.

References: the simulator's truth (ECEF-derived IMU, independent light-time GNSS; no code
shared with the filter's model); the χ² distribution for NEES; closed forms for the
output columns (a position offset applied in ENU, a covariance given in metres); the
GNSS fix's ECEF position and velocity for the start.
"""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2

from ekf.packing import pack_sym
from railnav.cli import main
from railnav.evaluation.metrics import error_series
from railnav.filters.protocol import make_filter
from railnav.jobs.run import run_simulated
from railnav.navigation.initialization import GnssFix
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario, simulate_scenario
from railnav.simulation.trip import navigator_config_for
from trackmodel.earth import C_n_e, enu_to_ecef, geodetic_to_ecef, radii
from trackmodel.io import read_track

#: Two-sided probability of the NEES band (the brief's 95 %); seeds are fixed, so a pass is
#: deterministic.
BAND = 0.95
#: GNSS of the "noise-free" run: 1 cm / 1 mm/s (the simulator needs σ > 0).
ACCURATE_PR_M, ACCURATE_RR_MPS = 0.01, 0.001
#: With that GNSS a single-epoch fix has σ ≈ PDOP·σ ≈ 2 cm and 2 mm/s; a filter that
#: averages epochs must beat 2.5 single-epoch σ.
MAX_POSITION_ERROR_M = 0.05
MAX_SPEED_ERROR_MPS = 0.005
#: A tilt δ leaks g·δ into the horizontal acceleration; 1e-4 rad (1 mm/s²) would show as
#: metres within a minute, so the GNSS-aided tilt must be far below it.
MAX_TILT_ERROR_RAD = 1e-4
#: After the start's acceleration and the first curves the heading is observed; the 1 mrad
#: initial σ must have been reduced by a factor > 3.
MAX_YAW_ERROR_RAD = 3e-4
#: Convergence time excluded from the accuracy checks, s (initial errors drawn from P0).
SETTLE_S = 30.0
#: Projection round trip s -> (lat, lon, h) -> s: `Track.project` converges to 1e-7 m.
ATOL_S_M = 1e-5


@pytest.fixture(scope="module")
def paper_track():
    return read_track(TRACKS_DIR / "paper2017.csv")


def test_nees_at_the_end_is_inside_the_chi2_band(paper_track):
    """8 runs of 200 s of the 2017 scenario with a 50-s outage: the mean over the runs of
    the NEES at the end (11 states: attitude, velocity, position, clock) inside the χ²
    band of 8·11 degrees of freedom."""
    sc = replace(get_scenario("paper2017"), duration_s=200.0, outages=((100.0, 50.0),))
    config = navigator_config_for(sc, filter="unconstrained")
    runs = [run_simulated(paper_track, sc, config=config, seed=seed) for seed in range(8)]
    dof = runs[0].errors.nees_dof
    assert dof == 11
    mean = np.mean([r.errors.nees[-1] for r in runs])
    low, high = chi2.ppf([(1 - BAND) / 2, (1 + BAND) / 2], len(runs) * dof) / len(runs)
    assert low < mean < high, (low, mean, high)
    # the baseline really leaves the track during the outage
    assert max(np.max(np.abs(r.errors.cross_track_m)) for r in runs) > 0.1


def test_perfect_imu_and_accurate_gnss_follow_the_truth_tightly():
    """Error-free IMU (the filter still assumes the 2017 paper's noise) and 1 cm / 1 mm/s
    GNSS on the curvy track, 200 s from a standstill through curves."""
    sc = replace(get_scenario("curvy"), duration_s=200.0, imu_errors="perfect",
                 sigma_pseudorange_m=ACCURATE_PR_M, sigma_range_rate_mps=ACCURATE_RR_MPS,
                 initial_s_sigma_m=1.0, initial_v_sigma_mps=0.01)
    config = replace(navigator_config_for(sc, filter="unconstrained"), imu_errors="paper2017")
    err = run_simulated(None, sc, config=config, seed=3).errors
    late = err.time_s >= SETTLE_S
    assert np.max(err.position_3d_m[late]) < MAX_POSITION_ERROR_M
    assert np.max(np.abs(err.speed_mps[late])) < MAX_SPEED_ERROR_MPS
    assert np.max(np.abs(err.roll_rad[late])) < MAX_TILT_ERROR_RAD
    assert np.max(np.abs(err.pitch_rad[late])) < MAX_TILT_ERROR_RAD
    assert np.max(np.abs(err.yaw_rad[err.time_s >= 100.0])) < MAX_YAW_ERROR_RAD


@pytest.fixture(scope="module")
def curvy():
    """A short simulated curvy trip and an unconstrained filter on its track."""
    sc = replace(get_scenario("curvy"), duration_s=120.0)
    sim = simulate_scenario(sc, seed=1)
    filt = make_filter(sim.track, navigator_config_for(sc, filter="unconstrained"), None)
    return sim, filt


class _Result:
    """The parts of a NavigationResult that `error_series` reads."""

    def __init__(self, filt, t, x, P):
        self.filter_object, self.layout, self.x, self.P = filt, filt.layout, x, P
        self.estimates = pd.DataFrame({"time_s": t, **filt.estimates(x, P)})


def test_estimates_of_the_true_state_and_of_an_offset_one(curvy):
    """At the truth: ``s_m`` = the truth's ``s``, speed its signed speed, zero errors; shifted
    by a known ENU offset: `error_series` finds it along, across and above the track."""
    sim, filt = curvy
    truth = sim.truth
    k = np.arange(0, truth.time_s.size, 100)
    x, _ = filt.truth_states(_view(truth, k), np.zeros(k.size), np.zeros(k.size))
    P = np.tile(pack_sym(np.eye(filt.layout.size) * 1e-12), (k.size, 1))
    est = filt.estimates(x, P)
    np.testing.assert_allclose(est["s_m"], truth.s[k], atol=ATOL_S_M)
    np.testing.assert_allclose(est["speed_mps"], truth.v[k], atol=1e-9)
    err = error_series(_Result(filt, truth.time_s[k], x, P), truth, sim.track)
    assert np.max(np.abs(err.position_3d_m)) < 1e-6 and np.all(np.isfinite(err.nees))
    # 2 m to the right of the track, 1 m forward, 0.5 m up: moved in ENU at the true point
    A = sim.track.at(truth.s[k]).azimuth
    offset_n = (2.0 * np.column_stack([np.cos(A), -np.sin(A), 0 * A])
                + 1.0 * np.column_stack([np.sin(A), np.cos(A), 0 * A])
                + np.array([0.0, 0.0, 0.5]))
    moved = _moved(filt, x, truth, k, offset_n)
    err = error_series(_Result(filt, truth.time_s[k], moved, P), truth, sim.track)
    grade = np.abs(sim.track.at(truth.s[k]).elevation).max()   # track tilt mixes up/along
    np.testing.assert_allclose(err.cross_track_m, 2.0, atol=1e-6)
    np.testing.assert_allclose(err.along_track_m, 1.0, atol=0.5 * grade + 1e-6)
    np.testing.assert_allclose(err.vertical_m, 0.5, atol=1.0 * grade + 1e-6)
    # a velocity pointing back along the track is a negative speed
    back = x.copy()
    back[:, filt.layout.slice("velocity")] *= -1.0
    np.testing.assert_allclose(filt.estimates(back, P)["speed_mps"], -truth.v[k], atol=1e-9)


def _view(truth, k):
    class View:
        pass
    v = View()
    for name in ("yaw", "pitch", "roll", "lat", "lon", "h", "s", "v"):
        setattr(v, name, getattr(truth, name)[k])
    v.v_n = truth.v_n[k]
    return v


def _moved(filt, x, truth, k, offset_n):
    """States with the position moved by ENU offsets (m) at the true points."""
    from trackmodel.earth import ecef_to_geodetic
    r = geodetic_to_ecef(truth.lat[k], truth.lon[k], truth.h[k])
    r += np.einsum("kij,kj->ki", C_n_e(truth.lat[k], truth.lon[k]), offset_n)
    lat, lon, h = ecef_to_geodetic(r)
    out = x.copy()
    for name, value in (("lat", lat), ("lon", lon), ("h", h)):
        out[:, filt.layout.index(name)] = value
    return out


def test_position_sigmas_are_the_metres_of_the_initial_covariance(curvy):
    """``initial_covariance(sigma_s_m=σ)``: σ per axis in metres (east, north, up), and the
    along/cross-track σ of an isotropic horizontal error are σ too."""
    sim, filt = curvy
    sigma = 4.0
    P0 = filt.initial_covariance(sigma_s_m=sigma, sigma_v_mps=0.2)
    start = sim.track.at(0.0)
    x, _ = filt.truth_states(_view(sim.truth, np.array([0])), np.zeros(1), np.zeros(1))
    est = filt.estimates(x, pack_sym(P0)[None, :])
    M, N = radii(start.lat)
    assert np.diag(P0)[filt.layout.index("lat")] == pytest.approx((sigma / (M + start.h)) ** 2)
    for column in ("sigma_east_m", "sigma_north_m", "sigma_up_m", "sigma_cross_track_m"):
        assert est[column][0] == pytest.approx(sigma, rel=1e-9), column
    # along the 3-D tangent: horizontal σ and vertical σ combine as cos²ϑ + sin²ϑ = 1
    assert est["sigma_s_m"][0] == pytest.approx(sigma, rel=1e-9)
    assert est["sigma_speed_mps"][0] == pytest.approx(0.2, rel=1e-9)


def test_start_from_a_gnss_fix(curvy):
    """The state is the fix's position and velocity, the attitude the track's; the σ are
    the fix's own per axis, floored."""
    sim, _ = curvy
    sc = replace(get_scenario("curvy"), duration_s=120.0)
    filt = make_filter(sim.track, replace(navigator_config_for(sc, filter="unconstrained"),
                                          initial_s_sigma_m=None, initial_v_sigma_mps=None),
                       None)
    j = 9000
    t = sim.truth
    r_fix = enu_to_ecef(np.array([3.0, -1.0, 2.0]), lat0=t.lat[j], lon0=t.lon[j], h0=t.h[j])
    v_fix = C_n_e(t.lat[j], t.lon[j]) @ t.v_n[j]
    fix = GnssFix(time_s=90.0, r_e=r_fix, v_e=v_fix, clock_bias_m={"G": 77.0},
                  clock_drift_mps=-0.3, cov_enu_m2=np.diag([9.0, 16.0, 0.25]),
                  cov_v_enu_m2ps2=np.diag([0.04, 0.09, 1e-6]))
    x0, P0 = filt.initial_from_fix(fix)
    get = dict(zip(filt.layout.names, x0))
    np.testing.assert_allclose(geodetic_to_ecef(get["lat"], get["lon"], get["h"]), r_fix,
                               atol=1e-6)
    v_e = C_n_e(get["lat"], get["lon"]) @ np.array([get["v_E"], get["v_N"], get["v_U"]])
    np.testing.assert_allclose(v_e, v_fix, atol=1e-9)
    assert get["yaw"] == pytest.approx(t.yaw[j] % (2 * np.pi), abs=1e-4)
    assert get["clock_bias"] == 77.0 and get["clock_drift"] == -0.3
    est = filt.estimates(x0[None, :], pack_sym(P0)[None, :])
    # fix σ 3, 4, 0.5 m: the height σ is floored at 1 m; velocity 0.2, 0.3, floored 0.05
    np.testing.assert_allclose([est["sigma_east_m"][0], est["sigma_north_m"][0],
                                est["sigma_up_m"][0]], [3.0, 4.0, 1.0], rtol=1e-9)
    var = dict(zip(filt.layout.names, np.diag(P0)))
    np.testing.assert_allclose([var["v_E"], var["v_N"], var["v_U"]], [0.04, 0.09, 0.0025],
                               rtol=1e-12)


def test_cli_runs_the_unconstrained_filter(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["-q", "run", str(TRACKS_DIR / "paper2017.csv"), "--filter", "unconstrained",
                 "--duration-s", "40", "--outage", "10:10", "--out", str(out)])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["filter"] == "unconstrained"
    errors = pd.read_csv(out / "errors.csv")
    assert errors["cross_track_m"].abs().max() > 1e-3   # off the track: a real error
    assert (out / "errors.png").is_file() and (out / "track.png").is_file()
    assert "unconstrained filter" in capsys.readouterr().out
