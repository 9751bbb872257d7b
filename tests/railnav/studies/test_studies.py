"""Studies end to end: the table, determinism over engines and worker counts, resume.

References: the grid itself (one row per run, in grid order, no run lost or duplicated),
`railnav.studies.runs.run_one` in a plain loop (the serial table every engine must
reproduce, `runtime_s` apart), and the parts on disk after an interruption (a raised
exception after N runs; a process killed with SIGKILL).

Dask runs on a `LocalCluster` of 2 worker processes (``processes=True``), as in
production; the local pool also uses 2 processes.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from dataclasses import replace

import pandas as pd
import pytest

from railnav.studies.runs import expand_grid, run_one
from railnav.studies.store import PartStore
from railnav.studies.study import run_study
from tests.conftest import REPO
from tests.railnav.studies.conftest import PART_WAIT_S, TINY
from tests.railnav.studies.conftest import same_table as _same


def test_serial_study_table(config, reference):
    """One ok row per run in grid order; results.parquet is that table; plots drawn."""
    specs = expand_grid(config)
    table = reference.table
    assert list(table["run_id"]) == [s.run_id for s in specs]
    assert list(table["run_index"]) == list(range(16))
    assert (table["status"] == "ok").all()
    assert reference.runs_total == 16 and reference.runs_resumed == 0
    _same(pd.read_parquet(reference.results_path), table)
    assert [p.name for p in reference.plots] == ["error_growth_along_track.png",
                                                 "error_growth_horizontal.png"]
    assert all(p.stat().st_size > 0 for p in reference.plots)
    row = run_one(specs[5])
    assert row["outage1_along_track_end_m"] == table.loc[5, "outage1_along_track_end_m"]


def test_dask_local_cluster_gives_the_same_table(config, reference, tmp_path):
    from dask.distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        result = run_study(config, tmp_path, scheduler=client, plots=False)
        assert len(client.scheduler_info()["workers"]) == 2
    _same(result.table, reference.table)


def test_process_pool_gives_the_same_table(config, reference, tmp_path):
    result = run_study(config, tmp_path, workers=2, plots=False)
    _same(result.table, reference.table)


class Interrupted(Exception):
    pass


def test_interrupted_then_resumed_loses_and_repeats_nothing(config, reference, tmp_path):
    """Stop after 5 of 16 runs (parts of 3: one full part, then the 2 finished runs are
    written on the way out); resume: 11 more runs, and the table is the reference."""
    calls = []

    def stop_after_five(done, total):
        calls.append(done)
        if done == 5:
            raise Interrupted

    with pytest.raises(Interrupted):
        run_study(config, tmp_path, workers=1, progress=stop_after_five, plots=False)
    assert len(PartStore(tmp_path).finished_ids()) == 5
    assert not (tmp_path / "results.parquet").exists()
    seen = []
    resumed = run_study(config, tmp_path, workers=1, plots=False,
                        progress=lambda done, total: seen.append(done))
    assert resumed.runs_resumed == 5 and seen == list(range(5, 17))
    _same(resumed.table, reference.table)
    parts = pd.concat([pd.read_parquet(p) for p in PartStore(tmp_path).part_paths()])
    assert sorted(parts["run_id"]) == sorted(reference.table["run_id"])   # each once


def test_killed_process_then_resumed(config, reference, tmp_path):
    """SIGKILL the CLI once its first part is on disk; the resumed study completes the
    table with every run exactly once and no leftover temporary part counted."""
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.Popen([sys.executable, "-m", "railnav.cli", "-q", "study", str(TINY),
                             "--out", str(tmp_path), "--workers", "1", "--no-plots"],
                            cwd=REPO, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + PART_WAIT_S
    try:
        while not list((tmp_path / "parts").glob("part-*.parquet")):
            assert proc.poll() is None, "the study ended before it could be killed"
            assert time.monotonic() < deadline
            time.sleep(0.05)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    done_before = PartStore(tmp_path).finished_ids()
    assert 3 <= len(done_before) < 16
    resumed = run_study(config, tmp_path, workers=1, plots=False)
    assert resumed.runs_resumed == len(done_before)
    _same(resumed.table, reference.table)


def test_failed_runs_are_recorded(config, tmp_path):
    """A grid with a 0.1-m track beside the real one: its runs fail (recorded with the
    error), the others complete."""
    stub = tmp_path / "stub.csv"
    stub.write_text("lat_deg,lon_deg,h_m,length_m,azimuth_deg,elevation_deg\n"
                    "50.45,30.52,100.0,0.1,30.0,0.0\n")
    small = replace(config, tracks=("paper2017.csv", "stub.csv"), base_dir=tmp_path,
                    imu_grades=("paper2017",), outage_sets=(((10.0, 5.0),),), replicates=1)
    result = run_study(small, tmp_path / "out", workers=1)
    table = result.table
    assert len(table) == 4 and result.runs_failed == 2
    assert list(table["status"]) == ["ok", "ok", "failed", "failed"]
    assert table["error"].iloc[2].startswith("ConfigError: the trip leaves the track")
    assert table["along_track_rms_m"].iloc[2:].isna().all()
