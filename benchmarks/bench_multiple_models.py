"""Cost of the fault screen and of parallel-track identification (issue 8).

Measured in one process, alternating the variants so that a change of machine load hits
both alike:

* ``fault_screen``: `railnav.navigate` on the 2017 paper's simulated trip (1000 s, 100 Hz
  IMU, ~900 GNSS epochs) with ``NavigatorConfig.fault_detection`` on (the default) and off;
  the target is at most +10 % (``ratio_on_over_off``, best of the repeats);
* ``track_bank``: the network navigator on the two tracks of the double line as a network
  without connections (`railnav.jobs.tracks.track_network`, `track_nav`; 300 s of the
  ``curvy`` scenario) against `railnav.navigate` on one of them (the issue expects ~N x
  the single filter for N tracks).

Writes ``benchmarks/results/multiple_models.json``. Run:
``python benchmarks/bench_multiple_models.py``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_navigator  # noqa: E402  (the 2017 trip and its start live there)

from railnav.filters.protocol import make_filter
from railnav.navigation.navigator import navigate  # noqa: E402
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario  # noqa: E402
from railnav.jobs.network import candidate_starts  # noqa: E402
from railnav.jobs.tracks import track_nav, track_network  # noqa: E402
from railnav.navigation.network_navigator import navigate_network  # noqa: E402
from railnav.simulation.trip import navigator_config_for, simulate_trip  # noqa: E402
from trackmodel.io import read_track  # noqa: E402

RESULTS = HERE / "results" / "multiple_models.json"
BANK_TRIP_S = 300.0


def _alternate(variants: dict, repeats: int) -> dict:
    """Each variant once (warm-up), then `repeats` rounds of all; best and all times."""
    for run in variants.values():
        run()
    times = {name: [] for name in variants}
    for _ in range(repeats):
        for name, run in variants.items():
            t0 = time.perf_counter()
            run()
            times[name].append(time.perf_counter() - t0)
    return {name: {"run_s": t, "best_s": min(t)} for name, t in times.items()}


def _fault_screen(repeats: int) -> dict:
    trip, config, initial = bench_navigator._trip_and_start(seed=1)
    data, off = trip.sensor_data(), replace(config, fault_detection=None)
    out = _alternate({"on": lambda: navigate(trip.track, data, config, initial=initial),
                      "off": lambda: navigate(trip.track, data, off, initial=initial)}, repeats)
    out["ratio_on_over_off"] = out["on"]["best_s"] / out["off"]["best_s"]
    out["meets_10_percent"] = out["ratio_on_over_off"] <= 1.10
    return out


def _track_bank(repeats: int) -> dict:
    tracks = [read_track(TRACKS_DIR / f"double_{x}.csv") for x in "ab"]
    scenario = replace(get_scenario("curvy"), duration_s=BANK_TRIP_S, sigma_pseudorange_m=3.0)
    trip = simulate_trip(scenario, track=tracks[1], seed=1)
    config = navigator_config_for(scenario)
    start = candidate_starts(trip, config, make_filter(tracks[1], config, None))
    network, names = track_network(tracks, ("a", "b")), ("a", "b")
    near = (float(trip.truth.lat[0]), float(trip.truth.lon[0]))
    data = trip.sensor_data()
    out = _alternate({
        "two_tracks": lambda: navigate_network(network, data, config, nav=track_nav(2),
                                               initial=start, near=near),
        "one_track": lambda: navigate(tracks[1], data, config,
                                      initial=lambda f: start(f, names[1], 1))}, repeats)
    out["ratio_two_over_one"] = out["two_tracks"]["best_s"] / out["one_track"]["best_s"]
    return out


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    doc = {"machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                       "load_average": list(os.getloadavg())},
           "fault_screen": _fault_screen(args.repeats), "track_bank": _track_bank(args.repeats)}
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps(doc, indent=2) + "\n")
    print(f"fault screen on/off: {doc['fault_screen']['ratio_on_over_off']:.3f}; "
          f"two tracks / one: {doc['track_bank']['ratio_two_over_one']:.2f}")
    return doc


if __name__ == "__main__":
    main()
