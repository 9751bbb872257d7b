"""An angular-rate step at a section joint (issue 14, part 4: the high-speed curve NEES).

Reference: the χ² band of the NEES on a circle of 100 m radius entered without a
transition at 100 m/s, with an IMU whose errors the filter models in full (the tactical
grade without scale factors and misalignments), and of the yaw's z² just after the entry.
Once the point samples' 5-mrad yaw jump at the entry, transferred to ``s`` through the
10-g centripetal acceleration, gave a NEES mean of ~1260 for 7 states; it was then given
to the filter as process noise (``joint_noise``, removed). The simulated samples are now
interval means (`railnav.simulation.joint_average`, tested against the closed form in
``tests/railnav/simulation/test_joint_average.py``), which leave no such jump, and the
filter takes the straddling sample's blend as geometry remainder
(`railnav.filters.geometry_noise`, "Interval means").
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ekf.consistency import chi2_band
from railnav.jobs.run import run_simulated
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import Scenario
from strapdown.imu_errors import imu_grade
from trackmodel.earth import WGS84
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

RADIUS_M = 100.0
SPEED_MPS = 100.0


def _circle_track(offset_m: float = 0.0) -> Track:
    """A straight of 1 km + `offset_m`, then three full turns of a 100-m arc (no
    transition), then 1 km of straight."""
    k = 1.0 / RADIUS_M
    sections = [Section(1000.0 + offset_m, 90.0, 0.0)]
    sections += [Section(0.5 * np.pi * RADIUS_M, None, None, k) for _ in range(12)]
    sections.append(Section(1000.0, None, None))
    return Track(sections, Origin(50.45, 30.52, 100.0), WGS84)


def test_issue14_high_speed_circle_nees_inside_band():
    """10 seeds, each with the joint at a uniformly drawn instant inside its sample
    interval (the trip starts at s = 0 at t = 0: a 1-km straight puts the joint on a
    sample). The yaw error just after the entry, in units of the filter's σ, is χ²_1
    (with point samples and no noise for them its mean was ~8: the sampling error is
    2.9 mrad against a 1-mrad σ), and the NEES mean over the circle is inside the 99 %
    band (it was ~1260)."""
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
