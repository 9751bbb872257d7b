"""Issue 18: RINEX observation/navigation and SP3 files cut short, dated nonsense, bytes that
are not text, navigation data that do not cover the observations.

Every case is built by editing a shipped real file (data/gnss) in a known way, and the
expected figure comes from that edit and the file's own header (e.g. TIME OF LAST OBS
12:42:59 at a 1 s INTERVAL from 12:40:00 = 180 epochs; 25 kept -> 155 missing).
"""
from __future__ import annotations

import datetime as dt
import logging
from pathlib import Path

import numpy as np
import pytest

from gnss_obs.coverage import check_nav_coverage, check_sp3_coverage
from gnss_obs.errors import GnssError, GnssInputError
from gnss_obs.gpstime import calendar_to_gps_time_s
from gnss_obs.precise import PreciseOrbits
from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import read_rinex_obs
from gnss_obs.sp3 import read_sp3
from railnav.cli import main

GNSS_DATA = Path(__file__).resolve().parents[2] / "data" / "gnss"
ROVER = GNSS_DATA / "rover_obs_1240.rnx"
NAV = GNSS_DATA / "broadcast_nav.rnx"
COD = GNSS_DATA / "COD21340_1100_1430.sp3"
PEERS = GNSS_DATA / "peers"
#: Broadcast-orbit lines after the epoch line of a RINEX 3 record, per system (Table A6+).
CONTINUATION = {"G": 7, "E": 7, "C": 7, "J": 7, "R": 3, "S": 3}


def _lines(path: Path) -> list[str]:
    return path.read_text().split("\n")


def _write(tmp_path, name: str, lines: list[str]) -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines).rstrip("\n") + "\n")
    return path


def _warnings(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]


def _epoch_lines(lines: list[str]) -> list[int]:
    return [i for i, ln in enumerate(lines) if ln.startswith("> ")]


# --- observations cut short: TIME OF LAST OBS, PRN / # OF OBS -------------------------

def test_issue18_obs_cut_at_an_epoch_boundary_is_reported_with_counts(tmp_path, caplog):
    lines = _lines(ROVER)
    cut = _write(tmp_path, "cut.rnx", lines[:_epoch_lines(lines)[25]])
    with caplog.at_level(logging.WARNING):
        obs = read_rinex_obs(cut)
    assert obs.table["gps_time_s"].nunique() == 25
    (message,) = _warnings(caplog)
    # header: 12:40:00 to 12:42:59 at 1 s = 180 epochs; 25 read -> 155 missing
    assert str(cut) in message and "155 of 180 epochs" in message
    assert "TIME OF LAST OBS is 2020-11-29 12:42:59" in message
    assert obs.header.last_obs_gps_time_s - obs.header.first_obs_gps_time_s == 179.0


def test_issue18_complete_obs_files_give_no_warning(caplog):
    with caplog.at_level(logging.WARNING):
        for name in ("rover_obs_1240.rnx", "base_obs_1240.rnx"):
            read_rinex_obs(GNSS_DATA / name)
    assert _warnings(caplog) == []


def test_issue18_obs_losing_its_first_epochs_is_reported(tmp_path, caplog):
    lines = _lines(ROVER)
    first = _epoch_lines(lines)
    body_start = first[0]
    cut = _write(tmp_path, "late.rnx", lines[:body_start] + lines[first[10]:])
    with caplog.at_level(logging.WARNING):
        read_rinex_obs(cut)
    (message,) = _warnings(caplog)
    assert "TIME OF FIRST OBS" in message and "10 of 180 epochs" in message


def test_issue18_declared_observation_counts_of_a_peer_file(caplog):
    """georinex's demo.10o keeps 2 epochs of a day whose header (gLAB) still declares
    ``G07   815 ...`` observations (line 24) and TIME OF LAST OBS 23:59:30."""
    with caplog.at_level(logging.WARNING):
        obs = read_rinex_obs(PEERS / "demo.10o")
    assert obs.header.obs_counts["G07"] == [815] * 7
    assert obs.header.n_satellites == 14
    (message,) = [m for m in _warnings(caplog) if "declares" in m]
    assert "G07 2 of 815" in message and "14 of 14 satellites" in message
    # 00:00:00 to 23:59:30 at 30 s = 2880 epochs, the file's last at 00:00:30
    assert "2878 of 2880 epochs" in message


# --- dates that name no instant ---------------------------------------------------------

@pytest.mark.parametrize("label, field", [("2020 13 29", "month"), ("2020 11 45", "day"),
                                          ("2020 02 30", "day"), ("2021 02 29", "day")])
def test_issue18_obs_epoch_date_out_of_range_is_a_located_error(tmp_path, label, field):
    lines = _lines(ROVER)
    k = _epoch_lines(lines)[5]
    lines[k] = lines[k][:2] + label + lines[k][12:]
    with pytest.raises(GnssInputError, match=f"line {k + 1}, epoch {field}: {field} "):
        read_rinex_obs(_write(tmp_path, "date.rnx", lines))


