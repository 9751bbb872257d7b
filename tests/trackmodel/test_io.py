"""Track files: round trips and one-line located errors (also through the CLI)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from railnav.cli import main
from trackmodel.errors import TrackFileError
from trackmodel.io import parse_track_text, read_track, track_to_text, write_track

TRACKS = Path(__file__).resolve().parents[2] / "data" / "tracks"

HEADER = "lat_deg,lon_deg,h_m,length_m,azimuth_deg,elevation_deg"
GOOD = f"""# earth=sphere radius_m=6371000
{HEADER},curvature_1pm,curvature_end_1pm,elevation_end_deg
50.45,30.52,100.0,1000.0,30.0,3.0,,,
,,,200.0,,,0.0,0.001,1.0
,,,300.0,,,0.001,,
"""


def test_round_trip_is_exact(tmp_path):
    track = parse_track_text(GOOD)
    path = tmp_path / "t.csv"
    write_track(track, path)
    again = read_track(path)
    assert again.sections == track.sections and again.origin == track.origin
    assert again.earth == track.earth
    assert track_to_text(again) == path.read_text()


@pytest.mark.parametrize("name", ["paper2017", "curvy", "east_west", "barcelona_drive"])
def test_shipped_tracks_round_trip(name, tmp_path):
    track = read_track(TRACKS / f"{name}.csv")
    write_track(track, tmp_path / "x.csv")
    assert read_track(tmp_path / "x.csv").sections == track.sections


def test_sphere_and_continuations():
    track = parse_track_text(GOOD)
    assert track.earth.is_sphere and track.earth.a_m == 6_371_000.0
    # the third row continues azimuth 30° + the clothoid's turn L (κ0 + κ1)/2 = 0.1 rad
    assert track.table.azimuth0[2] == pytest.approx(np.radians(30.0) + 0.1, abs=1e-15)
    assert track.table.elevation0[2] == pytest.approx(np.radians(1.0), abs=1e-15)


BAD = [
    ("", None, None, "empty"),
    (f"{HEADER}\n", None, None, "no section rows"),
    (f"{HEADER}\n50,30,0,abc,0,0\n", 1, "length_m", "'abc' is not a number"),
    (f"{HEADER}\n50,30,0,-5,0,0\n", 1, "length_m", "> 0"),
    (f"{HEADER}\n50,30,0,0,0,0\n", 1, "length_m", "> 0"),
    (f"{HEADER}\n50,30,0,10,0,90\n", 1, "elevation_deg", "-90 < elevation_deg < 90"),
    (f"{HEADER}\n50,30,0,10,0,nan\n", 1, "elevation_deg", "finite"),
    (f"{HEADER}\n50,30,0,10,inf,0\n", 1, "azimuth_deg", "finite"),
    (f"{HEADER}\n,,,10,0,0\n", 1, "lat_deg", "origin is missing"),
    (f"{HEADER}\n50,30,0,10,,0\n", 1, "azimuth_deg", "first section"),
    (f"{HEADER}\n50,30,0,10,0,0\n1,2,3,10,0,0\n", 2, "lat_deg", "row 1 only"),
    ("lat_deg,lon_deg,h_m,azimuth_deg,elevation_deg\n50,30,0,0,0\n", None, "length_m",
     "required column"),
    (f"{HEADER},radius_m\n50,30,0,10,0,0,5\n", None, "radius_m", "unknown column"),
    (f"# earth=mars\n{HEADER}\n50,30,0,10,0,0\n", None, None, "earth must be"),
    (f"{HEADER}\n95,30,0,10,0,0\n", 1, "lat_deg", "lat_deg"),
    (f"{HEADER}\n50,30,0,10,0,0,7\n", 1, None, "fields"),
]


@pytest.mark.parametrize("text,row,column,message", BAD)
def test_bad_files_raise_located_error(text, row, column, message):
    with pytest.raises(TrackFileError, match=message) as info:
        parse_track_text(text, path="x.csv")
    assert info.value.row == row and info.value.column == column
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("text,row,column,message", BAD[:6])
def test_bad_file_cli_exit_2_one_line(tmp_path, capsys, text, row, column, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    assert main(["track", "info", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {path}") and len(err.splitlines()) == 1


@settings(max_examples=200, deadline=None)
@given(st.text(alphabet="0123456789.,-e#\nabnif =", max_size=120))
def test_fuzzed_text_fails_only_with_our_error(text):
    try:
        parse_track_text(HEADER + "\n" + text)
    except TrackFileError:
        pass
