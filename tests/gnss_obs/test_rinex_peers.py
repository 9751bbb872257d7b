"""Issue 16 reader regressions: peer test files (data/gnss/peers), time systems, leniency,
archives, RINEX 2.12 Galileo and RINEX 4 navigation.

Every expected value is the text of the file it comes from (the RINEX line is quoted) or
a definition of the RINEX standard; the peer files are georinex's (MIT, see the README).
"""
from __future__ import annotations

import bz2
import logging
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gnss_obs.constants import WEEK_S
from gnss_obs.errors import GnssInputError
from gnss_obs.gpstime import calendar_to_gps_time_s
from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import read_rinex_obs

DATA = Path(__file__).resolve().parents[2] / "data" / "gnss"
PEERS = DATA / "peers"
NAV3 = DATA / "broadcast_nav.rnx"


def _one_warning(caplog, path) -> str:
    # the truncation warning of issue 18 (the peer excerpts hold fewer epochs than their
    # headers declare) is another concern, tested apart
    lines = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING
             and "than the header declares" not in r.getMessage()]
    assert len(lines) == 1, lines            # once per file
    assert str(path) in lines[0]
    return lines[0]


def test_issue16_demo10o_approx_position_one_column_late(caplog):
    """georinex demo.10o line 13 ``   4789028.4701    176610.0133   4195017.0310`` puts each
    F14.4 value one column late; the three numbers are unambiguous (RTKLIB reads them)."""
    with caplog.at_level(logging.WARNING):
        obs = read_rinex_obs(PEERS / "demo.10o")
    np.testing.assert_array_equal(obs.header.approx_position_e,
                                  [4789028.4701, 176610.0133, 4195017.0310])
    assert "line 13" in _one_warning(caplog, PEERS / "demo.10o")
    # epoch 1 of the file: 14 satellites at 2010-03-05 00:00:00 GPS (TIME OF FIRST OBS)
    t0 = calendar_to_gps_time_s(2010, 3, 5, 0, 0, 0.0)
    first = obs.table[obs.table["gps_time_s"] == t0]
    assert first["sv"].nunique() == 14
    # G13 (first satellite) C1 = 23095483.463 in the file (type 5 of 7, mapped to C1C)
    row = first[(first["sv"] == "G13") & (first["signal"] == "1C")]
    assert row["pseudorange_m"].item() == 23095483.463


def test_issue16_minimal10o_time_system_one_column_late(caplog):
    """georinex minimal.10o line 3 has ``GPS`` in columns 50-52 instead of 49-51."""
    with caplog.at_level(logging.WARNING):
        obs = read_rinex_obs(PEERS / "minimal.10o")
    assert obs.header.time_system == "GPS"
    assert "line 3" in _one_warning(caplog, PEERS / "minimal.10o")
    assert obs.table["gps_time_s"].unique().tolist() == [
        float(calendar_to_gps_time_s(2010, 3, 5, 0, 0, 30.0))]
    assert obs.table["sv"].nunique() == 8       # "  8G13R19G32G 7R23G31G20R11"


def test_issue16_demo10n_delta_utc_shifted(caplog):
    """georinex demo.10n line 9: ``   0.133179128170D-06   0.107469588780D-12   552960
    1025DELTA-UTC`` is not in 3X,2D19.12,2I9; read by blanks, A1 must not become 0.0107."""
    with caplog.at_level(logging.WARNING):
        nav = read_rinex_nav(PEERS / "demo.10n")
    assert nav.header.time_corrections["GPUT"] == (0.133179128170e-06, 0.107469588780e-12,
                                                   552960.0, 1025)
    assert "line 9" in _one_warning(caplog, PEERS / "demo.10n")
    g = nav.records["G"]
    assert g["sv"].tolist() == ["G06", "G13"]
    assert g["af0_s"].tolist() == [-.839701388031e-03, .490025617182e-03]
    np.testing.assert_array_equal(nav.header.iono_gps_alpha,
                                  [0.1676e-07, 0.2235e-07, -0.1192e-07, -0.1192e-07])


