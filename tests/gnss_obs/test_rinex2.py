"""RINEX 2.11 observation and navigation files, written here by hand from typed values.

The observation file has GPS types ``C1 L1 L2 P2 D1 S1`` (two lines per satellite) and an
epoch with 13 satellites (a continuation line in the satellite list); the navigation file
holds the G02 record of the shipped RINEX 3 file moved to the RINEX 2 columns and ``D``
exponents, so both versions must give the same values. (georinex 1.16 cannot serve as a second
reader here: with the installed xarray its RINEX 2 observation path fails in
``obs2.rinexobs2`` merging datasets, DTypePromotionError, for any file.)
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from gnss_obs.gpstime import calendar_to_gps_time_s
from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import read_rinex_obs

DATA = Path(__file__).resolve().parents[2] / "data" / "gnss"
TYPES = ["C1", "L1", "L2", "P2", "D1", "S1"]


def _head(content: str, label: str) -> str:
    return f"{content:<60}{label:<20}"


def _field(value: float | None, lli: int = 0, ssi: int = 0) -> str:
    if value is None:
        return " " * 16
    return f"{value:14.3f}{lli if lli else ' '}{ssi if ssi else ' '}"


def _satellite_lines(values: dict) -> list[str]:
    fields = [_field(*values.get(t, (None,))) for t in TYPES]
    return ["".join(fields[:5]).rstrip(), "".join(fields[5:]).rstrip()]


def _observations() -> dict:
    """(epoch second, sv) -> {type: (value, lli, ssi)}."""
    obs = {(0.0, "G05"): {"C1": (20741344.067, 0, 7), "L1": (108997118.258, 0, 7),
                          "L2": (84932796.345, 1, 6), "P2": (20741347.81, 0, 5),
                          "D1": (-585.312, 0, 0), "S1": (46.281, 0, 0)},
           (0.0, "G07"): {"C1": (24412003.132, 0, 5), "L1": (128285390.582, 0, 5),
                          "S1": (38.0, 0, 0)}}
    for prn in range(1, 14):
        obs[(1.0, f"G{prn:02d}")] = {"C1": (2e7 + 1000.0 * prn + 0.125, 0, 0),
                                     "P2": (2e7 + 1000.0 * prn + 2.5, 0, 0)}
    return obs


def _obs_file(path: Path) -> Path:
    obs = _observations()
    lines = [_head("     2.11           OBSERVATION DATA    G (GPS)", "RINEX VERSION / TYPE"),
             _head("hand-made", "PGM / RUN BY / DATE"),
             _head("TEST", "MARKER NAME"),
             _head("  4769615.6688   195962.0732  4216207.5526", "APPROX POSITION XYZ"),
             _head(f"{len(TYPES):6d}" + "".join(f"{t:>6}" for t in TYPES),
                   "# / TYPES OF OBSERV"),
             _head("     1.000", "INTERVAL"),
             _head("  2020    11    29    12    40    0.0000000     GPS", "TIME OF FIRST OBS"),
             _head("", "END OF HEADER")]
    for second in (0.0, 1.0):
        svs = [sv for (s, sv) in obs if s == second]
        ids = "".join(svs)
        lines.append(f" 20 11 29 12 40{second:11.7f}  0{len(svs):3d}{ids[:36]}")
        if len(svs) > 12:
            lines.append(" " * 32 + ids[36:])
        for sv in svs:
            lines += _satellite_lines(obs[(second, sv)])
    path.write_text("\n".join(lines) + "\n")
    return path


def test_rinex2_observations_map_to_rinex3_signals(tmp_path):
    obs = read_rinex_obs(_obs_file(tmp_path / "test.20o"))
    assert obs.header.version == 2.11
    assert obs.header.obs_types == {"G": ["C1C", "L1C", "L2W", "C2W", "D1C", "S1C"]}
    table = obs.table.set_index(["gps_time_s", "sv", "signal"])
    t0 = float(calendar_to_gps_time_s(2020, 11, 29, 12, 40, 0.0))
    column = {"C1": ("1C", "pseudorange_m"), "L1": ("1C", "carrier_cycles"),
              "L2": ("2W", "carrier_cycles"), "P2": ("2W", "pseudorange_m"),
              "D1": ("1C", "doppler_hz"), "S1": ("1C", "cn0_dbhz")}
    n_values = 0
    for (second, sv), values in _observations().items():
        for code, (value, lli, _) in values.items():
            signal, name = column[code]
            row = table.loc[(t0 + second, sv, signal)]
            assert row[name] == value
            if code[0] == "L":
                assert row["lli"] == lli
            n_values += 1
    assert table[["pseudorange_m", "carrier_cycles", "doppler_hz",
                  "cn0_dbhz"]].notna().to_numpy().sum() == n_values
    assert len(obs.table.query("gps_time_s == @t0 + 1.0")["sv"].unique()) == 13


def _v2_record(v3_lines: list[str]) -> list[str]:
    """A RINEX 3 Keplerian record moved to RINEX 2 columns with D exponents."""
    first = v3_lines[0]
    prn, y, mo, d, h, mi, s = (int(first[1:3]), int(first[4:8]), int(first[9:11]),
                               int(first[12:14]), int(first[15:17]), int(first[18:20]),
                               int(first[21:23]))
    out = [f"{prn:2d} {y % 100:02d} {mo:2d} {d:2d} {h:2d} {mi:2d}{s:5.1f}"
           + first[23:80].replace("e", "D")]
    out += ["   " + ln[4:80].replace("e", "D") for ln in v3_lines[1:]]
    return out


ALPHA = [1.4901e-08, -1.4901e-08, -5.9605e-08, 1.1921e-07]
BETA = [1.2083e+05, -2.2938e+05, -6.5536e+04, 8.5197e+05]


def _d12(values) -> str:
    """Fortran D12.4 fields."""
    return "".join(f"{v:12.4E}".replace("E", "D") for v in values)


def test_rinex2_navigation_equals_rinex3_record(tmp_path):
    text = (DATA / "broadcast_nav.rnx").read_text().split("\n")
    k = next(i for i, ln in enumerate(text) if ln.startswith("G02 "))
    lines = [_head("     2.11           N: GPS NAV DATA", "RINEX VERSION / TYPE"),
             _head("  " + _d12(ALPHA), "ION ALPHA"),
             _head("  " + _d12(BETA), "ION BETA"),
             _head("   9.313225746155D-10 4.440892098501D-15   147456     2134",
                   "DELTA-UTC: A0,A1,T,W"),
             _head("    18", "LEAP SECONDS"),
             _head("", "END OF HEADER")] + _v2_record(text[k:k + 8])
    path = tmp_path / "test.20n"
    path.write_text("\n".join(lines) + "\n")
    v2 = read_rinex_nav(path)
    v3 = read_rinex_nav(DATA / "broadcast_nav.rnx").records["G"]
    expected = v3[v3["sv"] == "G02"].iloc[[0]].reset_index(drop=True)
    pd.testing.assert_frame_equal(v2.records["G"], expected)
    np.testing.assert_array_equal(v2.header.iono_gps_alpha, ALPHA)
    np.testing.assert_array_equal(v2.header.iono_gps_beta, BETA)
    assert v2.header.time_corrections["GPUT"] == (9.313225746155e-10, 4.440892098501e-15,
                                                  147456.0, 2134)
    assert v2.header.leap_seconds == 18
