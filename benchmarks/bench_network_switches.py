"""Switches, simulated (issue 13's acceptance): which way at each switch, which track at
each epoch, on a double line with passing loops.

Usage::

    python benchmarks/bench_network_switches.py [--seeds 10] [--loops 10] [--only 9 ...]
                                                [--single-track]

The network is `railnav.simulation.switch_network` (double line A/B 4.5 m apart, a
passing loop 4.5 m to the right of A at each of ``--loops`` places: two switches each,
20 for 10 loops). For each seed the route takes each loop or not at random (seeded), the
trip runs along it at 20 m/s (curvy's sensors: tactical IMU, σ_pr of curvy, GPS), and the
network navigator (constrained INS/GNSS, told nothing of the route, started on every
netelement near the start) follows it (`railnav.jobs.network.run_simulated_network`).

Figures, over all seeds:

* **switches right**: at each switch of the route (the loop's facing switch, where the
  train chooses, and its trailing one), the final route (`route.csv`) has the true way;
* **per-epoch netelement right**: the share of cycles whose most probable netelement is
  the true one (issue 13: ≥ 99.5 %, Heirich 2016: 97.2 % of switch ways, 99.3 % track-
  selective); also without the first 10 s (the start between A and B) and how many
  cycles gave P >= 0.99 to a wrong netelement;
* **not-ok epochs**: the epochs beyond each run's first `START_EPOCHS` whose ``status``
  (`railnav.navigation.network_status`) is not ``ok``, and their times (the start's
  first epochs are the spawn test's own settling);
* **z of s**: the most probable hypothesis's along-track error (against the truth's
  position) over its σ_s: the largest |z| and the epochs with |z| > 3;
* **spawns**: hypotheses started from the epochs' single-point fixes when none agreed
  (`railnav.navigation.spawning`; every one of them a false alarm here, the start is
  right).

``--single-track`` adds, per seed, the epochs beyond 3σ_s (and their times) of the
network run and of one constrained filter told the route: the same trip on the route's
line (`railnav.jobs.run.run_simulated`, the same seed, sensors and start draw), scored at
the network run's epochs. An event in both is the filter's, not the network's
(`docs/consistency-ablations.md`, stop 34, s34seed2).

Writes ``benchmarks/results/network_switches.json``.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from railnav.jobs.network import run_simulated_network  # noqa: E402
from railnav.jobs.network_scoring import true_netelements  # noqa: E402
from railnav.jobs.run import run_simulated  # noqa: E402
from railnav.simulation.profiles import constant_speed  # noqa: E402
from railnav.simulation.scenarios import get_scenario  # noqa: E402
from railnav.simulation.switch_network import (  # noqa: E402
    SwitchNetworkSpec,
    loop_route,
    route_track,
    switch_network,
)
from trackmodel.files import atomic_write_text  # noqa: E402

RESULTS = REPO / "benchmarks" / "results" / "network_switches.json"
SPEED_MPS = 20.0
#: Start this far along A0, and end this far before the end of the line, m.
START_S_M, END_MARGIN_M = 50.0, 100.0
#: The start's ambiguity between A and B is left out of the second per-epoch figure, s.
SETTLE_S = 10.0
#: The not-ok count leaves out each run's first this many epochs.
START_EPOCHS = 4


def _beyond_3sigma(z, time_s) -> dict:
    """The epochs whose along-track z (error over σ_s) is beyond 3, and the largest |z|."""
    beyond = np.abs(z) > 3.0
    return {"max_abs_z_s": float(np.nanmax(np.abs(z))), "beyond_3sigma_epochs": int(beyond.sum()),
            "beyond_3sigma_times_s": [float(v) for v in time_s[beyond]]}


def _single_track(line, scenario, seed: int, time_s) -> dict:
    """`_beyond_3sigma` of one constrained filter on the route's `line` (the network
    run's trip: same scenario and seed), at those of the network run's epochs `time_s`
    where it has an estimate (all but the trip's end, which the network run adds)."""
    single = run_simulated(line, scenario, seed=seed)
    t = single.errors.time_s
    k = np.clip(np.searchsorted(t, time_s), 0, t.size - 1)
    same = np.abs(t[k] - time_s) < 1e-6
    z = single.errors.along_track_m / single.result.estimates["sigma_s_m"].to_numpy()
    return _beyond_3sigma(z[k[same]], time_s[same]) | {"epochs_scored": int(same.sum())}


def _run(net, spec, seed: int, single_track: bool = False) -> dict:
    rng = np.random.default_rng(1000 + seed)
    takes = [bool(v) for v in rng.integers(0, 2, spec.loops)]
    legs = loop_route(spec, takes)
    length = sum(net.length_m(e) for e, _ in legs)
    scenario = replace(get_scenario("curvy"), profile=constant_speed(SPEED_MPS),
                       duration_s=(length - START_S_M - END_MARGIN_M) / SPEED_MPS,
                       outages=(), start_s=START_S_M)
    started = time.perf_counter()
    line = route_track(net, legs)
    run = run_simulated_network(net, legs, scenario, line=line, seed=seed)
    wall = time.perf_counter() - started
    res = run.network_result
    cyc = res.cycles
    truth_s = np.interp(res.time_s, run.outcome.trip.truth.time_s, run.outcome.trip.truth.s)
    truth = true_netelements(net, legs, truth_s)
    right = cyc["netelement"].to_numpy() == truth
    late = res.time_s > SETTLE_S
    sure_wrong = (~right) & (cyc["netelement_probability"].to_numpy() >= 0.99)
    status = res.estimates["status"].to_numpy(dtype=object)[START_EPOCHS:]
    not_ok = status != "ok"
    z = run.outcome.errors.along_track_m / res.estimates["sigma_s_m"].to_numpy()
    route = [e for e in res.route_frame()["netelement"]]
    true = [e for e, _ in legs]
    ways = [(true[2 * k + 1], route[2 * k + 1] if 2 * k + 1 < len(route) else None)
            for k in range(spec.loops)]
    single = ({"network": _beyond_3sigma(z, res.time_s),
               "single_track": _single_track(line, scenario, seed, res.time_s)}
              if single_track else {})
    return single | {"seed": seed, "takes": takes, "cycles": int(len(cyc)),
            "netelement_right": int(right.sum()),
            "netelement_right_after_settle": int(right[late].sum()),
            "cycles_after_settle": int(late.sum()),
            "confidently_wrong_cycles": int(sure_wrong.sum()),
            "switches": 2 * spec.loops,
            "switches_right": 2 * sum(t == r for t, r in ways),
            "route_right": route == true, "hypotheses_max": int(cyc["hypotheses"].max()),
            "spawns": len(res.spawns),
            "not_ok_epochs": int(not_ok.sum()),
            "not_ok_times_s": [float(v) for v in res.time_s[START_EPOCHS:][not_ok]],
            "max_abs_z_s": float(np.nanmax(np.abs(z))),
            "beyond_3sigma_epochs": int(np.sum(np.abs(z) > 3.0)),
            "hypotheses_median": float(cyc["hypotheses"].median()),
            "wall_s": wall, "trip_s": float(scenario.duration_s)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--loops", type=int, default=10)
    parser.add_argument("--only", type=int, nargs="+", default=None,
                        help="run these seeds only (default: 1 .. --seeds)")
    parser.add_argument("--single-track", action="store_true",
                        help="also the epochs beyond 3 sigma_s of one filter told the route")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    spec = SwitchNetworkSpec(loops=args.loops)
    net = switch_network(spec)
    load_before = os.getloadavg()
    seeds = args.only if args.only else range(1, args.seeds + 1)
    runs = [_run(net, spec, seed, args.single_track) for seed in seeds]
    total = {k: sum(r[k] for r in runs) for k in ("cycles", "netelement_right",
                                                   "netelement_right_after_settle",
                                                   "cycles_after_settle", "switches",
                                                   "switches_right",
                                                   "confidently_wrong_cycles", "spawns",
                                                   "not_ok_epochs", "beyond_3sigma_epochs")}
    out = {"network": {"loops": spec.loops, "switches": 2 * spec.loops,
                       "spacing_m": spec.spacing_m, "turnout_radius_m": spec.turnout_radius_m,
                       "elements": len(net.elements)},
           "share_switches_right": total["switches_right"] / total["switches"],
           "share_netelement_right": total["netelement_right"] / total["cycles"],
           "share_netelement_right_after_settle":
               total["netelement_right_after_settle"] / total["cycles_after_settle"],
           "totals": total, "runs": runs,
           "machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                       "load_average_before": load_before,
                       "load_average_after": os.getloadavg()}}
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    print(f"{len(runs)} seeds x {2 * spec.loops} switches: switches right "
          f"{out['share_switches_right']:.4f}, per-epoch netelement right "
          f"{out['share_netelement_right']:.4f} ({out['share_netelement_right_after_settle']:.4f}"
          f" after {SETTLE_S:g} s), confidently wrong cycles {total['confidently_wrong_cycles']}"
          f", spawns {total['spawns']}, not-ok epochs {total['not_ok_epochs']}; {sum(r['wall_s'] for r in runs):.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
