"""Reading speed of recorded IMU logs: 1 h of 200 Hz (720 001 samples), three layouts.

Usage::

    python benchmarks/bench_imu_read.py [--repeat N] [--out FILE]

The logs are generated here with pandas (not our writer): a level train turning at
0.05 rad/s with noise, ±0.2 ms timestamp jitter and 20 dropouts of 5 samples, written

* ``imu_csv``: railnav's ``imu.csv`` layout (SI rates, 17 significant digits);
* ``logger_rates``: a logger's layout read through a spec (ms times, g and deg/s, an FRD
  sensor: axes mapped, mounting rotation applied);
* ``logger_increments``: Δv (m/s) and Δθ (rad) per sample, GPS-second times.

Each time is `strapdown.imu_log.read_imu_log` (CSV parsing, timing checks, gap report,
units, mounting, plausibility) as the best of ``--repeat`` runs, and, beside it,
``pandas.read_csv`` of the same file alone (the parser's share). Writes
``benchmarks/results/imu_read.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from strapdown.imu import IMU_COLUMNS
from strapdown.imu_log import read_imu_log
from strapdown.imu_spec import ImuSpec
from trackmodel.files import atomic_write_text

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results" / "imu_read.json"
DURATION_S, RATE_HZ = 3600.0, 200.0
G = 9.80665
LOGGER = ("t", "ax", "ay", "az", "gx", "gy", "gz")


def _samples(rng: np.random.Generator):
    n = int(DURATION_S * RATE_HZ) + 1
    t = np.arange(n) / RATE_HZ + rng.uniform(-2e-4, 2e-4, n)
    keep = np.ones(n, dtype=bool)
    for start in rng.integers(10, n - 10, 20):
        keep[start:start + 5] = False
    t = t[keep]
    f = np.column_stack([rng.normal(0.3, 0.2, t.size), rng.normal(1.0, 0.2, t.size),
                         rng.normal(G, 0.2, t.size)])
    w = np.column_stack([rng.normal(0, 1e-3, t.size), rng.normal(0, 1e-3, t.size),
                         rng.normal(0.05, 1e-3, t.size)])
    return t, f, w


def write_logs(folder: Path, rng: np.random.Generator) -> dict[str, tuple[Path, ImuSpec]]:
    t, f, w = _samples(rng)
    frd = np.array([1.0, -1.0, -1.0])
    layouts = {
        "imu_csv": (IMU_COLUMNS, np.column_stack([t, f, w]), ImuSpec()),
        "logger_rates": (LOGGER, np.column_stack([t * 1e3, f * frd / G, np.degrees(w * frd)]),
                         ImuSpec(time_column="t", accel_columns=LOGGER[1:4],
                                 gyro_columns=LOGGER[4:7], time_unit="ms", accel_unit="g",
                                 gyro_unit="deg/s", axes=("x", "-y", "-z"),
                                 mounting_rpy_deg=(0.1, -0.2, 0.3))),
        "logger_increments": (LOGGER, np.column_stack([1.3e9 + t, f / RATE_HZ, w / RATE_HZ]),
                              ImuSpec(time_column="t", accel_columns=LOGGER[1:4],
                                      gyro_columns=LOGGER[4:7], kind="increments",
                                      time_reference="gps", rate_hz=RATE_HZ))}
    out = {}
    for name, (columns, data, spec) in layouts.items():
        path = folder / f"{name}.csv"
        pd.DataFrame(data, columns=list(columns)).to_csv(path, index=False,
                                                         float_format="%.17g")
        out[name] = (path, spec)
    return out


def _best(call, repeat: int) -> tuple[float, object]:
    best, value = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        value = call()
        best = min(best, time.perf_counter() - t0)
    return best, value


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    out = {"duration_s": DURATION_S, "rate_hz": RATE_HZ, "repeat": args.repeat,
           "load_average_1min": os.getloadavg()[0]}
    with tempfile.TemporaryDirectory() as tmp:
        for name, (path, spec) in write_logs(Path(tmp), np.random.default_rng(17)).items():
            seconds, log = _best(lambda: read_imu_log(path, spec), args.repeat)
            parse_s, _ = _best(lambda: pd.read_csv(path), args.repeat)
            n, size = log.imu.time_s.size, path.stat().st_size
            out[name] = {"samples": int(n), "bytes": size, "read_s": seconds,
                         "pandas_read_csv_s": parse_s, "samples_per_s": n / seconds,
                         "mb_per_s": size / seconds / 1e6, "realtime_factor": DURATION_S / seconds,
                         "dropped_samples": log.dropped_samples, "gaps": len(log.gaps)}
            print(f"{name}: {n} samples ({size / 1e6:.0f} MB) read in {seconds:.2f} s "
                  f"(pandas alone {parse_s:.2f} s): {n / seconds:,.0f} samples/s, "
                  f"{DURATION_S / seconds:,.0f}x real time")
    out.update(python=platform.python_version(), machine=platform.machine(),
               load_average_1min_end=os.getloadavg()[0])
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
