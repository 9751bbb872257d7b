"""``railnav run`` in-process: files written, contract columns, one-line errors."""
from __future__ import annotations

import json

import pandas as pd
import pytest

from railnav.cli import main
from railnav.simulation.scenarios import TRACKS_DIR

PAPER = str(TRACKS_DIR / "paper2017.csv")
DOUBLE_A, DOUBLE_B = str(TRACKS_DIR / "double_a.csv"), str(TRACKS_DIR / "double_b.csv")

#: The estimates.csv contract (issue: time, position, speed, attitude, clock, 1-σ of each).
ESTIMATE_COLUMNS = ["time_s", "gps_time_s", "s_m", "lat_deg", "lon_deg", "h_m", "speed_mps",
                    "yaw_deg", "pitch_deg", "roll_deg", "clock_bias_m", "clock_drift_mps",
                    "sigma_s_m", "sigma_speed_mps", "sigma_yaw_deg", "sigma_pitch_deg",
                    "sigma_roll_deg", "sigma_clock_bias_m", "sigma_clock_drift_mps"]


def test_simulated_run_writes_every_output(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["-q", "run", PAPER, "--duration-s", "40", "--outage", "10:5",
                 "--window", "20:40", "--out", str(out)])
    assert code == 0
    for name in ("estimates.csv", "innovations.csv", "summary.json", "errors.csv",
                 "errors.png", "track.png"):
        assert (out / name).is_file(), name
    est = pd.read_csv(out / "estimates.csv")
    assert set(ESTIMATE_COLUMNS) <= set(est.columns)
    # 10 Hz outputs of steps 0..3999 at 100 Hz: the last stored step starts at 39.9 s
    assert est["time_s"].iloc[-1] == pytest.approx(39.9, abs=1e-9)
    inn = pd.read_csv(out / "innovations.csv")
    assert {"time_s", "sv", "kind", "innovation", "sigma", "accepted"} <= set(inn.columns)
    assert not ((inn["time_s"] >= 10) & (inn["time_s"] < 15)).any()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["filter"] == "constrained" and summary["outages"] == [[10.0, 5.0]]
    errors = summary["errors"]
    assert errors["window"]["start_s"] == 20.0 and errors["outages"][0]["start_s"] == 10.0
    assert errors["all"]["cross_track_m"]["max"] < 1e-6   # on the track by construction
    printed = capsys.readouterr().out
    assert "constrained filter" in printed and "outage 10+5 s" in printed


def test_files_from_simulate_run_the_same_filter(tmp_path):
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", PAPER, "--duration-s", "30", "--seed", "5",
                 "--out", str(sim)]) == 0
    out = tmp_path / "run"
    assert main(["-q", "run", PAPER, "--imu", str(sim / "imu.csv"), "--obs",
                 str(sim / "gnss_obs.rnx"), "--nav", str(sim / "gnss_nav.rnx"), "--no-plots",
                 "--out", str(out)]) == 0
    est = pd.read_csv(out / "estimates.csv")
    truth = pd.read_csv(sim / "truth.csv")
    s_true = truth.set_index("time_s")["s_m"].reindex(est["time_s"], method="nearest")
    # bound: the SPP start (σ ~ 4 m along the track) tightened by 30 epochs
    assert (est["s_m"].to_numpy() - s_true.to_numpy())[-50:].__abs__().max() < 5.0
    assert json.loads((out / "summary.json").read_text())["start_gps_time_s"] == pytest.approx(
        json.loads((sim / "scenario.json").read_text())["scenario"]["start_gps_time_s"])


