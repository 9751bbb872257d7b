"""References to score runs against (`railnav.evaluation.reference`): the fix screen on
hand-placed fixes (on the track, off it, a jump along it), truth.csv read back as the
simulator's truth, and errors only where the reference brackets an estimate."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from gnss_obs.fixes.table import FIX_COLUMNS
from railnav.errors import ConfigError
from railnav.evaluation.reference import (
    MAX_REFERENCE_GAP_S,
    REFERENCE_MAX_JUMP_M,
    REFERENCE_MAX_OFFSET_M,
    Reference,
    read_reference,
    reference_errors,
    screen_fix_reference,
    truth_from_frame,
)
from railnav.simulation.profiles import constant_speed
from railnav.simulation.scenarios import TRACKS_DIR
from railnav.simulation.truth import simulate_truth
from trackmodel.earth import C_n_e, ecef_to_geodetic
from trackmodel.io import read_track

TRACK = read_track(TRACKS_DIR / "east_west.csv")
SPEED_MPS = 10.0


def _fixes(s: np.ndarray, across_m: np.ndarray, quality: list[str]) -> pd.DataFrame:
    """Fixes at s (m) on the track moved `across_m` to its right, 0.4 s apart."""
    p = TRACK.at(s)
    right = np.column_stack([np.cos(p.azimuth), -np.sin(p.azimuth), np.zeros(s.size)])
    r = p.r_e + np.einsum("kij,kj->ki", C_n_e(p.lat, p.lon), right * across_m[:, None])
    lat, lon, h = ecef_to_geodetic(r, earth=TRACK.earth)
    cols = {c: np.full(s.size, np.nan) for c in FIX_COLUMNS}
    cols.update(gps_time_s=1e9 + 0.4 * np.arange(s.size), lat_deg=np.degrees(lat),
                lon_deg=np.degrees(lon), h_m=h, quality=np.array(quality, dtype=object))
    return pd.DataFrame(cols)


def test_screen_keeps_the_class_near_the_track_and_in_line():
    n = 12
    s = 1000.0 + SPEED_MPS * 0.4 * np.arange(n)
    across = np.full(n, 1.0)
    across[3] = 2.0 * REFERENCE_MAX_OFFSET_M               # off the track
    s[7] += 3.0 * REFERENCE_MAX_JUMP_M                       # a jump along it
    quality = ["rtk_fixed"] * n
    quality[10] = "single"                                    # another class
    keep, report = screen_fix_reference(_fixes(s, across, quality), TRACK)
    expected = np.ones(n, dtype=bool)
    expected[[3, 7, 10]] = False
    np.testing.assert_array_equal(keep, expected)
    assert report["candidates"] == 11 and report["off_track"] == 1 and report["jumps"] == 1
    assert report["quality"] == "rtk_fixed"
    assert report["median_offset_kept_m"] == pytest.approx(1.0, abs=1e-3)


def test_truth_csv_reads_back_the_simulated_truth():
    truth = simulate_truth(TRACK, constant_speed(SPEED_MPS), duration_s=20.0, rate_hz=10.0)
    back = truth_from_frame(truth.to_frame(), TRACK)
    np.testing.assert_allclose(back.r_e, truth.r_e, rtol=0, atol=1e-6)       # µm
    np.testing.assert_allclose(back.v_n, truth.v_n, rtol=0, atol=1e-9)
    np.testing.assert_allclose(back.yaw, truth.yaw, rtol=0, atol=1e-12)


class _Result:
    """The part of a NavigationResult `error_series` reads (no filter object: no NEES)."""

    def __init__(self, truth, t):
        p = TRACK.at(np.interp(t, truth.time_s, truth.s))
        v_n = SPEED_MPS * p.u_n
        self.estimates = pd.DataFrame({
            "time_s": t, "lat_deg": np.degrees(p.lat), "lon_deg": np.degrees(p.lon),
            "h_m": p.h, "speed_mps": SPEED_MPS, "v_north_mps": v_n[:, 1]})
        self.filter_object = None


def test_errors_only_where_the_reference_brackets_the_estimate():
    truth = simulate_truth(TRACK, constant_speed(SPEED_MPS), duration_s=30.0, rate_hz=10.0)
    keep = (truth.time_s < 10.0) | (truth.time_s > 10.0 + 2 * MAX_REFERENCE_GAP_S)
    sub = type(truth)(**{k: v[keep] for k, v in vars(truth).items()})
    t = np.arange(0.0, 30.0, 0.05)
    errors = reference_errors(_Result(truth, t), Reference(sub, ("s",)), TRACK)
    # the reference's samples around the hole: every estimate strictly between them has
    # one side farther than MAX_REFERENCE_GAP_S (the hole is longer than 2x that)
    last, first = sub.time_s[sub.time_s < 10.0][-1], sub.time_s[sub.time_s > 10.0][0]
    assert first - last > 2 * MAX_REFERENCE_GAP_S
    gap = (t > last + 1e-9) & (t < first - 1e-9)
    assert np.isnan(errors.along_track_m[gap]).all()
    np.testing.assert_allclose(errors.along_track_m[~gap & (t <= 29.9)], 0.0, atol=1e-6)


def test_a_reference_class_needs_a_fix_file(tmp_path):
    truth = simulate_truth(TRACK, constant_speed(SPEED_MPS), duration_s=2.0, rate_hz=10.0)
    truth.to_frame().to_csv(tmp_path / "truth.csv", index=False)
    with pytest.raises(ConfigError, match="applies to a fix file only"):
        read_reference(tmp_path / "truth.csv", TRACK, start_gps_time_s=0.0, quality="single")
    assert read_reference(tmp_path / "truth.csv", TRACK,
                          start_gps_time_s=0.0).report["source"] == "truth"
