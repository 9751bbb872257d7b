"""Speed a user feels (issue 15): every figure measured side by side in one run.

On this machine, in one invocation (the load average is recorded before and after):

* ``help``: wall time of ``railnav --help`` (``python -m railnav.cli --help``, a fresh
  interpreter each time);
* ``end_to_end``: ``railnav run data/tracks/paper2017.csv`` (the paper's 1000-s trip
  simulated and filtered, estimates/innovations/errors CSV, summary.json), with and
  without ``--no-plots``, as subprocesses; × real time = 1000 s / wall. ``first_run``
  is one more ``--no-plots`` run with an empty compiled-code cache (``RAILNAV_CACHE_DIR``
  pointing at a new directory): what the first run on a machine costs;
* ``filter``: `railnav.navigate` alone on that trip's sensor data, in this process
  (`bench_navigator._time_filter`: compiled code built and a first call made before timing);
* ``filter_parts``: the CPU of that filter run by component (the compiled step loop,
  epoch preparation, GNSS rows, inputs, fault screen, update, divergence monitor and the
  rest; `_filter_parts`);
* ``filter_detail``: what is inside those parts and the rest (the track grid, the
  receiver's track part, the screen's clock-jump test and channel rows, the monitor's
  own-rows fix and the fixes it solves, the engine's bookkeeping, ...; inclusive CPU,
  `_filter_parts.DETAIL`);
* ``numpy_loop``: the plain NumPy EKF of the same size in this process (7 states, a 2-D
  correlated pseudo-measurement at each of the 100 000 steps, 1000 updates of 20 rows;
  `bench_ekf_engine._time_numpy`), the whole loop unless ``--numpy-fraction`` < 1;
* ``bank``: the network navigator on 8 tracks as a network without connections
  (`railnav.jobs.tracks.track_network`, `track_nav`), 8 hypotheses, the tracks of a
  line and its parallels every 4.5 m (`trackmodel.offset.offset_track`), 300 s of the
  ``curvy`` scenario on one of them; × real time = 300 s / wall (and ``*_cpu``: / this
  process's CPU time, median of the repeats);
* ``streaming``: the 10-hour streamed trip of `bench_studies` in a subprocess, its peak
  resident memory (``--no-streaming`` skips it: about 2 minutes on a quiet machine);
* ``stages``: where a ``railnav run data/tracks/paper2017.csv`` goes, in a fresh
  subprocess with a warm cache: importing what the command imports, simulating the trip,
  the filter (`railnav.navigate`), the errors and summary, writing the CSVs, what the
  figures add when the plot helper draws them meanwhile (`railnav.jobs.plot_worker`, as
  the command does), and, for comparison, importing matplotlib and drawing the plots in
  the process after the tables (the same calls as `railnav.jobs.run`, timed one by one;
  the best of ``--repeats`` processes for each stage, wall and CPU).

The timed commands run as on a user's machine, where Python writes each module's
compiled bytecode (``.pyc``) on the first run, or ``pip install`` of the wheel compiles
them: ``PYTHONDONTWRITEBYTECODE`` (set in some sandboxes) is removed from their
environment and a warm-up run writes the ``.pyc`` first (``machine.bytecode``).
``end_to_end.compiling_sources`` is ``--no-plots`` with the variable set on a copy of the
packages without ``.pyc``: every run compiles railnav's modules from source, the
condition such a sandbox measures.

Writes ``benchmarks/results/speed.json``. Run from the repository root:
``python benchmarks/bench_speed.py`` (``--quick`` for a smoke run).
"""
from __future__ import annotations

import argparse
import functools
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path[:0] = [str(REPO), str(HERE)]       # this checkout, then the sibling benchmarks
# the sibling benchmarks (NumPy loop, filter timing, streamed trip) import the package: they
# are imported in `main`, after `--stages-child` (a fresh process that times the imports)

RESULTS = HERE / "results" / "speed.json"
TRACK = REPO / "data" / "tracks" / "paper2017.csv"
TRIP_S = 1000.0
BANK_TRIP_S = 300.0
BANK_HYPOTHESES = 8
BANK_SPACING_M = 4.5
#: Issue 15's acceptance figures.
TARGETS = {"help_s": 0.5, "end_to_end_x": 500.0, "end_to_end_no_plots_x": 800.0,
           "filter_x": 5000.0, "numpy_over_filter": 5.0, "bank_8_x": 1000.0,
           "streaming_peak_rss_mb": 300.0}