def test_issue18_obs_epoch_hour_24_and_leap_day_2020(tmp_path):
    lines = _lines(ROVER)
    k = _epoch_lines(lines)[5]
    hour = lines[:k] + [lines[k][:13] + "24" + lines[k][15:]] + lines[k + 1:]
    with pytest.raises(GnssInputError, match="epoch hour: hour 24 out of range"):
        read_rinex_obs(_write(tmp_path, "hour.rnx", hour))
    leap = lines[:k] + [lines[k][:2] + "2020 02 29" + lines[k][12:]] + lines[k + 1:]
    obs = read_rinex_obs(_write(tmp_path, "leap.rnx", leap))        # 2020-02-29 exists
    assert obs.table["gps_time_s"].min() == calendar_to_gps_time_s(2020, 2, 29, 12, 40, 5.0)


def test_issue18_header_and_nav_and_sp3_dates_out_of_range(tmp_path):
    lines = _lines(ROVER)
    k = next(i for i, ln in enumerate(lines) if "TIME OF LAST OBS" in ln)
    lines[k] = lines[k][:6] + "    13" + lines[k][12:]
    with pytest.raises(GnssInputError, match=f"line {k + 1}.*month 13"):
        read_rinex_obs(_write(tmp_path, "head.rnx", lines))
    nav = _lines(NAV)
    head, _ = _records(nav)
    k = next(i for i, ln in enumerate(nav) if i >= len(head) and ln.startswith("G"))
    nav[k] = nav[k][:9] + "13" + nav[k][11:]
    with pytest.raises(GnssInputError, match=f"line {k + 1}, epoch month"):
        read_rinex_nav(_write(tmp_path, "nav.rnx", nav))
    sp3 = _lines(COD)
    k = next(i for i, ln in enumerate(sp3) if ln.startswith("*"))
    sp3[k] = sp3[k][:11] + "45" + sp3[k][13:]
    with pytest.raises(GnssInputError, match=f"line {k + 1}, epoch day: day 45"):
        read_sp3(_write(tmp_path, "date.sp3", sp3))


# --- bytes that are not ASCII -------------------------------------------------------------

def _with_byte(path: Path, line: int, column: int, byte: bytes, out: Path) -> Path:
    lines = path.read_bytes().split(b"\n")
    lines[line - 1] = lines[line - 1][:column - 1] + byte + lines[line - 1][column:]
    out.write_bytes(b"\n".join(lines))
    return out


@pytest.mark.parametrize("reader, source, line, column", [
    (read_rinex_obs, ROVER, 49, 1),       # the satellite letter of a record
    (read_rinex_obs, ROVER, 49, 30),      # inside a pseudorange
    (read_rinex_obs, ROVER, 48, 3),       # an epoch line
    (read_rinex_nav, NAV, 12, 1),
    (read_sp3, COD, 24, 2),               # a satellite code
    (read_sp3, COD, 24, 11)])
def test_issue18_non_ascii_bytes_are_located_errors(tmp_path, reader, source, line, column):
    path = _with_byte(source, line, column, b"\xff", tmp_path / source.name)
    with pytest.raises(GnssInputError,
                       match=f"line {line}, column {column}: byte 0xff is not ASCII"):
        reader(path)


def test_issue18_non_ascii_sp3_comment_is_accepted(tmp_path):
    k = next(i for i, ln in enumerate(_lines(COD)) if ln.startswith("/*")) + 1
    path = _with_byte(COD, k, 20, "é".encode(), tmp_path / "comment.sp3")
    assert read_sp3(path).table["sv"].nunique() == 76


# --- navigation files: header only, cut mid-line, a year old, a system lost --------------

def _records(lines: list[str]) -> tuple[list[str], list[list[str]]]:
    end = next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln) + 1
    records, i = [], end
    while i < len(lines):
        if lines[i].strip():
            n = CONTINUATION[lines[i][0]]
            records.append(lines[i:i + 1 + n])
            i += 1 + n
        else:
            i += 1
    return lines[:end], records


def test_issue18_header_only_nav_names_both_files(tmp_path, caplog):
    head, _ = _records(_lines(NAV))
    path = _write(tmp_path, "head_only.rnx", head)
    with caplog.at_level(logging.WARNING):
        nav = read_rinex_nav(path)
    assert "no navigation records" in _warnings(caplog)[0]
    obs = read_rinex_obs(ROVER)
    with pytest.raises(GnssInputError, match="no navigation records of E.*G") as info:
        check_nav_coverage(obs, nav, "GE")
    assert str(path) in str(info.value) and str(ROVER) in str(info.value)


def test_issue18_nav_cut_mid_line_is_a_located_error(tmp_path):
    data = NAV.read_bytes()
    path = tmp_path / "cut.rnx"
    path.write_bytes(data[:1500])              # inside the 8th line of the first record
    line = data[:1500].count(b"\n") + 1
    with pytest.raises(GnssInputError, match=f"line {line}: the file ends inside this line"):
        read_rinex_nav(path)


