"""Recovery by spawning in GNSS network runs (issue 14 §3): a network navigator started
wrong, on simulated pseudoranges without position fixes, with and without spawning.

Usage::

    python benchmarks/bench_network_spawn_gnss.py [--seeds 3] [--cases along ...] [--out FILE]

The network is `railnav.simulation.switch_network`'s double line (A and B 4.5 m apart),
the route straight along A (no loop taken), 20 m/s, curvy's sensors with σ_pr 3 m (GPS),
for `TRIP_S`. The navigator is told a wrong start (`railnav.navigation.network_start.
NetworkStart` and the truth brought onto the start's track, `railnav.jobs.network.
candidate_starts`):

* ``along``: on A0, `ALONG_ERRORS_M` ahead of the truth with the scenario's σ_s: beyond
  the fault screen's gate, so that later GNSS rows are rejected and it dead-reckons;
* ``parallel``: on B, the wrong one of the two parallel tracks (the start takes the
  netelements abreast of a known one too, with their prior,
  `railnav.navigation.network_start.with_abreast`: at 4.5 m A0, at 15 m none);
* ``right``: on A0, where the train is (what the told start's abreast hypotheses cost when
  it is right);
* ``unknown``: no start netelement told (every netelement near the first fix: A0 and B).

``--multipath-sigma`` runs the cases again with code multipath simulated too (`Scenario.
multipath_sigma_m`, ``--multipath-tau``: a Gauss–Markov bias per satellite, σ/sin(el), on
top of the white σ_pr), the navigator told what it is told for white errors (issues 13/14:
is it ever confidently wrong?); with ``--declared`` it is told the multipath
(`declared_measurement`: each row's variance σ_pr² + σ_mp²/sin²el; and
``NetworkNavConfig.evidence_correlation_s`` = τ); with ``--filter-correlation`` the filters
are told τ instead (the rows' variance declared, ``NavigatorConfig.
pseudorange_correlation_s`` = τ: their pseudorange variances inflated,
`railnav.filters.gnss_only_noise.pseudorange_inflation`, which discounts each epoch's
evidence by the same ``(1 − ρ)/(1 + ρ)``; with ``--declared`` too, twice). ``summary`` in
the JSON gathers each
series' seeds. The ``unknown`` case runs only when asked (``--cases``).

Each case runs with the tactical IMU (constrained INS/GNSS; the GNSS-only filter needs
fixes in a network run), with spawning
off (``NetworkNavConfig(spawn=False)``, today's behaviour for GNSS runs) and on. Figures
per run: the share of cycles whose most probable netelement is the true one, the true
netelement's probability at the last cycle (``final_true_probability``), the confident
cycles (``confident``: the most probable netelement's probability >= `CONFIDENT`), those of
them on a wrong netelement (``confident_wrong``) and those wrong or on the right one with
the truth beyond `CONFIDENT_SIGMAS` of the mixture's σ along it (``confident_beyond_3sigma``),
the time
from which the most probable netelement stays on the route with its along-track error
(along the route) below `RECOVERED_M` (``recovered_s``, None: never), the spawns and the
final along-track error.

``parallel`` runs on two networks: the 4.5 m spacing, and `WIDE_SPACING_M` (where one
epoch's single-point fix, σ ≈ 3-4 m per axis at σ_pr 3 m, tells the tracks apart).

Writes ``benchmarks/results/network_spawn_gnss.json`` (or ``--out``).
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

from railnav.filters.protocol import make_filter  # noqa: E402
from railnav.jobs.network import candidate_starts  # noqa: E402
from railnav.jobs.network_scoring import true_netelements  # noqa: E402
from railnav.navigation.network_config import NetworkNavConfig  # noqa: E402
from railnav.navigation.network_navigator import navigate_network  # noqa: E402
from railnav.navigation.network_start import NetworkStart  # noqa: E402
from railnav.simulation.profiles import constant_speed  # noqa: E402
from railnav.simulation.scenarios import get_scenario  # noqa: E402
from railnav.simulation.switch_network import (  # noqa: E402
    SwitchNetworkSpec,
    loop_route,
    route_track,
    switch_network,
)
from railnav.simulation.trip import navigator_config_for, simulate_trip  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402

RESULTS = REPO / "benchmarks" / "results" / "network_spawn_gnss.json"
SPEED_MPS, SIGMA_PR_M, TRIP_S, START_S_M = 20.0, 3.0, 120.0, 50.0
#: The along-track start errors of case ``along``, m (at 150 m the start's first update
#: pulls the hypothesis part of the way in; at 400 m it does not).
ALONG_ERRORS_M = (150.0, 400.0)
#: Recovered: the right netelement with an along-track error below this, m.
RECOVERED_M = 10.0
#: The second network's spacing of case ``parallel``, m.
WIDE_SPACING_M = 15.0
#: The filters run (the GNSS-only filter does not screen its rows: a network run without
#: fixes refuses it, `railnav.navigation.network_navigator`).
FILTERS = {"tactical": "constrained"}
#: The cases (module docstring).
CASES = ("along", "parallel", "right", "unknown")
#: A netelement reported with at least this probability is a confident one (issue 13).
CONFIDENT = 0.99
#: ... and its truth must be within this many of the mixture's σ along it, σ.
CONFIDENT_SIGMAS = 3.0
#: The told start netelement of each case (None: none told).
START_OF = {"along": "A0", "parallel": "B", "right": "A0", "unknown": None}


def _initial(along_m: float, base):
    """The wrong start (module docstring) from the truth brought onto each candidate
    (`base`), `along_m` ahead."""
    def initial(filt, element, orientation):
        init = base(filt, element, orientation)
        if init is None or not along_m:
            return init
        x0 = np.array(init.x0, dtype=float)
        x0[filt.layout.index("s")] += along_m * orientation
        return replace(init, x0=x0)
    return initial


def simulated(net, legs, seed: int, filter: str = "constrained", *,
              multipath: tuple[float, float] = (0.0, 60.0), declared: bool = False,
              filter_correlation: bool = False):
    """The trip of `seed` along `legs` (module docstring), its navigator settings and
    the candidates' truth starts (`candidate_starts`); `multipath`: the simulated code
    multipath's (σ m, τ s), the navigator told nothing of it unless `declared`
    (`declared_measurement`) or `filter_correlation` (that, and the filters told τ:
    ``NavigatorConfig.pseudorange_correlation_s`` = τ, ``_m`` = 0, the simulated errors
    correlated in time only)."""
    scenario = replace(get_scenario("curvy"), profile=constant_speed(SPEED_MPS),
                       duration_s=TRIP_S, outages=(), start_s=START_S_M,
                       sigma_pseudorange_m=SIGMA_PR_M, multipath_sigma_m=multipath[0],
                       multipath_tau_s=multipath[1])
    line = route_track(net, legs)
    config = navigator_config_for(scenario, filter=filter, systems="G")
    if declared or filter_correlation:
        config = replace(config, measurement=declared_measurement(config.measurement,
                                                                  multipath[0]))
    if filter_correlation:
        config = replace(config, pseudorange_correlation_s=multipath[1],
                         pseudorange_correlation_m=0.0)
    trip = simulate_trip(scenario, track=line, seed=seed, systems="G")
    return trip, config, candidate_starts(trip, config, make_filter(line, config, None))


def declared_measurement(measurement, multipath_sigma_m: float):
    """`measurement` with the simulated multipath's variance declared too: the additive σ
    model ``σ² = σ_pr² + σ_mp²/sin²(max(el, 5°))`` (`gnss_obs.epoch.measurement_sigmas`),
    the simulator's white and Gauss–Markov parts' variances (`gnss_obs.simulate`)."""
    return replace(measurement, sigma_model="additive", elevation_weighting=True,
                   sigma_pr_elevation_m=multipath_sigma_m)


def write(path: Path, scenario: dict, runs: list, load_before, **more) -> None:
    """The results file: the scenario, the runs, `more` (e.g. a summary), the machine and
    its load."""
    out = {"scenario": scenario, "runs": runs, **more,
           "machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                       "load_average_before": load_before,
                       "load_average_after": os.getloadavg()}}
    atomic_write_text(path, json.dumps(out, indent=2) + "\n")


def _run(net, legs, case: str, along_m: float, kind: str, spawn: bool, seed: int, *,
         multipath: tuple[float, float] = (0.0, 60.0), declared: bool = False,
         filter_correlation: bool = False) -> dict:
    trip, config, base = simulated(net, legs, seed, FILTERS[kind], multipath=multipath,
                                   declared=declared, filter_correlation=filter_correlation)
    nav = {"evidence_correlation_s": multipath[1]} if declared else {}
    started, wall = time.process_time(), time.perf_counter()
    res = navigate_network(net, trip.sensor_data(), config,
                           nav=NetworkNavConfig(spawn=spawn, **nav),
                           start=NetworkStart(START_OF[case], direction=1),
                           initial=_initial(along_m, base),
                           near=(float(trip.truth.lat[0]), float(trip.truth.lon[0])))
    cpu, wall = time.process_time() - started, time.perf_counter() - wall
    cyc = res.cycles
    truth_s = np.interp(res.time_s, trip.truth.time_s, trip.truth.s)
    truth = true_netelements(net, legs, truth_s)
    starts = dict(zip([e for e, _ in legs],
                      np.concatenate([[0.0], np.cumsum([net.length_m(e) for e, _ in legs])])))
    est = cyc["netelement"].to_numpy()
    right = est == truth
    # along the route (A's elements chained): a joint passed a cycle early is no error
    along = np.array([starts.get(e, np.nan) for e in est], dtype=float) + \
        cyc["netelement_offset_m"].to_numpy() - truth_s
    good = np.abs(np.nan_to_num(along, nan=np.inf)) < RECOVERED_M     # NaN: off the route
    bad = np.flatnonzero(~good)
    recovered = float(res.time_s[0]) if bad.size == 0 else \
        (float(res.time_s[bad[-1] + 1]) if bad[-1] + 1 < good.size else None)
    return {"case": case, "along_error_m": along_m, "imu": kind, "spawn": spawn, "seed": seed,
            "cycles": int(len(cyc)), "netelement_right": int(right.sum()),
            "share_netelement_right": float(right.mean()), "recovered_s": recovered,
            **_confidence(cyc, right, starts, truth_s),
            "final_along_error_m": None if not np.isfinite(along[-1]) else float(along[-1]),
            "final_netelement": str(est[-1]),
            "final_true_probability": float(res.element_probability[-1].get(truth[-1], 0.0)),
            "spawns": [list(sp) for sp in res.spawns], "navigator_cpu_s": cpu,
            "navigator_wall_s": wall}


def _confidence(cyc, right, starts: dict, truth_s) -> dict:
    """The confident cycles' figures (module docstring): how many, how many on a wrong
    netelement, how many wrong or with the truth beyond `CONFIDENT_SIGMAS` of the
    mixture's σ along the reported (right) netelement, and the first confident-wrong
    cycle's time (None: none)."""
    confident = cyc["netelement_probability"].to_numpy() >= CONFIDENT
    est = cyc["netelement"].to_numpy()
    error = np.array([starts.get(e, np.nan) for e in est], dtype=float) + \
        cyc["mixture_offset_m"].to_numpy() - truth_s
    beyond = ~right | ~(np.abs(error) <= CONFIDENT_SIGMAS * cyc["mixture_sigma_m"].to_numpy())
    wrong = np.flatnonzero(confident & ~right)
    return {"confident": int(confident.sum()), "confident_wrong": int(wrong.size),
            "confident_beyond_3sigma": int((confident & beyond).sum()),
            "first_confident_wrong_s": float(cyc["time_s"].iloc[wrong[0]]) if wrong.size
            else None}


