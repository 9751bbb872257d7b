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
end to end = their sum; wall (``*_s``) and this process's CPU time (``*_cpu_s``: what a
shared machine's load does not inflate as much). The Brussels fix-only figure (< 2 s for
15 min) is in ``bench_network_brussels.py``.

``step_costs``: the compiled step of the constrained filter, CPU µs per step, on the
trip's first 100-sample chunk: ``scalar``, one member as a single filter steps
(`ekf.propagate.Propagator.run`: CasADi's code, every per-step output written), and
``members``, 8 members in one call as the bank steps them
(`ekf.propagate.Propagator.run_members`: 4 lanes, innovations and their covariance
kept); alternated, median of the rounds.

Writes ``benchmarks/results/network_speed.json``.
"""
from __future__ import annotations

import argparse
import json
import statistics
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

from railnav.blas_threads import one_blas_thread  # noqa: E402

one_blas_thread()       # before NumPy: the runs are timed as the CLI runs them

from railnav.jobs.network import run_simulated_network, write_network_run  # noqa: E402
from railnav.navigation.network_config import NetworkNavConfig  # noqa: E402
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


def _navigator_cpu(run_network):
    """`run_network()` with the CPU time of `navigate_network` in it measured: the run's
    outcome and those seconds."""
    import railnav.jobs.network as jobs_network
    inner = jobs_network.navigate_network
    spent = []

    def timed(*args, **kwargs):
        start = time.process_time()
        try:
            return inner(*args, **kwargs)
        finally:
            spent.append(time.process_time() - start)
    jobs_network.navigate_network = timed
    try:
        return run_network(), sum(spent)
    finally:
        jobs_network.navigate_network = inner


def _timed(net, base, scenario, nav) -> dict:
    started, cpu_started = time.perf_counter(), time.process_time()
    run, navigate_cpu = _navigator_cpu(lambda: run_simulated_network(
        net, [(f"T{TRUE_INDEX}", 1)], scenario, line=base, seed=1, nav=nav))
    total, total_cpu = time.perf_counter() - started, time.process_time() - cpu_started
    res = run.network_result
    with tempfile.TemporaryDirectory() as tmp:
        w0, c0 = time.perf_counter(), time.process_time()
        write_network_run(run, tmp, plots=False)
        write_s, write_cpu = time.perf_counter() - w0, time.process_time() - c0
    navigate_s = res.runtime_s
    e2e, e2e_cpu = total + write_s, total_cpu + write_cpu
    trip = float(scenario.duration_s)
    return {"navigator_s": navigate_s, "simulation_and_setup_s": total - navigate_s,
            "write_s": write_s, "end_to_end_s": e2e,
            "real_time_factor_end_to_end": trip / e2e,
            "real_time_factor_navigator": trip / navigate_s,
            "navigator_cpu_s": navigate_cpu, "end_to_end_cpu_s": e2e_cpu,
            "real_time_factor_end_to_end_cpu": trip / e2e_cpu,
            "real_time_factor_navigator_cpu": trip / navigate_cpu,
            "hypotheses_max": int(res.cycles["hypotheses"].max()),
            "hypotheses_median": float(res.cycles["hypotheses"].median()),
            "final_netelement": res.cycles["netelement"].iloc[-1],
            "final_probability": float(res.cycles["netelement_probability"].iloc[-1])}


def _step_costs(base, scenario, rounds: int = 7, calls: int = 20) -> dict:
    """CPU µs per step of the constrained filter's compiled step, one member as a single
    filter steps and `HYPOTHESES` members in one call (module docstring)."""
    import numpy as np

    from ekf.cd_filter import step_data
    from ekf.packing import pack_sym
    from ekf.series import InputSeries
    from ekf.step import window_median_at
    from railnav.filters.protocol import make_filter
    from railnav.jobs.run import truth_start
    from railnav.navigation.hypothesis_step import CONTINUOUS_OUTPUTS
    from railnav.navigation.loop import filter_engine
    from railnav.navigation.navigator import trip_samples
    from railnav.simulation.trip import navigator_config_for, simulate_trip

    short = replace(scenario, duration_s=10.0)
    trip = simulate_trip(short, track=base, seed=1)
    config = navigator_config_for(short)
    filt = make_filter(base, config, None)
    start = truth_start(filt, trip, config)
    samples = trip_samples(trip.sensor_data(), config)
    t, u = samples.t[:101], samples.u[:101]
    engine = filter_engine(filt, config, sample_interval_s=float(np.median(np.diff(t))))
    prop = engine.propagator
    u_c, p, r_c = filt.inputs(t, u, start.x0, start.P0, float(t[0]))
    window = prop.data.jacobian_window_s
    series = InputSeries(t=t, u=u_c, p=p, q_c=filt.step_q_c, r_c=r_c,
                         u_lin=window_median_at(samples.t, samples.u, 0, t.size, window)
                         if window > 0.0 else None)
    d = step_data(prop, series.shaped(prop.model.n_u, prop.model.n_p, prop.model.n_c,
                                      prop.model.n_w))
    x0, P0 = start.x0, pack_sym(start.P0)
    xs, Ps, ds = (np.repeat(a[None], HYPOTHESES, axis=0) for a in (x0, P0, d))
    prop.run(x0, P0, d)
    prop.run_members(xs, Ps, ds, CONTINUOUS_OUTPUTS)           # builds, compiles
    per_step = {"scalar": [], "members": []}
    for _ in range(rounds):
        c0 = time.process_time()
        for _ in range(calls * HYPOTHESES):
            prop.run(x0, P0, d)
        per_step["scalar"].append((time.process_time() - c0) / (calls * HYPOTHESES * len(d)))
        c0 = time.process_time()
        for _ in range(calls):
            prop.run_members(xs, Ps, ds, CONTINUOUS_OUTPUTS)
        per_step["members"].append((time.process_time() - c0) / (calls * HYPOTHESES * len(d)))
    return {"states": int(prop.model.n), "instructions": int(prop.step.n_instructions()),
            "chunk_steps": int(len(d)), "members": HYPOTHESES, "rounds": rounds,
            **{f"{k}_cpu_us_per_step": 1e6 * statistics.median(v)
               for k, v in per_step.items()},
            **{f"{k}_cpu_us_rounds": [1e6 * x for x in v] for k, v in per_step.items()}}


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
           "step_costs": _step_costs(base, scenario),
           "targets": {"end_to_end_x": 300.0, "navigator_x": 1000.0},
           "machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                       "openblas_num_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
                       "load_average_before": load_before}}
    out["machine"]["load_average_after"] = os.getloadavg()
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    for name in ("kept", "pruned"):
        r = out[name]
        print(f"{name}: {r['hypotheses_max']} hypotheses max: navigator {r['navigator_s']:.1f} s "
              f"= {r['real_time_factor_navigator']:.0f}x, end to end {r['end_to_end_s']:.1f} s "
              f"= {r['real_time_factor_end_to_end']:.0f}x; CPU: navigator "
              f"{r['navigator_cpu_s']:.1f} s = {r['real_time_factor_navigator_cpu']:.0f}x, end "
              f"to end {r['end_to_end_cpu_s']:.1f} s = {r['real_time_factor_end_to_end_cpu']:.0f}"
              f"x; final {r['final_netelement']} {r['final_probability']:.4f}")
    c = out["step_costs"]
    print(f"compiled step ({c['states']} states, {c['instructions']} instructions): one member "
          f"{c['scalar_cpu_us_per_step']:.2f} us, {c['members']} members in one call "
          f"{c['members_cpu_us_per_step']:.2f} us per member and step (CPU)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
