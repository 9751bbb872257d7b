"""Issue 14's consistency table: is the constrained filter's σ a promise it keeps?

Usage::

    nice -n 10 python benchmarks/bench_consistency.py [--quick] [--cases a,b] [--seeds N]
                                                      [--first-seed K] [--jobs J]
                                                      [--update] [--out FILE]
                                                      [--multipath-sigma M]
                                                      [--multipath-tau T] [--told WHAT]

Cases (simulated truth; the filter assumes the IMU grade that is simulated, scale factors
and misalignments included in the simulation but not in the filter's model):

==================  =========================================================  ======
case                trip                                                       seeds
==================  =========================================================  ======
paper2017           the 2017 paper's scenario (1000 s, two 50-s outages)        10
curvy_tactical      ``curvy`` (1000 s, a station stop), tactical IMU             10
curvy_mems          the same, MEMS IMU                                           10
circle_100mps       100 m/s on a 100-m circle entered without a transition       10
u_turn              a U-turn of 100 m radius at 20 m/s, tactical                 10
standstill_5min     MEMS, a 5-min stop with GNSS out for the whole stop, the     10
                    standstill detector on (``NavigatorConfig.standstill``,
                    `StandstillConfig` defaults, as ``--standstill``)
outage_20min        ``curvy``, tactical, a 20-min outage from 60 s               10
outage_300s         ``curvy``, MEMS, a 300-s outage from 60 s                    10
outage_300s_body    the same trip with the car body (``car_body``: chord,        10
                    suspension, mounting) and the attitude rows
                    (``NavigatorConfig.track_attitude``, as ``--track-attitude``)
trip_10h            a 10-h streamed trip (`bench_studies.long_line`), tactical   4
==================  =========================================================  ======

``--quick``: 3 seeds (1 for the 10-h trip, shortened to 1 h). ``--jobs J``: the 10-h trip's
seeds in J processes. ``--seeds N``: at most N
seeds per case (the JSON's ``runs`` says how many). ``--first-seed K``: seeds from K
(to run one case's seeds in parallel processes, each to its own ``--out``). ``--update``:
keep the cases of an existing ``--out`` that are not run again (each case records its own
load average).

``--multipath-sigma M`` (m, default 0: none) adds code multipath to the simulated cases'
pseudoranges (`Scenario.multipath_sigma_m`, ``--multipath-tau`` T s, default 60: a
first-order Gauss–Markov bias per satellite, σ/sin(el), on top of the white σ_pr), and
``--told`` says what the filter is told of it (`with_multipath`): ``nothing`` (default: the
white σ_pr of the scenario), ``variance`` (each row's variance σ_pr² + M²/sin²el,
`bench_network_spawn_gnss.declared_measurement`), ``correlation`` (that, and
``NavigatorConfig.pseudorange_correlation_s`` = T with ``pseudorange_correlation_m`` = 0:
the simulated errors are correlated in time, not in distance travelled). Not for the
streamed ``trip_10h``.

Per case, `railnav.evaluation.consistency.summarize_consistency` over the seeds: NEES mean
with its 99 % χ² interval, the share of epochs with ``|error_s| > 3 σ_s``, the share with
the truth outside ``[s_min_m, s_max_m]`` and the ``status`` counts where ``estimates.csv``
has those columns (else null), each with its number of epochs, and the RMS of the
along-track error (``rms_error_s_m``) and of σ_s (``rms_sigma_s_m``) over the seeds' epochs.
Writes
``benchmarks/results/consistency.json`` (each case as it finishes: a long run that is
stopped keeps the cases done).

What the misses come from (measured by ablation, same seeds; each simulated IMU error
switched off in the simulation only, the filter still assuming the full grade;
``docs/consistency-ablations.md`` has the tables):

* ``circle_100mps`` (NEES 12.8): three parts. (1) The joint lies on an IMU sample
  (t = 10.00 s). The rate step's sampling error was then ±Δω dt/2 = 5 mrad in every seed,
  against the uniform-phase σ of 2.9 mrad that the filter's joint noise assumed. With
  the first straight 0.5 m longer (the joint half a sample later) the NEES was 10.6.
  Fixed since (stop 33): a point sample of a rate step is what no IMU delivers; the
  simulated samples are interval means across such joints
  (`railnav.simulation.joint_average`), whose trapezoid keeps the angle, the joint noise
  is gone, and the geometry remainder is that of the sample's interval, centred on the
  predicted ``s``, and statistically linearized where it meets the step
  (`railnav.filters.geometry_noise`). Seeds 11-100: beyond 3σ_s 1.49 → 0.08 % (NEES
  8.56 → 6.70), half a sample off 1.59 → 0.63 % (7.69 → 6.58).
  (2) The accelerometer misalignment. On that track, without it the NEES is 7.0 and the
  roll's mean z² 0.54 instead of 2.9. Where the curvature steps, the misalignment steps
  the z bias by ``M_zy v²κ`` (σ 20 mm/s²). The filter gives that variance along the
  predicted paths (`railnav.filters.scale_noise`). When the estimate is ahead of the
  truth, most of it comes before the true step, and the normal row ties the bias again on
  the straight. The roll then takes the step (seed 10: roll σ from 0.45 to 0.067 mrad at
  the entry with a 0.41-mrad error; z bias 36 mm/s² off with σ 6 mm/s²). Giving the step
  late instead, with the rows loosened over the crossing window, was worse (NEES 17.5).
  (3) Noise on the GNSS rows. With a perfect IMU (and the joint half a sample later),
  seed 3 alone has 19.5 % of its epochs beyond 3σ_s. Right after an epoch in the curve,
  the continuous rows move (s, ψ) by 0.27 m and 2.8 mrad along ``δψ = κ δs``, a direction
  they do not observe. With the same IMU but near noise-free GNSS (3 seeds), the NEES is
  2.2 and no epoch is beyond 3σ_s. Since (2) is modelled (the accelerometer's ``M_zy`` and
  the gyro's ``S_zz`` are states, `railnav.filters.constrained_model.SCALE_ELEMENTS`) the
  NEES is 9.14, inside its band (roll mean z² 4.24 → 1.18); the share beyond 3σ_s, 3.09 %,
  is (1) and (3). (3) is the track expansion's truncation on the arc, ``v² κ³ δ² / 2``
  (1.25e-3 m/s² at δ = 0.5 m), a function of the truth's offset from the chunk's
  predicted path and so held for the chunk, which the geometry noise gave the correlation
  time of a passing feature; held (`railnav.filters.held_remainder`), the share is 0 on
  these seeds (0.93 % on seeds 11–40; ``docs/consistency-ablations.md``, stop 29).
* ``outage_20min`` seed 5: the error is already 3.3σ after the braking onset at 376–400 s
  (−1 % straight, 300 s into the outage; the same without scale factors and
  misalignments). The pitch moves 0.6 mrad while the x accelerometer bias stays 2σ off,
  and the along-track acceleration error grows from −0.8 to −5 mm/s². At the clothoid
  (9343.6 m) the prior is 122 m ahead. From 520 to 525 s the estimate is past the
  clothoid start while the truth is not, and "no curvature yet" says only that the truth
  lies before the start. A truncated Gaussian would give σ_s ≈ 21 m; the EKF, taking it as
  a line in ``s``, gave 7.2 m (error 88 m). Then the curvature rows made a 16σ speed
  update (σ_v from 0.4 to 0.025 m/s), and σ_s collapsed to 0.19 m (end: −14 km, σ_s
  6.8 m). Fixed by `railnav.filters.one_sided` (``NavigatorConfig.one_sided``, default
  on). Near an onset with σ_s > 2 m, the rows' noise density is scaled so that the
  information they give ``s`` over the episode is no more than the truncation of the
  episode's prior at the onset. Seed 5 now keeps σ_s 19.5 m at 525 s and ends −1.0 m off
  (σ_s 0.90 m). Over the 10 seeds: NEES 3.49e7 → 6.11, beyond 3σ_s 7.12 → 1.13 %,
  outside [s_min, s_max] 5.6 → 0.037 % (outage_300s: NEES 7.62 → 7.34). The cases with
  GNSS throughout never reach the bound. Left: the braking-onset error itself (3.3σ
  before any onset, the pitch/``b_ax`` mechanism), and the network navigator runs its
  Gaussian sum without the bound.
* ``trip_10h`` (main 0f16378, seeds 1–4: NEES 262, 52.1, 54.1, 30.9; yaw mean z² 255,
  46.7, 46.9, 24.4): a bug, fixed. The pseudo-observation's Jacobian was evaluated at
  the raw IMU sample. Its yaw column is the along-track specific force, which on a
  straight is accelerometer noise (``|H_yaw|²/R_k ≈ 1 rad⁻²`` a sample), so the filter
  drew yaw (and, through the correlation, ``b_gz``) information from noise at 100 Hz.
  ``H`` is now evaluated at a centred 0.5-s running median of the samples
  (`railnav.filters.common.JACOBIAN_WINDOW_S`, `ekf.step.StepOptions.jacobian_window_s`).
  ``ChunkLoop.chunks`` gives each chunk the median over the whole window, across chunks
  and stream segments. Seeds 1–4: NEES 8.62, 6.26, 8.27, 8.91 (8.01 over the four, band
  [3.78, 14.08]; yaw mean z² 1.52, 1.11, 1.12, 2.40; > 3σ_s 0.16–0.33 %). On a straight
  σ_yaw is 1.5 % below its closed form after 890 s (`bench_yaw_straight.py`).
  ``docs/consistency-ablations.md`` has the tables.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import os
import platform
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from railnav.evaluation.consistency import run_series, summarize_consistency  # noqa: E402
from railnav.filters.attitude_config import TrackAttitudeConfig  # noqa: E402
from railnav.filters.standstill import StandstillConfig  # noqa: E402
from railnav.simulation.car_body_config import CarBodyMotion  # noqa: E402
from railnav.simulation.trip import navigator_config_for  # noqa: E402
from railnav.jobs.run import run_simulated  # noqa: E402
from railnav.simulation.profiles import constant_speed, station_stop_profile  # noqa: E402
from railnav.simulation.scenarios import TRACKS_DIR, Scenario, get_scenario  # noqa: E402
from trackmodel.earth import WGS84  # noqa: E402
from trackmodel.files import atomic_write_text  # noqa: E402
from trackmodel.io import read_track  # noqa: E402
from trackmodel.sections import Section  # noqa: E402
from trackmodel.track import Origin, Track  # noqa: E402

RESULTS = HERE / "results" / "consistency.json"
HOUR_S = 3600.0
ORIGIN = Origin(50.45, 30.52, 100.0)


def circle_track(radius_m: float = 100.0, turns: int = 3) -> Track:
    """1 km of straight, `turns` full turns of an arc without transition, 1 km of straight."""
    k = 1.0 / radius_m
    return Track([Section(1000.0, 90.0, 0.0)]
                 + [Section(0.5 * math.pi * radius_m, None, None, k)] * (4 * turns)
                 + [Section(1000.0, None, None)], ORIGIN, WGS84)


def u_turn_track(radius_m: float = 100.0) -> Track:
    """500 m of straight, a half circle without transition, 500 m of straight."""
    return Track([Section(500.0, 90.0, 0.0), Section(math.pi * radius_m, None, None,
                                                     1.0 / radius_m),
                  Section(500.0, None, None)], ORIGIN, WGS84)


def _curvy(grade: str, *, duration_s: float | None = None, outages=None) -> Scenario:
    return get_scenario("curvy").with_overrides(imu_errors=grade, duration_s=duration_s,
                                                outages=outages)


def _with(scenario: Scenario, **fields):
    """`scenario` and the `NavigatorConfig` fields a user sets for it (the filter otherwise
    assumes what is simulated)."""
    return scenario, replace(navigator_config_for(scenario), **fields)


def standstill_scenario() -> Scenario:
    """MEMS: 10 s at rest, 60 s to 25 m/s, 100 s cruise, 50 s braking, 300 s standing with
    GNSS out from the stop's start to its end, then away again."""
    profile = station_stop_profile(cruise_speed_mps=25.0, accel_time_s=60.0,
                                   brake_time_s=50.0, cruise_before_stop_s=100.0,
                                   dwell_s=300.0, start_dwell_s=10.0)
    stop_start = 10.0 + 60.0 + 100.0 + 50.0
    return Scenario(name="standstill", profile=profile, duration_s=stop_start + 360.0,
                    imu_errors="mems", outages=((stop_start, 300.0),))


