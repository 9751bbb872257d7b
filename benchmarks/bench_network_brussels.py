"""The four Brussels logs through the network navigator (issue 13's real-data acceptance),
side by side with tp-lib on the same inputs.

Usage::

    python benchmarks/bench_network_brussels.py --data DIR [--tplib PYTHON312] [--seeds N]

``DIR`` is the shared folder ``train_network_brussels`` (the four ``log_*.csv`` and
``network_airport.geojson``); the network is the shipped fit
(``data/networks/brussels_airport``). ``--tplib`` names a Python >= 3.12 with the PyPI
package ``tp-lib`` (`benchmarks/tplib_runner.py` runs in it; without it tp-lib is left out).

Per log, with no start given (`railnav.jobs.network.run_files_network`):

* ``as_given``: the fixes as recorded; truth = issue 13's definition on the log's
  ``NARROW_INT3`` rows (`railnav.evaluation.netelement_truth`); the share of those epochs
  whose netelement is right, the route's check (navigable, passes the truth's elements);
* ``degraded``: seeds 1..N of the fixes degraded to single-point quality
  (`railnav.simulation.fix_degrade`: 2 m white + 2 m Gauss–Markov bias, τ 60 s, per axis),
  navigated with that error model declared (``NetworkNavConfig.evidence_correlation_s``
  = 60 s, ``fix_bias_sigma_m`` = 2 m: `railnav.navigation.fix_bias`); among the epochs given P >= 0.99 the share right, and overall the number right,
  against tp-lib's on the same degraded file;
* ``speed``: log_29304 out and back (it ends standing: its fixes, 3 min standing, then the
  same positions in reverse order, the train going back through its switch; 15 min at
  2.5 Hz), the navigator's wall time and tp-lib's on the same file; and ``command``, the
  whole ``railnav run --network ... --no-plots`` as a user runs it (a fresh interpreter
  each time), after one run that fills the caches (compiled code, the loaded network:
  `railnav.jobs.network_cache`).

Writes ``benchmarks/results/network_brussels.json``.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from railnav.evaluation.netelement_truth import (  # noqa: E402
    collapse,
    netelement_scores,
    netelement_truth,
    route_passes,
)
from railnav.jobs.network import load_network, run_files_network  # noqa: E402
from railnav.navigation.network_config import NetworkNavConfig  # noqa: E402
from railnav.simulation.fix_degrade import SPP_BIAS_M, SPP_TAU_S, degrade_log  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402

NETWORK = REPO / "data" / "networks" / "brussels_airport"
RESULTS = REPO / "benchmarks" / "results" / "network_brussels.json"
RESULTS_NO_SPAWN = RESULTS.with_name("network_brussels_no_spawn.json")
LOGS = ("log_28554_L36-A_to_L36C-A", "log_28876_L36-B", "log_29083_L36-A",
        "log_29304_L36-B_to_L36N-B")
#: The 15-min log: log_29304 (it ends standing), 3 min there, and back (2258 fixes).
SPEED_LOG, SPEED_DWELL_S = "log_29304_L36-B_to_L36N-B", 180.0


def _truth(network, log: Path):
    tab = pd.read_csv(log)
    truth = netelement_truth(network, np.radians(tab["latitude"].to_numpy()),
                             np.radians(tab["longitude"].to_numpy()))
    truth[tab["position_type"].to_numpy() != "NARROW_INT3"] = None
    stamps = pd.to_datetime(tab["timestamp"], format="ISO8601")
    t = (stamps - stamps.iloc[0]).dt.total_seconds().to_numpy()
    return t, truth


def _ours(network, fixes: Path, truth_t, truth, nav: NetworkNavConfig) -> dict:
    started = time.perf_counter()
    run = run_files_network(network, fixes_path=fixes, nav=nav)
    wall = time.perf_counter() - started
    res = run.network_result
    cyc = res.cycles
    # fix times as the reader saw them: UTC labels -> GPS seconds; align on the first fix
    t0 = float(run.outcome.data.fixes.table["gps_time_s"].iloc[0]) - run.outcome.data.start_gps_time_s
    scores = netelement_scores(cyc["time_s"], cyc["netelement"],
                               cyc["netelement_probability"], truth_t - truth_t[0] + t0, truth)
    route = res.route_frame()
    check = route_passes(network, zip(route["netelement"], route["orientation"]),
                         collapse(truth))
    return {"wall_s": wall, "navigator_s": res.runtime_s, **scores, **check,
            "route": route["netelement"].tolist(),
            "collapsed_per_epoch": collapse(cyc["netelement"].tolist()),
            "hypotheses_max": int(cyc["hypotheses"].max()),
            "hypotheses_median": float(cyc["hypotheses"].median()),
            "spawns": len(res.spawns)}


def _tplib(python: str | None, fixes: Path, truth, geojson: Path, work: Path) -> dict | None:
    if python is None:
        return None
    raw = pd.read_csv(fixes)
    path = work / f"tplib_{fixes.stem}.csv"
    stamps = raw["timestamp"].astype(str)
    stamps = stamps.where(stamps.str.endswith("Z"), stamps + "Z")
    pd.DataFrame({"latitude": raw["latitude"], "longitude": raw["longitude"],
                  "timestamp": stamps}).to_csv(path, index=False)
    done = subprocess.run([python, str(REPO / "benchmarks" / "tplib_runner.py"), str(path),
                           str(geojson)], capture_output=True, text=True, check=False)
    if done.returncode != 0:
        return {"error": done.stderr.strip().splitlines()[-1] if done.stderr else "failed"}
    out = json.loads(done.stdout.strip().splitlines()[-1])
    element = np.array(out["element"] + [None] * (len(truth) - len(out["element"])),
                       dtype=object)
    has = np.array([x is not None for x in truth])
    return {"runtime_s": out["runtime_s"], "epochs": int(has.sum()),
            "right": int((has & (element == truth)).sum()),
            "share_right": float((has & (element == truth)).sum() / has.sum())
            if has.any() else None, "route": [s["netelement_id"] for s in out["segments"]]}


def _command_times(fixes: Path, work: Path, repeats: int = 5) -> dict:
    """Wall times of ``railnav run --network NETWORK --fixes FIXES --no-plots`` in fresh
    interpreters, after one run that fills the caches (module docstring) and writes the
    ``.pyc`` files, as on a user's machine (``PYTHONDONTWRITEBYTECODE``, set in some
    sandboxes, is removed from the command's environment, as `bench_speed` does), s."""
    cmd = [sys.executable, "-m", "railnav.cli", "-q", "run", "--network", str(NETWORK),
           "--fixes", str(fixes), "--no-plots", "--overwrite", "--out", str(work / "cli")]
    path = os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))
    env = {**{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"},
           "MPLBACKEND": "Agg", "PYTHONPATH": path}
    times = []
    for k in range(repeats + 1):
        started = time.perf_counter()
        subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL)
        if k:
            times.append(time.perf_counter() - started)
    return {"command": "railnav run --network data/networks/brussels_airport --fixes "
                       "<the 15-min log> --no-plots", "bytecode": "written and read (no "
                       "PYTHONDONTWRITEBYTECODE)", "runs_s": times,
            "median_s": float(np.median(times)), "best_s": min(times)}


