"""Multimodal ``s`` (issue 13's acceptance): a long GNSS outage on ``curvy``, the Gaussian
sum along the track against today's single filter.

Usage::

    python benchmarks/bench_network_outage.py [--seeds 20] [--mems-seeds 20]

``curvy`` (its speed profile and sensors, GPS) as a one-element network; the network
navigator (`railnav.jobs.network.run_simulated_network`, constrained INS/GNSS; the
Gaussian sum of `railnav.navigation.s_split`) and the single filter
(`railnav.jobs.run.run_simulated`) on the same trips (same seed: same truth and sensor
errors):

* ``tactical``: the tactical IMU, an outage of 20 min from 60 s, ``--seeds`` seeds;
* ``mems``: the MEMS IMU, an outage of 300 s from 60 s.

Per run, at the outage's end (the last record before GNSS is back): the truth's ``s``; the mixture's 99 % interval (the 0.5 %
and 99.5 % quantiles of the Gaussian mixture of all live hypotheses) and whether the
truth lies in it; the most probable hypothesis's error and σ; the single filter's error
and σ. Over the run, from ``hypotheses.csv`` (once a second): the largest ``|error|/σ``
of a hypothesis reported with P > 0.99 ("confidently wrong" when > 3), the seconds
with P > 0.99 (the denominator), how many of the confidently wrong seconds had one live
hypothesis only (its P is 1 by construction: the figure is then the filter's own 3σ
consistency, which a consistent filter misses on 0.27 % of its epochs,
``confidently_wrong_expected_if_consistent_s``), how many were > 5σ, the episodes
(``confidently_wrong_episodes``: first and last second, seconds, largest ``|error|/σ``;
seconds at most `EPISODE_GAP_S` apart are one episode), and the spawns
(`railnav.navigation.spawning`; none expected: these runs have no position fixes). Per
case, over all seconds with P > 0.99: the share with ``|error|/σ`` beyond 2, 2.5 and 3
against a Gaussian's (``share_beyond_sigma``, ``gaussian_share_beyond_sigma``) and the
mean ``(error/σ)²`` (1 for a consistent filter): whether the misses are the tail of a
consistent filter or a mechanism.

Writes ``benchmarks/results/network_outage.json``.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import brentq
from scipy.stats import norm

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from railnav.jobs.network import run_simulated_network  # noqa: E402
from railnav.jobs.run import run_simulated  # noqa: E402
from railnav.navigation.network_config import NetworkNavConfig  # noqa: E402
from railnav.simulation.scenarios import get_scenario  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402
from trackmodel.io import read_track  # noqa: E402
from trackmodel.network import Network  # noqa: E402

RESULTS = REPO / "benchmarks" / "results" / "network_outage.json"
TRACK = REPO / "data" / "tracks" / "curvy.csv"
OUTAGE_START_S, AFTER_S = 60.0, 40.0
CASES = {"tactical": ("tactical", 1200.0), "mems": ("mems", 300.0)}
#: P(|z| > 3) of a Gaussian: the share of epochs a consistent filter has its truth more
#: than 3σ away; with one live hypothesis (P = 1) that is all "confidently wrong" can be.
CONSISTENT_TAIL_3SIGMA = float(2.0 * norm.sf(3.0))
#: ``|error|/σ`` levels of the tail shares (module docstring).
TAIL_SIGMAS = (2.0, 2.5, 3.0)
#: Confidently wrong seconds at most this far apart are one episode, s.
EPISODE_GAP_S = 2.0


def mixture_interval(w, mean, sigma, level: float = 0.99) -> tuple[float, float]:
    """The central `level` interval of a Gaussian mixture (quantiles by root finding)."""
    w, mean, sigma = (np.asarray(a, dtype=float) for a in (w, mean, sigma))
    w = w / w.sum()

    def cdf(x: float) -> float:
        return float(w @ norm.cdf((x - mean) / sigma))

    lo_b, hi_b = float(np.min(mean - 10 * sigma)), float(np.max(mean + 10 * sigma))
    tail = 0.5 * (1.0 - level)
    return (brentq(lambda x: cdf(x) - tail, lo_b, hi_b),
            brentq(lambda x: cdf(x) - (1.0 - tail), lo_b, hi_b))


def episodes(times_s, z, gap_s: float = EPISODE_GAP_S) -> list[list[float]]:
    """``[first_s, last_s, seconds, max z]`` of each run of `times_s` (sorted) whose
    neighbours are at most `gap_s` apart."""
    out: list[list[float]] = []
    for t, zz in zip(times_s, z):
        if out and t - out[-1][1] <= gap_s:
            out[-1][1], out[-1][2], out[-1][3] = float(t), out[-1][2] + 1, max(out[-1][3],
                                                                               float(zz))
        else:
            out.append([float(t), float(t), 1, float(zz)])
    return out


def _at(h, time_s: float):
    """The hypotheses of the last record before `time_s` (before GNSS is back)."""
    times = h["time_s"].to_numpy()
    near = times[times < time_s - 1e-6].max()
    return h[h["time_s"] == near]


def _run(track, grade: str, outage_s: float, seed: int, nav) -> dict:
    scenario = get_scenario("curvy").with_overrides(
        duration_s=OUTAGE_START_S + outage_s + AFTER_S, imu_errors=grade,
        outages=[(OUTAGE_START_S, outage_s)])
    net = Network({"curvy": track}, [])
    started = time.perf_counter()
    run = run_simulated_network(net, [("curvy", 1)], scenario, line=track, seed=seed, nav=nav)
    wall = time.perf_counter() - started
    truth = run.outcome.trip.truth
    h = run.network_result.hypotheses
    end = OUTAGE_START_S + outage_s
    last = _at(h, end)
    s_true = float(np.interp(float(last["time_s"].iloc[0]), truth.time_s, truth.s))
    lo, hi = mixture_interval(last["probability"], last["s_m"], last["sigma_s_m"])
    best = last.loc[last["probability"].idxmax()]
    truth_h = np.interp(h["time_s"].to_numpy(), truth.time_s, truth.s)
    z = np.abs(h["s_m"].to_numpy() - truth_h) / h["sigma_s_m"].to_numpy()
    sure = h["probability"].to_numpy() > 0.99
    live = h.groupby("time_s")["id"].transform("size").to_numpy()
    wrong = sure & (z > 3.0)
    single = run_simulated(track, scenario, seed=seed)
    est = single.result.estimates
    k = int(np.flatnonzero(est["time_s"].to_numpy() < end - 1e-6)[-1])   # before GNSS
    return {"seed": seed, "truth_s_m": s_true, "interval_m": [lo, hi],
            "truth_inside_99": bool(lo <= s_true <= hi),
            "components_at_end": int(len(last)), "best_error_m": float(best["s_m"] - s_true),
            "best_sigma_m": float(best["sigma_s_m"]), "best_probability":
                float(best["probability"]),
            "max_z_confident": float(np.max(z[sure])) if sure.any() else None,
            "confidently_wrong_seconds": int(np.sum(sure & (z > 3.0))),
            "confident_seconds": int(np.sum(sure)),
            "confidently_wrong_alone_seconds": int(np.sum(sure & (z > 3.0) & (live == 1))),
            "confidently_wrong_5sigma_seconds": int(np.sum(sure & (z > 5.0))),
            "confidently_wrong_episodes": episodes(h["time_s"].to_numpy()[wrong], z[wrong]),
            "confident_beyond": {str(k): int(np.sum(sure & (z > k))) for k in TAIL_SIGMAS},
            "confident_sum_z2": float(np.sum(z[sure] ** 2)),
            "spawns": len(run.network_result.spawns),
            "hypotheses_max": int(run.network_result.cycles["hypotheses"].max()),
            "restarts": list(run.network_result.restarts),
            "single_error_m": float(single.errors.along_track_m[k]),
            "single_sigma_m": float(est["sigma_s_m"].iloc[k]), "wall_s": wall}


def _tails(runs: list[dict]) -> dict:
    """The tail shares and mean ``(error/σ)²`` of all confident seconds of `runs`, and a
    Gaussian's shares (module docstring)."""
    n = sum(r["confident_seconds"] for r in runs)
    if not n:
        return {}
    return {"share_beyond_sigma": {str(k): sum(r["confident_beyond"][str(k)] for r in runs)
                                   / n for k in TAIL_SIGMAS},
            "gaussian_share_beyond_sigma": {str(k): float(2.0 * norm.sf(k))
                                            for k in TAIL_SIGMAS},
            "mean_z2_confident": sum(r["confident_sum_z2"] for r in runs) / n}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--mems-seeds", type=int, default=20)
    parser.add_argument("--max-hypotheses", type=int, default=16)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    track = read_track(TRACK)
    nav = NetworkNavConfig(max_hypotheses=args.max_hypotheses)
    load_before = os.getloadavg()
    out = {"nav": {"max_hypotheses": nav.max_hypotheses, "split_sigma_m": nav.split_sigma_m,
                   "split_accel_mps2": nav.split_accel_mps2,
                   "prune_probability": nav.prune_probability}}
    for case, seeds in (("tactical", args.seeds), ("mems", args.mems_seeds)):
        grade, outage = CASES[case]
        runs = [_run(track, grade, outage, seed, nav) for seed in range(1, seeds + 1)]
        inside = float(np.mean([r["truth_inside_99"] for r in runs])) if runs else None
        out[case] = {"imu": grade, "outage_s": outage, "share_truth_inside_99": inside,
                     "confidently_wrong_seconds": sum(r["confidently_wrong_seconds"]
                                                      for r in runs),
                     **{key: sum(r[key] for r in runs) for key in (
                         "confident_seconds", "confidently_wrong_alone_seconds",
                         "confidently_wrong_5sigma_seconds", "spawns")},
                     "confidently_wrong_expected_if_consistent_s":
                         CONSISTENT_TAIL_3SIGMA * sum(r["confident_seconds"] for r in runs),
                     **_tails(runs),
                     "median_abs_best_error_m": float(np.median(
                         [abs(r["best_error_m"]) for r in runs])) if runs else None,
                     "median_abs_single_error_m": float(np.median(
                         [abs(r["single_error_m"]) for r in runs])) if runs else None,
                     "runs": runs}
        if runs:
            print(f"{case}: truth inside the mixture's 99 % interval in {inside:.0%} of "
                  f"{seeds}; confidently wrong {out[case]['confidently_wrong_seconds']} s "
                  f"of {out[case]['confident_seconds']} s with P > 0.99 ("
                  f"{out[case]['confidently_wrong_alone_seconds']} s alone, "
                  f"{out[case]['confidently_wrong_5sigma_seconds']} s > 5σ; a consistent "
                  f"filter: {out[case]['confidently_wrong_expected_if_consistent_s']:.0f} s); "
                  f"median |error| {out[case]['median_abs_best_error_m']:.1f} m (single "
                  f"filter {out[case]['median_abs_single_error_m']:.1f} m); with P > 0.99 "
                  "beyond 2/2.5/3σ: " + "/".join(f"{100 * v:.2f}" for v in
                                                out[case]["share_beyond_sigma"].values())
                  + " % (Gaussian " + "/".join(f"{100 * v:.2f}" for v in
                                              out[case]["gaussian_share_beyond_sigma"]
                                              .values())
                  + f" %), mean z² {out[case]['mean_z2_confident']:.2f}")
    out["machine"] = {"python": platform.python_version(), "cpus": os.cpu_count(),
                      "load_average_before": load_before, "load_average_after": os.getloadavg()}
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
