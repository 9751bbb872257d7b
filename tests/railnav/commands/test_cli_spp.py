"""``railnav spp`` in-process: files, summary, reference comparison, one-line errors."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from railnav.cli import main
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
