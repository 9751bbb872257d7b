"""The RTS smoother of ``railnav run --smooth`` against the filter, over full scenarios.

For each case and seed: `railnav.jobs.run.run_simulated(..., smooth=True)` on the whole
scenario (1000 s, its own outages), then against the simulated truth the RMS along-track,
speed and attitude errors of the filter and of the smoother, and their NEES:

* ``nees_mean``: the mean over seeds and stored times (expected: the dof);
* ``share_in_band``: the share of stored times whose mean NEES over the seeds lies in the
  two-sided 95 % band of χ²(M·dof)/M (expected about 0.95 for a consistent estimator;
  times are correlated, so this is a description, not a test — the exact test at fixed
  times is in tests/railnav/navigation/test_issue18_smoother.py);
* runtime of the filter run and of the smoothing pass.

Cases: ``paper2017`` (its IMU errors all modelled), ``curvy`` (tactical grade: scale
factors and misalignments that the filter does not model) and ``curvy-modelled`` (the
same grade without them, to tell the smoother from the model).

Writes ``benchmarks/results/smoother.json``. Run: ``nice -n 10 python
benchmarks/bench_smoother.py [--seeds 8]``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from railnav.jobs.run import run_simulated
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
from strapdown.imu_errors import imu_grade

RESULTS = Path(__file__).resolve().parent / "results" / "smoother.json"
QUANTITIES = ("along_track_m", "speed_mps", "attitude_rad")
BAND = 0.95


def _cases() -> dict:
    modelled = replace(imu_grade("tactical"), accel_scale_factor_ppm=0.0,
                       gyro_scale_factor_ppm=0.0, accel_misalignment_rad=0.0,
                       gyro_misalignment_rad=0.0, name="tactical-modelled")
    curvy = get_scenario("curvy")
    return {"paper2017": ("paper2017.csv", get_scenario("paper2017")),
            "curvy": ("curvy.csv", curvy),
            "curvy-modelled": ("curvy.csv", curvy.with_overrides(imu_errors=modelled))}


def _case(track: str, scenario, seeds: int) -> dict:
    rows, nees = [], {"filter": [], "smoother": []}
    for seed in range(seeds):
        started = time.perf_counter()
        outcome = run_simulated(str(TRACKS_DIR / track), scenario, seed=seed, smooth=True)
        total = time.perf_counter() - started
        row = {"seed": seed, "runtime_s": total, "filter_runtime_s": outcome.result.runtime_s}
        for label, errors in (("filter", outcome.errors), ("smoother", outcome.smoothed.errors)):
            for q in QUANTITIES:
                row[f"{label}_{q}_rms"] = float(np.sqrt(np.nanmean(getattr(errors, q) ** 2)))
            nees[label].append(errors.nees)
        rows.append(row)
    dof = outcome.smoothed.errors.nees_dof
    lo, hi = chi2.ppf([(1 - BAND) / 2, (1 + BAND) / 2], seeds * dof) / seeds
    out = {"scenario": scenario.name, "imu": scenario.imu.name, "seeds": seeds, "dof": dof,
           "band": [float(lo), float(hi)], "runs": rows}
    for label, series in nees.items():
        mean_over_seeds = np.nanmean(np.array(series), axis=0)
        out[f"{label}_nees_mean"] = float(np.nanmean(series))
        out[f"{label}_share_in_band"] = float(np.mean((mean_over_seeds >= lo)
                                                      & (mean_over_seeds <= hi)))
        for q in QUANTITIES:
            values = [r[f"{label}_{q}_rms"] for r in rows]
            out[f"{label}_{q}_rms"] = float(np.sqrt(np.mean(np.square(values))))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    args = parser.parse_args()
    started = time.perf_counter()
    results = {name: _case(track, scenario, args.seeds)
               for name, (track, scenario) in _cases().items()}
    doc = {"machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                       "load_average": os.getloadavg()},
           "wall_s": time.perf_counter() - started, "cases": results}
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps(doc, indent=2) + "\n")
    for name, case in results.items():
        print(f"{name}: NEES filter {case['filter_nees_mean']:.2f} smoother "
              f"{case['smoother_nees_mean']:.2f} (dof {case['dof']}); along-track RMS "
              f"{case['filter_along_track_m_rms']:.3f} -> {case['smoother_along_track_m_rms']:.3f} m")


if __name__ == "__main__":
    main()
