"""The divergence monitor on real train fixes (railnav/navigation/monitor.py): fixes that jump
off the track (`TrackFixes.off_track`), and the lower-tail fix test
(railnav/navigation/small_disagreement.py).

References: log 29083's shipped excerpt (`data/fixes/brussels/`, 150 s of a real train log
whose receiver jumps 90-200 m off the track, those rows flagged carrier-fixed) and its
single-point rows near the track (`truth_quality="single"`, screened by
`railnav.evaluation.reference.screen_fix_reference`), against which the filter's error is
measured; the distances of the fixes from the track by `Track.project` (a second method);
log 28876's excerpt and its carrier-fixed rows; log 28554's carrier-fixed rows on the same
track as log 29083 (where they place the track across, against the single-point rows').
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gnss_obs.fixes.read import read_fixes
from railnav.jobs.run import run_files
from railnav.navigation.monitor_config import MonitorConfig
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


def test_carrier_fixed_fixes_better_than_their_sigma_do_not_degrade_the_filter():
    """Log 28876's shipped excerpt (60 s of a real train log, 148 carrier-fixed fixes at
    σ 3 cm, two of the receiver's propagated positions at σ 10 m), fix-only. Its
    carrier-fixed rows near the track (the reference) put the filter within 3σ_s at every
    row, and its prior σ_s (0.21 m after 0.4 s) is wider than a fix: each fix resets it
    (gain > 0.9). The fixes agree with the prior far better than √(σ²_fix + σ²_prior), the
    statistic of the lower-tail test before stop 36 (mean NIS of the along-track rows in
    innovations.csv < 0.1; it said ``degraded`` at every epoch). No correlation of the
    fixes can make such a filter overconfident: the lower tail must not fail, and the
    status is ``ok`` after the first `MonitorConfig.min_epochs` epochs."""
    log = REPO / "data" / "fixes" / "brussels" / "log_28876_L36-B_excerpt.csv"
    track = read_track(REPO / "data" / "tracks" / "brussels" / "log_28876_L36-B.csv")
    out = run_files(track, fixes_path=log, truth_path=log, truth_quality="rtk_fixed")
    err = out.errors.along_track_m
    sigma = out.result.estimates["sigma_s_m"].to_numpy()
    ok = np.isfinite(err)
    assert ok.sum() > 500 and out.summary["reference"]["kept"] > 140
    assert np.all(np.abs(err[ok]) <= 3.0 * sigma[ok])
    rows = out.result.innovations
    along = rows[(rows["kind"] == "fix_along") & (rows["sv"] == "fix:rtk_fixed")]
    assert len(along) > 140 and along["nis"].mean() < 0.1
    records = out.result.monitor
    assert np.median(records["sigma_s_prior_m"]) > 3.0 * 0.03
    assert (records["p_fix_small"] >= 1e-3).all()
    assert (records["status"].iloc[MonitorConfig().min_epochs:] == "ok").all()


def test_single_point_fixes_with_a_slow_sigma_sized_error_keep_failing_the_lower_tail():
    """Log 29083's excerpt, fix-only: its single-point rows (σ 2.5 m) agree with the
    filter far better than their σ (against them its error is centimetres), yet they are
    not better than their σ: across the track, which the filter cannot follow, they lie
    a median 2-4 m from the line where log 28554's carrier-fixed rows (another train, the
    same track A, shipped in data/fixes/brussels/) put the track, and that offset is slow
    (consecutive rows differ by < 1 m RMS). A slow error of their σ's size, which the
    filter (σ_s 1.7 m) follows along the track: the lower tail must keep failing (on at
    least 40 % of the epochs; 52 % at stop 36)."""
    fixes = read_fixes(LOG).table
    carrier = read_fixes(REPO / "data" / "fixes" / "brussels" /
                         "log_28554_L36-A_to_L36C-A.csv").table
    track = read_track(TRACK)
    p = track.project(np.radians(fixes["lat_deg"]), np.radians(fixes["lon_deg"]))
    q = track.project(np.radians(carrier["lat_deg"]), np.radians(carrier["lon_deg"]))
    single = (fixes["quality"] == "single").to_numpy() & (np.asarray(p.distance_m) < 15.0)
    fixed = (carrier["quality"] == "rtk_fixed").to_numpy() & (np.asarray(q.distance_m) < 5.0)
    order = np.argsort(q.s[fixed])
    line = np.interp(p.s[single], q.s[fixed][order], q.cross_track_m[fixed][order],
                     left=np.nan, right=np.nan)
    offset = p.cross_track_m[single] - line
    assert single.sum() > 40 and np.isfinite(offset).all()
    assert 2.0 < np.median(np.abs(offset)) < 4.0
    assert np.sqrt(np.mean(np.diff(offset) ** 2)) < 1.0
    out = run_files(track, fixes_path=LOG, truth_path=LOG, truth_quality="single")
    assert np.mean(out.result.monitor["p_fix_small"] < 1e-3) >= 0.4
