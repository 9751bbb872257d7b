"""The constrained filter's yaw on a level straight, against the closed form (issue 14, part 4:
the 10-h trip's yaw overconfidence).

Usage::

    nice -n 10 python benchmarks/bench_yaw_straight.py [--seeds N] [--duration-s T]
                                                       [--out FILE]

A level straight heading east at 20 m/s from the start (`tests.support.straight_yaw`),
tactical IMU (the filter assumes the simulated grade), GNSS all the way, 890 s, seeds 1..N
(default 4). On it nothing observes the yaw: its σ must follow the closed-form propagation
of the yaw and the z-gyro bias from the filter's own densities and initial σ
(`tests.support.straight_yaw.straight_yaw_covariance`; its docstring gives the derivation
and the assumptions). Each seed runs twice: with the pseudo-observation's Jacobian at the
raw IMU sample (``JACOBIAN_WINDOW_S = 0``, the code before the fix) and at the 0.5-s
running median (`railnav.filters.common.JACOBIAN_WINDOW_S`, the default). Per run: σ_yaw
and σ(b_gz) at the end, the mean z² of the yaw over the run, the NEES mean, CPU time.

Writes ``benchmarks/results/yaw_straight.json``.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path
from unittest import mock

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import railnav.navigation.loop as loop  # noqa: E402
from railnav.filters.common import JACOBIAN_WINDOW_S  # noqa: E402
from railnav.filters.constrained import ConstrainedFilter  # noqa: E402
from railnav.jobs.run import run_simulated  # noqa: E402
from railnav.simulation.trip import navigator_config_for  # noqa: E402
from tests.support.straight_yaw import (filter_yaw_densities, straight_scenario,  # noqa: E402
                                        straight_track, straight_yaw_covariance)
from trackmodel.files import atomic_write_text  # noqa: E402

RESULTS = HERE / "results" / "yaw_straight.json"
DEG_PER_HOUR = math.radians(1.0) / 3600.0  # rad/s


def _run(track, scenario, config, seed: int, window_s: float) -> dict:
    """One run with the Jacobian window `window_s` (s; patched into the chunk loop)."""
    started = time.process_time()
    with mock.patch.object(loop, "JACOBIAN_WINDOW_S", window_s):
        out = run_simulated(track, scenario, config=config, seed=seed)
    cpu_s = time.process_time() - started
    est = out.result.estimates
    sigma_yaw = np.radians(est["sigma_yaw_deg"].to_numpy())
    z_yaw = out.errors.yaw_rad / sigma_yaw
    t = est["time_s"].to_numpy()
    return {"seed": seed, "t_end_s": float(t[-1] - t[0]),
            "sigma_yaw_end_mrad": 1e3 * float(sigma_yaw[-1]),
            "sigma_b_gz_end_deg_per_h":
                float(est["sigma_gyro_bias_z_radps"].to_numpy()[-1]) / DEG_PER_HOUR,
            "yaw_error_end_mrad": 1e3 * float(out.errors.yaw_rad[-1]),
            "yaw_mean_z2": float(np.nanmean(z_yaw ** 2)),
            "nees_mean": float(np.nanmean(out.errors.nees)), "cpu_s": cpu_s}


def _mean(runs: list[dict], key: str) -> float:
    return float(np.mean([r[key] for r in runs]))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--duration-s", type=float, default=890.0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    if args.seeds < 1 or not args.duration_s > 0:
        print("error: --seeds must be >= 1 and --duration-s > 0", file=sys.stderr)
        return 2
    track, scenario = straight_track(args.duration_s), straight_scenario(args.duration_s)
    config = navigator_config_for(scenario)
    densities = filter_yaw_densities(ConstrainedFilter(track, config), config)
    load_before = os.getloadavg()
    cases = {}
    for name, window_s in (("raw_sample", 0.0), ("median_window", JACOBIAN_WINDOW_S)):
        runs = [_run(track, scenario, config, seed, window_s)
                for seed in range(1, args.seeds + 1)]
        cases[name] = {"jacobian_window_s": window_s, "runs": runs,
                       **{f"mean_{k}": _mean(runs, k) for k in
                          ("sigma_yaw_end_mrad", "sigma_b_gz_end_deg_per_h",
                           "yaw_mean_z2", "nees_mean", "cpu_s")}}
    t_end = cases["median_window"]["runs"][0]["t_end_s"]   # the last stored estimate
    P = straight_yaw_covariance(t_end, **densities)
    closed = {"t_s": t_end, "sigma_yaw_mrad": 1e3 * math.sqrt(P[0, 0]),
              "sigma_b_gz_deg_per_h": math.sqrt(P[1, 1]) / DEG_PER_HOUR,
              "inputs": densities}
    doc = {"duration_s": args.duration_s, "seeds": args.seeds, "closed_form": closed,
           "cases": cases,
           "machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                       "load_average_before": load_before,
                       "load_average_after": os.getloadavg()}}
    atomic_write_text(args.out, json.dumps(doc, indent=2) + "\n")
    print(f"closed form at {t_end:.1f} s: σ_yaw {closed['sigma_yaw_mrad']:.3f} mrad, "
          f"σ(b_gz) {closed['sigma_b_gz_deg_per_h']:.3f} °/h")
    for name, case in cases.items():
        print(f"{name:14s} σ_yaw {case['mean_sigma_yaw_end_mrad']:.3f} mrad, σ(b_gz) "
              f"{case['mean_sigma_b_gz_end_deg_per_h']:.3f} °/h, yaw z² "
              f"{case['mean_yaw_mean_z2']:.3g}, NEES {case['mean_nees_mean']:.3g} "
              f"(means of {args.seeds} seeds; CPU {case['mean_cpu_s']:.1f} s a run)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
