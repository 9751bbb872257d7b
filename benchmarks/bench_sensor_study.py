"""Which sensor buys what through a GNSS outage: the multi-sensor trip, sensors × seeds.

Usage::

    python benchmarks/bench_sensor_study.py [--seeds N] [--out FILE] [--figure PNG]

The trip is the acceptance trip of issue 17 (`tests/railnav/commands/test_cli_real_inputs`):
``railnav simulate`` of ``curvy`` for 300 s with a 120-s outage from 150 s, a jittered IMU
log (±0.2 ms, 5 dropouts of 5 samples), NMEA fixes, an odometer at 5 Hz (scale error drawn
σ 0.02) with a traction slip (100 s, 5 s, +30 %) and a braking slide inside the outage
(200 s, 4 s, −40 %), balises every 500 m. Each seed's files are run (`railnav.run_files`,
the truth found beside them) with these sensor sets:

* ``fixes+imu`` (constrained), ``+odometer``, ``+balises``, ``+odometer+balises``;
* ``fixes+odometer+balises`` without the IMU (GNSS-only filter).

Per run: the largest along-track error inside the outage and at its end, its σ there, the
run's along-track RMS, the NEES mean, the odometer episodes flagged, the runtime. Writes
``benchmarks/results/sensor_study.json`` and, with ``--figure``, the along-track error of
seed 1's runs (the acceptance test's seed).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from railnav.cli import main as railnav_main
from railnav.jobs.run import run_files
from trackmodel.files import atomic_write_text
from trackmodel.io import read_track

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results" / "sensor_study.json"
TRACK = REPO / "data" / "tracks" / "curvy.csv"
OUTAGE = (150.0, 120.0)
SLIPS = ("100:5:0.3", "200:4:-0.4")
SETS = {"fixes+imu": ("constrained", False, False),
        "fixes+imu+odometer": ("constrained", True, False),
        "fixes+imu+balises": ("constrained", False, True),
        "fixes+imu+odometer+balises": ("constrained", True, True),
        "fixes+odometer+balises": ("gnss-only", True, True)}


def simulate(folder: Path, seed: int) -> None:
    args = ["-q", "simulate", str(TRACK), "--scenario", "curvy", "--duration-s", "300",
            "--outage", f"{OUTAGE[0]:g}:{OUTAGE[1]:g}", "--fixes-format", "nmea",
            "--no-gnss", "--odometer", "--odometer-rate-hz", "5", "--balises",
            "--balise-spacing-m", "500", "--imu-jitter-s", "2e-4", "--imu-dropouts", "5",
            "--seed", str(seed), "--out", str(folder)]
    for slip in SLIPS:
        args += ["--slip", slip]
    assert railnav_main(args) == 0


def run_set(folder: Path, track, name: str):
    filter_, odometer, balises = SETS[name]
    t0 = time.perf_counter()
    outcome = run_files(track, imu_path=folder / "imu.csv" if filter_ == "constrained" else None,
                        fixes_path=folder / "fixes.nmea", filter=filter_,
                        odometer_path=folder / "odometer.csv" if odometer else None,
                        balises_path=folder / "balises.csv" if balises else None)
    return outcome, time.perf_counter() - t0


def figures(outcome) -> dict:
    e, est = outcome.errors, outcome.result.estimates
    t = e.time_s
    inside = (t >= OUTAGE[0]) & (t <= sum(OUTAGE))
    end = int(np.flatnonzero(inside)[-1])
    along = np.abs(e.along_track_m)
    stats = outcome.summary["statistics"]
    odo = stats.get("odometer") or {}
    return {"outage_max_along_m": float(along[inside].max()),
            "outage_end_along_m": float(e.along_track_m[end]),
            "outage_end_sigma_s_m": float(est["sigma_s_m"].to_numpy()[end]),
            "rms_along_m": float(np.sqrt(np.nanmean(e.along_track_m ** 2))),
            "nees_mean": float(np.nanmean(e.nees)), "nees_dof": int(e.nees_dof),
            "slip_episodes": [[ep["kind"], ep["start_s"], ep["end_s"]]
                              for ep in odo.get("slip_episodes", [])]}


def plot(runs: dict, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for name, outcome in runs.items():
        e, est = outcome.errors, outcome.result.estimates
        line, = ax.plot(e.time_s, e.along_track_m, lw=1.2, label=name)
        ax.fill_between(e.time_s, -3 * est["sigma_s_m"], 3 * est["sigma_s_m"],
                        color=line.get_color(), alpha=0.08)
    ax.axvspan(OUTAGE[0], sum(OUTAGE), color="grey", alpha=0.15, label="GNSS outage")
    for slip in SLIPS:
        start, duration, _ = (float(v) for v in slip.split(":"))
        ax.axvspan(start, start + duration, color="red", alpha=0.25)
    ax.set_xlabel("time from the trip start (s)")
    ax.set_ylabel("along-track error (m); bands ±3σ")
    worst = max(float(np.nanmax(np.abs(o.errors.along_track_m))) for o in runs.values())
    ax.set_ylim(-1.1 * worst, 1.1 * worst)
    ax.set_title("curvy, 300 s, seed 1: slip (100 s) and slide (200 s) shaded red")
    ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--figure", type=Path, default=None)
    args = parser.parse_args(argv)
    track = read_track(TRACK)
    table = {name: [] for name in SETS}
    out = {"outage": list(OUTAGE), "slips": list(SLIPS), "seeds": args.seeds,
           "load_average_1min": os.getloadavg()[0]}
    for seed in range(args.seeds):
        with tempfile.TemporaryDirectory() as tmp:
            simulate(Path(tmp), seed)
            keep = {}
            for name in SETS:
                outcome, seconds = run_set(Path(tmp), track, name)
                table[name].append({"seed": seed, "runtime_s": seconds, **figures(outcome)})
                keep[name] = outcome
                print(f"seed {seed} {name:28s} outage max {table[name][-1]['outage_max_along_m']:.3f}"
                      f" m, end {table[name][-1]['outage_end_along_m']:+.3f} m, "
                      f"{seconds:.1f} s", flush=True)
            if seed == 1 and args.figure is not None:
                plot(keep, args.figure)
    out["runs"] = table
    out["median_outage_max_along_m"] = {n: float(np.median([r["outage_max_along_m"] for r in v]))
                                        for n, v in table.items()}
    out.update(python=platform.python_version(), machine=platform.machine(),
               load_average_1min_end=os.getloadavg()[0])
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
