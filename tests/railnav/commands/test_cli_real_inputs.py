"""``railnav simulate --odometer --balises --imu-jitter-s`` and ``railnav run --odometer
--balises --imu-spec --lever-arm`` in-process (issue 17): the acceptance trip, recorded
IMU logs through a spec, and one-line errors for flags that cannot apply or bad data.

The acceptance trip: ``curvy`` for 300 s, a jittered IMU log with dropouts, NMEA fixes, an
odometer with a traction slip before and a braking slide inside a 120-s outage, balises
every 500 m. Reference: its own truth.csv (`railnav run --truth`, found beside
scenario.json), against the same files run without odometer and balises.
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from railnav.cli import main
from railnav.simulation.scenarios import TRACKS_DIR

CURVY = str(TRACKS_DIR / "curvy.csv")
OUTAGE = (150.0, 120.0)
SLIPS = ((100.0, 5.0, 0.3), (200.0, 4.0, -0.4))


@pytest.fixture(scope="module")
def trip(tmp_path_factory):
    sim = tmp_path_factory.mktemp("sim")
    slips = [a for s in SLIPS for a in ("--slip", ":".join(f"{v:g}" for v in s))]
    assert main(["-q", "simulate", CURVY, "--scenario", "curvy", "--duration-s", "300",
                 "--outage", f"{OUTAGE[0]:g}:{OUTAGE[1]:g}", "--fixes-format", "nmea",
                 "--no-gnss", "--odometer", "--odometer-rate-hz", "5", *slips, "--balises",
                 "--balise-spacing-m", "500", "--imu-jitter-s", "2e-4", "--imu-dropouts",
                 "5", "--seed", "1", "--out", str(sim)]) == 0
    return sim


def _run(sim, out, *extra) -> tuple[dict, pd.DataFrame]:
    assert main(["-q", "run", CURVY, "--imu", str(sim / "imu.csv"), "--fixes",
                 str(sim / "fixes.nmea"), *extra, "--no-plots", "--out", str(out)]) == 0
    return (json.loads((out / "summary.json").read_text()),
            pd.read_csv(out / "errors.csv"))


def test_simulated_files_and_their_record(trip):
    meta = json.loads((trip / "scenario.json").read_text())
    assert meta["odometer"]["slips"] == [list(s) for s in SLIPS]
    assert meta["imu_log"]["dropouts"] == 5
    odo = pd.read_csv(trip / "odometer.csv")
    assert list(odo.columns) == ["time_s", "speed_mps"] and len(odo) == 1501
    imu = pd.read_csv(trip / "imu.csv")
    steps = np.diff(imu["time_s"].to_numpy())
    assert steps.min() > 0.0095 and np.ptp(steps[steps < 0.015]) > 3e-4      # jittered
    assert len(imu) == 30001 - 25                                             # 5 × 5 dropped
    bal = pd.read_csv(trip / "balises.csv")
    assert len(bal) == meta["balises"]["passages"] > 5


def test_odometer_and_balises_beat_the_outage_and_flag_the_slips(trip, tmp_path):
    full, err_full = _run(trip, tmp_path / "full", "--odometer", str(trip / "odometer.csv"),
                          "--balises", str(trip / "balises.csv"))
    base, err_base = _run(trip, tmp_path / "base")
    assert full["reference"]["source"] == "truth" and full["outages"] == [list(OUTAGE)]
    inside = lambda e: e[(e["time_s"] >= OUTAGE[0]) & (e["time_s"] <= sum(OUTAGE))]  # noqa
    worst_full = np.abs(inside(err_full)["along_track_m"]).max()
    worst_base = np.abs(inside(err_base)["along_track_m"]).max()
    assert worst_full < 0.5 * worst_base, (worst_full, worst_base)
    episodes = full["statistics"]["odometer"]["slip_episodes"]
    assert [e["kind"] for e in episodes] == ["slip", "slide"]
    for ep, (start, duration, _) in zip(episodes, SLIPS):
        # flagged from the first reading that fails until the channel is re-admitted:
        # the 0.5-s ramp down, then ten consistent readings at 5 Hz
        assert start - 0.5 <= ep["start_s"] <= start + 1.5
        assert start + duration <= ep["end_s"] <= start + duration + 0.5 + 2.0 + 0.4
    assert full["imu"]["dropped_samples"] == 25 and len(full["imu"]["gaps"]) == 5
    assert full["statistics"]["balises"]["rows_rejected"] == 0


SPEC = """[columns]
time = "t_ms"
accel = ["ax_g", "ay_g", "az_g"]
gyro = ["gx_dps", "gy_dps", "gz_dps"]
[units]
time = "ms"
accel = "g"
gyro = "deg/s"
[mounting]
axes = ["x", "-y", "-z"]
[noise]
grade = "tactical"
"""


def _sensor_log(trip, path) -> None:
    """The trip's imu.csv as an FRD logger writes it: ms, g, deg/s."""
    imu = pd.read_csv(trip / "imu.csv")
    g = 9.80665
    pd.DataFrame({"t_ms": imu["time_s"] * 1e3, "ax_g": imu["ax_mps2"] / g,
                  "ay_g": -imu["ay_mps2"] / g, "az_g": -imu["az_mps2"] / g,
                  "gx_dps": np.degrees(imu["wx_radps"]), "gy_dps": -np.degrees(imu["wy_radps"]),
                  "gz_dps": -np.degrees(imu["wz_radps"])}).to_csv(path, index=False,
                                                                  float_format="%.17g")


