"""The sample times of a filter without IMU: the output grid and the epochs, each time once.

The shipped Brussels excerpt has fixes at 2.5 Hz on tenths of a UTC second. As floats
(GPS seconds ~1.3e9 less the trip start) they fall up to ~2e-7 s beside the 10-Hz output
grid's times, which were kept beside them: 745 samples where 597 are due (the run's
``estimates.csv`` had 119 of its 715 rows 0 µs after the one before). The expected times
are counted here in integer microseconds from the file's own labels.
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from gnss_obs.fixes.read import read_fixes
from railnav.config import NavigatorConfig
from railnav.navigation.navigator import _sample_times
from railnav.sensor_data import SensorData
from railnav_data import shipped_path

EXCERPT = shipped_path("fixes", "brussels/log_28876_L36-B_excerpt.csv")


def _expected_us(labels: pd.Series, rate_hz: int) -> list[int]:
    """The fix labels' times and the grid's from the first, µs after the first label."""
    stamps = pd.to_datetime(labels, format="ISO8601").to_numpy().astype("datetime64[us]")
    fixes = (stamps - stamps[0]).astype(np.int64)                 # µs, exact
    step = 1_000_000 // rate_hz
    grid = range(0, int(fixes[-1]), step)                          # [first, last)
    return sorted(set(grid) | set(int(f) for f in fixes))


def test_fix_times_on_the_output_grid_are_one_sample_each():
    log = read_fixes(EXCERPT)
    start = math.floor(log.table["gps_time_s"].iloc[0])
    config = NavigatorConfig(filter="gnss-only")
    t, u = _sample_times(SensorData(start_gps_time_s=float(start), fixes=log), config)
    expected = _expected_us(pd.read_csv(EXCERPT)["timestamp"], round(config.output_rate_hz))
    assert u.shape == (t.size, 0)
    assert t.size == len(expected)
    got = np.round((t - t[0]) * 1e6).astype(np.int64)
    np.testing.assert_array_equal(got, expected)
    assert np.diff(t).min() > 0.05           # no two samples closer than half a grid step