def cases(quick: bool, max_seeds: int | None = None) -> dict:
    """name -> (track, scenario, seeds) for `run_simulated`, or a 10-h streamed spec."""
    table = _cases(quick)
    if max_seeds is None:
        return table
    return {name: (*spec[:-1], min(spec[-1], max_seeds)) for name, spec in table.items()}


def _cases(quick: bool) -> dict:
    seeds = 3 if quick else 10
    curvy = read_track(TRACKS_DIR / "curvy.csv")
    return {
        "paper2017": (read_track(TRACKS_DIR / "paper2017.csv"), get_scenario("paper2017"),
                      seeds),
        "curvy_tactical": (curvy, _curvy("tactical"), seeds),
        "curvy_mems": (curvy, _curvy("mems"), seeds),
        "circle_100mps": (circle_track(), Scenario(name="circle", profile=constant_speed(
            100.0), duration_s=70.0, imu_errors="tactical"), seeds),
        "u_turn": (u_turn_track(), Scenario(name="u_turn", profile=constant_speed(20.0),
                                            duration_s=60.0, imu_errors="tactical"), seeds),
        "standstill_5min": (curvy, _with(standstill_scenario(),
                                         standstill=StandstillConfig()), seeds),
        "outage_20min": (curvy, _curvy("tactical", duration_s=1300.0,
                                       outages=[(60.0, 1200.0)]), seeds),
        "outage_300s": (curvy, _curvy("mems", duration_s=400.0, outages=[(60.0, 300.0)]),
                        seeds),
        "outage_300s_body": (curvy, _with(replace(
            _curvy("mems", duration_s=400.0, outages=[(60.0, 300.0)]),
            car_body=CarBodyMotion()), track_attitude=TrackAttitudeConfig()), seeds),
        "trip_10h": ("stream", 1.0 if quick else 10.0, 1 if quick else 4),
    }


