"""``railnav run --track-attitude --standstill --suspension-noise --car-body`` in-process
(`railnav.commands.attitude_flags`): the rows reach innovations.csv, the flags are thin
layers over the API (the same run through `run_simulated` gives the same estimates), and
flags that cannot apply are one-line errors with exit 2."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from railnav.cli import main
from railnav.filters.attitude_config import TrackAttitudeConfig
from railnav.filters.standstill import StandstillConfig
from railnav.jobs.run import run_simulated
from railnav.simulation.car_body_config import CarBodyMotion
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from railnav.simulation.trip import navigator_config_for

CURVY = str(TRACKS_DIR / "curvy.csv")


def test_flags_run_the_api(tmp_path):
    out = tmp_path / "run"
    argv = ["-q", "run", CURVY, "--imu-grade", "mems", "--duration-s", "40", "--outage",
            "20:15", "--car-body", "--track-attitude", "--standstill", "--seed", "3",
            "--no-plots", "--out", str(out)]
    assert main(argv) == 0
    inn = pd.read_csv(out / "innovations.csv")
    kinds = set(inn["kind"])
    assert {"att_yaw", "att_pitch", "att_roll", "zero_speed"} <= kinds
    # the start dwell (0-10 s), and the window that ends 1 s into the departure, when the
    # raised-cosine profile has reached 25 (1/60 - sin(2π/60)/2π) = 7e-4 m/s
    assert (inn.loc[inn["kind"] == "zero_speed", "time_s"] < 11.0).all()
    scenario = replace(get_scenario("curvy").with_overrides(
        duration_s=40.0, imu_errors="mems", outages=[(20.0, 15.0)]), car_body=CarBodyMotion())
    config = navigator_config_for(scenario, track_attitude=TrackAttitudeConfig(),
                                  standstill=StandstillConfig())
    api = run_simulated(CURVY, scenario, config=config, seed=3).result.estimates
    cli = pd.read_csv(out / "estimates.csv")
    np.testing.assert_allclose(cli["s_m"], api["s_m"], rtol=0, atol=1e-6)


def test_suspension_noise_flag_runs_the_api(tmp_path):
    """``--suspension-noise`` on a simulated trip without a car body is
    ``NavigatorConfig.suspension_noise``: the same estimates as the API with it, and not
    those without it (the flag acts)."""
    out = tmp_path / "run"
    assert main(["-q", "run", CURVY, "--imu-grade", "tactical", "--duration-s", "40",
                 "--outage", "20:15", "--suspension-noise", "--seed", "3", "--no-plots",
                 "--out", str(out)]) == 0
    scenario = get_scenario("curvy").with_overrides(duration_s=40.0, imu_errors="tactical",
                                                    outages=[(20.0, 15.0)])
    cli = pd.read_csv(out / "estimates.csv")
    api = {noise: run_simulated(CURVY, scenario, seed=3, config=navigator_config_for(
        scenario, suspension_noise=noise)).result.estimates for noise in (True, False)}
    np.testing.assert_allclose(cli["s_m"], api[True]["s_m"], rtol=0, atol=1e-6)
    assert not np.allclose(cli["sigma_s_m"], api[False]["sigma_s_m"], rtol=1e-6, atol=0)


DOUBLE = [str(TRACKS_DIR / "double_a.csv"), str(TRACKS_DIR / "double_b.csv")]


@pytest.mark.parametrize("argv, message", [
    ([CURVY, "--track-attitude", "--filter", "unconstrained"], "only with the constrained"),
    ([CURVY, "--standstill", "--filter", "gnss-only"], "only with the constrained filter"),
    ([CURVY, "--suspension-noise", "--filter", "gnss-only"], "--suspension-noise: only with"),
    ([*DOUBLE, "--suspension-noise"], "one track only"),
    ([CURVY, "--car-body", "--imu", "imu.csv"], "--car-body"),
    ([*DOUBLE, "--track-attitude"], "one track only"),
    ([*DOUBLE, "--recover"], "--recover: one track only"),
    ([*DOUBLE, "--no-recover"], "--no-recover: one track only"),
    ([CURVY, "--recover", "--no-recover"], "--recover, --no-recover: give one"),
    ([CURVY, "--spawn"], "--spawn: only with --network"),
])
def test_flags_that_cannot_apply_are_errors(tmp_path, capsys, argv, message):
    code = main(["-q", "run", *argv, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.startswith("error: ") and message in err and "\n" not in err
    assert not (tmp_path / "o").exists()


def test_recover_restarts_a_lost_filter(tmp_path, capsys):
    """Recovery is the monitor's default (`MonitorConfig.recover`): a MEMS IMU that the
    filter is told is navigation grade diverges with ``--no-recover`` (the truth from the
    simulation: along-track RMS beyond 1 km, the run ends lost, no restart); by default,
    and with ``--recover`` (the same run), the monitor restarts it from the epoch's fix and
    the error against the same truth falls by more than 10x."""
    sim = tmp_path / "sim"
    assert main(["-q", "simulate", str(TRACKS_DIR / "paper2017.csv"), "--imu-grade", "mems",
                 "--duration-s", "60", "--out", str(sim)]) == 0
    files = ["--imu", str(sim / "imu.csv"), "--obs", str(sim / "gnss_obs.rnx"),
             "--nav", str(sim / "gnss_nav.rnx"), "--imu-grade", "navigation", "--no-plots"]
    rms, recoveries, estimates = {}, {}, {}
    for name, flag in (("off", ["--no-recover"]), ("default", []), ("on", ["--recover"])):
        out = tmp_path / name
        assert main(["run", str(TRACKS_DIR / "paper2017.csv"), *files, *flag,
                     "--out", str(out)]) == 0
        text = capsys.readouterr().out
        summary = json.loads((out / "summary.json").read_text())
        rms[name] = summary["errors"]["all"]["along_track_m"]["rms"]
        recoveries[name] = summary["statistics"]["monitor"]["recoveries"]
        estimates[name] = (out / "estimates.csv").read_bytes()
        assert ("LOST at the end" in text) is (name == "off")
    assert rms["off"] > 1000.0 and recoveries["off"] == 0
    assert recoveries["default"] >= 1 and rms["default"] < 0.1 * rms["off"]
    assert estimates["on"] == estimates["default"]