#: Packages of this checkout (copied without their ``.pyc`` for `_compiling_sources`).
PACKAGES = ("ekf", "gnss_obs", "railnav", "strapdown", "trackmodel")
#: How the timed commands treat compiled bytecode (module docstring), in the JSON.
BYTECODE = ("PYTHONDONTWRITEBYTECODE removed from the timed commands' environment; a "
            "warm-up run writes the .pyc, which the timed runs read (a user's machine)")


def _env(*, root: Path = REPO, **extra: str) -> dict:
    """The commands' environment: `root`'s packages first, ``.pyc`` written and read."""
    path = os.pathsep.join([str(root), *filter(None, [os.environ.get("PYTHONPATH")])])
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return {**env, "PYTHONPATH": path, "MPLBACKEND": "Agg", **extra}


def _wall(argv: list[str], env: dict, *, cwd: Path = REPO) -> float:
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "railnav.cli", *argv], check=True, env=env,
                   stdout=subprocess.DEVNULL, cwd=cwd)
    return time.perf_counter() - start


def _help(repeats: int) -> dict:
    _wall(["--help"], _env())                                       # .pyc written
    times = [_wall(["--help"], _env()) for _ in range(repeats)]
    return {"command": "python -m railnav.cli --help", "run_s": times, "best_s": min(times),
            "median_s": statistics.median(times)}


def _end_to_end(repeats: int) -> dict:
    """With and without plots, alternated; then one run on an empty compiled-code cache."""
    times = {"plots": [], "no_plots": []}
    with tempfile.TemporaryDirectory() as tmp:
        run = ["-q", "run", str(TRACK)]
        _wall([*run, "--no-plots", "--out", f"{tmp}/warm"], _env())   # cache warm
        for k in range(repeats):
            times["plots"].append(_wall([*run, "--out", f"{tmp}/p{k}"], _env()))
            times["no_plots"].append(_wall([*run, "--no-plots", "--out", f"{tmp}/n{k}"],
                                           _env()))
        first = _wall([*run, "--no-plots", "--out", f"{tmp}/first"],
                      _env(RAILNAV_CACHE_DIR=f"{tmp}/empty-cache"))
    out = {key: {"command": f"railnav run data/tracks/paper2017.csv"
                            f"{'' if key == 'plots' else ' --no-plots'}",
                 "run_s": t, "best_s": min(t), "median_s": statistics.median(t),
                 "real_time_factor": TRIP_S / min(t)} for key, t in times.items()}
    out["first_run"] = {"command": "railnav run data/tracks/paper2017.csv --no-plots, "
                                   "empty RAILNAV_CACHE_DIR", "run_s": first,
                        "compile_overhead_s": first - out["no_plots"]["best_s"]}
    out["compiling_sources"] = _compiling_sources(repeats, out["no_plots"]["best_s"])
    return out


def _compiling_sources(repeats: int, no_plots_best_s: float) -> dict:
    """``--no-plots`` with ``PYTHONDONTWRITEBYTECODE=1`` on a copy of the packages without
    ``.pyc``: railnav's modules compiled from source at every run."""
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in PACKAGES:
            shutil.copytree(REPO / name, Path(tmp) / "src" / name,
                            ignore=shutil.ignore_patterns("__pycache__"))
        env = _env(root=Path(tmp) / "src", PYTHONDONTWRITEBYTECODE="1")
        run = ["-q", "run", str(TRACK), "--no-plots"]
        # run from `tmp`: ``python -m`` puts the working directory first on sys.path,
        # and this checkout's packages (with their .pyc) would be imported instead
        _wall([*run, "--out", f"{tmp}/warm"], env, cwd=Path(tmp))   # compiled code warm
        for k in range(repeats):
            times.append(_wall([*run, "--out", f"{tmp}/n{k}"], env, cwd=Path(tmp)))
    return {"command": "railnav run data/tracks/paper2017.csv --no-plots, "
                       "PYTHONDONTWRITEBYTECODE=1, no .pyc of railnav's packages",
            "run_s": times, "best_s": min(times), "real_time_factor": TRIP_S / min(times),
            "over_no_plots_s": min(times) - no_plots_best_s}


