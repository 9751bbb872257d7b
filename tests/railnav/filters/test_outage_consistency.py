"""σ_s through a GNSS outage that crosses curvature and grade features (issue 14, part 4:
"σ shrinking through a long outage").

The geometry remainder of the pseudo-observation (`railnav.filters.geometry_noise`) is a
function of where the train is against a feature and of the error of ``s``: it stays
correlated while the train runs across the ±σ_s window. Taken as white noise per 100-Hz
sample, a vertical curve or a transition crossed in an outage lent ``s`` a hundred
independent looks a second: on ``curvy`` (tactical IMU, 200-s outage from 60 s) the NEES
mean over the outage was ~2e5 for 7 states and 48 % of the epochs were beyond 3σ_s
(seeds 0-9). Reference: the simulated truth, through the 99 % χ² bands of the mean of
independent NEES values (10 seeds) and of ``(error_s/σ_s)²`` at the outage's end (χ²_1).
"""
from __future__ import annotations

import numpy as np
import pytest

from ekf.consistency import chi2_band
from railnav.filters.geometry_noise import MAX_CORRELATION_S, remainder_correlation_s
from railnav.jobs.run import run_simulated
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from trackmodel.io import read_track

SEEDS = range(10)          # chosen before the runs
OUTAGE = (60.0, 200.0)     # crosses curvy's first vertical curve and first curve


def test_correlation_time_is_the_crossing_time_of_the_window():
    # closed form: 2σ/|v|, at least one step, at most MAX_CORRELATION_S
    assert remainder_correlation_s(sigma_s_m=10.0, speed_mps=25.0, step_s=0.01) == \
        pytest.approx(0.8, rel=1e-12)
    assert remainder_correlation_s(sigma_s_m=0.01, speed_mps=25.0, step_s=0.01) == 0.01
    assert remainder_correlation_s(sigma_s_m=1e4, speed_mps=25.0, step_s=0.01) == \
        MAX_CORRELATION_S
    assert remainder_correlation_s(sigma_s_m=5.0, speed_mps=0.0, step_s=0.01) == \
        MAX_CORRELATION_S


def test_issue14_sigma_s_honest_through_an_outage_over_features():
    track = read_track(TRACKS_DIR / "curvy.csv")
    scenario = get_scenario("curvy").with_overrides(
        duration_s=OUTAGE[0] + OUTAGE[1] + 10.0, outages=[OUTAGE])
    means, z2_end = [], []
    for seed in SEEDS:
        out = run_simulated(track, scenario, seed=seed)
        t = out.result.estimates["time_s"].to_numpy()
        inside = (t >= OUTAGE[0]) & (t < OUTAGE[0] + OUTAGE[1])
        z = out.errors.along_track_m / out.result.estimates["sigma_s_m"].to_numpy()
        means.append(np.nanmean(out.errors.nees[inside]))
        z2_end.append(z[np.flatnonzero(inside)[-1]] ** 2)
    low, high = chi2_band(out.errors.nees_dof, len(SEEDS), 0.99)
    assert low <= np.mean(means) <= high
    low, high = chi2_band(1, len(SEEDS), 0.99)
    assert low <= np.mean(z2_end) <= high
