"""Non-uniform IMU samples (issue 17): a jittered log with dropouts filters to the same result
as the uniform record of the same motion.

Reference: the uniform run of the same trip, GNSS data and start; both IMU records are the
exact ideal IMU of the trajectory at their own instants (`railnav.simulation.imu_logs` with
no sensor errors), so any difference is the filter's handling of the steps. Stated
tolerance: 1 mm in ``s``, 0.2 mm/s in ``v``, 0.5 mm in ``σ_s`` at every GNSS epoch, and 1 mm
/ 0.1 mm/s through a 30-s outage, for ±1 ms jitter at 100 Hz and 30 dropouts of 5 samples
(measured: 0.43 mm, 0.08 mm/s, 0.17 mm at the epochs; 0.12 mm, 0.02 mm/s in the outage).
The run's own errors are ~1 m: the tolerance is a thousandth of them.
"""
from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import pytest

from railnav.filters.constrained import ConstrainedFilter
from railnav.jobs.run import truth_start
from railnav.navigation.navigator import navigate
from railnav.sensor_data import SensorData
from railnav.simulation.imu_logs import ImuLogSimConfig, simulate_imu_log
from railnav.simulation.scenarios import get_scenario
from railnav.simulation.trip import navigator_config_for, simulate_trip
from strapdown.imu_log import read_imu_log

OUTAGE = (60.0, 30.0)


@pytest.fixture(scope="module")
def trip():
    scenario = replace(get_scenario("curvy"), duration_s=120.0, outages=(OUTAGE,))
    return simulate_trip(scenario, seed=3)


def _run(trip, imu):
    config = replace(navigator_config_for(trip.scenario), output_rate_hz=100.0)  # every step
    data = SensorData(trip.scenario.start_gps_time_s, imu=imu, obs=trip.gnss.obs, nav=trip.nav)
    return navigate(trip.track, data, config, outages=trip.scenario.outages,
                    initial=functools.partial(truth_start, trip=trip, config=config)).estimates


def _rows_at(est, times):
    i = np.searchsorted(est["time_s"].to_numpy(), times - 1e-6)
    assert np.all(np.abs(est["time_s"].to_numpy()[i] - times) < 1e-6)
    return est.iloc[i]


def test_jittered_log_filters_like_the_uniform_record(trip, tmp_path):
    jittered = simulate_imu_log(trip, ImuLogSimConfig(jitter_s=1e-3, dropouts=30,
                                                      dropout_samples=5), errors="perfect")
    path = tmp_path / "imu.csv"
    jittered.to_frame().to_csv(path, index=False, float_format="%.17g")
    log = read_imu_log(path)
    assert log.dropped_samples == 150 and len(log.gaps) == 30
    np.testing.assert_array_equal(log.imu.f_b, jittered.f_b)
    uniform, jit = _run(trip, trip.simulation.imu_ideal), _run(trip, log.imu)
    epochs = np.arange(1.0, 120.0)
    epochs = epochs[(epochs < OUTAGE[0]) | (epochs > OUTAGE[0] + OUTAGE[1])]
    a, b = _rows_at(uniform, epochs), _rows_at(jit, epochs)
    for column, tol in (("s_m", 1e-3), ("speed_mps", 2e-4), ("sigma_s_m", 5e-4)):
        assert np.max(np.abs(a[column].to_numpy() - b[column].to_numpy())) < tol, column
    t = trip.truth.time_s
    inside = (t > OUTAGE[0] + 0.1) & (t < OUTAGE[0] + OUTAGE[1])
    for column, tol in (("s_m", 1e-3), ("speed_mps", 1e-4)):
        ua = np.interp(t[inside], uniform["time_s"], uniform[column])
        ja = np.interp(t[inside], jit["time_s"], jit[column])
        assert np.max(np.abs(ua - ja)) < tol, column


def test_geometry_density_uses_the_nominal_interval(trip):
    """A chunk of one short step (an epoch inserted just after another) gets the same
    geometry noise density as a full one: variance × the run's nominal interval."""
    config = navigator_config_for(trip.scenario)
    filt = ConstrainedFilter(trip.track, config, None)
    filt.sample_interval_s = 0.01
    x0 = np.zeros(filt.layout.size)
    x0[filt.layout.index("s")], x0[filt.layout.index("v")] = 500.0, 20.0
    P0 = np.diag(np.full(filt.layout.size, 1e-4))
    P0[filt.layout.index("s"), filt.layout.index("s")] = 4.0
    u = np.array([[0.0, 0.0, 9.81, 0.0, 0.0, 0.0]])
    short = filt.inputs(np.array([10.003]), u, x0, P0, 10.0)[2]
    full = filt.inputs(np.array([10.01]), u, x0, P0, 10.0)[2]
    np.testing.assert_allclose(short, full, rtol=1e-6)
    filt.sample_interval_s = None                 # without it: the chunk's own step
    np.testing.assert_allclose(filt.inputs(np.array([10.003]), u, x0, P0, 10.0)[2],
                               full * 0.3, rtol=1e-6)
