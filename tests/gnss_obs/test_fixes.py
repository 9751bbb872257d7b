"""Fix readers (`gnss_obs.fixes`): each format from an independent source.

References: NMEA sentences written by hand here with their XOR checksums computed here;
UBX messages built by pyubx2's own `UBXMessage` (not our code); GPX and CSV text written
here; GPS times from `datetime` arithmetic and the 18 leap seconds in force since
2017-01-01 (IERS Bulletin C), not from `gnss_obs.gpstime`.
"""
from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyubx2 import GET, UBXMessage

from gnss_obs.errors import GnssError, GnssInputError
from gnss_obs.fixes.quality import (
    DEFAULT_FIX_SIGMAS,
    FixSigmas,
    parse_fix_sigma,
)
from gnss_obs.fixes.read import detect_fix_format, read_fixes
from gnss_obs.fixes.table import FIX_COLUMNS
from gnss_obs.fixes.writers import write_fixes_csv, write_fixes_nmea
from tests.conftest import REPO

LEAP_S = 18                      # GPST - UTC since 2017-01-01
GPS_EPOCH = dt.datetime(1980, 1, 6)
WEEK_S = 604_800
#: NMEA minutes are written to 1e-4 here: 1e-4/60 deg = 0.19 m; compare at 1e-9 deg.
ATOL_DEG = 1e-9
#: Times are decimal in the files (0.01 s): compared to 1 µs.
ATOL_TIME_S = 1e-6
#: Knots and km/h to m/s, and integer-mm UBX fields: 1e-9 m/s of float rounding.
ATOL_SPEED_MPS = 1e-9
EXCERPT = REPO / "data" / "fixes" / "brussels" / "log_28876_L36-B_excerpt.csv"


def gps_seconds(utc: dt.datetime) -> float:
    """GPS time of a UTC label, by hand."""
    return (utc - GPS_EPOCH).total_seconds() + LEAP_S


def nmea(body: str) -> str:
    """``$body*hh`` with the XOR checksum of `body` (NMEA 0183)."""
    checksum = 0
    for char in body:
        checksum ^= ord(char)
    return f"${body}*{checksum:02X}"


# -- NMEA --------------------------------------------------------------------------------
BURST = [  # 2022-02-25 09:32:54.40 UTC: RTK fixed, then single 1 s later
    "GPRMC,093254.40,A,5053.5503,N,00432.3622,E,38.8,120.5,250222,,,R",
    "GPVTG,120.5,T,,M,38.8,N,71.9,K,R",
    "GPGGA,093254.40,5053.5503,N,00432.3622,E,4,14,0.7,54.20,M,45.80,M,1.0,0001",
    "GPGSA,A,3,01,02,03,04,05,06,,,,,,,1.2,0.7,1.0",
    "GPGST,093254.40,0.5,0.020,0.015,30.0,0.018,0.016,0.030",
    "GPRMC,093255.40,A,5053.5400,N,00432.3800,E,40.0,121.0,250222,,,A",
    "GPGGA,093255.40,5053.5400,N,00432.3800,E,1,09,1.1,54.00,M,45.80,M,,",
]


def write_lines(path, bodies, *, corrupt=()):
    lines = [nmea(b) for b in bodies]
    for i in corrupt:
        lines[i] = lines[i][:-2] + ("00" if lines[i][-2:] != "00" else "11")
    path.write_text("\r\n".join(lines) + "\r\n")
    return path


