"""SPP, code DGNSS and carrier-smoothed DGNSS, with and without SP3, on the real drive.

Windows (2020-11-29, urban drive near Barcelona, reference = post-processed trajectory):

* ``shared``: 12:40:00-12:42:59 GPST, the excerpts shipped in ``data/gnss`` (rover, base
  G+E records, broadcast nav, CODE SP3 11:00-14:30);
* ``held-out``: 12:43:00-12:47:59, from the full files of the shared data set, given with
  ``--data DIR`` (the folder of the shared urban drive: rover, base, nav, SP3, reference). Without ``--data`` only the
  shared window is computed and the JSON says so.

Solutions per window and systems (G, GE): ``spp``, ``spp+smooth``, ``dgps``,
``dgps+smooth``, each with broadcast (``brdc``) and precise (``sp3``) orbits and clocks
(`gnss_obs.augment` + `gnss_obs.solve_spp`, the functions behind ``railnav spp``); scored
with `railnav.evaluation.spp_accuracy` (horizontal RMS / 95 %, vertical RMS, epochs).

RTKLIB: the issue's figures (RTKLIB 2.4.3 rnx2rtkp, held-out) are copied in ``rtklib_issue``;
when ``rnx2rtkp`` is installed (Debian package ``rtklib``) it is run here in single-point
(``-p 0``) and DGPS (``-p 1``) modes on the same files, 10° mask, broadcast ionosphere
and Saastamoinen troposphere, and scored the same way; otherwise a note says it was
skipped.

Also: ``railnav run --filter gnss-only`` on ``data/tracks/barcelona_drive.csv`` (the
drive's first leg) with raw, DGNSS and smoothed DGNSS pseudorange rows, per piece; and
the multipath question (GPS+Galileo no better than GPS): a σ model of elevation and C/N0
chosen on the shared window (grid over `MeasurementConfig.cn0_ref_dbhz`,
``elevation_weighting`` and a Galileo-only mask), then applied to the held-out window,
and the DGNSS residual RMS per system and C/N0 bin.

Writes ``benchmarks/results/dgps.json``. Run:
``python benchmarks/bench_dgps.py --data DIR`` (a few minutes).
"""
from __future__ import annotations

import argparse
import json
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from gnss_obs.dgps import augment  # noqa: E402
from gnss_obs.measurements import MeasurementConfig  # noqa: E402
from gnss_obs.rinex_nav import read_rinex_nav  # noqa: E402
from gnss_obs.rinex_obs import read_rinex_obs  # noqa: E402
from gnss_obs.smoothing import SmoothingConfig  # noqa: E402
from gnss_obs.sp3 import read_sp3  # noqa: E402
from gnss_obs.spp import SppConfig, solve_spp  # noqa: E402
from railnav.evaluation.spp_accuracy import (  # noqa: E402
    accuracy_summary,
    read_reference_trajectory,
    spp_errors,
)
from trackmodel.files import atomic_write_text  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "dgps.json"
GNSS = REPO / "data" / "gnss"
TRACK = REPO / "data" / "tracks" / "barcelona_drive.csv"
WEEK = 2134
WEEK_S = 604_800
SPLIT_SOW = 45_780.0            # 12:43:00 GPST: first epoch of the held-out window
SMOOTH = SmoothingConfig(window_s=100.0)
#: RTKLIB 2.4.3 rnx2rtkp figures quoted in issue 16 (horizontal RMS, m).
RTKLIB_ISSUE = {"held-out": {"SPP G": 9.88, "SPP GE": 8.75, "DGPS": 7.82,
                             "kinematic float": 7.50},
                "shared": {"DGPS": 4.14}}


def _window(frame: pd.DataFrame, name: str) -> pd.DataFrame:
    sow = frame["gps_time_s"].to_numpy() - WEEK * WEEK_S
    return frame[sow < SPLIT_SOW] if name == "shared" else frame[sow >= SPLIT_SOW]


def _score(frame: pd.DataFrame, reference: pd.DataFrame, window: str) -> dict:
    acc = accuracy_summary(spp_errors(_window(frame, window), reference))
    return {"horizontal_rms_m": round(acc.horizontal_rms_m, 3),
            "horizontal_95_m": round(acc.horizontal_95_m, 3),
            "vertical_rms_m": round(acc.vertical_rms_m, 3), "n_epochs": acc.n_epochs}


def files_for(window: str, data: Path | None) -> dict:
    if window == "shared":
        return {"obs": GNSS / "rover_obs_1240.rnx", "base": GNSS / "base_obs_1240.rnx",
                "nav": GNSS / "broadcast_nav.rnx", "sp3": GNSS / "COD21340_1100_1430.sp3",
                "ref": GNSS / "reference_trajectory_1240.csv"}
    return {"obs": data / "rover_obs.rnx", "base": data / "base_obs.rnx",
            "nav": data / "broadcast_nav.rnx", "sp3": data / "COD21340.sp3",
            "ref": data / "reference_trajectory.csv"}


