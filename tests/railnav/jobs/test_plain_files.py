"""A simulated trip run as plain files (no ``scenario.json`` beside them: a recorded trip's
defaults), with and without the receiver's σ (``sigma_pr_m``, ``sigma_rr_mps``).

The simulator's receiver is the 2017 paper's (σ_pr √15 m, σ_rr √0.5 m/s, constant), noisier
than the real receiver `gnss_obs.MeasurementConfig`'s defaults describe (1 m, 0.05 m/s at
zenith): told nothing, the filter trusts its rows too much. Reference: the simulator's
truth.csv and the χ² band of the mean of independent NEES values (one per run, at
`NEES_TIME_S`; `ekf.consistency.chi2_band`) checked against SciPy's χ² quantiles.
"""
from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import chi2

from ekf.consistency import chi2_band
from railnav.cli import main
from railnav.commands.run_report import HINT_REJECTED_SHARE
from railnav.jobs.run import run_files
from railnav.jobs.sensor_files import read_sensor_files
from railnav.simulation.scenarios import TRACKS_DIR
from trackmodel.io import read_track

CURVY = TRACKS_DIR / "curvy.csv"
SEEDS = range(10)            # chosen before the runs
DURATION_S = 150.0
#: One NEES per run, cruising at 25 m/s among curves.
NEES_TIME_S = 140.0
#: What ``railnav simulate`` simulates (`gnss_obs.sim_defaults`, the paper's values).
SIM_SIGMA_PR_M, SIM_SIGMA_RR_MPS = math.sqrt(15.0), math.sqrt(0.5)


@pytest.fixture(scope="module")
def trips(tmp_path_factory):
    """Plain files of seeded curvy trips: scenario.json removed after reading it."""
    out = []
    for seed in SEEDS:
        folder = tmp_path_factory.mktemp(f"plain{seed}")
        assert main(["-q", "simulate", str(CURVY), "--duration-s", f"{DURATION_S:g}",
                     "--seed", str(seed), "--out", str(folder)]) == 0
        meta = json.loads((folder / "scenario.json").read_text())
        (folder / "scenario.json").unlink()
        out.append((folder, meta))
    return out


def _files(folder) -> dict:
    return {"imu_path": folder / "imu.csv", "obs_path": folder / "gnss_obs.rnx",
            "nav_path": folder / "gnss_nav.rnx"}


def _nees_at(folder, **options) -> tuple[float, int, float]:
    """NEES at `NEES_TIME_S`, its dof, and the share of GNSS rows not used (`options`:
    `run_files`'s told σ, or a configuration)."""
    grade = {} if "config" in options else {"imu_grade": "tactical"}   # a config has it
    out = run_files(read_track(CURVY), **_files(folder), truth_path=folder / "truth.csv",
                    **grade, **options)
    k = int(np.argmin(np.abs(out.errors.time_s - NEES_TIME_S)))
    assert abs(out.errors.time_s[k] - NEES_TIME_S) < 0.051
    rows = out.result.innovations
    gnss = rows["kind"].isin(("pseudorange", "range_rate")).to_numpy()
    unused = float(np.mean(rows["status"].to_numpy()[gnss] != "used"))
    return float(out.errors.nees[k]), out.errors.nees_dof, unused


def test_told_sigmas_reach_the_config_as_the_scenario_says(trips):
    folder, meta = trips[0]
    sc = meta["scenario"]
    _, told = read_sensor_files(**_files(folder), imu_grade="tactical",
                                sigma_pr_m=sc["sigma_pseudorange_m"],
                                sigma_rr_mps=sc["sigma_range_rate_mps"])
    _, plain = read_sensor_files(**_files(folder), imu_grade="tactical")
    assert told.measurement.sigma_pr_m == pytest.approx(SIM_SIGMA_PR_M, rel=1e-12)
    assert told.measurement.sigma_rr_mps == pytest.approx(SIM_SIGMA_RR_MPS, rel=1e-12)
    # only the two σ change: the rest is the plain files' (a real receiver's) model
    assert told.measurement.elevation_weighting == plain.measurement.elevation_weighting
    assert told.pseudorange_correlation_s == plain.pseudorange_correlation_s


def _plain_config(folder, **changes):
    """The plain files' default configuration (`read_sensor_files`), with `changes`."""
    return replace(read_sensor_files(**_files(folder), imu_grade="tactical")[1], **changes)


