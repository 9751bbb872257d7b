"""Which way did the train go: route identification on the shipped Brussels network.

Simulated trips (the `curvy` scenario's sensors, 20 m/s, 100 s) start 50 m before the end
of a netelement with a switch ahead, along each route ahead within 2.5 km in turn (its
netelements chained: `railnav.jobs.network.simulation_line`), seeds 1-3; the network
navigator (`railnav.jobs.network.run_simulated_network`, told the start netelement only)
follows them. Reports, per case, when the routes part (> 1 m apart), when the route's
netelement after the switch first gets P > 0.99, the lowest probability the true
netelement had in the 5 s after the switch, the final route, and the share of cycles with
the true netelement at P > 0.99 from 20 s after the routes part.

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

from railnav.jobs.network import (  # noqa: E402
    route_candidates,
    run_simulated_network,
    simulation_line,
)
from railnav.jobs.network_scoring import true_netelements  # noqa: E402
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
    names, routes, s0 = route_candidates(net, start, horizon_m=HORIZON_M)
    lines = [simulation_line(net, r.legs) for r in routes]
    grid = np.arange(s0, min(t.length_m for t in lines), 1.0)
    gaps = np.max([np.linalg.norm(lines[0].at(grid).r_e - t.at(grid).r_e, axis=1)
                   for t in lines[1:]], axis=0)
    t_part = float((grid[np.argmax(gaps > 1.0)] - s0) / SPEED_MPS)
    t_switch = (length - BACK_M) / SPEED_MPS        # the start is BACK_M into its element
    scenario = replace(get_scenario("curvy"), profile=constant_speed(SPEED_MPS),
                       duration_s=DURATION_S, outages=(), start_s=s0)
    rows = []
    for true, route in enumerate(routes):
        for seed in (1, 2, 3):
            started = time.perf_counter()
            run = run_simulated_network(net, route.legs, scenario, line=lines[true],
                                        seed=seed, known_start=True)
            res = run.network_result
            truth = true_netelements(net, route.legs, np.interp(
                res.time_s, run.outcome.trip.truth.time_s, run.outcome.trip.truth.s))
            p = np.array([q.get(e, 0.0) for q, e in zip(res.element_probability, truth)])
            after = np.flatnonzero((res.time_s > t_switch) & (p > 0.99))
            late = res.time_s > t_part + 20.0
            soon = (res.time_s > t_switch) & (res.time_s < t_switch + 5.0)
            rows.append({"start": element, "direction": direction, "routes": len(names),
                         "true_route": names[true], "seed": seed, "routes_part_s": t_part,
                         "switch_s": t_switch,
                         "first_above_0_99_after_switch_s": float(res.time_s[after[0]])
                         if after.size else None,
                         "min_p_true_5s_after_switch": float(p[soon].min()) if soon.any()
                         else None, "route": res.route_frame()["netelement"].tolist(),
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
        print(f"{r['start']} {r['true_route']:45s} seed {r['seed']}: part "
              f"{r['routes_part_s']:.0f} s, >0.99 at {r['first_above_0_99_after_switch_s']}, "
              f"share after {r['share_above_0_99_after_part_20s']:.3f}")
    print(f"identified {ok} of {len(rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
