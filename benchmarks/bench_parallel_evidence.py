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

``--multipath-sigma`` adds series with code multipath simulated (`Scenario.
multipath_sigma_m`, τ ``--multipath-tau``: a Gauss–Markov bias per satellite, σ/sin(el)).
The LLR's expectation is then the same K (the weights' statistic is linear in the errors),
but its variance is the errors' long-run one, ``Σ_k σ_pr² ‖W r_k‖² + Σ_jk (W r_j)ᵀ C_jk
(W r_k)`` with the multipath's covariance ``C_jk = diag(σ_mp² e^{−|t_j − t_k|/τ}/(sin el_j
sin el_k))`` over the satellites seen at both epochs (``llr_sigma_expected_multipath``;
white: ``√(2K)``), ``r`` the residual direction and ``W`` the navigator's declared inverse
variances. With
``--declared`` the navigator is told the multipath (``bench_network_spawn_gnss.
declared_measurement``: each row's variance σ_pr² + σ_mp²/sin²el, and
``NetworkNavConfig.evidence_correlation_s`` = τ): each epoch's evidence then counts
``c = (1 − ρ)/(1 + ρ)`` (`railnav.navigation.hypotheses.evidence_share`), and the LLR's
expectation and σ are ``c K`` and ``c σ`` (``llr_expected_declared``). With
``--filter-correlation`` the filters are told τ (``NavigatorConfig.
pseudorange_correlation_s`` = τ, the row variances declared as with ``--declared``): their
pseudorange variances are inflated by ``1/c`` (`railnav.filters.gnss_only_noise.
pseudorange_inflation`), which scales the LLR by ``c`` already; with ``--declared`` as
well the evidence counts ``c`` on top (``c²`` in all: the same discount twice).
``--first-seed`` runs seeds from K.

Writes ``benchmarks/results/parallel_evidence.json`` (or ``--out``).
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_network_spawn_gnss as trips  # noqa: E402
from railnav.jobs.network_scoring import true_netelements  # noqa: E402
from railnav.navigation.hypotheses import evidence_share  # noqa: E402
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
    return np.array([k for k, _, _ in _snapshots(trip, spacing_m, sigma_m, 0.0)])


def _snapshots(trip, spacing_m: float, sigma_m: float, declared_mp_m: float):
    """Per epoch: ``½ rᵀ W r`` (nats), the weighted residual direction ``W r`` (1/m) by
    satellite, and the satellites' ``1/sin(max(el, 5°))``; W the navigator's declared
    inverse variances (``σ_pr² + declared_mp_m²/sin²el``; module docstring)."""
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
        inv_sin = 1.0 / np.sin(np.maximum(el, np.radians(5.0)))
        var = sigma_m ** 2 + (declared_mp_m * inv_sin) ** 2
        w_rel = var.min() / var                 # 1 without multipath declared: the
        H = np.stack([e @ t, np.ones(el.size)], axis=1)       # plain projection's bits
        delta = spacing_m * (e @ n)
        sw = np.sqrt(w_rel)
        r = delta - H @ np.linalg.lstsq(H * sw[:, None], delta * sw, rcond=None)[0]
        out.append((0.5 * float(r @ (w_rel * r)) / var.min(),
                    dict(zip(epoch["sv"], r / var)), dict(zip(epoch["sv"], inv_sin))))
    return out