#: What ``--told`` tells the filter of the simulated multipath (`with_multipath`).
TOLD = ("nothing", "variance", "correlation")


def with_multipath(scenario, sigma_m: float, tau_s: float, told: str):
    """`scenario` (a Scenario, or `_with`'s pair) with code multipath of σ `sigma_m` (m) and
    correlation time `tau_s` (s) simulated, and the filter told `told` of it (`TOLD`; the
    module docstring): ``(Scenario, NavigatorConfig)``."""
    from bench_network_spawn_gnss import declared_measurement
    scenario, config = scenario if isinstance(scenario, tuple) else (scenario, None)
    scenario = replace(scenario, multipath_sigma_m=sigma_m, multipath_tau_s=tau_s)
    config = navigator_config_for(scenario) if config is None else config
    if told != "nothing":
        config = replace(config, measurement=declared_measurement(config.measurement, sigma_m))
    if told == "correlation":
        config = replace(config, pseudorange_correlation_s=tau_s, pseudorange_correlation_m=0.0)
    return scenario, config


def _simulated_runs(track, scenario, seeds: int, first_seed: int = 1):
    """`scenario`: a Scenario, or ``(Scenario, NavigatorConfig)`` (`_with`); seeds
    ``first_seed .. first_seed + seeds − 1``."""
    scenario, config = scenario if isinstance(scenario, tuple) else (scenario, None)
    runs, dof = [], 0
    for seed in range(first_seed, first_seed + seeds):
        out = run_simulated(track, scenario, config=config, seed=seed)
        runs.append(run_series(out.result.estimates, nees=out.errors.nees,
                               error_s_m=out.errors.along_track_m))
        dof = out.errors.nees_dof
    return runs, dof


