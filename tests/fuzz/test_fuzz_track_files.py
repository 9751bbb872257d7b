"""Fuzzed track files (issue 18): whatever the bytes, `read_track` returns a track or raises
`TrackFileError`, within the case time limit (`tests.support.fuzz`).

Two generators: mutations of the shipped tracks (a damaged file: bytes replaced, lines lost or
repeated, digits flipped, the file cut short) and tables written from scratch (any header
among the format's columns and some that are not, any cells).
"""
from __future__ import annotations

import tempfile
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from tests.conftest import TRACKS
from tests.support.fuzz import FUZZ, csv_cells, mutated, time_limit
from trackmodel.errors import TrackFileError
from trackmodel.io import parse_track_text, read_track
from trackmodel.table import ALL_COLUMNS

#: Shipped tracks small enough to read many times (curvy: 32 sections in ~30 ms).
ORIGINALS = {name: (TRACKS / f"{name}.csv").read_bytes()
             for name in ("paper2017", "curvy", "east_west")}


def _read_bytes(data: bytes):
    """`read_track` of `data` written to a file; our error or a track, nothing else."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "track.csv"
        path.write_bytes(data)
        with time_limit():
            try:
                return read_track(path)
            except TrackFileError as exc:
                assert "\n" not in str(exc) and str(exc).startswith(str(path))
                return None


@FUZZ
@given(st.sampled_from(sorted(ORIGINALS)).flatmap(lambda n: mutated(ORIGINALS[n])))
def test_fuzz_mutated_track_files(data):
    track = _read_bytes(data)
    if track is not None:
        assert track.length_m > 0.0


@st.composite
def track_tables(draw) -> str:
    columns = draw(st.lists(st.sampled_from(ALL_COLUMNS + ("radius_m", "", " lat_deg")),
                            min_size=1, max_size=10))
    rows = draw(st.lists(st.lists(csv_cells(), min_size=len(columns) - 1,
                                  max_size=len(columns) + 1), max_size=5))
    head = draw(st.sampled_from(["", "# earth=wgs84\n", "# earth=sphere radius_m=6371000\n",
                                 "# earth=sphere radius_m=-1\n", "# earth=\n", "# x=y\n"]))
    return head + ",".join(columns) + "\n" + "\n".join(",".join(r) for r in rows) + "\n"


@st.composite
def plausible_rows(draw) -> str:
    """Tables with the right columns and numbers mostly inside the limits and sometimes just
    beyond, so that the geometry itself (integration, limits, latitude reach) is exercised,
    not only parsing."""
    length = st.floats(1.0, 5e3) | st.floats(1e5, 1.2e7) | st.sampled_from([1e-9, 2.0])
    curvature = (st.floats(-3e-3, 3e-3) | st.floats(-0.6, 0.6) | st.just(0.0))
    header = ",".join(ALL_COLUMNS)
    rows = []
    for k in range(draw(st.integers(1, 4))):
        origin = [draw(st.floats(-89.95, 89.95)), draw(st.floats(-185.0, 185.0)),
                  draw(st.floats(-1100.0, 10100.0))] if k == 0 else [None] * 3
        cells = origin + [draw(length), draw(st.floats(-370.0, 370.0)),
                          draw(st.floats(-30.0, 30.0)), draw(curvature),
                          draw(curvature | st.none()), draw(st.floats(-30.0, 30.0) | st.none())]
        if k > 0 and draw(st.booleans()):
            cells[4] = cells[5] = None      # continue the previous azimuth/elevation
        rows.append(",".join("" if c is None else repr(c) for c in cells))
    return header + "\n" + "\n".join(rows) + "\n"


@FUZZ
@given(track_tables() | plausible_rows())
def test_fuzz_generated_track_tables(text):
    with time_limit():
        try:
            parse_track_text(text, path="t.csv")
        except TrackFileError as exc:
            assert "\n" not in str(exc)
