"""The sampling error of an angular-rate step at a section joint (issue 14, part 4: the
high-speed curve NEES).

References: (1) a Monte Carlo of the error itself — a rate step at a uniformly drawn
instant inside a sample interval, integrated by the linear interpolation of the two
samples (what `ekf.step` does with ``input_hold="linear"``) against the exact integral —
whose variance the process noise must match; (2) the χ² band of the NEES on a circle of
100 m radius entered without a transition at 100 m/s, with an IMU whose errors the filter
models in full (the tactical grade without scale factors and misalignments). Before the
fix the NEES mean over that trip was ~1260 for 7 states (the 5-mrad yaw jump of the
entry, transferred to ``s`` through the 10-g centripetal acceleration).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ekf.consistency import chi2_band
from railnav.filters.joint_noise import JointRateNoise
from railnav.jobs.run import run_simulated
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import Scenario
from strapdown.imu_errors import imu_grade
from trackmodel.earth import WGS84
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

RADIUS_M = 100.0
SPEED_MPS = 100.0
#: Monte Carlo draws, and the tolerance on the variance ratio: 5 standard errors of a
#: sample variance of a uniform variable (kurtosis 1.8: se = sqrt(0.8/N)).
DRAWS = 20_000
RATIO_TOL = 5.0 * np.sqrt(0.8 / DRAWS)


def _circle_track(offset_m: float = 0.0) -> Track:
    """A straight of 1 km + `offset_m`, then three full turns of a 100-m arc (no
    transition), then 1 km of straight."""
    k = 1.0 / RADIUS_M
    sections = [Section(1000.0 + offset_m, 90.0, 0.0)]
    sections += [Section(0.5 * np.pi * RADIUS_M, None, None, k) for _ in range(12)]
    sections.append(Section(1000.0, None, None))
    return Track(sections, Origin(50.45, 30.52, 100.0), WGS84)


def test_joint_variance_is_the_monte_carlo_variance_of_linear_hold():
    track = _circle_track()
    noise = JointRateNoise(track)
    dt = 0.01
    rng = np.random.default_rng(14)
    tau = rng.uniform(0.0, dt, DRAWS)              # instant of the step inside the interval
    d_omega = SPEED_MPS / RADIUS_M                 # rad/s
    exact = d_omega * (dt - tau)                   # ∫ of the step over the interval
    linear = 0.5 * dt * d_omega                    # samples 0 and Δω, interpolated
    mc_var = np.var(linear - exact)
    s = np.array([999.0, 1000.5, 1001.5])
    rows, q = noise.densities(998.0, s, SPEED_MPS, np.full(3, dt))
    assert rows.tolist() == [1]                    # the first step after the joint
    assert q[0, 0] == 0.0                          # no grade step at this joint
    assert q[0, 1] * dt / mc_var == pytest.approx(1.0, abs=RATIO_TOL)


def test_no_noise_on_clothoids_or_straights():
    track = Track([Section(500.0, 0.0, 0.0), Section(100.0, None, None, 0.0, 0.01),
                   Section(100.0, None, None, 0.01, 0.0), Section(500.0, None, None)],
                  Origin(50.0, 30.0, 100.0), WGS84)
    noise = JointRateNoise(track)
    assert noise.densities(0.0, np.linspace(1.0, 1199.0, 50), 20.0, np.full(50, 0.01)) is None


def test_crossed_is_false_only_where_no_shifted_path_crosses():
    """`JointRateNoise.crossed` against `densities` of each shifted path (its own test of
    a crossing): over paths ending on, just short of and just past the circle's first
    joint (1000 m, in ulps), and shifted by ±σ-like offsets, False never where a shifted
    path crosses a joint; True where one does."""
    noise = JointRateNoise(_circle_track())
    joint = float(noise.s_joint_m[0])
    rng = np.random.default_rng(8)
    found = {False: 0, True: 0}
    for end in [joint + k * np.spacing(joint) for k in range(-3, 4)] + \
            list(joint + rng.uniform(-3.0, 3.0, 200)):
        s = np.linspace(end - 0.25, end, 26)
        for offsets in ([0.0], [-1.2, -0.6, 0.0, 0.6, 1.2], list(rng.normal(0.0, 1.0, 5))):
            any_found = any(noise.densities(s[0] - 0.01 + o, s + o, 20.0, np.full(26, 0.01))
                            is not None for o in offsets)
            crossed = noise.crossed(s[0] - 0.01, s, np.array(offsets))
            assert crossed or not any_found
            found[any_found] += 1
    assert found[True] > 100 and found[False] > 100


def test_grade_step_goes_to_the_pitch_axis():
    track = Track([Section(500.0, 0.0, 0.0), Section(300.0, None, None, 0.0, None, 1.0),
                   Section(500.0, None, None)], Origin(50.0, 30.0, 100.0), WGS84)
    rows, q = JointRateNoise(track).densities(499.0, np.array([499.5, 500.5]), 20.0,
                                              np.full(2, 0.01))
    grade_rate = np.radians(1.0) / 300.0
    assert rows.tolist() == [1]
    assert q[0, 1] == 0.0
    assert q[0, 0] == pytest.approx(20.0 ** 2 * grade_rate ** 2 * 0.01 / 12.0, rel=1e-12)


def test_issue14_high_speed_circle_nees_inside_band():
    """10 seeds, each with the joint at a uniformly drawn instant inside its sample
    interval (the trip starts at s = 0 at t = 0: a 1-km straight puts the joint on a
    sample). The yaw error just after the entry, in units of the filter's σ, is χ²_1
    (before the fix its mean was ~8: the sampling error is 2.9 mrad against a 1-mrad σ),
    and the NEES mean over the circle is inside the 99 % band (it was ~1260)."""
    modelled = replace(imu_grade("tactical"), accel_scale_factor_ppm=0.0,
                       gyro_scale_factor_ppm=0.0, accel_misalignment_rad=0.0,
                       gyro_misalignment_rad=0.0, name="tactical-modelled")
    scenario = Scenario(name="circle", profile=constant_speed(SPEED_MPS), duration_s=28.0,
                        imu_errors=modelled)
    seeds = range(1, 11)
    yaw_z2, means = [], []
    for seed in seeds:
        offset_m = float(np.random.default_rng(seed).uniform(0.0, 1.0))  # 1 m: one sample
        out = run_simulated(_circle_track(offset_m), scenario, seed=seed)
        est, errors = out.result.estimates, out.errors
        t = est["time_s"].to_numpy()
        entry_s = (1000.0 + offset_m) / SPEED_MPS
        k = int(np.flatnonzero(t >= entry_s + 0.1)[0])
        yaw_z2.append((errors.yaw_rad[k] / np.radians(est["sigma_yaw_deg"].iloc[k])) ** 2)
        means.append(np.nanmean(errors.nees[t > entry_s]))
    low, high = chi2_band(1, len(seeds), 0.99)
    assert low <= np.mean(yaw_z2) <= high
    low, high = chi2_band(errors.nees_dof, len(seeds), 0.99)
    assert low <= np.mean(means) <= high
