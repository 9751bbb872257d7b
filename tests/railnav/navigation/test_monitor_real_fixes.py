"""The divergence monitor on real fixes that jump off the track (railnav/navigation/monitor.py,
`TrackFixes.off_track`).

Reference: log 29083's shipped excerpt (`data/fixes/brussels/`, 150 s of a real train log
whose receiver jumps 90-200 m off the track, those rows flagged carrier-fixed) and its
single-point rows near the track (`truth_quality="single"`, screened by
`railnav.evaluation.reference.screen_fix_reference`), against which the filter's error is
measured; the distances of the fixes from the track by `Track.project` (a second method).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gnss_obs.fixes.read import read_fixes
from railnav.jobs.run import run_files
from trackmodel.io import read_track

REPO = Path(__file__).resolve().parents[3]
TRACK = REPO / "data" / "tracks" / "brussels" / "log_29083_L36-A.csv"
LOG = REPO / "data" / "fixes" / "brussels" / "log_29083_L36-A_excerpt.csv"


def test_fixes_off_the_track_neither_fail_the_monitor_nor_restart_the_filter():
    """The excerpt's jumps are real (> 50 m off the track on more than 20 fixes) and the
    fix-only filter is not lost: its error at every reference row is within 3σ. So the
    monitor must call no epoch ``lost`` and restart nothing (with recovery on, the
    default). Before fixes off the track were left out of its test (de48e11): 108 of
    149 epochs ``lost`` without recovery, 9 restarts from jumped fixes with it; on the
    whole log the restarts took the filter 2.1 km off."""
    track = read_track(TRACK)
    fixes = read_fixes(LOG).table
    proj = track.project(np.radians(fixes["lat_deg"]), np.radians(fixes["lon_deg"]))
    assert np.count_nonzero(np.asarray(proj.distance_m) > 50.0) > 20
    out = run_files(track, fixes_path=LOG, truth_path=LOG, truth_quality="single")
    err = out.errors.along_track_m
    sigma = out.result.estimates["sigma_s_m"].to_numpy()
    ok = np.isfinite(err)
    assert ok.sum() > 50
    assert np.all(np.abs(err[ok]) <= 3.0 * sigma[ok])
    records = out.result.monitor
    assert len(records) > 100
    assert (records["status"] == "lost").sum() == 0
    assert (records["action"] == "").all()
