"""The runs on sensor files behave as ``railnav run`` without it (stop 38's parity audit):
the same default filter for one track and several, the same outages, and the inputs a
filter would ignore refused by the library too, not only by the command's flag checks.

References: files that do not exist (a check that runs before any file is read raises its
own error, not the reader's); a ``scenario.json`` written here; the filter kind a run
reports in its summary.
"""
from __future__ import annotations

import json

import pytest

from gnss_obs.fixes.writers import write_fixes_csv
from railnav.errors import ConfigError
from railnav.filters.fix_epochs import FixModelConfig
from railnav.jobs.run import run_files
from railnav.jobs.scoring import file_outages
from railnav.jobs.tracks import run_files_tracks
from railnav.simulation.fixes import FixSimConfig, trip_fixes
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import simulate_trip
from trackmodel.io import read_track


@pytest.fixture(scope="module")
def track():
    return read_track(TRACKS_DIR / "curvy.csv")


@pytest.mark.parametrize("keywords, named", [
    ({"fixes_path": "missing.csv", "imu_grade": "navigation"}, "imu_grade"),
    ({"fixes_path": "missing.csv", "imu_path": "missing_imu.csv", "filter": "gnss-only"},
     "imu_path"),
    ({"fixes_path": "missing.csv", "imu_path": "missing_imu.csv",
      "fix_model": FixModelConfig(correlated_code_errors=True)}, "fix_model"),
])
def test_inputs_the_filter_ignores_are_refused_before_reading(track, keywords, named):
    with pytest.raises(ConfigError) as info:
        run_files(track, **keywords)
    assert info.value.arguments == (named,)


@pytest.mark.parametrize("keywords", [
    {"filter": "gnss-only"}, {"systems": "GE"}, {"imu_grade": "navigation"},
    {"fix_model": FixModelConfig()}, {"sigma_pr_m": 3.0, "sigma_rr_mps": 0.1},
    {"lever_arms": ()},
])
def test_arguments_of_the_default_config_are_refused_with_a_config(track, keywords):
    """With `config` given, what only shapes the default configuration would be dropped
    silently: each is refused by name, before any file is read."""
    from railnav.config import NavigatorConfig
    with pytest.raises(ConfigError) as info:
        run_files(track, fixes_path="missing.csv", config=NavigatorConfig(), **keywords)
    assert info.value.arguments == tuple(keywords)


def test_file_outages_given_else_the_scenarios(tmp_path):
    (tmp_path / "scenario.json").write_text(json.dumps(
        {"scenario": {"outages": [[100.0, 50.0], [500.0, 25.0]]}}))
    imu = tmp_path / "imu.csv"                      # need not exist: scenario.json beside it
    assert [tuple(o) for o in file_outages(None, None, imu)] == [(100.0, 50.0), (500.0, 25.0)]
    assert file_outages((), imu) == ()
    assert [tuple(o) for o in file_outages([(1.0, 2.0)], imu)] == [(1.0, 2.0)]
    assert file_outages(None, tmp_path / "elsewhere" / "imu.csv") == ()


def test_tracks_run_of_fixes_alone_takes_the_gnss_only_filter(tmp_path):
    """`run_files_tracks` without `filter` on fixes alone runs the gnss-only filter, as
    ``railnav run A B --fixes F`` does (its default was the constrained filter, which
    needs an IMU)."""
    tracks = [read_track(TRACKS_DIR / f"double_{x}.csv") for x in "ab"]
    scenario = get_scenario("curvy").with_overrides(duration_s=20.0)
    trip = simulate_trip(scenario, track=tracks[0], gnss=False)
    path = tmp_path / "fixes.csv"
    write_fixes_csv(path, trip_fixes(trip, FixSimConfig()).table)
    run = run_files_tracks(tracks, ["double_a", "double_b"], fixes_path=path)
    assert run.outcome.summary["filter"] == "gnss-only"
