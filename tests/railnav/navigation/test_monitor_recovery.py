"""The divergence monitor's recovery (railnav/navigation/monitor_recovery.py): a filter the
monitor finds ``lost`` restarted from the epoch's single-point fix.

References: the simulator's truth, which the filter never sees.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from railnav.simulation.trip import navigator_config_for
from tests.railnav.navigation.test_monitor import _circle_scenario


def ring_restart_run(start_time_s: float = 0.0):
    """The R = 100 m ring at 100 m/s (`_circle_scenario`, seed 1), started at
    `start_time_s` (the straight ends at 10 s) 50 m ahead of the truth with σ_s 1 m and
    recovery on (the default): ``(NavigationResult, Trip)``."""
    from railnav.jobs.run import truth_start
    from railnav.navigation.navigator import navigate
    from railnav.simulation.trip import simulate_trip
    from tests.railnav.filters.test_rate_step_joint import _circle_track
    config = replace(navigator_config_for(_circle_scenario()), initial_s_sigma_m=1.0)
    assert config.monitor.recover
    trip = simulate_trip(_circle_scenario(), track=_circle_track(0.3), seed=1)

    k = int(np.searchsorted(trip.truth.time_s, start_time_s - 1e-9))

    def start(filt):
        x = filt.truth_states(trip.truth, *trip.clock_truth(trip.truth.time_s))[0][k].copy()
        x[filt.layout.index("s")] += 50.0
        return replace(truth_start(filt, trip, config, x_true=x),
                       time_s=float(trip.truth.time_s[k]))
    return navigate(trip.track, trip.sensor_data(), config, initial=start), trip


def test_a_restart_on_a_ring_stays_on_the_filters_lap():
    """`test_monitor`'s offset case with recovery (the default): the track runs round the same
    R = 100 m circle several times, so a single-point fix projects equally near on every
    lap. The restarts take the lap nearest the filter (`TrackFixes.near`): after 12 s the
    along-track error against the simulation's ``s`` stays below 3 m and the run ends
    ``ok`` (a restart on the whole-track projection put ``s`` 1256 m, two laps, ahead at
    11 s: 1384 m off after 12 s, 9 restarts)."""
    result, trip = ring_restart_run()
    est = result.estimates
    err = est["s_m"].to_numpy() - np.interp(est["time_s"], trip.truth.time_s, trip.truth.s)
    assert (result.monitor["action"] == "reinit").sum() >= 1      # it did restart
    assert np.abs(err[est["time_s"].to_numpy() > 12.0]).max() < 3.0
    assert result.final_status == "ok"



def test_a_restart_takes_the_fixs_own_sigma():
    """`ring_restart_run` from 0 s: the monitor restarts the filter once, from the
    single-point fix of the second epoch that disagrees (1 s, on the straight). The
    scenario's start σ (σ_v 0.1 m/s, `navigator_config_for`, for its start from the truth)
    is not the fix's: its speed from the fix's Doppler is 0.41 m/s off. With the fix's own
    σ the restarted speed is within 3σ of the simulation's, and σ_s holds after: ≤ 1 % of
    the estimates beyond 3σ_s against the truth (with the start's σ: 80 %, |error| 3 m at
    σ_s 0.9 m on the straight, then 0.26 m at 0.07 m to the end, ``ok``)."""
    result, trip = ring_restart_run()
    restarts = result.monitor.loc[result.monitor["action"] == "reinit", "time_s"]
    assert list(restarts) == [1.0]
    est = result.estimates
    after = est[est["time_s"] > 1.0]
    first = after.iloc[0]
    v_true = np.interp(first["time_s"], trip.truth.time_s, trip.truth.v)
    assert abs(first["speed_mps"] - v_true) <= 3.0 * first["sigma_speed_mps"]
    err = after["s_m"].to_numpy() - np.interp(after["time_s"], trip.truth.time_s,
                                              trip.truth.s)
    assert np.mean(np.abs(err) > 3.0 * after["sigma_s_m"].to_numpy()) <= 0.01


@pytest.mark.parametrize("p_lost", [1e-3, 1e-6, 1e-12])
def test_the_fix_test_without_its_worst_cannot_fail_below_the_skip_value(p_lost):
    """`FilterMonitor._status` skips the fix test without the window's worst epoch (it only
    decides ``lost``) where both its statistics lie below `FilterMonitor._lost_below`:
    there, scipy's doubled χ² tails of either, with 1 to 60 degrees of freedom, are above
    p_lost, so the test could not have failed."""
    from railnav.navigation.monitor import FilterMonitor
    from railnav.navigation.monitor_config import MonitorConfig
    from ekf.layout import StateLayout
    layout = StateLayout.from_blocks([("s", ["s"]), ("v", ["v"])])
    below = FilterMonitor(layout, None, MonitorConfig(p_lost=p_lost), None)._lost_below
    assert 0.0 < below < stats.chi2.isf(p_lost / 2, 1)
    assert (2 * stats.chi2.sf(below, np.arange(1, 61)) > p_lost).all()
