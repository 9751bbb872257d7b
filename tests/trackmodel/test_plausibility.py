"""Plausibility limits of a track (issue 18): implausible parameters are located one-line
errors found before any integration, so that no track file can hang the reader."""
from __future__ import annotations

import logging
import math
import re

import numpy as np
import pytest
from scipy.integrate import quad

import trackmodel.track as track_module
from trackmodel.errors import TrackFileError
from trackmodel.io import parse_track_text
from trackmodel.plausibility import (
    MAX_CURVATURE_1PM,
    MAX_KINK_DEG,
    MAX_SECTION_TURN_DEG,
    ImplausibleTrackError,
    section_heights,
)
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

HEADER = ("lat_deg,lon_deg,h_m,length_m,azimuth_deg,elevation_deg,curvature_1pm,"
          "curvature_end_1pm")
#: Heights of `section_heights` against numerical quadrature of dh/ds = sin ϑ(s): the
#: closed form is exact, quad reaches ~1e-12 relative.
ATOL_H_M = 1e-8

# (name, rows after the header, row, column, words of the message)
IMPLAUSIBLE = [
    ("curvature 1e6 1/m", "50,30,0,3000,0,0,1e6,", 1, "curvature_1pm",
     f"radius of {1 / 1e6:.3g} m"),
    ("radius 5 m over 3 km", "50,30,0,3000,0,0,0.2,", 1, "curvature_1pm",
     f"turns {math.degrees(3000 / 5):.4g}°"),
    ("end curvature", "50,30,0,10,0,0,0,-3", 1, "curvature_end_1pm", "below the minimum"),
    ("lon 400", "50,400,0,3000,0,0,,", 1, "lon_deg", "-180 <= lon_deg <= 180"),
    ("length 1e30 m", "50,30,0,1e30,0,0,,", 1, "length_m", "longer than any railway"),
    ("total length", "50,30,0,6e6,0,0,,\n,,,6e6,,,,", 2, "length_m", "longer than any railway"),
    ("h 1e12 m", "50,30,1e12,3000,0,0,,", 1, "h_m", "h_m <= 10000"),
    ("height reached", "50,30,0,1e6,0,10,,", 1, "elevation_deg", "height reaches"),
    ("azimuth 1e9°", "50,30,0,3000,1e9,0,,", 1, "azimuth_deg", "-360 <= azimuth_deg <= 360"),
    ("180° kink", "50,30,0,3000,0,0,,\n,,,3000,180,0,,", 2, "azimuth_deg",
     "turns the track by 180°"),
    ("kink across north", "50,30,0,100,359,0,,\n,,,100,10,0,,", 2, "azimuth_deg", "by 11°"),
    ("elevation kink", "50,30,0,100,0,0,,\n,,,100,,8,,", 2, "elevation_deg", "by 8°"),
    ("over the pole", "80,30,0,3000000,0,0,,", 1, "length_m", "beyond ±89.9°"),
    ("curve near the pole", "89.8,30,0,30000,90,0,1e-4,", 1, "length_m", "closer to a pole"),
]


@pytest.mark.parametrize("name,rows,row,column,message", IMPLAUSIBLE,
                         ids=[case[0] for case in IMPLAUSIBLE])
def test_issue18_implausible_track_is_a_located_error_before_integration(
        monkeypatch, name, rows, row, column, message):
    def no_integration(*args, **kwargs):
        raise AssertionError("a section was integrated before the check")
    monkeypatch.setattr(track_module, "integrate_section", no_integration)
    with pytest.raises(TrackFileError, match=re.escape(message)) as info:
        parse_track_text(f"{HEADER}\n{rows}\n", path="x.csv")
    assert (info.value.row, info.value.column) == (row, column)
    assert str(info.value).startswith(f"x.csv: row {row}, {column}: ")
    assert "\n" not in str(info.value)


def test_issue18_limits_hold_for_tracks_built_in_code():
    """`Track` checks what the file reader checks (the same `ImplausibleTrackError`)."""
    with pytest.raises(ImplausibleTrackError) as info:
        Track([Section(3000.0, 0.0, 0.0, curvature_1pm=1e6)], Origin(50.0, 30.0))
    assert info.value.column == "curvature_1pm"
    with pytest.raises(ImplausibleTrackError):
        Origin(50.0, 400.0)


def test_limits_are_inclusive_at_the_stated_values():
    """A 2-m radius turning exactly two full circles, and a kink of exactly MAX_KINK_DEG,
    are accepted: the limits are stated values, not approximations of them."""
    length = math.radians(MAX_SECTION_TURN_DEG) / MAX_CURVATURE_1PM
    track = Track([Section(length, 0.0, 0.0, curvature_1pm=MAX_CURVATURE_1PM),
                   Section(10.0, MAX_KINK_DEG, 0.0)], Origin(50.0, 30.0))
    assert track.length_m == pytest.approx(length + 10.0, rel=1e-15)


def test_small_kinks_are_logged(caplog):
    with caplog.at_level(logging.WARNING, logger="trackmodel.plausibility"):
        Track([Section(100.0, 10.0, 0.0), Section(100.0, 12.0, 0.0),
               Section(100.0, 12.05, 0.0)], Origin(50.0, 30.0))
    assert "1 joint(s)" in caplog.text and "largest 2°" in caplog.text


@pytest.mark.parametrize("e0_deg,e1_deg", [(0.0, 0.0), (2.0, 2.0), (-1.0, 3.0), (3.0, -2.0),
                                           (1.0, 1.0 + 1e-9)])
def test_section_heights_match_quadrature(e0_deg, e1_deg):
    length, h0 = 750.0, 120.0
    e0, e1 = np.radians(e0_deg), np.radians(e1_deg)

    def h(t):
        return h0 + quad(lambda x: math.sin(e0 + (e1 - e0) * x / length), 0.0, t,
                         epsabs=1e-13, epsrel=1e-13)[0]

    grid = np.linspace(0.0, length, 2001)
    sampled = np.array([h(t) for t in grid])
    h_end, h_min, h_max = section_heights(h0, e0, e1, length)
    assert h_end == pytest.approx(h(length), abs=ATOL_H_M)
    assert h_min <= sampled.min() + ATOL_H_M and h_max >= sampled.max() - ATOL_H_M
    assert h_min >= sampled.min() - 1e-3 and h_max <= sampled.max() + 1e-3   # grid spacing


def test_heights_agree_with_the_track():
    """The check's closed-form heights are the track's own (built by integration)."""
    sections = [Section(400.0, 30.0, 1.0, elevation_end_deg=-2.0, curvature_1pm=1e-3),
                Section(300.0, None, None)]
    track = Track(sections, Origin(48.0, 11.0, 500.0))
    h_end, _, _ = section_heights(500.0, np.radians(1.0), np.radians(-2.0), 400.0)
    assert track.at(400.0).h == pytest.approx(h_end, abs=1e-6)


def test_issue18_a_track_row_cut_short_is_an_error():
    """A track file truncated inside its last row read as if complete (mutation fuzzing):
    ',,,300' was a 300-m continuation; every row must have the header's fields."""
    full = f"{HEADER}\n50,30,0,1000,0,0,,\n,,,300,,,0,\n"
    assert parse_track_text(full).length_m == 1300.0
    with pytest.raises(TrackFileError, match="cut short") as info:
        parse_track_text(full[:full.rindex(",,0,")] + "\n", path="x.csv")
    assert info.value.row == 2
