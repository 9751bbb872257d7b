"""Fuzzed real-recording inputs (issue 17): an IMU log read through its spec, the IMU spec
TOML, odometer files (speeds and pulse counts) and balise files. Whatever the bytes, each
reader returns its result or raises its package's own located error, on one line, within
the case time limit (`tests.support.fuzz`).

Originals are small valid files written here: a logger's IMU log (ms, g, deg/s, FRD) with
its spec, a spec with every table, a speed and a pulse odometer, a balise file with both
position forms. `mutated` damages them; documents written from scratch with the spec's
tables and keys (and some that are not) hold values of every TOML type.
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
from hypothesis import given
from hypothesis import strategies as st

from railnav.errors import ConfigError
from railnav.sensors.balises import read_balises_csv
from railnav.sensors.odometer import read_odometer_csv
from strapdown.errors import ImuInputError
from strapdown.imu_log import read_imu_log
from strapdown.imu_spec import ImuSpec, read_imu_spec
from tests.support.fuzz import FUZZ, csv_cells, mutated, read_fuzzed

ROWS = 120
_t = np.arange(ROWS) * 0.01
LOG = pd.DataFrame({"t_ms": _t * 1e3, "ax": 0.01, "ay": 0.0, "az": -1.0, "gx": 0.0,
                    "gy": 0.0, "gz": -0.5}).to_csv(index=False).encode()
LOG_SPEC = ImuSpec(time_column="t_ms", accel_columns=("ax", "ay", "az"),
                   gyro_columns=("gx", "gy", "gz"), time_unit="ms", accel_unit="g",
                   gyro_unit="deg/s", axes=("x", "-y", "-z"), name="logger spec")
SPEC = b"""[columns]
time = "t_ms"
accel = ["ax", "ay", "az"]
gyro = ["gx", "gy", "gz"]
[units]
time = "ms"
time_reference = "trip"
kind = "rates"
accel = "g"
gyro = "deg/s"
[timing]
rate_hz = 100.0
gap_report_s = 0.05
max_gap_s = 1.0
[mounting]
axes = ["x", "-y", "-z"]
rpy_deg = [0.0, 0.5, -0.2]
[noise]
grade = "tactical"
gyro_arw_deg_rthr = 0.15
accel_noise_density_ug_rthz = 60.0
"""
ODO_SPEED = b"time_s,speed_mps,direction,sigma_mps\n" + b"".join(
    f"{0.1 * k:.1f},{min(k * 0.3, 15):.2f},1,0.05\n".encode() for k in range(30))
ODO_PULSES = b"# pulses\ngps_time_s,pulses\n" + b"".join(
    f"{1e9 + 0.1 * k:.1f},{k * k * 3}\n".encode() for k in range(30))
BALISES = (b"time_s,s_m,lat_deg,lon_deg,sigma_m,id\n1.0,500,,,0.3,B1\n2.0,,48.1,11.5,,B2\n"
           b"3.5,1500.5,,,,B3\n")
SPEC_KEYS = {"columns": ["time", "accel", "gyro"],
             "units": ["time", "time_reference", "kind", "accel", "gyro"],
             "timing": ["rate_hz", "gap_report_s", "max_gap_s"],
             "mounting": ["axes", "rpy_deg"],
             "noise": ["grade", "gyro_arw_deg_rthr", "accel_bias_mg",
                       "accel_noise_density_mps2_rthz", "gyro_bias_tau_s", "x"],
             "extra": ["y"]}


def _read(data: bytes, reader, errors: tuple[type, ...], name: str = "input.csv"):
    return read_fuzzed(data, reader, errors, name=name)


@FUZZ
@given(mutated(LOG))
def test_fuzz_imu_log_with_spec(data):
    log = _read(data, lambda p: read_imu_log(p, LOG_SPEC), (ImuInputError,))
    if log is not None:
        assert np.all(np.diff(log.imu.time_s) > 0) and np.all(np.isfinite(log.imu.f_b))


@FUZZ
@given(mutated(SPEC))
def test_fuzz_imu_spec_toml(data):
    spec = _read(data, read_imu_spec, (ImuInputError,), "spec.toml")
    if spec is not None:
        assert len(spec.axes) == 3 and spec.mounting_matrix().shape == (3, 3)


_scalars = st.one_of(st.integers(-2**70, 2**70), st.floats(allow_nan=True, allow_infinity=True),
                     st.booleans(), st.text(max_size=6),
                     st.sampled_from(["g", "deg/s", "ms", "increments", "gps", "-z", "x",
                                      "tactical", "\x00"]))
_values = st.recursive(_scalars, lambda inner: st.lists(inner, max_size=4), max_leaves=6)


@FUZZ
@given(st.dictionaries(st.sampled_from(sorted(SPEC_KEYS)),
                       st.dictionaries(st.sampled_from(sorted({k for v in SPEC_KEYS.values()
                                                               for k in v})), _values,
                                       max_size=4), max_size=4))
def test_fuzz_imu_spec_documents(doc):
    lines = []
    for table, keys in doc.items():
        lines.append(f"[{table}]")
        lines += [f"{k} = {_toml(v)}" for k, v in keys.items()]
    _read("\n".join(lines).encode("utf-8", errors="surrogatepass"), read_imu_spec,
          (ImuInputError,), "spec.toml")


def _toml(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if value != value else ("inf" if value == float("inf") else
                                             "-inf" if value == float("-inf") else repr(value))
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, str):
        return json.dumps(value)
    return str(value)


@FUZZ
@given(mutated(ODO_SPEED) | mutated(ODO_PULSES))
def test_fuzz_odometer(data):
    for wheel in ({}, {"wheel_circumference_m": 2.89, "pulses_per_rev": 100.0}):
        log = _read(data, lambda p: read_odometer_csv(p, **wheel), (ConfigError,))
        if log is not None:
            assert np.all(log.speed_mps >= 0) and np.all(np.isfinite(log.speed_mps))


@FUZZ
@given(mutated(BALISES))
def test_fuzz_balises(data):
    log = _read(data, read_balises_csv, (ConfigError,))
    if log is not None:
        assert np.all(np.isfinite(log.s_m) | np.isfinite(log.lat_deg))


@FUZZ
@given(st.sampled_from(["time_s,speed_mps", "gps_time_s,pulses", "time_s,s_m,sigma_m,id",
                        "time_s,lat_deg,lon_deg", "time_s,speed_mps,direction"]),
       st.lists(st.lists(csv_cells(), min_size=1, max_size=5), max_size=6))
def test_fuzz_generated_sensor_tables(header, rows):
    data = (header + "\n" + "\n".join(",".join(r) for r in rows) + "\n").encode(
        "utf-8", errors="surrogatepass")
    _read(data, lambda p: read_odometer_csv(p, wheel_circumference_m=3.0, pulses_per_rev=50),
          (ConfigError,))
    _read(data, read_odometer_csv, (ConfigError,))
    _read(data, read_balises_csv, (ConfigError,))