def _shifted(record: list[str], days: int) -> list[str]:
    """A RINEX 3 record moved by whole weeks: the clock epoch and the week number."""
    head = record[0]
    t = dt.datetime(*(int(head[a:b]) for a, b in ((4, 8), (9, 11), (12, 14), (15, 17),
                                                   (18, 20), (21, 23))))
    t -= dt.timedelta(days=days)
    out = [head[:4] + t.strftime("%Y %m %d %H %M %S") + head[23:]] + record[1:]
    if head[0] in "GEC":                       # week: line 6, third field (Table A6/A8/A14)
        week = float(out[5][42:61].replace("D", "E")) - days // 7
        out[5] = out[5][:42] + f"{week:19.12e}" + out[5][61:]
    return out


def test_issue18_nav_a_year_older_than_the_obs_names_both_files(tmp_path, capsys):
    head, records = _records(_lines(NAV))
    old = _write(tmp_path, "old.rnx", head + [ln for r in records for ln in _shifted(r, 364)])
    code = main(["-q", "spp", "--obs", str(ROVER), "--nav", str(old), "--out",
                 str(tmp_path / "spp")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert str(old) in err and str(ROVER) in err and "do not cover" in err
    # 364 days before 2020-11-29 is 2019-12-01 (2020 is a leap year)
    assert "2019-12-01" in err and "2020-11-29 12:40:00" in err
    assert not (tmp_path / "spp" / "spp.csv").exists()


def test_issue18_nav_record_week_inconsistent_with_its_epoch(tmp_path):
    head, records = _records(_lines(NAV))
    first = records[0]
    moved = _shifted(first, 364)[:1] + first[1:]            # epoch moved, week kept
    path = _write(tmp_path, "bad_week.rnx", head + moved)
    with pytest.raises(GnssInputError, match="52.0 weeks apart"):
        read_rinex_nav(path)


def test_issue18_nav_lost_all_gps_records_is_reported(tmp_path, caplog):
    head, records = _records(_lines(NAV))
    path = _write(tmp_path, "no_gps.rnx",
                  head + [ln for r in records if r[0][0] != "G" for ln in r])
    nav, obs = read_rinex_nav(path), read_rinex_obs(ROVER)
    with caplog.at_level(logging.WARNING):
        check_nav_coverage(obs, nav, "GE")
    (message,) = _warnings(caplog)
    assert "no navigation records of G (GPS)" in message and str(ROVER) in message
    with pytest.raises(GnssInputError, match="no navigation records of G"):
        check_nav_coverage(obs, nav, "G")


def test_issue18_complete_nav_covers_the_obs_silently(caplog):
    with caplog.at_level(logging.WARNING):
        check_nav_coverage(read_rinex_obs(ROVER), read_rinex_nav(NAV), "GERC")
    assert _warnings(caplog) == []


# --- SP3: fewer epochs or satellites than declared ---------------------------------------

def test_issue18_sp3_with_2_of_15_epochs(tmp_path, caplog):
    lines = _lines(COD)
    third = [i for i, ln in enumerate(lines) if ln.startswith("*")][2]
    path = _write(tmp_path, "two.sp3", lines[:third])
    with caplog.at_level(logging.WARNING):
        sp3 = read_sp3(path)
    (message,) = _warnings(caplog)
    assert "line 1 declares 15 epochs, the file holds 2" in message
    with pytest.raises(GnssError, match="G05 has 2 valid epochs, a degree-10 interpolation "
                                        "needs 11"):
        sp3.interpolate("G05", sp3.table["gps_time_s"].iloc[0] + 60.0)
    with pytest.raises(GnssInputError, match="no satellite has the 11 valid epochs"):
        PreciseOrbits.from_sp3(sp3)
    with pytest.raises(GnssInputError, match="do not cover the observations"):
        check_sp3_coverage(read_rinex_obs(ROVER), [sp3])


def test_issue18_sp3_missing_a_satellite_and_a_cut_epoch(tmp_path, caplog):
    lines = _lines(COD)
    no_g05 = _write(tmp_path, "no_g05.sp3", [ln for ln in lines if not ln.startswith("PG05")])
    last = [i for i, ln in enumerate(lines) if ln.startswith("*")][-1]
    cut = _write(tmp_path, "cut.sp3", lines[:last + 20])       # 19 of 76 satellites
    with caplog.at_level(logging.WARNING):
        read_sp3(no_g05)
        read_sp3(cut)
    first, second = _warnings(caplog)
    assert "1 of the 76 listed satellites have no position record (G05)" in first
    assert "1 of 15 epochs hold fewer than the 76 declared satellites (as few as 19)" in second


def test_issue18_sp3_record_cut_short_and_complete_files_silent(tmp_path, caplog):
    lines = _lines(COD)
    k = next(i for i, ln in enumerate(lines) if ln.startswith("P"))
    lines[k] = lines[k][:50]
    with pytest.raises(GnssInputError, match=f"line {k + 1}: position record cut short"):
        read_sp3(_write(tmp_path, "short.sp3", lines))
    with caplog.at_level(logging.WARNING):
        for name in ("COD21340_1100_1430.sp3", "igr21340_1100_1430.sp3"):
            read_sp3(GNSS_DATA / name)
    assert _warnings(caplog) == []
    assert np.isfinite(read_sp3(COD).interpolate("G05", 1290682800.0 + 600.0)[0]).all()
