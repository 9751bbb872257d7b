"""GNSS-only track-constrained filter vs single-epoch solutions on the urban drive.

Data: the full urban drive, a folder given as ``--data DIR`` (rover 2020-11-29 12:40-12:48
GPST, PPK reference; provenance in ``data/gnss/README.md``); track: ``data/tracks/barcelona_drive.csv``, the reference's first leg fitted by
``railnav track fit`` (the car turns round after SoW 46006 and drives back in the other
lane; the run navigates through the turn: `railnav.navigation.loop.TrackEndWatch`).

Solutions, each scored against the reference on the SAME epochs (those where every
solution has a position and the reference one):

* ``gnss-only G|GE`` — ``railnav run TRACK --obs --nav --filter gnss-only`` (`run_files`
  with the CLI's configuration);
* ``railnav SPP G|GE`` and ``gnss-lib-py WLS G`` (unweighted and sin²(el)-weighted):
  `bench_spp_real` (the same fair set-up: GPS time, header Klobuchar, nearest-toe records).

Figures: horizontal RMS / 95 %, vertical RMS, and the horizontal error split along/across
the track (each position and the reference projected on the track: ``Δs`` and
``Δcross``). Sensitivity of gnss-only (the design choices of `railnav.filters.gnss_only`):
white pseudorange errors (τ = 0), σ_a = 0.5 m/s², Huber row weights, the dual-frequency
ionosphere-free combination (with the SPP on the same measurements) to show what the
ionosphere residual costs, the filter with the ``additive`` pseudorange σ model
calibrated on this drive (`gnss_obs.measurements.URBAN_CODE_SIGMAS`; SPP with its own),
without the slow code error's state (`railnav.filters.code_bias`, k = 0) and with the
heading's curvature term at its calibrated 2.2 m (``track_heading_curvature_m``).
Also: the reference's distance to the track (the fit's part).

Writes ``benchmarks/results/real_data.json``. Run: ``python benchmarks/bench_real_data.py
--data DIR`` (about a minute, most of it gnss-lib-py; ``--skip-gnss-lib-py`` for seconds).
"""
from __future__ import annotations

import json
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_spp_real import drive_inputs, run_gnss_lib_py  # noqa: E402

from gnss_obs.measurements import URBAN_CODE_SIGMAS, MeasurementConfig  # noqa: E402
from gnss_obs.spp import SppConfig, solve_spp  # noqa: E402
from railnav.config import NavigatorConfig  # noqa: E402
from railnav.filters.code_bias import CodeBiasConfig  # noqa: E402
from railnav.jobs.run import run_files  # noqa: E402
from railnav.evaluation.spp_accuracy import accuracy_summary, spp_errors  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402
from trackmodel.io import read_track  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
TRACK = REPO / "data" / "tracks" / "barcelona_drive.csv"
RESULTS = Path(__file__).resolve().parent / "results" / "real_data.json"
#: ``NavigatorConfig.track_heading_curvature_m`` as calibrated (``bench_code_bias.py``), m.
CALIBRATED_HEADING_CURVATURE_M = 2.2
#: Files of the urban drive this benchmark reads from ``--data DIR``.
DATA_FILES = ("rover_obs.rnx", "broadcast_nav.rnx", "reference_trajectory.csv")
EPOCH_DECIMALS = 3     # epochs matched on gps_time_s to 1 ms (railnav.evaluation.spp_accuracy)


def gnss_only(track, obs_path, nav_path, config: NavigatorConfig, **filter_kw):
    """Run the gnss-only filter; its estimates at the epochs, run time, summary."""
    t0 = time.perf_counter()
    if filter_kw:
        import railnav.filters.gnss_only as gof
        saved = gof.GnssOnlyFilter.__init__.__kwdefaults__.copy()
        gof.GnssOnlyFilter.__init__.__kwdefaults__.update(filter_kw)
    try:
        outcome = run_files(track, obs_path=obs_path, nav_path=nav_path, config=config)
    finally:
        if filter_kw:
            gof.GnssOnlyFilter.__init__.__kwdefaults__.update(saved)
    est = outcome.result.estimates
    t = est["gps_time_s"].to_numpy()
    sol = est[np.abs(t - np.round(t)) < 10.0 ** -EPOCH_DECIMALS].copy()
    sol["gps_time_s"] = np.round(sol["gps_time_s"], EPOCH_DECIMALS)
    return sol, time.perf_counter() - t0, outcome.summary