def _bank(repeats: int) -> dict:
    """8 hypotheses (a line and its parallels) on 300 s of the curvy scenario."""
    from railnav.filters.protocol import make_filter
    from railnav.jobs.network import candidate_starts
    from railnav.jobs.tracks import track_nav, track_network
    from railnav.navigation.network_navigator import navigate_network
    from railnav.simulation.scenarios import TRACKS_DIR, get_scenario
    from railnav.simulation.trip import navigator_config_for, simulate_trip
    from trackmodel.io import read_track
    from trackmodel.offset import offset_track

    base = read_track(TRACKS_DIR / "double_a.csv")
    true_index = BANK_HYPOTHESES // 2
    tracks = [offset_track(base, (k - true_index) * BANK_SPACING_M) if k != true_index
              else base for k in range(BANK_HYPOTHESES)]
    scenario = replace(get_scenario("curvy"), duration_s=BANK_TRIP_S, sigma_pseudorange_m=3.0)
    trip = simulate_trip(scenario, track=base, seed=1)
    config = navigator_config_for(scenario)
    names = [f"T{k}" for k in range(BANK_HYPOTHESES)]
    network = track_network(tracks, names)
    initial = candidate_starts(trip, config, make_filter(base, config, None))
    near = (float(trip.truth.lat[0]), float(trip.truth.lon[0]))
    data = trip.sensor_data()

    def run():
        return navigate_network(network, data, config, nav=track_nav(BANK_HYPOTHESES),
                                initial=initial, near=near)
    first_start = time.perf_counter()
    run()                                                          # builds, compiles
    first = time.perf_counter() - first_start
    times, cpu = [], []
    for _ in range(repeats):
        start, cpu_start = time.perf_counter(), time.process_time()
        bank = run()
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - cpu_start)
    final = [bank.element_probability[-1].get(n, 0.0) for n in names]
    return {"hypotheses": BANK_HYPOTHESES, "spacing_m": BANK_SPACING_M,
            "trip_s": BANK_TRIP_S, "first_run_s": first, "run_s": times,
            "best_s": min(times), "real_time_factor": BANK_TRIP_S / min(times),
            "cpu_s": cpu, "median_cpu_s": statistics.median(cpu),
            "real_time_factor_cpu": BANK_TRIP_S / statistics.median(cpu),
            "true_track_probability_at_end": float(final[true_index])}


#: What ``railnav run`` (no plots) imports, at its top modules (the rest follows).
_RUN_MODULES = ("railnav.commands.run", "railnav.jobs.run", "railnav.navigation.navigator",
                "railnav.filters.constrained", "railnav.simulation.trip",
                "railnav.simulation.truth", "gnss_obs.simulate", "gnss_obs.spp",
                "railnav.evaluation.metrics", "trackmodel.csv_table", "trackmodel.track")


class _Laps:
    """Wall and CPU (this process) time of consecutive stages, s."""

    def __init__(self) -> None:
        self.wall, self.cpu = {}, {}
        self._mark = (time.perf_counter(), time.process_time())

    def lap(self, name: str) -> None:
        now = (time.perf_counter(), time.process_time())
        self.wall[name] = now[0] - self._mark[0]
        self.cpu[name] = now[1] - self._mark[1]
        self._mark = now


