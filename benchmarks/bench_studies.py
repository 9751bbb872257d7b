"""Throughput of Monte Carlo studies and memory of the streaming mode (issue: studies).

Measured on this machine, in one invocation:

* ``runs_per_hour``: a study of the 2017 paper's scenario (1000 s at 100 Hz, 1 Hz GNSS,
  two 50-s outages, the paper's IMU, the constrained filter; ``--runs`` replicate seeds)
  run by `railnav.studies.study.run_study` with 1 worker (in this process), a local process
  pool of 2 workers, and a Dask `LocalCluster` of 2 worker processes. Wall time includes
  the pool or cluster start-up and writing the parts and ``results.parquet`` (no plots);
  ``scaling_2_over_1`` is the ratio of the 2-worker and 1-worker rates.
* ``streaming``: `railnav.navigation.streaming.stream_simulated` of a 10-hour trip at 100 Hz
  (3.6 M IMU steps) on a 740-km synthetic line (`long_line`: 18-km straights joined by
  10° curves of 2 km radius with 150-m clothoids, WGS-84), tactical IMU, GPS + Galileo
  (the shipped file has 16 GPS satellites: alone they drop to 1-3 in view late in the
  trip; its records are re-issued over the 10 h, `gnss_obs.ephemeris_reissue`), a 120-s
  outage every hour, estimates and errors written at 1 Hz. Each run is a fresh
  subprocess whose own peak resident memory (`peak_rss_mb`: ``VmHWM``) is reported; a
  1-hour trip is run the same way so that the two peaks show whether memory grows with
  the trip.

Writes ``benchmarks/results/studies.json``. Run: ``python benchmarks/bench_studies.py``
(about 5 minutes; ``--quick`` for a smoke run).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "studies.json"
#: The issue's goal for the 10-hour streamed run.
STREAMING_RSS_TARGET_MB = 1024.0
HOUR_S = 3600.0


def long_line():
    """The 740-km synthetic line of the streaming runs (module docstring)."""
    from trackmodel.earth import WGS84
    from trackmodel.sections import Section
    from trackmodel.track import Origin, Track
    radius_m, turn_rad, transition_m = 2000.0, 0.1745, 150.0
    sections = []
    for k in range(40):
        kappa = (1.0 if k % 2 == 0 else -1.0) / radius_m
        sections.append(Section(18_000.0, 100.0, 0.0) if k == 0 else Section(18_000.0, None, None))
        sections += [Section(transition_m, None, None, 0.0, kappa),
                     Section(radius_m * turn_rad - transition_m, None, None, kappa),
                     Section(transition_m, None, None, kappa, 0.0)]
    return Track(sections, Origin(50.45, 30.52, 100.0), WGS84)


def _study_config(runs: int):
    from railnav.simulation.scenarios import get_scenario
    from railnav.studies.config import StudyConfig
    paper = get_scenario("paper2017")
    return StudyConfig(
        name="bench-paper2017", seed=1, replicates=runs, scenario="paper2017",
        duration_s=paper.duration_s, systems="G", mode="memory", chunk_runs=4,
        common_random_numbers=True, segment_s=300.0, tracks=("paper2017.csv",),
        imu_grades=("paper2017",), speeds_mps=(paper.profile.max_speed_mps,),
        filters=("constrained",), sigma_pseudorange_m=(paper.sigma_pseudorange_m,),
        sigma_range_rate_mps=(paper.sigma_range_rate_mps,), outage_sets=(paper.outages,))


def _time_study(runs: int, **engine) -> dict:
    from railnav.studies.study import run_study
    config = _study_config(runs)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = run_study(config, tmp, plots=False, **engine)
        wall = time.perf_counter() - t0
    table = result.table
    assert (table["status"] == "ok").all(), table["error"].unique()
    return {"runs": runs, "wall_s": wall, "runs_per_hour": runs / wall * HOUR_S,
            "mean_run_runtime_s": float(table["runtime_s"].mean())}


def _throughput(runs: int) -> dict:
    from railnav.studies.runs import expand_grid, run_one
    run_one(expand_grid(_study_config(1))[0])      # compiled code built and cached
    out = {"one_worker": _time_study(runs, workers=1),
           "pool_two_workers": _time_study(runs, workers=2),
           "dask_two_workers": _time_study(runs, scheduler="local", workers=2)}
    one = out["one_worker"]["runs_per_hour"]
    out["scaling_2_over_1"] = out["pool_two_workers"]["runs_per_hour"] / one
    out["scaling_dask_2_over_1"] = out["dask_two_workers"]["runs_per_hour"] / one
    return out


def peak_rss_mb() -> float:
    """This process's own peak resident memory, MB: Linux's ``VmHWM``, which starts afresh at
    ``exec``. ``ru_maxrss`` does not: a child started by a large parent (this benchmark's
    parent, or `bench_speed` after its NumPy loop and bank) reports at least the parent's
    resident memory at the fork (measured: a 10-MB child of a 330-MB parent reports 331 MB).
    Elsewhere ``ru_maxrss`` (kB on Linux)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _stream_child(hours: float, out_dir: str) -> None:
    """In a fresh process: one streamed trip; prints its figures as JSON."""
    from railnav.simulation.scenarios import get_scenario
    from railnav.navigation.streaming import stream_simulated
    from railnav.simulation.trip import navigator_config_for
    scenario = replace(get_scenario("paper2017"), duration_s=hours * HOUR_S,
                       imu_errors="tactical", default_track=None,
                       outages=tuple((600.0 + HOUR_S * h, 120.0) for h in range(int(hours))))
    config = navigator_config_for(scenario, systems="GE")
    t0 = time.perf_counter()
    outcome = stream_simulated(long_line(), scenario, config=config, seed=1, systems="GE",
                               out_dir=out_dir)
    wall = time.perf_counter() - t0
    s = outcome.summary
    sizes = {p.name: p.stat().st_size for p in outcome.paths}
    print(json.dumps({
        "trip_hours": hours, "imu_steps": s["steps"], "wall_s": wall,
        "real_time_factor": hours * HOUR_S / wall,
        "peak_rss_mb": peak_rss_mb(),
        "ru_maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "gnss_epochs": s["statistics"]["gnss_epochs"], "gnss_rows": s["statistics"]["gnss_rows"],
        "along_track_rms_m": s["errors"]["all"]["along_track_m"]["rms"],
        "outage_end_along_track_m": [o["at_end"]["along_track_m"]
                                     for o in s["errors"]["outages"]],
        "nees_mean": s["errors"]["nees"]["mean"], "nees_dof": s["errors"]["nees"]["dof"],
        "files_bytes": sizes}))


