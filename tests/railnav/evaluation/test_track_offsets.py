"""`tests.support.track_offsets` (the urban pieces' figures beside "never worse than SPP",
`benchmarks/bench_real_pieces.py`): points placed at known offsets from a straight track
come back with those offsets, and the worst epoch's split agrees with the horizontal
error an independent ENU difference (`railnav.evaluation.spp_accuracy.spp_errors`) gives."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from railnav.evaluation.spp_accuracy import spp_errors
from tests.support.track_offsets import (
    along_track_s,
    largest_error_parts,
    offset_summary,
    on_track_shift,
    reference_offsets,
)
from trackmodel.earth import ecef_to_geodetic, enu_to_ecef
from trackmodel.track import Section, Track

#: A 500-m straight track heading north: its right (positive cross-track) is east.
TRACK = Track.from_sections([Section(500.0, 0.0)], lat=math.radians(50.0),
                            lon=math.radians(4.0), h=100.0)


def _points(s_m, east_m, north_m, up_m) -> pd.DataFrame:
    """Points at ENU offsets (m) from the track's point at each ``s_m``."""
    at = TRACK.at(np.asarray(s_m, float))
    rows = []
    for k in range(len(s_m)):
        r_e = enu_to_ecef(np.array([east_m[k], north_m[k], up_m[k]]), lat0=float(at.lat[k]),
                          lon0=float(at.lon[k]), h0=float(at.h[k]))
        lat, lon, h = ecef_to_geodetic(r_e)
        rows.append((math.degrees(float(np.squeeze(lat))), math.degrees(float(np.squeeze(lon))),
                     float(np.squeeze(h))))
    return pd.DataFrame(rows, columns=["lat_deg", "lon_deg", "h_m"])


def test_points_at_known_offsets_come_back_with_them():
    # 2 m right and 1.5 m up at s = 100; 3 m left and 0.5 m down at 200; 4 m before the start
    pts = _points([100.0, 200.0, 0.0], [2.0, -3.0, 0.0], [0.0, 0.0, -4.0], [1.5, -0.5, 0.0])
    off = reference_offsets(TRACK, pts["lat_deg"], pts["lon_deg"], pts["h_m"])
    np.testing.assert_allclose(off["s_m"], [100.0, 200.0, 0.0], atol=1e-3)
    np.testing.assert_allclose(off["cross_track_m"], [2.0, -3.0, 0.0], atol=1e-3)
    np.testing.assert_allclose(off["horizontal_m"], [2.0, 3.0, 4.0], atol=1e-3)
    np.testing.assert_allclose(off["vertical_m"], [1.5, -0.5, 0.0], atol=1e-3)
    summary = offset_summary(off)
    assert summary["horizontal_max_m"] == pytest.approx(4.0, abs=1e-3)
    assert summary["horizontal_rms_m"] == pytest.approx(math.sqrt((4 + 9 + 16) / 3), abs=1e-3)
    assert summary["vertical_max_m"] == pytest.approx(1.5, abs=1e-3)
    assert summary["vertical_rms_m"] == pytest.approx(math.sqrt((2.25 + 0.25) / 3), abs=1e-3)


