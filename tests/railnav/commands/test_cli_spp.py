"""``railnav spp`` in-process: files, summary, reference comparison, one-line errors."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from railnav.cli import main
from railnav.errors import ConfigError
from railnav.evaluation.spp_accuracy import (
    accuracy_summary,
    read_reference_trajectory,
    spp_errors,
)

DATA = Path(__file__).resolve().parents[3] / "data" / "gnss"
OBS = DATA / "rover_obs_1240.rnx"
NAV = DATA / "broadcast_nav.rnx"
REF = DATA / "reference_trajectory_1240.csv"
#: The command must print the same accuracy the library computes (to its 2 decimals).
PRINT_DECIMALS_M = 0.005


def test_spp_writes_files_and_prints_accuracy(tmp_path, capsys):
    code = main(["-q", "spp", "--obs", str(OBS), "--nav", str(NAV), "--systems", "GE",
                 "--ref", str(REF), "--out", str(tmp_path)])
    assert code == 0
    frame = pd.read_csv(tmp_path / "spp.csv")
    assert len(frame) == 180 and frame["fix_ok"].all()
    for col in ("gps_time_s", "lat_deg", "lon_deg", "h_m", "v_east_mps", "v_north_mps",
                "v_up_mps", "clock_bias_G_m", "clock_bias_E_m", "clock_drift_mps",
                "n_sat_used", "hdop", "vdop", "pdop", "gdop", "tdop", "hpl_m", "raim_ok"):
        assert col in frame
    assert (tmp_path / "spp.png").stat().st_size > 0
    out = capsys.readouterr().out
    acc = accuracy_summary(spp_errors(frame, read_reference_trajectory(REF)))
    line = next(s for s in out.splitlines() if s.startswith("horizontal RMS"))
    assert abs(float(line.split()[2]) - acc.horizontal_rms_m) < PRINT_DECIMALS_M
    assert "speed RMS" in out and "HDOP" in out
    # the epochs are the file's (GPS time, 12:40:00 onwards), not shifted by leap seconds
    assert frame["gps_time_s"].iloc[0] == 2134 * 604_800 + 45_600.0


def test_reference_in_project_columns(tmp_path):
    ref = read_reference_trajectory(REF)
    path = tmp_path / "ref.csv"
    ref.to_csv(path, index=False)
    back = read_reference_trajectory(path)
    np.testing.assert_allclose(back.to_numpy(), ref.to_numpy())
    assert list(back.columns) == ["gps_time_s", "lat_deg", "lon_deg", "h_m"]


def test_a_fix_log_as_reference_names_both_layouts():
    """The shipped Belgian fix log (a header with latitude, longitude, timestamp) is in
    neither reference layout: the error says which columns are expected, not "row 1, week:
    'id' is not a finite number" (its header line read as the headerless layout's row)."""
    log = DATA.parent / "fixes" / "brussels" / "log_28876_L36-B_excerpt.csv"
    with pytest.raises(ConfigError) as info:
        read_reference_trajectory(log)
    assert str(info.value) == (f"{log}: expected columns gps_time_s, lat_deg, lon_deg, h_m, "
                               "or headerless rows of GPS week, seconds of week, latitude "
                               "(deg), longitude (deg), height (m)")


@pytest.mark.parametrize("case", ["missing_obs", "bad_systems", "bad_ref", "empty_ref"])
def test_bad_input_gives_one_line_and_exit_2(tmp_path, capsys, case):
    args = ["spp", "--obs", str(OBS), "--nav", str(NAV), "--out", str(tmp_path / "o")]
    if case == "missing_obs":
        args[2] = str(tmp_path / "nope.rnx")
    elif case == "bad_systems":
        args += ["--systems", "GX"]
    else:
        ref = tmp_path / "ref.csv"
        ref.write_text("" if case == "empty_ref" else
                       "gps_time_s,lat_deg,lon_deg,h_m\n1290688800,41.6,abc,250\n")
        args += ["--ref", str(ref)]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ")
    if case == "bad_ref":
        assert "ref.csv" in err[0] and "row 1" in err[0] and "lon_deg" in err[0]
    assert not (tmp_path / "o" / "spp.csv").exists()


def _rover_excerpt(path: Path, *, n_epochs: int, offset_s: float = 0.0,
                   single: int | None = None, system: str = "G") -> None:
    """The first `n_epochs` epochs of the shipped rover file; epoch tags moved by `offset_s`
    (< 1 s) and, for epoch index `single`, only its first satellite record of `system`."""
    lines = OBS.read_text().splitlines()
    end = next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln) + 1
    out, i, k = lines[:end], end, 0
    while k < n_epochs:
        head, count = lines[i], int(lines[i][32:35])
        records = lines[i + 1:i + 1 + count]
        if k == single:
            records = [r for r in records if r.startswith(system)][:1]
        second = float(head[19:29]) + offset_s
        out.append(f"{head[:19]}{second:010.7f}{head[29:32]}{len(records):3d}{head[35:]}")
        out += records
        i, k = i + 1 + count, k + 1
    path.write_text("\n".join(out) + "\n")


def _reference_seconds_of_week() -> set[int]:
    """Whole seconds of week of the reference file (its 2nd column), read as text."""
    rows = [ln.split(",") for ln in REF.read_text().splitlines() if not ln.startswith("#")]
    return {int(round(float(r[1]))) for r in rows}


