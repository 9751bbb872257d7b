"""``railnav track fit|sample|info|plot`` in-process: outputs and one-line errors."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from railnav.cli import main
from trackmodel.io import read_track

TRACKS = Path(__file__).resolve().parents[2] / "data" / "tracks"
ATOL_SAMPLE_DEG = 1e-9       # sample CSV written with 10 significant digits... of degrees


def test_sample_matches_track(tmp_path):
    out = tmp_path / "samples.csv"
    assert main(["-q", "track", "sample", str(TRACKS / "paper2017.csv"), "--step-m", "100",
                 "--out", str(out)]) == 0
    frame = pd.read_csv(out)
    assert list(frame.columns) == ["s_m", "lat_deg", "lon_deg", "h_m", "azimuth_deg",
                                   "elevation_deg", "curvature_1pm"]
    assert len(frame) == 251 and frame.s_m.iloc[-1] == 25_000.0
    # the paper's straight: h = h0 + s sin(π/60), constant A = 30°, ϑ = 3°
    assert np.allclose(frame.h_m, 100.0 + frame.s_m * np.sin(np.pi / 60), atol=1e-6)
    assert np.allclose(frame.azimuth_deg, 30.0) and np.allclose(frame.elevation_deg, 3.0)


def test_info_prints_figures(capsys):
    assert main(["track", "info", str(TRACKS / "curvy.csv")]) == 0
    out = capsys.readouterr().out
    assert "min radius 600.0 m" in out and "max grade 2.00 %" in out


def test_plot_writes_png(tmp_path):
    out = tmp_path / "t.png"
    assert main(["track", "plot", str(TRACKS / "east_west.csv"), "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_fit_writes_a_track_within_tolerance(tmp_path):
    survey = pd.read_csv(TRACKS / "barcelona_drive_survey.csv").iloc[:60]
    poly = tmp_path / "poly.csv"
    survey[["lat_deg", "lon_deg"]].to_csv(poly, index=False)
    out = tmp_path / "track.csv"
    assert main(["-q", "track", "fit", str(poly), "--tol-m", "0.5", "--out", str(out)]) == 0
    track = read_track(out)
    proj = track.project(np.radians(survey.lat_deg), np.radians(survey.lon_deg))
    assert np.hypot(proj.cross_track_m, proj.along_m).max() <= 0.5


@pytest.mark.parametrize("text,message", [
    ("lat_deg,lon_deg\n41.6,abc\n", "row 1, lon_deg: 'abc' is not a finite number"),
    ("lat_deg\n41.6\n", "lon_deg: required column missing"),
    ("", "empty file"),
])
def test_fit_bad_polyline_exit_2(tmp_path, capsys, text, message):
    poly = tmp_path / "poly.csv"
    poly.write_text(text)
    out = tmp_path / "track.csv"
    assert main(["track", "fit", str(poly), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.strip() == f"error: {poly}: {message}"
    assert not out.exists()
