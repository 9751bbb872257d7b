"""``railnav run --baro`` (railnav/jobs/baro.py, railnav/commands/run.py): the baro file read,
its bias estimated against the track height and the GNSS heights checked.

Reference: baro readings made here from the simulated truth height plus a known bias and
white noise; the estimated bias must find that bias within 4 σ, and consistent GNSS heights
must pass the 3σ test at the binomial rate.
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from railnav.cli import main
from railnav.simulation.scenarios import TRACKS_DIR

BIAS_M = 7.0          # baro bias put into the readings
NOISE_M = 1.0         # their white noise (railnav.evaluation.baro.BaroConfig.sigma_m)
DURATION_S = "120"
#: 121 GNSS heights at a 3σ test (p = 0.27 % each): more than 3 flags has probability 5e-4.
MAX_FLAGS = 3


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """A 120-s curvy trip simulated to files, and a baro file of its true height."""
    d = tmp_path_factory.mktemp("baro")
    track = TRACKS_DIR / "curvy.csv"
    assert main(["-q", "simulate", str(track), "--scenario", "curvy", "--duration-s",
                 DURATION_S, "--seed", "3", "--out", str(d / "sim")]) == 0
    truth = pd.read_csv(d / "sim" / "truth.csv")
    meta = json.loads((d / "sim" / "scenario.json").read_text())
    rng = np.random.default_rng(11)
    rows = truth.iloc[::100]
    h = rows["h_m"].to_numpy() + BIAS_M + rng.normal(0.0, NOISE_M, len(rows))
    pd.DataFrame({"time_s": rows["time_s"], "baro_h_m": h}).to_csv(d / "baro.csv", index=False)
    start = meta["scenario"]["start_gps_time_s"]
    pd.DataFrame({"gps_time_s": rows["time_s"] + start, "baro_h_m": h}).to_csv(
        d / "baro_gps.csv", index=False)
    return track, d


def _check_outputs(out):
    baro = json.loads((out / "summary.json").read_text())["baro"]
    assert abs(baro["bias_m"] - BIAS_M) < 4 * baro["sigma_bias_m"]
    assert baro["readings"] == 121 and baro["bias_flagged"] == 0
    assert baro["gnss_heights_checked"] > 100
    assert baro["gnss_heights_flagged"] <= MAX_FLAGS
    table = pd.read_csv(out / "baro.csv")
    assert list(table.columns) == ["time_s", "bias_m", "sigma_bias_m", "bias_flag"]
    gnss = pd.read_csv(out / "baro_gnss.csv")
    assert len(gnss) == baro["gnss_heights_checked"]


def test_simulated_run_with_a_baro_file(simulated, capsys):
    track, d = simulated
    out = d / "run_sim"
    assert main(["run", str(track), "--scenario", "curvy", "--duration-s", DURATION_S,
                 "--seed", "3", "--baro", str(d / "baro.csv"), "--no-plots",
                 "--out", str(out)]) == 0
    assert "baro bias" in capsys.readouterr().out
    _check_outputs(out)


def test_file_run_with_a_baro_file_in_gps_time(simulated):
    track, d = simulated
    sim, out = d / "sim", d / "run_files"
    assert main(["-q", "run", str(track), "--imu", str(sim / "imu.csv"), "--obs",
                 str(sim / "gnss_obs.rnx"), "--nav", str(sim / "gnss_nav.rnx"), "--baro",
                 str(d / "baro_gps.csv"), "--no-plots", "--out", str(out)]) == 0
    _check_outputs(out)


@pytest.mark.parametrize("text, message", [
    ("time_s,pressure_hpa\n0,1013\n", "missing column baro_h_m"),
    ("baro_h_m\n520\n", "missing column gps_time_s or time_s"),
    ("time_s,baro_h_m\n0,520\n1,nan\n", "row 2"),
    ("time_s,baro_h_m\n0,520\n0,521\n", "row 2, time_s: time does not increase"),
    ("time_s,baro_h_m\n", "no rows"),
])
def test_bad_baro_file_is_a_one_line_error(simulated, tmp_path, capsys, text, message):
    track, _ = simulated
    bad = tmp_path / "bad_baro.csv"
    bad.write_text(text)
    code = main(["run", str(track), "--duration-s", "5", "--baro", str(bad), "--out",
                 str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert "bad_baro.csv" in err and message in err
    assert not (tmp_path / "out").exists()


def test_simulate_writes_a_baro_file_that_run_reads(simulated, tmp_path):
    """``simulate --baro``: readings of the simulated truth height (truth.csv, a second
    record of the same trip) plus the bias asked for; ``run --baro`` on the folder finds it."""
    track, _ = simulated
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", str(track), "--scenario", "curvy", "--duration-s",
                 DURATION_S, "--seed", "3", "--baro", "--baro-bias-m", "5", "--out",
                 str(sim)]) == 0
    baro = pd.read_csv(sim / "baro.csv", comment="#")
    truth = pd.read_csv(sim / "truth.csv")
    assert list(baro.columns) == ["time_s", "baro_h_m"]
    np.testing.assert_allclose(baro["time_s"], np.arange(121.0))
    error = baro["baro_h_m"] - np.interp(baro["time_s"], truth["time_s"], truth["h_m"])
    # white noise 1 m over 121 readings (σ of the mean 0.09 m) + a bias walk of
    # 0.01 m/√s (σ ≤ 0.11 m at 120 s): the mean within 0.6 m of the bias is a 4σ bound.
    assert abs(error.mean() - 5.0) < 0.6
    assert 0.75 < error.std() < 1.3            # 1 m white noise: χ² 99.99 % bounds, 120 dof
    meta = json.loads((sim / "scenario.json").read_text())["baro"]
    assert meta == {"file": "baro.csv", "readings": 121, "rate_hz": 1.0, "bias_m": 5.0,
                    "sigma_m": 1.0, "bias_walk_mps": 0.01}
    out = tmp_path / "run"
    assert main(["-q", "run", str(track), "--imu", str(sim / "imu.csv"), "--obs",
                 str(sim / "gnss_obs.rnx"), "--nav", str(sim / "gnss_nav.rnx"), "--baro",
                 str(sim / "baro.csv"), "--no-plots", "--out", str(out)]) == 0
    found = json.loads((out / "summary.json").read_text())["baro"]
    assert abs(found["bias_m"] - 5.0) < 4 * found["sigma_bias_m"]


def test_simulate_baro_bias_without_baro_is_an_error(simulated, tmp_path, capsys):
    track, _ = simulated
    code = main(["simulate", str(track), "--baro-bias-m", "3", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "only with --baro" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("text", ["", "# only a comment\n", "time_s,baro_h_m\n0,520\n1,521,7\n"])
def test_baro_file_errors_are_the_sensor_files(tmp_path, text):
    """Audit finding: read_baro_csv was a copy of railnav.sensors.tables.read_timed_csv
    with its own messages (an empty file: 'not a CSV table (No columns to parse from
    file)'). Now it is that reader: an empty or malformed file reads as an odometer file
    with the same text does, in one line naming the file."""
    from railnav.errors import ConfigError
    from railnav.jobs.baro import read_baro_csv
    from railnav.sensors.odometer import read_odometer_csv
    baro, odo = tmp_path / "baro.csv", tmp_path / "odo.csv"
    baro.write_text(text)
    odo.write_text(text)
    with pytest.raises(ConfigError) as b:
        read_baro_csv(baro)
    with pytest.raises(ConfigError) as o:
        read_odometer_csv(odo)
    assert str(b.value) == str(o.value).replace("odo.csv", "baro.csv")
    assert str(b.value).startswith(f"{baro}: ") and "\n" not in str(b.value)
    assert "not a CSV table" not in str(b.value)