def test_nmea_burst_values_against_hand_computation(tmp_path):
    log = read_fixes(write_lines(tmp_path / "log.txt", BURST))
    t = log.table
    assert log.format == "nmea" and len(t) == 2
    assert t["gps_time_s"].to_numpy() == pytest.approx(
        [gps_seconds(dt.datetime(2022, 2, 25, 9, 32, 54, 400000)),
         gps_seconds(dt.datetime(2022, 2, 25, 9, 32, 55, 400000))], abs=ATOL_TIME_S)
    assert t["lat_deg"].iloc[0] == pytest.approx(50 + 53.5503 / 60, abs=ATOL_DEG)
    assert t["lon_deg"].iloc[0] == pytest.approx(4 + 32.3622 / 60, abs=ATOL_DEG)
    assert t["h_m"].iloc[0] == pytest.approx(54.20 + 45.80, abs=1e-9)   # MSL + geoid
    assert t["speed_mps"].iloc[0] == pytest.approx(38.8 * 1852 / 3600, abs=ATOL_SPEED_MPS)
    assert t["course_deg"].iloc[0] == pytest.approx(120.5)
    assert list(t["quality"]) == ["rtk_fixed", "single"]
    # GST gives σ_lat (north) 0.018, σ_lon (east) 0.016, σ_alt 0.030 for the first fix
    assert t[["sigma_north_m", "sigma_east_m", "sigma_up_m"]].iloc[0].tolist() == \
        pytest.approx([0.018, 0.016, 0.030])
    assert t["sigma_source"].tolist() == ["file", "table"]
    single = DEFAULT_FIX_SIGMAS["single"]
    assert t[["sigma_east_m", "sigma_up_m"]].iloc[1].tolist() == \
        [single.horizontal_m, single.vertical_m]


def test_nmea_bad_checksums_are_skipped_and_counted(tmp_path):
    log = read_fixes(write_lines(tmp_path / "log.nmea", BURST, corrupt=(5, 6)))
    assert len(log) == 1 and log.skipped["bad_checksum"] == 2


def test_nmea_with_every_checksum_bad_is_an_error(tmp_path):
    path = write_lines(tmp_path / "log.nmea", BURST, corrupt=range(len(BURST)))
    with pytest.raises(GnssInputError, match="7 bad checksum") as err:
        read_fixes(path)
    assert str(path) in str(err.value)


def test_nmea_without_rmc_needs_a_date(tmp_path):
    path = write_lines(tmp_path / "gga.nmea", [BURST[2]])
    with pytest.raises(GnssInputError, match="no RMC"):
        read_fixes(path)
    log = read_fixes(path, date=dt.date(2022, 2, 25))
    assert log.table["gps_time_s"].iloc[0] == pytest.approx(
        gps_seconds(dt.datetime(2022, 2, 25, 9, 32, 54, 400000)), abs=ATOL_TIME_S)


def test_nmea_midnight_rollover_starts_the_next_day(tmp_path):
    bodies = ["GPRMC,235959.00,A,5053.5503,N,00432.3622,E,0.0,0.0,311222,,,A",
              "GPGGA,000000.00,5053.5503,N,00432.3622,E,1,09,1.1,54.0,M,45.8,M,,"]
    t = read_fixes(write_lines(tmp_path / "x.nmea", bodies)).table["gps_time_s"]
    assert t.diff().iloc[1] == pytest.approx(1.0, abs=ATOL_TIME_S)


def test_nmea_no_fix_epochs_are_dropped(tmp_path):
    bodies = ["GPGGA,093254.40,5053.5503,N,00432.3622,E,0,00,,,M,,M,,",
              "GPRMC,093254.40,V,,,,,,,250222,,,N", BURST[5], BURST[6]]
    log = read_fixes(write_lines(tmp_path / "x.nmea", bodies))
    assert len(log) == 1 and log.skipped["no_fix"] == 1


def test_nmea_unreadable_field_is_located(tmp_path):
    bad = BURST[:2] + ["GPGGA,093254.40,50x3.5503,N,00432.3622,E,4,14,0.7,54.2,M,45.8,M,,"]
    with pytest.raises(GnssInputError, match="line 3"):
        read_fixes(write_lines(tmp_path / "x.nmea", bad))


@pytest.mark.parametrize("date", ["25\x000222", "2502x2"])
def test_nmea_unparsable_rmc_date_is_located(tmp_path, date):
    """A date pynmea2 cannot parse (it returns the raw field: the fuzz test's NUL byte)
    is a located error, not a TypeError when the timestamp is built."""
    bad = [f"GPRMC,093254.40,A,5053.5503,N,00432.3622,E,0.0,0.0,{date},,,A"]
    with pytest.raises(GnssInputError, match="line 1.*date"):
        read_fixes(write_lines(tmp_path / "x.nmea", bad))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.text(alphabet=st.characters(min_codepoint=32, max_codepoint=126),
                        max_size=60), min_size=1, max_size=5))
