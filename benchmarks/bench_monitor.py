"""Cost of the divergence monitor (`railnav.navigation.monitor`, issue 14 item 3; issue 15's
filter-alone speed) on the 2017 paper's 1000-s trip, measured side by side in one process.

* ``filter``: `railnav.navigate` on the trip's sensor data (`bench_navigator._trip_and_start`,
  compiled code built and a first call made before timing) with the monitor off and on,
  alternately, ``--repeats`` times each: wall and process CPU time, best of each;
* ``monitor``: one more run with the monitor on, its two hooks
  (`FilterMonitor.prior`, `FilterMonitor.epoch`) timed: wall and CPU per run and per
  tested epoch, with the share spent in the epochs whose fix is solved from all the
  epoch's data (`railnav.navigation.track_fixes.spp_fix_at`: the fault screen kept rows
  out) and in the snapshot fixes (`railnav.navigation.snapshot.snapshot_fix`).

The load average is recorded before and after: on a shared machine the wall figures move
with it, the CPU figures less. Writes ``benchmarks/results/monitor.json``. Run from the
repository root: ``python benchmarks/bench_monitor.py``.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import defaultdict
from dataclasses import replace
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_navigator  # noqa: E402  (the paper2017 trip and start live there)

from railnav.navigation import monitor as monitor_module  # noqa: E402
from railnav.navigation import navigator as navigator_module  # noqa: E402
from railnav.navigation.navigator import navigate  # noqa: E402

RESULTS = HERE / "results" / "monitor.json"


def _clocks() -> tuple[float, float]:
    return time.perf_counter(), time.process_time()


def _timed(totals: dict, name: str, function):
    """`function` adding its wall and CPU time to ``totals[name]``."""
    def timed(*args, **kwargs):
        wall0, cpu0 = _clocks()
        try:
            return function(*args, **kwargs)
        finally:
            wall1, cpu1 = _clocks()
            totals[name][0] += wall1 - wall0
            totals[name][1] += cpu1 - cpu0
            totals[name][2] += 1
    return timed


def _time_filter(trip, data, initial, configs: dict, repeats: int) -> dict:
    out = {name: {"wall_s": [], "cpu_s": []} for name in configs}
    for _ in range(repeats):
        for name, config in configs.items():
            wall0, cpu0 = _clocks()
            navigate(trip.track, data, config, initial=initial)
            wall1, cpu1 = _clocks()
            out[name]["wall_s"].append(wall1 - wall0)
            out[name]["cpu_s"].append(cpu1 - cpu0)
    for times in out.values():
        times["best_wall_s"], times["best_cpu_s"] = min(times["wall_s"]), min(times["cpu_s"])
    return out


def _time_hooks(trip, data, initial, config) -> dict:
    totals: dict = defaultdict(lambda: [0.0, 0.0, 0])
    cls = monitor_module.FilterMonitor
    saved = (cls.prior, cls.epoch, monitor_module.snapshot_fix, navigator_module.spp_fix_at)

    def spp_fix_at(*args, **kwargs):        # the run's fix_at, its calls timed
        return _timed(totals, "spp_fix_at", saved[3](*args, **kwargs))
    cls.prior, cls.epoch = _timed(totals, "prior", cls.prior), _timed(totals, "epoch", cls.epoch)
    monitor_module.snapshot_fix = _timed(totals, "snapshot_fix", saved[2])
    navigator_module.spp_fix_at = spp_fix_at
    try:
        result = navigate(trip.track, data, config, initial=initial)
    finally:
        cls.prior, cls.epoch, monitor_module.snapshot_fix, navigator_module.spp_fix_at = saved
    epochs = len(result.monitor)
    wall = totals["prior"][0] + totals["epoch"][0]
    cpu = totals["prior"][1] + totals["epoch"][1]
    return {"tested_epochs": epochs, "hooks_wall_s": wall, "hooks_cpu_s": cpu,
            "per_epoch_wall_ms": 1e3 * wall / epochs, "per_epoch_cpu_ms": 1e3 * cpu / epochs,
            "parts": {name: {"wall_s": w, "cpu_s": c, "calls": n}
                      for name, (w, c, n) in totals.items()
                      if name in ("snapshot_fix", "spp_fix_at")}}


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    load_before = os.getloadavg()
    trip, config, initial = bench_navigator._trip_and_start(seed=1)
    data = trip.sensor_data()
    configs = {"monitor_off": replace(config, monitor=replace(config.monitor, enabled=False)),
               "monitor_on": config}
    navigate(trip.track, data, config, initial=initial)        # compile and warm up
    filt = _time_filter(trip, data, initial, configs, args.repeats)
    hooks = _time_hooks(trip, data, initial, config)
    on, off = filt["monitor_on"], filt["monitor_off"]
    doc = {"scenario": "paper2017 (1000 s, 100 Hz IMU, 1 Hz GNSS, two 50-s outages), seed 1",
           "load_average": {"before": list(load_before), "after": list(os.getloadavg())},
           "filter": filt,
           "monitor_share_of_filter": {
               "wall": (on["best_wall_s"] - off["best_wall_s"]) / on["best_wall_s"],
               "cpu": (on["best_cpu_s"] - off["best_cpu_s"]) / on["best_cpu_s"]},
           "monitor": hooks}
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps(doc, indent=2) + "\n")
    return doc


if __name__ == "__main__":
    doc = main()
    mon = doc["monitor"]
    print(f"filter off {doc['filter']['monitor_off']['best_cpu_s']:.2f} s CPU, on "
          f"{doc['filter']['monitor_on']['best_cpu_s']:.2f} s; monitor "
          f"{mon['per_epoch_cpu_ms']:.3f} ms CPU per epoch ({mon['tested_epochs']} epochs)")
