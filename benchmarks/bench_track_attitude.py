"""What the attitude rows and the standstill rows buy (issue 14, parts 1 and 2).

Usage::

    python benchmarks/bench_track_attitude.py [--seeds 10] [--stop-seeds 10]

**Outages.** ``curvy`` with the car body (`railnav.simulation.car_body_motion`: chord
between bogies 19 m apart, the IMU over the leading bogie, suspension 1/2/3 mrad, mounting
N(0, 1°)), GPS, an outage of 60 / 120 / 300 s from t = 100 s (cruising at 25 m/s through the
curves), trip end 10 s after it; MEMS and tactical IMUs; per seed the same trip filtered
``without`` and ``with`` the attitude rows (`railnav.filters.attitude_rows`), and, as the
reference of the issue's "today", the plain ``curvy`` trip (IMU aligned with the track, no
suspension) without rows. Both ``with`` and ``without`` tell the filter of the suspension's
sampling error on the gyros (`railnav.filters.suspension_noise`:
``NavigatorConfig.suspension_noise``, which `navigator_config_for` sets for a car body and
``track_attitude`` implies); ``without_noise`` is ``without`` not told of the car body at
all (the filter before that setting). At the outage's end (the last record before GNSS
is back): the along-track error, its σ and |error|/σ; the NEES (mean over the outage and over the run,
with its degrees of freedom).

**Standstill.** ``curvy`` with a 300-s station stop (t = 420–720 s) and GNSS out over
415–725 s, MEMS; ``without`` and ``with`` the standstill rows (`railnav.filters.standstill`),
on the plain trip and on the car body (with the attitude rows). Per run: the drift while
standing (the largest change of the estimated ``s`` from the first standstill row to the
stop's end), the along-track error at the stop's end, the largest |speed| estimated while
standing, the NEES over the stop; and the detector against the truth: still windows
(truth speed 0 all through) detected, and windows detected while moving (false alarms,
with the true speed; the screen rejects those whose prior speed is many σ from 0).

Writes ``benchmarks/results/track_attitude.json``.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from railnav.filters.attitude_config import TrackAttitudeConfig  # noqa: E402
from railnav.filters.standstill import StandstillConfig, detect_standstill  # noqa: E402
from railnav.jobs.run import run_simulated  # noqa: E402
from railnav.simulation.car_body_config import CarBodyMotion  # noqa: E402
from railnav.simulation.profiles import station_stop_profile  # noqa: E402
from railnav.simulation.scenarios import get_scenario  # noqa: E402
from railnav.simulation.trip import navigator_config_for  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402
from trackmodel.io import read_track  # noqa: E402

RESULTS = REPO / "benchmarks" / "results" / "track_attitude.json"
TRACK = REPO / "data" / "tracks" / "curvy.csv"
OUTAGE_START_S, AFTER_S = 100.0, 10.0
OUTAGES_S = (60.0, 120.0, 300.0)
GRADES = ("mems", "tactical")
STOP_S, STOP_END_S, STOP_OUTAGE = 420.0, 720.0, (415.0, 310.0)


def _outage_run(track, grade: str, outage_s: float, seed: int, variant: str) -> dict:
    scenario = get_scenario("curvy").with_overrides(
        duration_s=OUTAGE_START_S + outage_s + AFTER_S, imu_errors=grade,
        outages=[(OUTAGE_START_S, outage_s)])
    if variant != "plain":
        scenario = replace(scenario, car_body=CarBodyMotion())
    config = navigator_config_for(scenario)
    if variant == "with":
        config = replace(config, track_attitude=TrackAttitudeConfig())
    elif variant == "without_noise":
        config = replace(config, suspension_noise=False)
    started = time.perf_counter()
    out = run_simulated(track, scenario, config=config, seed=seed)
    est, err = out.result.estimates, out.errors
    t = est["time_s"].to_numpy()
    end = OUTAGE_START_S + outage_s
    k = int(np.flatnonzero(t < end - 1e-6)[-1])
    inside = (t >= OUTAGE_START_S) & (t < end)
    e, sigma = float(err.along_track_m[k]), float(est["sigma_s_m"].iloc[k])
    return {"seed": seed, "error_m": e, "sigma_m": sigma, "z": abs(e) / sigma,
            "nees_outage": float(np.nanmean(err.nees[inside])),
            "nees_run": float(np.nanmean(err.nees)), "nees_dof": int(err.nees_dof),
            "wall_s": time.perf_counter() - started}


def _summary(runs: list[dict]) -> dict:
    err = np.abs([r["error_m"] for r in runs])
    z = np.array([r["z"] for r in runs])
    return {"median_abs_error_m": float(np.median(err)), "max_abs_error_m": float(err.max()),
            "median_sigma_m": float(np.median([r["sigma_m"] for r in runs])),
            "median_z": float(np.median(z)), "max_z": float(z.max()),
            "share_z_above_3": float(np.mean(z > 3)),
            "median_nees_outage": float(np.median([r["nees_outage"] for r in runs])),
            "median_nees_run": float(np.median([r["nees_run"] for r in runs])),
            "nees_dof": runs[0]["nees_dof"], "runs": runs}


def _stop_scenario(body: bool):
    profile = station_stop_profile(cruise_speed_mps=25.0, accel_time_s=60.0,
                                   brake_time_s=50.0, cruise_before_stop_s=300.0,
                                   dwell_s=STOP_END_S - STOP_S, start_dwell_s=10.0)
    return replace(get_scenario("curvy"), profile=profile, duration_s=STOP_END_S + 40.0,
                   imu_errors="mems", outages=(STOP_OUTAGE,),
                   car_body=CarBodyMotion() if body else None)


def _stop_run(track, seed: int, body: bool, standstill: bool) -> dict:
    scenario = _stop_scenario(body)
    config = navigator_config_for(scenario)
    if body:
        config = replace(config, track_attitude=TrackAttitudeConfig())
    if standstill:
        config = replace(config, standstill=StandstillConfig())
    out = run_simulated(track, scenario, config=config, seed=seed)
    est, err, inn = out.result.estimates, out.errors, out.result.innovations
    t, s = est["time_s"].to_numpy(), est["s_m"].to_numpy()
    stop = (t >= STOP_S) & (t <= STOP_END_S)
    zs = inn[inn["kind"] == "zero_speed"] if len(inn) else inn
    first = zs.loc[(zs["time_s"] >= STOP_S - 5) & (zs["status"] == "used"), "time_s"]
    t0 = float(first.min()) if len(first) else STOP_S
    after = (t >= t0) & (t <= STOP_END_S)
    k0 = int(np.searchsorted(t, t0))
    b = int(np.searchsorted(t, STOP_END_S))
    out_d = {"seed": seed, "first_row_s": t0 if len(first) else None,
             "drift_m": float(np.max(np.abs(s[after] - s[k0]))),
             "error_end_m": float(err.along_track_m[b]),
             "sigma_end_m": float(est["sigma_s_m"].iloc[b]),
             "max_abs_speed_mps": float(np.max(np.abs(est["speed_mps"].to_numpy()[stop]))),
             "nees_stop": float(np.nanmean(err.nees[stop])), "nees_dof": int(err.nees_dof)}
    if standstill:
        out_d.update(_detection(out, config))
        out_d["zero_speed_rows"] = {k: int(v) for k, v in zs["status"].value_counts().items()}
    return out_d


def _detection(out, config) -> dict:
    """The detector against the truth's stops (1-s windows)."""
    imu = out.trip.simulation.imu_measured
    u = np.column_stack([imu.f_b, imu.omega_ib_b])
    _, windows = detect_standstill(imu.time_s, u, config.standstill, config.imu)
    truth = out.truth
    ends = windows["time_s"]
    idx = np.searchsorted(truth.time_s, ends)
    k = np.floor(truth.time_s / config.standstill.window_s + 1e-9).astype(int)
    v_max = np.zeros(k.max() + 1)
    np.maximum.at(v_max, k, np.abs(truth.v))
    w = np.floor(ends / config.standstill.window_s + 1e-9).astype(int)
    true_still = v_max[w] == 0.0
    det = windows["still"]
    return {"windows_still_true": int(true_still.sum()),
            "windows_still_detected": int((det & true_still).sum()),
            "windows_moving": int((~true_still).sum()),
            "false_alarms": int((det & ~true_still).sum()),
            "false_alarm_speed_max_mps": float(np.max(np.abs(truth.v[idx[det & ~true_still]])))
            if (det & ~true_still).any() else 0.0}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--stop-seeds", type=int, default=10)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    track = read_track(TRACK)
    load_before = os.getloadavg()
    started = time.perf_counter()
    out: dict = {"outage_start_s": OUTAGE_START_S, "car_body": CarBodyMotion().__dict__,
                 "attitude_rows": TrackAttitudeConfig().__dict__, "outages": {}}
    for grade in GRADES:
        for outage in OUTAGES_S:
            case = {}
            for variant in ("plain", "without_noise", "without", "with"):
                runs = [_outage_run(track, grade, outage, seed, variant)
                        for seed in range(1, args.seeds + 1)]
                case[variant] = _summary(runs)
                print(f"{grade} {outage:.0f} s {variant}: median |err| "
                      f"{case[variant]['median_abs_error_m']:.2f} m, max "
                      f"{case[variant]['max_abs_error_m']:.2f} m, median |err|/σ "
                      f"{case[variant]['median_z']:.2f}, NEES outage "
                      f"{case[variant]['median_nees_outage']:.1f} / {case[variant]['nees_dof']}",
                      flush=True)
            out["outages"][f"{grade}_{outage:.0f}s"] = case
    out["standstill"] = {"stop_s": [STOP_S, STOP_END_S], "outage": list(STOP_OUTAGE),
                         "config": StandstillConfig().__dict__}
    for body in (False, True):
        for standstill in (False, True):
            runs = [_stop_run(track, seed, body, standstill)
                    for seed in range(1, args.stop_seeds + 1)]
            name = f"{'car_body' if body else 'plain'}_{'with' if standstill else 'without'}"
            drift = np.array([r["drift_m"] for r in runs])
            out["standstill"][name] = {
                "median_drift_m": float(np.median(drift)), "max_drift_m": float(drift.max()),
                "median_abs_error_end_m": float(np.median([abs(r["error_end_m"]) for r in runs])),
                "median_nees_stop": float(np.median([r["nees_stop"] for r in runs])),
                "nees_dof": runs[0]["nees_dof"], "runs": runs}
            print(f"standstill {name}: drift median {np.median(drift):.3f} m, max "
                  f"{drift.max():.3f} m", flush=True)
    out["machine"] = {"python": platform.python_version(), "cpus": os.cpu_count(),
                      "load_average_before": load_before, "load_average_after": os.getloadavg(),
                      "wall_s": time.perf_counter() - started}
    atomic_write_text(args.out, json.dumps(out, indent=2, default=list) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