def test_fuzzed_nmea_lines_fail_only_with_our_error(tmp_path_factory, junk):
    """Whatever follows a good burst: read, or one GnssInputError (never another type)."""
    path = tmp_path_factory.mktemp("f") / "x.nmea"
    path.write_text("\n".join([nmea(b) for b in BURST[:3]] + ["$" + j for j in junk]))
    try:
        log = read_fixes(path)
    except GnssInputError:
        return
    assert len(log) >= 1


# -- UBX ---------------------------------------------------------------------------------
def pvt(utc: dt.datetime, **fields) -> UBXMessage:
    """A NAV-PVT built by pyubx2 (iTOW from `utc` by hand)."""
    gps = gps_seconds(utc)
    base = dict(iTOW=int(round((gps % WEEK_S) * 1000)), year=utc.year, month=utc.month,
                day=utc.day, hour=utc.hour, min=utc.minute, second=utc.second,
                nano=utc.microsecond * 1000, validDate=1, validTime=1, fixType=3,
                gnssFixOk=1, numSV=12, lat=50.8925, lon=4.5393, height=100250,
                hMSL=54450, hAcc=1500, vAcc=2500, velN=12000, velE=-5000, velD=300,
                gSpeed=13000, headMot=337.38, sAcc=80, headAcc=1.0, pDOP=1.1)
    base.update(fields)
    return UBXMessage("NAV", "NAV-PVT", GET, **base)


def test_ubx_nav_pvt_values(tmp_path):
    t0 = dt.datetime(2022, 2, 25, 9, 32, 54)
    msgs = [pvt(t0), pvt(t0 + dt.timedelta(seconds=0.2), carrSoln=2, hAcc=14)]
    path = tmp_path / "log.bin"
    path.write_bytes(b"".join(m.serialize() for m in msgs))
    log = read_fixes(path)
    t = log.table
    assert log.format == "ubx" and log.time_scale == "GPS"
    assert t["gps_time_s"].to_numpy() == pytest.approx([gps_seconds(t0), gps_seconds(t0) + 0.2],
                                                       abs=ATOL_TIME_S)
    assert t["lat_deg"].iloc[0] == pytest.approx(50.8925, abs=ATOL_DEG)
    assert t["h_m"].iloc[0] == pytest.approx(100.250, abs=1e-9)
    assert t[["v_north_mps", "v_east_mps", "v_up_mps"]].iloc[0].tolist() == pytest.approx(
        [12.0, -5.0, -0.3], abs=ATOL_SPEED_MPS)
    assert t["sigma_east_m"].tolist() == pytest.approx([1.5, 0.014])
    assert t["sigma_up_m"].iloc[0] == pytest.approx(2.5)
    assert t["sigma_speed_mps"].iloc[0] == pytest.approx(0.08)
    assert list(t["quality"]) == ["single", "rtk_fixed"]


def test_ubx_nav_cov_replaces_hacc(tmp_path):
    t0 = dt.datetime(2023, 7, 28, 10, 48, 8)
    msg = pvt(t0)
    cov = UBXMessage("NAV", "NAV-COV", GET, iTOW=msg.iTOW, posCovValid=1, posCovNN=0.04,
                     posCovNE=0.01, posCovND=0.0, posCovEE=0.09, posCovED=0.0, posCovDD=0.25)
    path = tmp_path / "log.ubx"
    path.write_bytes(msg.serialize() + cov.serialize())
    row = read_fixes(path).table.iloc[0]
    assert [row["sigma_north_m"], row["sigma_east_m"], row["sigma_up_m"]] == \
        pytest.approx([0.2, 0.3, 0.5], rel=1e-6)     # float32 storage of the covariance
    assert row["cov_en_m2"] == pytest.approx(0.01, rel=1e-6)


def test_ubx_bad_checksum_skipped_and_no_fix_dropped(tmp_path):
    t0 = dt.datetime(2022, 2, 25, 9, 32, 54)
    bad = bytearray(pvt(t0).serialize())
    bad[-1] ^= 0xFF
    nofix = pvt(t0 + dt.timedelta(seconds=1), fixType=0, gnssFixOk=0).serialize()
    good = pvt(t0 + dt.timedelta(seconds=2)).serialize()
    path = tmp_path / "log.ubx"
    path.write_bytes(bytes(bad) + nofix + good)
    log = read_fixes(path)
    assert len(log) == 1 and log.skipped["bad_checksum"] == 1 and log.skipped["no_fix"] == 1


