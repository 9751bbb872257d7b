"""Parallel tracks (trackmodel/offset.py): the new track's points projected onto the
given one (`Track.project`, an independent Newton search on the built geometry) lie at
the offset across it and at its height; closed-form offset lengths of arcs and clothoids
on the flat; the shipped double line."""
from __future__ import annotations

import math

import numpy as np
import pytest

from tests.conftest import TRACKS
from trackmodel.earth import WGS84
from trackmodel.errors import TrackError
from trackmodel.io import read_track
from trackmodel.offset import offset_track
from trackmodel.sections import Section
from trackmodel.track import Origin, Track

#: Lateral accuracy of the parallel track: the parallel of a loxodrome at a fixed azimuth
#: drifts by d·tanφ·Δφ (1.2 cm on the 23-km double line at 49° N heading 40°); 2 cm bound.
ATOL_CROSS_M = 0.02
#: Height difference across the tracks: same height at each cross-section, the elevation
#: of clothoid pieces taken linear (sub-millimetre); 5 mm bound.
ATOL_VERTICAL_M = 0.005
#: Offset length of a clothoid against ∫(1 − k d) dx: the 10-m pieces err by millimetres.
ATOL_CLOTHOID_LENGTH_M = 0.01
SAMPLE_STEP_M = 2.0
SPACING_M = 4.5


def _cross_and_vertical(reference: Track, other: Track):
    s = np.arange(0.0, other.length_m, SAMPLE_STEP_M)
    p = other.at(s)
    proj = reference.project(p.lat, p.lon, p.h)
    inside = np.abs(proj.along_m) < 1e-6     # abreast of the reference (not beyond its ends)
    return proj.cross_track_m[inside], proj.vertical_m[inside]


@pytest.fixture(scope="module")
def graded_curves() -> Track:
    """Clothoid-arc-clothoid curves right and left, one on a +2 % grade."""
    k = 1.0 / 600.0
    g = math.degrees(math.atan(0.02))
    sections = [Section(800.0, 10.0, 0.0), Section(200.0, None, None, elevation_end_deg=g),
                Section(120.0, None, None, 0.0, k), Section(400.0, None, None, k),
                Section(120.0, None, None, k, 0.0), Section(600.0, None, None),
                Section(150.0, None, None, 0.0, -1.5 * k), Section(300.0, None, None, -1.5 * k),
                Section(150.0, None, None, -1.5 * k, 0.0, elevation_end_deg=0.0),
                Section(500.0, None, None)]
    return Track(sections, Origin(48.1, 11.5, 520.0), WGS84)


@pytest.mark.parametrize("offset_m", [SPACING_M, -SPACING_M, 12.0])
def test_parallel_track_is_at_the_offset_and_the_height(graded_curves, offset_m):
    other = offset_track(graded_curves, offset_m)
    cross, vertical = _cross_and_vertical(graded_curves, other)
    assert cross.size > 0.9 * other.length_m / SAMPLE_STEP_M
    np.testing.assert_allclose(cross, offset_m, atol=ATOL_CROSS_M)
    np.testing.assert_allclose(vertical, 0.0, atol=ATOL_VERTICAL_M)


def test_flat_arc_and_clothoid_lengths_are_the_offset_curve_lengths():
    """Arc: (R − d)·θ exactly. Clothoid: L − d·θ (∫(1 − k d) dx with ∫k dx = θ)."""
    R, turn, d, L_cl = 500.0, math.radians(60.0), 5.0, 150.0
    arc = Track([Section(R * turn, 0.0, 0.0, 1.0 / R)], Origin(45.0, 7.0, 0.0), WGS84)
    assert offset_track(arc, d).length_m == pytest.approx((R - d) * turn, rel=1e-12)
    assert offset_track(arc, -d).length_m == pytest.approx((R + d) * turn, rel=1e-12)
    clothoid = Track([Section(L_cl, 0.0, 0.0, 0.0, 1.0 / R)], Origin(45.0, 7.0, 0.0), WGS84)
    theta = L_cl / (2 * R)
    assert offset_track(clothoid, d).length_m == pytest.approx(L_cl - d * theta,
                                                               abs=ATOL_CLOTHOID_LENGTH_M)


def test_offset_back_returns_the_track(graded_curves):
    back = offset_track(offset_track(graded_curves, SPACING_M), -SPACING_M)
    assert back.length_m == pytest.approx(graded_curves.length_m, abs=ATOL_CLOTHOID_LENGTH_M)
    cross, vertical = _cross_and_vertical(graded_curves, back)
    np.testing.assert_allclose(cross, 0.0, atol=ATOL_CROSS_M)


def test_shipped_double_line_is_4_5_m_apart():
    """data/tracks/double_b.csv is 4.5 m to the right of double_a.csv all along."""
    a, b = read_track(TRACKS / "double_a.csv"), read_track(TRACKS / "double_b.csv")
    cross, vertical = _cross_and_vertical(a, b)
    assert cross.size > 0.9 * b.length_m / SAMPLE_STEP_M
    np.testing.assert_allclose(cross, SPACING_M, atol=ATOL_CROSS_M)
    np.testing.assert_allclose(vertical, 0.0, atol=ATOL_VERTICAL_M)
    assert np.any(a.at(np.arange(0, a.length_m, 50.0)).curvature_1pm != 0.0)   # has curves


def test_bad_offsets_are_refused(graded_curves):
    with pytest.raises(TrackError, match="finite"):
        offset_track(graded_curves, float("nan"))
    with pytest.raises(TrackError, match="too large"):
        offset_track(graded_curves, 400.0)    # more than half the 600-m radius
