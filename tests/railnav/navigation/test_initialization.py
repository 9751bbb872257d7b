"""Simulated starts (railnav/navigation/initialization.py `initial_from_truth`, railnav/jobs/run.py
`truth_start`): the start error must have the filter's own initial covariance.

References: the Gaussian draw's covariance checked by the chi-square mean of
``eᵀ P0⁻¹ e``; the IMU biases' truth drawn by the IMU simulator
(`strapdown.imu_errors.apply_imu_errors`, independent of the filter) against the
filter's prior variance of those biases.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from railnav.filters.protocol import make_filter
from railnav.jobs.run import truth_start
from railnav.navigation.initialization import initial_from_truth
from railnav.simulation.scenarios import get_scenario
from railnav.simulation.trip import navigator_config_for, simulate_trip
from strapdown.imu import Imu
from strapdown.imu_errors import IMU_GRADES, apply_imu_errors

#: Monte Carlo draws, and the accepted deviation of a mean of chi-square(1) variables from
#: 1: five standard deviations of that mean (σ = √(2 / samples)).
DRAWS = 2000
Z_SIGMAS = 5.0


def _chi2_mean_tolerance(samples: int) -> float:
    return Z_SIGMAS * math.sqrt(2.0 / samples)


def test_drawn_components_have_covariance_P0_and_the_others_start_at_the_prior_mean(rng):
    n = 5
    a = rng.normal(size=(n, n))
    P0 = np.zeros((n, n))
    P0[:3, :3] = a[:3, :3] @ a[:3, :3].T + 0.1 * np.eye(3)   # correlated drawn block
    P0[3:, 3:] = np.diag([4.0, 0.25])
    drawn = np.array([True, True, True, False, False])
    x_true = np.array([1.0, -2.0, 3.0, 0.0, 0.0])
    errors = np.array([initial_from_truth(x_true, P0, time_s=0.0, rng=rng, drawn=drawn).x0
                       for _ in range(DRAWS)]) - x_true
    assert np.all(errors[:, 3:] == 0.0)
    z2 = np.einsum("ki,ij,kj->k", errors[:, :3], np.linalg.inv(P0[:3, :3]), errors[:, :3]) / 3
    assert abs(z2.mean() - 1.0) < _chi2_mean_tolerance(3 * DRAWS)


def test_without_a_mask_every_component_is_drawn(rng):
    P0 = np.diag([1.0, 9.0])
    errors = np.array([initial_from_truth(np.zeros(2), P0, time_s=0.0, rng=rng).x0
                       for _ in range(DRAWS)])
    z2 = (errors ** 2 / np.diag(P0)).mean(axis=0)
    assert np.all(np.abs(z2 - 1.0) < _chi2_mean_tolerance(DRAWS))


@pytest.fixture(scope="module")
def tactical_start():
    # with_overrides: a 5-s trip drops the scenario's outages at 100 s and 500 s (issue 18:
    # an outage after the end of a trip that ran its whole duration is refused)
    scenario = get_scenario("paper2017").with_overrides(duration_s=5.0, imu_errors="tactical")
    trip = simulate_trip(scenario, seed=3)
    config = navigator_config_for(scenario)
    filt = make_filter(trip.track, config, None)
    return filt, trip, config, truth_start(filt, trip, config)


def test_imu_biases_start_at_the_prior_mean_and_known_states_are_drawn(tactical_start):
    filt, trip, _, start = tactical_start
    x_true, known = filt.truth_states(trip.truth, *trip.clock_truth(trip.truth.time_s))
    bias = [filt.layout.index(name) for name in filt.layout.names if name.startswith("b_")]
    assert len(bias) == 6 and not known[bias].any()
    assert np.all(start.x0[bias] == 0.0)
    assert np.all(start.x0[known] != x_true[0][known])


def test_simulated_bias_truth_has_the_filters_prior_variance(tactical_start, rng):
    """The error of a bias that starts at 0 is minus the simulated bias: its variance over
    trips must be the filter's prior variance (a second draw would double it)."""
    filt, _, _, start = tactical_start
    quiet = replace(IMU_GRADES["tactical"], accel_noise_density_mps2_rthz=0.0,
                    gyro_noise_density_radps_rthz=0.0, accel_scale_factor_ppm=0.0,
                    gyro_scale_factor_ppm=0.0, accel_misalignment_rad=0.0,
                    gyro_misalignment_rad=0.0)
    zero = Imu(time_s=np.array([0.0, 0.01]), f_b=np.zeros((2, 3)), omega_ib_b=np.zeros((2, 3)))
    first = np.array([np.concatenate([(m := apply_imu_errors(zero, quiet, rng)).f_b[0],
                                      m.omega_ib_b[0]]) for _ in range(DRAWS)])
    names = ["b_ax", "b_ay", "b_az", "b_gx", "b_gy", "b_gz"]
    var = np.diag(start.P0)[[filt.layout.index(n) for n in names]]
    z2 = (first ** 2 / var).mean(axis=0)
    assert np.all(np.abs(z2 - 1.0) < _chi2_mean_tolerance(DRAWS))