def test_ubx_without_nav_pvt_is_a_clear_error(tmp_path):
    path = tmp_path / "log.ubx"
    path.write_bytes(UBXMessage("NAV", "NAV-STATUS", GET, iTOW=1000).serialize())
    with pytest.raises(GnssInputError, match="no NAV-PVT message .*NAV-STATUS x1"):
        read_fixes(path)


# -- GPX, CSV, detection -----------------------------------------------------------------
GPX = """<?xml version="1.0" encoding="UTF-8"?>
<gpx version="1.1" creator="hand" xmlns="http://www.topografix.com/GPX/1/1"><trk><trkseg>
<trkpt lat="50.89" lon="4.539"><ele>54.5</ele><time>2022-02-25T10:32:54.400+01:00</time>
<geoidheight>45.8</geoidheight><fix>dgps</fix></trkpt>
<trkpt lat="50.891" lon="4.538"><ele>54.0</ele><time>2022-02-25T09:32:55Z</time></trkpt>
<trkpt lat="50.892" lon="4.537"><time>2022-02-25T09:32:56Z</time><fix>none</fix></trkpt>
</trkseg></trk></gpx>
"""


def test_gpx_points(tmp_path):
    path = tmp_path / "track.xml"
    path.write_text(GPX)
    log = read_fixes(path)
    t = log.table
    assert log.format == "gpx" and len(t) == 2 and log.skipped["no_fix"] == 1
    assert t["gps_time_s"].iloc[0] == pytest.approx(
        gps_seconds(dt.datetime(2022, 2, 25, 9, 32, 54, 400000)), abs=ATOL_TIME_S)
    assert t["h_m"].iloc[0] == pytest.approx(54.5 + 45.8)
    assert math.isnan(t["h_m"].iloc[1])        # no geoidheight: the ellipsoidal h unknown
    assert list(t["quality"]) == ["dgps", "single"]


def test_gpx_time_offset_out_of_range_is_a_located_error(tmp_path):
    """A UTC offset of 24 h or more (found by the fix readers' fuzz test) is bad input:
    a GnssInputError naming the file, not Python's ValueError."""
    path = tmp_path / "track.gpx"
    path.write_text(GPX.replace("10:32:54.400+01:00", "10:32:54.400+31:00"))
    with pytest.raises(GnssInputError, match="track.gpx.*not a valid UTC time"):
        read_fixes(path)


def test_csv_with_our_columns_and_iso_offsets(tmp_path):
    path = tmp_path / "fixes"
    path.write_text("timestamp,lat_deg,lon_deg,h_m,quality,sigma_east_m,sigma_north_m\n"
                    "2022-02-25T10:32:54.4+01:00,50.89,4.539,100.0,rtk_float,0.2,0.3\n")
    log = read_fixes(path)
    row = log.table.iloc[0]
    assert log.format == "csv" and log.utc_suffix == "Z"
    assert row["gps_time_s"] == pytest.approx(
        gps_seconds(dt.datetime(2022, 2, 25, 9, 32, 54, 400000)), abs=ATOL_TIME_S)
    assert [row["sigma_east_m"], row["sigma_north_m"]] == [0.2, 0.3]
    assert row["sigma_up_m"] == DEFAULT_FIX_SIGMAS["rtk_float"].vertical_m


def test_csv_speed_sigma_from_the_velocity_sigmas_per_axis(tmp_path):
    """An SPP table's ``sigma_v_east_mps``/``sigma_v_north_mps`` (``railnav spp``'s output)
    give the speed σ, √((σ_e² + σ_n²)/2), where the file has no ``sigma_speed_mps`` or an
    empty one; a file's own speed σ is kept; without either the class default holds."""
    path = tmp_path / "spp.csv"
    path.write_text("gps_time_s,lat_deg,lon_deg,sigma_v_east_mps,sigma_v_north_mps\n"
                    "100.0,41.6,2.35,0.3,0.4\n101.0,41.6,2.35,0.12,0.12\n")
    speed = read_fixes(path).table["sigma_speed_mps"].to_numpy()
    assert speed == pytest.approx([math.sqrt((0.09 + 0.16) / 2), 0.12], abs=1e-12)
    path.write_text("gps_time_s,lat_deg,lon_deg,sigma_speed_mps,sigma_v_east_mps,"
                    "sigma_v_north_mps\n100.0,41.6,2.35,0.05,0.3,0.4\n"
                    "101.0,41.6,2.35,,0.3,0.4\n")
    speed = read_fixes(path).table["sigma_speed_mps"].to_numpy()
    assert speed == pytest.approx([0.05, math.sqrt(0.125)], abs=1e-12)
    path.write_text("gps_time_s,lat_deg,lon_deg,sigma_v_east_mps\n100.0,41.6,2.35,0.3\n")
    assert read_fixes(path).table["sigma_speed_mps"].iloc[0] == \
        DEFAULT_FIX_SIGMAS["single"].speed_mps