def summary(runs: list) -> list:
    """Per series (multipath, declared, case, spacing, spawn), over its seeds: the share of
    cycles on the right netelement, the confident cycles and the share of them right (issue
    13: >= 0.99), the confident-wrong and beyond-3σ cycles, the runs recovered and their
    recovery times."""
    keys = ("multipath_sigma_m", "declared", "case", "along_error_m", "spacing_m", "spawn")
    groups: dict = {}
    for r in runs:
        groups.setdefault(tuple(r.get(k) for k in keys), []).append(r)
    out = []
    for key, rs in groups.items():
        cycles, confident = sum(r["cycles"] for r in rs), sum(r["confident"] for r in rs)
        wrong = sum(r["confident_wrong"] for r in rs)
        out.append({**dict(zip(keys, key)), "runs": len(rs), "cycles": cycles,
                    "share_right": sum(r["netelement_right"] for r in rs) / cycles,
                    "confident": confident, "confident_wrong": wrong,
                    "share_confident_right": (confident - wrong) / confident if confident
                    else None,
                    "confident_beyond_3sigma": sum(r["confident_beyond_3sigma"] for r in rs),
                    "runs_confident_wrong": sum(r["confident_wrong"] > 0 for r in rs),
                    "recovered_s": [r["recovered_s"] for r in rs]})
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES[:3]))
    parser.add_argument("--multipath-sigma", type=float, nargs="+", default=[0.0],
                        help="simulated multipath σ (m) of each series (0: none)")
    parser.add_argument("--multipath-tau", type=float, default=60.0,
                        help="its correlation time, s")
    parser.add_argument("--declared", action="store_true",
                        help="tell the navigator the multipath (`declared_measurement`, "
                        "NetworkNavConfig.evidence_correlation_s = τ)")
    parser.add_argument("--filter-correlation", action="store_true",
                        help="tell the filters τ and the rows' variance (module docstring)")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    load_before = os.getloadavg()
    runs = []
    cases = [("along", 4.5, a) for a in ALONG_ERRORS_M] + \
        [("parallel", 4.5, 0.0), ("parallel", WIDE_SPACING_M, 0.0), ("right", 4.5, 0.0),
         ("unknown", 4.5, 0.0)]
    cases = [c for c in cases if c[0] in args.cases]
    for sigma_m in args.multipath_sigma:
        multipath = (sigma_m, args.multipath_tau)
        for case, spacing, along_m in cases:
            spec = SwitchNetworkSpec(loops=2, spacing_m=spacing)
            net = switch_network(spec)
            legs = loop_route(spec, [False] * spec.loops)
            runs += [{"spacing_m": spacing, "multipath_sigma_m": sigma_m,
                      "multipath_tau_s": args.multipath_tau, "declared": args.declared,
                      **({"filter_correlation": True} if args.filter_correlation
                         and sigma_m > 0.0 else {}),
                      **_run(net, legs, case, along_m, kind, spawn, seed,
                             multipath=multipath, declared=args.declared,
                             filter_correlation=args.filter_correlation and sigma_m > 0.0)}
                     for kind in FILTERS for spawn in (False, True)
                     for seed in range(1, args.seeds + 1)]
    for r in runs:
        print(f"{r['case']:8s} {r['along_error_m']:5.0f} m {r['spacing_m']:4.1f} m "
              f"mp {r['multipath_sigma_m']:g} m {r['imu']} spawn={r['spawn']!s:5s} "
              f"seed {r['seed']}: "
              f"netelement right {r['share_netelement_right']:.3f}, recovered at "
              f"{r['recovered_s']} s, final along error {r['final_along_error_m']}, "
              f"P(true) at the end {r['final_true_probability']:.6f}, confident "
              f"{r['confident']} (wrong {r['confident_wrong']}, beyond 3σ "
              f"{r['confident_beyond_3sigma']}), spawns {len(r['spawns'])}, "
              f"{r['navigator_cpu_s']:.1f} s CPU")
    table = summary(runs)
    for g in table:
        print(f"mp {g['multipath_sigma_m']:g} m declared={g['declared']!s:5s} {g['case']:8s} "
              f"{g['along_error_m']:3.0f} m {g['spacing_m']:4.1f} m spawn={g['spawn']!s:5s}: "
              f"right {g['share_right']:.3f} of {g['cycles']} cycles; confident "
              f"{g['confident']}, wrong {g['confident_wrong']} (in {g['runs_confident_wrong']}"
              f"/{g['runs']} runs), beyond 3σ {g['confident_beyond_3sigma']}; recovered "
              f"{g['recovered_s']}")
    write(args.out, {"speed_mps": SPEED_MPS, "sigma_pr_m": SIGMA_PR_M, "trip_s": TRIP_S,
                     "along_errors_m": list(ALONG_ERRORS_M), "recovered_m": RECOVERED_M},
          runs, load_before, summary=table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