def test_issue16_rinex212_galileo_nav():
    """teqc RINEX 2.12 Galileo navigation (type ``E``, 2-digit PRN, RINEX 2 columns, the
    RINEX 3 Galileo field order; ION ALPHA = NeQuick-G ai0-ai2)."""
    nav = read_rinex_nav(PEERS / "ceda2100_3rec.18e")
    e = nav.records["E"]
    assert e["sv"].tolist() == ["E02", "E03", "E05"]    # sorted by sv
    e05 = e[e["sv"] == "E05"].iloc[0]
    # " 5 18  7 29  2 50  0.0 2.207611105405D-04-6.536993168993D-12 ..." (GST = GPST labels)
    assert e05["toc_gps_s"] == calendar_to_gps_time_s(2018, 7, 29, 2, 50, 0.0)
    assert e05["af0_s"] == 2.207611105405e-04
    assert e05["data_sources"] == 517 and e05["week"] == 2012
    assert e05["toe_gps_s"] == 2012 * WEEK_S + 1.020000000000e+04
    np.testing.assert_array_equal(nav.header.iono_gal, [4.9250e+01, 2.0703e-01, 4.0283e-03])


def test_issue16_wrong_v2_type_says_so(tmp_path):
    """A RINEX 2 GLONASS-type ('G') file holding GPS records (8 lines each) cannot be read;
    the message names the line and the probable cause instead of a field error."""
    text = (PEERS / "demo.10n").read_text().replace("N: GPS NAV. MESSAGE",
                                                    "G: GLONASS NAV DATA")
    path = tmp_path / "wrong.10g"
    path.write_text(text)
    with pytest.raises(GnssInputError, match=r"line 16.*file type letter"):
        read_rinex_nav(path)


@pytest.mark.parametrize("kind", ["zip", "bz2"])
def test_issue16_zip_and_bz2(tmp_path, kind):
    """Archives are read through the standard library and give the plain file's table."""
    plain = read_rinex_obs(PEERS / "demo.10o")
    path = tmp_path / f"demo.10o.{kind}"
    if kind == "zip":
        with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as z:
            z.write(PEERS / "demo.10o", "demo.10o")
    else:
        path.write_bytes(bz2.compress((PEERS / "demo.10o").read_bytes()))
    pd.testing.assert_frame_equal(read_rinex_obs(path).table, plain.table)


def test_issue16_zip_with_two_files_is_a_clear_error(tmp_path):
    path = tmp_path / "two.zip"
    with zipfile.ZipFile(path, "w") as z:
        z.write(PEERS / "demo.10o", "a.10o")
        z.write(PEERS / "demo.10n", "b.10n")
    with pytest.raises(GnssInputError, match="zip archive holds 2 files"):
        read_rinex_obs(path)


def _obs_glonass_only(time_system: str) -> str:
    """A RINEX 3.04 GLONASS-only observation file with one epoch at 12:40:00."""
    def h(content, label):
        return f"{content:<60}{label:<20}\n"
    return (h("     3.04           OBSERVATION DATA    R", "RINEX VERSION / TYPE")
            + h("R    1 C1C", "SYS / # / OBS TYPES")
            + h(f"  2020    11    29    12    40    0.0000000     {time_system:3}",
                "TIME OF FIRST OBS")
            + h("", "END OF HEADER")
            + "> 2020 11 29 12 40  0.0000000  0  1\n"
            + "R01  20000000.000\n")


@pytest.mark.parametrize("time_system", ["GLO", ""])
def test_issue16_glonass_obs_tags_are_utc(tmp_path, time_system):
    """RINEX 3.04 §3.2 / Table A1: GLO = UTC; a GLONASS-only file without a time system
    defaults to GLO (§5.3 TIME OF FIRST OBS). 12:40:00 GLO is 12:40:18 GPST (18 leap
    seconds, IERS Bulletin C, in force since 2017-01-01)."""
    path = tmp_path / "glo.rnx"
    path.write_text(_obs_glonass_only(time_system))
    obs = read_rinex_obs(path)
    assert obs.header.time_system == "GLO"
    assert obs.table["gps_time_s"].item() == calendar_to_gps_time_s(2020, 11, 29, 12, 40, 18.0)


def _nav_header_v3(leap_line: str) -> str:
    return ("     3.04           NAVIGATION DATA     C" + " " * 19 + "RINEX VERSION / TYPE\n"
            + f"{leap_line:<60}LEAP SECONDS        \n"
            + " " * 60 + "END OF HEADER\n")