def _split(track, solution: pd.DataFrame, reference: pd.DataFrame) -> pd.DataFrame:
    """Along/cross-track errors: solution and reference projected on the track."""
    key = np.round(reference["gps_time_s"].to_numpy(), EPOCH_DECIMALS)
    ref = reference.set_index(key)
    sol = solution[solution["gps_time_s"].isin(ref.index)]
    sol = sol[np.isfinite(sol["lat_deg"])]
    r = ref.loc[sol["gps_time_s"]]
    ps = track.project(np.radians(sol["lat_deg"]), np.radians(sol["lon_deg"]))
    pr = track.project(np.radians(r["lat_deg"]), np.radians(r["lon_deg"]))
    return pd.DataFrame({"gps_time_s": sol["gps_time_s"].to_numpy(),
                         "along_m": (ps.s + ps.along_m) - (pr.s + pr.along_m),
                         "cross_m": ps.cross_track_m - pr.cross_track_m})


def _rms(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x * x)))


def score(track, solutions: dict[str, pd.DataFrame], reference: pd.DataFrame) -> dict:
    """Accuracy of each solution on the epochs all of them have."""
    errors = {k: spp_errors(v, reference) for k, v in solutions.items()}
    common = None
    for e in errors.values():
        t = set(np.round(e.loc[np.isfinite(e["horizontal_m"]), "gps_time_s"], EPOCH_DECIMALS))
        common = t if common is None else common & t
    common = np.array(sorted(common))
    out = {}
    for name, e in errors.items():
        same = e[np.isin(np.round(e["gps_time_s"], EPOCH_DECIMALS), common)]
        row = accuracy_summary(same).__dict__
        split = _split(track, solutions[name][solutions[name]["gps_time_s"].isin(common)],
                       reference)
        row.update(along_track_rms_m=_rms(split["along_m"]),
                   cross_track_rms_m=_rms(split["cross_m"]))
        out[name] = row
    return {"n_common_epochs": int(common.size),
            "gps_time_s": [float(common[0]), float(common[-1])], "solutions": out}


def spp(obs, nav, systems: str, **measurement) -> tuple[pd.DataFrame, float]:
    t0 = time.perf_counter()
    m = MeasurementConfig(systems=systems, **measurement)
    return solve_spp(obs, nav, SppConfig(measurement=m)).to_frame(), time.perf_counter() - t0


def main(argv=None) -> dict:
    args, obs_path, nav_path, obs, nav, reference = drive_inputs(
        __doc__.splitlines()[0], DATA_FILES, RESULTS, argv)
    track = read_track(TRACK)
    seconds, stopped = {}, {}
    main_set: dict[str, pd.DataFrame] = {}
    for systems in ("G", "GE"):
        cfg = NavigatorConfig(filter="gnss-only", measurement=MeasurementConfig(systems=systems))
        name = f"gnss-only {systems}"
        main_set[name], seconds[name], summary = gnss_only(track, obs_path, nav_path, cfg)
        stopped[name] = summary["left_track"]
        main_set[f"railnav SPP {systems}"], seconds[f"railnav SPP {systems}"] = spp(
            obs, nav, systems)
    if not args.skip_gnss_lib_py:
        frames, seconds["gnss-lib-py (both weightings)"] = run_gnss_lib_py(
            obs_path, nav_path, obs.header.approx_position_e,
            [nav.header.iono_gps_alpha, nav.header.iono_gps_beta])
        main_set.update({f"gnss-lib-py WLS G {k}": v for k, v in frames.items()})
    report = {"data": args.data.resolve().name, "track": str(TRACK.relative_to(REPO)),
              "same_epochs": score(track, main_set, reference), "left_track": stopped,
              "seconds": seconds}
    report["sensitivity"] = sensitivity(track, obs, nav, obs_path, nav_path, reference)
    on_track = track.project(np.radians(reference["lat_deg"]), np.radians(reference["lon_deg"]))
    leg = reference["gps_time_s"] <= main_set["gnss-only G"]["gps_time_s"].max()
    report["reference_to_track_m"] = {
        "cross_track_rms": _rms(on_track.cross_track_m[leg]),
        "cross_track_max": float(np.abs(on_track.cross_track_m[leg]).max())}
    report.update(python=platform.python_version(), machine=platform.machine())
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out, json.dumps(report, indent=2) + "\n")
    _print(report)
    return report


