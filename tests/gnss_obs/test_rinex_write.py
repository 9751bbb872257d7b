"""RINEX writers: write -> read gives the values back to the format's precision, and a
third-party reader (georinex) reads what we write."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gnss_obs.errors import GnssInputError
from gnss_obs.gpstime import datetime64_to_gps_time_s
from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import ObsHeader, read_rinex_obs
from gnss_obs.rinex_write import derive_obs_types, write_rinex_nav, write_rinex_obs

DATA = Path(__file__).resolve().parents[2] / "data" / "gnss"
ROVER = DATA / "rover_obs_1240.rnx"
NAV = DATA / "broadcast_nav.rnx"
#: F14.3 keeps 3 decimals: a written value is within half a unit of the last place.
OBS_ATOL = 0.0005
#: D19.12 keeps 13 significant digits: relative error at most 5e-13.
NAV_RTOL = 5e-13
#: F11.7 epoch seconds.
EPOCH_ATOL_S = 5e-8
VALUES = ["pseudorange_m", "carrier_cycles", "doppler_hz", "cn0_dbhz"]


@pytest.fixture(scope="module")
def rover():
    return read_rinex_obs(ROVER)


def test_real_file_round_trip_is_identical(rover, tmp_path):
    path = tmp_path / "copy.rnx"
    write_rinex_obs(path, rover.header, rover.table)
    back = read_rinex_obs(path)
    pd.testing.assert_frame_equal(back.table, rover.table)
    for f in dataclasses.fields(ObsHeader):
        mine, theirs = getattr(back.header, f.name), getattr(rover.header, f.name)
        assert np.array_equal(mine, theirs) if isinstance(mine, np.ndarray) else mine == theirs


def _synthetic(rng, n_epochs=20) -> pd.DataFrame:
    t0 = 1_290_688_800.0
    rows = []
    for k in range(n_epochs):
        for sv in ("G01", "G12", "E05", "R03", "C30"):
            for signal in ("1C", "5Q") if sv[0] in "GE" else ("1C",):
                rows.append({"gps_time_s": t0 + 0.5 * k, "sv": sv, "signal": signal,
                             "pseudorange_m": rng.uniform(2e7, 3e7),
                             "carrier_cycles": rng.uniform(-1e9, 1e9),
                             "doppler_hz": rng.uniform(-5e3, 5e3),
                             "cn0_dbhz": rng.uniform(20, 50) if k % 3 else np.nan,
                             "lli": int(rng.integers(0, 3)), "ssi": int(rng.integers(0, 10))})
    return pd.DataFrame(rows)


@pytest.mark.parametrize("time_system", ["GPS", "GLO", "BDT"])
def test_synthetic_round_trip_to_format_precision(rng, tmp_path, time_system):
    table = _synthetic(rng)
    header = ObsHeader(obs_types={}, first_obs_gps_time_s=table["gps_time_s"].iloc[0],
                       time_system=time_system, leap_seconds=18, interval_s=0.5,
                       glonass_slots={"R03": 5})
    path = tmp_path / "sim.rnx"
    write_rinex_obs(path, header, table)
    back = read_rinex_obs(path)
    assert back.header.time_system == time_system
    assert back.header.obs_types == derive_obs_types(table)
    assert back.header.first_obs_gps_time_s == pytest.approx(table["gps_time_s"].iloc[0],
                                                             abs=EPOCH_ATOL_S)
    key = ["gps_time_s", "sv", "signal"]
    expected = table.sort_values(key, ignore_index=True)
    got = back.table
    assert list(got["sv"]) == list(expected["sv"])
    assert list(got["signal"]) == list(expected["signal"])
    np.testing.assert_allclose(got["gps_time_s"], expected["gps_time_s"], rtol=0,
                               atol=EPOCH_ATOL_S)
    for column in VALUES:
        np.testing.assert_allclose(got[column], expected[column], rtol=0, atol=OBS_ATOL,
                                   err_msg=column)
    np.testing.assert_array_equal(got["lli"], expected["lli"])
    np.testing.assert_array_equal(got["ssi"], expected["ssi"])


def test_written_file_reads_in_georinex(rng, tmp_path):
    gr = pytest.importorskip("georinex")
    table = _synthetic(rng, n_epochs=5)
    path = tmp_path / "sim.rnx"
    write_rinex_obs(path, ObsHeader(obs_types={}, first_obs_gps_time_s=0.0), table)
    ds = gr.load(path)
    times = datetime64_to_gps_time_s(ds.time.values)
    np.testing.assert_allclose(times, np.unique(table["gps_time_s"]), rtol=0,
                               atol=EPOCH_ATOL_S)
    for sv, code in (("G01", "C1C"), ("E05", "L5Q"), ("R03", "D1C"), ("C30", "C1C")):
        column = {"C": "pseudorange_m", "L": "carrier_cycles", "D": "doppler_hz"}[code[0]]
        sel = (table["sv"] == sv) & (table["signal"] == code[1:])
        expected = table.loc[sel, column].to_numpy()
        np.testing.assert_allclose(ds[code].sel(sv=sv).values, expected, rtol=0,
                                   atol=OBS_ATOL, err_msg=sv + code)


def test_writer_rejects_bad_tables(rover, tmp_path):
    path = tmp_path / "bad.rnx"
    table = rover.table.copy()
    table.loc[3, "carrier_cycles"] = 2e10        # beyond F14.3
    with pytest.raises(GnssInputError, match="F14.3"):
        write_rinex_obs(path, rover.header, table)
    header = dataclasses.replace(rover.header, obs_types={"G": ["C1C"]})
    with pytest.raises(GnssInputError, match="no observation types|not in the header"):
        write_rinex_obs(path, header, rover.table)
    with pytest.raises(GnssInputError, match="lacks columns"):
        write_rinex_obs(path, rover.header, rover.table.drop(columns="signal"))
    assert not path.exists() and list(tmp_path.iterdir()) == []   # nothing half-written


def test_navigation_round_trip(tmp_path):
    nav = read_rinex_nav(NAV)
    path = tmp_path / "nav.rnx"
    write_rinex_nav(path, nav)
    back = read_rinex_nav(path)
    assert back.records.keys() == nav.records.keys()
    for system, df in nav.records.items():
        pd.testing.assert_frame_equal(back.records[system], df, rtol=NAV_RTOL, atol=0)
    for name in ("leap_seconds", "time_corrections"):
        assert getattr(back.header, name) == getattr(nav.header, name)
    np.testing.assert_array_equal(back.header.iono_gal, nav.header.iono_gal)
    np.testing.assert_array_equal(back.header.iono_gps_beta, nav.header.iono_gps_beta)
