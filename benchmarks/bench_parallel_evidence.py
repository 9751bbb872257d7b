"""Can a GNSS run tell two parallel tracks 4.5 m apart? The log-likelihood ratio over time.

Usage::

    python benchmarks/bench_parallel_evidence.py [--seeds 5] [--out FILE]

The trips of `bench_network_spawn_gnss.py` (double line A/B 4.5 m apart, route along A,
20 m/s, curvy's sensors, σ_pr 3 m GPS: white pseudorange errors, no multipath, the
atmosphere removed exactly, `gnss_obs.simulate`), navigated with both A and B as start
hypotheses of equal prior (no start netelement given, every one near the true start),
no crossing prior (ε = 0: no mixing between the tracks), no pruning and no spawning: the
difference of the cumulated log-likelihoods of the true netelement and B
(`NetworkResult.element_log_likelihood`, the weights' own evidence) is the LLR of A over
B. Per seed: the LLR at `MARKS_S`, its rate per epoch, and the closed-form lower bound of
its expectation, the snapshot divergence ``K = Σ ½‖P⊥ δ‖²/σ²`` (each epoch's along-track
position and clock free; ``δ_i = d e_i·n`` from the simulator's satellite elevations and
azimuths, ``n`` the track's left normal from the truth's velocity; the LLR's standard
deviation is about ``√(2K)``).

Writes ``benchmarks/results/parallel_evidence.json`` (or ``--out``).
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_network_spawn_gnss as trips  # noqa: E402
from railnav.jobs.network import true_netelements  # noqa: E402
from railnav.navigation.network_config import NetworkNavConfig  # noqa: E402
from railnav.navigation.network_navigator import navigate_network  # noqa: E402
from railnav.navigation.network_start import NetworkStart  # noqa: E402
from railnav.simulation.switch_network import (  # noqa: E402
    SwitchNetworkSpec,
    loop_route,
    switch_network,
)

RESULTS = REPO / "benchmarks" / "results" / "parallel_evidence.json"
SPACING_M = 4.5
#: Times at which the LLR is reported, s from the start.
MARKS_S = (1, 2, 5, 10, 20, 30, 60, 90)


def snapshot_divergence(trip, spacing_m: float, sigma_m: float) -> np.ndarray:
    """Each epoch's ``½‖P⊥ δ‖²/σ²`` (module docstring), nats."""
    sats = trip.gnss.satellites
    t0 = trip.scenario.start_gps_time_s
    out = []
    for gps_time_s, epoch in sats.groupby("gps_time_s"):
        v = np.array([np.interp(gps_time_s - t0, trip.truth.time_s, trip.truth.v_n[:, k])
                      for k in range(2)])
        t = v / np.linalg.norm(v)
        n = np.array([-t[1], t[0]])
        el = np.radians(epoch["elevation_deg"].to_numpy())
        az = np.radians(epoch["azimuth_deg"].to_numpy())
        e = np.stack([np.cos(el) * np.sin(az), np.cos(el) * np.cos(az)], axis=1)
        H = np.stack([e @ t, np.ones(el.size)], axis=1)
        delta = spacing_m * (e @ n)
        r = delta - H @ np.linalg.lstsq(H, delta, rcond=None)[0]
        out.append(0.5 * float(r @ r) / sigma_m ** 2)
    return np.array(out)


def _run(net, legs, seed: int) -> dict:
    trip, config, initial = trips.simulated(net, legs, seed)
    nav = NetworkNavConfig(spawn=False, crossing_rate_per_s=0.0, prune_probability=0.0)
    res = navigate_network(net, trip.sensor_data(), config, nav=nav,
                           start=NetworkStart(None, direction=1), initial=initial,
                           near=(float(trip.truth.lat[0]), float(trip.truth.lon[0])))
    truth = true_netelements(net, legs, np.interp(res.time_s, trip.truth.time_s, trip.truth.s))
    step = [ll[e] - ll["B"] if e in ll and "B" in ll else 0.0
            for e, ll in zip(truth, res.element_log_likelihood)]
    llr = np.cumsum(step)
    at = {str(m): float(llr[min(int(np.searchsorted(res.time_s, m)), llr.size - 1)])
          for m in MARKS_S}
    K = snapshot_divergence(trip, SPACING_M, trips.SIGMA_PR_M)
    epochs = int(res.cycles["evidence_rows"].gt(0).sum())
    return {"seed": seed, "epochs": epochs, "end_s": float(res.time_s[-1]),
            "llr_at_s": at, "llr_end": float(llr[-1]), "llr_min": float(llr.min()),
            "llr_min_at_s": float(res.time_s[int(np.argmin(llr))]),
            "llr_per_epoch": float(llr[-1] / max(epochs, 1)),
            "snapshot_divergence_total": float(K.sum()),
            "snapshot_divergence_per_epoch": float(K.mean()),
            "llr_sigma_expected": float(np.sqrt(2.0 * K.sum()))}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    load_before = os.getloadavg()
    spec = SwitchNetworkSpec(loops=2, spacing_m=SPACING_M)
    net = switch_network(spec)
    legs = loop_route(spec, [False] * spec.loops)
    runs = [_run(net, legs, seed) for seed in range(1, args.seeds + 1)]
    for r in runs:
        print(f"seed {r['seed']}: LLR(A−B) " +
              " ".join(f"{m} s {v:+.1f}" for m, v in r["llr_at_s"].items()) +
              f", end ({r['end_s']:.0f} s, {r['epochs']} epochs) {r['llr_end']:+.1f} "
              f"({r['llr_per_epoch']:.2f}/epoch), lowest {r['llr_min']:+.1f} at "
              f"{r['llr_min_at_s']:.0f} s; snapshot K {r['snapshot_divergence_total']:.1f} "
              f"± {r['llr_sigma_expected']:.1f}")
    trips.write(args.out, {"speed_mps": trips.SPEED_MPS, "sigma_pr_m": trips.SIGMA_PR_M,
                           "trip_s": trips.TRIP_S, "spacing_m": SPACING_M}, runs, load_before)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
