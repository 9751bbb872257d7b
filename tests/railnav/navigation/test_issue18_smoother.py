"""Issue 18: ``railnav run --smooth``, the engine's RTS smoother over a navigation run.

Consistency is tested the way a filter's is, against the χ² distribution and not against
the smoother's own σ: over M independent seeds, the NEES at one fixed time is χ²(dof) per
run if the smoothed covariance is right, so the mean over the seeds must lie in the
two-sided 99 % band of χ²(M·dof)/M (each seed's run independent: an exact test, not a
time average of correlated samples). Accuracy is measured against the simulated truth:
the smoother uses every measurement before and after each time, so its RMS error over the
seeds must not exceed the filter's. The scenario is the 2017 paper's (its IMU errors are
all modelled by the filter) with a 30-s GNSS outage, where smoothing matters most.
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2

from railnav.cli import main
from railnav.errors import RailnavError
from railnav.jobs.run import run_simulated
from railnav.navigation.smoothing import smooth_result
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario

PAPER = str(TRACKS_DIR / "paper2017.csv")
SEEDS = 12
DURATION_S = 90.0
OUTAGE = (40.0, 30.0)
#: Times of the exact tests: mid-outage and after the GNSS is back.
TEST_TIMES_S = (55.0, 80.0)
BAND = 0.99
QUANTITIES = ("along_track_m", "speed_mps", "attitude_rad")


@pytest.fixture(scope="module")
def runs():
    scenario = get_scenario("paper2017").with_overrides(duration_s=DURATION_S,
                                                        outages=[OUTAGE])
    return [run_simulated(PAPER, scenario, seed=seed, smooth=True) for seed in range(SEEDS)]


@pytest.mark.parametrize("time_s", TEST_TIMES_S)
def test_issue18_smoothed_nees_in_the_chi2_band(runs, time_s):
    errors = [r.smoothed.errors for r in runs]
    k = int(np.argmin(np.abs(errors[0].time_s - time_s)))
    dof = errors[0].nees_dof
    assert dof == 7                      # yaw, pitch, roll, s, v, clock bias and drift
    mean = np.mean([e.nees[k] for e in errors])
    lo, hi = chi2.ppf([(1 - BAND) / 2, (1 + BAND) / 2], SEEDS * dof) / SEEDS
    assert lo <= mean <= hi, (time_s, mean, lo, hi)


def test_issue18_smoother_at_least_as_accurate_as_the_filter(runs):
    for q in QUANTITIES:
        f = np.concatenate([getattr(r.errors, q) for r in runs])
        s = np.concatenate([getattr(r.smoothed.errors, q) for r in runs])
        assert np.sqrt(np.nanmean(s ** 2)) <= np.sqrt(np.nanmean(f ** 2)), q
    # in the outage the filter drifts and the smoother bridges it from both sides
    inside = (runs[0].errors.time_s >= OUTAGE[0]) & (
        runs[0].errors.time_s < OUTAGE[0] + OUTAGE[1])
    f = np.concatenate([r.errors.along_track_m[inside] for r in runs])
    s = np.concatenate([r.smoothed.errors.along_track_m[inside] for r in runs])
    assert np.sqrt(np.mean(s ** 2)) < 0.5 * np.sqrt(np.mean(f ** 2))


def test_issue18_smoothed_twin_keeps_the_run_and_is_never_less_certain(runs):
    run = runs[0]
    smoothed = run.smoothed.result
    assert list(smoothed.estimates.columns) == list(run.result.estimates.columns)
    np.testing.assert_array_equal(smoothed.time_s, run.result.time_s)
    assert smoothed.innovations is run.result.innovations
    # RTS: P_{k|N} = P_{k|k} + C (P_{k+1|N} - P_{k+1|k}) Cᵀ <= P_{k|k} at the same sample
    # (more data cannot add uncertainty); a time misaligned by a step breaks it
    from ekf.packing import unpack_sym
    gap = unpack_sym(run.result.P) - unpack_sym(smoothed.P)
    scale = np.sqrt(np.einsum("kii->ki", unpack_sym(run.result.P)))
    worst = np.linalg.eigvalsh(gap / scale[:, :, None] / scale[:, None, :]).min()
    assert worst > -1e-9


def test_issue18_run_without_smoother_data_is_an_error():
    scenario = get_scenario("paper2017").with_overrides(duration_s=5.0)
    plain = run_simulated(PAPER, scenario)
    with pytest.raises(RailnavError, match="rts_smoothing=True"):
        smooth_result(plain.result)


def test_issue18_cli_smooth_writes_smoothed_csv_and_summary(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["-q", "run", PAPER, "--duration-s", "20", "--smooth", "--no-plots",
                 "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    estimates = pd.read_csv(out / "estimates.csv")
    smoothed = pd.read_csv(out / "smoothed.csv")
    assert list(smoothed.columns) == list(estimates.columns)
    np.testing.assert_array_equal(smoothed["time_s"], estimates["time_s"])
    errors = pd.read_csv(out / "smoothed_errors.csv")
    summary = json.loads((out / "summary.json").read_text())["smoothed"]
    assert summary["method"] == "rts"
    rms = summary["errors"]["all"]["along_track_m"]["rms"]
    assert rms == pytest.approx(np.sqrt(np.mean(errors["along_track_m"] ** 2)), rel=1e-9)
    assert "smoothed (RTS): along-track RMS" in printed
    code = main(["-q", "run", PAPER, str(TRACKS_DIR / "double_a.csv"), "--smooth",
                 "--out", str(tmp_path / "two")])
    assert code == 2 and "--smooth works with one track" in capsys.readouterr().err
