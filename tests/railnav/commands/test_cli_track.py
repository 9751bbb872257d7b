"""``railnav track fit|sample|info|plot`` in-process: outputs and one-line errors."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from railnav.cli import main
from trackmodel.io import read_track
from trackmodel.polyline import REVERSAL_CHORD_M, REVERSAL_WINDOW_M

TRACKS = Path(__file__).resolve().parents[3] / "data" / "tracks"
ATOL_SAMPLE_DEG = 1e-9       # sample CSV written with 10 significant digits... of degrees
SPACING_M = 5.0              # of the survey points
#: A leg ends at most this far before the turning point: `find_reversal`'s chord and
#: window, a point spacing for their discretization and one for the apex point (cleaned as
#: a spike when the way back retraces the way out).
MAX_LEG_CUT_M = REVERSAL_CHORD_M + REVERSAL_WINDOW_M + 2 * SPACING_M
TOL_M = 0.5                  # the fit's default tolerance


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
    # a fix log's header (the Belgian logs' latitude/longitude): neither layout, not "row 1,
    # week: 'id' is not a finite number" from the headerless reference layout
    ("id,solution_status,position_type,latitude,longitude,timestamp\n"
     "1,SOL_COMPUTED,NARROW_INT3,50.89,4.54,2022-02-25T09:32:54.400\n",
     "lat_deg: required column missing"),
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


def _out_and_back(tmp_path):
    """A survey in the reference-trajectory layout (GPS week, seconds of week, lat, lon, h):
    400 m along a known track, then back along it to 152 m (a turn on the spot)."""
    from trackmodel.sections import Section
    from trackmodel.track import Origin, Track
    truth = Track([Section(150.0, 40.0, 0.0), Section(100.0, None, None, 0.0, 1 / 120),
                   Section(150.0, None, None, 1 / 120, 1 / 120)], Origin(41.6, 2.35, 250.0))
    s = np.concatenate([np.arange(0.0, 400.0, SPACING_M), [400.0],
                        np.arange(397.0, 150.0, -SPACING_M)])
    pt = truth.at(s)
    frame = pd.DataFrame({"week": 2134, "sow": 45600.0 + np.arange(s.size),
                          "lat": np.degrees(pt.lat), "lon": np.degrees(pt.lon), "h": pt.h})
    path = tmp_path / "reference.csv"
    path.write_text("# GPSW,GPSSoW,latitude(deg),longitude(deg),height(m)\n"
                    + frame.to_csv(header=False, index=False))
    return path, truth


def test_fit_of_a_survey_that_reverses_names_its_legs(tmp_path, capsys):
    survey, _ = _out_and_back(tmp_path)
    code = main(["-q", "track", "fit", str(survey), "--out", str(tmp_path / "t.csv")])
    assert code == 2
    err = capsys.readouterr().err
    assert "reverses its direction" in err and "--leg N" in err and "2: points" in err
    assert not (tmp_path / "t.csv").exists()




def test_fit_of_one_leg(tmp_path):
    """--leg 1 covers the known track from 0 out to the turn in its direction, --leg 2 from
    the turn back to 152 m in the other direction (points located by projection)."""
    survey, truth = _out_and_back(tmp_path)
    turn_m = 400.0 - MAX_LEG_CUT_M
    for leg, span_m in ((1, [0.0, turn_m]), (2, [turn_m, 152.0])):
        out = tmp_path / f"leg{leg}.csv"
        assert main(["-q", "track", "fit", str(survey), "--leg", str(leg),
                     "--out", str(out)]) == 0
        track = read_track(out)
        pt = truth.at(np.array(span_m))
        proj = track.project(pt.lat, pt.lon, pt.h)
        assert np.all(proj.distance_m <= TOL_M)
        assert proj.s[1] - proj.s[0] >= abs(span_m[1] - span_m[0]) - 2 * TOL_M
        assert f"leg {leg} of 2" in out.read_text().splitlines()[1]
    assert main(["-q", "track", "fit", str(survey), "--leg", "3", "--out",
                 str(tmp_path / "x.csv")]) == 2


# --- issue 18: surveys that used to give tracebacks, and outputs that overwrote inputs ---

def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    return err


@pytest.mark.parametrize("data,message", [
    (b"lat_deg,lon_deg\n41.6,2.3\n\xff\xfe41.7,2.4\n", "line 3: not UTF-8 text (byte 0xff)"),
    (b"lat_deg,lon_deg\n41.6,2.3\n41.7,2.4,5\n41.8,2.5\n",
     "line 3: 3 fields, but the header has 2"),
    (b"# GPSW,GPSSoW,latitude(deg),longitude(deg),height(m)\n2134,45600,41.6,2.3,1\n"
     b"2134,45601,,2.4,1\n", "row 2, lat_deg: empty or NaN (a finite number is needed)"),
    (b"gps_week,gps_sow_s,lat_deg,lon_deg,h_m\n2134,45600,41.6,2.3,1\n2134,45601,,2.4,1\n",
     "row 2, lat_deg: empty or NaN (a finite number is needed)"),
    (b"# GPSW,GPSSoW,latitude(deg),longitude(deg),height(m)\n2134,45600,41.6,2.3,1\n"
     b"2134,45601,41.7,2.4,1,7\n", "line 3: 6 fields, but the header has 5"),
    (b"lat_deg,lon_deg,h_m\n41.6,2.3,1e12\n",
     "row 1, h_m: must satisfy -1000 <= h_m <= 10000, got 1000000000000.0"),
], ids=["non-UTF-8", "extra field", "NaN lat, week layout", "NaN lat, named columns",
        "extra field, week layout", "h 1e12"])
def test_issue18_bad_survey_is_a_located_error(tmp_path, capsys, data, message):
    survey, out = tmp_path / "survey.csv", tmp_path / "track.csv"
    survey.write_bytes(data)
    assert main(["-q", "track", "fit", str(survey), "--out", str(out)]) == 2
    assert _one_error_line(capsys) == f"error: {survey}: {message}"
    assert not out.exists()


def test_issue18_fit_refuses_to_overwrite_its_survey(tmp_path, capsys):
    survey = tmp_path / "s.csv"
    survey.write_text("lat_deg,lon_deg\n41.6,2.3\n41.6001,2.3001\n")
    before = survey.read_bytes()
    assert main(["-q", "track", "fit", str(survey), "--out", str(survey)]) == 2
    assert _one_error_line(capsys) == (f"error: {survey}: --out: is the survey being fitted: "
                                       "give a different file (nothing was written)")
    assert survey.read_bytes() == before
    # the same file through another spelling of its path
    other = tmp_path / "sub" / ".." / "s.csv"
    (tmp_path / "sub").mkdir()
    assert main(["-q", "track", "fit", str(survey), "--out", str(other)]) == 2
    assert survey.read_bytes() == before


def test_issue18_fit_refuses_residuals_on_the_track_file(tmp_path, capsys):
    survey = pd.read_csv(TRACKS / "barcelona_drive_survey.csv").iloc[:60]
    poly = tmp_path / "poly.csv"
    survey[["lat_deg", "lon_deg"]].to_csv(poly, index=False)
    out = tmp_path / "f.csv"
    assert main(["-q", "track", "fit", str(poly), "--out", str(out), "--residuals",
                 str(out)]) == 2
    assert "--residuals: is also --out" in _one_error_line(capsys)
    assert not out.exists()


def test_issue18_sample_and_plot_refuse_to_overwrite_the_track(tmp_path, capsys):
    track = tmp_path / "t.csv"
    track.write_bytes((TRACKS / "paper2017.csv").read_bytes())
    before = track.read_bytes()
    for command in ("sample", "plot"):
        assert main(["-q", "track", command, str(track), "--out", str(track)]) == 2
        assert f"is the track being {command}" in _one_error_line(capsys)
    assert track.read_bytes() == before


def test_issue18_empty_out_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as info:
        main(["track", "sample", str(TRACKS / "paper2017.csv"), "--out", ""])
    assert info.value.code == 2
    assert "an output path cannot be empty" in capsys.readouterr().err


def test_issue18_implausible_track_through_the_cli(tmp_path, capsys):
    """The flipped digit of issue 18: radius 5 m over 3 km; it hung the reader."""
    track = tmp_path / "t.csv"
    track.write_text("lat_deg,lon_deg,h_m,length_m,azimuth_deg,elevation_deg,curvature_1pm\n"
                     "50,30,0,3000,0,0,0.2\n")
    assert main(["track", "info", str(track)]) == 2
    assert _one_error_line(capsys).startswith(f"error: {track}: row 1, curvature_1pm: ")


def test_issue18_sample_plot_and_fit_say_what_they_wrote(tmp_path, capsys):
    samples, png = tmp_path / "s.csv", tmp_path / "t.png"
    assert main(["-q", "track", "sample", str(TRACKS / "paper2017.csv"), "--step-m", "1000",
                 "--out", str(samples)]) == 0
    assert capsys.readouterr().out.startswith(f"{samples}: {len(pd.read_csv(samples))} points")
    assert main(["-q", "track", "plot", str(TRACKS / "paper2017.csv"), "--out", str(png)]) == 0
    assert capsys.readouterr().out.startswith(f"{png}: map, height and curvature")
    survey = pd.read_csv(TRACKS / "barcelona_drive_survey.csv").iloc[:60]
    poly, out, res = tmp_path / "poly.csv", tmp_path / "f.csv", tmp_path / "r.csv"
    survey[["lat_deg", "lon_deg"]].to_csv(poly, index=False)
    assert main(["-q", "track", "fit", str(poly), "--out", str(out), "--residuals",
                 str(res)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"{out}: ") and lines[1].startswith(f"{res}: ")
    assert f"of the {len(pd.read_csv(res))} points" in lines[1]


@pytest.mark.parametrize("text", ["lat_deg,lon_deg\n41.6,2.3\n",
                                  "lat_deg,lon_deg\n41.6,2.3\n41.6,2.3\n41.6,2.3\n"])
def test_issue18_fit_errors_name_the_survey(tmp_path, capsys, text):
    """A 1-point survey (and one without spacing) printed no file name."""
    survey = tmp_path / "one.csv"
    survey.write_text(text)
    assert main(["-q", "track", "fit", str(survey), "--out", str(tmp_path / "t.csv")]) == 2
    assert _one_error_line(capsys).startswith(f"error: {survey}: ")


def test_issue18_every_track_subcommand_has_a_description():
    from railnav.cli import build_parser
    parser = build_parser()
    track = parser._subparsers._group_actions[0].choices["track"]
    subcommands = track._subparsers._group_actions[0].choices
    assert set(subcommands) == {"fit", "sample", "info", "plot"}
    for name, sub in subcommands.items():
        assert sub.description and len(sub.description) > 40, name
