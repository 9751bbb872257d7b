"""Fuzzed CSV inputs (issue 18): survey, reference trajectory, IMU and baro files. Whatever
the bytes, each reader returns its table or raises its package's own located error, on one
line, within the case time limit (`tests.support.fuzz`).

Originals are small valid files (the shipped survey and reference excerpts cut to a few
dozen rows, an IMU and a baro file written here); `mutated` damages them.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from hypothesis import given
from hypothesis import strategies as st

from railnav.jobs.survey import read_survey
from railnav.errors import ConfigError
from railnav.evaluation.spp_accuracy import read_reference_trajectory
from railnav.jobs.baro import read_baro_csv
from strapdown.errors import ImuInputError
from strapdown.imu import IMU_COLUMNS, read_imu_csv
from tests.conftest import GNSS_DATA, TRACKS
from tests.support.fuzz import FUZZ, csv_cells, mutated, read_fuzzed
from trackmodel.errors import InputError, TrackFileError
from trackmodel.polyline import read_polyline

ROWS = 25


def _head(path: Path, lines: int) -> bytes:
    return b"".join(path.read_bytes().splitlines(keepends=True)[:lines])


SURVEY = _head(TRACKS / "barcelona_drive_survey.csv", ROWS)
POLYLINE = pd.read_csv(TRACKS / "barcelona_drive_survey.csv").iloc[:ROWS][
    ["lat_deg", "lon_deg", "h_m"]].to_csv(index=False).encode()
REFERENCE = _head(GNSS_DATA / "reference_trajectory_1240.csv", ROWS)
_t = np.arange(ROWS) * 0.01
IMU = pd.DataFrame(np.column_stack([_t, np.zeros((ROWS, 2)), np.full(ROWS, 9.81),
                                    np.full((ROWS, 3), 1e-5)]),
                   columns=list(IMU_COLUMNS)).to_csv(index=False).encode()
BARO = pd.DataFrame({"time_s": np.arange(ROWS, dtype=float),
                     "baro_h_m": 500.0 + 0.1 * np.arange(ROWS)}).to_csv(index=False).encode()


def _read(data: bytes, reader, errors: tuple[type, ...]):
    return read_fuzzed(data, reader, errors)


@FUZZ
@given(mutated(POLYLINE) | mutated(SURVEY))
def test_fuzz_polyline_reader(data):
    poly = _read(data, read_polyline, (TrackFileError,))
    if poly is not None:
        assert len(poly) >= 1 and np.all(np.abs(poly.lat) < np.pi / 2)


@FUZZ
@given(mutated(POLYLINE) | mutated(SURVEY) | mutated(REFERENCE))
def test_fuzz_survey_reader_of_track_fit(data):
    """``railnav track fit``'s reader: a polyline, else the week / seconds-of-week layout;
    `TrackFileError` or `ConfigError`, both located `InputError` s."""
    poly = _read(data, read_survey, (InputError,))
    if poly is not None:
        assert len(poly) >= 1


@FUZZ
@given(mutated(REFERENCE) | mutated(SURVEY))
def test_fuzz_reference_trajectory(data):
    ref = _read(data, read_reference_trajectory, (ConfigError,))
    if ref is not None:
        assert np.all(np.diff(ref["gps_time_s"].to_numpy()) >= 0.0)


@FUZZ
@given(mutated(IMU))
def test_fuzz_imu_csv(data):
    imu = _read(data, read_imu_csv, (ImuInputError,))
    if imu is not None:
        assert np.all(np.isfinite(imu.f_b)) and np.all(np.diff(imu.time_s) > 0.0)


@FUZZ
@given(mutated(BARO))
def test_fuzz_baro_csv(data):
    baro = _read(data, read_baro_csv, (ConfigError,))
    if baro is not None:
        assert np.all(np.diff(baro.iloc[:, 0].to_numpy()) > 0.0)


@FUZZ
@given(st.sampled_from(["lat_deg,lon_deg", "lat_deg,lon_deg,h_m", "time_s,baro_h_m",
                        ",".join(IMU_COLUMNS), "gps_time_s,lat_deg,lon_deg,h_m"]),
       st.lists(st.lists(csv_cells(), min_size=1, max_size=8), max_size=6))
def test_fuzz_generated_tables(header, rows):
    """Tables written from scratch under each reader's header, with any cells."""
    data = (header + "\n" + "\n".join(",".join(r) for r in rows) + "\n").encode(
        "utf-8", errors="surrogatepass")
    _read(data, read_polyline, (TrackFileError,))
    _read(data, read_imu_csv, (ImuInputError,))
    _read(data, read_baro_csv, (ConfigError,))
    _read(data, read_reference_trajectory, (ConfigError,))