@pytest.mark.parametrize("argv, message", [
    (["run", "missing.csv"], "missing.csv"),
    (["run", PAPER, "--obs", "x.rnx"], "--obs and --nav go together"),
    (["run", PAPER, PAPER], "distinct file names"),
    (["run", PAPER, "--true-track", "2"], "--true-track 2"),
    (["run", DOUBLE_A, DOUBLE_B, "--filter", "gnss-only"], "constrained filter"),
    (["run", PAPER, "--systems", "GX"], "--systems"),
])
def test_bad_input_is_one_line_exit_2(tmp_path, capsys, argv, message):
    code = main(["-q", *argv, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.startswith("error: ") and message in err and "\n" not in err
    assert not (tmp_path / "o").exists()


def test_malformed_imu_file_is_located(tmp_path, capsys):
    bad = tmp_path / "imu.csv"
    bad.write_text("time_s,ax_mps2,ay_mps2,az_mps2,wx_radps,wy_radps,wz_radps\n0,0,0,9.8,0,0,0\n"
                   "0.01,abc,0,9.8,0,0,0\n")
    code = main(["-q", "run", PAPER, "--imu", str(bad), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and str(bad) in err and "\n" not in err


def test_step_count_of_a_filter_without_continuous_measurement(tmp_path):
    """Regression (baselines review): the unconstrained filter reported its stored samples
    (10 Hz) as steps. Reference: 20 s at 100 Hz = 2000 steps."""
    out = tmp_path / "u"
    assert main(["-q", "run", PAPER, "--filter", "unconstrained", "--duration-s", "20",
                 "--no-plots", "--out", str(out)]) == 0
    assert json.loads((out / "summary.json").read_text())["steps"] == 2000


def test_several_tracks_identify_the_track(tmp_path, capsys):
    """Two candidate tracks (the double line), the trip simulated on the second: the
    contract outputs (summary track_probabilities by stem, estimates track columns)."""
    out = tmp_path / "bank"
    code = main(["-q", "run", DOUBLE_A, DOUBLE_B, "--true-track", "2", "--duration-s", "40",
                 "--out", str(out)])
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    probs = summary["track_probabilities"]
    assert set(probs) == {"double_a", "double_b"} and sum(probs.values()) == pytest.approx(1.0)
    assert summary["true_track"] == "double_b" and summary["tracks"] == ["double_a", "double_b"]
    est = pd.read_csv(out / "estimates.csv")
    assert set(ESTIMATE_COLUMNS) | {"track", "track_probability"} <= set(est.columns)
    assert set(est["track"]) <= {"double_a", "double_b"}
    assert ((est["track_probability"] >= 0.5) & (est["track_probability"] <= 1.0)).all()
    table = pd.read_csv(out / "track_probabilities.csv")
    assert list(table.columns) == ["time_s", "gps_time_s", "double_a", "double_b", "common_rows"]
    assert (out / "track_probabilities.png").is_file()
    assert "track probabilities at the end" in capsys.readouterr().out


def test_several_tracks_from_simulated_files(tmp_path):
    """railnav simulate's files on track B, filtered on both tracks from the first GNSS fix."""
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", DOUBLE_B, "--scenario", "curvy", "--duration-s", "60",
                 "--seed", "2", "--out", str(sim)]) == 0
    out = tmp_path / "run"
    assert main(["-q", "run", DOUBLE_A, DOUBLE_B, "--imu", str(sim / "imu.csv"), "--obs",
                 str(sim / "gnss_obs.rnx"), "--nav", str(sim / "gnss_nav.rnx"), "--no-plots",
                 "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    # a minute of 1 Hz GPS at the simulator's 3.9 m sigma: the evidence is ~2 nats per epoch
    assert summary["track_probabilities"]["double_b"] > 0.99
    assert "true_track" not in summary


@pytest.mark.parametrize("argv, message", [
    (["run", PAPER, "--imu", "imu.csv", "--scenario", "curvy"], "--scenario"),
    (["run", PAPER, "--imu", "imu.csv", "--speed-mps", "10", "--duration-s", "5"],
     "--speed-mps, --duration-s"),
    (["run", PAPER, "--obs", "o.rnx", "--nav", "n.rnx", "--seed", "3"], "--seed"),
    (["run", PAPER, "--start-gps-time-s", "1e9"], "--start-gps-time-s"),
    (["run", PAPER, "--filter", "gnss-only", "--imu-grade", "mems"], "--imu-grade"),
    (["run", PAPER, "--crossing-rate-per-s", "1e-3"], "several tracks"),
    (["run", PAPER, "--base", "b.rnx"], "--base"),
    (["run", PAPER, "--obs", "o.rnx", "--nav", "n.rnx", "--base-position", "41,2,80"],
     "--base-position needs --base"),
    (["run", DOUBLE_A, DOUBLE_B, "--obs", "o.rnx", "--nav", "n.rnx", "--smooth-window-s",
      "100"], "one track"),
])
def test_flags_that_cannot_apply_are_errors(tmp_path, capsys, argv, message):
    """Issue 12 (honest CLI): a flag that cannot apply to the inputs given is a one-line
    error naming it, before any file is read or written (the files named do not exist)."""
    code = main(["-q", *argv, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.startswith("error: ") and message in err and "\n" not in err
    assert not (tmp_path / "o").exists()


def test_recorded_imu_needs_the_grade_the_filter_assumes(tmp_path, capsys):
    """Issue 12: a recorded IMU file (no scenario.json beside it) runs only with
    --imu-grade: the grade is what the filter assumes, and there is no truth to take it
    from."""
    imu = tmp_path / "imu.csv"
    imu.write_text("time_s,ax_mps2,ay_mps2,az_mps2,wx_radps,wy_radps,wz_radps\n"
                   "0,0,0,9.8,0,0,0\n0.01,0,0,9.8,0,0,0\n")
    code = main(["-q", "run", PAPER, "--imu", str(imu), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and str(imu) in err and "--imu-grade" in err and "\n" not in err
    assert not (tmp_path / "o").exists()


def test_issue16_gnss_only_with_dgps_and_smoothing(tmp_path):
    """``railnav run --filter gnss-only --base --smooth-window-s`` on the real drive's shipped
    window: the pseudorange rows are code-differential, so every (epoch, satellite) row is
    one the base file tracks on the same signal (GPS L1 C/A code, read from the base file
    itself), and their innovations differ from the raw run's on the same rows (the
    corrections are metres). (Accuracy gain: none measured here, see
    benchmarks/results/dgps.json.)"""
    from pathlib import Path

    from gnss_obs.rinex_obs import read_rinex_obs

    gnss = Path(__file__).resolve().parents[3] / "data" / "gnss"   # this checkout's data
    track = str(gnss.parent / "tracks" / "barcelona_drive.csv")
    common = ["-q", "run", track, "--obs", str(gnss / "rover_obs_1240.rnx"), "--nav",
              str(gnss / "broadcast_nav.rnx"), "--filter", "gnss-only", "--systems", "G",
              "--no-plots"]
    base_table = read_rinex_obs(gnss / "base_obs_1240.rnx").table
    code = base_table[(base_table["signal"] == "1C") & base_table["pseudorange_m"].notna()]
    at_base = set(zip(code["gps_time_s"].round(3), code["sv"]))
    rows = {}
    for name, extra in (("raw", []), ("dgps", ["--base", str(gnss / "base_obs_1240.rnx"),
                                               "--smooth-window-s", "100"])):
        assert main([*common, *extra, "--out", str(tmp_path / name)]) == 0
        inn = pd.read_csv(tmp_path / name / "innovations.csv")
        inn = inn[inn["kind"] == "pseudorange"]
        rows[name] = inn.assign(t=inn["gps_time_s"].round(3)).set_index(["t", "sv"])
    assert len(rows["dgps"]) and set(rows["dgps"].index) <= at_base
    both = rows["dgps"].index.intersection(rows["raw"].index)
    change = (rows["dgps"].loc[both, "innovation"] - rows["raw"].loc[both, "innovation"]).abs()
    assert len(both) > 100 and change.median() > 0.1
