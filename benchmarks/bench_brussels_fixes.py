"""Fix-only runs on the four Belgian train logs, scored against their own carrier-fixed rows.

Usage::

    python benchmarks/bench_brussels_fixes.py --data DIR [--out FILE]

``DIR`` is the shared folder ``train_network_brussels`` (the four ``log_*.csv``). Each log
runs with the GNSS-only filter on fixes alone (`railnav.run_files`, state ``[s, v]``) on its
track ``data/tracks/brussels/<log>.csv`` (built from the network by
``data/tracks/brussels/build_brussels_tracks.py``), scored against the log's own
``NARROW_INT3`` rows that agree with the track and their neighbours
(`railnav.evaluation.reference.screen_fix_reference`: within 3.5 m of the track, within
1 m of the line through their neighbours). Two runs per log:

* ``all``: every fix used; the error at the reference rows shows how well the filter
  follows them (the rows are in the filter's input, so this is consistency, not accuracy);
* ``held_out``: the fixes of 20-s windows every 60 s are withheld (outages from 30 s on);
  the along-track error at the reference rows inside the windows, against the filter's
  σ there, is a prediction the reference checks independently.

Where none of a log's ``NARROW_INT3`` rows agrees with the track (log_29083: all 148 lie
90-200 m off it), its ``SINGLE`` rows that do serve as a second, lower-quality reference.

Writes ``benchmarks/results/brussels_fixes.json``.
"""
from __future__ import annotations

import argparse
import json
import logging
import platform
import time
from pathlib import Path

import numpy as np

from gnss_obs.sim_events import in_outages
from railnav.jobs.run import run_files
from trackmodel.files import atomic_write_text
from trackmodel.io import read_track

REPO = Path(__file__).resolve().parents[1]
TRACKS = REPO / "data" / "tracks" / "brussels"
RESULTS = REPO / "benchmarks" / "results" / "brussels_fixes.json"
LOGS = ("log_28554_L36-A_to_L36C-A", "log_28876_L36-B", "log_29083_L36-A",
        "log_29304_L36-B_to_L36N-B")
#: Held-out windows: 20 s every 60 s from 30 s on.
HOLD_START_S, HOLD_EVERY_S, HOLD_LENGTH_S = 30.0, 60.0, 20.0


def _figures(outcome, mask=None) -> dict:
    """Along-track error and σ at the estimates compared (inside `mask` if given)."""
    err = outcome.errors.along_track_m
    est = outcome.result.estimates
    ok = np.isfinite(err) & (np.ones(err.size, bool) if mask is None else mask)
    if not ok.any():
        return {"compared": 0}
    e, sigma = err[ok], est["sigma_s_m"].to_numpy()[ok]
    return {"compared": int(ok.sum()), "rms_m": float(np.sqrt(np.mean(e * e))),
            "max_abs_m": float(np.max(np.abs(e))), "median_sigma_m": float(np.median(sigma)),
            "within_3_sigma": float(np.mean(np.abs(e) <= 3.0 * sigma)),
            "nees_mean": float(np.mean((e / sigma) ** 2))}


def _runs(track, log_path: Path, quality: str | None) -> dict:
    """The ``all`` and ``held_out`` runs of one log against one reference class."""
    started = time.perf_counter()
    full = run_files(track, fixes_path=log_path, truth_path=log_path, truth_quality=quality)
    runtime = time.perf_counter() - started
    end = float(full.result.estimates["time_s"].iloc[-1])
    windows = tuple((s, HOLD_LENGTH_S) for s in np.arange(HOLD_START_S, end, HOLD_EVERY_S))
    held = run_files(track, fixes_path=log_path, truth_path=log_path, truth_quality=quality,
                     outages=windows)
    inside = in_outages(held.result.estimates["time_s"].to_numpy(), windows)
    stats = full.summary["statistics"]
    return {"runtime_s": runtime, "fixes": full.summary["fixes"],
            "fix_epochs": stats["fix_epochs"], "fixes_rejected": stats["fixes_rejected"],
            "nis_fix_along_mean": stats.get("nis_fix_along_mean"),
            "nis_fix_cross_mean": stats.get("nis_fix_cross_mean"),
            "left_track": full.summary["left_track"], "reference": full.summary["reference"],
            "all": _figures(full),
            "held_out": {"windows": len(windows), **_figures(held, inside)}}


def run_log(data: Path, name: str) -> dict:
    """Both runs against the log's ``NARROW_INT3`` (rtk_fixed) rows; where none of them
    agrees with the track (log_29083), also against its ``SINGLE`` rows that do
    (``single_reference``: lower quality, and the filter's own input)."""
    track = read_track(TRACKS / f"{name}.csv")
    out = {"track_length_m": float(track.length_m),
           **_runs(track, data / f"{name}.csv", "rtk_fixed")}
    if out["reference"]["kept"] == 0:
        out["single_reference"] = _runs(track, data / f"{name}.csv", "single")
    return out


def _line(name: str, r: dict) -> str:
    ref, a, h = r["reference"], r["all"], r["held_out"]
    nan = float("nan")
    return (f"{name}: {r['fixes_rejected']}/{r['fix_epochs']} fixes rejected; reference "
            f"{ref['kept']}/{ref['candidates']} {ref['quality']} rows kept ({ref['off_track']} "
            f"off the track, {ref['jumps']} jumps); all: {a.get('rms_m', nan):.3f} m RMS "
            f"(median σ {a.get('median_sigma_m', nan):.3f} m); held out: "
            f"{h.get('rms_m', nan):.2f} m RMS, max {h.get('max_abs_m', nan):.1f} m (median σ "
            f"{h.get('median_sigma_m', nan):.2f} m, {h.get('within_3_sigma', nan):.0%} within 3σ)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, required=True,
                        help="the train_network_brussels folder")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    out = {"data": Path(args.data).name, "logs": {name: run_log(args.data, name) for name in LOGS},
           "python": platform.python_version(), "machine": platform.machine()}
    # record file names, not this machine's folders (the data folder is given by --data)
    text = json.dumps(out, indent=2).replace(str(args.data).rstrip("/") + "/", "")
    atomic_write_text(args.out, text + "\n")
    for name, r in out["logs"].items():
        print(_line(name, r))
        if "single_reference" in r:
            print(_line(name + " (SINGLE rows as reference)", r["single_reference"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