def _streamed_runs(hours: float, seeds: int, first_seed: int = 1, jobs: int = 1):
    """The 10-h trip of `bench_studies` (paper2017's 20 m/s, tactical, GPS + Galileo, a
    120-s outage every hour), estimates and errors at 1 Hz; seeds ``first_seed ..``, in
    `jobs` processes (the seeds are independent runs). Each seed's line also gives the
    mean z² of the yaw."""
    seed_list = list(range(first_seed, first_seed + seeds))
    if jobs > 1 and len(seed_list) > 1:
        from concurrent.futures import ProcessPoolExecutor
        with ProcessPoolExecutor(max_workers=min(jobs, len(seed_list))) as pool:
            done = list(pool.map(_streamed_seed, [hours] * len(seed_list), seed_list))
    else:
        done = [_streamed_seed(hours, seed) for seed in seed_list]
    for _, _, line in done:
        print(line, flush=True)
    return [run for run, _, _ in done], done[-1][1]


def _streamed_seed(hours: float, seed: int):
    """One seed of `_streamed_runs`: ``(run_series, dof, its line)``."""
    from bench_studies import long_line
    from railnav.navigation.streaming import stream_simulated
    scenario = replace(get_scenario("paper2017"), duration_s=hours * HOUR_S,
                       imu_errors="tactical", default_track=None,
                       outages=tuple((600.0 + HOUR_S * h, 120.0) for h in range(int(hours))))
    config = navigator_config_for(scenario, systems="GE")
    with tempfile.TemporaryDirectory() as tmp:
        outcome = stream_simulated(long_line(), scenario, config=config, seed=seed,
                                   systems="GE", out_dir=tmp, estimates_rate_hz=1.0)
        est = pd.read_csv(Path(tmp) / "estimates.csv")
        err = pd.read_csv(Path(tmp) / "errors.csv")
    run = run_series(est, nees=err["nees"].to_numpy(),
                     error_s_m=err["along_track_m"].to_numpy())
    dof = int(outcome.summary["errors"]["nees"]["dof"])
    one = summarize_consistency([run], dof=dof)
    z_yaw = (err["yaw_rad"].to_numpy() / np.radians(est["sigma_yaw_deg"].to_numpy())
             if "yaw_rad" in err and "sigma_yaw_deg" in est else np.full(1, np.nan))
    return run, dof, (f"  10-h trip seed {seed}: NEES mean {one.nees_mean:.3g} over "
                      f"{one.nees_epochs} epochs (inside the 99 % band on "
                      f"{one.share_epochs_nees_inside:.1%}), beyond 3σ_s "
                      f"{one.share_beyond_3sigma:.2%}, yaw mean z² "
                      f"{np.nanmean(z_yaw ** 2):.3g}")


