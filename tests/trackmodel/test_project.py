"""Projection: points generated at known (s, offsets) come back (hypothesis property)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from trackmodel.earth import C_n_e, ecef_to_geodetic
from trackmodel.io import read_track
from trackmodel.summary import track_info

TRACKS = Path(__file__).resolve().parents[2] / "data" / "tracks"

ATOL_S_M = 1e-6              # Newton to 1e-7 m; ECEF <-> geodetic round trip ~1e-9 m
ATOL_OFFSET_M = 1e-6
CURVY = read_track(TRACKS / "curvy.csv")
BARCELONA = read_track(TRACKS / "barcelona_drive.csv")


def offset_points(track, s, cross, vertical):
    """Points at cross-track (right) and vertical (up-normal) offsets, built from the
    definitions in the docstring of trackmodel.project, not from its code."""
    pt = track.at(s)
    A, E = pt.azimuth, pt.elevation
    right = np.stack([np.cos(A), -np.sin(A), 0 * A], axis=-1)
    normal = np.stack([-np.sin(E) * np.sin(A), -np.sin(E) * np.cos(A), np.cos(E)], axis=-1)
    d_n = cross[:, None] * right + vertical[:, None] * normal
    return ecef_to_geodetic(pt.r_e + np.einsum("...ij,...j->...i", C_n_e(pt.lat, pt.lon), d_n))


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(st.floats(0.0, 1.0), st.floats(-50.0, 50.0), st.floats(-20.0, 20.0)),
                min_size=1, max_size=20))
def test_projection_returns_generating_s_and_offsets(rows):
    # excluded region: |cross| < 50 m stays inside the 600 m minimum radius of curvy.csv
    f, cross, vertical = (np.array(c) for c in zip(*rows))
    s = f * CURVY.length_m
    lat, lon, h = offset_points(CURVY, s, cross, vertical)
    proj = CURVY.project(lat, lon, h)
    interior = (s > 0.0) & (s < CURVY.length_m)
    assert np.abs(proj.s - s)[interior].max(initial=0.0) < ATOL_S_M
    assert np.abs(proj.cross_track_m - cross)[interior].max(initial=0.0) < ATOL_OFFSET_M
    assert np.abs(proj.vertical_m - vertical)[interior].max(initial=0.0) < ATOL_OFFSET_M


def test_projection_in_sharp_street_turns(rng):
    # the fitted Barcelona path has street corners of a few metres radius; excluded region:
    # offsets beyond 0.4 x the smallest radius (there the nearest point is not unique)
    r_min = track_info(BARCELONA).min_radius_m
    s = rng.uniform(1.0, BARCELONA.length_m - 1.0, 2000)
    cross = rng.uniform(-0.4 * r_min, 0.4 * r_min, s.size)
    vertical = rng.uniform(-2.0, 2.0, s.size)
    proj = BARCELONA.project(*offset_points(BARCELONA, s, cross, vertical))
    assert np.abs(proj.s - s).max() < ATOL_S_M
    assert np.abs(proj.cross_track_m - cross).max() < ATOL_OFFSET_M


def test_beyond_the_ends_projects_to_the_ends():
    pt = CURVY.at(0.0)
    A = float(pt.azimuth)
    back = np.array([-np.sin(A), -np.cos(A), 0.0]) * 30.0     # 30 m behind the start
    lat, lon, h = ecef_to_geodetic(pt.r_e + C_n_e(pt.lat, pt.lon) @ back)
    proj = CURVY.project(np.array([lat]), np.array([lon]), np.array([h]))
    assert proj.s[0] == 0.0
    assert abs(proj.along_m[0] + 30.0) < 1e-3     # Earth curvature: 30²/2R ≈ 7e-5 m


def test_horizontal_projection_without_heights():
    s = np.array([1000.0, 5000.0, 20000.0])
    lat, lon, _ = offset_points(CURVY, s, np.array([2.0, -1.0, 0.5]), np.zeros(3))
    proj = CURVY.project(lat, lon)
    assert np.abs(proj.s - s).max() < 1e-3
    assert np.abs(proj.cross_track_m - [2.0, -1.0, 0.5]).max() < 1e-3