def sensitivity(track, obs, nav, obs_path, nav_path, reference) -> dict:
    """gnss-only design choices, each against the SPP on the same measurements/epochs."""
    out = {}
    base = NavigatorConfig(filter="gnss-only")
    variants = {"default": ({}, {}), "white pseudoranges (tau 0)": (
        {"pseudorange_correlation_s": 0.0}, {}), "sigma_a 0.5 m/s2": (
        {"along_accel_sigma_mps2": 0.5}, {}), "huber k 1.5": ({}, {"huber_k": 1.5}),
        "iono-free": ({"ionosphere": "iono-free"}, {}),
        "urban sigmas (filter only)": ({"sigmas": URBAN_CODE_SIGMAS}, {}),
        "no slow code error (k 0)": ({"code_bias": CodeBiasConfig(sigma=0.0)}, {}),
        f"heading curvature {CALIBRATED_HEADING_CURVATURE_M} m": (
            {"track_heading_curvature_m": CALIBRATED_HEADING_CURVATURE_M}, {})}
    for systems in ("G", "GE"):
        for label, (cfg_kw, filt_kw) in variants.items():
            measurement = {k: v for k, v in cfg_kw.items() if k == "ionosphere"}
            nav_kw = {k: v for k, v in cfg_kw.items() if k not in ("ionosphere", "sigmas")}
            cfg = replace(base, measurement=MeasurementConfig(
                systems=systems, **measurement, **cfg_kw.get("sigmas", {})), **nav_kw)
            sol, sec, _ = gnss_only(track, obs_path, nav_path, cfg, **filt_kw)
            ref_sol, _ = spp(obs, nav, systems, **measurement)
            scored = score(track, {"gnss-only": sol, "SPP": ref_sol}, reference)
            s = scored["solutions"]
            out[f"{systems} {label}"] = {
                "gnss_only_h_rms_m": s["gnss-only"]["horizontal_rms_m"],
                "gnss_only_h95_m": s["gnss-only"]["horizontal_95_m"],
                "spp_h_rms_m": s["SPP"]["horizontal_rms_m"],
                "ratio": s["gnss-only"]["horizontal_rms_m"] / s["SPP"]["horizontal_rms_m"],
                "n_epochs": scored["n_common_epochs"], "seconds": sec}
    return out


def _print(report: dict) -> None:
    same = report["same_epochs"]
    print(f"{same['n_common_epochs']} common epochs")
    for name, a in same["solutions"].items():
        print(f"{name:36s} H RMS {a['horizontal_rms_m']:5.2f} m  H95 {a['horizontal_95_m']:5.2f}"
              f"  along {a['along_track_rms_m']:5.2f}  cross {a['cross_track_rms_m']:5.2f}  "
              f"V RMS {a['vertical_rms_m']:5.2f}")
    for name, v in report["sensitivity"].items():
        print(f"{name:34s} gnss-only {v['gnss_only_h_rms_m']:5.2f} m  SPP "
              f"{v['spp_h_rms_m']:5.2f} m  ratio {v['ratio']:.2f}")


if __name__ == "__main__":
    main()
