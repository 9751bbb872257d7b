"""``railnav simulate TRACK --scenario NAME ...``: truth.csv, imu.csv and scenario.json.

Thin layer over `railnav.simulation.trip.simulate_trip` (STYLE.md §2.11) on a track file or,
with ``--network N --route E1,E2``, on the route's line (`trackmodel.route_track`); with
``--fixes-format`` over `railnav.simulation.fixes.simulate_fixes` and the fix writers of
`gnss_obs.fixes.writers`; with ``--odometer``, ``--balises``, ``--imu-jitter-s`` and
``--lever-arm`` over `railnav.commands.simulate_sensors`.
"""
from __future__ import annotations

import argparse
import json
import logging
from dataclasses import replace
from pathlib import Path

from railnav.commands.run_flags import SCENARIO_HELP
from railnav.commands.simulate_sensors import (
    add_sensor_arguments,
    sensor_configs,
    write_sensor_files,
)
from railnav.commands.support import (
    add_output_arguments,
    outage_window,
    output_dir,
    positive_float,
    progress_bar,
    written_line,
)
from railnav.defaults import DEFAULT_SEED, DEFAULT_SYSTEMS
from railnav.errors import ConfigError
from railnav.simulation.fixes import (
    DEFAULT_QUALITY_MIX,
    FIX_FORMATS_WRITTEN,
    FixSimConfig,
    parse_quality_mix,
)
from railnav.simulation.scenarios import SCENARIOS, scenario_for_track, scenario_to_dict
from strapdown.imu_errors import IMU_GRADES
from trackmodel.files import atomic_write_csv, atomic_write_text

__all__ = ["register", "handler", "FLOAT_FORMAT"]

log = logging.getLogger(__name__)

#: CSV float format: 17 significant digits round-trip every float64 exactly.
FLOAT_FORMAT = "%.17g"
#: With --network/--route: the route's line, a track file for ``railnav run``.
ROUTE_TRACK_FILE = "route_track.csv"
#: Output directory when --out is not given.
DEFAULT_OUT = "railnav-simulate"


def register(subparsers) -> None:
    """Add the ``simulate`` subcommand."""
    p = subparsers.add_parser(
        "simulate", help="simulate a trip: truth, IMU (and GNSS) files",
        description="Simulate a scenario (speed profile + sensors) on a track and write "
                    "truth.csv, imu.csv and scenario.json to DIR (+ GNSS observations, "
                    "and fixes with --fixes-format).")
    p.add_argument("track", metavar="TRACK", nargs="?", default=None,
                   help="track file (.csv); or --network with --route")
    add_network_route_arguments(p)
    p.add_argument("--scenario", default=None, choices=sorted(SCENARIOS), help=SCENARIO_HELP)
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
    p.add_argument("--fixes-format", choices=FIX_FORMATS_WRITTEN, default=None,
                   help="also write GNSS position fixes of the truth: fixes.csv or "
                        "fixes.nmea (GGA, RMC, VTG, GST)")
    p.add_argument("--fixes-rate-hz", type=positive_float, default=None,
                   help="fix rate, Hz (default 1; must divide the IMU rate)")
    p.add_argument("--fixes-quality", default=None, metavar="CLASS=W,...",
                   help="mix of fix classes by share of 30-s segments, e.g. "
                        "rtk_fixed=0.5,single=0.5 (default "
                        + ",".join(f"{q}={w:g}" for q, w in DEFAULT_QUALITY_MIX) + ")")
    add_sensor_arguments(p)
    p.add_argument("--seed", type=int, default=DEFAULT_SEED,
                   help=f"random seed (default {DEFAULT_SEED})")
    add_output_arguments(p, DEFAULT_OUT)
    p.set_defaults(func=handler)


def add_network_route_arguments(p) -> None:
    """``--network NETWORK --route E1,E2,...``: simulate on a route through a network."""
    p.add_argument("--network", metavar="NETWORK", default=None,
                   help="a network (folder, GeoJSON, OpenStreetMap) to simulate on, along "
                        "--route, instead of TRACK")
    p.add_argument("--route", metavar="E1,E2,...", default=None,
                   help="with --network: the netelements in order (',' or '>'; '-E' "
                        "backwards); the route's line is written as route_track.csv")


def _check_network_flags(args: argparse.Namespace) -> None:
    if (args.network is None) != (args.route is None):
        raise ConfigError("--network and --route go together")
    if (args.track is None) == (args.network is None):
        raise ConfigError("give a TRACK file, or --network with --route (not both)")


