"""The monitor's rejected-row test and the standstill detector's rows
(`railnav.navigation.monitor.FilterMonitor`, `railnav.filters.standstill_rows`).

A MEMS IMU cruising smoothly reads as standing (`tests/railnav/filters/test_standstill.py`):
the detector then adds zero-speed rows the fault screen rejects. Those rejections refute the
detector's guess, not the filter; counted as the filter's rejected rows, the consistency
table's 5-min stop (`benchmarks/bench_consistency.py`) was ``degraded`` on 21 % of its
epochs, every one by that test. The reference: the simulated trip's GNSS errors are white
and fault-free, so the test's tail probability can fall below its threshold only at its
design rate.
"""
from __future__ import annotations

from dataclasses import replace


from railnav.filters.standstill import StandstillConfig
from railnav.jobs.run import run_simulated
from railnav.navigation.monitor_config import MonitorConfig
from railnav.simulation.profiles import station_stop_profile
from railnav.simulation.scenarios import get_scenario
from railnav.simulation.trip import navigator_config_for
from railnav_data import shipped_path
from trackmodel.io import read_track


def test_refuted_standstill_rows_are_not_the_filters_rejections():
    profile = station_stop_profile(cruise_speed_mps=25.0, accel_time_s=60.0,
                                   brake_time_s=50.0, cruise_before_stop_s=100.0,
                                   dwell_s=60.0, start_dwell_s=10.0)
    scenario = replace(get_scenario("curvy"), profile=profile, duration_s=300.0,
                       imu_errors="mems")
    config = replace(navigator_config_for(scenario), standstill=StandstillConfig())
    out = run_simulated(read_track(shipped_path("tracks", "curvy.csv")), scenario,
                        config=config, seed=1)
    inn, monitor = out.result.innovations, out.result.monitor
    refuted = (inn["kind"] == "zero_speed") & (inn["status"] == "rejected")
    assert refuted.sum() >= 10                 # the premise: the detector guessed wrong
    failing = monitor["p_rejected"] < MonitorConfig().p_degraded
    # a consistent filter's test fails at ~p_degraded per epoch (windows overlap: runs)
    assert failing.sum() <= max(1, 10 * MonitorConfig().p_degraded * len(monitor))
