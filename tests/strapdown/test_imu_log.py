"""Recorded IMU logs (issue 17): jittered times, gaps, increments, units, mounting, the TOML
spec and the plausibility checks. Each expected value is computed here independently (closed
forms of the motion, the unit factors written out, rotation matrices built by hand)."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from strapdown.errors import ImuInputError
from strapdown.imu import IMU_COLUMNS, read_imu_csv
from strapdown.imu_checks import check_imu_plausible
from strapdown.imu_log import read_imu_log
from strapdown.imu_spec import ImuSpec, imu_spec_from_dict, read_imu_spec

G = 9.80665


def _write(path, t, f, w, columns=IMU_COLUMNS):
    frame = pd.DataFrame(np.column_stack([t, f, w]), columns=list(columns))
    frame.to_csv(path, index=False, float_format="%.17g")
    return path


def _level(n, rng=None):
    """A level, standing vehicle: f = (0, 0, g), small rates."""
    f = np.tile([0.0, 0.0, G], (n, 1))
    w = np.zeros((n, 3)) if rng is None else rng.normal(scale=1e-4, size=(n, 3))
    return f, w


def test_jittered_log_keeps_its_times_and_reports_gaps(tmp_path, rng):
    n = 2000
    t = np.arange(n) * 0.005 + rng.uniform(-2e-4, 2e-4, n)      # 200 Hz, ±0.2 ms jitter
    keep = np.ones(n, dtype=bool)
    keep[100:105] = False          # 5 dropped samples: a 30-ms step
    keep[1000:1040] = False        # 40 dropped: a 205-ms gap
    before = t[[99, 999]]          # the samples before the two gaps
    t = t[keep]
    f, w = _level(t.size, rng)
    log = read_imu_log(_write(tmp_path / "imu.csv", t, f, w))
    np.testing.assert_array_equal(log.imu.time_s, t)
    assert log.dropped_samples == 45
    assert log.nominal_interval_s == pytest.approx(0.005, rel=1e-3)
    starts = [g[0] for g in log.gaps]
    assert starts == list(before)             # both steps of >= 5 intervals, nothing else
    assert log.gaps[1][1] == pytest.approx(t[995] - t[994])
    assert 1e-4 < log.step_jitter_s < 2e-4    # uniform ±0.2 ms: step RMS 0.2/√6·√2 ms
    assert read_imu_csv(tmp_path / "imu.csv").time_s.size == t.size


def test_units_are_converted_to_si(tmp_path, rng):
    n = 300
    t = np.arange(n) * 0.01
    f = np.column_stack([rng.normal(0, 0.3, n), rng.normal(0, 0.3, n), G + rng.normal(0, .1, n)])
    w = rng.normal(0, 0.05, (n, 3))
    cols = ("t_ms", "ax", "ay", "az", "gx", "gy", "gz")
    _write(tmp_path / "log.csv", t * 1000.0, f / G, np.degrees(w), cols)
    spec = ImuSpec(time_column="t_ms", accel_columns=("ax", "ay", "az"),
                   gyro_columns=("gx", "gy", "gz"), time_unit="ms", accel_unit="g",
                   gyro_unit="deg/s")
    imu = read_imu_log(tmp_path / "log.csv", spec).imu
    np.testing.assert_allclose(imu.time_s, t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(imu.f_b, f, rtol=1e-14)
    np.testing.assert_allclose(imu.omega_ib_b, w, rtol=1e-14)


def test_increments_become_midpoint_rates(tmp_path):
    """f(t) = a + b t + c t²: the mean over [t0, t1] is the midpoint value + c Δt²/12."""
    a, b, c = 0.3, 0.2, 0.05
    t = np.arange(1, 401) * 0.005
    t[200:] += 0.02                               # 4 samples dropped before row 201
    F = lambda x: a * x + b * x ** 2 / 2 + c * x ** 3 / 3   # noqa: E731  antiderivative
    prev = np.concatenate([[t[0] - 0.005], t[:-1]])
    prev[200] = t[200] - 0.005                    # after the dropout: one nominal interval
    dv = F(t) - F(prev)
    dv3 = np.column_stack([dv, np.zeros_like(dv), np.full_like(dv, G * 0.005)])
    dtheta = np.tile([0.0, 0.0, 0.001 * 0.005], (t.size, 1))   # 1 mrad/s yaw
    _write(tmp_path / "inc.csv", t, dv3, dtheta)
    log = read_imu_log(tmp_path / "inc.csv", ImuSpec(kind="increments", rate_hz=200.0))
    mid = (t + prev) / 2
    np.testing.assert_allclose(log.imu.time_s, mid, atol=1e-12)
    expected = a + b * mid + c * mid ** 2 + c * (t - prev) ** 2 / 12
    np.testing.assert_allclose(log.imu.f_b[:, 0], expected, rtol=1e-9)
    np.testing.assert_allclose(log.imu.omega_ib_b[:, 2], 0.001, rtol=1e-12)
    assert log.dropped_samples == 4


def test_mounting_axes_and_rotation(tmp_path):
    n = 200
    t = np.arange(n) * 0.01
    # an FRD sensor (x forward, y right, z down) on a level vehicle turning left at 0.1 rad/s
    f_s = np.tile([0.5, 0.2, -G], (n, 1))
    w_s = np.tile([0.0, 0.0, -0.1], (n, 1))
    _write(tmp_path / "frd.csv", t, f_s, w_s)
    imu = read_imu_log(tmp_path / "frd.csv", ImuSpec(axes=("x", "-y", "-z"))).imu
    np.testing.assert_allclose(imu.f_b, np.tile([0.5, -0.2, G], (n, 1)))
    np.testing.assert_allclose(imu.omega_ib_b, np.tile([0.0, 0.0, 0.1], (n, 1)))
    # a sensor pitched up by 2°: its x axis sees g sin 2° of the level vehicle's f = (0, 0, g)
    th = math.radians(2.0)
    f_tilt = np.tile([G * math.sin(th), 0.0, G * math.cos(th)], (n, 1))
    _write(tmp_path / "tilt.csv", t, f_tilt, np.zeros((n, 3)))
    imu = read_imu_log(tmp_path / "tilt.csv", ImuSpec(mounting_rpy_deg=(0.0, 2.0, 0.0))).imu
    np.testing.assert_allclose(imu.f_b, np.tile([0.0, 0.0, G], (n, 1)), atol=1e-12)
    # yawed 90° to the right: the sensor's x is the vehicle's -y
    spec = ImuSpec(mounting_rpy_deg=(0.0, 0.0, 90.0))
    np.testing.assert_allclose(spec.mounting_matrix() @ [1.0, 0.0, 0.0], [0.0, -1.0, 0.0],
                               atol=1e-15)


SPEC_TOML = """
[columns]
time = "t_us"
accel = ["ax", "ay", "az"]
gyro = ["gx", "gy", "gz"]
[units]
time = "us"
time_reference = "gps"
accel = "g"
gyro = "deg/s"
[timing]
rate_hz = 100.0
[mounting]
axes = ["x", "-y", "-z"]
[noise]
grade = "tactical"
gyro_arw_deg_rthr = 0.15
accel_noise_density_ug_rthz = 60.0
accel_bias_mg = 2.0
"""


def test_spec_toml_with_gps_times(tmp_path, rng):
    path = tmp_path / "spec.toml"
    path.write_text(SPEC_TOML)
    spec = read_imu_spec(path)
    assert spec.errors.gyro_noise_density_radps_rthz == pytest.approx(
        0.15 * math.pi / 180 / 60)
    assert spec.errors.accel_noise_density_mps2_rthz == pytest.approx(60e-6 * G)
    assert spec.errors.accel_bias_mps2 == pytest.approx(2e-3 * G)
    assert spec.errors.gyro_bias_tau_s == 600.0            # the preset's, kept
    n = 300
    t_gps = 1.3e9 + np.arange(n) * 0.01
    f_s = np.tile([0.0, 0.0, -1.0], (n, 1))                # g units, z down
    cols = ("t_us", "ax", "ay", "az", "gx", "gy", "gz")
    _write(tmp_path / "log.csv", t_gps * 1e6, f_s, np.zeros((n, 3)), cols)
    log = read_imu_log(tmp_path / "log.csv", spec)
    assert log.start_gps_time_s == pytest.approx(1.3e9, abs=1e-6)
    np.testing.assert_allclose(log.imu.time_s, np.arange(n) * 0.01, atol=1e-6)
    np.testing.assert_allclose(log.imu.f_b[:, 2], G)


@pytest.mark.parametrize("text, match", [
    ("[columns]\ntime = 3\n", "distinct names"),
    ("[colums]\n", r"unknown table \[colums\]"),
    ("[units]\naccel = 'furlong'\n", "accelerometer unit of rates must be one of"),
    ("[units]\nkind = 'increments'\naccel = 'g'\n", "unit of increments"),
    ("[noise]\ngyro_arw_deg_rthr = 0.1\ngyro_noise_density_radps_rthz = 1e-5\n", "twice"),
    ("[noise]\ngyro_arw = 0.1\n", "unknown key 'gyro_arw'"),
    ("[noise]\ngrade = 'best'\n", "unknown IMU grade"),
    ("[mounting]\naxes = ['x', 'x', 'z']\n", "each of x, y, z once"),
    ("[mounting]\naxes = 'xyz'\n", "array of 3"),
    ("[timing]\nrate_hz = -5\n", "rate_hz must be"),
    ("[timing\n", "not valid TOML"),
])
def test_bad_spec_is_a_located_error(tmp_path, text, match):
    path = tmp_path / "spec.toml"
    path.write_text(text)
    with pytest.raises(ImuInputError, match=match) as info:
        read_imu_spec(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


@pytest.mark.parametrize("mistake, match", [
    ("g", "seem to be in g"),
    ("mg", "seem to be in mg"),
    ("z_down", r"along the vehicle's -z axis"),
    ("deg_per_s", "seem to be in deg/s"),
    ("increments", "increments read as rates"),
])
def test_unit_mistakes_are_clear_errors(tmp_path, rng, mistake, match):
    n = 500
    t = np.arange(n) * 0.01
    f, w = _level(n, rng)
    w[:, 2] += 0.067                     # a 300-m curve at 20 m/s
    if mistake == "g":
        f = f / G
    elif mistake == "mg":
        f = f / G * 1000.0
    elif mistake == "z_down":
        f = -f
    elif mistake == "deg_per_s":
        w = np.degrees(w)
    elif mistake == "increments":
        f = f * 0.01
    path = _write(tmp_path / "imu.csv", t, f, w)
    with pytest.raises(ImuInputError, match=match) as info:
        read_imu_log(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)
    read_imu_log(path, check=False)      # the format itself is fine


def test_plausible_moving_train_passes(rng):
    from strapdown.imu import Imu
    n = 3000
    t = np.arange(n) * 0.01
    f = np.column_stack([np.full(n, 1.2), 0.067 * 20 * np.ones(n), np.full(n, G)])
    f += rng.normal(scale=0.5, size=(n, 3))            # rough-riding vibration
    w = np.column_stack([rng.normal(0, 0.02, n), rng.normal(0, 0.02, n), np.full(n, 0.5)])
    check_imu_plausible(Imu(t, f, w))                  # a tram in a 20-m curve


@pytest.mark.parametrize("body, match", [
    ("0,0,0,9.8,0,0,0\n0.000001,0,0,9.8,0,0,0\n0.000002,0,0,9.8,0,0,0\n", "not an IMU's"),
    ("0,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0,0\n", "row 3, time_s"),
    ("0,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0,0\n0.02,0,0,9.8,0,0,0\n5.0,0,0,9.8,0,0,0\n",
     "4.980-s gap"),
])
def test_bad_timing_is_a_located_error(tmp_path, body, match):
    path = tmp_path / "imu.csv"
    path.write_text(",".join(IMU_COLUMNS) + "\n" + body)
    with pytest.raises(ImuInputError, match=match):
        read_imu_log(path, check=False)


def test_spec_rate_disagreeing_with_the_steps(tmp_path):
    t = np.arange(100) * 0.01
    f, w = _level(100)
    path = _write(tmp_path / "imu.csv", t, f, w)
    with pytest.raises(ImuInputError, match="disagrees with rate_hz = 200"):
        read_imu_log(path, ImuSpec(rate_hz=200.0))
    assert imu_spec_from_dict({}).name == "spec"