def _stages_child() -> None:
    """In a fresh process: each stage of ``railnav run paper2017.csv`` timed (JSON line:
    wall per stage, and under ``cpu`` this process's CPU per stage and the plot helper's).

    As the command does, the plot helper (`railnav.jobs.run_figures.run_plot_helper`) is forked
    after the imports, lays out the figures ahead, and draws them while `write_run` writes
    the tables:
    ``plots_helper_wait_s`` is what the figures add to the run then (`write_run` with the
    helper, less ``write_csv_s``); ``import_matplotlib_s`` and ``plots_s`` are the same
    figures drawn in this process after the tables (the path without fork)."""
    import importlib

    from railnav.blas_threads import one_blas_thread
    one_blas_thread()                   # as importing `railnav.cli` does, before NumPy
    from railnav.deferred_imports import defer_numpy_tools
    defer_numpy_tools()                 # as `railnav.cli.main` does before the command
    laps = _Laps()
    for name in _RUN_MODULES:       # the packages import their modules on first use
        importlib.import_module(name)
    from railnav.commands.run_flags import DEFAULT_SEED
    from railnav.evaluation.metrics import error_series
    from railnav.jobs.run import RunOutcome, run_summary, truth_start, write_run
    from railnav.jobs.run_figures import run_plot_helper
    from railnav.navigation.navigator import navigate
    from railnav.simulation.scenarios import get_scenario
    from railnav.simulation.trip import navigator_config_for, simulate_trip
    from trackmodel.io import read_track
    laps.lap("imports_s")
    with run_plot_helper("constrained", True) as helper:
        scenario = get_scenario("paper2017")
        config = navigator_config_for(scenario, filter="constrained", systems="G")
        trip = simulate_trip(scenario, track=read_track(TRACK), seed=DEFAULT_SEED,
                             systems="G")      # the command's trip
        laps.lap("simulate_s")
        result = navigate(trip.track, trip.sensor_data(), config, outages=scenario.outages,
                          initial=functools.partial(truth_start, trip=trip, config=config))
        laps.lap("filter_s")
        errors = error_series(result, trip.truth, trip.track, clock_truth=trip.clock_truth)
        summary = run_summary(result, trip.track, errors, None, scenario.outages, {})
        laps.lap("errors_summary_s")
        outcome = RunOutcome(result, trip.track, summary, errors, trip, trip.truth)
        with tempfile.TemporaryDirectory() as tmp:
            write_run(outcome, tmp, plots=False)
            laps.lap("write_csv_s")
            write_run(outcome, tmp, plots=True, plotter=helper)
            laps.lap("plots_helper_wait_s")
    helper_cpu = sum(os.times()[2:4])           # the helper and its fork, reaped
    with tempfile.TemporaryDirectory() as tmp:
        laps.lap("(helper's end)")
        import matplotlib.figure  # noqa: F401
        laps.lap("import_matplotlib_s")
        write_run(outcome, tmp, plots=True)
        laps.lap("plots_s")
    for times in (laps.wall, laps.cpu):
        times.pop("(helper's end)")
        for key in ("plots_helper_wait_s", "plots_s"):
            times[key] -= times["write_csv_s"]
    print(json.dumps({**laps.wall, "cpu": {**laps.cpu, "plot_helper_s": helper_cpu}}))


def _stages(repeats: int) -> dict:
    """Best of `repeats` fresh processes for each stage (`_stages_child`)."""
    runs = []
    for _ in range(repeats):
        done = subprocess.run([sys.executable, __file__, "--stages-child"], check=True,
                              env=_env(), capture_output=True, text=True, cwd=REPO)
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
    best = {key: min(r[key] for r in runs) for key in runs[0] if key != "cpu"}
    cpu = {key: min(r["cpu"][key] for r in runs) for key in runs[0]["cpu"]}
    critical = [k for k in best if k not in ("import_matplotlib_s", "plots_s")]
    return {"best_s": best, "best_cpu_s": cpu, "runs": runs,
            "sum_of_best_s": sum(best[k] for k in critical),
            "sum_of_best_s_in_process_plots": sum(best[k] for k in best
                                                  if k != "plots_helper_wait_s")}


