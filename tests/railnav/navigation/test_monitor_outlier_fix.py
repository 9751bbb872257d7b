"""The divergence monitor and one fix far along the track, then fixes off it
(railnav/navigation/monitor.py): issue 14, log_29083 at 288 s.

On the Brussels log 29083 (fix-only, one track) a single-point fix 41 m ahead of a filter at
σ_s 1.9 m, 9.7 m across the track, made the monitor say ``lost`` and restart from that very
fix; no fix of the next 16 s was on the track (the receiver's jumps, 87 m across), so the
restarted state kept the unknown start speed, exactly 0 (σ 50 m/s), while σ_s grew to
761 m, labelled ``ok``: the window's χ² fix test had failed on one fix, which it cannot tell
from a fault of that fix, and the rejected-row test never saw the fault screen's rejections.

References, independent of the filter: the fixes are written here from the track's own
geometry (`Track.geodetic`) at a known constant speed (their finite difference), with
seeded noise at the class's σ; `Track.project` measures the jumped fixes' distance from it.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from railnav.jobs.run import run_files
from trackmodel.io import read_track

REPO = Path(__file__).resolve().parents[3]
TRACK = REPO / "data" / "tracks" / "brussels" / "log_29083_L36-A.csv"
START_GPS_S, DT_S, S0_M, SPEED = 1_331_370_000.0, 0.4, 500.0, 20.0
#: The one fix ahead (along the track, on it), and the stretch of fixes off the track after it.
T_AHEAD_S, AHEAD_M, OFF_S, OFF_M = 30.0, 40.0, 10.0, 90.0


def _fixes(tmp: Path, track) -> tuple[Path, pd.DataFrame]:
    rng = np.random.default_rng(14)
    t = np.arange(0.0, 60.0 + DT_S / 2, DT_S)
    s = S0_M + SPEED * t                                         # the truth
    s_fix = s + rng.normal(0.0, 1.0, t.size)
    ahead = np.isclose(t, T_AHEAD_S)
    s_fix[ahead] = s[ahead] + AHEAD_M
    lat, lon, _ = track.geodetic(s_fix)
    lat = np.degrees(lat) + rng.normal(0.0, 1.0, t.size) / 111_200.0
    off = (t > T_AHEAD_S + 1e-6) & (t < T_AHEAD_S + OFF_S)
    lat[off] += OFF_M / 111_200.0                                # 90 m north, off the track
    frame = pd.DataFrame({"gps_time_s": START_GPS_S + t, "lat_deg": lat,
                          "lon_deg": np.degrees(lon), "quality": "single"})
    path = tmp / "fixes.csv"
    frame.to_csv(path, index=False, float_format="%.10f")
    return path, frame.assign(t=t, s=s, off=off)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    track = read_track(TRACK)
    path, truth = _fixes(tmp_path_factory.mktemp("outlier"), track)
    proj = track.project(np.radians(truth["lat_deg"]), np.radians(truth["lon_deg"]))
    return run_files(track, fixes_path=path), truth, np.asarray(proj.distance_m)


def test_one_fix_far_ahead_does_not_restart_the_filter(run):
    """The jumped fixes are off the track (> 50 m, the track's projection), the one ahead
    on it; the monitor restarts nothing, and the filter's speed through the 10 s of
    jumped fixes is the fixes' finite-difference speed (20 m/s) within 3σ, not the
    unknown start speed 0 (σ 50 m/s) of a restart from that fix (before: restarted at
    30 s, speed 0.000 m/s and σ_s 500 m through the stretch)."""
    out, truth, distance = run
    assert np.all(distance[truth["off"]] > 50.0)
    assert distance[np.isclose(truth["t"], T_AHEAD_S)][0] < 5.0
    records = out.result.monitor
    assert (records["action"] == "").all() and (records["status"] != "lost").all()
    est = out.result.estimates
    t = est["time_s"].to_numpy() - est["time_s"].iloc[0] + truth["t"].iloc[0]
    gap = (t > T_AHEAD_S + 1.0) & (t < T_AHEAD_S + OFF_S)
    fd = np.diff(truth["s"]) / np.diff(truth["t"])               # finite difference
    assert np.allclose(fd, SPEED)
    v, sigma_v = est["speed_mps"].to_numpy()[gap], est["sigma_speed_mps"].to_numpy()[gap]
    assert gap.sum() > 20 and np.all(np.abs(v - SPEED) <= 3.0 * sigma_v)
    assert np.all(sigma_v < 5.0)


def test_a_filter_rejecting_every_fix_is_not_ok(run):
    """Through the stretch every fix is rejected (innovations.csv); from its third epoch
    on (two rejected epochs are beyond a consistent filter's rejections at p_degraded:
    binomial, each epoch's rows rejected with ≤ ~6e-4) the status is not ``ok`` (before:
    ``ok`` from the 10th epoch after the restart to the end of the stretch)."""
    out, truth, _ = run
    rows = out.result.innovations
    t0 = out.result.estimates["time_s"].iloc[0] - truth["t"].iloc[0]
    in_gap = (rows["time_s"] - t0 > T_AHEAD_S + 1e-6) & (rows["time_s"] - t0 < T_AHEAD_S + OFF_S)
    assert in_gap.sum() > 40 and (rows.loc[in_gap, "status"] == "rejected").all()
    records = out.result.monitor
    tr = records["time_s"].to_numpy() - t0
    late = (tr > T_AHEAD_S + 1.0) & (tr < T_AHEAD_S + OFF_S)
    assert late.sum() > 20 and (records.loc[late, "status"] != "ok").all()