def _track_of(args: argparse.Namespace):
    """The track simulated on, and its name in scenario.json and the report."""
    if args.network is None:
        from trackmodel.io import read_track
        return read_track(args.track), str(Path(args.track))
    from trackmodel.network_routes import load_network, route_legs, route_text
    network = load_network(args.network)
    legs = route_legs(network, args.route)
    return network.route_track(legs), f"{args.network}:{route_text(legs)}"


def _fix_config(args: argparse.Namespace) -> FixSimConfig | None:
    """The fix simulation of the flags (None without --fixes-format)."""
    given = [f for f, v in (("--fixes-rate-hz", args.fixes_rate_hz),
                            ("--fixes-quality", args.fixes_quality)) if v is not None]
    if args.fixes_format is None:
        if given:
            raise ConfigError(f"{', '.join(given)}: only with --fixes-format")
        return None
    extra = {} if args.fixes_rate_hz is None else {"rate_hz": args.fixes_rate_hz}
    if args.fixes_quality is not None:
        extra["quality_mix"] = parse_quality_mix(args.fixes_quality)
    return FixSimConfig(**extra)


def _write_fixes(out: Path, fixes, config: FixSimConfig, fmt: str) -> dict:
    """Write the simulated fixes; their ``scenario.json`` entry."""
    from gnss_obs.fixes.writers import write_fixes_csv, write_fixes_nmea
    name = f"fixes.{fmt}"
    (write_fixes_csv if fmt == "csv" else write_fixes_nmea)(out / name, fixes.table)
    return {"file": name, "format": fmt, "count": len(fixes), **config.to_dict()}


def handler(args: argparse.Namespace) -> int:
    """Run ``railnav simulate``; returns the exit status."""
    from railnav.simulation.fixes import trip_fixes
    from railnav.simulation.trip import simulate_trip
    _check_network_flags(args)
    fix_config = _fix_config(args)
    sensors = sensor_configs(args)
    scenario = scenario_for_track(args.track or "", args.scenario).with_overrides(
        speed_mps=args.speed_mps, duration_s=args.duration_s, imu_errors=args.imu_grade,
        outages=args.outage)
    if args.lever_arm is not None:
        scenario = replace(scenario, antenna_m=args.lever_arm)
    track, track_name = _track_of(args)
    with output_dir(args, [args.track, args.network]) as tmp:
        with progress_bar("simulate", enabled=not args.quiet) as progress:
            trip = simulate_trip(scenario, track=track, seed=args.seed, gnss=args.gnss,
                                 systems=args.systems, progress=progress)
        fixes = None if fix_config is None else trip_fixes(trip, fix_config)
        written, meta = _write(tmp, trip, track, track_name, scenario, sensors, fixes,
                               fix_config, args)
    print(f"{written_line(args.out, written, tmp)} ({meta['n_samples']} IMU samples, "
          f"{meta['end_time_s']:.1f} s of the {scenario.name} scenario on {track_name})")
    return 0


def _write(out: Path, trip, track, track_name: str, scenario, sensors, fixes, fix_config,
           args: argparse.Namespace) -> tuple[list[Path], dict]:
    """Write a simulated trip's files into `out`: (paths written, scenario.json content)."""
    from gnss_obs.sim_files import write_simulation
    result = trip.simulation
    written = list(write_simulation(out, trip.gnss, trip.nav)) if trip.gnss is not None else []
    if args.network is not None:
        from trackmodel.io import write_track
        write_track(track, out / ROUTE_TRACK_FILE, comments=[f"route {track_name}"])
        written.append(out / ROUTE_TRACK_FILE)
    atomic_write_csv(out / "truth.csv", result.truth.to_frame(), float_format=FLOAT_FORMAT)
    atomic_write_csv(out / "imu.csv", result.imu_measured.to_frame(), float_format=FLOAT_FORMAT)
    meta = {"scenario": scenario_to_dict(scenario), "track": track_name,
            "seed": args.seed, "gnss_written": trip.gnss is not None,
            "gnss_systems": args.systems if trip.gnss is not None else None,
            "n_samples": int(len(result.truth.time_s)),
            "end_time_s": float(result.truth.time_s[-1])}
    if fix_config is not None:
        meta["fixes"] = _write_fixes(out, fixes, fix_config, args.fixes_format)
        written.append(out / meta["fixes"]["file"])
    extra, entries = write_sensor_files(out, trip, sensors, float_format=FLOAT_FORMAT)
    meta.update(entries)
    atomic_write_text(out / "scenario.json", json.dumps(meta, indent=2) + "\n")
    return [out / "truth.csv", out / "imu.csv", *written, *extra, out / "scenario.json"], meta
