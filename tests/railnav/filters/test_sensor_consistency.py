"""NEES consistency of the railway sensor models (issue 17) on simulated trips, over seeds.

Each run is a ``curvy`` trip (a 10-s stop, then accelerating to 25 m/s along curves and a
grade) whose odometer, balises or antenna are simulated by `railnav.simulation.
track_sensors` and written and read back as files (`railnav.sensors`); the filter assumes
what was simulated. One NEES per run at `NEES_TIME_S`, inside a GNSS outage (the sensors
alone aid the filter there), on every state the simulation knows, the odometer's scale
factor included (its truth is the drawn wheel error). Reference: the 95 % χ² band of the
mean of independent NEES values (`ekf.consistency.chi2_band`), the truth from the
simulator. The lever-arm test has a control: the same runs with a filter that ignores the
arm must fall outside the band.
"""
from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import pytest

from ekf.consistency import chi2_band
from ekf.packing import unpack_sym
from railnav.filters.odometer_epochs import OdometerConfig
from railnav.filters.track_frame import LeverArms
from railnav.jobs.run import truth_start
from railnav.navigation.navigator import navigate
from railnav.sensor_data import SensorData
from railnav.sensors.balises import read_balises_csv, write_balises_csv
from railnav.sensors.odometer import read_odometer_csv, write_odometer_csv
from railnav.simulation.fixes import FixSimConfig, trip_fixes
from railnav.simulation.scenarios import get_scenario
from railnav.simulation.track_sensors import (
    BaliseSimConfig,
    OdometerSimConfig,
    simulate_balises,
    simulate_odometer,
)
from railnav.simulation.trip import navigator_config_for, simulate_trip

SEEDS = range(10)          # chosen before the runs
OUTAGE = (40.0, 40.0)
#: One NEES time per run: 30 s into the outage (speeds 10-20 m/s, curves).
NEES_TIME_S = 70.0
ODOMETER = OdometerSimConfig(rate_hz=5.0, sigma_mps=0.05, scale_sigma=0.02)
BALISES = BaliseSimConfig(spacing_m=150.0, first_m=100.0, sigma_m=0.5)
ARM = (3.0, -1.2, 4.1)
MIX = (("rtk_float", 0.5), ("dgps", 0.5))


def _scenario(antenna=(0.0, 0.0, 0.0)):
    return replace(get_scenario("curvy"), duration_s=90.0, outages=(OUTAGE,), antenna_m=antenna)


def _files(trip, folder, *, odometer: bool, balises: bool) -> dict:
    out = {}
    if odometer:
        odo = simulate_odometer(trip, ODOMETER)
        write_odometer_csv(folder / "odo.csv", odo["time_s"], speed_mps=odo["speed_mps"])
        out["odometer"] = (read_odometer_csv(folder / "odo.csv"), odo["scale_error"])
    if balises:
        bal = simulate_balises(trip, BALISES)
        write_balises_csv(folder / "bal.csv", bal["time_s"], bal["s_m"], sigma_m=bal["sigma_m"])
        out["balises"] = read_balises_csv(folder / "bal.csv")
    return out


def _nees(result, trip, scale_error: float | None) -> tuple[float, int]:
    """NEES at `NEES_TIME_S` on the states the simulation knows (+ the wheel's scale)."""
    filt = result.filter_object
    k = int(np.argmin(np.abs(result.time_s - NEES_TIME_S)))
    j = int(np.argmin(np.abs(trip.truth.time_s - result.time_s[k])))
    assert abs(trip.truth.time_s[j] - result.time_s[k]) < 1e-6
    x_true, known = filt.truth_states(trip.truth, *trip.clock_truth(trip.truth.time_s))
    x_true = x_true[j].copy()
    names = list(result.layout.names)
    if scale_error is not None:
        x_true[names.index("odo_scale")], known[names.index("odo_scale")] = scale_error, True
    idx = np.flatnonzero(known)
    err = result.x[k, idx] - x_true[idx]
    if "yaw" in names and names.index("yaw") in idx:
        i = list(idx).index(names.index("yaw"))
        err[i] = (err[i] + np.pi) % (2 * np.pi) - np.pi
    P = unpack_sym(result.P[k])[np.ix_(idx, idx)]
    return float(err @ np.linalg.solve(P, err)), int(idx.size)