def test_issue16_ref_matches_epochs_a_few_ms_off_whole_seconds(tmp_path, capsys):
    """Epochs tagged 3.5 ms after whole seconds (as u-blox receivers tag them) are all
    compared with the whole-second reference, and spp.csv keeps their µs."""
    obs = tmp_path / "rover.rnx"
    _rover_excerpt(obs, n_epochs=30, offset_s=0.0035)
    # --out beside the input, not the folder holding it (issue 18: a non-empty --out is
    # refused without --overwrite)
    assert main(["-q", "spp", "--obs", str(obs), "--nav", str(NAV), "--ref", str(REF),
                 "--out", str(tmp_path / "out")]) == 0
    text = (tmp_path / "out" / "spp.csv").read_text().splitlines()
    t = pd.read_csv(tmp_path / "out" / "spp.csv")["gps_time_s"].to_numpy()
    sow = t - 2134 * 604_800
    np.testing.assert_allclose(sow - np.floor(sow), 0.0035, atol=1e-6)
    assert text[1].split(",")[0].endswith(".003500")
    expected = len({45_600 + k for k in range(30)} & _reference_seconds_of_week())
    out = capsys.readouterr().out
    assert f"epochs compared      {expected}" in out


def test_issue16_match_tolerance_is_the_documented_one():
    from railnav.evaluation.spp_accuracy import MATCH_TOLERANCE_S, match_epochs

    ref = np.arange(10.0)
    i_sol, i_ref = match_epochs(ref + 0.004, ref)
    assert i_sol.tolist() == i_ref.tolist() == list(range(10))
    assert match_epochs(ref - MATCH_TOLERANCE_S * 0.99, ref)[0].size == 10
    assert match_epochs(ref + MATCH_TOLERANCE_S * 1.01, ref)[0].size == 0


@pytest.mark.parametrize("system, used", [("G", 1), ("C", 0)])
def test_issue16_one_satellite_epoch_is_a_row_without_fix(tmp_path, system, used):
    """An epoch whose file record lists one satellite is a spp.csv row with fix_ok False
    (like epochs with 2-3 satellites), not a missing row: whether the satellite is of a
    used system (G) or not (C, with --systems GE: the row used to vanish)."""
    obs = tmp_path / "rover.rnx"
    _rover_excerpt(obs, n_epochs=5, single=2, system=system)
    assert main(["-q", "spp", "--obs", str(obs), "--nav", str(NAV), "--systems", "GE",
                 "--out", str(tmp_path / "out")]) == 0     # GE: was spp's default
    frame = pd.read_csv(tmp_path / "out" / "spp.csv")
    assert len(frame) == 5
    assert frame["fix_ok"].tolist() == [True, True, False, True, True]
    assert frame["n_sat_used"].iloc[2] == 0 and frame["n_sat_tracked"].iloc[2] == used


BASE = DATA / "base_obs_1240.rnx"
SP3 = DATA / "COD21340_1100_1430.sp3"


def test_issue16_spp_with_base_smoothing_and_sp3(tmp_path, capsys):
    """``--base --smooth-window-s --sp3``: the printed accuracy is the library's for the
    same augmentation, and below RTKLIB DGPS's 4.14 m on this window (issue 16)."""
    from gnss_obs.dgps import augment
    from gnss_obs.measurements import MeasurementConfig
    from gnss_obs.rinex_nav import read_rinex_nav
    from gnss_obs.rinex_obs import read_rinex_obs
    from gnss_obs.smoothing import SmoothingConfig
    from gnss_obs.sp3 import read_sp3
    from gnss_obs.spp import SppConfig, solve_spp

    assert main(["-q", "spp", "--obs", str(OBS), "--nav", str(NAV), "--systems", "G",
                 "--base", str(BASE), "--smooth-window-s", "100", "--sp3", str(SP3),
                 "--ref", str(REF), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "DGNSS (base base_obs_1240.rnx), code smoothed over 100 s, precise orbits" in out
    mc = MeasurementConfig(systems="G")
    nav = read_rinex_nav(NAV)
    aug = augment(read_rinex_obs(OBS), nav, mc, base_obs=read_rinex_obs(BASE),
                  smoothing=SmoothingConfig(window_s=100.0), sp3=[read_sp3(SP3)])
    frame = solve_spp(aug.obs, nav, SppConfig(measurement=mc), corrections=aug.corrections,
                      precise=aug.precise).to_frame()
    acc = accuracy_summary(spp_errors(frame, read_reference_trajectory(REF)))
    line = next(s for s in out.splitlines() if s.startswith("horizontal RMS"))
    assert abs(float(line.split()[2]) - acc.horizontal_rms_m) < PRINT_DECIMALS_M
    assert acc.horizontal_rms_m < 4.14


@pytest.mark.parametrize("extra, message", [
    (["--base-position", "41.5,2.4,80"], "--base-position needs --base"),
    (["--base", "BASE", "--base-position", "41.5,2.4"], None),
    (["--base", "NOFILE"], "NOFILE"),
])
def test_issue16_bad_augmentation_input(tmp_path, capsys, extra, message):
    extra = [str(BASE) if x == "BASE" else str(tmp_path / x) if x == "NOFILE" else x
             for x in extra]
    args = ["spp", "--obs", str(OBS), "--nav", str(NAV), "--out", str(tmp_path)] + extra
    if message is None:           # argparse rejects the value: usage error, exit 2
        with pytest.raises(SystemExit) as exc:
            main(args)
        assert exc.value.code == 2
        assert "LAT,LON,H" in capsys.readouterr().err
        return
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and message in err[0]
