"""Speed of the network navigator with an inertial filter: a bank of 8 hypotheses on the
paper scenario (issue 13: >= 300x real time end to end, >= 1000x the filter alone).

Usage::

    python benchmarks/bench_network_speed.py [--trip-s 1000]

The ``paper2017`` scenario (its track, 100-Hz IMU, GNSS), simulated once; the network of
8 one-element netelements: the track and its parallels every 4.5 m
(`trackmodel.offset.offset_track`), the true one the 4th. The network navigator
(constrained INS/GNSS, one hypothesis per netelement, each from the truth brought onto
it) runs twice: ``kept``, every hypothesis kept to the end (no pruning, up to 8 live:
what 8 hypotheses cost), and ``pruned``, the default limits. Times (one run each, after
a first run that builds and compiles): simulation, navigation, writing the outputs;
end to end = their sum. The Brussels fix-only figure (< 2 s for 15 min) is in
``bench_network_brussels.py``.

Writes ``benchmarks/results/network_speed.json``.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from railnav.jobs.network import run_simulated_network, write_network_run  # noqa: E402
from railnav.navigation.hypotheses import NetworkNavConfig  # noqa: E402
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402
from trackmodel.io import read_track  # noqa: E402
from trackmodel.network import Network  # noqa: E402
from trackmodel.offset import offset_track  # noqa: E402

RESULTS = REPO / "benchmarks" / "results" / "network_speed.json"
HYPOTHESES, SPACING_M, TRUE_INDEX = 8, 4.5, 3


def _network():
    base = read_track(TRACKS_DIR / "paper2017.csv")
    elements = {f"T{k}": base if k == TRUE_INDEX else
                offset_track(base, (k - TRUE_INDEX) * SPACING_M) for k in range(HYPOTHESES)}
    return Network(elements, []), base


def _timed(net, base, scenario, nav) -> dict:
    started = time.perf_counter()
    run = run_simulated_network(net, [(f"T{TRUE_INDEX}", 1)], scenario, line=base, seed=1,
                                nav=nav)
    total = time.perf_counter() - started
    res = run.network_result
    with tempfile.TemporaryDirectory() as tmp:
        w0 = time.perf_counter()
        write_network_run(run, tmp, plots=False)
        write_s = time.perf_counter() - w0
    navigate_s = res.runtime_s
    e2e = total + write_s
    trip = float(scenario.duration_s)
    return {"navigator_s": navigate_s, "simulation_and_setup_s": total - navigate_s,
            "write_s": write_s, "end_to_end_s": e2e,
            "real_time_factor_end_to_end": trip / e2e,
            "real_time_factor_navigator": trip / navigate_s,
            "hypotheses_max": int(res.cycles["hypotheses"].max()),
            "hypotheses_median": float(res.cycles["hypotheses"].median()),
            "final_netelement": res.cycles["netelement"].iloc[-1],
            "final_probability": float(res.cycles["netelement_probability"].iloc[-1])}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trip-s", type=float, default=1000.0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    net, base = _network()
    scenario = replace(get_scenario("paper2017"), duration_s=args.trip_s, outages=())
    load_before = os.getloadavg()
    kept = NetworkNavConfig(prune_probability=0.0, max_hypotheses=HYPOTHESES,
                            start_radius_m=40.0)
    pruned = NetworkNavConfig(start_radius_m=40.0)
    _timed(net, base, replace(scenario, duration_s=20.0), kept)      # builds, compiles
    out = {"trip_s": args.trip_s, "hypotheses": HYPOTHESES, "spacing_m": SPACING_M,
           "kept": _timed(net, base, scenario, kept),
           "pruned": _timed(net, base, scenario, pruned),
           "targets": {"end_to_end_x": 300.0, "navigator_x": 1000.0},
           "machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                       "load_average_before": load_before}}
    out["machine"]["load_average_after"] = os.getloadavg()
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    for name in ("kept", "pruned"):
        r = out[name]
        print(f"{name}: {r['hypotheses_max']} hypotheses max: navigator {r['navigator_s']:.1f} s "
              f"= {r['real_time_factor_navigator']:.0f}x, end to end {r['end_to_end_s']:.1f} s "
              f"= {r['real_time_factor_end_to_end']:.0f}x; final {r['final_netelement']} "
              f"{r['final_probability']:.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