def railnav_solutions(files: dict, window: str, config_for=None) -> tuple[dict, dict]:
    """The 16 railnav solutions of one window: scores and run times."""
    obs, base = read_rinex_obs(files["obs"]), read_rinex_obs(files["base"])
    nav, ref = read_rinex_nav(files["nav"]), read_reference_trajectory(files["ref"])
    sp3 = read_sp3(files["sp3"])
    scores, seconds = {}, {}
    for systems in ("G", "GE"):
        mc = MeasurementConfig(systems=systems)
        for orbits in ("brdc", "sp3"):
            for name, with_base, smooth in (("spp", False, None), ("spp+smooth", False, SMOOTH),
                                            ("dgps", True, None), ("dgps+smooth", True, SMOOTH)):
                t0 = time.perf_counter()
                aug = augment(obs, nav, mc, base_obs=base if with_base else None,
                              smoothing=smooth, sp3=[sp3] if orbits == "sp3" else [])
                frame = solve_spp(aug.obs, nav, SppConfig(measurement=mc),
                                  corrections=aug.corrections, precise=aug.precise).to_frame()
                key = f"{name} {systems} {orbits}"
                scores[key] = _score(frame, ref, window)
                seconds[key] = round(time.perf_counter() - t0, 2)
    return scores, seconds


def rtklib(files: dict, windows: list[str]) -> dict:
    """rnx2rtkp single point and DGPS on the same files, scored per window."""
    exe = shutil.which("rnx2rtkp")
    if exe is None:
        return {"note": "rnx2rtkp not installed (Debian package rtklib): skipped"}
    ref = read_reference_trajectory(files["ref"])
    base = read_rinex_obs(files["base"]).header.approx_position_e
    out: dict = {"version": _rtklib_version(exe)}
    with tempfile.TemporaryDirectory() as tmp:
        for mode, flag in (("SPP", "0"), ("DGPS", "1")):
            for systems, sys_flag in (("G", "G"), ("GE", "G,E")):
                pos = Path(tmp) / f"{mode}_{systems}.pos"
                cmd = [exe, "-p", flag, "-m", "10", "-sys", sys_flag, "-o", str(pos),
                       "-r", *(f"{x:.4f}" for x in base), str(files["obs"]),
                       str(files["base"]), str(files["nav"])]
                subprocess.run(cmd, check=True, capture_output=True, timeout=600)
                frame = _read_pos(pos)
                for w in windows:
                    out.setdefault(w, {})[f"{mode} {systems}"] = _score(frame, ref, w)
        out["command"] = "rnx2rtkp -p {0|1} -m 10 -sys {G|G,E} -r BASE_XYZ ROVER BASE NAV"
    return out


def _rtklib_version(exe: str) -> str:
    """The installed package's version (rnx2rtkp itself prints none)."""
    try:
        done = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", "rtklib"],
                              capture_output=True, text=True, timeout=30)
        return f"rtklib {done.stdout.strip()} ({exe})" if done.returncode == 0 else exe
    except (OSError, subprocess.SubprocessError):
        return exe


def _read_pos(path: Path) -> pd.DataFrame:
    """An RTKLIB .pos file (GPST week/tow or date/time, lat, lon, height) as spp.csv columns."""
    rows = [ln.split() for ln in path.read_text().splitlines() if ln and ln[0] != "%"]
    if not rows:
        return pd.DataFrame(columns=["gps_time_s", "lat_deg", "lon_deg", "h_m"])
    if "/" in rows[0][0]:
        t = pd.to_datetime([f"{r[0]} {r[1]}" for r in rows], format="%Y/%m/%d %H:%M:%S.%f")
        gps = (t - pd.Timestamp("1980-01-06")).total_seconds().to_numpy()
        vals = np.array([[float(x) for x in r[2:5]] for r in rows])
    else:
        gps = np.array([float(r[0]) * WEEK_S + float(r[1]) for r in rows])
        vals = np.array([[float(x) for x in r[2:5]] for r in rows])
    return pd.DataFrame({"gps_time_s": gps, "lat_deg": vals[:, 0], "lon_deg": vals[:, 1],
                         "h_m": vals[:, 2]})


