"""A curvature step met with a prior in its tail (railnav/filters/step_blend.py).

References: the truth of the simulated trip and the Gaussian 3σ bound of the filter's own
σ_s; the closed-form regression of the interval's ramp over a Gaussian for the lines.

The case is the switch network's (`benchmarks/bench_network_switches.py`, seed 9 at
385.47 s, where the lines fitted once over the chunk's prior left the estimate 4σ off:
`tests/railnav/jobs/test_network_runs.py`): 20 m/s, a straight joined to a 500-m arc
without transition (``v²Δκ`` = 0.8 m/s², the ramp of one sample 0.2 m long in ``s``), no
GNSS, the filter's ``s`` 2.6σ behind the truth with σ_s = 0.075 m. Alone, with the rest
of the state right, the chunk-prior lines met it too (z −0.8 after the step, seeds 1–5;
here +1.0: the straddling sample's line at its tail prior overshoots).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from railnav.config import NavigatorConfig
from railnav.filters.geometry_noise import _XI, blend_parameters
from railnav.filters.track_grid import TrackParameterGrid
from railnav.navigation.initialization import InitialState
from railnav.navigation.navigator import navigate
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import Scenario
from railnav.simulation.trip import navigator_config_for, simulate_trip
from strapdown.imu_errors import imu_grade
from strapdown.reduced import cross_track_basis
from trackmodel.earth import WGS84
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

SPEED_MPS = 20.0
STEP_M = 200.0
KAPPA = 1.0 / 500.0
SIGMA_S_M = 0.075
BEHIND_SIGMAS = 2.6


def _track() -> Track:
    return Track([Section(STEP_M, 90.0, 0.0), Section(300.0, None, None, KAPPA)],
                 Origin(50.45, 30.52, 100.0), WGS84)


def _run(seed: int):
    """The trip from 1 s before the step to 2 s after it, GNSS out, the filter started
    on the truth but ``s`` (2.6σ behind) and ``v`` (σ 5 mm/s)."""
    modelled = replace(imu_grade("tactical"), accel_scale_factor_ppm=0.0,
                       gyro_scale_factor_ppm=0.0, accel_misalignment_rad=0.0,
                       gyro_misalignment_rad=0.0, name="tactical-modelled")
    scenario = Scenario(name="step", profile=constant_speed(SPEED_MPS), duration_s=3.0,
                        imu_errors=modelled, start_s=STEP_M - SPEED_MPS * 1.005)
    trip = simulate_trip(scenario, track=_track(), seed=seed, gnss=False)
    config = navigator_config_for(scenario)

    def start(filt) -> InitialState:
        states, _ = filt.truth_states(trip.truth, *trip.clock_truth(trip.truth.time_s))
        x0 = states[0].copy()
        x0[filt.layout.index("s")] -= BEHIND_SIGMAS * SIGMA_S_M
        P0 = filt.initial_covariance(sigma_s_m=SIGMA_S_M, sigma_v_mps=0.005)
        return InitialState(float(trip.truth.time_s[0]), x0, P0)

    result = navigate(trip.track, trip.sensor_data(), config, initial=start)
    est = result.estimates
    t = est["time_s"].to_numpy()
    truth_s = np.interp(t, trip.truth.time_s, trip.truth.s)
    return t, est["s_m"].to_numpy() - truth_s, est["sigma_s_m"].to_numpy()


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_step_met_in_the_prior_tail_leaves_an_honest_estimate(seed):
    """Past the step (1.5–3 s) the error is within 3σ_s at every output, and the step
    has told ``s`` where it is: within 0.1 m of the truth, 2.6σ = 0.195 m before."""
    t, error, sigma = _run(seed)
    after = t >= 1.5
    assert after.sum() >= 10
    assert np.all(np.abs(error[after]) <= 3.0 * sigma[after]), \
        (error[after] / sigma[after]).round(2)
    assert np.all(np.abs(error[after]) < 0.1)


def test_the_line_is_the_ramp_regression_over_the_given_prior():
    """One sample's line over ``N(s_m, σ²)`` with σ = 0.1 m and 1 m run per sample,
    0.3 m before the step: its value at ``s_m`` and slope are the mean and regression
    slope of the ramp ``κ clip(½ + x, 0, 1)`` (x: the interval's centre past the step, m)
    over that Gaussian, and its remainder variance what the line misses (5 % and the
    8-point staircase's rounding, as the chunk-prior fit's test)."""
    track = Track([Section(1000.0, 10.0, 0.0), Section(800.0, None, None, 1 / 2000)],
                  Origin(47.0, 8.0, 400.0), WGS84)
    grid = TrackParameterGrid(track)
    s_m, sigma, speed = 999.7, 0.1, 25.0
    params, _ = grid.parameters(np.array([s_m]))
    line, var = blend_parameters(grid, params, np.ones(1, dtype=bool), s_m=np.array([s_m]),
                                 sigma_s_m=np.array([sigma]), speed_mps=speed,
                                 interval_m=1.0)
    lateral, _ = cross_track_basis(params[:, 7:10])
    kappa_l = float(grid.parameters(np.array([1000.0 + 1e-3]))[0][0, 10:13] @ lateral[0])
    x = sigma * _XI
    w = np.exp(-0.5 * _XI ** 2)
    w /= w.sum()
    ramp = kappa_l * np.clip(0.5 + (s_m - 1000.0) + x, 0.0, 1.0)
    slope = np.sum(w * ramp * x) / np.sum(w * x * x)
    mean = np.sum(w * ramp)
    at_s = (line[0, 10:13] + line[0, 13:16] * (s_m - params[0, 0])) @ lateral[0]
    assert at_s == pytest.approx(mean, abs=abs(kappa_l) / 16)
    assert line[0, 13:16] @ lateral[0] == pytest.approx(slope, abs=abs(kappa_l) / 16 / sigma)
    missed = speed ** 4 * np.sum(w * (ramp - mean - slope * x) ** 2)
    assert var[0, 0] == pytest.approx(missed, rel=0.05, abs=speed ** 4 * kappa_l ** 2 / 768)
