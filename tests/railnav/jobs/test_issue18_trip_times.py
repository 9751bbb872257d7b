"""Issue 18: times that miss the trip — IMU samples that never overlap the GNSS, outages
and summary windows after the trip's end — are clear errors, not a traceback or a
silently empty result."""
from __future__ import annotations

import json
import logging

import pandas as pd
import pytest

from gnss_obs.fixes.read import read_fixes
from railnav.cli import main
from railnav.errors import ConfigError, RailnavError
from railnav.jobs.run import run_files, run_simulated
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from trackmodel import read_track

PAPER = str(TRACKS_DIR / "paper2017.csv")
SHIFT_S = 5000.0


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "sim"
    assert main(["-q", "simulate", PAPER, "--duration-s", "20", "--seed", "3",
                 "--out", str(out)]) == 0
    return out


def _start(sim) -> float:
    return json.loads((sim / "scenario.json").read_text())["scenario"]["start_gps_time_s"]


def test_issue18_imu_never_overlapping_the_gnss(sim, tmp_path, capsys):
    imu = pd.read_csv(sim / "imu.csv")
    imu["time_s"] += SHIFT_S                      # the IMU clock 5000 s late
    late = tmp_path / "imu.csv"
    imu.to_csv(late, index=False)
    with pytest.raises(RailnavError, match="do not overlap") as info:
        run_files(read_track(PAPER), imu_path=late, obs_path=sim / "gnss_obs.rnx",
                  nav_path=sim / "gnss_nav.rnx", start_gps_time_s=_start(sim))
    message = str(info.value)
    assert "5000.0 to 5020.0 s" in message and "0.0 to 20.0 s" in message
    assert str(sim / "gnss_obs.rnx") in message
    code = main(["-q", "run", PAPER, "--imu", str(late), "--obs", str(sim / "gnss_obs.rnx"),
                 "--nav", str(sim / "gnss_nav.rnx"), "--out", str(tmp_path / "run")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "do not overlap" in err
    assert not (tmp_path / "run").exists()


def test_issue18_outage_after_the_trip_end_is_an_error():
    scenario = get_scenario("paper2017").with_overrides(duration_s=20.0,
                                                        outages=[(30.0, 5.0)])
    with pytest.raises(ConfigError, match="outage 30-35 s starts after the trip ends at 20 s"):
        run_simulated(PAPER, scenario)


def test_issue18_window_after_the_trip_end_is_an_error_at_the_cli(capsys, tmp_path):
    code = main(["-q", "run", PAPER, "--duration-s", "20", "--window", "25:40",
                 "--no-plots", "--out", str(tmp_path / "run")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err == "error: window 25-40 s starts after the trip ends at 20 s"
    assert not (tmp_path / "run").exists()


def test_issue18_window_ending_after_the_trip_is_cut_with_a_warning(caplog):
    scenario = get_scenario("paper2017").with_overrides(duration_s=20.0)
    with caplog.at_level(logging.WARNING):
        outcome = run_simulated(PAPER, scenario, window=(10.0, 40.0))
    assert any("window 10-40 s ends after the trip (at 20 s)" in r.getMessage()
               for r in caplog.records)
    errors = outcome.errors.to_frame()
    inside = errors[(errors["time_s"] >= 10.0) & (errors["time_s"] <= 40.0)]
    # the window's statistics are those of its part inside the trip
    assert outcome.summary["errors"]["window"]["along_track_m"]["max"] == pytest.approx(
        inside["along_track_m"].abs().max())


def test_issue18_a_shorter_trip_drops_the_scenarios_later_outages():
    paper = get_scenario("paper2017")
    assert [tuple(o) for o in paper.outages] == [(100.0, 50.0), (500.0, 50.0)]
    assert [tuple(o) for o in paper.with_overrides(duration_s=200.0).outages] == [(100.0, 50.0)]
    assert paper.with_overrides(duration_s=20.0).outages == ()
    given = paper.with_overrides(duration_s=20.0, outages=[(30.0, 5.0)])
    assert [tuple(o) for o in given.outages] == [(30.0, 5.0)]     # given: kept, refused later


def test_a_simulated_fix_run_whose_outage_lasts_to_the_end_runs(tmp_path, capsys):
    """README's `simulate paper2017 --duration-s 120 --fixes-format nmea` then `run --fixes`:
    the scenario's outage 100-150 s covers the trip's end, so no fix is written after 99 s.
    The outage is the scenario's (scenario.json), not a mistake: the run goes on with a
    warning (it was refused: "outage 100-150 s starts after the trip ends at 99 s")."""
    sim = tmp_path / "simf"
    assert main(["-q", "simulate", PAPER, "--duration-s", "105", "--fixes-format", "nmea",
                 "--out", str(sim)]) == 0
    last_fix_s = (read_fixes(sim / "fixes.nmea").table["gps_time_s"].max()
                  - _start(sim))
    assert last_fix_s == pytest.approx(99.0)      # the file itself: none in the outage
    capsys.readouterr()
    code = main(["run", PAPER, "--fixes", str(sim / "fixes.nmea"), "--no-plots",
                 "--out", str(tmp_path / "run")])
    assert code == 0
    assert ("outage 100-150 s starts after the trip ends (99 s, where the simulated files "
            "end): no effect") in capsys.readouterr().err
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["outages"] == [[100.0, 50.0]] and summary["errors"]["outages"] == []
    # the same outage given by the user is still a mistake
    with pytest.raises(ConfigError, match="outage 100-150 s starts after the trip ends at 99 s"):
        run_files(read_track(PAPER), fixes_path=sim / "fixes.nmea", outages=[(100.0, 50.0)])


def test_library_errors_name_arguments_the_command_line_its_flags(sim, tmp_path, capsys):
    """Audit finding: ``run_files(track)`` without any sensor file said 'give
    --start-gps-time-s' (a flag, in a library error, and not the problem). Now it says
    there is no sensor data and names run_files' arguments; the trip-start error names
    ``start_gps_time_s``, which the command line writes as its flag. The IMU log alone,
    away from its scenario.json, has no GPS time."""
    import inspect
    track = read_track(PAPER)
    with pytest.raises(ConfigError, match="^no sensor data: give imu_path, obs_path with "
                       "nav_path, or fixes_path$") as info:
        run_files(track)
    assert "--" not in str(info.value)
    assert set(info.value.arguments) <= set(inspect.signature(run_files).parameters)
    alone = tmp_path / "alone"
    alone.mkdir()
    (alone / "imu.csv").write_bytes((sim / "imu.csv").read_bytes())
    with pytest.raises(ConfigError, match="give start_gps_time_s$") as info:
        run_files(track, imu_path=alone / "imu.csv", imu_grade="tactical")
    assert info.value.arguments == ("start_gps_time_s",)
    code = main(["run", PAPER, "--imu", str(alone / "imu.csv"), "--imu-grade", "tactical",
                 "--out", str(tmp_path / "run")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.endswith("give --start-gps-time-s") and "\n" not in err
    assert not (tmp_path / "run").exists()
