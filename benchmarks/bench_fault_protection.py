"""Small satellite faults against the fault screen and the along-track protection level
(issue 14: "build [s_min, s_max] from the filter covariance, the fault screen's
undetected-fault bound and the monitor's status").

The consistency table (`bench_consistency.py`) checks the protection interval on
fault-free trips only. Here one satellite (the one with the most pseudorange rows in the
fault-free run of each seed) gets a code fault the screen cannot always see, on the
``curvy`` scenario, tactical IMU, 1000 s, seeds 1..N:

* ``step_10m``: a 10-m pseudorange step for 300 s from t = 300 s;
* ``step_30m``: the same, 30 m;
* ``ramp_0.1mps``: a pseudorange ramp of 0.1 m/s for 300 s (0 → 30 m);
* ``ramp_0.03mps``: 0.03 m/s for 600 s (0 → 18 m), the slow kind a row test misses longest;
* ``ramp_0.1mps_doppler``: 0.1 m/s on the pseudorange and the same on the range rate (a
  consistent signal fault, invisible to the code-Doppler consistency).

Each faulted run uses the fault-free run's noise (`railnav.studies.faults.fault_case`: the
same seed, the fault adds a deterministic error). Per case, over the seeds and over the
fault window plus 300 s after it (the filter's memory of the fault):

* the screen: the share of detectable faulty rows (≥ 3σ of their innovation) not used, the
  faulty rows used, false alarms on the other rows (`fault_case`);
* the pull: the largest fault-caused change of the along-track error in σ_s;
* `railnav.evaluation.consistency.summarize_consistency` on those epochs: the share beyond
  3σ_s, the largest |error|/σ_s, and the share with the truth outside [s_min, s_max]
  (risk 1e-5 per epoch) with the number of epochs behind it; also the share outside the
  1e-3 interval (``s_m ± protection_level_risk_0p001_m``);
* the median protection levels (1e-5, 1e-3) and σ_s, and the status counts.

Usage::

    python benchmarks/bench_fault_protection.py [--seeds 5] [--out FILE]

About 5 minutes for 5 seeds on a 2-core machine.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from gnss_obs.sim_events import SatelliteFault  # noqa: E402
from railnav.evaluation.consistency import run_series, summarize_consistency  # noqa: E402
from railnav.jobs.run import run_simulated  # noqa: E402
from railnav.simulation.scenarios import TRACKS_DIR, get_scenario  # noqa: E402
from railnav.studies.faults import fault_case, faulty_rows  # noqa: E402

RESULTS = HERE / "results" / "fault_protection.json"
START_S = 300.0
#: name: (duration s, step m, ramp m/s, on the range rate too)
CASES = {"step_10m": (300.0, 10.0, 0.0, False), "step_30m": (300.0, 30.0, 0.0, False),
         "ramp_0.1mps": (300.0, 0.0, 0.1, False), "ramp_0.03mps": (600.0, 0.0, 0.03, False),
         "ramp_0.1mps_doppler": (300.0, 0.0, 0.1, True)}
#: Epochs scored after a fault ends: the filter remembers it.
AFTER_S = 300.0


def _faulted_satellite(clean) -> str:
    """The satellite with the most pseudorange rows in the fault-free run."""
    inn = clean.result.innovations
    return str(inn[inn["kind"] == "pseudorange"].groupby("sv").size().idxmax())


def _window(outcome, end_s: float):
    """The estimates and errors of the scored window (fault start to end + `AFTER_S`)."""
    est = outcome.result.estimates
    t = est["time_s"].to_numpy()
    inside = (t >= START_S) & (t < end_s + AFTER_S)
    errors = outcome.errors
    if errors.time_s.size != t.size or not np.allclose(errors.time_s, t):
        raise RuntimeError("errors and estimates are not at the same epochs")
    return est[inside].reset_index(drop=True), errors.nees[inside], errors.along_track_m[inside]


def _outside_1e3(est, error_s):
    pl = est["protection_level_risk_0p001_m"].to_numpy(dtype=float)
    ok = np.isfinite(pl)
    return int(ok.sum()), int(np.count_nonzero(np.abs(error_s[ok]) > pl[ok]))


def _score(name: str, runs: list, end_s: float) -> dict:
    """One case's figures over its seeds; `runs`: ``(fault_case result, faults)`` each."""
    series, n3, out3, pl, pl3, sig, used, faulty_n = [], 0, 0, [], [], [], [], []
    for case, faults in runs:
        est, nees, err = _window(case.faulted, end_s)
        series.append(run_series(est, nees=nees, error_s_m=err))
        n, o = _outside_1e3(est, err)
        n3, out3 = n3 + n, out3 + o
        pl.append(est["protection_level_m"].to_numpy(dtype=float))
        pl3.append(est["protection_level_risk_0p001_m"].to_numpy(dtype=float))
        sig.append(est["sigma_s_m"].to_numpy(dtype=float))
        inn = case.faulted.result.innovations
        faulty, _ = faulty_rows(inn, faults)
        faulty_n.append(int(faulty.sum()))
        used.append(int((faulty & (inn["status"] == "used").to_numpy()).sum()))
    summary = summarize_consistency(series, dof=runs[0][0].faulted.errors.nees_dof)
    rows = [case.row() for case, _ in runs]
    return {
        "case": name, "seeds": len(runs),
        "detection_rate": [r["detection_rate"] for r in rows],
        "detectable_rows": [r["detectable_rows"] for r in rows],
        "faulty_rows_used": used, "faulty_rows": faulty_n,
        "false_alarm_rate": [r["false_alarm_rate"] for r in rows],
        "pull_sigma": [r["pull_sigma"] for r in rows],
        "epochs": summary.sigma_epochs,
        "share_beyond_3sigma": summary.share_beyond_3sigma, "max_abs_z": summary.max_abs_z,
        "protection_epochs": summary.protection_epochs,
        "share_outside_protection": summary.share_outside_protection,
        "protection_epochs_1e-3": n3, "outside_protection_1e-3": out3,
        "median_protection_level_m": float(np.nanmedian(np.concatenate(pl))),
        "median_protection_level_1e-3_m": float(np.nanmedian(np.concatenate(pl3))),
        "median_sigma_s_m": float(np.nanmedian(np.concatenate(sig))),
        "status_counts": summary.status_counts,
    }