def _out_and_back(log: Path, work: Path, dwell_s: float) -> Path:
    """The log (which ends at a standstill), `dwell_s` standing there, then its positions in
    reverse order: the train going back the way it came (module docstring)."""
    raw = pd.read_csv(log)
    t = pd.to_datetime(raw["timestamp"], format="ISO8601")
    step = t.iloc[-1] - t.iloc[-2]
    n_dwell = int(round(dwell_s / step.total_seconds()))
    stand = pd.concat([raw.iloc[[-1]]] * n_dwell, ignore_index=True)
    back = raw.iloc[::-1].reset_index(drop=True)
    both = pd.concat([raw, stand, back], ignore_index=True)
    both["timestamp"] = [(t.iloc[0] + step * k).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3]
                         for k in range(len(both))]
    path = work / "out_and_back.csv"
    both.to_csv(path, index=False)
    return path


def _log_figures(network, data: Path, name: str, python, seeds: int, work: Path,
                 spawn: bool = True) -> dict:
    log = data / f"{name}.csv"
    truth_t, truth = _truth(network, log)
    geojson = data / "network_airport.geojson"
    out = {"truth_epochs": int(sum(x is not None for x in truth)),
           "as_given": _ours(network, log, truth_t, truth, NetworkNavConfig(spawn=spawn)),
           "as_given_tplib": _tplib(python, log, truth, geojson, work), "degraded": []}
    for seed in range(1, seeds + 1):
        path = work / f"{name}_spp{seed}.csv"
        degrade_log(log, path, seed=seed)
        ours = _ours(network, path, truth_t, truth,
                     NetworkNavConfig(evidence_correlation_s=SPP_TAU_S,
                                      fix_bias_sigma_m=SPP_BIAS_M, spawn=spawn))
        out["degraded"].append({"seed": seed, "ours": ours,
                                "tplib": _tplib(python, path, truth, geojson, work)})
    return out