def _streaming(hours: float) -> dict:
    env = dict(os.environ, MPLBACKEND="Agg")
    with tempfile.TemporaryDirectory() as tmp:
        done = subprocess.run([sys.executable, __file__, "--stream-child", str(hours), tmp],
                              check=True, env=env, capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=16, help="runs per throughput study")
    parser.add_argument("--hours", type=float, default=10.0, help="long streamed trip, h")
    parser.add_argument("--quick", action="store_true", help="4 runs, 0.2 h and 0.1 h trips")
    parser.add_argument("--stream-child", nargs=2, metavar=("HOURS", "DIR"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.stream_child:
        _stream_child(float(args.stream_child[0]), args.stream_child[1])
        return {}
    runs, hours, short = (4, 0.2, 0.1) if args.quick else (args.runs, args.hours, 1.0)
    throughput = _throughput(runs)
    long_run, short_run = _streaming(hours), _streaming(short)
    doc = {
        "scenario": "paper2017 (1000 s, 100 Hz IMU, 1 Hz GNSS, two 50-s outages), "
                    "constrained filter, memory mode",
        "machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                    "load_average": list(os.getloadavg())},
        "throughput": throughput,
        "streaming": {"long": long_run, "short": short_run,
                      "peak_rss_ratio_long_over_short":
                          long_run["peak_rss_mb"] / short_run["peak_rss_mb"]},
        "targets": {"streaming_peak_rss_mb": STREAMING_RSS_TARGET_MB},
        "meets": {"streaming_peak_rss": long_run["peak_rss_mb"] < STREAMING_RSS_TARGET_MB},
    }
    if not args.quick:
        RESULTS.parent.mkdir(exist_ok=True)
        RESULTS.write_text(json.dumps(doc, indent=2) + "\n")
    t = throughput
    print(f"runs/hour: 1 worker {t['one_worker']['runs_per_hour']:.0f}, pool of 2 "
          f"{t['pool_two_workers']['runs_per_hour']:.0f} (x{t['scaling_2_over_1']:.2f}), "
          f"Dask 2 {t['dask_two_workers']['runs_per_hour']:.0f} "
          f"(x{t['scaling_dask_2_over_1']:.2f})")
    for name, r in (("long", long_run), ("short", short_run)):
        print(f"streaming {name}: {r['trip_hours']:g} h, {r['imu_steps']} steps in "
              f"{r['wall_s']:.0f} s, peak RSS {r['peak_rss_mb']:.0f} MB")
    return doc


if __name__ == "__main__":
    main()
