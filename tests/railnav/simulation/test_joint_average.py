"""The simulated IMU across a rate-step joint is the mean over each sample's interval
(`railnav.simulation.joint_average`).

References: (1) the closed form of the angle turned across the entry of an arc at constant
speed, ``∫ω_z dt = Ω_z T − v κ (t_b − t_c)`` (Ω_z the Earth rate's component about the
body's up axis on a level track; the transport rate's ≤ 2e-5 rad/s is below the
tolerance over 0.2 s), against the trapezoid of the samples, as the filter's step
integrates them; (2) each averaged sample against a second method, the midpoint rule of
the point IMU (`ideal_imu`) on 4000 points of its interval.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from railnav.simulation.joint_average import interval_mean_imu, joint_crossing_times
from railnav.simulation.profiles import constant_speed
from railnav.simulation.truth import ideal_imu, simulate_truth, truth_at
from trackmodel.earth import WGS84
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

SPEED_MPS = 100.0
RADIUS_M = 100.0
RATE_HZ = 100.0
ORIGIN = Origin(50.45, 30.52, 100.0)
#: Angle tolerance of the closed form, rad: the transport rate's share (≤ 2e-5 rad/s)
#: over the 0.2-s window, with margin.
ANGLE_TOL_RAD = 1e-5


def _track(straight_m: float) -> Track:
    """A level straight of `straight_m`, then a 100-m arc without transition."""
    return Track([Section(straight_m, 90.0, 0.0), Section(300.0, None, None, 1.0 / RADIUS_M)],
                 ORIGIN, WGS84)


def _imus(straight_m: float):
    track, profile = _track(straight_m), constant_speed(SPEED_MPS)
    truth = simulate_truth(track, profile, duration_s=12.0, rate_hz=RATE_HZ)
    point = ideal_imu(track, truth)
    return track, profile, point, interval_mean_imu(track, profile, point, start_s=0.0,
                                                    rate_hz=RATE_HZ)


def _trapezoid(imu, t_a: float, t_b: float) -> float:
    t, w = imu.time_s, imu.omega_ib_b[:, 2]
    k = (t >= t_a - 1e-9) & (t <= t_b + 1e-9)
    return float(np.trapezoid(w[k], t[k]) if hasattr(np, "trapezoid") else np.trapz(w[k], t[k]))


def _closed_form(track, t_a: float, t_b: float, t_c: float) -> float:
    """``Ω sin φ (t_b − t_a) − v κ (t_b − t_c)`` (curvature + = clockwise: ω_z < 0)."""
    lat = track.at(np.array([SPEED_MPS * t_c])).lat[0]
    return (WGS84.omega_radps * math.sin(lat) * (t_b - t_a)
            - SPEED_MPS / RADIUS_M * (t_b - t_c))


@pytest.mark.parametrize("straight_m", [1000.0, 1000.3, 1000.5, 1000.99])
def test_trapezoid_of_the_samples_turns_the_closed_form_angle(straight_m):
    """On a sample (1000 m), a third of a sample after, half, and just before the next:
    the trapezoid of the interval means is the exact angle; that of point samples is off
    by ``Δω (τ − dt/2)`` for a step ``τ`` after the interval's first sample (the linear
    interpolation against the step; 5 mrad with the joint on a sample)."""
    track, _, point, mean = _imus(straight_m)
    t_c = straight_m / SPEED_MPS
    t_a, t_b = 9.9, 10.2
    exact = _closed_form(track, t_a, t_b, t_c)
    assert _trapezoid(mean, t_a, t_b) == pytest.approx(exact, abs=ANGLE_TOL_RAD)
    dt = 1.0 / RATE_HZ
    # the point sample at t_k = t_c takes the arc's side (the joint's s is the arc's start):
    # the step is then at the end of the interval [t_k − dt, t_k]
    tau = (t_c - 10.0) if t_c > 10.0 + 1e-12 else dt
    d_omega = -SPEED_MPS / RADIUS_M                # clockwise arc: ω_z steps down
    off = d_omega * (tau - dt / 2.0)
    assert _trapezoid(point, t_a, t_b) - exact == pytest.approx(off, abs=ANGLE_TOL_RAD)


@pytest.mark.parametrize("straight_m", [1000.0, 1000.3])
def test_the_averaged_sample_is_the_midpoint_rule_mean_of_the_point_imu(straight_m):
    """Only the sample whose interval holds the crossing changes; it is the mean of the
    point IMU over its interval (4000-point midpoint rule: a step's share to 1/8000)."""
    track, profile, point, mean = _imus(straight_m)
    changed = np.flatnonzero(np.any(mean.f_b != point.f_b, axis=1)
                             | np.any(mean.omega_ib_b != point.omega_ib_b, axis=1))
    t_c = straight_m / SPEED_MPS
    k = int(np.round(t_c * RATE_HZ))
    assert changed.tolist() == [k]
    n = 4000
    times = point.time_s[k] + ((np.arange(n) + 0.5) / n - 0.5) / RATE_HZ
    fine = ideal_imu(track, truth_at(track, profile, times)[0])
    assert mean.f_b[k] == pytest.approx(fine.f_b.mean(axis=0), abs=SPEED_MPS ** 2 / RADIUS_M / n)
    assert mean.omega_ib_b[k] == pytest.approx(fine.omega_ib_b.mean(axis=0),
                                               abs=SPEED_MPS / RADIUS_M / n)


def test_crossing_time_solves_the_profile_for_the_joint():
    track = _track(1000.3)
    t = joint_crossing_times(track, constant_speed(SPEED_MPS), start_s=0.0, t0_s=0.0,
                             t1_s=12.0)
    assert t == pytest.approx([10.003], abs=1e-12)


def test_a_trip_without_rate_steps_is_left_as_point_samples():
    """Clothoids: the rate is continuous, no sample changes (the same object back)."""
    track = Track([Section(500.0, 0.0, 0.0), Section(100.0, None, None, 0.0, 0.01),
                   Section(100.0, None, None, 0.01, 0.0), Section(500.0, None, None)],
                  ORIGIN, WGS84)
    profile = constant_speed(20.0)
    point = ideal_imu(track, simulate_truth(track, profile, duration_s=40.0, rate_hz=RATE_HZ))
    assert interval_mean_imu(track, profile, point, start_s=0.0, rate_hz=RATE_HZ) is point