def _fault_free(clean_runs: list, end_s: float) -> dict:
    """The same figures on the fault-free runs, over the longest case's window."""
    series = []
    for clean in clean_runs:
        est, nees, err = _window(clean, end_s)
        series.append(run_series(est, nees=nees, error_s_m=err))
    return summarize_consistency(series, dof=clean_runs[0].errors.nees_dof).to_dict()


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5, help="seeds 1..N (default 5)")
    parser.add_argument("--cases", default=",".join(CASES),
                        help="comma-separated, of: " + ", ".join(CASES))
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    names = [c for c in args.cases.split(",") if c]
    unknown = [c for c in names if c not in CASES]
    if unknown:
        parser.error(f"unknown case(s) {unknown}; known: {', '.join(CASES)}")
    scenario, track = get_scenario("curvy"), TRACKS_DIR / "curvy.csv"
    load_before = os.getloadavg()
    t0 = time.perf_counter()
    per_case: dict[str, list] = {c: [] for c in names}
    clean_runs = []
    for seed in range(1, args.seeds + 1):
        clean = run_simulated(track, scenario, seed=seed)
        sv = _faulted_satellite(clean)
        clean_runs.append(clean)
        for name in names:
            duration, step, ramp, doppler = CASES[name]
            faults = (SatelliteFault(sv, START_S, duration, step_m=step, ramp_mps=ramp,
                                     affects_doppler=doppler),)
            case = fault_case(track, scenario, faults, name=name, seed=seed, clean=clean)
            per_case[name].append((case, faults))
            print(f"seed {seed} {name} ({sv}): {case.row()}", flush=True)
    cases = {name: _score(name, per_case[name], START_S + CASES[name][0]) for name in names}
    fault_free = _fault_free(clean_runs, START_S + max(CASES[n][0] for n in names))
    doc = {"scenario": "curvy", "imu": scenario.imu_errors, "trip_s": scenario.duration_s,
           "fault_start_s": START_S, "scored_after_fault_s": AFTER_S, "seeds": args.seeds,
           "cases": cases, "fault_free": fault_free,
           "wall_s": time.perf_counter() - t0,
           "machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                       "load_average_before": load_before,
                       "load_average_after": os.getloadavg()}}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1, default=float) + "\n")
    for name, c in cases.items():
        print(f"{name}: faulty rows used {sum(c['faulty_rows_used'])}/{sum(c['faulty_rows'])}, "
              f"pull max {max(c['pull_sigma']):.2f} σ, beyond 3σ {c['share_beyond_3sigma']:.2%}, "
              f"max |z| {c['max_abs_z']:.2f}, outside [s_min, s_max] "
              f"{c['share_outside_protection']} of {c['protection_epochs']}, outside 1e-3 "
              f"{c['outside_protection_1e-3']} of {c['protection_epochs_1e-3']}, PL median "
              f"{c['median_protection_level_m']:.2f} m (1e-3: "
              f"{c['median_protection_level_1e-3_m']:.2f} m; σ_s {c['median_sigma_s_m']:.2f} m)")
    print(f"fault-free: {fault_free}")
    return doc


if __name__ == "__main__":
    main()
