"""RINEX observation reader against georinex, a plain per-value parser, the reference
trajectory's GPS week/seconds and hand-made files (events, RINEX 2.11, malformed input)."""
from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gnss_obs.constants import WEEK_S
from gnss_obs.gpstime import datetime64_to_gps_time_s
from gnss_obs.rinex_obs import read_rinex_obs

DATA = Path(__file__).resolve().parents[2] / "data" / "gnss"
ROVER = DATA / "rover_obs_1240.rnx"
NAV = DATA / "broadcast_nav.rnx"
KINDS = {"C": "pseudorange_m", "L": "carrier_cycles", "D": "doppler_hz", "S": "cn0_dbhz"}
#: 2020-11-29 12:40:00 GPST is Sunday of GPS week 2134 (COD21340.sp3 names it), 45600 s.
FIRST_EPOCH_S = 2134 * WEEK_S + 12 * 3600 + 40 * 60


def _text_lines() -> list[str]:
    return ROVER.read_text().split("\n")


def _first_epochs(n_epochs: int) -> str:
    """Header and the first `n_epochs` epochs of the excerpt, as text."""
    lines = _text_lines()
    starts = [i for i, ln in enumerate(lines) if ln.startswith(">")]
    return "\n".join(lines[:starts[n_epochs]]) + "\n"


def _header_end() -> int:
    return next(i for i, ln in enumerate(_text_lines()) if "END OF HEADER" in ln) + 1


@pytest.fixture(scope="module")
def rover():
    return read_rinex_obs(ROVER)


def _plain_parse(path: Path) -> dict:
    """A slow, independent reading: every 16-column field with Python's float()."""
    lines = path.read_text().split("\n")
    types, out, t = {}, {}, None
    end = next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln)
    for ln in lines[:end]:
        if ln[60:].strip() == "SYS / # / OBS TYPES":
            if ln[0] != " ":
                system = ln[0]
                types[system] = []
            types[system] += ln[7:60].split()
    for ln in lines[end + 1:]:
        if ln.startswith(">"):
            t = (int(ln[13:15]), int(ln[16:18]), float(ln[18:29]))
            continue
        if not ln:
            continue
        for j, code in enumerate(types[ln[0]]):
            text = ln[3 + 16 * j:3 + 16 * j + 14]
            if text.strip():
                out[(t, ln[:3], code)] = float(text)
    return out