def test_imu_spec_reads_a_logger_file_like_imu_csv(trip, tmp_path):
    _sensor_log(trip, tmp_path / "log.csv")
    (tmp_path / "spec.toml").write_text(SPEC)
    spec_run, err_spec = _run_imu(trip, tmp_path / "a", tmp_path / "log.csv",
                                  "--imu-spec", str(tmp_path / "spec.toml"))
    plain, err_plain = _run(trip, tmp_path / "b")
    assert spec_run["imu"]["spec"].endswith("spec.toml")
    np.testing.assert_allclose(err_spec["along_track_m"], err_plain["along_track_m"],
                               atol=1e-6)


def _run_imu(trip, out, imu, *extra):
    assert main(["-q", "run", CURVY, "--imu", str(imu), "--fixes", str(trip / "fixes.nmea"),
                 "--truth", str(trip / "truth.csv"), *extra, "--no-plots",
                 "--out", str(out)]) == 0
    return json.loads((out / "summary.json").read_text()), pd.read_csv(out / "errors.csv")


@pytest.mark.parametrize("extra, message", [
    (["--odometer", "o.csv"], "go with sensor files"),
    (["--wheel-circumference-m", "3", "--fixes", "f.nmea"], "only with --odometer"),
    (["--imu-spec", "s.toml", "--fixes", "f.nmea"], "--imu-spec: only with --imu"),
    (["--balises", "b.csv", "--imu", "i.csv", "--filter", "unconstrained", "--obs", "o",
      "--nav", "n"], "the unconstrained filter takes no odometer, balises or lever arms"),
])
def test_bad_flags_are_one_line_exit_2(tmp_path, capsys, extra, message):
    code = main(["-q", "run", CURVY, *extra, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith("error: ") and message in err and "\n" not in err, err


def test_bad_lever_arm_is_an_argument_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as info:
        main(["-q", "run", CURVY, "--lever-arm", "1,2", "--fixes", "f.nmea"])
    assert info.value.code == 2 and "is not F,L,U" in capsys.readouterr().err


@pytest.mark.parametrize("edit, message", [
    (lambda f: f.assign(ax_mps2=f["ax_mps2"] / 9.80665, ay_mps2=f["ay_mps2"] / 9.80665,
                        az_mps2=f["az_mps2"] / 9.80665), "seem to be in g"),
    (lambda f: f.assign(wz_radps=np.degrees(f["wz_radps"])), "seem to be in deg/s"),
])
def test_unit_mistakes_in_a_run_are_one_line_exit_2(trip, tmp_path, capsys, edit, message):
    imu = edit(pd.read_csv(trip / "imu.csv"))
    imu.to_csv(tmp_path / "imu.csv", index=False)
    code = main(["-q", "run", CURVY, "--imu", str(tmp_path / "imu.csv"), "--fixes",
                 str(trip / "fixes.nmea"), "--imu-grade", "tactical", "--out",
                 str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and message in err and "\n" not in err and str(tmp_path) in err
    assert not (tmp_path / "o").exists()


def test_odometer_missing_the_run_is_an_error(trip, tmp_path, capsys):
    (tmp_path / "odo.csv").write_text("time_s,speed_mps\n5000,1\n5001,1\n")
    code = main(["-q", "run", CURVY, "--imu", str(trip / "imu.csv"), "--fixes",
                 str(trip / "fixes.nmea"), "--odometer", str(tmp_path / "odo.csv"),
                 "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "odometer times [5000.0, 5001.0] s miss the run" in err


def test_report_counts_each_kind_of_epoch(trip, tmp_path, capsys):
    """Audit finding: with fixes, an odometer and balises the report said '<all measurement
    epochs> GNSS epochs'. Now each kind's epochs: the GNSS ones are the fixes (GGA
    sentences of fixes.nmea), the balise ones the passages of balises.csv."""
    out = tmp_path / "o"
    assert main(["run", CURVY, "--fixes", str(trip / "fixes.nmea"), "--odometer",
                 str(trip / "odometer.csv"), "--balises", str(trip / "balises.csv"),
                 "--no-plots", "--out", str(out)]) == 0
    head = capsys.readouterr().out.splitlines()[0]
    n_fixes = sum(line[3:6] == "GGA" for line in (trip / "fixes.nmea").read_text().split())
    n_balises = len(pd.read_csv(trip / "balises.csv"))
    stats = json.loads((out / "summary.json").read_text())["statistics"]
    assert stats["fix_epochs"] == n_fixes
    assert (f"{stats['gnss_epochs']} measurement epochs ({n_fixes} GNSS, "
            f"{stats['odometer']['rows']} odometer, {n_balises} balise)") in head
    assert "GNSS epochs" not in head


def test_a_logger_file_without_a_spec_names_both_column_sets(trip, tmp_path, capsys):
    """Audit finding: an IMU log with its own column names, given without --imu-spec, got
    'missing columns X (imu.csv has X)': the expected names twice, the file's not at all,
    and no word of --imu-spec. Now the missing ones, the file's, and the flag."""
    from strapdown.imu import IMU_COLUMNS
    theirs = ["t", "acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]
    imu = pd.read_csv(trip / "imu.csv")
    imu.columns = theirs
    imu.to_csv(tmp_path / "logger.csv", index=False)
    code = main(["run", CURVY, "--imu", str(tmp_path / "logger.csv"), "--fixes",
                 str(trip / "fixes.nmea"), "--imu-grade", "tactical", "--out",
                 str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    header = (tmp_path / "logger.csv").read_text().splitlines()[0]
    assert code == 2 and "\n" not in err and not (tmp_path / "o").exists()
    assert err.startswith(f"error: {tmp_path / 'logger.csv'}: missing columns "
                          f"{', '.join(IMU_COLUMNS)} of the imu.csv layout; the file has "
                          f"{header.replace(',', ', ')}; ")
    assert err.count(IMU_COLUMNS[1]) == 1 and "--imu-spec" in err
