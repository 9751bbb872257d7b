"""Fixes on the track for the divergence monitor (railnav/navigation/track_fixes.py).

References: the closed-form geometry of a circle driven round three times
(`tests.railnav.filters.test_joint_noise`).
"""
from __future__ import annotations

import numpy as np
import pytest

from railnav.navigation.track_fixes import TrackFixes


def test_fix_projects_on_the_pass_near_the_filter():
    """A fix on the circle driven round three times (`test_joint_noise`) projects, over
    the whole track, on any pass; near a prior on the first pass it takes that pass's
    point, 2·(2πR) before the same place on the third (closed form, to within the
    track's own closure of its repeated arcs), with the same σ
    along the (identical) tangent."""
    from tests.railnav.filters.test_joint_noise import RADIUS_M, _circle_track
    track = _circle_track()
    lap = 2 * np.pi * RADIUS_M
    s_third = 1000.0 + 2 * lap + 0.3 * lap
    pt = track.at(s_third)
    cov = np.diag([4.0, 9.0, 25.0])[None]
    fixes = TrackFixes.on_track(track, time_s=[0.0], lat=[float(pt.lat)], lon=[float(pt.lon)],
                                cov_enu_m2=cov)
    s_first = s_third - 2 * lap
    # the passes of the track's repeated arcs close to within this (its own geometry)
    closure = float(np.linalg.norm(np.asarray(track.at(s_first).r_e)
                                   - np.asarray(track.at(s_third).r_e)))
    assert closure < 0.05
    s, sigma = fixes.near(0, s_first + 3.0)
    assert s == pytest.approx(s_first, abs=closure + 1e-4)
    u = np.asarray(track.at(s).u_n).reshape(3)               # the tangent where it lands
    assert sigma == pytest.approx(np.sqrt(u @ cov[0] @ u), rel=1e-6)
    s, _ = fixes.near(0, s_third - 2.0)
    assert s == pytest.approx(s_third, abs=1e-3)
