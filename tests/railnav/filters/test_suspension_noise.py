"""The sampling error of a car body's suspension rates (`railnav.filters.suspension_noise`;
issue 14, part 1: the NEES must stay consistent on trips with suspension motion).

References: (1) the simulator's suspension (`railnav.simulation.car_body_motion`, its own
implementation of the oscillator, sampled exactly): the angle between two of its samples
against the trapezoid of its two rate samples (what `ekf.step` integrates with
``input_hold="linear"``), whose variance per step the filter's density times the step must
match; (2) the χ² band of the NEES through a GNSS outage on ``curvy`` with the car body,
the tactical IMU and the attitude rows (a 120-s outage, seeds 0-9). Without the density
the NEES mean over the outage was 19.6 for 10 states, above the band's upper end 14.0
(9.4 with it).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ekf.consistency import chi2_band
from railnav.filters.attitude_config import TrackAttitudeConfig
from railnav.filters.suspension_noise import sampling_densities
from railnav.jobs.run import run_simulated
from railnav.simulation.car_body_config import CarBodyMotion
from railnav.simulation.car_body_motion import suspension_angles
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for
from trackmodel.io import read_track

DURATION_S = 600.0
#: Tolerance on the ratio of the measured to the modelled variance per step: 5 standard
#: errors of the sample variance of N ≥ 60 000 Gaussian values, sqrt(2/N) (the missed
#: angles are independent from step to step), plus ~(ω₀ dt)² ≈ 4e-3 relative for the
#: smooth part of the rate, which the trapezoid integrates to third order.
RATIO_TOL = 5.0 * np.sqrt(2.0 / 60_000) + 4e-3
SEEDS = range(10)              # chosen before the runs
OUTAGE = (100.0, 120.0)        # cruising at 25 m/s through curvy's curves


@pytest.mark.parametrize("speed_mps, step_s", [(25.0, 0.01), (5.0, 0.01), (25.0, 0.005)])
def test_density_is_the_variance_the_trapezoid_misses(speed_mps, step_s):
    """At full motion and at ``v_f`` (amplitude factor 1 − 1/e), at 100 and 200 Hz."""
    motion, config = CarBodyMotion(), TrackAttitudeConfig()
    t = np.arange(0.0, DURATION_S, step_s)
    angle, rate = suspension_angles(t, np.full(t.size, speed_mps), np.zeros(t.size), motion,
                                    np.random.default_rng(14))
    missed = np.diff(angle, axis=0) - 0.5 * step_s * (rate[1:] + rate[:-1])
    measured = missed.var(axis=0)[::-1]                   # roll, pitch, yaw: gyro x, y, z
    modelled = sampling_densities(config, np.array([step_s]), speed_mps)[0] * step_s
    np.testing.assert_allclose(measured / modelled, 1.0, atol=RATIO_TOL)


def test_no_density_at_a_standstill():
    """The simulated body does not move at a standstill (its amplitude factor is 0)."""
    assert np.all(sampling_densities(TrackAttitudeConfig(), np.array([0.01]), 0.0) == 0.0)


@pytest.mark.parametrize("rows", [True, False], ids=["attitude_rows", "no_rows"])
def test_issue14_nees_with_a_car_body_tactical(rows):
    """With the attitude rows, or without them and the density alone
    (``NavigatorConfig.suspension_noise``, which `navigator_config_for` sets for a
    scenario with a car body): without the density the NEES mean over the outage was
    19.6 for 10 states with the rows (band [6.7, 14.0]) and 16.0 for 7 without them (band
    [4.3, 10.4]; 7.0 with it)."""
    track = read_track(TRACKS_DIR / "curvy.csv")
    scenario = replace(get_scenario("curvy").with_overrides(
        duration_s=OUTAGE[0] + OUTAGE[1] + 10.0, outages=[OUTAGE], imu_errors="tactical"),
        car_body=CarBodyMotion())
    config = navigator_config_for(scenario)
    assert config.suspension_noise
    if rows:
        config = replace(config, track_attitude=TrackAttitudeConfig())
    means = []
    for seed in SEEDS:
        out = run_simulated(track, scenario, config=config, seed=seed)
        t = out.result.estimates["time_s"].to_numpy()
        inside = (t >= OUTAGE[0]) & (t < OUTAGE[0] + OUTAGE[1])
        means.append(np.nanmean(out.errors.nees[inside]))
    low, high = chi2_band(out.errors.nees_dof, len(SEEDS), 0.99)
    assert low <= np.mean(means) <= high