def _accuracy(runs) -> dict:
    """The RMS of the along-track error and of σ_s over the seeds' epochs (what ``--told``
    costs or buys in accuracy)."""
    error = np.concatenate([r.error_s_m for r in runs])
    sigma = np.concatenate([r.sigma_s_m for r in runs])
    return {"rms_error_s_m": float(np.sqrt(np.nanmean(error ** 2))),
            "rms_sigma_s_m": float(np.sqrt(np.nanmean(sigma ** 2)))}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="3 seeds, a 1-h trip")
    parser.add_argument("--cases", default=None, help="comma-separated case names")
    parser.add_argument("--seeds", type=int, default=None, help="at most this many seeds")
    parser.add_argument("--first-seed", type=int, default=1,
                        help="the first seed (seeds first .. first + N − 1; to split a case "
                             "over processes)")
    parser.add_argument("--jobs", type=int, default=1,
                        help="processes for the 10-h trip's seeds (default 1)")
    parser.add_argument("--update", action="store_true",
                        help="keep the other cases of an existing --out")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--multipath-sigma", type=float, default=0.0,
                        help="simulated code multipath σ, m (default 0: none)")
    parser.add_argument("--multipath-tau", type=float, default=60.0,
                        help="its correlation time, s (default 60)")
    parser.add_argument("--told", choices=TOLD, default=TOLD[0],
                        help="what the filter is told of the multipath (default nothing)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)
    if args.seeds is not None and args.seeds < 1:
        print(f"error: --seeds must be >= 1, got {args.seeds}", file=sys.stderr)
        return 2
    if args.jobs < 1:
        print(f"error: --jobs must be >= 1, got {args.jobs}", file=sys.stderr)
        return 2
    if args.first_seed < 1:
        print(f"error: --first-seed must be >= 1, got {args.first_seed}", file=sys.stderr)
        return 2
    table = cases(args.quick, args.seeds)
    names = list(table) if args.cases is None else args.cases.split(",")
    unknown = [n for n in names if n not in table]
    if unknown:
        print(f"error: unknown case(s) {unknown}; cases: {', '.join(table)}", file=sys.stderr)
        return 2
    if not (math.isfinite(args.multipath_sigma) and args.multipath_sigma >= 0.0) or \
            not (math.isfinite(args.multipath_tau) and args.multipath_tau > 0.0):
        print(f"error: --multipath-sigma must be >= 0 and --multipath-tau > 0, got "
              f"{args.multipath_sigma} and {args.multipath_tau}", file=sys.stderr)
        return 2
    if args.multipath_sigma > 0.0:
        if any(table[n][0] == "stream" for n in names):
            print("error: --multipath-sigma is for the simulated cases, not trip_10h",
                  file=sys.stderr)
            return 2
        table = {n: (track, with_multipath(sc, args.multipath_sigma, args.multipath_tau,
                                           args.told), seeds)
                 for n, (track, sc, seeds) in ((n, table[n]) for n in names)}
    doc = {"quick": args.quick, "first_seed": args.first_seed, "cases": {},
           "machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                       "load_average_before": os.getloadavg()}}
    if args.update and args.out.exists():
        try:
            old = json.loads(args.out.read_text())
            doc["cases"] = {k: v for k, v in old["cases"].items() if k not in names}
        except (ValueError, KeyError, TypeError) as exc:
            print(f"error: {args.out}: not a consistency table ({exc})", file=sys.stderr)
            return 2
    for name in names:
        started = time.perf_counter()
        spec = table[name]
        if spec[0] == "stream":
            runs, dof = _streamed_runs(spec[1], spec[2], args.first_seed, args.jobs)
        else:
            runs, dof = _simulated_runs(*spec, args.first_seed)
        figures = summarize_consistency(runs, dof=dof).to_dict()
        figures.update(_accuracy(runs))
        if args.multipath_sigma > 0.0:
            figures.update(multipath_sigma_m=args.multipath_sigma,
                           multipath_tau_s=args.multipath_tau, told=args.told)
        figures["wall_s"] = time.perf_counter() - started
        figures["load_average_after"] = os.getloadavg()
        doc["cases"][name] = figures
        doc["machine"]["load_average_after"] = os.getloadavg()
        atomic_write_text(args.out, json.dumps(doc, indent=2) + "\n")
        lo, hi = figures["nees_interval"]
        print(f"{name}: NEES {figures['nees_mean']:.3g} (99 % [{lo:.2f}, {hi:.2f}], "
              f"dof {dof}, {figures['nees_epochs']} epochs), |err_s| > 3σ on "
              f"{figures['share_beyond_3sigma']:.2%} of {figures['sigma_epochs']}, "
              f"outside [s_min, s_max] {figures['share_outside_protection']} of "
              f"{figures['protection_epochs']}, status {figures['status_counts']}, "
              f"RMS err_s {figures['rms_error_s_m']:.3f} m σ_s "
              f"{figures['rms_sigma_s_m']:.3f} m, {figures['wall_s']:.0f} s", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