def _summary_line(name: str, r: dict) -> str:
    a, tp = r["as_given"], r["as_given_tplib"] or {}
    deg = r["degraded"]
    conf = [d["ours"]["share_confident_right"] for d in deg
            if d["ours"]["share_confident_right"] is not None]
    ours_right = sum(d["ours"]["right"] for d in deg)
    tp_right = sum((d["tplib"] or {}).get("right", 0) for d in deg)
    return (f"{name}: as given {a['right']}/{a['epochs']} right (tp-lib "
            f"{tp.get('right', '-')}), route ok {a['navigable'] and a['passes_truth']}, "
            f"{a['navigator_s']:.2f} s; degraded x{len(deg)}: P>=0.99 right "
            f"{min(conf) if conf else float('nan'):.4f} (worst seed), right overall "
            f"{ours_right} vs tp-lib {tp_right}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, required=True,
                        help="the train_network_brussels folder")
    parser.add_argument("--tplib", default=None, metavar="PYTHON312",
                        help="a Python >= 3.12 with tp-lib installed (optional)")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--out", type=Path, default=None,
                        help=f"default {RESULTS.name}, or {RESULTS_NO_SPAWN.name} with "
                             "--no-spawn")
    parser.add_argument("--no-spawn", action="store_true",
                        help="never spawn hypotheses from the fixes (NetworkNavConfig.spawn=False;"
                             " results/network_brussels_no_spawn.json)")
    args = parser.parse_args(argv)
    if args.out is None:         # a --no-spawn run never overwrites the default run's figures
        args.out = RESULTS_NO_SPAWN if args.no_spawn else RESULTS
    logging.basicConfig(level=logging.ERROR)
    network = load_network(NETWORK)
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        logs = {name: _log_figures(network, args.data, name, args.tplib, args.seeds, work,
                                   spawn=not args.no_spawn)
                for name in LOGS}
        both = _out_and_back(args.data / f"{SPEED_LOG}.csv", work, SPEED_DWELL_S)
        started = time.perf_counter()
        run = run_files_network(network, fixes_path=both)
        speed = {"fixes": len(pd.read_csv(both)), "wall_s": time.perf_counter() - started,
                 "navigator_s": run.network_result.runtime_s,
                 "route": run.network_result.route_frame()["netelement"].tolist()}
        speed["tplib"] = _tplib(args.tplib, both, [None] * speed["fixes"],
                                args.data / "network_airport.geojson", work)
        speed["command"] = _command_times(both, work)
    out = {"data": Path(args.data).name, "logs": logs, "speed_15min": speed,
           "machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                       "load_average_before": load_before,
                       "load_average_after": os.getloadavg()}}
    atomic_write_text(args.out, json.dumps(out, indent=2, default=str) + "\n")
    for name, r in logs.items():
        print(_summary_line(name, r))
    print(f"15-min log ({speed['fixes']} fixes): {speed['navigator_s']:.2f} s navigator, "
          f"{speed['wall_s']:.2f} s with reading; tp-lib "
          f"{(speed['tplib'] or {}).get('runtime_s', float('nan')):.2f} s; the command "
          f"(warm caches) median {speed['command']['median_s']:.2f} s, best "
          f"{speed['command']['best_s']:.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
