"""Odometer and balise files (issue 17): what the readers make of speeds, pulse counts,
directions, distances and coordinates (values computed here from the rows written), and
located one-line errors for bad files."""
from __future__ import annotations

import numpy as np
import pytest

from railnav.errors import ConfigError
from railnav.sensors.balises import read_balises_csv, write_balises_csv
from railnav.sensors.odometer import read_odometer_csv, write_odometer_csv


def test_speed_file_round_trip(tmp_path):
    t = np.arange(0.0, 5.0, 0.1)
    speed = np.abs(np.sin(t)) * 10.0
    path = tmp_path / "odo.csv"
    write_odometer_csv(path, t, speed_mps=speed, direction=np.ones(t.size))
    log = read_odometer_csv(path)
    np.testing.assert_array_equal(log.time_s, t)
    np.testing.assert_array_equal(log.speed_mps, speed)
    assert log.kind == "speed" and np.all(log.direction == 1) and np.all(log.resolution_mps == 0)
    np.testing.assert_allclose(log.relative_time_s(0.0), t)


def test_pulse_counts_become_interval_speeds(tmp_path):
    """100 pulses per 2.89-m revolution: 0.0289 m a pulse; 70 pulses in 0.1 s are
    20.23 m/s at the interval's midpoint, quantization 0.289 m/s."""
    path = tmp_path / "odo.csv"
    path.write_text("# a tachometer\ngps_time_s,pulses\n100.0,1000\n100.1,1070\n100.2,1140\n"
                    "100.3,1140\n")
    log = read_odometer_csv(path, wheel_circumference_m=2.89, pulses_per_rev=100)
    np.testing.assert_allclose(log.time_s, [100.05, 100.15, 100.25])
    np.testing.assert_allclose(log.speed_mps, [70 * 0.0289 / 0.1, 70 * 0.0289 / 0.1, 0.0])
    np.testing.assert_allclose(log.resolution_mps, 0.289)
    assert log.pulse_length_m == pytest.approx(0.0289) and log.time_column == "gps_time_s"
    np.testing.assert_allclose(log.relative_time_s(100.0), [0.05, 0.15, 0.25], atol=1e-12)


@pytest.mark.parametrize("text, kw, match", [
    ("time_s,speed_mps\n0,1\n0,2\n", {},
     r"row 2, time_s: time does not increase \(0.0 after 0.0\)"),
    ("time_s,speed_mps\n0,1\n1,-2\n", {}, "row 2, speed_mps: speed_mps must be >= 0"),
    ("time_s,speed_mps,pulses\n0,1,1\n", {}, "not both"),
    ("time_s,rpm\n0,1\n", {}, "needs one of the columns speed_mps or pulses"),
    ("t,speed_mps\n0,1\n", {}, "missing column gps_time_s or time_s"),
    ("time_s,pulses\n0,1\n1,2\n", {}, "need the wheel circumference"),
    ("time_s,pulses\n0,5\n1,2\n", {"wheel_circumference_m": 3.0, "pulses_per_rev": 60},
     "row 2, pulses: pulses must be never decreasing"),
    ("time_s,pulses\n0,5\n1,6.5\n", {"wheel_circumference_m": 3.0, "pulses_per_rev": 60},
     "row 2, pulses: pulses must be an integer"),
    ("time_s,speed_mps\n0,1\n", {"wheel_circumference_m": 3.0}, "this file has speed_mps"),
    ("time_s,speed_mps,direction\n0,1,2\n", {}, "row 1, direction"),
    ("time_s,speed_mps,sigma_mps\n0,1,abc\n", {}, "row 1, sigma_mps: 'abc' is not"),
    ("time_s,speed_mps\n", {}, "no rows"),
    ("", {}, "empty file"),
])
def test_bad_odometer_files(tmp_path, text, kw, match):
    path = tmp_path / "odo.csv"
    path.write_text(text)
    with pytest.raises(ConfigError, match=match) as info:
        read_odometer_csv(path, **kw)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


def test_balise_file_forms(tmp_path):
    path = tmp_path / "bal.csv"
    path.write_text("time_s,s_m,lat_deg,lon_deg,sigma_m,id\n1.0,500,,,0.3,B1\n"
                    "2.0,,48.1,11.5,,B2\n")
    log = read_balises_csv(path)
    np.testing.assert_array_equal(log.s_m[:1], [500.0])
    assert np.isnan(log.s_m[1]) and log.lat_deg[1] == 48.1 and np.isnan(log.sigma_m[1])
    assert list(log.ids) == ["B1", "B2"]
    write_balises_csv(tmp_path / "b2.csv", np.array([3.0]), np.array([7.5]))
    back = read_balises_csv(tmp_path / "b2.csv")
    assert back.s_m[0] == 7.5 and list(back.ids) == ["row1"]


@pytest.mark.parametrize("text, match", [
    ("time_s,name\n1,a\n", "needs the column s_m"),
    ("time_s,s_m,lat_deg,lon_deg\n1,,48.1,\n", "row 1, lat_deg: a coordinate needs both"),
    ("time_s,s_m\n1,\n", "row 1, s_m: no position"),
    ("time_s,lat_deg,lon_deg\n1,95,3\n", "row 1, lat_deg: latitude beyond"),
    ("time_s,s_m\n1,-4\n", "row 1, s_m: a track distance is >= 0"),
    ("time_s,s_m,sigma_m\n1,4,0\n", "row 1, sigma_m: sigma_m must be > 0"),
    ("time_s,s_m\n1,4\n0.5,5\n", r"row 2, time_s: time does not increase \(0.5 after 1.0\)"),
])
def test_bad_balise_files(tmp_path, text, match):
    path = tmp_path / "bal.csv"
    path.write_text(text)
    with pytest.raises(ConfigError, match=match) as info:
        read_balises_csv(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)