def _meets(doc: dict) -> dict:
    e2e = doc["end_to_end"]
    meets = {
        "help_s": doc["help"]["best_s"] < TARGETS["help_s"],
        "end_to_end_x": e2e["plots"]["real_time_factor"] >= TARGETS["end_to_end_x"],
        "end_to_end_no_plots_x":
            e2e["no_plots"]["real_time_factor"] >= TARGETS["end_to_end_no_plots_x"],
        "filter_x": doc["filter"]["real_time_factor"] >= TARGETS["filter_x"],
        "numpy_over_filter": doc["ratios"]["numpy_loop_over_filter"]
        >= TARGETS["numpy_over_filter"],
    }
    if doc.get("bank"):
        meets["bank_8_x"] = doc["bank"]["real_time_factor"] >= TARGETS["bank_8_x"]
    if doc.get("streaming"):
        meets["streaming_peak_rss_mb"] = (doc["streaming"]["peak_rss_mb"]
                                          < TARGETS["streaming_peak_rss_mb"])
    return meets


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--numpy-fraction", type=float, default=1.0,
                        help="fraction of the NumPy loop timed (scaled up); 1: all of it")
    parser.add_argument("--hours", type=float, default=10.0, help="streamed trip, h")
    parser.add_argument("--no-streaming", action="store_true")
    parser.add_argument("--no-bank", action="store_true")
    parser.add_argument("--quick", action="store_true",
                        help="1 repeat, 5 %% of the NumPy loop, no streaming (smoke run)")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--stages-child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.stages_child:
        _stages_child()
        return {}
    from railnav.blas_threads import one_blas_thread
    one_blas_thread()       # the in-process timings (filter, bank) run as the CLI does
    import bench_ekf_engine  # the plain NumPy loop
    import bench_navigator  # the 2017 trip, the filter timing
    import bench_studies  # the 10-h streamed trip
    from _filter_parts import paper2017_detail, paper2017_parts  # the filter's CPU
    import numpy as np
    if args.quick:
        args.repeats, args.numpy_fraction, args.no_streaming = 1, 0.05, True
    doc = {"machine": {"python": platform.python_version(),
                       "processor": platform.processor() or platform.machine(),
                       "cpus": os.cpu_count(), "load_average_before": list(os.getloadavg()),
                       "bytecode": BYTECODE,
                       "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
                       "environment_sets_PYTHONDONTWRITEBYTECODE":
                       bool(os.environ.get("PYTHONDONTWRITEBYTECODE"))},
           "help": _help(max(args.repeats, 5)), "end_to_end": _end_to_end(args.repeats),
           "filter": bench_navigator._time_filter(args.repeats),
           "filter_parts": paper2017_parts(args.repeats),
           "filter_detail": paper2017_detail(args.repeats),
           "stages": _stages(args.repeats)}
    samples, epochs = bench_ekf_engine._scenario(np.random.default_rng(7))
    doc["numpy_loop"] = bench_ekf_engine._time_numpy(samples, epochs, args.numpy_fraction)
    doc["numpy_loop"]["real_time_factor"] = TRIP_S / doc["numpy_loop"]["run_s"]
    doc["ratios"] = {"numpy_loop_over_filter":
                     doc["numpy_loop"]["run_s"] / doc["filter"]["best_s"]}
    doc["bank"] = None if args.no_bank else _bank(args.repeats)
    doc["streaming"] = None if args.no_streaming else bench_studies._streaming(args.hours)
    doc["machine"]["load_average_after"] = list(os.getloadavg())
    doc["targets"], doc["meets"] = TARGETS, _meets(doc)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(doc, indent=2) + "\n")
    tmp.replace(args.out)
    return doc


def _print(doc: dict) -> None:
    e2e = doc["end_to_end"]
    print(f"railnav --help        {doc['help']['best_s']:.3f} s (median "
          f"{doc['help']['median_s']:.3f})")
    print(f"run, plots            {e2e['plots']['best_s']:.2f} s = "
          f"{e2e['plots']['real_time_factor']:.0f}x real time")
    print(f"run, --no-plots       {e2e['no_plots']['best_s']:.2f} s = "
          f"{e2e['no_plots']['real_time_factor']:.0f}x; first run (empty cache) "
          f"{e2e['first_run']['run_s']:.2f} s")
    print(f"  compiling sources   {e2e['compiling_sources']['best_s']:.2f} s "
          f"(PYTHONDONTWRITEBYTECODE=1, no .pyc)")
    print(f"filter alone          {doc['filter']['best_s']:.3f} s = "
          f"{doc['filter']['real_time_factor']:.0f}x")
    print(f"NumPy loop            {doc['numpy_loop']['run_s']:.2f} s "
          f"({doc['ratios']['numpy_loop_over_filter']:.1f}x the filter)")
    print("filter parts, CPU     " + ", ".join(f"{k.removesuffix('_s')} {v:.3f}"
                                                for k, v in doc["filter_parts"].items()))
    print("  inside (inclusive)  " + ", ".join(f"{k.removesuffix('_s')} {v:.3f}"
                                                for k, v in doc["filter_detail"].items()))
    if doc["bank"]:
        print(f"bank of 8             {doc['bank']['best_s']:.2f} s = "
              f"{doc['bank']['real_time_factor']:.0f}x")
    print("stages (best of runs) " + ", ".join(f"{k.removesuffix('_s')} {v:.2f}"
                                                for k, v in doc["stages"]["best_s"].items()))
    print("stages, CPU           " + ", ".join(f"{k.removesuffix('_s')} {v:.2f}"
                                                for k, v in doc["stages"]["best_cpu_s"].items()))
    if doc["streaming"]:
        print(f"10-h streamed trip    peak RSS {doc['streaming']['peak_rss_mb']:.0f} MB, "
              f"{doc['streaming']['wall_s']:.0f} s")
    print("load average", doc["machine"]["load_average_before"], "->",
          doc["machine"]["load_average_after"])
    print("meets", json.dumps(doc["meets"]))


if __name__ == "__main__":
    _doc = main()
    if _doc:
        _print(_doc)
