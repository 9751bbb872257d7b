"""Study plots: the outage-end table built from study rows, and the figure files.

References: hand-written study rows (values chosen in the test; horizontal = hypot of
along and cross, time into the outage = end sample - start), and
`railnav.evaluation.outage_plots.errors_at_durations` on the converted table (each run counted once,
at its own outage length).
"""
from __future__ import annotations

import math

import numpy as np
import pandas as pd

from railnav.evaluation.outage_plots import OUTAGE_COLUMNS, errors_at_durations
from railnav.studies.plots import outage_end_table, plot_study


def _row(run: int, filter_: str, grade: str, duration: float, along: float, cross: float,
         *, status: str = "ok", track: str = "a.csv", second: tuple | None = None) -> dict:
    row = {"run_id": f"r{run}", "track": track, "imu_grade": grade, "filter": filter_,
           "speed_mps": 20.0, "replicate": run, "seed": 1, "status": status,
           "outage1_start_s": 100.0, "outage1_duration_s": duration,
           "outage1_end_sample_s": 100.0 + duration - 0.1,
           "outage1_along_track_end_m": along, "outage1_cross_track_end_m": cross,
           "outage1_vertical_end_m": 0.5, "outage1_position_3d_end_m": 9.0,
           "outage2_start_s": math.nan, "outage2_duration_s": math.nan,
           "outage2_end_sample_s": math.nan, "outage2_along_track_end_m": math.nan,
           "outage2_cross_track_end_m": math.nan, "outage2_vertical_end_m": math.nan,
           "outage2_position_3d_end_m": math.nan}
    if second is not None:
        start, dur, a = second
        row.update(outage2_start_s=start, outage2_duration_s=dur,
                   outage2_end_sample_s=start + dur - 1.0, outage2_along_track_end_m=a,
                   outage2_cross_track_end_m=0.0, outage2_vertical_end_m=0.0,
                   outage2_position_3d_end_m=abs(a))
    return row


def test_outage_end_table_values():
    table = pd.DataFrame([
        _row(0, "constrained", "mems", 10.0, -3.0, 4.0),
        _row(1, "unconstrained", "mems", 30.0, 6.0, -8.0, second=(500.0, 60.0, 2.0)),
        _row(2, "constrained", "mems", 10.0, 1.0, 1.0, status="failed")])
    ends = outage_end_table(table)
    assert list(ends.columns)[-len(OUTAGE_COLUMNS):] == list(OUTAGE_COLUMNS)
    assert list(ends["run_id"]) == ["r0", "r1", "r1"]
    np.testing.assert_allclose(ends["horizontal_m"], [5.0, 10.0, 2.0])
    np.testing.assert_allclose(ends["time_into_outage_s"], [9.9, 29.9, 59.0])
    np.testing.assert_allclose(ends["outage_start_s"], [100.0, 100.0, 500.0])
    assert list(ends["along_track_m"]) == [-3.0, 6.0, 2.0]


def test_each_run_counts_once_at_its_own_duration():
    """Runs with 10-s and 30-s outages: errors_at_durations takes each at its length."""
    rows = [_row(k, "constrained", "tactical", d, a, 0.0)
            for k, (d, a) in enumerate([(10.0, 1.0), (10.0, 3.0), (30.0, 7.0), (30.0, 9.0)])]
    bands = errors_at_durations(outage_end_table(pd.DataFrame(rows)), [10.0, 30.0],
                                quantity="along_track_m")
    assert list(bands["runs"]) == [2, 2]
    np.testing.assert_allclose(bands["median"], [2.0, 8.0])


def test_plot_files(tmp_path):
    """One figure per quantity; one per track when the track varies; none without an
    outage end."""
    rows = [_row(k, f, g, d, 1.0 + k, 0.1, track=t)
            for k, (t, g, f, d) in enumerate(
                (t, g, f, d) for t in ("a.csv", "b.csv") for g in ("navigation", "mems")
                for f in ("constrained", "unconstrained") for d in (10.0, 30.0))]
    paths = plot_study(pd.DataFrame(rows), tmp_path)
    assert sorted(p.name for p in paths) == [
        "error_growth_along_track_1.png", "error_growth_along_track_2.png",
        "error_growth_horizontal_1.png", "error_growth_horizontal_2.png"]
    assert all(p.read_bytes().startswith(b"\x89PNG") for p in paths)
    no_outage = pd.DataFrame([{"run_id": "r", "status": "ok", "imu_grade": "mems",
                               "filter": "constrained"}])
    assert plot_study(no_outage, tmp_path) == []


def test_single_group_names(tmp_path):
    rows = [_row(k, "constrained", "mems", d, 1.0, 0.0) for k, d in enumerate((10.0, 30.0))]
    paths = plot_study(pd.DataFrame(rows), tmp_path)
    assert [p.name for p in paths] == ["error_growth_along_track.png",
                                       "error_growth_horizontal.png"]
