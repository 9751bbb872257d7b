"""Study runs: grid expansion, seeds, run ids, and one run -> one row.

References: the product of the axes (count and order), `numpy.random.SeedSequence` for
the documented seed derivation, a fresh interpreter with another hash seed (run ids are
not Python-hash based), and `railnav.jobs.run.run_simulated` / `stream_simulated` called
directly on the run's scenario (the row must carry their summary's figures).
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from railnav.jobs.run import run_simulated
from railnav.navigation.streaming import stream_simulated
from railnav.simulation.scenarios import get_scenario
from railnav.simulation.trip import navigator_config_for
from railnav.studies.file import load_study_config
from railnav.studies.runs import (
    RunSpec,
    derive_seed,
    expand_grid,
    metric_columns,
    run_one,
)
from tests.conftest import DATA, REPO
from trackmodel.io import read_track

TINY = DATA / "studies" / "tiny.toml"


def test_grid_count_order_and_seeds():
    """2 grades x 2 outages x 2 replicates x 2 filters, filter innermost; replicate r has
    the same seed in every cell (common random numbers), derived as documented."""
    config = load_study_config(TINY)
    specs = expand_grid(config)
    assert len(specs) == 16 and [s.index for s in specs] == list(range(16))
    assert [s.filter for s in specs[:4]] == ["constrained", "unconstrained"] * 2
    assert [s.replicate for s in specs[:4]] == [0, 0, 1, 1]
    assert [s.imu_grade for s in specs] == ["paper2017"] * 8 + ["tactical"] * 8
    assert len({s.run_id for s in specs}) == 16
    for s in specs:
        state = np.random.SeedSequence([7, s.replicate]).generate_state(2, np.uint32)
        assert s.seed == (int(state[0]) << 31) ^ int(state[1])
    assert specs[0].seed != specs[2].seed
    independent = expand_grid(replace(config, common_random_numbers=False))
    cells = {(s.imu_grade, s.outages, s.replicate): s.seed for s in independent}
    assert len(set(cells.values())) == 8                       # one seed per cell x replicate
    assert all(cells[(s.imu_grade, s.outages, s.replicate)] == s.seed for s in independent)
    assert derive_seed(7, 0) == specs[0].seed


def test_run_ids_follow_the_track_content(tmp_path):
    """The same track name with other content (a copy with a longer section) is another
    run: new ids; the same content under a copy gives the same ids."""
    config = load_study_config(TINY)
    text = (DATA / "tracks" / "paper2017.csv").read_text()
    (tmp_path / "paper2017.csv").write_text(text)
    same = expand_grid(replace(config, base_dir=tmp_path))
    (tmp_path / "paper2017.csv").write_text(text.replace("25000.0", "26000.0"))
    edited = expand_grid(replace(config, base_dir=tmp_path))
    original = expand_grid(config)
    assert [s.run_id for s in same] == [s.run_id for s in original]
    assert not {s.run_id for s in edited} & {s.run_id for s in original}
    assert "26000.0" in edited[0].track_text


def test_run_ids_are_stable_across_interpreters():
    """Another interpreter with another string-hash seed expands the same ids."""
    code = ("import json; from railnav.studies.file import load_study_config; "
            "from railnav.studies.runs import expand_grid; "
            f"print(json.dumps([s.run_id for s in expand_grid(load_study_config({str(TINY)!r}))]))")
    env = dict(os.environ, PYTHONHASHSEED="12345")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env=env, cwd=REPO)
    assert json.loads(out.stdout) == [s.run_id for s in expand_grid(load_study_config(TINY))]


def _scenario_of(spec: RunSpec):
    scenario = get_scenario(spec.scenario).with_overrides(speed_mps=spec.speed_mps,
                                                          duration_s=spec.duration_s)
    return replace(scenario, imu_errors=spec.imu_grade, outages=spec.outages,
                   sigma_pseudorange_m=spec.sigma_pseudorange_m,
                   sigma_range_rate_mps=spec.sigma_range_rate_mps)


def _check_row(row: dict, summary: dict) -> None:
    errors = summary["errors"]
    assert row["status"] == "ok" and row["error"] == ""
    assert row["along_track_rms_m"] == errors["all"]["along_track_m"]["rms"]
    assert row["position_3d_max_m"] == errors["all"]["position_3d_m"]["max"]
    assert row["attitude_rms_rad"] == errors["all"]["attitude_rad"]["rms"]
    end = errors["outages"][0]
    assert row["outage1_end_sample_s"] == end["end_sample_s"]
    assert row["outage1_along_track_end_m"] == end["at_end"]["along_track_m"]
    assert row["outage1_speed_end_mps"] == end["at_end"]["speed_mps"]
    assert row["outage1_along_track_max_m"] == end["max"]["along_track_m"]
    assert row["nees_mean"] == errors["nees"]["mean"]
    assert row["gnss_epochs"] == summary["statistics"]["gnss_epochs"]
    assert math.isnan(row["left_track_time_s"])


@pytest.mark.parametrize("index", [1, 13])
def test_row_carries_the_run_summary(index):
    """The row of a run against run_simulated of the same scenario, filter and seed."""
    spec = expand_grid(load_study_config(TINY))[index]
    row = run_one(spec)
    scenario = _scenario_of(spec)
    summary = run_simulated(read_track(DATA / "tracks" / spec.track), scenario, seed=spec.seed,
                            config=navigator_config_for(scenario, filter=spec.filter)).summary
    _check_row(row, summary)
    assert list(row)[:len(spec.parameters())] == list(spec.parameters())
    assert list(row)[len(spec.parameters()):-3] == metric_columns(1)


def test_streaming_row_carries_the_stream_summary():
    config = replace(load_study_config(TINY), mode="streaming", segment_s=7.0)
    spec = expand_grid(config)[2]
    row = run_one(spec)
    scenario = _scenario_of(spec)
    summary = stream_simulated(read_track(DATA / "tracks" / spec.track), scenario, seed=spec.seed,
                               config=navigator_config_for(scenario, filter=spec.filter),
                               segment_s=7.0).summary
    _check_row(row, summary)
    assert row["mode"] == "streaming"


def test_failed_run_is_a_row():
    """A run that cannot be simulated (a 0.1-m track: the trip leaves it at once) returns
    a failed row with the exception and NaN figures."""
    stub = ("lat_deg,lon_deg,h_m,length_m,azimuth_deg,elevation_deg\n"
            "50.45,30.52,100.0,0.1,30.0,0.0\n")
    spec = replace(expand_grid(load_study_config(TINY))[0], track_text=stub)
    row = run_one(spec)
    assert row["status"] == "failed"
    assert row["error"].startswith("ConfigError: the trip leaves the track")
    assert all(math.isnan(row[c]) for c in metric_columns(1))
    assert row["runtime_s"] >= 0