def test_every_value_matches_a_plain_float_parse(rover):
    ref = _plain_parse(ROVER)
    table = rover.table
    sow = table["gps_time_s"].to_numpy() - FIRST_EPOCH_S + 12 * 3600 + 40 * 60
    got = {}
    for kind, column in KINDS.items():
        present = table[column].notna().to_numpy()
        for s, sv, sig, v in zip(sow[present], table["sv"][present], table["signal"][present],
                                 table[column][present]):
            key = ((int(s // 3600), int(s % 3600 // 60), float(s % 60)), sv, kind + sig)
            got[key] = v
    assert got.keys() == ref.keys()
    assert all(got[k] == ref[k] for k in ref)  # identical floats, not approximately


def test_table_layout_and_order(rover):
    t = rover.table
    assert list(t.columns) == ["gps_time_s", "sv", "system", "prn", "signal", "band",
                               "pseudorange_m", "carrier_cycles", "doppler_hz", "cn0_dbhz",
                               "lli", "ssi", "epoch_flag"]
    keys = list(zip(t["gps_time_s"], t["sv"], t["signal"]))
    assert keys == sorted(keys)
    assert (t["sv"] == t["system"] + t["prn"].map("{:02d}".format)).all()
    assert (t["band"] == t["signal"].str[0].astype(int)).all()
    values = t[list(KINDS.values())]
    assert values.notna().any(axis=1).all()  # no empty rows
    assert set(t["system"]) == {"G", "E", "R", "C", "S"}


def test_header(rover):
    h = rover.header
    # values typed off the excerpt's header lines
    np.testing.assert_array_equal(h.approx_position_e, [4769615.6688, 195962.0732, 4216207.5526])
    assert (h.version, h.interval_s, h.time_system) == (3.04, 1.0, "GPS")
    assert (h.marker_name, h.receiver, h.antenna) == ("CARD", "SEPT MOSAIC-X5",
                                                      "Tallysman TW7972NONE")
    assert {s: len(v) for s, v in h.obs_types.items()} == {"C": 16, "E": 16, "G": 18, "R": 16,
                                                           "S": 8}
    assert h.obs_types["G"][:5] == ["C1C", "C1W", "C2L", "C2W", "C5Q"]
    assert h.glonass_slots == {"R05": 1, "R06": -4, "R07": 5, "R08": 6, "R09": -2, "R10": -7,
                               "R15": 0, "R16": -1, "R22": -3}
    assert h.first_obs_gps_time_s == FIRST_EPOCH_S
    assert h.signal_strength_unit == "DBHZ"


def test_epochs_against_reference_trajectory_week_and_seconds(rover):
    ref = pd.read_csv(DATA / "reference_trajectory_1240.csv")
    t_ref = ref.iloc[:, 0].to_numpy() * float(WEEK_S) + ref.iloc[:, 1].to_numpy()
    epochs = np.unique(rover.table["gps_time_s"])
    assert epochs[0] == FIRST_EPOCH_S
    assert len(epochs) == 180 and np.all(np.diff(epochs) == 1.0)
    assert np.isin(t_ref, epochs).all()


def test_systems_filter(rover):
    ge = read_rinex_obs(ROVER, systems="GE").table
    expected = rover.table[rover.table["system"].isin(["G", "E"])].reset_index(drop=True)
    pd.testing.assert_frame_equal(ge, expected)


def test_gzip_file_reads_the_same(rover, tmp_path):
    path = tmp_path / "rover.rnx.gz"
    path.write_bytes(gzip.compress(ROVER.read_bytes()))
    pd.testing.assert_frame_equal(read_rinex_obs(path).table, rover.table)


def test_against_georinex(tmp_path):
    gr = pytest.importorskip("georinex")
    path = tmp_path / "ten_epochs.rnx"
    path.write_text(_first_epochs(10))
    obs = read_rinex_obs(path)
    ours = obs.table
    ds = gr.load(path, useindicators=True)
    times = datetime64_to_gps_time_s(ds.time.values)
    np.testing.assert_array_equal(times, np.unique(ours["gps_time_s"]))
    sv_systems = np.array([sv[0] for sv in ds.sv.values])
    compared = 0

    def grid(sub, column):
        return sub.pivot_table(index="gps_time_s", columns="sv", values=column, aggfunc="first",
                               dropna=False).reindex(index=times, columns=ds.sv.values).to_numpy()

    for code in (v for v in ds.data_vars if len(v) == 3 and v[0] in KINDS):
        # only satellites whose system declares this code (others are NaN in both)
        cols = np.isin(sv_systems, [s for s, t in obs.header.obs_types.items() if code in t])
        sub = ours[ours["signal"] == code[1:]]
        expected = ds[code].values[:, cols]
        np.testing.assert_array_equal(grid(sub, KINDS[code[0]])[:, cols], expected)
        compared += int(np.isfinite(expected).sum())
        if code[0] == "L":
            has = np.isfinite(expected)
            # georinex 1.16 gives LLI for L1*/L2* carriers only (obs3._indicators)
            for ind in ("lli", "ssi") if code[:2] in ("L1", "L2") else ("ssi",):
                raw = ds[code + ind].values if code + ind in ds else np.zeros(ds[code].shape)
                theirs = np.nan_to_num(raw[:, cols][has])
                np.testing.assert_array_equal(grid(sub, ind)[:, cols][has], theirs)
    assert compared > 3_000  # 10 epochs x ~30 satellites x ~11 values


def test_hatanaka_compressed_file_reads_the_same(rover, tmp_path):
    hatanaka = pytest.importorskip("hatanaka")
    path = tmp_path / "rover.crx.gz"
    path.write_bytes(hatanaka.compress(ROVER.read_bytes(), compression="gz"))
    pd.testing.assert_frame_equal(read_rinex_obs(path).table, rover.table)
