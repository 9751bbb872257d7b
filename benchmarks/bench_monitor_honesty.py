"""Is the divergence monitor honest on real data: its ``degraded`` epochs against the
filter's actual error (issue 14, stop 36: the lower-tail fix test, ``p_fix_small``).

Usage::

    python benchmarks/bench_monitor_honesty.py --brussels DIR --data DIR [--out FILE]

``--brussels``: the shared folder ``train_network_brussels``; ``--data``: the urban drive's
folder (`_data_dir`). Runs, each scored per monitored epoch (status, the tests that fail at
``p_degraded``, the along-track error against the reference, σ_s after the update):

* the four Belgian train logs, fix-only (`railnav.run_files`, as
  ``bench_brussels_fixes.py``), against their carrier-fixed rows near the track (log_29083:
  its single-point rows, none of its carrier-fixed rows being near it). The reference rows
  are the filter's own input: an error within 3σ_s says the filter is not overconfident
  about them, not that they are right;
* the urban drive's pieces (`bench_real_pieces.pieces`), the fix-based filter on the SPP
  fixes taken as white (``FixModelConfig.correlated_code_errors`` off: the lower tail is on;
  with it on, as ``bench_real_pieces.py`` runs, the test is off), against the PPK reference.

Per run: epochs, ``degraded`` (``lost``), those where ``p_fix_small`` is the only failing
test, split by the error (``false``: within 3σ_s; ``catch``: beyond), epochs beyond 3σ_s
and those left ``ok``. Two checks with a second reference:

* ``propagated``: on the carrier-fixed logs, each stretch of the receiver's propagated
  positions (σ 10 m) followed by a carrier-fixed fix: that fix's disagreement with the
  prior in the prior's σ (the carrier-fixed fix is centimetres from the truth), from the
  monitor's ``fix_disagreement_sigma`` (σ_fix floored at ``min_fix_sigma_m``, above
  3 cm) and ``sigma_s_prior_m``;
* ``cross_track_29083``: log_29083's single-point fixes across the track, which the filter
  cannot follow, against the line where log_28554's carrier-fixed fixes (another train,
  the same track A) put it.

Run it on this tree and on another (``PYTHONPATH``) for a before/after.
"""
from __future__ import annotations

import argparse
import json
import logging
import platform
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _data_dir import add_data_argument, checked_data_dir  # noqa: E402
from bench_brussels_fixes import LOGS, TRACKS  # noqa: E402
from bench_real_pieces import (  # noqa: E402
    DATA_FILES,
    GPS_WEEK,
    WEEK_S,
    bench_config,
    load_drive,
    pieces,
)

from gnss_obs.fixes.read import read_fixes  # noqa: E402
from railnav.jobs.run import run_files  # noqa: E402
from railnav.navigation.monitor_config import MonitorConfig  # noqa: E402
from railnav.navigation.navigator import navigate  # noqa: E402
from railnav.sensor_data import SensorData  # noqa: E402
from tests.support.track_offsets import along_track_s  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402
from trackmodel.io import read_track  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "monitor_honesty.json"
TESTS = ("p_gnss_nis", "p_rejected", "p_fix", "p_pseudo_nis", "p_fix_small",
         "p_kind_rejected")


def score(frame: pd.DataFrame, config: MonitorConfig) -> dict:
    """The module docstring's counts of one run (`frame`: the monitor's records with
    ``err_m``, ``sigma_m`` and NaN where the epoch has no reference)."""
    fails = frame[list(TESTS)] < config.p_degraded
    small_only = fails["p_fix_small"] & ~fails.drop(columns="p_fix_small").any(axis=1) \
        & (frame["status"] == "degraded")
    known = np.isfinite(frame["err_m"])
    beyond = known & (np.abs(frame["err_m"]) > 3.0 * frame["sigma_m"])
    return {"epochs": len(frame), "degraded": int((frame["status"] == "degraded").sum()),
            "lost": int((frame["status"] == "lost").sum()),
            "failing": {k: int(v) for k, v in fails.sum().items()},
            "small_only": int(small_only.sum()),
            "with_reference": int(known.sum()),
            "small_only_false": int((small_only & known & ~beyond).sum()),
            "small_only_catch": int((small_only & beyond).sum()),
            "beyond_3sigma": int(beyond.sum()),
            "beyond_3sigma_ok": int((beyond & (frame["status"] == "ok")).sum()),
            "median_sigma_s_m": float(frame["sigma_m"].median())}