def test_the_worst_epoch_splits_into_the_along_track_error_and_the_offset():
    s_ref = np.array([50.0, 120.0, 300.0, 410.0])
    across = np.array([0.5, -2.5, 1.0, 0.0])          # the reference beside the track, m
    along = np.array([1.0, -3.0, 3.2, -0.4])          # the estimates' errors along it, m
    t = 1_000.0 + np.arange(4.0)
    reference = _points(s_ref, across, np.zeros(4), np.zeros(4)).assign(gps_time_s=t)
    on_track = TRACK.at(s_ref + along)                 # estimates lie on the track
    estimates = pd.DataFrame({"gps_time_s": t, "lat_deg": np.degrees(on_track.lat),
                              "lon_deg": np.degrees(on_track.lon), "h_m": on_track.h})
    horizontal = spp_errors(estimates, reference)["horizontal_m"].to_numpy()
    # straight track: the ENU difference is the two parts at right angles
    np.testing.assert_allclose(horizontal, np.hypot(along, across), atol=1e-3)
    off = reference_offsets(TRACK, reference["lat_deg"], reference["lon_deg"], reference["h_m"])
    parts = largest_error_parts(t, horizontal, on_track.s - off["s_m"].to_numpy(),
                                off["cross_track_m"].to_numpy())
    assert parts["along_track_max_m"] == pytest.approx(3.2, abs=1e-3)
    worst = parts["at_horizontal_max"]                 # |(-3.0, -2.5)| = 3.91 > |(3.2, 1.0)|
    assert worst["gps_time_s"] == 1_001.0
    assert worst["along_track_m"] == pytest.approx(-3.0, abs=1e-3)
    assert worst["offset_m"] == pytest.approx(-2.5, abs=1e-3)
    assert worst["horizontal_m"] == pytest.approx(math.hypot(3.0, 2.5), abs=1e-3)


#: Unit vectors from the receiver to six satellites, ENU (east, north, up), normalised.
_LOS = np.array([[0.3, 0.8, 0.5], [-0.7, 0.2, 0.6], [0.1, -0.6, 0.8], [0.9, -0.1, 0.4],
                 [-0.4, -0.7, 0.5], [0.0, 0.3, 0.95]])
_LOS = _LOS / np.linalg.norm(_LOS, axis=1)[:, None]


def test_a_receiver_moved_along_the_track_is_solved_to_that_shift():
    # track heading north (t = north); the receiver 2.7 m further along and its clock 13 m
    # off: each range shortens by e·t·2.7 and lengthens by 13 (first order, exact here)
    t = np.array([0.0, 1.0, 0.0])
    drho_ds = -_LOS @ t
    y = drho_ds * 2.7 + 13.0
    shift, sigma = on_track_shift(drho_ds, y, np.full(6, 4.0), ["G"] * 6)
    assert shift == pytest.approx(2.7, abs=1e-9)
    # equal variances: σ² = σ_row² / Σ(h − h̄)² (a line's slope fitted with an intercept)
    assert sigma == pytest.approx(2.0 / math.sqrt(np.sum((drho_ds - drho_ds.mean()) ** 2)))


def test_a_receiver_beside_the_track_moves_s_by_the_geometry_s_regression():
    # 1.5 m east of a north-running track: the misfit is −e·east·1.5; solved on the track
    # it goes to s by the regression of the east column on the north one (with the clock),
    # computed here from the normal equations of the two columns directly
    t, east = np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0])
    drho_ds, y = -_LOS @ t, -_LOS @ east * 1.5
    hc, yc = drho_ds - drho_ds.mean(), y - y.mean()
    shift, _ = on_track_shift(drho_ds, y, np.ones(6), ["G"] * 6)
    assert shift == pytest.approx(float(hc @ yc / (hc @ hc)), abs=1e-12)
    # two systems, each with its own clock: a step between them does not move s
    systems = ["G", "G", "G", "E", "E", "E"]
    y2 = drho_ds * 0.4 + np.where(np.array(systems) == "E", 25.0, -3.0)
    assert on_track_shift(drho_ds, y2, np.ones(6), systems)[0] == pytest.approx(0.4, abs=1e-9)
    assert math.isnan(on_track_shift(drho_ds[:2], y[:2], np.ones(2), ["G"] * 2)[0])


def test_along_track_s_runs_on_beyond_the_track_ends():
    # 4 m before the start and 3 m past the end along the tangent, 1 m to the side; one
    # inside: the projection's s there, its signed remainder beyond the ends
    pts = _points([0.0, 500.0, 250.0], [1.0, -1.0, 0.5], [-4.0, 3.0, 0.0], [0.0, 0.0, 0.0])
    s = along_track_s(TRACK, pts["lat_deg"], pts["lon_deg"])
    np.testing.assert_allclose(s, [-4.0, 503.0, 250.0], atol=2e-3)