def gnss_only_runs(files: dict, windows: list[str]) -> dict:
    """``railnav run --filter gnss-only`` with raw / DGNSS / smoothed DGNSS rows."""
    from railnav.config import NavigatorConfig
    from railnav.jobs.run import run_files
    from trackmodel.io import read_track

    track = read_track(TRACK)
    ref = read_reference_trajectory(files["ref"])
    out: dict = {}
    estimates = {}
    for name, kw in (("raw", {}), ("dgps", {"base_path": files["base"]}),
                     ("dgps+smooth", {"base_path": files["base"], "smoothing": SMOOTH})):
        cfg = NavigatorConfig(filter="gnss-only", measurement=MeasurementConfig(systems="G"))
        t0 = time.perf_counter()
        outcome = run_files(track, obs_path=files["obs"], nav_path=files["nav"], config=cfg,
                            **kw)
        est = outcome.result.estimates
        t = est["gps_time_s"].to_numpy()
        estimates[name] = est[np.abs(t - np.round(t)) < 1e-3]
        out.setdefault("seconds", {})[name] = round(time.perf_counter() - t0, 1)
    # the same epochs for all three (each run stops where it leaves the track's end)
    common = set.intersection(*(set(np.round(e["gps_time_s"], 3)) for e in estimates.values()))
    for name, est in estimates.items():
        est = est[np.isin(np.round(est["gps_time_s"], 3), sorted(common))]
        for w in windows:
            out.setdefault(w, {})[f"gnss-only G {name}"] = _score(est, ref, w)
    for w in windows:
        raw = out[w]["gnss-only G raw"]["horizontal_rms_m"]
        out[w]["gain_over_raw_m"] = {k: round(raw - v["horizontal_rms_m"], 3)
                                     for k, v in out[w].items() if k != "gnss-only G raw"}
    return out


def weighting_study(shared: dict, held: dict | None) -> dict:
    """σ(elevation, C/N0) chosen on the shared window; G vs GE on both windows."""
    grid = [(cn0, el) for cn0 in (np.nan, 35.0, 40.0, 45.0, 50.0) for el in (False, True)]

    def run(files, window, systems, cn0, el):
        obs, nav = read_rinex_obs(files["obs"]), read_rinex_nav(files["nav"])
        base = read_rinex_obs(files["base"])
        mc = MeasurementConfig(systems=systems, cn0_ref_dbhz=cn0, elevation_weighting=el)
        aug = augment(obs, nav, mc, base_obs=base)
        res = solve_spp(aug.obs, nav, SppConfig(measurement=mc), corrections=aug.corrections)
        return res, _score(res.to_frame(), read_reference_trajectory(files["ref"]), window)

    fits = {}
    for cn0, el in grid:
        key = f"cn0_ref={cn0:g} elev_weight={el}"
        fits[key] = {s: run(shared, "shared", s, cn0, el)[1]["horizontal_rms_m"]
                     for s in ("G", "GE")}
    best = min(fits, key=lambda k: fits[k]["GE"])
    cn0, el = grid[list(fits).index(best)]
    res, _ = run(shared, "shared", "GE", cn0, el)
    sats = res.satellites[res.satellites["used"]].copy()
    sats["cn0_bin"] = (sats["cn0_dbhz"] // 5 * 5).astype(int)
    table = sats.groupby(["system", "cn0_bin"])["pr_residual_m"].agg(
        lambda x: float(np.sqrt(np.mean(np.square(x)))))
    out = {"grid_shared_dgps_horizontal_rms_m": fits, "chosen_on_shared": best,
           "dgps_residual_rms_m_by_system_cn0": {f"{s} {b}": round(v, 3)
                                                  for (s, b), v in table.items()}}
    if held is not None:
        out["held_out_with_chosen"] = {s: run(held, "held-out", s, cn0, el)[1]
                                       for s in ("G", "GE")}
    return out


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None,
                        help="folder of the full shared data set (gnss_urban_drive) for the "
                             "held-out window; without it only the shipped window is run")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--skip-rtklib", action="store_true")
    parser.add_argument("--skip-run", action="store_true", help="no gnss-only filter runs")
    args = parser.parse_args(argv)
    if args.data is not None and not (args.data / "rover_obs.rnx").is_file():
        parser.error(f"--data {args.data}: no rover_obs.rnx there (expected the folder of "
                     "the shared gnss_urban_drive data set)")
    shared = files_for("shared", None)
    held = files_for("held-out", args.data) if args.data is not None else None
    result: dict = {"machine": f"{platform.node()} {platform.processor()} "
                               f"{platform.python_version()}",
                    "smoothing_window_s": SMOOTH.window_s, "rtklib_issue": RTKLIB_ISSUE}
    result["shared"], result["seconds_shared"] = railnav_solutions(shared, "shared")
    if held is not None:
        result["held-out"], result["seconds_held_out"] = railnav_solutions(held, "held-out")
    else:
        result["held-out"] = "skipped: give --data DIR (the shared gnss_urban_drive folder)"
    if not args.skip_rtklib:
        result["rtklib_here"] = (rtklib(held, ["shared", "held-out"]) if held is not None
                                 else rtklib(shared, ["shared"]))
    if not args.skip_run:
        result["gnss_only_run"] = (gnss_only_runs(held, ["shared", "held-out"])
                                   if held is not None else gnss_only_runs(shared, ["shared"]))
    result["weighting"] = weighting_study(shared, held)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out, json.dumps(result, indent=2, default=float) + "\n")
    return result


if __name__ == "__main__":
    out = main()
    print(json.dumps({k: out[k] for k in ("shared", "held-out")}, indent=1))
