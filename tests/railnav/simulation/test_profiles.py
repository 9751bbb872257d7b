"""Speed profiles: v = ds/dt and a = dv/dt (central differences), continuity at the
segment joints, closed-form ramp distance (v0 + v1) T / 2, overrides and validation."""
from __future__ import annotations

import numpy as np
import pytest

from railnav.errors import ConfigError
from railnav.simulation.profiles import (
    ProfileSegment,
    SpeedProfile,
    constant_speed,
    station_stop_profile,
)

STEP_S = 1e-4
# Central differences of O(10 km) distances at 1e-4 s: rounding 1e-12 m / 1e-4 s = 1e-8 m/s,
# truncation a''·h²/6 ~ 1e-9: 1e-6 m/s and 1e-6 m/s² leave margin.
ATOL_V_MPS = 1e-6
ATOL_A_MPS2 = 1e-6
ATOL_S_M = 1e-9


@pytest.fixture
def profile():
    return station_stop_profile(cruise_speed_mps=25.0, accel_time_s=60.0, brake_time_s=50.0,
                                cruise_before_stop_s=300.0, dwell_s=60.0, start_dwell_s=10.0)


def test_derivatives_are_consistent(profile):
    t = np.linspace(0.0, 700.0, 7001) + 0.37
    mid, lo, hi = profile.evaluate(t), profile.evaluate(t - STEP_S), profile.evaluate(t + STEP_S)
    np.testing.assert_allclose((hi.s - lo.s) / (2 * STEP_S), mid.v, atol=ATOL_V_MPS)
    np.testing.assert_allclose((hi.v - lo.v) / (2 * STEP_S), mid.a, atol=ATOL_A_MPS2)


def test_joints_are_continuous_up_to_acceleration(profile):
    joints = np.cumsum([g.duration_s for g in profile.segments])
    eps = 1e-9
    before, after = profile.evaluate(joints - eps), profile.evaluate(joints + eps)
    for name, tol in (("s", 1e-6), ("v", 1e-6), ("a", 1e-6)):
        np.testing.assert_allclose(getattr(before, name), getattr(after, name), atol=tol)
    np.testing.assert_allclose(profile.evaluate(joints).a, 0.0, atol=1e-12)


def test_closed_form_distances_and_speeds(profile):
    """Ramp distance (v0+v1)T/2; dwell at 0 m/s; station stop after accel+cruise+brake."""
    out = profile.evaluate(np.array([10.0, 70.0, 370.0, 420.0, 480.0, 540.0, 600.0]))
    expected_s = [0.0, 750.0, 750.0 + 7500.0, 750.0 + 7500.0 + 625.0, 8875.0, 8875.0 + 750.0,
                  8875.0 + 750.0 + 1500.0]
    np.testing.assert_allclose(out.s, expected_s, atol=ATOL_S_M * 1e4)
    np.testing.assert_allclose(out.v, [0, 25, 25, 0, 0, 25, 25], atol=1e-12)
    dwell = profile.evaluate(np.linspace(420.0, 480.0, 61))
    assert np.all(dwell.v == 0.0) and np.all(dwell.a == 0.0)
    peak = profile.evaluate(np.array([10.0 + 30.0])).a[0]
    assert peak == pytest.approx(2 * 25.0 / 60.0, rel=1e-12)  # 2Δv/T


def test_constant_and_scaled():
    c = constant_speed(20.0).evaluate(np.array([0.0, 1000.0]))
    np.testing.assert_allclose(c.s, [0.0, 20000.0])
    scaled = SpeedProfile(5.0, (ProfileSegment(10.0, 10.0),)).scaled_to(30.0)
    assert scaled.initial_speed_mps == 15.0 and scaled.segments[0].end_speed_mps == 30.0
    assert SpeedProfile(0.0).scaled_to(12.0).max_speed_mps == 12.0


@pytest.mark.parametrize("bad", [
    lambda: ProfileSegment(0.0, 10.0),
    lambda: ProfileSegment(5.0, -1.0),
    lambda: SpeedProfile(float("nan")),
    lambda: constant_speed(10.0).evaluate([-1.0]),
    lambda: constant_speed(10.0).scaled_to(0.0),
])
def test_validation(bad):
    with pytest.raises(ConfigError):
        bad()