def _posterior(estimates: pd.DataFrame, errors, times) -> pd.DataFrame:
    """The last estimate at each of `times` (the update's): its error and σ_s."""
    e = pd.DataFrame({"t": estimates["time_s"].round(3).to_numpy(), "err_m": errors,
                      "sigma_m": estimates["sigma_s_m"].to_numpy()})
    e = e.drop_duplicates("t", keep="last").set_index("t")
    return e.reindex(np.round(times, 3))


def brussels_log(data: Path, name: str, config: MonitorConfig) -> tuple[dict, pd.DataFrame]:
    """One log, fix-only, scored; its frame (with each epoch's fix class ``quality``)."""
    quality = "single" if "29083" in name else "rtk_fixed"
    out = run_files(read_track(TRACKS / f"{name}.csv"), fixes_path=data / f"{name}.csv",
                    truth_path=data / f"{name}.csv", truth_quality=quality)
    frame = out.result.monitor.reset_index(drop=True)
    post = _posterior(out.result.estimates, out.errors.along_track_m, frame["time_s"])
    frame = frame.assign(err_m=post["err_m"].to_numpy(), sigma_m=post["sigma_m"].to_numpy())
    rows = out.result.innovations
    along = rows[rows["kind"] == "fix_along"].drop_duplicates("time_s").set_index("time_s")
    frame["quality"] = along["sv"].reindex(frame["time_s"]).str.replace(
        "fix:", "").to_numpy()
    return {"reference": quality, **score(frame, config)}, frame


def propagated_stretches(frame: pd.DataFrame, config: MonitorConfig) -> list[dict]:
    """Each stretch of ``dead_reckoning`` fixes followed by a carrier-fixed one: its
    epochs, those ``degraded``, and the next fix's disagreement with the prior in the
    prior's σ (module docstring)."""
    q = frame["quality"].to_numpy()
    prop = q == "dead_reckoning"
    out = []
    for start in np.flatnonzero(prop & ~np.r_[False, prop[:-1]]):
        end = start
        while end + 1 < len(q) and prop[end + 1]:
            end += 1
        if end + 1 >= len(q) or q[end + 1] != "rtk_fixed":
            continue
        nxt = frame.iloc[end + 1]
        sp = float(nxt["sigma_s_prior_m"])
        z = float(nxt["fix_disagreement_sigma"]) * np.hypot(config.min_fix_sigma_m, sp) / sp
        out.append({"time_s": [float(frame["time_s"].iloc[start]),
                               float(frame["time_s"].iloc[end])],
                    "epochs": int(end - start + 1),
                    "degraded": int((frame["status"].iloc[start:end + 1] != "ok").sum()),
                    "next_fix_z_prior": z})
    return out


def cross_track_29083(data: Path) -> dict:
    """log_29083's single-point fixes across its track, against log_28554's carrier-fixed
    line (module docstring)."""
    track = read_track(TRACKS / "log_29083_L36-A.csv")
    a = read_fixes(data / "log_29083_L36-A.csv").table
    b = read_fixes(data / "log_28554_L36-A_to_L36C-A.csv").table
    pa = track.project(np.radians(a["lat_deg"].to_numpy()), np.radians(a["lon_deg"].to_numpy()))
    pb = track.project(np.radians(b["lat_deg"].to_numpy()), np.radians(b["lon_deg"].to_numpy()))
    single = (a["quality"] == "single").to_numpy() & (pa.distance_m < 15.0)
    fixed = (b["quality"] == "rtk_fixed").to_numpy() & (pb.distance_m < 5.0)
    order = np.argsort(pb.s[fixed])
    line = np.interp(pa.s[single], pb.s[fixed][order], pb.cross_track_m[fixed][order],
                     left=np.nan, right=np.nan)
    x = (pa.cross_track_m[single] - line)[np.isfinite(line)]
    return {"single_rows": int(x.size), "carrier_rows": int(fixed.sum()),
            "carrier_line_median_m": float(np.median(pb.cross_track_m[fixed])),
            "offset_mean_m": float(x.mean()), "offset_rms_m": float(np.sqrt(np.mean(x * x))),
            "offset_median_abs_m": float(np.median(np.abs(x))),
            "consecutive_difference_rms_m": float(np.sqrt(np.mean(np.diff(x) ** 2))),
            "stated_sigma_m": float(a.loc[a["quality"] == "single", "sigma_east_m"].median())}


