"""Scenarios: the paper's numbers (SEEDS.md §1), overrides, validation, reproducible and
independent random streams, JSON-ready parameters, the GPS start time."""
from __future__ import annotations

import datetime as dt
import json
from dataclasses import replace

import numpy as np
import pytest

from railnav.errors import ConfigError
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import (
    DEFAULT_START_GPS_TIME_S,
    SCENARIOS,
    Scenario,
    get_scenario,
    scenario_to_dict,
    simulate_scenario,
)
from trackmodel.earth import sphere
from trackmodel.io import write_track
from trackmodel.sections import Section
from trackmodel.track import Track


@pytest.fixture(scope="module")
def short_track():
    return Track.from_sections([Section(5000.0, 30.0, 3.0)], lat=0.88, lon=0.53, h=100.0,
                               earth=sphere())


def test_paper2017_scenario_has_the_papers_numbers():
    """Dolgiy et al. 2017: 1000 s, 100 Hz, 20 m/s, accel (1e-5 m/s²)²·s, σ² 15 m² and
    0.5 (m/s)², outages of 50 s at 100 s and 500 s."""
    sc = get_scenario("paper2017")
    assert sc.duration_s == 1000.0 and sc.imu_rate_hz == 100.0
    assert sc.profile.evaluate([0.0, 999.0]).v.tolist() == [20.0, 20.0]
    assert sc.imu.accel_noise_density_mps2_rthz ** 2 == pytest.approx(1e-10, rel=1e-12)
    assert sc.sigma_pseudorange_m ** 2 == pytest.approx(15.0)
    assert sc.sigma_range_rate_mps ** 2 == pytest.approx(0.5)
    assert sc.outages == ((100.0, 50.0), (500.0, 50.0))
    assert set(SCENARIOS) >= {"paper2017", "curvy"}


def test_curvy_has_a_station_stop():
    sc = get_scenario("curvy")
    v = sc.profile.evaluate(np.arange(0.0, sc.duration_s, 0.5)).v
    moving = v > 0
    assert moving.any() and (np.diff(moving.astype(int)) == -1).sum() >= 1  # stops once
    assert sc.imu.name == "tactical"


def test_start_time_is_2020_11_29_1240_gpst():
    expected = (dt.datetime(2020, 11, 29, 12, 40) - dt.datetime(1980, 1, 6)).total_seconds()
    assert DEFAULT_START_GPS_TIME_S == expected


def test_overrides_and_validation():
    sc = get_scenario("curvy").with_overrides(speed_mps=10.0, duration_s=50.0)
    assert sc.profile.max_speed_mps == 10.0 and sc.duration_s == 50.0
    for bad in (dict(duration_s=-1.0), dict(outages=((10.0, 0.0),)), dict(imu_errors="nope"),
                dict(imu_rate_hz=float("nan"))):
        with pytest.raises(ConfigError):
            replace(sc, **bad)
    with pytest.raises(ConfigError, match="unknown scenario"):
        get_scenario("nope")


def test_simulation_is_reproducible_and_streams_are_independent(short_track):
    sc = Scenario("t", constant_speed(20.0), 30.0, imu_errors="tactical")
    a = simulate_scenario(sc, track=short_track, seed=7)
    b = simulate_scenario(sc, track=short_track, seed=7)
    c = simulate_scenario(sc, track=short_track, seed=8)
    np.testing.assert_array_equal(a.imu_measured.f_b, b.imu_measured.f_b)
    assert not np.array_equal(a.imu_measured.f_b, c.imu_measured.f_b)
    np.testing.assert_array_equal(a.imu_ideal.f_b, c.imu_ideal.f_b)
    # The IMU stream is child 0 of SeedSequence(seed): the same for any scenario length.
    longer = simulate_scenario(replace(sc, duration_s=40.0), track=short_track, seed=7)
    assert longer.rng_streams[1].entropy == a.rng_streams[1].entropy
    perfect = simulate_scenario(replace(sc, imu_errors="perfect"), track=short_track, seed=7)
    assert perfect.imu_measured is perfect.imu_ideal


def test_track_from_file_and_json(tmp_path, short_track):
    path = tmp_path / "t.csv"
    write_track(short_track, path)
    sc = Scenario("t", constant_speed(20.0), 10.0, imu_errors="mems", outages=((1, 2),))
    res = simulate_scenario(sc, track=path, seed=0)
    assert len(res.truth.time_s) == 1001
    data = json.loads(json.dumps(scenario_to_dict(sc)))
    assert data["imu_errors"]["name"] == "mems" and data["outages"] == [[1.0, 2.0]]
    with pytest.raises(ConfigError, match="seed"):
        simulate_scenario(sc, track=short_track, seed=-1)
