"""RINEX 3 navigation reader against georinex, ICD conventions and broken files."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gnss_obs.constants import WEEK_S
from gnss_obs.errors import GnssInputError
from gnss_obs.gpstime import datetime64_to_gps_time_s
from gnss_obs.rinex_nav import KEPLER_FIELDS, read_rinex_nav

DATA = Path(__file__).resolve().parents[2] / "data" / "gnss"
NAV = DATA / "broadcast_nav.rnx"
#: GLONASS nominal orbit radius 25,510 km (ICD 5.1 §3.1); eccentricity < 0.01 keeps any
#: position within 1 % of it.
GLONASS_RADIUS_M = 25_510e3
GLONASS_RADIUS_RTOL = 0.01
#: Header LEAP SECONDS of the file (GPST - UTC), and BDT = GPST - 14 s.
LEAP_S = 18
BDT_S = 14

#: georinex 1.16 variable -> our column, per system.
COMMON = {"SVclockBias": "af0_s", "SVclockDrift": "af1_sps", "SVclockDriftRate": "af2_sps2",
          "Crs": "crs_m", "DeltaN": "delta_n_radps", "M0": "m0_rad", "Cuc": "cuc_rad",
          "Eccentricity": "e", "Cus": "cus_rad", "sqrtA": "sqrt_a_sqrtm", "Toe": "toe_sow",
          "Cic": "cic_rad", "Omega0": "omega0_rad", "Cis": "cis_rad", "Io": "i0_rad",
          "Crc": "crc_m", "omega": "omega_rad", "OmegaDot": "omega_dot_radps",
          "IDOT": "idot_radps", "TransTime": "transmission_time_sow"}
GEORINEX = {
    "G": {**COMMON, "IODE": "iode", "GPSWeek": "week", "SVacc": "sv_accuracy_m",
          "health": "health", "TGD": "tgd_s", "IODC": "iodc"},
    "E": {**COMMON, "IODnav": "iode", "DataSrc": "data_sources", "GALWeek": "week",
          "SISA": "sv_accuracy_m", "health": "health", "BGDe5a": "bgd_e5a_e1_s",
          "BGDe5b": "bgd_e5b_e1_s"},
    "C": {**COMMON, "AODE": "aode", "BDTWeek": "week", "SVacc": "sv_accuracy_m",
          "SatH1": "health", "TGD1": "tgd1_s", "TGD2": "tgd2_s", "AODC": "aodc"},
    "R": {"SVclockBias": "clock_bias_s", "SVrelFreqBias": "gamma_n",
          "MessageFrameTime": "message_frame_time_s", "X": "x_m", "dX": "vx_mps",
          "dX2": "ax_mps2", "Y": "y_m", "dY": "vy_mps", "dY2": "ay_mps2", "Z": "z_m",
          "dZ": "vz_mps", "dZ2": "az_mps2", "health": "health", "FreqNum": "freq_channel",
          "AgeOpInfo": "age_days"},
    "S": {"SVclockBias": "af0_s", "SVrelFreqBias": "af1_sps",
          "MessageFrameTime": "message_frame_time_s", "X": "x_m", "dX": "vx_mps",
          "dX2": "ax_mps2", "Y": "y_m", "dY": "vy_mps", "dY2": "ay_mps2", "Z": "z_m",
          "dZ": "vz_mps", "dZ2": "az_mps2", "health": "health", "URA": "ura",
          "IODN": "iodn"},
}
#: Offset from the file's clock-epoch labels to GPS time, per system (RINEX 3.04 §6.6).
LABEL_TO_GPS_S = {"G": 0.0, "E": 0.0, "C": BDT_S, "R": LEAP_S, "S": 0.0}


@pytest.fixture(scope="module")
def nav():
    return read_rinex_nav(NAV)


def test_header_values_typed_from_the_file(nav):
    h = nav.header
    assert h.leap_seconds == LEAP_S
    np.testing.assert_array_equal(h.iono_gps_alpha, [1.4901e-08, -1.4901e-08, -5.9605e-08,
                                                     1.1921e-07])
    np.testing.assert_array_equal(h.iono_gps_beta, [1.2083e+05, -2.2938e+05, -6.5536e+04,
                                                    8.5197e+05])
    np.testing.assert_array_equal(h.iono_gal, [6.9250e+01, 3.5156e-02, -3.9063e-03])
    assert h.iono_bds_alpha is None
    assert h.time_corrections["GPUT"] == (9.3132257462e-10, 4.440892099e-15, 147456.0, 2134)
    assert h.time_corrections["GAGP"] == (-4.9185473472e-09, -1.731947918e-14, 86400.0, 2134)


def test_record_counts_match_the_file(nav):
    text = NAV.read_text().split("END OF HEADER")[1]
    for system, df in nav.records.items():
        assert len(df) == len(re.findall(rf"^{system}\d\d ", text, flags=re.M))


def test_against_georinex(nav):
    gr = pytest.importorskip("georinex")
    ds = gr.load(NAV)
    for system, mapping in GEORINEX.items():
        svs = [sv for sv in ds.sv.values if sv[0] == system]
        sub = ds.sel(sv=svs)
        theirs = sub.to_dataframe().reset_index()
        theirs = theirs.dropna(subset=[next(iter(mapping))])
        theirs["sv"] = theirs["sv"].str[:3]   # georinex names a duplicate E01 record E01_1
        theirs["toc_gps_s"] = (datetime64_to_gps_time_s(theirs["time"].to_numpy())
                               + LABEL_TO_GPS_S[system])
        theirs = theirs[["sv", "toc_gps_s", *mapping]].rename(columns=mapping)
        ours = nav.records[system][["sv", "toc_gps_s", *mapping.values()]]
        key = ["sv", "toc_gps_s", "message_frame_time_s" if system in "RS"
               else "transmission_time_sow", mapping.get("DataSrc", "toc_gps_s")]
        a = ours.sort_values(key, ignore_index=True)
        b = theirs.sort_values(key, ignore_index=True)
        assert len(a) == len(b)
        for column in a.columns:
            np.testing.assert_array_equal(a[column].to_numpy(dtype=object if column == "sv"
                                                             else float),
                                          b[column].to_numpy(dtype=object if column == "sv"
                                                             else float), err_msg=column)


def test_toe_and_toc_agree_as_gps_seconds(nav):
    # GPS, Galileo and BeiDou broadcast the ephemeris and clock for the same epoch
    # (toe = toc), each in its own time scale: the conversion of week + toe (BeiDou week
    # zero = GPS week 1356, BDT = GPST - 14 s) must land on the converted toc.
    for system in "GEC":
        df = nav.records[system]
        np.testing.assert_array_equal(df["toe_gps_s"], df["toc_gps_s"], err_msg=system)
    c = nav.records["C"]
    assert (c["week"] + 1356 == 2134).all()   # BDT week 778 is GPS week 2134
    g = nav.records["G"]
    assert ((g["toc_gps_s"] - g["week"] * WEEK_S) == g["toe_sow"]).all()


def test_kepler_columns_and_units(nav):
    for system in "GEC":
        df = nav.records[system]
        assert list(df.columns[:3]) == ["sv", "prn", "toc_gps_s"]
        assert set(KEPLER_FIELDS) <= set(df.columns)
        # sqrt(A) of MEO satellites: ~5153 (GPS), ~5440 (Galileo), ~5282 (BDS MEO) sqrt(m)
        assert df["sqrt_a_sqrtm"].between(5000, 6500).all()
    e = nav.records["E"]
    assert set(e["nav_type"]) == {"INAV", "FNAV"}
    assert ((e["data_sources"] & 2 > 0) == (e["nav_type"] == "FNAV")).all()
    assert e["tgd_s"].isna().all() and nav.records["G"]["tgd_s"].notna().all()


def test_glonass_in_metres_and_tau_sign(nav):
    r = nav.records["R"]
    radius = np.linalg.norm(r[["x_m", "y_m", "z_m"]].to_numpy(), axis=1)
    np.testing.assert_allclose(radius, GLONASS_RADIUS_M, rtol=GLONASS_RADIUS_RTOL)
    assert (r["tau_n_s"] == -r["clock_bias_s"]).all()
    # first GLONASS record of the file: R04 at 10:15:00 UTC
    text = NAV.read_text()
    line = next(ln for ln in text.splitlines() if ln.startswith("R04 2020 11 29 10 15 00"))
    first = r[r["sv"] == "R04"].iloc[0]
    assert first["clock_bias_s"] == float(line[23:42].replace("D", "E"))
    assert first["toc_gps_s"] == datetime64_to_gps_time_s(
        np.datetime64("2020-11-29T10:15:00")) + LEAP_S


def _nav_lines() -> list[str]:
    """Header and the first five (BeiDou, 8-line) records."""
    lines = NAV.read_text().split("\n")
    end = next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln) + 1
    return lines[:end + 5 * 8]


def _write(tmp_path, lines):
    path = tmp_path / "nav.rnx"
    path.write_text("\n".join(lines) + "\n")
    return path


def _raises(path, line, what):
    return pytest.raises(GnssInputError, match=rf"^{re.escape(str(path))}: line {line}\b.*{what}")


def test_broken_navigation_files(tmp_path):
    lines = _nav_lines()
    first = next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln) + 1
    cases = [
        # (edit, line (1-based) and message expected)
        (lambda ls: ls[:first + 5], first + 1, "file ends inside a record"),
        (lambda ls: ls[:first + 3] + ls[first + 4:], first + 8, "fewer than 7"),
        (lambda ls: ls[:first + 2] + [ls[first + 2][:30] + "X" + ls[first + 2][31:]]
         + ls[first + 3:], first + 3, "crs_m|delta_n|not a number"),
        (lambda ls: ls[:first] + ["Z" + ls[first][1:]] + ls[first + 1:], first + 1,
         "unsupported satellite system 'Z'"),
        (lambda ls: ls[:first + 1] + [ls[first + 1][:40]] + ls[first + 2:], first + 2,
         "not a number"),
    ]
    for edit, line, what in cases:
        path = _write(tmp_path, edit(list(lines)))
        with _raises(path, line, what):
            read_rinex_nav(path)


def test_observation_file_is_not_a_navigation_file():
    path = DATA / "rover_obs_1240.rnx"
    with _raises(path, 1, "wrong file type 'O'"):
        read_rinex_nav(path)


def test_rinex305_glonass_records_have_a_fifth_line(tmp_path):
    # RINEX 3.05 adds a fourth broadcast-orbit line to GLONASS records (status flags,
    # L1/L2 delay difference, URAI, health flags): same values, one more line to skip.
    lines = NAV.read_text().split("\n")
    end = next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln) + 1
    k = next(i for i, ln in enumerate(lines) if ln.startswith("R04 "))
    extra = "    " + " 0.000000000000e+00" * 4
    v305 = ["     3.05" + lines[0][9:]] + lines[1:end] + lines[k:k + 4] + [extra]
    path = _write(tmp_path, v305)
    got = read_rinex_nav(path).records["R"]
    expected = read_rinex_nav(NAV).records["R"].iloc[[0]].reset_index(drop=True)
    pd.testing.assert_frame_equal(got, expected)
