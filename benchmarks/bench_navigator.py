"""Speed of the track-constrained navigator on the 2017 paper's scenario (issue: ≥ 1000×
real time for the filter alone, ≥ 200× end to end).

Measured in one process on one simulated trip (1000 s: 100 000 IMU steps, ~900 GNSS
epochs of 8–12 satellites × pseudorange + Doppler, two 50-s outages):

* ``filter``: `railnav.navigate` on the simulated sensor data — the whole filter with its
  model evaluation, track re-linearization and GNSS epoch preparation (compiled code
  built and cached before timing; the first call is reported apart);
* ``numpy_loop``: the plain NumPy EKF of the same dimensions (the engine's reference
  step of a 7-state model with a 2-D correlated pseudo-measurement per step and 1000
  updates of 20 rows, `benchmarks/bench_ekf_engine.py`), timed on a fraction and scaled;
* ``end_to_end``: ``railnav run data/tracks/paper2017.csv --scenario paper2017`` as a
  subprocess (interpreter start, simulation, filtering, CSV/JSON/PNG outputs).

Writes ``benchmarks/results/navigator.json``. Run: ``python benchmarks/bench_navigator.py``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_ekf_engine  # noqa: E402  (the NumPy reference loop lives there)

from railnav.navigation.initialization import initial_from_truth  # noqa: E402
from railnav.filters.protocol import make_filter
from railnav.navigation.navigator import navigate  # noqa: E402
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario  # noqa: E402
from railnav.simulation.trip import navigator_config_for, simulate_trip  # noqa: E402
from trackmodel.io import read_track  # noqa: E402

RESULTS = HERE / "results" / "navigator.json"
TRIP_S = 1000.0


def _trip_and_start(seed: int):
    scenario = get_scenario("paper2017")
    trip = simulate_trip(scenario, track=read_track(TRACKS_DIR / "paper2017.csv"), seed=seed)
    config = navigator_config_for(scenario)
    filt = make_filter(trip.track, config, None)
    x_true, _ = filt.truth_states(trip.truth, *trip.clock_truth(trip.truth.time_s))
    P0 = filt.initial_covariance(sigma_s_m=5.0, sigma_v_mps=0.1)
    initial = initial_from_truth(x_true[0], P0, time_s=0.0, rng=np.random.default_rng(seed))
    return trip, config, initial


def _time_filter(repeats: int) -> dict:
    trip, config, initial = _trip_and_start(seed=1)
    data = trip.sensor_data()
    t0 = time.perf_counter()
    navigate(trip.track, data, config, initial=initial)
    first = time.perf_counter() - t0
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = navigate(trip.track, data, config, initial=initial)
        times.append(time.perf_counter() - t0)
    best = min(times)
    return {"first_run_s": first, "run_s": times, "best_s": best,
            "median_s": statistics.median(times), "real_time_factor": TRIP_S / best,
            "imu_steps": result.n_steps, "gnss_epochs": result.n_epochs,
            "gnss_rows": int(len(result.innovations))}


def _time_numpy(fraction: float) -> dict:
    samples, epochs = bench_ekf_engine._scenario(np.random.default_rng(7))
    out = bench_ekf_engine._time_numpy(samples, epochs, fraction)
    return out


def _time_end_to_end(repeats: int) -> dict:
    env = dict(os.environ, MPLBACKEND="Agg")
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(repeats):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "railnav.cli", "-q", "run",
                            str(TRACKS_DIR / "paper2017.csv"), "--scenario", "paper2017",
                            "--out", str(Path(tmp) / f"run{k}")], check=True, env=env,
                           stdout=subprocess.DEVNULL)
            times.append(time.perf_counter() - t0)
    best = min(times)
    return {"run_s": times, "best_s": best, "real_time_factor": TRIP_S / best}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--numpy-fraction", type=float, default=0.05,
                        help="fraction of the run timed for the NumPy loop (scaled up)")
    args = parser.parse_args(argv)
    filt = _time_filter(args.repeats)
    numpy_loop = _time_numpy(args.numpy_fraction)
    e2e = _time_end_to_end(args.repeats)
    numpy_s = numpy_loop["run_s"]   # scaled from the timed fraction
    doc = {
        "scenario": "paper2017 (1000 s, 100 Hz IMU, 1 Hz GNSS, two 50-s outages)",
        "machine": {"python": platform.python_version(), "processor": platform.processor(),
                    "cpus": os.cpu_count(), "load_average": list(os.getloadavg())},
        "filter": filt, "numpy_loop": numpy_loop, "end_to_end": e2e,
        "ratios": {"numpy_loop_over_filter": numpy_s / filt["best_s"] if numpy_s else None},
        "targets": {"filter_real_time_factor": 1000.0, "end_to_end_real_time_factor": 200.0},
        "meets": {"filter": filt["real_time_factor"] >= 1000.0,
                  "end_to_end": e2e["real_time_factor"] >= 200.0},
    }
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps(doc, indent=2) + "\n")
    print(json.dumps({k: doc[k] for k in ("ratios", "meets")}, indent=2))
    print(f"filter {filt['best_s']:.3f} s ({filt['real_time_factor']:.0f}x real time), "
          f"end to end {e2e['best_s']:.2f} s ({e2e['real_time_factor']:.0f}x)")
    return doc


if __name__ == "__main__":
    main()
