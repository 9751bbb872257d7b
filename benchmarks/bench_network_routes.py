"""Which way did the train go: route identification on the shipped Brussels network.

Simulated trips (the `curvy` scenario's sensors, 20 m/s, 100 s) start 50 m before the end
of a netelement with a switch ahead; every route ahead within 2.5 km is a hypothesis of the
bank (`railnav.jobs.network`), each route taken in turn as the truth, seeds 1-3. Reports,
per case, when the routes part (> 1 m apart), when P(true) first passes 0.99, its final
value and the share of cycles with P(true) > 0.99 from 20 s after the routes part.

    python benchmarks/bench_network_routes.py      # ~1-2 min; writes results/network_routes.json
"""
from __future__ import annotations

import json
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from railnav.jobs.network import route_candidates, run_simulated_network  # noqa: E402
from railnav.simulation.profiles import constant_speed  # noqa: E402
from railnav.simulation.scenarios import get_scenario  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402
from trackmodel.network import NetPosition  # noqa: E402
from trackmodel.network_io import read_network  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results" / "network_routes.json"
STARTS = (("88_L_111", -1), ("88_L_7855", -1), ("88_L_5900", 1))
SPEED_MPS, DURATION_S, HORIZON_M, BACK_M = 20.0, 100.0, 2500.0, 50.0


def one_start(net, element: str, direction: int) -> list[dict]:
    length = net.length_m(element)
    start = NetPosition(element, length - BACK_M if direction == -1 else BACK_M, direction)
    names, tracks, s0 = route_candidates(net, start, horizon_m=HORIZON_M)
    grid = np.arange(s0, min(t.length_m for t in tracks), 1.0)
    gaps = np.max([np.linalg.norm(tracks[0].at(grid).r_e - t.at(grid).r_e, axis=1)
                   for t in tracks[1:]], axis=0)
    t_part = float((grid[np.argmax(gaps > 1.0)] - s0) / SPEED_MPS)
    scenario = replace(get_scenario("curvy"), profile=constant_speed(SPEED_MPS),
                       duration_s=DURATION_S, outages=())
    rows = []
    for true in range(len(names)):
        for seed in (1, 2, 3):
            started = time.perf_counter()
            bank = run_simulated_network(net, start, scenario, true_route=true,
                                         horizon_m=HORIZON_M, seed=seed).bank
            p = bank.probabilities[:, true]
            late = bank.time_s > t_part + 20.0
            above = np.flatnonzero(p > 0.99)
            rows.append({"start": element, "direction": direction, "routes": len(names),
                         "true_route": names[true], "seed": seed, "routes_part_s": t_part,
                         "first_above_0_99_s": float(bank.time_s[above[0]]) if above.size
                         else None, "final_p_true": float(p[-1]),
                         "min_p_true_before_part": float(p[bank.time_s < t_part - 5].min()),
                         "share_above_0_99_after_part_20s": float(np.mean(p[late] > 0.99)),
                         "runtime_s": time.perf_counter() - started})
    return rows


def main() -> int:
    net = read_network(REPO / "data" / "networks" / "brussels_airport")
    rows = [r for element, d in STARTS for r in one_start(net, element, d)]
    ok = sum(r["share_above_0_99_after_part_20s"] == 1.0 for r in rows)
    out = {"cases": rows, "identified": ok, "runs": len(rows),
           "python": platform.python_version(), "machine": platform.machine()}
    atomic_write_text(RESULTS, json.dumps(out, indent=2) + "\n")
    for r in rows:
        print(f"{r['start']} {r['true_route']:45s} seed {r['seed']}: part {r['routes_part_s']:.0f} s, "
              f">0.99 at {r['first_above_0_99_s']}, final {r['final_p_true']:.4f}, "
              f"min before {r['min_p_true_before_part']:.3f}")
    print(f"identified {ok} of {len(rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