def llr_moments(trip, spacing_m: float, sigma_m: float, multipath: tuple[float, float],
                declared_mp_m: float = 0.0) -> tuple[float, float]:
    """The expectation (K, nats) and σ of the weights' LLR of the true track over the one
    `spacing_m` to its left at the end of `trip`, in the snapshot approximation (module
    docstring): white rows σ_pr = `sigma_m` plus the simulated multipath (σ_mp m, τ s);
    the navigator's declared variances with `declared_mp_m`'s elevation term."""
    snaps = _snapshots(trip, spacing_m, sigma_m, declared_mp_m)
    K = sum(k for k, _, _ in snaps)
    var = sum(sigma_m ** 2 * float(np.sum(np.square(list(wr.values())))) for _, wr, _ in snaps)
    mp_m, tau_s = multipath
    if mp_m > 0.0:
        times = np.array(sorted(trip.gnss.satellites["gps_time_s"].unique()))
        rho = np.exp(-np.abs(times[:, None] - times[None, :]) / tau_s)
        for sv in trip.gnss.satellites["sv"].unique():
            a = np.array([wr.get(sv, 0.0) * mp_m * inv.get(sv, 0.0) for _, wr, inv in snaps])
            var += float(a @ rho @ a)
    return K, float(np.sqrt(var))


def _run(net, legs, seed: int, multipath: tuple[float, float] = (0.0, 60.0),
         declared: bool = False, filter_correlation: bool = False) -> dict:
    trip, config, initial = trips.simulated(net, legs, seed, multipath=multipath,
                                            declared=declared,
                                            filter_correlation=filter_correlation)
    nav = NetworkNavConfig(spawn=False, crossing_rate_per_s=0.0, prune_probability=0.0,
                           evidence_correlation_s=multipath[1] if declared else 0.0)
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
    extra = {}
    if multipath[0] > 0.0:
        told = declared or filter_correlation
        mean, sigma = llr_moments(trip, SPACING_M, trips.SIGMA_PR_M, multipath,
                                  multipath[0] if told else 0.0)
        share = evidence_share(replace(nav, evidence_correlation_s=multipath[1]),
                               1.0 / trip.scenario.gnss_rate_hz)
        c = (share if declared else 1.0) * (share if filter_correlation else 1.0)
        extra = {"multipath_sigma_m": multipath[0], "multipath_tau_s": multipath[1],
                 "declared": declared, "filter_correlation": filter_correlation,
                 "llr_expected": c * mean,
                 "llr_sigma_expected_multipath": c * sigma}
    return {"seed": seed, **extra, "epochs": epochs, "end_s": float(res.time_s[-1]),
            "llr_at_s": at, "llr_end": float(llr[-1]), "llr_min": float(llr.min()),
            "llr_min_at_s": float(res.time_s[int(np.argmin(llr))]),
            "llr_per_epoch": float(llr[-1] / max(epochs, 1)),
            "snapshot_divergence_total": float(K.sum()),
            "snapshot_divergence_per_epoch": float(K.mean()),
            "llr_sigma_expected": float(np.sqrt(2.0 * K.sum()))}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--multipath-sigma", type=float, nargs="+", default=[0.0],
                        help="simulated multipath σ (m) of each series (0: none)")
    parser.add_argument("--multipath-tau", type=float, default=60.0,
                        help="its correlation time, s")
    parser.add_argument("--declared", action="store_true",
                        help="tell the navigator the multipath (module docstring)")
    parser.add_argument("--filter-correlation", action="store_true",
                        help="tell the filters τ and the rows' variance (module docstring)")
    parser.add_argument("--first-seed", type=int, default=1, help="the first seed")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    load_before = os.getloadavg()
    spec = SwitchNetworkSpec(loops=2, spacing_m=SPACING_M)
    net = switch_network(spec)
    legs = loop_route(spec, [False] * spec.loops)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    runs = [_run(net, legs, seed, (sigma_m, args.multipath_tau),
                 args.declared and sigma_m > 0.0, args.filter_correlation and sigma_m > 0.0)
            for sigma_m in args.multipath_sigma for seed in seeds]
    for r in runs:
        if "multipath_sigma_m" in r:
            print(f"multipath {r['multipath_sigma_m']:g} m (declared {r['declared']}, "
                  f"filters told τ {r['filter_correlation']}): "
                  f"expected LLR {r['llr_expected']:+.1f} ± "
                  f"{r['llr_sigma_expected_multipath']:.1f}")
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
