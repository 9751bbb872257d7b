"""Speed of the GNSS measurement simulator: 1000 epochs of a moving receiver.

`gnss_obs.simulate.simulate_gnss` on the shipped 2020-11-29 navigation file, GPS +
Galileo (about 14 visible satellites near Barcelona, i.e. ~14 000 observations), 1 Hz,
TCXO clock, noise and multipath on. Target (the lead's): well under 1 s for 1000 epochs of
~10 satellites. Best of ``--repeat`` runs in one process.

Writes ``benchmarks/results/simulate_gnss.json``. Run: ``python benchmarks/bench_simulate_gnss.py``.
"""
from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.simulate import (DEFAULT_START_GPS_TIME_S, GnssSimConfig, default_nav_path,
                               simulate_gnss)
from trackmodel.earth import C_n_e, geodetic_to_ecef
from trackmodel.files import atomic_write_text

RESULTS = Path(__file__).resolve().parent / "results" / "simulate_gnss.json"
TARGET_S = 1.0
EPOCHS = 1000
LAT, LON, H = np.deg2rad(41.6), np.deg2rad(2.35), 120.0
SPEED_MPS = 20.0


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    nav = read_rinex_nav(default_nav_path())
    t = DEFAULT_START_GPS_TIME_S + np.arange(EPOCHS, dtype=float)
    v_e = np.tile(C_n_e(LAT, LON) @ np.array([0.5, np.sqrt(0.75), 0.0]) * SPEED_MPS,
                  (EPOCHS, 1))
    r_e = geodetic_to_ecef(LAT, LON, H) + v_e * (t - t[0])[:, None]
    config = GnssSimConfig(systems="GE", multipath_sigma_m=1.0)
    times = []
    for seed in range(args.repeat):
        t0 = time.perf_counter()
        sim = simulate_gnss(t, r_e, v_e, nav, config, rng=np.random.default_rng(seed))
        times.append(time.perf_counter() - t0)
    n_obs = len(sim.obs.table)
    report = {"epochs": EPOCHS, "observations": n_obs,
              "satellites_per_epoch": n_obs / EPOCHS, "best_s": min(times),
              "median_s": float(np.median(times)), "target_s": TARGET_S,
              "meets_target": min(times) < TARGET_S, "python": platform.python_version()}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out, json.dumps(report, indent=2) + "\n")
    print(f"simulate_gnss: {EPOCHS} epochs x {n_obs / EPOCHS:.1f} satellites in "
          f"{min(times):.3f} s (best of {args.repeat}; target < {TARGET_S} s)")
    return report


if __name__ == "__main__":
    main()
