"""Read the 8-minute rover observation file and the broadcast navigation file with
`gnss_obs` and with georinex, in one process, and write the times and ratios as JSON.

Usage::

    python benchmarks/bench_rinex_read.py --data DIR [--repeat N] [--out FILE]

``DIR`` holds the full urban drive's ``rover_obs.rnx`` and ``broadcast_nav.rnx``
(provenance in ``data/gnss/README.md``).

Each reader's time is the best of ``--repeat`` runs (georinex: one run by default, it
takes tens of seconds). Target: ours at least 20x faster on the observation file.
"""
from __future__ import annotations

import argparse
import json
import platform
import time
from pathlib import Path

import numpy as np

from gnss_obs.rinex_nav import read_rinex_nav
from gnss_obs.rinex_obs import read_rinex_obs
from trackmodel.files import atomic_write_text

from _data_dir import add_data_argument, checked_data_dir  # beside this file

REPO = Path(__file__).resolve().parents[1]
#: Files of the urban drive this benchmark reads from ``--data DIR``.
DATA_FILES = ("rover_obs.rnx", "broadcast_nav.rnx")
TARGET_RATIO = 20.0


def _best_time(func, repeat: int) -> tuple[float, object]:
    best, result = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = func()
        best = min(best, time.perf_counter() - t0)
    return best, result


def _count_values_ours(table) -> int:
    return int(table[["pseudorange_m", "carrier_cycles", "doppler_hz",
                      "cn0_dbhz"]].notna().to_numpy().sum())


def _count_values_georinex(ds) -> int:
    return int(sum(np.isfinite(ds[v].values).sum() for v in ds.data_vars
                   if len(v) == 3 and v[0] in "CLDS"))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_data_argument(parser, DATA_FILES)
    parser.add_argument("--repeat", type=int, default=5, help="runs of our readers")
    parser.add_argument("--repeat-georinex", type=int, default=1, help="runs of georinex")
    parser.add_argument("--out", type=Path,
                        default=REPO / "benchmarks" / "results" / "rinex_read.json")
    args = parser.parse_args(argv)
    checked_data_dir(parser, args.data, DATA_FILES)
    import georinex

    obs_path, nav_path = args.data / "rover_obs.rnx", args.data / "broadcast_nav.rnx"
    ours_obs_s, obs = _best_time(lambda: read_rinex_obs(obs_path), args.repeat)
    ours_nav_s, _ = _best_time(lambda: read_rinex_nav(nav_path), args.repeat)
    geo_obs_s, ds = _best_time(lambda: georinex.load(obs_path, useindicators=True),
                               args.repeat_georinex)
    geo_nav_s, _ = _best_time(lambda: georinex.load(nav_path), args.repeat_georinex)
    result = {
        "obs_file": obs_path.name, "nav_file": nav_path.name,
        "obs_values": {"ours": _count_values_ours(obs.table),
                       "georinex": _count_values_georinex(ds)},
        "seconds": {"ours_obs": ours_obs_s, "georinex_obs": geo_obs_s,
                    "ours_nav": ours_nav_s, "georinex_nav": geo_nav_s},
        "ratio": {"obs": geo_obs_s / ours_obs_s, "nav": geo_nav_s / ours_nav_s},
        "target_ratio_obs": TARGET_RATIO,
        "meets_target": geo_obs_s / ours_obs_s >= TARGET_RATIO,
        "repeat": {"ours": args.repeat, "georinex": args.repeat_georinex},
        "python": platform.python_version(), "machine": platform.machine(),
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out, json.dumps(result, indent=2) + "\n")
    print(json.dumps(result["seconds"]), json.dumps(result["ratio"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