def test_belgian_excerpt_as_shipped():
    """Reference: the excerpt's own columns read with pandas, naive times taken as UTC."""
    raw = pd.read_csv(EXCERPT)
    log = read_fixes(EXCERPT)
    ok = raw["solution_status"] == "SOL_COMPUTED"
    assert len(log) == ok.sum() and log.utc_suffix == ""
    stamps = pd.to_datetime(raw.loc[ok, "timestamp"], format="ISO8601")
    expected = np.array([gps_seconds(s.to_pydatetime()) for s in stamps])
    assert log.table["gps_time_s"].to_numpy() == pytest.approx(expected, abs=ATOL_TIME_S)
    assert log.table["lat_deg"].to_numpy() == pytest.approx(raw.loc[ok, "latitude"], abs=0)
    fixed = raw.loc[ok, "position_type"].eq("NARROW_INT3").to_numpy()
    assert (log.table["quality"].to_numpy()[fixed] == "rtk_fixed").all()


def test_csv_errors_are_located(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("timestamp,latitude,longitude,position_type\n"
                    "2022-02-25T09:32:54,50.9,4.5,SINGLE\n2022-02-25T09:32:55,abc,4.5,SINGLE\n")
    with pytest.raises(GnssInputError, match=r"row 2, latitude: 'abc' is not a finite"):
        read_fixes(path)
    path.write_text("timestamp,latitude,longitude,position_type\n"
                    "2022-02-25T09:32:54,50.9,4.5,WEIRD\n")
    with pytest.raises(GnssInputError, match=r"row 1, position_type: unknown position type"):
        read_fixes(path)


def test_a_time_that_goes_back_is_an_error_naming_both_labels(tmp_path):
    """One row of the Belgian excerpt dated minutes earlier (a wrong or cut label): it was
    sorted to the front (on the whole log_28876, one row at 09:30: the run started 174 s
    early and the fault screen rejected 370 of its 1132 fixes); now the file is refused
    with the two labels as written."""
    raw = EXCERPT.read_text().splitlines()
    cells = raw[60].split(",")
    stamp_at = raw[0].split(",").index("timestamp")
    later, earlier = "2022-02-25T09:30:00.000", raw[59].split(",")[stamp_at]
    cells[stamp_at] = later
    path = tmp_path / "back.csv"
    path.write_text("\n".join(raw[:60] + [",".join(cells)] + raw[61:]) + "\n")
    with pytest.raises(GnssInputError, match=rf"back.csv: time goes back: {later} after "
                                             rf"{earlier} \(fixes must be in time order\)"):
        read_fixes(path)


def test_a_csv_cut_inside_its_last_timestamp_is_refused(tmp_path):
    """The excerpt cut inside its last row's timestamp: ``2022-02`` is a valid ISO 8601
    month, read as 2022-02-01, 24 days before the log (the whole log_28876 cut so ran 21
    million steps, 243 s); now the time going back refuses the file."""
    text = EXCERPT.read_text().rstrip("\n")
    cut = text[:text.rindex(",2022-02-25T") + len(",2022-02")]
    path = tmp_path / "cut.csv"
    path.write_text(cut)
    with pytest.raises(GnssInputError, match=r"cut.csv: time goes back: 2022-02 after"):
        read_fixes(path)


def test_a_latitude_out_of_range_is_named_as_written(tmp_path):
    path = tmp_path / "lat.csv"
    path.write_text("gps_time_s,lat_deg,lon_deg\n1e9,50.5,4.5\n1000000001,95.3,4.5\n")
    with pytest.raises(GnssInputError, match=r"lat.csv: lat_deg: 95.3 is not in \[-90, 90\]"):
        read_fixes(path)


def test_nmea_epochs_out_of_order_are_an_error(tmp_path):
    bodies = [BURST[5], BURST[6], BURST[0], BURST[2]]      # 09:32:55.40 before 09:32:54.40
    with pytest.raises(GnssInputError, match=r"time goes back: 2022-02-25T09:32:54.400Z "
                                             r"after 2022-02-25T09:32:55.400Z"):
        read_fixes(write_lines(tmp_path / "swapped.nmea", bodies))


@pytest.mark.parametrize("name, content, expected", [
    ("a.csv", BURST, "nmea"), ("a.nmea", None, "csv"), ("a.txt", GPX, "gpx"),
])
def test_format_is_told_by_content_not_name(tmp_path, name, content, expected):
    path = tmp_path / name
    if isinstance(content, list):
        write_lines(path, content)
    elif content is None:
        path.write_text("gps_time_s,lat_deg,lon_deg\n1e9,50,4\n")
    else:
        path.write_text(content)
    assert detect_fix_format(path) == expected


def test_empty_file_is_an_error(tmp_path):
    (tmp_path / "e").write_text("\n")
    with pytest.raises(GnssInputError, match="empty fix file"):
        read_fixes(tmp_path / "e")


# -- σ table and writers -----------------------------------------------------------------
def test_sigma_table_override_through_read_and_parse(tmp_path):
    quality, sigmas = parse_fix_sigma("single=4,8")
    assert quality == "single" and sigmas == FixSigmas(4.0, 8.0,
                                                      DEFAULT_FIX_SIGMAS["single"].speed_mps)
    log = read_fixes(write_lines(tmp_path / "x.nmea", BURST[5:]), sigmas={quality: sigmas})
    assert log.table[["sigma_east_m", "sigma_up_m"]].iloc[0].tolist() == [4.0, 8.0]
    for bad in ("single", "nope=1", "single=0", "single=a"):
        with pytest.raises(GnssError):
            parse_fix_sigma(bad)


def test_writers_round_trip_through_the_readers(tmp_path):
    """Our writers read back by the readers (checked above against hand-made files)."""
    fixes = read_fixes(write_lines(tmp_path / "in.nmea", BURST)).table
    for writer, name in ((write_fixes_csv, "out.csv"), (write_fixes_nmea, "out.nmea")):
        writer(tmp_path / name, fixes)
        back = read_fixes(tmp_path / name).table
        assert back["gps_time_s"].to_numpy() == pytest.approx(fixes["gps_time_s"],
                                                              abs=ATOL_TIME_S)
        assert back["lat_deg"].to_numpy() == pytest.approx(fixes["lat_deg"], abs=ATOL_DEG)
        assert back["h_m"].to_numpy() == pytest.approx(fixes["h_m"], abs=1e-4)
        assert list(back["quality"]) == list(fixes["quality"])
        assert list(back.columns) == list(FIX_COLUMNS)


@pytest.mark.parametrize("header, value", [("sigma_east_m", "-0.1"), ("sigma_up_m", "-1.5"),
                                           ("sigma_speed_mps", "inf"),
                                           ("sigma_v_east_mps,sigma_v_north_mps", "-1,0")])
def test_csv_sigma_not_finite_and_positive_is_a_located_error(tmp_path, header, value):
    """A negative or infinite σ is no σ: each is a one-line error naming the file, row and
    column; an empty cell is no σ given (the class's fills it)."""
    path = tmp_path / "f.csv"
    path.write_text(f"gps_time_s,lat_deg,lon_deg,{header}\n100.0,41.6,2.35,{value}\n")
    with pytest.raises(GnssInputError) as err:
        read_fixes(path)
    text = str(err.value)
    assert "f.csv" in text and "is not a σ" in text and "row 1" in text \
        and "\n" not in text, text
    assert header.split(",")[0] in text
    column = "sigma_speed_mps" if header.startswith("sigma_v") else header
    path.write_text(f"gps_time_s,lat_deg,lon_deg,{header}\n100.0,41.6,2.35,"
                    f"{','.join([''] * (header.count(',') + 1))}\n")
    assert np.isfinite(read_fixes(path).table[column].iloc[0])

