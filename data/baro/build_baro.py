"""Rebuild the example baro file of this folder (run from the repository root).

    python data/baro/build_baro.py

``curvy_baro.csv``: what a barometric altimeter would read on the ``curvy`` scenario on
``data/tracks/curvy.csv`` (the trip ``railnav run data/tracks/curvy.csv`` simulates): the true
height of that trip once a second (`railnav.simulation.truth.simulate_truth`, the scenario's
speed profile and start) with the baro errors of `railnav.evaluation.baro.simulate_baro` — a
constant bias of `BIAS_M` (the 2021 paper's ΔH = 7 m), the default random walk of the bias and
1σ white noise of `railnav.evaluation.baro.BaroConfig` — drawn with seed `SEED`.
See README.md here.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from railnav.evaluation.baro import BaroConfig, simulate_baro
from railnav.simulation.scenarios import get_scenario
from railnav.simulation.truth import simulate_truth
from trackmodel.files import atomic_write_text
from trackmodel.io import read_track

HERE = Path(__file__).resolve().parent
TRACK = HERE.parent / "tracks" / "curvy.csv"
SCENARIO = "curvy"
#: Baro bias at the first reading, m (Ivanov et al. 2021: ΔH = 7 m).
BIAS_M = 7.0
#: Readings per second.
RATE_HZ = 1.0
SEED = 2021


def curvy_baro() -> pd.DataFrame:
    """``time_s, baro_h_m`` of the curvy scenario (module docstring)."""
    scenario = get_scenario(SCENARIO)
    truth = simulate_truth(read_track(TRACK), scenario.profile, duration_s=scenario.duration_s,
                           rate_hz=RATE_HZ, start_s=scenario.start_s)
    h = simulate_baro(truth.time_s, truth.h, bias_m=BIAS_M, config=BaroConfig(),
                      rng=np.random.default_rng(SEED))
    return pd.DataFrame({"time_s": truth.time_s, "baro_h_m": h})


def main() -> None:
    frame = curvy_baro()
    config = BaroConfig()
    head = (f"# simulated by data/baro/build_baro.py: true height of the {SCENARIO} scenario on "
            f"data/tracks/curvy.csv at {RATE_HZ:g} Hz + bias {BIAS_M:g} m + bias walk "
            f"{config.bias_walk_mps:g} m/sqrt(s) + white noise {config.sigma_m:g} m, seed {SEED}\n")
    atomic_write_text(HERE / "curvy_baro.csv",
                      head + frame.to_csv(index=False, float_format="%.3f"))
    print(f"curvy_baro.csv: {len(frame)} readings, {frame.time_s.iloc[-1]:.0f} s")


if __name__ == "__main__":
    main()