def urban(data: Path) -> dict:
    """The urban drive's pieces, the fix-based filter on white SPP fixes, scored."""
    obs, nav, reference, spp = load_drive(data)
    config = bench_config()
    config = replace(config, fix_model=replace(config.fix_model, correlated_code_errors=False))
    week = GPS_WEEK * WEEK_S
    ref = reference.set_index(np.round(reference["gps_time_s"] - week).astype(int))
    ref = ref[~ref.index.duplicated()]
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for piece in pieces(reference):
            times = reference["gps_time_s"].to_numpy()[piece["rows"]]
            t0, t1 = float(times[0]), float(times[-1])
            path = Path(tmp) / "fixes.csv"
            spp[(spp["gps_time_s"] >= t0 - 1e-6) & (spp["gps_time_s"] <= t1 + 1e-6)].to_csv(
                path, index=False)
            result = navigate(piece["track"], SensorData(start_gps_time_s=t0,
                                                         fixes=read_fixes(path)), config)
            frame = result.monitor.reset_index(drop=True)
            sow = np.round(frame["time_s"].to_numpy() + t0 - week)
            est = result.estimates.assign(s_state_m=result.x[:, result.layout.index("s")])
            t = est["gps_time_s"].to_numpy() - week
            est = est[np.abs(t - np.round(t)) < 1e-3]          # the fixes' whole seconds
            est = est.set_index(np.round(est["gps_time_s"] - week))
            est = est[~est.index.duplicated(keep="last")].reindex(sow)
            r = ref.reindex(sow.astype(int))
            s_ref = np.full(sow.size, np.nan)
            have = np.isfinite(r["lat_deg"].to_numpy())
            s_ref[have] = along_track_s(piece["track"], r["lat_deg"].to_numpy()[have],
                                        r["lon_deg"].to_numpy()[have])
            frame = frame.assign(err_m=est["s_state_m"].to_numpy() - s_ref,
                                 sigma_m=est["sigma_s_m"].to_numpy())
            out[piece["name"]] = score(frame, config.monitor)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--brussels", type=Path, required=True,
                        help="the train_network_brussels folder")
    add_data_argument(parser, DATA_FILES)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    missing = [n for n in LOGS if not (args.brussels / f"{n}.csv").is_file()]
    if missing:
        parser.error(f"--brussels {args.brussels}: missing {', '.join(missing)}.csv")
    data = checked_data_dir(parser, args.data, DATA_FILES)
    logging.basicConfig(level=logging.ERROR)
    started = time.process_time()
    config = MonitorConfig()
    logs, stretches = {}, {}
    for name in LOGS:
        logs[name], frame = brussels_log(args.brussels, name, config)
        if logs[name]["reference"] == "rtk_fixed":
            stretches[name] = propagated_stretches(frame, config)
    out = {"brussels": logs, "propagated": stretches,
           "cross_track_29083": cross_track_29083(args.brussels), "urban": urban(data),
           "cpu_s": time.process_time() - started, "python": platform.python_version(),
           "machine": platform.machine()}
    atomic_write_text(args.out, json.dumps(out, indent=2) + "\n")
    for name, r in [*logs.items(), *out["urban"].items()]:
        print(f"{name}: degraded {r['degraded']}/{r['epochs']} (p_fix_small alone "
              f"{r['small_only']}: false {r['small_only_false']}, catches "
              f"{r['small_only_catch']}); beyond 3σ_s {r['beyond_3sigma']}, ok "
              f"{r['beyond_3sigma_ok']}")
    print(f"{args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
