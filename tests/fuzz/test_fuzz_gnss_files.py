"""Fuzzed GNSS inputs (issue 18): RINEX observation (3.04 and 2.11) and navigation files,
SP3 orbits, and GNSS fix files (CSV, NMEA, UBX, GPX). Whatever the bytes, each reader
returns what it reads or raises `gnss_obs.errors.GnssInputError` located at the file, on
one line, within the case time limit (`tests.support.fuzz`).

Originals are small valid files: the shipped real excerpts cut to a few epochs or records
(data/gnss), georinex's RINEX 2 peer files, and fix files written by the project's
writers (CSV, NMEA), by pyubx2 (UBX) and by hand (GPX); `mutated` damages them.
"""
from __future__ import annotations

import datetime as dt
import functools
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from hypothesis import given
from pyubx2 import GET, UBXMessage

from gnss_obs.coverage import check_nav_coverage
from gnss_obs.errors import GnssInputError
from gnss_obs.fixes.read import read_fixes
from gnss_obs.fixes.writers import write_fixes_csv, write_fixes_nmea
from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import read_rinex_obs
from gnss_obs.sp3 import read_sp3
from tests.conftest import GNSS_DATA
from tests.support.fuzz import FUZZ, mutated, read_fuzzed

PEERS = GNSS_DATA / "peers"


def _cut(path: Path, *, before: int, marker: bytes) -> bytes:
    """The file up to its `before`-th line starting with `marker` (header + records)."""
    lines = path.read_bytes().splitlines(keepends=True)
    starts = [i for i, ln in enumerate(lines) if ln.startswith(marker)]
    return b"".join(lines[:starts[before]])


OBS3 = _cut(GNSS_DATA / "rover_obs_1240.rnx", before=3, marker=b"> ")
OBS2 = (PEERS / "demo.10o").read_bytes()
NAV3 = b"".join((GNSS_DATA / "broadcast_nav.rnx").read_bytes().splitlines(keepends=True)[:59])
NAV2 = (PEERS / "demo.10n").read_bytes()
SP3 = _cut(GNSS_DATA / "igr21340_1100_1430.sp3", before=3, marker=b"*")


def _fix_table() -> pd.DataFrame:
    n = 6
    t = 1329730392.0 + np.arange(n)
    return pd.DataFrame({"gps_time_s": t, "timestamp": "", "lat_deg": 50.89 + 1e-5 * np.arange(n),
                         "lon_deg": 4.539 + 1e-5 * np.arange(n), "h_m": 100.0 + np.arange(n),
                         "speed_mps": 10.0, "course_deg": 30.0, "v_east_mps": np.nan,
                         "v_north_mps": np.nan, "v_up_mps": np.nan, "sigma_east_m": 1.5,
                         "sigma_north_m": 1.2, "sigma_up_m": 3.0, "cov_en_m2": 0.0,
                         "sigma_speed_mps": 0.1, "quality": "single", "flag": "",
                         "sigma_source": "file"})


def _written(writer) -> bytes:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fixes"
        writer(path, _fix_table())
        return path.read_bytes()


def _ubx() -> bytes:
    t0 = dt.datetime(2022, 2, 25, 9, 32, 54)
    out = b""
    for k in range(4):
        t = t0 + dt.timedelta(seconds=0.2 * k)
        out += UBXMessage("NAV", "NAV-PVT", GET, iTOW=int(378792000 + 200 * k), year=t.year,
                          month=t.month, day=t.day, hour=t.hour, min=t.minute,
                          second=t.second, nano=t.microsecond * 1000, validDate=1,
                          validTime=1, fixType=3, gnssFixOk=1, numSV=12, lat=50.8925,
                          lon=4.5393, height=100250, hMSL=54450, hAcc=1500, vAcc=2500,
                          velN=12000, velE=-5000, velD=300, gSpeed=13000, headMot=337.38,
                          sAcc=80, headAcc=1.0, pDOP=1.1).serialize()
    return out


FIX_CSV = _written(write_fixes_csv)
FIX_NMEA = _written(write_fixes_nmea)
FIX_UBX = _ubx()
FIX_GPX = b"""<?xml version="1.0" encoding="UTF-8"?>
<gpx version="1.1" creator="hand" xmlns="http://www.topografix.com/GPX/1/1"><trk><trkseg>
<trkpt lat="50.89" lon="4.539"><ele>54.5</ele><time>2022-02-25T10:32:54.400+01:00</time>
<geoidheight>45.8</geoidheight><fix>dgps</fix></trkpt>
<trkpt lat="50.891" lon="4.538"><ele>54.0</ele><time>2022-02-25T09:32:55Z</time></trkpt>
</trkseg></trk></gpx>
"""


def _read(data: bytes, reader):
    return read_fuzzed(data, reader, (GnssInputError,), name="input")


def test_originals_are_read():
    assert read_rinex_obs(_tmp(OBS3)).table["gps_time_s"].nunique() == 3
    assert _read(OBS2, read_rinex_obs) is not None
    assert sum(len(f) for f in read_rinex_nav(_tmp(NAV3)).records.values()) == 6
    assert _read(NAV2, read_rinex_nav) is not None
    assert read_sp3(_tmp(SP3)).table["gps_time_s"].nunique() == 3
    for data in (FIX_CSV, FIX_NMEA, FIX_UBX, FIX_GPX):
        assert len(_read(data, read_fixes)) >= 2


_KEEP: list = []


def _tmp(data: bytes) -> Path:
    folder = tempfile.TemporaryDirectory()
    _KEEP.append(folder)
    path = Path(folder.name) / "original"
    path.write_bytes(data)
    return path


@FUZZ
@given(mutated(OBS3) | mutated(OBS2))
def test_fuzz_rinex_obs_reader(data):
    obs = _read(data, read_rinex_obs)
    if obs is not None and len(obs.table):
        assert np.isfinite(obs.table["gps_time_s"]).all()


@FUZZ
@given(mutated(NAV3) | mutated(NAV2))
def test_fuzz_rinex_nav_reader(data):
    nav = _read(data, read_rinex_nav)
    if nav is not None:
        for table in nav.records.values():
            assert np.isfinite(table["toc_gps_s"]).all()


@FUZZ
@given(mutated(NAV3))
def test_fuzz_nav_against_real_observations(data):
    """A damaged navigation file with good observations: the coverage check answers with
    a located error or a warning, never another exception."""
    obs = _observations()
    _read(data, lambda path: check_nav_coverage(obs, read_rinex_nav(path), "GERC"))


@functools.lru_cache(maxsize=1)
def _observations():
    return read_rinex_obs(_tmp(OBS3))


@FUZZ
@given(mutated(SP3))
def test_fuzz_sp3_reader(data):
    sp3 = _read(data, read_sp3)
    if sp3 is not None:
        assert np.isfinite(sp3.table["gps_time_s"]).all()


@FUZZ
@given(mutated(FIX_CSV) | mutated(FIX_NMEA) | mutated(FIX_UBX, max_edits=3)
       | mutated(FIX_GPX))
def test_fuzz_fix_readers(data):
    log = _read(data, read_fixes)
    if log is not None:
        assert len(log) >= 1 and np.isfinite(log.table["gps_time_s"]).all()