def _run(seed, tmp_path, *, filter, odometer=False, balises=False, antenna=(0, 0, 0),
         filter_antenna=None):
    scenario = _scenario(antenna)
    trip = simulate_trip(scenario, seed=seed, gnss=filter == "constrained")
    files = _files(trip, tmp_path, odometer=odometer, balises=balises)
    config = navigator_config_for(scenario, filter=filter, odometer_model=OdometerConfig(
        sigma_speed_mps=ODOMETER.sigma_mps, scale_sigma=ODOMETER.scale_sigma))
    if filter_antenna is not None:
        config = replace(config, lever_arms=LeverArms(antenna_m=filter_antenna))
    data = {"imu": trip.simulation.imu_measured, "obs": trip.gnss.obs, "nav": trip.nav} \
        if filter == "constrained" else {"fixes": trip_fixes(trip, FixSimConfig(quality_mix=MIX))}
    data = SensorData(scenario.start_gps_time_s, **data,
                      odometer=files.get("odometer", (None,))[0], balises=files.get("balises"))
    result = navigate(trip.track, data, config, outages=scenario.outages,
                      initial=functools.partial(truth_start, trip=trip, config=config))
    return result, _nees(result, trip, files["odometer"][1] if odometer else None)


def _assert_consistent(runs, dof):
    nees = [n for _, (n, d) in runs]
    assert {d for _, (_, d) in runs} == {dof}
    low, high = chi2_band(dof, len(nees))
    assert low <= np.mean(nees) <= high, (np.mean(nees), low, high)
    return np.mean(nees)


def _nis_mean(runs, kinds):
    nis = np.concatenate([r.innovations.loc[r.innovations["kind"].isin(kinds)
                                            & r.innovations["accepted"], "nis"].to_numpy()
                          for r, _ in runs])
    low, high = chi2_band(1, nis.size)
    assert low <= nis.mean() <= high, (nis.mean(), low, high, nis.size)


@pytest.mark.slow
def test_constrained_filter_with_odometer_is_consistent(tmp_path):
    """IMU + pseudoranges + odometer with its scale state: NEES of attitude, s, v, clock and
    the scale (dof 8) through 30 s of odometer-only aiding, and the moving odometer rows'
    NIS."""
    runs = [_run(seed, tmp_path, filter="constrained", odometer=True) for seed in SEEDS]
    _assert_consistent(runs, dof=8)
    _nis_mean(runs, ("odo_speed",))
    # a standstill reading has no error at all (the wheel stands, the vehicle too): the
    # zero-speed row's σ is a bound, its NIS well below 1 (measured 0.02 over 4 seeds)
    zero = np.concatenate([r.innovations.loc[r.innovations["kind"] == "odo_zero_speed",
                                             "nis"].to_numpy() for r, _ in runs])
    assert zero.size > 100 and zero.mean() < 0.5


def test_gnss_only_filter_with_odometer_and_balises_is_consistent(tmp_path):
    """Fixes + odometer + balises every 150 m on the GNSS-only filter: NEES of s, v and the
    scale (dof 3), and the balise rows' NIS."""
    runs = [_run(seed, tmp_path, filter="gnss-only", odometer=True, balises=True)
            for seed in SEEDS]
    _assert_consistent(runs, dof=3)
    _nis_mean(runs, ("balise",))


@pytest.mark.slow
def test_antenna_lever_arm_is_consistent_and_needed(tmp_path):
    """GNSS simulated at an antenna 3 m ahead, 1.2 m right and 4.1 m above the reference
    point: the filter told the arm is consistent (dof 7); told nothing, it is not."""
    told = [_run(seed, tmp_path, filter="constrained", antenna=ARM) for seed in SEEDS]
    _assert_consistent(told, dof=7)
    blind = [_run(seed, tmp_path, filter="constrained", antenna=ARM, filter_antenna=(0, 0, 0))
             for seed in SEEDS]
    assert np.mean([n for _, (n, _) in blind]) > chi2_band(7, len(blind))[1]