def test_plain_files_told_the_receiver_sigmas_are_not_overconfident(trips):
    """Told the simulated σ (the rest the real-data defaults: σ/sin(el), C/N0 penalty,
    correlated pseudoranges, all of which only add variance to the simulator's constant
    σ), the mean NEES is at most the 99 % band's top, and the fault screen keeps out few
    rows (its row test's design rate is 1.9e-4). Told nothing and without the adaptive
    noise scale (``NavigatorConfig.noise_scale`` None), the rows are read as far more
    precise than they are, and the screen keeps out a large share of them (the run's
    hint says so). Told nothing, the mean NEES at 140 s was above the band (17.4) until
    the screen tested correlated rows at their own variance (s37screen): it now rejects
    the rows it cannot explain instead (5.2), so NEES no longer tells the two apart
    here."""
    told = [_nees_at(folder, sigma_pr_m=SIM_SIGMA_PR_M, sigma_rr_mps=SIM_SIGMA_RR_MPS)
            for folder, _ in trips]
    untold = [_nees_at(folder, config=_plain_config(folder, noise_scale=None))
              for folder, _ in trips]
    dof = {d for _, d, _ in told + untold}
    assert dof == {5}
    n = len(SEEDS)
    low, high = chi2_band(5, n, 0.99)
    assert high == pytest.approx(chi2.ppf(0.995, 5 * n) / n, rel=1e-9)
    assert low == pytest.approx(chi2.ppf(0.005, 5 * n) / n, rel=1e-9)
    assert np.mean([v for v, _, _ in told]) <= high, told
    assert max(u for _, _, u in told) < HINT_REJECTED_SHARE, told
    assert min(u for _, _, u in untold) > HINT_REJECTED_SHARE, untold


def test_plain_files_with_the_noise_scale(trips):
    """Told nothing, with the adaptive noise scale (the default,
    `railnav.filters.noise_scale`): the mean NEES at 140 s is inside the 99 % band, and
    the screen keeps out fewer rows than without the scale on every trip."""
    untold = [_nees_at(folder) for folder, _ in trips]
    without = [_nees_at(folder, config=_plain_config(folder, noise_scale=None))
               for folder, _ in trips]
    low, high = chi2_band(5, len(SEEDS), 0.99)
    assert low <= np.mean([v for v, _, _ in untold]) <= high, untold
    assert all(u < w for (_, _, u), (_, _, w) in zip(untold, without)), (untold, without)




#: Early times of the start test: the train stands (0-10 s), then accelerates.
EARLY_TIMES_S = (5.0, 20.0)


def _early_nees(folder, **options) -> list[float]:
    out = run_files(read_track(CURVY), **_files(folder), truth_path=folder / "truth.csv",
                    imu_grade="tactical", **options)
    k = [int(np.argmin(np.abs(out.errors.time_s - t))) for t in EARLY_TIMES_S]
    return [float(out.errors.nees[j]) for j in k]


def test_plain_files_start_honest(trips):
    """Told nothing, the start from the first fix (`railnav.navigation.start_scatter`:
    its covariance and the noise scale's seed from the first fixes' scatter): the mean
    NEES at 5 s and at 20 s over the trips is inside the 99 % band of the mean of
    independent χ²₅ (SciPy's quantiles). Before (stop 39: the fix's own σ and the scale
    at 1) it was 64 and 17 on ten other seeds; told the σ and with the scale off, it was
    and is out of the band too (the start's σ as given: ``--no-noise-scale``)."""
    low, high = chi2_band(5, len(SEEDS), 0.99)
    assert (low, high) == pytest.approx((chi2.ppf(0.005, 50) / 10, chi2.ppf(0.995, 50) / 10),
                                        rel=1e-9)
    nees = np.array([_early_nees(folder) for folder, _ in trips])
    assert np.all((low <= nees.mean(axis=0)) & (nees.mean(axis=0) <= high)), nees.mean(axis=0)
    kept = np.array([_early_nees(folder, noise_scale=False) for folder, _ in trips])
    assert np.all(kept.mean(axis=0) > high), kept.mean(axis=0)


def test_the_start_keeps_the_sigmas_it_is_told(trips):
    """The first fix's covariance is the SPP's own (`gnss_obs.solve_spp` on the same
    epochs) with the noise scale off, and when told the simulated σ (the scatter test
    finds nothing: 10 of 10 trips); told nothing, it is the SPP's times the factors."""
    from gnss_obs.spp import SppConfig, solve_spp
    from railnav.navigation.initialization import first_fix
    told = {"sigma_pr_m": SIM_SIGMA_PR_M, "sigma_rr_mps": SIM_SIGMA_RR_MPS}
    for folder, _ in trips:
        data, plain = read_sensor_files(**_files(folder), imu_grade="tactical")
        config = read_sensor_files(**_files(folder), imu_grade="tactical", **told)[1]
        for cfg, inflated in ((replace(plain, noise_scale=None), False), (config, False),
                              (plain, True)):
            fix = first_fix(data, cfg)
            spp = solve_spp(data.obs, data.nav, SppConfig(
                measurement=cfg.measurement, elevation_mask_deg=cfg.elevation_mask_deg))
            k = int(np.argmin(np.abs(spp.gps_time_s - data.start_gps_time_s - fix.time_s)))
            pos, vel = fix.start_factors
            assert (pos > 1.0 and vel > 1.0) if inflated else (pos, vel) == (1.0, 1.0)
            np.testing.assert_allclose(fix.cov_enu_m2, spp.cov_enu_m2[k] * pos, rtol=1e-12)
            np.testing.assert_allclose(fix.cov_v_enu_m2ps2, spp.cov_v_enu_m2ps2[k] * vel,
                                       rtol=1e-12)
