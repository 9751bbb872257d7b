"""``railnav run --track-attitude --standstill --car-body`` in-process
(`railnav.commands.attitude_flags`): the rows reach innovations.csv, the flags are thin
layers over the API (the same run through `run_simulated` gives the same estimates), and
flags that cannot apply are one-line errors with exit 2."""
from __future__ import annotations

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


DOUBLE = [str(TRACKS_DIR / "double_a.csv"), str(TRACKS_DIR / "double_b.csv")]


@pytest.mark.parametrize("argv, message", [
    ([CURVY, "--track-attitude", "--filter", "unconstrained"], "only with the constrained"),
    ([CURVY, "--standstill", "--filter", "gnss-only"], "only with the constrained filter"),
    ([CURVY, "--car-body", "--imu", "imu.csv"], "--car-body"),
    ([*DOUBLE, "--track-attitude"], "one track only"),
])
def test_flags_that_cannot_apply_are_errors(tmp_path, capsys, argv, message):
    code = main(["-q", "run", *argv, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert err.startswith("error: ") and message in err and "\n" not in err
    assert not (tmp_path / "o").exists()
