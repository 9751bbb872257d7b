"""``railnav simulate TRACK --scenario NAME ...``: truth.csv, imu.csv and scenario.json.

Thin layer over `railnav.simulation.scenarios.simulate_scenario` (STYLE.md §2.11).
"""
from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path

from railnav.commands.support import outage_window, positive_float, progress_bar
from railnav.defaults import DEFAULT_SYSTEMS
from railnav.simulation.scenarios import SCENARIOS, get_scenario, scenario_to_dict
from strapdown.imu_errors import IMU_GRADES
from trackmodel.files import atomic_write_csv, atomic_write_text

__all__ = ["register", "handler", "FLOAT_FORMAT"]

log = logging.getLogger(__name__)

#: CSV float format: 17 significant digits round-trip every float64 exactly.
FLOAT_FORMAT = "%.17g"


def register(subparsers) -> None:
    """Add the ``simulate`` subcommand."""
    p = subparsers.add_parser(
        "simulate", help="simulate a trip: truth, IMU (and GNSS) files",
        description="Simulate a scenario (speed profile + sensors) on a track and write "
                    "truth.csv, imu.csv and scenario.json to DIR.")
    p.add_argument("track", metavar="TRACK", help="track file (.csv)")
    p.add_argument("--scenario", default="paper2017", choices=sorted(SCENARIOS),
                   help="named scenario (default: paper2017)")
    p.add_argument("--imu-grade", choices=sorted(IMU_GRADES), default=None,
                   help="IMU error preset (default: the scenario's; 'perfect' = ideal IMU)")
    p.add_argument("--speed-mps", type=positive_float, default=None,
                   help="top speed in m/s (scales the scenario's speed profile)")
    p.add_argument("--duration-s", type=positive_float, default=None,
                   help="trip duration in s (the trip ends at the track end at the latest)")
    p.add_argument("--outage", type=outage_window, action="append", default=None,
                   metavar="START:DURATION",
                   help="GNSS outage in seconds from the start (repeatable; replaces the "
                        "scenario's outages)")
    p.add_argument("--gnss", action=argparse.BooleanOptionalAction, default=True,
                   help="also simulate GNSS observations: gnss_obs.rnx and the navigation "
                        "file used, gnss_nav.rnx (default: yes)")
    p.add_argument("--systems", default=DEFAULT_SYSTEMS,
                   help=f"GNSS systems to simulate, e.g. G or GE (default {DEFAULT_SYSTEMS})")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    """Run ``railnav simulate``; returns the exit status."""
    from gnss_obs.sim_files import write_simulation
    from railnav.simulation.trip import simulate_trip
    from trackmodel.io import read_track
    scenario = get_scenario(args.scenario).with_overrides(
        speed_mps=args.speed_mps, duration_s=args.duration_s, imu_errors=args.imu_grade,
        outages=args.outage)
    track = read_track(args.track)
    with progress_bar("simulate", enabled=not args.quiet) as progress:
        trip = simulate_trip(scenario, track=track, seed=args.seed, gnss=args.gnss,
                             systems=args.systems, progress=progress)
    result = trip.simulation
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if trip.gnss is not None:
        write_simulation(out, trip.gnss, trip.nav)
    atomic_write_csv(out / "truth.csv", result.truth.to_frame(), float_format=FLOAT_FORMAT)
    atomic_write_csv(out / "imu.csv", result.imu_measured.to_frame(), float_format=FLOAT_FORMAT)
    meta = {"scenario": scenario_to_dict(scenario), "track": str(Path(args.track)),
            "seed": args.seed, "gnss_written": trip.gnss is not None,
            "gnss_systems": args.systems if trip.gnss is not None else None,
            "n_samples": int(len(result.truth.time_s)),
            "end_time_s": float(result.truth.time_s[-1])}
    atomic_write_text(out / "scenario.json", json.dumps(meta, indent=2) + "\n")
    log.info("wrote %d samples to %s", meta["n_samples"], out)
    return 0