@pytest.mark.parametrize("line, expected", [("     4     4  2134     6BDS", 18),
                                            ("    18", 18), ("    18    18  2134     7GPS", 18)])
def test_issue16_beidou_leap_seconds(tmp_path, line, expected):
    """RINEX 3.04 Table A5 LEAP SECONDS: columns 25-27 name the time system of the counts;
    with ``BDS`` they are BDT - UTC (4 s in 2020), so GPST - UTC = 4 + 14 (BDT = GPST - 14 s,
    BDS-SIS-ICD §5.1.2.2)."""
    path = tmp_path / "bds.rnx"
    path.write_text(_nav_header_v3(line))
    assert read_rinex_nav(path).header.leap_seconds == expected


def _to_rinex4(text: str, n_records: int) -> str:
    """The first records of a RINEX 3.04 nav file in RINEX 4.01 framing, plus records the
    reader must skip (STO, a CNAV ephemeris) and a GPS ION record from the 3.04 header."""
    lines = text.splitlines()
    end = next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln)
    klob = {ln[:4]: ln[5:53].split() for ln in lines[:end] if ln[:4] in ("GPSA", "GPSB")}
    a, b = [[float(v) for v in klob[k]] for k in ("GPSA", "GPSB")]
    head = ["     4.01           N: GNSS NAV DATA    M: MIXED            RINEX VERSION / TYPE"]
    head += [ln for ln in lines[1:end] if "IONOSPHERIC CORR" not in ln] + [lines[end]]

    def d(x):
        return f"{x:19.12e}"
    body = ["> ION G01 LNAV", "    2020 11 29 00 00 00" + d(a[0]) + d(a[1]) + d(a[2]),
            "    " + d(a[3]) + d(b[0]) + d(b[1]) + d(b[2]), "    " + d(b[3]) + d(0.0),
            "> STO G01 LNAV", "    2020 11 29 00 00 00 GPUT  UTC(USNO)",
            "    " + d(0.0) + d(0.0) + d(0.0) + d(0.0),
            "> EPH G01 CNAV", "G01 2020 11 29 12 00 00" + d(0.0) * 3] + ["    " + d(0.0) * 4] * 8
    i, k = end + 1, 0
    while k < n_records and i < len(lines):
        sv = lines[i][:3]
        n = {"R": 3, "S": 3}.get(sv[0], 7)
        msg = {"G": "LNAV", "E": "INAV", "C": "D1", "R": "FDMA", "S": "SBAS", "J": "LNAV"}
        body += [f"> EPH {sv} {msg[sv[0]]}"] + lines[i:i + 1 + n]
        if sv[0] == "R":            # RINEX >= 3.05 GLONASS: a 4th broadcast-orbit line
            body.append("    " + d(0.0) * 4)
        i += 1 + n
        k += 1
    return "\n".join(head + body) + "\n"


def test_issue16_rinex4_nav_matches_rinex3(tmp_path, caplog):
    """RINEX 4.01 legacy-message records carry the RINEX 3 record layout (Table A31), so the
    same records in both framings give identical tables; the GPS ION record gives the
    Klobuchar coefficients the 3.04 header states; the CNAV and STO records are skipped
    with one warning."""
    text = NAV3.read_text()
    v3 = read_rinex_nav(NAV3)
    path = tmp_path / "nav4.rnx"
    path.write_text(_to_rinex4(text, n_records=len(text)))  # all records
    with caplog.at_level(logging.WARNING):
        v4 = read_rinex_nav(path)
    warning = _one_warning(caplog, path)
    assert "1 EPH G CNAV" in warning and "1 STO" in warning
    assert v4.header.version == 4.01
    np.testing.assert_allclose(v4.header.iono_gps_alpha, v3.header.iono_gps_alpha, rtol=1e-12)
    np.testing.assert_allclose(v4.header.iono_gps_beta, v3.header.iono_gps_beta, rtol=1e-12)
    assert set(v4.records) <= set(v3.records) and len(v4.records) >= 3
    for system, frame in v4.records.items():
        expected = v3.records[system]
        expected = expected[expected.set_index(["sv", "toc_gps_s"]).index.isin(
            frame.set_index(["sv", "toc_gps_s"]).index)].reset_index(drop=True)
        assert len(frame) > 0
        pd.testing.assert_frame_equal(frame.reset_index(drop=True), expected)
