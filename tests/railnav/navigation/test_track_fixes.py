"""Fixes on the track for the divergence monitor (railnav/navigation/track_fixes.py).

References: the closed-form geometry of a circle driven round three times
(`tests.railnav.filters.test_rate_step_joint`).
"""
from __future__ import annotations

import numpy as np
import pytest

from railnav.navigation.track_fixes import TrackFixes


def test_fix_projects_on_the_pass_near_the_filter():
    """A fix on the circle driven round three times (`test_rate_step_joint`) projects, over
    the whole track, on any pass; near a prior on the first pass it takes that pass's
    point, 2·(2πR) before the same place on the third (closed form, to within the
    track's own closure of its repeated arcs), with the same σ
    along the (identical) tangent."""
    from tests.railnav.filters.test_rate_step_joint import RADIUS_M, _circle_track
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


def test_fix_at_from_the_filter_epochs_equals_the_fix_of_the_epoch_alone():
    """`spp_fix_at` with the filter (its GNSS epochs and transmission states, solved by
    `gnss_obs.spp.solve_spp_epoch`) gives, to the bit, the fix `spp_track_fixes` solves
    from the epoch's rows of the observation table alone (pandas selection, `solve_spp`):
    every field, the restart from it and the projection near a prior; on a 60-s
    paper2017 trip, every 7th epoch, one inside an outage (no filter epoch: the table's
    path) and one between epochs (no fix)."""
    from railnav.filters.protocol import make_filter
    from railnav.navigation.navigator import trip_samples
    from railnav.navigation.track_fixes import _FilterEpochs, spp_fix_at, spp_track_fixes
    from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
    from railnav.simulation.trip import navigator_config_for, simulate_trip
    from trackmodel.io import read_track

    scenario = get_scenario("paper2017").with_overrides(duration_s=60.0)
    trip = simulate_trip(scenario, track=read_track(TRACKS_DIR / "paper2017.csv"), seed=3)
    config = navigator_config_for(scenario)
    data = trip.sensor_data()
    outage = (20.0, 5.0)
    samples = trip_samples(data, config, outages=[outage], track=trip.track, body=True)
    filt = make_filter(trip.track, config, samples.gnss)
    fix_at = spp_fix_at(trip.track, data, config, filt=filt)
    times = [*samples.gnss.time_s[::7], 22.0, 30.5]
    assert not np.any(np.isclose(samples.gnss.time_s, 22.0))      # inside the outage
    own = _FilterEpochs.of(data, config, filt)                     # the filter's path is taken
    assert [own.index_at(t) for t in times[:3]] == [0, 7, 14]
    assert own.index_at(22.0) is None and own.index_at(30.5) is None
    solved = 0
    for time_s in times:
        old = spp_track_fixes(trip.track, data, config, start_s=time_s, end_s=time_s,
                              filt=filt)
        new = fix_at(time_s)
        assert (old is None) == (new is None)
        if old is None:
            continue
        solved += 1
        for name in ("time_s", "s_m", "sigma_s_m", "v_mps", "sigma_v_mps", "source", "lat",
                     "lon", "cov_enu_m2"):
            assert np.array_equal(getattr(old, name), getattr(new, name), equal_nan=True)
        for a, b in zip(old.start(0), new.start(0)):
            assert np.array_equal(a, b)
        j = old.at(time_s)
        assert old.near(j, float(old.s_m[j]) + 2.0) == new.near(j, float(new.s_m[j]) + 2.0)
    assert solved == len(times) - 1                  # all but the time between epochs


def test_off_track_is_the_cross_track_distance_against_its_sigma():
    """Fixes placed at known distances across a straight of the paper2017 track (along
    its horizontal normal from the track's point) with a covariance built from a known σ
    across and along: `on_track` gives back the distance and the σ across, and
    `off_track` says off exactly beyond `gate_sigma` times that σ (floored)."""
    from trackmodel.earth import C_n_e, ecef_to_geodetic
    from trackmodel.io import read_track
    from railnav.simulation.scenarios import TRACKS_DIR
    track = read_track(TRACKS_DIR / "paper2017.csv")
    pt = track.at(5000.0)
    A = float(pt.azimuth)
    normal_n = np.array([np.cos(A), -np.sin(A), 0.0])       # horizontal, across the track
    offsets = np.array([0.0, 3.0, 4.8, 5.2, 30.0, 200.0])
    r_e = np.asarray(pt.r_e, dtype=float).reshape(3) \
        + (C_n_e(float(pt.lat), float(pt.lon)) @ normal_n)[None] * offsets[:, None]
    lat, lon, _ = ecef_to_geodetic(r_e, earth=track.earth)
    sigma_cross = 1.0
    along_n = np.array([np.sin(A), np.cos(A), 0.0])
    cov = sigma_cross ** 2 * np.outer(normal_n, normal_n) + 0.5 ** 2 * np.outer(
        along_n, along_n) + np.diag([0.0, 0.0, 4.0])        # σ 1 m across, 0.5 m along
    cov_n = np.repeat(cov[None], offsets.size, axis=0)
    fixes = TrackFixes.on_track(track, time_s=np.arange(offsets.size, dtype=float),
                                lat=lat, lon=lon, cov_enu_m2=cov_n)
    assert fixes.sigma_cross_m == pytest.approx(np.full(offsets.size, sigma_cross), rel=1e-9)
    assert fixes.distance_m == pytest.approx(offsets, abs=1e-3)
    off = [fixes.off_track(j, floor_m=0.5, gate_sigma=5.0) for j in range(offsets.size)]
    assert off == [False, False, False, True, True, True]
    # a floor above σ moves the gate to 10 m: only the 30 and 200 m fixes are off
    off = [fixes.off_track(j, floor_m=2.0, gate_sigma=5.0) for j in range(offsets.size)]
    assert off == [False, False, False, False, True, True]
