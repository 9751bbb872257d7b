"""The shipped baro example (issue 18: the README's ``--baro`` example had no file to run).

Reference: the provenance in ``data/baro/README.md`` — the true height of the curvy trip plus a
7-m bias, a bias walk of 0.01 m/√s and 1-m white noise — checked against the truth computed
here from the track and the scenario.
"""
from __future__ import annotations

import numpy as np
import pytest

from railnav.jobs.baro import read_baro_csv
from railnav.simulation.scenarios import get_scenario
from railnav.simulation.truth import simulate_truth
from tests.conftest import DATA, TRACKS
from trackmodel.io import read_track

BARO_FILE = DATA / "baro" / "curvy_baro.csv"
BIAS_M = 7.0
#: The mean of (baro − truth) over 1001 readings differs from the bias by the walk's mean
#: (σ ≈ 0.01 m/√s · √(1000 s / 3) ≈ 0.18 m) and the noise's (1 m / √1001 ≈ 0.03 m): 5σ.
ATOL_BIAS_M = 1.0
#: White noise of 1 m: the residual's spread about its trend stays within 0.8..1.2 m.
NOISE_M = (0.8, 1.2)


def test_issue18_shipped_baro_file_matches_its_provenance():
    baro = read_baro_csv(BARO_FILE)
    scenario = get_scenario("curvy")
    assert baro["time_s"].iloc[0] == 0.0 and baro["time_s"].iloc[-1] == scenario.duration_s
    truth = simulate_truth(read_track(TRACKS / "curvy.csv"), scenario.profile,
                           duration_s=scenario.duration_s, rate_hz=1.0,
                           start_s=scenario.start_s)
    np.testing.assert_array_equal(baro["time_s"].to_numpy(), truth.time_s)
    residual = baro["baro_h_m"].to_numpy() - truth.h
    assert residual.mean() == pytest.approx(BIAS_M, abs=ATOL_BIAS_M)
    trend = np.convolve(residual, np.ones(61) / 61, mode="valid")
    spread = np.std(residual[30:-30] - trend)
    assert NOISE_M[0] < spread < NOISE_M[1]
